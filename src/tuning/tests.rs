use super::*;
use crate::estimator::{Adaptive2, AdaptiveConfig, Estimator, StepStatus};
use crate::excitation::SquareWave;
use crate::modal::modal_from_tf;
use crate::model::{ModalParams, PAPER_B, PAPER_OMEGA, PAPER_ZETA};
use crate::rig::{ModalPlant, Rig};

const TS: f64 = 1e-4;

fn tf_of(omega: &[f64], zeta: &[f64]) -> TransferFunction<f64> {
    let n = omega.len();
    ModalParams::new(omega, zeta, &[10.0, 15.0, 20.0][..n], None)
        .unwrap()
        .transfer_function()
}

#[test]
fn invalid_settings_are_named() {
    let ok = TuningConfig::new(TS, LambdaSource::Data);
    assert!(AutoTune::new(&ok).is_ok());
    let bad = |f: fn(&mut TuningConfig)| {
        let mut c = ok;
        f(&mut c);
        AutoTune::new(&c).err()
    };
    assert_eq!(bad(|c| c.ts_s = 0.0), Some(TuningError::SamplePeriod));
    assert_eq!(
        bad(|c| c.lambda = LambdaSource::Fixed(f64::NAN)),
        Some(TuningError::Lambda)
    );
    assert_eq!(
        bad(|c| {
            c.lambda = LambdaSource::Band {
                lo_rad_s: 300.0,
                hi_rad_s: 100.0,
            }
        }),
        Some(TuningError::Band)
    );
    assert_eq!(
        bad(|c| {
            c.scales = Some(SignalScales {
                u_scale: -1.0,
                y_scale: 1.0,
            })
        }),
        Some(TuningError::Scale)
    );
    assert_eq!(bad(|c| c.startup_s = 0.0), Some(TuningError::Window));
    assert_eq!(bad(|c| c.stable_reviews = 0), Some(TuningError::Review));
    assert_eq!(bad(|c| c.stable_reviews = 33), Some(TuningError::Review));
}

#[test]
fn known_settings_build_at_once_without_settling() {
    let scales = SignalScales {
        u_scale: 0.1,
        y_scale: 1e-3,
    };
    let mut cfg = TuningConfig::new(TS, LambdaSource::Fixed(120.0));
    cfg.scales = Some(scales);
    let mut t = AutoTune::new(&cfg).unwrap();
    let f = t.immediate().expect("known up front");
    assert_eq!((f.lambda_rad_s, f.scales), (120.0, scales));
    assert_eq!(t.phase(), Phase::Settled(Settled::Fixed));
    assert_eq!(t.startup_sample(1.0, 1.0), None);
    assert!(!t.sample());
    // A band with known scales starts at its centre and keeps reviewing.
    cfg.lambda = LambdaSource::Band {
        lo_rad_s: 40.0,
        hi_rad_s: 250.0,
    };
    let t = AutoTune::new(&cfg).unwrap();
    assert_eq!(t.immediate().unwrap().lambda_rad_s, 100.0);
    assert_eq!(t.phase(), Phase::Reviewing);
    // Without scales there is a start-up window.
    cfg.scales = None;
    assert_eq!(AutoTune::new(&cfg).unwrap().immediate(), None);
}

#[test]
fn startup_window_gives_rms_scales_and_a_data_lambda() {
    let mut t = AutoTune::new(&TuningConfig::new(TS, LambdaSource::Data)).unwrap();
    let plant = ModalPlant::with_numerator(&PAPER_OMEGA, &PAPER_ZETA, &PAPER_B, TS).unwrap();
    let mut rig = Rig::new(plant, SquareWave::<f64>::paper());
    let (mut sy2, mut n) = (0.0, 0);
    let filter = loop {
        let s = rig.tick();
        sy2 += s.y * s.y;
        n += 1;
        if let Some(f) = t.startup_sample(s.u, s.y) {
            break f;
        }
        assert!(n < 10_000);
    };
    assert_eq!(n, 2000, "0.2 s at 10 kHz");
    assert!((filter.scales.u_scale / 0.1 - 1.0).abs() < 1e-12);
    assert!((filter.scales.y_scale / libm::sqrt(sy2 / n as f64) - 1.0).abs() < 1e-12);
    let c = t.stats().centroid_rad_s(TS).unwrap();
    assert!((filter.lambda_rad_s - 2.0 * c).abs() < 1e-9);
    assert_eq!(t.phase(), Phase::Reviewing);
    // No review while the new filters settle (`quarantine_samples_for`).
    let settle = quarantine_samples_for(&filter) as usize;
    assert!((0..settle).all(|_| !t.sample()));
}

#[test]
fn the_window_waits_for_excitation_and_skips_bad_samples() {
    let mut t = AutoTune::new(&TuningConfig::new(TS, LambdaSource::Data)).unwrap();
    for _ in 0..5000 {
        assert_eq!(t.startup_sample(0.0, 0.0), None);
    }
    assert_eq!(t.startup_sample(f64::NAN, 1.0), None);
    let f = t.startup_sample(1.0f32, 2.0f32).expect("u, y non-zero");
    assert_eq!(t.stats().rejected(), 1);
    assert!(f.scales.u_scale > 0.0 && f.scales.y_scale > f.scales.u_scale);
    // A constant y has no centroid: λ0 falls back to the middle of the
    // allowed range, √(1e-4·0.3)/Ts ≈ 55 rad/s.
    assert!((f.lambda_rad_s - libm::sqrt(3e-5) / TS).abs() < 1e-6);
}

/// Drive the review schedule with a fixed estimate; returns what the rule
/// asked for, in order.
fn reviews(t: &mut AutoTune, tf: &TransferFunction<f64>, samples: usize) -> Vec<f64> {
    let mut out = Vec::new();
    for _ in 0..samples {
        if t.sample() {
            if let Some(f) = t.review(tf) {
                out.push(f.lambda_rad_s);
            }
        }
    }
    out
}

#[test]
fn a_stable_estimate_recentres_lambda_once_then_settles() {
    let mut cfg = TuningConfig::new(
        TS,
        LambdaSource::Band {
            lo_rad_s: 10.0,
            hi_rad_s: 10.0,
        },
    );
    cfg.scales = Some(SignalScales::default());
    let mut t = AutoTune::new(&cfg).unwrap();
    assert_eq!(t.immediate().unwrap().lambda_rad_s, 10.0);
    let tf = tf_of(&[40.0, 250.0], &[0.02, 0.13]);
    let asked = reviews(&mut t, &tf, 50_000);
    assert_eq!(asked.len(), 1);
    assert!((asked[0] - 100.0).abs() < 1e-9, "{asked:?}");
    assert_eq!(t.recentres(), 1);
    assert_eq!(t.phase(), Phase::Settled(Settled::Converged));
    assert_eq!(t.filter().unwrap().lambda_rad_s, asked[0]);
}

#[test]
fn the_first_review_comes_after_settling_and_a_full_stability_window() {
    let mut cfg = TuningConfig::new(
        TS,
        LambdaSource::Band {
            lo_rad_s: 10.0,
            hi_rad_s: 10.0,
        },
    );
    cfg.scales = Some(SignalScales::default());
    let mut t = AutoTune::new(&cfg).unwrap();
    let tf = tf_of(&[40.0, 250.0], &[0.02, 0.13]);
    let mut k = 0;
    let when = loop {
        k += 1;
        if t.sample() && t.review(&tf).is_some() {
            break k;
        }
    };
    // Built at sample 0 without settling: 10 reviews of 100 samples.
    assert_eq!(when, 1000);
    // The rebuilt estimator settles for `QUARANTINE_TIME_CONSTANTS`/λ = 4000 samples first.
    let mut k = 0;
    while t.phase() == Phase::Reviewing {
        k += 1;
        if t.sample() {
            assert!(t.review(&tf).is_none());
        }
    }
    assert_eq!(k, 4000 + 1000);
}

#[test]
fn unstable_or_moving_estimates_do_not_recentre() {
    let mut cfg = TuningConfig::new(
        TS,
        LambdaSource::Band {
            lo_rad_s: 10.0,
            hi_rad_s: 10.0,
        },
    );
    cfg.scales = Some(SignalScales::default());
    cfg.review_timeout_s = 1.0;
    let mut t = AutoTune::new(&cfg).unwrap();
    // ζ < 0: not valid.
    let unstable = tf_of(&[40.0, 250.0], &[0.02, -0.13]);
    assert!(reviews(&mut t, &unstable, 9_000).is_empty());
    // Moving by 5% per review: never stable; the rule gives up after 1 s.
    let mut moved = Vec::new();
    let mut w2 = 250.0;
    for _ in 0..20_000 {
        if t.sample() {
            w2 *= 1.05;
            let tf = tf_of(&[40.0, w2], &[0.02, 0.13]);
            moved.extend(t.review(&tf));
        }
    }
    assert!(moved.is_empty());
    assert_eq!(t.phase(), Phase::Settled(Settled::Timeout));
}

#[test]
fn recentring_stops_after_the_most_allowed() {
    let mut cfg = TuningConfig::new(
        TS,
        LambdaSource::Band {
            lo_rad_s: 1.0,
            hi_rad_s: 1.0,
        },
    );
    cfg.scales = Some(SignalScales::default());
    cfg.max_recentres = 2;
    let mut t = AutoTune::new(&cfg).unwrap();
    // An estimate that moves by 2× between rebuilds (each review window
    // sees it constant).
    let mut asked = Vec::new();
    let mut w = 20.0;
    for _ in 0..200_000 {
        if t.sample() {
            let tf = tf_of(&[w, 4.0 * w], &[0.05, 0.05]);
            if let Some(f) = t.review(&tf) {
                asked.push(f.lambda_rad_s);
                w *= 2.0;
            }
        }
    }
    assert_eq!(asked, vec![40.0, 80.0]);
    assert_eq!(t.phase(), Phase::Settled(Settled::MaxRecentres));
}

#[test]
fn carry_over_keeps_the_transfer_function() {
    let tf = tf_of(&[39.1533, 245.3711], &[0.0207, 0.13]);
    let filter = FilterConfig {
        ts_s: TS,
        lambda_rad_s: 173.0,
        scales: SignalScales {
            u_scale: 0.07,
            y_scale: 3e-4,
        },
        ..FilterConfig::default()
    };
    let theta_s = carry_over::<f64, 7>(&tf, &filter).unwrap();
    let theta = Scaling::<7>::new(&filter).to_physical(&theta_s);
    let back = TransferFunction::from_theta(&theta, 173.0).unwrap();
    for i in 0..4 {
        assert!((back.a[i] / tf.a[i] - 1.0).abs() < 1e-12, "a{i}");
    }
    for i in 0..3 {
        assert!((back.b[i] / tf.b[i] - 1.0).abs() < 1e-12, "b{i}");
    }
    // Wrong size or non-finite: none.
    assert_eq!(carry_over::<f64, 3>(&tf, &filter), None);
    let mut nan = tf;
    nan.a[0] = f64::NAN;
    assert_eq!(carry_over::<f64, 7>(&nan, &filter), None);
}

/// The whole rule on the paper's plant, f64: data λ0 (made 3× too low so
/// that it must move), re-centred near √(ω1ω2) = 98 rad/s, estimate
/// carried over without a jump, final error at the floor of the
/// sampled-data filters.
#[test]
fn paper_plant_end_to_end_from_data_alone() {
    let mut cfg = TuningConfig::new(TS, LambdaSource::Data);
    cfg.data_lambda_factor = 0.6;
    let mut t = AutoTune::new(&cfg).unwrap();
    let plant = ModalPlant::with_numerator(&PAPER_OMEGA, &PAPER_ZETA, &PAPER_B, TS).unwrap();
    let mut rig = Rig::new(plant, SquareWave::<f64>::paper());
    let mut est: Option<Adaptive2<f64>> = None;
    let w = [-2.0, 2.0];
    let err = |e: &Adaptive2<f64>| {
        let m = modal_from_tf(&e.transfer_function(), &w).unwrap();
        (0..2)
            .map(|i| {
                (m.omega_rad_s[i] / PAPER_OMEGA[i] - 1.0)
                    .abs()
                    .max((m.zeta[i] / PAPER_ZETA[i] - 1.0).abs())
            })
            .fold(0.0, f64::max)
    };
    for _ in 0..40_000 {
        let s = rig.tick();
        match est.as_mut() {
            None => {
                if let Some(f) = t.startup_sample(s.u, s.y) {
                    let mut e = Adaptive2::new(&f, &AdaptiveConfig::default()).unwrap();
                    e.hold_for_settling();
                    est = Some(e);
                }
            }
            Some(e) => {
                let status = e.step(s.u, s.y);
                assert_ne!(status, StepStatus::Rejected);
                if t.sample() {
                    let tf = e.transfer_function();
                    if let Some(f) = t.review(&tf) {
                        let before = err(e);
                        let cfg = AdaptiveConfig {
                            theta0: carry_over(&tf, &f).unwrap(),
                            ..AdaptiveConfig::default()
                        };
                        let mut next = Adaptive2::new(&f, &cfg).unwrap();
                        next.hold_for_settling();
                        assert!((err(&next) - before).abs() < 1e-9, "carry-over jumped");
                        *e = next;
                    }
                }
            }
        }
    }
    let lambda = t.filter().unwrap().lambda_rad_s;
    let centre = libm::sqrt(PAPER_OMEGA[0] * PAPER_OMEGA[1]);
    assert!((lambda / centre - 1.0).abs() < 0.1, "λ = {lambda}");
    assert!(t.recentres() >= 1);
    assert_eq!(t.phase(), Phase::Settled(Settled::Converged));
    let e = err(est.as_ref().unwrap());
    assert!(e < 1e-8, "{e:e}");
}

#[test]
fn advance_is_the_same_as_that_many_samples() {
    // Settling 4000 samples (λ = 100), reviews every 100, timeout 1 s:
    // batches of every size from 1 to 257 across settling, the reviews
    // and the timeout give the same due flags and the same phase.
    let mut cfg = TuningConfig::new(TS, LambdaSource::Data);
    cfg.review_timeout_s = 1.0;
    let filter = FilterConfig {
        ts_s: TS,
        lambda_rad_s: 100.0,
        ..FilterConfig::default()
    };
    let armed = || {
        let mut t = AutoTune::new(&cfg).unwrap();
        for _ in 0..2_000 {
            t.startup_sample(0.1, 1e-3 * libm::sin(0.01 * t.stats().samples() as f64));
        }
        assert_eq!(t.phase(), Phase::Reviewing);
        t.rebuilt(filter);
        t
    };
    for batch in 1..=257u64 {
        let (mut a, mut b) = (armed(), armed());
        for _ in 0..(16_000 / batch) {
            let due_a = (0..batch).fold(false, |d, _| a.sample() | d);
            let due_b = b.advance(batch);
            assert_eq!(due_a, due_b, "batch {batch}");
            assert_eq!(a.phase(), b.phase(), "batch {batch}");
        }
        assert_eq!(b.phase(), Phase::Settled(Settled::Timeout));
    }
    assert!(!armed().advance(0));
}

#[test]
fn rebuilt_rearms_the_reviews_with_settling() {
    let mut cfg = TuningConfig::new(TS, LambdaSource::Fixed(10.0));
    cfg.scales = Some(SignalScales::default());
    let mut t = AutoTune::new(&cfg).unwrap();
    assert_eq!(t.phase(), Phase::Settled(Settled::Fixed));
    let filter = FilterConfig {
        lambda_rad_s: 10.0,
        ..t.filter().unwrap()
    };
    t.rebuilt(filter);
    assert_eq!((t.phase(), t.recentres()), (Phase::Reviewing, 0));
    // `QUARANTINE_TIME_CONSTANTS`/λ = 40,000 samples of settling before the first review.
    assert!(!t.advance(40_000));
    let tf = tf_of(&[40.0, 250.0], &[0.02, 0.13]);
    let asked = reviews(&mut t, &tf, 2_000);
    assert_eq!(asked.len(), 1);
    assert!((asked[0] - 100.0).abs() < 1e-9);
    // During the start-up window it does nothing.
    let mut s = AutoTune::new(&TuningConfig::new(TS, LambdaSource::Data)).unwrap();
    s.rebuilt(filter);
    assert_eq!(s.phase(), Phase::Startup);
}
