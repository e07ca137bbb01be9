//! End-to-end tests of the noise-robust estimator (`--estimator robust`)
//! and of the Cramér–Rao bound (`beamctl crlb`, error ÷ bound in
//! `simulate`, `replay --crlb`, `simulate --seeds`).

mod common;

use beamest::crlb::{FisherAccumulator, ModelSet};
use beamest::excitation::SquareWave;
use beamest::model::paper_plant_tf;
use common::*;

fn arr(v: &Value) -> Vec<f64> {
    v.as_array()
        .unwrap_or_else(|| panic!("not an array: {v}"))
        .iter()
        .map(num)
        .collect()
}

#[test]
fn robust_runs_in_both_precisions_and_reports_its_fields() {
    for (precision, tol) in [("f64", 1e-9), ("f32", 1e-4)] {
        for modes in ["1", "2", "3"] {
            let r = json(&beamctl(&[
                "simulate",
                "--estimator",
                "robust",
                "--precision",
                precision,
                "--modes",
                modes,
                "--duration",
                "3",
                "--json",
            ]));
            assert_eq!(r["estimator"], "robust");
            assert_eq!(r["precision"], precision);
            for k in ["omega", "zeta"] {
                for e in arr(&r["rel_error"][k]) {
                    assert!(e < tol, "{precision} {modes} modes: {k} {e:e}");
                }
            }
            let rb = &r["robust"];
            // 3 s: within the host's 13.1 s record, still refining.
            assert_eq!(rb["phase"], "refining", "{rb}");
            assert!(num(&rb["model_updates"]) >= 1.0);
            assert_eq!(rb["started_moving"], false, "simulated from rest");
            // Noise-free: the output-error residual is rounding, relative
            // to the output scale Y0.
            let y0 = num(&r["builds"][0]["y_scale"]);
            assert!(num(&rb["noise_rms"]) < tol * y0, "{rb}");
            // The window is replayed into it: the first build saw sample 0.
            let b0 = &r["builds"][0];
            assert_eq!(b0["replayed_samples"], b0["sample"]);
            assert!(r["crlb"].is_null(), "no bound without noise");
        }
    }
}

/// With noise the report carries the experiment's bound and error ÷ bound,
/// and the robust estimator's a-posteriori noise RMS estimates σ.
#[test]
fn noisy_simulate_reports_the_bound_and_the_ratio() {
    let r = json(&beamctl(&[
        "simulate",
        "--estimator",
        "robust",
        "--snr-db",
        "40",
        "--duration",
        "4",
        "--json",
    ]));
    let b = &r["crlb"];
    assert_eq!(b["model_set"], "transfer_function");
    assert_eq!(b["parameters"], 7);
    assert_eq!(b["samples"], 40_000);
    let sigma = num(&r["noise_sd"]);
    assert_eq!(num(&b["sigma"]), sigma);
    // SNR relative to the noise-free y's RMS over the whole run.
    assert!((num(&b["snr_db"]) - 40.0).abs() < 1e-9);
    let noise = num(&r["robust"]["noise_rms"]);
    assert!((noise / sigma - 1.0).abs() < 0.05, "{noise} vs {sigma}");
    for k in ["omega", "zeta", "bbar"] {
        let e = arr(&r["rel_error"][k]);
        let rel = arr(&b[k]["rel"]);
        let ratio = arr(&r["error_over_crlb"][k]);
        for i in 0..2 {
            assert!((ratio[i] - e[i] / rel[i]).abs() <= 1e-12 * ratio[i].abs());
            // One realisation of an efficient estimator: within a few σ.
            assert!(ratio[i] < 5.0, "{k}{}: {} ÷ CRB", i + 1, ratio[i]);
        }
    }
    // The table shows the bound column and the ratios.
    let o = beamctl(&["simulate", "--snr-db", "40", "--duration", "1.5"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let s = stdout(&o);
    for label in [
        "CRB (rel.)",
        "÷ CRB",
        "bound:  Cramér–Rao, transfer-function set",
    ] {
        assert!(s.contains(label), "missing {label} in\n{s}");
    }
}

/// The paper's experiment (0.1·square(7 Hz), Ts = 0.1 ms, 60 s, 40 dB):
/// `beamctl crlb` gives the core's numbers, i.e. the figures of issue 9
/// (modal set: ω1 3.2e-6, ω2 3.9e-4, ζ1 7.8e-5, ζ2 3.2e-3) and the
/// transfer-function set's ζ1 ≈ 1.6e-4 — the bound that
/// host-tests/examples/crlb_monte_carlo.rs prints and checks by Monte Carlo.
#[test]
fn crlb_matches_the_core_on_the_papers_experiment() {
    let mut acc = FisherAccumulator::from_tf(&paper_plant_tf(), &[-2.0, 2.0], 1e-4).unwrap();
    let mut sq = SquareWave::<f64>::paper();
    for _ in 0..600_000 {
        acc.push(sq.next_sample());
    }
    let sigma = acc.sigma_for_snr_db(40.0);
    for (set, flag) in [
        (ModelSet::Modal, "modal"),
        (ModelSet::TransferFunction, "tf"),
    ] {
        let core = acc.bound(set, sigma).unwrap();
        let r = json(&beamctl(&[
            "crlb",
            "--snr-db",
            "40",
            "--duration",
            "60",
            "--model-set",
            flag,
            "--json",
        ]));
        assert!((num(&r["sigma"]) / sigma - 1.0).abs() < 1e-12);
        let pairs = [
            ("omega", core.omega_rel),
            ("zeta", core.zeta_rel),
            ("bbar", core.bbar_rel),
        ];
        for (k, want) in pairs {
            let got = arr(&r[k]["rel"]);
            for i in 0..2 {
                assert!(
                    (got[i] / want[i] - 1.0).abs() < 1e-12,
                    "{flag} {k}{}: {} vs {}",
                    i + 1,
                    got[i],
                    want[i]
                );
            }
        }
        if set == ModelSet::Modal {
            let issue = [("omega", [3.2e-6, 3.9e-4]), ("zeta", [7.8e-5, 3.2e-3])];
            for (k, want) in issue {
                let got = arr(&r[k]["rel"]);
                for i in 0..2 {
                    assert!(
                        (got[i] / want[i] - 1.0).abs() < 0.02,
                        "{k}{}: {}",
                        i + 1,
                        got[i]
                    );
                }
            }
        } else {
            let z1 = arr(&r["zeta"]["rel"])[0];
            assert!((z1 / 1.59e-4 - 1.0).abs() < 0.01, "{z1}");
        }
    }
    // --noise-sd gives the same bound as the SNR it corresponds to; the
    // table states the model set.
    let o = beamctl(&[
        "crlb",
        "--noise-sd",
        &format!("{sigma:e}"),
        "--duration",
        "60",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let s = stdout(&o);
    assert!(s.contains("transfer-function set"), "{s}");
    assert!(s.contains("1.59e-4"), "ζ1 in\n{s}");
    assert!(s.contains("SNR 40.00 dB"), "{s}");
}

/// The bound scales with σ and needs every plant flag simulate takes.
#[test]
fn crlb_takes_the_plant_flags() {
    let r = json(&beamctl(&[
        "crlb",
        "--omega",
        "30,400",
        "--zeta",
        "0.01,0.05",
        "--bbar",
        "5,-12",
        "--snr-db",
        "20",
        "--json",
    ]));
    let w = arr(&r["omega"]["value"]);
    assert!(
        (w[0] - 30.0).abs() < 1e-9 && (w[1] - 400.0).abs() < 1e-9,
        "{w:?}"
    );
    let loud = arr(&r["zeta"]["rel"]);
    let r = json(&beamctl(&[
        "crlb",
        "--omega",
        "30,400",
        "--zeta",
        "0.01,0.05",
        "--bbar",
        "5,-12",
        "--snr-db",
        "40",
        "--json",
    ]));
    let quiet = arr(&r["zeta"]["rel"]);
    for i in 0..2 {
        assert!((loud[i] / quiet[i] - 10.0).abs() < 1e-9);
    }
    let r = json(&beamctl(&[
        "crlb", "--modes", "3", "--snr-db", "40", "--json",
    ]));
    assert_eq!(r["parameters"], 11);
    assert_eq!(arr(&r["zeta"]["rel"]).len(), 3);
}

/// `crlb` describes the user's own experiment: with simulate's drive and
/// sample-interval flags it gives the bound `simulate` reports for that
/// run, and a bound that depends on them.
#[test]
fn crlb_takes_the_drive_and_the_sample_interval() {
    let experiment = [
        "--snr-db",
        "40",
        "--duration",
        "4",
        "--ts",
        "2e-4",
        "--wave",
        "prbs",
        "--bit-rate",
        "1000",
        "--bits",
        "11",
        "--amplitude",
        "0.1",
    ];
    let bound = json(&beamctl(&[&["crlb", "--json"][..], &experiment].concat()));
    assert_eq!(bound["ts_s"], 2e-4);
    assert_eq!(bound["samples"], 20_000);
    assert!(
        bound["drive"].as_str().unwrap().contains("prbs"),
        "{}",
        bound["drive"]
    );
    assert!(bound.get("u_freq_hz").is_none());
    let sim = json(&beamctl(
        &[&["simulate", "--json"][..], &experiment].concat(),
    ));
    // The same bound (the σ of the SNR is summed in another order).
    for k in ["omega", "zeta", "bbar"] {
        for (a, b) in arr(&sim["crlb"][k]["rel"])
            .iter()
            .zip(arr(&bound[k]["rel"]))
        {
            assert!((a / b - 1.0).abs() < 1e-12, "{k}: {a} vs {b}");
        }
    }
    let square = json(&beamctl(&[
        "crlb",
        "--json",
        "--snr-db",
        "40",
        "--duration",
        "4",
        "--ts",
        "2e-4",
    ]));
    assert_ne!(square["zeta"]["rel"], bound["zeta"]["rel"]);
    let bad = beamctl(&["crlb", "--snr-db", "40", "--wave", "prbs"]);
    assert_eq!(bad.status.code(), Some(2));
    assert!(
        stderr(&bad).starts_with("error: --wave:"),
        "{}",
        stderr(&bad)
    );
}

/// Replay with the robust estimator: a recorded file replays to the
/// simulation's estimate, and `--crlb` bounds it at the estimate with the
/// estimator's own noise estimate.
#[test]
fn replay_with_robust_and_the_bound() {
    let path = scratch("robust-40db.csv");
    let p = path.to_str().unwrap();
    let common = ["--estimator", "robust", "--json"];
    let mut sim = vec!["simulate", "--duration", "3", "--snr-db", "40", "--csv", p];
    sim.extend(common);
    let s = json(&beamctl(&sim));
    let mut rep = vec!["replay", p, "--crlb"];
    rep.extend(common);
    let r = json(&beamctl(&rep));
    for k in ["estimate", "builds", "robust", "fit_percent"] {
        assert_eq!(s[k], r[k], "{k}");
    }
    assert_eq!(r["crlb_sigma_source"], "robust_residual");
    let b = &r["crlb"];
    assert_eq!(num(&b["sigma"]), num(&r["robust"]["noise_rms"]));
    assert!((num(&b["sigma"]) / num(&s["noise_sd"]) - 1.0).abs() < 0.05);
    // At the estimate, the bound is close to the one at the truth.
    for k in ["omega", "zeta"] {
        let (at_est, at_truth) = (arr(&b[k]["rel"]), arr(&s["crlb"][k]["rel"]));
        for i in 0..2 {
            assert!((at_est[i] / at_truth[i] - 1.0).abs() < 0.2, "{k}{}", i + 1);
        }
    }
    // A given σ and the modal set; the other laws use the fit residual.
    let r = json(&beamctl(&[
        "replay",
        p,
        "--estimator",
        "all",
        "--crlb",
        "--noise-sd",
        "1e-4",
        "--model-set",
        "modal",
        "--json",
    ]));
    for run in r.as_array().unwrap() {
        assert_eq!(run["crlb_sigma_source"], "given");
        assert_eq!(run["crlb"]["model_set"], "modal");
        assert_eq!(num(&run["crlb"]["sigma"]), 1e-4);
    }
    let r = json(&beamctl(&[
        "replay",
        p,
        "--estimator",
        "adaptive",
        "--crlb",
        "--json",
    ]));
    assert_eq!(r["crlb_sigma_source"], "model_output_residual");
    let o = beamctl(&["replay", p, "--estimator", "robust", "--crlb"]);
    let t = stdout(&o);
    for label in ["CRB (rel.)", "σ for the CRB", "OE residual", "robust phase"] {
        assert!(t.contains(label), "missing {label} in\n{t}");
    }
}

/// The external recordings (host-tests/data), one starting in motion:
/// the robust estimator replays them to the truth with no flag but the
/// file and the law.
#[test]
fn robust_replays_external_recordings() {
    let data = concat!(env!("CARGO_MANIFEST_DIR"), "/../host-tests/data");
    let truth: Value = serde_json::from_str(
        &std::fs::read_to_string(format!("{data}/replay_truth.json")).expect("truth file"),
    )
    .expect("truth JSON");
    for (name, t) in truth.as_object().expect("object") {
        let path = format!("{data}/{name}.csv.gz");
        let r = json(&beamctl(&[
            "replay",
            &path,
            "--estimator",
            "robust",
            "--json",
        ]));
        for (k, key) in [("omega", "omega_rad_s"), ("zeta", "zeta")] {
            for i in 0..2 {
                let e = (num(&r["estimate"][k][i]) / num(&t[key][i]) - 1.0).abs();
                // The generator's own discretization limits the truth
                // file's figures (the paper's law reaches 1e-5 on them).
                assert!(e < 1e-7, "{name} {k}{}: {e:e}", i + 1);
            }
        }
        let moving = num(&t["starts_in_motion_after_s"]) > 0.0;
        assert_eq!(r["robust"]["started_moving"], moving, "{name}");
    }
}

#[test]
fn seeds_summarize_rms_and_ratio() {
    let o = beamctl(&[
        "simulate",
        "--estimator",
        "all",
        "--snr-db",
        "40",
        "--duration",
        "2",
        "--seeds",
        "1..3",
        "--json",
    ]);
    let v = json(&o);
    assert_eq!(v["seeds"], serde_json::json!([1, 2, 3]));
    let ests = v["estimators"].as_array().unwrap();
    assert_eq!(ests.len(), 4);
    let b = &v["crlb"];
    for e in ests {
        let runs = e["runs"].as_array().unwrap();
        assert_eq!(runs.len(), 3);
        for (k, seed) in runs.iter().zip(1..) {
            assert_eq!(k["seed"], seed);
        }
        if e["failed_seeds"].as_array().unwrap().is_empty() {
            for p in ["omega", "zeta"] {
                for i in 0..2 {
                    let errs: Vec<f64> = runs.iter().map(|r| num(&r["rel_error"][p][i])).collect();
                    let rms = (errs.iter().map(|x| x * x).sum::<f64>() / 3.0).sqrt();
                    let got = num(&e["rms_rel_error"][p][i]);
                    assert!((got / rms - 1.0).abs() < 1e-9, "{p}{}", i + 1);
                    let ratio = num(&e["rms_over_crlb"][p][i]);
                    assert!((ratio - rms / num(&b[p]["rel"][i])).abs() < 1e-9 * ratio);
                }
            }
        }
    }
    // A single seed run gives the same error as that seed inside --seeds.
    let one = json(&beamctl(&[
        "simulate",
        "--estimator",
        "robust",
        "--snr-db",
        "40",
        "--duration",
        "2",
        "--seed",
        "2",
        "--json",
    ]));
    assert_eq!(one["estimate"], ests[3]["runs"][1]["estimate"]);
    let o = beamctl(&[
        "simulate",
        "--snr-db",
        "40",
        "--duration",
        "1.5",
        "--seeds",
        "1,2",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let s = stdout(&o);
    for label in ["RMS error", "mean error", "RMS ÷ CRB", "seeds:  1, 2"] {
        assert!(s.contains(label), "missing {label} in\n{s}");
    }
}

/// Bad combinations and values: one line on stderr naming the flag, exit 2.
#[test]
fn bad_bound_and_seed_flags_fail_cleanly() {
    let file = scratch("bad-flags.csv");
    std::fs::write(&file, "t,u,y\n0,0.1,0\n0.0001,0.1,0\n").unwrap();
    let f = file.to_str().unwrap();
    let cases: &[(&[&str], &str)] = &[
        (&["simulate", "--seeds", "1..5"], "--seeds"),
        (&["simulate", "--model-set", "modal"], "--model-set"),
        (
            &["simulate", "--snr-db", "40", "--seeds", "5..1"],
            "--seeds",
        ),
        (
            &["simulate", "--snr-db", "40", "--seeds", "a..b"],
            "--seeds",
        ),
        (
            &["simulate", "--snr-db", "40", "--seeds", "1..2000"],
            "--seeds",
        ),
        (
            &[
                "simulate", "--snr-db", "40", "--seeds", "1..3", "--seed", "2",
            ],
            "--seeds",
        ),
        (
            &[
                "simulate", "--snr-db", "40", "--seeds", "1..3", "--csv", "x.csv",
            ],
            "--seeds",
        ),
        (&["simulate", "--noise-sd", "0"], "--noise-sd"),
        (&["simulate", "--noise-sd", "-1e-5"], "--noise-sd"),
        (&["simulate", "--noise-sd", "nan"], "--noise-sd"),
        (
            &["simulate", "--noise-sd", "1e-5", "--snr-db", "40"],
            "--noise-sd",
        ),
        (
            &["simulate", "--model-set", "both", "--snr-db", "40"],
            "--model-set",
        ),
        (&["crlb"], "--snr-db"),
        (
            &["crlb", "--snr-db", "40", "--noise-sd", "1e-5"],
            "--noise-sd",
        ),
        (&["crlb", "--snr-db", "nan"], "--snr-db"),
        (&["crlb", "--noise-sd", "0"], "--noise-sd"),
        (&["crlb", "--snr-db", "40", "--duration", "0"], "--duration"),
        (&["crlb", "--snr-db", "40", "--zeta", "0,0.1"], "--zeta"),
        (&["crlb", "--snr-db", "40", "--modes", "4"], "--modes"),
        (&["replay", f, "--noise-sd", "1e-5"], "--crlb"),
        (&["replay", f, "--model-set", "modal"], "--crlb"),
        (&["replay", f, "--crlb", "--noise-sd", "0"], "--noise-sd"),
    ];
    for (args, flag) in cases {
        let o = beamctl(args);
        let err = stderr(&o);
        assert_eq!(o.status.code(), Some(2), "{args:?}: {err}");
        assert!(!err.contains("panicked"), "{args:?} panicked: {err}");
        assert!(err.starts_with("error: "), "{args:?}: {err}");
        assert!(err.contains(flag), "{args:?}: does not name {flag}: {err}");
        assert_eq!(err.trim_end().lines().count(), 1, "{args:?}: {err}");
        assert!(o.stdout.is_empty(), "{args:?} wrote to stdout");
    }
}

#[test]
fn help_documents_the_new_flags() {
    let h = stdout(&beamctl(&["simulate", "--help"]));
    for flag in [
        "robust",
        "--noise-sd",
        "--seeds",
        "--model-set",
        "Cramér–Rao",
    ] {
        assert!(h.contains(flag), "{flag} missing from simulate help");
    }
    let h = stdout(&beamctl(&["replay", "--help"]));
    for flag in ["robust", "--crlb", "--noise-sd", "--model-set"] {
        assert!(h.contains(flag), "{flag} missing from replay help");
    }
    let h = stdout(&beamctl(&["crlb", "--help"]));
    for flag in [
        "--snr-db",
        "--noise-sd",
        "--duration",
        "--model-set",
        "--omega",
        "--json",
        "transfer-function",
    ] {
        assert!(h.contains(flag), "{flag} missing from crlb help");
    }
}

/// docs/SETTINGS.md, "Failure modes": at 20 dB the data's λ0 left the
/// robust estimator of seed 4 without a usable model at the end of a 2 s
/// record (before the restart policy this run had no estimate; with it the
/// driver restarted at other λ). With the host's 13.1 s record and the
/// start from a reflected model the same run is usable at 3 s without a
/// restart; a record that fills with the estimate unusable is still
/// restarted (`crate::run::tuned`).
#[test]
fn a_20_db_robust_start_is_usable_without_a_restart() {
    let r = json(&beamctl(&[
        "simulate",
        "--json",
        "--estimator",
        "robust",
        "--snr-db",
        "20",
        "--seed",
        "4",
        "--duration",
        "3",
    ]));
    assert_ne!(r["tuning"], "restarted", "{}", r["builds"]);
    assert_eq!(r["validity"], Value::Array(vec![]));
    for k in ["omega", "zeta"] {
        for e in r["rel_error"][k].as_array().unwrap() {
            assert!(num(e) < 0.1, "{k}: {}", r["rel_error"]);
        }
    }
}
