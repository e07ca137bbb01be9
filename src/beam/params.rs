//! The beam's material, geometry, actuator and sensor data (Tables I–II) and
//! the choice of output, with their validation.
//!
//! # Design
//!
//! **Geometry not in the paper.** Table I gives A = b·h = 8·10⁻⁵ m² and
//! I = b·h³/12 = 6.67·10⁻¹² m⁴ but not h; we solve h = √(12 I/A) ≈ 1.0 mm
//! (b = A/h ≈ 80 mm). The actuator span x_a..x_b is not given either; see
//! [`BeamParams::paper`] for the assumed default.

use super::error::{BeamError, BeamParam};
use super::is_positive_finite;
use super::shape::{frequency_root, ModeShape};

/// Which physical quantity the beam model outputs (row C_w of eq. 22).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum BeamOutput {
    /// Deflection w(x_s, t) in metres: c_i = W_i(x_s). With x_s = L this is
    /// the tip deflection and c_i = W_i(L) = [−2, 2, −2] (eq. 24).
    Deflection,
    /// Surface bending strain at the gauge, ε = (h/2)·∂²w/∂x²(x_s)
    /// (dimensionless): c_i = (h/2)·W_i''(x_s). Sign: the strain of the face
    /// on the −w side, positive (tension) when the curvature w'' is positive
    /// (centre of curvature on the +w side). This is the sign for which a
    /// static tip load gives ε > 0 together with w(L) > 0, i.e. the sign
    /// under which eq. 16–17 hold.
    Strain,
    /// The paper's experimental output y = 2L³ε/(3 L₁ h) (eq. 17 applied to
    /// the strain above, L₁ = L − x_s the gauge-to-tip distance), in metres:
    /// c_i = L³·W_i''(x_s)/(3 L₁). It equals the tip deflection for a static
    /// tip load, not for a vibrating beam. Requires x_s < L.
    StrainAsTipDeflection,
}

/// Material, geometry, actuator and sensor data of the beam (Tables I–II plus
/// the assumptions documented on [`BeamParams::paper`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BeamParams {
    /// Beam density ρ (kg/m³).
    pub density_kg_m3: f64,
    /// Cross-section area A = b·h (m²).
    pub area_m2: f64,
    /// Young's modulus E (Pa).
    pub youngs_modulus_pa: f64,
    /// Bending moment of inertia I = b·h³/12 (m⁴).
    pub inertia_m4: f64,
    /// Kelvin–Voigt damping factor C of eq. 3 (Pa·s: the stress per unit
    /// strain rate, so that C·I multiplies ∂⁵w/∂t∂x⁴ like E·I multiplies
    /// ∂⁴w/∂x⁴; Table I prints the unit as N/(m/s)). Zero means undamped.
    pub damping_pa_s: f64,
    /// Beam length L (m).
    pub length_m: f64,
    /// Beam thickness h (m), used by the strain outputs and eq. 17.
    pub thickness_m: f64,
    /// Young's modulus of the piezo patch E_p (Pa).
    pub piezo_modulus_pa: f64,
    /// Piezoelectric coefficient d31 (C/N = m/V); its sign sets the polarity.
    pub piezo_d31_m_v: f64,
    /// Effective moment arm r_a of eq. 8 (m).
    pub moment_arm_m: f64,
    /// Actuator start x_a, measured from the clamp (m).
    pub actuator_start_m: f64,
    /// Actuator end x_b, measured from the clamp (m).
    pub actuator_end_m: f64,
    /// Output (sensor) position x_s, measured from the clamp (m).
    pub output_position_m: f64,
    /// Output quantity at x_s.
    pub output: BeamOutput,
}

impl BeamParams {
    /// The paper's beam: Table I (steel beam) and Table II (piezo ceramic),
    /// with tip-deflection output (x_s = L, c_i = W_i(L), eq. 24).
    ///
    /// Values not in the paper, and therefore assumptions:
    /// * thickness h = √(12 I/A) ≈ 1.00025 mm (width b = A/h ≈ 79.98 mm), from
    ///   A = b·h and I = b·h³/12;
    /// * actuator span x_a = 5 mm, x_b = 55 mm: a PI P-876.A12 DuraAct patch
    ///   (the paper's actuator, active length 50 mm) bonded 5 mm from the
    ///   clamp. Only b̄_i depends on it (through W_i' at the patch ends).
    pub fn paper() -> Self {
        let area_m2 = 8.0e-5;
        let inertia_m4 = 6.67e-12;
        let length_m = 0.36;
        Self {
            density_kg_m3: 7723.13,
            area_m2,
            youngs_modulus_pa: 1.93e11,
            inertia_m4,
            damping_pa_s: 9.8e7,
            length_m,
            thickness_m: rectangular_thickness_m(area_m2, inertia_m4),
            piezo_modulus_pa: 7.06e10,
            piezo_d31_m_v: -1.8e-10,
            moment_arm_m: 0.001,
            actuator_start_m: 0.005,
            actuator_end_m: 0.055,
            output_position_m: length_m,
            output: BeamOutput::Deflection,
        }
    }

    /// Width b = A/h of the rectangular section (m).
    pub fn width_m(&self) -> f64 {
        self.area_m2 / self.thickness_m
    }

    /// Check every field: ρ, A, E, I, L, h, E_p, r_a finite and > 0; C finite
    /// and ≥ 0; d31 finite and ≠ 0; 0 ≤ x_a < x_b ≤ L; 0 ≤ x_s ≤ L (x_s < L
    /// for [`BeamOutput::StrainAsTipDeflection`]).
    pub fn validate(&self) -> Result<(), BeamError> {
        let positive = [
            (self.density_kg_m3, BeamParam::Density),
            (self.area_m2, BeamParam::Area),
            (self.youngs_modulus_pa, BeamParam::YoungsModulus),
            (self.inertia_m4, BeamParam::Inertia),
            (self.length_m, BeamParam::Length),
            (self.thickness_m, BeamParam::Thickness),
            (self.piezo_modulus_pa, BeamParam::PiezoModulus),
            (self.moment_arm_m, BeamParam::MomentArm),
        ];
        for (value, which) in positive {
            if !is_positive_finite(value) {
                return Err(BeamError::InvalidParameter(which));
            }
        }
        if !(self.damping_pa_s.is_finite() && self.damping_pa_s >= 0.0) {
            return Err(BeamError::InvalidParameter(BeamParam::Damping));
        }
        if !(self.piezo_d31_m_v.is_finite() && self.piezo_d31_m_v != 0.0) {
            return Err(BeamError::InvalidParameter(BeamParam::PiezoD31));
        }
        let l = self.length_m;
        let (xa, xb) = (self.actuator_start_m, self.actuator_end_m);
        // Written so that NaN fails every comparison and is rejected.
        if !(xa >= 0.0 && xa < xb && xb <= l) {
            return Err(BeamError::ActuatorSpan);
        }
        let xs = self.output_position_m;
        let xs_ok = match self.output {
            BeamOutput::StrainAsTipDeflection => xs >= 0.0 && xs < l,
            BeamOutput::Deflection | BeamOutput::Strain => xs >= 0.0 && xs <= l,
        };
        if !xs_ok {
            return Err(BeamError::OutputPosition);
        }
        Ok(())
    }

    /// Wave number scale √(EI/(ρA)) (m²/s): ω_i = β_i²·√(EI/(ρA)).
    pub(crate) fn wave_scale_m2_s(&self) -> f64 {
        libm::sqrt(self.youngs_modulus_pa * self.inertia_m4 / (self.density_kg_m3 * self.area_m2))
    }

    /// Closed-form undamped natural frequency of mode `mode_number` (1-based):
    /// ω_i = (β_iL)²/L²·√(EI/(ρA)) (rad/s).
    pub fn natural_frequency_rad_s(&self, mode_number: usize) -> Result<f64, BeamError> {
        self.validate()?;
        let bl = frequency_root(mode_number)?;
        let l = self.length_m;
        Ok(bl * bl / (l * l) * self.wave_scale_m2_s())
    }

    /// Mode shape `mode_number` (1-based) of this beam.
    #[cfg(test)]
    pub(crate) fn mode_shape(&self, mode_number: usize) -> Result<ModeShape, BeamError> {
        self.validate()?;
        ModeShape::new(mode_number, self.length_m)
    }

    /// Output weight c_i of one mode for the configured output (see
    /// [`BeamOutput`]).
    pub(super) fn output_weight(&self, shape: &ModeShape) -> f64 {
        let xs = self.output_position_m;
        match self.output {
            BeamOutput::Deflection => shape.value(xs),
            BeamOutput::Strain => 0.5 * self.thickness_m * shape.derivative(2, xs),
            BeamOutput::StrainAsTipDeflection => {
                let l = self.length_m;
                l * l * l * shape.derivative(2, xs) / (3.0 * (l - xs))
            }
        }
    }
}

/// Thickness of a solid rectangular section from its area and second moment:
/// A = b·h, I = b·h³/12 ⇒ h = √(12 I/A) (m).
pub fn rectangular_thickness_m(area_m2: f64, inertia_m4: f64) -> f64 {
    libm::sqrt(12.0 * inertia_m4 / area_m2)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::MAX_MODES;

    #[test]
    fn validate_rejects_bad_params() {
        let good = BeamParams::paper();
        assert_eq!(good.validate(), Ok(()));
        let cases: [(BeamParams, BeamError); 14] = [
            (
                BeamParams {
                    density_kg_m3: 0.0,
                    ..good
                },
                BeamError::InvalidParameter(BeamParam::Density),
            ),
            (
                BeamParams {
                    area_m2: -1.0,
                    ..good
                },
                BeamError::InvalidParameter(BeamParam::Area),
            ),
            (
                BeamParams {
                    youngs_modulus_pa: f64::NAN,
                    ..good
                },
                BeamError::InvalidParameter(BeamParam::YoungsModulus),
            ),
            (
                BeamParams {
                    inertia_m4: f64::INFINITY,
                    ..good
                },
                BeamError::InvalidParameter(BeamParam::Inertia),
            ),
            (
                BeamParams {
                    damping_pa_s: -1.0,
                    ..good
                },
                BeamError::InvalidParameter(BeamParam::Damping),
            ),
            (
                BeamParams {
                    length_m: 0.0,
                    ..good
                },
                BeamError::InvalidParameter(BeamParam::Length),
            ),
            (
                BeamParams {
                    thickness_m: 0.0,
                    ..good
                },
                BeamError::InvalidParameter(BeamParam::Thickness),
            ),
            (
                BeamParams {
                    piezo_d31_m_v: 0.0,
                    ..good
                },
                BeamError::InvalidParameter(BeamParam::PiezoD31),
            ),
            (
                BeamParams {
                    actuator_start_m: 0.06,
                    ..good
                },
                BeamError::ActuatorSpan,
            ),
            (
                BeamParams {
                    actuator_start_m: -0.001,
                    ..good
                },
                BeamError::ActuatorSpan,
            ),
            (
                BeamParams {
                    actuator_end_m: 0.4,
                    ..good
                },
                BeamError::ActuatorSpan,
            ),
            (
                BeamParams {
                    output_position_m: 0.37,
                    ..good
                },
                BeamError::OutputPosition,
            ),
            (
                BeamParams {
                    output_position_m: f64::NAN,
                    ..good
                },
                BeamError::OutputPosition,
            ),
            (
                BeamParams {
                    output: BeamOutput::StrainAsTipDeflection,
                    ..good
                },
                BeamError::OutputPosition,
            ),
        ];
        for (i, (p, e)) in cases.iter().enumerate() {
            assert_eq!(p.validate(), Err(*e), "case {i}");
            assert_eq!(p.modal(2).err(), Some(*e), "case {i}");
        }
        assert_eq!(good.modal(0).err(), Some(BeamError::ModeCount));
        assert_eq!(good.modal(MAX_MODES + 1).err(), Some(BeamError::ModeCount));
        assert_eq!(good.mode_shape(0).err(), Some(BeamError::ModeNumber));
    }
}
