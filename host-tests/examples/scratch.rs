//! Ad-hoc experiment driver (not part of the test suite).
use host_tests::runner::*;
use host_tests::scenario::*;
fn main() {
    let a: Vec<String> = std::env::args().skip(1).collect();
    let precision = if a.first().map(|s| s == "f32").unwrap_or(true) {
        Precision::F32
    } else {
        Precision::F64
    };
    let duration_s: f64 = a.get(1).map(|s| s.parse().unwrap()).unwrap_or(20.0);
    let gains = if a.get(2).map(|s| s == "paper").unwrap_or(false) {
        Gains::Paper
    } else {
        Gains::Default
    };
    let plant = match a.get(3).map(|s| s.parse::<usize>().unwrap()) {
        Some(i) => PlantSpec::Modal(random_two_mode_plants(5, 2026)[i]),
        None => PlantSpec::Paper,
    };
    let lambda_rad_s = a.get(4).map(|s| s.parse().unwrap());
    let cfg = RunConfig {
        precision,
        duration_s,
        gains,
        plant,
        lambda_rad_s,
        ..Default::default()
    };
    let mut next = 0.05;
    let r = run(&cfg, &mut |t: &Trace| {
        if t.t_s >= next {
            print!("t={:.2}:{:.1e} ", t.t_s, t.max_rel_error);
            next *= 2.0;
        }
    })
    .unwrap();
    println!(
        "\n{:?}\nt1 {:?} t01 {:?} max_after_1s {:?} exc {:?} skipped {}",
        r.rel_error,
        r.time_to_1pct_s,
        r.time_to_0p1pct_s,
        r.max_error_after_1s,
        r.excitation_min_eig,
        r.skipped_updates
    );
}
