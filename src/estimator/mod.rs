//! Online estimators of Θ (eq. 29) behind one trait.
//!
//! An estimator is a filter bank ([`FilterBank`]) feeding an update law
//! ([`UpdateLaw`]); [`Identifier`] joins the two, screens the raw samples and
//! keeps health counters. Three laws are provided:
//!
//! * [`adaptive::AdaptiveLaw`] — the paper's proposed law, eqs. 33–41;
//! * [`gradient::GradientLaw`] — the gradient baseline, eq. 47;
//! * [`least_squares::LeastSquaresLaw`] — the least-squares baseline, eq. 48.
//!
//! [`robust::RobustEstimator`] is not an `Identifier`: it runs the proposed
//! law on the output error of a simulated model (unbiased under measurement
//! noise, near the Cramér–Rao bound) and shares only the input screening.
//!
//! All laws work on the scaled regressor φ and scaled parameters θ_s (see
//! [`Scaling`]); [`Estimator::theta`] returns the paper's Θ in physical units.
//!
//! # Bad input
//! A non-finite sample, or one more than [`INPUT_LIMIT`] times its signal
//! scale, is never fed to the filters: the last good value is substituted to
//! keep the filter states continuous, and the law is frozen until the
//! filters have forgotten the substitute: [`QUARANTINE_TIME_CONSTANTS`]
//! filter time constants 1/λ (0.4 s at λ = 100 rad/s). The (s+λ)^D impulse
//! response's tail (λt)^{D−1}e^{−λt}/(D−1)! is below 1e-10 by then; a
//! four-sample freeze (the interpolation window alone) measurably left a
//! 1.1e-2 error on ζ. Estimator state is therefore never corrupted by bad
//! data; the law simply holds Θ meanwhile.

pub mod adaptive;
pub mod gradient;
pub mod least_squares;
pub mod robust;
mod screen;

use crate::filter_bank::{FilterBank, FilterConfig, FilterConfigError, Regressor, Scaling};
use crate::modal::excitation_min_eig;
use crate::model::TransferFunction;
use crate::scalar::Real;

pub use adaptive::{AdaptiveConfig, AdaptiveLaw};
pub use gradient::{GradientConfig, GradientLaw};
pub use least_squares::{LeastSquaresConfig, LeastSquaresLaw};
pub use robust::{Robust1, Robust2, Robust3, RobustConfig, RobustEstimator};
use screen::{InputScreen, Screened};

/// A sample more than this many signal scales away from zero is rejected.
pub const INPUT_LIMIT: f64 = 1e6;
/// How long (in filter time constants 1/λ) the law stays frozen after a
/// rejected sample.
pub const QUARANTINE_TIME_CONSTANTS: f64 = 40.0;

/// What one call to [`Estimator::step`] did.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum StepStatus {
    /// The law was updated with a new regressor.
    Updated,
    /// The sample was accepted but the law is frozen (recent bad sample).
    Frozen,
    /// The sample was non-finite or out of range and was replaced.
    Rejected,
    /// The law could not update (its step matrix had no positive diagonal or
    /// a non-finite entry — e.g. R(0) decayed to zero after a long absence of
    /// excitation); Θ was left unchanged.
    Skipped,
}

/// Why a law could not apply an update. Θ is unchanged when this is returned.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LawError {
    /// The step matrix was not positive definite in working precision.
    Singular,
    /// The update produced a non-finite value and was discarded.
    NonFinite,
}

/// Invalid gain or rate settings.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ConfigError {
    /// The filter-bank configuration is invalid.
    Filter(FilterConfigError),
    /// A gain, rate or initial matrix entry is not positive and finite.
    Gain,
    /// Inconsistent const sizes (e.g. NS ≠ NP(NP+1)/2).
    Dimensions,
}

impl From<FilterConfigError> for ConfigError {
    fn from(e: FilterConfigError) -> Self {
        Self::Filter(e)
    }
}

/// Counters describing how an estimator has been fed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Health {
    /// Samples pushed.
    pub samples: u64,
    /// Samples rejected as non-finite or out of range (saturating).
    pub rejected: u32,
    /// Law updates that failed, Θ held (saturating).
    pub skipped: u32,
    /// False if the law's state has degraded (a non-finite word, or a
    /// negative diagonal in P or R). Never expected; checked when
    /// [`Estimator::health`] is called, so call it at the telemetry rate.
    pub state_ok: bool,
}

/// An update law acting on scaled regressors (one per paper equation).
pub trait UpdateLaw<T: Real, const NP: usize>: Sized {
    /// Gains and rates, in scaled coordinates.
    type Config: Clone;
    /// Build from a validated configuration.
    fn new(cfg: &Self::Config, ts_s: f64) -> Result<Self, ConfigError>;
    /// Apply one regressor sample.
    fn update(&mut self, reg: &Regressor<T, NP>) -> Result<(), LawError>;
    /// Current scaled estimate θ_s.
    fn theta_scaled(&self) -> [T; NP];
    /// Return to the initial state.
    fn reset(&mut self);
    /// The law's information matrix P (eq. 33) if it keeps one; its smallest
    /// eigenvalue is the excitation monitor of Lemma 1.
    fn information(&self) -> Option<[[T; NP]; NP]>;
    /// Cheap integrity check of the law's state (finite, definite
    /// diagonals); laws without matrices only check Θ.
    fn is_healthy(&self) -> bool {
        self.theta_scaled().iter().all(|t| t.is_finite())
    }
}

/// The common interface of every estimator: feed samples, read Θ.
pub trait Estimator<T: Real, const NP: usize> {
    /// Push one sample: `u` held over the coming sample period and `y`
    /// sampled now, in physical units. Never panics.
    fn step(&mut self, u: T, y: T) -> StepStatus;
    /// Θ of eq. 29 in physical units.
    fn theta(&self) -> [T; NP];
    /// The estimated transfer function (a, b of eq. 25–27).
    fn transfer_function(&self) -> TransferFunction<T>;
    /// Back to the initial state (filters at rest, initial Θ and gains).
    fn reset(&mut self);
    /// Excitation level: λmin of the scaled information matrix P (Lemma 1),
    /// `None` for laws that keep no P. Costs an eigen-decomposition: call at
    /// the telemetry rate, not per sample.
    fn excitation_level(&self) -> Option<T>;
    /// Input-screening and update counters.
    fn health(&self) -> Health;
}

/// A filter bank and an update law: a complete estimator.
///
/// `D = 2n` is the model order and `NP = 2D − 1` the number of parameters.
#[derive(Debug, Clone)]
pub struct Identifier<T, L, const D: usize, const NP: usize> {
    bank: FilterBank<T, D, NP>,
    law: L,
    /// Θ_j = θ_s,j·unscale_j (Y0·E_j of [`Scaling`]), in working precision.
    unscale: [T; NP],
    lambda_rad_s: f64,
    screen: InputScreen<T>,
    samples: u64,
    skipped: u32,
}

impl<T: Real, L: UpdateLaw<T, NP>, const D: usize, const NP: usize> Identifier<T, L, D, NP> {
    /// Build from a filter configuration and a law configuration.
    pub fn new(filter: &FilterConfig, law: &L::Config) -> Result<Self, ConfigError> {
        let bank = FilterBank::new(filter)?;
        let law = L::new(law, filter.ts_s)?;
        Ok(Self {
            bank,
            law,
            unscale: Scaling::<NP>::new(filter).to_physical(&[T::ONE; NP]),
            lambda_rad_s: filter.lambda_rad_s,
            screen: InputScreen::new(filter),
            samples: 0,
            skipped: 0,
        })
    }

    /// The update law (read-only).
    pub fn law(&self) -> &L {
        &self.law
    }

    /// Samples the law stays frozen after a rejected sample.
    pub fn quarantine_samples(&self) -> u32 {
        self.screen.quarantine_len()
    }

    /// The filter pole λ (rad/s).
    pub fn lambda_rad_s(&self) -> f64 {
        self.lambda_rad_s
    }
}

impl<T: Real, L: UpdateLaw<T, NP>, const D: usize, const NP: usize> Estimator<T, NP>
    for Identifier<T, L, D, NP>
{
    #[inline]
    fn step(&mut self, u: T, y: T) -> StepStatus {
        self.samples = self.samples.wrapping_add(1);
        match self.screen.screen(u, y) {
            Screened::Good(u, y) => {
                let reg = self.bank.push(u, y);
                match self.law.update(&reg) {
                    Ok(()) => StepStatus::Updated,
                    Err(_) => {
                        self.skipped = self.skipped.saturating_add(1);
                        StepStatus::Skipped
                    }
                }
            }
            Screened::Quarantined(u, y) => {
                self.bank.push(u, y);
                StepStatus::Frozen
            }
            Screened::Rejected(u, y) => {
                self.bank.push(u, y);
                StepStatus::Rejected
            }
        }
    }

    fn theta(&self) -> [T; NP] {
        let mut th = self.law.theta_scaled();
        for (t, k) in th.iter_mut().zip(self.unscale.iter()) {
            *t *= *k;
        }
        th
    }

    fn transfer_function(&self) -> TransferFunction<T> {
        let th = self.theta();
        // NP = 4n − 1 with n ≤ MAX_MODES is guaranteed by FilterConfig::validate.
        TransferFunction::from_theta(&th, self.lambda_rad_s).unwrap_or(TransferFunction {
            modes: 0,
            a: Default::default(),
            b: Default::default(),
        })
    }

    fn reset(&mut self) {
        self.bank.reset();
        self.law.reset();
        self.screen.reset();
        self.samples = 0;
        self.skipped = 0;
    }

    fn excitation_level(&self) -> Option<T> {
        self.law.information().map(|p| excitation_min_eig(&p))
    }

    fn health(&self) -> Health {
        Health {
            samples: self.samples,
            rejected: self.screen.rejected,
            skipped: self.skipped,
            state_ok: self.law.is_healthy(),
        }
    }
}

/// The proposed estimator (eqs. 33–41) for `n` modes: `D = 2n`,
/// `NP = 4n − 1`, `NS = NP(NP+1)/2` (packed symmetric storage).
pub type AdaptiveEstimator<T, const D: usize, const NP: usize, const NS: usize> =
    Identifier<T, AdaptiveLaw<T, NP, NS>, D, NP>;
/// The proposed estimator for one mode.
pub type Adaptive1<T> = AdaptiveEstimator<T, 2, 3, 6>;
/// The proposed estimator for two modes (the paper's case).
pub type Adaptive2<T> = AdaptiveEstimator<T, 4, 7, 28>;
/// The proposed estimator for three modes.
pub type Adaptive3<T> = AdaptiveEstimator<T, 6, 11, 66>;
/// The gradient baseline (eq. 47).
pub type GradientEstimator<T, const D: usize, const NP: usize> =
    Identifier<T, GradientLaw<T, NP>, D, NP>;
/// The least-squares baseline (eq. 48).
pub type LeastSquaresEstimator<T, const D: usize, const NP: usize> =
    Identifier<T, LeastSquaresLaw<T, NP>, D, NP>;

/// (1 − e^{−x})/x, accurate for small x ≥ 0 (the exact-step factor of the
/// rank-one laws).
pub(crate) fn one_minus_exp_over_x<T: Real>(x: T) -> T {
    let small = T::from_f64(1e-3);
    if x < small {
        // 1 − x/2 + x²/6 − x³/24
        let half = T::from_f64(0.5);
        let sixth = T::from_f64(1.0 / 6.0);
        let q = T::from_f64(1.0 / 24.0);
        T::ONE - x * (half - x * (sixth - x * q))
    } else {
        (T::ONE - (-x).exp()) / x
    }
}

/// Check a gain is positive and finite.
pub(crate) fn positive(x: f64) -> Result<(), ConfigError> {
    if x > 0.0 && x.is_finite() {
        Ok(())
    } else {
        Err(ConfigError::Gain)
    }
}

/// Check every entry of a gain diagonal is positive and finite.
pub(crate) fn all_positive(xs: &[f64]) -> Result<(), ConfigError> {
    xs.iter().try_for_each(|&x| positive(x))
}

/// Check every entry (e.g. of an initial estimate) is finite.
pub(crate) fn all_finite_f64(xs: &[f64]) -> Result<(), ConfigError> {
    if xs.iter().all(|x| x.is_finite()) {
        Ok(())
    } else {
        Err(ConfigError::Gain)
    }
}
