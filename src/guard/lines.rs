//! Narrowband lines in y that u does not drive (the mains and its
//! harmonics): removed by an adaptive line canceller applied identically
//! to u and y.
//!
//! # The filter
//! For each line ℓ of known frequency f_ℓ, a reference phasor r_k =
//! (cos θ_ℓk, sin θ_ℓk), θ_ℓ = 2π f_ℓ Ts, and per channel a weight pair
//! w_ℓ; the channel's output is its error
//!
//! e_k = x_k − Σ_ℓ w_ℓ,k · r_ℓ,k,  w_ℓ,k+1 = w_ℓ,k + 2μ e_k r_ℓ,k,
//!
//! with μ = Ts/τ (τ the weights' time constant: the mean of r² is ½). With
//! a sinusoidal reference this least-mean-squares canceller is a linear
//! time-invariant filter from x to e (Glover, "Adaptive noise cancelling
//! applied to sinusoidal interferences", IEEE Trans. ASSP 25(6), 1977):
//! for one line N(z) = (z² − 2z cos θ + 1)/(z² − 2(1 − μ)z cos θ + 1 − 2μ),
//! a notch with zeros on the unit circle at ±θ and a −3 dB width of about
//! 1/(πτ) Hz. A line in y at f_ℓ is removed once the weights have settled.
//!
//! # Why both channels, and why it does not bias
//! As for the level correction's high-pass (the guard's, [`super`]): the same
//! LTI filter on the sampled u and y commutes with the plant, N(z)G_d(z)u =
//! G_d(z)N(z)u, so the estimator identifies the same G from the filtered
//! pair; the line enters y only and is removed there. The price is the
//! excitation u had inside the notch (≈ 1/(πτ) Hz wide), which a mode a
//! few hertz away does not miss.
//!
//! # Starting on a line already present
//! Started with zero weights, y's canceller lets the line through for a
//! few τ while its weights rise. A caller that knows the line's phasor in
//! y at the first sample (the host, from a first model's residual) gives it
//! as y's initial weights ([`LineSpec::y_phasor`]): the weights' free
//! response then cancels the line's onset exactly, the filter from u to y
//! is unchanged (u's canceller starts at zero, as the drive does), and y is
//! clean from the first sample. The firmware starts from zero.
//!
//! # Bad samples
//! A non-finite sample passes through unchanged (the guard has flagged it)
//! and leaves its channel's weights as they were; the references advance
//! with the sample clock either way, so a gap does not shift their phase.
//!
//! # Precision
//! The references are rotated by a fixed (cos θ, sin θ) and renormalized
//! every sample (one Newton step towards |r| = 1), so their phase error
//! stays at the rounding of θ (in `f32`, ~1e-7 relative on f_ℓ) and their
//! amplitude at 1 to rounding.

use crate::scalar::Real;

/// Lines a canceller can hold at most on the host (the mains and its
/// harmonics to the 7th, and one more).
pub const MAX_LINES: usize = 8;

/// Weights' time constant τ (s) by default: a notch about 0.32 Hz wide.
pub const DEFAULT_LINE_TIME_CONSTANT_S: f64 = 1.0;

/// One line to cancel.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct LineSpec {
    /// Its frequency (Hz), in (0, 1/(2Ts)).
    pub freq_hz: f64,
    /// The line in y at the first sample as (a, b) of a·cos(2πf t_k) +
    /// b·sin(2πf t_k), t_k = k·Ts from the first sample pushed; (0, 0) when
    /// unknown (see the module docs).
    pub y_phasor: [f64; 2],
}

/// Why a canceller cannot be built.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum LineError {
    /// More lines than the canceller holds.
    TooMany,
    /// A frequency not in (0, 1/(2Ts)), a phasor not finite, or a time
    /// constant or sample period not positive and finite.
    Setting,
}

impl core::fmt::Display for LineError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(match self {
            Self::TooMany => "line canceller: more lines than it holds",
            Self::Setting => {
                "line canceller: each frequency must be in (0, 1/(2Ts)) Hz, phasors finite, \
                 the time constant and Ts positive"
            }
        })
    }
}

impl core::error::Error for LineError {}

/// One line's reference and both channels' weights.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Line<T> {
    /// Reference (cos θk, sin θk).
    c: T,
    s: T,
    /// The rotation by θ.
    cos_step: T,
    sin_step: T,
    /// u's and y's weights (on cos, on sin).
    wu: [T; 2],
    wy: [T; 2],
}

impl<T: Real> Line<T> {
    /// This line's part of a channel's prediction.
    #[inline(always)]
    fn predict(&self, w: &[T; 2]) -> T {
        w[0] * self.c + w[1] * self.s
    }

    /// Rotate the reference to the next sample and renormalize it.
    #[inline(always)]
    fn advance(&mut self) {
        let c = self.c * self.cos_step - self.s * self.sin_step;
        let s = self.s * self.cos_step + self.c * self.sin_step;
        let half = T::from_f64(0.5);
        let g = T::from_f64(1.5) - half * (c * c + s * s);
        self.c = c * g;
        self.s = s * g;
    }
}

/// The canceller on both channels, for up to `L` lines (see the module
/// docs).
#[derive(Debug, Clone, PartialEq)]
pub struct LineCanceller<T, const L: usize> {
    lines: [Line<T>; L],
    len: usize,
    /// 2μ = 2Ts/τ.
    gain: T,
}

impl<T: Real, const L: usize> LineCanceller<T, L> {
    /// A canceller of `lines` at sample period `ts_s`, weights' time
    /// constant `time_constant_s`.
    ///
    /// # Errors
    /// [`LineError`] naming the bad setting.
    pub fn new(lines: &[LineSpec], ts_s: f64, time_constant_s: f64) -> Result<Self, LineError> {
        if lines.len() > L {
            return Err(LineError::TooMany);
        }
        let positive = |v: f64| v.is_finite() && v > 0.0;
        if !(positive(ts_s) && positive(time_constant_s) && time_constant_s > ts_s) {
            return Err(LineError::Setting);
        }
        let zero = Line {
            c: T::ONE,
            s: T::ZERO,
            cos_step: T::ONE,
            sin_step: T::ZERO,
            wu: [T::ZERO; 2],
            wy: [T::ZERO; 2],
        };
        let mut out = [zero; L];
        for (slot, spec) in out.iter_mut().zip(lines) {
            let theta = core::f64::consts::TAU * spec.freq_hz * ts_s;
            let [a, b] = spec.y_phasor;
            if !(theta > 0.0 && theta < core::f64::consts::PI && a.is_finite() && b.is_finite()) {
                return Err(LineError::Setting);
            }
            slot.cos_step = T::from_f64(libm::cos(theta));
            slot.sin_step = T::from_f64(libm::sin(theta));
            slot.wy = [T::from_f64(a), T::from_f64(b)];
        }
        Ok(Self {
            lines: out,
            len: lines.len(),
            gain: T::from_f64(2.0 * ts_s / time_constant_s),
        })
    }

    /// Lines cancelled.
    pub fn len(&self) -> usize {
        self.len
    }

    /// No line.
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// Filter one pair (u held over the coming period, y sampled now).
    #[inline]
    pub fn push(&mut self, u: T, y: T) -> (T, T) {
        let lines = self.lines.get_mut(..self.len).unwrap_or_default();
        let (mut pu, mut py) = (T::ZERO, T::ZERO);
        for l in lines.iter() {
            pu += l.predict(&l.wu);
            py += l.predict(&l.wy);
        }
        let (eu, ey) = (u - pu, y - py);
        let (gu, gy) = (self.gain * eu, self.gain * ey);
        let (ok_u, ok_y) = (eu.is_finite(), ey.is_finite());
        for l in lines.iter_mut() {
            if ok_u {
                l.wu[0] += gu * l.c;
                l.wu[1] += gu * l.s;
            }
            if ok_y {
                l.wy[0] += gy * l.c;
                l.wy[1] += gy * l.s;
            }
            l.advance();
        }
        (if ok_u { eu } else { u }, if ok_y { ey } else { y })
    }

    /// y's current weights per line, (a, b) of a·cos + b·sin at the
    /// current sample's phase: the line as the canceller sees it now (its
    /// RMS is |(a, b)|/√2).
    #[cfg(test)]
    fn y_weights(&self) -> impl Iterator<Item = [T; 2]> + '_ {
        self.lines.iter().take(self.len).map(|l| l.wy)
    }

    /// The amplitude of each line in y as the canceller holds it now,
    /// |(a, b)| of its weights (the peak of the sinusoid it subtracts), in
    /// the order the lines were given: what it has found of each line.
    pub(crate) fn y_amplitudes(&self) -> impl Iterator<Item = T> + '_ {
        self.lines
            .iter()
            .take(self.len)
            .map(|l| (l.wy[0] * l.wy[0] + l.wy[1] * l.wy[1]).sqrt())
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used, clippy::indexing_slicing)]
mod tests {
    use super::*;
    use core::f64::consts::TAU;

    fn spec(freq_hz: f64) -> LineSpec {
        LineSpec {
            freq_hz,
            y_phasor: [0.0, 0.0],
        }
    }

    /// The canceller is the LTI notch of the module docs: its response to
    /// a sine at the line settles to zero, a sine 5 Hz away passes with
    /// the notch's gain |N(e^{jω})|, and u and y, fed the same sequence,
    /// give the same output.
    #[test]
    fn is_the_notch_and_identical_on_both_channels() {
        let ts = 1e-4;
        let tau = 1.0;
        let mut c = LineCanceller::<f64, 2>::new(&[spec(50.0)], ts, tau).unwrap();
        let n = 100_000;
        let (mut max_at_line, mut max_away) = (0.0f64, 0.0f64);
        for k in 0..n {
            let t = k as f64 * ts;
            let x_line = (TAU * 50.0 * t + 0.3).sin();
            let x_away = (TAU * 55.0 * t).sin();
            let (eu, ey) = c.push(x_away, x_line + x_away);
            if k > n - 10_000 {
                max_at_line = max_at_line.max((ey - eu).abs());
                max_away = max_away.max(eu.abs());
            }
        }
        // y − u is the line through the notch: gone after 9 τ.
        assert!(max_at_line < 1e-3, "{max_at_line}");
        // The notch's gain 5 Hz from a 0.32 Hz-wide notch.
        let mu = ts / tau;
        let theta = TAU * 50.0 * ts;
        let w = TAU * 55.0 * ts;
        let z = (w.cos(), w.sin());
        let mul = |a: (f64, f64), b: (f64, f64)| (a.0 * b.0 - a.1 * b.1, a.0 * b.1 + a.1 * b.0);
        let z2 = mul(z, z);
        let num = (
            z2.0 - 2.0 * z.0 * theta.cos() + 1.0,
            z2.1 - 2.0 * z.1 * theta.cos(),
        );
        let den = (
            z2.0 - 2.0 * (1.0 - mu) * z.0 * theta.cos() + 1.0 - 2.0 * mu,
            z2.1 - 2.0 * (1.0 - mu) * z.1 * theta.cos(),
        );
        let gain = num.0.hypot(num.1) / den.0.hypot(den.1);
        assert!((max_away - gain).abs() < 2e-3, "{max_away} vs {gain}");
        assert!(gain > 0.99, "{gain}");
    }

    /// With y's phasor known at the first sample the line is gone from the
    /// start, and the response to u is that of u's canceller (started at
    /// zero): y − G·u stays at rounding.
    #[test]
    fn a_known_phasor_cancels_the_line_from_the_first_sample() {
        let ts = 1e-4;
        let (a, b) = (0.03, -0.02);
        let specs = [
            LineSpec {
                freq_hz: 49.7,
                y_phasor: [a, b],
            },
            LineSpec {
                freq_hz: 149.1,
                y_phasor: [0.0, 0.01],
            },
        ];
        for tau in [0.2, 1.0] {
            let mut c = LineCanceller::<f64, 8>::new(&specs, ts, tau).unwrap();
            let mut worst = 0.0f64;
            for k in 0..30_000 {
                let t = k as f64 * ts;
                let u = (TAU * 13.0 * t).sin() + 0.5 * (TAU * 48.0 * t).cos();
                let line = a * (TAU * 49.7 * t).cos()
                    + b * (TAU * 49.7 * t).sin()
                    + 0.01 * (TAU * 149.1 * t).sin();
                // G = 2 (a static plant: commutes with anything).
                let (eu, ey) = c.push(u, 2.0 * u + line);
                worst = worst.max((ey - 2.0 * eu).abs());
            }
            assert!(worst < 1e-12, "τ {tau}: {worst}");
        }
    }

    /// In f32 over 60 s at 10 kHz the references keep their phase: the line
    /// stays removed to the level of the f64 canceller.
    #[test]
    fn f32_references_keep_their_phase() {
        let ts = 1e-4;
        let mut c = LineCanceller::<f32, 1>::new(&[spec(60.6)], ts, 0.5).unwrap();
        let mut worst = 0.0f32;
        for k in 0..600_000u32 {
            let t = f64::from(k) * ts;
            let y = 0.05 * (TAU * 60.6 * t).sin();
            let (_, ey) = c.push(0.0, y as f32);
            if k > 590_000 {
                worst = worst.max(ey.abs());
            }
        }
        assert!(worst < 5e-6, "{worst}");
    }

    /// Started from zero weights on a line already present (the firmware),
    /// the line left in y's output decays as e^(−t/τ): the settling time
    /// docs/FIRMWARE.md states (to 1e-3 of the line in 6.9τ), and the
    /// weights then hold the line's amplitude.
    #[test]
    fn from_zero_weights_the_line_decays_with_the_time_constant() {
        let ts = 1e-4;
        let tau = 0.2;
        let amp = 0.03;
        let mut c = LineCanceller::<f32, 1>::new(&[spec(50.0)], ts, tau).unwrap();
        let peak_at = |from: f64, to: f64, c: &mut LineCanceller<f32, 1>, k0: &mut u32| {
            let mut peak = 0.0f64;
            while f64::from(*k0) * ts < to {
                let t = f64::from(*k0) * ts;
                let (_, e) = c.push(0.0, (amp * (TAU * 50.0 * t + 0.4).sin()) as f32);
                if t >= from {
                    peak = peak.max(f64::from(e).abs());
                }
                *k0 += 1;
            }
            peak
        };
        let mut k = 0u32;
        for n in [1.0, 3.0, 6.9] {
            let peak = peak_at(n * tau - 0.02, n * tau, &mut c, &mut k);
            let want = amp * (-n).exp();
            assert!((peak / want - 1.0).abs() < 0.1, "{n} τ: {peak} vs {want}");
        }
        let found: f32 = c.y_amplitudes().next().unwrap();
        assert!((f64::from(found) / amp - 1.0).abs() < 2e-3, "{found}");
    }

    #[test]
    fn bad_samples_pass_and_settings_are_checked() {
        let ts = 1e-3;
        let mut c = LineCanceller::<f64, 1>::new(&[spec(50.0)], ts, 1.0).unwrap();
        for k in 0..2_000 {
            let t = k as f64 * ts;
            c.push(0.0, (TAU * 50.0 * t).cos());
        }
        let before: Vec<[f64; 2]> = c.y_weights().collect();
        let (eu, ey) = c.push(f64::NAN, f64::INFINITY);
        assert!(eu.is_nan() && ey == f64::INFINITY);
        let after: Vec<[f64; 2]> = c.y_weights().collect();
        assert_eq!(before, after);
        assert_eq!(
            LineCanceller::<f64, 1>::new(&[spec(50.0), spec(60.0)], ts, 1.0),
            Err(LineError::TooMany)
        );
        for bad in [0.0, -1.0, 500.0, f64::NAN] {
            assert_eq!(
                LineCanceller::<f64, 1>::new(&[spec(bad)], ts, 1.0),
                Err(LineError::Setting),
                "{bad}"
            );
        }
        assert_eq!(
            LineCanceller::<f64, 1>::new(&[spec(50.0)], ts, 0.0),
            Err(LineError::Setting)
        );
        assert!(LineCanceller::<f64, 1>::new(&[], ts, 1.0)
            .unwrap()
            .is_empty());
    }
}
