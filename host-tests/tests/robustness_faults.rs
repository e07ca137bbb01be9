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
//!   during and after it (measured 5.7e-4 during, 1.7e-4 after).
//!
//! Figures: `cargo run --release -p host-tests --example robustness_table faults`.

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
        counts: feed.guard.counts(),
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
