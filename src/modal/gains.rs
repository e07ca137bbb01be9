//! Modal gains b̄ from the numerator of the transfer function (eq. 31–32,
//! generalised to n modes), for known modes.
//!
//! # Method
//! B(s) = Σ_i c_i·b̄_i·Π_{j≠i} q_j(s) is linear in b̄: M·b̄ = b with M of size
//! (2n−1)×n, column i the coefficients of c_i·Π_{j≠i} q_j (for n = 2 exactly
//! the matrix of eq. 31). Like eq. 32 it is solved in the least-squares
//! (Moore–Penrose) sense. The row weighting matters whenever b is not
//! exactly in the range of M (an estimate, or the rounded eq. 46):
//! [`modal_from_tf`](super::modal_from_tf) uses the paper's unscaled
//! Euclidean weighting ([`GainWeighting::Paper`], which gives
//! b̄ = [9.6293, 16.1458] for eq. 46's numerator, see the test
//! `paper_plant_eq46_numerator_gives_reference_bbar`);
//! [`GainWeighting::Balanced`] weights the coefficients in the scaled
//! variable instead and is much better conditioned, which matters for three
//! modes in `f32`.
//!
//! # Design
//! * The mode polynomials are built in the scaled variable σ = s/ρ, ρ a power
//!   of two near the geometric mean of the ω_i (≈ a_0^{1/(2n)}), so every
//!   entry of M is O(1); the paper's row weighting is then re-applied as exact
//!   powers of two (normalised so the largest weight is 1). Nothing is
//!   rounded by the scaling, and `f32` does not overflow even at
//!   a_0 ≈ 10¹⁸ (three modes at 1000 rad/s).
//! * With the paper's weighting M's columns are nearly parallel (column-
//!   equilibrated cond ≈ 1.6·10³ for the paper's beam, up to ~10⁶ for three
//!   modes) and its rows strongly graded (ρ^{2n−2} between the first and the
//!   last), so normal equations would square that. Instead: column
//!   equilibration, rows sorted by decreasing size, and Householder QR with
//!   column pivoting (row-wise stable, Powell–Reid). A numerically
//!   rank-deficient M (two identical modes, a zero output weight, or in
//!   `f32` with the paper's weighting about 2% of random three-mode sets) is
//!   [`ModalError::GainsRankDeficient`], not a garbage b̄; ω and ζ remain
//!   available from [`modes_from_denominator`](super::modes_from_denominator).

use super::{ModalError, Modes};
use crate::model::{poly_mul_quadratic, MAX_MODES, MAX_ORDER};
use crate::scalar::{pow2_nearest, Real};

/// Largest number of numerator coefficients, 2·[`MAX_MODES`] − 1.
const MAX_NUM: usize = MAX_ORDER - 1;

/// Row weighting of the least-squares problem M·b̄ = b of eq. 31–32.
///
/// Both give the same b̄ when b lies in the range of M (a numerator exactly
/// consistent with the poles); they differ when it does not (an estimate in
/// transit, noise, or the rounded numerator of eq. 46).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum GainWeighting {
    /// Eq. 32 as printed: minimise the Euclidean norm of the residual in the
    /// unscaled coefficients b_k. The low-order coefficients (∝ ω^{2n−2})
    /// dominate. This is the paper's definition and the project's reference
    /// (b̄ = [9.6293, 16.1458] for eq. 46's numerator).
    #[default]
    Paper,
    /// Minimise the residual of the coefficients of B(ρσ)/ρ^{2n−2} in the
    /// scaled variable σ = s/ρ (ρ ≈ geometric mean of ω), i.e. every
    /// coefficient counted at its natural size. Better conditioned: in the
    /// host-tests sweep (`roots.rs`) the worst consistent-b̄ error is ~500×
    /// smaller for three modes in `f64`, and in `f32` it never reports rank
    /// deficiency where the paper's weighting does for ~2% of three-mode
    /// sets. Preferable in `f32`, but it is not eq. 32.
    Balanced,
}

/// Modal gains b̄ (eq. 31–32, generalised) for known modes: the
/// least-squares solution of M·b̄ = b, M's column i holding the coefficients
/// of c_i·Π_{j≠i} q_j(s), with `b = [b_{2n−2}, …, b_0]` (highest power first)
/// and `output_weight = [c_1, …, c_n]` in the mode order of `modes`.
/// With [`GainWeighting::Paper`] this is the Moore–Penrose solution of
/// eq. 32 (unscaled Euclidean residual); see [`GainWeighting`] for the
/// alternative. Entries of the result past n are zero.
///
/// # Errors
/// [`ModalError::InvalidModeCount`], [`ModalError::LengthMismatch`],
/// [`ModalError::NonFinite`], [`ModalError::GainsRankDeficient`].
pub(crate) fn gains_from_numerator<T: Real>(
    modes: &Modes<T>,
    b: &[T],
    output_weight: &[T],
    weighting: GainWeighting,
) -> Result<[T; MAX_MODES], ModalError> {
    let n = modes.count;
    if n == 0 || n > MAX_MODES {
        return Err(ModalError::InvalidModeCount);
    }
    let rows = 2 * n - 1;
    if b.len() != rows || output_weight.len() != n {
        return Err(ModalError::LengthMismatch);
    }
    let finite = |v: &T| v.is_finite();
    if !b.iter().all(finite)
        || !output_weight.iter().all(finite)
        || !modes.omega_rad_s[..n].iter().all(finite)
        || !modes.zeta[..n].iter().all(finite)
    {
        return Err(ModalError::NonFinite);
    }
    if modes.omega_rad_s[..n].iter().any(|w| !(*w > T::ZERO)) {
        return Err(ModalError::GainsRankDeficient);
    }
    // ρ: power of two near the geometric mean of ω.
    let ln2 = T::from_f64(core::f64::consts::LN_2);
    let mut lsum = T::ZERO;
    for w in &modes.omega_rad_s[..n] {
        lsum += w.ln();
    }
    // Keep ρ a normal power of two; the weights below only ever divide by
    // ρ (ρ ≥ 1) or multiply by it (ρ < 1), so they cannot overflow.
    let rho = pow2_nearest(lsum / (T::from_usize(n) * ln2));
    let inv_rho = T::ONE / rho;

    // Scaled mode polynomials q̃_j(σ) = σ² + 2ζ_j(ω_j/ρ)σ + (ω_j/ρ)².
    let two = T::ONE + T::ONE;
    let mut q = [[T::ZERO; 3]; MAX_MODES];
    for j in 0..n {
        let w = modes.omega_rad_s[j] * inv_rho;
        q[j] = [T::ONE, two * modes.zeta[j] * w, w * w];
    }
    // M̃ (scaled), then the paper's row weights: row r (coefficient of
    // s^{rows−1−r}) of the unscaled M is ρ^r·M̃_r. Multiply every row by
    // g = min(1, ρ^{−(rows−1)}) so the largest weight is 1: weight_r = g·ρ^r.
    let mut m = [[T::ZERO; MAX_MODES]; MAX_NUM];
    let mut rhs = [T::ZERO; MAX_NUM];
    for i in 0..n {
        let mut p = [T::ZERO; MAX_ORDER + 1];
        p[0] = T::ONE;
        let mut len = 1;
        for (j, qj) in q.iter().enumerate().take(n) {
            if j != i {
                len = poly_mul_quadratic(&mut p, len, qj);
            }
        }
        for r in 0..rows.min(len) {
            m[r][i] = output_weight[i] * p[r];
        }
    }
    match weighting {
        GainWeighting::Paper => {
            let grow = rho >= T::ONE;
            for r in 0..rows {
                // weight_r = ρ^{−(rows−1−r)} if ρ ≥ 1, else ρ^r: exact powers
                // of two.
                let (factor, count) = if grow {
                    (inv_rho, rows - 1 - r)
                } else {
                    (rho, r)
                };
                let mut w = T::ONE;
                for _ in 0..count {
                    w *= factor;
                }
                for mi in m[r].iter_mut().take(n) {
                    *mi *= w;
                }
                // rhs_r = g·b_r, g = ρ^{−(rows−1)} (ρ ≥ 1) or 1.
                let mut g = b[r];
                if grow {
                    for _ in 0..rows - 1 {
                        g *= inv_rho;
                    }
                }
                rhs[r] = g;
            }
        }
        GainWeighting::Balanced => {
            // M̃ as is; b̃_r = b_r/ρ^r (coefficient of σ^{rows−1−r}).
            for r in 0..rows {
                let mut g = b[r];
                for _ in 0..r {
                    g *= inv_rho;
                }
                rhs[r] = g;
            }
        }
    }
    let x = least_squares(&mut m, &mut rhs, rows, n)?;
    let mut out = [T::ZERO; MAX_MODES];
    out[..n].copy_from_slice(&x[..n]);
    if !out.iter().all(finite) {
        return Err(ModalError::GainsRankDeficient);
    }
    Ok(out)
}

/// Least squares min ‖A·x − b‖₂ for the leading `rows × cols` block
/// (rows ≥ cols): column equilibration, rows sorted by decreasing norm,
/// Householder QR with column pivoting.
fn least_squares<T: Real>(
    a: &mut [[T; MAX_MODES]; MAX_NUM],
    b: &mut [T; MAX_NUM],
    rows: usize,
    cols: usize,
) -> Result<[T; MAX_MODES], ModalError> {
    // Column equilibration (does not change the LS solution, only its
    // scaling): x = D·y with D = diag(1/‖a_j‖).
    let mut colscale = [T::ONE; MAX_MODES];
    for (j, cs) in colscale.iter_mut().enumerate().take(cols) {
        let nrm = norm2((0..rows).map(|i| a[i][j]));
        if !(nrm > T::ZERO) || !nrm.is_finite() {
            return Err(ModalError::GainsRankDeficient);
        }
        *cs = T::ONE / nrm;
        for row in a.iter_mut().take(rows) {
            row[j] *= *cs;
        }
    }
    // Sort rows by decreasing 2-norm (insertion sort, ≤ 5 rows).
    let mut rn = [T::ZERO; MAX_NUM];
    for i in 0..rows {
        rn[i] = norm2(a[i][..cols].iter().copied());
    }
    for i in 1..rows {
        let mut j = i;
        while j > 0 && rn[j] > rn[j - 1] {
            rn.swap(j, j - 1);
            a.swap(j, j - 1);
            b.swap(j, j - 1);
            j -= 1;
        }
    }
    // Householder QR with column pivoting.
    let mut perm = [0usize; MAX_MODES];
    for (j, p) in perm.iter_mut().enumerate() {
        *p = j;
    }
    let rank_tol = T::from_usize(16 * rows) * T::EPSILON;
    let mut r00 = T::ZERO;
    for k in 0..cols {
        // Pivot: the remaining column with the largest remaining norm.
        let mut best = k;
        let mut best_n = -T::ONE;
        for j in k..cols {
            let nj = norm2((k..rows).map(|i| a[i][j]));
            if nj > best_n {
                best_n = nj;
                best = j;
            }
        }
        if best != k {
            for row in a.iter_mut().take(rows) {
                row.swap(k, best);
            }
            perm.swap(k, best);
        }
        let xnorm = norm2((k..rows).map(|i| a[i][k]));
        if k == 0 {
            r00 = xnorm;
        }
        if !(xnorm > rank_tol * r00) || !xnorm.is_finite() {
            return Err(ModalError::GainsRankDeficient);
        }
        let alpha = if a[k][k] > T::ZERO { -xnorm } else { xnorm };
        // v = x − α·e_1, H = I − 2vvᵀ/(vᵀv); vᵀv = 2·xnorm·(xnorm + |x_0|).
        let v0 = a[k][k] - alpha;
        let vtv = (xnorm + a[k][k].abs()) * xnorm * (T::ONE + T::ONE);
        let mut v = [T::ZERO; MAX_NUM];
        v[k] = v0;
        for i in k + 1..rows {
            v[i] = a[i][k];
        }
        for j in k + 1..cols {
            let mut s = T::ZERO;
            for i in k..rows {
                s += v[i] * a[i][j];
            }
            let f = (s + s) / vtv;
            for i in k..rows {
                a[i][j] -= f * v[i];
            }
        }
        let mut s = T::ZERO;
        for i in k..rows {
            s += v[i] * b[i];
        }
        let f = (s + s) / vtv;
        for i in k..rows {
            b[i] -= f * v[i];
        }
        a[k][k] = alpha;
        for row in a.iter_mut().take(rows).skip(k + 1) {
            row[k] = T::ZERO;
        }
    }
    // Back substitution R·y = (Qᵀb)[..cols].
    let mut y = [T::ZERO; MAX_MODES];
    for k in (0..cols).rev() {
        let mut acc = b[k];
        for j in k + 1..cols {
            acc -= a[k][j] * y[j];
        }
        y[k] = acc / a[k][k];
    }
    let mut x = [T::ZERO; MAX_MODES];
    for k in 0..cols {
        let j = perm[k];
        x[j] = y[k] * colscale[j];
    }
    Ok(x)
}

/// Overflow-safe 2-norm of a short sequence (scaled by its largest entry).
fn norm2<T: Real, I: Iterator<Item = T> + Clone>(it: I) -> T {
    let mut amax = T::ZERO;
    for v in it.clone() {
        amax = amax.max(v.abs());
    }
    if !(amax > T::ZERO) || !amax.is_finite() {
        return amax;
    }
    let mut s = T::ZERO;
    for v in it {
        let t = v / amax;
        s += t * t;
    }
    amax * s.sqrt()
}

#[cfg(test)]
mod tests {
    use super::super::modal_from_tf;
    use super::super::tests::{rel, PW, PZ};
    use crate::model::paper_plant_tf;

    #[test]
    fn eq32_pseudo_inverse_by_hand() {
        // Independent check of the weighting: (MᵀM)⁻¹Mᵀb in f64 for eq. 31.
        let tf = paper_plant_tf();
        let (w1, w2, z1, z2) = (PW[0], PW[1], PZ[0], PZ[1]);
        let (k1, k2, c1, c2) = (-w1 * w1, -w2 * w2, -2.0 * z1 * w1, -2.0 * z2 * w2);
        let mm = [[-2.0, 2.0], [2.0 * c2, -2.0 * c1], [2.0 * k2, -2.0 * k1]];
        let b = [tf.b[0], tf.b[1], tf.b[2]];
        let mut ata = [[0.0; 2]; 2];
        let mut atb = [0.0; 2];
        for r in 0..3 {
            for i in 0..2 {
                atb[i] += mm[r][i] * b[r];
                for j in 0..2 {
                    ata[i][j] += mm[r][i] * mm[r][j];
                }
            }
        }
        let det = ata[0][0] * ata[1][1] - ata[0][1] * ata[1][0];
        let x = [
            (ata[1][1] * atb[0] - ata[0][1] * atb[1]) / det,
            (ata[0][0] * atb[1] - ata[1][0] * atb[0]) / det,
        ];
        let m = modal_from_tf(&tf, &[-2.0, 2.0]).unwrap();
        for i in 0..2 {
            assert!(rel(m.bbar[i], x[i]) < 1e-8, "{} vs {}", m.bbar[i], x[i]);
        }
    }
}
