//! The estimator flags `simulate` and `replay` share (law, precision,
//! gains, where λ comes from), validated into what the runs use.

use crate::cli::args::{EstimatorArgs, EstimatorChoice, OutputChoice, PrecisionChoice};
use crate::error::CliError;
use crate::run::estimator::{EstimatorKind, Gains};
use crate::run::Precision;
use beamest::tuning::LambdaSource;
use std::f64::consts::PI;

/// The filter pole of the paper's Λ(s) = (s+100)^4 (Section IV.A), used
/// with the paper's gain presets.
pub const PAPER_LAMBDA_RAD_S: f64 = 100.0;

/// Validated estimator settings.
#[derive(Debug, Clone, PartialEq)]
pub struct EstimatorPlan {
    /// Laws, in report order.
    pub kinds: Vec<EstimatorKind>,
    /// Float type.
    pub precision: Precision,
    /// Gain set.
    pub gains: Gains,
    /// Where λ comes from.
    pub lambda: LambdaSource,
    /// How λ is chosen, for the report heading.
    pub lambda_label: String,
    /// What the sensor measures (`replay` chooses `auto` from the data).
    pub output: OutputChoice,
}

/// Validate the shared flags for an `modes`-mode model.
pub fn plan(args: &EstimatorArgs, modes: usize) -> Result<EstimatorPlan, CliError> {
    let kinds = match args.estimator {
        // `replay` resolves `auto` itself (crate::judge::select) before
        // it gets here; anywhere else it is the firmware's default law.
        EstimatorChoice::Auto => vec![EstimatorKind::Adaptive],
        EstimatorChoice::One(k) => vec![k],
        EstimatorChoice::All => EstimatorKind::ALL.to_vec(),
    };
    let feedthrough = args.estimator == EstimatorChoice::One(EstimatorKind::Feedthrough);
    if feedthrough && modes != 2 {
        return Err(CliError::usage(
            "--estimator feedthrough",
            format!(
                "the feedthrough estimator is defined for 2 modes only (this model has {modes})"
            ),
        ));
    }
    if feedthrough
        && !matches!(
            args.output,
            OutputChoice::Auto | OutputChoice::Given(beam_protocol::OutputKind::Strain)
        )
    {
        return Err(CliError::usage(
            "--estimator feedthrough",
            "the feedthrough estimator models a strain (or displacement) output only: a velocity or acceleration sensor sees the modes above the band as s·D or s²·D, which a held input makes impulses between the samples",
        ));
    }
    if feedthrough && (args.paper_gains || args.paper_exp_gains) {
        return Err(CliError::usage(
            "--estimator feedthrough",
            "the feedthrough estimator has no published gains: drop --paper-gains/--paper-exp-gains",
        ));
    }
    let precision = match args.precision {
        PrecisionChoice::F64 => Precision::F64,
        PrecisionChoice::F32 => Precision::F32,
    };
    let (gains, preset) = match (args.paper_gains, args.paper_exp_gains) {
        (true, _) => (Gains::Paper, Some("--paper-gains")),
        (_, true) => (Gains::PaperExperiment, Some("--paper-exp-gains")),
        _ => (Gains::Default, None),
    };
    if let Some(flag) = preset {
        if modes != 2 {
            return Err(CliError::usage(
                flag,
                format!("the paper's gains are defined for 2 modes only (this model has {modes})"),
            ));
        }
    }
    let (lambda, lambda_label) = if let Some(l) = args.lambda {
        if !(l.is_finite() && l > 0.0) {
            return Err(CliError::usage(
                "--lambda",
                format!("the filter pole must be a finite number > 0 rad/s (got {l})"),
            ));
        }
        (
            LambdaSource::Fixed(l),
            format!("λ = {} rad/s (fixed)", short(l)),
        )
    } else if let Some(band) = &args.band_hz {
        let (f1, f2) = match band.as_slice() {
            &[f1, f2] => (f1, f2),
            _ => {
                return Err(CliError::usage(
                    "--band-hz",
                    format!("expected two frequencies F1,F2 in Hz (got {})", band.len()),
                ))
            }
        };
        if !(f1.is_finite() && f2.is_finite() && f1 > 0.0 && f1 <= f2) {
            return Err(CliError::usage(
                "--band-hz",
                format!("need finite 0 < F1 <= F2 (got {f1},{f2})"),
            ));
        }
        let (lo, hi) = (2.0 * PI * f1, 2.0 * PI * f2);
        (
            LambdaSource::Band {
                lo_rad_s: lo,
                hi_rad_s: hi,
            },
            format!(
                "λ: auto, from the band {}–{} Hz ({} rad/s), re-centred",
                short(f1),
                short(f2),
                short((lo * hi).sqrt())
            ),
        )
    } else if let Some(path) = &args.beam {
        let params = crate::cli::model::load(path)?;
        let m = params.modal(modes).map_err(|e| {
            CliError::usage(
                "--beam",
                format!(
                    "{}: {}",
                    path.display(),
                    crate::cli::model::explain(e, &params)
                ),
            )
        })?;
        let (lo, hi) = (m.omega_rad_s[0], m.omega_rad_s[modes - 1]);
        (
            LambdaSource::Band {
                lo_rad_s: lo,
                hi_rad_s: hi,
            },
            format!(
                "λ: auto, from the beam model's band {}–{} rad/s ({} rad/s), re-centred",
                short(lo),
                short(hi),
                short((lo * hi).sqrt())
            ),
        )
    } else if preset.is_some() {
        (
            LambdaSource::Fixed(PAPER_LAMBDA_RAD_S),
            "λ = 100 rad/s (the paper's Λ(s) = (s+100)⁴)".to_string(),
        )
    } else {
        (
            LambdaSource::Data,
            "λ: auto, from the data, re-centred".to_string(),
        )
    };
    Ok(EstimatorPlan {
        kinds,
        precision,
        gains,
        lambda,
        lambda_label,
        output: args.output,
    })
}

fn short(v: f64) -> String {
    crate::io::table::short(v, 4)
}
