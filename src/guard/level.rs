//! The sensor guard's level tests: offset steps of y (removed) and drift
//! (flagged); see the parent module's docs.

use super::{LevelEvent, SensorGuard};
use crate::scalar::Real;

impl<T: Real> SensorGuard<T> {
    /// Offset-step test on an accepted y (see the module docs). A y that
    /// repeats the previous one exactly is not tested (a sensor that
    /// freezes bends its second difference like a step; it is the stuck
    /// test's to judge).
    #[inline]
    pub(super) fn offset_step(&mut self, y: T, repeat: bool) -> Option<LevelEvent> {
        let yc = y - self.offset;
        let [y1, y2] = self.hist;
        self.hist = [yc, y1];
        if self.hist_len < 2 {
            self.hist_len += 1;
            return None;
        }
        if repeat {
            return None;
        }
        let d2 = yc - (y1 + y1 - y2);
        let e2 = d2 * d2;
        if self.jump_learn > 0 {
            self.jump_learn -= 1;
            self.jump_ms += self.alpha_jump * (e2 - self.jump_ms);
            return None;
        }
        if e2 > self.jump_factor2 * self.jump_ms && self.jump_ms > T::ZERO {
            // Remove the step from here on: this sample's y becomes the
            // extrapolation of the previous two.
            self.offset += d2;
            if let Some(first) = self.hist.first_mut() {
                *first = yc - d2;
            }
            self.counts.offset = self.counts.offset.saturating_add(1);
            return Some(LevelEvent::Offset);
        }
        // The reference takes values up to the threshold (a step does not
        // raise its own yardstick).
        let clipped = e2.min(self.jump_factor2 * self.jump_ms);
        self.jump_ms += self.alpha_jump * (clipped - self.jump_ms);
        None
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
