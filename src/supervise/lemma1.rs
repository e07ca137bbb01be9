//! Lemma 1 (the paper's persistent-excitation condition), in one place:
//! the regressor is persistently exciting iff λmin(P) of the information
//! matrix P (eqs. 33–34) stays above some σ > 0.
//!
//! * **The test** used everywhere — the estimator's own supervision, the
//!   firmware's EXCITED flag, the host tools — is [`lemma1_excited`]:
//!   λmin(P) ≥ [`EXCITATION_REL_THRESHOLD`] · tr(P). With forgetting l, P
//!   reflects the last ~1/l seconds (20 s at the default l = 0.05 /s), so
//!   λmin reacts on that time scale.
//! * **In the loop** (`InLoopLemma1`): one step of inverse iteration with
//!   the factors of the θ step's matrix every [`LEMMA1_EVERY`] θ steps, a
//!   by-product of the θ step (`estimator::theta_step`) that the
//!   supervisor reads ([`crate::supervise::Supervisor::lemma1`]).
//! * **At the telemetry rate** ([`excitation_min_eig`],
//!   [`excitation_ratio`]): λmin(P) and λmin/λmax of a copy of P by cyclic
//!   Jacobi, never in the sample path.
//!
//! # Why relative to tr(P)
//! λmin alone cannot tell excitation from rounding: in `f32` the λmin of a
//! non-exciting input is rounding noise whose size grows with P (above the
//! square wave's early values), while λmin/tr(P) separates them (the
//! levels: BENCHMARKS.md, "Design measurements"; host test
//! `link::excited_flag_follows_the_excitation`). 1e-7 is near `f32`'s ε
//! (1.2e-7): below it λmin is within the rounding of P's entries. A plant
//! whose P is inherently worse conditioned than ~10⁷ (e.g. three modes, or
//! a weak high mode) never passes, excited or not.

use crate::linalg::{ldlt_substitute_packed, symmetric_eigenvalues};
use crate::scalar::Real;

/// Lemma 1's threshold: excited iff λmin(P) ≥ this × tr(P) (scaled P).
pub(crate) const EXCITATION_REL_THRESHOLD: f64 = 1e-7;

/// The in-loop Lemma 1 estimate takes one inverse-iteration step every
/// this many θ steps, i.e. every 100 samples at K = 10 (the supervisor's
/// cost, this included: BENCHMARKS.md, "Cost of the supervisor").
pub(crate) const LEMMA1_EVERY: u32 = 10;

/// Lemma 1 as this project decides it: λmin(P) ≥
/// [`EXCITATION_REL_THRESHOLD`]·tr(P), P the scaled information matrix.
/// False for a non-finite or non-positive trace (fails safe).
#[cfg(test)]
pub(crate) fn lemma1_excited<T: Real>(lambda_min: T, trace: T) -> bool {
    trace > T::ZERO
        && trace.is_finite()
        && lambda_min >= T::from_f64(EXCITATION_REL_THRESHOLD) * trace
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
/// it is by construction. Telemetry rate (cyclic Jacobi), not per sample.
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

/// Lemma 1 in the loop: λmin(P)/tr(P) by inverse iteration with the
/// factors of the θ step's matrix S = R/g + K·TsΓ·P̃ (eq. 41 stepped
/// implicitly; g the lazy scale of P, P̃ = P/g), a by-product of the θ
/// step that owns it.
///
/// # What it relies on
/// With γ = l (R = e^{−lt}R(0) + P, eq. 39) and R(0) ∝ I, S = (1 +
/// K·TsΓ)·P̃ + w·R(0) has P's eigenvectors, so λmin(P̃) = (λmin(S) −
/// w·r0)/(1 + K·TsΓ) exactly: the θ step passes w·min R(0) as the `prior`
/// of [`InLoopLemma1::iterate`]. With γ ≠ l it passes 0 and the estimate
/// is S's own weakest direction scaled by 1/(1 + K·TsΓ). Either way its
/// accuracy is that of any λmin of a rounded P (the factorization's
/// backward error, ~ε·‖P‖), the limit the threshold is set against
/// ([`EXCITATION_REL_THRESHOLD`]).
#[derive(Debug, Clone, Copy)]
pub(crate) struct InLoopLemma1<T, const NP: usize> {
    /// The inverse-iteration vector.
    probe: [T; NP],
    /// λmin(P)/tr(P) from the last iteration (`None`: not known yet).
    ratio: Option<T>,
    /// θ steps since the last iteration.
    phase: u32,
}

impl<T: Real, const NP: usize> Default for InLoopLemma1<T, NP> {
    /// No estimate yet, probe ∝ (1, …, 1).
    fn default() -> Self {
        Self {
            probe: [T::ONE; NP],
            ratio: None,
            phase: 0,
        }
    }
}

impl<T: Real, const NP: usize> InLoopLemma1<T, NP> {
    /// λmin(P)/tr(P) as the iteration estimates it; `None` before the
    /// first iteration.
    pub fn ratio(&self) -> Option<T> {
        self.ratio
    }

    /// Count one θ step; true every [`LEMMA1_EVERY`]-th (100 Hz at the
    /// defaults: the information matrix moves on the forgetting time scale,
    /// 1/l), when [`InLoopLemma1::iterate`] is due.
    #[inline(always)]
    pub fn due(&mut self) -> bool {
        self.phase += 1;
        if self.phase >= LEMMA1_EVERY {
            self.phase = 0;
            true
        } else {
            false
        }
    }

    /// One step of inverse iteration with the factors the θ step just
    /// computed (`s`, `inv_d` of [`crate::linalg::ldlt_solve_packed_floored_keep`]):
    /// v ← S⁻¹v/‖S⁻¹v‖, λmin(S) ≈ 1/‖S⁻¹v‖ for the unit v of the previous
    /// step; `trace` = tr(P̃), `prior` = the R(0) share of λmin(S) taken off
    /// (see the type's docs), `step_gain` = K·TsΓ. ~NP² + 3·NP flops.
    #[inline(never)]
    pub(crate) fn iterate<const NS: usize>(
        &mut self,
        s: &[T; NS],
        inv_d: &[T; NP],
        trace: T,
        prior: T,
        step_gain: T,
    ) {
        let norm2 = self.probe.iter().fold(T::ZERO, |a, &v| a + v * v);
        if !(norm2 > T::ZERO && norm2.is_finite()) {
            self.probe = [T::ONE; NP];
            self.ratio = None;
            return;
        }
        let inv_norm = T::ONE / norm2.sqrt();
        for v in self.probe.iter_mut() {
            *v *= inv_norm;
        }
        let w = ldlt_substitute_packed(s, inv_d, &self.probe);
        let wn2 = w.iter().fold(T::ZERO, |a, &v| a + v * v);
        if !(wn2 > T::ZERO && wn2.is_finite()) {
            self.probe = [T::ONE; NP];
            self.ratio = None;
            return;
        }
        self.probe = w;
        let lambda_s = T::ONE / wn2.sqrt();
        let lambda_p = (lambda_s - prior) / (T::ONE + step_gain);
        self.ratio = (trace > T::ZERO).then(|| lambda_p / trace);
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used, clippy::indexing_slicing)]
mod tests {
    use super::*;

    #[test]
    fn lemma1_threshold_is_relative_and_fails_safe() {
        assert!(lemma1_excited(1e-6f32, 1.0));
        assert!(!lemma1_excited(0.99e-7f64, 1.0));
        assert!(lemma1_excited(1e-7f64 * 5.0, 5.0));
        assert!(!lemma1_excited(1.0f64, 0.0));
        assert!(!lemma1_excited(f64::NAN, 1.0));
        assert!(!lemma1_excited(1.0f64, f64::INFINITY));
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
