//! Monte Carlo check of the Cramér–Rao bound (`beamest::crlb`): the sample
//! standard deviation of the maximum-likelihood (output-error, Gauss–Newton)
//! estimate over N noisy realizations against the bound, on the paper's
//! plant (u = 0.1·square(7 Hz), Ts = 0.1 ms).
//!
//! `cargo run --release -p host-tests --example crlb_monte_carlo -- [seconds] [N] [snr_db]`
//! (defaults 60 s, 100 realizations, 40 dB). The bound of a sample standard
//! deviation over N draws has a relative 1σ of ≈ 1/√(2N) (7% for N = 100).

use beamest::crlb::{FisherAccumulator, ModelSet};
use beamest::model::{paper_plant_tf, PAPER_OMEGA, PAPER_ZETA};
use host_tests::noise_study::{fit_output_error, paper_tf_params, Record};

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let seconds: f64 = args.get(1).and_then(|s| s.parse().ok()).unwrap_or(60.0);
    let n: u64 = args.get(2).and_then(|s| s.parse().ok()).unwrap_or(100);
    let snr: f64 = args.get(3).and_then(|s| s.parse().ok()).unwrap_or(40.0);
    let rec = Record::paper(seconds);
    let mut acc = FisherAccumulator::from_tf(&paper_plant_tf(), &[-2.0, 2.0], 1e-4).unwrap();
    acc.push_all(rec.u.iter().copied());
    let sigma = acc.sigma_for_snr_db(snr);
    let tf = acc.bound(ModelSet::TransferFunction, sigma).unwrap();
    let modal = acc.bound(ModelSet::Modal, sigma).unwrap();
    let truth = paper_tf_params();
    let mut errs: Vec<[f64; 4]> = Vec::new();
    for seed in 1..=n {
        let y = rec.noisy_y(Some(snr), 1000 + seed);
        let Some(p) = fit_output_error(&rec.u, &y, &truth, 3) else {
            eprintln!("seed {seed}: fit failed");
            continue;
        };
        errs.push([
            p[0] / PAPER_OMEGA[0] - 1.0,
            p[1] / PAPER_OMEGA[1] - 1.0,
            p[2] / PAPER_ZETA[0] - 1.0,
            p[3] / PAPER_ZETA[1] - 1.0,
        ]);
    }
    let m = errs.len() as f64;
    println!("paper's plant, {seconds} s, {snr} dB (σ = {sigma:.3e}), {} realizations, ML (output-error Gauss–Newton) fit\n", errs.len());
    println!("| | ω1 | ω2 | ζ1 | ζ2 |");
    println!("|---|---|---|---|---|");
    let names = ["ω1", "ω2", "ζ1", "ζ2"];
    let b_tf = [
        tf.omega_rel[0],
        tf.omega_rel[1],
        tf.zeta_rel[0],
        tf.zeta_rel[1],
    ];
    let b_mod = [
        modal.omega_rel[0],
        modal.omega_rel[1],
        modal.zeta_rel[0],
        modal.zeta_rel[1],
    ];
    let mean: Vec<f64> = (0..4)
        .map(|i| errs.iter().map(|e| e[i]).sum::<f64>() / m)
        .collect();
    let sd: Vec<f64> = (0..4)
        .map(|i| (errs.iter().map(|e| (e[i] - mean[i]).powi(2)).sum::<f64>() / (m - 1.0)).sqrt())
        .collect();
    let row = |label: &str, v: &dyn Fn(usize) -> String| {
        println!("| {label} | {} | {} | {} | {} |", v(0), v(1), v(2), v(3));
    };
    row("bound, transfer-function set (relative 1σ)", &|i| {
        format!("{:.3e}", b_tf[i])
    });
    row("bound, modal set (β known)", &|i| {
        format!("{:.3e}", b_mod[i])
    });
    row("ML sample std", &|i| format!("{:.3e}", sd[i]));
    row("ML mean error", &|i| format!("{:+.1e}", mean[i]));
    row("sample std ÷ TF-set bound", &|i| {
        format!("{:.2}", sd[i] / b_tf[i])
    });
    println!(
        "\nMC uncertainty of the ratio (1σ): ±{:.2}",
        1.0 / (2.0 * m).sqrt()
    );
    let _ = names;
}
