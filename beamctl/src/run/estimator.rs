//! Which law, at which gains: the default gains of each law (scaled
//! coordinates) and the paper's two published sets — its simulation
//! (Section IV.A) and its experiment (Section IV.B) — mapped exactly into
//! the same scaled coordinates ([`beamest::filter_bank::Scaling`]).
//!
//! The robust estimator ([`beamest::estimator::robust`]) runs the proposed
//! law as its start-up law and then the same law on the output error of a
//! simulated model. It has no published gains: with a paper preset its
//! start-up law takes the preset's proposed-law gains and its output-error
//! law keeps [`RobustConfig::default`]'s.

use crate::run::error::RunError;
use beamest::estimator::robust::{RobustConfig, RobustEstimator};
use beamest::estimator::{
    AdaptiveConfig, AdaptiveEstimator, Estimator, Feedthrough, GradientConfig, GradientEstimator,
    LeastSquaresConfig, LeastSquaresEstimator,
};
use beamest::filter_bank::{FilterConfig, Scaling};
use beamest::Real;
use clap::ValueEnum;
use serde::Serialize;

/// Which estimator the host runs: the laws the device can run (the
/// protocol's `beam_protocol::EstimatorKind`) and the feedthrough model,
/// which only the host has. The doc lines are the `--estimator` help.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, ValueEnum)]
#[serde(rename_all = "lowercase")]
pub enum EstimatorKind {
    /// The proposed adaptive law (eqs. 33–41).
    Adaptive,
    /// The gradient baseline (eq. 47).
    Gradient,
    /// The least-squares baseline (eq. 48).
    #[serde(rename = "ls")]
    #[value(name = "ls")]
    LeastSquares,
    /// The noise-robust estimator: the proposed law on the output error of
    /// a simulated model, refined over a 2 s start-up record (near the
    /// Cramér–Rao bound under white noise on y).
    Robust,
    /// The proposed law on the two-mode model plus a feedthrough
    /// (residual) term, filter (s+λ)^6: for a beam whose modes above the
    /// model's two act on the band (see docs/ROBUSTNESS.md §5). Two modes,
    /// default gains only.
    Feedthrough,
}

impl EstimatorKind {
    /// The paper's three laws, in report order.
    pub const PAPER_LAWS: [EstimatorKind; 3] = [Self::Adaptive, Self::Gradient, Self::LeastSquares];

    /// The estimators of `--estimator all`, in report order: the paper's
    /// three laws, then the robust estimator ([`Self::Feedthrough`] runs
    /// on request only: it is a different model, two modes only).
    pub const ALL: [EstimatorKind; 4] = [
        Self::Adaptive,
        Self::Gradient,
        Self::LeastSquares,
        Self::Robust,
    ];

    /// The name used on the command line and in reports.
    pub fn name(self) -> &'static str {
        match self {
            Self::Adaptive => "adaptive",
            Self::Gradient => "gradient",
            Self::LeastSquares => "ls",
            Self::Robust => "robust",
            Self::Feedthrough => "feedthrough",
        }
    }
}

/// Which gains.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Gains {
    /// The defaults of each law's config (scaled coordinates).
    Default,
    /// The paper's simulation gains (Section IV.A), two modes only.
    Paper,
    /// The paper's experimental gains (Section IV.B), two modes only.
    PaperExperiment,
}

impl Gains {
    /// The name used in reports.
    pub fn name(self) -> &'static str {
        match self {
            Self::Default => "default",
            Self::Paper => "paper",
            Self::PaperExperiment => "paper_experiment",
        }
    }
}

/// The paper's experimental gains (Section IV.B), physical units, two
/// modes: the proposed law's Γ = 10 and H(0), with l = 0.01, γ = 0.1.
pub const EXPERIMENT_GAIN: f64 = 10.0;
/// H(0) of the experiment (Section IV.B).
pub const EXPERIMENT_H0: [f64; 7] = [1e23, 1e15, 1e24, 1e21, 1e22, 1e24, 1e25];
/// Γ1 of the gradient law (47) in the experiment (Section IV.B).
pub const EXPERIMENT_GRADIENT_GAIN: [f64; 7] = [1e11, 1e10, 1e19, 1e16, 1e17, 1e19, 1e21];
/// Γ2(0) of the least-squares law (48) in the experiment (Section IV.B).
pub const EXPERIMENT_LS_GAIN0: [f64; 7] = [1e10, 1e16, 1e17, 1e21, 1e24, 1e23, 1e27];

fn two_modes<const NP: usize>(v: &[f64; 7]) -> Result<[f64; NP], RunError> {
    v.as_slice()
        .try_into()
        .map_err(|_| RunError::Estimator("the paper's gains are defined for 2 modes only".into()))
}

/// The proposed law's configuration for a gain set.
fn adaptive_config<const NP: usize>(
    gains: Gains,
    scaling: &Scaling<NP>,
) -> Result<AdaptiveConfig<NP>, RunError> {
    Ok(match gains {
        Gains::Default => AdaptiveConfig::default(),
        Gains::Paper => {
            AdaptiveConfig::paper(scaling, &two_modes(&AdaptiveConfig::<7>::PAPER_H0_2_MODES)?)
        }
        Gains::PaperExperiment => AdaptiveConfig {
            gain: EXPERIMENT_GAIN,
            ..AdaptiveConfig::paper(scaling, &two_modes(&EXPERIMENT_H0)?)
        },
    })
}

/// The host's robust estimator records up to this many samples, 13.1 s at
/// 10 kHz (the firmware's record is [`beamest::estimator::robust::DEFAULT_RECORD`], 2 s): its
/// model is re-linearised by replaying everything recorded, so a slow
/// excitation (a chirp that reaches the modes only after seconds) is
/// refined on the part that reveals them instead of being frozen at a
/// linearisation point the first 2 s gave (measured on the committed
/// records: docs/REPLAY.md, "Model selection"). The replays' spacing grows
/// with the record ([`RobustConfig::update_relative`] = [`HOST_UPDATE_RELATIVE`]).
pub const HOST_RECORD: usize = 1 << 17;

/// A model update every (samples recorded)/this, once that exceeds the
/// default spacing ([`RobustConfig::update_relative`]).
pub const HOST_UPDATE_RELATIVE: u32 = 8;

/// The robust estimator with the host's record ([`HOST_RECORD`]).
pub type HostRobust<T, const D: usize, const NP: usize, const NS: usize> =
    RobustEstimator<T, D, NP, NS, HOST_RECORD>;

/// Stack a thread needs to build a [`HostRobust`] (its record, 2 MiB in
/// `f64`, passes through the stack on its way to the heap).
pub const ROBUST_STACK_BYTES: usize = 32 << 20;

/// Build the robust estimator for `filter` on the heap (its record makes it
/// ~1 MB in `f32`, ~2 MB in `f64`: build it on a thread with
/// [`ROBUST_STACK_BYTES`] of stack). With a paper preset its start-up law
/// takes the preset's proposed-law gains (see the module docs).
pub fn build_robust<T: Real, const D: usize, const NP: usize, const NS: usize>(
    gains: Gains,
    filter: &FilterConfig,
) -> Result<Box<HostRobust<T, D, NP, NS>>, RunError> {
    let scaling = Scaling::<NP>::new(filter);
    let cfg = RobustConfig {
        startup: adaptive_config(gains, &scaling)?,
        update_relative: HOST_UPDATE_RELATIVE,
        ..RobustConfig::default()
    };
    HostRobust::<T, D, NP, NS>::new(filter, &cfg)
        .map(Box::new)
        .map_err(|e| RunError::Estimator(format!("{e}")))
}

/// Build the configured estimator for `D`, `NP` (`NS = NP(NP+1)/2`) as a
/// boxed trait object, starting from the scaled estimate `theta0` (zero if
/// `None`; the robust and the feedthrough estimators ignore it and start
/// from zero).
pub fn build_estimator<T: Real, const D: usize, const NP: usize, const NS: usize>(
    kind: EstimatorKind,
    gains: Gains,
    filter: &FilterConfig,
    theta0: Option<&[f64; NP]>,
) -> Result<Box<dyn Estimator<T, NP> + Send>, RunError> {
    let scaling = Scaling::<NP>::new(filter);
    let theta0 = theta0.copied().unwrap_or([0.0; NP]);
    let err = |e| RunError::Estimator(format!("{e}"));
    Ok(match kind {
        EstimatorKind::Robust => build_robust::<T, D, NP, NS>(gains, filter)?,
        EstimatorKind::Feedthrough => {
            if NP != 7 {
                return Err(RunError::Estimator(
                    "the feedthrough estimator is defined for 2 modes only".into(),
                ));
            }
            if gains != Gains::Default {
                return Err(RunError::Estimator(
                    "the feedthrough estimator has no published gains: default gains only".into(),
                ));
            }
            Box::new(Feedthrough::<T, NP>::new(filter, &AdaptiveConfig::default()).map_err(err)?)
        }
        EstimatorKind::Adaptive => {
            let cfg = adaptive_config(gains, &scaling)?;
            Box::new(
                AdaptiveEstimator::<T, D, NP, NS>::new(filter, &AdaptiveConfig { theta0, ..cfg })
                    .map_err(err)?,
            )
        }
        EstimatorKind::Gradient => {
            let cfg = match gains {
                Gains::Default => GradientConfig::default(),
                Gains::Paper => GradientConfig::from_physical(
                    &scaling,
                    &two_modes(&GradientConfig::<7>::PAPER_GAIN_2_MODES)?,
                ),
                Gains::PaperExperiment => {
                    GradientConfig::from_physical(&scaling, &two_modes(&EXPERIMENT_GRADIENT_GAIN)?)
                }
            };
            Box::new(
                GradientEstimator::<T, D, NP>::new(filter, &GradientConfig { theta0, ..cfg })
                    .map_err(err)?,
            )
        }
        EstimatorKind::LeastSquares => {
            let cfg = match gains {
                Gains::Default => LeastSquaresConfig::default(),
                Gains::Paper => LeastSquaresConfig::from_physical(
                    &scaling,
                    &two_modes(&LeastSquaresConfig::<7>::PAPER_GAIN0_2_MODES)?,
                ),
                Gains::PaperExperiment => {
                    LeastSquaresConfig::from_physical(&scaling, &two_modes(&EXPERIMENT_LS_GAIN0)?)
                }
            };
            Box::new(
                LeastSquaresEstimator::<T, D, NP>::new(
                    filter,
                    &LeastSquaresConfig { theta0, ..cfg },
                )
                .map_err(err)?,
            )
        }
    })
}
