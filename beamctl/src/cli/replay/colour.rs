//! `replay`'s coloured-noise pass (docs/REPLAY.md, "Coloured noise"):
//! after the line pass, the report's model residual on the record as the
//! estimator saw it (guard, level correction, lines removed) gets an AR
//! noise model ([`crate::judge::noise`]); when that residual is coloured
//! and not explained by u ([`NoiseModel::coloured`]) the replay runs
//! again with u and y through the model's whitening filter, and once more
//! if the new model's residual is still coloured under that filter (the
//! noise model re-estimated from the better model), up to
//! [`MAX_COLOUR_RUNS`] runs added. The last run is the report; its fit and
//! verdict are of the prewhitened record (the innovation's whiteness).

use super::{conditioned, summary_model, ReplayReport, Replayed};
use crate::cli::args::{PrewhitenChoice, ReplayArgs};
use crate::error::CliError;
use crate::judge::fit;
use crate::judge::noise::{NoiseModel, MAX_ORDER};
use beamest::guard::lines::LineSpec;
use serde::Serialize;

/// Runs the coloured-noise pass adds at most.
pub const MAX_COLOUR_RUNS: usize = 2;

/// No prewhitening when the residual's RMS is below this share of y's
/// (80 dB): there the estimate is at the model's own floor, and a
/// noise-free record's residual (round-off, the discretisation's floor) is
/// no noise spectrum.
pub const MIN_RESIDUAL_SHARE: f64 = 1e-4;

/// A prewhitened run is made again with the new residual's noise model
/// when the filter in use leaves at least this times that model's
/// innovation power in the new residual (it was fitted to a worse model's
/// residual: a model error's peak becomes a notch of the filter, at the
/// mode).
pub const REFIT_GAIN: f64 = 1.02;

/// How coloured noise was handled, as reported (`prewhitening`).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Prewhitening {
    /// `auto` (the pass ran) or `off` (`--prewhiten off`, or a streaming
    /// estimator).
    pub mode: &'static str,
    /// u and y went through the whitening filter of `noise_model` before
    /// this estimate.
    pub applied: bool,
    /// The noise model applied; when none was, the one the pass fitted to
    /// the residual (an order 0: white; or coloured but explained by u:
    /// its `input_share`), if any.
    pub noise_model: Option<NoiseModel>,
    /// Replays the pass added.
    pub runs: usize,
}

impl Default for Prewhitening {
    fn default() -> Self {
        Self {
            mode: "off",
            applied: false,
            noise_model: None,
            runs: 0,
        }
    }
}

impl Prewhitening {
    /// What a run's plan applies (the pass completes it).
    pub(super) fn of(plan: &super::Plan) -> Self {
        Self {
            mode: match plan.prewhiten {
                PrewhitenChoice::Auto => "auto",
                PrewhitenChoice::Off => "off",
            },
            applied: plan.whitening.is_some(),
            noise_model: plan.whitening.clone(),
            runs: 0,
        }
    }
}

/// What a prewhitened run applies: the noise model, and the start-up band
/// (Hz) its tuning rule starts from when the flags give no λ, band or beam
/// (the previous run's modes: the whitened y's frequency centroid follows
/// the noise's spectrum, not the modes).
pub(super) type Whitened = (NoiseModel, Option<Vec<f64>>);

/// The pass over `run` (the line pass's last run, made with `lines`
/// removed); `again` replays with a noise model's whitening filter.
/// Returns the report's run, what it applied and what to report.
pub(super) fn pass(
    args: &ReplayArgs,
    mut run: Replayed,
    lines: &[LineSpec],
    (u, y): (&[f64], &[f64]),
    ts: f64,
    mut again: impl FnMut(Option<Whitened>) -> Result<Replayed, CliError>,
) -> Result<(Replayed, Option<Whitened>, Prewhitening), CliError> {
    let mut out = Prewhitening {
        mode: "auto",
        ..Prewhitening::default()
    };
    if args.prewhiten == PrewhitenChoice::Off {
        out.mode = "off";
        return Ok((run, None, out));
    }
    let mut applied: Option<Whitened> = None;
    for _ in 0..MAX_COLOUR_RUNS {
        let Some(report) = run.reports.first() else {
            break;
        };
        let Some((model, residual)) = noise_model(report, (u, y), ts, args, lines)? else {
            break;
        };
        // A noise model only from a physical model with a fit, a residual
        // that is a visible part of y, and no narrow line in it away from
        // the modes (lines are the line pass's: with `--lines off` they
        // stay, and in the verdict; a "line" in a mode's band is as often
        // the mode's own misfit, which the whitened run may correct).
        let v = &report.outcome.verdict;
        let credible = v
            .reasons
            .iter()
            .all(|r| !matches!(r.code, "no_estimate" | "not_physical" | "no_fit"))
            && v.lines.iter().all(|l| l.near_mode.is_some())
            && report
                .outcome
                .fit_percent
                .is_some_and(|f| 1.0 - f / 100.0 >= MIN_RESIDUAL_SHARE);
        let usable = credible && model.coloured();
        let stop = match &applied {
            None => !usable,
            // The filter in use against the new residual's own model:
            // re-estimated when it leaves 2% more innovation power.
            Some((old, _)) => {
                !usable
                    || innovation_power(&old.whiten(&residual))
                        < REFIT_GAIN * model.innovation_rms.powi(2)
            }
        };
        if stop {
            if applied.is_none() {
                out.noise_model = Some(model);
            }
            break;
        }
        let e = &args.est;
        let given = e.lambda.is_some()
            || e.band_hz.is_some()
            || e.beam.is_some()
            || e.paper_gains
            || e.paper_exp_gains;
        let band = (!given).then(|| modes_band(report)).flatten();
        let next = (model, band);
        run = again(Some(next.clone()))?;
        out.runs += 1;
        applied = Some(next);
    }
    if let Some((m, _)) = &applied {
        out.applied = true;
        out.noise_model = Some(m.clone());
    }
    Ok((run, applied, out))
}

/// Mean square of the finite values of `x` after their mean.
fn innovation_power(x: &[f64]) -> f64 {
    let v: Vec<f64> = x.iter().copied().filter(|v| v.is_finite()).collect();
    if v.is_empty() {
        return f64::NAN;
    }
    let n = v.len() as f64;
    let m = v.iter().sum::<f64>() / n;
    v.iter().map(|x| (x - m) * (x - m)).sum::<f64>() / n
}

/// The band [f_min, f_max] (Hz) of a report's modes, if it has a valid
/// estimate.
fn modes_band(report: &ReplayReport) -> Option<Vec<f64>> {
    let e = &report.outcome.estimate;
    if !e.is_valid() || !report.outcome.validity.is_empty() {
        return None;
    }
    let hz = |w: f64| w / std::f64::consts::TAU;
    let lo = e.omega.iter().copied().fold(f64::INFINITY, f64::min);
    let hi = e.omega.iter().copied().fold(0.0, f64::max);
    (lo > 0.0 && hi.is_finite()).then(|| vec![hz(lo), hz(hi)])
}

/// The noise model of `report`'s residual on the record it was judged on
/// before any whitening (guard, level correction, `lines` removed), with
/// its input share, and that residual; `None` without a model or fit.
fn noise_model(
    report: &ReplayReport,
    (u, y): (&[f64], &[f64]),
    ts: f64,
    args: &ReplayArgs,
    lines: &[LineSpec],
) -> Result<Option<(NoiseModel, Vec<f64>)>, CliError> {
    let range = crate::cli::event_flags::range(&args.guard)?;
    let pairs = u.iter().copied().zip(y.iter().copied());
    let record = conditioned(pairs, ts, range, report.level_correction, lines, None)?;
    let Some(model) = summary_model(&report.outcome, ts) else {
        return Ok(None);
    };
    let Some(f) = fit::fit(&model, || record.iter().copied()) else {
        return Ok(None);
    };
    let residual: Vec<f64> = fit::residuals(&model, &f, record.iter().copied()).collect();
    let Some(mut m) = NoiseModel::fit(&residual, MAX_ORDER) else {
        return Ok(None);
    };
    let record_u: Vec<f64> = record.iter().map(|p| p.0).collect();
    m.set_input_share(&residual, &record_u);
    Ok(Some((m, residual)))
}
