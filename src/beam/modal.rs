//! The beam's diagonal modal model (eq. 21–24): per-mode ω_i, ζ_i, b̄_i and
//! c_i from the Galerkin matrices, its state-space form (eq. 22) and its
//! transfer function (eq. 25–26), the bridge to the estimator's
//! [`ModalParams`].

use super::error::BeamError;
use super::galerkin::GalerkinMatrices;
use super::is_positive_finite;
use super::params::BeamParams;
use super::shape::ModeShape;
#[cfg(test)]
use crate::model::MAX_ORDER;
use crate::model::{ModalParams, TransferFunction, MAX_MODES};

/// The diagonal modal model of the beam (eq. 21–24) for n modes: every
/// per-mode number from β_iL to the output weight.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BeamModal {
    /// Number of modes n (1..=[`MAX_MODES`]); entries beyond n are zero.
    pub modes: usize,
    /// Roots β_iL of eq. 20.
    pub beta_l: [f64; MAX_MODES],
    /// Wave numbers β_i (1/m).
    pub beta_per_m: [f64; MAX_MODES],
    /// Natural frequencies ω_i = √(k_ii/m_ii) (rad/s).
    pub omega_rad_s: [f64; MAX_MODES],
    /// Damping ratios ζ_i = c_ii/(2 m_ii ω_i); for Kelvin–Voigt damping
    /// ζ_i = (C/E)·ω_i/2.
    pub zeta: [f64; MAX_MODES],
    /// Modal masses m_ii (kg), eq. 54.
    pub mass_kg: [f64; MAX_MODES],
    /// Modal stiffnesses k_ii (N/m), eq. 56.
    pub stiffness_n_m: [f64; MAX_MODES],
    /// Modal damping c_ii (N·s/m), eq. 55.
    pub damping_n_s_m: [f64; MAX_MODES],
    /// Modal inputs z_i, eq. 57 (first line; N/(V·m), see
    /// `galerkin` for the sign and units).
    pub input_z: [f64; MAX_MODES],
    /// Modal input gains b̄_i = z_i/m_ii (eq. 24), in 1/(V·s²) as eq. 8 is
    /// written (m/(V·s²) once multiplied by the patch width; see
    /// `galerkin`).
    pub bbar: [f64; MAX_MODES],
    /// Output weights c_i (row C_w of eq. 22, C̄ of eq. 24).
    pub output_weight: [f64; MAX_MODES],
}

/// The state-space model of eq. 22 with X = [η_1..η_n, η̇_1..η̇_n]:
/// A = [0 I; −Ω² −2ζΩ], B = [0; B_w], C = [C_w 0]. Only the leading
/// 2n × 2n block (2n entries of B, C) is used; the rest is zero.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg(test)]
pub(crate) struct BeamStateSpace {
    /// Number of modes n; the state dimension is 2n.
    pub modes: usize,
    /// System matrix A (row-major).
    pub a: [[f64; MAX_ORDER]; MAX_ORDER],
    /// Input vector B.
    pub b: [f64; MAX_ORDER],
    /// Output row C.
    pub c: [f64; MAX_ORDER],
}

#[cfg(test)]
impl BeamStateSpace {
    /// State dimension 2n.
    #[cfg(test)]
    pub fn order(&self) -> usize {
        2 * self.modes
    }
}

impl BeamModal {
    /// Modal model of the first `modes` (1..=[`MAX_MODES`]) modes of `params`.
    pub fn new(params: &BeamParams, modes: usize) -> Result<Self, BeamError> {
        let g = GalerkinMatrices::new(params, modes)?;
        let mut m = Self {
            modes,
            beta_l: [0.0; MAX_MODES],
            beta_per_m: [0.0; MAX_MODES],
            omega_rad_s: [0.0; MAX_MODES],
            zeta: [0.0; MAX_MODES],
            mass_kg: [0.0; MAX_MODES],
            stiffness_n_m: [0.0; MAX_MODES],
            damping_n_s_m: [0.0; MAX_MODES],
            input_z: [0.0; MAX_MODES],
            bbar: [0.0; MAX_MODES],
            output_weight: [0.0; MAX_MODES],
        };
        for i in 0..modes {
            let shape = ModeShape::new(i + 1, params.length_m)?;
            let (mass, stiffness, damping) = (
                g.mass_kg[i][i],
                g.stiffness_n_m[i][i],
                g.damping_n_s_m[i][i],
            );
            if !(is_positive_finite(mass) && is_positive_finite(stiffness)) {
                return Err(BeamError::NonFinite);
            }
            let omega = libm::sqrt(stiffness / mass);
            m.beta_l[i] = shape.beta_l();
            m.beta_per_m[i] = shape.beta_per_m();
            m.omega_rad_s[i] = omega;
            m.zeta[i] = damping / (2.0 * mass * omega);
            m.mass_kg[i] = mass;
            m.stiffness_n_m[i] = stiffness;
            m.damping_n_s_m[i] = damping;
            m.input_z[i] = g.input_z[i];
            m.bbar[i] = g.input_z[i] / mass;
            m.output_weight[i] = params.output_weight(&shape);
            let all = [omega, m.zeta[i], m.bbar[i], m.output_weight[i]];
            if !all.iter().all(|v| v.is_finite()) {
                return Err(BeamError::NonFinite);
            }
        }
        Ok(m)
    }

    /// The modal parameters (ω, ζ, b̄, c) of eq. 23–24 for the estimator side.
    pub fn modal_params(&self) -> ModalParams<f64> {
        let mut p = ModalParams {
            modes: self.modes,
            omega_rad_s: [0.0; MAX_MODES],
            zeta: [0.0; MAX_MODES],
            bbar: [0.0; MAX_MODES],
            output_weight: [0.0; MAX_MODES],
        };
        let n = self.modes;
        p.omega_rad_s[..n].copy_from_slice(&self.omega_rad_s[..n]);
        p.zeta[..n].copy_from_slice(&self.zeta[..n]);
        p.bbar[..n].copy_from_slice(&self.bbar[..n]);
        p.output_weight[..n].copy_from_slice(&self.output_weight[..n]);
        p
    }

    /// The state-space model of eq. 22.
    #[cfg(test)]
    pub(crate) fn state_space(&self) -> BeamStateSpace {
        let n = self.modes;
        let mut ss = BeamStateSpace {
            modes: n,
            a: [[0.0; MAX_ORDER]; MAX_ORDER],
            b: [0.0; MAX_ORDER],
            c: [0.0; MAX_ORDER],
        };
        for i in 0..n {
            let w = self.omega_rad_s[i];
            ss.a[i][n + i] = 1.0;
            ss.a[n + i][i] = -w * w;
            ss.a[n + i][n + i] = -2.0 * self.zeta[i] * w;
            ss.b[n + i] = self.bbar[i];
            ss.c[i] = self.output_weight[i];
        }
        ss
    }

    /// Transfer function B(s)/A(s) of eq. 25–26 (generalised to n modes).
    pub fn transfer_function(&self) -> TransferFunction<f64> {
        self.modal_params().transfer_function()
    }
}

/// One mode of any order of the beam as a diagonal modal model (eq. 21–24):
/// the diagonal Galerkin entries of eq. 54–57 for that mode alone (the
/// matrices are diagonal, test `galerkin_matrices_are_diagonal`), so modes
/// beyond [`MAX_MODES`] — the 4th, which a 3-mode [`BeamModal`] cannot hold —
/// come out as [`BeamModal`] would give them.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ModeModel {
    /// Mode number (1-based).
    pub mode_number: usize,
    /// ω_i = √(k_ii/m_ii) (rad/s).
    pub omega_rad_s: f64,
    /// ζ_i = c_ii/(2 m_ii ω_i).
    pub zeta: f64,
    /// b̄_i = z_i/m_ii (1/(V·s²), per metre of patch width as eq. 8 is
    /// written; see `galerkin`).
    pub bbar: f64,
    /// Output weight c_i.
    pub output_weight: f64,
}

impl BeamParams {
    /// The diagonal modal model of eq. 21–24 for the first `modes` modes.
    pub fn modal(&self, modes: usize) -> Result<BeamModal, BeamError> {
        BeamModal::new(self, modes)
    }

    /// The diagonal modal model of mode `mode_number` (1-based, any order).
    ///
    /// # Errors
    /// [`BeamError`] for invalid beam data or mode number, or a non-finite
    /// result.
    pub fn mode_model(&self, mode_number: usize) -> Result<ModeModel, BeamError> {
        self.validate()?;
        let shape = ModeShape::new(mode_number, self.length_m)?;
        let l = self.length_m;
        let overlap = super::galerkin::integrate(l, |x| shape.value(x) * shape.value(x));
        let fourth = super::galerkin::integrate(l, |x| shape.derivative(4, x) * shape.value(x));
        let mass = self.density_kg_m3 * self.area_m2 * overlap;
        let stiffness = self.youngs_modulus_pa * self.inertia_m4 * fourth;
        let damping = self.damping_pa_s * self.inertia_m4 * fourth;
        let z = self.moment_arm_m
            * self.piezo_d31_m_v
            * self.piezo_modulus_pa
            * (shape.derivative(1, self.actuator_start_m)
                - shape.derivative(1, self.actuator_end_m));
        if !(is_positive_finite(mass) && is_positive_finite(stiffness)) {
            return Err(BeamError::NonFinite);
        }
        let omega = libm::sqrt(stiffness / mass);
        let m = ModeModel {
            mode_number,
            omega_rad_s: omega,
            zeta: damping / (2.0 * mass * omega),
            bbar: z / mass,
            output_weight: self.output_weight(&shape),
        };
        if [m.zeta, m.bbar, m.output_weight]
            .iter()
            .all(|v| v.is_finite())
        {
            Ok(m)
        } else {
            Err(BeamError::NonFinite)
        }
    }
}

#[cfg(test)]
// The tests walk several per-mode arrays in step; an index reads best there.
#[allow(clippy::needless_range_loop)]
mod tests {
    use super::*;
    use crate::beam::paper_shapes as shapes;
    use crate::beam::params::BeamOutput;
    use crate::beam::strain::deflection_from_strain;
    use crate::model::default_output_weight;
    use crate::scalar::isclose;

    const BETA_L_REF: [f64; 3] = [1.875_104_068_7, 4.694_091_133_0, 7.854_757_438_2];

    #[test]
    fn single_mode_model_matches_the_modal_model() {
        let p = BeamParams::paper();
        let all = p.modal(3).unwrap();
        for i in 0..3 {
            let m = p.mode_model(i + 1).unwrap();
            assert!(isclose(m.omega_rad_s, all.omega_rad_s[i], 1e-14, 0.0));
            assert!(isclose(m.zeta, all.zeta[i], 1e-14, 0.0));
            assert!(isclose(m.bbar, all.bbar[i], 1e-14, 0.0));
            assert_eq!(m.output_weight, all.output_weight[i]);
        }
        // Mode 4: ω ∝ (β_iL)², Kelvin–Voigt ζ ∝ ω, W_4(L) = +2.
        let m4 = p.mode_model(4).unwrap();
        let ratio = (m4.omega_rad_s / all.omega_rad_s[0]) / (m4.zeta / all.zeta[0]);
        assert!(isclose(ratio, 1.0, 1e-9, 0.0));
        assert!(
            isclose(m4.omega_rad_s, 1346.56, 1e-4, 0.0),
            "{}",
            m4.omega_rad_s
        );
        assert!(isclose(m4.output_weight, 2.0, 1e-9, 0.0));
        assert!(p.mode_model(0).is_err());
    }

    #[test]
    fn paper_natural_frequencies() {
        let m = BeamParams::paper().modal(2).unwrap();
        assert!(
            isclose(m.omega_rad_s[0], 39.1603, 1e-5, 0.0),
            "{}",
            m.omega_rad_s[0]
        );
        assert!(
            isclose(m.omega_rad_s[1], 245.4132, 1e-5, 0.0),
            "{}",
            m.omega_rad_s[1]
        );
        // The paper's Table III "true" values (the simulation plant) are
        // 1.5e-4 … 2e-4 below the Table I beam's ω (asserted here).
        let table_iii = crate::model::PAPER_OMEGA;
        for i in 0..2 {
            let rel = m.omega_rad_s[i] / table_iii[i] - 1.0;
            assert!(rel > 1.5e-4 && rel < 2.0e-4, "mode {}: {rel}", i + 1);
        }
        // h from A and I.
        let p = BeamParams::paper();
        assert!(isclose(p.thickness_m, 1.000_25e-3, 1e-5, 0.0));
        assert!(isclose(p.width_m(), 0.079_98, 1e-4, 0.0));
    }

    #[test]
    fn omega_from_galerkin_equals_closed_form() {
        let p = BeamParams::paper();
        let m = p.modal(MAX_MODES).unwrap();
        for i in 0..MAX_MODES {
            let closed = p.natural_frequency_rad_s(i + 1).unwrap();
            assert!(
                isclose(m.omega_rad_s[i], closed, 1e-12, 0.0),
                "mode {}",
                i + 1
            );
            let bl = BETA_L_REF[i];
            let textbook = bl * bl / (p.length_m * p.length_m) * p.wave_scale_m2_s();
            assert!(isclose(m.omega_rad_s[i], textbook, 1e-9, 0.0));
            // m_ii = ρAL with ∫W² = L.
            assert!(isclose(
                m.mass_kg[i],
                p.density_kg_m3 * p.area_m2 * p.length_m,
                1e-13,
                0.0
            ));
        }
    }

    #[test]
    fn kelvin_voigt_damping_ratio() {
        let p = BeamParams::paper();
        let m = p.modal(MAX_MODES).unwrap();
        let c_over_e = p.damping_pa_s / p.youngs_modulus_pa;
        for i in 0..MAX_MODES {
            assert!(isclose(
                m.zeta[i],
                0.5 * c_over_e * m.omega_rad_s[i],
                1e-12,
                0.0
            ));
        }
        // With Table I's C: ζ1 ≈ 0.00994, ζ2 ≈ 0.0623 (Table III: 0.0207, 0.13).
        assert!(isclose(m.zeta[0], 0.009_943, 1e-3, 0.0), "{}", m.zeta[0]);
        assert!(isclose(m.zeta[1], 0.062_31, 1e-3, 0.0), "{}", m.zeta[1]);
        let undamped = BeamParams {
            damping_pa_s: 0.0,
            ..p
        }
        .modal(2)
        .unwrap();
        assert_eq!(undamped.zeta[..2], [0.0, 0.0]);
    }

    /// C(jωI − A)⁻¹B by Gaussian elimination with partial pivoting on the
    /// complex 2n × 2n system (jωI − A)x = B.
    fn state_space_response(ss: &BeamStateSpace, omega: f64) -> (f64, f64) {
        let d = ss.order();
        let mut re = [[0.0; MAX_ORDER + 1]; MAX_ORDER];
        let mut im = [[0.0; MAX_ORDER + 1]; MAX_ORDER];
        for r in 0..d {
            for c in 0..d {
                re[r][c] = -ss.a[r][c];
            }
            im[r][r] = omega;
            re[r][d] = ss.b[r];
        }
        for col in 0..d {
            let piv = (col..d)
                .max_by(|&a, &b| {
                    libm::hypot(re[a][col], im[a][col])
                        .total_cmp(&libm::hypot(re[b][col], im[b][col]))
                })
                .unwrap();
            re.swap(col, piv);
            im.swap(col, piv);
            let (pr, pi) = (re[col][col], im[col][col]);
            let den = pr * pr + pi * pi;
            for r in 0..d {
                if r == col {
                    continue;
                }
                // factor = row[r][col] / pivot
                let (ar, ai) = (re[r][col], im[r][col]);
                let (fr, fi) = ((ar * pr + ai * pi) / den, (ai * pr - ar * pi) / den);
                for c in col..=d {
                    let (br, bi) = (re[col][c], im[col][c]);
                    re[r][c] -= fr * br - fi * bi;
                    im[r][c] -= fr * bi + fi * br;
                }
            }
        }
        let (mut yr, mut yi) = (0.0, 0.0);
        for r in 0..d {
            let (pr, pi) = (re[r][r], im[r][r]);
            let den = pr * pr + pi * pi;
            let (xr, xi) = (
                (re[r][d] * pr + im[r][d] * pi) / den,
                (im[r][d] * pr - re[r][d] * pi) / den,
            );
            yr += ss.c[r] * xr;
            yi += ss.c[r] * xi;
        }
        (yr, yi)
    }

    #[test]
    fn state_space_matches_transfer_function() {
        for output in [
            BeamOutput::Deflection,
            BeamOutput::Strain,
            BeamOutput::StrainAsTipDeflection,
        ] {
            let p = BeamParams {
                output,
                output_position_m: if output == BeamOutput::Deflection {
                    0.36
                } else {
                    0.02
                },
                ..BeamParams::paper()
            };
            for n in 1..=MAX_MODES {
                let m = p.modal(n).unwrap();
                let ss = m.state_space();
                let tf = m.transfer_function();
                for &w in &[0.0, 5.0, 39.0, 120.0, 245.0, 700.0, 3000.0] {
                    let (sr, si) = state_space_response(&ss, w);
                    let (tr, ti) = tf.freq_response(w);
                    let mag = libm::hypot(tr, ti);
                    assert!(
                        libm::hypot(sr - tr, si - ti) < 1e-10 * mag,
                        "{output:?} n={n} w={w}"
                    );
                }
            }
        }
    }

    #[test]
    fn modal_params_carry_the_modal_numbers() {
        let m = BeamParams::paper().modal(2).unwrap();
        let mp = m.modal_params();
        assert_eq!(mp.modes, 2);
        assert_eq!(mp.omega_rad_s, m.omega_rad_s);
        assert_eq!(mp.zeta, m.zeta);
        assert_eq!(mp.bbar, m.bbar);
        for i in 0..2 {
            assert!(isclose(
                mp.output_weight[i],
                default_output_weight(i),
                1e-9,
                0.0
            ));
            assert!(isclose(m.bbar[i], m.input_z[i] / m.mass_kg[i], 1e-15, 0.0));
        }
        assert_eq!(m.modes, 2);
        assert_eq!(m.omega_rad_s[2], 0.0);
    }

    #[test]
    fn strain_outputs_follow_eq17_scaling() {
        let xs = 0.02;
        let base = BeamParams {
            output_position_m: xs,
            ..BeamParams::paper()
        };
        let strain = BeamParams {
            output: BeamOutput::Strain,
            ..base
        }
        .modal(MAX_MODES)
        .unwrap();
        let eq17 = BeamParams {
            output: BeamOutput::StrainAsTipDeflection,
            ..base
        }
        .modal(MAX_MODES)
        .unwrap();
        let s = shapes(MAX_MODES);
        for i in 0..MAX_MODES {
            let expect = 0.5 * base.thickness_m * s[i].derivative(2, xs);
            assert!(isclose(strain.output_weight[i], expect, 1e-14, 0.0));
            let w = deflection_from_strain(
                strain.output_weight[i],
                base.length_m,
                base.length_m - xs,
                base.thickness_m,
            )
            .unwrap();
            assert!(isclose(eq17.output_weight[i], w, 1e-13, 0.0));
        }
        // Sign: with η_1 > 0 the paper-sign mode 1 deflects towards −w
        // (W_1 < 0, W_1'' < 0), compressing the −w face: c_1 < 0.
        assert!(strain.output_weight[0] < 0.0);
    }
}
