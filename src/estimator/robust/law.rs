//! The proposed law (eqs. 33–41) driven by the output error of a simulated
//! model instead of the equation error: a recursive Gauss–Newton
//! (prediction-error) method in the paper's P/Q/W form.
//!
//! With ψ_r = ∂ŷ/∂θ and ε_r = y_r − ŷ_r computed with the model θ_m,r in
//! force at sample r, the linearized output ỹ_r = ε_r + ψ_rᵀθ_m,r obeys
//! ỹ_r ≈ ψ_rᵀθ + e_r, and the paper's auxiliary quantities become
//!
//! * P = ∫e^{−l(t−r)}ψψᵀ (eq. 33),
//! * Q = ∫e^{−l(t−r)}ψỹ (eq. 33 with ỹ for y),
//! * W = Pθ̂ − Q (eq. 35), R = H⁻¹ = e^{−lt}R(0) + P (eq. 39, γ = l),
//! * θ̂' = −ΓHW (eq. 41), stepped implicitly every K samples.
//!
//! W = 0 is the normal equation of the output-error (maximum-likelihood for
//! white noise on y) criterion, linearized sample by sample.
//!
//! # Storage: incremental form
//! Q is kept as q = Q − Pθ_m = ∫ψε − ∫ψψᵀ(θ_m − θ_m,r), so that
//! W = P(θ̂ − θ_m) − q. Per sample only ψψᵀ and ψε are added (no ψᵀθ_m);
//! when the model moves to θ_m' (`shift`), q ← q + P(θ_m − θ_m'). Every
//! term is then of the size of the *error* θ̂ − θ_m, never of θ, so no
//! cancellation of large terms decides the fixed point: working precision
//! suffices in `f32` where the equation-error law needs double words
//! (docs/NUMERICS.md). θ̂ and θ_m are double words so their difference is
//! exact.

use crate::estimator::theta_step::ThetaStep;
use crate::estimator::{ConfigError, LawError};
use crate::scalar::compensated::{product_dw, two_prod, Compensated, CompensatedArray, Dot2};
use crate::scalar::Real;

/// Damping of the step matrix in units of NP·ε·max diag (see `step`).
const STEP_DAMPING: f64 = 16.0;

/// State of the output-error law. `NS = NP(NP+1)/2`.
#[derive(Debug, Clone)]
pub(crate) struct OeLaw<T, const NP: usize, const NS: usize> {
    /// The θ step of eq. 41 (gain K·Ts·Γ, every K samples); no Lemma 1 in
    /// the loop (the robust estimator's supervisor does not use it).
    step: ThetaStep<T, NP, ()>,
    ts: T,
    decay: T,
    /// Lazy scale g: P = g·P̃, q = g·q̃.
    scale: T,
    /// e^{−lt}/g.
    r0_weight: T,
    r0_diag: [T; NP],
    /// Diagonal damping of the step matrix relative to its largest
    /// diagonal entry (see `step`).
    damping: T,
    /// P̃, packed upper triangle row by row (double words when
    /// `T::COMPENSATED`).
    p: CompensatedArray<T, NS>,
    q: CompensatedArray<T, NP>,
    /// Σw·ε² and Σw (lazy-scaled like P): the residual variance, an
    /// estimate of the noise variance once the model has converged.
    e2: T,
    wsum: T,
    theta: CompensatedArray<T, NP>,
    model: CompensatedArray<T, NP>,
}

impl<T: Real, const NP: usize, const NS: usize> OeLaw<T, NP, NS> {
    /// Forgetting and R(0) validated by the caller.
    ///
    /// # Errors
    /// As [`ThetaStep::new`] for Γ = `gain`, Ts = `ts_s`, K = `every`.
    pub fn new(
        gain: f64,
        forgetting: f64,
        r0_diag: &[f64; NP],
        every: u32,
        ts_s: f64,
    ) -> Result<Self, ConfigError> {
        Ok(Self {
            step: ThetaStep::new::<NS>(gain, ts_s, every, ())?,
            ts: T::from_f64(ts_s),
            decay: T::from_f64(libm::exp(-forgetting * ts_s)),
            scale: T::ONE,
            r0_weight: T::ONE,
            r0_diag: r0_diag.map(T::from_f64),
            damping: T::from_f64(STEP_DAMPING * NP as f64) * T::EPSILON,
            p: CompensatedArray::default(),
            q: CompensatedArray::default(),
            e2: T::ZERO,
            wsum: T::ZERO,
            theta: CompensatedArray::default(),
            model: CompensatedArray::default(),
        })
    }

    /// θ̂ = θ_m = `theta`, no information.
    pub fn restart(&mut self, theta: &CompensatedArray<T, NP>) {
        self.scale = T::ONE;
        self.r0_weight = T::ONE;
        self.p = CompensatedArray::default();
        self.q = CompensatedArray::default();
        self.e2 = T::ZERO;
        self.wsum = T::ZERO;
        self.step.reset();
        self.theta = *theta;
        self.model = *theta;
    }

    /// θ̂ (double word).
    pub fn theta(&self) -> &CompensatedArray<T, NP> {
        &self.theta
    }

    /// The linearization point θ_m (double word).
    pub fn model(&self) -> &CompensatedArray<T, NP> {
        &self.model
    }

    /// Weighted mean squared residual ε (scaled units); `None` before the
    /// first sample.
    pub(crate) fn residual_variance(&self) -> Option<T> {
        if self.wsum > T::ZERO {
            Some(self.e2 / self.wsum)
        } else {
            None
        }
    }

    /// θ̂ − θ_m, rounded.
    fn delta(&self) -> [T; NP] {
        core::array::from_fn(|i| {
            (self.theta.hi[i] - self.model.hi[i]) + (self.theta.lo[i] - self.model.lo[i])
        })
    }

    /// `steps` more implicit θ̂ steps on the information gathered so far (no
    /// new sample, no decay): converges θ̂ further towards W = 0 where the
    /// damped step is slow (weak directions in `f32`). Off the sample path.
    /// Returns false if a step failed (θ̂ unchanged by it; the caller stops
    /// refining).
    pub(crate) fn refine(&mut self, steps: u32) -> bool {
        for _ in 0..steps {
            if self.step().is_err() {
                return false;
            }
        }
        true
    }

    /// W/g = P̃·(θ̂ − θ_m) − q̃, a Dot2 product when `T::COMPENSATED`.
    fn w_unscaled(&self) -> [T; NP] {
        let d = self.delta();
        let mut acc = [Dot2::<T>::new(); NP];
        let mut idx = 0;
        for i in 0..NP {
            for j in i..NP {
                let pij = self.p.get(idx);
                acc[i].add_product_dd(pij, Compensated::new(d[j]));
                if j != i {
                    acc[j].add_product_dd(pij, Compensated::new(d[i]));
                }
                idx += 1;
            }
        }
        core::array::from_fn(|i| {
            let mut a = acc[i];
            a.add_value(Compensated {
                hi: -self.q.hi[i],
                lo: -self.q.lo[i],
            });
            a.value()
        })
    }

    /// Accumulate one sample (ψ, ε); every K samples take the θ̂ step.
    #[inline]
    pub fn update(&mut self, psi: &[T; NP], eps: T) -> Result<(), LawError> {
        self.decay();
        let w = self.ts / self.scale;
        self.accumulate(w, psi, eps);
        self.e2 += w * eps * eps;
        self.wsum += w;
        if !self.step.due() {
            return Ok(());
        }
        self.step()
    }

    /// Accumulate a block of `span` samples, `count` of them readings,
    /// whose mean gradient is `psi` and mean residual `eps` (a record of
    /// block means, see `record.rs`): the decay of `span` samples, weight
    /// `count`·Ts, and θ̂ steps as if its samples came one by one (one
    /// step when a multiple of K falls in the block). The residual
    /// variance counts the block as `count` samples (the mean of `count`
    /// residuals has 1/`count` of their variance).
    pub fn update_block(
        &mut self,
        psi: &[T; NP],
        eps: T,
        count: u32,
        span: u32,
    ) -> Result<(), LawError> {
        for _ in 0..span {
            self.decay();
        }
        if count > 0 {
            let c = T::from_usize(count as usize);
            let w = c * self.ts / self.scale;
            self.accumulate(w, psi, eps);
            self.e2 += w * c * eps * eps;
            self.wsum += w;
        }
        if !self.step.due_after(span) {
            return Ok(());
        }
        self.step()
    }

    /// One sample of forgetting (lazy: the scale, halved with the sums
    /// when it falls below ½).
    #[inline(always)]
    fn decay(&mut self) {
        self.scale *= self.decay;
        if self.scale < T::from_f64(0.5) {
            self.scale += self.scale;
            let half = T::from_f64(0.5);
            self.p.halve();
            self.q.halve();
            self.e2 *= half;
            self.wsum *= half;
            self.r0_weight *= half;
        }
    }

    /// P̃ += w·ψψᵀ, q̃ += w·ψ·ε.
    #[inline(always)]
    fn accumulate(&mut self, w: T, psi: &[T; NP], eps: T) {
        let mut idx = 0;
        for i in 0..NP {
            if T::COMPENSATED {
                // W decides the fixed point: form w·ψ_iψ_j exactly.
                let (ah, al) = two_prod(w, psi[i]);
                for j in i..NP {
                    let (p, e) = product_dw(ah, al, psi[j]);
                    self.p.add_dw(idx, p, e);
                    idx += 1;
                }
                let (p, e) = product_dw(ah, al, eps);
                self.q.add_dw(i, p, e);
            } else {
                let a = w * psi[i];
                for j in i..NP {
                    self.p.hi[idx] += a * psi[j];
                    idx += 1;
                }
                self.q.hi[i] += a * eps;
            }
        }
    }

    /// (R + K·TsΓ·P)Δ = −K·TsΓ·W with W = P(θ̂ − θ_m) − q, divided by g.
    ///
    ///
    /// The step matrix's diagonal is raised by [`STEP_DAMPING`]·NP·ε times
    /// its largest diagonal entry (Levenberg–Marquardt damping). The
    /// factorization of a matrix with cond ≳ 1/ε has a backward error of
    /// that size; without the damping it can *over*-estimate the inverse in
    /// a weak direction and the iteration stops contracting (single
    /// precision, paper plant: cond(P) ≈ 1.6e7 after 3 s, divergence after
    /// 1.3 s). With it the computed inverse under-estimates, which only
    /// slows that direction; the fixed point W = 0 is unchanged.
    fn step(&mut self) -> Result<(), LawError> {
        let w = self.w_unscaled();
        let one_plus = T::ONE + self.step.gain();
        // S packed like P̃ (upper triangle row by row).
        let mut s = [T::ZERO; NS];
        let mut max_diag = T::ZERO;
        for (v, &p) in s.iter_mut().zip(self.p.hi.iter()) {
            *v = one_plus * p;
        }
        let mut idx = 0;
        for i in 0..NP {
            if let Some(&d) = s.get(idx) {
                max_diag = max_diag.max(d);
            }
            idx += NP - i;
        }
        let mut idx = 0;
        for i in 0..NP {
            if let (Some(v), Some(&r0)) = (s.get_mut(idx), self.r0_diag.get(i)) {
                *v += self.damping * max_diag + self.r0_weight * r0;
            }
            idx += NP - i;
        }
        // No by-product here: its inputs are never asked for.
        self.step
            .apply(&mut s, &w, &mut self.theta, || (T::ZERO, T::ZERO))
    }

    /// P (scaled, working precision, full symmetric).
    pub fn p(&self) -> [[T; NP]; NP] {
        let mut m = [[T::ZERO; NP]; NP];
        let mut idx = 0;
        for i in 0..NP {
            for j in i..NP {
                let v = self.p.get(idx).value() * self.scale;
                m[i][j] = v;
                m[j][i] = v;
                idx += 1;
            }
        }
        m
    }

    /// Every word finite, P's diagonal non-negative.
    pub(crate) fn is_healthy(&self) -> bool {
        let mut idx = 0;
        for i in 0..NP {
            if !(self.p.hi[idx] >= T::ZERO) {
                return false;
            }
            idx += NP - i;
        }
        self.p.is_finite()
            && self.q.is_finite()
            && self.theta.is_finite()
            && self.model.is_finite()
            && self.scale.is_finite()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn converges_to_the_linearized_solution_from_any_model() {
        // ε = ψᵀ(θ* − θ_m) exactly: W = 0 at θ̂ = θ*, wherever θ_m is.
        let star = [0.3, -1.2, 0.7];
        let mut m = CompensatedArray::<f64, 3>::default();
        m.set(0, 1.0);
        m.set(2, -0.5);
        let mut law = OeLaw::<f64, 3, 6>::new(1e4, 0.01, &[1e-9; 3], 10, 1e-4).unwrap();
        law.restart(&m);
        for k in 0..20_000 {
            let t = k as f64 * 1e-3;
            let psi = [t.sin(), (2.3 * t).cos(), 1.0];
            let eps: f64 = (0..3).map(|i| psi[i] * (star[i] - m.get(i).value())).sum();
            law.update(&psi, eps).unwrap();
        }
        let th = law.theta().values();
        for i in 0..3 {
            assert!((th[i] - star[i]).abs() < 1e-9, "{i}: {}", th[i]);
        }
        assert!(law.residual_variance().unwrap() > 0.0);
        assert!(law.is_healthy());
    }
}
