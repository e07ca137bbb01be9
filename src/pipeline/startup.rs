//! Start-up: the estimator's output scale Y0 from the data.
//!
//! The filter bank works on y/Y0 (see `filter_bank`, "Normalized states"),
//! so Y0 must be a typical |y| of the running rig — and on a rig nobody
//! knows the plant, so it cannot come from a model. The firmware therefore
//! starts the pipeline frozen ([`super::Pipeline::freeze`]: excitation and
//! converters running, estimator not stepped), measures the RMS of the y
//! it converts over a window with [`OutputScaleWindow`], builds the
//! estimator with U0 = the commanded excitation amplitude and Y0 = that
//! RMS, swaps it in ([`super::Pipeline::replace_estimator`]) and resumes
//! ([`super::Pipeline::resume`]), which holds the law until the new
//! filters have settled on the moving beam.
//!
//! Only valid samples count (a rejected sample reaches [`super::Tick`] as
//! NaN); the window closes after `samples` of them.

use super::config::Tick;
use crate::scalar::Real;

/// RMS of the valid y over the first `samples` valid ticks.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OutputScaleWindow<T> {
    needed: u32,
    seen: u32,
    sum_sq: T,
}

impl<T: Real> OutputScaleWindow<T> {
    /// A window of `samples` valid samples (at least 1).
    pub fn new(samples: u32) -> Self {
        Self {
            needed: samples.max(1),
            seen: 0,
            sum_sq: T::ZERO,
        }
    }

    /// Take one tick's fed pair; returns the RMS once, at the tick that
    /// completes the window, and `None` before and after.
    #[inline]
    pub fn observe(&mut self, tick: &Tick<T>) -> Option<T> {
        if self.seen >= self.needed {
            return None;
        }
        let (u, y) = tick.fed?;
        if !(u.is_finite() && y.is_finite()) {
            return None;
        }
        self.sum_sq += y * y;
        self.seen += 1;
        if self.seen < self.needed {
            return None;
        }
        Some((self.sum_sq / T::from_i32(self.seen as i32)).sqrt())
    }

    /// Whether the window has closed.
    pub fn is_done(&self) -> bool {
        self.seen >= self.needed
    }

    /// Valid samples taken so far.
    pub fn samples_seen(&self) -> u32 {
        self.seen
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;

    fn tick(fed: Option<(f64, f64)>) -> Tick<f64> {
        Tick {
            sample_index: 0,
            commanded_v: 0.0,
            fed,
            step: None,
        }
    }

    #[test]
    fn rms_of_the_valid_samples_once() {
        let mut w = OutputScaleWindow::new(4);
        assert_eq!(w.observe(&tick(None)), None);
        assert_eq!(w.observe(&tick(Some((0.1, 3.0)))), None);
        assert_eq!(w.observe(&tick(Some((f64::NAN, f64::NAN)))), None);
        assert_eq!(w.observe(&tick(Some((0.1, -1.0)))), None);
        assert_eq!(w.observe(&tick(Some((0.1, 1.0)))), None);
        assert_eq!(w.samples_seen(), 3);
        assert!(!w.is_done());
        let y0 = w.observe(&tick(Some((0.1, -3.0)))).unwrap();
        assert_eq!(y0, 5.0f64.sqrt());
        assert!(w.is_done());
        assert_eq!(w.observe(&tick(Some((0.1, 7.0)))), None);
        let mut one = OutputScaleWindow::<f32>::new(0);
        let t = Tick {
            sample_index: 0,
            commanded_v: 0.0,
            fed: Some((0.0f32, -2.0)),
            step: None,
        };
        assert_eq!(one.observe(&t), Some(2.0));
    }
}
