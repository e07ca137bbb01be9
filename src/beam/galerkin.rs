//! The Galerkin projection of the beam PDE onto its mode shapes (eq. 49–57):
//! mass, damping and stiffness matrices and the piezo input vector, by
//! composite Gauss–Legendre quadrature.
//!
//! # Design
//!
//! **Sign of the input z_i.** Projecting eq. 12 onto W_j gives, for the
//! actuator term, ∫ W_j ∂²M_a/∂x² dx = r_a d31 E_p U_a [W_j'(x_b) − W_j'(x_a)]
//! (distributional derivative of the Heaviside window of eq. 9). Moving it to
//! the right-hand side gives exactly eq. 21, M η̈ + C η̇ + K η = z u, with the
//! *first line* of eq. 57: z_i = r_a d31 E_p [W_i'(x_a) − W_i'(x_b)]. We use
//! that convention, so b̄_i = z_i/m_ii enters B̄ of eq. 24 with a plus sign.
//! (Eq. 53 keeps the term on the left, "+ z_i u", which is consistent with
//! the *second* line of eq. 57, z_i = r_a d31 E_p ∫W_i ∂²/∂x²[H(x−x_a) −
//! H(x−x_b)] dx = r_a d31 E_p [W_i'(x_b) − W_i'(x_a)], the opposite sign of
//! its first line. Both pairs describe the same physics; mixing eq. 53 with
//! the first line of eq. 57 would flip every b̄_i.)
//!
//! **Units of z_i.** Eq. 8, M_a = r_a d31 E_p U_a, has the unit N, not N·m:
//! the moment of a patch of width b_p is r_a d31 E_p b_p U_a. We follow the
//! paper literally (no b_p), so z_i is in N/(V·m) and b̄_i in 1/(V·s²);
//! multiply both by the patch width (m) for the physical N/V and m/(V·s²).
//! Only the input gain is affected; ω_i, ζ_i and c_i are not.

use super::error::BeamError;
use super::params::BeamParams;
use super::shape::ModeShape;
use crate::model::MAX_MODES;

/// Number of equal panels of the composite Gauss–Legendre rule over [0, L].
/// With 5 nodes per panel the rule is exact for polynomials of degree 9 per
/// panel; for the first three modes β·(L/64) < 0.13, so the quadrature error
/// of the Galerkin integrals is at the level of rounding.
pub(crate) const QUADRATURE_PANELS: usize = 64;

/// Nodes of the 5-point Gauss–Legendre rule on [−1, 1]: 0, ±√(5 − 2√(10/7))/3,
/// ±√(5 + 2√(10/7))/3.
const GL5_NODES: [f64; 5] = [
    -0.906_179_845_938_664,
    -0.538_469_310_105_683_1,
    0.0,
    0.538_469_310_105_683_1,
    0.906_179_845_938_664,
];

/// Weights of the 5-point Gauss–Legendre rule on [−1, 1]: 128/225 at the
/// centre, (322 ± 13√70)/900 at the inner/outer pairs.
const GL5_WEIGHTS: [f64; 5] = [
    0.236_926_885_056_189_1,
    0.478_628_670_499_366_5,
    0.568_888_888_888_888_9,
    0.478_628_670_499_366_5,
    0.236_926_885_056_189_1,
];

/// ∫₀ᴸ f(x) dx by the composite 5-point Gauss–Legendre rule on
/// [`QUADRATURE_PANELS`] equal panels.
pub(crate) fn integrate<F: FnMut(f64) -> f64>(length_m: f64, mut f: F) -> f64 {
    let panel = length_m / QUADRATURE_PANELS as f64;
    let half = 0.5 * panel;
    let mut total = 0.0;
    for p in 0..QUADRATURE_PANELS {
        let mid = (p as f64 + 0.5) * panel;
        let mut sum = 0.0;
        for (node, weight) in GL5_NODES.iter().zip(GL5_WEIGHTS.iter()) {
            sum += weight * f(mid + half * node);
        }
        total += half * sum;
    }
    total
}

/// The Galerkin matrices of eq. 54–57 for the first `modes` mode shapes,
/// full (not assumed diagonal), with entries beyond `modes` zero.
///
/// m_ij = ∫ρA W_iW_j dx (54), c_ij = ∫CI W_i''''W_j dx (55),
/// k_ij = ∫EI W_i''''W_j dx (56), by quadrature with W_i'''' evaluated from
/// its own closed form (not replaced by β⁴W), so the diagonality of eq. 52 is
/// a genuine numerical property; z_i = r_a d31 E_p [W_i'(x_a) − W_i'(x_b)]
/// (57, first line; see the module docs for the sign).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GalerkinMatrices {
    /// Number of modes n.
    pub modes: usize,
    /// Roots β_iL of eq. 20.
    pub beta_l: [f64; MAX_MODES],
    /// Mass matrix m_ij (kg), eq. 54.
    pub mass_kg: [[f64; MAX_MODES]; MAX_MODES],
    /// Damping matrix c_ij (N·s/m), eq. 55.
    pub damping_n_s_m: [[f64; MAX_MODES]; MAX_MODES],
    /// Stiffness matrix k_ij (N/m), eq. 56.
    pub stiffness_n_m: [[f64; MAX_MODES]; MAX_MODES],
    /// Input vector z_i of eq. 57 (N/(V·m) as the paper writes eq. 8, whose
    /// moment lacks the patch width; see the module docs).
    pub input_z: [f64; MAX_MODES],
}

impl BeamParams {
    /// Galerkin matrices of eq. 54–57 for the first `modes` modes.
    pub fn galerkin(&self, modes: usize) -> Result<GalerkinMatrices, BeamError> {
        GalerkinMatrices::new(self, modes)
    }
}

impl GalerkinMatrices {
    /// Compute eq. 54–57 for the first `modes` (1..=[`MAX_MODES`]) modes.
    pub fn new(params: &BeamParams, modes: usize) -> Result<Self, BeamError> {
        params.validate()?;
        if modes == 0 || modes > MAX_MODES {
            return Err(BeamError::ModeCount);
        }
        let l = params.length_m;
        let mut shapes = [ModeShape::new(1, l)?; MAX_MODES];
        for (i, shape) in shapes.iter_mut().enumerate().take(modes).skip(1) {
            *shape = ModeShape::new(i + 1, l)?;
        }
        let shapes = &shapes[..modes];

        let rho_a = params.density_kg_m3 * params.area_m2;
        let ei = params.youngs_modulus_pa * params.inertia_m4;
        let ci = params.damping_pa_s * params.inertia_m4;
        let piezo = params.moment_arm_m * params.piezo_d31_m_v * params.piezo_modulus_pa;

        let mut g = Self {
            modes,
            beta_l: [0.0; MAX_MODES],
            mass_kg: [[0.0; MAX_MODES]; MAX_MODES],
            damping_n_s_m: [[0.0; MAX_MODES]; MAX_MODES],
            stiffness_n_m: [[0.0; MAX_MODES]; MAX_MODES],
            input_z: [0.0; MAX_MODES],
        };
        for (i, wi) in shapes.iter().enumerate() {
            g.beta_l[i] = wi.beta_l();
            for (j, wj) in shapes.iter().enumerate() {
                let overlap = integrate(l, |x| wi.value(x) * wj.value(x));
                let fourth = integrate(l, |x| wi.derivative(4, x) * wj.value(x));
                g.mass_kg[i][j] = rho_a * overlap;
                g.stiffness_n_m[i][j] = ei * fourth;
                g.damping_n_s_m[i][j] = ci * fourth;
            }
            g.input_z[i] = piezo
                * (wi.derivative(1, params.actuator_start_m)
                    - wi.derivative(1, params.actuator_end_m));
        }
        Ok(g)
    }
}

#[cfg(test)]
// The tests walk several per-mode arrays in step; an index reads best there.
#[allow(clippy::needless_range_loop)]
mod tests {
    use super::*;
    use crate::beam::paper_shapes as shapes;
    use crate::scalar::isclose;

    const PI: f64 = core::f64::consts::PI;

    #[test]
    fn quadrature_rule_is_exact_to_degree_nine_per_panel() {
        let w: f64 = GL5_WEIGHTS.iter().sum();
        assert!(isclose(w, 2.0, 1e-15, 0.0));
        // Degree 9 is integrated exactly (up to rounding) on every panel.
        assert!(isclose(
            integrate(1.0, |x| libm::pow(x, 9.0)),
            0.1,
            1e-14,
            0.0
        ));
        assert!(isclose(integrate(PI, libm::sin), 2.0, 1e-14, 0.0));
    }

    #[test]
    fn galerkin_matrices_are_diagonal() {
        let g = BeamParams::paper().galerkin(MAX_MODES).unwrap();
        for i in 0..MAX_MODES {
            for j in 0..MAX_MODES {
                if i == j {
                    continue;
                }
                let m_scale = libm::sqrt(g.mass_kg[i][i] * g.mass_kg[j][j]);
                let k_scale = libm::sqrt(g.stiffness_n_m[i][i] * g.stiffness_n_m[j][j]);
                let c_scale = libm::sqrt(g.damping_n_s_m[i][i] * g.damping_n_s_m[j][j]);
                assert!(g.mass_kg[i][j].abs() < 1e-10 * m_scale, "m{i}{j}");
                assert!(g.stiffness_n_m[i][j].abs() < 1e-10 * k_scale, "k{i}{j}");
                assert!(g.damping_n_s_m[i][j].abs() < 1e-10 * c_scale, "c{i}{j}");
            }
        }
    }

    #[test]
    fn stiffness_equals_strain_energy_form() {
        // ∫EI W_i''''W_j = ∫EI W_i''W_j'' after two integrations by parts,
        // which is exact only with the boundary conditions of eq. 7.
        let p = BeamParams::paper();
        let g = p.galerkin(MAX_MODES).unwrap();
        let s = shapes(MAX_MODES);
        let ei = p.youngs_modulus_pa * p.inertia_m4;
        for i in 0..MAX_MODES {
            for j in 0..MAX_MODES {
                let energy = ei
                    * integrate(p.length_m, |x| {
                        s[i].derivative(2, x) * s[j].derivative(2, x)
                    });
                let scale = libm::sqrt(g.stiffness_n_m[i][i] * g.stiffness_n_m[j][j]);
                assert!(
                    (energy - g.stiffness_n_m[i][j]).abs() < 1e-10 * scale,
                    "{i}{j}"
                );
            }
        }
    }

    #[test]
    fn input_z_matches_patch_curvature_integral() {
        // z_i = r_a d31 E_p [W'(x_a) − W'(x_b)] = −r_a d31 E_p ∫_{x_a}^{x_b} W''.
        let p = BeamParams::paper();
        let g = p.galerkin(MAX_MODES).unwrap();
        let s = shapes(MAX_MODES);
        let piezo = p.moment_arm_m * p.piezo_d31_m_v * p.piezo_modulus_pa;
        let span = p.actuator_end_m - p.actuator_start_m;
        for i in 0..MAX_MODES {
            let curvature = integrate(span, |x| s[i].derivative(2, p.actuator_start_m + x));
            assert!(
                isclose(g.input_z[i], -piezo * curvature, 1e-12, 0.0),
                "mode {}",
                i + 1
            );
        }
        // Near the clamp W_i'' < 0 (paper sign), d31 < 0: z_i < 0 for all modes.
        assert!(g.input_z.iter().all(|z| *z < 0.0));
    }
}
