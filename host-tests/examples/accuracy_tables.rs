//! Accuracy tables for BENCHMARKS.md that `beamctl` has no flag for:
//! the y-hold order's floor and the five random two-mode plants of the
//! acceptance tests, in f64 and f32.
//! `cargo run --release -p host-tests --example accuracy_tables`
use beamctl::run::plant::PlantSpec;
use beamctl::run::{run, Precision, RunConfig, RunReport};
use beamest::filter_bank::OutputHold;
use beamest::tuning::LambdaSource;
use host_tests::scenario::random_two_mode_plants;

fn go(cfg: &RunConfig) -> RunReport {
    run(cfg, &mut |_| {}).expect("valid configuration")
}

fn fmt_t(t: Option<f64>) -> String {
    t.map_or("never".into(), |t| format!("{t:.3}"))
}

fn main() {
    println!("### y-hold order (paper plant, f64, 20 s, the paper's λ = 100 rad/s)\n");
    println!("| hold | ω1 | ω2 | ζ1 | ζ2 |");
    println!("|---|---|---|---|---|");
    for hold in [
        OutputHold::ZeroOrder,
        OutputHold::FirstOrder,
        OutputHold::Cubic,
        OutputHold::Quintic,
    ] {
        let r = go(&RunConfig {
            hold,
            lambda: LambdaSource::Fixed(100.0),
            ..RunConfig::default()
        });
        let e = &r.rel_error;
        println!(
            "| {hold:?} | {:.1e} | {:.1e} | {:.1e} | {:.1e} |",
            e.omega[0], e.omega[1], e.zeta[0], e.zeta[1]
        );
    }
    println!("\n### Five random two-mode plants (seed 2026, 20 s, λ by the truth-free rule)\n");
    println!("| # | ω (rad/s) | ζ | λ | f64 max error | f64 time to 0.1% (s) | f32 max error | f32 time to 0.1% (s) |");
    println!("|---|---|---|---|---|---|---|---|");
    for (i, m) in random_two_mode_plants(5, 2026).into_iter().enumerate() {
        let base = RunConfig {
            plant: PlantSpec::Modal(m),
            ..RunConfig::default()
        };
        let r64 = go(&base);
        let lambda = r64.lambda_rad_s.unwrap_or(f64::NAN);
        let r32 = go(&RunConfig {
            precision: Precision::F32,
            ..base
        });
        println!(
            "| {i} | {:.1}, {:.1} | {:.3}, {:.3} | {:.0} | {:.1e} | {} | {:.1e} | {} |",
            m.omega_rad_s[0],
            m.omega_rad_s[1],
            m.zeta[0],
            m.zeta[1],
            lambda,
            r64.rel_error.max(),
            fmt_t(r64.time_to_0p1pct_s),
            r32.rel_error.max(),
            fmt_t(r32.time_to_0p1pct_s)
        );
    }
}
