//! The sensor guard in front of the estimators, and the holds it asks for:
//! the host's one implementation of the policy the firmware's sample task
//! applies (`beamest::pipeline::Pipeline`), used by the session
//! ([`super::session::Session`]) and by the host tests' scenario runs.
//!
//! Per raw sample, in this order:
//! 1. the guard screens it ([`SensorGuard::push_monitored`]); what leaves
//!    its delay line (a faulty sample as NaN, which an estimator rejects)
//!    passes the line canceller if lines are set ([`Feed::with_lines`],
//!    [`beamest::guard::lines`]) and then the whitening filter if one is
//!    set ([`Feed::with_whitener`], [`crate::judge::noise`]), and is the
//!    estimators' sample; nothing leaves it while it fills;
//! 2. a hold the guard asks for after a gap or an offset step with the
//!    high-pass on ([`SensorGuard::take_hold`]) is given to every
//!    estimator first, whether or not a sample leaves the line;
//! 3. each estimator steps on the sample that left;
//! 4. an estimator whose detected plant changes rose at that step is held
//!    for [`SensorGuard::change_hold`] (12/ω_c with the high-pass on,
//!    0 with it off), while the high-pass's memory of the old plant
//!    settles.
//!
//! A residual monitor following an estimator's model (`--residual-monitor`)
//! takes none while a change hold runs and for [`CHANGE_QUIET_S`] after it
//! ([`Feed::model_allowed`]): the held law keeps the old plant's model, and
//! the monitor would read the new plant's response as offset steps
//! (measured: host test `a_plant_change_is_not_a_sensor_fault` flagged 3–9
//! offsets and drifts 1.2 s after an ω1 +10% step without this). A gap
//! hold keeps the model: the plant has not changed.

use crate::judge::noise::Whitener;
use beamest::estimator::{Estimator, StepStatus};
use beamest::guard::lines::{
    LineCanceller, LineError, LineSpec, DEFAULT_LINE_TIME_CONSTANT_S, MAX_LINES,
};
use beamest::guard::{
    GuardConfig, GuardError, ResidualMonitor, Screening, SensorGuard, CHANGE_QUIET_S,
};
use beamest::Real;

/// What a feed drives: an estimator, or something that owns one (the
/// tuning rule's [`super::tuned::Tuned`]).
pub trait Target<T: Real> {
    /// Hold the law for `samples` ([`Estimator::hold`]).
    fn hold(&mut self, samples: u32);
    /// Step on one sample; `None` if nothing was stepped.
    fn step(&mut self, u: T, y: T) -> Option<StepStatus>;
    /// Plant changes its supervisor has detected (0 without one).
    fn changes(&self) -> u32;
}

/// Any estimator of `NP` parameters, driven directly (fixed settings, no
/// tuning rule).
pub struct Direct<'a, E: ?Sized, const NP: usize>(pub &'a mut E);

impl<T: Real, E: Estimator<T, NP> + ?Sized, const NP: usize> Target<T> for Direct<'_, E, NP> {
    fn hold(&mut self, samples: u32) {
        self.0.hold(samples);
    }
    fn step(&mut self, u: T, y: T) -> Option<StepStatus> {
        Some(self.0.step(u, y))
    }
    fn changes(&self) -> u32 {
        self.0.supervision().map_or(0, |s| s.changes)
    }
}

/// One raw sample after the guard: what every estimator gets.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Screened {
    /// The pair that left the delay line (`None` while it fills).
    pub pair: Option<(f64, f64)>,
    /// Hold every estimator for this many samples first (0: none).
    pub gap_hold: u32,
    /// Hold an estimator whose detected changes rose for this many
    /// samples (0: the high-pass is off).
    pub change_hold: u32,
    /// What the guard saw in the raw sample.
    pub screening: Screening,
}

/// The guard, the index of the next raw sample and when a residual
/// monitor may take a model again.
#[derive(Debug, Clone)]
pub struct Feed {
    guard: SensorGuard<f64>,
    /// The line canceller after the guard (`None`: no lines).
    lines: Option<LineCanceller<f64, MAX_LINES>>,
    /// The whitening filter after it (`None`: none).
    whitener: Option<Whitener>,
    ts_s: f64,
    index: u64,
    /// [`CHANGE_QUIET_S`] in samples.
    quiet: u64,
    /// No model for a monitor before this raw sample index.
    rest_until: u64,
}

impl Feed {
    /// A feed through a guard with `cfg`.
    ///
    /// # Errors
    /// Invalid guard settings.
    pub fn new(cfg: &GuardConfig) -> Result<Self, GuardError> {
        Ok(Self {
            guard: SensorGuard::new(cfg)?,
            lines: None,
            whitener: None,
            ts_s: cfg.ts_s,
            index: 0,
            quiet: (CHANGE_QUIET_S / cfg.ts_s).round() as u64,
            rest_until: 0,
        })
    }

    /// The same feed with `lines` cancelled after the guard, the weights'
    /// time constant [`DEFAULT_LINE_TIME_CONSTANT_S`] (no lines: none).
    ///
    /// # Errors
    /// [`LineError`] for a line the canceller cannot hold.
    pub fn with_lines(mut self, lines: &[LineSpec]) -> Result<Self, LineError> {
        self.lines = if lines.is_empty() {
            None
        } else {
            Some(LineCanceller::new(
                lines,
                self.ts_s,
                DEFAULT_LINE_TIME_CONSTANT_S,
            )?)
        };
        Ok(self)
    }

    /// The same feed with the whitening filter `coeffs` ([1, c_1, …]) on u
    /// and y after the line canceller; `None`: none.
    pub fn with_whitener(mut self, coeffs: Option<&[f64]>) -> Self {
        self.whitener = coeffs.map(Whitener::new);
        self
    }

    /// Give a screened sample to `target` (steps 2–4 of the module docs);
    /// `held` is its detected-change count when last looked at (start at
    /// 0; a rebuilt estimator counts from 0 again). Returns its step
    /// status.
    pub fn deliver<T: Real, E: Target<T> + ?Sized>(
        &mut self,
        screened: &Screened,
        target: &mut E,
        held: &mut u32,
    ) -> Option<StepStatus> {
        if screened.gap_hold > 0 {
            // The plant is the one the model was fitted to: a monitor
            // keeps its model (and catches the step's other edge).
            target.hold(screened.gap_hold);
        }
        let (u, y) = screened.pair?;
        let status = target.step(T::from_f64(u), T::from_f64(y));
        if screened.change_hold > 0 {
            let changes = target.changes();
            if changes > *held {
                target.hold(screened.change_hold);
                self.rest_for(screened.change_hold);
            }
            *held = changes;
        }
        status
    }

    /// A change hold of `samples` was given: no model for a monitor until
    /// [`CHANGE_QUIET_S`] after it ends.
    fn rest_for(&mut self, samples: u32) {
        let until = self.index + u64::from(samples) + self.quiet;
        self.rest_until = self.rest_until.max(until);
    }

    /// A residual monitor may take the estimator's model now: no change
    /// hold has run within [`CHANGE_QUIET_S`] (see the module docs).
    pub fn model_allowed(&self) -> bool {
        self.index >= self.rest_until
    }

    /// Screen raw sample (u, y), the residual monitor (if any) fed with it.
    #[inline]
    pub fn push(&mut self, u: f64, y: f64, monitor: Option<&mut ResidualMonitor<f64>>) -> Screened {
        let out = self.guard.push_monitored(u, y, true, self.index, monitor);
        self.index += 1;
        let (lines, whitener) = (&mut self.lines, &mut self.whitener);
        Screened {
            pair: out.map(|g| {
                let (u, y) = g.for_estimator();
                let (u, y) = match lines {
                    Some(c) => c.push(u, y),
                    None => (u, y),
                };
                match whitener {
                    Some(w) => w.push(u, y),
                    None => (u, y),
                }
            }),
            gap_hold: self.guard.take_hold(),
            change_hold: self.guard.change_hold(),
            screening: self.guard.last_screening(),
        }
    }

    /// The guard (counters, level corrections, offset removed).
    pub fn guard(&self) -> &SensorGuard<f64> {
        &self.guard
    }

    /// The guard, to change its settings between samples.
    pub fn guard_mut(&mut self) -> &mut SensorGuard<f64> {
        &mut self.guard
    }

    /// Raw samples screened so far (the index of the next one).
    pub fn index(&self) -> u64 {
        self.index
    }
}

impl<T: Real, const D: usize, const NP: usize, const NS: usize> Target<T>
    for super::tuned::Tuned<T, D, NP, NS>
{
    fn hold(&mut self, samples: u32) {
        super::tuned::Tuned::hold(self, samples);
    }
    fn step(&mut self, u: T, y: T) -> Option<StepStatus> {
        super::tuned::Tuned::step(self, u, y)
    }
    fn changes(&self) -> u32 {
        // A rebuilt estimator counts from 0 again.
        self.estimator()
            .and_then(|e| e.supervision())
            .map_or(0, |s| s.changes)
    }
}
