//! `beamctl replay`: the estimator over recorded samples, judged without
//! the truth.
//!
//! # Design
//! * **Same code as the firmware and `simulate`.** Samples go through
//!   [`crate::run::session::Session`]: the same estimators under the same
//!   truth-free tuning rule, stepped one sample at a time in the chosen
//!   precision, so a CSV written by `beamctl simulate --csv` replays to the
//!   simulation's estimates bit for bit.
//! * **Two threads.** One reads and parses the file
//!   ([`crate::io::csv_in::Reader`], no allocation per row) into batches of
//!   [`BATCH`] samples; the other steps the estimators. The batches are
//!   kept (16 bytes per sample) for the model-output fit, which needs the
//!   final model and so a second look at the record.
//! * **Modal recovery at a reduced rate**: every 0.1 s of record time, or
//!   every 1 ms with `--csv`/`--plot` (a recovery costs as much as many
//!   estimator steps: BENCHMARKS.md, "Speed: ns per sample").
//! * **`--crlb`**: the bound at each final estimate (that model driven
//!   from rest by the recorded u; a record that does not start at rest is
//!   bounded as if it did), with σ from `--noise-sd` or the a-posteriori
//!   noise estimate: the robust estimator's output-error residual RMS, for
//!   the other laws the RMS of y − ŷ of the model output fit (which also
//!   holds their bias, so it over-states σ when they are biased).

use crate::cli::args::ReplayArgs;
use crate::cli::estimator_flags::{self, EstimatorPlan};
use crate::error::{note, write_stdout};
use crate::error::{CliError, EXIT_USAGE};
use crate::io::csv_in::{Columns, Reader};
use crate::io::csv_out::CsvOut;
use crate::io::plot::{self, OutputPanel, Recorder};
use crate::io::report::{self, Column};
use crate::judge::bound::{experiment_bound, ExperimentBound, NoiseLevel};
use crate::judge::fit;
use crate::run::estimator::EstimatorKind;
use crate::run::session::Outcome;
use crate::run::session::{drift_every, guard_config, Session};
use crate::run::{Precision, Trace};
use beamest::crlb::ModelSet;
use beamest::model::default_output_weight;
use beamest::tuning::TuningConfig;
use beamest::Real;
use serde::Serialize;
use std::path::Path;
use std::sync::mpsc::sync_channel;

/// Samples per batch handed from the parsing thread.
pub const BATCH: usize = 1 << 16;

/// Validated `replay` settings.
#[derive(Debug, Clone)]
struct Plan {
    est: EstimatorPlan,
    modes: usize,
    weights: Vec<f64>,
    columns: Columns,
    ts_s: Option<f64>,
    /// `--crlb`: the model set and a given σ.
    crlb: Option<(ModelSet, Option<f64>)>,
    /// `--range`.
    range: Option<[f64; 2]>,
    /// `--level-correction`.
    level_correction: bool,
    /// `--residual-monitor`.
    residual_monitor: bool,
}

fn plan(args: &ReplayArgs) -> Result<Plan, CliError> {
    let modes = usize::from(args.modes);
    let est = estimator_flags::plan(&args.est, modes)?;
    if let Some(ts) = args.ts {
        if !(ts.is_finite() && ts > 0.0) {
            return Err(CliError::usage(
                "--ts",
                format!("the sample interval must be a finite number > 0 s (got {ts})"),
            ));
        }
    }
    let columns = match &args.columns {
        None => Columns::default_for(args.ts.is_some()),
        Some(c) => match (c.as_slice(), args.ts.is_some()) {
            ([t, u, y], false) => Columns::named(Some(t), u, y),
            ([u, y], true) => Columns::named(None, u, y),
            (_, false) => {
                return Err(CliError::usage(
                    "--columns",
                    format!("expected three names T,U,Y (got {})", c.len()),
                ))
            }
            (_, true) => {
                return Err(CliError::usage(
                    "--columns",
                    format!("with --ts, expected two names U,Y (got {})", c.len()),
                ))
            }
        },
    };
    let weights = match &args.weights {
        None => (0..modes).map(default_output_weight).collect(),
        Some(w) => {
            if w.len() != modes {
                return Err(CliError::usage(
                    "--weights",
                    format!("expected {modes} values (one per mode), got {}", w.len()),
                ));
            }
            if let Some(&bad) = w.iter().find(|v| !(v.is_finite() && **v != 0.0)) {
                return Err(CliError::usage(
                    "--weights",
                    format!("output weights must be finite and non-zero (got {bad})"),
                ));
            }
            w.clone()
        }
    };
    if let Some(p) = &args.plot {
        plot::check_extension(p)?;
    }
    crate::cli::simulate::plan::check_noise(None, args.noise_sd)?;
    Ok(Plan {
        est,
        modes,
        weights,
        columns,
        ts_s: args.ts,
        crlb: args.crlb.then(|| (args.model_set.set(), args.noise_sd)),
        range: crate::cli::event_flags::range(&args.guard)?,
        level_correction: args.guard.level_correction,
        residual_monitor: args.guard.residual_monitor,
    })
}

/// One replay's report (the JSON object).
#[derive(Debug, Serialize)]
pub struct ReplayReport {
    /// The input file.
    pub file: String,
    /// Update law.
    pub estimator: EstimatorKind,
    /// Float type.
    pub precision: Precision,
    /// Modes identified.
    pub modes: usize,
    /// Gain set.
    pub gains: &'static str,
    /// Sample interval (s).
    pub ts_s: f64,
    /// Data rows read.
    pub samples: u64,
    /// Record length, samples × Ts (s).
    pub duration_s: f64,
    /// Estimate and truth-free metrics.
    #[serde(flatten)]
    pub outcome: Outcome,
    /// With `--crlb`: the Cramér–Rao bound at the final estimate.
    pub crlb: Option<ExperimentBound>,
    /// Where the σ of `crlb` came from: `given` (--noise-sd),
    /// `robust_residual` or `model_output_residual`.
    pub crlb_sigma_source: Option<&'static str>,
}

/// Everything a replay produced, before formatting.
struct Replayed {
    reports: Vec<ReplayReport>,
    series: Vec<plot::Series>,
    output: Option<OutputPanel>,
    csv_rows: Option<u64>,
}

/// Run `beamctl replay`.
pub fn run(args: &ReplayArgs) -> Result<(), CliError> {
    let plan = plan(args)?;
    let input = |e: crate::io::csv_in::CsvError| CliError {
        message: format!("{}: {e}", args.file.display()),
        code: EXIT_USAGE,
    };
    let reader = Reader::open(&args.file, &plan.columns, plan.ts_s).map_err(input)?;
    let names: Vec<&str> = plan.est.kinds.iter().map(|k| k.name()).collect();
    let csv = match &args.csv {
        Some(p) => Some(CsvOut::create(p, plan.modes, &names)?),
        None => None,
    };
    if let Some(p) = &args.plot {
        plot::check_writable(p)?;
    }
    let sized = match (plan.modes, plan.est.precision) {
        (1, Precision::F64) => replay_sized::<f64, 2, 3, 6>,
        (1, Precision::F32) => replay_sized::<f32, 2, 3, 6>,
        (2, Precision::F64) => replay_sized::<f64, 4, 7, 28>,
        (2, Precision::F32) => replay_sized::<f32, 4, 7, 28>,
        (3, Precision::F64) => replay_sized::<f64, 6, 11, 66>,
        _ => replay_sized::<f32, 6, 11, 66>,
    };
    let out = sized(&plan, &args.file, reader, csv, args.plot.is_some())?;
    if let (Some(rows), Some(p)) = (out.csv_rows, &args.csv) {
        note(&format!("wrote {} ({rows} rows)", p.display()));
    }
    if let Some(p) = &args.plot {
        let duration = out.reports.first().map_or(0.0, |r| r.duration_s);
        let title = format!(
            "{} — {} samples, Ts = {} s, {}",
            args.file.display(),
            out.reports.first().map_or(0, |r| r.samples),
            out.reports.first().map_or(f64::NAN, |r| r.ts_s),
            plan.est.lambda_label
        );
        let labelled = plot::write(p, &title, None, &out.series, duration, out.output.as_ref())?;
        let extra = if labelled {
            ""
        } else {
            " (no font found: drawn without text; set BEAMCTL_FONT to a .ttf file)"
        };
        note(&format!("wrote {}{extra}", p.display()));
    }
    let text = if args.json {
        report::to_json(&out.reports)?
    } else {
        render(&plan, &out.reports)
    };
    write_stdout(&text)?;
    report::require_estimates(out.reports.iter().map(|r| {
        (
            r.estimator,
            &r.outcome.estimate,
            r.outcome.tuning,
            r.outcome.law_updates,
        )
    }))
}

fn replay_sized<T: Real, const D: usize, const NP: usize, const NS: usize>(
    plan: &Plan,
    path: &Path,
    mut reader: Reader,
    mut csv: Option<CsvOut>,
    want_plot: bool,
) -> Result<Replayed, CliError> {
    let ts = reader.ts_s();
    let tuning = TuningConfig::new(ts, plan.est.lambda);
    let mut session =
        Session::<T, D, NP, NS>::new(&plan.est.kinds, plan.est.gains, &tuning, &plan.weights)
            .and_then(|s| s.with_guard(&guard_config(ts, plan.range, plan.level_correction)))
            .and_then(|s| s.with_monitor(plan.residual_monitor))
            .map_err(|e| CliError::failure(format!("replay: {e}")))?;
    let dense = csv.is_some() || want_plot;
    let drift = drift_every(ts);
    let every = if dense {
        (1e-3 / ts).round().max(1.0) as u64
    } else {
        drift
    };
    let mut recorders: Vec<Recorder> = if want_plot {
        plan.est
            .kinds
            .iter()
            .map(|k| Recorder::unbounded(k.name(), plan.modes))
            .collect()
    } else {
        Vec::new()
    };
    let file_error = |e: crate::io::csv_in::CsvError| CliError {
        message: format!("{}: {e}", path.display()),
        code: EXIT_USAGE,
    };
    let mut batches: Vec<Vec<(f64, f64)>> = Vec::new();
    let mut k: u64 = 0;
    let mut countdown = every;
    let mut last = (f64::NAN, f64::NAN);
    let mut evaluate = |session: &mut Session<T, D, NP, NS>,
                        k: u64,
                        (u, y): (f64, f64),
                        csv: &mut Option<CsvOut>,
                        last: bool| {
        let t = k as f64 * ts;
        let record = last || (k + 1).is_multiple_of(drift);
        for i in 0..session.len() {
            let e = session.evaluate(i, t, record);
            let trace = Trace {
                estimator: session.kind(i),
                t_s: t,
                u,
                y,
                theta: &e.theta,
                modal: e.modal.as_ref(),
                lambda_rad_s: e.lambda_rad_s,
                max_rel_error: None,
                supervision: session.supervision(i),
                validity: e.validity,
            };
            if let Some(c) = csv.as_mut() {
                c.estimate(i, &trace);
            }
            if let Some(r) = recorders.get_mut(i) {
                r.push(&trace);
            }
        }
        if let Some(c) = csv.as_mut() {
            c.row(t, u, y);
        }
    };
    let mut failed: Option<CliError> = None;
    std::thread::scope(|scope| {
        let (tx, rx) = sync_channel(4);
        scope.spawn(move || loop {
            let mut batch = Vec::with_capacity(BATCH);
            match reader.next_batch(&mut batch, BATCH) {
                Ok(true) => {
                    if tx.send(Ok(batch)).is_err() {
                        return;
                    }
                }
                Ok(false) => return,
                Err(e) => {
                    let _ = tx.send(Err(e));
                    return;
                }
            }
        });
        for msg in rx {
            let batch = match msg {
                Ok(b) => b,
                Err(e) => {
                    failed = Some(file_error(e));
                    return;
                }
            };
            for &(u, y) in &batch {
                let screening = session.step(u, y);
                if let Some(c) = csv.as_mut() {
                    c.screening(&screening);
                }
                // A countdown, not (k + 1) % every: a 64-bit division per
                // sample is a measurable share of the ~70 ns budget.
                countdown -= 1;
                if countdown == 0 {
                    countdown = every;
                    evaluate(&mut session, k, (u, y), &mut csv, false);
                }
                k += 1;
            }
            if let Some(&l) = batch.last() {
                last = l;
            }
            batches.push(batch);
        }
    });
    if let Some(e) = failed {
        return Err(e);
    }
    let n = k;
    if n > 0 {
        // The last sample is always evaluated for the drift; its CSV row
        // only if it was not written already.
        if n.is_multiple_of(every) {
            if !n.is_multiple_of(drift) {
                for i in 0..session.len() {
                    session.evaluate(i, (n - 1) as f64 * ts, true);
                }
            }
        } else {
            evaluate(&mut session, n - 1, last, &mut csv, true);
        }
    }
    let csv_rows = match csv {
        Some(c) => Some(c.finish()?),
        None => None,
    };
    let record = || batches.iter().flatten().copied();
    let end_s = n.saturating_sub(1) as f64 * ts;
    let mut reports = Vec::with_capacity(session.len());
    let mut output = want_plot.then(|| OutputPanel {
        t: Vec::new(),
        y: Vec::new(),
        models: Vec::new(),
    });
    let keep = n.saturating_sub((0.5 / ts).round() as u64)..n;
    for i in 0..session.len() {
        let model = session.model(i, ts);
        let f = model.as_ref().and_then(|m| fit::fit(m, record));
        let outcome = session.outcome(i, end_s, f.as_ref());
        let (crlb, crlb_sigma_source) = match plan.crlb {
            Some((set, given)) => {
                let sigma = match (given, outcome.robust.and_then(|r| r.noise_rms)) {
                    (Some(sd), _) => Some((sd, "given")),
                    (None, Some(sd)) => Some((sd, "robust_residual")),
                    (None, None) => f
                        .as_ref()
                        .map(|f| (f.residual_rms, "model_output_residual")),
                };
                let tf = session.transfer_function(i);
                let bound = match (tf, sigma) {
                    (Some(tf), Some((sd, _))) => experiment_bound(
                        &tf,
                        &plan.weights,
                        ts,
                        record().map(|(u, _)| u),
                        NoiseLevel::Sd(sd),
                        set,
                    )
                    .map_err(|e| e.to_string()),
                    _ => Err("no estimate or no noise estimate".to_string()),
                };
                match bound {
                    Ok(b) => (Some(b), sigma.map(|s| s.1)),
                    Err(e) => {
                        note(&format!(
                            "warning: --crlb: no bound for the {} law: {e}",
                            session.kind(i).name()
                        ));
                        (None, None)
                    }
                }
            }
            None => (None, None),
        };
        if let Some(panel) = output.as_mut() {
            let yhat = match (&model, &f) {
                (Some(m), Some(f)) => fit::model_output(m, f, record(), keep.clone())
                    .into_iter()
                    .map(|o| o.2)
                    .collect(),
                _ => Vec::new(),
            };
            panel.models.push((
                session.kind(i).name().to_string(),
                f.as_ref().map(|f| f.percent),
                yhat,
            ));
        }
        reports.push(ReplayReport {
            file: path.display().to_string(),
            estimator: session.kind(i),
            precision: match std::mem::size_of::<T>() {
                4 => Precision::F32,
                _ => Precision::F64,
            },
            modes: plan.modes,
            gains: plan.est.gains.name(),
            ts_s: ts,
            samples: n,
            duration_s: n as f64 * ts,
            outcome,
            crlb,
            crlb_sigma_source,
        });
    }
    if let Some(panel) = output.as_mut() {
        let window: Vec<(f64, f64)> = record().skip(keep.start as usize).collect();
        panel.t = (keep.start..n).map(|k| k as f64 * ts).collect();
        panel.y = window.iter().map(|s| s.1).collect();
    }
    Ok(Replayed {
        reports,
        series: recorders.into_iter().map(Recorder::finish).collect(),
        output,
        csv_rows,
    })
}

/// The human-readable report.
fn render(plan: &Plan, reports: &[ReplayReport]) -> String {
    let Some(first) = reports.first() else {
        return String::new();
    };
    let mut out = format!(
        "file:   {}\nrecord: {} samples at Ts = {} s ({} s), {} mode{}, {}, {}, {} gains\n",
        first.file,
        first.samples,
        first.ts_s,
        crate::io::table::short(first.duration_s, 6),
        plan.modes,
        if plan.modes == 1 { "" } else { "s" },
        plan.est.lambda_label,
        match first.precision {
            Precision::F64 => "f64",
            Precision::F32 => "f32",
        },
        first.gains
    );
    let columns: Vec<Column<'_>> = reports
        .iter()
        .map(|r| Column {
            name: r.estimator.name(),
            estimate: &r.outcome.estimate,
            excitation_min_eig: r.outcome.excitation_min_eig,
            feedthrough: r.outcome.feedthrough,
            samples: r.samples,
            rejected: r.outcome.rejected_samples,
            skipped: r.outcome.skipped_updates,
            builds: &r.outcome.builds,
            tuning: r.outcome.tuning,
            fit_percent: r.outcome.fit_percent,
            drift: r.outcome.drift_last_10pct,
            ts_s: r.ts_s,
            truth: None,
            bound: r.crlb.as_ref(),
            sigma_source: r.crlb_sigma_source,
            ratio: None,
            robust: r.outcome.robust,
            supervision: r.outcome.supervision,
            validity: &r.outcome.validity,
            guard: r.outcome.guard,
            tracking: None,
        })
        .collect();
    if let Some((set, _)) = plan.crlb {
        out.push_str(&format!(
            "bound:  Cramér–Rao at each final estimate, {}, that model driven from rest by the recorded u\n",
            crate::judge::bound::model_set_description(set, plan.modes)
        ));
    }
    out.push('\n');
    out.push_str(&report::table(plan.modes, None, None, &columns));
    out.push_str(report::FOOTNOTE);
    out.push_str(report::FOOTNOTE_GUARD);
    if reports.iter().any(|r| r.outcome.robust.is_some()) {
        out.push_str(report::FOOTNOTE_ROBUST);
    }
    if plan.crlb.is_some() {
        out.push_str(
            "CRB (rel.): the relative 1σ no unbiased estimator could beat if the estimate were the \
truth, at the noise σ shown: given (--noise-sd), OE residual (the robust estimator's \
output-error residual RMS) or fit residual (RMS of y − ŷ of the model output fit, which holds \
any bias of the estimate too).\n",
        );
    }
    out
}
