//! Issue 9, sensor faults: each kind on the measured y of the paper's
//! plant (noise-free) from 5 s for 0.5 s (a drift for 10 s), screened by
//! the `SensorGuard` at its defaults (high-pass on, the converter's range
//! ±10·Y0) in front of the 2-mode adaptive law, f64 and f32.
//!
//! * nan, saturate, stuck, open, offset: flagged within 10 ms; estimates
//!   within 1% from the fault's end on and within 0.1% from ≤ 1 s after
//!   it.
//! * drift (0.02·Y0/s for 10 s): flagged once its level has moved by 5% of
//!   y's RMS (the rate sets the latency: 5.0 s here, **not** 10 ms — a
//!   slow drift cannot be told from the signal in 10 ms; reported in
//!   docs/ROBUSTNESS.md); the high-pass keeps the estimates within 0.1%
//!   during and after it (measured 5.7e-4 during, 3.6e-5 after).
//! * At 40 dB: no offset step seen in clean data (40 and 20 dB, 5 seeds);
//!   the offset fault's edges and the drift's end flagged within 10 ms and
//!   harmless (the estimate stays at the fault-free run's, see the test).
//!
//! Figures: `cargo run --release -p host-tests --example robustness_table faults`
//! (and `faults40`).

use beamest::estimator::{Adaptive2, AdaptiveConfig};
use beamest::guard::{GuardCounts, LevelEvent, SampleFault, Screening};
use beamest::rig::{FaultKind, Scenario};
use beamest::Real;
use host_tests::scenario_run::*;

struct Outcome {
    trace: RunTrace,
    first_flag: Option<(u64, Screening)>,
    counts: GuardCounts,
    t_off: f64,
}

fn y0() -> f64 {
    startup_filter(&paper_rig(Scenario::default(), None, 1, None))
        .scales
        .y_scale
}

fn run_fault<T: Real>(kind: FaultKind) -> Outcome {
    let y0 = y0();
    let (_, until) = fault_window(kind);
    let mut rig = paper_rig(fault_scenario(kind), None, 1, None);
    let f = startup_filter(&paper_rig(Scenario::default(), None, 1, None));
    let mut est = Adaptive2::<T>::new(&f, &AdaptiveConfig::default()).expect("valid settings");
    let mut feed = fault_guard(y0);
    let trace = run_guarded(&mut est, &mut rig, until + 30_000, 10, &mut feed);
    Outcome {
        trace,
        first_flag: feed.first_flag,
        counts: feed.guard().counts(),
        t_off: until as f64 * TS_S,
    }
}

fn kind_of(name: &str) -> FaultKind {
    faults(y0())
        .into_iter()
        .find(|(n, _)| *n == name)
        .map(|(_, k)| k)
        .expect("a fault kind")
}

/// Flagged within 10 ms as `want`; the counter `count` grew; within 1%
/// after the fault and 0.1% from 1 s after it.
fn check<T: Real>(name: &str, want: fn(&Screening) -> bool, count: fn(&GuardCounts) -> u32) {
    let ty = T::NAME;
    let o = run_fault::<T>(kind_of(name));
    let (k, seen) = o.first_flag.expect("flagged");
    let latency_s = (k - FAULT_AT) as f64 * TS_S;
    assert!(
        latency_s <= 0.010,
        "{name} {ty}: flagged after {latency_s} s"
    );
    assert!(want(&seen), "{name} {ty}: flagged as {seen:?}");
    assert!(count(&o.counts) > 0, "{name} {ty}: {:?}", o.counts);
    let tr = &o.trace;
    assert!(
        tr.est.iter().flatten().all(|v| v.is_finite()),
        "{name} {ty}: NaN"
    );
    let before = tr.max_err(3.0, FAULT_AT as f64 * TS_S);
    let during = tr.max_err(FAULT_AT as f64 * TS_S, o.t_off);
    let after = tr.max_err(o.t_off, o.t_off + 1.0);
    let later = tr.max_err(o.t_off + 1.0, 1e9);
    assert!(before <= 1e-4, "{name} {ty}: {before:e} before");
    assert!(during <= 1e-2, "{name} {ty}: {during:e} during");
    assert!(after <= 1e-2, "{name} {ty}: {after:e} in the second after");
    assert!(later <= 1e-3, "{name} {ty}: {later:e} from 1 s after");
}

fn fault(s: &Screening, f: SampleFault) -> bool {
    s.fault == Some(f)
}

#[test]
fn nan_is_flagged_at_once_and_leaves_no_trace() {
    check::<f64>(
        "nan",
        |s| fault(s, SampleFault::NonFinite),
        |c| c.non_finite,
    );
    check::<f32>(
        "nan",
        |s| fault(s, SampleFault::NonFinite),
        |c| c.non_finite,
    );
}

#[test]
fn saturation_is_flagged_at_once_and_leaves_no_trace() {
    // The first samples at one rail look like an open gauge (both are
    // faults, flagged at once); from the first switch of rails on they
    // count as saturated.
    let rail = |s: &Screening| fault(s, SampleFault::Saturated) || fault(s, SampleFault::Open);
    check::<f64>("saturate", rail, |c| c.saturated);
    check::<f32>("saturate", rail, |c| c.saturated);
}

#[test]
fn a_stuck_sensor_is_flagged_within_three_ms_and_leaves_no_trace() {
    check::<f64>("stuck", |s| fault(s, SampleFault::Stuck), |c| c.stuck);
    check::<f32>("stuck", |s| fault(s, SampleFault::Stuck), |c| c.stuck);
}

#[test]
fn an_open_bridge_is_flagged_at_once_and_leaves_no_trace() {
    check::<f64>("open", |s| fault(s, SampleFault::Open), |c| c.open);
    check::<f32>("open", |s| fault(s, SampleFault::Open), |c| c.open);
}

#[test]
fn an_offset_step_is_removed_at_once() {
    let off = |s: &Screening| s.fault.is_none() && s.level == Some(LevelEvent::Offset);
    check::<f64>("offset", off, |c| c.offset);
    check::<f32>("offset", off, |c| c.offset);
}

/// What is reached for a drift (see the module docs): flagged as a drift
/// within 6 s (not 10 ms), within 0.1% during and after.
#[test]
fn a_drift_is_flagged_and_high_passed() {
    for o in [
        run_fault::<f64>(kind_of("drift")),
        run_fault::<f32>(kind_of("drift")),
    ] {
        let (k, seen) = o.first_flag.expect("flagged");
        let latency_s = (k - FAULT_AT) as f64 * TS_S;
        assert!(latency_s <= 6.0, "flagged after {latency_s} s");
        assert_eq!(seen.level, Some(LevelEvent::Drift));
        assert!(o.counts.drift > 0);
        let tr = &o.trace;
        let during = tr.max_err(FAULT_AT as f64 * TS_S, o.t_off);
        let after = tr.max_err(o.t_off, 1e9);
        assert!(during <= 1e-3, "{during:e} during");
        assert!(after <= 1e-3, "{after:e} after");
    }
}

/// 60 s of the paper's plant at 40 dB and 20 dB SNR, 5 noise seeds each,
/// through the guard at its defaults: not one offset step is seen (the
/// matched step test's threshold is 8× its running RMS,
/// `beamest::guard::STEP_FACTOR`), and no sample is rejected.
#[test]
fn clean_noisy_data_never_looks_like_an_offset_step() {
    let y0 = y0();
    for snr in [40.0, 20.0] {
        for seed in 1..=5u64 {
            let mut rig = paper_rig(Scenario::default(), Some(snr), seed, None);
            let mut feed = fault_guard(y0);
            for k in 0..600_000u64 {
                feed.screen(k, rig.tick());
            }
            let c = feed.guard().counts();
            assert_eq!(c.offset, 0, "{snr} dB, seed {seed}: {c:?}");
            assert_eq!(c.rejected(), 0, "{snr} dB, seed {seed}: {c:?}");
            assert_eq!(feed.guard().offset(), 0.0);
        }
    }
}

/// The offset fault (+0.5·Y0 over [5 s, 5.5 s)) and the end of a drift
/// (a step of −0.2·Y0 at 15 s) at 40 dB, 3 noise seeds, in front of the
/// 2-mode adaptive law (f64): every step is flagged as an offset within
/// 10 ms, removed to within a few noise σ, and the estimate (held over
/// the high-pass's transient) is never lost and stays within 2.5% of the
/// same run's without the fault (a 0.5 s gap of NaN gives up to 1.3%; the
/// law's own error at 40 dB is 2–7%: `robustness_table faults40`).
#[test]
fn offset_steps_at_40_db_are_removed_within_the_noise() {
    let y0 = y0();
    for seed in 1..=3u64 {
        let f = startup_filter(&paper_rig(Scenario::default(), Some(40.0), seed, None));
        let est = || Adaptive2::<f64>::new(&f, &AdaptiveConfig::default()).expect("valid");
        let mut rig = paper_rig(Scenario::default(), Some(40.0), seed, None);
        let reference = run_guarded(&mut est(), &mut rig, 250_000, 100, &mut fault_guard(y0));
        for (name, steps, size) in [
            ("offset", &[FAULT_AT, FAULT_UNTIL][..], 0.0),
            ("drift", &[FAULT_AT + 100_000][..], -0.2 * y0),
        ] {
            let kind = kind_of(name);
            let (_, until) = fault_window(kind);
            let mut rig = paper_rig(fault_scenario(kind), Some(40.0), seed, None);
            let mut feed = fault_guard(y0);
            let mut flags = Vec::new();
            let tr = run_guarded_with(
                &mut est(),
                &mut rig,
                until + 100_000,
                100,
                &mut feed,
                &mut |_, k, _, screened| {
                    if screened.screening.level == Some(LevelEvent::Offset) {
                        flags.push(k);
                    }
                },
            );
            let at = format!("{name}, seed {seed}");
            assert_eq!(flags.len(), steps.len(), "{at}: flags at {flags:?}");
            for (k, s) in flags.iter().zip(steps) {
                assert!(*k >= *s && (*k - *s) as f64 * TS_S <= 0.010, "{at}: {k}");
            }
            let left = (feed.guard().offset() - size).abs() / y0;
            assert!(left < 0.1, "{at}: {left} Y0 of the steps left");
            assert!(tr.est.iter().flatten().all(|v| v.is_finite()), "{at}");
            let t_on = FAULT_AT as f64 * TS_S;
            let dev = tr.max_dev_from(&reference, t_on, 1e9);
            assert!(dev < 2.5e-2, "{at}: {dev:e} from the fault-free run");
        }
    }
}
