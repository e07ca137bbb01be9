//! Detected-change tracking: a CUSUM test on the law's a-priori prediction
//! error against its own running level. When the plant changes (the beam's
//! ω or ζ moves), the equation error e = y/Y0 − θ̂ᵀφ (eq. 29, scaled)
//! leaves its steady level at once, long before forgetting (1/l = 20 s at
//! the defaults) would let the estimate follow. On detection the estimator
//! discounts its old data strongly (P, Q and R × [`DISCOUNT`], θ̂ kept as
//! the starting point, nothing held) and the law converges on the new data
//! as it did at start-up.
//!
//! # The test
//! s_k = e_k²/σ̂², σ̂² = max(running mean of e², ([`RESIDUAL_FLOOR`])²),
//! g_k = max(0, g_{k−1} + s_k − [`DRIFT`]), alarm when g_k > h — the
//! one-sided CUSUM for an increase of the residual's variance (Page's test,
//! with the log-likelihood ratio for a variance ratio of ≈ 4 scaled to
//! unit drift). For a steady plant s_k has mean ≈ 1 and the drift keeps g
//! at 0; a change that multiplies the residual's RMS by ≥ 2 drives g up by
//! ≥ 2 per sample. The running mean is updated with e² clipped at
//! [`CLIP`]·σ̂² (a change does not pull its own reference up before it is
//! detected), over [`REFERENCE_S`]; after a start or a detection it is
//! first learnt fast ([`LEARN_S`]) for [`ARM_S`] while the estimate
//! converges, and the test is armed only then.
//!
//! # The knob
//! h ([`TrackingConfig::change_threshold`], default
//! [`DEFAULT_CHANGE_THRESHOLD`]) trades tracking speed against noise: a
//! lower h detects smaller changes sooner but fires on noise more often,
//! and each false alarm costs the estimate its memory (it then has the
//! noise of a short record until the memory rebuilds); a higher h ignores
//! small changes, which forgetting follows over ~1/l instead. `h = ∞`
//! disables detection. Measured figures: docs/ROBUSTNESS.md.
//!
//! # Only what a plant change produces
//! The test reads the residual through a first-order high-pass at
//! [`RESIDUAL_HIGHPASS_RAD_S`]. A change of the beam shows in the residual
//! at the frequencies the drive excites (the paper's 7 Hz square wave:
//! 44 rad/s and its harmonics, near ω1 = 39 rad/s and above), which pass;
//! what a sensor's slow drift leaves after the guard's high-pass
//! ([`crate::guard`], corner ω_c: a transient r·t·e^{−ω_c t}) lies at and
//! below ω_c and is attenuated (by 3.4 at ω_c = 3 rad/s, 1.4 at 10) — it
//! is a disturbance the forgetting memory averages out, not a new beam to
//! discount the past for. Measured with the guard at 3 rad/s: without this
//! high-pass a drift of 0.02·Y0/s fired the test and the estimate went 37%
//! off; with it, 0.7% (docs/ROBUSTNESS.md, sensor faults).
//!
//! # The floor
//! Noise-free the residual is at the rounding and interpolation floor
//! (1e-10…1e-6 of Y0 in `f64`/`f32`), and a ratio to that level would fire
//! on any numerical hiccup; σ̂ is therefore never taken below
//! [`RESIDUAL_FLOOR`] (1e-3 of the output's RMS): noise-free, a change is
//! detected once it moves the residual above a few 1e-3 of Y0, which a 1%
//! step of ω1 does within a millisecond.

use crate::scalar::Real;

/// Drift of the CUSUM (in units of the residual's mean square).
pub const DRIFT: f64 = 1.5;
/// Default alarm threshold h.
pub(crate) const DEFAULT_CHANGE_THRESHOLD: f64 = 200.0;
/// σ̂ is at least this (scaled units: a fraction of Y0).
pub const RESIDUAL_FLOOR: f64 = 1e-3;
/// The reference is updated with e² clipped at this multiple of σ̂².
pub const CLIP: f64 = 4.0;
/// Time constant of the residual's running mean square once armed (s).
pub const REFERENCE_S: f64 = 1.0;
/// Time constant while learning it (after a start or a detection) (s).
pub const LEARN_S: f64 = 0.02;
/// Corner of the high-pass on the residual (rad/s; see the module docs).
pub const RESIDUAL_HIGHPASS_RAD_S: f64 = 10.0;
/// The test's 1/σ̂² is recomputed every this many samples.
pub(crate) const INVERSE_EVERY: u32 = 8;
/// Learning time before the test is armed (s).
pub const ARM_S: f64 = 0.5;
/// Old data are multiplied by this on a detection (2⁻⁴⁰ ≈ 9.1e-13: exact
/// in binary floating point, so the old data's fixed point is unchanged;
/// the memory of 1/l = 20 s then weighs as 1.8e-11 s of new data, and
/// scaled P entries of order 1–1e4 stay far above `f32`'s smallest normal
/// number, 1.2e-38).
pub(crate) const DISCOUNT: f64 = 1.0 / 1_099_511_627_776.0;

/// Tracking settings.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct TrackingConfig {
    /// CUSUM alarm threshold h (see the module docs); `f64::INFINITY`
    /// disables detection.
    pub change_threshold: f64,
}

impl Default for TrackingConfig {
    fn default() -> Self {
        Self {
            change_threshold: DEFAULT_CHANGE_THRESHOLD,
        }
    }
}

impl TrackingConfig {
    /// No detection (forgetting alone follows changes).
    pub const OFF: Self = Self {
        change_threshold: f64::INFINITY,
    };

    /// Whether detection is on.
    pub fn enabled(&self) -> bool {
        self.change_threshold.is_finite()
    }
}

/// The CUSUM state (see the module docs).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct ChangeDetector<T> {
    enabled: bool,
    threshold: T,
    drift: T,
    floor2: T,
    clip: T,
    alpha_ref: T,
    alpha_learn: T,
    alpha_hp: T,
    /// The residual's slow part (removed before the test).
    slow: T,
    arm_samples: u32,
    /// Samples until armed (0 = armed).
    warmup: u32,
    mean_square: T,
    /// 1/σ̂², refreshed every [`INVERSE_EVERY`] samples.
    inv_ref2: T,
    /// Samples until the next refresh.
    refresh: u32,
    cusum: T,
    /// Largest g since the test was last armed.
    peak: T,
}

impl<T: Real> ChangeDetector<T> {
    /// A detector for sample period `ts_s` (learning from the first sample).
    pub fn new(cfg: &TrackingConfig, ts_s: f64) -> Self {
        let alpha = |tau: f64| T::from_f64(1.0 - libm::exp(-ts_s / tau));
        let arm = libm::ceil(ARM_S / ts_s);
        let enabled = cfg.enabled() && cfg.change_threshold > 0.0;
        Self {
            enabled,
            threshold: T::from_f64(if enabled { cfg.change_threshold } else { 0.0 }),
            drift: T::from_f64(DRIFT),
            floor2: T::from_f64(RESIDUAL_FLOOR * RESIDUAL_FLOOR),
            clip: T::from_f64(CLIP),
            alpha_ref: alpha(REFERENCE_S),
            alpha_learn: alpha(LEARN_S),
            alpha_hp: alpha(1.0 / RESIDUAL_HIGHPASS_RAD_S),
            slow: T::ZERO,
            arm_samples: if arm >= u32::MAX as f64 {
                u32::MAX
            } else {
                arm as u32
            },
            warmup: 0,
            mean_square: T::ZERO,
            inv_ref2: T::ZERO,
            refresh: 0,
            cusum: T::ZERO,
            peak: T::ZERO,
        }
        .restarted()
    }

    fn restarted(mut self) -> Self {
        self.restart();
        self
    }

    /// Learn the residual's level afresh and arm after `ARM_S` (a new
    /// estimate, or one that has just discounted its past).
    pub fn restart(&mut self) {
        self.warmup = self.arm_samples;
        self.cusum = T::ZERO;
        self.peak = T::ZERO;
        self.mean_square = T::ZERO;
        self.slow = T::ZERO;
        self.refresh = 0;
    }

    /// Take the a-priori prediction error of one updated sample; true on a
    /// detection (the detector then restarts itself).
    #[inline]
    pub fn push(&mut self, e: T) -> bool {
        if !self.enabled || !e.is_finite() {
            return false;
        }
        self.slow += self.alpha_hp * (e - self.slow);
        let e = e - self.slow;
        let e2 = e * e;
        if self.warmup > 0 {
            self.warmup -= 1;
            self.mean_square += self.alpha_learn * (e2 - self.mean_square);
            return false;
        }
        let ref2 = self.mean_square.max(self.floor2);
        self.mean_square += self.alpha_ref * (e2.min(self.clip * ref2) - self.mean_square);
        // 1/σ̂² is refreshed every INVERSE_EVERY samples (σ̂² moves by
        // < 0.3% in that time: 3·α·8 with the clip): no division per sample.
        if self.refresh == 0 {
            self.refresh = INVERSE_EVERY;
            self.inv_ref2 = T::ONE / ref2;
        }
        self.refresh -= 1;
        let s = e2 * self.inv_ref2;
        self.cusum = (self.cusum + s - self.drift).max(T::ZERO);
        self.peak = self.peak.max(self.cusum);
        if self.cusum > self.threshold {
            self.restart();
            return true;
        }
        false
    }

    /// Whether the test is armed (learning finished).
    #[cfg(test)]
    pub(crate) fn armed(&self) -> bool {
        self.enabled && self.warmup == 0
    }

    /// The CUSUM statistic g now (for telemetry and tests).
    pub(crate) fn statistic(&self) -> T {
        self.cusum
    }

    /// The largest g since the test was last armed (how close a steady
    /// run came to a detection).
    pub fn peak(&self) -> T {
        self.peak
    }

    /// RMS of the residual the test compares against (σ̂, scaled units).
    #[cfg(test)]
    pub(crate) fn reference_rms(&self) -> T {
        self.mean_square.max(self.floor2).sqrt()
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used, clippy::indexing_slicing)]
mod tests {
    use super::*;
    use crate::rig::GaussianNoise;

    #[test]
    fn quiet_on_white_noise_fires_on_a_variance_step() {
        let ts = 1e-4;
        let mut d = ChangeDetector::<f64>::new(&TrackingConfig::default(), ts);
        let mut n = GaussianNoise::<f64>::new(0.05, 7).unwrap();
        // 60 s of white noise at 5% of Y0: never fires.
        for k in 0..600_000 {
            assert!(!d.push(n.sample()), "false alarm at {k}");
        }
        assert!(d.armed());
        // The clipped running mean reads the RMS ~8% low (E[min(z², 4)]).
        let r = d.reference_rms() / 0.05;
        assert!(r > 0.85 && r < 1.0, "{r}");
        // The RMS triples: detected within a few ms.
        let at = (0..1000).position(|_| d.push(3.0 * n.sample())).unwrap();
        assert!(at < 100, "{at}");
        assert!(!d.armed());
    }

    #[test]
    fn floor_and_disabled() {
        let mut d = ChangeDetector::<f32>::new(&TrackingConfig::default(), 1e-4);
        // Noise-free residuals far below the floor never fire, a jump to a
        // few floors does, within a millisecond.
        for k in 0..100_000 {
            let e = 1e-6 * if k % 2 == 0 { 1.0 } else { -1.0 };
            assert!(!d.push(e));
        }
        let at = (0..100).position(|_| d.push(1e-2)).unwrap();
        assert!(at < 10, "{at}");
        let mut off = ChangeDetector::<f32>::new(&TrackingConfig::OFF, 1e-4);
        assert!((0..100_000).all(|_| !off.push(1.0)));
        assert!(!off.armed());
        assert!(!TrackingConfig::OFF.enabled());
    }
}
