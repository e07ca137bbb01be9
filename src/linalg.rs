//! Small dense linear algebra on fixed-size arrays: what the estimators,
//! filter bank and modal recovery need, nothing more.
//!
//! Everything works on `[T; N]` vectors and `[[T; N]; N]` row-major matrices,
//! never allocates and never panics (sizes are compile-time constants; a
//! failed factorization is reported through [`LinalgError`]).
//!
//! # Design
//! * [`expm`] (matrix exponential) is only used at start-up to discretize the
//!   filter bank and the plant, so it runs in `f64` on a runtime-sized block
//!   of a fixed maximum size ([`EXPM_MAX`]).
//! * [`ldlt_solve_packed_floored`] solves the implicit parameter step (see
//!   `estimator::adaptive`) once per θ step: a root-free LDLᵀ whose pivots
//!   are floored, so a rounding-level loss of definiteness cannot produce
//!   NaN or stop the law. It works on the packed upper triangle; the dense
//!   `ldlt_solve_floored` it was derived from is kept (tests only) as its
//!   bit-for-bit reference.
//! * [`symmetric_eigenvalues`] (cyclic Jacobi) backs the excitation monitor of
//!   Lemma 1 (λmin(P)); it is run at the telemetry rate, not per sample.

use crate::scalar::compensated::{each_row, packed_index, UNROLLED_ROWS};
use crate::scalar::Real;

/// Failure of a factorization.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LinalgError {
    /// A pivot was not strictly positive (matrix not positive definite in
    /// working precision) or not finite.
    NotPositiveDefinite,
}

impl core::fmt::Display for LinalgError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(match self {
            Self::NotPositiveDefinite => "matrix not positive definite in working precision",
        })
    }
}

impl core::error::Error for LinalgError {}

/// y = A·x.
#[inline(always)]
pub fn mat_vec<T: Real, const R: usize, const C: usize>(a: &[[T; C]; R], x: &[T; C]) -> [T; R] {
    let mut y = [T::ZERO; R];
    for (yi, row) in y.iter_mut().zip(a.iter()) {
        *yi = dot(row, x);
    }
    y
}

/// xᵀy.
#[inline(always)]
pub fn dot<T: Real, const N: usize>(x: &[T; N], y: &[T; N]) -> T {
    let mut s = T::ZERO;
    for i in 0..N {
        s += x[i] * y[i];
    }
    s
}

/// True if every element is finite.
pub fn all_finite<T: Real, const N: usize>(x: &[T; N]) -> bool {
    x.iter().all(|v| v.is_finite())
}

/// [`ldlt_solve_floored`] on packed storage: `s` holds the upper triangle
/// of the symmetric S row by row (S_ii, S_i,i+1, …, S_i,N−1 for i = 0, 1,
/// …; `NS = N(N+1)/2`) and is overwritten by the factors (row j: the pivot,
/// then L_ij for i > j). The same floating-point operations in the same
/// order as the dense function, so the same result bit for bit (test
/// `packed_ldlt_is_bit_identical_to_dense`), but every inner loop runs over
/// a contiguous row: column j of L is row j of the packed upper triangle,
/// the trailing update of row k is an axpy with the multipliers L_·j, and
/// the forward substitution runs column by column (each x_i still receives
/// its terms in ascending order). Loops run to the fixed bound N with an
/// early exit, which the compiler unrolls completely (its effect on the
/// Cortex-M4F's θ step: BENCHMARKS.md, "History: the f32 step and recovery
/// optimisation").
///
/// Like the dense form: a pivot below `N·ε·max_i S_ii` is raised to that
/// floor (a modified Cholesky factorization), so a rounding-level loss of
/// definiteness slows one direction of the step instead of stopping it.
///
/// # Errors
/// [`LinalgError::NotPositiveDefinite`] if S has no positive diagonal or
/// contains non-finite values (or the solution does not come out finite),
/// or if `NS ≠ N(N+1)/2`.
#[cfg_attr(not(test), allow(dead_code))]
pub fn ldlt_solve_packed_floored<T: Real, const N: usize, const NS: usize>(
    s: &mut [T; NS],
    b: &[T; N],
) -> Result<[T; N], LinalgError> {
    let mut inv_d = [T::ZERO; N];
    ldlt_solve_packed_floored_keep(s, b, &mut inv_d)
}

/// [`ldlt_solve_packed_floored`] that also returns the inverse pivots
/// 1/d_j in `inv_d`, so that more right-hand sides can be solved with the
/// same factors ([`ldlt_substitute_packed`]).
///
/// # Errors
/// As [`ldlt_solve_packed_floored`].
#[inline(always)]
pub fn ldlt_solve_packed_floored_keep<T: Real, const N: usize, const NS: usize>(
    s: &mut [T; NS],
    b: &[T; N],
    inv_d: &mut [T; N],
) -> Result<[T; N], LinalgError> {
    if NS != N * (N + 1) / 2 {
        return Err(LinalgError::NotPositiveDefinite);
    }
    let mut max_diag = T::ZERO;
    let mut start = 0;
    for i in 0..N {
        if let Some(&d) = s.get(start) {
            max_diag = max_diag.max(d);
        }
        start += N - i;
    }
    let floor = T::from_usize(N) * T::EPSILON * max_diag;
    if !(floor > T::ZERO) || !floor.is_finite() {
        return Err(LinalgError::NotPositiveDefinite);
    }
    if N > UNROLLED_ROWS {
        for j in 0..N {
            ldlt_pivot(j, s, inv_d, floor)?;
        }
    } else {
        // A constant pivot index in each: every index below is known at
        // compile time (no slice bookkeeping, no early exits).
        each_row!(J => ldlt_pivot(J, s, inv_d, floor)?);
    }
    let x = ldlt_substitute_packed(s, inv_d, b);
    if x.iter().all(|v| v.is_finite()) {
        Ok(x)
    } else {
        Err(LinalgError::NotPositiveDefinite)
    }
}

/// Pivot `j` of [`ldlt_solve_packed_floored_keep`] (nothing for j ≥ N):
/// the floored pivot d_j (1/d_j into `inv_d`), row j of the packed upper
/// triangle (S_·j below the pivot) replaced by the multipliers
/// L_·j = S_·j/d_j, and the trailing rows updated, S_ik −= L_ij·S_kj for
/// i ≥ k > j, in the dense function's order.
#[inline(always)]
fn ldlt_pivot<T: Real, const N: usize, const NS: usize>(
    j: usize,
    s: &mut [T; NS],
    inv_d: &mut [T; N],
    floor: T,
) -> Result<(), LinalgError> {
    if j >= N {
        return Ok(());
    }
    let (Some(&pivot), Some(inv_j)) = (s.get(packed_index::<N>(j, j)), inv_d.get_mut(j)) else {
        return Ok(());
    };
    let mut d = pivot;
    if d < floor {
        d = floor;
    }
    if !d.is_finite() {
        return Err(LinalgError::NotPositiveDefinite);
    }
    let inv = T::ONE / d;
    *inv_j = inv;
    // col = S_·j below the pivot (L_·j·d_j); row j becomes l = col·inv.
    let mut col = [T::ZERO; N];
    let mut l = [T::ZERO; N];
    for t in 0..N - 1 - j {
        if let (Some(v), Some(c), Some(li)) = (
            s.get_mut(packed_index::<N>(j, j + 1 + t)),
            col.get_mut(t),
            l.get_mut(t),
        ) {
            *c = *v;
            *li = *c * inv;
            *v = *li;
        }
    }
    // Row k = j + 1 + m holds S_k,k … S_k,N−1: S_ik −= l_i·col_k, i ≥ k.
    for (m, &ck) in col.iter().enumerate().take(N - 1 - j) {
        let k = j + 1 + m;
        for t in 0..N - k {
            if let (Some(sk), Some(&li)) = (s.get_mut(packed_index::<N>(k, k + t)), l.get(m + t)) {
                *sk -= li * ck;
            }
        }
    }
    Ok(())
}

/// Solve S·x = b with the factors [`ldlt_solve_packed_floored_keep`] left
/// in `s` and `inv_d`: L·z = b (unit lower, column by column), z ← D⁻¹z,
/// Lᵀ·x = z. O(N²); the result may be non-finite if the factors are.
#[inline(always)]
pub fn ldlt_substitute_packed<T: Real, const N: usize, const NS: usize>(
    s: &[T; NS],
    inv_d: &[T; N],
    b: &[T; N],
) -> [T; N] {
    let mut x = *b;
    if N > UNROLLED_ROWS {
        for j in 0..N {
            forward_column(j, s, &mut x);
        }
    } else {
        each_row!(J => forward_column(J, s, &mut x));
    }
    for (xi, inv) in x.iter_mut().zip(inv_d.iter()) {
        *xi *= *inv;
    }
    if N > UNROLLED_ROWS {
        for r in 0..N {
            back_row(N - 1 - r, s, &mut x);
        }
    } else {
        // Rows N − 1, N − 2, … 0 (R counts from the last).
        each_row!(R => if R < N {
            back_row(N - 1 - R, s, &mut x)
        });
    }
    x
}

/// L·z = b, column `j` (unit lower, the multipliers in row j of `s`):
/// z_i −= L_ij·z_j for i > j.
#[inline(always)]
fn forward_column<T: Real, const N: usize, const NS: usize>(j: usize, s: &[T; NS], x: &mut [T; N]) {
    let Some(&xj) = x.get(j) else {
        return;
    };
    for t in 1..N - j {
        if let (Some(&l), Some(xi)) = (s.get(packed_index::<N>(j, j + t)), x.get_mut(j + t)) {
            *xi -= l * xj;
        }
    }
}

/// Lᵀ·x = z, row `i`: x_i = z_i − Σ_{k>i} L_ki·x_k (in ascending k).
#[inline(always)]
fn back_row<T: Real, const N: usize, const NS: usize>(i: usize, s: &[T; NS], x: &mut [T; N]) {
    let Some(&xi) = x.get(i) else {
        return;
    };
    let mut acc = xi;
    for t in 1..N - i {
        if let (Some(&l), Some(&xk)) = (s.get(packed_index::<N>(i, i + t)), x.get(i + t)) {
            acc -= l * xk;
        }
    }
    if let Some(v) = x.get_mut(i) {
        *v = acc;
    }
}

/// Solve S·x = b for symmetric S by a root-free LDLᵀ factorization in which
/// a pivot below `N·ε·max_i S_ii` is raised to that floor instead of failing
/// (a modified Cholesky factorization). Used where S only sets a step's
/// speed, so that a rounding-level loss of definiteness slows one direction
/// instead of stopping the update. Fails only if S has no positive diagonal
/// or contains non-finite values. `s` is overwritten by the factors.
///
/// # Design
/// LDLᵀ needs one division per column and no square root, and the
/// factorization is right-looking (outer-product form), so each column's
/// update is independent multiply-adds rather than long dot-product chains.
/// On the benchmark host a 7×7 solve is faster than the textbook
/// Cholesky–Crout loop (BENCHMARKS.md, "Design measurements"); the remaining cost is the serial
/// divide/update chain, which is why the θ step runs every K samples.
/// The dense form of [`ldlt_solve_packed_floored`] (bit-identical), for
/// the laws that keep full matrices (the robust estimator).
pub fn ldlt_solve_floored<T: Real, const N: usize>(
    s: &mut [[T; N]; N],
    b: &[T; N],
) -> Result<[T; N], LinalgError> {
    let mut max_diag = T::ZERO;
    for i in 0..N {
        max_diag = max_diag.max(s[i][i]);
    }
    let floor = T::from_usize(N) * T::EPSILON * max_diag;
    if !(floor > T::ZERO) || !floor.is_finite() {
        return Err(LinalgError::NotPositiveDefinite);
    }
    // Right-looking (outer-product) LDLᵀ: each column's trailing update is a
    // set of independent multiply-adds, so the loop is throughput-bound
    // rather than bound by the latency of long dot-product chains.
    let mut inv_d = [T::ZERO; N];
    for j in 0..N {
        let mut d = s[j][j];
        if d < floor {
            d = floor;
        }
        if !d.is_finite() {
            return Err(LinalgError::NotPositiveDefinite);
        }
        let inv = T::ONE / d;
        inv_d[j] = inv;
        // Column j below the pivot still holds L_ij·d_j.
        let mut col = [T::ZERO; N];
        for i in j + 1..N {
            col[i] = s[i][j];
        }
        for i in j + 1..N {
            let l = col[i] * inv;
            for k in j + 1..=i {
                s[i][k] -= l * col[k];
            }
            s[i][j] = l;
        }
    }
    // L·z = b (unit lower), z ← D⁻¹z, Lᵀ·x = z.
    let mut x = *b;
    for i in 0..N {
        let mut acc = x[i];
        for k in 0..i {
            acc -= s[i][k] * x[k];
        }
        x[i] = acc;
    }
    for i in 0..N {
        x[i] *= inv_d[i];
    }
    for i in (0..N).rev() {
        let mut acc = x[i];
        for k in i + 1..N {
            acc -= s[k][i] * x[k];
        }
        x[i] = acc;
    }
    if x.iter().all(|v| v.is_finite()) {
        Ok(x)
    } else {
        Err(LinalgError::NotPositiveDefinite)
    }
}

/// Eigenvalues of a symmetric matrix by cyclic Jacobi rotations, ascending.
/// Robust for any finite symmetric input; the cost (~10³ flops for 7×7 per
/// sweep, a handful of sweeps) suits a telemetry-rate monitor.
pub fn symmetric_eigenvalues<T: Real, const N: usize>(m: &[[T; N]; N]) -> [T; N] {
    let mut a = *m;
    for _sweep in 0..50 {
        let mut off = T::ZERO;
        let mut diag = T::ZERO;
        for i in 0..N {
            diag += a[i][i] * a[i][i];
            for j in i + 1..N {
                off += a[i][j] * a[i][j];
            }
        }
        if !(off > T::EPSILON * T::EPSILON * diag) {
            break;
        }
        for p in 0..N {
            for q in p + 1..N {
                let apq = a[p][q];
                if apq == T::ZERO {
                    continue;
                }
                let two = T::ONE + T::ONE;
                let theta = (a[q][q] - a[p][p]) / (two * apq);
                let sign = if theta >= T::ZERO { T::ONE } else { -T::ONE };
                let t = sign / (theta.abs() + (theta * theta + T::ONE).sqrt());
                let c = T::ONE / (t * t + T::ONE).sqrt();
                let s = t * c;
                for k in 0..N {
                    let akp = a[k][p];
                    let akq = a[k][q];
                    a[k][p] = c * akp - s * akq;
                    a[k][q] = s * akp + c * akq;
                }
                for k in 0..N {
                    let apk = a[p][k];
                    let aqk = a[q][k];
                    a[p][k] = c * apk - s * aqk;
                    a[q][k] = s * apk + c * aqk;
                }
            }
        }
    }
    let mut ev = [T::ZERO; N];
    for i in 0..N {
        ev[i] = a[i][i];
    }
    // Insertion sort (N ≤ 11).
    for i in 1..N {
        let mut j = i;
        while j > 0 && ev[j - 1] > ev[j] {
            ev.swap(j - 1, j);
            j -= 1;
        }
    }
    ev
}

/// Largest matrix handled by [`expm`].
pub const EXPM_MAX: usize = 12;

/// A square `f64` block of runtime size `n ≤ EXPM_MAX`.
pub type Block = [[f64; EXPM_MAX]; EXPM_MAX];

/// Matrix exponential of the leading `n×n` block of `a` by scaling and
/// squaring with a truncated Taylor series (degree 18 on a matrix scaled to
/// ‖A‖₁ ≤ 1/2, truncation error < 1e-22 relative). Used at start-up only.
///
/// `n` is clamped to [`EXPM_MAX`].
pub fn expm(a: &Block, n: usize) -> Block {
    let n = n.min(EXPM_MAX);
    // 1-norm (max column sum).
    let mut norm = 0.0f64;
    for j in 0..n {
        let mut s = 0.0;
        for row in a.iter().take(n) {
            s += row[j].abs();
        }
        norm = norm.max(s);
    }
    let mut squarings = 0u32;
    let mut scale = 1.0f64;
    while norm * scale > 0.5 && squarings < 200 {
        scale *= 0.5;
        squarings += 1;
    }
    let mut x = [[0.0f64; EXPM_MAX]; EXPM_MAX];
    for i in 0..n {
        for j in 0..n {
            x[i][j] = a[i][j] * scale;
        }
    }
    // Horner: E = I + X(I + X/2(I + X/3(...))).
    let mut e = identity(n);
    for k in (1..=18).rev() {
        let xe = block_mul(&x, &e, n);
        e = identity(n);
        for i in 0..n {
            for j in 0..n {
                e[i][j] += xe[i][j] / k as f64;
            }
        }
    }
    for _ in 0..squarings {
        e = block_mul(&e, &e, n);
    }
    e
}

/// Solve the leading `n×n` block of `a`·x = b by Gaussian elimination with
/// partial pivoting (start-up use: plant construction). Returns `None` if
/// the matrix is singular to working precision.
pub fn solve_dense(a: &Block, b: &[f64; EXPM_MAX], n: usize) -> Option<[f64; EXPM_MAX]> {
    let n = n.min(EXPM_MAX);
    let mut m = *a;
    let mut x = *b;
    let mut scale = 0.0f64;
    for row in m.iter().take(n) {
        for v in row.iter().take(n) {
            scale = scale.max(v.abs());
        }
    }
    if !(scale > 0.0) || !scale.is_finite() {
        return None;
    }
    for col in 0..n {
        let mut piv = col;
        for r in col + 1..n {
            if m[r][col].abs() > m[piv][col].abs() {
                piv = r;
            }
        }
        if !(m[piv][col].abs() > 1e-14 * scale) {
            return None;
        }
        if piv != col {
            // Row swap in place (`m.swap` on whole rows compiles to a
            // `memmove` call, ~1.5 KB of flash on the firmware target).
            let (upper, lower) = m.split_at_mut(piv);
            if let (Some(a), Some(b)) = (upper.get_mut(col), lower.first_mut()) {
                a.swap_with_slice(b);
            }
            x.swap(col, piv);
        }
        for r in col + 1..n {
            let f = m[r][col] / m[col][col];
            for c in col..n {
                m[r][c] -= f * m[col][c];
            }
            x[r] -= f * x[col];
        }
    }
    for col in (0..n).rev() {
        let mut acc = x[col];
        for c in col + 1..n {
            acc -= m[col][c] * x[c];
        }
        x[col] = acc / m[col][col];
    }
    if x.iter().take(n).all(|v| v.is_finite()) {
        Some(x)
    } else {
        None
    }
}

fn identity(n: usize) -> Block {
    let mut e = [[0.0f64; EXPM_MAX]; EXPM_MAX];
    for (i, row) in e.iter_mut().enumerate().take(n) {
        row[i] = 1.0;
    }
    e
}

fn block_mul(a: &Block, b: &Block, n: usize) -> Block {
    let mut c = [[0.0f64; EXPM_MAX]; EXPM_MAX];
    for i in 0..n {
        for k in 0..n {
            let aik = a[i][k];
            if aik == 0.0 {
                continue;
            }
            for j in 0..n {
                c[i][j] += aik * b[k][j];
            }
        }
    }
    c
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn expm_of_rotation_generator_is_rotation() {
        let mut a = [[0.0; EXPM_MAX]; EXPM_MAX];
        let w = 3.7;
        a[0][1] = -w;
        a[1][0] = w;
        let e = expm(&a, 2);
        assert!((e[0][0] - w.cos()).abs() < 1e-14);
        assert!((e[1][0] - w.sin()).abs() < 1e-14);
        assert!((e[0][1] + w.sin()).abs() < 1e-14);
    }

    #[test]
    fn expm_of_nilpotent_jordan_block_is_polynomial() {
        let mut a = [[0.0; EXPM_MAX]; EXPM_MAX];
        a[0][1] = 2.0;
        a[1][2] = 3.0;
        let e = expm(&a, 3);
        // exp(N) = I + N + N²/2: (0,2) entry = 2·3/2 = 3.
        assert!((e[0][1] - 2.0).abs() < 1e-15);
        assert!((e[0][2] - 3.0).abs() < 1e-15);
        assert_eq!(e[2][0], 0.0);
    }

    #[test]
    fn ldlt_solves_spd_system_and_rejects_non_finite() {
        let s0 = [[4.0, 2.0, 0.6], [2.0, 5.0, 1.0], [0.6, 1.0, 3.0]];
        let x_true = [1.0, -2.0, 0.5];
        let b = mat_vec(&s0, &x_true);
        let x = ldlt_solve_floored(&mut s0.clone(), &b).unwrap();
        for i in 0..3 {
            assert!((x[i] - x_true[i]).abs() < 1e-14);
        }
        let mut nan = [[f64::NAN, 0.0], [0.0, 1.0]];
        assert!(ldlt_solve_floored(&mut nan, &[1.0, 1.0]).is_err());
        let mut inf = [[1.0, f64::INFINITY], [f64::INFINITY, 1.0]];
        assert!(ldlt_solve_floored(&mut inf, &[1.0, 1.0]).is_err());
    }

    /// Pack the upper triangle of a dense symmetric matrix row by row.
    fn pack<T: Real, const N: usize, const NS: usize>(m: &[[T; N]; N]) -> [T; NS] {
        let mut p = [T::ZERO; NS];
        let mut idx = 0;
        for i in 0..N {
            for j in i..N {
                p[idx] = m[i][j];
                idx += 1;
            }
        }
        p
    }

    #[test]
    fn packed_ldlt_is_bit_identical_to_dense() {
        // Random SPD-ish (and some indefinite, floored) 7×7 systems in f64
        // and f32: the packed solver must reproduce the dense one exactly.
        let mut seed = 0x9E37_79B9_7F4A_7C15u64;
        let mut next = move || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed >> 11) as f64 / (1u64 << 53) as f64 - 0.5
        };
        for trial in 0..200 {
            let mut a = [[0.0f64; 7]; 7];
            for row in a.iter_mut() {
                for v in row.iter_mut() {
                    *v = next();
                }
            }
            // S = AAᵀ + shift·I (shift < 0 for some trials: floored pivots).
            let shift = if trial % 5 == 0 { -0.05 } else { 1e-6 };
            let mut s = [[0.0f64; 7]; 7];
            for i in 0..7 {
                for j in 0..7 {
                    s[i][j] = (0..7).map(|k| a[i][k] * a[j][k]).sum::<f64>();
                }
                s[i][i] += shift;
            }
            let b: [f64; 7] = core::array::from_fn(|_| next());
            let dense = ldlt_solve_floored(&mut s.clone(), &b);
            let packed = ldlt_solve_packed_floored(&mut pack::<f64, 7, 28>(&s), &b);
            assert_eq!(dense, packed, "f64 trial {trial}");
            let s32 = s.map(|r| r.map(|v| v as f32));
            let b32 = b.map(|v| v as f32);
            let dense = ldlt_solve_floored(&mut s32.clone(), &b32);
            let packed = ldlt_solve_packed_floored(&mut pack::<f32, 7, 28>(&s32), &b32);
            assert_eq!(dense, packed, "f32 trial {trial}");
        }
        let mut nan = [f64::NAN, 0.0, 1.0];
        assert!(ldlt_solve_packed_floored::<f64, 2, 3>(&mut nan, &[1.0, 1.0]).is_err());
        assert!(ldlt_solve_packed_floored::<f64, 2, 4>(&mut [1.0; 4], &[1.0, 1.0]).is_err());
    }

    #[test]
    fn solve_dense_with_pivoting() {
        let mut a = [[0.0; EXPM_MAX]; EXPM_MAX];
        a[0][0] = 0.0;
        a[0][1] = 2.0;
        a[1][0] = 3.0;
        a[1][1] = 1.0;
        let mut b = [0.0; EXPM_MAX];
        b[0] = 4.0;
        b[1] = 5.0;
        let x = solve_dense(&a, &b, 2).unwrap();
        assert!((x[0] - 1.0).abs() < 1e-15 && (x[1] - 2.0).abs() < 1e-15);
        a[1][1] = 0.0;
        a[1][0] = 0.0;
        assert!(solve_dense(&a, &b, 2).is_none());
    }

    #[test]
    fn floored_ldlt_regularizes_semidefinite_matrix() {
        // Rank-one matrix (second pivot exactly 0): the floored solver
        // solves a nearby positive-definite system instead of failing.
        let m = [[1.0f32, 1.0], [1.0, 1.0]];
        let x = ldlt_solve_floored(&mut m.clone(), &[1.0, 1.0]).unwrap();
        assert!(x.iter().all(|v| v.is_finite()));
        assert!((x[0] + x[1] - 1.0).abs() < 1e-3, "{x:?}");
        assert!(ldlt_solve_floored(&mut [[0.0f32; 2]; 2], &[1.0, 1.0]).is_err());
    }

    #[test]
    fn jacobi_eigenvalues_of_known_matrix() {
        // Eigenvalues of [[2,1,0],[1,2,1],[0,1,2]] are 2-√2, 2, 2+√2.
        let m = [[2.0, 1.0, 0.0], [1.0, 2.0, 1.0], [0.0, 1.0, 2.0]];
        let ev = symmetric_eigenvalues(&m);
        let r2 = 2f64.sqrt();
        assert!((ev[0] - (2.0 - r2)).abs() < 1e-14);
        assert!((ev[1] - 2.0).abs() < 1e-14);
        assert!((ev[2] - (2.0 + r2)).abs() < 1e-14);
    }
}
