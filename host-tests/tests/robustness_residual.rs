//! Issue 9, sensor faults seen on the model's equation error: the guard
//! with its residual monitor (`beamest::guard::ResidualMonitor`, fed the
//! 2-mode adaptive law's Θ̂ every 10 ms through
//! `beamest::guard::model_for_monitor`) in front of the law, on the paper's
//! plant.
//!
//! * A drift's onset is flagged within 10 ms (noise-free, f64 and f32,
//!   0.02 and 0.002·Y0/s; measured 5.0 ms), where the raw level test takes
//!   5 s.
//! * At 40 dB, offset steps of 0.1·Y0 (below the raw test's ≈ 0.16·Y0) are
//!   found within 10 ms and removed (seeds 1–5: 9 of 10 edges; the
//!   estimate stays within 10% of the fault-free run's instead of going
//!   44% off; the missed edge of seed 5 leaves its step in y, which moves
//!   the estimate, and a drift is flagged a second later).
//! * Never a false flag: 60 s of clean data at 40 and 20 dB (5 seeds), and
//!   across a 10% step of ω1 and a 50% step of ζ1 (noise-free and 40 dB,
//!   f64 and f32) — a plant change bends ε too, but not like a step or a
//!   ramp.
//! * The gap faults (nan, saturate, stuck, open) behave as without the
//!   monitor.
//!
//! Figures: `cargo run --release -p host-tests --example residual_detect guard`
//! (and `guardclean`).

use beamest::estimator::{Adaptive2, AdaptiveConfig};
use beamest::guard::{GuardCounts, LevelEvent};
use beamest::rig::{FaultKind, Scenario, SensorFault, Window};
use beamest::Real;
use host_tests::scenario_run::*;

fn y0() -> f64 {
    startup_filter(&paper_rig(Scenario::default(), None, 1, None))
        .scales
        .y_scale
}

struct Run {
    trace: RunTrace,
    flags: Vec<(u64, LevelEvent)>,
    counts: GuardCounts,
    first_flag: Option<u64>,
}

fn guarded<T: Real>(
    sc: Scenario,
    snr: Option<f64>,
    seed: u64,
    samples: u64,
    monitored: bool,
) -> Run {
    let f = startup_filter(&paper_rig(Scenario::default(), snr, seed, None));
    let mut rig = paper_rig(sc, snr, seed, None);
    let mut est = Adaptive2::<T>::new(&f, &AdaptiveConfig::default()).expect("valid");
    let mut feed = fault_guard(y0());
    if monitored {
        feed = feed.with_monitor(&f);
    }
    let mut flags = Vec::new();
    let trace = run_guarded_with(
        &mut est,
        &mut rig,
        samples,
        100,
        &mut feed,
        &mut |_, k, _, screened| {
            if let Some(l) = screened.screening.level {
                flags.push((k, l));
            }
        },
    );
    Run {
        trace,
        flags,
        counts: feed.guard().counts(),
        first_flag: feed.first_flag.map(|(k, _)| k),
    }
}

fn scenario(kind: FaultKind, until: u64) -> Scenario {
    Scenario {
        fault: Some(SensorFault {
            kind,
            window: Window::new(FAULT_AT, Some(until)),
        }),
        ..Scenario::default()
    }
}

#[test]
fn a_drift_is_flagged_at_its_onset() {
    let y0 = y0();
    for rate in [0.02, 0.002] {
        let sc = scenario(FaultKind::Drift { per_s: rate * y0 }, FAULT_AT + 100_000);
        for r in [
            guarded::<f64>(sc, None, 1, 70_000, true),
            guarded::<f32>(sc, None, 1, 70_000, true),
        ] {
            let (k, l) = *r.flags.first().expect("flagged");
            assert_eq!(l, LevelEvent::Drift, "{rate}: {:?}", r.flags);
            assert!(k >= FAULT_AT, "{rate}: flagged before the onset, {k}");
            let ms = (k - FAULT_AT) as f64 * TS_S * 1e3;
            assert!(ms <= 10.0, "{rate}: flagged after {ms} ms");
            assert_eq!(r.counts.offset, 0, "{rate}: {:?}", r.counts);
            assert_eq!(r.counts.drift, 1, "{rate}: {:?}", r.counts);
            let during = r.trace.max_err(FAULT_AT as f64 * TS_S, 1e9);
            assert!(during <= 1e-3, "{rate}: {during:e}");
        }
        // Without the monitor: not within the second that follows.
        let r = guarded::<f64>(sc, None, 1, 60_000, false);
        assert!(r.flags.is_empty(), "{:?}", r.flags);
    }
}

#[test]
fn offset_steps_below_the_raw_threshold_are_removed_at_40_db() {
    let y0 = y0();
    let sc = scenario(FaultKind::Offset { step: 0.1 * y0 }, FAULT_UNTIL);
    let mut edges = 0;
    for seed in 1..=5 {
        let r = guarded::<f64>(sc, Some(40.0), seed, 100_000, true);
        let reference = guarded::<f64>(Scenario::default(), Some(40.0), seed, 100_000, true);
        let plain = guarded::<f64>(sc, Some(40.0), seed, 100_000, false);
        // Flags within 10 ms of an edge are offsets. (Seed 5 misses the
        // second edge; the step left in y then moves the estimate, and the
        // ramp test flags a drift 1 s later: measured, reported in
        // docs/ROBUSTNESS.md.)
        for (k, l) in &r.flags {
            let near = [FAULT_AT, FAULT_UNTIL]
                .iter()
                .any(|e| *k >= *e && *k - *e <= 100);
            assert!(
                !near || *l == LevelEvent::Offset,
                "seed {seed}: {:?}",
                r.flags
            );
        }
        for edge in [FAULT_AT, FAULT_UNTIL] {
            if let Some((k, _)) = r.flags.iter().find(|(k, _)| *k >= edge) {
                let ms = (k - edge) as f64 * TS_S * 1e3;
                if ms <= 10.0 {
                    edges += 1;
                }
            }
        }
        let (k, _) = r.flags.first().expect("the first edge flagged");
        assert!(
            *k >= FAULT_AT && (*k - FAULT_AT) as f64 * TS_S <= 0.010,
            "seed {seed}: first flag at {k}"
        );
        // The estimate stays near the fault-free run's; without the
        // monitor the steps throw it off (the raw test misses them).
        let t_on = FAULT_AT as f64 * TS_S;
        let dev = r.trace.max_dev_from(&reference.trace, t_on, 1e9);
        let dev_plain = plain.trace.max_dev_from(&reference.trace, t_on, 1e9);
        assert!(plain.flags.is_empty(), "seed {seed}: {:?}", plain.flags);
        assert!(dev < 0.1, "seed {seed}: {dev:e} from the fault-free run");
        assert!(dev_plain > 0.2, "seed {seed}: {dev_plain:e} without");
    }
    assert!(edges >= 9, "{edges} of 10 edges flagged within 10 ms");
}

#[test]
fn clean_noisy_data_raises_no_flag() {
    for snr in [40.0, 20.0] {
        for seed in 1..=5u64 {
            let r = guarded::<f64>(Scenario::default(), Some(snr), seed, 600_000, true);
            assert!(r.flags.is_empty(), "{snr} dB, seed {seed}: {:?}", r.flags);
            assert_eq!(r.counts, GuardCounts::default(), "{snr} dB, seed {seed}");
        }
    }
}

#[test]
fn a_plant_change_is_not_a_sensor_fault() {
    for sc in [step_scenario(1.1, 1.0), step_scenario(1.0, 1.5)] {
        for snr in [None, Some(40.0)] {
            for r in [
                guarded::<f64>(sc, snr, 1, 120_000, true),
                guarded::<f32>(sc, snr, 1, 120_000, true),
            ] {
                assert!(r.flags.is_empty(), "{snr:?}: {:?}", r.flags);
                if snr.is_none() {
                    // The estimator's own change test saw it (and the
                    // monitor rested from then on).
                    assert!(r.trace.changes() >= 1, "the change was not detected");
                }
            }
        }
    }
}

#[test]
fn gap_faults_behave_as_without_the_monitor() {
    let y0 = y0();
    for (name, kind) in faults(y0).into_iter().take(4) {
        let (_, until) = fault_window(kind);
        let sc = fault_scenario(kind);
        for (with, without) in [
            (
                guarded::<f64>(sc, None, 1, until + 30_000, true),
                guarded::<f64>(sc, None, 1, until + 30_000, false),
            ),
            (
                guarded::<f32>(sc, None, 1, until + 30_000, true),
                guarded::<f32>(sc, None, 1, until + 30_000, false),
            ),
        ] {
            assert_eq!(with.first_flag, without.first_flag, "{name}");
            assert_eq!(with.counts, without.counts, "{name}");
            assert!(with.flags.is_empty(), "{name}: {:?}", with.flags);
            let t_off = until as f64 * TS_S;
            let later = with.trace.max_err(t_off + 1.0, 1e9);
            assert!(later <= 1e-3, "{name}: {later:e} from 1 s after");
        }
    }
}
