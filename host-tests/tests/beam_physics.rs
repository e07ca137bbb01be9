//! Property tests of the beam physics (`beamest::beam`) over random but
//! physical beams: the Galerkin model must agree with the closed-form
//! Euler–Bernoulli results for any geometry, material and actuator span, not
//! just the paper's Table I.

use beamest::beam::{BeamError, BeamOutput, BeamParams, ModeShape};
use beamest::model::MAX_MODES;
use proptest::prelude::*;

/// A random valid beam around the paper's steel beam (each quantity within a
/// factor of ~10 of Table I), with a random actuator span and gauge.
fn beam() -> impl Strategy<Value = BeamParams> {
    (
        (1000.0f64..20_000.0, 0.05f64..2.0, 5e-4f64..5e-3),
        (1e10f64..4e11, 0.0f64..1e9),
        (0.0f64..0.9, 0.05f64..1.0, 0.0f64..1.0),
        0usize..3,
    )
        .prop_map(|((rho, len, h), (e, c), (xa, span, xs), out)| {
            let b = 0.08;
            let output = [
                BeamOutput::Deflection,
                BeamOutput::Strain,
                BeamOutput::StrainAsTipDeflection,
            ][out];
            let xa = xa * len;
            let xb = xa + span * (len - xa);
            BeamParams {
                density_kg_m3: rho,
                area_m2: b * h,
                youngs_modulus_pa: e,
                inertia_m4: b * h * h * h / 12.0,
                damping_pa_s: c,
                length_m: len,
                thickness_m: h,
                actuator_start_m: xa,
                actuator_end_m: xb,
                // Strictly inside the beam so every output kind is valid.
                output_position_m: 0.999 * xs * len,
                output,
                ..BeamParams::paper()
            }
        })
}

proptest! {
    #[test]
    fn galerkin_model_matches_closed_form(p in beam()) {
        prop_assume!(p.actuator_start_m < p.actuator_end_m);
        let m = p.modal(MAX_MODES).unwrap();
        let g = p.galerkin(MAX_MODES).unwrap();
        for i in 0..MAX_MODES {
            let closed = p.natural_frequency_rad_s(i + 1).unwrap();
            prop_assert!((m.omega_rad_s[i] / closed - 1.0).abs() < 1e-11);
            // Kelvin–Voigt: ζ = (C/E)·ω/2.
            let zeta = 0.5 * p.damping_pa_s / p.youngs_modulus_pa * m.omega_rad_s[i];
            prop_assert!((m.zeta[i] - zeta).abs() <= 1e-11 * zeta);
            // m_ii = ρAL (∫W² = L).
            let mass = p.density_kg_m3 * p.area_m2 * p.length_m;
            prop_assert!((m.mass_kg[i] / mass - 1.0).abs() < 1e-11);
            for j in 0..MAX_MODES {
                if i != j {
                    prop_assert!(g.mass_kg[i][j].abs() < 1e-10 * mass);
                    let k = (g.stiffness_n_m[i][i] * g.stiffness_n_m[j][j]).sqrt();
                    prop_assert!(g.stiffness_n_m[i][j].abs() < 1e-10 * k);
                }
            }
        }
        // The state-space form and the transfer function agree at DC:
        // G(0) = Σ c_i b̄_i / ω_i² = b_0/a_0.
        let tf = m.transfer_function();
        let d = tf.order();
        let terms = (0..MAX_MODES)
            .map(|i| m.output_weight[i] * m.bbar[i] / (m.omega_rad_s[i] * m.omega_rad_s[i]));
        let dc: f64 = terms.clone().sum();
        // Relative to Σ|terms|: the modes may cancel at some gauge positions.
        let scale: f64 = terms.map(f64::abs).sum();
        let dc_tf = tf.b[d - 2] / tf.a[d - 1];
        prop_assert!((dc - dc_tf).abs() <= 1e-10 * scale);
    }

    #[test]
    fn mode_shapes_meet_clamped_free_conditions(mode in 1usize..40, len in 0.01f64..10.0) {
        let w = ModeShape::new(mode, len).unwrap();
        let b = w.beta_per_m();
        prop_assert!(w.value(0.0).abs() < 1e-12);
        prop_assert!(w.derivative(1, 0.0).abs() < 1e-12 * 2.0 * b);
        prop_assert!(w.derivative(2, len).abs() < 1e-11 * 2.0 * b * b);
        prop_assert!(w.derivative(3, len).abs() < 1e-11 * 2.0 * b * b * b);
        let tip = if mode % 2 == 0 { 2.0 } else { -2.0 };
        prop_assert!((w.value(len) - tip).abs() < 1e-11);
    }
}

#[test]
fn paper_beam_end_to_end() {
    let m = BeamParams::paper().modal(2).unwrap();
    let mp = m.modal_params();
    assert!((mp.omega_rad_s[0] - 39.1603).abs() < 1e-3);
    assert!((mp.omega_rad_s[1] - 245.4132).abs() < 1e-3);
    assert_eq!(
        BeamParams::paper().modal(4).err(),
        Some(BeamError::ModeCount)
    );
}
