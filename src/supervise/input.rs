//! Is the input there? The per-sample "input gone" detector
//! ([`InputMonitor`]): the mean square of the scaled input u/U0 over a
//! short window ([`INPUT_WINDOW_S`]) against its own level over the last
//! excited seconds ([`INPUT_REFERENCE_S`]): an excitation that stops (u = 0,
//! or the DAC's offset) is seen within ~50 ms instead of the ~1/l of
//! Lemma 1 ([`super::lemma1_excited`]).
//!
//! # Design
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

/// Window of the input's short-term mean square (s).
pub(crate) const INPUT_WINDOW_S: f64 = 0.01;
/// Time constant of the input's reference level while present (s).
pub(crate) const INPUT_REFERENCE_S: f64 = 2.0;
/// The input is gone when its short-term mean square falls below this
/// fraction of the reference (−20 dB).
pub(crate) const INPUT_GONE_RATIO: f64 = 1e-2;
/// ... and back when it rises above this fraction (−15 dB).
pub(crate) const INPUT_BACK_RATIO: f64 = 3e-2;

/// The per-sample "input gone" detector (see the module docs).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct InputMonitor<T> {
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
    pub(crate) fn relative_level(&self) -> T {
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

/// Is the data still informative? The power of the law's regressor
/// (|φ|², the trace of the information P gains per sample, eq. 33) over a
/// short window ([`INPUT_WINDOW_S`]) against its level while the input
/// was present (a mean over [`INPUT_REFERENCE_S`], frozen while the input
/// is gone), with the input monitor's thresholds: informative while it is
/// within −20 dB ([`INPUT_GONE_RATIO`]) of that level.
///
/// # Why
/// An impact and the free decay after it, or the ring-down after a drive
/// stops, carry information on the modes for as long as the response
/// stands above the noise (a lightly damped mode rings for seconds), while
/// the input is "gone" within milliseconds ([`InputMonitor`]). Freezing on
/// the input alone threw that decay away (a hammer test gave no estimate).
/// What anti-windup must prevent is adaptation on data that carries no
/// information on the model, when P would accumulate only noise: with the
/// response decayed 20 dB below its level under excitation, the regressor
/// carries a hundredth of the information it did, and the law freezes.
/// The reference starts at zero and follows only while the input is
/// present: an input of a few milliseconds (an impact) leaves a reference
/// a few percent of the response's peak, so the free decay counts as
/// informative until it is some 35 dB down; a drive that stopped after
/// seconds leaves the full level.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct InformationMonitor<T> {
    alpha_short: T,
    alpha_ref: T,
    gone_ratio: T,
    back_ratio: T,
    level: T,
    reference: T,
    informative: bool,
}

impl<T: Real> InformationMonitor<T> {
    /// A monitor fed every `every_s` seconds.
    pub fn new(every_s: f64) -> Self {
        let alpha = |tau: f64| T::from_f64(1.0 - libm::exp(-every_s / tau));
        Self {
            alpha_short: alpha(INPUT_WINDOW_S),
            alpha_ref: alpha(INPUT_REFERENCE_S),
            gone_ratio: T::from_f64(INPUT_GONE_RATIO),
            back_ratio: T::from_f64(INPUT_BACK_RATIO),
            level: T::ZERO,
            reference: T::ZERO,
            informative: true,
        }
    }

    /// Take the regressor's power |φ|² of a sample; `input_present`: the
    /// reference follows it. Returns whether the data is informative (once
    /// not informative without the input, not again until the input is
    /// back).
    #[inline]
    pub fn push(&mut self, power: T, input_present: bool) -> bool {
        self.level += self.alpha_short * (power - self.level);
        if input_present {
            self.reference += self.alpha_ref * (self.level - self.reference);
        }
        // Without the input a decay once judged spent stays so until the
        // input returns: two modes beating make the short window's power
        // swing across the threshold, and the law would adapt in bursts on
        // the decay's tail.
        if !input_present && !self.informative {
            return false;
        }
        let ratio = if self.informative {
            self.gone_ratio
        } else {
            self.back_ratio
        };
        self.informative = self.level >= ratio * self.reference;
        self.informative
    }

    /// As of the last sample.
    pub fn informative(&self) -> bool {
        self.informative
    }

    /// Back to the start.
    pub fn reset(&mut self) {
        self.level = T::ZERO;
        self.reference = T::ZERO;
        self.informative = true;
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used, clippy::indexing_slicing)]
mod tests {
    use super::*;

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

    /// A response that decays after a short input stays informative until
    /// it is far below its level under the input; one that decays after a
    /// long drive, until 20 dB below.
    #[test]
    fn a_free_decay_is_informative_until_it_has_decayed() {
        let every = 1e-3;
        // Two seconds of drive at power 1, then e^{−4t}.
        let mut m = InformationMonitor::<f64>::new(every);
        for _ in 0..2000 {
            assert!(m.push(1.0, true));
        }
        let off = (0..5000)
            .position(|k| !m.push((-4.0 * k as f64 * every).exp(), false))
            .unwrap();
        // The reference holds 1 − e^{−1} of the level after 2 s: −20 dB of
        // that is 0.63e-2 (1.26 s at e^{−4t}), with the window's lag.
        assert!((1200..1350).contains(&off), "{off}");
        // An impact: 5 ms of input, then the same decay from power 1.
        let mut m = InformationMonitor::<f64>::new(every);
        for _ in 0..5 {
            m.push(1.0, true);
        }
        let off = (0..5000)
            .position(|k| !m.push((-4.0 * k as f64 * every).exp(), false))
            .unwrap();
        assert!(off > 2000, "{off}");
        // Nothing comes back without input.
        for _ in 0..1000 {
            assert!(!m.push(0.0, false));
        }
        m.reset();
        assert!(m.informative());
    }
}
