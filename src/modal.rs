//! Modal recovery: transfer function (eq. 25–26) or parameter vector Θ
//! (eq. 29) → natural frequencies ω_i, damping ratios ζ_i and modal gains
//! b̄_i (eq. 30–32), generalised from the paper's two modes to
//! n = 1..=[`MAX_MODES`]; and the excitation monitor of Lemma 1.
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
//!    b̄: M·b̄ = b with M of size (2n−1)×n, column i the coefficients of
//!    c_i·Π_{j≠i} q_j (for n = 2 exactly the matrix of eq. 31). Like eq. 32 it
//!    is solved in the least-squares (Moore–Penrose) sense. The row weighting
//!    matters whenever b is not exactly in the range of M (an estimate, or
//!    the rounded eq. 46): [`modal_from_tf`] uses the paper's unscaled
//!    Euclidean weighting ([`GainWeighting::Paper`], which reproduces
//!    DESIGN.md's b̄ = [9.6293, 16.1458]); [`GainWeighting::Balanced`]
//!    weights the coefficients in the scaled variable instead and is much
//!    better conditioned, which matters for three modes in `f32`.
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
//!   available from [`modes_from_denominator`].
//! * Everything is fixed-size, allocation-free and panic-free; NaN or
//!   infinite input is [`ModalError::NonFinite`].

use crate::linalg::symmetric_eigenvalues;
use crate::model::{poly_mul_quadratic, ModalParams, TransferFunction, MAX_MODES, MAX_ORDER};
use crate::poly::{roots_monic, PolyError};
use crate::scalar::Real;

/// Largest number of numerator coefficients, 2·[`MAX_MODES`] − 1.
const MAX_NUM: usize = MAX_ORDER - 1;

/// Why modal parameters could not be recovered.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
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

/// Row weighting of the least-squares problem M·b̄ = b of eq. 31–32.
///
/// Both give the same b̄ when b lies in the range of M (a numerator exactly
/// consistent with the poles); they differ when it does not (an estimate in
/// transit, noise, or the rounded numerator of eq. 46).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum GainWeighting {
    /// Eq. 32 as printed: minimise the Euclidean norm of the residual in the
    /// unscaled coefficients b_k. The low-order coefficients (∝ ω^{2n−2})
    /// dominate. This is the paper's definition and the project's reference
    /// (DESIGN.md §3: b̄ = [9.6293, 16.1458] for eq. 46's numerator).
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

/// Natural frequencies and damping ratios of n modes (eq. 30, generalised),
/// sorted by ω ascending.
#[derive(Debug, Clone, Copy, PartialEq)]
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
pub fn gains_from_numerator<T: Real>(
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
    let emax = (T::MAX.ln() / ln2).to_f64() - 4.0;
    let e = libm::round((lsum / (T::from_usize(n) * ln2)).to_f64()).clamp(-emax, emax);
    let rho = T::from_f64(2.0).powi(e as i32);
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

/// Modal parameters from a transfer function (eq. 25–32, n modes):
/// poles → ω, ζ ([`modes_from_denominator`]), then b̄ by the Moore–Penrose
/// least-squares solution of eq. 31–32 ([`gains_from_numerator`]).
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

/// Eigenvalues (ascending) of P/s with s = max|P_ij|, and s; `None` if P
/// has a non-finite entry or the decomposition overflowed. The scaling keeps
/// the Jacobi rotations of [`symmetric_eigenvalues`] away from overflow for
/// entries near the type's maximum; λ(P) = s·λ(P/s).
fn scaled_eigenvalues<T: Real, const N: usize>(p: &[[T; N]; N]) -> Option<([T; N], T)> {
    let mut s = T::ZERO;
    for v in p.iter().flatten() {
        if !v.is_finite() {
            return None;
        }
        s = s.max(v.abs());
    }
    if s == T::ZERO {
        return Some(([T::ZERO; N], T::ONE));
    }
    let mut q = *p;
    for v in q.iter_mut().flatten() {
        *v /= s;
    }
    let ev = symmetric_eigenvalues(&q);
    if ev.iter().all(|v| v.is_finite()) {
        Some((ev, s))
    } else {
        None
    }
}

/// Excitation monitor of Lemma 1: λ_min(P) of the symmetric information
/// matrix P (eq. 33–34). The regressor is persistently exciting iff this
/// stays above some σ > 0. Returns NaN if P has a non-finite entry (so a
/// `λ_min > σ` test fails safe) and 0 for N = 0. P is assumed symmetric, as
/// it is by construction.
pub fn excitation_min_eig<T: Real, const N: usize>(p: &[[T; N]; N]) -> T {
    match scaled_eigenvalues(p) {
        Some((ev, s)) => ev.first().map_or(T::ZERO, |&lo| lo * s),
        None => T::from_f64(f64::NAN),
    }
}

/// Excitation ratio λ_min(P)/λ_max(P) (the inverse condition number of P,
/// Lemma 1): near 0 means some direction of Θ is not excited; negative if
/// rounding has made P indefinite. Returns 0 if λ_max ≤ 0, N = 0, or P has
/// a non-finite entry; never NaN.
pub fn excitation_ratio<T: Real, const N: usize>(p: &[[T; N]; N]) -> T {
    let Some((ev, _)) = scaled_eigenvalues(p) else {
        return T::ZERO;
    };
    let (lo, hi) = match (ev.first(), ev.last()) {
        (Some(&lo), Some(&hi)) => (lo, hi),
        _ => return T::ZERO,
    };
    if !(hi > T::ZERO) {
        return T::ZERO;
    }
    lo / hi
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::paper_plant_tf;

    fn rel(a: f64, b: f64) -> f64 {
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

    const PW: [f64; 2] = [39.1533, 245.3711];
    const PZ: [f64; 2] = [0.0207, 0.13];
    const PB: [f64; 2] = [9.6293, 16.1458];

    #[test]
    fn paper_plant_round_trip_f64_f32() {
        check_round_trip::<f64>(&PW, &PZ, &PB, 1e-12);
        check_round_trip::<f32>(&PW, &PZ, &PB, 1e-5);
    }

    #[test]
    fn paper_plant_eq46_numerator_gives_design_truth() {
        // b from eq. 46 is not exactly in the range of M: this is eq. 32's
        // Moore–Penrose answer, DESIGN.md §3's b̄ = [9.6293, 16.1458].
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

    #[test]
    fn excitation_monitor() {
        let p = [[2.0f64, 1.0, 0.0], [1.0, 2.0, 1.0], [0.0, 1.0, 2.0]];
        let r2 = 2f64.sqrt();
        assert!((excitation_min_eig(&p) - (2.0 - r2)).abs() < 1e-14);
        assert!((excitation_ratio(&p) - (2.0 - r2) / (2.0 + r2)).abs() < 1e-14);
        let zero = [[0.0f32; 2]; 2];
        assert_eq!(excitation_ratio(&zero), 0.0);
        assert_eq!(excitation_min_eig(&zero), 0.0);
        let nan = [[f64::NAN, 0.0], [0.0, 1.0]];
        assert!(excitation_min_eig(&nan).is_nan());
        assert_eq!(excitation_ratio(&nan), 0.0);
        let empty: [[f64; 0]; 0] = [];
        assert_eq!(excitation_min_eig(&empty), 0.0);
        assert_eq!(excitation_ratio(&empty), 0.0);
    }
}
