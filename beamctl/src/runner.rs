//! Run one estimator against a simulated rig and measure it.
//!
//! The estimator sees only what the firmware would: the held input u and the
//! sampled output y (plus optional noise), through its own filter bank.
//! Modal parameters are recovered at the telemetry rate ([`RunConfig::eval_every`])
//! and compared with the truth.

use crate::scenario::{output_scale, PlantSpec, Truth};
use beamest::estimator::{
    AdaptiveConfig, AdaptiveEstimator, Estimator, GradientConfig, GradientEstimator, Health,
    LeastSquaresConfig, LeastSquaresEstimator,
};
use beamest::excitation::SquareWave;
use beamest::filter_bank::{FilterConfig, OutputHold, Scaling, SignalScales};
use beamest::modal::modal_from_tf;
use beamest::model::{ModalParams, TransferFunction};
use beamest::rig::{noise_sd_for_snr, GaussianNoise, Rig, Sample};
use beamest::Real;
use serde::Serialize;

/// Which update law.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum EstimatorKind {
    /// The proposed law (eqs. 33–41).
    Adaptive,
    /// The gradient baseline (eq. 47).
    Gradient,
    /// The least-squares baseline (eq. 48).
    #[serde(rename = "ls")]
    LeastSquares,
}

impl EstimatorKind {
    /// All three, in report order.
    pub const ALL: [EstimatorKind; 3] = [Self::Adaptive, Self::Gradient, Self::LeastSquares];

    /// The name used on the command line and in reports.
    pub fn name(self) -> &'static str {
        match self {
            Self::Adaptive => "adaptive",
            Self::Gradient => "gradient",
            Self::LeastSquares => "ls",
        }
    }
}

/// Floating-point type of the estimator.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Precision {
    /// Single precision (Cortex-M4F class).
    F32,
    /// Double precision.
    F64,
}

/// Which gains.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Gains {
    /// The defaults of each law's config (scaled coordinates).
    Default,
    /// The paper's Section IV.A gains, mapped exactly to scaled coordinates
    /// (two modes only).
    Paper,
}

/// Everything that defines a run.
#[derive(Debug, Clone, PartialEq)]
pub struct RunConfig {
    /// The simulated beam.
    pub plant: PlantSpec,
    /// Update law.
    pub kind: EstimatorKind,
    /// Estimator float type.
    pub precision: Precision,
    /// Gain set.
    pub gains: Gains,
    /// Simulated seconds.
    pub duration_s: f64,
    /// Sample period.
    pub ts_s: f64,
    /// Filter pole λ (rad/s); `None` chooses it from the nominal plant
    /// ([`auto_lambda`]).
    pub lambda_rad_s: Option<f64>,
    /// y interpolation.
    pub hold: OutputHold,
    /// Square-wave amplitude (input units).
    pub u_amplitude: f64,
    /// Square-wave frequency.
    pub u_freq_hz: f64,
    /// White noise on y, as an SNR in dB relative to the noise-free y's RMS.
    pub snr_db: Option<f64>,
    /// Noise seed.
    pub seed: u64,
    /// Evaluate modal parameters every this many samples (10 → 1 kHz).
    pub eval_every: usize,
}

impl Default for RunConfig {
    /// The paper's simulation: its plant, 0.1·square(7 Hz), Ts = 0.1 ms,
    /// λ = 100, 20 s, the proposed law in f64 with default gains.
    fn default() -> Self {
        Self {
            plant: PlantSpec::Paper,
            kind: EstimatorKind::Adaptive,
            precision: Precision::F64,
            gains: Gains::Default,
            duration_s: 20.0,
            ts_s: 1e-4,
            lambda_rad_s: None,
            hold: OutputHold::default(),
            u_amplitude: 0.1,
            u_freq_hz: 7.0,
            snr_db: None,
            seed: 1,
            eval_every: 10,
        }
    }
}

/// Why a run could not start.
#[derive(Debug, Clone, PartialEq)]
pub enum RunError {
    /// Invalid plant.
    Plant(String),
    /// Invalid estimator configuration.
    Estimator(String),
    /// Invalid excitation or timing.
    Setup(String),
}

impl std::fmt::Display for RunError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::Plant(s) => write!(f, "invalid plant: {s}"),
            Self::Estimator(s) => write!(f, "invalid estimator settings: {s}"),
            Self::Setup(s) => write!(f, "invalid run settings: {s}"),
        }
    }
}

impl std::error::Error for RunError {}

/// Modal parameters and polynomial of an estimate or of the truth.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ModalSummary {
    /// ω_i (rad/s).
    pub omega: Vec<f64>,
    /// ζ_i.
    pub zeta: Vec<f64>,
    /// b̄_i.
    pub bbar: Vec<f64>,
    /// [a_{2n−1}, …, a_0].
    pub a: Vec<f64>,
    /// [b_{2n−2}, …, b_0].
    pub b: Vec<f64>,
}

impl ModalSummary {
    fn new(m: Option<&ModalParams<f64>>, tf: &TransferFunction<f64>) -> Self {
        let n = tf.modes;
        let (omega, zeta, bbar) = match m {
            Some(m) => (
                m.omega_rad_s[..n].to_vec(),
                m.zeta[..n].to_vec(),
                m.bbar[..n].to_vec(),
            ),
            None => (vec![f64::NAN; n], vec![f64::NAN; n], vec![f64::NAN; n]),
        };
        Self {
            omega,
            zeta,
            bbar,
            a: tf.a[..2 * n].to_vec(),
            b: tf.b[..2 * n - 1].to_vec(),
        }
    }
}

/// Relative errors of ω and ζ.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct RelError {
    /// |ω̂ − ω|/ω per mode.
    pub omega: Vec<f64>,
    /// |ζ̂ − ζ|/ζ per mode.
    pub zeta: Vec<f64>,
}

impl RelError {
    /// The largest of all.
    pub fn max(&self) -> f64 {
        self.omega
            .iter()
            .chain(self.zeta.iter())
            .fold(
                0.0f64,
                |m, &e| if e.is_nan() { f64::INFINITY } else { m.max(e) },
            )
    }
}

/// What a run measured (the JSON object of `beamctl simulate --json`).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct RunReport {
    /// Update law.
    pub estimator: EstimatorKind,
    /// Float type.
    pub precision: Precision,
    /// Simulated seconds.
    pub duration_s: f64,
    /// Samples processed.
    pub samples: u64,
    /// Final estimate.
    pub estimate: ModalSummary,
    /// Truth.
    pub truth: ModalSummary,
    /// Final relative errors.
    pub rel_error: RelError,
    /// Simulated time after which the largest relative ω/ζ error stays
    /// below 1% until the end (None if it never does).
    pub time_to_1pct_s: Option<f64>,
    /// Same for 0.1%.
    pub time_to_0p1pct_s: Option<f64>,
    /// λmin of the scaled P at the end (Lemma 1), None for the baselines.
    pub excitation_min_eig: Option<f64>,
    /// Largest relative ω/ζ error seen after the first second (None if the
    /// run is shorter).
    pub max_error_after_1s: Option<f64>,
    /// Samples rejected as non-finite or out of range.
    pub rejected_samples: u64,
    /// Law updates skipped (singular step).
    pub skipped_updates: u64,
    /// The estimator's state integrity check at the end of the run.
    pub state_ok: bool,
}

/// One telemetry-rate sample handed to an observer.
#[derive(Debug, Clone)]
pub struct Trace<'a> {
    /// Time of the sample (s).
    pub t_s: f64,
    /// Input u.
    pub u: f64,
    /// Measured y (with noise).
    pub y: f64,
    /// Θ̂ (physical units).
    pub theta: &'a [f64],
    /// Recovered modal parameters, if recovery succeeded.
    pub modal: Option<&'a ModalParams<f64>>,
    /// Largest relative ω/ζ error.
    pub max_rel_error: f64,
}

/// Run one configuration. `observer` is called at the evaluation rate.
pub fn run(cfg: &RunConfig, observer: &mut dyn FnMut(&Trace<'_>)) -> Result<RunReport, RunError> {
    let modes = cfg.plant.modes();
    match (modes, cfg.precision) {
        (1, Precision::F64) => run_sized::<f64, 2, 3, 6>(cfg, observer),
        (1, Precision::F32) => run_sized::<f32, 2, 3, 6>(cfg, observer),
        (2, Precision::F64) => run_sized::<f64, 4, 7, 28>(cfg, observer),
        (2, Precision::F32) => run_sized::<f32, 4, 7, 28>(cfg, observer),
        (3, Precision::F64) => run_sized::<f64, 6, 11, 66>(cfg, observer),
        (3, Precision::F32) => run_sized::<f32, 6, 11, 66>(cfg, observer),
        _ => Err(RunError::Plant(format!(
            "{modes} modes (supported: 1, 2, 3)"
        ))),
    }
}

/// Build the configured estimator for `D`, `NP` (`NS = NP(NP+1)/2`) as a
/// boxed trait object.
pub fn build_estimator<T: Real, const D: usize, const NP: usize, const NS: usize>(
    kind: EstimatorKind,
    gains: Gains,
    filter: &FilterConfig,
) -> Result<Box<dyn Estimator<T, NP>>, RunError> {
    let scaling = Scaling::<NP>::new(filter);
    let paper = |what: &str| -> Result<[f64; NP], RunError> {
        let v: &[f64] = match what {
            "h0" => &AdaptiveConfig::<7>::PAPER_H0_2_MODES,
            "g1" => &GradientConfig::<7>::PAPER_GAIN_2_MODES,
            _ => &LeastSquaresConfig::<7>::PAPER_GAIN0_2_MODES,
        };
        v.try_into().map_err(|_| {
            RunError::Estimator("the paper's gains are defined for 2 modes only".into())
        })
    };
    let err = |e| RunError::Estimator(format!("{e:?}"));
    Ok(match (kind, gains) {
        (EstimatorKind::Adaptive, Gains::Default) => Box::new(
            AdaptiveEstimator::<T, D, NP, NS>::new(filter, &AdaptiveConfig::default())
                .map_err(err)?,
        ),
        (EstimatorKind::Adaptive, Gains::Paper) => Box::new(
            AdaptiveEstimator::<T, D, NP, NS>::new(
                filter,
                &AdaptiveConfig::paper(&scaling, &paper("h0")?),
            )
            .map_err(err)?,
        ),
        (EstimatorKind::Gradient, Gains::Default) => Box::new(
            GradientEstimator::<T, D, NP>::new(filter, &GradientConfig::default()).map_err(err)?,
        ),
        (EstimatorKind::Gradient, Gains::Paper) => Box::new(
            GradientEstimator::<T, D, NP>::new(
                filter,
                &GradientConfig::from_physical(&scaling, &paper("g1")?),
            )
            .map_err(err)?,
        ),
        (EstimatorKind::LeastSquares, Gains::Default) => Box::new(
            LeastSquaresEstimator::<T, D, NP>::new(filter, &LeastSquaresConfig::default())
                .map_err(err)?,
        ),
        (EstimatorKind::LeastSquares, Gains::Paper) => Box::new(
            LeastSquaresEstimator::<T, D, NP>::new(
                filter,
                &LeastSquaresConfig::from_physical(&scaling, &paper("g2")?),
            )
            .map_err(err)?,
        ),
    })
}

/// Relative ω/ζ errors of an estimate (NaN where recovery failed).
pub fn rel_error(est: Option<&ModalParams<f64>>, truth: &ModalParams<f64>) -> RelError {
    let n = truth.modes;
    let mut e = RelError {
        omega: vec![f64::NAN; n],
        zeta: vec![f64::NAN; n],
    };
    if let Some(m) = est {
        if m.modes == n {
            for i in 0..n {
                e.omega[i] =
                    ((m.omega_rad_s[i] - truth.omega_rad_s[i]) / truth.omega_rad_s[i]).abs();
                e.zeta[i] = ((m.zeta[i] - truth.zeta[i]) / truth.zeta[i]).abs();
            }
        }
    }
    e
}

/// The default filter pole for a plant: the paper's λ = 100 rad/s for its
/// plant, otherwise the geometric mean √(ω_min·ω_max) of the nominal modes
/// (98 rad/s for the paper's plant — the paper's choice follows the same
/// rule). A λ far below the highest mode leaves P ill-conditioned: on a
/// 155/1520 rad/s plant λ = 100 stalls at 1e-3 while λ = 300 reaches 2e-7.
pub fn auto_lambda(plant: &PlantSpec) -> f64 {
    match plant {
        PlantSpec::Paper => 100.0,
        PlantSpec::Modal(m) => {
            let w = &m.omega_rad_s[..m.modes];
            let lo = w.iter().cloned().fold(f64::INFINITY, f64::min);
            let hi = w.iter().cloned().fold(0.0, f64::max);
            (lo * hi).sqrt()
        }
    }
}

/// The filter configuration a run uses (scales from the excitation and the
/// plant's static gain).
pub fn filter_config(cfg: &RunConfig, truth: &Truth) -> FilterConfig {
    FilterConfig {
        ts_s: cfg.ts_s,
        lambda_rad_s: cfg.lambda_rad_s.unwrap_or_else(|| auto_lambda(&cfg.plant)),
        scales: SignalScales {
            u_scale: if cfg.u_amplitude > 0.0 {
                cfg.u_amplitude
            } else {
                1.0
            },
            y_scale: output_scale(truth, cfg.u_amplitude),
        },
        hold: cfg.hold,
        ..FilterConfig::default()
    }
}

fn to_f64_tf<T: Real>(tf: &TransferFunction<T>) -> TransferFunction<f64> {
    TransferFunction {
        modes: tf.modes,
        a: tf.a.map(|v| v.to_f64()),
        b: tf.b.map(|v| v.to_f64()),
    }
}

fn to_f64_modal<T: Real>(m: &ModalParams<T>) -> ModalParams<f64> {
    ModalParams {
        modes: m.modes,
        omega_rad_s: m.omega_rad_s.map(|v| v.to_f64()),
        zeta: m.zeta.map(|v| v.to_f64()),
        bbar: m.bbar.map(|v| v.to_f64()),
        output_weight: m.output_weight.map(|v| v.to_f64()),
    }
}

/// Tracks "the time after which the error stays below a threshold".
#[derive(Debug, Clone, Copy)]
struct Settling {
    threshold: f64,
    since: Option<f64>,
}

impl Settling {
    fn new(threshold: f64) -> Self {
        Self {
            threshold,
            since: None,
        }
    }
    fn observe(&mut self, t: f64, err: f64) {
        if err < self.threshold {
            if self.since.is_none() {
                self.since = Some(t);
            }
        } else {
            self.since = None;
        }
    }
}

fn run_sized<T: Real, const D: usize, const NP: usize, const NS: usize>(
    cfg: &RunConfig,
    observer: &mut dyn FnMut(&Trace<'_>),
) -> Result<RunReport, RunError> {
    if !(cfg.duration_s > 0.0 && cfg.duration_s.is_finite()) {
        return Err(RunError::Setup("duration must be positive".into()));
    }
    if cfg.eval_every == 0 {
        return Err(RunError::Setup("eval_every must be at least 1".into()));
    }
    let truth = cfg.plant.truth();
    let plant = cfg
        .plant
        .plant(cfg.ts_s)
        .map_err(|e| RunError::Plant(format!("{e:?}")))?;
    let filter = filter_config(cfg, &truth);
    let mut est = build_estimator::<T, D, NP, NS>(cfg.kind, cfg.gains, &filter)?;
    let fs = 1.0 / cfg.ts_s;
    let square = SquareWave::<f64>::new(cfg.u_amplitude, cfg.u_freq_hz, fs)
        .map_err(|e| RunError::Setup(format!("excitation: {e:?}")))?;
    let samples = (cfg.duration_s / cfg.ts_s).round() as u64;
    let mut rig = Rig::new(plant, square);
    if let Some(snr) = cfg.snr_db {
        // RMS of the noise-free output over (up to) the first 2 s.
        let mut probe = rig.noise_free();
        let n = samples.min((2.0 / cfg.ts_s) as u64).max(1);
        let mut acc = 0.0;
        for _ in 0..n {
            let y = probe.tick().y;
            acc += y * y;
        }
        let rms = (acc / n as f64).sqrt();
        let noise = GaussianNoise::new(noise_sd_for_snr(rms, snr), cfg.seed)
            .map_err(|_| RunError::Setup("invalid SNR".into()))?;
        rig = rig.with_noise(noise);
    }
    let weights: Vec<T> = truth.modal.output_weight[..truth.modal.modes]
        .iter()
        .map(|&c| T::from_f64(c))
        .collect();
    let mut s1 = Settling::new(1e-2);
    let mut s01 = Settling::new(1e-3);
    let mut max_after_1s: Option<f64> = None;
    let mut theta64 = [0.0f64; NP];
    for k in 0..samples {
        let Sample { u, y } = rig.tick();
        est.step(T::from_f64(u), T::from_f64(y));
        if (k + 1) % cfg.eval_every as u64 == 0 || k + 1 == samples {
            // Real time of the newest sample: when the estimate is available.
            let t = k as f64 * cfg.ts_s;
            let modal = modal_from_tf(&est.transfer_function(), &weights)
                .ok()
                .map(|m| to_f64_modal(&m));
            let err = rel_error(modal.as_ref(), &truth.modal).max();
            s1.observe(t, err);
            s01.observe(t, err);
            if t >= 1.0 {
                max_after_1s = Some(max_after_1s.unwrap_or(0.0).max(err));
            }
            for (d, s) in theta64.iter_mut().zip(est.theta().iter()) {
                *d = s.to_f64();
            }
            observer(&Trace {
                t_s: t,
                u,
                y,
                theta: &theta64,
                modal: modal.as_ref(),
                max_rel_error: err,
            });
        }
    }
    // Recover in the estimator's own precision, as the firmware does.
    let est_tf = est.transfer_function();
    let tf = to_f64_tf(&est_tf);
    let modal = modal_from_tf(&est_tf, &weights)
        .ok()
        .map(|m| to_f64_modal(&m));
    let health: Health = est.health();
    Ok(RunReport {
        estimator: cfg.kind,
        precision: cfg.precision,
        duration_s: samples as f64 * cfg.ts_s,
        samples,
        estimate: ModalSummary::new(modal.as_ref(), &tf),
        truth: ModalSummary::new(Some(&truth.modal), &truth.tf),
        rel_error: rel_error(modal.as_ref(), &truth.modal),
        time_to_1pct_s: s1.since,
        time_to_0p1pct_s: s01.since,
        excitation_min_eig: est.excitation_level().map(|v| v.to_f64()),
        max_error_after_1s: max_after_1s,
        rejected_samples: health.rejected.into(),
        skipped_updates: health.skipped.into(),
        state_ok: health.state_ok,
    })
}
