//! End-to-end tests of the `beamctl` binary: output formats, files, and
//! one-line errors for bad input. Simulations are kept at ≤ 1.5 s simulated
//! (the truth-free tuning rule starts the law after a 0.2 s start-up
//! window and the filters' settling time, 40/λ ≈ 0.4 s).

use serde_json::Value;
use std::path::PathBuf;
use std::process::{Command, Output};

fn beamctl(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_beamctl"))
        .args(args)
        .output()
        .expect("run beamctl")
}

fn stdout(o: &Output) -> String {
    String::from_utf8_lossy(&o.stdout).into_owned()
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// A fresh path in cargo's per-target scratch directory.
fn scratch(name: &str) -> PathBuf {
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("beamctl-cli");
    std::fs::create_dir_all(&dir).expect("scratch dir");
    let p = dir.join(name);
    let _ = std::fs::remove_file(&p);
    p
}

fn json(o: &Output) -> Value {
    assert!(o.status.success(), "failed: {}", stderr(o));
    serde_json::from_str(&stdout(o)).unwrap_or_else(|e| panic!("not JSON ({e}): {}", stdout(o)))
}

fn num(v: &Value) -> f64 {
    v.as_f64().unwrap_or(f64::NAN)
}

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
fn simulate_all_json_is_an_array_of_three() {
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
    assert_eq!(runs.len(), 3);
    let names: Vec<&str> = runs
        .iter()
        .filter_map(|r| r["estimator"].as_str())
        .collect();
    assert_eq!(names, ["adaptive", "gradient", "ls"]);
    for r in runs {
        check_report_shape(r, 2);
        assert_eq!(r["samples"], 15_000);
    }
    // Baselines keep no P.
    assert!(runs[1]["excitation_min_eig"].is_null());
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
        Some("t_s,u,y,theta_0,theta_1,theta_2,theta_3,theta_4,theta_5,theta_6,omega_1,omega_2,zeta_1,zeta_2,lambda_rad_s")
    );
    let rows: Vec<&str> = lines.collect();
    assert_eq!(rows.len(), 10_000, "one row per sample");
    let last: Vec<&str> = rows.last().unwrap().split(',').collect();
    assert_eq!(last.len(), 15);
    let t: f64 = last[0].parse().unwrap();
    assert!((t - 0.9999).abs() < 1e-12, "last t = {t}");
    let w1: f64 = last[10].parse().unwrap(); // omega_1
    assert!((w1 / 39.1533 - 1.0).abs() < 1e-3);
    // Estimates on every 10th row only; none in the start-up window.
    let filled = rows.iter().filter(|r| !r.ends_with(",,")).count();
    assert!(
        (380..=1000).contains(&filled),
        "{filled} rows with estimates"
    );
    assert!(rows[..1999].iter().all(|r| r.ends_with(",,,,,,,,,,,,")));
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
        "t_s,u,y,adaptive_theta_0,adaptive_theta_1,adaptive_theta_2,adaptive_omega_1,adaptive_zeta_1,adaptive_lambda_rad_s,\
gradient_theta_0,gradient_theta_1,gradient_theta_2,gradient_omega_1,gradient_zeta_1,gradient_lambda_rad_s,\
ls_theta_0,ls_theta_1,ls_theta_2,ls_omega_1,ls_zeta_1,ls_lambda_rad_s"
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
    ] {
        assert!(h.contains(flag), "{flag} missing from help");
    }
    for unit in [
        "SECONDS",
        "rad/s",
        "[default: 20]",
        "[default: adaptive]",
        "dB",
    ] {
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

/// Recorded data simulated outside this project (host-tests/data,
/// written by generate_replay_data.py with numpy/scipy, plants the tests
/// never name): the replay, given nothing but the file, reaches ω, ζ
/// within 1e-5 of the truth the generator recorded — noise-free, as
/// `simulate` does on its own plants. One file starts with the beam already
/// moving.
#[test]
fn external_recordings_replay_to_1e5_with_no_flag_but_the_file() {
    let data = concat!(env!("CARGO_MANIFEST_DIR"), "/../host-tests/data");
    let truth: Value = serde_json::from_str(
        &std::fs::read_to_string(format!("{data}/replay_truth.json")).expect("truth file"),
    )
    .expect("truth JSON");
    let files = truth.as_object().expect("object");
    assert_eq!(files.len(), 3);
    for (name, t) in files {
        let path = format!("{data}/{name}.csv.gz");
        let r = json(&beamctl(&["replay", &path, "--json"]));
        assert_eq!(r["samples"], 30_000, "{name}");
        for (k, key) in [("omega", "omega_rad_s"), ("zeta", "zeta")] {
            for i in 0..2 {
                let est = num(&r["estimate"][k][i]);
                let tru = num(&t[key][i]);
                let e = (est / tru - 1.0).abs();
                assert!(e < 1e-5, "{name} {k}{}: {est} vs {tru} ({e:e})", i + 1);
            }
        }
        for i in 0..2 {
            let e = (num(&r["estimate"]["bbar"][i]) / num(&t["bbar"][i]) - 1.0).abs();
            assert!(e < 1e-4, "{name} b̄{}: {e:e}", i + 1);
        }
        assert!(
            num(&r["fit_percent"]) > 99.99,
            "{name}: {}",
            r["fit_percent"]
        );
        assert!(num(&r["drift_last_10pct"]) < 1e-5, "{name}");
        assert_eq!(r["rejected_samples"], 0);
    }
}

/// A small replayable file: `simulate --csv` of the paper's plant.
fn recorded(name: &str, seconds: &str) -> PathBuf {
    let path = scratch(name);
    let o = beamctl(&[
        "simulate",
        "--duration",
        seconds,
        "--csv",
        path.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    path
}

#[test]
fn replay_table_has_no_truth_but_the_fit_and_drift() {
    let path = recorded("table.csv", "2");
    let o = beamctl(&["replay", path.to_str().unwrap()]);
    assert!(o.status.success(), "{}", stderr(&o));
    let s = stdout(&o);
    for label in [
        "ω1",
        "ζ2",
        "b̄2",
        "model output fit",
        "moved over last 10%",
        "λ (rad/s)",
        "rejected samples",
    ] {
        assert!(s.contains(label), "missing {label} in\n{s}");
    }
    for truth_only in ["truth", "rel. error", "time to 1%"] {
        assert!(!s.contains(truth_only), "{truth_only} in\n{s}");
    }
}

#[test]
fn nan_and_inf_samples_are_skipped_and_counted() {
    let path = recorded("nan.csv", "4");
    let text = std::fs::read_to_string(&path).unwrap();
    let mut lines: Vec<String> = text.lines().map(|l| l.to_string()).collect();
    let mut bad = 0;
    for (row, what) in [
        (5_000, "nan"),
        (20_001, "inf"),
        (30_000, "-inf"),
        (30_001, ""),
    ] {
        let mut f: Vec<String> = lines[row].split(',').map(String::from).collect();
        f[2] = what.to_string(); // y
        lines[row] = f.join(",");
        bad += 1;
    }
    let bad_path = scratch("nan-edited.csv");
    std::fs::write(&bad_path, lines.join("\n") + "\n").unwrap();
    let r = json(&beamctl(&["replay", bad_path.to_str().unwrap(), "--json"]));
    assert_eq!(r["rejected_samples"], bad);
    assert_eq!(r["samples"], 40_000);
    for i in 0..2 {
        let e = (num(&r["estimate"]["omega"][i]) / [39.1533, 245.3711][i] - 1.0).abs();
        assert!(e < 1e-6, "omega{}: {e:e}", i + 1);
    }
}

#[test]
fn replay_chooses_columns_and_takes_a_given_ts() {
    let dir = scratch("cols.csv");
    let src = recorded("cols-src.csv", "2");
    // Only y and u, in another order and under other names, no time.
    let text = std::fs::read_to_string(&src).unwrap();
    let mut out = String::from("strain,drive\n");
    for l in text.lines().skip(1) {
        let f: Vec<&str> = l.split(',').collect();
        out.push_str(&format!("{},{}\n", f[2], f[1]));
    }
    std::fs::write(&dir, out).unwrap();
    let a = json(&beamctl(&[
        "replay",
        dir.to_str().unwrap(),
        "--ts",
        "1e-4",
        "--columns",
        "drive,strain",
        "--json",
    ]));
    let b = json(&beamctl(&["replay", src.to_str().unwrap(), "--json"]));
    assert_eq!(a["estimate"], b["estimate"]);
    assert_eq!(a["ts_s"], 1e-4);
}

#[test]
fn replay_writes_csv_and_plot() {
    let src = recorded("out-src.csv", "2");
    let (csv, png) = (scratch("replay-est.csv"), scratch("replay.png"));
    let o = beamctl(&[
        "replay",
        src.to_str().unwrap(),
        "--estimator",
        "all",
        "--csv",
        csv.to_str().unwrap(),
        "--plot",
        png.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = std::fs::read_to_string(&csv).unwrap();
    assert!(text.starts_with("t_s,u,y,adaptive_theta_0,"));
    assert_eq!(text.lines().count(), 1 + 2000, "one row per ms of record");
    let bytes = std::fs::read(&png).unwrap();
    assert!(bytes.starts_with(b"\x89PNG\r\n\x1a\n"));
}

/// Bad input files: one line naming the file (and the line), exit 2.
#[test]
fn replay_bad_inputs_fail_cleanly() {
    let write = |name: &str, text: &str| {
        let p = scratch(name);
        std::fs::write(&p, text).unwrap();
        p.to_str().unwrap().to_string()
    };
    let cases: Vec<(String, &str)> = vec![
        ("/nonexistent-dir/x.csv".into(), "cannot open"),
        (write("empty.csv", ""), "the file is empty"),
        (write("header.csv", "t,u,y\n"), "no data rows"),
        (
            write("count.csv", "t,u,y\n0,1,2\n1e-4,1\n"),
            "line 3: 2 fields",
        ),
        (
            write("text.csv", "t,u,y\n0,1,2\n1e-4,1,x\n"),
            "line 3: field 3 (y) is not a number",
        ),
        (
            write(
                "uneven.csv",
                "t,u,y\n0,1,2\n1e-4,1,2\n2e-4,1,2\n3.5e-4,1,2\n",
            ),
            "line 5: non-uniform sampling",
        ),
        (
            write("back.csv", "t,u,y\n0,1,2\n1e-4,1,2\n0.5e-4,1,2\n"),
            "line 4: the time column does not increase",
        ),
        (
            write("names.csv", "time,in,out\n0,1,2\n"),
            "line 1: no column named",
        ),
    ];
    for (file, what) in &cases {
        let o = beamctl(&["replay", file]);
        let err = stderr(&o);
        assert_eq!(o.status.code(), Some(2), "{file}: {err}");
        assert!(err.starts_with("error: "), "{err}");
        assert!(err.contains(file.as_str()), "{err}");
        assert!(err.contains(what), "{file}: expected {what:?} in {err}");
        assert_eq!(err.trim_end().lines().count(), 1, "{err}");
        assert!(!err.contains("panicked"));
        assert!(o.stdout.is_empty());
    }
    // Flag errors name the flag.
    let ok = write("ok.csv", "t,u,y\n0,1,2\n1e-4,1,2\n");
    for (args, flag) in [
        (vec!["replay", &ok, "--columns", "a,b"], "--columns"),
        (vec!["replay", &ok, "--ts", "0"], "--ts"),
        (vec!["replay", &ok, "--weights", "1"], "--weights"),
        (
            vec!["replay", &ok, "--modes", "3", "--paper-gains"],
            "--paper-gains",
        ),
        (vec!["replay", &ok, "--plot", "x.svg"], "--plot"),
    ] {
        let o = beamctl(&args);
        assert_eq!(o.status.code(), Some(2), "{args:?}");
        assert!(stderr(&o).contains(flag), "{args:?}: {}", stderr(&o));
    }
    // A valid file without excitation has no estimate: exit 1, one line.
    let flat = write("flat.csv", &{
        let mut s = String::from("t,u,y\n");
        for k in 0..5000 {
            s.push_str(&format!("{},0,0\n", k as f64 * 1e-4));
        }
        s
    });
    let o = beamctl(&["replay", &flat]);
    assert_eq!(o.status.code(), Some(1));
    assert!(
        stderr(&o).contains("start-up window never completed"),
        "{}",
        stderr(&o)
    );
}

mod replay_fuzz {
    use super::*;
    use proptest::prelude::*;

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(24))]

        /// The binary on arbitrary bytes: exit 0, 1 or 2, never a panic.
        #[test]
        fn arbitrary_files_never_panic(bytes in prop::collection::vec(any::<u8>(), 0..400), n in 0u32..1000) {
            let p = scratch(&format!("fuzz-{n}.csv"));
            let mut b = b"t,u,y\n".to_vec();
            b.extend(bytes);
            std::fs::write(&p, &b).unwrap();
            let o = beamctl(&["replay", p.to_str().unwrap()]);
            let code = o.status.code();
            prop_assert!(matches!(code, Some(0..=2)), "{code:?}");
            prop_assert!(!stderr(&o).contains("panicked"));
        }
    }
}
