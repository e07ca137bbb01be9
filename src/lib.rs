//! # beamest — online modal-parameter estimation of a piezo-actuated beam
//!
//! The `no_std`, allocation-free core shared by the firmware, the QEMU build
//! and the host tools. It implements Wang, Costa-Castelló, Na et al.,
//! *Modelling and Adaptive Parameter Estimation for a Piezoelectric
//! Cantilever Beam* (see `docs/ARCHITECTURE.md` for the data path):
//!
//! * [`filter_bank`] — the 1/Λ(s) filters that produce the regressor Ψ (eq. 29);
//! * [`estimator`] — the proposed adaptive law (eqs. 33–41) and the gradient
//!   (47) and least-squares (48) baselines, behind one trait, and a
//!   noise-robust (output-error) form of the proposed law;
//! * [`crlb`] — the Cramér–Rao bound on ω, ζ, b̄ for an experiment;
//! * [`modal`] / [`poly`] — Θ → polynomial → ω, ζ, b̄ (eqs. 25–32) and the
//!   excitation monitor of Lemma 1;
//! * [`beam`] — Euler–Bernoulli beam physics (Section II, Appendix);
//! * [`plant`] — an exact discrete simulator of the modal model (eq. 22);
//! * [`scalar`] / [`linalg`] — the `f32`/`f64` abstraction and small matrices.
//!
//! # Example
//!
//! Identify the paper's simulated plant (Section IV.A) in single precision,
//! exactly as the firmware would: the held input u and the sampled output y,
//! one sample at a time.
//!
//! ```
//! use beamest::estimator::{Adaptive2, AdaptiveConfig, Estimator, StepStatus};
//! use beamest::excitation::SquareWave;
//! use beamest::filter_bank::{FilterConfig, SignalScales};
//! use beamest::modal::modal_from_tf;
//! use beamest::model::{PAPER_B, PAPER_OMEGA, PAPER_ZETA};
//! use beamest::plant::ModalPlant;
//!
//! let filter = FilterConfig {
//!     ts_s: 1e-4,
//!     lambda_rad_s: 100.0,
//!     scales: SignalScales { u_scale: 0.1, y_scale: 1.2e-3 }, // typical |u|, |y|
//!     ..FilterConfig::default()
//! };
//! let mut est = Adaptive2::<f32>::new(&filter, &AdaptiveConfig::default()).unwrap();
//! let mut rig = ModalPlant::<f64>::with_numerator(&PAPER_OMEGA, &PAPER_ZETA, &PAPER_B, 1e-4).unwrap();
//! let mut excitation = SquareWave::<f64>::paper();
//! for _ in 0..5_000 {
//!     // The 10 kHz sample path: u held over the coming period, y sampled now.
//!     let u = excitation.next_sample();
//!     let y = rig.sample(u);
//!     assert_eq!(est.step(u as f32, y as f32), StepStatus::Updated);
//! }
//! // At the telemetry rate: Θ → ω, ζ, b̄ (eqs. 30–32) and Lemma 1's monitor.
//! let modes = modal_from_tf(&est.transfer_function(), &[-2.0, 2.0]).unwrap();
//! assert!((modes.omega_rad_s[0] / 39.1533 - 1.0).abs() < 1e-4);
//! assert!((modes.zeta[1] / 0.13 - 1.0).abs() < 1e-4);
//! assert!(est.excitation_level().unwrap() > 0.0);
//! ```
#![cfg_attr(not(test), no_std)]
#![forbid(unsafe_code)]
#![warn(missing_docs)]
// Index loops are the clearest form of small dense matrix code (i, j, k
// mirror the equations).
#![allow(clippy::needless_range_loop)]
// `!(x > 0)` is used on purpose: it is true for NaN, so a NaN fails every
// positivity check instead of slipping through.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

pub mod beam;
pub mod compensated;
pub mod crlb;
pub mod estimator;
pub mod excitation;
pub mod filter_bank;
pub mod linalg;
pub mod modal;
pub mod model;
pub mod plant;
pub mod poly;
pub mod scalar;

pub use scalar::Real;
