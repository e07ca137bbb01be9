//! An estimator driven by the truth-free tuning rule
//! ([`beamest::tuning::AutoTune`]): start-up window → first build → held
//! while its filters settle → re-centred on the estimated band, with the
//! estimate carried over. `beamctl simulate` and `beamctl replay` both feed
//! their samples through this, so the same samples give the same
//! estimates whichever command reads them.
//!
//! The rebuilds happen between two samples; on the firmware the same
//! happens in the low-priority task (see the core module's docs).
//!
//! # The robust estimator's policy
//! The robust estimator ([`beamest::estimator::robust`]) records its first
//! 2 s and replays them through its current model: it is exact only if the
//! record starts where the beam does (at rest, or with a state it can fit),
//! and most of the information on the first mode is in the seconds right
//! after the excitation starts (the Cramér–Rao bound on ω1 grows 1.7× if
//! the first 2 s are lost; `beamest::crlb`). Building it 0.2 s late and
//! rebuilding it at every re-centring, as the paper's laws are, would throw
//! that away. So the driver keeps every sample from the first one while
//! they fit in the estimator's record ([`HOST_RECORD`], 13.1 s at 10 kHz),
//! and every build of the robust estimator — the first one after the
//! start-up window, and each re-centring — replays them all before it takes
//! the next sample: it sees the record from sample 0, as if λ and the
//! scales had been known from the start, and needs no settling hold (its
//! own start test decides whether the beam was at rest). Nothing is
//! carried over: the replay rebuilds the estimate. Once more samples have
//! arrived than its record holds, a rebuild could no longer see the start,
//! so the rule stops re-centring it (`tuning: "record_full"`); its
//! output-error estimate does not depend on λ (λ sets only the start-up
//! law and the coordinates), so nothing is lost.
//!
//! λ does decide whether the start-up law gives the output-error
//! refinement a usable first model: at 20 dB the data's λ0 can be far
//! below the band (docs/SETTINGS.md, "Failure modes"), and then the start-up
//! law never yields a stable model or the refinement ends in a wrong one.
//! So when the record is about to be dropped and the estimate is not
//! usable (still in start-up, or not a set of stable oscillatory modes),
//! the driver restarts the robust estimator from sample 0 at λ·
//! [`RESTART_FACTORS`] and keeps the usable one with the smallest
//! output-error residual — the largest likelihood among the starts, a
//! truth-free choice (`tuning: "restarted"`). docs/SETTINGS.md has the
//! measurements.

use crate::run::error::RunError;
use crate::run::estimator::{
    build_estimator, build_robust, EstimatorKind, Gains, HostRobust, HOST_RECORD,
};
use beamest::estimator::robust::Phase as RobustPhase;
use beamest::estimator::{Estimator, StepStatus};
use beamest::filter_bank::FilterConfig;
use beamest::modal::modes_from_denominator;
use beamest::tuning::{
    carry_over, AutoTune, Phase, Settled, TuningConfig, MAX_LAMBDA_TS, MIN_LAMBDA_TS,
};
use beamest::Real;
use serde::Serialize;

/// One (re)build of the estimator.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Build {
    /// Index of the first live sample the new estimator receives.
    pub sample: u64,
    /// Its filter pole λ (rad/s).
    pub lambda_rad_s: f64,
    /// Its signal scale U0 (input units).
    pub u_scale: f64,
    /// Its signal scale Y0 (output units).
    pub y_scale: f64,
    /// Samples it was fed from the record before that (the robust
    /// estimator: every sample from the first; 0 for the paper's laws).
    pub replayed_samples: u64,
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
    /// Law updates applied (over every build; for a robust estimator fed
    /// the record from its first sample, that estimator's own).
    pub updates: u64,
}

/// What the robust estimator reports beyond Θ̂.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct RobustStatus {
    /// `startup` (the paper's law on the Λ filters, recording), `refining`
    /// (output error, re-linearized by replaying the record) or `steady`
    /// (record full, linearization point fixed).
    pub phase: &'static str,
    /// RMS of the output-error residual y − ŷ (units of y): the a-posteriori
    /// estimate of the measurement noise's σ once the model has converged;
    /// `None` during start-up.
    pub noise_rms: Option<f64>,
    /// Model updates (record replays) applied.
    pub model_updates: u32,
    /// Whether its start test found the beam moving at its first sample
    /// (the replays then fit an initial state); `None` before the test.
    pub started_moving: Option<bool>,
}

/// The estimator a [`Tuned`] drives.
enum Current<T: Real, const D: usize, const NP: usize, const NS: usize> {
    /// One of the paper's laws (an `Identifier`).
    Law(Box<dyn Estimator<T, NP> + Send>),
    /// The robust estimator (kept concrete for its extra outputs).
    Robust(Box<HostRobust<T, D, NP, NS>>),
}

impl<T: Real, const D: usize, const NP: usize, const NS: usize> Current<T, D, NP, NS> {
    fn get(&self) -> &dyn Estimator<T, NP> {
        match self {
            Self::Law(e) => e.as_ref(),
            Self::Robust(e) => e.as_ref(),
        }
    }

    fn get_mut(&mut self) -> &mut dyn Estimator<T, NP> {
        match self {
            Self::Law(e) => e.as_mut(),
            Self::Robust(e) => e.as_mut(),
        }
    }
}

/// An estimator of one law and precision under the tuning rule.
pub struct Tuned<T: Real, const D: usize, const NP: usize, const NS: usize> {
    kind: EstimatorKind,
    gains: Gains,
    tune: AutoTune,
    est: Option<Current<T, D, NP, NS>>,
    builds: Vec<Build>,
    samples: u64,
    updates: u64,
    /// Rejected/skipped of the estimators already replaced.
    retired_rejected: u64,
    retired_skipped: u64,
    /// Robust estimator only: every sample from the first, while they fit
    /// in its record (see the module docs).
    history: Vec<(T, T)>,
    /// `history` holds every sample given so far.
    history_complete: bool,
    /// The current estimator has seen every sample from the first (a robust
    /// estimator built on the replayed record).
    covers_record: bool,
    /// Re-centring stopped because the robust estimator's record is full.
    record_stop: bool,
    /// The end-of-record restart chose another λ.
    restarted: bool,
}

/// λ multipliers of the robust estimator's restarts when its estimate is
/// not usable at the end of its record (see the module docs).
pub const RESTART_FACTORS: [f64; 6] = [0.5, 0.707, 1.414, 2.0, 2.828, 4.0];

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
            history: Vec::new(),
            history_complete: kind == EstimatorKind::Robust,
            covers_record: false,
            record_stop: false,
            restarted: false,
        };
        if let Some(filter) = t.tune.immediate() {
            t.install(&filter, None, false)?;
        }
        Ok(t)
    }

    /// Build an estimator for `filter` and make it current; the next sample
    /// goes to it. The paper's laws start from θ(0) = `theta0` (scaled) and
    /// are held for settling if `settle`; the robust estimator is fed the
    /// record from its first sample if it is complete (else it is held for
    /// settling like the others).
    fn install(
        &mut self,
        filter: &FilterConfig,
        theta0: Option<[f64; NP]>,
        settle: bool,
    ) -> Result<(), RunError> {
        let mut replayed = 0u64;
        let est = match self.kind {
            EstimatorKind::Robust => {
                let mut est = build_robust::<T, D, NP, NS>(self.gains, filter)?;
                if self.history_complete {
                    let mut updates = 0;
                    for &(u, y) in &self.history {
                        if est.step(u, y) == StepStatus::Updated {
                            updates += 1;
                        }
                    }
                    replayed = self.history.len() as u64;
                    self.updates = updates;
                } else if settle {
                    est.hold_for_settling();
                }
                Current::Robust(est)
            }
            kind => {
                let mut est =
                    build_estimator::<T, D, NP, NS>(kind, self.gains, filter, theta0.as_ref())?;
                if settle {
                    est.hold_for_settling();
                }
                Current::Law(est)
            }
        };
        let covers = self.history_complete;
        if let Some(old) = self.est.replace(est) {
            if !covers {
                let h = old.get().health();
                self.retired_rejected += u64::from(h.rejected);
                self.retired_skipped += u64::from(h.skipped);
            }
        }
        self.covers_record = covers;
        self.builds.push(Build {
            sample: self.samples,
            lambda_rad_s: filter.lambda_rad_s,
            u_scale: filter.scales.u_scale,
            y_scale: filter.scales.y_scale,
            replayed_samples: replayed,
        });
        Ok(())
    }

    /// Keep a sample for the robust estimator's rebuilds while its record
    /// can hold every sample from the first.
    #[inline]
    fn remember(&mut self, u: T, y: T) {
        if !self.history_complete {
            return;
        }
        if self.history.len() < HOST_RECORD {
            self.history.push((u, y));
        } else {
            self.history_complete = false;
            self.history = Vec::new();
        }
    }

    /// Feed one sample (physical units). `None` during the start-up window
    /// (no estimator yet). Never panics; a failed rebuild keeps the
    /// current estimator and stops the rule.
    #[inline]
    pub fn step(&mut self, u: T, y: T) -> Option<StepStatus> {
        self.samples += 1;
        self.remember(u, y);
        let Some(est) = self.est.as_mut() else {
            if let Some(filter) = self.tune.startup_sample(u, y) {
                // A failure here (invalid gains for this λ) leaves no
                // estimator: the run reports no estimate. The robust
                // estimator replays the window (this sample included).
                let _ = self.install(&filter, None, true);
            }
            return None;
        };
        let status = est.get_mut().step(u, y);
        if status == StepStatus::Updated {
            self.updates += 1;
        }
        if self.history_complete && self.history.len() == HOST_RECORD {
            // The last sample the history can replay: the last chance to
            // restart from sample 0. (Re-centring stops after it.)
            self.restart_if_unusable();
            return Some(status);
        }
        if self.record_stop {
            return Some(status);
        }
        if self.kind == EstimatorKind::Robust && !self.history_complete {
            // A rebuild could no longer replay the record from its start.
            self.record_stop = self.tune.phase() == Phase::Reviewing;
            if self.record_stop {
                return Some(status);
            }
        }
        if self.tune.sample() {
            let tf = est.get().transfer_function();
            if let Some(filter) = self.tune.review(&tf) {
                let theta0 = carry_over::<T, NP>(&tf, &filter);
                let _ = self.install(&filter, theta0, true);
            }
        }
        Some(status)
    }

    /// The robust estimator's output-error residual RMS if its estimate is
    /// usable: refined (past start-up) and a set of stable oscillatory
    /// modes.
    fn usable(r: &HostRobust<T, D, NP, NS>) -> Option<f64> {
        if r.phase() == RobustPhase::Startup {
            return None;
        }
        let tf = r.transfer_function();
        let modes = modes_from_denominator(&tf.a[..D]).ok()?;
        if !modes.is_stable() || modes.any_real_poles() {
            return None;
        }
        r.noise_rms().map(|v| v.to_f64()).filter(|v| v.is_finite())
    }

    /// See the module docs: restart an unusable robust estimator from
    /// sample 0 at other λ and keep the most likely usable one.
    fn restart_if_unusable(&mut self) {
        let Some(Current::Robust(r)) = &self.est else {
            return;
        };
        if Self::usable(r).is_some() {
            return;
        }
        // The rule's current configuration is the current build's.
        let Some(base) = self.tune.filter() else {
            return;
        };
        let ts = base.ts_s;
        let mut best: Option<(f64, FilterConfig, Box<HostRobust<T, D, NP, NS>>, u64)> = None;
        for f in RESTART_FACTORS {
            let filter = FilterConfig {
                lambda_rad_s: (base.lambda_rad_s * f).clamp(MIN_LAMBDA_TS / ts, MAX_LAMBDA_TS / ts),
                ..base
            };
            let Ok(mut est) = build_robust::<T, D, NP, NS>(self.gains, &filter) else {
                continue;
            };
            let mut updates = 0;
            for &(u, y) in &self.history {
                if est.step(u, y) == StepStatus::Updated {
                    updates += 1;
                }
            }
            if let Some(score) = Self::usable(&est) {
                if best.as_ref().is_none_or(|b| score < b.0) {
                    best = Some((score, filter, est, updates));
                }
            }
        }
        if let Some((_, filter, est, updates)) = best {
            self.est = Some(Current::Robust(est));
            self.updates = updates;
            self.restarted = true;
            self.builds.push(Build {
                sample: self.samples,
                lambda_rad_s: filter.lambda_rad_s,
                u_scale: filter.scales.u_scale,
                y_scale: filter.scales.y_scale,
                replayed_samples: self.history.len() as u64,
            });
        }
    }

    /// Hold the current estimator for `samples` ([`Estimator::hold`]: it
    /// keeps its estimate, its filters run on); nothing during the
    /// start-up window.
    pub fn hold(&mut self, samples: u32) {
        if let Some(est) = self.est.as_mut() {
            est.get_mut().hold(samples);
        }
    }

    /// The current estimator (`None` during the start-up window).
    pub fn estimator(&self) -> Option<&dyn Estimator<T, NP>> {
        self.est.as_ref().map(Current::get)
    }

    /// The current estimator once its law (or an earlier build's, carried
    /// over) has updated at least once: before that Θ̂ is only θ(0) = 0,
    /// which is no estimate.
    pub fn estimate(&self) -> Option<&dyn Estimator<T, NP>> {
        if self.updates > 0 {
            self.estimator()
        } else {
            None
        }
    }

    /// The robust estimator's extra outputs (`None` for the paper's laws
    /// and before it is built).
    pub fn robust_status(&self) -> Option<RobustStatus> {
        let Some(Current::Robust(r)) = &self.est else {
            return None;
        };
        Some(RobustStatus {
            phase: match r.phase() {
                RobustPhase::Startup => "startup",
                RobustPhase::Refining => "refining",
                RobustPhase::Steady => "steady",
            },
            noise_rms: r.noise_rms().map(|v| v.to_f64()),
            model_updates: r.updates(),
            started_moving: r.initial_state_significance().map(|(_, moving)| moving),
        })
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
                let h = e.get().health();
                (u64::from(h.rejected), u64::from(h.skipped))
            }
            None => (0, 0),
        };
        // An estimator fed the record from its first sample has counted
        // the start-up window itself.
        let window = if self.covers_record {
            0
        } else {
            u64::from(self.tune.stats().rejected())
        };
        Totals {
            samples: self.samples,
            rejected: self.retired_rejected + rejected + window,
            skipped: self.retired_skipped + skipped,
            updates: self.updates,
        }
    }

    /// A short description of where the rule ended (see [`phase_label`];
    /// for a robust estimator also `"restarted"` when its end-of-record
    /// restart chose another λ, and `"record_full"` when re-centring
    /// stopped because its record was full).
    pub fn phase_label(&self) -> &'static str {
        if self.restarted {
            "restarted"
        } else if self.record_stop {
            "record_full"
        } else {
            phase_label(self.tune.phase())
        }
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
