//! The sensor guard's level tests: offset steps of y (removed) and drift
//! (flagged); see the parent module's docs.

use super::monitor::MONITOR_STEP_LATENCY;
use super::{LevelEvent, MonitorEvent, ResidualMonitor, SensorGuard};
use crate::scalar::Real;

impl<T: Real> SensorGuard<T> {
    /// Offset-step test on an accepted y (see the module docs and
    /// [`super::step`]). A y that repeats the previous one exactly is not
    /// tested (a sensor that freezes bends the signal like a step; it is
    /// the stuck test's to judge). A step is found up to
    /// [`super::STEP_LATENCY`] samples after it and removed from its
    /// first sample on, in the delay line.
    #[inline]
    pub(super) fn offset_step(&mut self, y: T, repeat: bool, index: u64) -> Option<LevelEvent> {
        let yc = y - self.offset;
        let step = self.step.push(yc, index, !repeat)?;
        self.offset += step.size;
        self.delay.shift_from(step.index, step.size);
        self.counts.offset = self.counts.offset.saturating_add(1);
        // What is left of the step (its estimate's error, ~σ·0.82 for
        // white noise σ) becomes the high-pass's transient: a slow error
        // the estimator would fit. Hold it over the transient as after a
        // gap (the samples from the step on are still in the delay line).
        self.hold_pending = self.hold_pending.max(self.gap_hold);
        Some(LevelEvent::Offset)
    }

    /// The residual monitor's tests on an accepted y (after the raw step
    /// test, whose event `level` is): a step it finds is removed as the raw
    /// test's are, a drift's onset flagged.
    #[inline]
    pub(super) fn monitored(
        &mut self,
        m: &mut ResidualMonitor<T>,
        u: T,
        y: T,
        repeat: bool,
        index: u64,
        level: Option<LevelEvent>,
    ) -> Option<LevelEvent> {
        if self.offset_steps && self.delay.delay() < MONITOR_STEP_LATENCY + 1 {
            // A step on ε is found up to MONITOR_STEP_LATENCY samples
            // after it (the raw test's latency and ε's lag): the line must
            // still hold it (only without the stuck test is it shorter).
            self.delay.lengthen(MONITOR_STEP_LATENCY + 1);
        }
        let test = !repeat && level.is_none();
        let ev = m.push(u, y - self.offset, index, test);
        if level.is_some() {
            // The raw test corrected a step: ε's windows hold it.
            m.corrected();
            return level;
        }
        match ev? {
            MonitorEvent::Step { index: from, size } if self.offset_steps => {
                self.offset += size;
                self.delay.shift_from(from, size);
                self.step.correct(index, from, size);
                m.corrected();
                self.counts.offset = self.counts.offset.saturating_add(1);
                self.hold_pending = self.hold_pending.max(self.gap_hold);
                Some(LevelEvent::Offset)
            }
            MonitorEvent::Step { .. } => None,
            MonitorEvent::Drift { .. } => {
                self.counts.drift = self.counts.drift.saturating_add(1);
                Some(LevelEvent::Drift)
            }
        }
    }

    /// Drift test on a good, offset-free (and high-passed) output.
    #[inline]
    pub(super) fn drift(&mut self, y_out: T) {
        // The level the high-pass (or nothing) left in y: track the raw
        // offset-free level through the filter's complement.
        let level_in = match self.hp.as_ref() {
            Some(hp) => hp.y_level(),
            None => y_out,
        };
        let a = self.alpha_level;
        self.level1 += a * (level_in - self.level1);
        self.level2 += a * (self.level1 - self.level2);
        let ac = match self.hp.as_ref() {
            Some(_) => y_out,
            None => y_out - self.level2,
        };
        self.level_ms += a * (ac * ac - self.level_ms);
        if self.level_learn > 0 {
            self.level_learn -= 1;
            if self.level_learn == 0 {
                self.level_ref = Some(self.level2);
            }
            return;
        }
        if let Some(r) = self.level_ref {
            let dev = self.level2 - r;
            if dev * dev > self.drift_fraction2 * self.level_ms {
                self.level_ref = Some(self.level2);
                self.counts.drift = self.counts.drift.saturating_add(1);
                self.last.level = Some(LevelEvent::Drift);
            }
        }
    }
}
