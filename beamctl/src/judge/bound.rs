//! The Cramér–Rao bound of a configured experiment ([`beamest::crlb`]) as
//! `beamctl` reports it: before a run, what accuracy the experiment can
//! give at best (`beamctl crlb`); after it, how close each estimator came
//! (error ÷ bound in `beamctl simulate` with noise, and `beamctl replay
//! --crlb` at the estimate).
//!
//! An experiment is a plant (or an estimate) as a transfer function with
//! its output weights, the held input sequence from rest, the sample
//! period, and white Gaussian noise on the sampled y given as a standard
//! deviation σ or as an SNR in dB relative to the RMS of the noise-free y
//! over the whole record (the core's and `beamctl simulate`'s definition).
//!
//! The bound depends on what is unknown ([`ModelSet`]): by default the
//! estimators' own transfer-function set (4n − 1 coefficients, eq. 29),
//! which every estimator here identifies; [`ModelSet::Modal`] (the paper's
//! ω, ζ, b̄ with the output and velocity weights known) is smaller, e.g.
//! half as large on ζ1 for the paper's plant, and no estimator of Θ can
//! reach it.

use beamest::crlb::{CrbError, FisherAccumulator, ModelSet};
use beamest::model::TransferFunction;
use serde::Serialize;

/// How loud the measurement noise is.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum NoiseLevel {
    /// Signal-to-noise ratio in dB relative to the RMS of the noise-free y
    /// over the record.
    SnrDb(f64),
    /// Standard deviation of the noise on y (units of y).
    Sd(f64),
}

/// The name of a model set in reports: `"transfer_function"` or `"modal"`.
pub fn model_set_name(set: ModelSet) -> &'static str {
    match set {
        ModelSet::TransferFunction => "transfer_function",
        ModelSet::Modal => "modal",
    }
}

/// A description of a model set for a human reader.
pub fn model_set_description(set: ModelSet, modes: usize) -> String {
    match set {
        ModelSet::TransferFunction => format!(
            "transfer-function set: the estimators' {} coefficients of B(s)/A(s) unknown (eq. 29)",
            4 * modes - 1
        ),
        ModelSet::Modal => format!(
            "modal set: the {} parameters ω, ζ, b̄ unknown, output and velocity weights known (eq. 23)",
            3 * modes
        ),
    }
}

/// The bound on one kind of parameter, per mode.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ParamBound {
    /// The parameter's value in the bounded model.
    pub value: Vec<f64>,
    /// Absolute 1σ bound.
    pub sd: Vec<f64>,
    /// Relative 1σ bound, sd/|value|.
    pub rel: Vec<f64>,
}

/// The Cramér–Rao bound of an experiment (the `crlb` JSON object).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ExperimentBound {
    /// `"transfer_function"` or `"modal"` (see [`model_set_name`]).
    pub model_set: &'static str,
    /// Number of unknowns of that set.
    pub parameters: usize,
    /// Number of modes.
    pub modes: usize,
    /// Samples of the experiment.
    pub samples: u64,
    /// Sample period (s).
    pub ts_s: f64,
    /// σ of the white noise on y (units of y).
    pub sigma: f64,
    /// RMS of the model's noise-free output over the record.
    pub rms_y: f64,
    /// 20·log10(rms_y/σ).
    pub snr_db: f64,
    /// Bound on ω_i (rad/s).
    pub omega: ParamBound,
    /// Bound on ζ_i.
    pub zeta: ParamBound,
    /// Bound on b̄_i (b̄ = α/c; in the transfer-function set by the delta
    /// method through eq. 32).
    pub bbar: ParamBound,
}

/// An estimate's relative errors divided by the relative bound, per mode.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct BoundRatio {
    /// |ω̂ − ω|/ω ÷ the relative bound on ω.
    pub omega: Vec<f64>,
    /// |ζ̂ − ζ|/ζ ÷ the relative bound on ζ.
    pub zeta: Vec<f64>,
    /// |b̂̄ − b̄|/|b̄| ÷ the relative bound on b̄.
    pub bbar: Vec<f64>,
}

impl ExperimentBound {
    /// Relative errors `(ω, ζ, b̄)` per mode divided by the relative bounds.
    pub fn ratio(&self, omega: &[f64], zeta: &[f64], bbar: &[f64]) -> BoundRatio {
        let div = |e: &[f64], b: &[f64]| e.iter().zip(b).map(|(e, b)| e / b).collect();
        BoundRatio {
            omega: div(omega, &self.omega.rel),
            zeta: div(zeta, &self.zeta.rel),
            bbar: div(bbar, &self.bbar.rel),
        }
    }
}

/// The bound for the model `tf` (output weights `weights`, one per mode)
/// driven from rest by `inputs` (held over each period Ts; a non-finite
/// input is replaced by the last finite one, as the estimators do), with
/// noise `noise` on y, for the model set `set`.
///
/// # Errors
/// [`CrbError`]: the model is not a set of stable oscillatory modes, σ is
/// not positive, or the input does not excite every parameter.
pub fn experiment_bound(
    tf: &TransferFunction<f64>,
    weights: &[f64],
    ts_s: f64,
    inputs: impl IntoIterator<Item = f64>,
    noise: NoiseLevel,
    set: ModelSet,
) -> Result<ExperimentBound, CrbError> {
    let mut acc = FisherAccumulator::from_tf(tf, weights, ts_s)?;
    let mut held = 0.0;
    for u in inputs {
        if u.is_finite() {
            held = u;
        }
        acc.push(held);
    }
    let sigma = match noise {
        NoiseLevel::SnrDb(db) => acc.sigma_for_snr_db(db),
        NoiseLevel::Sd(sd) => sd,
    };
    let b = acc.bound(set, sigma)?;
    let n = b.modes;
    let m = acc.model();
    let bbar = acc.bbar();
    let param = |value: &[f64], sd: &[f64], rel: &[f64]| ParamBound {
        value: value[..n].to_vec(),
        sd: sd[..n].to_vec(),
        rel: rel[..n].to_vec(),
    };
    let rms_y = acc.rms_output();
    Ok(ExperimentBound {
        model_set: model_set_name(set),
        parameters: set.params(n),
        modes: n,
        samples: acc.samples(),
        ts_s,
        sigma,
        rms_y,
        snr_db: 20.0 * (rms_y / sigma).log10(),
        omega: param(&m.omega_rad_s, &b.omega_sd, &b.omega_rel),
        zeta: param(&m.zeta, &b.zeta_sd, &b.zeta_rel),
        bbar: param(&bbar, &b.bbar_sd, &b.bbar_rel),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use beamest::excitation::SquareWave;
    use beamest::model::paper_plant_tf;

    fn paper_input(seconds: f64) -> impl Iterator<Item = f64> {
        let mut sq = SquareWave::<f64>::paper();
        (0..(seconds * 1e4) as usize).map(move |_| sq.next_sample())
    }

    #[test]
    fn snr_and_sigma_give_the_same_bound() {
        let tf = paper_plant_tf();
        let w = [-2.0, 2.0];
        let set = ModelSet::TransferFunction;
        let a = experiment_bound(
            &tf,
            &w,
            1e-4,
            paper_input(5.0),
            NoiseLevel::SnrDb(40.0),
            set,
        )
        .unwrap();
        assert!((a.snr_db - 40.0).abs() < 1e-9);
        let b = experiment_bound(
            &tf,
            &w,
            1e-4,
            paper_input(5.0),
            NoiseLevel::Sd(a.sigma),
            set,
        )
        .unwrap();
        assert_eq!(a, b);
        assert_eq!(a.parameters, 7);
        assert_eq!(a.samples, 50_000);
        // A NaN input is held, not propagated.
        let nan = paper_input(5.0)
            .enumerate()
            .map(|(k, u)| if k == 7 { f64::NAN } else { u });
        let c = experiment_bound(&tf, &w, 1e-4, nan, NoiseLevel::Sd(a.sigma), set).unwrap();
        assert!(c.zeta.rel.iter().all(|v| v.is_finite()));
        let r = a.ratio(
            &[a.omega.rel[0], 0.0],
            &[2.0 * a.zeta.rel[0], 0.0],
            &[0.0, 0.0],
        );
        assert_eq!(r.omega, [1.0, 0.0]);
        assert_eq!(r.zeta, [2.0, 0.0]);
    }

    #[test]
    fn an_unexcited_experiment_is_an_error() {
        let e = experiment_bound(
            &paper_plant_tf(),
            &[-2.0, 2.0],
            1e-4,
            std::iter::repeat_n(0.0, 1000),
            NoiseLevel::Sd(1e-5),
            ModelSet::Modal,
        );
        assert!(e.is_err());
    }
}
