//! The θ step of the proposed law, eq. 41 (θ' = −ΓHW), in its one
//! implementation: the backward-Euler step
//! θ⁺ = θ − K·TsΓ·H(Pθ⁺ − Q) ⇔ S·Δ = −K·TsΓ·W, S = R + K·TsΓ·P (R = H⁻¹,
//! eq. 39), θ⁺ = θ + Δ, taken every K samples, with Lemma 1 in the loop
//! ([`InLoopLemma1`]) as its by-product: the factors of S serve one step
//! of inverse iteration for λmin(P).
//!
//! Both laws that run eq. 41 own one: the equation-error law
//! ([`super::AdaptiveLaw`], W = Pθ − Q of eq. 35) and the robust
//! estimator's output-error law (`robust/law.rs`, W = P(θ̂ − θ_m) − q).
//! Each forms its own S from the matrices it keeps (information form,
//! lazily scaled; the output-error law adds a Levenberg–Marquardt damping)
//! and its own W; the step's gain, cadence, solve, checks and update of θ
//! are here. The backward-Euler step is unconditionally stable for any Γ,
//! H(0), l, γ and has the fixed point W = 0 of the explicit one
//! (`adaptive.rs`, module docs, for the measurements).

use super::{positive, ConfigError, LawError};
use crate::linalg::ldlt_solve_packed_floored_keep;
use crate::scalar::compensated::{Compensated, CompensatedArray};
use crate::scalar::Real;
use crate::supervise::InLoopLemma1;

/// What the θ step does with the factors of S besides solving for Δ:
/// Lemma 1 in the loop ([`InLoopLemma1`]), or nothing (`()`).
pub(crate) trait ByProduct<T, const NP: usize> {
    /// Take the factors of this θ step's S (`s`, `inv_d`) and its gain
    /// K·TsΓ; `inputs` gives tr(P̃) and the R(0) share of λmin(S) when
    /// they are needed.
    fn take<const NS: usize>(
        &mut self,
        s: &[T; NS],
        inv_d: &[T; NP],
        gain: T,
        inputs: impl FnOnce() -> (T, T),
    );
    /// Back to the start.
    fn reset(&mut self);
}

impl<T, const NP: usize> ByProduct<T, NP> for () {
    #[inline(always)]
    fn take<const NS: usize>(
        &mut self,
        _: &[T; NS],
        _: &[T; NP],
        _: T,
        _: impl FnOnce() -> (T, T),
    ) {
    }
    fn reset(&mut self) {}
}

impl<T: Real, const NP: usize> ByProduct<T, NP> for InLoopLemma1<T, NP> {
    /// One inverse-iteration step every [`crate::supervise::LEMMA1_EVERY`]
    /// θ steps.
    #[inline(always)]
    fn take<const NS: usize>(
        &mut self,
        s: &[T; NS],
        inv_d: &[T; NP],
        gain: T,
        inputs: impl FnOnce() -> (T, T),
    ) {
        if self.due() {
            let (trace, prior) = inputs();
            self.iterate(s, inv_d, trace, prior, gain);
        }
    }

    fn reset(&mut self) {
        *self = Self::default();
    }
}

/// Gain, cadence and by-product of the θ step (module docs).
#[derive(Debug, Clone)]
pub(crate) struct ThetaStep<T, const NP: usize, B> {
    /// K·Ts·Γ, K = samples per θ step.
    gain: T,
    /// K.
    every: u32,
    /// Samples since the last θ step.
    pending: u32,
    /// What the factors of S also serve.
    by_product: B,
}

impl<T: Real, const NP: usize, B: ByProduct<T, NP>> ThetaStep<T, NP, B> {
    /// Γ = `gain` (1/s) of eq. 41, stepped every `every` samples of
    /// `ts_s`, on packed matrices of `NS` entries, with `by_product`.
    ///
    /// # Errors
    /// The assumptions the step relies on: [`ConfigError::Dimensions`]
    /// unless `NS = NP(NP+1)/2` (S is packed), [`ConfigError::Gain`]
    /// unless Γ and Ts are positive and finite and K ≥ 1 (S is then
    /// positive definite whenever R is).
    pub fn new<const NS: usize>(
        gain: f64,
        ts_s: f64,
        every: u32,
        by_product: B,
    ) -> Result<Self, ConfigError> {
        if NS != NP * (NP + 1) / 2 {
            return Err(ConfigError::Dimensions);
        }
        positive(gain)?;
        positive(ts_s)?;
        if every == 0 {
            return Err(ConfigError::Gain);
        }
        Ok(Self {
            gain: T::from_f64(ts_s * gain * every as f64),
            every,
            pending: 0,
            by_product,
        })
    }

    /// K·Ts·Γ: S = R + this·P, right-hand side −this·W.
    #[inline(always)]
    pub fn gain(&self) -> T {
        self.gain
    }

    /// Count one sample; true on every K-th, when the θ step is due.
    #[inline(always)]
    pub fn due(&mut self) -> bool {
        // Not `due_after(1)`: its saturating add costs the adaptive law's
        // step 4 instructions per sample on the Cortex-M4F (`cargo xtask
        // qemu`); one sample at a time cannot overflow.
        self.pending += 1;
        if self.pending < self.every {
            return false;
        }
        self.pending = 0;
        true
    }

    /// Count `n` samples at once; true if the θ step falls due among them
    /// (one step, however many multiples of K they span).
    #[inline(always)]
    pub fn due_after(&mut self, n: u32) -> bool {
        self.pending = self.pending.saturating_add(n);
        if self.pending < self.every {
            return false;
        }
        self.pending = 0;
        true
    }

    /// Back to the start: no sample pending, the by-product reset.
    pub fn reset(&mut self) {
        self.pending = 0;
        self.by_product.reset();
    }

    /// Solve S·Δ = −K·TsΓ·W with the floored root-free LDLᵀ (`s`, packed,
    /// is overwritten by its factors), hand the factors to the by-product
    /// (`inputs`: see [`ByProduct::take`]) and add Δ to `theta`. On an
    /// error θ is unchanged: [`LawError::Singular`] if S is not positive
    /// definite even after flooring, [`LawError::NonFinite`] if Δ or θ + Δ
    /// is not finite.
    #[inline(always)]
    pub fn apply<const NS: usize>(
        &mut self,
        s: &mut [T; NS],
        w: &[T; NP],
        theta: &mut CompensatedArray<T, NP>,
        inputs: impl FnOnce() -> (T, T),
    ) -> Result<(), LawError> {
        let mut rhs = [T::ZERO; NP];
        for (r, wi) in rhs.iter_mut().zip(w.iter()) {
            *r = -self.gain * *wi;
        }
        let mut inv_d = [T::ZERO; NP];
        // (The solve refuses a Δ that is not finite.)
        let delta =
            ldlt_solve_packed_floored_keep(s, &rhs, &mut inv_d).map_err(|_| LawError::Singular)?;
        self.by_product.take(s, &inv_d, self.gain, inputs);
        // θ + Δ word by word (a copy of θ would be a memcpy call on the
        // Cortex-M4F); finite leading words mean finite trailing ones.
        let next: [Compensated<T>; NP] = core::array::from_fn(|i| {
            let mut c = theta.get(i);
            c.add(delta.get(i).copied().unwrap_or(T::ZERO));
            c
        });
        if !next.iter().all(|c| c.hi.is_finite()) {
            return Err(LawError::NonFinite);
        }
        for ((h, l), c) in theta.hi.iter_mut().zip(theta.lo.iter_mut()).zip(next) {
            (*h, *l) = (c.hi, c.lo);
        }
        Ok(())
    }
}

impl<T: Real, const NP: usize> ThetaStep<T, NP, InLoopLemma1<T, NP>> {
    /// The in-loop Lemma 1 estimate λmin(P)/tr(P), once it has run.
    pub fn lemma1_ratio(&self) -> Option<T> {
        self.by_product.ratio()
    }
}
