//! One configuration over several noise seeds: the RMS and mean of each
//! estimator's relative errors over the seeds and, with the Cramér–Rao
//! bound of the experiment ([`crate::judge::bound`]), RMS ÷ bound — the figure an
//! efficient estimator brings to 1 (`beamctl simulate --seeds`).
//!
//! The seeds change only the noise realisation: plant, excitation, σ and
//! so the bound are the same for every seed, and computed once.

use crate::judge::bound::{BoundRatio, ExperimentBound};
use crate::run::error::RunError;
use crate::run::estimator::EstimatorKind;
use crate::run::{run_bound, run_many, Precision, RunConfig, RunReport};
use serde::Serialize;

/// A statistic of the relative errors, per mode.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ParamStats {
    /// Of ω_i.
    pub omega: Vec<f64>,
    /// Of ζ_i.
    pub zeta: Vec<f64>,
    /// Of b̄_i.
    pub bbar: Vec<f64>,
}

/// One estimator over the seeds.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SeedSummary {
    /// Which estimator.
    pub estimator: EstimatorKind,
    /// Its float type.
    pub precision: Precision,
    /// Root mean square over the seeds of the relative errors (NaN if a
    /// seed produced no estimate).
    pub rms_rel_error: ParamStats,
    /// Mean over the seeds of the signed relative errors (est − true)/true:
    /// the bias that more data would not remove.
    pub mean_rel_error: ParamStats,
    /// `rms_rel_error` ÷ the relative bound (with a bound).
    pub rms_over_crlb: Option<BoundRatio>,
    /// Largest relative ω/ζ error over all seeds at the end of the runs.
    pub max_rel_error: f64,
    /// Seeds that produced no valid estimate.
    pub failed_seeds: Vec<u64>,
    /// Every seed's report, in seed order.
    pub runs: Vec<RunReport>,
}

/// Several estimators over the same seeds (the JSON of `beamctl simulate
/// --seeds`).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SeedsReport {
    /// The noise seeds, in run order.
    pub seeds: Vec<u64>,
    /// σ of the noise on y.
    pub noise_sd: Option<f64>,
    /// The experiment's bound (the same for every seed).
    pub crlb: Option<ExperimentBound>,
    /// One summary per estimator, in run order.
    pub estimators: Vec<SeedSummary>,
}

/// Run `cfg` (with its `crlb` model set) for every seed, `kinds` side by
/// side on each seed's samples.
///
/// # Errors
/// [`RunError`] if a run cannot start or the bound cannot be computed.
pub fn run_seeds(
    cfg: &RunConfig,
    kinds: &[EstimatorKind],
    seeds: &[u64],
) -> Result<SeedsReport, RunError> {
    let bound = match cfg.crlb {
        Some(set) => run_bound(cfg, set)?,
        None => None,
    };
    let per_seed = seeds
        .iter()
        .map(|&seed| {
            let c = RunConfig {
                seed,
                crlb: None,
                ..cfg.clone()
            };
            run_many(&c, kinds, &mut |_: &crate::run::Trace<'_>| {})
        })
        .collect::<Result<Vec<_>, _>>()?;
    Ok(summarize(seeds, per_seed, bound))
}

/// Combine per-seed runs (`per_seed[s][k]`: seed `s`, estimator `k`, as
/// [`run_many`] returns them, computed without a bound) with the
/// experiment's bound: each run gets the bound and its error ÷ bound.
pub fn summarize(
    seeds: &[u64],
    per_seed: Vec<Vec<RunReport>>,
    bound: Option<ExperimentBound>,
) -> SeedsReport {
    let kinds = per_seed.first().map_or(0, Vec::len);
    let noise_sd = per_seed
        .first()
        .and_then(|r| r.first())
        .and_then(|r| r.noise_sd);
    let mut columns: Vec<Vec<RunReport>> = vec![Vec::new(); kinds];
    for runs in per_seed {
        for (k, mut r) in runs.into_iter().enumerate().take(kinds) {
            if let Some(b) = &bound {
                let e = &r.rel_error;
                r.error_over_crlb = Some(b.ratio(&e.omega, &e.zeta, &e.bbar));
                r.crlb = Some(b.clone());
            }
            columns[k].push(r);
        }
    }
    let estimators = columns
        .into_iter()
        .map(|runs| summary(seeds, runs, bound.as_ref()))
        .collect();
    SeedsReport {
        seeds: seeds.to_vec(),
        noise_sd,
        crlb: bound,
        estimators,
    }
}

fn summary(seeds: &[u64], runs: Vec<RunReport>, bound: Option<&ExperimentBound>) -> SeedSummary {
    let first = &runs[0];
    let n = first.truth.omega.len();
    let signed = |r: &RunReport, pick: fn(&crate::run::ModalSummary) -> &Vec<f64>| {
        (0..n)
            .map(|i| pick(&r.estimate)[i] / pick(&r.truth)[i] - 1.0)
            .collect::<Vec<f64>>()
    };
    let stat = |pick: fn(&crate::run::ModalSummary) -> &Vec<f64>, rms: bool| {
        let mut out = vec![0.0; n];
        for r in &runs {
            for (o, e) in out.iter_mut().zip(signed(r, pick)) {
                *o += if rms { e * e } else { e };
            }
        }
        let m = runs.len() as f64;
        out.iter()
            .map(|v| if rms { (v / m).sqrt() } else { v / m })
            .collect::<Vec<f64>>()
    };
    let both = |rms: bool| ParamStats {
        omega: stat(|m| &m.omega, rms),
        zeta: stat(|m| &m.zeta, rms),
        bbar: stat(|m| &m.bbar, rms),
    };
    let rms = both(true);
    SeedSummary {
        estimator: first.estimator,
        precision: first.precision,
        rms_over_crlb: bound.map(|b| b.ratio(&rms.omega, &rms.zeta, &rms.bbar)),
        mean_rel_error: both(false),
        rms_rel_error: rms,
        max_rel_error: runs.iter().map(|r| r.rel_error.max()).fold(0.0, f64::max),
        failed_seeds: seeds
            .iter()
            .zip(&runs)
            .filter(|(_, r)| !r.estimate.is_valid())
            .map(|(&s, _)| s)
            .collect(),
        runs,
    }
}
