//! Statistics of the start-up window: the signal scales U0, Y0 (RMS of u
//! and y) and a noise-corrected frequency centroid of y, from which the
//! first filter pole is taken when the user gives no band.
//!
//! # Design
//! * **Scales are RMS values.** They only condition the regression (the
//!   fixed point PΘ = Q is invariant under any diagonal rescaling of φ, see
//!   [`super`]), so a typical magnitude is all that is needed. The RMS
//!   includes the mean: it is what the filters see.
//! * **Frequency centroid ω_c**, the frequency of the sine with the same
//!   ratio of difference variance to variance: with r = var(y_k −
//!   y_{k−m})/var(y), ω_c = 2·asin(√r/2)/(m·Ts) (exact for a sine; for a
//!   broadband y an RMS-frequency-like centroid). Differences are taken
//!   over m = [`lag_samples`] samples (1 ms), not one: the signal's share
//!   grows as m² while white noise adds the same 2σ² at any lag. σ² is
//!   estimated from third differences of consecutive samples, whose
//!   variance is 20σ² for white noise and only (ωTs)⁶·var(y) for the signal
//!   (1e-6 of var(y) at ωTs = 0.1), and removed from both variances.
//! * Everything is accumulated in `f64`: a handful of operations per sample,
//!   and only during the start-up window.

/// Running sums over the start-up window.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StartupStats {
    /// Accepted samples.
    n: u32,
    /// Rejected (non-finite) samples.
    rejected: u32,
    sum_u2: f64,
    sum_y: f64,
    sum_y2: f64,
    /// Lag-m differences y_k − y_{k−m}, squared.
    n_d1: u32,
    sum_d1: f64,
    /// Difference lag m (samples).
    lag: usize,
    /// The last `lag` accepted y (ring) and how many are valid.
    ring: [f64; MAX_LAG],
    ring_len: usize,
    ring_pos: usize,
    /// Third differences Δ³y, squared.
    n_d3: u32,
    sum_d3: f64,
    /// The last three accepted y (newest last) and how many are valid.
    hist: [f64; 3],
    hist_len: u8,
}

/// Longest difference lag (samples).
pub const MAX_LAG: usize = 16;

/// The difference lag m for the centroid: 1 ms in samples, 1..=[`MAX_LAG`].
pub fn lag_samples(ts_s: f64) -> usize {
    let m = libm::round(1e-3 / ts_s);
    if m.is_finite() && m >= 1.0 {
        (m as usize).min(MAX_LAG)
    } else {
        1
    }
}

impl StartupStats {
    /// Empty sums, for samples `ts_s` apart.
    pub fn new(ts_s: f64) -> Self {
        Self {
            n: 0,
            rejected: 0,
            sum_u2: 0.0,
            sum_y: 0.0,
            sum_y2: 0.0,
            n_d1: 0,
            sum_d1: 0.0,
            lag: lag_samples(ts_s),
            ring: [0.0; MAX_LAG],
            ring_len: 0,
            ring_pos: 0,
            n_d3: 0,
            sum_d3: 0.0,
            hist: [0.0; 3],
            hist_len: 0,
        }
    }

    /// Add one sample. A non-finite u or y is not used (and breaks the
    /// difference chain, so no difference spans it); returns whether the
    /// sample was accepted.
    pub fn push(&mut self, u: f64, y: f64) -> bool {
        if !(u.is_finite() && y.is_finite()) {
            self.rejected = self.rejected.saturating_add(1);
            self.hist_len = 0;
            self.ring_len = 0;
            return false;
        }
        self.n = self.n.saturating_add(1);
        self.sum_u2 += u * u;
        self.sum_y += y;
        self.sum_y2 += y * y;
        let [y3, y2, y1] = self.hist; // y_{k−3}, y_{k−2}, y_{k−1}
                                      // The ring's slot at ring_pos holds y_{k−m} once it is full.
        if self.ring_len >= self.lag {
            let d = y - self.ring[self.ring_pos];
            self.n_d1 += 1;
            self.sum_d1 += d * d;
        }
        self.ring[self.ring_pos] = y;
        self.ring_pos = (self.ring_pos + 1) % self.lag;
        self.ring_len = (self.ring_len + 1).min(self.lag);
        if self.hist_len >= 3 {
            // Δ³y_k = y_k − 3y_{k−1} + 3y_{k−2} − y_{k−3}
            let d3 = y - 3.0 * y1 + 3.0 * y2 - y3;
            self.n_d3 += 1;
            self.sum_d3 += d3 * d3;
        }
        self.hist = [y2, y1, y];
        self.hist_len = (self.hist_len + 1).min(3);
        true
    }

    /// Accepted samples so far.
    pub fn samples(&self) -> u32 {
        self.n
    }

    /// Rejected (non-finite) samples so far.
    pub fn rejected(&self) -> u32 {
        self.rejected
    }

    /// RMS of the accepted u (0 before the first sample).
    pub(crate) fn u_rms(&self) -> f64 {
        if self.n == 0 {
            0.0
        } else {
            libm::sqrt(self.sum_u2 / f64::from(self.n))
        }
    }

    /// RMS of the accepted y, mean included (0 before the first sample).
    pub fn y_rms(&self) -> f64 {
        if self.n == 0 {
            0.0
        } else {
            libm::sqrt(self.sum_y2 / f64::from(self.n))
        }
    }

    /// Estimated white-noise variance σ² of y (from third differences).
    pub(crate) fn noise_variance(&self) -> f64 {
        if self.n_d3 == 0 {
            0.0
        } else {
            self.sum_d3 / (20.0 * f64::from(self.n_d3))
        }
    }

    /// Noise-corrected frequency centroid of y in rad/s (see the module
    /// docs), or `None` if y has no measurable variation above its noise.
    pub fn centroid_rad_s(&self, ts_s: f64) -> Option<f64> {
        if self.n < 2 || self.n_d1 == 0 || !(ts_s > 0.0) {
            return None;
        }
        let n = f64::from(self.n);
        let mean = self.sum_y / n;
        let var_y = self.sum_y2 / n - mean * mean;
        let s2 = self.noise_variance();
        let var_d = self.sum_d1 / f64::from(self.n_d1) - 2.0 * s2;
        let var_sig = var_y - s2;
        if !(var_d > 0.0 && var_sig > 0.0) {
            return None;
        }
        // var(Δ_m)/var = 4·sin²(ωmTs/2) for a sine; above 4 (no sine fits)
        // the estimate saturates at the Nyquist-like ωmTs = π.
        let half = libm::sqrt((var_d / var_sig).min(4.0)) / 2.0;
        let w = 2.0 * libm::asin(half) / (self.lag as f64 * ts_s);
        (w.is_finite() && w > 0.0).then_some(w)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rms_and_centroid_of_a_sine() {
        // y = sin(ωt): RMS 1/√2, centroid ω (the window is not a whole
        // number of periods: 1e-3).
        let (ts, w) = (1e-4, 200.0);
        let mut s = StartupStats::new(ts);
        for k in 0..20_000 {
            let t = k as f64 * ts;
            assert!(s.push(0.5, libm::sin(w * t)));
        }
        assert!((s.u_rms() - 0.5).abs() < 1e-12);
        assert!((s.y_rms() - core::f64::consts::FRAC_1_SQRT_2).abs() < 1e-3);
        let c = s.centroid_rad_s(ts).unwrap();
        assert!((c / w - 1.0).abs() < 2e-3, "{c}");
    }

    #[test]
    fn centroid_ignores_white_noise() {
        // Deterministic white-ish noise (an LCG), σ = 0.05 on a unit sine:
        // uncorrected, 2σ²/Ts² would move the centroid from 200 to ~730 rad/s.
        let (ts, w) = (1e-4, 200.0);
        let mut s = StartupStats::new(ts);
        let mut state: u64 = 12345;
        for k in 0..20_000 {
            let mut acc = 0.0;
            for _ in 0..12 {
                state = state
                    .wrapping_mul(6364136223846793005)
                    .wrapping_add(1442695040888963407);
                acc += (state >> 11) as f64 / (1u64 << 53) as f64;
            }
            let noise = 0.05 * (acc - 6.0);
            s.push(0.0, libm::sin(w * k as f64 * ts) + noise);
        }
        let c = s.centroid_rad_s(ts).unwrap();
        assert!((c / w - 1.0).abs() < 0.1, "{c}");
        assert!((libm::sqrt(s.noise_variance()) / 0.05 - 1.0).abs() < 0.05);
    }

    #[test]
    fn non_finite_samples_are_counted_and_skipped() {
        let mut s = StartupStats::new(1e-4);
        assert!(!s.push(f64::NAN, 1.0));
        assert!(!s.push(1.0, f64::INFINITY));
        assert!(s.push(2.0, 1.0));
        assert_eq!((s.samples(), s.rejected()), (1, 2));
        assert_eq!(s.u_rms(), 2.0);
        // One sample: no centroid; a constant: none either.
        assert_eq!(s.centroid_rad_s(1e-4), None);
        for _ in 0..10 {
            s.push(2.0, 1.0);
        }
        assert_eq!(s.centroid_rad_s(1e-4), None);
    }
}
