//! Eq. 17: the static relation between the surface strain at a gauge and
//! the tip deflection of the cantilever, in both directions. The paper's
//! experiments measure strain and report y = 2L³ε/(3 L₁ h); the firmware
//! converts the gauge signal with it where configured.

use super::error::{BeamError, BeamParam};
use super::is_positive_finite;
/// Eq. 17: the deflection w = 2L³ε/(3 L₁ h) that a static tip force produces
/// together with the surface strain ε at a gauge L₁ before the force point
/// (L₁ = L − x_s for a tip force). Sign as in
/// [`BeamOutput::Strain`](super::BeamOutput::Strain).
#[cfg(test)]
pub(crate) fn deflection_from_strain(
    strain: f64,
    length_m: f64,
    gauge_lever_arm_m: f64,
    thickness_m: f64,
) -> Result<f64, BeamError> {
    check_eq17(strain, length_m, gauge_lever_arm_m, thickness_m)?;
    Ok(2.0 * length_m * length_m * length_m * strain / (3.0 * gauge_lever_arm_m * thickness_m))
}

/// Inverse of eq. 17: ε = 3 L₁ h w/(2L³), the gauge strain of a static tip
/// deflection w (eq. 15–16 with ε = σ/E, eq. 14).
#[cfg(test)]
pub(crate) fn strain_from_deflection(
    deflection_m: f64,
    length_m: f64,
    gauge_lever_arm_m: f64,
    thickness_m: f64,
) -> Result<f64, BeamError> {
    check_eq17(deflection_m, length_m, gauge_lever_arm_m, thickness_m)?;
    Ok(3.0 * gauge_lever_arm_m * thickness_m * deflection_m
        / (2.0 * length_m * length_m * length_m))
}

#[cfg(test)]
fn check_eq17(value: f64, length_m: f64, lever_m: f64, thickness_m: f64) -> Result<(), BeamError> {
    if !value.is_finite() {
        return Err(BeamError::InvalidParameter(BeamParam::Measurement));
    }
    if !is_positive_finite(length_m) {
        return Err(BeamError::InvalidParameter(BeamParam::Length));
    }
    if !is_positive_finite(lever_m) {
        return Err(BeamError::InvalidParameter(BeamParam::GaugeLeverArm));
    }
    if !is_positive_finite(thickness_m) {
        return Err(BeamError::InvalidParameter(BeamParam::Thickness));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scalar::isclose;

    #[test]
    fn strain_deflection_eq17() {
        let (l, h) = (0.36, 1.0e-3);
        let xs = 0.02;
        let l1 = l - xs;
        // Static tip force F: w(L) = FL³/(3EI) (eq. 15), ε(x_s) = F L1 h/(2EI) (eq. 16).
        let (f, ei) = (0.5, 1.93e11 * 6.67e-12);
        let tip = f * l * l * l / (3.0 * ei);
        let strain = f * l1 * h / (2.0 * ei);
        let w = deflection_from_strain(strain, l, l1, h).unwrap();
        assert!(isclose(w, tip, 1e-14, 0.0));
        let back = strain_from_deflection(w, l, l1, h).unwrap();
        assert!(isclose(back, strain, 1e-14, 0.0));
        assert!(isclose(
            strain_from_deflection(-1e-3, l, l1, h).unwrap(),
            -3.0 * l1 * h * 1e-3 / (2.0 * l * l * l),
            1e-14,
            0.0
        ));
        assert_eq!(
            deflection_from_strain(1e-6, l, 0.0, h),
            Err(BeamError::InvalidParameter(BeamParam::GaugeLeverArm))
        );
        assert_eq!(
            deflection_from_strain(f64::NAN, l, l1, h),
            Err(BeamError::InvalidParameter(BeamParam::Measurement))
        );
        assert_eq!(
            strain_from_deflection(1e-3, l, l1, -h),
            Err(BeamError::InvalidParameter(BeamParam::Thickness))
        );
    }
}
