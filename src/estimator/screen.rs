//! Input screening shared by every estimator: bad samples never reach the
//! filters, and the law is frozen until the filters have forgotten the
//! substitute (see the `estimator` module documentation, "Bad input").

use super::{quarantine_samples_for, INPUT_LIMIT};
use crate::filter_bank::FilterConfig;
use crate::scalar::Real;

/// What screening decided for one sample.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum Screened<T> {
    /// Good sample: feed it and update the law.
    Good(T, T),
    /// Good sample, but a recent one was bad: feed it, keep the law frozen.
    Quarantined(T, T),
    /// Bad sample: feed this substitute (the last good values) to keep the
    /// filter states continuous; do not update the law.
    Rejected(T, T),
}

/// Screening state: limits, last good values, quarantine countdown.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct InputScreen<T> {
    u_limit: T,
    y_limit: T,
    last_u: T,
    last_y: T,
    quarantine: u32,
    quarantine_len: u32,
    /// Samples rejected (saturating).
    pub rejected: u32,
}

impl<T: Real> InputScreen<T> {
    /// Limits from the signal scales; quarantine from λ.
    pub fn new(filter: &FilterConfig) -> Self {
        Self {
            u_limit: T::from_f64(INPUT_LIMIT * filter.scales.u_scale),
            y_limit: T::from_f64(INPUT_LIMIT * filter.scales.y_scale),
            last_u: T::ZERO,
            last_y: T::ZERO,
            quarantine: 0,
            quarantine_len: quarantine_samples_for(filter),
            rejected: 0,
        }
    }

    /// Screen one sample.
    #[inline]
    pub fn screen(&mut self, u: T, y: T) -> Screened<T> {
        let good =
            u.is_finite() && y.is_finite() && u.abs() <= self.u_limit && y.abs() <= self.y_limit;
        if !good {
            self.rejected = self.rejected.saturating_add(1);
            // A rejected sample never shortens a longer hold.
            self.quarantine = self.quarantine.max(self.quarantine_len);
            return Screened::Rejected(self.last_u, self.last_y);
        }
        self.last_u = u;
        self.last_y = y;
        if self.quarantine > 0 {
            self.quarantine -= 1;
            Screened::Quarantined(u, y)
        } else {
            Screened::Good(u, y)
        }
    }

    /// Freeze the law for the quarantine length from now on, as after a bad
    /// sample (e.g. at the first sample, when the filters start at rest but
    /// the plant may not).
    pub(crate) fn start_quarantine(&mut self) {
        self.hold(self.quarantine_len);
    }

    /// Freeze the law for `samples` samples from now on without counting a
    /// rejection ([`super::Estimator::hold`]); extends a running hold or
    /// quarantine, never shortens it.
    pub fn hold(&mut self, samples: u32) {
        self.quarantine = self.quarantine.max(samples);
    }

    /// Whether `u` alone would pass the screen.
    pub(crate) fn accepts_u(&self, u: T) -> bool {
        u.is_finite() && u.abs() <= self.u_limit
    }

    /// True while a recent bad sample keeps the law frozen.
    pub(crate) fn in_quarantine(&self) -> bool {
        self.quarantine > 0
    }

    /// Samples the law stays frozen after a rejected sample.
    pub(crate) fn quarantine_len(&self) -> u32 {
        self.quarantine_len
    }

    /// Forget the history (last good values, quarantine, counter).
    pub fn reset(&mut self) {
        self.last_u = T::ZERO;
        self.last_y = T::ZERO;
        self.quarantine = 0;
        self.rejected = 0;
    }
}
