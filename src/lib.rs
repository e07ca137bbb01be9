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
//! * [`modal`] / [`poly`] — Θ → polynomial → ω, ζ, b̄ (eqs. 25–32);
//! * [`beam`] — Euler–Bernoulli beam physics (Section II, Appendix);
//! * [`rig`] — the simulated rig: an exact discrete simulator of the modal
//!   model (eq. 22), seeded measurement noise, and [`rig::Rig`] that joins
//!   them with the excitation per sample; the converter chip models behind
//!   the real drivers (the `ads131m02` and `ad5761r` crates, `crates/`);
//! * [`bench`](mod@bench) — the simulated bench assembled above the rig and the
//!   sample task: [`bench::ConverterRig`] (the beam between the chip
//!   models with the pipeline's front end) and the settings of the QEMU
//!   image and the firmware host tests;
//! * [`excitation`] — square wave (the paper's, Section IV.A), multisine,
//!   PRBS and chirp for the piezo, inside a safe voltage window;
//! * [`guard`] — the sensor guard: float-level checks of each sample
//!   (non-finite, saturated, stuck, open bridge) and the removal of offset
//!   steps and drift, before any estimator;
//! * [`pipeline`] — the 10 kHz sample task: ADC codes → y, excitation → DAC,
//!   estimator step, telemetry records for the low-priority task;
//! * [`supervise`] — the estimator's supervisor: excitation monitor
//!   (Lemma 1, in its one home, and an "input gone" detector) with
//!   anti-windup, and
//!   detected-change tracking;
//! * [`tuning`] — truth-free settings: signal scales from a start-up
//!   window, the filter pole λ from the user's band or the data, re-centred
//!   on the estimated band;
//! * `scalar` — the `f32`/`f64` abstraction;
//! * [`link`] — the device end of the serial link (its messages, framing
//!   and stream decoder are the [`beam_protocol`] crate, shared with the
//!   host; `docs/PROTOCOL.md`): telemetry records →
//!   frames in a bounded TX ring, command frames → validated changes of the
//!   pipeline between samples, acknowledgements (any board);
//! * [`selftest`] — the bring-up self-test (converter ID and registers,
//!   DRDY rate, DAC → ADC loopback, noise floor and SNR), run by the link
//!   at start-up and on the `SelfTest` command.
//!
//! Internal helpers (`linalg`: small fixed-size matrices;
//! `scalar::compensated`: double-word arithmetic for `f32`) are
//! crate-private.
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
//! use beamest::rig::{ModalPlant, Rig};
//!
//! let filter = FilterConfig {
//!     ts_s: 1e-4,
//!     lambda_rad_s: 100.0,
//!     scales: SignalScales { u_scale: 0.1, y_scale: 1.2e-3 }, // typical |u|, |y|
//!     ..FilterConfig::default()
//! };
//! let mut est = Adaptive2::<f32>::new(&filter, &AdaptiveConfig::default()).unwrap();
//! let plant = ModalPlant::<f64>::with_numerator(&PAPER_OMEGA, &PAPER_ZETA, &PAPER_B, 1e-4).unwrap();
//! let mut rig = Rig::new(plant, SquareWave::<f64>::paper());
//! for _ in 0..5_000 {
//!     // The 10 kHz sample path: u held over the coming period, y sampled now.
//!     let sample = rig.tick();
//!     assert_eq!(est.step(sample.u as f32, sample.y as f32), StepStatus::Updated);
//! }
//! // At the telemetry rate: Θ → ω, ζ, b̄ (eqs. 30–32) and Lemma 1's monitor.
//! let modes = modal_from_tf(&est.transfer_function(), &[-2.0, 2.0]).unwrap();
//! assert!((modes.omega_rad_s[0] / 39.1533 - 1.0).abs() < 1e-4);
//! assert!((modes.zeta[1] / 0.13 - 1.0).abs() < 1e-4);
//! assert!(est.excitation_level().unwrap() > 0.0);
//! ```
#![cfg_attr(not(test), no_std)]
// No `unsafe` anywhere in the core. Firmware builds (a board feature) add
// the board layer, which alone opts back in (`board/*/mod.rs`); builds for
// the Cortex-M4F/M7 add the `VFMA` wrappers of `scalar/fma.rs`, the one
// audited module outside the board layer that opts in.
#![cfg_attr(
    not(any(feature = "board-qemu", feature = "board-nucleo", beamest_fma_f32)),
    forbid(unsafe_code)
)]
#![cfg_attr(
    any(feature = "board-qemu", feature = "board-nucleo", beamest_fma_f32),
    deny(unsafe_code)
)]
#![warn(missing_docs)]
// Index loops are the clearest form of small dense matrix code (i, j, k
// mirror the equations).
#![allow(clippy::needless_range_loop)]
// `!(x > 0)` is used on purpose: it is true for NaN, so a NaN fails every
// positivity check instead of slipping through.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

pub mod beam;
pub mod bench;
#[cfg(any(feature = "board-qemu", feature = "board-nucleo"))]
pub mod board;
pub mod crlb;
pub mod estimator;
pub mod excitation;
pub mod filter_bank;
pub mod guard;
pub(crate) mod linalg;
pub mod link;
pub mod modal;
pub mod model;
pub mod pipeline;
pub mod poly;
pub mod rig;
pub(crate) mod scalar;
pub mod selftest;
pub mod supervise;
pub mod tuning;

pub use scalar::Real;

/// Compile-time check (with `--features defmt`) that the types the firmware
/// logs implement `defmt::Format`, for both scalar types where generic.
#[cfg(feature = "defmt")]
#[allow(dead_code)]
fn defmt_formats() {
    fn is_format<F: defmt::Format>() {}
    is_format::<estimator::StepStatus>();
    is_format::<estimator::Health>();
    is_format::<estimator::LawError>();
    is_format::<estimator::ConfigError>();
    is_format::<estimator::AdaptiveConfig<7>>();
    is_format::<estimator::GradientConfig<7>>();
    is_format::<estimator::LeastSquaresConfig<7>>();
    is_format::<filter_bank::FilterConfig>();
    is_format::<filter_bank::FilterConfigError>();
    is_format::<modal::ModalError>();
    is_format::<modal::Modes<f32>>();
    is_format::<modal::GainWeighting>();
    is_format::<model::ModalParams<f32>>();
    is_format::<model::ModalParams<f64>>();
    is_format::<model::TransferFunction<f32>>();
    is_format::<model::TransferFunction<f64>>();
    is_format::<poly::PolyError>();
    is_format::<poly::Complex<f32>>();
    is_format::<rig::PlantError>();
    is_format::<supervise::SupervisorConfig>();
    is_format::<guard::SampleFault>();
    is_format::<guard::GuardConfig>();
    is_format::<guard::GuardCounts>();
    is_format::<supervise::ExcitationReason>();
    is_format::<supervise::Supervision<f32>>();
    is_format::<rig::NoiseError>();
    is_format::<rig::Sample<f32>>();
    is_format::<excitation::ExcitationError>();
    is_format::<beam::BeamError>();
    is_format::<beam::BeamOutput>();
    is_format::<tuning::TuningError>();
    is_format::<tuning::TuningConfig>();
    is_format::<tuning::Phase>();
    // The converter drivers' types, formatted through their own `defmt`
    // features (switched on by this crate's).
    is_format::<ads131m02::Frame>();
    is_format::<ads131m02::Error<rig::chips::ModelBusError>>();
    is_format::<ad5761r::ControlReadback>();
    is_format::<ad5761r::Error<rig::chips::ModelBusError>>();
}

#[cfg(test)]
mod tests {
    use crate::beam::{BeamError, BeamParam};
    use crate::estimator::{ConfigError, LawError};
    use crate::excitation::ExcitationError;
    use crate::filter_bank::FilterConfigError;
    use crate::linalg::LinalgError;
    use crate::modal::ModalError;
    use crate::poly::PolyError;
    use crate::rig::{NoiseError, PlantError};
    use crate::tuning::TuningError;
    use core::error::Error;
    use std::string::{String, ToString};
    use std::vec::Vec;

    /// Every variant of every error enum of the core (wrapping variants with
    /// one representative inner error).
    fn all_errors() -> Vec<&'static dyn Error> {
        vec![
            &FilterConfigError::SamplePeriod,
            &FilterConfigError::Lambda,
            &FilterConfigError::Scale,
            &FilterConfigError::Dimensions,
            &ConfigError::Filter(FilterConfigError::Lambda),
            &ConfigError::Gain,
            &ConfigError::Dimensions,
            &LawError::Singular,
            &LawError::NonFinite,
            &LinalgError::NotPositiveDefinite,
            &PolyError::InvalidDegree,
            &PolyError::NonFinite,
            &PolyError::NoConvergence,
            &ModalError::InvalidModeCount,
            &ModalError::LengthMismatch,
            &ModalError::NonFinite,
            &ModalError::Roots(PolyError::NoConvergence),
            &ModalError::RealRootPairIndefinite,
            &ModalError::GainsRankDeficient,
            &PlantError::Dimensions,
            &PlantError::Value,
            &PlantError::Numerator,
            &NoiseError::StandardDeviation,
            &ExcitationError::Frequency,
            &ExcitationError::Amplitude,
            &BeamError::InvalidParameter(BeamParam::Length),
            &BeamError::ActuatorSpan,
            &BeamError::OutputPosition,
            &BeamError::ModeCount,
            &BeamError::ModeNumber,
            &BeamError::RootNotConverged,
            &BeamError::NonFinite,
            &TuningError::SamplePeriod,
            &TuningError::Lambda,
            &TuningError::Band,
            &TuningError::Scale,
            &TuningError::Window,
            &TuningError::Review,
        ]
    }

    #[test]
    fn error_messages_are_short_distinct_lowercase_lines() {
        let messages: Vec<String> = all_errors().iter().map(|e| e.to_string()).collect();
        for (i, m) in messages.iter().enumerate() {
            assert!(!m.is_empty(), "error {i} has an empty message");
            assert!(m.chars().next().is_some_and(|c| c.is_lowercase()), "{m}");
            assert!(!m.contains('\n') && !m.ends_with('.'), "{m}");
            assert!(m.len() < 120, "{m}");
            for other in &messages[i + 1..] {
                assert_ne!(m, other);
            }
        }
    }

    #[test]
    fn messages_name_the_parameter_and_wrapped_errors_are_sources() {
        assert!(FilterConfigError::SamplePeriod.to_string().contains("ts_s"));
        assert!(FilterConfigError::Lambda
            .to_string()
            .contains("lambda_rad_s"));
        assert!(ExcitationError::Amplitude.to_string().contains("amplitude"));
        assert!(NoiseError::StandardDeviation
            .to_string()
            .contains("standard deviation"));
        let config = ConfigError::Filter(FilterConfigError::Lambda);
        assert!(config
            .to_string()
            .ends_with(&FilterConfigError::Lambda.to_string()));
        let inner = config
            .source()
            .and_then(|s| s.downcast_ref::<FilterConfigError>());
        assert_eq!(inner, Some(&FilterConfigError::Lambda));
        assert!(ConfigError::Gain.source().is_none());
        let modal = ModalError::Roots(PolyError::NonFinite);
        let inner = modal.source().and_then(|s| s.downcast_ref::<PolyError>());
        assert_eq!(inner, Some(&PolyError::NonFinite));
        assert!(ModalError::NonFinite.source().is_none());
    }
}
