//! Accuracy under white measurement noise: the robust estimator, the
//! paper's law and the two baselines against the Cramér–Rao bound, as a
//! markdown table (for BENCHMARKS.md).
//!
//! `cargo run --release -p host-tests --example noise_table -- [seconds] [seeds]`
//! (defaults: 60 s, 5 seeds). Paper's plant, u = 0.1·square(7 Hz), Ts =
//! 0.1 ms, λ = 100 rad/s, U0/Y0 = RMS of u, y over the first 0.5 s of the
//! noisy data; noise σ = RMS of the noise-free y over the record / 10^(SNR/20);
//! seeds 1…N. "RMS" is over the seeds, "max" the largest |error|.

use beamest::crlb::{FisherAccumulator, ModelSet};
use beamest::estimator::robust::{Robust2, Robust2Compact, RobustConfig};
use beamest::estimator::{
    Adaptive2, AdaptiveConfig, GradientConfig, GradientEstimator, LeastSquaresConfig,
    LeastSquaresEstimator,
};
use beamest::filter_bank::FilterConfig;
use beamest::model::paper_plant_tf;
use beamest::Real;
use host_tests::noise_study::{rms, run, study_filter, Errors, Record};

/// One estimator row: builds a fresh estimator per record.
type Build = fn(&FilterConfig, &[f64], &[f64]) -> Errors;

fn robust<T: Real>(f: &FilterConfig, u: &[f64], y: &[f64]) -> Errors {
    let mut est = Box::new(Robust2::<T>::new(f, &RobustConfig::default()).expect("config"));
    run(&mut *est, u, y, 0, &mut |_, _| {})
}

/// The firmware's form: the compact record (u in 16 bits, y in block
/// means), `f32`.
fn robust_compact(f: &FilterConfig, u: &[f64], y: &[f64]) -> Errors {
    let mut est =
        Box::new(Robust2Compact::<f32>::new(f, &RobustConfig::default()).expect("config"));
    run(&mut *est, u, y, 0, &mut |_, _| {})
}

fn adaptive(f: &FilterConfig, u: &[f64], y: &[f64]) -> Errors {
    let mut est = Adaptive2::<f64>::new(f, &AdaptiveConfig::default()).expect("config");
    run(&mut est, u, y, 0, &mut |_, _| {})
}

fn gradient(f: &FilterConfig, u: &[f64], y: &[f64]) -> Errors {
    let mut est =
        GradientEstimator::<f64, 4, 7>::new(f, &GradientConfig::default()).expect("config");
    run(&mut est, u, y, 0, &mut |_, _| {})
}

fn least_squares(f: &FilterConfig, u: &[f64], y: &[f64]) -> Errors {
    let mut est =
        LeastSquaresEstimator::<f64, 4, 7>::new(f, &LeastSquaresConfig::default()).expect("config");
    run(&mut est, u, y, 0, &mut |_, _| {})
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let seconds: f64 = args.get(1).and_then(|s| s.parse().ok()).unwrap_or(60.0);
    let seeds: u64 = args.get(2).and_then(|s| s.parse().ok()).unwrap_or(5);
    let rec = Record::paper(seconds);
    let mut crb = FisherAccumulator::from_tf(&paper_plant_tf(), &[-2.0, 2.0], 1e-4).expect("plant");
    crb.push_all(rec.u.iter().copied());
    let rows: [(&str, Build); 6] = [
        ("robust (f64)", robust::<f64>),
        ("robust (f32)", robust::<f32>),
        (
            "robust (f32, compact record: the firmware's)",
            robust_compact,
        ),
        ("adaptive, paper's law (f64)", adaptive),
        ("gradient (47) (f64)", gradient),
        ("least squares (48) (f64)", least_squares),
    ];
    println!("Paper's plant, {seconds} s, {seeds} seeds; relative errors of ω1, ω2, ζ1, ζ2.\n");
    println!("| SNR | estimator | RMS ω1 | RMS ω2 | RMS ζ1 | RMS ζ2 | RMS ÷ CRB (ω1, ω2, ζ1, ζ2) | max \\|error\\| |");
    println!("|---|---|---|---|---|---|---|---|");
    for snr in [40.0, 20.0] {
        let b = crb
            .bound(ModelSet::TransferFunction, crb.sigma_for_snr_db(snr))
            .expect("excited");
        let bound = [b.omega_rel[0], b.omega_rel[1], b.zeta_rel[0], b.zeta_rel[1]];
        println!(
            "| {snr} dB | Cramér–Rao bound (1σ, 7-parameter model) | {:.2e} | {:.2e} | {:.2e} | {:.2e} | 1, 1, 1, 1 | |",
            bound[0], bound[1], bound[2], bound[3]
        );
        let noisy: Vec<Vec<f64>> = (1..=seeds).map(|s| rec.noisy_y(Some(snr), s)).collect();
        for (name, build) in rows {
            let errs: Vec<Errors> = noisy
                .iter()
                .map(|y| build(&study_filter(&rec.u, y), &rec.u, y))
                .collect();
            if errs.iter().flatten().any(|e| !e.is_finite()) {
                let failed = errs
                    .iter()
                    .filter(|e| e.iter().any(|v| !v.is_finite()))
                    .count();
                println!(
                    "| {snr} dB | {name} | — | — | — | — | modal recovery failed for {failed} of {seeds} seeds | — |"
                );
                continue;
            }
            let r = rms(&errs);
            let max = errs.iter().flatten().fold(0.0f64, |m, e| {
                if e.is_nan() {
                    f64::INFINITY
                } else {
                    m.max(e.abs())
                }
            });
            println!(
                "| {snr} dB | {name} | {:.2e} | {:.2e} | {:.2e} | {:.2e} | {:.1}, {:.1}, {:.1}, {:.1} | {:.1e} |",
                r[0], r[1], r[2], r[3],
                r[0] / bound[0], r[1] / bound[1], r[2] / bound[2], r[3] / bound[3], max
            );
        }
    }
}
