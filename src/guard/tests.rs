#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::panic,
    clippy::indexing_slicing
)]

use super::*;
use crate::rig::GaussianNoise;

const TS: f64 = 1e-4;

/// A beam-like signal: two tones near the paper's modes, amplitude ~1.
fn signal(k: u64) -> f64 {
    let t = k as f64 * TS;
    (44.0 * t).sin() + 0.3 * (245.0 * t + 1.0).sin()
}

fn guard(range: Option<[f64; 2]>, highpass: Option<f64>) -> SensorGuard<f64> {
    SensorGuard::new(&GuardConfig {
        range,
        highpass_rad_s: highpass,
        ..GuardConfig::new(TS)
    })
    .unwrap()
}

/// Run `n` samples of `y(k)` through `g`; the outputs by index.
fn feed(g: &mut SensorGuard<f64>, from: u64, n: u64, y: impl Fn(u64) -> f64) -> Vec<Guarded<f64>> {
    (from..from + n)
        .filter_map(|k| g.push(signal(k), y(k)))
        .collect()
}

#[test]
fn clean_signal_passes_unchanged_without_the_high_pass() {
    let mut g = guard(Some([-3.0, 3.0]), None);
    let mut n = GaussianNoise::<f64>::new(1e-2, 3).unwrap();
    let noise: Vec<f64> = (0..300_000).map(|_| n.sample()).collect();
    let out = feed(&mut g, 0, 300_000, |k| signal(k) + noise[k as usize]);
    let d = g.delay_samples() as u64;
    assert_eq!(d, u64::from(DEFAULT_STUCK_AFTER) + 1);
    assert_eq!(out.len() as u64, 300_000 - d);
    for o in &out {
        assert_eq!(o.fault, None);
        assert_eq!(o.y, signal(o.index) + noise[o.index as usize]);
        assert_eq!(o.u, signal(o.index));
    }
    assert_eq!(g.counts(), GuardCounts::default());
}

#[test]
fn non_finite_and_upstream_samples_are_rejected_at_once() {
    let mut g = guard(None, Some(DEFAULT_HIGHPASS_RAD_S));
    feed(&mut g, 0, 1000, signal);
    assert!(g.push(f64::NAN, 0.0).is_some());
    assert_eq!(g.last_screening().fault, Some(SampleFault::NonFinite));
    g.push(0.0, f64::INFINITY);
    g.push_checked(0.1, 0.2, false);
    assert_eq!(g.last_screening().fault, Some(SampleFault::Upstream));
    let out = feed(&mut g, 1003, 100, signal);
    let bad: Vec<_> = out
        .iter()
        .filter(|o| o.fault.is_some())
        .map(|o| o.index)
        .collect();
    assert_eq!(bad, [1000, 1001, 1002]);
    let o = out.iter().find(|o| o.index == 1000).unwrap();
    assert!(o.for_estimator().0.is_nan() && o.for_estimator().1.is_nan());
    let c = g.counts();
    assert_eq!((c.non_finite, c.upstream, c.rejected()), (2, 1, 3));
}

#[test]
fn stuck_runs_are_caught_from_their_first_sample() {
    let mut g = guard(None, None);
    // The reading freezes at sample 5000 for 100 samples.
    let y = |k: u64| {
        if (5000..5100).contains(&k) {
            signal(4999)
        } else {
            signal(k)
        }
    };
    let out = feed(&mut g, 0, 10_000, y);
    let bad: Vec<_> = out
        .iter()
        .filter(|o| o.fault.is_some())
        .map(|o| o.index)
        .collect();
    // The value first seen at 4999 repeats 100 times: a run of 101.
    assert_eq!(bad, (4999..5100).collect::<Vec<_>>());
    assert!(out
        .iter()
        .filter(|o| o.fault.is_some())
        .all(|o| o.fault == Some(SampleFault::Stuck)));
    assert_eq!(g.counts().stuck, 101);
    // A freezing reading bends the signal like a step's onset: it is
    // not taken for an offset.
    assert_eq!((g.counts().offset, g.offset()), (0, 0.0));
    // A shorter repeat is not a fault.
    let mut g = guard(None, None);
    let out = feed(&mut g, 0, 2000, |k| {
        if (500..520).contains(&k) {
            signal(499)
        } else {
            signal(k)
        }
    });
    assert!(out.iter().all(|o| o.fault.is_none()));
}

#[test]
fn saturation_and_open_bridge_at_the_rails() {
    let fs = 0.8;
    let mut g = guard(Some([-fs, fs]), None);
    // Clipped signal: saturated where |y| ≥ 0.8 (approached continuously).
    let out = feed(&mut g, 0, 5000, |k| signal(k).clamp(-fs, fs));
    let sat = out
        .iter()
        .filter(|o| o.fault == Some(SampleFault::Saturated))
        .count();
    let expect = (0..5000 - g.delay_samples() as u64)
        .filter(|&k| signal(k).abs() >= fs)
        .count();
    assert_eq!(sat, expect);
    assert!(sat > 100);
    assert!(out.iter().all(|o| o.fault != Some(SampleFault::Open)));
    // An open gauge: from mid-range to the positive rail at once, staying.
    let before = g.counts();
    g.push(0.0, 0.1);
    g.push(0.0, 0.05);
    g.push(0.0, fs);
    assert_eq!(g.last_screening().fault, Some(SampleFault::Open));
    for _ in 0..500 {
        g.push(0.0, fs);
        assert_eq!(g.last_screening().fault, Some(SampleFault::Open));
    }
    assert_eq!(g.counts().open - before.open, 501);
    // Reconnected: good again.
    g.push(0.0, 0.1);
    assert_eq!(g.last_screening().fault, None);
    // An overload that reads the rail of y's sign: the first samples at
    // one rail look like an open gauge; from the switch on, saturated.
    let before = g.counts();
    g.push(0.0, fs);
    assert_eq!(g.last_screening().fault, Some(SampleFault::Open));
    g.push(0.0, -fs);
    assert_eq!(g.last_screening().fault, Some(SampleFault::Saturated));
    g.push(0.0, fs);
    assert_eq!(g.last_screening().fault, Some(SampleFault::Saturated));
    let c = g.counts();
    assert_eq!(
        (c.open - before.open, c.saturated - before.saturated),
        (1, 2)
    );
    g.push(0.0, 0.1);
    g.push(0.0, fs);
    assert_eq!(g.last_screening().fault, Some(SampleFault::Open));
}

#[test]
fn a_gap_asks_for_a_hold_only_with_the_high_pass() {
    for (hp, want) in [
        (
            Some(DEFAULT_HIGHPASS_RAD_S),
            (GAP_SETTLE_TIME_CONSTANTS / (DEFAULT_HIGHPASS_RAD_S * TS)).ceil() as u32,
        ),
        (None, 0),
    ] {
        let mut g = guard(None, hp);
        let mut holds = Vec::new();
        for k in 0..3000u64 {
            let y = if (1000..1010).contains(&k) {
                f64::NAN
            } else {
                signal(k)
            };
            g.push(signal(k), y);
            let h = g.take_hold();
            if h > 0 {
                holds.push((k, h));
            }
        }
        // Once, when the first good sample after the gap leaves the line.
        let d = g.delay_samples() as u64;
        if want > 0 {
            assert_eq!(holds, [(1010 + d, want)], "{hp:?}");
        } else {
            assert!(holds.is_empty());
        }
    }
}

#[test]
fn offset_steps_are_removed_and_noise_never_looks_like_one() {
    let mut n = GaussianNoise::<f64>::new(1e-2, 9).unwrap();
    let noise: Vec<f64> = (0..600_000).map(|_| n.sample()).collect();
    for (step, noisy) in [(0.05, false), (0.5, true)] {
        let mut g = guard(None, None);
        let y = |k: u64| {
            signal(k)
                + if noisy { noise[k as usize] } else { 0.0 }
                + if k >= 300_000 { step } else { 0.0 }
        };
        let out = feed(&mut g, 0, 600_000, y);
        assert_eq!(g.counts().offset, 1, "step {step}");
        assert!(
            (g.offset() - step).abs() < 0.1 * step,
            "{} vs {step}",
            g.offset()
        );
        // After the step the output is the signal again, to the estimate's
        // accuracy (0.82σ of the noise).
        let worst = out
            .iter()
            .filter(|o| o.index > 300_000)
            .map(|o| (o.y - (y(o.index) - step)).abs())
            .fold(0.0, f64::max);
        assert!(worst < 0.1 * step, "{worst}");
    }
    // 60 s of noisy signal without a step: nothing removed.
    let mut g = guard(None, None);
    feed(&mut g, 0, 600_000, |k| signal(k) + noise[k as usize]);
    assert_eq!(g.counts().offset, 0);
}

/// Offset removal switched on at run time on a guard without a stuck test
/// (no delay line, as the pipeline builds it): the line is lengthened to
/// the step test's latency without losing a sample, every output from
/// the step's own sample on is corrected, the step is found once (not on
/// its side lobe) and a hold is asked for only with the high-pass.
#[test]
fn a_step_is_corrected_from_its_first_sample_when_switched_on_later() {
    for highpass in [None, Some(DEFAULT_HIGHPASS_RAD_S)] {
        let mut g = SensorGuard::<f64>::new(&GuardConfig {
            stuck_after: 0,
            highpass_rad_s: highpass,
            offset_steps: false,
            ..GuardConfig::new(TS)
        })
        .unwrap();
        assert_eq!(g.delay_samples(), 0);
        let mut out = feed(&mut g, 0, 1000, signal);
        g.set_level_correction(highpass, true, TS).unwrap();
        assert_eq!(g.delay_samples(), STEP_LATENCY + 1);
        let step = 0.5;
        let y = |k: u64| signal(k) + if k >= 5000 { step } else { 0.0 };
        let mut holds = Vec::new();
        for k in 1000..10_000 {
            if let Some(o) = g.push(signal(k), y(k)) {
                out.push(o);
            }
            let h = g.take_hold();
            if h > 0 {
                holds.push((k, h));
            }
            if g.last_screening().level == Some(LevelEvent::Offset) {
                assert!(k - 5000 <= STEP_LATENCY as u64, "found at {k}");
            }
        }
        // No sample lost or repeated.
        let idx: Vec<u64> = out.iter().map(|o| o.index).collect();
        assert_eq!(idx, (0..idx.len() as u64).collect::<Vec<_>>());
        assert_eq!(g.counts().offset, 1);
        assert!((g.offset() - step).abs() < 1e-3, "{}", g.offset());
        if highpass.is_none() {
            assert!(holds.is_empty());
            let worst = out
                .iter()
                .filter(|o| o.index >= 5000)
                .map(|o| (o.y - signal(o.index)).abs())
                .fold(0.0, f64::max);
            assert!(worst < 1e-3, "{worst}");
        } else {
            assert_eq!(holds.len(), 1, "{holds:?}");
        }
    }
}

#[test]
fn drift_is_flagged_and_high_passed_away() {
    let mut g = guard(None, Some(DEFAULT_HIGHPASS_RAD_S));
    // 0.2/s from 10 s on (20% of the signal's amplitude per second).
    let y = |k: u64| {
        signal(k)
            + if k >= 100_000 {
                0.2 * (k - 100_000) as f64 * TS
            } else {
                0.0
            }
    };
    let out = feed(&mut g, 0, 200_000, y);
    assert_eq!(g.counts().offset, 0);
    assert!(g.counts().drift >= 1);
    // Before the drift no flag; the filtered output of u and y agree again
    // (same filter, same signal) once the ramp's transient has passed.
    let worst = out
        .iter()
        .filter(|o| o.index > 180_000)
        .map(|o| (o.y - o.u).abs())
        .fold(0.0, f64::max);
    assert!(worst < 1e-3, "{worst}");
}

#[test]
fn bad_settings_are_refused() {
    let c = GuardConfig::new(TS);
    let bad = [
        GuardConfig { ts_s: 0.0, ..c },
        GuardConfig {
            range: Some([1.0, -1.0]),
            ..c
        },
        GuardConfig {
            range: Some([f64::NAN, 1.0]),
            ..c
        },
        GuardConfig {
            stuck_after: MAX_DELAY as u16,
            ..c
        },
        GuardConfig {
            highpass_rad_s: Some(0.0),
            ..c
        },
    ];
    let want = [
        GuardError::SamplePeriod,
        GuardError::Range,
        GuardError::Range,
        GuardError::StuckAfter,
        GuardError::Highpass,
    ];
    for (b, w) in bad.iter().zip(want) {
        assert_eq!(SensorGuard::<f32>::new(b).err(), Some(w));
    }
}

#[test]
fn a_resting_beam_without_drive_is_not_stuck() {
    let mut g = guard(None, None);
    // No drive: the reading sits at one code for 1,000 samples.
    g.set_input_quiet(true);
    for k in 0..1_000u64 {
        if let Some(o) = g.push(0.0, 0.25) {
            assert_eq!(o.fault, None, "{k}");
        }
    }
    assert_eq!(g.counts().stuck, 0);
    // The drive returns and the reading still does not move: the repeats
    // count afresh, the 25th driven sample completes a stuck run, which is
    // rejected back through the delay line (26 samples: the 25 driven ones
    // and the last quiet one), then each of the 15 more.
    g.set_input_quiet(false);
    for k in 0..40 {
        g.push(0.1, 0.25);
        if k == 23 {
            assert_eq!(g.counts().stuck, 0);
        }
    }
    assert_eq!(g.counts().stuck, 41);
}
