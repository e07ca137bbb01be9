//! Repeating frequency sweep (chirp) f0 → f1 over a period, linear or
//! logarithmic, phase continuous everywhere (also where the sweep restarts).
//!
//! # Design
//! * The phase is a 32-bit DDS accumulator ([`sin_q30`] output).
//! * **Linear:** the phase step is a 64-bit Q32.32 integer that grows by a
//!   constant every sample: exact, no drift, identical in f32 and f64 builds.
//! * **Logarithmic:** f(t) = f0·(f1/f0)^(t/T); the step is multiplied by
//!   r = (f1/f0)^(1/N) every sample in `f32` as s += s·(r − 1) (r − 1 keeps
//!   its relative precision in `f32`, r itself would not; no `f64` on a
//!   single-precision FPU) and reset exactly at each restart, so rounding
//!   cannot accumulate beyond one sweep (unit test: the instantaneous
//!   frequency stays within 1e-4 of the ideal curve).
//! * Lemma 1: a periodic sweep of period T has spectral lines every 1/T
//!   inside [f0, f1], i.e. about (f1 − f0)·T sinusoids — far more than the
//!   2n that n modes need, provided the band covers the modes.

use super::sine::sin_q30;
use super::ExcitationError;

/// 2³² as f64 (phase units per cycle).
const CYCLE: f64 = 4_294_967_296.0;

/// How the frequency moves from f0 to f1.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Sweep {
    /// f(t) = f0 + (f1 − f0)·t/T.
    Linear,
    /// f(t) = f0·(f1/f0)^(t/T).
    Logarithmic,
}

/// A chirp's settings.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ChirpSpec {
    /// Start frequency (Hz), > 0.
    pub f0_hz: f64,
    /// End frequency (Hz), > 0 and below half the sample rate (f1 < f0
    /// sweeps downwards).
    pub f1_hz: f64,
    /// Sweep duration (s), at least two samples; the sweep then restarts.
    pub period_s: f64,
    /// Linear or logarithmic.
    pub sweep: Sweep,
}

/// A running chirp generator.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Chirp {
    phase: u32,
    /// Linear: the step in Q32.32.
    step_q32: u64,
    step0_q32: u64,
    dstep_q32: i64,
    /// Logarithmic: the step in phase units and its per-sample ratio.
    step_f: f32,
    step0_f: f32,
    /// r − 1 (held apart from 1 so f32 keeps its relative precision).
    ratio_m1: f32,
    n: u32,
    len: u32,
    spec: ChirpSpec,
}

impl Chirp {
    /// Validate `spec` at `sample_rate_hz` and start at f0 with phase 0.
    pub fn new(spec: &ChirpSpec, sample_rate_hz: f64) -> Result<Self, ExcitationError> {
        if !(sample_rate_hz > 0.0 && sample_rate_hz.is_finite()) {
            return Err(ExcitationError::SampleRate);
        }
        let nyq = 0.5 * sample_rate_hz;
        let ok = |f: f64| f > 0.0 && f < nyq;
        if !(ok(spec.f0_hz) && ok(spec.f1_hz)) {
            return Err(ExcitationError::Frequency);
        }
        let len = libm::round(spec.period_s * sample_rate_hz);
        if !(len >= 2.0 && len <= f64::from(u32::MAX)) {
            return Err(ExcitationError::Period);
        }
        let s0 = spec.f0_hz / sample_rate_hz * CYCLE;
        let s1 = spec.f1_hz / sample_rate_hz * CYCLE;
        let q = CYCLE; // Q32.32 scale
        let step0_q32 = libm::round(s0 * q) as u64;
        let dstep_q32 = libm::round((s1 - s0) / len * q) as i64;
        let ratio_m1 = libm::expm1(libm::log(s1 / s0) / len) as f32;
        Ok(Self {
            phase: 0,
            step_q32: step0_q32,
            step0_q32,
            dstep_q32,
            step_f: s0 as f32,
            step0_f: s0 as f32,
            ratio_m1,
            n: 0,
            len: len as u32,
            spec: *spec,
        })
    }

    /// This sample's value (Q30), then advance one sample.
    #[inline]
    pub(crate) fn next_raw(&mut self) -> i32 {
        let v = sin_q30(self.phase);
        let step = self.current_step();
        self.phase = self.phase.wrapping_add(step);
        self.n += 1;
        if self.n >= self.len {
            self.n = 0;
            self.step_q32 = self.step0_q32;
            self.step_f = self.step0_f;
        } else {
            match self.spec.sweep {
                Sweep::Linear => {
                    self.step_q32 = self.step_q32.wrapping_add_signed(self.dstep_q32);
                }
                Sweep::Logarithmic => self.step_f += self.step_f * self.ratio_m1,
            }
        }
        v
    }

    /// Phase step (2³²/cycle) applied after the current sample, i.e. the
    /// instantaneous frequency f = step·fs/2³².
    #[inline]
    pub(crate) fn current_step(&self) -> u32 {
        match self.spec.sweep {
            Sweep::Linear => (self.step_q32 >> 32) as u32,
            // 0 ≤ step_f < 2³¹ by construction (f < fs/2).
            Sweep::Logarithmic => self.step_f as u32,
        }
    }

    /// The settings.
    pub fn spec(&self) -> &ChirpSpec {
        &self.spec
    }

    /// Sweep length in samples.
    #[cfg(test)]
    pub(crate) fn period_samples(&self) -> u32 {
        self.len
    }

    /// Restart the sweep at f0, phase 0.
    pub fn reset(&mut self) {
        self.phase = 0;
        self.n = 0;
        self.step_q32 = self.step0_q32;
        self.step_f = self.step0_f;
    }

    /// New band and period, keeping the phase (continuous output) and the
    /// position within the sweep in proportion.
    pub fn retune(&mut self, spec: &ChirpSpec, sample_rate_hz: f64) -> Result<(), ExcitationError> {
        let mut next = Self::new(spec, sample_rate_hz)?;
        next.phase = self.phase;
        let frac = f64::from(self.n) / f64::from(self.len);
        let target = ((frac * f64::from(next.len)) as u32).min(next.len - 1);
        // Jump the frequency trajectory to the same relative position
        // (closed form: no per-sample loop while the sample task waits).
        next.n = target;
        next.step_q32 = next
            .step0_q32
            .wrapping_add_signed(next.dstep_q32.wrapping_mul(i64::from(target)));
        next.step_f = (f64::from(next.step0_f)
            * libm::pow(1.0 + f64::from(next.ratio_m1), f64::from(target)))
            as f32;
        *self = next;
        Ok(())
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used, clippy::indexing_slicing)]
mod tests {
    use super::*;

    fn inst_freq(c: &Chirp, fs: f64) -> f64 {
        f64::from(c.current_step()) * fs / CYCLE
    }

    #[test]
    fn instantaneous_frequency_follows_the_sweep() {
        let fs = 1e4;
        for sweep in [Sweep::Linear, Sweep::Logarithmic] {
            let spec = ChirpSpec {
                f0_hz: 2.0,
                f1_hz: 200.0,
                period_s: 5.0,
                sweep,
            };
            let mut c = Chirp::new(&spec, fs).unwrap();
            let len = c.period_samples();
            assert_eq!(len, 50_000);
            for k in 0..2 * len {
                let t = f64::from(k % len) / fs;
                let ideal = match sweep {
                    Sweep::Linear => 2.0 + 198.0 * t / 5.0,
                    Sweep::Logarithmic => 2.0 * libm::pow(100.0, t / 5.0),
                };
                let got = inst_freq(&c, fs);
                assert!(
                    (got - ideal).abs() <= 1e-4 * ideal + 1e-5,
                    "{sweep:?} k={k}: {got} vs {ideal}"
                );
                c.next_raw();
            }
        }
    }

    #[test]
    fn zero_crossings_match_the_integrated_frequency() {
        // Linear 10 → 30 Hz over 1 s: 20 cycles per sweep, 40 crossings.
        let spec = ChirpSpec {
            f0_hz: 10.0,
            f1_hz: 30.0,
            period_s: 1.0,
            sweep: Sweep::Linear,
        };
        let mut c = Chirp::new(&spec, 1e4).unwrap();
        let mut last = c.next_raw();
        let mut crossings = 0;
        for _ in 1..10_000 {
            let v = c.next_raw();
            if (v >= 0) != (last >= 0) {
                crossings += 1;
            }
            last = v;
        }
        assert!((39..=41).contains(&crossings), "{crossings}");
    }

    #[test]
    fn retune_keeps_phase_and_rejects_bad_specs() {
        let spec = ChirpSpec {
            f0_hz: 5.0,
            f1_hz: 50.0,
            period_s: 2.0,
            sweep: Sweep::Logarithmic,
        };
        let mut c = Chirp::new(&spec, 1e4).unwrap();
        for _ in 0..5_000 {
            c.next_raw();
        }
        let phase = c.phase;
        let wider = ChirpSpec {
            f1_hz: 100.0,
            ..spec
        };
        c.retune(&wider, 1e4).unwrap();
        assert_eq!(c.phase, phase);
        assert_eq!(c.n, 5_000);
        let bad = ChirpSpec {
            f1_hz: 6000.0,
            ..spec
        };
        assert_eq!(c.retune(&bad, 1e4), Err(ExcitationError::Frequency));
        assert_eq!(c.phase, phase);
        let short = ChirpSpec {
            period_s: 1e-4,
            ..spec
        };
        assert_eq!(
            Chirp::new(&short, 1e4).unwrap_err(),
            ExcitationError::Period
        );
    }
}
