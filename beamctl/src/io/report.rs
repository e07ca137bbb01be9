//! The result table and JSON shared by `simulate` (with the truth) and
//! `replay` (without), and the exit status when a run produced no
//! estimate.

use crate::error::CliError;
use crate::io::table::{rel, seconds, sig, Column as TableColumn, Table};
use crate::judge::bound::{BoundRatio, ExperimentBound};
use crate::judge::verdict::Verdict;
use crate::run::estimator::EstimatorKind;
use crate::run::session::ModalSummary;
use crate::run::session::{GuardReport, SupervisionReport};
use crate::run::tuned::{Build, RobustStatus};
use serde::Serialize;

/// Metrics that need the truth (simulation only).
#[derive(Debug, Clone, Copy)]
pub struct TruthColumn {
    /// See `RunReport::time_to_1pct_s`.
    pub time_to_1pct_s: Option<f64>,
    /// See `RunReport::time_to_0p1pct_s`.
    pub time_to_0p1pct_s: Option<f64>,
    /// See `RunReport::max_error_after_1s`.
    pub max_error_after_1s: Option<f64>,
}

/// One estimator's column group.
#[derive(Debug, Clone)]
pub struct Column<'a> {
    /// Law name.
    pub name: &'static str,
    /// Final estimate.
    pub estimate: &'a ModalSummary,
    /// λmin(P), adaptive law only.
    pub excitation_min_eig: Option<f64>,
    /// Feedthrough D, `--estimator feedthrough` only.
    pub feedthrough: Option<f64>,
    /// Samples read.
    pub samples: u64,
    /// Rejected samples.
    pub rejected: u64,
    /// Skipped law updates.
    pub skipped: u64,
    /// Every build of the tuning rule.
    pub builds: &'a [Build],
    /// How the tuning rule ended.
    pub tuning: &'static str,
    /// Model output fit, %.
    pub fit_percent: Option<f64>,
    /// Movement over the last 10% of the record.
    pub drift: Option<f64>,
    /// Sample period (s), to turn build indices into times.
    pub ts_s: f64,
    /// Truth metrics, when known.
    pub truth: Option<TruthColumn>,
    /// This estimator's own Cramér–Rao bound (replay: at its estimate,
    /// with its noise estimate).
    pub bound: Option<&'a ExperimentBound>,
    /// Where the σ of `bound` came from.
    pub sigma_source: Option<&'static str>,
    /// Relative error ÷ the relative bound (simulation with noise).
    pub ratio: Option<&'a BoundRatio>,
    /// The robust estimator's extra outputs.
    pub robust: Option<RobustStatus>,
    /// The supervisor's state at the end.
    pub supervision: Option<SupervisionReport>,
    /// The final estimate's physical-validity flags (empty: valid).
    pub validity: &'a [&'static str],
    /// The sensor guard's counters.
    pub guard: GuardReport,
    /// After a plant step: the tracking times to 1% and 0.1%.
    pub tracking: Option<(Option<f64>, Option<f64>)>,
    /// Whether the estimate can be trusted.
    pub verdict: &'a Verdict,
}

/// The table: estimate (and with the truth, truth and relative error) per
/// parameter, then the metrics. With `shared_bound` (the experiment's
/// Cramér–Rao bound, simulation) a relative-bound column follows the truth
/// and each estimator gets an error ÷ bound column; an estimator's own
/// bound (replay) is a column of its group.
pub fn table(
    n: usize,
    truth: Option<&ModalSummary>,
    shared_bound: Option<&ExperimentBound>,
    cols: &[Column<'_>],
) -> String {
    let mut t = Table::new();
    let mut head = vec![TableColumn::text("parameter")];
    if truth.is_some() {
        head.push(TableColumn::num("truth"));
    }
    if shared_bound.is_some() {
        head.push(TableColumn::num("CRB (rel.)"));
    }
    t.group("", head);
    for c in cols {
        let mut g = vec![TableColumn::num("estimate")];
        if truth.is_some() {
            g.push(TableColumn::num("rel. error"));
        }
        if c.ratio.is_some() {
            g.push(TableColumn::num("÷ CRB"));
        }
        if c.bound.is_some() {
            g.push(TableColumn::num("CRB (rel.)"));
        }
        t.group(c.name, g);
    }
    type Pick = fn(&ModalSummary) -> &Vec<f64>;
    type PickBound = fn(&ExperimentBound) -> &Vec<f64>;
    type PickRatio = fn(&BoundRatio) -> &Vec<f64>;
    let params: [(&str, &str, Pick, PickBound, PickRatio); 3] = [
        (
            "ω",
            " (rad/s)",
            |m| &m.omega,
            |b| &b.omega.rel,
            |r| &r.omega,
        ),
        ("ζ", "", |m| &m.zeta, |b| &b.zeta.rel, |r| &r.zeta),
        ("b̄", "", |m| &m.bbar, |b| &b.bbar.rel, |r| &r.bbar),
    ];
    let at = |v: &Vec<f64>, i: usize| v.get(i).copied().unwrap_or(f64::NAN);
    for (sym, unit, pick, pick_bound, pick_ratio) in params {
        for i in 0..n {
            let mut row = vec![format!("{sym}{}{unit}", i + 1)];
            let tv = truth.map(|tr| at(pick(tr), i));
            if let Some(tv) = tv {
                row.push(sig(tv, 7));
            }
            if let Some(b) = shared_bound {
                row.push(rel(at(pick_bound(b), i)));
            }
            for c in cols {
                let ev = at(pick(c.estimate), i);
                row.push(sig(ev, 7));
                if let Some(tv) = tv {
                    row.push(rel(((ev - tv) / tv).abs()));
                }
                if let Some(r) = c.ratio {
                    row.push(ratio(at(pick_ratio(r), i)));
                }
                if let Some(b) = c.bound {
                    row.push(rel(at(pick_bound(b), i)));
                }
            }
            t.row(row);
        }
    }
    t.rule();
    let lead = usize::from(truth.is_some()) + usize::from(shared_bound.is_some());
    let metric = |t: &mut Table, label: &str, f: &dyn Fn(&Column<'_>) -> String| {
        let mut row = vec![label.to_string()];
        row.extend(std::iter::repeat_n(String::new(), lead));
        for c in cols {
            row.push(f(c));
            let extra = usize::from(truth.is_some())
                + usize::from(c.ratio.is_some())
                + usize::from(c.bound.is_some());
            row.extend(std::iter::repeat_n(String::new(), extra));
        }
        t.row(row);
    };
    let with_truth = truth.is_some();
    if with_truth {
        let tr = |c: &Column<'_>| {
            c.truth.unwrap_or(TruthColumn {
                time_to_1pct_s: None,
                time_to_0p1pct_s: None,
                max_error_after_1s: None,
            })
        };
        metric(&mut t, "time to 1%", &|c| seconds(tr(c).time_to_1pct_s));
        metric(&mut t, "time to 0.1%", &|c| seconds(tr(c).time_to_0p1pct_s));
        metric(&mut t, "max error after 1 s", &|c| {
            tr(c).max_error_after_1s.map_or("n/a".to_string(), rel)
        });
    }
    metric(&mut t, "model output fit", &|c| {
        c.fit_percent
            .map_or("n/a".to_string(), |f| format!("{f:.3} %"))
    });
    metric(&mut t, "moved over last 10%", &|c| {
        c.drift.map_or("n/a".to_string(), rel)
    });
    metric(&mut t, "λ (rad/s)", &|c| lambda_path(c.builds));
    metric(&mut t, "λ last built at", &|c| match c.builds.last() {
        Some(b) => format!("{:.3} s ({})", b.sample as f64 * c.ts_s, c.tuning),
        None => format!("never ({})", c.tuning),
    });
    metric(&mut t, "excitation λmin(P)", &|c| {
        c.excitation_min_eig
            .map_or("n/a".to_string(), |v| sig(v, 4))
    });
    if cols.iter().any(|c| c.feedthrough.is_some()) {
        metric(&mut t, "feedthrough D (y per u)", &|c| {
            c.feedthrough.map_or("n/a".to_string(), |v| sig(v, 4))
        });
    }
    if cols.iter().any(|c| c.robust.is_some()) {
        metric(&mut t, "robust phase", &|c| {
            c.robust.map_or("n/a".to_string(), |r| {
                format!("{} ({} updates)", r.phase, r.model_updates)
            })
        });
        metric(&mut t, "noise RMS (a posteriori)", &|c| {
            c.robust
                .and_then(|r| r.noise_rms)
                .map_or("n/a".to_string(), |v| sig(v, 4))
        });
    }
    if cols.iter().any(|c| c.bound.is_some()) {
        metric(
            &mut t,
            "σ for the CRB",
            &|c| match (c.bound, c.sigma_source) {
                (Some(b), Some(src)) => format!("{} ({})", sig(b.sigma, 4), sigma_label(src)),
                (Some(b), None) => sig(b.sigma, 4),
                _ => "n/a".to_string(),
            },
        );
    }
    if cols.iter().any(|c| c.tracking.is_some()) {
        metric(&mut t, "tracking: 1% after step", &|c| {
            seconds(c.tracking.and_then(|t| t.0))
        });
        metric(&mut t, "tracking: 0.1% after step", &|c| {
            seconds(c.tracking.and_then(|t| t.1))
        });
    }
    metric(&mut t, "excitation (supervisor)", &|c| {
        c.supervision.map_or("n/a".to_string(), |s| {
            if s.frozen {
                format!("{} (frozen)", s.excitation_reason)
            } else {
                s.excitation_reason.to_string()
            }
        })
    });
    metric(&mut t, "changes detected", &|c| {
        c.supervision
            .map_or("n/a".to_string(), |s| s.changes_detected.to_string())
    });
    metric(&mut t, "physically valid", &|c| {
        if c.validity.is_empty() {
            "yes".to_string()
        } else {
            format!("no: {}", c.validity.join(", "))
        }
    });
    metric(&mut t, "trusted", &|c| c.verdict.summary());
    metric(&mut t, "samples", &|c| c.samples.to_string());
    metric(&mut t, "guard: rejected", &|c| guard_kinds(&c.guard));
    metric(&mut t, "guard: level events", &|c| {
        format!(
            "offset {}, drift {}",
            c.guard.offset_steps, c.guard.drift_flags
        )
    });
    metric(&mut t, "rejected samples", &|c| c.rejected.to_string());
    metric(&mut t, "skipped updates", &|c| c.skipped.to_string());
    t.render()
}

/// The reasons of every untrusted column, a line each ("" when every
/// column is trusted).
pub fn verdict_reasons(cols: &[Column<'_>]) -> String {
    let mut out = String::new();
    for c in cols {
        for r in &c.verdict.reasons {
            out.push_str(&format!(
                "not trusted ({}): {}: {}\n",
                c.name, r.code, r.detail
            ));
        }
    }
    out
}

/// Footnote of the verdict.
pub const FOOTNOTE_VERDICT: &str = "trusted: no check failed — an estimate, physically valid, \
a white model-output residual (or one whose structure is below 1% of y), moved ≤ 1% over the last \
10%, and input power within an octave of every mode (docs/REPLAY.md, \"The verdict\").\n";

/// "none" or "N (stuck N, …)": the guard's rejections by kind.
pub fn guard_kinds(g: &GuardReport) -> String {
    if g.rejected == 0 {
        return "none".to_string();
    }
    let kinds: Vec<String> = [
        ("non-finite", g.non_finite),
        ("saturated", g.saturated),
        ("stuck", g.stuck),
        ("open", g.open),
    ]
    .iter()
    .filter(|(_, n)| *n > 0)
    .map(|(k, n)| format!("{k} {n}"))
    .collect();
    format!("{} ({})", g.rejected, kinds.join(", "))
}

/// The table's short name of a σ source (`given`, `robust_residual`,
/// `model_output_residual`).
fn sigma_label(source: &str) -> &str {
    match source {
        "robust_residual" => "OE residual",
        "model_output_residual" => "fit residual",
        other => other,
    }
}

/// An error ÷ bound ratio: "1.03", "41.7", "2.1e3"; "n/a" if not finite.
pub fn ratio(v: f64) -> String {
    if !v.is_finite() {
        "n/a".to_string()
    } else if v < 100.0 {
        format!("{v:.2}")
    } else if v < 1e4 {
        format!("{v:.0}")
    } else {
        format!("{v:.1e}")
    }
}

/// "94 → 129": the λ of every build.
fn lambda_path(builds: &[Build]) -> String {
    if builds.is_empty() {
        return "n/a".to_string();
    }
    builds
        .iter()
        .map(|b| crate::io::table::short(b.lambda_rad_s, 4))
        .collect::<Vec<_>>()
        .join(" → ")
}

/// Footnote of the truth metrics.
pub const FOOTNOTE_TRUTH: &str = "\ntime to x%: simulated time after which the largest relative \
ω/ζ error stays below x% to the end.";

/// Footnote of the truth-free metrics.
pub const FOOTNOTE_GUARD: &str =
    "guard: samples the sensor guard kept from the estimators, by kind \
(non-finite, saturated/open at a rail of --range, stuck: y repeated 25 times), and the level \
events it flagged (offset steps, drifts; removed with --level-correction). excitation: the \
supervisor's flag (excited, input_gone, not_persistent, starting); frozen = adaptation held \
while the input is gone. physically valid: ω > 0, 0 < ζ < 1, distinct modes.\n";
/// Footnote of the fit and drift rows.
pub const FOOTNOTE: &str = "\nmodel output fit: 100·(1 − ‖y − ŷ‖/‖y − ȳ‖), ŷ = the final \
model driven by the recorded u (initial state fitted).\nmoved over last 10%: largest \
|median(later half) − median(earlier half)|/|median(later half)| of ω̂, ζ̂ over the \
evaluations of the last 10% of the record (one outlying evaluation does not count).\nλ: the filter pole of each \
build of the tuning rule (start-up window, then re-centred on the estimate; docs/SETTINGS.md); \
last built at = when the last estimator was built, and how the rule ended.\nλmin(P): smallest eigenvalue of the scaled information \
matrix P (Lemma 1; the robust estimator's is that of its active law); the baselines keep no P.\n";

/// Footnote of the robust estimator's rows.
pub const FOOTNOTE_ROBUST: &str = "robust phase: startup (the proposed law, recording 2 s), \
refining (output error, re-linearized by replaying the record), steady (record full); noise \
RMS: RMS of its output-error residual y − ŷ, the measurement noise's σ once the model is right.\n";

/// Footnote of the bound.
pub const FOOTNOTE_CRB: &str = "CRB: Cramér–Rao bound, the relative 1σ no unbiased \
estimator of the stated model set can beat on this experiment (beamctl crlb); ÷ CRB: \
relative error ÷ that bound (one realisation: values of order 1 are at the bound, and \
1–3 occurs by chance; --seeds gives RMS ÷ CRB).\n";

/// Pretty JSON: one object for one run, an array for several.
pub fn to_json<T: Serialize>(runs: &[T]) -> Result<String, CliError> {
    let text = if runs.len() == 1 {
        serde_json::to_string_pretty(&runs[0])
    } else {
        serde_json::to_string_pretty(runs)
    }
    .map_err(|e| CliError::failure(format!("--json: {e}")))?;
    Ok(text + "\n")
}

/// Exit status after the report is printed: an error (exit 1) naming the
/// first law that produced no estimate, and why.
pub fn require_estimates<'a>(
    runs: impl IntoIterator<Item = (EstimatorKind, &'a ModalSummary, &'static str, u64)>,
) -> Result<(), CliError> {
    for (kind, estimate, tuning, updates) in runs {
        if !estimate.is_valid() {
            let why = if tuning == "startup" {
                "the start-up window never completed (u or y never non-zero and finite)"
            } else if updates == 0 {
                "the law never updated (all samples rejected, or the record ends within the start-up window and the filters' settling time)"
            } else {
                "the final estimate is not a valid modal model (recovery failed)"
            };
            return Err(CliError::failure(format!(
                "no estimate from the {} law: {why}",
                kind.name()
            )));
        }
    }
    Ok(())
}
