//! Optional low-pass prefilter, applied identically to u and y.
//!
//! The paper's experiments low-pass filtered the measurements "to alleviate
//! the effect of the high-frequency electrical noises" (Wang,
//! Costa-Castelló, Na et al., Section IV.B). A filter on y alone would add
//! its phase to the identified model (G would become F·G). Applied to both
//! sampled sequences with the same coefficients, it commutes with the plant:
//! if y_k = G_d(z)·u_k (the exact zero-order-hold relation the estimator's
//! filter bank assumes) then F(z)y_k = G_d(z)·F(z)u_k, so the filtered pair
//! obeys the same relation, the filtered u is still held by the estimator's
//! model, and the estimate is unchanged (host test `pipeline.rs`:
//! `prefilter_on_both_channels_leaves_the_estimate_unchanged`).
//!
//! # Design
//! Butterworth low-pass of order 1–4 (maximally flat, DC gain 1): cascaded
//! second-order sections (plus one first-order section for odd orders) from
//! the analog prototype by the bilinear transform with the cutoff
//! pre-warped, K = tan(π·f_c/f_s). Transposed direct form II, coefficients
//! computed in `f64` and rounded once. The rounding noise of this form
//! grows as the poles approach z = 1: keep f_c ≳ f_s/50 in `f32` (200 Hz
//! at 10 kHz), well above the beam's modes anyway.

use crate::scalar::Real;

/// Highest order.
pub const MAX_ORDER: u8 = 4;
const MAX_SECTIONS: usize = 2;

/// Invalid prefilter settings.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PrefilterError {
    /// Order outside 1..=`MAX_ORDER`.
    Order,
    /// Cutoff not in (0, 0.45·f_s), or f_s not positive and finite.
    Cutoff,
}

impl core::fmt::Display for PrefilterError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(match self {
            Self::Order => "prefilter order outside 1..=4",
            Self::Cutoff => "prefilter cutoff not in (0, 0.45 fs)",
        })
    }
}

impl core::error::Error for PrefilterError {}

/// Prefilter settings.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PrefilterConfig {
    /// Butterworth order, 1..=4.
    pub order: u8,
    /// −3 dB frequency (Hz).
    pub cutoff_hz: f64,
    /// Sample rate (Hz).
    pub sample_rate_hz: f64,
}

/// One section's coefficients: y = b0·x + s1; s1 = b1·x − a1·y + s2;
/// s2 = b2·x − a2·y.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Section<T> {
    b: [T; 3],
    a: [T; 2],
}

/// The filter's coefficients (shared by both channels).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Prefilter<T> {
    sections: [Section<T>; MAX_SECTIONS],
    count: usize,
    config: PrefilterConfig,
}

/// One channel's state.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct PrefilterState<T> {
    s: [[T; 2]; MAX_SECTIONS],
}

impl<T: Real> Prefilter<T> {
    /// Design the filter.
    pub fn new(config: &PrefilterConfig) -> Result<Self, PrefilterError> {
        let n = config.order;
        if n == 0 || n > MAX_ORDER {
            return Err(PrefilterError::Order);
        }
        let fs = config.sample_rate_hz;
        let fc = config.cutoff_hz;
        if !(fs > 0.0 && fs.is_finite() && fc > 0.0 && fc < 0.45 * fs) {
            return Err(PrefilterError::Cutoff);
        }
        let k = libm::tan(core::f64::consts::PI * fc / fs);
        let zero = Section {
            b: [T::ZERO; 3],
            a: [T::ZERO; 2],
        };
        let mut sections = [zero; MAX_SECTIONS];
        let pairs = usize::from(n / 2);
        for (i, sec) in sections.iter_mut().enumerate().take(pairs) {
            // Prototype 1/(s² + 2ζs + 1), 2ζ = 2·sin(π(2i+1)/(2N)).
            let two_zeta =
                2.0 * libm::sin(core::f64::consts::PI * (2 * i + 1) as f64 / (2.0 * f64::from(n)));
            let norm = 1.0 / (1.0 + two_zeta * k + k * k);
            let b0 = k * k * norm;
            *sec = Section {
                b: [T::from_f64(b0), T::from_f64(2.0 * b0), T::from_f64(b0)],
                a: [
                    T::from_f64(2.0 * (k * k - 1.0) * norm),
                    T::from_f64((1.0 - two_zeta * k + k * k) * norm),
                ],
            };
        }
        let mut count = pairs;
        if n % 2 == 1 {
            // Prototype 1/(s + 1).
            let norm = 1.0 / (1.0 + k);
            if let Some(sec) = sections.get_mut(pairs) {
                *sec = Section {
                    b: [T::from_f64(k * norm), T::from_f64(k * norm), T::ZERO],
                    a: [T::from_f64((k - 1.0) * norm), T::ZERO],
                };
            }
            count += 1;
        }
        Ok(Self {
            sections,
            count,
            config: *config,
        })
    }

    /// Filter one sample of one channel.
    #[inline]
    pub fn process(&self, state: &mut PrefilterState<T>, x: T) -> T {
        let mut v = x;
        for (c, s) in self
            .sections
            .iter()
            .zip(state.s.iter_mut())
            .take(self.count)
        {
            let y = c.b[0] * v + s[0];
            s[0] = c.b[1] * v - c.a[0] * y + s[1];
            s[1] = c.b[2] * v - c.a[1] * y;
            v = y;
        }
        v
    }

    /// Start a channel at steady state for a constant input `x` (no
    /// start-up transient when the signal sits at a DC level).
    pub fn settle(&self, state: &mut PrefilterState<T>, x: T) {
        let mut v = x;
        for (c, s) in self
            .sections
            .iter()
            .zip(state.s.iter_mut())
            .take(self.count)
        {
            // DC gain 1: y = x; s1 = y − b0·x; s2 = b2·x − a2·y.
            s[1] = c.b[2] * v - c.a[1] * v;
            s[0] = v - c.b[0] * v;
            v = x;
        }
    }

    /// The settings.
    pub fn config(&self) -> &PrefilterConfig {
        &self.config
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used, clippy::indexing_slicing)]
mod tests {
    use super::*;

    fn gain_at(f: &Prefilter<f64>, freq: f64, fs: f64) -> f64 {
        // Steady-state amplitude of a sine (lock-in over whole cycles).
        let mut st = PrefilterState::default();
        let w = 2.0 * core::f64::consts::PI * freq / fs;
        let (mut s, mut c) = (0.0, 0.0);
        for k in 0..40_000 {
            let x = (w * k as f64).sin();
            let y = f.process(&mut st, x);
            if k >= 20_000 {
                s += y * x;
                c += y * (w * k as f64).cos();
            }
        }
        2.0 * (s * s + c * c).sqrt() / 20_000.0
    }

    #[test]
    fn butterworth_magnitude_response() {
        let fs = 1e4;
        for order in 1..=MAX_ORDER {
            let f = Prefilter::<f64>::new(&PrefilterConfig {
                order,
                cutoff_hz: 500.0,
                sample_rate_hz: fs,
            })
            .unwrap();
            // The bilinear transform maps the analog Butterworth exactly:
            // |H(f)| = 1/√(1 + (tan(πf/fs)/tan(πfc/fs))^{2N}); −3 dB at fc.
            let t = |f: f64| (core::f64::consts::PI * f / fs).tan();
            for freq in [10.0, 250.0, 500.0, 2000.0] {
                let analog = 1.0 / (1.0 + (t(freq) / t(500.0)).powi(2 * i32::from(order))).sqrt();
                let g = gain_at(&f, freq, fs);
                assert!(
                    (g / analog - 1.0).abs() < 1e-9,
                    "order {order} at {freq} Hz: {g}"
                );
            }
            assert!((gain_at(&f, 500.0, fs) - core::f64::consts::FRAC_1_SQRT_2).abs() < 1e-9);
            // Settled state passes a constant through unchanged.
            let mut st = PrefilterState::default();
            f.settle(&mut st, 0.7);
            for _ in 0..10 {
                assert!((f.process(&mut st, 0.7) - 0.7).abs() < 1e-14);
            }
        }
    }

    #[test]
    fn rejects_bad_settings() {
        let c = |order, cutoff_hz| PrefilterConfig {
            order,
            cutoff_hz,
            sample_rate_hz: 1e4,
        };
        assert_eq!(
            Prefilter::<f32>::new(&c(0, 100.0)).unwrap_err(),
            PrefilterError::Order
        );
        assert_eq!(
            Prefilter::<f32>::new(&c(5, 100.0)).unwrap_err(),
            PrefilterError::Order
        );
        assert_eq!(
            Prefilter::<f32>::new(&c(2, 4600.0)).unwrap_err(),
            PrefilterError::Cutoff
        );
        assert_eq!(
            Prefilter::<f32>::new(&c(2, f64::NAN)).unwrap_err(),
            PrefilterError::Cutoff
        );
    }
}
