//! Periodic multisine: a sum of equal-amplitude sines on an exact frequency
//! grid, normalised so its peak is exactly full scale.
//!
//! # Design
//! * **Exact period.** The period is N = 2^k samples, so the grid spacing
//!   fs/N is represented exactly by the 32-bit phase step 2^(32−k) and tone
//!   h has step h·2^(32−k): after N samples every phase is back where it
//!   started, bit for bit. The signal is exactly periodic (no leakage for a
//!   DFT over N samples) and its peak, found by scanning one period at
//!   construction, bounds every future sample.
//! * **Tones.** `tones` harmonics log-spaced between `f_min_hz` and
//!   `f_max_hz` (rounded to the grid, made strictly increasing), so a band
//!   spanning decades gets the same number of lines per decade.
//! * **Low crest factor.** Schroeder phases φ_i = −2π·Σ_{l<i}(h_i − h_l)/M
//!   (= −π·i(i−1)/M on consecutive harmonics h; Schroeder,
//!   *Synthesis of low-peak-factor signals…*, IEEE Trans. IT 1970) or
//!   uniformly random phases from a seed.
//! * **Cost.** Per sample and tone: one add and one [`sin_q30`]. The
//!   construction scan costs N·M of those (2^16 × 16 ≈ 1 M at most): build
//!   in the low-priority task, then hand the result over
//!   ([`super::Excitation::set_generator`]).
//! * Measured crest factors (peak/RMS; all tones in phase: √(2M)):
//!   Schroeder on consecutive harmonics is lowest (unit test); on a
//!   log-spaced grid it is no better than random phases — 2–80 Hz, 8
//!   tones: Schroeder 3.13, random seeds 1/2/3 2.96/3.38/3.09; 1–400 Hz, 16
//!   tones: Schroeder 3.78, random 2.92/3.32/3.87 (bound 4.0 and 5.66). Try
//!   a few seeds when the crest factor matters.
//! * Lemma 1: M tones give 2M spectral lines, so n modes (4n − 1
//!   parameters of Θ, eq. 29) need M ≥ 2n tones.

use super::sine::sin_q30;
use super::ExcitationError;

/// Most tones in one multisine.
pub const MAX_TONES: usize = 16;
/// Shortest period, 2^8 samples.
pub const MIN_PERIOD_LOG2: u8 = 8;
/// Longest period, 2^16 samples (6.5 s at 10 kHz: a 0.15 Hz grid).
pub const MAX_PERIOD_LOG2: u8 = 16;
/// Each tone enters the sum as Q30 >> this, so 16 tones never overflow i32.
const TONE_SHIFT: u32 = 4;

/// The device's multisine period (the wire leaves it to the device,
/// `docs/PROTOCOL.md` §5.1): the shortest 2^k samples (k = 8…16) whose
/// grid f_s/2^k is at most f_min/8, so the lowest tone lands within 1/16 of
/// its request (the longest period if none is that fine).
pub fn period_log2_for(f_min_hz: f64, sample_rate_hz: f64) -> u8 {
    (MIN_PERIOD_LOG2..=MAX_PERIOD_LOG2)
        .find(|&k| sample_rate_hz / f64::from(1u32 << k) <= f_min_hz / 8.0)
        .unwrap_or(MAX_PERIOD_LOG2)
}

/// Initial phases of the tones.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Phases {
    /// Schroeder's low-peak phases (see the module doc).
    Schroeder,
    /// Uniformly random phases from this seed (xorshift32; 0 is replaced
    /// by a fixed non-zero seed).
    Random(u32),
}

/// What a multisine should contain.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MultisineSpec {
    /// Lowest tone (Hz), rounded to the grid, at least one grid step.
    pub f_min_hz: f64,
    /// Highest tone (Hz), below half the sample rate.
    pub f_max_hz: f64,
    /// Number of tones, 1..=`MAX_TONES`.
    pub tones: u8,
    /// Period 2^`period_log2` samples (grid fs/2^k),
    /// `MIN_PERIOD_LOG2`..=`MAX_PERIOD_LOG2`.
    pub period_log2: u8,
    /// Initial phases.
    pub phases: Phases,
}

/// A running multisine generator.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Multisine {
    phase: [u32; MAX_TONES],
    initial: [u32; MAX_TONES],
    step: [u32; MAX_TONES],
    harmonic: [u32; MAX_TONES],
    tones: u8,
    period_log2: u8,
    peak: i32,
}

impl Multisine {
    /// Build, validate and normalise (scans one period: see the module doc).
    pub fn new(spec: &MultisineSpec, sample_rate_hz: f64) -> Result<Self, ExcitationError> {
        let m = usize::from(spec.tones);
        if m == 0 || m > MAX_TONES {
            return Err(ExcitationError::Tones);
        }
        if !(MIN_PERIOD_LOG2..=MAX_PERIOD_LOG2).contains(&spec.period_log2) {
            return Err(ExcitationError::Period);
        }
        if !(sample_rate_hz > 0.0 && sample_rate_hz.is_finite()) {
            return Err(ExcitationError::SampleRate);
        }
        let n = 1u32 << spec.period_log2;
        let grid_hz = sample_rate_hz / f64::from(n);
        let (lo, hi) = (spec.f_min_hz, spec.f_max_hz);
        if !(lo > 0.0 && lo <= hi && hi < 0.5 * sample_rate_hz) {
            return Err(ExcitationError::Frequency);
        }
        let mut s = Self {
            phase: [0; MAX_TONES],
            initial: [0; MAX_TONES],
            step: [0; MAX_TONES],
            harmonic: [0; MAX_TONES],
            tones: spec.tones,
            period_log2: spec.period_log2,
            peak: 1,
        };
        let ratio = hi / lo;
        let mut prev = 0u32;
        let mut rng = match spec.phases {
            Phases::Random(0) => 0x9E37_79B9,
            Phases::Random(seed) => seed,
            Phases::Schroeder => 0,
        };
        for i in 0..m {
            let f = if m == 1 {
                lo
            } else {
                lo * libm::pow(ratio, i as f64 / (m - 1) as f64)
            };
            let h = (libm::round(f / grid_hz) as u32).max(prev + 1);
            // Strictly below Nyquist (h < n/2).
            if h >= n / 2 {
                return Err(ExcitationError::Frequency);
            }
            prev = h;
            let phi = match spec.phases {
                Phases::Schroeder => {
                    // Schroeder's rule for equal powers 1/M on any grid:
                    // φ_i = −2π·Σ_{l<i} (h_i − h_l)/M (reduces to
                    // −π·i(i−1)/M on consecutive harmonics), in cycles.
                    let mut cyc = 0.0;
                    for &hl in s.harmonic.iter().take(i) {
                        cyc -= f64::from(h - hl) / m as f64;
                    }
                    cyc
                }
                Phases::Random(_) => {
                    rng ^= rng << 13;
                    rng ^= rng >> 17;
                    rng ^= rng << 5;
                    f64::from(rng) / 4_294_967_296.0
                }
            };
            // Cosine phases (Schroeder's form): cos x = sin(x + π/2).
            let cyc = phi - libm::floor(phi) + 0.25;
            let p = (libm::round(cyc * 4_294_967_296.0) as u64 & 0xFFFF_FFFF) as u32;
            if let (Some(hh), Some(st), Some(ini)) = (
                s.harmonic.get_mut(i),
                s.step.get_mut(i),
                s.initial.get_mut(i),
            ) {
                *hh = h;
                *st = h << (32 - u32::from(spec.period_log2));
                *ini = p;
            }
        }
        s.phase = s.initial;
        // Peak over one exact period.
        let mut probe = s;
        let mut peak = 1i32;
        for _ in 0..n {
            peak = peak.max(probe.next_raw().saturating_abs());
        }
        s.peak = peak;
        Ok(s)
    }

    /// Sum of the tones for this sample (|v| ≤ [`Multisine::peak`]), then
    /// advance one sample.
    #[inline]
    pub(crate) fn next_raw(&mut self) -> i32 {
        let m = usize::from(self.tones);
        let mut acc = 0i32;
        for (p, st) in self.phase.iter_mut().zip(self.step.iter()).take(m) {
            acc += sin_q30(*p) >> TONE_SHIFT;
            *p = p.wrapping_add(*st);
        }
        acc
    }

    /// Largest |sum| over one period (the normalisation).
    pub fn peak(&self) -> i32 {
        self.peak
    }

    /// Number of tones M.
    pub fn tones(&self) -> usize {
        usize::from(self.tones)
    }

    /// Period in samples, 2^k.
    #[cfg(test)]
    pub(crate) fn period_samples(&self) -> u32 {
        1 << self.period_log2
    }

    /// Tone `i`'s frequency as a multiple of the grid fs/2^k.
    #[cfg(test)]
    pub(crate) fn harmonic(&self, i: usize) -> Option<u32> {
        self.harmonic.get(i).copied().filter(|_| i < self.tones())
    }

    /// Back to the initial phases.
    pub fn reset(&mut self) {
        self.phase = self.initial;
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used, clippy::indexing_slicing)]
mod tests {
    use super::*;

    fn spec(tones: u8, phases: Phases) -> MultisineSpec {
        MultisineSpec {
            f_min_hz: 2.0,
            f_max_hz: 80.0,
            tones,
            period_log2: 14,
            phases,
        }
    }

    #[test]
    fn exactly_periodic_and_peak_bounds_every_sample() {
        let mut m = Multisine::new(&spec(8, Phases::Schroeder), 1e4).unwrap();
        let n = m.period_samples() as usize;
        let first: Vec<i32> = (0..n).map(|_| m.next_raw()).collect();
        let second: Vec<i32> = (0..n).map(|_| m.next_raw()).collect();
        assert_eq!(first, second);
        let peak = first.iter().map(|v| v.abs()).max().unwrap();
        assert_eq!(peak, m.peak());
    }

    #[test]
    fn log_spaced_distinct_harmonics_and_schroeder_crest() {
        let m = Multisine::new(&spec(8, Phases::Schroeder), 1e4).unwrap();
        let grid = 1e4 / 16384.0;
        let h: Vec<u32> = (0..8).map(|i| m.harmonic(i).unwrap()).collect();
        assert!(h.windows(2).all(|w| w[0] < w[1]), "{h:?}");
        assert!((h[0] as f64 * grid - 2.0).abs() <= grid);
        assert!((h[7] as f64 * grid - 80.0).abs() <= grid);
        assert_eq!(m.harmonic(8), None);
        // Crest factor peak/RMS: all tones in phase would give √(2M) = 4.
        let rms = (8.0f64 / 2.0).sqrt() * f64::from(1 << 26);
        let crest = |m: &Multisine| f64::from(m.peak()) / rms;
        assert!(crest(&m) < 3.2, "Schroeder crest {}", crest(&m));
        let r = Multisine::new(&spec(8, Phases::Random(7)), 1e4).unwrap();
        assert!(crest(&r) < 3.9);
        // Consecutive harmonics 1..8: Schroeder's classic low crest factor.
        let lin = MultisineSpec {
            f_min_hz: grid,
            f_max_hz: 8.0 * grid,
            ..spec(8, Phases::Schroeder)
        };
        let l = Multisine::new(&lin, 1e4).unwrap();
        assert_eq!(l.harmonic(7), Some(8));
        assert!(crest(&l) < 2.0, "consecutive Schroeder crest {}", crest(&l));
    }

    #[test]
    fn device_periods() {
        assert_eq!(period_log2_for(2.0, 1e4), 16);
        assert_eq!(period_log2_for(100.0, 1e4), 10);
        assert_eq!(period_log2_for(4_000.0, 1e4), 8);
        assert_eq!(period_log2_for(0.01, 1e4), 16);
    }

    #[test]
    fn rejects_bad_specs() {
        let ok = spec(4, Phases::Schroeder);
        let bad = |f: fn(&mut MultisineSpec)| {
            let mut s = ok;
            f(&mut s);
            Multisine::new(&s, 1e4).unwrap_err()
        };
        assert_eq!(bad(|s| s.tones = 0), ExcitationError::Tones);
        assert_eq!(bad(|s| s.tones = 17), ExcitationError::Tones);
        assert_eq!(bad(|s| s.period_log2 = 7), ExcitationError::Period);
        assert_eq!(bad(|s| s.f_max_hz = 5000.0), ExcitationError::Frequency);
        assert_eq!(bad(|s| s.f_min_hz = f64::NAN), ExcitationError::Frequency);
        assert_eq!(bad(|s| s.f_min_hz = 100.0), ExcitationError::Frequency);
        assert_eq!(
            Multisine::new(&ok, f64::INFINITY).unwrap_err(),
            ExcitationError::SampleRate
        );
    }
}
