//! The scenario and guard flags' validation: every bad combination fails
//! before anything runs, with exit status 2 and one line naming the flag;
//! and the flags that take other sources (`--beam` for the extra modes,
//! `--seeds` with events) work.

mod common;

use common::*;

/// (arguments after `simulate --duration 20`, the flag the error names).
const BAD: &[(&[&str], &str)] = &[
    (&["--step-omega", "43,245"], "--step-omega"),
    (&["--step-zeta", "0.03,0.13"], "--step-zeta"),
    (&["--step-at", "5"], "--step-at"),
    (
        &["--step-at", "30", "--step-zeta", "0.03,0.13"],
        "--step-at",
    ),
    (&["--step-at", "0", "--step-zeta", "0.03,0.13"], "--step-at"),
    (
        &["--step-at", "-1", "--step-zeta", "0.03,0.13"],
        "--step-at",
    ),
    (&["--step-at", "5", "--step-omega", "43"], "--step-omega"),
    (
        &["--step-at", "5", "--step-omega", "245,43"],
        "--step-omega",
    ),
    (&["--step-at", "5", "--step-omega", "0,245"], "--step-omega"),
    (
        &["--step-at", "5", "--step-zeta", "0.03,1.5"],
        "--step-zeta",
    ),
    (&["--step-at", "5", "--step-zeta", "NaN,0.1"], "--step-zeta"),
    (&["--excitation-off", "5"], "--excitation-off"),
    (&["--excitation-off", "5,30"], "--excitation-off"),
    (&["--excitation-off", "8,5"], "--excitation-off"),
    (&["--excitation-off", "-1,5"], "--excitation-off"),
    (&["--fault", "nan"], "--fault-at"),
    (&["--fault-at", "1"], "--fault"),
    (&["--fault-for", "1"], "--fault"),
    (&["--fault", "nan", "--fault-at", "30"], "--fault-at"),
    (
        &["--fault", "nan", "--fault-at", "1", "--fault-for", "0"],
        "--fault-for",
    ),
    (
        &["--fault", "nan", "--fault-at", "18", "--fault-for", "5"],
        "--fault-for",
    ),
    (&["--fault", "saturate", "--fault-at", "1"], "--fault"),
    (&["--fault", "open", "--fault-at", "1"], "--fault"),
    (&["--fault", "bogus", "--fault-at", "1"], "--fault"),
    (
        &["--fault", "nan", "--fault-at", "1", "--fault-level", "1"],
        "--fault-level",
    ),
    (
        &["--fault", "offset", "--fault-at", "1", "--fault-level", "0"],
        "--fault-level",
    ),
    (&["--range", "1"], "--range"),
    (&["--range", "1,-1"], "--range"),
    (&["--range", "-1,inf"], "--range"),
    (&["--truth-modes", "1"], "--truth-modes"),
    (&["--truth-modes", "5"], "--truth-modes"),
    (&["--modes", "3", "--truth-modes", "2"], "--truth-modes"),
    (
        &["--modes", "3", "--estimator", "feedthrough"],
        "--estimator feedthrough",
    ),
    (
        &["--estimator", "feedthrough", "--paper-gains"],
        "--estimator feedthrough",
    ),
    (
        &[
            "--snr-db",
            "40",
            "--model-set",
            "modal",
            "--excitation-off",
            "5,6",
        ],
        "--model-set",
    ),
];

#[test]
fn bad_combinations_fail_with_one_line() {
    for (extra, flag) in BAD {
        let mut args = vec!["simulate", "--duration", "20"];
        args.extend_from_slice(extra);
        let o = beamctl(&args);
        let err = stderr(&o);
        assert_eq!(o.status.code(), Some(2), "{args:?}: {err}");
        assert_eq!(err.lines().count(), 1, "{args:?}: one line, got {err}");
        assert!(err.starts_with("error: "), "{args:?}: {err}");
        assert!(err.contains(flag), "{args:?} should name {flag}: {err}");
        assert!(stdout(&o).is_empty(), "{args:?}: nothing on stdout");
    }
}

#[test]
fn replay_validates_the_range() {
    let path = scratch("range.csv");
    std::fs::write(&path, "t,u,y\n0,0.1,0\n0.0001,0.1,0.001\n").unwrap();
    let o = beamctl(&["replay", path.to_str().unwrap(), "--range", "1,0"]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).starts_with("error: --range:"), "{}", stderr(&o));
}

#[test]
fn replay_counts_saturation_with_a_range() {
    // A record whose y sits at the rail for 40 samples: saturated with a
    // range, stuck without one.
    let path = scratch("rail.csv");
    let mut text = String::from("t,u,y\n");
    for k in 0..4000 {
        let t = k as f64 * 1e-4;
        let u = if (k / 700) % 2 == 0 { 0.1 } else { -0.1 };
        let y = if (2000..2040).contains(&k) {
            0.01
        } else {
            0.009 * (t * 45.0).sin()
        };
        text.push_str(&format!("{t},{u},{y}\n"));
    }
    std::fs::write(&path, text).unwrap();
    let p = path.to_str().unwrap();
    let with = beamctl(&["replay", p, "--json", "--range", "-0.01,0.01"]);
    let r: Value = serde_json::from_str(&stdout(&with)).expect("JSON");
    let g = &r["guard"];
    assert!(num(&g["saturated"]) + num(&g["open"]) >= 40.0, "{g}");
    let without = beamctl(&["replay", p, "--json"]);
    let r: Value = serde_json::from_str(&stdout(&without)).expect("JSON");
    assert!(num(&r["guard"]["stuck"]) >= 14.0, "{}", r["guard"]);
    assert_eq!(r["guard"]["saturated"], 0);
}

#[test]
fn extra_modes_come_from_the_beam_file() {
    // The example beam file is the paper's beam: the same extra modes.
    let beam = concat!(env!("CARGO_MANIFEST_DIR"), "/examples/paper-beam.toml");
    let base = [
        "simulate",
        "--json",
        "--duration",
        "2",
        "--truth-modes",
        "3",
    ];
    let from_file = json(&beamctl(&[&base[..], &["--beam", beam]].concat()));
    let default = json(&beamctl(&base));
    assert_eq!(from_file["scenario"]["truth_modes"], 3);
    // --beam also sets the start-up λ, so compare the simulated beam via
    // the truth only.
    assert_eq!(from_file["truth"], default["truth"]);
    // A beam file with a stiffer beam moves the extra mode: another run.
    let stiff = scratch("stiff.toml");
    std::fs::write(&stiff, "youngs_modulus_pa = 3.0e11\n").unwrap();
    let o = beamctl(&[&base[..], &["--beam", stiff.to_str().unwrap()]].concat());
    let other: Value = serde_json::from_str(&stdout(&o)).expect("JSON");
    assert_ne!(other["estimate"], from_file["estimate"]);
}

#[test]
fn seeds_run_with_a_scenario() {
    let o = beamctl(&[
        "simulate",
        "--json",
        "--duration",
        "3",
        "--snr-db",
        "60",
        "--seeds",
        "1..2",
        "--step-at",
        "1.5",
        "--step-zeta",
        "0.03105,0.13",
    ]);
    let r = json(&o);
    assert!(r["crlb"].is_null(), "no bound with a scenario");
    let runs = r["estimators"][0]["runs"].as_array().unwrap();
    assert_eq!(runs.len(), 2);
    for run in runs {
        assert!((num(&run["truth"]["zeta"][0]) - 0.03105).abs() < 1e-12);
        assert!(
            run["scenario"]["tracking_1pct_s"].is_number(),
            "{}",
            run["scenario"]
        );
    }
}

/// `--hum` and `--noise-colour` put a lab's disturbances on y: reported in
/// the JSON, no Cramér–Rao bound with them, refused where they make no
/// sense; the CSV's y carries the line.
#[test]
fn hum_and_coloured_noise_are_simulated_and_reported() {
    let csv = scratch("hum.csv");
    let clean_csv = scratch("clean.csv");
    let base = ["simulate", "--json", "--duration", "2", "--snr-db", "60"];
    let hum = json(&beamctl(
        &[
            &base[..],
            &["--hum", "50:0.03,150:0.01", "--csv", csv.to_str().unwrap()],
        ]
        .concat(),
    ));
    let clean = json(&beamctl(
        &[&base[..], &["--csv", clean_csv.to_str().unwrap()]].concat(),
    ));
    assert_eq!(hum["hum"][0]["freq_hz"], 50.0);
    assert_eq!(hum["hum"][1]["level"], 0.01);
    assert!(hum["crlb"].is_null() && !clean["crlb"].is_null());
    assert_ne!(hum["estimate"], clean["estimate"]);
    // y − y_clean (same noise seed) is the two lines: RMS √(0.03² + 0.01²)
    // of the noise-free y's RMS, which 60 dB of noise barely moves.
    let column = |p: &PathBuf| -> Vec<f64> {
        let text = std::fs::read_to_string(p).unwrap();
        let mut lines = text.lines();
        let header: Vec<&str> = lines.next().unwrap().split(',').collect();
        let y = header.iter().position(|h| *h == "y").expect("y column");
        lines
            .map(|l| l.split(',').nth(y).unwrap().parse().unwrap())
            .collect()
    };
    let (a, b) = (column(&csv), column(&clean_csv));
    let rms = |v: &mut dyn Iterator<Item = f64>| {
        let (s, n) = v.fold((0.0, 0), |(s, n), x| (s + x * x, n + 1));
        (s / n as f64).sqrt()
    };
    let line_rms = rms(&mut a.iter().zip(&b).map(|(a, b)| a - b));
    let y_rms = rms(&mut b.iter().copied());
    let expected = (0.03f64.powi(2) + 0.01f64.powi(2)).sqrt();
    assert!(
        (line_rms / y_rms / expected - 1.0).abs() < 0.02,
        "{line_rms} / {y_rms}"
    );
    let coloured = json(&beamctl(
        &[&base[..], &["--noise-colour", "lowpass:50"]].concat(),
    ));
    assert_eq!(coloured["noise_colour"]["low_pass"]["corner_hz"], 50.0);
    assert!(coloured["crlb"].is_null());
    for (args, flag) in [
        (
            vec!["simulate", "--noise-colour", "lowpass:50"],
            "--noise-colour",
        ),
        (vec!["simulate", "--hum", "6000:0.1"], "--hum"),
        (vec!["simulate", "--hum", "50"], "--hum"),
        (
            vec![
                "simulate",
                "--snr-db",
                "40",
                "--hum",
                "50:0.03",
                "--model-set",
                "tf",
            ],
            "--model-set",
        ),
    ] {
        let o = beamctl(&args);
        assert_eq!(o.status.code(), Some(2), "{args:?}");
        assert!(stderr(&o).contains(flag), "{args:?}: {}", stderr(&o));
    }
}
