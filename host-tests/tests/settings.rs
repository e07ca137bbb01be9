//! The truth-free settings: λ and the signal scales come from the data (or
//! from what a user would know), and a wrong λ or a wrong scale still
//! converges. Every value handed to an estimator here is a literal or comes
//! from the data; the truth is read only to score the result.

use beamctl::run::plant::PlantSpec;
use beamctl::run::{run, Precision, RunConfig, RunReport};
use beamest::filter_bank::SignalScales;
use beamest::tuning::LambdaSource;

fn simulate(cfg: &RunConfig) -> RunReport {
    run(cfg, &mut |_| {}).expect("valid configuration")
}

/// λ fixed at half and twice the paper plant's band centre
/// (√(39.15·245.4) ≈ 98 rad/s, written here as the literals 50 and 200).
#[test]
fn a_wrong_lambda_still_converges() {
    for lambda in [50.0, 200.0] {
        for (precision, limit) in [(Precision::F64, 1e-6), (Precision::F32, 1e-4)] {
            let r = simulate(&RunConfig {
                lambda: LambdaSource::Fixed(lambda),
                precision,
                ..RunConfig::default()
            });
            assert_eq!(r.lambda_rad_s, Some(lambda));
            assert_eq!(r.tuning, "fixed");
            assert!(
                r.rel_error.max() < limit,
                "λ = {lambda} {precision:?}: {:?}",
                r.rel_error
            );
        }
    }
}

/// Scales off by 0.5× and 2× from what the start-up window measures on this
/// run (U0 = 0.1, Y0 ≈ 2.3e-3; written as literals): only the conditioning
/// changes, the fixed point does not.
#[test]
fn a_wrong_signal_scale_still_converges() {
    for (u0, y0) in [
        (0.05, 1.15e-3),
        (0.2, 4.6e-3),
        (0.05, 4.6e-3),
        (0.2, 1.15e-3),
    ] {
        for (precision, limit) in [(Precision::F64, 1e-6), (Precision::F32, 1e-4)] {
            let r = simulate(&RunConfig {
                scales: Some(SignalScales {
                    u_scale: u0,
                    y_scale: y0,
                }),
                precision,
                ..RunConfig::default()
            });
            let b = r.builds.last().expect("built");
            assert_eq!((b.u_scale, b.y_scale), (u0, y0));
            assert!(
                r.rel_error.max() < limit,
                "U0 = {u0}, Y0 = {y0} {precision:?}: {:?}",
                r.rel_error
            );
        }
    }
}

/// The scales the rule measures are the start-up window's RMS values (the
/// square wave's amplitude for u).
#[test]
fn the_rule_measures_the_scales_and_recentres_lambda() {
    let r = simulate(&RunConfig::default());
    let first = r.builds.first().expect("built");
    assert_eq!(first.sample, 2000, "after the 0.2 s start-up window");
    assert!((first.u_scale / 0.1 - 1.0).abs() < 1e-12);
    assert!(first.y_scale > 1e-4 && first.y_scale < 1e-2);
    // The paper's plant: λ ends within 10% of √(ω1ω2) ≈ 98 rad/s.
    let lambda = r.lambda_rad_s.expect("built");
    assert!((lambda / 98.0 - 1.0).abs() < 0.1, "λ = {lambda}");
    // A band given in Hz starts there and is re-centred on the estimate.
    let r = simulate(&RunConfig {
        lambda: LambdaSource::Band {
            lo_rad_s: 2.0 * std::f64::consts::PI * 40.0,
            hi_rad_s: 2.0 * std::f64::consts::PI * 80.0,
        },
        ..RunConfig::default()
    });
    assert!((r.builds[0].lambda_rad_s / 355.4 - 1.0).abs() < 1e-3);
    assert!(r.builds.len() >= 2, "re-centred: {:?}", r.builds);
    assert!((r.lambda_rad_s.unwrap() / 98.0 - 1.0).abs() < 0.1);
    assert!(r.rel_error.max() < 1e-6, "{:?}", r.rel_error);
}

/// Single precision with one and three modes (the two-mode cases are in
/// precision.rs).
#[test]
fn f32_one_and_three_modes_converge() {
    for (modes, limit) in [(1, 1e-5), (3, 1e-4)] {
        let r = simulate(&RunConfig {
            plant: PlantSpec::default_for_modes(modes).expect("default plant"),
            precision: Precision::F32,
            ..RunConfig::default()
        });
        assert!(
            r.rel_error.max() < limit,
            "{modes} modes: {:?}",
            r.rel_error
        );
        assert_eq!(r.skipped_updates, 0);
    }
}

/// The rule on plants spread over the range the issue names (ω1 10–200,
/// ω2/ω1 2–10) in both precisions, noise-free: every one converges.
#[test]
fn random_plants_converge_with_the_rule() {
    for (i, m) in host_tests::scenario::random_two_mode_plants(8, 77)
        .into_iter()
        .enumerate()
    {
        for (precision, limit) in [(Precision::F64, 1e-5), (Precision::F32, 1e-4)] {
            let r = simulate(&RunConfig {
                plant: PlantSpec::Modal(m),
                precision,
                ..RunConfig::default()
            });
            assert!(
                r.rel_error.max() < limit,
                "plant {i} ({:?} rad/s) {precision:?}: {:?}, λ {:?}",
                &m.omega_rad_s[..2],
                r.rel_error,
                r.builds
            );
        }
    }
}
