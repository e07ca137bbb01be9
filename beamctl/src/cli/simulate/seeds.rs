//! `beamctl simulate --seeds`: the same experiment over several noise
//! realisations, each estimator's RMS and mean relative error over them,
//! and RMS ÷ the experiment's Cramér–Rao bound ([`crate::run::seeds`]).
//!
//! A seed on which an estimator produced no estimate is listed (table, JSON
//! and a warning on stderr) and makes that estimator's RMS "n/a"; the exit
//! status stays 0, because the summary is the result.

use crate::cli::progress::Progress;
use crate::cli::simulate::plan::{bound_line, run_line, JsonRun, Plan};
use crate::error::note;
use crate::error::CliError;
use crate::io::report::{self, ratio};
use crate::io::table::{rel, sig, Column, Table};
use crate::run::error::RunError;
use crate::run::interrupt::Interrupt;
use crate::run::seeds::{summarize, ParamStats, SeedSummary, SeedsReport};
use crate::run::{run_bound, run_many};
use crate::run::{Observer, RunConfig, Trace};
use serde::Serialize;
use std::io::IsTerminal;

/// Moves the progress bar across all seeds; asks the caller whether to
/// stop.
struct SeedProgress<'a, 'i> {
    progress: &'a mut Progress,
    offset: u64,
    ts_s: f64,
    interrupt: &'a mut Interrupt<'i>,
}

impl Observer for SeedProgress<'_, '_> {
    fn estimate(&mut self, index: usize, t: &Trace<'_>) {
        if index == 0 {
            let done = (t.t_s / self.ts_s).round() as u64 + 1;
            self.progress.set_position(self.offset + done);
        }
    }

    fn stopped(&mut self) -> bool {
        self.interrupt.stopped()
    }
}

/// Run every seed; the summary `beamctl simulate --seeds` prints.
/// `interrupt` is asked every few thousand evaluations; true stops the
/// runs with an error whose code is [`crate::error::EXIT_INTERRUPTED`].
pub fn output(
    plan: &Plan,
    seeds: &[u64],
    json: bool,
    interrupt: Option<&mut dyn FnMut() -> bool>,
) -> Result<String, CliError> {
    let failure = |e| match e {
        RunError::Interrupted => CliError::interrupted("simulation"),
        e => CliError::failure(format!("simulation: {e}")),
    };
    let mut interrupt = Interrupt::new(interrupt);
    let bound = match plan.base.crlb {
        Some(set) => run_bound(&plan.base, set).map_err(failure)?,
        None => None,
    };
    let per_run = plan.samples_per_run();
    let mut progress = Progress::new(
        per_run * seeds.len() as u64,
        !json && std::io::stderr().is_terminal(),
    );
    let names: Vec<&str> = plan.est.kinds.iter().map(|k| k.name()).collect();
    progress.set_message(&names.join("+"));
    let mut per_seed = Vec::with_capacity(seeds.len());
    for (i, &seed) in seeds.iter().enumerate() {
        let cfg = RunConfig {
            seed,
            crlb: None,
            ..plan.base.clone()
        };
        let mut obs = SeedProgress {
            progress: &mut progress,
            offset: i as u64 * per_run,
            ts_s: cfg.ts_s,
            interrupt: &mut interrupt,
        };
        per_seed.push(run_many(&cfg, &plan.est.kinds, &mut obs).map_err(failure)?);
    }
    progress.finish();
    let report = summarize(seeds, per_seed, bound);
    for s in &report.estimators {
        if !s.failed_seeds.is_empty() {
            note(&format!(
                "warning: no estimate from the {} law for seed{} {}",
                s.estimator.name(),
                if s.failed_seeds.len() == 1 { "" } else { "s" },
                list(&s.failed_seeds)
            ));
        }
    }
    let text = if json {
        to_json(plan, &report)?
    } else {
        render(plan, &report)
    };
    Ok(text)
}

/// The JSON document: the summary with every seed's full report.
fn to_json(plan: &Plan, report: &SeedsReport) -> Result<String, CliError> {
    #[derive(Serialize)]
    struct Summary<'a> {
        #[serde(flatten)]
        summary: &'a SeedSummary,
        #[serde(skip_serializing_if = "Vec::is_empty")]
        runs: Vec<JsonRun<'a>>,
    }
    #[derive(Serialize)]
    struct Doc<'a> {
        modes: usize,
        gains: &'static str,
        ts_s: f64,
        duration_s: f64,
        snr_db: Option<f64>,
        seeds: &'a [u64],
        noise_sd: Option<f64>,
        crlb: &'a Option<crate::judge::bound::ExperimentBound>,
        estimators: Vec<Summary<'a>>,
    }
    let estimators = report
        .estimators
        .iter()
        .map(|s| Summary {
            summary: s,
            runs: s
                .runs
                .iter()
                .zip(&report.seeds)
                .map(|(r, &seed)| JsonRun {
                    report: r,
                    modes: plan.modes,
                    gains: plan.base.gains.name(),
                    ts_s: plan.base.ts_s,
                    snr_db: plan.base.snr_db,
                    seed,
                    excitation: plan.base.excitation,
                })
                .collect(),
        })
        .collect();
    let doc = Doc {
        modes: plan.modes,
        gains: plan.base.gains.name(),
        ts_s: plan.base.ts_s,
        duration_s: plan.base.duration_s,
        snr_db: plan.base.snr_db,
        seeds: &report.seeds,
        noise_sd: report.noise_sd,
        crlb: &report.crlb,
        estimators,
    };
    report::to_json(std::slice::from_ref(&doc))
}

/// "1–5" for a contiguous run, else "1, 3, 9".
fn list(seeds: &[u64]) -> String {
    let contiguous = seeds.windows(2).all(|w| w[1] == w[0] + 1);
    match (seeds.first(), seeds.last()) {
        (Some(a), Some(b)) if contiguous && seeds.len() > 2 => format!("{a}–{b}"),
        _ => seeds
            .iter()
            .map(u64::to_string)
            .collect::<Vec<_>>()
            .join(", "),
    }
}

/// The table: per parameter the relative bound, then per estimator the RMS
/// and mean relative error over the seeds and RMS ÷ bound.
fn render(plan: &Plan, report: &SeedsReport) -> String {
    let n = plan.modes;
    let mut out = format!(
        "plant:  {}, {n} mode{}\n",
        plan.plant_label,
        if n == 1 { "" } else { "s" }
    );
    out.push_str(&run_line(
        plan,
        plan.samples_per_run(),
        report.noise_sd,
        None,
    ));
    out.push_str(&format!(
        "seeds:  {} ({} run{} per estimator)\n",
        list(&report.seeds),
        report.seeds.len(),
        if report.seeds.len() == 1 { "" } else { "s" }
    ));
    if let Some(b) = &report.crlb {
        out.push_str(&bound_line(b, n));
    }
    out.push('\n');
    let mut t = Table::new();
    let mut head = vec![Column::text("parameter"), Column::num("truth")];
    if report.crlb.is_some() {
        head.push(Column::num("CRB (rel.)"));
    }
    t.group("", head);
    for s in &report.estimators {
        let mut g = vec![Column::num("RMS error"), Column::num("mean error")];
        if s.rms_over_crlb.is_some() {
            g.push(Column::num("RMS ÷ CRB"));
        }
        t.group(s.estimator.name(), g);
    }
    type Pick = fn(&ParamStats) -> &Vec<f64>;
    type PickB = fn(&crate::judge::bound::BoundRatio) -> &Vec<f64>;
    type PickC = fn(&crate::judge::bound::ExperimentBound) -> &Vec<f64>;
    type PickT = fn(&crate::run::session::ModalSummary) -> &Vec<f64>;
    let rows: [(&str, &str, Pick, PickB, PickC, PickT); 3] = [
        (
            "ω",
            " (rad/s)",
            |p| &p.omega,
            |r| &r.omega,
            |c| &c.omega.rel,
            |m| &m.omega,
        ),
        (
            "ζ",
            "",
            |p| &p.zeta,
            |r| &r.zeta,
            |c| &c.zeta.rel,
            |m| &m.zeta,
        ),
        (
            "b̄",
            "",
            |p| &p.bbar,
            |r| &r.bbar,
            |c| &c.bbar.rel,
            |m| &m.bbar,
        ),
    ];
    let at = |v: &Vec<f64>, i: usize| v.get(i).copied().unwrap_or(f64::NAN);
    let truth = report
        .estimators
        .first()
        .and_then(|s| s.runs.first())
        .map(|r| &r.truth);
    for (sym, unit, pick, pick_ratio, pick_bound, pick_truth) in rows {
        for i in 0..n {
            let mut row = vec![
                format!("{sym}{}{unit}", i + 1),
                truth.map_or("n/a".to_string(), |t| sig(at(pick_truth(t), i), 7)),
            ];
            if let Some(b) = &report.crlb {
                row.push(rel(at(pick_bound(b), i)));
            }
            for s in &report.estimators {
                row.push(rel(at(pick(&s.rms_rel_error), i)));
                let mean = at(pick(&s.mean_rel_error), i);
                row.push(if mean.is_finite() {
                    format!("{mean:+.2e}")
                } else {
                    "n/a".to_string()
                });
                if let Some(r) = &s.rms_over_crlb {
                    row.push(ratio(at(pick_ratio(r), i)));
                }
            }
            t.row(row);
        }
    }
    t.rule();
    let lead = 1 + usize::from(report.crlb.is_some());
    let metric = |t: &mut Table, label: &str, f: &dyn Fn(&SeedSummary) -> String| {
        let mut row = vec![label.to_string()];
        row.extend(std::iter::repeat_n(String::new(), lead));
        for s in &report.estimators {
            row.push(f(s));
            row.push(String::new());
            if s.rms_over_crlb.is_some() {
                row.push(String::new());
            }
        }
        t.row(row);
    };
    metric(&mut t, "max ω/ζ error, any seed", &|s| {
        rel(s.max_rel_error)
    });
    metric(&mut t, "seeds without estimate", &|s| {
        if s.failed_seeds.is_empty() {
            "none".to_string()
        } else {
            list(&s.failed_seeds)
        }
    });
    out.push_str(&t.render());
    out.push_str(
        "\nRMS, mean: over the seeds, of the relative error (est − true)/true at the end of \
each run; mean ≠ 0 beyond RMS/√seeds is a bias.\n",
    );
    if report.crlb.is_some() {
        out.push_str(
            "CRB: Cramér–Rao bound, the relative 1σ no unbiased estimator of the stated model \
set can beat on this experiment; RMS ÷ CRB ≈ 1 is efficient (over N seeds it scatters by \
about ±1/√(2N) even then).\n",
        );
    }
    out
}
