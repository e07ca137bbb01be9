//! End-to-end tests of `beamctl replay`: recorded data from outside this
//! project, missing samples, column choice, outputs, one-line errors for
//! bad files, and no panic on arbitrary bytes.

mod common;

use common::*;

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
    // The adaptive law, whose values on this record are the reference.
    let r = json(&beamctl(&[
        "replay",
        bad_path.to_str().unwrap(),
        "--estimator",
        "adaptive",
        "--json",
    ]));
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
    assert!(text.starts_with("t_s,u,y,guard,adaptive_theta_0,"));
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
        // Four weights: no model has four modes.
        (vec!["replay", &ok, "--weights", "1,2,3,4"], "--weights"),
        (
            vec!["replay", &ok, "--modes", "2", "--weights", "1"],
            "--weights",
        ),
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

/// With no flags, replay chooses the model from the data (docs/REPLAY.md,
/// "Model selection"): on three committed lab records simulated outside
/// this project (host-tests/data/records, numpy/scipy) it picks one mode,
/// three modes and the level correction, each estimate within the
/// record's reference tolerance (max(3σ_CRB, 1e-4) of the truth). Only
/// this scoring reads reference.json.
#[test]
fn no_flags_chooses_the_model_order_and_the_level_correction() {
    let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/../host-tests/data/records");
    // (record, modes, level correction, lowest fit: the noise's limit is
    // ≈ 99.0% at 40 dB, 99.9% at 60 dB)
    for (name, modes, level, fit) in [
        ("lab_1mode_1khz", 1, false, 98.5),
        ("lab_3mode_20khz", 3, false, 99.5),
        ("lab_offset_step_prbs", 2, true, 99.5),
    ] {
        let reference: Value = serde_json::from_str(
            &std::fs::read_to_string(format!("{dir}/{name}/reference.json")).expect("reference"),
        )
        .expect("reference JSON");
        let path = format!("{dir}/{name}/record.csv.gz");
        let r = json(&beamctl(&["replay", &path, "--json"]));
        assert_eq!(r["modes"], modes, "{name}");
        assert_eq!(r["level_correction"], level, "{name}");
        assert_eq!(r["estimator"], "robust", "{name}");
        let sel = &r["selection"];
        assert_eq!(sel["rule"], "bic_of_the_output_error");
        let chosen = &sel["candidates"][sel["chosen"].as_u64().expect("chosen") as usize];
        assert_eq!(chosen["modes"], modes, "{name}");
        assert_eq!(chosen["excluded"], Value::Null, "{name}");
        assert_within_reference(name, &r, &reference, modes);
        assert_eq!(r["verdict"]["trusted"], true, "{name}");
        // The fit is of the samples the estimator saw: with the level
        // correction, the corrected ones (the measured y holds the offset
        // step, which no model explains).
        assert!(num(&r["fit_percent"]) > fit, "{name}: {}", r["fit_percent"]);
    }
}

/// Every scored ω̂_i, ζ̂_i of report `r` within the reference's tolerance
/// (reference.json's `acceptance`), for its first `modes` modes.
fn assert_within_reference(name: &str, r: &Value, reference: &Value, modes: usize) {
    let acc = &reference["acceptance"];
    for (k, key, tol) in [
        ("omega", "omega_rad_s", "omega_rel_tol"),
        ("zeta", "zeta", "zeta_rel_tol"),
    ] {
        for i in 0..modes {
            let est = num(&r["estimate"][k][i]);
            let tru = num(&reference["truth"][key][i]);
            let e = (est / tru - 1.0).abs();
            let t = num(&acc[tol][i]);
            assert!(e <= t, "{name} {k}{}: {est} vs {tru}: {e:e} > {t:e}", i + 1);
        }
    }
}

/// The sensor's output kind is chosen from the data (a dimension of the
/// model selection, docs/REPLAY.md): an accelerometer under a multisine,
/// an accelerometer after one impact (1 ms half-sine, then free decay) and
/// a velocity sensor under a PRBS (numpy/scipy records) are each read as
/// what they are, with ω, ζ within max(3σ_CRB, 1e-4) of the truth and a
/// trusted verdict; the impact record read as a strain output by
/// `--output strain` is not trusted (exit status 1).
#[test]
fn no_flags_finds_the_sensors_output_kind_and_an_impact_is_estimated() {
    let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/../host-tests/data/records");
    for (name, kind) in [
        ("lab_accel_multisine", "acceleration"),
        ("lab_impact_accel", "acceleration"),
        ("lab_velocity_prbs", "velocity"),
    ] {
        let reference: Value = serde_json::from_str(
            &std::fs::read_to_string(format!("{dir}/{name}/reference.json")).expect("reference"),
        )
        .expect("reference JSON");
        let path = format!("{dir}/{name}/record.csv.gz");
        let r = json(&beamctl(&["replay", &path, "--json"]));
        assert_eq!(r["estimate"]["output"], kind, "{name}");
        assert_eq!(r["modes"], 2, "{name}");
        assert_within_reference(name, &r, &reference, 2);
        assert_eq!(r["verdict"]["trusted"], true, "{name}");
        // b̄ keeps its meaning (y = s^r·Σ c_i b̄_i/q_i·u): within 1e-3.
        for i in 0..2 {
            let (est, tru) = (
                num(&r["estimate"]["bbar"][i]),
                num(&reference["truth"]["bbar"][i]),
            );
            assert!(
                (est / tru - 1.0).abs() < 1e-3,
                "{name} b̄{}: {est} vs {tru}",
                i + 1
            );
        }
    }
    let path = format!("{dir}/lab_impact_accel/record.csv.gz");
    let o = beamctl(&["replay", &path, "--output", "strain", "--json"]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    let r: Value = serde_json::from_slice(&o.stdout).expect("the report");
    assert_eq!(r["verdict"]["trusted"], false);
    assert_eq!(r["estimate"]["output"], "strain");
}

/// A third mode above the two the input reaches (a chirp to 120 Hz, the
/// mode at 260 Hz, its static response 1.5× mode 2's) and an offset plus
/// a thermal drift of the gauge's level: each right with no flags within
/// its tolerance (model mismatch: ω ≤ 1%, ζ ≤ 5%; the offset record:
/// max(3σ_CRB, 1e-4)) and trusted.
#[test]
fn no_flags_handles_a_mode_above_the_band_and_a_drifting_level() {
    let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/../host-tests/data/records");
    for name in ["lab_mode3_above_chirp", "lab_offset_drift_square"] {
        let reference: Value = serde_json::from_str(
            &std::fs::read_to_string(format!("{dir}/{name}/reference.json")).expect("reference"),
        )
        .expect("reference JSON");
        let path = format!("{dir}/{name}/record.csv.gz");
        let r = json(&beamctl(&["replay", &path, "--json"]));
        assert_eq!(r["estimate"]["output"], "strain", "{name}");
        assert_within_reference(name, &r, &reference, 2);
        assert_eq!(r["verdict"]["trusted"], true, "{name}: {}", r["verdict"]);
    }
}

/// Mains lines in y that u does not drive are found in a first fit's
/// residual and removed from u and y (docs/REPLAY.md "Lines in y"): on a
/// record simulated independently of this project (60 Hz mains running 1%
/// fast, its third harmonic, a mode 5 Hz below the line, 40 dB) the lines
/// are reported at their frequencies and the estimate is within the
/// record's tolerance (max(3σ_CRB, 1e-3), the bound paying for the lines'
/// unknown amplitudes and phases); with `--lines off` it is not (ζ2 3×
/// off), and a record with no line has none removed.
#[test]
fn no_flags_removes_the_mains_lines() {
    let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/../host-tests/data/records");
    let name = "lab_hum60_prbs";
    let reference: Value = serde_json::from_str(
        &std::fs::read_to_string(format!("{dir}/{name}/reference.json")).expect("reference"),
    )
    .expect("reference JSON");
    let path = format!("{dir}/{name}/record.csv.gz");
    let within = |r: &Value| {
        let acc = &reference["acceptance"];
        (0..2).all(|i| {
            [
                ("omega", "omega_rad_s", "omega_rel_tol"),
                ("zeta", "zeta", "zeta_rel_tol"),
            ]
            .iter()
            .all(|(k, key, tol)| {
                let e = (num(&r["estimate"][k][i]) / num(&reference["truth"][key][i]) - 1.0).abs();
                e <= num(&acc[tol][i])
            })
        })
    };
    let r = json(&beamctl(&["replay", &path, "--json"]));
    assert_eq!(r["line_removal"]["mode"], "auto");
    let removed = r["line_removal"]["removed"].as_array().expect("removed");
    assert_eq!(removed.len(), 2, "{removed:?}");
    for (line, (f, rms)) in removed.iter().zip([(60.6, 0.03), (181.8, 0.01)]) {
        assert!((num(&line["freq_hz"]) - f).abs() < 0.01, "{line}");
        let share = num(&line["rms"]) / num(&reference["noise"]["rms_clean_y"]);
        assert!((share / rms - 1.0).abs() < 0.05, "{line}: {share}");
        assert_eq!(line["source"], "detected");
    }
    assert!(within(&r), "{}", r["estimate"]);
    assert_eq!(r["verdict"]["trusted"], true);
    assert_eq!(r["verdict"]["lines"], serde_json::json!([]));
    let o = beamctl(&["replay", &path, "--lines", "off", "--json"]);
    // Not trusted (the lines are in the residual): exit 1 after the report.
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    let off: Value = serde_json::from_str(&stdout(&o)).expect("JSON");
    assert_eq!(off["line_removal"]["removed"], serde_json::json!([]));
    // Lines are no noise spectrum: the residual that holds them is not
    // prewhitened (docs/REPLAY.md, "Coloured noise").
    assert_eq!(off["prewhitening"]["applied"], false);
    assert_eq!(off["prewhitening"]["runs"], 0);
    let clean = json(&beamctl(&[
        "replay",
        &format!("{dir}/lab_noise40_prbs/record.csv.gz"),
        "--json",
    ]));
    assert_eq!(clean["line_removal"]["mode"], "auto");
    assert_eq!(clean["line_removal"]["removed"], serde_json::json!([]));
}

/// Coloured measurement noise (docs/REPLAY.md, "Coloured noise"): on a
/// record simulated independently of this project (a bridge amplifier's
/// noise, first-order low-pass at 50 Hz, 40 dB, plus a white floor and a
/// 16-bit ADC) the first fit's residual is coloured and not explained by
/// u, so the replay runs again with u and y prewhitened by its AR model,
/// and the estimate is within the record's tolerance (max(3σ_CRB, 1e-4),
/// the bound for that noise spectrum); `--prewhiten off` runs no pass (how
/// far off it then is: BENCHMARKS.md, "Mains lines and coloured noise").
/// A white-noise record reports
/// an order-0 noise model and no prewhitening.
#[test]
fn no_flags_prewhitens_coloured_noise() {
    let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/../host-tests/data/records");
    let name = "lab_colour40_prbs";
    let reference: Value = serde_json::from_str(
        &std::fs::read_to_string(format!("{dir}/{name}/reference.json")).expect("reference"),
    )
    .expect("reference JSON");
    let path = format!("{dir}/{name}/record.csv.gz");
    let within = |r: &Value| {
        let acc = &reference["acceptance"];
        r["modes"] == 2
            && (0..2).all(|i| {
                [
                    ("omega", "omega_rad_s", "omega_rel_tol"),
                    ("zeta", "zeta", "zeta_rel_tol"),
                ]
                .iter()
                .all(|(k, key, tol)| {
                    let e =
                        (num(&r["estimate"][k][i]) / num(&reference["truth"][key][i]) - 1.0).abs();
                    e <= num(&acc[tol][i])
                })
            })
    };
    let r = json(&beamctl(&["replay", &path, "--json"]));
    let p = &r["prewhitening"];
    assert_eq!(p["mode"], "auto");
    assert_eq!(p["applied"], true, "{p}");
    let m = &p["noise_model"];
    assert!(m["order"].as_u64().expect("order") >= 1, "{m}");
    assert!(num(&m["prediction_gain"]) >= 2.0, "{m}");
    assert!(num(&m["input_share"]) <= num(&m["input_share_max"]), "{m}");
    assert!(within(&r), "{}", r["estimate"]);
    assert_eq!(r["verdict"]["trusted"], true, "{}", r["verdict"]);
    let off = json(&beamctl(&["replay", &path, "--prewhiten", "off", "--json"]));
    assert_eq!(off["prewhitening"]["mode"], "off");
    assert_eq!(off["prewhitening"]["applied"], false);
    assert_eq!(off["prewhitening"]["runs"], 0);
    let clean = json(&beamctl(&[
        "replay",
        &format!("{dir}/lab_noise40_prbs/record.csv.gz"),
        "--json",
    ]));
    let p = &clean["prewhitening"];
    assert_eq!(p["applied"], false, "{p}");
    assert_eq!(p["runs"], 0);
    assert_eq!(p["noise_model"]["order"], 0, "{p}");
}

/// A wrong model's residual is coloured too, but by u: one mode fitted to
/// a two-mode record (numpy/scipy, white noise) leaves the second mode's
/// response in the residual, which the FIR of u explains beyond what
/// noise would (`input_share` above `input_share_max`). It is not
/// prewhitened (the noise model would absorb the missing mode and the
/// verdict, which tests the whitened record, would trust it), and the
/// verdict reads the structured residual.
#[test]
fn a_missing_mode_is_not_whitened_away() {
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../host-tests/data/records/lab_2mode_5khz/record.csv.gz"
    );
    let o = beamctl(&["replay", path, "--modes", "1", "--json"]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    let r: Value = serde_json::from_str(&stdout(&o)).expect("the report, as JSON");
    let p = &r["prewhitening"];
    assert_eq!(p["applied"], false, "{p}");
    assert_eq!(p["runs"], 0, "{p}");
    let m = &p["noise_model"];
    assert!(num(&m["prediction_gain"]) >= 2.0, "{m}");
    assert!(num(&m["input_share"]) > num(&m["input_share_max"]), "{m}");
    assert_eq!(r["verdict"]["trusted"], false, "{}", r["verdict"]);
    let codes: Vec<&str> = r["verdict"]["reasons"]
        .as_array()
        .expect("reasons")
        .iter()
        .filter_map(|c| c["code"].as_str())
        .collect();
    assert!(codes.contains(&"residual_structured"), "{codes:?}");
}

/// The flags fix their part of the choice: `--modes`, `--output` and
/// `--no-level-correction` leave only the estimator to choose, and a named
/// estimator runs with no selection at all.
#[test]
fn flags_fix_their_part_of_the_model() {
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../host-tests/data/records/lab_offset_step_prbs/record.csv.gz"
    );
    let o = beamctl(&[
        "replay",
        path,
        "--modes",
        "1",
        "--no-level-correction",
        "--output",
        "displacement",
        "--json",
    ]);
    // One mode and no correction of the offset step: nothing to trust, so
    // exit status 1 after the full report.
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("no trusted estimate: no: "),
        "{}",
        stderr(&o)
    );
    let r: Value = serde_json::from_slice(&o.stdout).expect("the report");
    assert_eq!(r["verdict"]["trusted"], false);
    let cands = r["selection"]["candidates"].as_array().expect("candidates");
    assert_eq!(cands.len(), 2, "robust and adaptive, 1 mode, no correction");
    for c in cands {
        assert_eq!(c["modes"], 1);
        assert_eq!(c["level_correction"], false);
        assert_eq!(c["output"], "strain");
    }
    assert_eq!(r["modes"], 1);
    assert_eq!(r["level_correction"], false);
    // The adaptive law alone (an offset step, no correction: not trusted).
    let o = beamctl(&["replay", path, "--estimator", "adaptive", "--json"]);
    let r: Value = serde_json::from_slice(&o.stdout).expect("the report");
    assert_eq!(r["selection"], Value::Null);
    assert_eq!(r["modes"], 2);
    assert_eq!(r["level_correction"], false);
}
