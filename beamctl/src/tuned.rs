//! An estimator driven by the truth-free tuning rule
//! ([`beamest::tuning::AutoTune`]): start-up window → first build → held
//! while its filters settle → re-centred on the estimated band, with the
//! estimate carried over. `beamctl simulate` and `beamctl replay` both feed
//! their samples through this, so the same samples give the same
//! estimates whichever command reads them.
//!
//! The rebuilds happen between two samples; on the firmware the same
//! happens in the low-priority task (see the core module's docs).

use crate::gains::{build_estimator, EstimatorKind, Gains};
use crate::runner::RunError;
use beamest::estimator::{Estimator, StepStatus};
use beamest::filter_bank::FilterConfig;
use beamest::tuning::{carry_over, AutoTune, Phase, Settled, TuningConfig};
use beamest::Real;
use serde::Serialize;

/// One (re)build of the estimator.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Build {
    /// Index of the first sample the new estimator receives.
    pub sample: u64,
    /// Its filter pole λ (rad/s).
    pub lambda_rad_s: f64,
    /// Its signal scale U0 (input units).
    pub u_scale: f64,
    /// Its signal scale Y0 (output units).
    pub y_scale: f64,
}

/// Sample counters over every estimator the rule built, plus the start-up
/// window.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Totals {
    /// Samples given to [`Tuned::step`].
    pub samples: u64,
    /// Non-finite or out-of-range samples (start-up window included).
    pub rejected: u64,
    /// Law updates that failed (Θ held).
    pub skipped: u64,
    /// Law updates applied (over every build).
    pub updates: u64,
}

/// An estimator of one law and precision under the tuning rule.
pub struct Tuned<T: Real, const D: usize, const NP: usize, const NS: usize> {
    kind: EstimatorKind,
    gains: Gains,
    tune: AutoTune,
    est: Option<Box<dyn Estimator<T, NP>>>,
    builds: Vec<Build>,
    samples: u64,
    updates: u64,
    /// Rejected/skipped of the estimators already replaced.
    retired_rejected: u64,
    retired_skipped: u64,
}

impl<T: Real, const D: usize, const NP: usize, const NS: usize> Tuned<T, D, NP, NS> {
    /// A new driver; builds at once if the settings are all known.
    pub fn new(kind: EstimatorKind, gains: Gains, tuning: &TuningConfig) -> Result<Self, RunError> {
        let tune =
            AutoTune::new(tuning).map_err(|e| RunError::Estimator(format!("tuning: {e}")))?;
        let mut t = Self {
            kind,
            gains,
            tune,
            est: None,
            builds: Vec::new(),
            samples: 0,
            updates: 0,
            retired_rejected: 0,
            retired_skipped: 0,
        };
        if let Some(filter) = t.tune.immediate() {
            t.install(&filter, None, false)?;
        }
        Ok(t)
    }

    /// Build an estimator for `filter` (θ(0) = `theta0`, scaled) and make
    /// it current; the next sample goes to it.
    fn install(
        &mut self,
        filter: &FilterConfig,
        theta0: Option<[f64; NP]>,
        settle: bool,
    ) -> Result<(), RunError> {
        let mut est =
            build_estimator::<T, D, NP, NS>(self.kind, self.gains, filter, theta0.as_ref())?;
        if settle {
            est.hold_for_settling();
        }
        if let Some(old) = self.est.replace(est) {
            let h = old.health();
            self.retired_rejected += u64::from(h.rejected);
            self.retired_skipped += u64::from(h.skipped);
        }
        self.builds.push(Build {
            sample: self.samples,
            lambda_rad_s: filter.lambda_rad_s,
            u_scale: filter.scales.u_scale,
            y_scale: filter.scales.y_scale,
        });
        Ok(())
    }

    /// Feed one sample (physical units). `None` during the start-up window
    /// (no estimator yet). Never panics; a failed rebuild keeps the
    /// current estimator and stops the rule.
    #[inline]
    pub fn step(&mut self, u: T, y: T) -> Option<StepStatus> {
        self.samples += 1;
        let Some(est) = self.est.as_mut() else {
            if let Some(filter) = self.tune.startup_sample(u, y) {
                // A failure here (invalid gains for this λ) leaves no
                // estimator: the run reports no estimate.
                let _ = self.install(&filter, None, true);
            }
            return None;
        };
        let status = est.step(u, y);
        if status == StepStatus::Updated {
            self.updates += 1;
        }
        if self.tune.sample() {
            let tf = est.transfer_function();
            if let Some(filter) = self.tune.review(&tf) {
                let theta0 = carry_over::<T, NP>(&tf, &filter);
                let _ = self.install(&filter, theta0, true);
            }
        }
        Some(status)
    }

    /// The current estimator (`None` during the start-up window).
    pub fn estimator(&self) -> Option<&dyn Estimator<T, NP>> {
        self.est.as_deref()
    }

    /// The current estimator once its law (or an earlier build's, carried
    /// over) has updated at least once: before that Θ̂ is only θ(0) = 0,
    /// which is no estimate.
    pub fn estimate(&self) -> Option<&dyn Estimator<T, NP>> {
        if self.updates > 0 {
            self.est.as_deref()
        } else {
            None
        }
    }

    /// Every build so far (first = the one after start-up).
    pub fn builds(&self) -> &[Build] {
        &self.builds
    }

    /// The current λ (rad/s), once built.
    pub fn lambda_rad_s(&self) -> Option<f64> {
        self.builds.last().map(|b| b.lambda_rad_s)
    }

    /// The tuning rule's state.
    pub fn tune(&self) -> &AutoTune {
        &self.tune
    }

    /// Counters over the whole record.
    pub fn totals(&self) -> Totals {
        let (rejected, skipped) = match &self.est {
            Some(e) => {
                let h = e.health();
                (u64::from(h.rejected), u64::from(h.skipped))
            }
            None => (0, 0),
        };
        Totals {
            samples: self.samples,
            rejected: self.retired_rejected + rejected + u64::from(self.tune.stats().rejected()),
            skipped: self.retired_skipped + skipped,
            updates: self.updates,
        }
    }

    /// A short description of where the rule ended.
    pub fn phase_label(&self) -> &'static str {
        phase_label(self.tune.phase())
    }
}

/// `"startup"`, `"reviewing"`, `"fixed"`, `"converged"`, `"max_recentres"`,
/// `"timeout"`.
pub fn phase_label(p: Phase) -> &'static str {
    match p {
        Phase::Startup => "startup",
        Phase::Reviewing => "reviewing",
        Phase::Settled(Settled::Fixed) => "fixed",
        Phase::Settled(Settled::Converged) => "converged",
        Phase::Settled(Settled::MaxRecentres) => "max_recentres",
        Phase::Settled(Settled::Timeout) => "timeout",
    }
}
