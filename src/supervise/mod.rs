//! The estimator's supervisor: what keeps the paper's law right on a real
//! rig, where the excitation stops, the beam changes and sensors fail.
//!
//! * **excitation** — is the estimator excited? Lemma 1 (`lemma1.rs`, its
//!   one home): λmin(P)/tr(P) against `EXCITATION_REL_THRESHOLD`
//!   (`lemma1_excited`), computed in the loop as a by-product of the
//!   law's θ step (`InLoopLemma1`) and at the telemetry rate
//!   ([`excitation_min_eig`]); and `input.rs`: a per-sample "input gone"
//!   detector (`InputMonitor`) and an "information gone" detector on the
//!   regressor's power (`InformationMonitor`: the trace of what P gains);
//!   the **anti-windup**: adaptation is frozen while the input is gone and
//!   the data no longer informative — a free decay after an impact, or
//!   the ring-down after the drive stops, is learnt from until it has
//!   decayed 20 dB below the regressor's power under the input (P, Q, R,
//!   θ̂ then neither accumulate nor decay, the filters
//!   keep running on the real samples so nothing needs to settle when it
//!   returns), and forgetting is suspended while Lemma 1 fails after having
//!   passed (the directions the input no longer excites keep what they
//!   know); one answer, [`ExcitationReason`];
//! * `change` — **tracking**: a CUSUM test on the a-priori prediction
//!   error; a detected change discounts the old data (P, Q, R × 2⁻⁴⁰, θ̂
//!   kept) so the law follows the new beam within a fraction of a second;
//!   its threshold is the one knob that trades tracking speed against
//!   noise;
//!
//! and, outside the estimator, [`crate::guard`] screens the sensor's
//! samples and `crate::modal::validity` flags unphysical estimates.
//!
//! `Supervisor` joins the first two for an estimator
//! ([`crate::estimator::Identifier`], [`crate::estimator::robust::RobustEstimator`]):
//! per sample it costs a few flops (the input's mean square); the
//! residual's CUSUM runs every `crate::estimator::SUPERVISE_EVERY`-th
//! sample in [`crate::estimator::Identifier`]
//! (`Supervisor::with_residual_every`), and the in-loop λmin is one
//! inverse-iteration step every `LEMMA1_EVERY` θ steps. Its state is
//! read at the telemetry rate through
//! [`crate::estimator::Estimator::supervision`] ([`Supervision`]).
//! docs/ROBUSTNESS.md has the measurements behind every threshold.

pub(crate) mod change;
mod input;
mod lemma1;

pub use change::TrackingConfig;
pub(crate) use change::{ChangeDetector, DISCOUNT};
pub(crate) use input::{InformationMonitor, InputMonitor};
pub(crate) use lemma1::InLoopLemma1;
pub(crate) use lemma1::EXCITATION_REL_THRESHOLD;
pub use lemma1::{excitation_min_eig, excitation_ratio};

use crate::scalar::Real;

/// Why the estimator is or is not excited.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum ExcitationReason {
    /// Input present and Lemma 1 satisfied (or not known yet).
    #[default]
    Excited,
    /// The input's short-window energy fell more than 20 dB below its
    /// level and so has the information the data brings (the regressor's
    /// power, `InformationMonitor`): adaptation is frozen.
    InputGone,
    /// The input is there but λmin(P)/tr(P) is below the threshold: some
    /// direction of Θ is not excited; forgetting is suspended so it cannot
    /// decay.
    NotPersistent,
    /// The input is there, Lemma 1 not measured yet (no θ step since the
    /// estimator started).
    Starting,
    /// The input is gone, but the response still carries information (a
    /// free decay after an impact or after the drive stopped, within 20 dB
    /// of the regressor's power under the input): adaptation goes on.
    FreeResponse,
}

impl ExcitationReason {
    /// True for [`ExcitationReason::Excited`].
    pub(crate) fn is_excited(self) -> bool {
        self == Self::Excited
    }

    /// A short lowercase name (`"excited"`, `"input_gone"`,
    /// `"not_persistent"`, `"starting"`, `"free_response"`).
    pub fn as_str(self) -> &'static str {
        match self {
            Self::Excited => "excited",
            Self::InputGone => "input_gone",
            Self::NotPersistent => "not_persistent",
            Self::Starting => "starting",
            Self::FreeResponse => "free_response",
        }
    }
}

impl core::fmt::Display for ExcitationReason {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(self.as_str())
    }
}

/// The information monitor takes the regressor's power of every this
/// many samples ([`Supervisor::inform`]; its windows are in seconds).
pub(crate) const INFORM_EVERY: u32 = 10;

/// What the supervisor does.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct SupervisorConfig {
    /// Freeze adaptation while the input is gone (`InputMonitor`).
    pub freeze_without_input: bool,
    /// Suspend forgetting while Lemma 1 fails (after it has passed once).
    pub hold_forgetting_unexcited: bool,
    /// Detected-change tracking.
    pub tracking: TrackingConfig,
}

impl Default for SupervisorConfig {
    /// Everything on, the default change threshold.
    fn default() -> Self {
        Self {
            freeze_without_input: true,
            hold_forgetting_unexcited: true,
            tracking: TrackingConfig::default(),
        }
    }
}

impl SupervisorConfig {
    /// Nothing: the law as published.
    pub const OFF: Self = Self {
        freeze_without_input: false,
        hold_forgetting_unexcited: false,
        tracking: TrackingConfig::OFF,
    };
}

/// The supervisor's state as telemetry and the host tools see it.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Supervision<T> {
    /// Excited, or why not.
    pub reason: ExcitationReason,
    /// Adaptation is frozen by the supervisor now (input gone).
    pub frozen: bool,
    /// Forgetting is active (false while suspended, see
    /// [`SupervisorConfig::hold_forgetting_unexcited`]).
    pub forgetting: bool,
    /// λmin(P)/tr(P) from the law's θ step (Lemma 1), if known.
    pub lemma1_ratio: Option<T>,
    /// The input's short-window mean square over its reference.
    pub input_level: T,
    /// Changes detected since the estimator started (saturating).
    pub changes: u32,
    /// The change test's statistic g now and its largest value since it
    /// was last armed (alarm at [`TrackingConfig::change_threshold`]).
    pub change_statistic: T,
    /// See `change_statistic`.
    pub change_peak: T,
    /// The estimator's sample count at the last detection.
    pub last_change_sample: Option<u64>,
}

impl<T: Real> Supervision<T> {
    /// Excited by both tests.
    pub fn excited(&self) -> bool {
        self.reason.is_excited()
    }
}

/// The per-estimator supervisor state (see the module docs).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Supervisor<T> {
    cfg: SupervisorConfig,
    input: InputMonitor<T>,
    /// Whether the data is still informative (the regressor's power).
    info: InformationMonitor<T>,
    change: ChangeDetector<T>,
    discount: T,
    lemma1_ratio: Option<T>,
    /// The law reports Lemma 1 in the loop ([`Supervisor::with_lemma1`]).
    lemma1_measured: bool,
    lemma1_passed: bool,
    forgetting: bool,
    frozen: bool,
    changes: u32,
    last_change: Option<u64>,
}

impl<T: Real> Supervisor<T> {
    /// For sample period `ts_s`.
    pub fn new(cfg: &SupervisorConfig, ts_s: f64) -> Self {
        Self {
            cfg: *cfg,
            input: InputMonitor::new(ts_s),
            info: InformationMonitor::new(ts_s * f64::from(INFORM_EVERY)),
            change: ChangeDetector::new(&cfg.tracking, ts_s),
            discount: T::from_f64(DISCOUNT),
            lemma1_ratio: None,
            lemma1_measured: false,
            lemma1_passed: false,
            forgetting: true,
            frozen: false,
            changes: 0,
            last_change: None,
        }
    }

    /// The law measures Lemma 1 in the loop ([`Supervisor::lemma1`]):
    /// until its first measurement the status is
    /// [`ExcitationReason::Starting`].
    pub(crate) fn with_lemma1(mut self) -> Self {
        self.lemma1_measured = true;
        self
    }

    /// The change test sees the residual of every `every`-th sample only
    /// (its time constants are kept in seconds): for an estimator that
    /// calls [`Supervisor::residual`] at that cadence to save per-sample
    /// work. `every` = 0 is taken as 1.
    pub(crate) fn with_residual_every(mut self, every: u32, ts_s: f64) -> Self {
        self.change = ChangeDetector::new(&self.cfg.tracking, ts_s * f64::from(every.max(1)));
        self
    }

    /// Take the scaled input u/U0 of a sample; false if adaptation must be
    /// frozen for it (input gone and the data no longer informative, as
    /// of the last [`Supervisor::inform`]).
    #[inline]
    pub(crate) fn admit(&mut self, u_scaled: T) -> bool {
        let present = self.input.push(u_scaled);
        self.frozen = self.cfg.freeze_without_input && !present && !self.info.informative();
        !self.frozen
    }

    /// Take the power |φ|² of the regressor the law is given (every
    /// [`INFORM_EVERY`]-th sample): the information monitor.
    #[inline]
    pub(crate) fn inform(&mut self, power: T) {
        self.info.push(power, self.input.present());
    }

    /// Take the law's a-priori prediction error of a sample it is about to
    /// learn from (`sample` = the estimator's sample count); `Some(factor)`
    /// on a detected change: multiply the old data by it.
    #[inline]
    pub fn residual(&mut self, e: T, sample: u64) -> Option<T> {
        if !self.change.push(e) {
            return None;
        }
        self.changes = self.changes.saturating_add(1);
        self.last_change = Some(sample);
        Some(self.discount)
    }

    /// Take the law's in-loop λmin(P)/tr(P); returns whether forgetting
    /// stays on.
    #[inline]
    pub fn lemma1(&mut self, ratio: Option<T>) -> bool {
        self.lemma1_ratio = ratio;
        // Suspend below the threshold once it has been passed clearly
        // (twice over: no chatter while P fills at start-up); resume when
        // it is clearly passed again.
        let threshold = T::from_f64(EXCITATION_REL_THRESHOLD);
        if let Some(r) = ratio {
            if r >= threshold + threshold {
                self.lemma1_passed = true;
                self.forgetting = true;
            } else if r < threshold && self.lemma1_passed {
                self.forgetting = !self.cfg.hold_forgetting_unexcited;
            }
        }
        self.forgetting
    }

    /// The status now.
    pub fn status(&self) -> Supervision<T> {
        let lemma_fails = self
            .lemma1_ratio
            .is_some_and(|r| !(r >= T::from_f64(EXCITATION_REL_THRESHOLD)));
        let reason = if !self.input.present() {
            if self.info.informative() {
                ExcitationReason::FreeResponse
            } else {
                ExcitationReason::InputGone
            }
        } else if lemma_fails {
            ExcitationReason::NotPersistent
        } else if self.lemma1_measured && self.lemma1_ratio.is_none() {
            ExcitationReason::Starting
        } else {
            ExcitationReason::Excited
        };
        Supervision {
            reason,
            frozen: self.frozen,
            forgetting: self.forgetting,
            lemma1_ratio: self.lemma1_ratio,
            input_level: self.input.relative_level(),
            changes: self.changes,
            change_statistic: self.change.statistic(),
            change_peak: self.change.peak(),
            last_change_sample: self.last_change,
        }
    }

    /// Learn the residual's level afresh before the change test is armed
    /// again (after a hold: the samples around it were disturbed — a sensor
    /// gap, a resume — and the residual may take a while to return to its
    /// level; that is not a change of the plant).
    pub(crate) fn restart_change(&mut self) {
        self.change.restart();
    }

    /// Back to the start (a reset estimator).
    pub fn reset(&mut self) {
        *self = Self {
            input: {
                let mut m = self.input;
                m.reset();
                m
            },
            info: {
                let mut m = self.info;
                m.reset();
                m
            },
            change: {
                let mut c = self.change;
                c.restart();
                c
            },
            lemma1_ratio: None,
            lemma1_passed: false,
            forgetting: true,
            frozen: false,
            changes: 0,
            last_change: None,
            ..*self
        };
    }
}
