//! BENCHMARKS.md, "Truth-free settings": the truth-free rule (λ and scales
//! from the data, re-centred) against the settings the project used before,
//! which read the simulated plant's truth (λ = √(ω_min·ω_max) of the true
//! modes, 100 rad/s for the paper's plant; Y0 = |G(0)|·U0 of the true
//! transfer function; the estimator started at sample 0). The truth is read
//! here only to build that old baseline and to score.
//!
//! `cargo run --release -p host-tests --example settings_table`

use beamctl::run::plant::{PlantSpec, Truth};
use beamctl::run::{run, Precision, RunConfig, RunReport};
use beamest::filter_bank::SignalScales;
use beamest::model::ModalParams;
use beamest::tuning::LambdaSource;
use host_tests::scenario::random_two_mode_plants;

fn go(cfg: &RunConfig) -> RunReport {
    run(cfg, &mut |_| {}).expect("valid configuration")
}

/// The old, truth-derived settings (removed from the runner): λ from the
/// true modes, Y0 = |G(0)|·U0 (the peak resonant response if G(0) = 0).
fn old_settings(plant: &PlantSpec, u0: f64) -> (f64, SignalScales) {
    let truth: Truth = plant.truth();
    let n = truth.modal.modes;
    let w = &truth.modal.omega_rad_s[..n];
    let lambda = match plant {
        PlantSpec::Paper => 100.0,
        PlantSpec::Modal(_) => (w[0] * w[n - 1]).sqrt(),
    };
    let (re, im) = truth.tf.freq_response(0.0);
    let mut g = re.hypot(im);
    if g.is_nan() || g <= 0.0 {
        g = w
            .iter()
            .map(|&wi| {
                let (re, im) = truth.tf.freq_response(wi);
                re.hypot(im)
            })
            .fold(0.0, f64::max);
    }
    (
        lambda,
        SignalScales {
            u_scale: u0,
            y_scale: g * u0,
        },
    )
}

fn t(x: Option<f64>) -> String {
    x.map_or("never".into(), |v| format!("{v:.3}"))
}

fn lambdas(r: &RunReport) -> String {
    r.builds
        .iter()
        .map(|b| format!("{:.0}", b.lambda_rad_s))
        .collect::<Vec<_>>()
        .join("→")
}

fn row(label: &str, base: &RunConfig) {
    let (lambda, scales) = old_settings(&base.plant, base.u_amplitude);
    let old = go(&RunConfig {
        lambda: LambdaSource::Fixed(lambda),
        scales: Some(scales),
        ..base.clone()
    });
    let new = go(base);
    println!(
        "| {label} | {:.0} | {:.1e} | {} | {} | {:.1e} | {} | {} |",
        lambda,
        old.rel_error.max(),
        t(old.time_to_0p1pct_s),
        lambdas(&new),
        new.rel_error.max(),
        t(new.time_to_0p1pct_s),
        new.tuning,
    );
}

fn header(title: &str) {
    println!("\n#### {title}\n");
    println!("| case | old λ | old max error | old time to 0.1% (s) | rule λ (rad/s) | rule max error | rule time to 0.1% (s) | rule ended |");
    println!("|---|---|---|---|---|---|---|---|");
}

fn main() {
    for precision in [Precision::F64, Precision::F32] {
        header(&format!("Noise-free, {precision:?}, 20 s"));
        for modes in [2, 1, 3] {
            let base = RunConfig {
                plant: PlantSpec::default_for_modes(modes).expect("default plant"),
                precision,
                ..RunConfig::default()
            };
            row(&format!("default {modes}-mode plant"), &base);
        }
        for (i, m) in random_two_mode_plants(8, 77).into_iter().enumerate() {
            let base = RunConfig {
                plant: PlantSpec::Modal(m),
                precision,
                ..RunConfig::default()
            };
            row(
                &format!(
                    "random #{i}: {:.1}/{:.1} rad/s",
                    m.omega_rad_s[0], m.omega_rad_s[1]
                ),
                &base,
            );
        }
    }
    let plant_52 = PlantSpec::Modal(
        ModalParams::new(&[52.7, 318.0], &[0.0207, 0.13], &[9.6293, 16.1458], None)
            .expect("2 modes"),
    );
    header("40 dB SNR, f64, 20 s");
    for (name, plant) in [
        ("paper plant", PlantSpec::Paper),
        ("52.7/318 rad/s", plant_52.clone()),
    ] {
        for seed in 1..=5 {
            let base = RunConfig {
                plant: plant.clone(),
                snr_db: Some(40.0),
                seed,
                ..RunConfig::default()
            };
            row(&format!("{name}, seed {seed}"), &base);
        }
    }
    println!("\n#### 52.7/318 rad/s at 40 dB: error vs a fixed λ (f64, 20 s, seeds 1–5, median of the largest ω/ζ error; ω2 error in parentheses)\n");
    println!("| λ (rad/s) | median max error | median ω2 error |");
    println!("|---|---|---|");
    let mut cases: Vec<(String, LambdaSource)> = [40.0, 60.0, 90.0, 129.5, 200.0, 300.0]
        .iter()
        .map(|&l| (format!("{l} (fixed)"), LambdaSource::Fixed(l)))
        .collect();
    cases.push(("rule (data)".into(), LambdaSource::Data));
    for (label, lambda) in cases {
        let mut max_err = Vec::new();
        let mut w2 = Vec::new();
        for seed in 1..=5 {
            let r = go(&RunConfig {
                plant: plant_52.clone(),
                snr_db: Some(40.0),
                seed,
                lambda,
                ..RunConfig::default()
            });
            max_err.push(r.rel_error.max());
            w2.push(r.rel_error.omega[1]);
        }
        max_err.sort_by(f64::total_cmp);
        w2.sort_by(f64::total_cmp);
        println!("| {label} | {:.1e} | {:.1e} |", max_err[2], w2[2]);
    }
}
