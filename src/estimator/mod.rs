//! Online estimators of Θ (eq. 29) behind one trait.
//!
//! An [`Identifier`] is a [`Regression`] (the filters that turn a sample
//! into the law's regressor, and the map from the law's θ_s back to the
//! reported model) feeding an update law ([`UpdateLaw`]), inside a learner
//! (`learner.rs`: the input screen, the supervisor and the health
//! counters, owned by every estimator). [`PaperRegression`] is the paper's
//! filter bank ([`FilterBank`], eqs. 28–29); the feedthrough estimator
//! ([`feedthrough::Feedthrough`]) is the same identifier over another
//! regression. Three laws are provided:
//!
//! * [`adaptive::AdaptiveLaw`] — the paper's proposed law, eqs. 33–41;
//! * [`gradient::GradientLaw`] — the gradient baseline, eq. 47;
//! * [`least_squares::LeastSquaresLaw`] — the least-squares baseline, eq. 48.
//!
//! The θ step of eq. 41 has one implementation (`theta_step.rs`), with
//! Lemma 1 in the loop as its by-product (`supervise/lemma1.rs`).
//!
//! [`robust::RobustEstimator`] is not an `Identifier`: it runs the proposed
//! law on the output error of a simulated model (unbiased under measurement
//! noise, near the Cramér–Rao bound), with the same learner and θ step.
//!
//! All laws work on the scaled regressor φ and scaled parameters θ_s (see
//! [`Scaling`]); [`Estimator::theta`] returns the paper's Θ in physical units.
//!
//! # Bad input
//! A non-finite sample, or one more than `INPUT_LIMIT` times its signal
//! scale, is never fed to the filters: the last good value is substituted to
//! keep the filter states continuous, and the law is frozen until the
//! filters have forgotten the substitute: `QUARANTINE_TIME_CONSTANTS`
//! filter time constants 1/λ (0.4 s at λ = 100 rad/s). The (s+λ)^D impulse
//! response's tail (λt)^{D−1}e^{−λt}/(D−1)! is below 1e-10 by then; a
//! four-sample freeze (the interpolation window alone) measurably left a
//! 1.1e-2 error on ζ. Estimator state is therefore never corrupted by bad
//! data; the law simply holds Θ meanwhile.
//!
//! # Holding the law on purpose
//! [`Estimator::hold`] freezes the law the same way for a given number of
//! samples while the filters keep taking real samples: for when the filter
//! states are out of step with the plant through no fault of the data — an
//! estimator started (or reset) while the beam already moves, a resume
//! after adaptation was paused, sample ticks lost to an overrun. Held steps
//! return [`StepStatus::Frozen`] and are not counted as rejected;
//! [`Estimator::settling_samples`] is the length that lets the filters
//! forget the disturbance (the quarantine's).

pub(crate) mod adaptive;
mod either;
pub(crate) mod feedthrough;
pub(crate) mod gradient;
mod learner;
pub(crate) mod least_squares;
pub mod robust;
mod screen;
mod theta_step;

use crate::filter_bank::{FilterBank, FilterConfig, FilterConfigError, Regressor, Scaling};
use crate::model::TransferFunction;
use crate::scalar::Real;
use crate::supervise::{excitation_min_eig, Supervision, SupervisorConfig};
use beam_protocol::OutputKind;

pub use adaptive::{AdaptiveConfig, AdaptiveLaw};
pub use either::Either;
pub use feedthrough::{Feedthrough, Feedthrough2};
pub use gradient::{GradientConfig, GradientLaw};
use learner::Learner;
pub use least_squares::{LeastSquaresConfig, LeastSquaresLaw};

/// A sample more than this many signal scales away from zero is rejected.
pub(crate) const INPUT_LIMIT: f64 = 1e6;
/// How long (in filter time constants 1/λ) the law stays frozen after a
/// rejected sample.
pub(crate) const QUARANTINE_TIME_CONSTANTS: f64 = 40.0;

/// What one call to [`Estimator::step`] did.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
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
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum LawError {
    /// The step matrix was not positive definite in working precision.
    Singular,
    /// The update produced a non-finite value and was discarded.
    NonFinite,
}

/// Invalid gain or rate settings.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
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

impl core::fmt::Display for LawError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(match self {
            Self::Singular => "law update skipped: step matrix not positive definite",
            Self::NonFinite => "law update skipped: the update came out non-finite",
        })
    }
}

impl core::error::Error for LawError {}

impl core::fmt::Display for ConfigError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Self::Filter(e) => write!(f, "invalid filter configuration: {e}"),
            Self::Gain => f.write_str(
                "invalid gain: every gain, forgetting rate and initial matrix entry must be positive and finite",
            ),
            Self::Dimensions => {
                f.write_str("invalid estimator sizes: need NS = NP*(NP+1)/2 and NP = 2*D - 1")
            }
        }
    }
}

impl core::error::Error for ConfigError {
    fn source(&self) -> Option<&(dyn core::error::Error + 'static)> {
        match self {
            Self::Filter(e) => Some(e),
            Self::Gain | Self::Dimensions => None,
        }
    }
}

/// Counters describing how an estimator has been fed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
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
    /// The supervisor settings in `cfg` ([`crate::supervise`]); laws
    /// without them are not supervised.
    fn supervision_config(_cfg: &Self::Config) -> SupervisorConfig {
        SupervisorConfig::OFF
    }
    /// The a-priori prediction error y/Y0 − θ̂ᵀφ of a regressor (before
    /// [`UpdateLaw::update`] takes it): the change detector's input.
    #[inline]
    fn prediction_error(&self, reg: &Regressor<T, NP>) -> T {
        let th = self.theta_scaled();
        let mut e = reg.y;
        for (t, p) in th.iter().zip(reg.phi.iter()) {
            e -= *t * *p;
        }
        e
    }
    /// Multiply the information gathered so far by `factor` (< 1: a
    /// detected change; θ̂ is kept). Laws that keep none ignore it.
    fn discount(&mut self, _factor: T) {}
    /// Suspend (false) or resume forgetting; laws that do not forget
    /// ignore it.
    fn set_forgetting(&mut self, _on: bool) {}
    /// Whether [`UpdateLaw::lemma1`] measures anything.
    const MEASURES_LEMMA1: bool = false;
    /// λmin(P)/tr(P) as the law tracks it in the loop (Lemma 1), if it does
    /// (`None` also before its first measurement).
    fn lemma1(&self) -> Option<T> {
        None
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
    /// A copy of the scaled information matrix P (eq. 33) whose λmin is
    /// [`Estimator::excitation_level`], `None` for laws that keep no P.
    /// Cheap (a copy, no decomposition): the sample path snapshots it into
    /// telemetry and the eigenvalues are computed elsewhere.
    fn information(&self) -> Option<[[T; NP]; NP]> {
        None
    }
    /// Hold the law for the next `samples` steps (see *Holding the law on
    /// purpose* in the module docs): the filters keep running on the
    /// samples given, Θ and the law's matrices stay as they are, and each
    /// held step returns [`StepStatus::Frozen`] without counting as
    /// rejected. Extends a hold or quarantine already running, never
    /// shortens it; `hold(0)` does nothing.
    fn hold(&mut self, samples: u32);
    /// Samples the filters need to forget a discontinuity in their input:
    /// the quarantine after a rejected sample
    /// (`QUARANTINE_TIME_CONSTANTS` filter time constants). The length to
    /// [`Estimator::hold`] for after a start, a resume or an overrun.
    fn settling_samples(&self) -> u32;
    /// The supervisor's state ([`crate::supervise`]: excitation and its
    /// reason, anti-windup, detected changes); `None` for an unsupervised
    /// estimator. Cheap: call at the telemetry rate.
    fn supervision(&self) -> Option<Supervision<T>> {
        None
    }
    /// The residual terms (the feedthrough D, units of y per unit of u, and
    /// the s³ numerator coefficient) of a model with a residual term
    /// ([`feedthrough::Feedthrough`]); `None` for the models without one.
    /// Not part of [`Estimator::transfer_function`].
    fn residual(&self) -> Option<feedthrough::Residual<T>> {
        None
    }
    /// Hold the law for the filters' settling time
    /// ([`Estimator::settling_samples`], without counting a rejection): for
    /// an estimator that joins a signal already in motion, whose filters
    /// start from rest — the start-up and re-centring of [`crate::tuning`].
    fn hold_for_settling(&mut self) {
        let n = self.settling_samples();
        self.hold(n);
    }
}

/// An estimator borrowed mutably is an estimator (so a caller can lend one
/// to a pipeline, or keep it in static storage and hand out the reference).
impl<T: Real, E: Estimator<T, NP> + ?Sized, const NP: usize> Estimator<T, NP> for &mut E {
    #[inline]
    fn step(&mut self, u: T, y: T) -> StepStatus {
        (**self).step(u, y)
    }
    fn theta(&self) -> [T; NP] {
        (**self).theta()
    }
    fn transfer_function(&self) -> TransferFunction<T> {
        (**self).transfer_function()
    }
    fn reset(&mut self) {
        (**self).reset()
    }
    fn excitation_level(&self) -> Option<T> {
        (**self).excitation_level()
    }
    fn health(&self) -> Health {
        (**self).health()
    }
    fn information(&self) -> Option<[[T; NP]; NP]> {
        (**self).information()
    }
    fn hold(&mut self, samples: u32) {
        (**self).hold(samples)
    }
    fn settling_samples(&self) -> u32 {
        (**self).settling_samples()
    }
    fn supervision(&self) -> Option<Supervision<T>> {
        (**self).supervision()
    }
    fn residual(&self) -> Option<feedthrough::Residual<T>> {
        (**self).residual()
    }
}

/// What an [`Identifier`] regresses on: the filters that turn a sample
/// (u, y) into the law's regressor of `NL` entries (scaled φ and target,
/// eq. 29), and the map from the law's scaled estimate θ_s back to the
/// reported model, whose Θ has `NP` entries. [`PaperRegression`] is the
/// paper's (eqs. 28–29); `feedthrough::FeedthroughRegression` adds a
/// feedthrough term on a sixth-order filter.
pub trait Regression<T: Real, const NL: usize, const NP: usize>: Sized {
    /// Build for a filter configuration.
    ///
    /// # Errors
    /// [`ConfigError::Filter`] for an invalid `filter`;
    /// [`ConfigError::Dimensions`] for sizes the regression cannot report.
    fn new(filter: &FilterConfig) -> Result<Self, ConfigError>;
    /// One sample through the filters: the law's regressor.
    fn push(&mut self, u: T, y: T) -> Regressor<T, NL>;
    /// Filters back to rest.
    fn reset(&mut self);
    /// The filter pole λ (rad/s).
    fn lambda_rad_s(&self) -> f64;
    /// Θ of the reported model (eq. 29) in physical units, from θ_s.
    fn theta(&self, theta_s: &[T; NL]) -> [T; NP];
    /// The reported transfer function (a, b of eqs. 25–27), from θ_s.
    fn transfer_function(&self, theta_s: &[T; NL]) -> TransferFunction<T>;
    /// The law's information matrix P as the reported model's
    /// ([`Estimator::information`]), `None` if it is not one (another size).
    fn information(p: [[T; NL]; NL]) -> Option<[[T; NP]; NP]>;
    /// The residual terms ([`Estimator::residual`]), from θ_s.
    fn residual(&self, _theta_s: &[T; NL]) -> Option<feedthrough::Residual<T>> {
        None
    }
}

/// The paper's regression (eqs. 28–29): the filter bank's regressor Ψ
/// through Λ(s) = (s+λ)^D, Θ = θ_s·(Y0·E_j) of [`Scaling`].
///
/// `D = 2n` is the model order and `NP = 2D − 1` the number of parameters.
#[derive(Debug, Clone)]
pub struct PaperRegression<T, const D: usize, const NP: usize> {
    bank: FilterBank<T, D, NP>,
    /// Θ_j = θ_s,j·unscale_j (Y0·E_j of [`Scaling`]), in working precision.
    unscale: [T; NP],
    lambda_rad_s: f64,
    /// What the sensor measures (the reported model's `output`).
    output: OutputKind,
}

impl<T: Real, const D: usize, const NP: usize> Regression<T, NP, NP> for PaperRegression<T, D, NP> {
    fn new(filter: &FilterConfig) -> Result<Self, ConfigError> {
        Ok(Self {
            bank: FilterBank::new(filter)?,
            unscale: Scaling::<NP>::new(filter).to_physical(&[T::ONE; NP]),
            lambda_rad_s: filter.lambda_rad_s,
            output: filter.output,
        })
    }

    #[inline(always)]
    fn push(&mut self, u: T, y: T) -> Regressor<T, NP> {
        self.bank.push(u, y)
    }

    fn reset(&mut self) {
        self.bank.reset();
    }

    fn lambda_rad_s(&self) -> f64 {
        self.lambda_rad_s
    }

    fn theta(&self, theta_s: &[T; NP]) -> [T; NP] {
        let mut th = *theta_s;
        for (t, k) in th.iter_mut().zip(self.unscale.iter()) {
            *t *= *k;
        }
        th
    }

    fn transfer_function(&self, theta_s: &[T; NP]) -> TransferFunction<T> {
        let th = self.theta(theta_s);
        // NP = 4n − 1 with n ≤ MAX_MODES is guaranteed by FilterConfig::validate.
        let mut tf =
            TransferFunction::from_theta(&th, self.lambda_rad_s).unwrap_or(TransferFunction {
                modes: 0,
                a: Default::default(),
                b: Default::default(),
                output: OutputKind::Strain,
            });
        tf.output = self.output;
        tf
    }

    fn information(p: [[T; NP]; NP]) -> Option<[[T; NP]; NP]> {
        Some(p)
    }
}

/// A regression ([`Regression`]: filters and the map back to the reported
/// model), an update law on its regressor, and the learner around them
/// (input screen, supervisor, counters): a complete estimator.
///
/// `NL` is the law's number of parameters, `NP` the reported Θ's.
#[derive(Debug, Clone)]
pub struct Identifier<T, L, R, const NL: usize, const NP: usize> {
    regression: R,
    law: L,
    learner: Learner<T>,
}

impl<T: Real, L: UpdateLaw<T, NL>, R: Regression<T, NL, NP>, const NL: usize, const NP: usize>
    Identifier<T, L, R, NL, NP>
{
    /// Build from a filter configuration and a law configuration (which
    /// carries the supervisor's settings, [`UpdateLaw::supervision_config`]).
    ///
    /// # Errors
    /// As [`Regression::new`], then as the law's `new`.
    pub fn new(filter: &FilterConfig, law: &L::Config) -> Result<Self, ConfigError> {
        let sup = L::supervision_config(law);
        let regression = R::new(filter)?;
        let law = L::new(law, filter.ts_s)?;
        Ok(Self {
            regression,
            law,
            learner: Learner::new(filter, &sup, L::MEASURES_LEMMA1),
        })
    }

    /// The update law (read-only).
    pub fn law(&self) -> &L {
        &self.law
    }

    /// Samples the law stays frozen after a rejected sample.
    pub fn quarantine_samples(&self) -> u32 {
        self.learner.screen.quarantine_len()
    }

    /// The filter pole λ (rad/s).
    pub fn lambda_rad_s(&self) -> f64 {
        self.regression.lambda_rad_s()
    }
}

impl<T: Real, L: UpdateLaw<T, NL>, R: Regression<T, NL, NP>, const NL: usize, const NP: usize>
    Estimator<T, NP> for Identifier<T, L, R, NL, NP>
{
    #[inline]
    fn step(&mut self, u: T, y: T) -> StepStatus {
        let Self {
            regression,
            law,
            learner,
        } = self;
        learner.step(u, y, |u, y| regression.push(u, y), law)
    }

    fn theta(&self) -> [T; NP] {
        self.regression.theta(&self.law.theta_scaled())
    }

    fn transfer_function(&self) -> TransferFunction<T> {
        self.regression.transfer_function(&self.law.theta_scaled())
    }

    fn reset(&mut self) {
        self.regression.reset();
        self.law.reset();
        self.learner.reset();
    }

    fn excitation_level(&self) -> Option<T> {
        self.law.information().map(|p| excitation_min_eig(&p))
    }

    fn information(&self) -> Option<[[T; NP]; NP]> {
        self.law.information().and_then(R::information)
    }

    /// Also restarts the change test's learning
    /// (`Supervisor::restart_change`).
    fn hold(&mut self, samples: u32) {
        self.learner.hold(samples);
    }

    fn settling_samples(&self) -> u32 {
        self.learner.settling_samples()
    }

    fn supervision(&self) -> Option<Supervision<T>> {
        self.learner.supervision()
    }

    fn residual(&self) -> Option<feedthrough::Residual<T>> {
        self.regression.residual(&self.law.theta_scaled())
    }

    fn health(&self) -> Health {
        self.learner.health(self.law.is_healthy())
    }
}

/// The proposed estimator (eqs. 33–41) for `n` modes: `D = 2n`,
/// `NP = 4n − 1`, `NS = NP(NP+1)/2` (packed symmetric storage).
pub type AdaptiveEstimator<T, const D: usize, const NP: usize, const NS: usize> =
    Identifier<T, AdaptiveLaw<T, NP, NS>, PaperRegression<T, D, NP>, NP, NP>;
/// The proposed estimator for one mode.
pub type Adaptive1<T> = AdaptiveEstimator<T, 2, 3, 6>;
/// The proposed estimator for two modes (the paper's case).
pub type Adaptive2<T> = AdaptiveEstimator<T, 4, 7, 28>;
/// The proposed estimator for three modes.
pub type Adaptive3<T> = AdaptiveEstimator<T, 6, 11, 66>;
/// The gradient baseline (eq. 47).
pub type GradientEstimator<T, const D: usize, const NP: usize> =
    Identifier<T, GradientLaw<T, NP>, PaperRegression<T, D, NP>, NP, NP>;
/// The least-squares baseline (eq. 48).
pub type LeastSquaresEstimator<T, const D: usize, const NP: usize> =
    Identifier<T, LeastSquaresLaw<T, NP>, PaperRegression<T, D, NP>, NP, NP>;

/// Samples covering [`QUARANTINE_TIME_CONSTANTS`] filter time constants
/// (at least the interpolation window), saturating at `u32::MAX`: how long
/// an [`Identifier`] built with `filter` holds its law after a rejected
/// sample or [`Estimator::hold_for_settling`].
pub(crate) fn quarantine_samples_for(filter: &FilterConfig) -> u32 {
    let n = libm::ceil(QUARANTINE_TIME_CONSTANTS / (filter.lambda_rad_s * filter.ts_s));
    if n >= u32::MAX as f64 {
        u32::MAX
    } else {
        (n as u32).max(8)
    }
}

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

#[cfg(test)]
mod output_tests;

#[cfg(test)]
mod tests {
    use super::*;
    use crate::excitation::SquareWave;
    use crate::filter_bank::SignalScales;
    use crate::model::{PAPER_B, PAPER_OMEGA, PAPER_ZETA};
    use crate::rig::{ModalPlant, Rig};

    const TS: f64 = 1e-4;

    /// The first `N` physical-unit regressors Ψ (eq. 29) of the paper's
    /// plant under its square wave: the core's filter bank with unit signal
    /// scales, mapped back by E⁻¹ (as the paper's law would see them).
    fn paper_regressors<const N: usize>() -> [[f64; 7]; N] {
        let cfg = FilterConfig {
            ts_s: TS,
            lambda_rad_s: 100.0,
            scales: SignalScales::default(),
            ..FilterConfig::default()
        };
        let e = Scaling::<7>::new(&cfg).e;
        let mut bank = FilterBank::<f64, 4, 7>::new(&cfg).unwrap();
        let plant = ModalPlant::with_numerator(&PAPER_OMEGA, &PAPER_ZETA, &PAPER_B, TS).unwrap();
        let mut rig = Rig::new(plant, SquareWave::paper());
        core::array::from_fn(|_| {
            let s = rig.tick();
            let reg = bank.push(s.u, s.y);
            core::array::from_fn(|i| reg.phi[i] / e[i])
        })
    }

    type Mat = [[f64; 7]; 7];

    /// H' = γH − HΨΨᵀH (eq. 37; with γ = 0 it is eq. 48's Γ2').
    fn riccati(h: &Mat, psi: &[f64; 7], gamma: f64) -> Mat {
        let hp: [f64; 7] = core::array::from_fn(|i| (0..7).map(|j| h[i][j] * psi[j]).sum());
        core::array::from_fn(|i| core::array::from_fn(|j| gamma * h[i][j] - hp[i] * hp[j]))
    }

    fn axpy(h: &Mat, d: &Mat, k: f64) -> Mat {
        core::array::from_fn(|i| core::array::from_fn(|j| h[i][j] + k * d[i][j]))
    }

    #[derive(Clone, Copy)]
    enum Step {
        Euler,
        Rk4,
        /// The discrete form the laws use (exponential decay plus the
        /// rectangle rule: what eq. 39 and the laws. information
        /// form amount to), as a Sherman–Morrison update of H.
        Exact,
    }

    /// The first sample (1-based) after which H, started at diag(`h0`) and
    /// advanced with `step`, has a diagonal entry that is not positive and
    /// finite, i.e. is no longer positive definite; `None` if it stays so.
    fn breakdown(h0: &[f64; 7], gamma: f64, step: Step, psi: &[[f64; 7]]) -> Option<usize> {
        let mut h: Mat =
            core::array::from_fn(|i| core::array::from_fn(|j| if i == j { h0[i] } else { 0.0 }));
        for (k, p) in psi.iter().enumerate() {
            h = match step {
                Step::Euler => axpy(&h, &riccati(&h, p, gamma), TS),
                Step::Rk4 => {
                    let k1 = riccati(&h, p, gamma);
                    let k2 = riccati(&axpy(&h, &k1, TS / 2.0), p, gamma);
                    let k3 = riccati(&axpy(&h, &k2, TS / 2.0), p, gamma);
                    let k4 = riccati(&axpy(&h, &k3, TS), p, gamma);
                    let sum: Mat = core::array::from_fn(|i| {
                        core::array::from_fn(|j| k1[i][j] + 2.0 * (k2[i][j] + k3[i][j]) + k4[i][j])
                    });
                    axpy(&h, &sum, TS / 6.0)
                }
                Step::Exact => {
                    let g = libm::exp(gamma * TS);
                    let c = TS * g;
                    let hp: [f64; 7] =
                        core::array::from_fn(|i| (0..7).map(|j| h[i][j] * p[j]).sum());
                    let den = 1.0 + c * (0..7).map(|i| p[i] * hp[i]).sum::<f64>();
                    core::array::from_fn(|i| {
                        core::array::from_fn(|j| g * (h[i][j] - c * hp[i] * hp[j] / den))
                    })
                }
            };
            if (0..7).any(|i| !(h[i][i] > 0.0 && h[i][i].is_finite())) {
                return Some(k + 1);
            }
        }
        None
    }

    fn paper_estimator() -> (Adaptive2<f64>, Rig<f64>) {
        let cfg = FilterConfig {
            ts_s: TS,
            lambda_rad_s: 100.0,
            scales: SignalScales {
                u_scale: 0.1,
                y_scale: 1e-3,
            },
            ..FilterConfig::default()
        };
        let est = Adaptive2::<f64>::new(&cfg, &AdaptiveConfig::default()).unwrap();
        let plant = ModalPlant::with_numerator(&PAPER_OMEGA, &PAPER_ZETA, &PAPER_B, TS).unwrap();
        (est, Rig::new(plant, SquareWave::paper()))
    }

    fn run(est: &mut impl Estimator<f64, 7>, rig: &mut Rig<f64>, n: usize) -> [usize; 4] {
        let mut counts = [0; 4];
        for _ in 0..n {
            let s = rig.tick();
            counts[est.step(s.u, s.y) as usize] += 1;
        }
        counts
    }

    #[test]
    fn hold_freezes_the_law_for_exactly_n_samples_and_rejects_nothing() {
        let (mut est, mut rig) = paper_estimator();
        assert_eq!(
            est.settling_samples(),
            4000,
            "40/λ at λ = 100 rad/s, Ts = 0.1 ms"
        );
        run(&mut est, &mut rig, 2000);
        let theta = est.theta();
        est.hold(150);
        // A shorter hold does not shorten it; hold(0) does nothing.
        est.hold(20);
        est.hold(0);
        // [Updated, Frozen, Rejected, Skipped]
        assert_eq!(run(&mut est, &mut rig, 150), [0, 150, 0, 0]);
        assert_eq!(est.theta(), theta);
        // θ steps every K = 10 samples (the default config).
        assert_eq!(run(&mut est, &mut rig, 10), [10, 0, 0, 0]);
        assert_ne!(est.theta(), theta);
        let h = est.health();
        assert_eq!((h.samples, h.rejected, h.skipped), (2160, 0, 0));
        // Through a mutable reference (the pipeline's way), and a rejected
        // sample inside a longer hold does not cut it short.
        let mut by_ref: &mut dyn Estimator<f64, 7> = &mut est;
        by_ref.hold(6000);
        assert_eq!(by_ref.step(f64::NAN, 0.0), StepStatus::Rejected);
        // (The rejected step itself is not one of the held steps.)
        assert_eq!(run(&mut by_ref, &mut rig, 6000), [0, 6000, 0, 0]);
        assert_eq!(run(&mut by_ref, &mut rig, 1), [1, 0, 0, 0]);
        assert_eq!(est.health().rejected, 1);
    }

    /// The filters keep running through a hold: an estimator held from its
    /// first sample on a moving beam for the settling time and one that was
    /// never held reach the same estimate, while a law that adapts on
    /// filters started out of step with the beam is visibly off.
    #[test]
    fn hold_lets_filters_started_on_a_moving_beam_settle() {
        let modal_error = |est: &Adaptive2<f64>| {
            let m = crate::modal::modal_from_tf(&est.transfer_function(), &[-2.0, 2.0]).unwrap();
            (0..2)
                .flat_map(|i| {
                    [
                        (m.omega_rad_s[i] / PAPER_OMEGA[i] - 1.0).abs(),
                        (m.zeta[i] / PAPER_ZETA[i] - 1.0).abs(),
                    ]
                })
                .fold(0.0, f64::max)
        };
        // The beam has moved for 0.1 s before either estimator starts.
        let (fresh, mut rig) = paper_estimator();
        for _ in 0..1000 {
            rig.tick();
        }
        let (mut held, mut plain) = (fresh.clone(), fresh);
        let mut rig2 = rig.clone();
        held.hold(held.settling_samples());
        run(&mut held, &mut rig, 20_000);
        run(&mut plain, &mut rig2, 20_000);
        let (eh, ep) = (modal_error(&held), modal_error(&plain));
        assert!(eh < 1e-6, "held: {eh:e}");
        assert!(ep > 10.0 * eh, "not held: {ep:e}, held: {eh:e}");
    }

    /// Why the laws never integrate H (eq. 37) or Γ2 (eq. 48) explicitly:
    /// with the paper's H(0) and Γ2(0), Ts·ΨᵀHΨ is far above 1 as soon as
    /// the filters respond, and explicit Euler or classical RK4 make H
    /// indefinite at the 5th sample (Γ2: the 4th), after which it overflows
    /// within a few samples more; the exact discrete update stays positive
    /// definite on the same data.
    #[test]
    fn explicit_riccati_steps_break_down_with_the_paper_gains() {
        let psi = paper_regressors::<2000>();
        let h0 = AdaptiveConfig::<7>::PAPER_H0_2_MODES;
        let g0 = LeastSquaresConfig::<7>::PAPER_GAIN0_2_MODES;
        for (gain0, gamma) in [(h0, 0.1), (g0, 0.0)] {
            for step in [Step::Euler, Step::Rk4] {
                let k = breakdown(&gain0, gamma, step, &psi);
                assert!(k.is_some_and(|k| k <= 5), "{k:?}");
            }
            assert_eq!(breakdown(&gain0, gamma, Step::Exact, &psi), None);
        }
        // The data is not the problem: with H(0) 100× smaller, RK4 holds.
        let small = h0.map(|v| v * 1e-2);
        assert_eq!(breakdown(&small, 0.1, Step::Rk4, &psi), None);
    }
}
