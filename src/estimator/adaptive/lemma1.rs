//! Lemma 1 in the loop (Wang, Costa-Castelló, Na et al., *Modelling and
//! Adaptive Parameter Estimation for a Piezoelectric Cantilever Beam*):
//! λmin(P)/tr(P) by inverse iteration with the θ step's factors
//! ([`crate::supervise::excitation`]).

use super::AdaptiveLaw;
use crate::linalg::ldlt_substitute_packed;
use crate::scalar::Real;

/// The in-loop Lemma 1 estimate takes one inverse-iteration step every
/// this many θ steps, i.e. every 100 samples at K = 10 (the supervisor's
/// cost, this included: BENCHMARKS.md, "Cost of the supervisor").
pub const LEMMA1_EVERY: u32 = 10;

impl<T: Real, const NP: usize, const NS: usize> AdaptiveLaw<T, NP, NS> {
    /// One step of inverse iteration for the smallest eigenvalue of the
    /// step matrix S = R/g + K·TsΓ·P̃ with the factors the θ step just
    /// computed (`s`, `inv_d`): v ← S⁻¹v/‖S⁻¹v‖, λmin(S) ≈ 1/‖S⁻¹v‖ for the
    /// unit v of the previous step. With γ = l and R(0) ∝ I (the defaults),
    /// S = (1 + K·TsΓ)·P̃ + w·R(0) has P's eigenvectors, so λmin(P̃) =
    /// (λmin(S) − w·r0)/(1 + K·TsΓ) exactly; otherwise it estimates the
    /// step matrix's weakest direction. Its accuracy is that of any λmin of
    /// a rounded P (the factorization's backward error, ~ε·‖P‖), the limit
    /// the threshold of Lemma 1 is set against ([`crate::supervise`]).
    /// ~NP² + 3·NP flops per θ step.
    #[inline(never)]
    pub(super) fn lemma1_iteration(&mut self, s: &[T; NS], inv_d: &[T; NP]) {
        let norm2 = self.probe.iter().fold(T::ZERO, |a, &v| a + v * v);
        if !(norm2 > T::ZERO && norm2.is_finite()) {
            self.probe = [T::ONE; NP];
            self.lemma1_ratio = None;
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
            self.lemma1_ratio = None;
            return;
        }
        self.probe = w;
        let lambda_s = T::ONE / wn2.sqrt();
        // tr(P̃) and the smallest R(0) share of S's diagonal.
        let (mut trace, mut r0_min) = (T::ZERO, T::MAX);
        let mut idx = 0;
        for i in 0..NP {
            trace += self.p.sum.hi.get(idx).copied().unwrap_or(T::ZERO);
            r0_min = r0_min.min(self.r0_diag.get(i).copied().unwrap_or(T::ZERO));
            idx += NP - i;
        }
        let prior = if self.tied {
            self.r0_weight * r0_min
        } else {
            T::ZERO
        };
        let lambda_p = (lambda_s - prior) / (T::ONE + self.step_gain);
        self.lemma1_ratio = (trace > T::ZERO).then(|| lambda_p / trace);
    }

    /// λmin(P)/tr(P) as the θ steps' inverse iteration estimates it
    /// (Lemma 1 in the loop); `None` before the first θ step.
    pub fn lemma1_ratio(&self) -> Option<T> {
        self.lemma1_ratio
    }
}
