//! Modal recovery: transfer function (eq. 25–26) or parameter vector Θ
//! (eq. 29) → natural frequencies ω_i, damping ratios ζ_i and modal gains
//! b̄_i (eq. 30–32), generalised from the paper's two modes to
//! n = 1..=[`MAX_MODES`]. (The excitation monitor of Lemma 1 is
//! [`crate::supervise::excitation_min_eig`].)
//!
//! One concept per file:
//! * this file: poles → ω, ζ ([`modes_from_denominator`]) and the entry
//!   points that chain the steps ([`modal_from_tf`], [`modal_from_tf_weighted`],
//!   [`modal_from_theta`]);
//! * `gains`: the numerator → b̄ least-squares solver of eq. 31–32
//!   (`gains_from_numerator`, [`GainWeighting`]);
//! * `validity`: physical bounds of an estimate ([`Validity`]) and what
//!   to report when it is not physical ([`ModalHold`]).
//!
//! # Method
//! 1. **Poles (eq. 30).** The roots of A(s) = s^{2n} + a_{2n−1}s^{2n−1} + … + a_0
//!    are found with [`crate::poly::roots_monic`] (exact power-of-two scaling of
//!    s, Aberth–Ehrlich, conjugate symmetrisation). A conjugate pair p, p̄ is
//!    the mode q(s) = s² + 2ζω·s + ω² with ω = |p|, ζ = −Re p/|p|.
//!    Real roots (over-damped modes, or an estimate in transit) are sorted and
//!    taken in adjacent pairs r₁ ≤ r₂: ω = √(r₁r₂), ζ = −(r₁ + r₂)/(2ω) (so
//!    |ζ| ≥ 1). Sorting first makes every pair same-signed whenever that is
//!    possible at all; if it is not (an odd number of roots in the open left
//!    half plane among the real ones, or a root at s = 0) no real mode
//!    polynomial with ω > 0 fits and [`ModalError::RealRootPairIndefinite`] is
//!    returned. Right-half-plane poles give ζ < 0: that is reported, not an
//!    error (see [`Modes::is_stable`], [`is_stable`]). Modes are sorted by ω
//!    ascending; `output_weight[i]` belongs to the i-th mode in that order
//!    (the paper's C̄ = [−2, 2] puts −2 on the lower mode).
//! 2. **Gains (eq. 31–32).** B(s) = Σ_i c_i·b̄_i·Π_{j≠i} q_j(s) is linear in
//!    b̄ and solved in the least-squares (Moore–Penrose) sense like eq. 32;
//!    see `gains` for the weighting and the solver.
//!
//! Everything is fixed-size, allocation-free and panic-free; NaN or
//! infinite input is [`ModalError::NonFinite`].

pub(crate) mod gains;
pub(crate) mod validity;

pub(crate) use gains::gains_from_numerator;
pub use gains::GainWeighting;
pub use validity::{ModalHold, Reported, Validity};

use crate::model::{ModalParams, TransferFunction, MAX_MODES, MAX_ORDER};
use crate::poly::{roots_monic, PolyError};
use crate::scalar::Real;

/// Why modal parameters could not be recovered.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum ModalError {
    /// The number of modes is 0 or exceeds [`MAX_MODES`].
    InvalidModeCount,
    /// A slice has the wrong length for the number of modes (output weights
    /// ≠ n, numerator ≠ 2n − 1, denominator odd, or Θ ≠ 4n − 1).
    LengthMismatch,
    /// A coefficient, output weight or Θ entry is NaN or infinite, or a
    /// recovered ω, ζ overflowed (coefficients near the type's maximum).
    NonFinite,
    /// The root finder failed (see [`PolyError`]).
    Roots(PolyError),
    /// Some poles are real and cannot be grouped into real mode polynomials
    /// s² + 2ζω·s + ω² with ω > 0: after sorting, an adjacent pair has
    /// r₁·r₂ ≤ 0 (one pole in each half plane, or a pole at s = 0, e.g.
    /// a_0 = 0).
    RealRootPairIndefinite,
    /// The gain matrix M of eq. 31 is numerically rank-deficient (two
    /// coinciding modes, or a zero output weight), so b̄ is not determined.
    GainsRankDeficient,
}

impl From<PolyError> for ModalError {
    fn from(e: PolyError) -> Self {
        ModalError::Roots(e)
    }
}

impl core::fmt::Display for ModalError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Self::InvalidModeCount => write!(f, "invalid mode count: must be 1..={MAX_MODES}"),
            Self::LengthMismatch => f.write_str(
                "slice length does not match the mode count (weights n, numerator 2n-1, denominator 2n, theta 4n-1)",
            ),
            Self::NonFinite => {
                f.write_str("coefficient, output weight or recovered omega/zeta is not finite")
            }
            Self::Roots(e) => write!(f, "poles not found: {e}"),
            Self::RealRootPairIndefinite => f.write_str(
                "real poles cannot be paired into modes (one in each half plane, or at s = 0)",
            ),
            Self::GainsRankDeficient => {
                f.write_str("modal gains bbar undetermined: gain matrix (eq. 31) is rank-deficient")
            }
        }
    }
}

impl core::error::Error for ModalError {
    fn source(&self) -> Option<&(dyn core::error::Error + 'static)> {
        match self {
            Self::Roots(e) => Some(e),
            _ => None,
        }
    }
}

/// Natural frequencies and damping ratios of n modes (eq. 30, generalised),
/// sorted by ω ascending.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Modes<T> {
    /// Number of modes n (1..=[`MAX_MODES`]).
    pub count: usize,
    /// Natural frequencies ω_i > 0 in rad/s, ascending.
    pub omega_rad_s: [T; MAX_MODES],
    /// Damping ratios ζ_i (negative for right-half-plane poles, |ζ| ≥ 1 for
    /// a mode made of two real poles).
    pub zeta: [T; MAX_MODES],
    /// True where the mode was formed from two real poles (over-damped, or
    /// an estimate that has not yet become oscillatory).
    pub real_poles: [bool; MAX_MODES],
}

impl<T: Real> Modes<T> {
    /// True if every mode has ζ > 0 (all poles in the open left half plane).
    pub fn is_stable(&self) -> bool {
        self.zeta[..self.count.min(MAX_MODES)]
            .iter()
            .all(|&z| z > T::ZERO)
    }

    /// True if any mode was formed from two real poles.
    pub fn any_real_poles(&self) -> bool {
        self.real_poles[..self.count.min(MAX_MODES)]
            .iter()
            .any(|&r| r)
    }
}

/// True if every mode of `m` has ω > 0 and ζ > 0 (finite), i.e. the model is
/// asymptotically stable. Use it on the output of [`modal_from_tf`], which
/// accepts unstable estimates (ζ < 0).
pub fn is_stable<T: Real>(m: &ModalParams<T>) -> bool {
    let n = m.modes.min(MAX_MODES);
    (0..n).all(|i| {
        let (w, z) = (m.omega_rad_s[i], m.zeta[i]);
        w.is_finite() && z.is_finite() && w > T::ZERO && z > T::ZERO
    })
}

/// ω_i, ζ_i from the denominator coefficients `a = [a_{2n−1}, …, a_0]`
/// (highest power first, monic s^{2n} implied; eq. 25, 30), n = `a.len()/2`.
///
/// # Errors
/// [`ModalError::LengthMismatch`] for an odd length,
/// [`ModalError::InvalidModeCount`] for n ∉ 1..=[`MAX_MODES`],
/// [`ModalError::NonFinite`], [`ModalError::Roots`],
/// [`ModalError::RealRootPairIndefinite`] (see the module documentation).
pub fn modes_from_denominator<T: Real>(a: &[T]) -> Result<Modes<T>, ModalError> {
    if a.len() % 2 != 0 {
        return Err(ModalError::LengthMismatch);
    }
    let n = a.len() / 2;
    if n == 0 || n > MAX_MODES {
        return Err(ModalError::InvalidModeCount);
    }
    if a.iter().any(|v| !v.is_finite()) {
        return Err(ModalError::NonFinite);
    }
    let roots = roots_monic(a)?;
    let two = T::ONE + T::ONE;
    let mut out = Modes {
        count: n,
        omega_rad_s: [T::ZERO; MAX_MODES],
        zeta: [T::ZERO; MAX_MODES],
        real_poles: [false; MAX_MODES],
    };
    let mut k = 0; // modes filled
    let mut reals = [T::ZERO; MAX_ORDER];
    let mut nr = 0;
    let r = roots.as_slice();
    let mut i = 0;
    while i < r.len() {
        let p = r[i];
        if p.im != T::ZERO {
            // Upper member of a conjugate pair (the next entry is its
            // conjugate, see `poly::Roots`).
            if k >= MAX_MODES {
                return Err(ModalError::Roots(PolyError::NoConvergence));
            }
            let w = p.norm();
            out.omega_rad_s[k] = w;
            out.zeta[k] = -p.re / w;
            k += 1;
            i += 2;
        } else {
            reals[nr] = p.re;
            nr += 1;
            i += 1;
        }
    }
    // Real roots: sort, pair adjacent ones.
    for x in 1..nr {
        let mut y = x;
        while y > 0 && reals[y] < reals[y - 1] {
            reals.swap(y, y - 1);
            y -= 1;
        }
    }
    let mut j = 0;
    while j + 1 < nr {
        let (r1, r2) = (reals[j], reals[j + 1]);
        let same_sign = (r1 < T::ZERO && r2 < T::ZERO) || (r1 > T::ZERO && r2 > T::ZERO);
        if !same_sign || k >= MAX_MODES {
            return Err(ModalError::RealRootPairIndefinite);
        }
        // √(r1·r2) without overflow.
        let w = r1.abs().sqrt() * r2.abs().sqrt();
        out.omega_rad_s[k] = w;
        out.zeta[k] = -(r1 + r2) / (two * w);
        out.real_poles[k] = true;
        k += 1;
        j += 2;
    }
    if k != n || j != nr {
        // Cannot happen for a conjugate-symmetric root set of even degree.
        return Err(ModalError::Roots(PolyError::NoConvergence));
    }
    // Sort modes by ω ascending (insertion sort, n ≤ 3).
    for x in 1..n {
        let mut y = x;
        while y > 0 && out.omega_rad_s[y] < out.omega_rad_s[y - 1] {
            out.omega_rad_s.swap(y, y - 1);
            out.zeta.swap(y, y - 1);
            out.real_poles.swap(y, y - 1);
            y -= 1;
        }
    }
    // Overflow guard (only reachable with coefficients near T::MAX).
    for i in 0..n {
        let (w, z) = (out.omega_rad_s[i], out.zeta[i]);
        if !(w > T::ZERO) || !w.is_finite() || !z.is_finite() {
            return Err(ModalError::NonFinite);
        }
    }
    Ok(out)
}

/// Modal parameters from a transfer function (eq. 25–32, n modes):
/// poles → ω, ζ ([`modes_from_denominator`]), then b̄ by the Moore–Penrose
/// least-squares solution of eq. 31–32 (`gains_from_numerator`).
/// `output_weight` holds c_i for the modes in ascending-ω order (length n;
/// the paper's two-mode beam uses [−2, 2]); it is copied into the result.
///
/// b̄ uses the paper's weighting ([`GainWeighting::Paper`]); see
/// [`modal_from_tf_weighted`] for the alternative.
///
/// Unstable estimates (ζ < 0) are returned; check [`is_stable`].
///
/// # Errors
/// See [`ModalError`]; no input (NaN, zero, huge) panics.
pub fn modal_from_tf<T: Real>(
    tf: &TransferFunction<T>,
    output_weight: &[T],
) -> Result<ModalParams<T>, ModalError> {
    modal_from_tf_weighted(tf, output_weight, GainWeighting::Paper)
}

/// [`modal_from_tf`] with a choice of least-squares weighting for b̄
/// (identical results when the numerator is consistent with the poles).
///
/// # Errors
/// See [`ModalError`].
pub fn modal_from_tf_weighted<T: Real>(
    tf: &TransferFunction<T>,
    output_weight: &[T],
    weighting: GainWeighting,
) -> Result<ModalParams<T>, ModalError> {
    let n = tf.modes;
    if n == 0 || n > MAX_MODES {
        return Err(ModalError::InvalidModeCount);
    }
    if output_weight.len() != n {
        return Err(ModalError::LengthMismatch);
    }
    let d = 2 * n;
    if !tf.a[..d].iter().all(|v| v.is_finite())
        || !tf.b[..d - 1].iter().all(|v| v.is_finite())
        || !output_weight.iter().all(|v| v.is_finite())
    {
        return Err(ModalError::NonFinite);
    }
    let modes = modes_from_denominator(&tf.a[..d])?;
    let bbar = gains_from_numerator(&modes, &tf.b[..d - 1], output_weight, weighting)?;
    let mut c = [T::ZERO; MAX_MODES];
    c[..n].copy_from_slice(output_weight);
    Ok(ModalParams {
        modes: n,
        omega_rad_s: modes.omega_rad_s,
        zeta: modes.zeta,
        bbar,
        output_weight: c,
    })
}

/// Modal parameters straight from the estimator's Θ (eq. 29) for the filter
/// Λ(s) = (s + λ)^{2n}: Θ → (a, b) by
/// [`TransferFunction::from_theta`], then [`modal_from_tf`].
/// `theta.len()` must be 4n − 1 and `output_weight.len()` n.
///
/// # Errors
/// [`ModalError::LengthMismatch`] for a Θ of invalid length, otherwise as
/// [`modal_from_tf`] (a non-finite λ or Θ gives [`ModalError::NonFinite`]).
pub fn modal_from_theta<T: Real>(
    theta: &[T],
    lambda_rad_s: f64,
    output_weight: &[T],
) -> Result<ModalParams<T>, ModalError> {
    let tf = TransferFunction::from_theta(theta, lambda_rad_s).ok_or(ModalError::LengthMismatch)?;
    modal_from_tf(&tf, output_weight)
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::model::{paper_plant_tf, poly_mul_quadratic};

    pub(crate) fn rel(a: f64, b: f64) -> f64 {
        ((a - b) / b).abs()
    }

    fn check_round_trip<T: Real>(w: &[f64], z: &[f64], bb: &[f64], tol: f64) -> f64 {
        let n = w.len();
        let t = |v: &[f64]| -> [T; MAX_MODES] {
            let mut o = [T::ZERO; MAX_MODES];
            for (oi, vi) in o.iter_mut().zip(v) {
                *oi = T::from_f64(*vi);
            }
            o
        };
        let (wt, zt, bt) = (t(w), t(z), t(bb));
        let m = ModalParams::new(&wt[..n], &zt[..n], &bt[..n], None).unwrap();
        let tf = m.transfer_function();
        let back = modal_from_tf(&tf, &m.output_weight[..n]).unwrap();
        assert_eq!(back.modes, n);
        let mut worst = 0.0f64;
        for i in 0..n {
            for (got, want) in [
                (back.omega_rad_s[i], w[i]),
                (back.zeta[i], z[i]),
                (back.bbar[i], bb[i]),
            ] {
                let e = rel(got.to_f64(), want);
                assert!(
                    e <= tol,
                    "{}: mode {i}: got {got:?} want {want} (rel {e:e})",
                    T::NAME
                );
                worst = worst.max(e);
            }
        }
        assert!(is_stable(&back));
        worst
    }

    pub(crate) const PW: [f64; 2] = [39.1533, 245.3711];
    pub(crate) const PZ: [f64; 2] = [0.0207, 0.13];
    pub(crate) const PB: [f64; 2] = [9.6293, 16.1458];

    #[test]
    fn paper_plant_round_trip_f64_f32() {
        check_round_trip::<f64>(&PW, &PZ, &PB, 1e-12);
        check_round_trip::<f32>(&PW, &PZ, &PB, 1e-5);
    }

    #[test]
    fn paper_plant_eq46_numerator_gives_reference_bbar() {
        // b from eq. 46 is not exactly in the range of M: this is eq. 32's
        // Moore–Penrose answer, b̄ = [9.6293, 16.1458] (`PB`, the reference
        // b̄ of the paper's plant used throughout the repository).
        let tf = paper_plant_tf();
        let m = modal_from_tf(&tf, &[-2.0, 2.0]).unwrap();
        for i in 0..2 {
            assert!(rel(m.omega_rad_s[i], PW[i]) < 1e-12);
            assert!(rel(m.zeta[i], PZ[i]) < 1e-12);
            assert!(rel(m.bbar[i], PB[i]) < 1e-4, "b̄{i} = {}", m.bbar[i]);
        }
        // Same through Θ, and in f32.
        let mut th = [0.0; 7];
        tf.to_theta(100.0, &mut th).unwrap();
        let m2 = modal_from_theta(&th, 100.0, &[-2.0, 2.0]).unwrap();
        for i in 0..2 {
            assert!(rel(m2.bbar[i], PB[i]) < 1e-4);
            assert!(rel(m2.zeta[i], PZ[i]) < 1e-9);
        }
        let th32 = th.map(|v| v as f32);
        let m3 = modal_from_theta(&th32, 100.0, &[-2.0f32, 2.0]).unwrap();
        for i in 0..2 {
            assert!(rel(m3.omega_rad_s[i] as f64, PW[i]) < 1e-5);
            assert!(
                rel(m3.bbar[i] as f64, PB[i]) < 1e-3,
                "f32 b̄{i} = {}",
                m3.bbar[i]
            );
        }
    }

    #[test]
    fn one_and_three_mode_round_trips() {
        check_round_trip::<f64>(&[12.5], &[0.05], &[3.0], 1e-13);
        check_round_trip::<f32>(&[12.5], &[0.05], &[3.0], 1e-6);
        let (w, z, b) = ([39.16, 245.4, 687.2], [0.02, 0.13, 0.05], [9.6, 16.1, -4.2]);
        check_round_trip::<f64>(&w, &z, &b, 1e-11);
        // In f32 the forward map itself (`transfer_function`) loses ~1e-4 of
        // b̄₃: the numerator coefficients are sums of cancelling terms.
        check_round_trip::<f32>(&w, &z, &b, 1e-3);
        // Wide spread (ratio 100), light damping.
        check_round_trip::<f64>(
            &[10.0, 100.0, 1000.0],
            &[0.001, 0.01, 0.5],
            &[1.0, 2.0, 3.0],
            1e-10,
        );
    }

    #[test]
    fn over_damped_and_unstable_modes() {
        // (s+2)(s+8) = s² + 10s + 16: ω = 4, ζ = 1.25; with a lightly damped mode.
        let mut tf = ModalParams::new(&[4.0f64, 50.0], &[1.25, 0.01], &[1.0, 2.0], None)
            .unwrap()
            .transfer_function();
        let m = modal_from_tf(&tf, &[-2.0, 2.0]).unwrap();
        assert!(rel(m.omega_rad_s[0], 4.0) < 1e-13 && rel(m.zeta[0], 1.25) < 1e-13);
        assert!(rel(m.bbar[0], 1.0) < 1e-12 && rel(m.bbar[1], 2.0) < 1e-12);
        let modes = modes_from_denominator(&tf.a[..4]).unwrap();
        assert_eq!(modes.real_poles[..2], [true, false]);
        assert!(modes.any_real_poles() && modes.is_stable());
        // Unstable complex pair: ζ < 0 returned, flagged.
        tf = ModalParams::new(&[4.0f64, 50.0], &[-0.1, 0.01], &[1.0, 2.0], None)
            .unwrap()
            .transfer_function();
        let m = modal_from_tf(&tf, &[-2.0, 2.0]).unwrap();
        assert!(rel(m.zeta[0], -0.1) < 1e-12);
        assert!(!is_stable(&m));
        // Real poles on both sides: (s−1)(s+3)(s²+2s+100).
        let mut den = [0.0f64; MAX_ORDER + 1];
        den[0] = 1.0;
        let len = poly_mul_quadratic(&mut den, 1, &[1.0, 2.0, -3.0]);
        poly_mul_quadratic(&mut den, len, &[1.0, 2.0, 100.0]);
        assert_eq!(
            modes_from_denominator(&den[1..5]),
            Err(ModalError::RealRootPairIndefinite)
        );
        // Two unstable real poles pair fine (ζ ≤ −1).
        let mut den = [0.0f64; MAX_ORDER + 1];
        den[0] = 1.0;
        poly_mul_quadratic(&mut den, 1, &[1.0, -5.0, 4.0]);
        let md = modes_from_denominator(&den[1..3]).unwrap();
        assert!(rel(md.omega_rad_s[0], 2.0) < 1e-14 && rel(md.zeta[0], -1.25) < 1e-14);
        assert!(!md.is_stable());
    }

    #[test]
    fn degenerate_inputs_are_errors() {
        let good = paper_plant_tf();
        let mut tf = good;
        tf.a[3] = 0.0; // a_0 = 0: a pole at s = 0
        assert_eq!(
            modal_from_tf(&tf, &[-2.0, 2.0]),
            Err(ModalError::RealRootPairIndefinite)
        );
        tf = good;
        tf.a = [0.0; MAX_ORDER];
        tf.b = [0.0; MAX_ORDER];
        assert_eq!(
            modal_from_tf(&tf, &[-2.0, 2.0]),
            Err(ModalError::RealRootPairIndefinite)
        );
        tf = good;
        tf.a[1] = f64::NAN;
        assert_eq!(modal_from_tf(&tf, &[-2.0, 2.0]), Err(ModalError::NonFinite));
        tf = good;
        tf.b[0] = f64::INFINITY;
        assert_eq!(modal_from_tf(&tf, &[-2.0, 2.0]), Err(ModalError::NonFinite));
        assert_eq!(
            modal_from_tf(&good, &[-2.0, f64::NAN]),
            Err(ModalError::NonFinite)
        );
        assert_eq!(
            modal_from_tf(&good, &[-2.0]),
            Err(ModalError::LengthMismatch)
        );
        tf = good;
        tf.modes = 0;
        assert_eq!(modal_from_tf(&tf, &[]), Err(ModalError::InvalidModeCount));
        tf.modes = 4;
        assert_eq!(
            modal_from_tf(&tf, &[1.0; 4]),
            Err(ModalError::InvalidModeCount)
        );
        // Zero output weight: b̄ undetermined.
        assert_eq!(
            modal_from_tf(&good, &[0.0, 2.0]),
            Err(ModalError::GainsRankDeficient)
        );
        // Two identical modes: M's columns are parallel.
        let twin = Modes {
            count: 2,
            omega_rad_s: [10.0f64, 10.0, 0.0],
            zeta: [0.1, 0.1, 0.0],
            real_poles: [false; MAX_MODES],
        };
        assert_eq!(
            gains_from_numerator(&twin, &[1.0, 2.0, 3.0], &[-2.0, 2.0], GainWeighting::Paper),
            Err(ModalError::GainsRankDeficient)
        );
        // A computed double pole pair (roots only √ε apart) must not panic;
        // ω and ζ are still close.
        let tf2 = ModalParams::new(&[10.0f64, 10.0], &[0.1, 0.1], &[1.0, 3.0], None)
            .unwrap()
            .transfer_function();
        if let Ok(m) = modal_from_tf(&tf2, &[-2.0, 2.0]) {
            assert!(rel(m.omega_rad_s[0], 10.0) < 1e-6 && rel(m.zeta[1], 0.1) < 1e-5);
        }
        // Θ of the wrong length / NaN λ.
        assert_eq!(
            modal_from_theta(&[0.0f64; 6], 100.0, &[1.0, 1.0]),
            Err(ModalError::LengthMismatch)
        );
        let mut th = [0.0; 7];
        good.to_theta(100.0, &mut th).unwrap();
        assert_eq!(
            modal_from_theta(&th, f64::NAN, &[-2.0, 2.0]),
            Err(ModalError::NonFinite)
        );
        // f32 NaN too.
        let mut th32 = th.map(|v| v as f32);
        th32[3] = f32::NAN;
        assert_eq!(
            modal_from_theta(&th32, 100.0, &[-2.0, 2.0]),
            Err(ModalError::NonFinite)
        );
        // Odd denominator length.
        assert_eq!(
            modes_from_denominator(&[1.0f64, 2.0, 3.0]),
            Err(ModalError::LengthMismatch)
        );
    }
}
