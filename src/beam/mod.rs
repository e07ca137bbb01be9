//! Euler–Bernoulli physics of the piezo-actuated cantilever (Section II and
//! Appendix of Wang, Costa-Castelló, Na et al., *Modelling and Adaptive
//! Parameter Estimation for a Piezoelectric Cantilever Beam*): from the
//! material data of Tables I–II to the modal model (ω_i, ζ_i, b̄_i, c_i) that
//! the estimator identifies.
//!
//! The chain, with the paper's equation numbers, one file per step:
//!
//! 1. `params`: the beam's material, geometry, actuator and sensor data
//!    (Tables I–II, [`BeamParams`]) and which output the model has
//!    ([`BeamOutput`]). The PDE (eq. 12) has Kelvin–Voigt damping (eq. 2–3)
//!    and the clamped-free boundary conditions (eq. 7).
//! 2. `shape`: the roots β_iL of the frequency equation
//!    cos βL·cosh βL + 1 = 0 (eq. 20, `frequency_root`) and the mode shapes
//!    W_i(x) of eq. 19 ([`ModeShape`]).
//! 3. `galerkin`: the Galerkin projection (eq. 49–57): mass m_ij (54),
//!    damping c_ij (55), stiffness k_ij (56) and piezo input z_i (57),
//!    integrated numerically by composite Gauss–Legendre quadrature
//!    ([`GalerkinMatrices`]).
//! 4. `modal`: the diagonal modal model M η̈ + C η̇ + K η = z u (eq. 21), its
//!    state-space form (eq. 22) and transfer function (eq. 25–26)
//!    ([`BeamModal`], `BeamStateSpace`).
//! 5. `strain`: eq. 17, the static map between the gauge strain and the tip
//!    deflection (`deflection_from_strain`, `strain_from_deflection`).
//!
//! Errors are one enum for the family ([`BeamError`], naming the bad
//! parameter through [`BeamParam`]), in `error`.
//!
//! The physics runs in `f64`: it is computed once, at start-up or on the
//! host, and its results are rounded to the estimator's scalar type there.
//! Each file's `# Design` section defends the choices made in that step (mode
//! shape sign and normalization in `shape`, the sign and units of z_i in
//! `galerkin`, the geometry the paper does not give in `params`).

pub(crate) mod error;
pub(crate) mod galerkin;
pub(crate) mod modal;
pub(crate) mod params;
pub(crate) mod shape;
// Eq. 17 as a pair of checked maps; the tests (and the conversion's
// tests) use it, the pipeline has its own (`pipeline::Eq17`).
#[cfg(test)]
pub(crate) mod strain;
#[cfg(test)]
pub(crate) use strain::deflection_from_strain;

pub use error::{BeamError, BeamParam};
pub use galerkin::GalerkinMatrices;
pub use modal::{BeamModal, ModeModel};
pub use params::{rectangular_thickness_m, BeamOutput, BeamParams};
pub use shape::ModeShape;

/// True for a finite, strictly positive number (NaN fails).
fn is_positive_finite(x: f64) -> bool {
    x.is_finite() && x > 0.0
}

/// The first `n` mode shapes of the paper's beam (the rest repeat mode 1),
/// for the tests of several files.
#[cfg(test)]
fn paper_shapes(n: usize) -> [ModeShape; crate::model::MAX_MODES] {
    let l = BeamParams::paper().length_m;
    let mut s = [ModeShape::new(1, l).unwrap(); crate::model::MAX_MODES];
    for (i, si) in s.iter_mut().enumerate().take(n) {
        *si = ModeShape::new(i + 1, l).unwrap();
    }
    s
}
