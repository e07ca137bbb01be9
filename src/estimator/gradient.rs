//! The gradient baseline, eq. 47: Θ' = Γ1·e·Ψ, e = y − ΘᵀΨ.
//!
//! # Design
//! With φ held over one sample the law is a linear ODE with rank-one
//! dynamics: the prediction error obeys e' = −c·e with c = φᵀΓ1φ, so the
//! exact step is θ⁺ = θ + Γ1φ·e·Ts·(1 − e^{−cTs})/(cTs). It is stable for any
//! gain (an explicit Euler step needs Ts·φᵀΓ1φ < 2). With the paper's Γ1
//! the largest Ts·ΨᵀΓ1Ψ over its 20 s run is 0.57, so explicit Euler would
//! be stable there too (test
//! `explicit_euler_of_the_gradient_law_is_stable_at_the_papers_gain`,
//! host-tests/tests/claims.rs); the exact step keeps larger gains safe. Γ1
//! is diagonal, as in the paper.

use super::{
    all_finite_f64, all_positive, one_minus_exp_over_x, positive, ConfigError, LawError, UpdateLaw,
};
use crate::filter_bank::{Regressor, Scaling};
use crate::linalg::{all_finite, dot};
use crate::scalar::Real;

/// Gains of the gradient law, in scaled coordinates.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct GradientConfig<const NP: usize> {
    /// Diagonal of Γ1 (scaled).
    pub gain_diag: [f64; NP],
    /// Initial scaled estimate.
    pub theta0: [f64; NP],
}

impl<const NP: usize> Default for GradientConfig<NP> {
    /// Γ1 = 1e2·I in scaled coordinates. The gradient law's convergence
    /// rate is not monotone in its gain: with a slowly varying regressor a
    /// large Γ1 makes θ follow each sample's projection instead of the
    /// average, and convergence slows (the classical bound on the rate,
    /// ∝ γα/(1 + γβ²)², for PE level α and ‖φ‖ ≤ β). Measured on a
    /// one-mode plant (ω = 200 rad/s, ζ = 0.2, the paper's square wave):
    /// ‖θ̃_s‖ after 10 s is 1.0e-6 at Γ1 = 1e2, 1.5e-5 at 3e2, 8.2e-3 at
    /// 1e3, 1.1e-4 at 30 (test `gradient_law_converges_on_a_one_mode_plant`
    /// in host-tests/tests/baselines.rs).
    fn default() -> Self {
        Self {
            gain_diag: [1e2; NP],
            theta0: [0.0; NP],
        }
    }
}

impl<const NP: usize> GradientConfig<NP> {
    /// Map a physical diagonal Γ1 (the paper's) to scaled coordinates:
    /// Γ1,s = E⁻¹Γ1E⁻¹.
    pub fn from_physical(scaling: &Scaling<NP>, gain_physical: &[f64; NP]) -> Self {
        Self {
            gain_diag: scaling.gain_to_scaled(gain_physical),
            theta0: [0.0; NP],
        }
    }

    /// The paper's Γ1 for two modes (Section IV.A).
    pub const PAPER_GAIN_2_MODES: [f64; 7] = [2e11, 2e15, 6e19, 3e12, 2e17, 7e18, 4e23];
}

/// State of the gradient law.
#[derive(Debug, Clone)]
pub struct GradientLaw<T, const NP: usize> {
    cfg: GradientConfig<NP>,
    gain: [T; NP],
    ts: T,
    theta: [T; NP],
}

impl<T: Real, const NP: usize> UpdateLaw<T, NP> for GradientLaw<T, NP> {
    type Config = GradientConfig<NP>;

    fn new(cfg: &Self::Config, ts_s: f64) -> Result<Self, ConfigError> {
        positive(ts_s)?;
        all_positive(&cfg.gain_diag)?;
        all_finite_f64(&cfg.theta0)?;
        let gain = cfg.gain_diag.map(T::from_f64);
        let mut law = Self {
            cfg: *cfg,
            gain,
            ts: T::from_f64(ts_s),
            theta: [T::ZERO; NP],
        };
        law.reset();
        Ok(law)
    }

    #[inline]
    fn update(&mut self, reg: &Regressor<T, NP>) -> Result<(), LawError> {
        let phi = &reg.phi;
        let e = reg.y - dot(phi, &self.theta);
        let mut g = [T::ZERO; NP];
        let mut c = T::ZERO;
        for j in 0..NP {
            g[j] = self.gain[j] * phi[j];
            c += g[j] * phi[j];
        }
        let factor = self.ts * e * one_minus_exp_over_x(c * self.ts);
        let mut next = self.theta;
        for j in 0..NP {
            next[j] += g[j] * factor;
        }
        if !all_finite(&next) {
            return Err(LawError::NonFinite);
        }
        self.theta = next;
        Ok(())
    }

    fn theta_scaled(&self) -> [T; NP] {
        self.theta
    }

    fn reset(&mut self) {
        for j in 0..NP {
            self.theta[j] = T::from_f64(self.cfg.theta0[j]);
        }
    }

    fn information(&self) -> Option<[[T; NP]; NP]> {
        None
    }
}
