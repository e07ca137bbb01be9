//! # beamest — online modal-parameter estimation of a piezo-actuated beam
//!
//! The `no_std`, allocation-free core shared by the firmware, the QEMU build
//! and the host tools. It implements Wang, Costa-Castelló, Na et al.,
//! *Modelling and Adaptive Parameter Estimation for a Piezoelectric
//! Cantilever Beam* (see `docs/ARCHITECTURE.md` for the data path):
//!
//! * [`filter_bank`] — the 1/Λ(s) filters that produce the regressor Ψ (eq. 29);
//! * [`estimator`] — the proposed adaptive law (eqs. 33–41) and the gradient
//!   (47) and least-squares (48) baselines, behind one trait;
//! * [`modal`] / [`poly`] — Θ → polynomial → ω, ζ, b̄ (eqs. 25–32) and the
//!   excitation monitor of Lemma 1;
//! * [`beam`] — Euler–Bernoulli beam physics (Section II, Appendix);
//! * [`plant`] — an exact discrete simulator of the modal model (eq. 22);
//! * [`scalar`] / [`linalg`] — the `f32`/`f64` abstraction and small matrices.
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
