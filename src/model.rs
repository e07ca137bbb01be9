//! The two descriptions of the beam that the estimator links: modal
//! parameters (ω, ζ, b̄ per mode, eq. 23–24) and the rational transfer
//! function (eq. 25–26), generalised from the paper's two modes to `n`.
//!
//! For `n` modes, with output weights `c_i` (the paper's C̄ = [−2, 2] for
//! `n = 2`) and mode polynomials q_i(s) = s² + 2ζ_iω_i·s + ω_i²:
//!
//! * denominator  A(s) = Π q_i(s) = s^{2n} + a_{2n−1}s^{2n−1} + … + a_0,
//! * numerator    B(s) = Σ_i c_i·b̄_i·Π_{j≠i} q_j(s) = b_{2n−2}s^{2n−2} + … + b_0.
//!
//! For `n = 2` this is exactly eq. 26 (k̄_i = −ω_i², c̄_i = −2ζ_iω_i).
//!
//! Coefficient arrays are stored in the paper's order, highest power first:
//! `a = [a_{2n−1}, …, a_0]`, `b = [b_{2n−2}, …, b_0]`, padded to
//! [`MAX_ORDER`].

use crate::scalar::Real;
use beam_protocol::OutputKind;

/// Largest number of modes the core supports.
pub const MAX_MODES: usize = 3;
// Every model the core supports fits in the wire's estimate messages.
const _: () = assert!(MAX_MODES <= beam_protocol::MAX_MODES);
/// Largest model order (2 per mode).
pub const MAX_ORDER: usize = 2 * MAX_MODES;

/// Default output weight of mode `i` (0-based) when none is given:
/// c_i = 2·(−1)^{i+1}, i.e. [−2, 2, −2]. For two modes this is the paper's
/// C̄ = [−2, 2, 0, 0] of eq. 24.
pub fn default_output_weight(i: usize) -> f64 {
    if i % 2 == 0 {
        -2.0
    } else {
        2.0
    }
}

/// Modal parameters of an `n`-mode model (eq. 23–24).
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ModalParams<T> {
    /// Number of modes `n` (1..=[`MAX_MODES`]).
    pub modes: usize,
    /// Natural frequencies ω_i in rad/s, ascending.
    pub omega_rad_s: [T; MAX_MODES],
    /// Damping ratios ζ_i.
    pub zeta: [T; MAX_MODES],
    /// Modal input gains b̄_i = z_i/m_ii.
    pub bbar: [T; MAX_MODES],
    /// Output weights c_i (row C̄ of eq. 24).
    pub output_weight: [T; MAX_MODES],
}

/// The transfer function s^r·B(s)/A(s) of order 2n with monic denominator
/// (eq. 25, generalised): B/A of the modes as eq. 25 has it, read by a
/// sensor of the kind `output` (r = 0 for strain or displacement: strictly
/// proper, the paper's case; r = 1 velocity; r = 2 acceleration, a direct
/// term). A, B and so ω, ζ and b̄ (eqs. 30–32) do not depend on `output`.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct TransferFunction<T> {
    /// Number of modes `n`; the order is `2n`.
    pub modes: usize,
    /// Denominator coefficients `[a_{2n−1}, …, a_0]` (monic s^{2n} implied).
    pub a: [T; MAX_ORDER],
    /// Numerator coefficients `[b_{2n−2}, …, b_0]` of B (2n−1 of them).
    pub b: [T; MAX_ORDER],
    /// What the sensor measures: G = s^r·B/A with r =
    /// [`OutputKind::numerator_shift`].
    pub output: OutputKind,
}

impl<T: Real> TransferFunction<T> {
    /// Model order 2n.
    pub fn order(&self) -> usize {
        2 * self.modes
    }

    /// Number of numerator coefficients, 2n − 1 (0 for an empty model).
    #[cfg(test)]
    pub(crate) fn numerator_len(&self) -> usize {
        (2 * self.modes).saturating_sub(1)
    }

    /// Build Θ of eq. 29 for a filter Λ(s) = (s+λ)^{2n}:
    /// Θ = [b_{2n−2}, …, b_0, k_{2n−1} − a_{2n−1}, …, k_0 − a_0].
    /// `theta` must have length 4n − 1; returns `None` otherwise.
    pub fn to_theta(&self, lambda: f64, theta: &mut [T]) -> Option<()> {
        let d = self.order();
        if d == 0 || d > MAX_ORDER || theta.len() != 2 * d - 1 {
            return None;
        }
        let k = lambda_poly_in::<T>(d, lambda);
        let nb = d - 1;
        theta[..nb].copy_from_slice(&self.b[..nb]);
        for j in 0..d {
            theta[nb + j] = k[j] - self.a[j];
        }
        Some(())
    }

    /// Inverse of [`to_theta`](Self::to_theta): read a and b back from Θ.
    /// `theta.len()` must be 4n − 1 with 1 ≤ n ≤ [`MAX_MODES`]. Θ does not
    /// say what the sensor measures: `output` is [`OutputKind::Strain`]
    /// (set it if the estimator's was another; the modes and b̄ do not
    /// depend on it).
    pub fn from_theta(theta: &[T], lambda: f64) -> Option<Self> {
        let np = theta.len();
        if np < 3 || (np + 1) % 4 != 0 || (np + 1) / 4 > MAX_MODES {
            return None;
        }
        let modes = (np + 1) / 4;
        let d = 2 * modes;
        let k = lambda_poly_in::<T>(d, lambda);
        let mut tf = Self {
            modes,
            a: [T::ZERO; MAX_ORDER],
            b: [T::ZERO; MAX_ORDER],
            output: OutputKind::Strain,
        };
        let nb = d - 1;
        tf.b[..nb].copy_from_slice(&theta[..nb]);
        for j in 0..d {
            tf.a[j] = k[j] - theta[nb + j];
        }
        Some(tf)
    }

    /// Frequency response G(jω) = (jω)^r·B(jω)/A(jω) as (re, im); NaN for
    /// an empty or invalid model.
    pub fn freq_response(&self, omega_rad_s: f64) -> (f64, f64) {
        let d = self.order();
        if d == 0 || d > MAX_ORDER {
            return (f64::NAN, f64::NAN);
        }
        // Evaluate with Horner in complex arithmetic (f64).
        let (mut ar, mut ai) = (1.0f64, 0.0f64);
        for j in 0..d {
            let (r, i) = (ar * 0.0 - ai * omega_rad_s, ar * omega_rad_s + ai * 0.0);
            ar = r + self.a[j].to_f64();
            ai = i;
        }
        let (mut br, mut bi) = (0.0f64, 0.0f64);
        for j in 0..d - 1 {
            let (r, i) = (-bi * omega_rad_s, br * omega_rad_s);
            br = r + self.b[j].to_f64();
            bi = i;
        }
        // s^r at s = jω.
        for _ in 0..self.output.numerator_shift() {
            (br, bi) = (-bi * omega_rad_s, br * omega_rad_s);
        }
        let den = ar * ar + ai * ai;
        ((br * ar + bi * ai) / den, (bi * ar - br * ai) / den)
    }
}

/// Coefficients [k_{d−1}, …, k_0] of Λ(s) = (s+λ)^d (monic, binomial).
pub fn lambda_poly(d: usize, lambda: f64) -> [f64; MAX_ORDER] {
    let mut k = [0.0; MAX_ORDER];
    // k_j = C(d, j)·λ^{d−j}; stored highest power first: index i ↔ s^{d−1−i}.
    for (i, ki) in k.iter_mut().enumerate().take(d) {
        let j = d - 1 - i;
        *ki = binomial(d, j) * libm::pow(lambda, (d - j) as f64);
    }
    k
}

/// [`lambda_poly`] rounded to `T`, each coefficient C(d, j)·λ^{d−j}
/// formed by [`Real::scaled_powi_from_f64`]: in `f64` exactly the values
/// of [`lambda_poly`] (libm `pow`), in `f32` integer powers in double-word
/// single precision (no `f64` `pow`, which cost ~3 KB of flash and a
/// software-double call per recovery on the Cortex-M4F). Entries past `d`
/// are zero.
pub(crate) fn lambda_poly_in<T: Real>(d: usize, lambda: f64) -> [T; MAX_ORDER] {
    let mut k = [T::ZERO; MAX_ORDER];
    for (i, ki) in k.iter_mut().enumerate().take(d) {
        let j = d - 1 - i;
        *ki = T::scaled_powi_from_f64(lambda, (d - j) as u32, binomial_u32(d, j));
    }
    k
}

/// Binomial coefficient C(n, k) for small n (exact; C(6, 3) = 20 at most
/// here).
fn binomial_u32(n: usize, k: usize) -> u32 {
    let mut c = 1u32;
    for i in 0..k.min(n) {
        c = c * (n - i) as u32 / (i + 1) as u32;
    }
    c
}

/// Binomial coefficient C(n, k) as f64 (small n).
pub(crate) fn binomial(n: usize, k: usize) -> f64 {
    let mut c = 1.0f64;
    for i in 0..k {
        c = c * (n - i) as f64 / (i + 1) as f64;
    }
    c
}

impl<T: Real> ModalParams<T> {
    /// Build from slices (length = number of modes). Output weights default
    /// to [`default_output_weight`] when `output_weight` is `None`.
    pub fn new(
        omega_rad_s: &[T],
        zeta: &[T],
        bbar: &[T],
        output_weight: Option<&[T]>,
    ) -> Option<Self> {
        let n = omega_rad_s.len();
        if n == 0 || n > MAX_MODES || zeta.len() != n || bbar.len() != n {
            return None;
        }
        if let Some(c) = output_weight {
            if c.len() != n {
                return None;
            }
        }
        let mut m = Self {
            modes: n,
            omega_rad_s: [T::ZERO; MAX_MODES],
            zeta: [T::ZERO; MAX_MODES],
            bbar: [T::ZERO; MAX_MODES],
            output_weight: [T::ZERO; MAX_MODES],
        };
        for i in 0..n {
            m.omega_rad_s[i] = omega_rad_s[i];
            m.zeta[i] = zeta[i];
            m.bbar[i] = bbar[i];
            m.output_weight[i] = match output_weight {
                Some(c) => c[i],
                None => T::from_f64(default_output_weight(i)),
            };
        }
        Some(m)
    }

    /// Mode polynomial q_i(s) = s² + 2ζ_iω_i s + ω_i² as [1, 2ζω, ω²].
    pub(crate) fn mode_poly(&self, i: usize) -> [T; 3] {
        let w = self.omega_rad_s[i];
        let two = T::ONE + T::ONE;
        [T::ONE, two * self.zeta[i] * w, w * w]
    }

    /// Transfer function by eq. 26 generalised to n modes (a strain or
    /// displacement output; set `output` for another sensor).
    /// A `modes` outside 1..=[`MAX_MODES`] (the fields are public) is
    /// clamped; 0 gives the empty model.
    pub fn transfer_function(&self) -> TransferFunction<T> {
        let n = self.modes.min(MAX_MODES);
        if n == 0 {
            return TransferFunction {
                modes: 0,
                a: [T::ZERO; MAX_ORDER],
                b: [T::ZERO; MAX_ORDER],
                output: OutputKind::Strain,
            };
        }
        let d = 2 * n;
        // Denominator: product of all mode polynomials.
        let mut den = [T::ZERO; MAX_ORDER + 1];
        den[0] = T::ONE;
        let mut len = 1;
        for i in 0..n {
            len = poly_mul_quadratic(&mut den, len, &self.mode_poly(i));
        }
        // Numerator: Σ c_i b̄_i Π_{j≠i} q_j.
        let mut num = [T::ZERO; MAX_ORDER];
        for i in 0..n {
            let mut p = [T::ZERO; MAX_ORDER + 1];
            p[0] = T::ONE;
            let mut plen = 1;
            for j in 0..n {
                if j != i {
                    plen = poly_mul_quadratic(&mut p, plen, &self.mode_poly(j));
                }
            }
            // plen = 2n − 1 coefficients, highest first.
            let g = self.output_weight[i] * self.bbar[i];
            for k in 0..plen {
                num[k] += g * p[k];
            }
        }
        let mut tf = TransferFunction {
            modes: n,
            a: [T::ZERO; MAX_ORDER],
            b: [T::ZERO; MAX_ORDER],
            output: OutputKind::Strain,
        };
        tf.a[..d].copy_from_slice(&den[1..=d]);
        tf.b[..d - 1].copy_from_slice(&num[..d - 1]);
        tf
    }
}

/// Multiply polynomial `p` (first `len` coefficients, highest power first)
/// by a quadratic `q` in place; returns the new length `len + 2`.
pub(crate) fn poly_mul_quadratic<T: Real>(
    p: &mut [T; MAX_ORDER + 1],
    len: usize,
    q: &[T; 3],
) -> usize {
    let mut out = [T::ZERO; MAX_ORDER + 1];
    for i in 0..len {
        for (k, qk) in q.iter().enumerate() {
            if i + k < out.len() {
                out[i + k] += p[i] * *qk;
            }
        }
    }
    *p = out;
    (len + 2).min(MAX_ORDER + 1)
}

/// The paper's simulated plant (Section IV.A): Table III's true ω, ζ and the
/// numerator of eq. 46. Its denominator is rebuilt from ω, ζ (eq. 46 rounds
/// a_i to three digits, which moves ζ1 by 0.46%).
pub fn paper_plant_tf() -> TransferFunction<f64> {
    let m = ModalParams::new(&PAPER_OMEGA, &PAPER_ZETA, &[0.0, 0.0], None).expect("static");
    let mut tf = m.transfer_function();
    tf.b[..3].copy_from_slice(&PAPER_B);
    tf
}

/// Table III true natural frequencies (rad/s).
pub const PAPER_OMEGA: [f64; 2] = [39.1533, 245.3711];
/// Table III true damping ratios.
pub const PAPER_ZETA: [f64; 2] = [0.0207, 0.13];
/// Eq. 46 numerator [b2, b1, b0].
pub const PAPER_B: [f64; 3] = [13.02, -1.18e3, -1.11e6];

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn two_mode_tf_matches_eq_26() {
        let m =
            ModalParams::new(&[39.1533, 245.3711], &[0.0207, 0.13], &[9.6, 16.1], None).unwrap();
        let tf = m.transfer_function();
        let (w1, w2, z1, z2) = (39.1533f64, 245.3711f64, 0.0207f64, 0.13f64);
        let (k1, k2, c1, c2) = (-w1 * w1, -w2 * w2, -2.0 * z1 * w1, -2.0 * z2 * w2);
        let (b1, b2) = (9.6, 16.1);
        let expect_a = [-c1 - c2, -k1 - k2 + c1 * c2, c1 * k2 + k1 * c2, k1 * k2];
        let expect_b = [
            2.0 * b2 - 2.0 * b1,
            2.0 * b1 * c2 - 2.0 * b2 * c1,
            2.0 * b1 * k2 - 2.0 * b2 * k1,
        ];
        for i in 0..4 {
            assert!(
                crate::scalar::isclose(tf.a[i], expect_a[i], 1e-13, 0.0),
                "a{i}"
            );
        }
        for i in 0..3 {
            assert!(
                crate::scalar::isclose(tf.b[i], expect_b[i], 1e-13, 0.0),
                "b{i}"
            );
        }
        // Eq. 46 rounds these: a3 = 65.42, a2 = 6.18e4, a1 = 1.95e5, a0 = 9.23e7.
        assert!((tf.a[0] - 65.42).abs() < 0.01);
        assert!((tf.a[3] / 9.23e7 - 1.0).abs() < 1e-3);
    }

    #[test]
    fn theta_round_trip() {
        let tf = paper_plant_tf();
        let mut th = [0.0; 7];
        tf.to_theta(100.0, &mut th).unwrap();
        // k0 − a0 = 1e8 − a0.
        assert!((th[6] - (1e8 - tf.a[3])).abs() < 1e-6);
        let back = TransferFunction::from_theta(&th, 100.0).unwrap();
        assert_eq!(back.modes, 2);
        for i in 0..4 {
            assert!((back.a[i] - tf.a[i]).abs() <= 1e-9 * tf.a[i].abs());
        }
        assert!(TransferFunction::<f64>::from_theta(&th[..6], 100.0).is_none());
    }

    #[test]
    fn degenerate_models_do_not_panic() {
        let mut m = ModalParams::new(&[10.0], &[0.1], &[1.0], None).unwrap();
        m.modes = 0;
        let tf = m.transfer_function();
        assert_eq!(tf.modes, 0);
        assert_eq!(tf.numerator_len(), 0);
        assert!(tf.freq_response(1.0).0.is_nan());
        assert!(tf.to_theta(100.0, &mut [0.0; 3]).is_none());
        m.modes = 7;
        assert_eq!(m.transfer_function().modes, MAX_MODES);
    }

    #[test]
    fn lambda_poly_is_binomial() {
        let k = lambda_poly(4, 100.0);
        assert_eq!(&k[..4], &[400.0, 6e4, 4e6, 1e8]);
        // The typed form: bit-identical in f64, within an ulp in f32.
        for &lam in &[100.0, 164.04669, 485.2, 53.3] {
            for d in [2, 4, 6] {
                let k64 = lambda_poly(d, lam);
                assert_eq!(lambda_poly_in::<f64>(d, lam), k64);
                let k32 = lambda_poly_in::<f32>(d, lam);
                for i in 0..d {
                    let want = k64[i] as f32;
                    let ulps = (k32[i].to_bits() as i64 - want.to_bits() as i64).abs();
                    assert!(ulps <= 1, "d {d} λ {lam} k{i}: {} vs {want}", k32[i]);
                }
            }
        }
        assert_eq!(binomial_u32(6, 3), 20);
        assert_eq!(binomial_u32(4, 0), 1);
    }
}
