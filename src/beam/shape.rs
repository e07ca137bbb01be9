//! Mode shapes of the clamped-free beam: the roots β_iL of the frequency
//! equation (eq. 20) and the shapes W_i(x) of eq. 19 with their derivatives.
//!
//! # Design
//!
//! **Mode shapes.** Eq. 19 is garbled in the available text. We use the
//! classical clamped-free shape with the *paper's sign*,
//!
//! W_i(x) = cos β_ix − cosh β_ix − σ_i (sin β_ix − sinh β_ix),
//! σ_i = (cosh β_iL + cos β_iL)/(sinh β_iL + sin β_iL),
//!
//! i.e. the negative of the textbook form cosh − cos − σ(sinh − sin). With
//! this sign the tip values are W_i(L) = 2·(−1)^i = −2, 2, −2, …, which is the
//! paper's output row C̄ = [−2, 2] of eq. 24 and
//! [`model::default_output_weight`](crate::model::default_output_weight).
//! Every modal product the plant depends on (c_i·b̄_i, m_ii, k_ii, c_ii) is
//! invariant under a per-mode sign flip, so the transfer function is the same
//! with either sign.
//!
//! **Normalization.** No rescaling is applied: with the σ_i above,
//! ∫₀ᴸ W_i² dx = L and |W_i(L)| = 2 (both checked by the tests). The modal
//! coordinate η_i therefore has the unit of a deflection (m) and W_i is
//! dimensionless.
//!
//! **Numerical stability.** cosh βx − σ sinh βx cancels catastrophically for
//! large βx because σ → 1. We evaluate it as
//! ½(1−σ)e^{βx} + ½(1+σ)e^{−βx} with 1 − σ written without cancellation
//! (see [`ModeShape`]); the growing term is then bounded by O(1) for every
//! mode, so high modes (βL in the hundreds) evaluate as accurately as low ones.

use super::error::{BeamError, BeamParam};
use super::is_positive_finite;

/// π, for the root brackets of eq. 20.
const PI: f64 = core::f64::consts::PI;

/// Iteration cap of the safeguarded Newton search for β_iL. Newton converges
/// quadratically from the bracket centre in ≤ 6 steps; bisection alone would
/// need ~52 steps to reach f64 resolution on a bracket of width π/2.
const ROOT_MAX_ITERATIONS: usize = 100;

/// g(x) = cos x + 1/cosh x: eq. 20 divided by cosh x, same roots but O(1)
/// everywhere (cos x·cosh x + 1 grows like eˣ).
fn frequency_function(x: f64) -> f64 {
    libm::cos(x) + 1.0 / libm::cosh(x)
}

/// g'(x) = −sin x − tanh x / cosh x.
fn frequency_function_slope(x: f64) -> f64 {
    -libm::sin(x) - libm::tanh(x) / libm::cosh(x)
}

/// The `mode_number`-th (1-based) positive root β_iL of the clamped-free
/// frequency equation cos βL·cosh βL + 1 = 0 (eq. 20).
///
/// The i-th root lies within π/4 of (2i − 1)π/2 (for i ≥ 2 within about
/// 2e^{−βL} of it), where g(x) = cos x + 1/cosh x changes sign; it is found by Newton's
/// method safeguarded by bisection on that bracket, to f64 resolution.
/// Reference values: 1.875 104 068 7, 4.694 091 133 0, 7.854 757 438 2.
pub(crate) fn frequency_root(mode_number: usize) -> Result<f64, BeamError> {
    if mode_number == 0 {
        return Err(BeamError::ModeNumber);
    }
    let centre = (2.0 * mode_number as f64 - 1.0) * 0.5 * PI;
    let (mut lo, mut hi) = (centre - 0.25 * PI, centre + 0.25 * PI);
    let mut f_lo = frequency_function(lo);
    let mut f_hi = frequency_function(hi);
    // (Written so that a NaN also fails.)
    let bracketed = f_lo * f_hi < 0.0;
    if !bracketed {
        return Err(BeamError::RootNotConverged);
    }
    let tolerance = 4.0 * f64::EPSILON * centre;
    let mut x = centre;
    for _ in 0..ROOT_MAX_ITERATIONS {
        let f = frequency_function(x);
        if f == 0.0 {
            return Ok(x);
        }
        // Keep the sign change inside [lo, hi].
        if (f < 0.0) == (f_lo < 0.0) {
            lo = x;
            f_lo = f;
        } else {
            hi = x;
            f_hi = f;
        }
        let slope = frequency_function_slope(x);
        let newton = x - f / slope;
        // A Newton step that rounds onto the bracket end is still good (the
        // last step at f64 resolution does); otherwise bisect.
        let next = if slope != 0.0 && newton >= lo && newton <= hi {
            newton
        } else {
            0.5 * (lo + hi)
        };
        if libm::fabs(next - x) <= tolerance {
            return Ok(next);
        }
        if hi - lo <= tolerance {
            return Ok(if libm::fabs(f_lo) < libm::fabs(f_hi) {
                lo
            } else {
                hi
            });
        }
        x = next;
    }
    Err(BeamError::RootNotConverged)
}

/// One clamped-free mode shape W_i(x) (eq. 19, paper's sign; see the module
/// docs for the sign and normalization):
///
/// W(x) = cos βx − cosh βx − σ (sin βx − sinh βx),
/// σ = (cosh βL + cos βL)/(sinh βL + sin βL),
///
/// satisfying W(0) = W'(0) = 0 and W''(L) = W'''(L) = 0 (eq. 7),
/// W'''' = β⁴W, ∫₀ᴸ W² dx = L and W(L) = 2·(−1)^i.
///
/// Evaluated in the cancellation-free form
/// W(x) = −[½(1−σ)e^{βx} + ½(1+σ)e^{−βx} − cos βx + σ sin βx], with
/// ½(1−σ)e^{βx} = τ·e^{β(x−L)} and
/// τ = (sin βL − cos βL − e^{−βL}) / (1 − e^{−2βL} + 2 sin βL·e^{−βL}).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ModeShape {
    mode_number: usize,
    beta_l: f64,
    beta_per_m: f64,
    length_m: f64,
    sigma: f64,
    /// τ of the stable form: ½(1−σ)e^{βx} = τ·e^{β(x−L)}.
    tail: f64,
}

impl ModeShape {
    /// Mode `mode_number` (1-based) of a cantilever of length `length_m`.
    pub fn new(mode_number: usize, length_m: f64) -> Result<Self, BeamError> {
        if !is_positive_finite(length_m) {
            return Err(BeamError::InvalidParameter(BeamParam::Length));
        }
        let beta_l = frequency_root(mode_number)?;
        let e = libm::exp(-beta_l);
        let (s, c) = (libm::sin(beta_l), libm::cos(beta_l));
        let tail = (s - c - e) / (1.0 - e * e + 2.0 * s * e);
        // ½(1 − σ) = τ·e^{−βL}.
        let sigma = 1.0 - 2.0 * tail * e;
        Ok(Self {
            mode_number,
            beta_l,
            beta_per_m: beta_l / length_m,
            length_m,
            sigma,
            tail,
        })
    }

    /// Mode number i (1-based).
    pub fn mode_number(&self) -> usize {
        self.mode_number
    }

    /// Root β_iL of eq. 20 (dimensionless).
    pub fn beta_l(&self) -> f64 {
        self.beta_l
    }

    /// Wave number β_i = β_iL/L (1/m).
    pub fn beta_per_m(&self) -> f64 {
        self.beta_per_m
    }

    /// Beam length L (m).
    pub fn length_m(&self) -> f64 {
        self.length_m
    }

    /// σ_i = (cosh β_iL + cos β_iL)/(sinh β_iL + sin β_iL).
    pub fn sigma(&self) -> f64 {
        self.sigma
    }

    /// W(x) (dimensionless).
    pub fn value(&self, x_m: f64) -> f64 {
        self.derivative(0, x_m)
    }

    /// The `order`-th derivative dᵏW/dxᵏ at x (unit 1/mᵏ). Any order is
    /// supported; the exponential and trigonometric parts cycle with period
    /// 2 and 4 in k.
    pub fn derivative(&self, order: usize, x_m: f64) -> f64 {
        let beta = self.beta_per_m;
        let xi = beta * x_m;
        let grow = self.tail * libm::exp(xi - self.beta_l);
        let decay = 0.5 * (1.0 + self.sigma) * libm::exp(-xi);
        let (s, c) = (libm::sin(xi), libm::cos(xi));
        // k-th derivatives of cos ξ and sin ξ with respect to ξ.
        let (dcos, dsin) = match order % 4 {
            0 => (c, s),
            1 => (-s, c),
            2 => (-c, -s),
            _ => (s, -c),
        };
        let decay_sign = if order % 2 == 0 { 1.0 } else { -1.0 };
        let textbook = grow + decay_sign * decay - dcos + self.sigma * dsin;
        let mut scale = 1.0;
        for _ in 0..order {
            scale *= beta;
        }
        -scale * textbook
    }

    /// [W, W', W'', W''', W''''] at x.
    #[cfg(test)]
    pub(crate) fn derivatives(&self, x_m: f64) -> [f64; 5] {
        let mut d = [0.0; 5];
        for (k, dk) in d.iter_mut().enumerate() {
            *dk = self.derivative(k, x_m);
        }
        d
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::beam::galerkin::integrate;
    use crate::model::{default_output_weight, MAX_MODES};
    use crate::scalar::isclose;

    const BETA_L_REF: [f64; 3] = [1.875_104_068_7, 4.694_091_133_0, 7.854_757_438_2];
    /// The same roots to 17 significant digits (mpmath, 40-digit arithmetic).
    const BETA_L_PRECISE: [f64; 3] = [
        1.875_104_068_711_961,
        4.694_091_132_974_175,
        7.854_757_438_237_613,
    ];

    #[test]
    fn frequency_roots_match_reference() {
        for (i, r) in BETA_L_REF.iter().enumerate() {
            let bl = frequency_root(i + 1).unwrap();
            assert!((bl - r).abs() < 1e-9, "mode {}: {bl}", i + 1);
            // 40-digit values (mpmath findroot) to near f64 resolution.
            assert!(
                isclose(bl, BETA_L_PRECISE[i], 4.0 * f64::EPSILON, 0.0),
                "mode {}",
                i + 1
            );
            // Eq. 20 itself, in its scaled form.
            assert!(frequency_function(bl).abs() < 4.0 * f64::EPSILON * bl);
        }
        // Higher roots: satisfy eq. 20 and approach (2i − 1)π/2.
        for i in 4..=30 {
            let bl = frequency_root(i).unwrap();
            let centre = (2 * i - 1) as f64 * PI / 2.0;
            // |g'| ≈ 1 near the root, so |g| is bounded by the spacing of f64 at βL.
            assert!(
                frequency_function(bl).abs() < 4.0 * f64::EPSILON * bl,
                "mode {i}"
            );
            assert!(
                (bl - centre).abs() < 2.01 * libm::exp(-centre) + 4.0 * f64::EPSILON * centre,
                "mode {i}"
            );
        }
        assert_eq!(frequency_root(0), Err(BeamError::ModeNumber));
    }

    #[test]
    fn mode_shapes_satisfy_boundary_conditions() {
        let l = 0.36;
        for i in 1..=8 {
            let w = ModeShape::new(i, l).unwrap();
            let b = w.beta_per_m;
            // Scale of the k-th derivative: 2·β^k.
            let at0 = w.derivatives(0.0);
            let at_l = w.derivatives(l);
            assert!(at0[0].abs() < 1e-12, "mode {i} W(0) = {}", at0[0]);
            assert!(at0[1].abs() < 1e-12 * 2.0 * b, "mode {i} W'(0)");
            assert!(at_l[2].abs() < 1e-12 * 2.0 * b * b, "mode {i} W''(L)");
            assert!(at_l[3].abs() < 1e-12 * 2.0 * b * b * b, "mode {i} W'''(L)");
            // Tip value 2·(−1)^i: the paper's C̄ = [−2, 2] (eq. 24).
            let tip = if i % 2 == 0 { 2.0 } else { -2.0 };
            assert!(
                isclose(at_l[0], tip, 1e-12, 0.0),
                "mode {i} W(L) = {}",
                at_l[0]
            );
            if i <= MAX_MODES {
                assert_eq!(tip, default_output_weight(i - 1));
            }
        }
        // The stable form keeps high modes finite and on their BCs.
        let w = ModeShape::new(200, l).unwrap();
        let b = w.beta_per_m;
        assert!(w.value(0.0).abs() < 1e-12);
        assert!(isclose(w.value(l), 2.0, 1e-12, 0.0));
        assert!(w.derivative(2, l).abs() < 1e-12 * 2.0 * b * b);
    }

    #[test]
    fn mode_shapes_solve_the_beam_equation_and_are_normalized() {
        let l = 0.36;
        for i in 1..=MAX_MODES {
            let w = ModeShape::new(i, l).unwrap();
            let b4 = libm::pow(w.beta_per_m, 4.0);
            for k in 0..=10 {
                let x = l * k as f64 / 10.0;
                // W'''' = β⁴W (eq. 6 separated); scale 2β⁴.
                assert!((w.derivative(4, x) - b4 * w.value(x)).abs() < 1e-12 * 2.0 * b4);
            }
            // Derivative formula against a central difference of the lower one.
            let (x, dx) = (0.21, 1e-6);
            for k in 0..4 {
                let fd = (w.derivative(k, x + dx) - w.derivative(k, x - dx)) / (2.0 * dx);
                let scale = 2.0 * libm::pow(w.beta_per_m, (k + 1) as f64);
                assert!(
                    (fd - w.derivative(k + 1, x)).abs() < 1e-7 * scale,
                    "mode {i} k {k}"
                );
            }
            // ∫W² = L, and σ from its defining expression.
            assert!(isclose(
                integrate(l, |x| w.value(x) * w.value(x)),
                l,
                1e-13,
                0.0
            ));
            let bl = w.beta_l;
            let sigma = (libm::cosh(bl) + libm::cos(bl)) / (libm::sinh(bl) + libm::sin(bl));
            assert!(isclose(w.sigma, sigma, 1e-14, 0.0));
            // The stable evaluation equals eq. 19 written out directly.
            for k in 0..=10 {
                let xi = w.beta_per_m * l * k as f64 / 10.0;
                let direct =
                    libm::cos(xi) - libm::cosh(xi) - sigma * (libm::sin(xi) - libm::sinh(xi));
                assert!(
                    (w.value(xi / w.beta_per_m) - direct).abs() < 1e-12,
                    "mode {i}"
                );
            }
        }
    }
}
