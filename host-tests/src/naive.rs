//! A deliberately straightforward port of the paper's law, kept only as a
//! reference that documents *why* the core's estimator is built the way it
//! is (issue 3): physical units (no signal scaling), plain (uncompensated)
//! sums, H kept by Sherman–Morrison, explicit Θ step, P and Q exact.
//!
//! * Ψ in physical units (eq. 29): the filter states are the core's, mapped
//!   back with E⁻¹ (so the discretization is identical and only the numerics
//!   differ);
//! * P ← e^{−lTs}P + TsΨΨᵀ, Q ← e^{−lTs}Q + TsΨy (eq. 34);
//! * H ← e^{γTs}[H − c·HΨΨᵀH/(1 + c·ΨᵀHΨ)], c = Ts·e^{γTs} (exact eq. 39);
//! * Θ ← Θ − TsΓH(PΘ − Q) (eq. 41, explicit).
//!
//! In `f64` this converges on the paper's plant with the paper's gains; in
//! `f32` it does not (see `tests/precision.rs`).

use beamest::filter_bank::{FilterBank, FilterConfig, Scaling, SignalScales};
use beamest::model::TransferFunction;
use beamest::Real;

/// The paper's law in physical units, plain arithmetic, two modes.
pub struct NaiveAdaptive<T> {
    bank: FilterBank<T, 4, 7>,
    inv_e: [T; 7],
    lambda_rad_s: f64,
    ts: T,
    gain: T,
    decay_p: T,
    growth_h: T,
    p: [[T; 7]; 7],
    q: [T; 7],
    h: [[T; 7]; 7],
    theta: [T; 7],
}

impl<T: Real> NaiveAdaptive<T> {
    /// The paper's simulation gains: Γ = 80, l = 0.01, γ = 0.1,
    /// H(0) = 1e22·diag(1, 1, 10, 10, 10, 10, 10), Θ(0) = 0.
    pub fn paper(ts_s: f64, lambda_rad_s: f64) -> Self {
        let cfg = FilterConfig {
            ts_s,
            lambda_rad_s,
            scales: SignalScales::default(),
            ..FilterConfig::default()
        };
        let scaling = Scaling::<7>::new(&cfg);
        let h0 = [1e22, 1e22, 1e23, 1e23, 1e23, 1e23, 1e23];
        let mut h = [[T::ZERO; 7]; 7];
        for (i, row) in h.iter_mut().enumerate() {
            row[i] = T::from_f64(h0[i]);
        }
        Self {
            bank: FilterBank::new(&cfg).expect("valid filter"),
            inv_e: scaling.e.map(|e| T::from_f64(1.0 / e)),
            lambda_rad_s,
            ts: T::from_f64(ts_s),
            gain: T::from_f64(80.0),
            decay_p: T::from_f64((-0.01 * ts_s).exp()),
            growth_h: T::from_f64((0.1 * ts_s).exp()),
            p: [[T::ZERO; 7]; 7],
            q: [T::ZERO; 7],
            h,
            theta: [T::ZERO; 7],
        }
    }

    /// Push one sample (u held, y sampled), physical units.
    pub fn step(&mut self, u: T, y: T) {
        let reg = self.bank.push(u, y);
        let mut psi = [T::ZERO; 7];
        for i in 0..7 {
            psi[i] = reg.phi[i] * self.inv_e[i];
        }
        let y = reg.y;
        for i in 0..7 {
            for j in 0..7 {
                self.p[i][j] = self.decay_p * self.p[i][j] + self.ts * psi[i] * psi[j];
            }
            self.q[i] = self.decay_p * self.q[i] + self.ts * psi[i] * y;
        }
        // Sherman–Morrison on H⁻¹ ← e^{−γTs}H⁻¹ + TsΨΨᵀ.
        let c = self.ts * self.growth_h;
        let mut hp = [T::ZERO; 7];
        for i in 0..7 {
            for j in 0..7 {
                hp[i] += self.h[i][j] * psi[j];
            }
        }
        let mut denom = T::ONE;
        for i in 0..7 {
            denom += c * psi[i] * hp[i];
        }
        for i in 0..7 {
            for j in 0..7 {
                self.h[i][j] = self.growth_h * (self.h[i][j] - c * hp[i] * hp[j] / denom);
            }
        }
        // W = PΘ − Q; Θ ← Θ − TsΓHW.
        let mut w = [T::ZERO; 7];
        for i in 0..7 {
            w[i] = -self.q[i];
            for j in 0..7 {
                w[i] += self.p[i][j] * self.theta[j];
            }
        }
        for i in 0..7 {
            let mut hw = T::ZERO;
            for j in 0..7 {
                hw += self.h[i][j] * w[j];
            }
            self.theta[i] -= self.ts * self.gain * hw;
        }
    }

    /// Estimated transfer function (a, b of eq. 25).
    pub fn transfer_function(&self) -> Option<TransferFunction<T>> {
        TransferFunction::from_theta(&self.theta, self.lambda_rad_s)
    }
}
