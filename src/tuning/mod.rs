//! Truth-free settings: the signal scales U0, Y0 and the filter pole λ,
//! chosen from the data and from what the user knows, never from a
//! simulated plant's truth. The same rule runs in `beamctl simulate`,
//! `beamctl replay` and (through this module) the firmware.
//!
//! # The rule
//! 1. **Start-up window** ([`TuningConfig::startup_s`], 0.2 s by default):
//!    the estimator does not run yet; [`StartupStats`] accumulates the RMS
//!    of u and y and a noise-corrected frequency centroid ω_c of y.
//! 2. **First settings.** U0 = RMS(u), Y0 = RMS(y) (unless given). λ0 is
//!    the user's (`Fixed`, never changed), the geometric centre √(ω_lo·ω_hi)
//!    of a band the user knows (`Band`: `--band-hz F1,F2`, or the modes of
//!    a beam model), or [`TuningConfig::data_lambda_factor`]·ω_c (`Data`).
//!    The estimator is built with them and, because the beam is already
//!    moving while its filters start from rest, its law is held for the
//!    filters' settling time (`crate::estimator::QUARANTINE_TIME_CONSTANTS`).
//! 3. **Re-centring.** Every [`TuningConfig::review_period_s`] the current
//!    estimate is reviewed ([`AutoTune::review`]). Once it is valid (every
//!    mode an underdamped, stable pole pair) and stable (ω̂ of every mode
//!    within [`TuningConfig::stable_tolerance`] over the last
//!    [`TuningConfig::stable_reviews`] reviews), λ is moved to the
//!    estimated band's centre √(ω̂_min·ω̂_max) unless it is already within
//!    [`TuningConfig::recentre_threshold`] of it. The estimate is carried
//!    over ([`carry_over`]: the same transfer function in the new λ's
//!    coordinates, so the reported ω̂, ζ̂ do not jump), the filter bank is
//!    rebuilt and the law held while the new filters settle. At most
//!    [`TuningConfig::max_recentres`] times; after that, or once λ stays,
//!    the rule is settled and costs nothing more.
//!
//! # Why it is sound
//! * **Scales do not move the fixed point.** With φ = E·Ψ and y/Y0 the law
//!   converges to P⁻¹Q in scaled coordinates, and P_s = E·P·E, Q_s = E·Q/Y0
//!   for any positive diagonal E, so Θ = Y0·E·θ_s is the same P⁻¹Q in
//!   physical units whatever U0, Y0 are. They set only the conditioning
//!   (and the prior R(0), which decays): RMS values keep φ's entries O(1).
//!   Tests: wrong scales by 0.5× and 2× converge (`host-tests`).
//! * **λ changes the regression, not its solution without noise.** Every
//!   λ gives the same true Θ (eq. 29 holds exactly for any Λ), so
//!   noise-free estimates agree for λ from 30 to 400 rad/s on the paper's
//!   plant (BENCHMARKS.md, "Truth-free settings"). λ sets how Λ(s) weighs the band: far below the highest
//!   mode P is ill-conditioned; with noise on y the errors-in-variables
//!   bias is smallest near the band's geometric centre (BENCHMARKS.md,
//!   "Truth-free settings"). Re-centring needs the first estimate only to
//!   within ~10% to land near the centre; the second pass then starts from
//!   a well-placed λ.
//! * **Carry-over is exact.** Θ of eq. 29 for a new λ is [b, k(λ') − a]
//!   (the same a, b), so the transfer function — and ω̂, ζ̂, b̄ — are
//!   unchanged by the switch; only the filters restart.
//! * **It terminates.** At most `max_recentres` rebuilds, reviews stop
//!   after `review_timeout_s` without a stable estimate, and nothing runs
//!   per sample once settled.
//!
//! # Failure modes
//! * No excitation in the window: the window is extended until u and y
//!   both have a non-zero RMS; an all-zero record never starts the
//!   estimator.
//! * ω_c reflects y's spectrum, which the excitation shapes (a 7 Hz square
//!   wave puts most of it near 44 rad/s), so the data λ0 can be off the
//!   band by a factor 2–5. Noise-free this does not matter (see above); at
//!   low SNR with a weak high mode the first estimate can be too poor to
//!   point at the band, and λ stays where it is: give a band.
//! * A plant that drifts after the rule settled is not followed (λ only
//!   affects conditioning and noise sensitivity, not what is tracked).
//!
//! # Using it
//! The host driver is `beamctl::run::tuned`; the firmware does the same split
//! across its two tasks: the sample task feeds [`AutoTune::startup_sample`]
//! until it returns the first [`FilterConfig`]; the low-priority task builds
//! the estimator (the matrix exponentials), calls
//! [`crate::estimator::Estimator::hold_for_settling`] and swaps it in; at
//! the telemetry rate it calls [`AutoTune::review`] with the estimate and,
//! when that returns a new configuration, builds the new estimator with
//! its law's θ(0) = [`carry_over`] of the current transfer function, holds
//! it for settling and swaps it in at a sample boundary.

pub(crate) mod startup;

pub use startup::StartupStats;

use crate::estimator::quarantine_samples_for;
use crate::filter_bank::{FilterConfig, OutputHold, OutputTiming, Scaling, SignalScales};
use crate::modal::modes_from_denominator;
use crate::model::{TransferFunction, MAX_MODES};
use crate::scalar::Real;
use beam_protocol::OutputKind;

/// Default start-up window (s): a little more than one period of the
/// paper's 7 Hz excitation.
pub(crate) const DEFAULT_STARTUP_S: f64 = 0.2;
/// Default review period (s).
pub(crate) const DEFAULT_REVIEW_PERIOD_S: f64 = 0.01;
/// Most reviews a stability window can span.
pub(crate) const MAX_STABLE_REVIEWS: usize = 32;
/// Largest λ·Ts the rule picks: the filters' time constant stays above
/// ~3 samples.
pub const MAX_LAMBDA_TS: f64 = 0.3;
/// Smallest λ·Ts the rule picks (1 rad/s at 10 kHz).
pub const MIN_LAMBDA_TS: f64 = 1e-4;

/// Where the first filter pole comes from.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum LambdaSource {
    /// A λ (rad/s) given by the user; never re-centred.
    Fixed(f64),
    /// A band the user knows (rad/s): λ0 = √(lo·hi), then re-centred on the
    /// estimate.
    Band {
        /// Lower edge (rad/s).
        lo_rad_s: f64,
        /// Upper edge (rad/s).
        hi_rad_s: f64,
    },
    /// From the start-up window's frequency centroid, then re-centred.
    Data,
}

/// Settings of the rule. [`TuningConfig::new`] gives the defaults.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct TuningConfig {
    /// Sample period Ts (s).
    pub ts_s: f64,
    /// y interpolation of the filter bank.
    pub hold: OutputHold,
    /// The converters' timing the filter bank compensates
    /// ([`FilterConfig::timing`]; ideal by default).
    pub timing: OutputTiming,
    /// What the sensor measures ([`FilterConfig::output`]; strain by
    /// default).
    pub output: OutputKind,
    /// First λ.
    pub lambda: LambdaSource,
    /// U0, Y0 if the user knows them; `None` = RMS over the start-up window.
    pub scales: Option<SignalScales>,
    /// Start-up window (s); extended while u or y is still all zero.
    pub startup_s: f64,
    /// λ0 = this factor × the start-up frequency centroid (`Data` only).
    pub data_lambda_factor: f64,
    /// Review period (s).
    pub review_period_s: f64,
    /// Reviews over which ω̂ must be stable (≤ `MAX_STABLE_REVIEWS`).
    pub stable_reviews: u8,
    /// Largest relative spread of each ω̂ over those reviews.
    pub stable_tolerance: f64,
    /// Re-centre only if λ would move by more than this (relative).
    pub recentre_threshold: f64,
    /// Most re-centrings.
    pub max_recentres: u8,
    /// Stop reviewing if no estimate was stable this long after a build (s).
    pub review_timeout_s: f64,
}

impl TuningConfig {
    /// The defaults (measured in BENCHMARKS.md, "Truth-free settings"):
    /// 0.2 s start-up, λ0 = 2·ω_c from data, reviews every 10 ms, stable
    /// = each ω̂ within 2% over 10 reviews (0.1 s), re-centre if λ moves by
    /// more than 10%, at most 3 times, give up after 30 s.
    pub fn new(ts_s: f64, lambda: LambdaSource) -> Self {
        Self {
            ts_s,
            hold: OutputHold::default(),
            timing: OutputTiming::IDEAL,
            output: OutputKind::Strain,
            lambda,
            scales: None,
            startup_s: DEFAULT_STARTUP_S,
            data_lambda_factor: 2.0,
            review_period_s: DEFAULT_REVIEW_PERIOD_S,
            stable_reviews: 10,
            stable_tolerance: 0.02,
            recentre_threshold: 0.1,
            max_recentres: 3,
            review_timeout_s: 30.0,
        }
    }

    fn validate(&self) -> Result<(), TuningError> {
        let pos = |x: f64| x > 0.0 && x.is_finite();
        if !pos(self.ts_s) {
            return Err(TuningError::SamplePeriod);
        }
        match self.lambda {
            LambdaSource::Fixed(l) if !pos(l) => return Err(TuningError::Lambda),
            LambdaSource::Band { lo_rad_s, hi_rad_s }
                if !(pos(lo_rad_s) && pos(hi_rad_s) && lo_rad_s <= hi_rad_s) =>
            {
                return Err(TuningError::Band)
            }
            _ => {}
        }
        if let Some(s) = self.scales {
            if !(pos(s.u_scale) && pos(s.y_scale)) {
                return Err(TuningError::Scale);
            }
        }
        if !(pos(self.startup_s) && pos(self.data_lambda_factor)) {
            return Err(TuningError::Window);
        }
        let reviews = usize::from(self.stable_reviews);
        if !(pos(self.review_period_s)
            && pos(self.stable_tolerance)
            && pos(self.recentre_threshold)
            && pos(self.review_timeout_s)
            && (1..=MAX_STABLE_REVIEWS).contains(&reviews))
        {
            return Err(TuningError::Review);
        }
        Ok(())
    }
}

/// Invalid tuning settings.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum TuningError {
    /// Ts must be positive and finite.
    SamplePeriod,
    /// A fixed λ must be positive and finite.
    Lambda,
    /// A band must have finite edges 0 < lo ≤ hi.
    Band,
    /// Given scales must be positive and finite.
    Scale,
    /// The start-up window and the data factor must be positive and finite.
    Window,
    /// Review period, tolerances and timeout must be positive and finite,
    /// and the stability window 1..=`MAX_STABLE_REVIEWS` reviews.
    Review,
}

impl core::fmt::Display for TuningError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(match self {
            Self::SamplePeriod => "invalid tuning: sample period ts_s must be positive and finite",
            Self::Lambda => "invalid tuning: a fixed filter pole must be positive and finite",
            Self::Band => "invalid tuning: the band needs finite edges 0 < lo <= hi",
            Self::Scale => "invalid tuning: given signal scales must be positive and finite",
            Self::Window => "invalid tuning: start-up window and data factor must be positive",
            Self::Review => "invalid tuning: review period, tolerances or stable_reviews (1..=32)",
        })
    }
}

impl core::error::Error for TuningError {}

/// Why the rule stopped reviewing.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Settled {
    /// λ was given by the user.
    Fixed,
    /// The estimated band's centre is within the threshold of λ.
    Converged,
    /// The most re-centrings were done.
    MaxRecentres,
    /// No estimate was valid and stable within the review timeout.
    Timeout,
}

/// Where the rule is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Phase {
    /// Collecting the start-up window; no estimator yet.
    Startup,
    /// An estimator runs; its estimate is reviewed.
    Reviewing,
    /// Nothing more to do.
    Settled(Settled),
}

/// The truth-free tuning rule (see the module docs). Allocation-free; the
/// per-sample calls are a few operations.
#[derive(Debug, Clone)]
pub struct AutoTune {
    cfg: TuningConfig,
    stats: StartupStats,
    startup_samples: u32,
    phase: Phase,
    filter: Option<FilterConfig>,
    recentres: u8,
    since_build: u64,
    settle_samples: u64,
    review_every: u64,
    timeout_samples: u64,
    ring: [[f64; MAX_MODES]; MAX_STABLE_REVIEWS],
    ring_len: usize,
    ring_pos: usize,
}

impl AutoTune {
    /// A rule in its start-up phase (or, when λ is `Fixed` and the scales
    /// are given, ready at once: see [`AutoTune::immediate`]).
    pub fn new(cfg: &TuningConfig) -> Result<Self, TuningError> {
        cfg.validate()?;
        let samples = |s: f64| libm::ceil(s / cfg.ts_s).clamp(1.0, u32::MAX as f64);
        let mut t = Self {
            cfg: *cfg,
            stats: StartupStats::new(cfg.ts_s),
            startup_samples: samples(cfg.startup_s) as u32,
            phase: Phase::Startup,
            filter: None,
            recentres: 0,
            since_build: 0,
            settle_samples: 0,
            review_every: samples(cfg.review_period_s) as u64,
            timeout_samples: samples(cfg.review_timeout_s) as u64,
            ring: [[0.0; MAX_MODES]; MAX_STABLE_REVIEWS],
            ring_len: 0,
            ring_pos: 0,
        };
        if let (Some(scales), Some(lambda)) = (cfg.scales, known_lambda(&cfg.lambda)) {
            // Everything is known before the first sample: build at once,
            // assuming the record starts at rest (no settling).
            t.start(lambda, scales, false);
        }
        Ok(t)
    }

    /// The configuration to build before the first sample, if everything
    /// was known up front (λ `Fixed` or `Band` and the scales given). The
    /// estimator then starts with the record, which is assumed to start at
    /// rest: no settling.
    pub fn immediate(&self) -> Option<FilterConfig> {
        if self.stats.samples() == 0 && self.stats.rejected() == 0 {
            self.filter
        } else {
            None
        }
    }

    /// Feed one sample of the start-up window (physical units). Returns
    /// the first filter configuration once the window is complete (u and y
    /// both non-zero); the estimator built from it must be held for
    /// settling and receives the samples after this one. Returns `None`
    /// outside the start-up phase.
    pub fn startup_sample<T: Real>(&mut self, u: T, y: T) -> Option<FilterConfig> {
        if self.phase != Phase::Startup {
            return None;
        }
        self.stats.push(u.to_f64(), y.to_f64());
        let (u0, y0) = (self.stats.u_rms(), self.stats.y_rms());
        let ready = self.stats.samples() >= self.startup_samples
            && u0 > 0.0
            && y0 > 0.0
            && u0.is_finite()
            && y0.is_finite();
        if !ready {
            return None;
        }
        let scales = self.cfg.scales.unwrap_or(SignalScales {
            u_scale: u0,
            y_scale: y0,
        });
        let lambda = match known_lambda(&self.cfg.lambda) {
            Some(l) => l,
            None => match self.stats.centroid_rad_s(self.cfg.ts_s) {
                Some(c) => self.clamp_lambda(self.cfg.data_lambda_factor * c),
                // No measurable variation: the middle of the allowed range
                // in log scale.
                None => libm::sqrt(MIN_LAMBDA_TS * MAX_LAMBDA_TS) / self.cfg.ts_s,
            },
        };
        self.start(lambda, scales, true);
        self.filter
    }

    fn start(&mut self, lambda: f64, scales: SignalScales, settle: bool) {
        let filter = FilterConfig {
            ts_s: self.cfg.ts_s,
            lambda_rad_s: lambda,
            scales,
            hold: self.cfg.hold,
            timing: self.cfg.timing,
            output: self.cfg.output,
        };
        self.phase = match self.cfg.lambda {
            LambdaSource::Fixed(_) => Phase::Settled(Settled::Fixed),
            _ => Phase::Reviewing,
        };
        self.built(filter, settle);
    }

    fn built(&mut self, filter: FilterConfig, settle: bool) {
        self.filter = Some(filter);
        self.since_build = 0;
        self.settle_samples = if settle {
            u64::from(quarantine_samples_for(&filter))
        } else {
            0
        };
        self.ring_len = 0;
        self.ring_pos = 0;
    }

    fn clamp_lambda(&self, lambda: f64) -> f64 {
        let (lo, hi) = (MIN_LAMBDA_TS / self.cfg.ts_s, MAX_LAMBDA_TS / self.cfg.ts_s);
        if lambda.is_finite() {
            lambda.clamp(lo, hi)
        } else {
            hi
        }
    }

    /// Count one estimator step; true when [`AutoTune::review`] is due (only
    /// while reviewing, after the settling time, every review period).
    #[inline]
    pub fn sample(&mut self) -> bool {
        if self.phase != Phase::Reviewing {
            return false;
        }
        self.since_build += 1;
        let Some(after) = self.since_build.checked_sub(self.settle_samples) else {
            return false;
        };
        if after > self.timeout_samples {
            self.phase = Phase::Settled(Settled::Timeout);
            return false;
        }
        after > 0 && after % self.review_every == 0
    }

    /// [`AutoTune::sample`] for `steps` estimator steps at once: true if any
    /// of them made a review due (the low-priority task counts the steps
    /// between two telemetry records and reviews the latest estimate). The
    /// phase afterwards is the one `steps` calls would leave.
    pub fn advance(&mut self, steps: u64) -> bool {
        if self.phase != Phase::Reviewing || steps == 0 {
            return false;
        }
        let before = self.since_build.saturating_sub(self.settle_samples);
        self.since_build = self.since_build.saturating_add(steps);
        let Some(after) = self.since_build.checked_sub(self.settle_samples) else {
            return false;
        };
        // Steps with 0 < a ≤ timeout, a in (before, after], review when a
        // is a multiple of the period.
        let last = after.min(self.timeout_samples);
        if after > self.timeout_samples {
            self.phase = Phase::Settled(Settled::Timeout);
        }
        last > before && last / self.review_every > before / self.review_every
    }

    /// The estimator was rebuilt at `filter` by someone else (new gains
    /// commanded with the automatic λ): review again from this build, with
    /// the settling time, the re-centring count and the stability window
    /// reset. Ignored during the start-up window (the rule builds first).
    pub(crate) fn rebuilt(&mut self, filter: FilterConfig) {
        if self.phase == Phase::Startup {
            return;
        }
        self.phase = Phase::Reviewing;
        self.recentres = 0;
        self.built(filter, true);
    }

    /// What the sensor measures changed (a command): every filter the
    /// rule gives from now on, and the current one, models `output`
    /// ([`FilterConfig::output`]; it sets the scaled coordinates of θ(0)).
    pub(crate) fn set_output(&mut self, output: OutputKind) {
        self.cfg.output = output;
        if let Some(f) = self.filter.as_mut() {
            f.output = output;
        }
    }

    /// Review the current estimate. Returns the new filter configuration
    /// when λ is to be re-centred: build it with θ(0) = [`carry_over`] of
    /// `tf`, hold it for settling and use it from the next sample on.
    pub fn review<T: Real>(&mut self, tf: &TransferFunction<T>) -> Option<FilterConfig> {
        let filter = self.filter?;
        if self.phase != Phase::Reviewing {
            return None;
        }
        let Some(omega) = valid_omegas(tf) else {
            self.ring_len = 0;
            return None;
        };
        let n = tf.modes;
        let window = usize::from(self.cfg.stable_reviews);
        self.ring[self.ring_pos] = omega;
        self.ring_pos = (self.ring_pos + 1) % window;
        self.ring_len = (self.ring_len + 1).min(window);
        if self.ring_len < window {
            return None;
        }
        for i in 0..n {
            let (mut lo, mut hi) = (f64::INFINITY, 0.0f64);
            for w in &self.ring[..window] {
                lo = lo.min(w[i]);
                hi = hi.max(w[i]);
            }
            if !(hi - lo <= self.cfg.stable_tolerance * lo) {
                return None;
            }
        }
        let proposed = self.clamp_lambda(libm::sqrt(omega[0] * omega[n - 1]));
        let ratio = proposed / filter.lambda_rad_s;
        if ratio.max(1.0 / ratio) < 1.0 + self.cfg.recentre_threshold {
            self.phase = Phase::Settled(Settled::Converged);
            return None;
        }
        if self.recentres >= self.cfg.max_recentres {
            self.phase = Phase::Settled(Settled::MaxRecentres);
            return None;
        }
        self.recentres += 1;
        let next = FilterConfig {
            lambda_rad_s: proposed,
            ..filter
        };
        self.built(next, true);
        Some(next)
    }

    /// Where the rule is.
    pub fn phase(&self) -> Phase {
        self.phase
    }

    /// The current filter configuration (`None` during start-up).
    pub fn filter(&self) -> Option<FilterConfig> {
        self.filter
    }

    /// Re-centrings done.
    pub fn recentres(&self) -> u8 {
        self.recentres
    }

    /// The start-up window's statistics.
    pub fn stats(&self) -> &StartupStats {
        &self.stats
    }

    /// The settings.
    pub fn config(&self) -> &TuningConfig {
        &self.cfg
    }
}

/// λ0 when the user gave it (`Fixed`) or a band (its geometric centre).
fn known_lambda(source: &LambdaSource) -> Option<f64> {
    match *source {
        LambdaSource::Fixed(l) => Some(l),
        LambdaSource::Band { lo_rad_s, hi_rad_s } => Some(libm::sqrt(lo_rad_s * hi_rad_s)),
        LambdaSource::Data => None,
    }
}

/// ω̂ of every mode if the estimate is a stable, underdamped model.
fn valid_omegas<T: Real>(tf: &TransferFunction<T>) -> Option<[f64; MAX_MODES]> {
    let n = tf.modes;
    if n == 0 || n > MAX_MODES {
        return None;
    }
    let modes = modes_from_denominator(&tf.a[..2 * n]).ok()?;
    if !modes.is_stable() || modes.any_real_poles() {
        return None;
    }
    let mut w = [0.0; MAX_MODES];
    for i in 0..n {
        let (wi, zi) = (modes.omega_rad_s[i].to_f64(), modes.zeta[i].to_f64());
        if !(wi > 0.0 && wi.is_finite() && zi < 1.0) {
            return None;
        }
        w[i] = wi;
    }
    Some(w)
}

/// θ(0) for an estimator built with `filter` that continues from the
/// estimate `tf`: Θ = [b, k(λ') − a] of eq. 29 at the new λ', in the new
/// scaled coordinates ([`Scaling::to_scaled`]). The transfer function, and
/// so ω̂, ζ̂, b̄, is unchanged. `None` if `tf` does not have `NP = 4n − 1`
/// parameters or a value is not finite.
pub fn carry_over<T: Real, const NP: usize>(
    tf: &TransferFunction<T>,
    filter: &FilterConfig,
) -> Option<[f64; NP]> {
    let tf64 = TransferFunction {
        modes: tf.modes,
        a: tf.a.map(|v| v.to_f64()),
        b: tf.b.map(|v| v.to_f64()),
        output: tf.output,
    };
    let mut theta = [0.0; NP];
    tf64.to_theta(filter.lambda_rad_s, &mut theta)?;
    let scaled = Scaling::<NP>::new(filter).to_scaled(&theta);
    scaled.iter().all(|v| v.is_finite()).then_some(scaled)
}

#[cfg(test)]
mod tests;
