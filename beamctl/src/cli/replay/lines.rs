//! `replay`'s line pass (docs/REPLAY.md, "Lines in y"): with `--lines
//! auto` (the default) the replay runs once as the flags say; the steady,
//! coherent lines its report's residual holds ([`crate::judge::lines`]) are
//! then removed from u and y by the line canceller
//! ([`beamest::guard::lines`]), seeded with each line's phasor in y, and
//! the replay runs again on the cleaned record, which that report's fit
//! and verdict are of. A model can take a line for a lightly damped mode,
//! so that its residual shows only the others: each cleaned run's residual
//! is searched again, up to [`MAX_LINE_RUNS`] runs. No line found: the
//! first run is the report. `--lines HZ,...` and `--mains HZ` name the
//! lines instead (the first run only gives their phasors); `--lines off`
//! runs once, untouched.

use super::colour::Whitened;
use super::{conditioned, execute, plan, summary_model, ReplayReport, Replayed, Source};
use crate::cli::args::{LinesChoice, PrewhitenChoice, ReplayArgs};
use crate::error::CliError;
use crate::judge::fit;
use crate::judge::frf::PowerSpectrum;
use crate::judge::lines::{self, RemovedLine};
use beamest::guard::lines::{LineSpec, MAX_LINES};
use serde::Serialize;

/// The highest mains harmonic `--mains` removes.
pub const MAINS_HARMONICS: u32 = 7;

/// How far (relative) a named line's frequency is refined from the record.
pub const NAMED_TOLERANCE: f64 = 0.01;

/// Runs of the replay at most with `--lines auto`: the first, and two
/// more, each after the lines the last one's residual showed were removed.
pub const MAX_LINE_RUNS: usize = 3;

/// A line found again within this relative distance of one removed is the
/// same line.
const SAME_LINE: f64 = 0.005;

/// How the lines in y were handled, as reported.
#[derive(Debug, Clone, Serialize)]
pub struct LineRemoval {
    /// `auto` (detected), `named` (`--lines HZ,...`, `--mains`) or `off`.
    pub mode: &'static str,
    /// The lines removed from u and y before this estimate.
    pub removed: Vec<RemovedLine>,
}

impl LineRemoval {
    /// What the flags ask for, with the lines the pass found.
    pub fn of(args: &ReplayArgs) -> Self {
        let mode = match (&args.lines, args.mains) {
            (_, Some(_)) | (LinesChoice::Named(_), None) => "named",
            (LinesChoice::Off, None) => "off",
            (LinesChoice::Auto, None) => "auto",
        };
        Self {
            mode,
            removed: args.removing.iter().map(|r| r.1.clone()).collect(),
        }
    }
}

/// The harmonics 1..=[`MAINS_HARMONICS`] of `mains_hz` that stay below the
/// Nyquist frequency with their tolerance.
pub fn mains_lines(mains_hz: f64, ts_s: f64) -> Vec<f64> {
    (1..=MAINS_HARMONICS)
        .map(|k| f64::from(k) * mains_hz)
        .filter(|f| f * (1.0 + NAMED_TOLERANCE) < 0.5 / ts_s)
        .collect()
}

/// The replay with the line pass (module docs).
pub(super) fn execute_with_lines(
    args: &ReplayArgs,
    plan_now: &super::Plan,
    label: &str,
    ts: f64,
    log_every: Option<u64>,
    source: Source<'_>,
) -> Result<Replayed, CliError> {
    let named: Option<Vec<f64>> = match (&args.lines, args.mains) {
        (_, Some(m)) if m.is_finite() && m > 0.0 => Some(mains_lines(m, ts)),
        (_, Some(m)) => {
            return Err(CliError::usage(
                "--mains",
                format!("the mains frequency must be a finite number > 0 Hz (got {m})"),
            ))
        }
        (LinesChoice::Named(f), None) => Some(f.clone()),
        (LinesChoice::Off, None) => None,
        (LinesChoice::Auto, None) => None,
    };
    let lines_off = args.lines == LinesChoice::Off && args.mains.is_none();
    let colour_off = args.prewhiten == PrewhitenChoice::Off;
    if lines_off && colour_off || !args.removing.is_empty() || args.whitening.is_some() {
        return execute(args, plan_now, label, ts, log_every, source);
    }
    if let Some(bad) = named
        .iter()
        .flatten()
        .find(|&&f| f * (1.0 + NAMED_TOLERANCE) >= 0.5 / ts)
    {
        return Err(CliError::usage(
            "--lines",
            format!(
                "{bad} Hz is not below the Nyquist frequency {} Hz",
                0.5 / ts
            ),
        ));
    }
    let mut owned: (Vec<f64>, Vec<f64>) = (Vec::new(), Vec::new());
    let mut never = || false;
    let (u, y, chunk, interrupt) = super::in_memory(source, label, &mut owned, &mut never)?;
    // The runs that look for lines need no CSV, plot, bound or logs.
    let reusable = args.csv.is_none() && args.plot.is_none() && !args.crlb && log_every.is_none();
    let mut run_with =
        |removing: &[(LineSpec, RemovedLine)], whitening: Option<Whitened>, last: bool| {
            let mut a = args.clone();
            a.removing = removing.to_vec();
            if let Some((m, band)) = whitening {
                a.whitening = Some(m);
                if band.is_some() {
                    a.est.band_hz = band;
                }
            }
            let logs = if last { log_every } else { None };
            if !last {
                a.csv = None;
                a.plot = None;
                a.crlb = false;
            }
            let arrays = Source::Arrays {
                u,
                y,
                chunk,
                interrupt: &mut *interrupt,
            };
            execute(&a, &plan(&a)?, label, ts, logs, arrays)
        };
    let mut run = run_with(&[], None, reusable)?;
    let mut found: Vec<(LineSpec, RemovedLine)> = Vec::new();
    // A model may take a line for a lightly damped mode, and its residual
    // then shows only the others: detected lines are looked for again in
    // each cleaned run's residual, up to MAX_LINE_RUNS runs in all.
    for pass in (1..MAX_LINE_RUNS).filter(|_| !lines_off) {
        let look = if pass == 1 { named.as_deref() } else { None };
        let new = match run.reports.first() {
            Some(r) => found_lines(r, look, (u, y), ts, args)?,
            None => Vec::new(),
        };
        let fresh: Vec<_> = new
            .into_iter()
            .filter(|(s, _)| {
                found
                    .iter()
                    .all(|(f, _)| (f.freq_hz - s.freq_hz).abs() > SAME_LINE * s.freq_hz)
            })
            .collect();
        if fresh.is_empty() {
            break;
        }
        found.extend(fresh);
        found.truncate(MAX_LINES);
        run = run_with(&found, None, reusable)?;
        if named.is_some() || found.len() == MAX_LINES {
            break;
        }
    }
    // Then the coloured-noise pass, on the record with the lines removed.
    let specs: Vec<LineSpec> = found.iter().map(|f| f.0).collect();
    let (run, whitening, prewhitening) = super::colour::pass(args, run, &specs, (u, y), ts, |w| {
        run_with(&found, w, reusable)
    })?;
    let mut run = if reusable {
        run
    } else {
        run_with(&found, whitening, true)?
    };
    for r in &mut run.reports {
        r.prewhitening = prewhitening.clone();
    }
    Ok(run)
}

/// The lines to remove after the first run's `report` (module docs): its
/// model's residual on the record it was judged on, the verdict's lines
/// kept if steady and coherent, or the `named` ones with their phasors.
fn found_lines(
    report: &ReplayReport,
    named: Option<&[f64]>,
    (u, y): (&[f64], &[f64]),
    ts: f64,
    args: &ReplayArgs,
) -> Result<Vec<(LineSpec, RemovedLine)>, CliError> {
    if named.is_none() && report.outcome.verdict.lines.is_empty() {
        return Ok(Vec::new());
    }
    let pairs = || u.iter().copied().zip(y.iter().copied());
    let range = crate::cli::event_flags::range(&args.guard)?;
    let record: Vec<(f64, f64)> = if report.level_correction {
        conditioned(pairs(), ts, range, true, &[], None)?
    } else {
        pairs().collect()
    };
    let model = summary_model(&report.outcome, ts);
    let f = model
        .as_ref()
        .and_then(|m| fit::fit(m, || record.iter().copied()));
    let residual: Vec<f64> = match (&model, &f) {
        (Some(m), Some(f)) => fit::residuals(m, f, record.iter().copied()).collect(),
        // No model: the lines' phasors in y itself (named lines only).
        _ if named.is_some() => record.iter().map(|p| p.1).collect(),
        _ => return Ok(Vec::new()),
    };
    if let Some(freqs) = named {
        return Ok(lines::named(freqs, &residual, ts, |f| NAMED_TOLERANCE * f));
    }
    let Some(bin_hz) =
        PowerSpectrum::of(residual.iter().copied(), residual.len(), ts).map(|s| s.bin_hz())
    else {
        return Ok(Vec::new());
    };
    let candidates: Vec<(f64, f64, Option<usize>)> = report
        .outcome
        .verdict
        .lines
        .iter()
        .map(|l| (l.freq_hz, l.rms, l.near_mode))
        .collect();
    Ok(lines::to_remove(&candidates, &residual, ts, bin_hz))
}
