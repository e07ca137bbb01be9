//! Is the estimator excited? Two detectors, one answer
//! ([`ExcitationReason`]):
//!
//! * **Lemma 1** (Wang, Costa-Castelló, Na et al., *Modelling and Adaptive
//!   Parameter Estimation for a Piezoelectric Cantilever Beam*): the
//!   regressor is persistently exciting iff λmin(P) of the information
//!   matrix (eq. 33) stays above some σ > 0. The test used everywhere —
//!   the estimator's own supervision, the firmware's EXCITED flag, the host
//!   tools — is [`lemma1_excited`]: λmin(P) ≥ [`EXCITATION_REL_THRESHOLD`]
//!   · tr(P). With forgetting l, P reflects the last ~1/l seconds (20 s at
//!   the default l = 0.05 /s), so λmin reacts on that time scale.
//! * **Input gone** ([`InputMonitor`], per sample): the mean square of the
//!   scaled input u/U0 over a short window ([`INPUT_WINDOW_S`]) against its
//!   own level over the last excited seconds ([`INPUT_REFERENCE_S`]): an
//!   excitation that stops (u = 0, or the DAC's offset) is seen within
//!   ~50 ms instead of ~1/l.
//!
//! # Design
//! * **Why relative to tr(P).** λmin alone cannot tell excitation from
//!   rounding: in `f32` the λmin of a non-exciting input is rounding noise
//!   whose size grows with P (above the square wave's early values), while
//!   λmin/tr(P) separates them (the levels: BENCHMARKS.md, "Design
//!   measurements"; host test `link::excited_flag_follows_the_excitation`). 1e-7 is near
//!   `f32`'s ε (1.2e-7): below it λmin is within the rounding of P's
//!   entries. A plant whose P is inherently worse conditioned than ~10⁷
//!   (e.g. three modes, or a weak high mode) never passes, excited or not.
//! * **Why a short-window energy for "input gone".** What must not happen
//!   without excitation is adaptation on y alone: with u = 0 the y-channel
//!   regressor carries only the decaying free response and the measurement
//!   noise, P, Q (and R) accumulate the noise and the u block of P forgets,
//!   so Θ̂ drifts towards a fit of the noise. Lemma 1 sees that after ~1/l;
//!   the energy of u drops at once. The window (10 ms) averages a square
//!   wave, a PRBS or a multisine of tones ≳ 20 Hz; the threshold (−20 dB
//!   of the reference, [`INPUT_GONE_RATIO`]) keeps a paused output's DAC
//!   offset (mV against a 100 mV drive: −40 dB) "gone", with hysteresis
//!   ([`INPUT_BACK_RATIO`]) against chatter at the threshold.
//! * **The reference** follows the input's level while it is present (a
//!   2 s mean square, so a new amplitude is learnt in seconds) and is
//!   frozen while it is gone. A deliberate cut of the drive by more than
//!   20 dB therefore reads as "input gone" until the level returns: lower
//!   the amplitude in steps of < 20 dB, or rebuild the estimator.

use crate::scalar::Real;

/// Lemma 1's threshold: excited iff λmin(P) ≥ this × tr(P) (scaled P).
pub const EXCITATION_REL_THRESHOLD: f64 = 1e-7;
/// Window of the input's short-term mean square (s).
pub const INPUT_WINDOW_S: f64 = 0.01;
/// Time constant of the input's reference level while present (s).
pub const INPUT_REFERENCE_S: f64 = 2.0;
/// The input is gone when its short-term mean square falls below this
/// fraction of the reference (−20 dB).
pub const INPUT_GONE_RATIO: f64 = 1e-2;
/// ... and back when it rises above this fraction (−15 dB).
pub const INPUT_BACK_RATIO: f64 = 3e-2;

/// Lemma 1 as this project decides it: λmin(P) ≥
/// [`EXCITATION_REL_THRESHOLD`]·tr(P), P the scaled information matrix.
/// False for a non-finite or non-positive trace (fails safe).
pub fn lemma1_excited<T: Real>(lambda_min: T, trace: T) -> bool {
    trace > T::ZERO
        && trace.is_finite()
        && lambda_min >= T::from_f64(EXCITATION_REL_THRESHOLD) * trace
}

/// Why the estimator is or is not excited.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum ExcitationReason {
    /// Input present and Lemma 1 satisfied (or not known yet).
    #[default]
    Excited,
    /// The input's short-window energy fell more than 20 dB below its
    /// level: adaptation is frozen.
    InputGone,
    /// The input is there but λmin(P)/tr(P) is below the threshold: some
    /// direction of Θ is not excited; forgetting is suspended so it cannot
    /// decay.
    NotPersistent,
    /// The input is there, Lemma 1 not measured yet (no θ step since the
    /// estimator started).
    Starting,
}

impl ExcitationReason {
    /// True for [`ExcitationReason::Excited`].
    pub fn is_excited(self) -> bool {
        self == Self::Excited
    }

    /// A short lowercase name (`"excited"`, `"input_gone"`,
    /// `"not_persistent"`, `"starting"`).
    pub fn as_str(self) -> &'static str {
        match self {
            Self::Excited => "excited",
            Self::InputGone => "input_gone",
            Self::NotPersistent => "not_persistent",
            Self::Starting => "starting",
        }
    }
}

impl core::fmt::Display for ExcitationReason {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(self.as_str())
    }
}

/// The per-sample "input gone" detector (see the module docs).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct InputMonitor<T> {
    alpha_short: T,
    alpha_ref: T,
    gone_ratio: T,
    back_ratio: T,
    /// Short-window mean square of u/U0.
    level: T,
    /// Reference mean square.
    reference: T,
    present: bool,
}

impl<T: Real> InputMonitor<T> {
    /// A monitor for sample period `ts_s`, starting "present" at the
    /// start-up scale (u/U0 has mean square ≈ 1 by construction of U0).
    pub fn new(ts_s: f64) -> Self {
        let alpha = |tau: f64| T::from_f64(1.0 - libm::exp(-ts_s / tau));
        Self {
            alpha_short: alpha(INPUT_WINDOW_S),
            alpha_ref: alpha(INPUT_REFERENCE_S),
            gone_ratio: T::from_f64(INPUT_GONE_RATIO),
            back_ratio: T::from_f64(INPUT_BACK_RATIO),
            level: T::ONE,
            reference: T::ONE,
            present: true,
        }
    }

    /// Take one scaled input sample u/U0; true while the input is present.
    #[inline]
    pub fn push(&mut self, u_scaled: T) -> bool {
        self.level += self.alpha_short * (u_scaled * u_scaled - self.level);
        let ratio = if self.present {
            self.gone_ratio
        } else {
            self.back_ratio
        };
        self.present = self.level >= ratio * self.reference;
        if self.present {
            self.reference += self.alpha_ref * (self.level - self.reference);
        }
        self.present
    }

    /// Whether the input is present (as of the last sample).
    pub fn present(&self) -> bool {
        self.present
    }

    /// Short-window mean square over the reference (dimensionless; < 0.01
    /// means gone).
    pub fn relative_level(&self) -> T {
        if self.reference > T::ZERO {
            self.level / self.reference
        } else {
            T::ZERO
        }
    }

    /// Back to the start (present, reference at the start-up scale).
    pub fn reset(&mut self) {
        self.level = T::ONE;
        self.reference = T::ONE;
        self.present = true;
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used, clippy::indexing_slicing)]
mod tests {
    use super::*;

    #[test]
    fn lemma1_threshold_is_relative_and_fails_safe() {
        assert!(lemma1_excited(1e-6f32, 1.0));
        assert!(!lemma1_excited(0.99e-7f64, 1.0));
        assert!(lemma1_excited(1e-7f64 * 5.0, 5.0));
        assert!(!lemma1_excited(1.0f64, 0.0));
        assert!(!lemma1_excited(f64::NAN, 1.0));
        assert!(!lemma1_excited(1.0f64, f64::INFINITY));
    }

    #[test]
    fn input_gone_within_fifty_ms_and_back_at_once() {
        let mut m = InputMonitor::<f32>::new(1e-4);
        // A ±1 square wave (the scaled paper drive) for 1 s: present.
        for k in 0..10_000 {
            let u = if (k / 714) % 2 == 0 { 1.0 } else { -1.0 };
            assert!(m.push(u), "{k}");
        }
        // Off at a 1 mV offset on a 100 mV drive (scaled 0.01): gone in
        // ≤ 50 ms (4.6 windows), and stays gone for a minute.
        let mut gone_at = None;
        for k in 0..600_000 {
            if !m.push(0.01) && gone_at.is_none() {
                gone_at = Some(k);
            }
            if let Some(g) = gone_at {
                assert!(k < g || !m.present(), "came back at {k}");
            }
        }
        let g = gone_at.unwrap();
        assert!(g <= 500, "{g}");
        // Back within a millisecond of the drive's return.
        let back = (0..100).position(|_| m.push(1.0)).unwrap();
        assert!(back <= 10, "{back}");
        // A 10 dB quieter drive is still present; the reference follows it.
        for _ in 0..200_000 {
            assert!(m.push(0.3));
        }
        assert!(
            (m.relative_level() - 1.0).abs() < 0.01,
            "{}",
            m.relative_level()
        );
        m.reset();
        assert!(m.present());
    }
}
