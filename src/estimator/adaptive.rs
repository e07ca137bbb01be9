//! The proposed adaptive law (Section III.B, eqs. 33–41), discretized
//! exactly where the paper's ODEs allow it and implicitly where they do not.
//!
//! Continuous law, in scaled coordinates (φ, y_s, θ_s; see
//! `filter_bank::Scaling`):
//!
//! * P' = −lP + φφᵀ, Q' = −lQ + φy (eq. 33),
//! * W = Pθ − Q (eq. 35),
//! * H' = γH − HφφᵀH, i.e. (H⁻¹)' = −γH⁻¹ + φφᵀ (eqs. 37, 39, 44),
//! * θ' = −ΓHW (eq. 41).
//!
//! # Design
//! * **P, Q**: the exact solution (34) over one sample with φ held:
//!   P ← e^{−lTs}P + Ts·φφᵀ (the rectangle rule of the convolution).
//! * **H in information form.** We keep R = H⁻¹, whose exact update (39) is
//!   R ← e^{−γTs}R + Ts·φφᵀ, and never form H. (Euler of eq. 37 diverges at
//!   step 8 with the paper's H0; RK4 at 10× H0 — DESIGN.md §3.)
//! * **θ by a backward-Euler step.** The explicit step
//!   θ ← θ − TsΓH(Pθ − Q) is stable only while TsΓλmax(HP) < 2, and with
//!   γ ≠ l (the paper's l = 0.01, γ = 0.1) λmax(HP) reaches the thousands
//!   while H0 dominates. The implicit step
//!   θ⁺ = θ − TsΓH(Pθ⁺ − Q) ⇔ (R + TsΓP)·Δ = −TsΓ·W, θ⁺ = θ + Δ
//!   is unconditionally stable for any Γ, H0, l, γ, has the same fixed point
//!   Pθ = Q, and costs one 7×7 Cholesky solve per sample — about what
//!   forming H by Sherman–Morrison would cost. The Lyapunov argument of
//!   Theorem 1 carries over: V = θ̃ᵀRθ̃/(2Γ) decreases along the implicit
//!   step whenever it decreases along the ODE.
//! * If the step matrix is not positive definite (no excitation yet and R
//!   decayed to zero), θ is held and the step reports [`LawError::Singular`].

use super::{positive, ConfigError, LawError, UpdateLaw};
use crate::filter_bank::{Regressor, Scaling};
use crate::linalg::{all_finite, cholesky_solve, decay_add_outer, mat_vec};
use crate::scalar::Real;

/// Gains of the proposed law, in scaled coordinates.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AdaptiveConfig<const NP: usize> {
    /// Learning gain Γ of eq. 41 (1/s).
    pub gain: f64,
    /// Forgetting factor l of eq. 33 (1/s).
    pub forgetting_p: f64,
    /// Forgetting factor γ of eq. 37 (1/s).
    pub forgetting_h: f64,
    /// Diagonal of H(0)⁻¹ = R(0) (scaled). Must be positive.
    pub r0_diag: [f64; NP],
    /// Initial scaled estimate θ_s(0).
    pub theta0: [f64; NP],
}

impl<const NP: usize> Default for AdaptiveConfig<NP> {
    /// Defaults for scaled coordinates (measured in BENCHMARKS.md): Γ = 1e4,
    /// l = γ = 0.05, R(0) = 1e-9·I, θ(0) = 0.
    fn default() -> Self {
        Self {
            gain: 10000.0,
            forgetting_p: 0.05,
            forgetting_h: 0.05,
            r0_diag: [1e-9; NP],
            theta0: [0.0; NP],
        }
    }
}

impl<const NP: usize> AdaptiveConfig<NP> {
    /// The paper's simulation gains (Section IV.A), given in physical units
    /// and mapped exactly to scaled coordinates: Γ = 80, l = 0.01, γ = 0.1,
    /// H(0) = `h0_physical` (for two modes, 1e22·diag(1, 1, 10, 10, 10, 10, 10)).
    /// R_s(0) = E·H(0)⁻¹·E with E from [`Scaling`].
    pub fn paper(scaling: &Scaling<NP>, h0_physical: &[f64; NP]) -> Self {
        let mut r0_diag = [0.0; NP];
        for j in 0..NP {
            r0_diag[j] = scaling.e[j] * scaling.e[j] / h0_physical[j];
        }
        Self {
            gain: 10000.0,
            forgetting_p: 0.01,
            forgetting_h: 0.1,
            r0_diag,
            theta0: [0.0; NP],
        }
    }

    /// The paper's H(0) for two modes: 1e22·diag(1, 1, 10, 10, 10, 10, 10).
    pub const PAPER_H0_2_MODES: [f64; 7] = [1e22, 1e22, 1e23, 1e23, 1e23, 1e23, 1e23];
}

/// State of the proposed law.
#[derive(Debug, Clone)]
pub struct AdaptiveLaw<T, const NP: usize> {
    cfg: AdaptiveConfig<NP>,
    /// Ts·Γ.
    step_gain: T,
    ts: T,
    decay_p: T,
    decay_h: T,
    p: [[T; NP]; NP],
    q: [T; NP],
    r: [[T; NP]; NP],
    theta: [T; NP],
}

impl<T: Real, const NP: usize> AdaptiveLaw<T, NP> {
    /// Auxiliary matrix P (eq. 33), scaled.
    pub fn p(&self) -> &[[T; NP]; NP] {
        &self.p
    }
    /// Auxiliary vector Q (eq. 33), scaled.
    pub fn q(&self) -> &[T; NP] {
        &self.q
    }
    /// R = H⁻¹ (eq. 39), scaled.
    pub fn h_inverse(&self) -> &[[T; NP]; NP] {
        &self.r
    }
    /// W = Pθ − Q (eq. 35), scaled.
    pub fn w(&self) -> [T; NP] {
        let mut w = mat_vec(&self.p, &self.theta);
        for (wi, qi) in w.iter_mut().zip(self.q.iter()) {
            *wi -= *qi;
        }
        w
    }
}

impl<T: Real, const NP: usize> UpdateLaw<T, NP> for AdaptiveLaw<T, NP> {
    type Config = AdaptiveConfig<NP>;

    fn new(cfg: &Self::Config, ts_s: f64) -> Result<Self, ConfigError> {
        positive(cfg.gain)?;
        positive(cfg.forgetting_p)?;
        positive(cfg.forgetting_h)?;
        positive(ts_s)?;
        for &r in &cfg.r0_diag {
            positive(r)?;
        }
        if !cfg.theta0.iter().all(|t| t.is_finite()) {
            return Err(ConfigError::Gain);
        }
        let mut law = Self {
            cfg: *cfg,
            step_gain: T::from_f64(ts_s * cfg.gain),
            ts: T::from_f64(ts_s),
            decay_p: T::from_f64(libm::exp(-cfg.forgetting_p * ts_s)),
            decay_h: T::from_f64(libm::exp(-cfg.forgetting_h * ts_s)),
            p: [[T::ZERO; NP]; NP],
            q: [T::ZERO; NP],
            r: [[T::ZERO; NP]; NP],
            theta: [T::ZERO; NP],
        };
        law.reset();
        Ok(law)
    }

    #[inline]
    fn update(&mut self, reg: &Regressor<T, NP>) -> Result<(), LawError> {
        let phi = &reg.phi;
        decay_add_outer(&mut self.p, self.decay_p, self.ts, phi);
        decay_add_outer(&mut self.r, self.decay_h, self.ts, phi);
        let ty = self.ts * reg.y;
        for (qi, fi) in self.q.iter_mut().zip(phi.iter()) {
            *qi = self.decay_p * *qi + ty * *fi;
        }
        // (R + TsΓP)Δ = −TsΓ·W.
        let w = self.w();
        let mut s = self.r;
        let mut rhs = [T::ZERO; NP];
        for i in 0..NP {
            for j in 0..NP {
                s[i][j] += self.step_gain * self.p[i][j];
            }
            rhs[i] = -self.step_gain * w[i];
        }
        let delta = cholesky_solve(&mut s, &rhs).map_err(|_| LawError::Singular)?;
        let mut next = self.theta;
        for (t, d) in next.iter_mut().zip(delta.iter()) {
            *t += *d;
        }
        if !all_finite(&next) {
            return Err(LawError::NonFinite);
        }
        self.theta = next;
        Ok(())
    }

    fn theta_scaled(&self) -> &[T; NP] {
        &self.theta
    }

    fn reset(&mut self) {
        self.p = [[T::ZERO; NP]; NP];
        self.q = [T::ZERO; NP];
        self.r = [[T::ZERO; NP]; NP];
        for i in 0..NP {
            self.r[i][i] = T::from_f64(self.cfg.r0_diag[i]);
            self.theta[i] = T::from_f64(self.cfg.theta0[i]);
        }
    }

    fn information(&self) -> Option<&[[T; NP]; NP]> {
        Some(&self.p)
    }
}
