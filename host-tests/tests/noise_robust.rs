//! Noise: the Cramér–Rao bound (`beamest::crlb`) and the noise-robust
//! estimator (`beamest::estimator::robust`) on the paper's plant
//! (u = 0.1·square(7 Hz), Ts = 0.1 ms, λ = 100 rad/s, truth-free scales:
//! RMS of u and y over the first 0.5 s).
//!
//! The long ones are `#[ignore]`:
//! `cargo test --release -p host-tests --test noise_robust -- --ignored`.

use beamest::crlb::{FisherAccumulator, ModelSet};
use beamest::estimator::robust::Phase;
use beamest::estimator::robust::{Robust2, Robust2Compact, RobustConfig};
use beamest::estimator::{Adaptive2, AdaptiveConfig, Estimator};
use beamest::model::{paper_plant_tf, PAPER_OMEGA, PAPER_ZETA};
use beamest::Real;
use host_tests::noise_study::{
    fit_output_error, paper_tf_params, rms, run, study_filter, Errors, Record,
};

/// The bound (transfer-function set) on ω1, ω2, ζ1, ζ2 for a record and an
/// SNR.
fn bound(rec: &Record, snr_db: f64, set: ModelSet) -> [f64; 4] {
    let mut acc = FisherAccumulator::from_tf(&paper_plant_tf(), &[-2.0, 2.0], 1e-4).unwrap();
    acc.push_all(rec.u.iter().copied());
    let b = acc.bound(set, acc.sigma_for_snr_db(snr_db)).unwrap();
    [b.omega_rel[0], b.omega_rel[1], b.zeta_rel[0], b.zeta_rel[1]]
}

fn close(got: f64, want: f64, rel: f64) -> bool {
    (got / want - 1.0).abs() <= rel
}

#[test]
fn bound_reproduces_the_figures_of_issue_9() {
    // The figures of issue 9 (relative 1σ, 60 s, 40 dB): ω1 3.2e-6, ω2 3.9e-4,
    // ζ1 7.8e-5, ζ2 3.2e-3; ×10 at 20 dB; ζ2 0.53% over 20 s. These are the
    // modal set (ω, ζ, b̄ unknown, the velocity weights of eq. 46 known).
    let rec = Record::paper(60.0);
    let m40 = bound(&rec, 40.0, ModelSet::Modal);
    for (got, want) in m40.iter().zip([3.2e-6, 3.9e-4, 7.8e-5, 3.2e-3]) {
        assert!(close(*got, want, 0.02), "{got} vs {want}");
    }
    let m20 = bound(&rec, 20.0, ModelSet::Modal);
    for i in 0..4 {
        assert!(close(m20[i], 10.0 * m40[i], 1e-9));
    }
    let short = bound(&Record::paper(20.0), 40.0, ModelSet::Modal);
    assert!(close(short[3], 5.3e-3, 0.01), "{}", short[3]);
    // The estimators' 7-parameter set: ζ1's bound doubles, the rest moves ≤ 6%.
    let tf = bound(&rec, 40.0, ModelSet::TransferFunction);
    assert!(close(tf[2], 1.59e-4, 0.01), "{}", tf[2]);
    for i in [0, 1, 3] {
        assert!(tf[i] >= m40[i] && tf[i] <= 1.06 * m40[i], "{i}");
    }
}

#[test]
fn bound_is_dominated_by_the_start_up_ring_down() {
    // The same 50 s of data carry 100× less information on ω1 once mode 1's
    // start-up transient (time constant 1.2 s) has died out.
    let rec = Record::paper(60.0);
    let full = bound(&rec, 40.0, ModelSet::TransferFunction);
    let mut late = FisherAccumulator::from_tf(&paper_plant_tf(), &[-2.0, 2.0], 1e-4).unwrap();
    late.push_all(rec.u[..100_000].iter().copied());
    let sigma = late.sigma_for_snr_db(40.0);
    late.clear_information();
    late.push_all(rec.u[100_000..].iter().copied());
    let b = late.bound(ModelSet::TransferFunction, sigma).unwrap();
    assert!(
        b.omega_rel[0] > 50.0 * full[0],
        "{} vs {}",
        b.omega_rel[0],
        full[0]
    );
    assert!(b.zeta_rel[0] > 20.0 * full[2]);
}

#[test]
#[ignore]
fn maximum_likelihood_reaches_the_bound() {
    // Monte Carlo: 60 realizations of 20 s at 40 dB; the sample standard
    // deviation of the output-error ML fit has a relative 1σ of 1/√120 ≈ 9%.
    let rec = Record::paper(20.0);
    let b = bound(&rec, 40.0, ModelSet::TransferFunction);
    let truth = paper_tf_params();
    let mut errs = Vec::new();
    for seed in 0..60 {
        let y = rec.noisy_y(Some(40.0), 5000 + seed);
        let p = fit_output_error(&rec.u, &y, &truth, 3).expect("fit");
        errs.push([
            p[0] / PAPER_OMEGA[0] - 1.0,
            p[1] / PAPER_OMEGA[1] - 1.0,
            p[2] / PAPER_ZETA[0] - 1.0,
            p[3] / PAPER_ZETA[1] - 1.0,
        ]);
    }
    let r = rms(&errs);
    for i in 0..4 {
        // 3.3σ either way: the bound is neither beaten nor missed.
        assert!(
            r[i] / b[i] > 0.7 && r[i] / b[i] < 1.3,
            "{i}: {}",
            r[i] / b[i]
        );
    }
}

/// Five seeds of 60 s at `snr_db` in precision `T`, the record kept as it
/// came or (`compact`) in the firmware's form (u in 16 bits, y in block
/// means): per-seed errors.
fn five_seeds<T: Real>(snr_db: f64, compact: bool) -> (Vec<Errors>, [f64; 4]) {
    let rec = Record::paper(60.0);
    let errs = (1..=5)
        .map(|seed| {
            let y = rec.noisy_y(Some(snr_db), seed);
            let f = study_filter(&rec.u, &y);
            let cfg = RobustConfig::default();
            let (e, phase, ok) = if compact {
                let mut est = Box::new(Robust2Compact::<T>::new(&f, &cfg).unwrap());
                let e = run(&mut *est, &rec.u, &y, 0, &mut |_, _| {});
                (e, est.phase(), est.health().state_ok)
            } else {
                let mut est = Box::new(Robust2::<T>::new(&f, &cfg).unwrap());
                let e = run(&mut *est, &rec.u, &y, 0, &mut |_, _| {});
                (e, est.phase(), est.health().state_ok)
            };
            assert_eq!(phase, Phase::Steady);
            assert!(ok);
            e
        })
        .collect();
    (errs, bound(&rec, snr_db, ModelSet::TransferFunction))
}

fn check_40_db<T: Real>(compact: bool) {
    let (errs, b) = five_seeds::<T>(40.0, compact);
    for e in &errs {
        assert!(
            e.iter().all(|v| v.abs() < 0.01),
            "{} seed errors {e:?}",
            T::NAME
        );
    }
    let r = rms(&errs);
    for i in 0..4 {
        assert!(
            r[i] <= 2.0 * b[i],
            "{} (compact {compact}) {i}: RMS {} bound {}",
            T::NAME,
            r[i],
            b[i]
        );
    }
}

#[test]
#[ignore]
fn robust_is_within_twice_the_bound_at_40_db_f64() {
    check_40_db::<f64>(false);
}

#[test]
#[ignore]
fn robust_is_within_twice_the_bound_at_40_db_f32() {
    check_40_db::<f32>(false);
}

/// The firmware's form: `f32` with the compact record (the QEMU image's).
#[test]
#[ignore]
fn robust_with_the_compact_record_is_within_twice_the_bound_at_40_db_f32() {
    check_40_db::<f32>(true);
}

#[test]
#[ignore]
fn robust_at_20_db() {
    // Measured (5 seeds, 2 s record): RMS ÷ bound 1.2, 2.5, 0.7, 0.6 (f64),
    // 1.2, 2.3, 0.7, 0.7 (f32); over 20 seeds 1.0, 2.0, 1.0, 1.6. ω2 misses
    // 2× by the linearization point frozen at 2 s (module docs).
    for (name, (errs, b)) in [
        ("f64", five_seeds::<f64>(20.0, false)),
        ("f32", five_seeds::<f32>(20.0, false)),
        ("f32, compact record", five_seeds::<f32>(20.0, true)),
    ] {
        let r = rms(&errs);
        for i in [0, 2, 3] {
            assert!(r[i] <= 2.0 * b[i], "{name} {i}: {}", r[i] / b[i]);
        }
        assert!(r[1] <= 3.0 * b[1], "{name} ω2: {}", r[1] / b[1]);
    }
}

#[test]
fn robust_removes_the_bias_of_the_paper_law_at_40_db() {
    // 20 s, one seed: the paper's law is 1.9% off on ζ2 (errors in
    // variables; 3.2× the bound and growing with the record, since the bias
    // does not average out); the robust estimator is within its bound's
    // range.
    let rec = Record::paper(20.0);
    let y = rec.noisy_y(Some(40.0), 1);
    let f = study_filter(&rec.u, &y);
    let mut paper = Adaptive2::<f64>::new(&f, &AdaptiveConfig::default()).unwrap();
    let e_paper = run(&mut paper, &rec.u, &y, 0, &mut |_, _| {});
    let mut robust = Box::new(Robust2::<f64>::new(&f, &RobustConfig::default()).unwrap());
    let e_robust = run(&mut *robust, &rec.u, &y, 0, &mut |_, _| {});
    let b = bound(&rec, 40.0, ModelSet::TransferFunction);
    assert!(e_paper[3].abs() > 0.015, "{e_paper:?}");
    for i in 0..4 {
        assert!(e_robust[i].abs() < 4.0 * b[i], "{i}: {e_robust:?}");
    }
    // A posteriori noise level: the residual RMS is the noise σ within 2%.
    let sigma = rec.rms_y() / 100.0;
    let got = robust.noise_rms().unwrap();
    assert!(close(got, sigma, 0.02), "{got} vs {sigma}");
}

#[test]
fn robust_noise_free_accuracy() {
    // 20 s noise-free: f64 at the plain law's level, f32 well below 1e-4.
    let rec = Record::paper(20.0);
    let f = study_filter(&rec.u, &rec.y);
    let mut e64 = Box::new(Robust2::<f64>::new(&f, &RobustConfig::default()).unwrap());
    let err = run(&mut *e64, &rec.u, &rec.y, 0, &mut |_, _| {});
    assert!(err.iter().all(|e| e.abs() < 1e-9), "f64 {err:?}");
    let mut e32 = Box::new(Robust2::<f32>::new(&f, &RobustConfig::default()).unwrap());
    let err = run(&mut *e32, &rec.u, &rec.y, 0, &mut |_, _| {});
    assert!(err.iter().all(|e| e.abs() < 1e-5), "f32 {err:?}");
}

#[test]
fn robust_one_and_three_modes_noise_free() {
    use beamctl::run::plant::PlantSpec;
    use beamest::estimator::robust::{Robust1, Robust3};
    use beamest::excitation::SquareWave;
    use beamest::filter_bank::{FilterConfig, SignalScales};
    use beamest::modal::modal_from_tf;
    use beamest::model::TransferFunction;
    // The documented default beams: the paper's first mode; the paper's two
    // plus ω3 = 687.4 rad/s. λ = √(ω_min·ω_max) of the nominal plant, scales
    // from the first 0.5 s of data; 5 s of data.
    for modes in [1usize, 3] {
        let spec = PlantSpec::default_for_modes(modes).unwrap();
        let truth = spec.truth();
        let mut plant = spec.plant(1e-4).unwrap();
        let mut sq = SquareWave::<f64>::paper();
        let (u, y): (Vec<f64>, Vec<f64>) = (0..50_000)
            .map(|_| {
                let u = sq.next_sample();
                (u, plant.sample(u))
            })
            .unzip();
        let w = &truth.modal.omega_rad_s[..modes];
        let f = FilterConfig {
            lambda_rad_s: (w[0] * w[modes - 1]).sqrt(),
            scales: SignalScales {
                u_scale: 0.1,
                y_scale: (y[..5000].iter().map(|v| v * v).sum::<f64>() / 5000.0).sqrt(),
            },
            ..FilterConfig::default()
        };
        let tf: TransferFunction<f64> = if modes == 1 {
            let mut e = Box::new(Robust1::<f64>::new(&f, &RobustConfig::default()).unwrap());
            run(&mut *e, &u, &y, 0, &mut |_, _| {});
            assert_eq!(e.phase(), Phase::Steady);
            e.transfer_function()
        } else {
            let mut e = Box::new(Robust3::<f64>::new(&f, &RobustConfig::default()).unwrap());
            run(&mut *e, &u, &y, 0, &mut |_, _| {});
            assert_eq!(e.phase(), Phase::Steady);
            e.transfer_function()
        };
        let m = modal_from_tf(&tf, &truth.modal.output_weight[..modes]).unwrap();
        for i in 0..modes {
            let ew = m.omega_rad_s[i] / truth.modal.omega_rad_s[i] - 1.0;
            let ez = m.zeta[i] / truth.modal.zeta[i] - 1.0;
            assert!(
                ew.abs() < 1e-9 && ez.abs() < 1e-9,
                "{modes} modes, #{i}: {ew} {ez}"
            );
        }
    }
}

#[test]
fn robust_started_on_a_moving_beam() {
    // The estimator starts 1 s after the excitation: the start test of
    // InitialState::Auto sees the beam moving and the replays fit its state.
    let rec = Record::paper(21.0);
    let start = 10_000;
    for snr in [None, Some(40.0)] {
        let y = rec.noisy_y(snr, 3);
        let (u, y) = (&rec.u[start..], &y[start..]);
        let f = study_filter(u, y);
        let mut est = Box::new(Robust2::<f64>::new(&f, &RobustConfig::default()).unwrap());
        let err = run(&mut *est, u, y, 0, &mut |_, _| {});
        let (chi2, used) = est.initial_state_significance().unwrap();
        assert!(used && chi2 > 1e3, "{chi2}");
        // At 40 dB over these 20 s the Cramér–Rao bound on ζ2 is 5.3e-3
        // from rest, and a start on a moving beam loses the ring-down's
        // information (≈1.8× that, examples/robust_design.rs): σ ≈ 1e-2 on
        // ζ2, so 3e-2 is a 3σ check, not a 1% one.
        let tol = if snr.is_none() { 1e-9 } else { 3e-2 };
        assert!(err.iter().all(|e| e.abs() < tol), "{snr:?}: {err:?}");
    }
    // Started with the excitation, the same test finds the beam at rest.
    let y = rec.noisy_y(Some(40.0), 3);
    let f = study_filter(&rec.u, &y);
    let mut est = Box::new(Robust2::<f64>::new(&f, &RobustConfig::default()).unwrap());
    run(&mut *est, &rec.u[..30_000], &y[..30_000], 0, &mut |_, _| {});
    let (chi2, used) = est.initial_state_significance().unwrap();
    assert!(!used && chi2 < 25.0, "{chi2}");
}
