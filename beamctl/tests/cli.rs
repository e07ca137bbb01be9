//! End-to-end tests of the `beamctl` binary: output formats, files, and
//! one-line errors for bad input. Simulations are kept at ≤ 1.5 s simulated
//! (the truth-free tuning rule starts the law after a 0.2 s start-up
//! window and the filters' settling time, `beamest::estimator::QUARANTINE_TIME_CONSTANTS`/λ).

mod common;

use common::*;

const REPORT_KEYS: [&str; 10] = [
    "estimator",
    "precision",
    "duration_s",
    "samples",
    "estimate",
    "truth",
    "rel_error",
    "time_to_1pct_s",
    "time_to_0p1pct_s",
    "excitation_min_eig",
];

fn check_report_shape(r: &Value, modes: usize) {
    for k in REPORT_KEYS {
        assert!(r.get(k).is_some(), "missing key {k} in {r}");
    }
    for part in ["estimate", "truth"] {
        for k in ["omega", "zeta", "bbar", "a", "b"] {
            assert!(r[part][k].is_array(), "{part}.{k}");
        }
        assert_eq!(r[part]["omega"].as_array().map(Vec::len), Some(modes));
        assert_eq!(r[part]["a"].as_array().map(Vec::len), Some(2 * modes));
        assert_eq!(r[part]["b"].as_array().map(Vec::len), Some(2 * modes - 1));
    }
    for k in ["omega", "zeta"] {
        assert_eq!(r["rel_error"][k].as_array().map(Vec::len), Some(modes));
    }
}

#[test]
fn simulate_json_is_one_report_with_small_errors() {
    let o = beamctl(&["simulate", "--json", "--duration", "1"]);
    let r = json(&o);
    check_report_shape(&r, 2);
    assert_eq!(r["estimator"], "adaptive");
    assert_eq!(r["precision"], "f64");
    assert_eq!(r["samples"], 10_000);
    assert!((num(&r["duration_s"]) - 1.0).abs() < 1e-9);
    assert!((num(&r["truth"]["omega"][0]) - 39.1533).abs() < 1e-9);
    for k in ["omega", "zeta"] {
        for e in r["rel_error"][k].as_array().unwrap() {
            assert!(num(e) < 1e-3, "rel_error.{k} = {e}");
        }
    }
    assert!(num(&r["time_to_1pct_s"]) < 1.0);
    assert!(num(&r["excitation_min_eig"]) > 0.0);
    // The JSON goes to stdout alone; stderr is quiet (no progress bar).
    assert_eq!(stderr(&o), "");
}

#[test]
fn simulate_all_json_is_an_array_of_four() {
    let o = beamctl(&[
        "simulate",
        "--estimator",
        "all",
        "--json",
        "--duration",
        "1.5",
    ]);
    let v = json(&o);
    let runs = v.as_array().expect("array");
    assert_eq!(runs.len(), 4);
    let names: Vec<&str> = runs
        .iter()
        .filter_map(|r| r["estimator"].as_str())
        .collect();
    assert_eq!(names, ["adaptive", "gradient", "ls", "robust"]);
    for r in runs {
        check_report_shape(r, 2);
        assert_eq!(r["samples"], 15_000);
    }
    // Baselines keep no P; only the robust estimator has its extra outputs.
    assert!(runs[1]["excitation_min_eig"].is_null());
    assert!(runs[0]["robust"].is_null());
    assert!(runs[3]["robust"]["phase"].is_string());
}

#[test]
fn simulate_table_lists_every_parameter() {
    let o = beamctl(&["simulate", "--duration", "1.5", "--modes", "3"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let s = stdout(&o);
    for label in [
        "ω1",
        "ω2",
        "ω3",
        "ζ1",
        "ζ3",
        "b̄1",
        "b̄3",
        "time to 1%",
        "time to 0.1%",
        "model output fit",
        "moved over last 10%",
        "λ (rad/s)",
        "λmin(P)",
        "samples",
        "rejected",
        "skipped",
    ] {
        assert!(s.contains(label), "missing {label} in\n{s}");
    }
}

#[test]
fn simulate_all_table_has_a_group_per_estimator() {
    let o = beamctl(&["simulate", "--estimator", "all", "--duration", "1.5"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let s = stdout(&o);
    let title = s
        .lines()
        .find(|l| l.contains("adaptive"))
        .expect("title line");
    assert!(
        title.contains("gradient") && title.contains("ls"),
        "{title}"
    );
}

#[test]
fn custom_plant_from_lists() {
    let o = beamctl(&[
        "simulate",
        "--json",
        "--duration",
        "1",
        "--omega",
        "50,300",
        "--zeta",
        "0.05,0.1",
        "--bbar",
        "10,20",
        "--weights",
        "-1,1",
        "--lambda",
        "120",
    ]);
    let r = json(&o);
    assert_eq!(r["truth"]["omega"], serde_json::json!([50.0, 300.0]));
    assert_eq!(r["truth"]["bbar"], serde_json::json!([10.0, 20.0]));
    assert_eq!(r["lambda_rad_s"], 120.0);
    // --modes taken from the list length; a missing list from the defaults.
    let r = json(&beamctl(&[
        "simulate",
        "--json",
        "--duration",
        "1.5",
        "--omega",
        "40",
    ]));
    assert_eq!(r["truth"]["omega"], serde_json::json!([40.0]));
    assert!((num(&r["truth"]["zeta"][0]) - 0.0207).abs() < 1e-12);
}

#[test]
fn noise_and_precision_flags() {
    let args = [
        "simulate",
        "--json",
        "--duration",
        "1.5",
        "--snr-db",
        "40",
        "--seed",
        "7",
        "--precision",
        "f32",
    ];
    let a = json(&beamctl(&args));
    assert_eq!(a["precision"], "f32");
    assert_eq!(a["snr_db"], 40.0);
    let b = json(&beamctl(&args));
    assert_eq!(a["estimate"], b["estimate"], "same seed, same run");
}

#[test]
fn csv_has_every_sample_and_estimates_at_1khz() {
    let path = scratch("run.csv");
    let p = path.to_str().unwrap();
    let o = beamctl(&["simulate", "--duration", "1", "--csv", p, "--json"]);
    let _ = json(&o); // stdout still pure JSON
    let text = std::fs::read_to_string(&path).expect("csv written");
    let mut lines = text.lines();
    assert_eq!(
        lines.next(),
        Some("t_s,u,y,guard,theta_0,theta_1,theta_2,theta_3,theta_4,theta_5,theta_6,omega_1,omega_2,zeta_1,zeta_2,lambda_rad_s,excited,excitation_reason,changes,validity")
    );
    let rows: Vec<&str> = lines.collect();
    assert_eq!(rows.len(), 10_000, "one row per sample");
    let last: Vec<&str> = rows.last().unwrap().split(',').collect();
    assert_eq!(last.len(), 20);
    let t: f64 = last[0].parse().unwrap();
    assert!((t - 0.9999).abs() < 1e-12, "last t = {t}");
    assert_eq!(last[3], "", "no guard flag");
    let w1: f64 = last[11].parse().unwrap(); // omega_1
    assert!((w1 / 39.1533 - 1.0).abs() < 1e-3);
    assert_eq!(
        &last[16..],
        ["1", "excited", "0", "0"],
        "supervisor, validity"
    );
    // Estimates on every 10th row only; none in the start-up window (nor
    // in the sensor guard's 2.6 ms delay line after it).
    let omega = |r: &&str| r.split(',').nth(11).is_some_and(|v| !v.is_empty());
    let filled = rows.iter().filter(|r| omega(r)).count();
    assert!(
        (360..=1000).contains(&filled),
        "{filled} rows with estimates"
    );
    assert!(!rows[..1999].iter().any(omega));
    // Evaluation rows carry the validity (not_recovered = 1 before the
    // first estimate), the other rows nothing.
    assert!(rows[9].ends_with(",1") && rows[8].ends_with(",,,,"));
}

#[test]
fn csv_with_all_has_prefixed_columns() {
    let path = scratch("all.csv");
    let o = beamctl(&[
        "simulate",
        "--estimator",
        "all",
        "--duration",
        "1",
        "--modes",
        "1",
        "--csv",
        path.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = std::fs::read_to_string(&path).unwrap();
    let header = text.lines().next().unwrap();
    assert_eq!(
        header,
        "t_s,u,y,guard,\
adaptive_theta_0,adaptive_theta_1,adaptive_theta_2,adaptive_omega_1,adaptive_zeta_1,adaptive_lambda_rad_s,\
adaptive_excited,adaptive_excitation_reason,adaptive_changes,adaptive_validity,\
gradient_theta_0,gradient_theta_1,gradient_theta_2,gradient_omega_1,gradient_zeta_1,gradient_lambda_rad_s,\
gradient_excited,gradient_excitation_reason,gradient_changes,gradient_validity,\
ls_theta_0,ls_theta_1,ls_theta_2,ls_omega_1,ls_zeta_1,ls_lambda_rad_s,\
ls_excited,ls_excitation_reason,ls_changes,ls_validity,\
robust_theta_0,robust_theta_1,robust_theta_2,robust_omega_1,robust_zeta_1,robust_lambda_rad_s,\
robust_excited,robust_excitation_reason,robust_changes,robust_validity"
    );
    assert_eq!(text.lines().count() - 1, 10_000);
}

/// What `simulate --csv` wrote replays to the same estimates, bit for bit,
/// in both precisions and for all three laws.
#[test]
fn a_simulate_csv_replays_to_the_same_estimates() {
    for precision in ["f64", "f32"] {
        let path = scratch(&format!("same-{precision}.csv"));
        let p = path.to_str().unwrap();
        let common = ["--precision", precision, "--estimator", "all", "--json"];
        let mut sim = vec!["simulate", "--duration", "2", "--snr-db", "60", "--csv", p];
        sim.extend(common);
        let s = json(&beamctl(&sim));
        let mut rep = vec!["replay", p];
        rep.extend(common);
        let r = json(&beamctl(&rep));
        for (s, r) in s.as_array().unwrap().iter().zip(r.as_array().unwrap()) {
            assert_eq!(s["estimator"], r["estimator"]);
            for k in [
                "estimate",
                "builds",
                "fit_percent",
                "drift_last_10pct",
                "rejected_samples",
                "law_updates",
                "lambda_rad_s",
            ] {
                assert_eq!(s[k], r[k], "{precision} {}: {k}", s["estimator"]);
            }
            assert_eq!(r["ts_s"], 1e-4);
            assert_eq!(r["samples"], 20_000);
        }
    }
}

#[test]
fn a_run_without_an_estimate_warns_and_fails() {
    // 0.3 s: the law would start only after the start-up window (0.2 s)
    // and the filters' settling time.
    let o = beamctl(&["simulate", "--duration", "0.3", "--json"]);
    assert_eq!(o.status.code(), Some(1));
    let r: Value = serde_json::from_str(&stdout(&o)).expect("JSON still printed");
    assert!(r["estimate"]["omega"][0].is_null());
    assert_eq!(r["law_updates"], 0);
    let err = stderr(&o);
    assert!(
        err.starts_with("error: no estimate from the adaptive law"),
        "{err}"
    );
    assert_eq!(err.lines().count(), 1);
}

#[test]
fn plot_writes_a_png() {
    let path = scratch("run.png");
    let o = beamctl(&[
        "simulate",
        "--estimator",
        "all",
        "--duration",
        "1.5",
        "--plot",
        path.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let bytes = std::fs::read(&path).expect("png written");
    assert!(bytes.starts_with(b"\x89PNG\r\n\x1a\n"), "not a PNG");
    assert!(bytes.len() > 1000);
}

#[test]
fn model_json_has_the_beam_frequencies() {
    let v = json(&beamctl(&["model", "--json"]));
    let w = &v["omega_rad_s"];
    assert!((num(&w[0]) / 39.1603 - 1.0).abs() < 1e-4, "{w}");
    assert!((num(&w[1]) / 245.4132 - 1.0).abs() < 1e-4, "{w}");
    assert_eq!(v["modes"], 2);
    for k in [
        "beta_l",
        "zeta",
        "mass_kg",
        "stiffness_n_m",
        "damping_n_s_m",
        "input_z",
        "bbar",
        "output_weight",
    ] {
        assert_eq!(v[k].as_array().map(Vec::len), Some(2), "{k}");
    }
    assert_eq!(v["tf"]["a"].as_array().map(Vec::len), Some(4));
    assert_eq!(v["tf"]["b"].as_array().map(Vec::len), Some(3));
}

#[test]
fn model_reads_the_sample_beam_file() {
    let sample = concat!(env!("CARGO_MANIFEST_DIR"), "/examples/paper-beam.toml");
    let a = json(&beamctl(&[
        "model", "--json", "--modes", "3", "--beam", sample,
    ]));
    let b = json(&beamctl(&["model", "--json", "--modes", "3"]));
    assert_eq!(a["omega_rad_s"], b["omega_rad_s"]);
    assert_eq!(a["bbar"], b["bbar"]);
    let text = beamctl(&["model", "--modes", "1"]);
    assert!(text.status.success());
    assert!(stdout(&text).contains("β_iL"));
}

/// Every bad input exits non-zero with one line naming the flag, no panic.
#[test]
fn bad_inputs_fail_cleanly() {
    let bad_toml = scratch("bad.toml");
    std::fs::write(&bad_toml, "length_m = 0.36\nlenght_m = 1\n").unwrap();
    let neg_toml = scratch("neg.toml");
    std::fs::write(&neg_toml, "density_kg_m3 = -1\n").unwrap();
    let (bad, neg) = (bad_toml.to_str().unwrap(), neg_toml.to_str().unwrap());
    let cases: &[(&[&str], &str)] = &[
        (&["simulate", "--duration", "-1"], "--duration"),
        (&["simulate", "--duration", "0"], "--duration"),
        (&["simulate", "--duration", "abc"], "--duration"),
        (&["simulate", "--duration", "inf"], "--duration"),
        (&["simulate", "--zeta", "-0.1,0.1"], "--zeta"),
        (&["simulate", "--zeta", "0,0.1"], "--zeta"),
        (&["simulate", "--omega", "-40,245"], "--omega"),
        (&["simulate", "--omega", "0,245"], "--omega"),
        (&["simulate", "--omega", "NaN,245"], "--omega"),
        (&["simulate", "--omega", "245,40"], "--omega"),
        (&["simulate", "--bbar", "inf,1"], "--bbar"),
        (&["simulate", "--weights", "1,x"], "--weights"),
        (&["simulate", "--modes", "3", "--zeta", "0.1,0.2"], "--zeta"),
        (
            &["simulate", "--omega", "40,245", "--bbar", "1,2,3"],
            "--bbar",
        ),
        (&["simulate", "--omega", "1,2,3,4"], "--omega"),
        (&["simulate", "--modes", "4"], "--modes"),
        (&["simulate", "--modes", "0"], "--modes"),
        (&["simulate", "--estimator", "kalman"], "--estimator"),
        (&["simulate", "--precision", "f16"], "--precision"),
        (&["simulate", "--lambda", "-100"], "--lambda"),
        (&["simulate", "--band-hz", "10"], "--band-hz"),
        (&["simulate", "--band-hz", "50,5"], "--band-hz"),
        (
            &["simulate", "--band-hz", "5,50", "--lambda", "100"],
            "--band-hz",
        ),
        (&["simulate", "--beam", "/nonexistent-dir/b.toml"], "--beam"),
        (
            &["simulate", "--modes", "1", "--paper-exp-gains"],
            "--paper-exp-gains",
        ),
        (&["simulate", "--snr-db", "nan"], "--snr-db"),
        (&["simulate", "--seed", "-1"], "--seed"),
        (&["simulate", "--csv", "/nonexistent-dir/x.csv"], "--csv"),
        (&["simulate", "--plot", "/nonexistent-dir/x.png"], "--plot"),
        (&["simulate", "--plot", "x.svg"], "--plot"),
        (
            &["simulate", "--modes", "3", "--paper-gains"],
            "--paper-gains",
        ),
        (
            &["simulate", "--modes", "1", "--paper-gains"],
            "--paper-gains",
        ),
        (&["model", "--modes", "5"], "--modes"),
        (&["model", "--beam", "/nonexistent-dir/b.toml"], "--beam"),
        (&["model", "--beam", bad], "--beam"),
        (&["model", "--beam", neg], "--beam"),
    ];
    for (args, flag) in cases {
        let o = beamctl(args);
        let err = stderr(&o);
        assert!(!o.status.success(), "{args:?} succeeded");
        assert_eq!(o.status.code(), Some(2), "{args:?}: {err}");
        assert!(!err.contains("panicked"), "{args:?} panicked: {err}");
        assert!(err.starts_with("error: "), "{args:?}: {err}");
        assert!(
            err.contains(flag),
            "{args:?}: message does not name {flag}: {err}"
        );
        assert_eq!(
            err.trim_end().lines().count(),
            1,
            "{args:?}: not one line: {err}"
        );
        assert!(o.stdout.is_empty(), "{args:?} wrote to stdout");
    }
    // The exact wording for a typical case.
    let o = beamctl(&["simulate", "--zeta", "-0.1,0.1"]);
    assert_eq!(
        stderr(&o),
        "error: --zeta: damping ratios must be > 0 (got -0.1)\n"
    );
}

#[test]
fn seed_without_snr_is_fine() {
    let o = beamctl(&["simulate", "--seed", "5", "--duration", "1", "--json"]);
    let _ = json(&o);
}

#[test]
fn help_documents_every_flag() {
    let o = beamctl(&["simulate", "--help"]);
    assert!(o.status.success());
    let h = stdout(&o);
    for flag in [
        "--estimator",
        "--precision",
        "--duration",
        "--modes",
        "--omega",
        "--zeta",
        "--bbar",
        "--weights",
        "--lambda",
        "--snr-db",
        "--seed",
        "--paper-gains",
        "--paper-exp-gains",
        "--band-hz",
        "--beam",
        "--csv",
        "--plot",
        "--json",
        "--step-at",
        "--step-omega",
        "--step-zeta",
        "--excitation-off",
        "--fault",
        "--fault-at",
        "--fault-for",
        "--fault-level",
        "--truth-modes",
        "--range",
        "--level-correction",
        "--ts",
        "--wave",
        "--freq",
        "--band",
        "--tones",
        "--bit-rate",
        "--bits",
        "--sweep",
        "--amplitude",
        "--offset",
    ] {
        assert!(h.contains(flag), "{flag} missing from help");
    }
    for unit in ["SECONDS", "rad/s", "[default: 20]", "[default: auto]", "dB"] {
        assert!(h.contains(unit), "{unit} missing from help");
    }
    let o = beamctl(&["replay", "--help"]);
    assert!(o.status.success());
    let h = stdout(&o);
    for flag in [
        "--estimator",
        "--precision",
        "--lambda",
        "--band-hz",
        "--beam",
        "--paper-gains",
        "--paper-exp-gains",
        "--columns",
        "--ts",
        "--modes",
        "--weights",
        "--csv",
        "--plot",
        "--json",
        "docs/REPLAY.md",
    ] {
        assert!(h.contains(flag), "{flag} missing from replay help");
    }
    let o = beamctl(&["model", "--help"]);
    let h = stdout(&o);
    for flag in ["--modes", "--json", "--beam", "density_kg_m3"] {
        assert!(h.contains(flag), "{flag} missing from model help");
    }
}
