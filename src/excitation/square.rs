//! The paper's square wave (Section IV.A: 0.1·square(7 Hz)), generated
//! sample by sample.
//!
//! # Design
//! The phase is a 32-bit integer accumulator (direct digital synthesis), so
//! the waveform never drifts, whatever the float type or run length: at
//! 10 kHz the frequency resolution is 2.3 µHz and the phase error is bounded
//! forever. Its odd harmonics give Lemma 1 as many frequencies as any model
//! order needs.

use super::ExcitationError;
use crate::scalar::Real;

/// A square wave ±amplitude, starting at +amplitude at t = 0.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SquareWave<T> {
    amplitude: T,
    phase: u32,
    phase_step: u32,
}

impl<T: Real> SquareWave<T> {
    /// `freq_hz` at `sample_rate_hz`.
    pub fn new(amplitude: f64, freq_hz: f64, sample_rate_hz: f64) -> Result<Self, ExcitationError> {
        if !(amplitude >= 0.0 && amplitude.is_finite()) {
            return Err(ExcitationError::Amplitude);
        }
        if !(freq_hz > 0.0 && sample_rate_hz.is_finite() && freq_hz < 0.5 * sample_rate_hz) {
            return Err(ExcitationError::Frequency);
        }
        let step = libm::round(freq_hz / sample_rate_hz * 4_294_967_296.0);
        Ok(Self {
            amplitude: T::from_f64(amplitude),
            phase: 0,
            phase_step: step as u32,
        })
    }

    /// The paper's excitation: 0.1·square(7 Hz) at 10 kHz.
    pub fn paper() -> Self {
        Self {
            amplitude: T::from_f64(0.1),
            phase: 0,
            // round(7 / 1e4 · 2^32)
            phase_step: 3_006_477,
        }
    }

    /// Value for the current sample, then advance one sample.
    #[inline]
    pub fn next_sample(&mut self) -> T {
        let v = if self.phase < 0x8000_0000 {
            self.amplitude
        } else {
            -self.amplitude
        };
        self.phase = self.phase.wrapping_add(self.phase_step);
        v
    }

    /// Amplitude.
    pub fn amplitude(&self) -> T {
        self.amplitude
    }

    /// Restart at phase 0.
    pub fn reset(&mut self) {
        self.phase = 0;
    }
}

/// An endless sequence of samples ([`SquareWave::next_sample`]), so code
/// generic over the excitation (e.g. [`crate::rig::Rig`]) takes a square wave
/// as it takes any other signal.
impl<T: Real> Iterator for SquareWave<T> {
    type Item = T;

    #[inline]
    fn next(&mut self) -> Option<T> {
        Some(self.next_sample())
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used, clippy::indexing_slicing)]
mod tests {
    use super::*;

    #[test]
    fn paper_square_wave_has_7_hz_period_and_half_duty() {
        let mut s = SquareWave::<f64>::paper();
        assert_eq!(s, SquareWave::new(0.1, 7.0, 1e4).unwrap());
        let mut pos = 0;
        let mut flips = 0;
        let mut last = s.next_sample();
        for _ in 1..100_000 {
            let v = s.next_sample();
            if v > 0.0 {
                pos += 1;
            }
            if v != last {
                flips += 1;
            }
            last = v;
        }
        // 10 s at 7 Hz: 140 half periods.
        assert!((139..=141).contains(&flips), "{flips}");
        assert!((pos - 50_000i32).abs() < 200);
        assert!(SquareWave::<f32>::new(1.0, 6000.0, 1e4).is_err());
        // As an iterator it is the same endless sequence.
        let mut a = SquareWave::<f32>::paper();
        let b: [f32; 3000] = core::array::from_fn(|_| a.next_sample());
        assert!(SquareWave::<f32>::paper().take(3000).eq(b));
        assert!(SquareWave::<f32>::new(f64::NAN, 6.0, 1e4).is_err());
    }
}
