//! The least-squares baseline, eq. 48:
//! Θ' = Γ2·e·Ψ, e = y − ΘᵀΨ, Γ2' = −Γ2ΨΨᵀΓ2.
//!
//! # Design
//! (Γ2⁻¹)' = ΨΨᵀ and (Γ2⁻¹Θ)' = Ψy, so with Ψ held over a sample the exact
//! step is the "exact-sum" recursive least squares:
//! Γ2⁺ = Γ2 − TsΓ2φφᵀΓ2/(1 + Tsφᵀ Γ2φ) (Sherman–Morrison of
//! Γ2⁻¹ ← Γ2⁻¹ + Tsφφᵀ) and θ⁺ = θ + Ts·Γ2⁺φ·e. Unlike Euler or RK4 of (48),
//! which make Γ2 indefinite at the 4th sample with the paper's Γ2(0) (test
//! `estimator::tests::explicit_riccati_steps_break_down_with_the_paper_gains`),
//! this never winds up; it is the honest version of the baseline. There is no forgetting, as in
//! the paper.

use super::{all_finite_f64, all_positive, positive, ConfigError, LawError, UpdateLaw};
use crate::filter_bank::{Regressor, Scaling};
use crate::linalg::{all_finite, dot, mat_vec};
use crate::scalar::Real;

/// Gains of the least-squares law, in scaled coordinates.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct LeastSquaresConfig<const NP: usize> {
    /// Diagonal of Γ2(0) (scaled).
    pub gain0_diag: [f64; NP],
    /// Initial scaled estimate.
    pub theta0: [f64; NP],
}

impl<const NP: usize> Default for LeastSquaresConfig<NP> {
    /// Γ2(0) = 1e9·I in scaled coordinates: the same initial gain as the
    /// proposed law's default H(0) = R(0)⁻¹ = 1e9·I, so the two laws are
    /// compared from the same start. Unlike the proposed law, whose fixed
    /// point PΘ = Q does not depend on H(0), least squares without
    /// forgetting keeps Γ2(0)⁻¹ as a prior for ever: it biases the estimate
    /// by about Γ2(0)⁻¹·P⁻¹ (1.4e-5 on the paper's plant after 20 s; 1.4e-2
    /// with Γ2(0) = 1e6).
    fn default() -> Self {
        Self {
            gain0_diag: [1e9; NP],
            theta0: [0.0; NP],
        }
    }
}

impl<const NP: usize> LeastSquaresConfig<NP> {
    /// Map a physical diagonal Γ2(0) to scaled coordinates: Γ2,s = E⁻¹Γ2E⁻¹.
    pub fn from_physical(scaling: &Scaling<NP>, gain0_physical: &[f64; NP]) -> Self {
        Self {
            gain0_diag: scaling.gain_to_scaled(gain0_physical),
            theta0: [0.0; NP],
        }
    }

    /// The paper's Γ2(0) for two modes: 1e23·diag(1, 1, 1, 10, 10, 10, 10).
    pub const PAPER_GAIN0_2_MODES: [f64; 7] = [1e23, 1e23, 1e23, 1e24, 1e24, 1e24, 1e24];
}

/// State of the least-squares law.
#[derive(Debug, Clone)]
pub struct LeastSquaresLaw<T, const NP: usize> {
    cfg: LeastSquaresConfig<NP>,
    ts: T,
    gain: [[T; NP]; NP],
    theta: [T; NP],
}

impl<T: Real, const NP: usize> UpdateLaw<T, NP> for LeastSquaresLaw<T, NP> {
    type Config = LeastSquaresConfig<NP>;

    fn new(cfg: &Self::Config, ts_s: f64) -> Result<Self, ConfigError> {
        positive(ts_s)?;
        all_positive(&cfg.gain0_diag)?;
        all_finite_f64(&cfg.theta0)?;
        let mut law = Self {
            cfg: *cfg,
            ts: T::from_f64(ts_s),
            gain: [[T::ZERO; NP]; NP],
            theta: [T::ZERO; NP],
        };
        law.reset();
        Ok(law)
    }

    #[inline]
    fn update(&mut self, reg: &Regressor<T, NP>) -> Result<(), LawError> {
        let phi = &reg.phi;
        let g = mat_vec(&self.gain, phi);
        let denom = T::ONE + self.ts * dot(phi, &g);
        if !(denom > T::ZERO) || !denom.is_finite() {
            return Err(LawError::NonFinite);
        }
        let k = self.ts / denom;
        let mut next_gain = self.gain;
        for i in 0..NP {
            let gi = g[i] * k;
            for j in i..NP {
                let v = self.gain[i][j] - gi * g[j];
                next_gain[i][j] = v;
                next_gain[j][i] = v;
            }
        }
        // Γ2⁺φ = Γ2φ/(1 + Tsφᵀ Γ2φ).
        let e = reg.y - dot(phi, &self.theta);
        let step = self.ts * e / denom;
        let mut next = self.theta;
        for j in 0..NP {
            next[j] += g[j] * step;
        }
        if !all_finite(&next) {
            return Err(LawError::NonFinite);
        }
        self.gain = next_gain;
        self.theta = next;
        Ok(())
    }

    fn theta_scaled(&self) -> [T; NP] {
        self.theta
    }

    fn reset(&mut self) {
        self.gain = [[T::ZERO; NP]; NP];
        for j in 0..NP {
            self.gain[j][j] = T::from_f64(self.cfg.gain0_diag[j]);
            self.theta[j] = T::from_f64(self.cfg.theta0[j]);
        }
    }

    fn information(&self) -> Option<[[T; NP]; NP]> {
        None
    }
}
