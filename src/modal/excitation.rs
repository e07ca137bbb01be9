//! The excitation monitor of Lemma 1: the smallest eigenvalue of the
//! information matrix P (eq. 33–34) and its ratio to the largest. The
//! regressor is persistently exciting iff λ_min(P) stays above some σ > 0;
//! run at the telemetry rate, never in the sample path (cyclic Jacobi).

use crate::linalg::symmetric_eigenvalues;
use crate::scalar::Real;

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
