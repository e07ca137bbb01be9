//! End-to-end tests of `beamctl simulate`'s scenario flags (issue 9): a
//! plant step, an excitation pause, each sensor fault, modes beyond the
//! model, and the report's robustness fields (supervisor, guard, physical
//! validity) in the table, the JSON and the CSV. Noise-free runs of a few
//! simulated seconds (the law converges within ~0.7 s).

mod common;

use common::*;

/// The paper's plant with ω1 +10% and ζ1 +50% (Table III: 39.1533 rad/s,
/// 0.0207).
const STEP_OMEGA: &str = "43.06863,245.3711";
const STEP_ZETA: &str = "0.03105,0.13";

fn sim(extra: &[&str]) -> Value {
    let mut args = vec!["simulate", "--json"];
    args.extend_from_slice(extra);
    json(&beamctl(&args))
}

fn max_error(r: &Value) -> f64 {
    ["omega", "zeta"]
        .iter()
        .flat_map(|k| r["rel_error"][k].as_array().unwrap().clone())
        .map(|v| v.as_f64().unwrap_or(f64::INFINITY))
        .fold(0.0, f64::max)
}

#[test]
fn the_json_has_the_robustness_fields() {
    let r = sim(&["--duration", "2"]);
    let s = &r["supervision"];
    assert_eq!(s["excited"], true, "{s}");
    assert_eq!(s["excitation_reason"], "excited");
    assert_eq!(s["frozen"], false);
    assert_eq!(s["changes_detected"], 0);
    assert_eq!(r["validity"], Value::Array(vec![]), "a valid estimate");
    let g = &r["guard"];
    for k in [
        "rejected",
        "non_finite",
        "saturated",
        "stuck",
        "open",
        "offset_steps",
        "drift_flags",
    ] {
        assert_eq!(g[k], 0, "guard.{k} in {g}");
    }
    // No events: no scenario object, and the bound is still there with noise.
    assert!(r["scenario"].is_null());
    let n = sim(&["--duration", "2", "--snr-db", "40"]);
    assert!(n["crlb"].is_object());
}

#[test]
fn a_plant_step_scores_against_the_new_plant() {
    for precision in ["f64", "f32"] {
        let r = sim(&[
            "--duration",
            "6",
            "--precision",
            precision,
            "--step-at",
            "3",
            "--step-omega",
            STEP_OMEGA,
            "--step-zeta",
            STEP_ZETA,
        ]);
        // The truth is the new plant's.
        assert!((num(&r["truth"]["omega"][0]) - 43.06863).abs() < 1e-9);
        assert!((num(&r["truth"]["zeta"][0]) - 0.03105).abs() < 1e-12);
        let sc = &r["scenario"];
        assert_eq!(sc["step_at_s"], 3.0);
        let t1 = num(&sc["tracking_1pct_s"]);
        let t01 = num(&sc["tracking_0p1pct_s"]);
        assert!(
            t1 > 0.0 && t1 <= 2.0,
            "{precision}: back within 1% after {t1} s"
        );
        assert!(t01 >= t1 && t01 < 3.0, "{precision}: 0.1% after {t01} s");
        assert!(
            num(&r["supervision"]["changes_detected"]) >= 1.0,
            "{precision}"
        );
        // Detected within 10 ms of the step (record time).
        let at = num(&r["supervision"]["last_change_s"]);
        assert!((3.0..3.01).contains(&at), "{precision}: change at {at} s");
        assert!(max_error(&r) < 1e-3, "{precision}: {}", r["rel_error"]);
        assert!(r["crlb"].is_null());
    }
}

/// With the level corrections' high-pass on, the estimator is held after
/// the detected change while the high-pass's memory of the old plant
/// settles (`SensorGuard::change_hold`); without that hold it took 3.3 s
/// to 1% and did not reach 0.1% within 6 s.
#[test]
fn a_plant_step_is_tracked_with_the_high_pass_on() {
    for precision in ["f64", "f32"] {
        let r = sim(&[
            "--duration",
            "9",
            "--precision",
            precision,
            "--level-correction",
            "--step-at",
            "3",
            "--step-omega",
            STEP_OMEGA,
            "--step-zeta",
            STEP_ZETA,
        ]);
        let sc = &r["scenario"];
        let t1 = num(&sc["tracking_1pct_s"]);
        let t01 = num(&sc["tracking_0p1pct_s"]);
        assert!(
            t1 > 0.0 && t1 <= 2.0,
            "{precision}: back within 1% after {t1} s"
        );
        assert!(t01 >= t1 && t01 <= 2.0, "{precision}: 0.1% after {t01} s");
        assert!(max_error(&r) < 1e-4, "{precision}: {}", r["rel_error"]);
    }
}

#[test]
fn a_step_of_zeta_alone_keeps_omega() {
    let r = sim(&[
        "--duration",
        "4",
        "--step-at",
        "2",
        "--step-zeta",
        STEP_ZETA,
    ]);
    assert!((num(&r["truth"]["omega"][0]) - 39.1533).abs() < 1e-9);
    assert!((num(&r["truth"]["zeta"][0]) - 0.03105).abs() < 1e-12);
    assert!(r["scenario"]["tracking_1pct_s"].is_number());
}

/// The drive stops: the law learns from the ring-down while it carries
/// information (the paper's mode 1 loses 20 dB in 2.8 s), then freezes.
#[test]
fn an_excitation_pause_is_flagged_and_frozen() {
    // Half a second into the pause: the free response is still learnt from.
    let r = sim(&["--duration", "2.5", "--excitation-off", "2,2.5"]);
    let s = &r["supervision"];
    assert_eq!(s["excitation_reason"], "free_response", "{s}");
    assert_eq!(s["frozen"], false);
    // Ends 4 s into the pause: the supervisor says why it froze.
    let r = sim(&["--duration", "6", "--excitation-off", "2,6"]);
    let s = &r["supervision"];
    assert_eq!(s["excited"], false, "{s}");
    assert_eq!(s["excitation_reason"], "input_gone");
    assert_eq!(s["frozen"], true);
    assert!(max_error(&r) < 1e-3, "estimate held: {}", r["rel_error"]);
    assert_eq!(
        r["scenario"]["excitation_off_s"],
        serde_json::json!([2.0, 6.0])
    );
    // And comes back when the drive does.
    let r = sim(&["--duration", "5", "--excitation-off", "2,3"]);
    assert_eq!(r["supervision"]["frozen"], false);
    assert!(max_error(&r) < 1e-3);
}

/// (flags, the guard's counter that must count the fault, what it is
/// flagged as, detection limit in s). The simulated overload jumps to ±
/// the full scale at once (`beamest::rig::FaultKind::Saturate`), which the
/// guard tells from an overload growing into the rail by that jump: with
/// rails 2× beyond the signal's peak (±0.0103) it is counted as `open`.
/// A drift is flagged once y's slow level has moved by 5% of its RMS
/// (`beamest::guard::DRIFT_FRACTION`): 1 mV/s against an RMS of 4.4 mV
/// takes ~0.2 s plus the level filters' lag.
const FAULTS: [(&[&str], &str, &str, f64); 6] = [
    (&["--fault", "nan"], "non_finite", "non_finite", 0.01),
    (&["--fault", "stuck"], "stuck", "stuck", 0.01),
    (
        &["--fault", "saturate", "--range", "-0.02,0.02"],
        "open",
        "open",
        0.01,
    ),
    (
        &["--fault", "open", "--range", "-0.02,0.02"],
        "open",
        "open",
        0.01,
    ),
    (
        &["--fault", "offset", "--level-correction"],
        "offset_steps",
        "offset",
        0.01,
    ),
    (
        &["--fault", "drift", "--fault-level", "0.001"],
        "drift_flags",
        "drift",
        1.0,
    ),
];

#[test]
fn every_fault_is_flagged_counted_and_kept_out() {
    for (flags, counter, as_what, limit) in FAULTS {
        let name = flags[1];
        // A drift lasts to the end; the others 0.5 s.
        let mut args = vec!["--duration", "4", "--fault-at", "2"];
        if name != "drift" {
            args.extend_from_slice(&["--fault-for", "0.5"]);
        }
        args.extend_from_slice(flags);
        let o = beamctl(&[&["simulate", "--json"], args.as_slice()].concat());
        let r: Value = serde_json::from_str(&stdout(&o)).expect("JSON");
        let sc = &r["scenario"];
        assert_eq!(sc["fault"], name);
        let end = if name == "drift" { 4.0 } else { 2.5 };
        assert_eq!(
            sc["fault_window_s"],
            serde_json::json!([2.0, end]),
            "{name}"
        );
        assert_eq!(sc["fault_detected_as"], as_what, "{name}: {sc}");
        let latency = num(&sc["fault_detection_latency_s"]);
        assert!(latency <= limit, "{name}: flagged after {latency} s");
        assert!(num(&r["guard"][counter]) >= 1.0, "{name}: {}", r["guard"]);
        let rejected = num(&r["guard"]["rejected"]);
        if ["nan", "stuck", "saturate", "open"].contains(&name) {
            // Every faulty sample is kept from the estimator, which is
            // back within 1% by the end.
            assert!(rejected >= 5000.0, "{name}: {rejected} rejected");
            assert!(num(&r["rejected_samples"]) >= 5000.0, "{name}");
        } else {
            assert_eq!(rejected, 0.0, "{name}: level faults are not rejections");
        }
        if name != "drift" {
            assert!(o.status.success(), "{name}: {}", stderr(&o));
            assert!(max_error(&r) < 1e-2, "{name}: {}", r["rel_error"]);
            assert_eq!(r["validity"], Value::Array(vec![]), "{name}");
        }
    }
}

#[test]
fn an_uncorrected_offset_is_reported_as_biasing() {
    // Without --level-correction the step is not removed and the estimate
    // is biased (here to an unphysical model, or none at all: exit 1): the
    // report shows it.
    let o = beamctl(&[
        "simulate",
        "--json",
        "--duration",
        "4",
        "--fault",
        "offset",
        "--fault-at",
        "2",
    ]);
    let r: Value = serde_json::from_str(&stdout(&o)).expect("JSON");
    assert_eq!(r["guard"]["offset_steps"], 0);
    let validity = r["validity"].as_array().unwrap();
    assert!(
        !validity.is_empty() || max_error(&r) > 1e-2,
        "{}",
        r["rel_error"]
    );
    // Exit 1 only when there is no estimate at all.
    let recovered = validity.iter().all(|v| v != "not_recovered");
    assert_eq!(o.status.success(), recovered, "{validity:?}");
}

#[test]
fn extra_modes_are_the_beams() {
    let r = sim(&["--duration", "4", "--truth-modes", "4"]);
    assert_eq!(r["scenario"]["truth_modes"], 4);
    // The estimator stays a 2-mode model scored against the first two.
    assert_eq!(r["estimate"]["omega"].as_array().unwrap().len(), 2);
    assert!((num(&r["truth"]["omega"][1]) - 245.3711).abs() < 1e-9);
    assert!(num(&r["estimate"]["omega"][0]).is_finite());
    // With the modes of the model only, nothing changes.
    let same = sim(&["--duration", "2", "--truth-modes", "2"]);
    let plain = sim(&["--duration", "2"]);
    assert_eq!(same["estimate"], plain["estimate"]);
}

/// `--estimator feedthrough` (two modes plus a residual term) meets the
/// issue's target on the 3- and 4-mode beam where the plain law does not
/// (docs/ROBUSTNESS.md §5), in both precisions, with the truth-free λ;
/// `replay` of the same record gives the same estimate.
#[test]
fn the_feedthrough_estimator_meets_the_target_on_the_extra_modes() {
    let within = |r: &Value| {
        let e = |k: &str, i: usize| num(&r["rel_error"][k][i]);
        e("omega", 0) <= 1e-2
            && e("omega", 1) <= 1e-2
            && e("zeta", 0) <= 5e-2
            && e("zeta", 1) <= 5e-2
    };
    for (modes, precision) in [("3", "f64"), ("4", "f32")] {
        let args = [
            "--duration",
            "8",
            "--truth-modes",
            modes,
            "--precision",
            precision,
        ];
        let mut ft = vec!["--estimator", "feedthrough"];
        ft.extend_from_slice(&args);
        let r = sim(&ft);
        assert_eq!(r["estimator"], "feedthrough", "{r}");
        assert!(within(&r), "{modes} modes {precision}: {}", r["rel_error"]);
        // D: the extra modes' static gain, Σ c_i·b̄_i/ω_i² ≈ −2.9e-4 (3
        // modes) / −2.4e-4 (4), within a factor 2.
        let d = num(&r["feedthrough"]);
        assert!((-6e-4..-1e-4).contains(&d), "D = {d}");
        let plain = sim(&args);
        assert!(
            !within(&plain),
            "{modes} modes {precision}: {}",
            plain["rel_error"]
        );
        assert!(
            plain.get("feedthrough").is_none(),
            "only with a residual term"
        );
    }
    let path = scratch("feedthrough.csv");
    let p = path.to_str().unwrap();
    let r = sim(&[
        "--estimator",
        "feedthrough",
        "--duration",
        "4",
        "--truth-modes",
        "3",
        "--csv",
        p,
    ]);
    let o = beamctl(&["replay", p, "--estimator", "feedthrough", "--json"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let back = json(&o);
    for k in ["omega", "zeta"] {
        for i in 0..2 {
            let (a, b) = (num(&r["estimate"][k][i]), num(&back["estimate"][k][i]));
            assert!((a - b).abs() <= 1e-9 * b.abs(), "{k}{i}: {a} vs {b}");
        }
    }
}

#[test]
fn the_table_shows_the_events_and_flags() {
    let o = beamctl(&[
        "simulate",
        "--duration",
        "4",
        "--step-at",
        "2",
        "--step-omega",
        STEP_OMEGA,
        "--fault",
        "nan",
        "--fault-at",
        "3",
        "--fault-for",
        "0.1",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = stdout(&o);
    for needle in [
        "events: plant step at 2 s",
        "sensor fault nan 3–3.1 s, flagged as non_finite after 0 ms",
        "tracking: 1% after step",
        "tracking: 0.1% after step",
        "excitation (supervisor)",
        "changes detected",
        "physically valid",
        "guard: rejected",
        "1000 (non-finite 1000)",
        "guard: level events",
    ] {
        assert!(text.contains(needle), "missing {needle:?} in\n{text}");
    }
}

#[test]
fn the_csv_carries_the_flags() {
    let path = scratch("fault.csv");
    let p = path.to_str().unwrap();
    let o = beamctl(&[
        "simulate",
        "--duration",
        "2",
        "--fault",
        "nan",
        "--fault-at",
        "1.5",
        "--fault-for",
        "0.01",
        "--csv",
        p,
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = std::fs::read_to_string(&path).unwrap();
    let rows: Vec<Vec<&str>> = text
        .lines()
        .skip(1)
        .map(|l| l.split(',').collect())
        .collect();
    let flagged: Vec<usize> = rows
        .iter()
        .enumerate()
        .filter(|(_, r)| r[3] == "non_finite")
        .map(|(k, _)| k)
        .collect();
    assert_eq!(flagged.len(), 100, "one flag per faulty sample");
    assert_eq!(flagged[0], 15_000);
    // The supervisor's and validity columns on an evaluation row.
    let last = rows.last().unwrap();
    assert_eq!(&last[16..], ["1", "excited", "0", "0"]);
    // Replay counts the same rejections by kind (its guard runs on the
    // recorded floats).
    let r = json(&beamctl(&["replay", p, "--json"]));
    assert_eq!(r["guard"]["non_finite"], 100, "{}", r["guard"]);
    assert!(r["supervision"]["excitation_reason"].is_string());
    assert_eq!(r["validity"], Value::Array(vec![]));
}

/// `--residual-monitor`: a drift of 0.1 mV/s (≈ 0.02 of y's RMS per
/// second) is flagged at its onset, within 10 ms (the level test alone:
/// not within the 2 s that follow); a plant step raises no flag.
#[test]
fn the_residual_monitor_flags_a_drift_at_its_onset_and_not_a_plant_step() {
    let drift = [
        "--duration",
        "7",
        "--fault",
        "drift",
        "--fault-at",
        "5",
        "--fault-level",
        "0.0001",
    ];
    let r = sim(&[&drift[..], &["--residual-monitor"]].concat());
    let sc = &r["scenario"];
    assert_eq!(sc["fault_detected_as"], "drift", "{sc}");
    let latency = num(&sc["fault_detection_latency_s"]);
    assert!(latency <= 0.010, "flagged after {latency} s");
    assert_eq!(num(&r["guard"]["drift_flags"]), 1.0, "{}", r["guard"]);
    let plain = sim(&drift);
    assert_eq!(
        num(&plain["guard"]["drift_flags"]),
        0.0,
        "{}",
        plain["guard"]
    );
    for step in [["--step-omega", STEP_OMEGA], ["--step-zeta", STEP_ZETA]] {
        let r = sim(&[
            &["--duration", "8", "--step-at", "5", "--residual-monitor"][..],
            &step[..],
        ]
        .concat());
        assert_eq!(
            num(&r["guard"]["drift_flags"]),
            0.0,
            "{step:?}: {}",
            r["guard"]
        );
        assert_eq!(
            num(&r["guard"]["offset_steps"]),
            0.0,
            "{step:?}: {}",
            r["guard"]
        );
        assert!(max_error(&r) < 1e-4, "{step:?}: {}", r["rel_error"]);
    }
}
