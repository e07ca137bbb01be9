//! The Cramér–Rao bound as `beamctl` computes it for a configured
//! experiment (`beamctl::run::run_bound`, behind `beamctl crlb` and the
//! error ÷ bound of `beamctl simulate`), checked against a Monte Carlo run of
//! an efficient estimator, and against the figures of
//! `host-tests/examples/crlb_monte_carlo.rs`.

use beamctl::run::{rig, run_bound, RunConfig};
use beamest::crlb::{FisherAccumulator, ModelSet};
use beamest::model::{paper_plant_tf, PAPER_OMEGA, PAPER_ZETA};
use host_tests::noise_study::{fit_output_error, paper_tf_params, Record};

fn experiment(seconds: f64, snr_db: f64, seed: u64) -> RunConfig {
    RunConfig {
        duration_s: seconds,
        snr_db: Some(snr_db),
        seed,
        ..RunConfig::default()
    }
}

/// `beamctl simulate --snr-db` draws exactly the data of the noise studies
/// (same plant, input, σ definition and generator), so the bound it reports
/// is the one `crlb_monte_carlo` checks, to the last digit.
#[test]
fn beamctl_bound_and_data_are_the_examples() {
    let cfg = experiment(60.0, 40.0, 3);
    let b = run_bound(&cfg, ModelSet::TransferFunction)
        .expect("valid")
        .expect("noisy");
    let rec = Record::paper(60.0);
    let mut acc = FisherAccumulator::from_tf(&paper_plant_tf(), &[-2.0, 2.0], 1e-4).unwrap();
    acc.push_all(rec.u.iter().copied());
    let core = acc
        .bound(ModelSet::TransferFunction, acc.sigma_for_snr_db(40.0))
        .unwrap();
    assert!((b.sigma / core.sigma - 1.0).abs() < 1e-12);
    for i in 0..2 {
        assert!((b.omega.rel[i] / core.omega_rel[i] - 1.0).abs() < 1e-12);
        assert!((b.zeta.rel[i] / core.zeta_rel[i] - 1.0).abs() < 1e-12);
    }
    // The first 2 s of the simulated rig are the noisy record, sample for
    // sample.
    let y = rec.noisy_y(Some(40.0), 3);
    let mut r = rig(&cfg).unwrap();
    assert!(rec.u.len() >= 20_000 && y.len() >= 20_000);
    for (k, (u, yk)) in rec.u.iter().zip(&y).take(20_000).enumerate() {
        let s = r.tick();
        assert_eq!((s.u, s.y), (*u, *yk), "sample {k}");
    }
}

/// Monte Carlo: over 100 noise realizations of the paper's experiment (5 s
/// at 40 dB) the sample standard deviation of the maximum-likelihood
/// (output-error Gauss–Newton) estimate — an efficient estimator — matches
/// the bound beamctl computes for that experiment within the Monte Carlo
/// uncertainty (relative 1σ of a sample standard deviation over 100 draws:
/// 1/√200 ≈ 0.07; the test allows 3.5σ either way, so a bound off by 1.25×
/// in either direction fails). `--nocapture` prints the ratios.
#[test]
fn beamctl_bound_is_the_spread_of_an_efficient_estimator() {
    const N: u64 = 100;
    let cfg = experiment(5.0, 40.0, 1);
    let b = run_bound(&cfg, ModelSet::TransferFunction)
        .expect("valid")
        .expect("noisy");
    let bound = [b.omega.rel[0], b.omega.rel[1], b.zeta.rel[0], b.zeta.rel[1]];
    let rec = Record::paper(5.0);
    let truth = paper_tf_params();
    let errs: Vec<[f64; 4]> = (0..N)
        .map(|seed| {
            let y = rec.noisy_y(Some(40.0), 7000 + seed);
            let p = fit_output_error(&rec.u, &y, &truth, 3).expect("fit");
            [
                p[0] / PAPER_OMEGA[0] - 1.0,
                p[1] / PAPER_OMEGA[1] - 1.0,
                p[2] / PAPER_ZETA[0] - 1.0,
                p[3] / PAPER_ZETA[1] - 1.0,
            ]
        })
        .collect();
    let m = N as f64;
    let tol = 3.5 / (2.0 * m).sqrt();
    for i in 0..4 {
        let mean = errs.iter().map(|e| e[i]).sum::<f64>() / m;
        let sd = (errs.iter().map(|e| (e[i] - mean).powi(2)).sum::<f64>() / (m - 1.0)).sqrt();
        let ratio = sd / bound[i];
        println!(
            "parameter {i}: sample std {sd:.3e}, bound {:.3e}, ratio {ratio:.3}",
            bound[i]
        );
        assert!(
            (ratio - 1.0).abs() < tol,
            "parameter {i}: sample std ÷ bound {ratio}"
        );
        // And the ML estimate is unbiased at this level.
        assert!(
            mean.abs() < 4.0 * bound[i] / m.sqrt(),
            "parameter {i}: mean {mean:e}"
        );
    }
}
