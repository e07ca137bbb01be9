//! DC removal applied identically to u and y: a fourth-order high-pass
//! (four cascaded first-order stages x − m, m ← m + α(x − m)), so a DC
//! offset and a drift of the strain gauge that is a polynomial of degree
//! ≤ 3 over the record are removed exactly once its transient has passed
//! (a fourfold zero at z = 1), and a slow drift of rate ω ≪ ω_c is
//! attenuated as (ω/ω_c)⁴.
//!
//! # Order (measured)
//! On `lab_offset_drift_square` (host-tests/data/records: an offset of
//! 0.5·RMS(y) plus a thermal drift 0.5·RMS(y)·(1 − e^{−t/3 s}), 60 dB; the
//! robust estimator, 2 modes, the corner at 10 rad/s) the largest error of
//! ζ ÷ its 3σ_CRB tolerance is 1.20 with two stages, 0.67 with three, 0.42
//! with four: the drift the filter lets through, not the filter, biases
//! the estimate (two stages at 15, 20, 30 rad/s: 0.65, 0.43, 0.27, but then
//! mode 1 at 50 rad/s loses its share of the excitation). On the records
//! without a drift two and four stages agree within 0.01 of the
//! tolerance.
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

/// First-order stages per channel (module docs, *Order*).
const STAGES: usize = 4;

/// One channel's low-pass states, one per stage.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
struct Channel<T> {
    m: [Compensated<T>; STAGES],
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
        self.m.iter_mut().fold(x, |v, m| Self::stage(m, alpha, v))
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
            self.y.m[0] = Compensated::new(y);
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
        self.y.m[0].hi + self.y.m[0].lo
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used, clippy::indexing_slicing)]
mod tests {
    use super::*;

    /// A constant, a ramp and a quadratic drift go (a two-stage filter
    /// left the quadratic's 2c/ω_c² behind); the band passes.
    #[test]
    fn removes_offset_and_ramp_and_passes_the_band() {
        let ts = 1e-4;
        let mut hp = HighPass::<f32>::new(3.0, ts).unwrap();
        let w = 245.0f64;
        let mut last = (0.0, 0.0);
        for k in 0..200_000 {
            let t = k as f64 * ts;
            let s = (w * t).sin();
            // Offset 5, a ramp of 0.5/s and a quadratic on y; u the same
            // sine.
            last = hp.push(s as f32, (s + 5.0 + 0.5 * t + 0.05 * t * t) as f32);
            if k > 100_000 {
                // Identical channels up to the offset's and ramp's residue.
                assert!((last.1 - last.0).abs() < 2e-5, "{k}: {last:?}");
            }
        }
        // Four first-order stages at 3 rad/s: gain (w/|w + 3j|)⁴, phase
        // lead 4·atan(3/w).
        let (gain, lead) = ((w / w.hypot(3.0)).powi(4), 4.0 * (3.0 / w).atan());
        assert!((last.0 - (gain * (w * 19.9999 + lead).sin()) as f32).abs() < 0.02);
        assert!(HighPass::<f64>::new(0.0, ts).is_none());
        assert!(HighPass::<f64>::new(1e5, ts).is_none());
    }
}
