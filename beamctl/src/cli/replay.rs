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

use crate::cli::args::{EstimatorChoice, OutputChoice, ReplayArgs};
use crate::cli::estimator_flags::{self, EstimatorPlan};
use crate::error::{note, write_stdout};
use crate::error::{CliError, EXIT_USAGE};
use crate::io::csv_in::{Columns, Reader};
use crate::io::csv_out::CsvOut;
use crate::io::plot::{self, FrfPanel, OutputPanel, Recorder};
use crate::io::report::{self, Column};
use crate::judge::bound::{experiment_bound, ExperimentBound, NoiseLevel};
use crate::judge::fit;
use crate::judge::frf::PowerSpectrum;
use crate::judge::select;
use crate::judge::verdict::{residual_spectrum, RecordEvidence};
use crate::run::estimator::EstimatorKind;
use crate::run::session::Outcome;
use crate::run::session::{drift_every, guard_config, Session};
use crate::run::{Precision, Trace};
use beam_protocol::OutputKind;
use beamest::crlb::ModelSet;
use beamest::model::default_output_weight;
use beamest::tuning::TuningConfig;
use beamest::Real;
use serde::Serialize;
use std::sync::mpsc::sync_channel;

mod colour;
mod lines;
use beamest::guard::lines::LineSpec;
pub use colour::{Prewhitening, MAX_COLOUR_RUNS};
pub use lines::{mains_lines, LineRemoval, MAINS_HARMONICS, MAX_LINE_RUNS, NAMED_TOLERANCE};

/// Samples per batch handed from the parsing thread.
pub const BATCH: usize = 1 << 16;

/// Validated `replay` settings.
#[derive(Debug, Clone)]
struct Plan {
    est: EstimatorPlan,
    modes: usize,
    /// What the sensor measures (the model s^r·B/A).
    output: OutputKind,
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
    /// The lines the guard's output passes the canceller for (the line
    /// pass's second pass; empty otherwise).
    lines: Vec<LineSpec>,
    /// What the report says of them.
    line_removal: LineRemoval,
    /// The noise model whose whitening filter follows the canceller (the
    /// prewhitening pass's runs; `None` otherwise).
    whitening: Option<crate::judge::noise::NoiseModel>,
    /// `--prewhiten`.
    prewhiten: crate::cli::args::PrewhitenChoice,
}

/// The modes of a replay whose flags fix the model: `--modes`, else as
/// many as `--weights` gives, else 2.
fn fixed_modes(args: &ReplayArgs) -> usize {
    match (args.modes, &args.weights) {
        (Some(m), _) => usize::from(m),
        (None, Some(w)) if (1..=3).contains(&w.len()) => w.len(),
        _ => 2,
    }
}

/// The flags' plan; with `--estimator auto` the first candidate's (the
/// choice among the candidates is [`execute_auto`]'s).
fn plan(args: &ReplayArgs) -> Result<Plan, CliError> {
    match candidates(args) {
        Some(c) => c
            .iter()
            .find_map(|c| plan_for(args, Some(*c)).ok())
            .map_or_else(|| plan_for(args, c.first().copied()), Ok),
        None => plan_for(args, None),
    }
}

/// One model `--estimator auto` tries.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub struct Candidate {
    /// Update law.
    pub estimator: EstimatorKind,
    /// Modes of the model.
    pub modes: usize,
    /// The guard's level correction on.
    pub level_correction: bool,
    /// What the sensor measures (the model s^r·B/A).
    #[serde(serialize_with = "crate::run::session::output_name")]
    pub output: OutputKind,
}

impl Candidate {
    /// Parameters a model output fit of it adjusts
    /// ([`crate::judge::select`]): 4N − 1 coefficients, 2N initial-state
    /// coefficients, the feedthrough term's two.
    fn parameters(&self) -> usize {
        6 * self.modes - 1
            + if self.estimator == EstimatorKind::Feedthrough {
                2
            } else {
                0
            }
    }
}

/// With `--estimator auto`: every candidate model, in the rule's
/// preference order (fewer modes, then no level correction, then the
/// output kind — strain, velocity, acceleration — with the robust
/// estimator before the adaptive law, then the feedthrough model, which
/// has two parameters more and models a strain output only); the flags
/// given fix their dimension. `None` when `--estimator` names a law.
pub fn candidates(args: &ReplayArgs) -> Option<Vec<Candidate>> {
    if args.est.estimator != EstimatorChoice::Auto {
        return None;
    }
    let modes: Vec<usize> = match (args.modes, &args.weights) {
        (Some(m), _) => vec![usize::from(m)],
        (None, Some(w)) if (1..=3).contains(&w.len()) => vec![w.len()],
        // A wrong count: the plan's error names it.
        (None, Some(_)) => vec![2],
        (None, None) => vec![1, 2, 3],
    };
    let levels: &[bool] = match (args.guard.level_correction, args.guard.no_level_correction) {
        (true, _) => &[true],
        (_, true) => &[false],
        _ => &[false, true],
    };
    let outputs: &[OutputKind] = match args.est.output {
        OutputChoice::Given(k) => &[k],
        OutputChoice::Auto => &OutputKind::ALL,
    };
    let mut out = Vec::new();
    for &m in &modes {
        for &level_correction in levels {
            for &output in outputs {
                for estimator in [EstimatorKind::Robust, EstimatorKind::Adaptive] {
                    out.push(Candidate {
                        estimator,
                        modes: m,
                        level_correction,
                        output,
                    });
                }
            }
            // Two more parameters: after the models of as many modes.
            if m == 2 && outputs.contains(&OutputKind::Strain) {
                out.push(Candidate {
                    estimator: EstimatorKind::Feedthrough,
                    modes: m,
                    level_correction,
                    output: OutputKind::Strain,
                });
            }
        }
    }
    Some(out)
}

/// The plan of the flags, or of `candidate` in place of the estimator,
/// modes and level-correction flags.
fn plan_for(args: &ReplayArgs, candidate: Option<Candidate>) -> Result<Plan, CliError> {
    let (modes, level_correction, est) = match candidate {
        Some(c) => {
            let mut est = args.est.clone();
            est.estimator = EstimatorChoice::One(c.estimator);
            est.output = OutputChoice::Given(c.output);
            (
                c.modes,
                c.level_correction,
                estimator_flags::plan(&est, c.modes)?,
            )
        }
        None => {
            let modes = fixed_modes(args);
            (
                modes,
                args.guard.level_correction,
                estimator_flags::plan(&args.est, modes)?,
            )
        }
    };
    let output = est.output.or_strain();
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
        output,
        weights,
        columns,
        ts_s: args.ts,
        crlb: args.crlb.then(|| (args.model_set.set(), args.noise_sd)),
        range: crate::cli::event_flags::range(&args.guard)?,
        level_correction,
        residual_monitor: args.guard.residual_monitor,
        lines: args.removing.iter().map(|r| r.0).collect(),
        line_removal: LineRemoval::of(args),
        whitening: args.whitening.clone(),
        prewhiten: args.prewhiten,
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
    /// The guard's level correction was on (the fit and the verdict are
    /// then of the corrected samples).
    pub level_correction: bool,
    /// Gain set.
    pub gains: &'static str,
    /// Sample interval (s).
    pub ts_s: f64,
    /// With `--estimator auto`: how the model was chosen.
    pub selection: Option<Selection>,
    /// The lines in y removed before this estimate (the line pass, docs/REPLAY.md
    /// "Lines in y").
    pub line_removal: LineRemoval,
    /// The coloured-noise pass: whether u and y were prewhitened before
    /// this estimate, and the noise model (docs/REPLAY.md, "Coloured
    /// noise").
    pub prewhitening: Prewhitening,
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
#[derive(Debug)]
pub struct Replayed {
    /// One report per estimator, in run order (the `--json` objects).
    pub reports: Vec<ReplayReport>,
    /// The plotted ω̂, ζ̂ over time (with `--plot`).
    pub series: Vec<plot::Series>,
    /// The model output panel (with `--plot`).
    pub output: Option<OutputPanel>,
    /// The frequency-response row (with `--plot`; `None` if the record has
    /// no frequency with power in u).
    pub frf: Option<FrfPanel>,
    /// Rows written with `--csv`.
    pub csv_rows: Option<u64>,
    /// Every evaluation, one log per estimator, when asked for
    /// ([`ArrayOptions::log_every`]).
    pub logs: Vec<EstimateLog>,
}

/// One estimator's evaluations over a record (the estimate over time), one
/// entry per evaluation; NaN where there is no estimate.
#[derive(Debug, Clone, Default)]
pub struct EstimateLog {
    /// Modes of the model.
    pub modes: usize,
    /// Entries of Θ̂ (4N − 1).
    pub params: usize,
    /// Index of the evaluated sample (from 0).
    pub sample: Vec<u64>,
    /// Time of the evaluated sample (s), `sample × Ts`.
    pub t_s: Vec<f64>,
    /// Θ̂ of eq. 29 (physical units), `params` per evaluation.
    pub theta: Vec<f64>,
    /// ω̂_i (rad/s), `modes` per evaluation.
    pub omega: Vec<f64>,
    /// ζ̂_i, `modes` per evaluation.
    pub zeta: Vec<f64>,
    /// b̂̄_i, `modes` per evaluation.
    pub bbar: Vec<f64>,
    /// λ in use (rad/s), NaN before the estimator is built.
    pub lambda_rad_s: Vec<f64>,
    /// [`beamest::modal::Validity`] bits (0 = valid).
    pub validity: Vec<u8>,
    /// The supervisor's excitation flag (false for an unsupervised law or
    /// before the build).
    pub excited: Vec<bool>,
}

impl EstimateLog {
    /// An empty log for `modes` modes and `params` entries of Θ̂.
    pub fn new(modes: usize, params: usize) -> Self {
        Self {
            modes,
            params,
            ..Self::default()
        }
    }

    /// Append one evaluation.
    pub fn push(&mut self, sample: u64, trace: &Trace<'_>) {
        self.sample.push(sample);
        self.t_s.push(trace.t_s);
        self.theta.extend_from_slice(&trace.theta[..self.params]);
        let n = self.modes;
        match trace.modal.filter(|m| m.modes == n) {
            Some(m) => {
                self.omega.extend_from_slice(&m.omega_rad_s[..n]);
                self.zeta.extend_from_slice(&m.zeta[..n]);
                self.bbar.extend_from_slice(&m.bbar[..n]);
            }
            None => {
                for v in [&mut self.omega, &mut self.zeta, &mut self.bbar] {
                    v.extend(std::iter::repeat_n(f64::NAN, n));
                }
            }
        }
        self.lambda_rad_s
            .push(trace.lambda_rad_s.unwrap_or(f64::NAN));
        self.validity.push(trace.validity);
        self.excited
            .push(trace.supervision.is_some_and(|s| s.excited));
    }

    /// Number of evaluations.
    pub fn len(&self) -> usize {
        self.sample.len()
    }

    /// True without evaluations.
    pub fn is_empty(&self) -> bool {
        self.sample.is_empty()
    }
}

/// Samples between two evaluations for a rate in Hz of record time at
/// sample interval `ts_s` (at least 1): 10 Hz is the drift grid
/// ([`drift_every`]), 1000 Hz the `--csv`/`--plot` grid.
pub fn every_for_rate(rate_hz: f64, ts_s: f64) -> u64 {
    ((1.0 / rate_hz) / ts_s).round().max(1.0) as u64
}

/// How a replay of arrays ([`replay_arrays`]) is run besides its flags.
pub struct ArrayOptions<'a> {
    /// The name reported as `file`.
    pub label: String,
    /// Sample interval (s).
    pub ts_s: f64,
    /// Keep every evaluation in [`Replayed::logs`], evaluating every this
    /// many samples (and at the last sample); `None`: no logs.
    pub log_every: Option<u64>,
    /// Samples stepped between two calls of `interrupt`.
    pub chunk: usize,
    /// Called between chunks; returning true stops the replay with an
    /// error whose code is [`crate::error::EXIT_INTERRUPTED`].
    pub interrupt: &'a mut dyn FnMut() -> bool,
}

/// Where a replay's samples come from.
enum Source<'a> {
    /// The CSV reader (`beamctl replay FILE`), read on its own thread.
    File(Reader),
    /// Two arrays of the same length.
    Arrays {
        u: &'a [f64],
        y: &'a [f64],
        chunk: usize,
        interrupt: &'a mut dyn FnMut() -> bool,
    },
}

/// Run `beamctl replay`.
pub fn run(args: &ReplayArgs) -> Result<(), CliError> {
    let plan = plan(args)?;
    let input = |e: crate::io::csv_in::CsvError| CliError {
        message: format!("{}: {e}", args.file.display()),
        code: EXIT_USAGE,
    };
    let reader = Reader::open(&args.file, &plan.columns, plan.ts_s).map_err(input)?;
    let ts = reader.ts_s();
    let label = args.file.display().to_string();
    let out = lines::execute_with_lines(args, &plan, &label, ts, None, Source::File(reader))?;
    let text = if args.json {
        report::to_json(&out.reports)?
    } else {
        render(&plan, &out.reports)
    };
    write_stdout(&text)?;
    require_trusted(&out.reports)
}

/// Exit status after the report: an error naming the first law that
/// produced no estimate (see [`report::require_estimates`]).
pub fn require_estimates(reports: &[ReplayReport]) -> Result<(), CliError> {
    report::require_estimates(reports.iter().map(|r| {
        (
            r.estimator,
            &r.outcome.estimate,
            r.outcome.tuning,
            r.outcome.law_updates,
        )
    }))
}

/// `beamctl replay`'s exit status after the report: [`require_estimates`],
/// then, when no report's verdict trusts its estimate, an error with the
/// first one's reasons (exit status 1 either way).
fn require_trusted(reports: &[ReplayReport]) -> Result<(), CliError> {
    require_estimates(reports)?;
    if reports.iter().any(|r| r.outcome.verdict.trusted) {
        return Ok(());
    }
    let why = reports
        .first()
        .map(|r| r.outcome.verdict.summary())
        .unwrap_or_default();
    Err(CliError::failure(format!("no trusted estimate: {why}")))
}

/// `beamctl replay` over samples already in memory: `u[k]`, `y[k]` as the
/// file's rows, at the sample interval of `opts`; every flag of `args` as
/// on the command line except the file's own (`FILE.csv` is only the
/// `file` of the report unless `opts.label` says otherwise, `--columns`
/// and `--ts` do not apply). Same session, same evaluation grid, same
/// report as [`run`] on a file holding the same values (the Python
/// package's `beamest.replay`).
///
/// # Errors
/// The flags' errors (as [`run`]'s), `u` and `y` of different lengths or
/// empty, a bad `ts_s`, and [`crate::error::EXIT_INTERRUPTED`].
pub fn replay_arrays(
    args: &ReplayArgs,
    u: &[f64],
    y: &[f64],
    opts: ArrayOptions<'_>,
) -> Result<Replayed, CliError> {
    let plan = plan(args)?;
    if !(opts.ts_s.is_finite() && opts.ts_s > 0.0) {
        return Err(CliError::usage(
            "ts",
            format!(
                "the sample interval must be a finite number > 0 s (got {})",
                opts.ts_s
            ),
        ));
    }
    same_length(u, y)?;
    if u.is_empty() {
        return Err(CliError::usage("u", "no samples (empty arrays)"));
    }
    let source = Source::Arrays {
        u,
        y,
        chunk: opts.chunk.max(1),
        interrupt: opts.interrupt,
    };
    lines::execute_with_lines(args, &plan, &opts.label, opts.ts_s, opts.log_every, source)
}

/// The replay proper: the session over `source`, then `--csv`/`--plot`;
/// with `--estimator auto`, the choice of a model first
/// ([`execute_auto`]).
fn execute(
    args: &ReplayArgs,
    plan: &Plan,
    label: &str,
    ts: f64,
    log_every: Option<u64>,
    source: Source<'_>,
) -> Result<Replayed, CliError> {
    if let Some(c) = candidates(args) {
        return execute_auto(args, &c, label, ts, log_every, source);
    }
    let names: Vec<&str> = plan.est.kinds.iter().map(|k| k.name()).collect();
    let csv = match &args.csv {
        Some(p) => Some(CsvOut::create(p, plan.modes, &names)?),
        None => None,
    };
    if let Some(p) = &args.plot {
        plot::check_writable(p)?;
    }
    let out = sized_for(plan)(plan, label, ts, source, csv, args.plot.is_some(), log_every)?;
    if let (Some(rows), Some(p)) = (out.csv_rows, &args.csv) {
        note(&format!("wrote {} ({rows} rows)", p.display()));
    }
    if let Some(p) = &args.plot {
        let duration = out.reports.first().map_or(0.0, |r| r.duration_s);
        let title = format!(
            "{} — {} samples, Ts = {} s, {}",
            label,
            out.reports.first().map_or(0, |r| r.samples),
            out.reports.first().map_or(f64::NAN, |r| r.ts_s),
            plan.est.lambda_label
        );
        let labelled = plot::write(
            p,
            &title,
            None,
            &out.series,
            duration,
            out.output.as_ref(),
            out.frf.as_ref(),
        )?;
        let extra = if labelled {
            ""
        } else {
            " (no font found: drawn without text; set BEAMCTL_FONT to a .ttf file)"
        };
        note(&format!("wrote {}{extra}", p.display()));
    }
    Ok(out)
}

/// How `--estimator auto` chose the model ([`crate::judge::select`]).
#[derive(Debug, Clone, Serialize)]
pub struct Selection {
    /// The rule: `bic_of_the_output_error`.
    pub rule: &'static str,
    /// Index of the chosen candidate in `candidates`; None if none was
    /// eligible (the report is then the fallback's: the adaptive law,
    /// no level correction, `--modes` or 2 modes).
    pub chosen: Option<usize>,
    /// Every candidate, in the rule's preference order.
    pub candidates: Vec<CandidateReport>,
}

/// One candidate as the rule read it.
#[derive(Debug, Clone, Serialize)]
pub struct CandidateReport {
    /// The model.
    #[serde(flatten)]
    pub candidate: Candidate,
    /// Its better model output fit: on the record as measured or after
    /// the level correction ([`crate::judge::select`], step 2).
    pub fit_percent: Option<f64>,
    /// Which record that fit is of: `measured` or `level_corrected`.
    pub fit_on: Option<&'static str>,
    /// BIC and why it could not be chosen, if so.
    #[serde(flatten)]
    pub score: crate::judge::select::Score,
}

/// The samples a replay is judged on when the guard changes them: its
/// output with `level_correction` (offset steps removed, u and y through
/// the same DC-removing high-pass), then through the line canceller of
/// `lines` (if any) and the whitening filter `whitening` (if any), a
/// faulty y as NaN; the guard's delay line drops the last few samples.
fn conditioned(
    samples: impl Iterator<Item = (f64, f64)>,
    ts: f64,
    range: Option<[f64; 2]>,
    level_correction: bool,
    lines: &[LineSpec],
    whitening: Option<&[f64]>,
) -> Result<Vec<(f64, f64)>, CliError> {
    let fail = |e: &dyn std::fmt::Display| CliError::failure(format!("replay: {e}"));
    let mut guard =
        beamest::guard::SensorGuard::<f64>::new(&guard_config(ts, range, level_correction))
            .map_err(|e| fail(&e))?;
    let mut canceller = match lines {
        [] => None,
        l => Some(
            beamest::guard::lines::LineCanceller::<f64, { beamest::guard::lines::MAX_LINES }>::new(
                l,
                ts,
                beamest::guard::lines::DEFAULT_LINE_TIME_CONSTANT_S,
            )
            .map_err(|e| fail(&e))?,
        ),
    };
    let mut whitener = whitening.map(crate::judge::noise::Whitener::new);
    let mut out = Vec::with_capacity(samples.size_hint().0);
    for (u, y) in samples {
        if let Some(g) = guard.push(u, y) {
            let (u, y) = g.for_estimator();
            let (u, y) = match canceller.as_mut() {
                Some(c) => c.push(u, y),
                None => (u, y),
            };
            out.push(match whitener.as_mut() {
                Some(w) => w.push(u, y),
                None => (u, y),
            });
        }
    }
    Ok(out)
}

/// `--estimator auto`: every candidate over the record (as many at once
/// as there are cores), each judged on the measured and the
/// level-corrected samples, the rule's choice ([`crate::judge::select`]),
/// then the chosen flags' replay (so its report is exactly that of those
/// flags given by hand; the candidate's own run when it is that replay
/// already) with the selection attached.
fn execute_auto(
    args: &ReplayArgs,
    candidates: &[Candidate],
    label: &str,
    ts: f64,
    log_every: Option<u64>,
    source: Source<'_>,
) -> Result<Replayed, CliError> {
    use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
    use std::sync::Mutex;
    let mut owned: (Vec<f64>, Vec<f64>) = (Vec::new(), Vec::new());
    let mut never = || false;
    let (u, y, chunk, interrupt) = in_memory(source, label, &mut owned, &mut never)?;
    let range = crate::cli::event_flags::range(&args.guard)?;
    let lines: Vec<LineSpec> = args.removing.iter().map(|r| r.0).collect();
    let pairs = || u.iter().copied().zip(y.iter().copied());
    let with_band = record_band(args, pairs(), ts);
    let args = &with_band;
    let whitening = args.whitening.as_ref().map(|m| m.whitening.as_slice());
    let judged = conditioned(pairs(), ts, range, true, &lines, whitening)?;
    let measured = match (lines.as_slice(), whitening) {
        ([], None) => None,
        (l, w) => Some(conditioned(pairs(), ts, range, false, l, w)?),
    };
    let stop = AtomicBool::new(false);
    let next = AtomicUsize::new(0);
    let done = AtomicUsize::new(0);
    let results: Mutex<Vec<Option<Result<Judged, CliError>>>> =
        Mutex::new(candidates.iter().map(|_| None).collect());
    let workers = std::thread::available_parallelism()
        .map_or(1, |n| n.get())
        .min(candidates.len());
    let work = || loop {
        let i = next.fetch_add(1, Ordering::Relaxed);
        let Some(&c) = candidates.get(i) else {
            return;
        };
        let r = candidate_evidence(
            args,
            c,
            label,
            ts,
            (u, y),
            (measured.as_deref(), &judged),
            &stop,
        );
        if let Ok(mut all) = results.lock() {
            if let Some(slot) = all.get_mut(i) {
                *slot = Some(r);
            }
        }
        done.fetch_add(1, Ordering::Release);
    };
    std::thread::scope(|scope| {
        // The robust estimator's record passes through the stack
        // (`ROBUST_STACK_BYTES`).
        let spawned = (0..workers)
            .filter(|_| {
                std::thread::Builder::new()
                    .stack_size(crate::run::estimator::ROBUST_STACK_BYTES)
                    .spawn_scoped(scope, work)
                    .is_ok()
            })
            .count();
        if spawned == 0 {
            work();
        }
        while done.load(Ordering::Acquire) < candidates.len() {
            if !stop.load(Ordering::Relaxed) && interrupt() {
                stop.store(true, Ordering::Relaxed);
            }
            std::thread::sleep(std::time::Duration::from_millis(10));
        }
    });
    if stop.load(Ordering::Relaxed) {
        return Err(CliError::interrupted("replay"));
    }
    let results = results
        .into_inner()
        .map_err(|_| CliError::failure("replay: a candidate's run panicked"))?;
    let mut fits = Vec::with_capacity(candidates.len());
    let mut evidence = Vec::with_capacity(candidates.len());
    let mut runs = Vec::with_capacity(candidates.len());
    for r in results {
        let (fit, e, run) = match r {
            Some(Ok((fit, e, run))) => (fit, e, Some(run)),
            Some(Err(e)) if e.code == crate::error::EXIT_INTERRUPTED => return Err(e),
            // A candidate the flags rule out (e.g. --paper-gains with 1 mode).
            Some(Err(_)) | None => (
                None,
                select::Evidence {
                    excluded: Some("not_applicable"),
                    relative_residual: None,
                    parameters: 0,
                },
                None,
            ),
        };
        fits.push(fit);
        evidence.push(e);
        runs.push(run);
    }
    let (scores, chosen) = select::choose(&evidence, judged.len());
    let fallback = candidates
        .iter()
        .position(|c| {
            c.estimator == EstimatorKind::Adaptive
                && c.modes == fixed_modes(args)
                && !c.level_correction
        })
        .unwrap_or(0);
    let index = chosen.unwrap_or(fallback);
    let pick = candidates
        .get(index)
        .copied()
        .ok_or_else(|| CliError::failure("replay: no candidate model"))?;
    let mut fixed = args.clone();
    fixed.est.estimator = EstimatorChoice::One(pick.estimator);
    fixed.modes = u8::try_from(pick.modes).ok();
    fixed.guard.level_correction = pick.level_correction;
    fixed.guard.no_level_correction = !pick.level_correction;
    fixed.est.output = OutputChoice::Given(pick.output);
    let plan = plan_for(&fixed, None)?;
    // The candidate's run is that replay already, unless the report needs
    // more than a candidate computes (the CSV, the plot, the logs, the bound).
    let reusable = args.csv.is_none() && args.plot.is_none() && log_every.is_none() && !args.crlb;
    let mut out = match runs.get_mut(index).and_then(Option::take) {
        Some(run) if reusable => run,
        _ => execute(
            &fixed,
            &plan,
            label,
            ts,
            log_every,
            Source::Arrays {
                u,
                y,
                chunk,
                interrupt,
            },
        )?,
    };
    let selection = Selection {
        rule: "bic_of_the_output_error",
        chosen,
        candidates: candidates
            .iter()
            .zip(fits)
            .zip(scores)
            .map(|((c, fit), score)| CandidateReport {
                candidate: *c,
                fit_percent: fit.map(|f| f.0),
                fit_on: fit.map(|f| f.1),
                score,
            })
            .collect(),
    };
    for r in &mut out.reports {
        r.selection = Some(selection.clone());
    }
    Ok(out)
}

/// `args` with the first λ taken from the whole record when the flags
/// leave it to the data: the tuning rule's data λ (docs/SETTINGS.md: twice
/// the noise-corrected frequency centroid of y) over every sample instead
/// of the first 0.2 s, given as `--band-hz F,F` (re-centred as any band).
/// A record whose excitation sweeps (a chirp that starts below the modes)
/// or starts with a pulse shows its modes only later; model selection has
/// the record in memory, so it uses all of it.
fn record_band(
    args: &ReplayArgs,
    samples: impl Iterator<Item = (f64, f64)>,
    ts: f64,
) -> ReplayArgs {
    let mut out = args.clone();
    let e = &args.est;
    if e.lambda.is_some()
        || e.band_hz.is_some()
        || e.beam.is_some()
        || e.paper_gains
        || e.paper_exp_gains
    {
        return out;
    }
    let mut stats = beamest::tuning::StartupStats::new(ts);
    for (u, y) in samples {
        stats.push(u, y);
    }
    let tuning = TuningConfig::new(ts, beamest::tuning::LambdaSource::Data);
    if let Some(c) = stats.centroid_rad_s(ts) {
        let lambda = (tuning.data_lambda_factor * c).clamp(
            beamest::tuning::MIN_LAMBDA_TS / ts,
            beamest::tuning::MAX_LAMBDA_TS / ts,
        );
        let f = lambda / std::f64::consts::TAU;
        out.est.band_hz = Some(vec![f, f]);
    }
    out
}

/// The record of `source` in memory: its u, y, batch size and interrupt
/// poll (a file is read into `owned` and polls `never`).
#[allow(clippy::type_complexity)]
fn in_memory<'s: 'o, 'o>(
    source: Source<'s>,
    label: &str,
    owned: &'o mut (Vec<f64>, Vec<f64>),
    never: &'o mut dyn FnMut() -> bool,
) -> Result<(&'o [f64], &'o [f64], usize, &'o mut dyn FnMut() -> bool), CliError> {
    match source {
        Source::File(reader) => {
            let (ou, oy) = (&mut owned.0, &mut owned.1);
            read_file(reader, label, |batch| {
                ou.extend(batch.iter().map(|s| s.0));
                oy.extend(batch.iter().map(|s| s.1));
            })?;
            Ok((&owned.0, &owned.1, BATCH, never))
        }
        Source::Arrays {
            u,
            y,
            chunk,
            interrupt,
        } => {
            let interrupt: &'o mut dyn FnMut() -> bool = interrupt;
            Ok((u, y, chunk, interrupt))
        }
    }
}

/// Samples as (u, y) pairs.
type Pairs<'a> = &'a [(f64, f64)];

/// A candidate's better fit (percent, and on which record), what the rule
/// knows of it, and its replay.
type Judged = (Option<(f64, &'static str)>, select::Evidence, Replayed);

/// One candidate's replay (no `--csv`, `--plot`, logs) and what the rule
/// needs of it: its better fit percentage, on the record as measured
/// (`u`, `y`, or `measured` when lines are removed from it) or
/// level-corrected (`judged`), which one, and its evidence.
fn candidate_evidence(
    args: &ReplayArgs,
    c: Candidate,
    label: &str,
    ts: f64,
    (u, y): (&[f64], &[f64]),
    (measured, judged): (Option<Pairs<'_>>, Pairs<'_>),
    stop: &std::sync::atomic::AtomicBool,
) -> Result<Judged, CliError> {
    let mut plan = plan_for(args, Some(c))?;
    // The bound is the chosen model's only (execute_auto's final run).
    plan.crlb = None;
    let mut stopped = || stop.load(std::sync::atomic::Ordering::Relaxed);
    let out = sized_for(&plan)(
        &plan,
        label,
        ts,
        Source::Arrays {
            u,
            y,
            chunk: BATCH,
            interrupt: &mut stopped,
        },
        None,
        false,
        None,
    )?;
    let report = out
        .reports
        .first()
        .ok_or_else(|| CliError::failure("replay: a candidate made no report"))?;
    let e = &report.outcome.estimate;
    // Every mode of the model, those reported apart above the band too.
    let above = &report.outcome.residual_modes;
    let zeta: Vec<f64> = e
        .zeta
        .iter()
        .copied()
        .chain(above.iter().map(|m| m.zeta))
        .collect();
    let omega: Vec<f64> = e
        .omega
        .iter()
        .copied()
        .chain(above.iter().map(|m| m.omega))
        .collect();
    let excluded = if !e.is_valid() {
        Some("no_estimate")
    } else {
        report
            .outcome
            .validity
            .first()
            .copied()
            .or_else(|| select::overdamped(&zeta))
            .or_else(|| select::slower_than_record(&omega, report.duration_s))
    };
    let model = excluded
        .is_none()
        .then(|| summary_model(&report.outcome, ts))
        .flatten();
    let raw = model.as_ref().and_then(|m| match measured {
        Some(r) => fit::fit(m, || r.iter().copied()),
        None => fit::fit(m, || u.iter().copied().zip(y.iter().copied())),
    });
    let corrected = model
        .as_ref()
        .and_then(|m| fit::fit(m, || judged.iter().copied()));
    let best = match (raw, corrected) {
        (Some(a), Some(b)) => Some(if a.percent >= b.percent {
            (a.percent, "measured")
        } else {
            (b.percent, "level_corrected")
        }),
        (Some(a), None) => Some((a.percent, "measured")),
        (None, Some(b)) => Some((b.percent, "level_corrected")),
        (None, None) => None,
    };
    let evidence = select::Evidence {
        excluded,
        relative_residual: best.map(|(p, _)| 1.0 - p / 100.0),
        parameters: c.parameters(),
    };
    Ok((best, evidence, out))
}

/// The reported model of an outcome (with its residual terms, if any),
/// for a fit.
fn summary_model(o: &Outcome, ts: f64) -> Option<fit::Model> {
    let e = &o.estimate;
    // The model's order (its modes above the band included).
    let n = e.a.len() / 2;
    let mut tf = beamest::model::TransferFunction::<f64> {
        modes: n,
        a: [0.0; beamest::model::MAX_ORDER],
        b: [0.0; beamest::model::MAX_ORDER],
        output: e.output,
    };
    tf.a.get_mut(..e.a.len())?.copy_from_slice(&e.a);
    tf.b.get_mut(..e.b.len())?.copy_from_slice(&e.b);
    match (o.numerator_s3, o.feedthrough) {
        (Some(s3), Some(d)) => fit::Model::with_residual(&tf, ts, s3, d),
        _ => fit::Model::new(&tf, ts),
    }
}

/// The sized replay for a plan's modes and precision.
type Sized = fn(
    &Plan,
    &str,
    f64,
    Source<'_>,
    Option<CsvOut>,
    bool,
    Option<u64>,
) -> Result<Replayed, CliError>;

fn sized_for(plan: &Plan) -> Sized {
    match (plan.modes, plan.est.precision) {
        (1, Precision::F64) => replay_sized::<f64, 2, 3, 6>,
        (1, Precision::F32) => replay_sized::<f32, 2, 3, 6>,
        (2, Precision::F64) => replay_sized::<f64, 4, 7, 28>,
        (2, Precision::F32) => replay_sized::<f32, 4, 7, 28>,
        (3, Precision::F64) => replay_sized::<f64, 6, 11, 66>,
        _ => replay_sized::<f32, 6, 11, 66>,
    }
}

/// An evaluation grid: every `every` samples, the first at sample
/// `every − 1`. A countdown, not (k + 1) % every: a 64-bit division per
/// sample is a measurable share of the ~70 ns budget.
#[derive(Debug, Clone, Copy)]
struct Grid {
    every: u64,
    countdown: u64,
}

impl Grid {
    fn new(every: u64) -> Self {
        let every = every.max(1);
        Self {
            every,
            countdown: every,
        }
    }

    /// Count one sample; true if it is on the grid.
    #[inline]
    fn tick(&mut self) -> bool {
        self.countdown -= 1;
        if self.countdown == 0 {
            self.countdown = self.every;
            true
        } else {
            false
        }
    }

    /// True if the last sample counted was on the grid.
    fn just_hit(&self) -> bool {
        self.countdown == self.every
    }
}

/// The session and what is kept while the samples go through it.
struct Stepper<T: Real, const D: usize, const NP: usize, const NS: usize> {
    session: Session<T, D, NP, NS>,
    ts: f64,
    /// The `--csv`/`--plot` grid (1 kHz with either, else the drift grid).
    traces: Grid,
    /// The evaluations kept for the drift (0.1 s of record).
    drift: Grid,
    /// The evaluations kept in `logs`, if any.
    log: Option<Grid>,
    /// Samples stepped.
    k: u64,
    /// The last sample stepped.
    last: (f64, f64),
    csv: Option<CsvOut>,
    recorders: Vec<Recorder>,
    logs: Vec<EstimateLog>,
}

/// What an evaluation is for.
#[derive(Debug, Clone, Copy)]
struct Uses {
    /// The CSV row and the plot's point.
    traced: bool,
    /// The drift's history.
    recorded: bool,
    /// The logs.
    logged: bool,
}

impl<T: Real, const D: usize, const NP: usize, const NS: usize> Stepper<T, D, NP, NS> {
    /// Step every sample of `samples`.
    #[inline]
    fn feed(&mut self, samples: impl Iterator<Item = (f64, f64)>) {
        for (u, y) in samples {
            let screening = self.session.step(u, y);
            if let Some(c) = self.csv.as_mut() {
                c.screening(&screening);
            }
            let uses = Uses {
                traced: self.traces.tick(),
                recorded: self.drift.tick(),
                logged: self.log.as_mut().is_some_and(Grid::tick),
            };
            if uses.traced || uses.recorded || uses.logged {
                self.evaluate(self.k, (u, y), uses);
            }
            self.k += 1;
            self.last = (u, y);
        }
    }

    /// Evaluate every estimator at sample `k` for `uses`.
    fn evaluate(&mut self, k: u64, (u, y): (f64, f64), uses: Uses) {
        let t = k as f64 * self.ts;
        for i in 0..self.session.len() {
            let e = self.session.evaluate(i, t, uses.recorded);
            if !(uses.traced || uses.logged) {
                continue;
            }
            let trace = Trace {
                estimator: self.session.kind(i),
                t_s: t,
                u,
                y,
                theta: &e.theta,
                modal: e.modal.as_ref(),
                lambda_rad_s: e.lambda_rad_s,
                max_rel_error: None,
                supervision: self.session.supervision(i),
                validity: e.validity,
            };
            if uses.traced {
                if let Some(c) = self.csv.as_mut() {
                    c.estimate(i, &trace);
                }
                if let Some(r) = self.recorders.get_mut(i) {
                    r.push(&trace);
                }
            }
            if uses.logged {
                if let Some(l) = self.logs.get_mut(i) {
                    l.push(k, &trace);
                }
            }
        }
        if uses.traced {
            if let Some(c) = self.csv.as_mut() {
                c.row(t, u, y);
            }
        }
    }

    /// After the last sample: it is always evaluated for the drift, traced
    /// and logged, if it was not already.
    fn end(&mut self) {
        let n = self.k;
        if n == 0 {
            return;
        }
        let uses = Uses {
            traced: !self.traces.just_hit(),
            recorded: !self.drift.just_hit(),
            logged: self.log.is_some_and(|g| !g.just_hit()),
        };
        if uses.traced || uses.recorded || uses.logged {
            self.evaluate(n - 1, self.last, uses);
        }
    }
}

impl<T: Real, const D: usize, const NP: usize, const NS: usize> Stepper<T, D, NP, NS> {
    /// The session of `plan` at sample interval `ts`, traced on the
    /// `--csv`/`--plot` grid (1 kHz) when `csv` or `want_plot`, its drift
    /// kept every 0.1 s, and every `log_every` samples into logs.
    fn new(
        plan: &Plan,
        ts: f64,
        csv: Option<CsvOut>,
        want_plot: bool,
        log_every: Option<u64>,
    ) -> Result<Self, CliError> {
        let tuning = TuningConfig {
            output: plan.output,
            ..TuningConfig::new(ts, plan.est.lambda)
        };
        let session =
            Session::<T, D, NP, NS>::new(&plan.est.kinds, plan.est.gains, &tuning, &plan.weights)
                .and_then(|s| s.with_guard(&guard_config(ts, plan.range, plan.level_correction)))
                .and_then(|s| s.with_lines(&plan.lines))
                .map(|s| s.with_whitener(plan.whitening.as_ref().map(|m| m.whitening.as_slice())))
                .and_then(|s| s.with_monitor(plan.residual_monitor))
                .map_err(|e| CliError::failure(format!("replay: {e}")))?;
        let dense = csv.is_some() || want_plot;
        let drift = drift_every(ts);
        let traces = if dense {
            every_for_rate(1e3, ts)
        } else {
            drift
        };
        let recorders: Vec<Recorder> = if want_plot {
            plan.est
                .kinds
                .iter()
                .map(|k| Recorder::unbounded(k.name(), plan.modes))
                .collect()
        } else {
            Vec::new()
        };
        let logs = match log_every {
            Some(_) => vec![EstimateLog::new(plan.modes, NP); plan.est.kinds.len()],
            None => Vec::new(),
        };
        Ok(Self {
            session,
            ts,
            traces: Grid::new(traces),
            drift: Grid::new(drift),
            log: log_every.map(Grid::new),
            k: 0,
            last: (f64::NAN, f64::NAN),
            csv,
            recorders,
            logs,
        })
    }
}

fn replay_sized<T: Real, const D: usize, const NP: usize, const NS: usize>(
    plan: &Plan,
    label: &str,
    ts: f64,
    source: Source<'_>,
    csv: Option<CsvOut>,
    want_plot: bool,
    log_every: Option<u64>,
) -> Result<Replayed, CliError> {
    let mut st = Stepper::<T, D, NP, NS>::new(plan, ts, csv, want_plot, log_every)?;
    match source {
        Source::File(reader) => {
            let mut batches: Vec<Vec<(f64, f64)>> = Vec::new();
            read_file(reader, label, |batch| {
                st.feed(batch.iter().copied());
                batches.push(batch);
            })?;
            st.end();
            if plan.level_correction || !plan.lines.is_empty() || plan.whitening.is_some() {
                let c = conditioned(
                    batches.iter().flatten().copied(),
                    ts,
                    plan.range,
                    plan.level_correction,
                    &plan.lines,
                    plan.whitening.as_ref().map(|m| m.whitening.as_slice()),
                )?;
                return judge(plan, label, st, || c.iter().copied());
            }
            judge(plan, label, st, || batches.iter().flatten().copied())
        }
        Source::Arrays {
            u,
            y,
            chunk,
            interrupt,
        } => {
            for (cu, cy) in u.chunks(chunk).zip(y.chunks(chunk)) {
                st.feed(cu.iter().copied().zip(cy.iter().copied()));
                if interrupt() {
                    return Err(CliError::interrupted("replay"));
                }
            }
            st.end();
            if plan.level_correction || !plan.lines.is_empty() || plan.whitening.is_some() {
                let c = conditioned(
                    u.iter().copied().zip(y.iter().copied()),
                    ts,
                    plan.range,
                    plan.level_correction,
                    &plan.lines,
                    plan.whitening.as_ref().map(|m| m.whitening.as_slice()),
                )?;
                return judge(plan, label, st, || c.iter().copied());
            }
            judge(plan, label, st, || u.iter().copied().zip(y.iter().copied()))
        }
    }
}

/// An estimator's model for the FRF row, owned.
type FrfEntry = (String, Option<fit::Model>, Option<f64>, Vec<(f64, f64)>);

fn frf_inputs(m: &[FrfEntry]) -> Vec<plot::FrfInput<'_>> {
    m.iter()
        .map(|(name, model, fit_percent, modes)| plot::FrfInput {
            name: name.clone(),
            model: model.as_ref(),
            fit_percent: *fit_percent,
            modes: modes.clone(),
        })
        .collect()
}

/// Read the file on its own thread, handing each batch to `each` in order.
fn read_file(
    mut reader: Reader,
    label: &str,
    mut each: impl FnMut(Vec<(f64, f64)>),
) -> Result<(), CliError> {
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
            match msg {
                Ok(b) => each(b),
                Err(e) => {
                    failed = Some(CliError {
                        message: format!("{label}: {e}"),
                        code: EXIT_USAGE,
                    });
                    return;
                }
            }
        }
    });
    match failed {
        Some(e) => Err(e),
        None => Ok(()),
    }
}

/// The reports once every sample is stepped: each estimator's model, its
/// fit over the record (`record` yields it again, from the start), the
/// bound, the plot's panels.
fn judge<T: Real, const D: usize, const NP: usize, const NS: usize, I>(
    plan: &Plan,
    label: &str,
    st: Stepper<T, D, NP, NS>,
    record: impl Fn() -> I,
) -> Result<Replayed, CliError>
where
    I: Iterator<Item = (f64, f64)>,
{
    let Stepper {
        session,
        ts,
        k: n,
        csv,
        recorders,
        logs,
        ..
    } = st;
    let want_plot = !recorders.is_empty();
    let csv_rows = match csv {
        Some(c) => Some(c.finish()?),
        None => None,
    };
    let end_s = n.saturating_sub(1) as f64 * ts;
    let mut reports = Vec::with_capacity(session.len());
    let mut output = want_plot.then(|| OutputPanel {
        t: Vec::new(),
        y: Vec::new(),
        models: Vec::new(),
    });
    let keep = n.saturating_sub((0.5 / ts).round() as u64)..n;
    let mut frf_models: Vec<FrfEntry> = Vec::new();
    let input = PowerSpectrum::of(record().map(|(u, _)| u), n as usize, ts);
    for i in 0..session.len() {
        let model = session.model(i, ts);
        let f = model.as_ref().and_then(|m| fit::fit(m, &record));
        let residual = model
            .as_ref()
            .zip(f.as_ref())
            .and_then(|(m, f)| residual_spectrum(m, f, record(), n as usize, ts));
        let outcome = session.outcome(
            i,
            end_s,
            &RecordEvidence {
                fit: f.as_ref(),
                input: input.as_ref(),
                residual: residual.as_ref(),
            },
        );
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
            let e = &outcome.estimate;
            frf_models.push((
                session.kind(i).name().to_string(),
                model.clone(),
                f.as_ref().map(|f| f.percent),
                e.omega
                    .iter()
                    .copied()
                    .zip(e.zeta.iter().copied())
                    .collect::<Vec<_>>(),
            ));
        }
        reports.push(ReplayReport {
            file: label.to_string(),
            estimator: session.kind(i),
            precision: match std::mem::size_of::<T>() {
                4 => Precision::F32,
                _ => Precision::F64,
            },
            modes: plan.modes,
            level_correction: plan.level_correction,
            gains: plan.est.gains.name(),
            ts_s: ts,
            selection: None,
            line_removal: plan.line_removal.clone(),
            prewhitening: Prewhitening::of(plan),
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
    let frf = if want_plot {
        let (u, y): (Vec<f64>, Vec<f64>) = record().unzip();
        crate::judge::frf::h1(&u, &y, ts, None)
            .map(|h| FrfPanel::new(h, &frf_inputs(&frf_models), ts))
    } else {
        None
    };
    Ok(Replayed {
        reports,
        series: recorders.into_iter().map(Recorder::finish).collect(),
        output,
        frf,
        csv_rows,
        logs,
    })
}

/// A replay fed chunk by chunk (the Python package's `beamest.Estimator`):
/// the session of [`replay_arrays`] (sensor guard, tuning rule, the
/// laws), its evaluations handed back as they happen. How the samples are
/// split into chunks changes nothing: they are stepped one at a time.
pub struct Stream {
    inner: Box<dyn StreamSteps>,
    plan: Plan,
    ts_s: f64,
}

trait StreamSteps: Send {
    fn feed(&mut self, u: &[f64], y: &[f64]) -> Vec<EstimateLog>;
    fn samples(&self) -> u64;
    fn reports(&self, plan: &Plan, label: &str, record: Option<Record<'_>>) -> Vec<ReplayReport>;
}

/// Drive and sensor samples a streaming report's fit is computed over.
#[derive(Clone, Copy)]
pub struct Record<'a> {
    /// Drive, one per sample.
    pub u: &'a [f64],
    /// Sensor, one per sample.
    pub y: &'a [f64],
}

impl<T: Real, const D: usize, const NP: usize, const NS: usize> StreamSteps
    for Stepper<T, D, NP, NS>
{
    fn feed(&mut self, u: &[f64], y: &[f64]) -> Vec<EstimateLog> {
        Stepper::feed(self, u.iter().copied().zip(y.iter().copied()));
        self.logs
            .iter_mut()
            .map(|l| std::mem::replace(l, EstimateLog::new(l.modes, l.params)))
            .collect()
    }

    fn samples(&self) -> u64 {
        self.k
    }

    fn reports(&self, plan: &Plan, label: &str, record: Option<Record<'_>>) -> Vec<ReplayReport> {
        let n = self.k;
        let end_s = n.saturating_sub(1) as f64 * self.ts;
        let input = record.and_then(|r| PowerSpectrum::of(r.u.iter().copied(), r.u.len(), self.ts));
        (0..self.session.len())
            .map(|i| {
                let judged = record.and_then(|r| {
                    let model = self.session.model(i, self.ts)?;
                    let samples = || r.u.iter().copied().zip(r.y.iter().copied());
                    let fit = fit::fit(&model, samples)?;
                    let residual = residual_spectrum(&model, &fit, samples(), r.u.len(), self.ts);
                    Some((fit, residual))
                });
                (i, judged)
            })
            .map(|(i, judged)| ReplayReport {
                file: label.to_string(),
                estimator: self.session.kind(i),
                precision: match std::mem::size_of::<T>() {
                    4 => Precision::F32,
                    _ => Precision::F64,
                },
                modes: plan.modes,
                level_correction: plan.level_correction,
                gains: plan.est.gains.name(),
                ts_s: self.ts,
                selection: None,
                line_removal: LineRemoval {
                    mode: "off",
                    removed: Vec::new(),
                },
                prewhitening: Prewhitening::default(),
                samples: n,
                duration_s: n as f64 * self.ts,
                outcome: self.session.outcome(
                    i,
                    end_s,
                    &RecordEvidence {
                        fit: judged.as_ref().map(|j| &j.0),
                        input: input.as_ref(),
                        residual: judged.as_ref().and_then(|j| j.1.as_ref()),
                    },
                ),
                crlb: None,
                crlb_sigma_source: None,
            })
            .collect()
    }
}

impl Stream {
    /// A session with the flags of `args` (as [`replay_arrays`]; not
    /// `--csv`, `--plot`, `--crlb`) at sample interval `ts_s`, evaluating
    /// every `every` samples (the first evaluation at sample `every − 1`).
    ///
    /// # Errors
    /// The flags' errors, a bad `ts_s`, a flag that does not apply.
    pub fn new(args: &ReplayArgs, ts_s: f64, every: u64) -> Result<Self, CliError> {
        // A stream cannot choose among candidates before it has the
        // record: `auto` is the adaptive law, `--modes` or 2 modes.
        let plan = plan_for(args, None)?;
        if !(ts_s.is_finite() && ts_s > 0.0) {
            return Err(CliError::usage(
                "ts",
                format!("the sample interval must be a finite number > 0 s (got {ts_s})"),
            ));
        }
        for (given, flag) in [
            (args.csv.is_some(), "--csv"),
            (args.plot.is_some(), "--plot"),
            (args.crlb, "--crlb"),
        ] {
            if given {
                return Err(CliError::usage(
                    flag,
                    "not available for a streaming estimator (use replay)",
                ));
            }
        }
        fn make<T: Real, const D: usize, const NP: usize, const NS: usize>(
            plan: &Plan,
            ts: f64,
            every: u64,
        ) -> Result<Box<dyn StreamSteps>, CliError> {
            Ok(Box::new(Stepper::<T, D, NP, NS>::new(
                plan,
                ts,
                None,
                false,
                Some(every),
            )?))
        }
        let inner = match (plan.modes, plan.est.precision) {
            (1, Precision::F64) => make::<f64, 2, 3, 6>(&plan, ts_s, every)?,
            (1, Precision::F32) => make::<f32, 2, 3, 6>(&plan, ts_s, every)?,
            (2, Precision::F64) => make::<f64, 4, 7, 28>(&plan, ts_s, every)?,
            (2, Precision::F32) => make::<f32, 4, 7, 28>(&plan, ts_s, every)?,
            (3, Precision::F64) => make::<f64, 6, 11, 66>(&plan, ts_s, every)?,
            _ => make::<f32, 6, 11, 66>(&plan, ts_s, every)?,
        };
        Ok(Self { inner, plan, ts_s })
    }

    /// Step `u[k]`, `y[k]` in order; the evaluations that fell in them, one
    /// log per estimator.
    ///
    /// # Errors
    /// `u` and `y` of different lengths.
    pub fn feed(&mut self, u: &[f64], y: &[f64]) -> Result<Vec<EstimateLog>, CliError> {
        same_length(u, y)?;
        Ok(self.inner.feed(u, y))
    }

    /// Samples stepped so far.
    pub fn samples(&self) -> u64 {
        self.inner.samples()
    }

    /// Sample interval (s).
    pub fn ts_s(&self) -> f64 {
        self.ts_s
    }

    /// The report of every estimator now, as `--json`'s. The model-output
    /// fit is computed over `record` (the caller's samples: the whole
    /// record so far, or a recent window of it, since the stream keeps no
    /// samples); without it `fit_percent` is null.
    ///
    /// # Errors
    /// `record`'s `u` and `y` of different lengths.
    pub fn reports(
        &self,
        label: &str,
        record: Option<Record<'_>>,
    ) -> Result<Vec<ReplayReport>, CliError> {
        if let Some(r) = record {
            same_length(r.u, r.y)?;
        }
        Ok(self.inner.reports(&self.plan, label, record))
    }
}

/// The human-readable report.
fn render(plan: &Plan, reports: &[ReplayReport]) -> String {
    let Some(first) = reports.first() else {
        return String::new();
    };
    let mut out = format!(
        "file:   {}\nrecord: {} samples at Ts = {} s ({} s), {} mode{}, {} output, {}, {}, {} gains\n",
        first.file,
        first.samples,
        first.ts_s,
        crate::io::table::short(first.duration_s, 6),
        first.modes,
        if first.modes == 1 { "" } else { "s" },
        first.outcome.estimate.output,
        plan.est.lambda_label,
        match first.precision {
            Precision::F64 => "f64",
            Precision::F32 => "f32",
        },
        first.gains
    );
    if let Some(sel) = &first.selection {
        out.push_str(&selection_line(sel, first));
    }
    if !first.line_removal.removed.is_empty() {
        let each: Vec<String> = first
            .line_removal
            .removed
            .iter()
            .map(|l| {
                let near = l
                    .near_mode
                    .map_or(String::new(), |m| format!(", in mode {m}'s band"));
                format!("{:.4} Hz (RMS {:.3e}{near})", l.freq_hz, l.rms)
            })
            .collect();
        out.push_str(&format!(
            "lines:  removed from u and y ({}): {}\n",
            first.line_removal.mode,
            each.join(", ")
        ));
    }
    if let (true, Some(m)) = (first.prewhitening.applied, &first.prewhitening.noise_model) {
        out.push_str(&format!(
            "noise:  coloured (AR({}) of the residual predicts {:.0}% of its power); u and y \
             prewhitened by it, the fit and verdict of the prewhitened record (docs/REPLAY.md, \
             \"Coloured noise\")\n",
            m.order,
            100.0 * (1.0 - 1.0 / m.prediction_gain)
        ));
    }
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
            verdict: &r.outcome.verdict,
        })
        .collect();
    if let Some((set, _)) = plan.crlb {
        out.push_str(&format!(
            "bound:  Cramér–Rao at each final estimate, {}, that model driven from rest by the recorded u\n",
            crate::judge::bound::model_set_description(set, first.modes)
        ));
    }
    out.push('\n');
    out.push_str(&report::table(
        first.outcome.estimate.omega.len(),
        None,
        None,
        &columns,
    ));
    for r in reports {
        for m in &r.outcome.residual_modes {
            out.push_str(&format!(
                "{}: a mode above the band, not estimated: ω = {} rad/s, ζ = {} (the input does \
                 not reveal it; it stands for the modes above the excited band)\n",
                r.estimator.name(),
                crate::io::table::sig(m.omega, 6),
                crate::io::table::sig(m.zeta, 4)
            ));
        }
    }
    out.push_str(&report::verdict_reasons(&columns));
    out.push_str(report::FOOTNOTE);
    out.push_str(report::FOOTNOTE_GUARD);
    out.push_str(report::FOOTNOTE_VERDICT);
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

/// The table's line on how `--estimator auto` chose the model.
fn selection_line(sel: &Selection, report: &ReplayReport) -> String {
    let eligible = sel
        .candidates
        .iter()
        .filter(|c| c.score.excluded.is_none())
        .count();
    let what = format!(
        "{}, {} mode{}, {} output, level correction {}",
        report.estimator.name(),
        report.modes,
        if report.modes == 1 { "" } else { "s" },
        report.outcome.estimate.output,
        if report.level_correction { "on" } else { "off" }
    );
    match sel.chosen {
        Some(_) => format!(
            "model:  {what}: chosen from the data ({eligible} of {} candidates eligible; \
             docs/REPLAY.md, \"Model selection\")\n",
            sel.candidates.len()
        ),
        None => format!(
            "model:  {what}: no candidate model was eligible (of {}), this is the fallback\n",
            sel.candidates.len()
        ),
    }
}

/// `u` and `y` are sample pairs: the same length, else a usage error
/// naming `y`.
fn same_length(u: &[f64], y: &[f64]) -> Result<(), CliError> {
    if u.len() == y.len() {
        return Ok(());
    }
    Err(CliError::usage(
        "y",
        format!(
            "u and y must have the same length (got {} and {})",
            u.len(),
            y.len()
        ),
    ))
}
