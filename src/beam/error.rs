//! The error type of the beam physics: one enum for the family, each
//! invalid-parameter variant naming the field ([`BeamParam`]) it is about.

use crate::model::MAX_MODES;
use core::fmt;

/// Names the parameter a [`BeamError`] is about.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum BeamParam {
    /// [`BeamParams::density_kg_m3`](super::BeamParams::density_kg_m3).
    Density,
    /// [`BeamParams::area_m2`](super::BeamParams::area_m2).
    Area,
    /// [`BeamParams::youngs_modulus_pa`](super::BeamParams::youngs_modulus_pa).
    YoungsModulus,
    /// [`BeamParams::inertia_m4`](super::BeamParams::inertia_m4).
    Inertia,
    /// [`BeamParams::damping_pa_s`](super::BeamParams::damping_pa_s).
    Damping,
    /// [`BeamParams::length_m`](super::BeamParams::length_m).
    Length,
    /// [`BeamParams::thickness_m`](super::BeamParams::thickness_m).
    Thickness,
    /// [`BeamParams::piezo_modulus_pa`](super::BeamParams::piezo_modulus_pa).
    PiezoModulus,
    /// [`BeamParams::piezo_d31_m_v`](super::BeamParams::piezo_d31_m_v).
    PiezoD31,
    /// [`BeamParams::moment_arm_m`](super::BeamParams::moment_arm_m).
    MomentArm,
    /// The gauge-to-force distance L₁ of eq. 16–17.
    GaugeLeverArm,
    /// A strain or deflection value passed to the eq. 17 conversions.
    Measurement,
}

/// Errors of the beam computations.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum BeamError {
    /// The parameter is not finite or not strictly positive (for
    /// [`BeamParam::Damping`]: negative; for [`BeamParam::PiezoD31`]: zero).
    InvalidParameter(BeamParam),
    /// The actuator span is not 0 ≤ x_a < x_b ≤ L (or not finite).
    ActuatorSpan,
    /// The output position is not within [0, L] (or not finite), or equals L
    /// for [`BeamOutput::StrainAsTipDeflection`](super::BeamOutput::StrainAsTipDeflection) (L₁ = 0).
    OutputPosition,
    /// The mode count is not in 1..=[`MAX_MODES`].
    ModeCount,
    /// Mode numbers are 1-based; 0 was given.
    ModeNumber,
    /// The root of eq. 20 was not bracketed or did not converge.
    RootNotConverged,
    /// A derived quantity came out NaN, infinite or with a zero modal mass
    /// (parameters too extreme for f64).
    NonFinite,
}

impl fmt::Display for BeamParam {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Self::Density => "density_kg_m3",
            Self::Area => "area_m2",
            Self::YoungsModulus => "youngs_modulus_pa",
            Self::Inertia => "inertia_m4",
            Self::Damping => "damping_pa_s",
            Self::Length => "length_m",
            Self::Thickness => "thickness_m",
            Self::PiezoModulus => "piezo_modulus_pa",
            Self::PiezoD31 => "piezo_d31_m_v",
            Self::MomentArm => "moment_arm_m",
            Self::GaugeLeverArm => "gauge lever arm (m)",
            Self::Measurement => "strain or deflection value",
        })
    }
}

impl fmt::Display for BeamError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::InvalidParameter(BeamParam::Damping) => {
                f.write_str("invalid damping_pa_s: must be finite and >= 0")
            }
            Self::InvalidParameter(BeamParam::PiezoD31) => {
                f.write_str("invalid piezo_d31_m_v: must be finite and non-zero")
            }
            Self::InvalidParameter(BeamParam::Measurement) => {
                f.write_str("invalid strain or deflection value: must be finite")
            }
            Self::InvalidParameter(p) => write!(f, "invalid {p}: must be finite and > 0"),
            Self::ActuatorSpan => f.write_str(
                "invalid actuator span: need 0 <= actuator_start_m < actuator_end_m <= length_m",
            ),
            Self::OutputPosition => f.write_str(
                "invalid output_position_m: must lie in [0, length_m] (below length_m for strain_as_tip_deflection)",
            ),
            Self::ModeCount => write!(f, "invalid beam mode count: must be 1..={MAX_MODES}"),
            Self::ModeNumber => f.write_str("invalid mode number: mode numbers start at 1"),
            Self::RootNotConverged => {
                f.write_str("root of the frequency equation (eq. 20) not found")
            }
            Self::NonFinite => {
                f.write_str("beam model came out non-finite: parameters too extreme for f64")
            }
        }
    }
}

impl core::error::Error for BeamError {}

#[cfg(test)]
mod tests {
    use super::*;
    use std::string::ToString;

    #[test]
    fn messages_are_distinct_and_name_the_parameter() {
        let params = [
            BeamParam::Density,
            BeamParam::Area,
            BeamParam::YoungsModulus,
            BeamParam::Inertia,
            BeamParam::Damping,
            BeamParam::Length,
            BeamParam::Thickness,
            BeamParam::PiezoModulus,
            BeamParam::PiezoD31,
            BeamParam::MomentArm,
            BeamParam::GaugeLeverArm,
            BeamParam::Measurement,
        ];
        let mut all: std::vec::Vec<_> = params
            .iter()
            .map(|&p| BeamError::InvalidParameter(p).to_string())
            .collect();
        for (p, m) in params.iter().zip(&all) {
            if !matches!(p, BeamParam::Measurement | BeamParam::GaugeLeverArm) {
                assert!(m.contains(&p.to_string()), "{m}");
            }
        }
        for e in [
            BeamError::ActuatorSpan,
            BeamError::OutputPosition,
            BeamError::ModeCount,
            BeamError::ModeNumber,
            BeamError::RootNotConverged,
            BeamError::NonFinite,
        ] {
            all.push(e.to_string());
        }
        for (i, a) in all.iter().enumerate() {
            assert!(
                !a.is_empty() && a.chars().next().unwrap().is_lowercase(),
                "{a}"
            );
            for b in &all[i + 1..] {
                assert_ne!(a, b);
            }
        }
    }
}
