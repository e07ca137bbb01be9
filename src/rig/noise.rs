//! Seeded, deterministic white Gaussian noise for the simulated rig (the
//! measurement noise on y), `no_std` and allocation-free, so `beamctl
//! simulate`, the host tests and the emulated firmware draw the same
//! realisation from the same seed.
//!
//! # Design
//! * **Uniform bits: xoshiro256++** (Blackman and Vigna, *Scrambled linear
//!   pseudorandom number generators*, ACM TOMS 47(4), 2021): 256 bits of
//!   state, period 2²⁵⁶ − 1, a handful of 64-bit adds, shifts and rotations
//!   per output, and no known statistical weakness in its upper bits. It is
//!   seeded from one `u64` through SplitMix64, as its authors recommend, so
//!   nearby seeds give unrelated streams and the state is never all zero.
//!   [`Xoshiro256PlusPlus`] is tested against the reference implementation's
//!   outputs.
//! * **Gaussian: Box–Muller** in its basic form: two uniforms
//!   u₁ ∈ (0, 1], u₂ ∈ [0, 1) give the two independent N(0, 1) values
//!   √(−2 ln u₁)·cos 2πu₂ and √(−2 ln u₁)·sin 2πu₂; the second is kept for
//!   the next call. The work per pair is constant (no rejection loop, unlike
//!   the polar method), and u₁ > 0 keeps the logarithm finite: with 53-bit
//!   uniforms |z| ≤ √(2·53·ln 2) ≈ 8.57. A ziggurat would be faster but
//!   needs kilobytes of tables; the rig draws one value per 10 kHz sample.
//! * The arithmetic runs in the scalar type `T` (`libm` through [`Real`]),
//!   so an `f32` rig on a single-precision FPU never calls software `f64`
//!   maths; each type gives its own (deterministic) realisation.

use crate::scalar::Real;

/// 2⁻⁵³: the spacing of the 53-bit uniforms.
const TWO_POW_M53: f64 = 1.0 / 9_007_199_254_740_992.0;

/// Invalid noise settings.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum NoiseError {
    /// The standard deviation is negative, NaN or infinite.
    StandardDeviation,
}

impl core::fmt::Display for NoiseError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(match self {
            Self::StandardDeviation => "invalid noise standard deviation: must be finite and >= 0",
        })
    }
}

impl core::error::Error for NoiseError {}

/// The xoshiro256++ generator of uniform 64-bit words (see the module
/// documentation).
#[derive(Debug, Clone, PartialEq, Eq)]
pub(crate) struct Xoshiro256PlusPlus {
    s: [u64; 4],
}

impl Xoshiro256PlusPlus {
    /// The generator whose state is expanded from `seed` by SplitMix64 (four
    /// consecutive outputs of SplitMix64 started at `seed`).
    pub fn seed_from_u64(seed: u64) -> Self {
        let mut sm = SplitMix64(seed);
        Self {
            s: [sm.next_u64(), sm.next_u64(), sm.next_u64(), sm.next_u64()],
        }
    }

    /// The generator with this exact state. An all-zero state is a fixed
    /// point of the recurrence (it would only ever output 0), so it is
    /// replaced by the state [`seed_from_u64`](Self::seed_from_u64)`(0)`
    /// gives.
    #[cfg(test)]
    pub(crate) fn from_state(s: [u64; 4]) -> Self {
        if s == [0; 4] {
            Self::seed_from_u64(0)
        } else {
            Self { s }
        }
    }

    /// The next uniformly distributed 64-bit word.
    #[inline]
    pub(crate) fn next_u64(&mut self) -> u64 {
        let s = &mut self.s;
        let out = s[0].wrapping_add(s[3]).rotate_left(23).wrapping_add(s[0]);
        let t = s[1] << 17;
        s[2] ^= s[0];
        s[3] ^= s[1];
        s[1] ^= s[2];
        s[0] ^= s[3];
        s[2] ^= t;
        s[3] = s[3].rotate_left(45);
        out
    }

    /// A uniform number in [0, 1) with 53 random bits (the upper bits of
    /// [`next_u64`](Self::next_u64), which are the best ones).
    #[inline]
    pub(crate) fn next_f64(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 * TWO_POW_M53
    }
}

/// SplitMix64 (Steele, Lea and Flood, *Fast splittable pseudorandom number
/// generators*, OOPSLA 2014), used only to expand a seed.
struct SplitMix64(u64);

impl SplitMix64 {
    fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }
}

/// Standard deviation of white noise at a signal-to-noise ratio of `snr_db`
/// decibels relative to a signal of RMS value `rms_signal`:
/// σ = rms / 10^(SNR/20). A NaN or infinite result is rejected by
/// [`GaussianNoise::new`].
pub fn noise_sd_for_snr(rms_signal: f64, snr_db: f64) -> f64 {
    rms_signal / libm::pow(10.0, snr_db / 20.0)
}

/// Zero-mean white Gaussian noise with a fixed standard deviation, from a
/// seed: the same seed gives the same sequence on every machine.
#[derive(Debug, Clone, PartialEq)]
pub struct GaussianNoise<T> {
    sd: T,
    rng: Xoshiro256PlusPlus,
    /// The second value of the last Box–Muller pair, not yet returned.
    spare: Option<T>,
}

impl<T: Real> GaussianNoise<T> {
    /// Noise of standard deviation `sd` (in the units of the signal it is
    /// added to; 0 gives exact zeros) drawn from the stream of `seed`.
    ///
    /// # Errors
    /// [`NoiseError::StandardDeviation`] if `sd` is negative, NaN or
    /// infinite.
    pub fn new(sd: f64, seed: u64) -> Result<Self, NoiseError> {
        if !(sd >= 0.0 && sd.is_finite()) {
            return Err(NoiseError::StandardDeviation);
        }
        Ok(Self {
            sd: T::from_f64(sd),
            rng: Xoshiro256PlusPlus::seed_from_u64(seed),
            spare: None,
        })
    }

    /// The standard deviation σ.
    pub fn sd(&self) -> T {
        self.sd
    }

    /// One sample of N(0, σ²).
    #[inline]
    pub fn sample(&mut self) -> T {
        if let Some(z) = self.spare.take() {
            return self.sd * z;
        }
        let (z0, z1) = self.standard_pair();
        self.spare = Some(z1);
        self.sd * z0
    }

    /// Two independent N(0, 1) values by Box–Muller.
    fn standard_pair(&mut self) -> (T, T) {
        // u1 ∈ (0, 1] (never 0: the logarithm stays finite), u2 ∈ [0, 1).
        let u1 = ((self.rng.next_u64() >> 11) + 1) as f64 * TWO_POW_M53;
        let u2 = self.rng.next_f64();
        let two = T::ONE + T::ONE;
        let radius = (-two * T::from_f64(u1).ln()).sqrt();
        let angle = T::from_f64(core::f64::consts::TAU) * T::from_f64(u2);
        (radius * angle.cos(), radius * angle.sin())
    }
}

#[cfg(test)]
#[allow(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::panic,
    clippy::indexing_slicing
)]
mod tests {
    use super::*;
    use std::vec::Vec;

    #[test]
    fn xoshiro_matches_the_reference_implementation() {
        // Outputs of the authors' xoshiro256plusplus.c from state [1, 2, 3, 4].
        let mut rng = Xoshiro256PlusPlus::from_state([1, 2, 3, 4]);
        let expected: [u64; 6] = [
            41_943_041,
            58_720_359,
            3_588_806_011_781_223,
            3_591_011_842_654_386,
            9_228_616_714_210_784_205,
            9_973_669_472_204_895_162,
        ];
        for e in expected {
            assert_eq!(rng.next_u64(), e);
        }
        // Outputs of the authors' splitmix64.c from this seed.
        let mut sm = SplitMix64(1_477_776_061_723_855_037);
        for e in [
            1_985_237_415_132_408_290u64,
            2_979_275_885_539_914_483,
            13_511_426_838_097_143_398,
        ] {
            assert_eq!(sm.next_u64(), e);
        }
        // The all-zero state would be stuck at zero.
        let mut z = Xoshiro256PlusPlus::from_state([0; 4]);
        assert_ne!(z.next_u64() | z.next_u64(), 0);
    }

    fn draw<T: Real>(sd: f64, seed: u64, n: usize) -> Vec<f64> {
        let mut g = GaussianNoise::<T>::new(sd, seed).unwrap();
        (0..n).map(|_| g.sample().to_f64()).collect()
    }

    /// Mean, variance, skewness and excess kurtosis of `x`.
    fn moments(x: &[f64]) -> (f64, f64, f64, f64) {
        let n = x.len() as f64;
        let mean = x.iter().sum::<f64>() / n;
        let m = |p: i32| x.iter().map(|v| (v - mean).powi(p)).sum::<f64>() / n;
        let var = m(2);
        (mean, var, m(3) / var.powf(1.5), m(4) / (var * var) - 3.0)
    }

    fn correlation(a: &[f64], b: &[f64]) -> f64 {
        let n = a.len().min(b.len());
        let (a, b) = (&a[..n], &b[..n]);
        let ma = a.iter().sum::<f64>() / n as f64;
        let mb = b.iter().sum::<f64>() / n as f64;
        let mut sab = 0.0;
        let mut saa = 0.0;
        let mut sbb = 0.0;
        for (x, y) in a.iter().zip(b) {
            sab += (x - ma) * (y - mb);
            saa += (x - ma) * (x - ma);
            sbb += (y - mb) * (y - mb);
        }
        sab / (saa * sbb).sqrt()
    }

    // The statistical tests use N = 200 000 samples and 5-standard-error
    // bounds, so each fails by chance with probability < 1e-6; the streams
    // are deterministic, so they pass or fail the same way every run.
    const N: usize = 200_000;

    fn check_gaussian<T: Real>(sd: f64, seed: u64) {
        let x = draw::<T>(sd, seed, N);
        let n = N as f64;
        let (mean, var, skew, kurt) = moments(&x);
        assert!(mean.abs() < 5.0 * sd / n.sqrt(), "{}: mean {mean}", T::NAME);
        assert!(
            (var / (sd * sd) - 1.0).abs() < 5.0 * (2.0 / n).sqrt(),
            "{}: variance {var}",
            T::NAME
        );
        assert!(skew.abs() < 5.0 * (6.0 / n).sqrt(), "skewness {skew}");
        assert!(
            kurt.abs() < 5.0 * (24.0 / n).sqrt(),
            "excess kurtosis {kurt}"
        );
        // Probability mass within 1, 2, 3 σ (Φ-based), binomial 5σ bounds.
        for (k, p) in [
            (1.0, 0.682_689_49),
            (2.0, 0.954_499_74),
            (3.0, 0.997_300_20),
        ] {
            let inside = x.iter().filter(|v| v.abs() < k * sd).count() as f64 / n;
            let se = (p * (1.0 - p) / n).sqrt();
            assert!((inside - p).abs() < 5.0 * se, "{k}σ: {inside} vs {p}");
        }
        // Independence: lag-1..3 autocorrelation, and between the two
        // members of each Box–Muller pair (even vs odd samples).
        for lag in 1..=3 {
            let r = correlation(&x[..N - lag], &x[lag..]);
            assert!(r.abs() < 5.0 / n.sqrt(), "lag {lag}: {r}");
        }
        let even: Vec<f64> = x.iter().step_by(2).copied().collect();
        let odd: Vec<f64> = x.iter().skip(1).step_by(2).copied().collect();
        let r = correlation(&even, &odd);
        assert!(r.abs() < 5.0 / (n / 2.0).sqrt(), "pairs: {r}");
        // Squares are uncorrelated too (a dependence the mean and plain
        // correlations cannot see).
        let sq: Vec<f64> = x.iter().map(|v| v * v).collect();
        let r = correlation(&sq[..N - 1], &sq[1..]);
        assert!(r.abs() < 5.0 / n.sqrt(), "squares lag 1: {r}");
    }

    #[test]
    fn samples_have_the_moments_and_mass_of_a_gaussian() {
        check_gaussian::<f64>(2.5e-3, 1);
        check_gaussian::<f32>(1.0, 7);
    }

    #[test]
    fn streams_are_deterministic_and_seed_dependent() {
        let a = draw::<f64>(1.0, 42, 1000);
        assert_eq!(a, draw::<f64>(1.0, 42, 1000));
        let b = draw::<f64>(1.0, 43, 1000);
        assert_ne!(a, b);
        // Seeds 42 and 43 are not shifted copies of each other.
        assert!(correlation(&a, &b).abs() < 5.0 / (1000f64).sqrt());
        assert!(correlation(&a[1..], &b).abs() < 5.0 / (1000f64).sqrt());
        // σ scales the same standard stream exactly.
        let c = draw::<f64>(2.0, 42, 1000);
        assert!(a.iter().zip(&c).all(|(x, y)| 2.0 * x == *y));
        // σ = 0 is allowed and silent.
        assert!(draw::<f32>(0.0, 5, 100).iter().all(|v| *v == 0.0));
    }

    #[test]
    fn invalid_settings_are_rejected() {
        for sd in [-1.0, f64::NAN, f64::INFINITY] {
            assert_eq!(
                GaussianNoise::<f64>::new(sd, 1).err(),
                Some(NoiseError::StandardDeviation)
            );
        }
        assert_eq!(noise_sd_for_snr(2.0, 20.0), 0.2);
        assert!((noise_sd_for_snr(1.0, 60.0) - 1e-3).abs() < 1e-18);
        assert!(GaussianNoise::<f64>::new(noise_sd_for_snr(1.0, f64::NAN), 1).is_err());
    }
}
