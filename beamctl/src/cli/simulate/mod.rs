//! `beamctl simulate`: validate the flags into [`RunConfig`]s, run them
//! through [`crate::run`] and report (table or JSON, plus optional CSV
//! and PNG).
//!
//! # Design
//! * Validation happens before anything runs or any file is created, and
//!   every message names the flag it is about. clap parses the types; the
//!   value rules (ω > 0, ζ > 0, list lengths, …) are checked here, where the
//!   mode count is known.
//! * The plant flags are resolved by `plant.rs` (shared with `crlb`).
//! * With noise the experiment's Cramér–Rao bound is computed once
//!   ([`crate::run::run_bound`]) and each estimator's error is divided
//!   by it; `--seeds` is `multiseed.rs`.
//! * The runner's observer is called at 1 kHz; it feeds the CSV writer, the
//!   plot recorder and the progress bar without allocating per call (apart
//!   from the CSV cell strings).

pub mod plan;
pub mod seeds;

use crate::cli::args::SimulateArgs;
use crate::cli::progress::Progress;
use crate::error::{note, write_stdout, CliError};
use crate::io::csv_out::CsvOut;
use crate::io::plot::{self, FrfPanel, OutputPanel, Recorder};
use crate::io::report;
use crate::judge::fit::{self, Model};
use crate::judge::frf::h1;
use crate::run::error::RunError;
use crate::run::interrupt::Interrupt;
use crate::run::{run_many, samples, scenario_rig};
use crate::run::{Observer, RunConfig, RunReport, Trace};
use beamest::model::{TransferFunction, MAX_ORDER};
use plan::{bound_line, plan, run_line, JsonRun, Plan};
use std::io::IsTerminal;

/// Feeds the CSV writer, the plot recorders and the progress bar.
struct SimObserver<'a, 'i> {
    csv: Option<&'a mut CsvOut>,
    recorders: Vec<Recorder>,
    progress: &'a mut Progress,
    ts_s: f64,
    total: u64,
    /// Asked after each evaluation.
    interrupt: Interrupt<'i>,
}

impl Observer for SimObserver<'_, '_> {
    fn estimate(&mut self, index: usize, t: &Trace<'_>) {
        if let Some(c) = self.csv.as_deref_mut() {
            c.estimate(index, t);
        }
        if let Some(r) = self.recorders.get_mut(index) {
            r.push(t);
        }
        if index == 0 {
            let done = ((t.t_s / self.ts_s).round() as u64 + 1).min(self.total);
            self.progress.set_position(done);
        }
    }

    fn screening(&mut self, _k: u64, s: &beamest::guard::Screening) {
        if let Some(c) = self.csv.as_deref_mut() {
            c.screening(s);
        }
    }

    fn sample(&mut self, _k: u64, t_s: f64, u: f64, y: f64) {
        if let Some(c) = self.csv.as_deref_mut() {
            c.row(t_s, u, y);
        }
    }

    fn stopped(&mut self) -> bool {
        self.interrupt.stopped()
    }

    fn wants_samples(&self) -> bool {
        self.csv.is_some()
    }
}

/// Run `beamctl simulate`.
pub fn run(args: &SimulateArgs) -> Result<(), CliError> {
    let (text, status) = output(args)?;
    write_stdout(&text)?;
    status
}

/// What `beamctl simulate` prints (the JSON document with `--json`), and
/// its exit status once printed (an error if a law produced no estimate).
pub fn output(args: &SimulateArgs) -> Result<(String, Result<(), CliError>), CliError> {
    output_with(args, None)
}

/// [`output`], with `interrupt` asked every few thousand evaluations
/// during the simulation (each seed's, with `--seeds`): true stops it with
/// an error whose code is [`crate::error::EXIT_INTERRUPTED`].
pub fn output_with(
    args: &SimulateArgs,
    interrupt: Option<&mut dyn FnMut() -> bool>,
) -> Result<(String, Result<(), CliError>), CliError> {
    let plan = plan(args)?;
    if let Some(seeds) = &plan.seeds {
        return Ok((seeds::output(&plan, seeds, args.json, interrupt)?, Ok(())));
    }
    let names: Vec<&str> = plan.est.kinds.iter().map(|k| k.name()).collect();
    // Create output files up front so a bad path fails before the run.
    let mut csv = match &args.csv {
        Some(p) => Some(CsvOut::create(p, plan.modes, &names)?),
        None => None,
    };
    if let Some(p) = &args.plot {
        plot::check_writable(p)?;
    }

    let per_run = plan.samples_per_run();
    let eval_every = plan.base.eval_every.max(1) as u64;
    let mut progress = Progress::new(per_run, !args.json && std::io::stderr().is_terminal());
    progress.set_message(&names.join("+"));
    let recorders = match &args.plot {
        Some(_) => names
            .iter()
            .map(|n| Recorder::new(n, plan.modes, per_run / eval_every))
            .collect(),
        None => Vec::new(),
    };
    let mut obs = SimObserver {
        csv: csv.as_mut(),
        recorders,
        progress: &mut progress,
        ts_s: plan.base.ts_s,
        total: per_run,
        interrupt: Interrupt::new(interrupt),
    };
    let result = run_many(&plan.base, &plan.est.kinds, &mut obs);
    let recorders = std::mem::take(&mut obs.recorders);
    progress.finish();
    let reports = result.map_err(|e| match e {
        RunError::Interrupted => CliError::interrupted("simulation"),
        e => CliError::failure(format!("simulation: {e}")),
    })?;

    if let Some(c) = csv.take() {
        let rows = c.finish()?;
        if let Some(p) = &args.csv {
            note(&format!("wrote {} ({rows} rows)", p.display()));
        }
    }
    if let Some(p) = &args.plot {
        // The truth in force: after a plant step, the new plant's.
        let truths = crate::run::Truths::new(&plan.base)
            .map_err(|e| CliError::failure(format!("simulation: {e}")))?;
        let truth = plot::TruthLines {
            before: &truths.before.modal,
            after: truths
                .after
                .as_ref()
                .map(|(at, t)| (*at as f64 * plan.base.ts_s, &t.modal)),
        };
        let title = format!(
            "{} — {} s, {}{}",
            plan.plant_label,
            plan.base.duration_s,
            plan.est.lambda_label,
            noise_label(&plan.base)
        );
        let series: Vec<_> = recorders.into_iter().map(Recorder::finish).collect();
        let (output, frf) = output_panel(&plan.base, &reports)?;
        let labelled = plot::write(
            p,
            &title,
            Some(&truth),
            &series,
            plan.base.duration_s,
            Some(&output),
            frf.as_ref(),
        )?;
        let extra = if labelled {
            ""
        } else {
            " (no font found: drawn without text; set BEAMCTL_FONT to a .ttf file)"
        };
        note(&format!("wrote {}{extra}", p.display()));
    }

    let text = if args.json {
        json(&plan, &reports)?
    } else {
        render(&plan, &reports)
    };
    let status = report::require_estimates(
        reports
            .iter()
            .map(|r| (r.estimator, &r.estimate, r.tuning, r.law_updates)),
    );
    Ok((text, status))
}

/// Model output vs measured y over the last 0.5 s of the run, per
/// estimator, and the frequency-response row (the rig is replayed to get
/// the samples again).
fn output_panel(
    cfg: &RunConfig,
    reports: &[RunReport],
) -> Result<(OutputPanel, Option<FrfPanel>), CliError> {
    let n = samples(cfg);
    let keep = n.saturating_sub((0.5 / cfg.ts_s).round() as u64)..n;
    let start = scenario_rig(cfg).map_err(|e| CliError::failure(format!("--plot: {e}")))?;
    let record = || {
        let mut r = start.clone();
        (0..n).map(move |_| {
            let s = r.tick();
            (s.u, s.y)
        })
    };
    let mut panel = OutputPanel {
        t: Vec::new(),
        y: Vec::new(),
        models: Vec::new(),
    };
    let models: Vec<Option<Model>> = reports
        .iter()
        .map(|r| model_of(&r.estimate, cfg.ts_s))
        .collect();
    let mut frf_models = Vec::new();
    for (r, model) in reports.iter().zip(&models) {
        let (fit, yhat) = match model {
            Some(model) => match fit::fit(model, record) {
                Some(f) => {
                    let out = fit::model_output(model, &f, record(), keep.clone());
                    if panel.t.is_empty() {
                        panel.t = out.iter().map(|o| o.0 as f64 * cfg.ts_s).collect();
                        panel.y = out.iter().map(|o| o.1).collect();
                    }
                    (Some(f.percent), out.iter().map(|o| o.2).collect())
                }
                None => (None, Vec::new()),
            },
            None => (None, Vec::new()),
        };
        frf_models.push(plot::FrfInput {
            name: r.estimator.name().to_string(),
            model: model.as_ref(),
            fit_percent: fit,
            modes: r
                .estimate
                .omega
                .iter()
                .copied()
                .zip(r.estimate.zeta.iter().copied())
                .collect(),
        });
        panel
            .models
            .push((r.estimator.name().to_string(), fit, yhat));
    }
    let (u, y): (Vec<f64>, Vec<f64>) = record().unzip();
    let frf = h1(&u, &y, cfg.ts_s, None).map(|h| FrfPanel::new(h, &frf_models, cfg.ts_s));
    if panel.t.is_empty() {
        let out: Vec<(f64, f64)> = record()
            .skip(keep.start as usize)
            .map(|(_, y)| (0.0, y))
            .collect();
        panel.t = (keep.start..n).map(|k| k as f64 * cfg.ts_s).collect();
        panel.y = out.into_iter().map(|o| o.1).collect();
    }
    Ok((panel, frf))
}

/// The identified model from a report's estimate, if its coefficients
/// are finite.
pub fn model_of(e: &crate::run::session::ModalSummary, ts_s: f64) -> Option<Model> {
    let (a, b) = (&e.a, &e.b);
    let n = a.len() / 2;
    if n == 0 || a.len() > MAX_ORDER || b.len() + 1 != a.len() {
        return None;
    }
    let mut tf = TransferFunction {
        modes: n,
        a: [0.0; MAX_ORDER],
        b: [0.0; MAX_ORDER],
        output: e.output,
    };
    tf.a[..a.len()].copy_from_slice(a);
    tf.b[..b.len()].copy_from_slice(b);
    if !tf.a.iter().chain(&tf.b).all(|v| v.is_finite()) {
        return None;
    }
    Model::new(&tf, ts_s)
}

fn noise_label(cfg: &RunConfig) -> String {
    use crate::run::disturbance::NoiseColour;
    let mut out = match (cfg.snr_db, cfg.noise_sd) {
        (_, Some(sd)) => format!(", noise σ = {sd} (seed {})", cfg.seed),
        (Some(snr), None) => format!(", SNR {snr} dB (seed {})", cfg.seed),
        (None, None) => String::new(),
    };
    if let NoiseColour::LowPass { corner_hz } = cfg.noise_colour {
        out.push_str(&format!(", noise low-passed at {corner_hz} Hz"));
    }
    if !cfg.hum.is_empty() {
        out.push_str(&format!(", {} line(s) in y", cfg.hum.len()));
    }
    out
}

/// The JSON document: one object, or an array for several estimators.
fn json(plan: &Plan, reports: &[RunReport]) -> Result<String, CliError> {
    let runs: Vec<JsonRun<'_>> = reports
        .iter()
        .map(|report| JsonRun {
            report,
            modes: plan.modes,
            gains: plan.base.gains.name(),
            ts_s: plan.base.ts_s,
            snr_db: plan.base.snr_db,
            seed: plan.base.seed,
            excitation: plan.base.excitation,
        })
        .collect();
    report::to_json(&runs)
}

/// The human-readable report: a heading, the table, a footnote.
pub fn render(plan: &Plan, reports: &[RunReport]) -> String {
    let Some(first) = reports.first() else {
        return String::new();
    };
    let cfg = &plan.base;
    let n = plan.modes;
    let mut out = String::new();
    out.push_str(&format!(
        "plant:  {}, {n} mode{}\n",
        plan.plant_label,
        if n == 1 { "" } else { "s" }
    ));
    out.push_str(&run_line(
        plan,
        first.samples,
        first.noise_sd,
        Some(cfg.seed),
    ));
    if let Some(b) = &first.crlb {
        out.push_str(&bound_line(b, n));
    }
    if let Some(sc) = &first.scenario {
        out.push_str(&scenario_lines(sc));
    }
    out.push('\n');
    let columns: Vec<report::Column<'_>> = reports
        .iter()
        .map(|r| report::Column {
            name: r.estimator.name(),
            estimate: &r.estimate,
            excitation_min_eig: r.excitation_min_eig,
            feedthrough: r.feedthrough,
            samples: r.samples,
            rejected: r.rejected_samples,
            skipped: r.skipped_updates,
            builds: &r.builds,
            tuning: r.tuning,
            fit_percent: r.fit_percent,
            drift: r.drift_last_10pct,
            ts_s: cfg.ts_s,
            truth: Some(report::TruthColumn {
                time_to_1pct_s: r.time_to_1pct_s,
                time_to_0p1pct_s: r.time_to_0p1pct_s,
                max_error_after_1s: r.max_error_after_1s,
            }),
            bound: None,
            sigma_source: None,
            ratio: r.error_over_crlb.as_ref(),
            robust: r.robust,
            supervision: r.supervision,
            validity: &r.validity,
            guard: r.guard,
            tracking: r
                .scenario
                .as_ref()
                .filter(|s| s.step_at_s.is_some())
                .map(|s| (s.tracking_1pct_s, s.tracking_0p1pct_s)),
            verdict: &r.verdict,
        })
        .collect();
    out.push_str(&report::table(
        n,
        Some(&first.truth),
        first.crlb.as_ref(),
        &columns,
    ));
    out.push_str(&report::verdict_reasons(&columns));
    out.push_str(report::FOOTNOTE_TRUTH);
    out.push_str(report::FOOTNOTE);
    out.push_str(report::FOOTNOTE_GUARD);
    out.push_str(report::FOOTNOTE_VERDICT);
    if reports.iter().any(|r| r.robust.is_some()) {
        out.push_str(report::FOOTNOTE_ROBUST);
    }
    if first.crlb.is_some() {
        out.push_str(report::FOOTNOTE_CRB);
    }
    out
}

/// The "events:" heading lines of a run with a scenario.
pub fn scenario_lines(sc: &crate::run::events::ScenarioReport) -> String {
    let mut parts = Vec::new();
    if let Some(at) = sc.step_at_s {
        parts.push(format!(
            "plant step at {at} s (truth and errors: the new plant's)"
        ));
    }
    if let Some([a, b]) = sc.excitation_off_s {
        parts.push(format!("excitation off {a}–{b} s"));
    }
    if let (Some(f), Some([a, b])) = (sc.fault, sc.fault_window_s) {
        let detected = match (sc.fault_detection_latency_s, sc.fault_detected_as) {
            (Some(l), Some(w)) => format!(
                "flagged as {w} after {} ms",
                crate::io::table::short(l * 1e3, 4)
            ),
            _ => "not flagged by the guard".to_string(),
        };
        parts.push(format!("sensor fault {f} {a}–{b} s, {detected}"));
    }
    parts.push(format!("simulated beam: {} modes", sc.truth_modes));
    format!("events: {}\n", parts.join("; "))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::run::estimator::EstimatorKind;
    use crate::run::plant::PlantSpec;
    use beam_protocol as protocol;
    use clap::Parser;

    fn args(extra: &[&str]) -> SimulateArgs {
        #[derive(Parser)]
        struct T {
            #[command(flatten)]
            a: SimulateArgs,
        }
        let mut v = vec!["t"];
        v.extend_from_slice(extra);
        T::try_parse_from(v).expect("parse").a
    }

    fn err(extra: &[&str]) -> String {
        plan(&args(extra)).expect_err("should fail").to_string()
    }

    #[test]
    fn defaults_are_the_paper_run() {
        let p = plan(&args(&[])).unwrap();
        assert_eq!(p.modes, 2);
        assert_eq!(p.base.plant, PlantSpec::Paper);
        assert_eq!(p.est.kinds, vec![EstimatorKind::Adaptive]);
        assert_eq!(p.base.duration_s, 20.0);
        assert_eq!(p.samples_per_run(), 200_000);
    }

    #[test]
    fn modes_follow_the_lists() {
        let p = plan(&args(&["--omega", "10,100,300"])).unwrap();
        assert_eq!(p.modes, 3);
        let PlantSpec::Modal(m) = p.base.plant else {
            panic!("modal expected")
        };
        assert_eq!(m.omega_rad_s, [10.0, 100.0, 300.0]);
        // ζ defaults from the 3-mode default plant.
        assert_eq!(m.zeta[2], 0.05);
        assert_eq!(m.output_weight[..3], [-2.0, 2.0, -2.0]);
    }

    #[test]
    fn validation_names_the_flag() {
        assert_eq!(
            err(&["--zeta", "-0.1,0.1"]),
            "--zeta: damping ratios must be > 0 (got -0.1)"
        );
        assert!(err(&["--duration", "0"]).starts_with("--duration:"));
        assert!(err(&["--duration", "-1"]).starts_with("--duration:"));
        assert!(err(&["--duration", "inf"]).starts_with("--duration:"));
        assert!(err(&["--duration", "1e-5"]).contains("one sample period"));
        assert!(err(&["--duration", "1e7"]).starts_with("--duration: must be at most"));
        assert!(err(&["--omega", "0,10"]).starts_with("--omega:"));
        assert!(err(&["--omega", "100,10"]).contains("ascending"));
        assert!(err(&["--omega", "NaN,10"]).starts_with("--omega:"));
        assert!(err(&["--modes", "3", "--zeta", "0.1,0.2"]).starts_with("--zeta: expected 3"));
        assert!(err(&["--omega", "1,2", "--bbar", "1"]).starts_with("--bbar: expected 2"));
        assert!(err(&["--modes", "1", "--paper-gains"]).starts_with("--paper-gains:"));
        assert!(err(&["--modes", "3", "--paper-exp-gains"]).starts_with("--paper-exp-gains:"));
        assert!(err(&["--lambda", "0"]).starts_with("--lambda:"));
        assert!(err(&["--band-hz", "5"]).starts_with("--band-hz: expected two"));
        assert!(err(&["--band-hz", "50,5"]).starts_with("--band-hz: need"));
        assert!(err(&["--omega", "1,2,3,4"]).starts_with("--omega: at most 3"));
        assert!(err(&["--plot", "x.svg"]).starts_with("--plot:"));
        assert!(err(&["--weights", "0,1"]).starts_with("--weights:"));
    }

    #[test]
    fn drive_flags_are_the_send_grammar() {
        // None: the paper's square wave, bit for bit today's run.
        let p = plan(&args(&[])).unwrap();
        assert_eq!(p.base.excitation, None);
        assert_eq!(p.base.ts_s, 1e-4);
        let p = plan(&args(&[
            "--wave",
            "multisine",
            "--band",
            "2:80",
            "--tones",
            "8",
            "--ts",
            "2e-4",
        ]))
        .unwrap();
        assert_eq!(
            p.base.excitation,
            Some(protocol::Excitation {
                waveform: protocol::Waveform::Multisine {
                    f_min_hz: 2.0,
                    f_max_hz: 80.0,
                    tones: 8,
                },
                ..protocol::Excitation::default()
            })
        );
        assert_eq!(p.base.ts_s, 2e-4);
        assert!(run_line(&p, 1, None, None).contains(
            "u = the firmware's --wave multisine --band 2:80 --tones 8 --amplitude 0.1 --offset 0"
        ));
        // What is not given is the paper's square wave's.
        let p = plan(&args(&["--amplitude", "0.2"])).unwrap();
        assert_eq!(
            p.base.excitation,
            Some(protocol::Excitation {
                amplitude_v: 0.2,
                ..protocol::Excitation::default()
            })
        );
        assert_eq!(
            err(&["--wave", "prbs", "--bits", "7"]),
            "--wave: --bit-rate is needed for --wave prbs"
        );
        assert!(err(&["--wave", "square", "--amplitude", "20"]).contains("rejected (3)"));
        assert!(
            err(&["--wave", "square", "--freq", "4000", "--ts", "2e-4"]).contains("rejected (4)")
        );
        assert!(err(&["--ts", "0"]).starts_with("--ts:"));
        assert!(err(&["--ts", "nan"]).starts_with("--ts:"));
    }

    #[test]
    fn nan_becomes_null_in_json() {
        // serde_json writes non-finite floats as null, so the output parses.
        let v = serde_json::to_string(&[f64::NAN, f64::INFINITY, 1.5]).unwrap();
        assert_eq!(v, "[null,null,1.5]");
    }
}
