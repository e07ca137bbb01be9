//! The model's equation error on the raw stream: the guard's own copy of
//! the estimator's 1/Λ(s) filter bank ([`FilterBank`]) fed the raw u and
//! the offset-corrected y at the guard's entry, and the estimator's current
//! Θ̂ (eq. 29 of Wang, Costa-Castelló, Na et al., *Modelling and Adaptive
//! Parameter Estimation for a Piezoelectric Cantilever Beam*), give
//!
//! ε = y/Y0 − θ̂_sᵀφ = (Â(s)/Λ(s)·y − B̂(s)/Λ(s)·u)/Y0,
//!
//! the scaled equation error of eq. 29 for the current estimate. Once Θ̂
//! has converged, the beam's own vibration is gone from ε; what a sensor
//! adds to y enters ε through Â(s)/Λ(s): an offset step δ as δ·g(t), with
//! g the step response of Â/Λ (g(0) = 1, g(∞) = Â(0)/Λ(0) ≈ 0.9 on the
//! paper's plant at λ = 100 rad/s), and white noise σ with gain ≈ 1.
//! This module only computes ε; the tests on it are [`super::monitor`]'s.

use crate::filter_bank::{FilterBank, FilterConfig, FilterConfigError, Scaling};
use crate::scalar::Real;

/// The residual's filter bank and the model it is evaluated with.
#[derive(Debug, Clone)]
pub struct ResidualFilter<T, const D: usize, const NP: usize> {
    bank: FilterBank<T, D, NP>,
    /// 1/(Y0·E_j): physical Θ → scaled θ_s ([`Scaling`]).
    to_scaled: [T; NP],
    theta_s: [T; NP],
    has_model: bool,
}

impl<T: Real, const D: usize, const NP: usize> ResidualFilter<T, D, NP> {
    /// A bank with the estimator's filter settings `cfg` (λ, U0, Y0, Ts,
    /// hold, timing: the Θ̂ it will be given must be for the same λ).
    ///
    /// # Errors
    /// The bank's [`FilterConfigError`].
    pub fn new(cfg: &FilterConfig) -> Result<Self, FilterConfigError> {
        let bank = FilterBank::new(cfg)?;
        let s = Scaling::<NP>::new(cfg);
        let mut to_scaled = [T::ZERO; NP];
        for (t, e) in to_scaled.iter_mut().zip(s.e.iter()) {
            *t = T::from_f64(1.0 / (s.y_scale * e));
        }
        Ok(Self {
            bank,
            to_scaled,
            theta_s: [T::ZERO; NP],
            has_model: false,
        })
    }

    /// Evaluate with the physical Θ̂ `theta` (eq. 29, the estimator's
    /// [`crate::estimator::Estimator::theta`]); a non-finite entry drops
    /// the model. Returns whether a model is set.
    pub fn set_theta(&mut self, theta: &[T; NP]) -> bool {
        if theta.iter().all(|v| v.is_finite()) {
            for ((s, t), k) in self.theta_s.iter_mut().zip(theta).zip(&self.to_scaled) {
                *s = *t * *k;
            }
            self.has_model = true;
        } else {
            self.has_model = false;
        }
        self.has_model
    }

    /// Forget the model (ε is NaN until the next [`Self::set_theta`]).
    pub fn clear_theta(&mut self) {
        self.has_model = false;
    }

    /// Push one finite raw pair (u held over the coming period, y sampled
    /// now); returns ε of the sample [`RESIDUAL_LAG`] pushes back (the
    /// bank's interpolating hold looks ahead), NaN without a model.
    #[inline]
    pub fn push(&mut self, u: T, y: T) -> T {
        let r = self.bank.push(u, y);
        if !self.has_model {
            return T::from_f64(f64::NAN);
        }
        let mut p = T::ZERO;
        for ((t, a), b) in self.theta_s.iter().zip(&r.phi).zip(&r.phi_lo) {
            p += *t * *a;
            if T::COMPENSATED {
                p += *t * *b;
            }
        }
        r.y - p
    }

    /// The bank back to rest (the model stays).
    pub fn reset(&mut self) {
        self.bank.reset();
    }
}

/// Pushes between a sample and its ε ([`ResidualFilter::push`]): the
/// bank's quintic hold integrates [t_{n−3}, t_{n−2}] at push n and returns
/// the regressor at t_{n−2}.
pub const RESIDUAL_LAG: usize = 2;
