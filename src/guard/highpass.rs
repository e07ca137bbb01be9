//! DC removal applied identically to u and y: a second-order high-pass
//! (two cascaded first-order stages x − m, m ← m + α(x − m)), so a DC
//! offset and a linear drift of the strain gauge are removed exactly once
//! its transient has passed (a double zero at z = 1).
//!
//! # Why both channels, and why it does not bias
//! A filter on y alone would add its phase to the identified model. The
//! same linear time-invariant filter F(z) on both sampled sequences
//! commutes with the plant: if y_k = G_d(z)u_k (the exact zero-order-hold
//! relation of the estimator's filter bank), then F(z)y_k = G_d(z)F(z)u_k,
//! and F(z)y_k are the samples of the continuous response to the held
//! F(z)u_k. The estimator therefore identifies the same G from the filtered
//! pair (as for the pipeline's low-pass prefilter,
//! [`crate::pipeline::prefilter`]). Offsets and drifts enter y only; the
//! filter removes them from y and they never reach the estimator.
//!
//! # Design
//! * **Start from rest with the beam.** The filter's memory is ~2/ω_c: a
//!   high-pass started on a signal that is already moving (or offset)
//!   produces a transient of that length. It is therefore part of the
//!   sensor chain that runs from the first sample on ([`super::SensorGuard`]),
//!   not of the estimator, whose rebuilds (the tuning rule's re-centring)
//!   would restart it. Its first sample initializes y's low-pass states to
//!   that sample (a beam at rest with a bridge offset produces no
//!   transient) and u's to zero (the drive starts with the run).
//! * **Precision.** α = 1 − e^{−ω_c·Ts} is ~1e-4: each state's increment is
//!   a small fraction of the state, so in `f32` the states are double words
//!   (as the filter bank's, `crate::scalar::compensated`); the output x − m is then
//!   rounded once.

use crate::scalar::compensated::Compensated;
use crate::scalar::Real;

/// One channel's two low-pass states.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
struct Channel<T> {
    m1: Compensated<T>,
    m2: Compensated<T>,
}

impl<T: Real> Channel<T> {
    #[inline(always)]
    fn stage(m: &mut Compensated<T>, alpha: T, x: T) -> T {
        let (hi, lo) = (m.hi, m.lo);
        let dev = (x - hi) - lo;
        m.add(alpha * dev);
        (x - m.hi) - m.lo
    }

    #[inline(always)]
    fn push(&mut self, alpha: T, x: T) -> T {
        let a = Self::stage(&mut self.m1, alpha, x);
        Self::stage(&mut self.m2, alpha, a)
    }
}

/// The filter on both channels (see the module docs).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct HighPass<T> {
    alpha: T,
    u: Channel<T>,
    y: Channel<T>,
    started: bool,
}

impl<T: Real> HighPass<T> {
    /// Corner ω_c (rad/s) at sample period `ts_s`; `None` if not positive,
    /// finite and below the Nyquist rate.
    pub fn new(corner_rad_s: f64, ts_s: f64) -> Option<Self> {
        let x = corner_rad_s * ts_s;
        if !(x > 0.0 && x < core::f64::consts::PI && ts_s.is_finite()) {
            return None;
        }
        Some(Self {
            alpha: T::from_f64(-libm::expm1(-x)),
            u: Channel::default(),
            y: Channel::default(),
            started: false,
        })
    }

    /// Filter one pair.
    #[inline]
    pub fn push(&mut self, u: T, y: T) -> (T, T) {
        if !self.started {
            self.started = true;
            self.y.m1 = Compensated::new(y);
        }
        (self.u.push(self.alpha, u), self.y.push(self.alpha, y))
    }

    /// Filter u alone (a sample whose y is faulty: u stays continuous, y's
    /// states hold).
    #[inline]
    pub(crate) fn push_u(&mut self, u: T) -> T {
        self.u.push(self.alpha, u)
    }

    /// The level removed from y by the first stage (its low-pass state,
    /// units of y): the offset the filter is taking away.
    pub(crate) fn y_level(&self) -> T {
        self.y.m1.hi + self.y.m1.lo
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used, clippy::indexing_slicing)]
mod tests {
    use super::*;

    #[test]
    fn removes_offset_and_ramp_and_passes_the_band() {
        let ts = 1e-4;
        let mut hp = HighPass::<f32>::new(3.0, ts).unwrap();
        let w = 245.0f64;
        let mut last = (0.0, 0.0);
        for k in 0..200_000 {
            let t = k as f64 * ts;
            let s = (w * t).sin();
            // Offset 5 and a ramp of 0.5/s on y; u the same sine.
            last = hp.push(s as f32, (s + 5.0 + 0.5 * t) as f32);
            if k > 100_000 {
                // Identical channels up to the offset's and ramp's residue.
                assert!((last.1 - last.0).abs() < 2e-5, "{k}: {last:?}");
            }
        }
        assert!((last.0 - 0.999_85 * (w * 19.9999).sin() as f32).abs() < 0.02);
        assert!(HighPass::<f64>::new(0.0, ts).is_none());
        assert!(HighPass::<f64>::new(1e5, ts).is_none());
    }
}
