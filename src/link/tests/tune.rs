//! The automatic tuning rule through the link (`link::tune`): the first
//! build from the start-up window, re-centring with carry-over, λ fixed and
//! handed back by `SetEstimator`, dropped start-up blocks, a long freeze.

use super::*;

/// A record of the running estimator: Θ of ω = 40, 250 rad/s (ζ 0.02,
/// 0.13) at λ, with one law update.
fn record_of(index: u64, lambda: f64) -> TelemetryRecord<f32, 7, 28> {
    let tf = crate::model::ModalParams::new(&[40.0, 250.0], &[0.02, 0.13], &[10.0, 15.0], None)
        .unwrap()
        .transfer_function();
    let mut theta = [0.0f64; 7];
    tf.to_theta(lambda, &mut theta).unwrap();
    TelemetryRecord {
        theta: theta.map(|v| v as f32),
        lambda_rad_s: lambda,
        steps: StepCounts {
            updated: 1,
            ..StepCounts::default()
        },
        ..record(index, Counters::default())
    }
}

#[test]
fn the_automatic_rule_builds_from_the_window_and_recentres_with_carry_over() {
    let mut q: Queue<u8, 8192> = Queue::new();
    let (mut tx, mut rx) = q.split();
    let auto = Settings {
        estimator: EstimatorSettings::default(),
        ..settings()
    };
    assert_eq!(auto.estimator.lambda_rad_s, None, "automatic by default");
    let (mut l, mut d, mut h) = (link_with(auto), device(), Host::new());
    assert!(
        l.poll(&mut d).unwrap().is_none(),
        "nothing before the window"
    );
    let n = feed_startup(&mut l);
    assert_eq!(n, 512, "500 samples, handed over in blocks of 32");
    let first = l.poll(&mut d).unwrap().unwrap();
    // U0, Y0: the window's RMS; λ0: twice y's centroid (300 rad/s).
    let (_, lambda0, u0, y0, carried) = d.built[0];
    assert!((u0 - 0.1).abs() < 1e-6, "{u0}");
    assert!((y0 / 1.414e-3 - 1.0).abs() < 0.1, "{y0}");
    assert!((lambda0 / 600.0 - 1.0).abs() < 0.05, "{lambda0}");
    assert_eq!(carried, 0);
    assert_eq!(first.filter.lambda_rad_s, lambda0);
    assert_eq!(d.p.calls, [format!("replace 1 {lambda0}"), "resume".into()]);
    assert_eq!(l.lambda_rad_s(), Some(lambda0));
    assert!(!l.collecting_startup());
    let at = first.at;
    d.p.calls.clear();
    // Records of a stable estimate: after settling (`QUARANTINE_TIME_CONSTANTS`/λ0) and ten reviews
    // λ moves to √(40·250) = 100, Θ̂ carried over.
    let mut k = at / 100 + 1;
    let recentred = loop {
        l.on_record(&record_of(k * 100 + 99, lambda0), &[-2.0, 2.0], &mut tx);
        h.drain(&mut rx);
        k += 1;
        if let Some(t) = l.poll(&mut d).unwrap() {
            break t;
        }
        assert!(k < at / 100 + 40, "no re-centring");
    };
    let after = (k * 100).saturating_sub(at);
    let settle = (40.0 / lambda0 / 1e-4) as u64;
    assert!(after >= settle + 1000 && after <= settle + 1300, "{after}");
    assert_eq!(recentred.kind, BuildKind::Recentre);
    assert!((recentred.filter.lambda_rad_s - 100.0).abs() < 1e-4);
    assert_eq!(d.built[1].4, 7, "the estimate is carried over");
    assert_eq!((d.built[1].2, d.built[1].3), (u0, y0), "same scales");
    assert_eq!(
        d.p.calls,
        [format!("replace 2 {}", recentred.filter.lambda_rad_s)]
    );
    assert!(l.has_estimate(), "the carried Θ̂ is an estimate");
    // Records still at λ0 are not the new estimator's; at λ = 100 the rule
    // converges without another build.
    for j in 0..100 {
        l.on_record(
            &record_of((k + j) * 100 + 99, lambda0),
            &[-2.0, 2.0],
            &mut tx,
        );
        l.on_record(
            &record_of((k + j) * 100 + 99, recentred.filter.lambda_rad_s),
            &[-2.0, 2.0],
            &mut tx,
        );
        h.drain(&mut rx);
        assert!(l.poll(&mut d).unwrap().is_none());
    }
    assert_eq!(
        l.tuner().phase(),
        crate::tuning::Phase::Settled(crate::tuning::Settled::Converged)
    );
    assert_eq!(
        l.status(0, &Counters::default()).estimator.lambda_rad_s,
        Some(recentred.filter.lambda_rad_s as f32)
    );
}

#[test]
fn a_fixed_lambda_stops_the_rule_and_none_rearms_it() {
    let mut q: Queue<u8, 8192> = Queue::new();
    let (mut tx, mut rx) = q.split();
    let auto = Settings {
        estimator: EstimatorSettings::default(),
        ..settings()
    };
    let (mut l, mut d, mut h) = (link_with(auto), device(), Host::new());
    let at = start(&mut l, &mut d);
    let fixed = EstimatorSettings {
        lambda_rad_s: Some(60.0),
        ..EstimatorSettings::default()
    };
    l.receive(h.command(Command::SetEstimator(fixed)), &mut d, &mut tx);
    assert_eq!(l.lambda_rad_s(), Some(60.0));
    assert!(!l.is_automatic());
    // A stable estimate for 3 s: no review, no build.
    for k in at / 100 + 1..at / 100 + 300 {
        l.on_record(&record_of(k * 100 + 99, 60.0), &[-2.0, 2.0], &mut tx);
        h.drain(&mut rx);
        assert!(l.poll(&mut d).unwrap().is_none());
    }
    assert_eq!(d.built.len(), 2);
    // λ = None again: new gains at λ = 60, then re-centred on the band.
    d.p.next = 40_000;
    l.receive(
        h.command(Command::SetEstimator(EstimatorSettings::default())),
        &mut d,
        &mut tx,
    );
    assert_eq!(acks(&h.drain(&mut rx)), [(1, AckResult::Accepted)]);
    assert_eq!((d.built[2].1, d.built[2].4), (60.0, 0));
    assert!(l.is_automatic() && !l.has_estimate());
    let mut got = None;
    for k in 400..500u64 {
        l.on_record(&record_of(k * 100 + 99, 60.0), &[-2.0, 2.0], &mut tx);
        h.drain(&mut rx);
        if let Some(t) = l.poll(&mut d).unwrap() {
            got = Some((k, t));
            break;
        }
    }
    let (k, t) = got.expect("re-centred");
    // 40/60 s of settling and ten reviews after sample 40,000.
    assert!((k * 100 + 99 - 40_000) >= 6_667 + 1_000, "{k}");
    assert!((t.filter.lambda_rad_s - 100.0).abs() < 1e-4, "{t:?}");
}

/// The sensor output kind of the settings reaches every build: the first
/// one from the start-up window, a commanded one and the rule's
/// re-centring (whose θ(0) is scaled for that kind, `Scaling::new`).
#[test]
fn the_output_kind_reaches_every_build() {
    use beam_protocol::OutputKind;
    let mut q: Queue<u8, 8192> = Queue::new();
    let (mut tx, mut rx) = q.split();
    let accel = Settings {
        estimator: EstimatorSettings {
            output: OutputKind::Acceleration,
            ..EstimatorSettings::default()
        },
        ..settings()
    };
    let (mut l, mut d, mut h) = (link_with(accel), device(), Host::new());
    assert_eq!(l.tuner().rule().config().output, OutputKind::Acceleration);
    start(&mut l, &mut d);
    assert_eq!(d.built[0].0.output, OutputKind::Acceleration);
    assert_eq!(l.filter().unwrap().output, OutputKind::Acceleration);
    // A velocity sensor, λ still automatic.
    d.p.next = 40_000;
    let velocity = EstimatorSettings {
        output: OutputKind::Velocity,
        ..EstimatorSettings::default()
    };
    l.receive(h.command(Command::SetEstimator(velocity)), &mut d, &mut tx);
    assert_eq!(acks(&h.drain(&mut rx)), [(0, AckResult::Accepted)]);
    assert_eq!(l.filter().unwrap().output, OutputKind::Velocity);
    assert_eq!(l.tuner().rule().config().output, OutputKind::Velocity);
    assert_eq!(
        l.status(0, &Counters::default()).estimator.output,
        OutputKind::Velocity
    );
    let lambda = l.filter().unwrap().lambda_rad_s;
    let mut got = None;
    for k in 400..600u64 {
        l.on_record(&record_of(k * 100 + 99, lambda), &[-2.0, 2.0], &mut tx);
        h.drain(&mut rx);
        if let Some(t) = l.poll(&mut d).unwrap() {
            got = Some(t);
            break;
        }
    }
    let t = got.expect("re-centred");
    assert_eq!(t.filter.output, OutputKind::Velocity);
    let built = d.built.last().unwrap();
    assert_eq!((built.0.output, built.4), (OutputKind::Velocity, 7));
}

#[test]
fn dropped_startup_blocks_are_gaps_not_joins() {
    let mut c = StartupCollector::<f32>::new();
    let mut blocks = Vec::new();
    for k in 0..(RAW_BLOCK_LEN * 4) {
        c.push(0.1, k as f32, |b| {
            if blocks.len() == 1 && b.first_index == RAW_BLOCK_LEN as u64 {
                return false;
            }
            blocks.push(b);
            true
        });
    }
    assert_eq!(c.dropped(), 1);
    let firsts: Vec<u64> = blocks.iter().map(|b| b.first_index).collect();
    let n = RAW_BLOCK_LEN as u64;
    assert_eq!(firsts, [0, 2 * n, 3 * n]);
    let mut t = Tuner::new(&TuningConfig::new(1e-4, crate::tuning::LambdaSource::Data)).unwrap();
    for b in &blocks {
        assert!(!t.startup_block(b));
    }
    assert_eq!(t.lost_pairs(), n);
    let s = t.rule().stats();
    assert_eq!((s.samples(), s.rejected()), (3 * n as u32, 1));
}

#[test]
fn a_long_freeze_does_not_time_the_rule_out() {
    let mut q: Queue<u8, 8192> = Queue::new();
    let (mut tx, mut rx) = q.split();
    let auto = Settings {
        estimator: EstimatorSettings::default(),
        ..settings()
    };
    let (mut l, mut d, mut h) = (link_with(auto), device(), Host::new());
    let at = start(&mut l, &mut d);
    let lambda0 = l.lambda_rad_s().unwrap();
    l.receive(h.command(Command::Freeze), &mut d, &mut tx);
    // 35 s frozen (longer than the rule's 30 s timeout): not counted.
    let mut k = at / 100 + 1;
    for _ in 0..3_500 {
        l.on_record(&record_of(k * 100 + 99, lambda0), &[-2.0, 2.0], &mut tx);
        h.drain(&mut rx);
        assert!(l.poll(&mut d).unwrap().is_none());
        k += 1;
    }
    l.receive(h.command(Command::Resume), &mut d, &mut tx);
    h.drain(&mut rx);
    let mut recentred = None;
    for _ in 0..100 {
        l.on_record(&record_of(k * 100 + 99, lambda0), &[-2.0, 2.0], &mut tx);
        h.drain(&mut rx);
        k += 1;
        if let Some(t) = l.poll(&mut d).unwrap() {
            recentred = Some(t);
            break;
        }
    }
    let t = recentred.expect("re-centred after the freeze");
    assert!((t.filter.lambda_rad_s - 100.0).abs() < 1e-4);
}
