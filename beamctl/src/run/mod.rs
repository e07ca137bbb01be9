//! Run estimators against a simulated rig and measure them.
//!
//! The estimators see only what the firmware would: the held input u and
//! the sampled output y (plus optional noise, and the run's events:
//! [`crate::run::events`]), screened by the sensor guard ([`beamest::guard`],
//! via [`crate::run::session`]), through their own filter banks, with λ and the
//! signal scales chosen by the truth-free rule ([`beamest::tuning`], via
//! [`crate::run::tuned`]). Modal parameters are recovered at the telemetry rate
//! ([`RunConfig::eval_every`]) and compared here, and only here, with the
//! truth in force (after a plant step, the new plant's).
//!
//! The run machinery, from the bottom up: [`error`] (why a run cannot
//! start), [`plant`] (which beam, its truth), [`estimator`] (which law, at
//! which gains), [`tuned`] (one estimator under the tuning rule),
//! [`session`] (several fed the same samples and evaluated: what `beamctl
//! replay` runs on a file), [`events`] (a simulated run's events), this
//! module (the simulated rig of a run and the run loop) and [`seeds`] (one
//! configuration over several noise seeds).

pub mod disturbance;
pub mod drive;
pub mod error;
pub mod estimator;
pub mod events;
pub mod feed;
pub mod interrupt;
pub mod plant;
pub mod seeds;
pub mod session;
pub mod tuned;

use crate::judge::bound::{experiment_bound, BoundRatio, ExperimentBound, NoiseLevel};
use crate::judge::fit::{self, Model};
use crate::judge::frf::PowerSpectrum;
use crate::judge::verdict::RecordEvidence;
use crate::run::drive::{drive, Drive};
use crate::run::error::RunError;
use crate::run::estimator::{EstimatorKind, Gains};
use crate::run::events::{
    sample_at, scenario, stepped_plant, truth_of, Detection, Events, ScenarioReport, Settling,
};
use crate::run::plant::{PlantSpec, Truth};
use crate::run::session::{
    drift_every, guard_config, Eval, ModalSummary, Session, SupervisionReport,
};
use crate::run::tuned::{Build, RobustStatus};
use beam_protocol::OutputKind;
use beamest::crlb::ModelSet;
use beamest::filter_bank::{FilterConfig, OutputHold, SignalScales};
use beamest::model::ModalParams;
use beamest::rig::{noise_sd_for_snr, GaussianNoise, ModalPlant, Rig, Sample, ScenarioRig};
use beamest::tuning::{LambdaSource, TuningConfig};
use beamest::Real;
use disturbance::{DisturbedRig, HumLine, NoiseColour};
use serde::Serialize;

/// Floating-point type of the estimator.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Precision {
    /// Single precision (Cortex-M4F class).
    F32,
    /// Double precision.
    F64,
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
    /// Where λ comes from (default: the data; see [`beamest::tuning`]).
    pub lambda: LambdaSource,
    /// U0, Y0 if known (default: RMS over the start-up window).
    pub scales: Option<SignalScales>,
    /// y interpolation.
    pub hold: OutputHold,
    /// Square-wave amplitude (input units).
    pub u_amplitude: f64,
    /// Square-wave frequency.
    pub u_freq_hz: f64,
    /// The firmware's excitation (wire settings, [`drive`](mod@drive)) instead
    /// of the square wave above; None: the square wave.
    pub excitation: Option<beam_protocol::Excitation>,
    /// White noise on y, as an SNR in dB relative to the RMS of the
    /// noise-free y over the whole run (ignored if `noise_sd` is given).
    pub snr_db: Option<f64>,
    /// White noise on y, as a standard deviation (units of y).
    pub noise_sd: Option<f64>,
    /// With noise: also compute the Cramér–Rao bound of the experiment
    /// for this model set and report each estimator's error ÷ bound.
    pub crlb: Option<ModelSet>,
    /// Noise seed.
    pub seed: u64,
    /// Evaluate modal parameters every this many samples (10 → 1 kHz).
    pub eval_every: usize,
    /// Events of the run: plant change, excitation pause, sensor fault,
    /// modes beyond the model ([`crate::run::events`]).
    pub events: Events,
    /// The converter's rails in units of y, [min, max]: the sensor guard's
    /// saturation and open-bridge tests, and what a saturated or open
    /// sensor reads (None: unknown).
    pub range: Option<[f64; 2]>,
    /// The guard's level corrections (DC-removing high-pass on u and y,
    /// offset-step removal; [`beamest::guard`]).
    pub level_correction: bool,
    /// The guard's residual monitor ([`crate::run::session::Session::with_monitor`]).
    pub residual_monitor: bool,
    /// Lines in y that u does not drive ([`disturbance`]).
    pub hum: Vec<HumLine>,
    /// The measurement noise's spectrum ([`disturbance`]).
    pub noise_colour: NoiseColour,
    /// What the sensor measures: the simulated beam is read as strain (or
    /// displacement), velocity or acceleration, and the estimators' model
    /// is s^r·B/A accordingly.
    pub output: OutputKind,
}

impl Default for RunConfig {
    /// The paper's simulation: its plant, 0.1·square(7 Hz), Ts = 0.1 ms,
    /// 20 s, the proposed law in f64 with default gains, λ and scales by
    /// the truth-free rule.
    fn default() -> Self {
        Self {
            plant: PlantSpec::Paper,
            kind: EstimatorKind::Adaptive,
            precision: Precision::F64,
            gains: Gains::Default,
            duration_s: 20.0,
            ts_s: 1e-4,
            lambda: LambdaSource::Data,
            scales: None,
            hold: OutputHold::default(),
            u_amplitude: 0.1,
            u_freq_hz: 7.0,
            excitation: None,
            snr_db: None,
            noise_sd: None,
            crlb: None,
            seed: 1,
            eval_every: 10,
            events: Events::default(),
            range: None,
            level_correction: false,
            residual_monitor: false,
            hum: Vec::new(),
            noise_colour: NoiseColour::White,
            output: OutputKind::Strain,
        }
    }
}

impl RunConfig {
    /// The tuning rule's settings for this run.
    pub fn tuning(&self) -> TuningConfig {
        TuningConfig {
            hold: self.hold,
            scales: self.scales,
            output: self.output,
            ..TuningConfig::new(self.ts_s, self.lambda)
        }
    }

    /// The true ω, ζ, b̄ and transfer function of the simulated beam as its
    /// sensor reads it.
    pub fn truth(&self) -> Truth {
        let mut t = self.plant.truth();
        t.tf.output = self.output;
        t
    }

    /// An exact discrete simulator of the beam as its sensor reads it.
    ///
    /// # Errors
    /// An invalid plant.
    pub fn sim_plant(&self) -> Result<ModalPlant<f64>, RunError> {
        self.plant
            .plant(self.ts_s)
            .and_then(|p| p.with_output(self.output))
            .map_err(|e| RunError::Plant(format!("{e:?}")))
    }
}

/// Relative errors of ω, ζ and b̄.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct RelError {
    /// |ω̂ − ω|/ω per mode.
    pub omega: Vec<f64>,
    /// |ζ̂ − ζ|/ζ per mode.
    pub zeta: Vec<f64>,
    /// |b̂̄ − b̄|/|b̄| per mode.
    pub bbar: Vec<f64>,
}

impl RelError {
    /// The largest ω/ζ error.
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
    /// The feedthrough D (see [`session::Outcome::feedthrough`]); absent for the
    /// estimators without one.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub feedthrough: Option<f64>,
    /// Largest relative ω/ζ error seen after the first second (None if the
    /// run is shorter).
    pub max_error_after_1s: Option<f64>,
    /// Samples rejected as non-finite or out of range.
    pub rejected_samples: u64,
    /// Law updates skipped (singular step).
    pub skipped_updates: u64,
    /// Law updates applied (0: the law never ran, no estimate).
    pub law_updates: u64,
    /// The estimator's state integrity check at the end of the run.
    pub state_ok: bool,
    /// The final filter pole λ (rad/s).
    pub lambda_rad_s: Option<f64>,
    /// How the tuning rule ended (see [`session::Outcome::tuning`]).
    pub tuning: &'static str,
    /// Every estimator the tuning rule built.
    pub builds: Vec<Build>,
    /// Model output vs measured output, % (see [`session::Outcome::fit_percent`]).
    pub fit_percent: Option<f64>,
    /// Movement over the last 10% of the run (see
    /// [`session::Outcome::drift_last_10pct`]).
    pub drift_last_10pct: Option<f64>,
    /// σ of the white noise added to y (None: noise-free).
    pub noise_sd: Option<f64>,
    /// The Cramér–Rao bound of the run's experiment (with noise and
    /// [`RunConfig::crlb`]).
    pub crlb: Option<ExperimentBound>,
    /// `rel_error` ÷ the relative bound, per parameter.
    pub error_over_crlb: Option<BoundRatio>,
    /// The robust estimator's phase, a-posteriori noise RMS and model
    /// updates (None for the paper's laws).
    pub robust: Option<RobustStatus>,
    /// The supervisor's state at the end (see [`session::Outcome::supervision`]).
    pub supervision: Option<SupervisionReport>,
    /// The final estimate's physical-validity flags (see
    /// [`session::Outcome::validity`]).
    pub validity: Vec<&'static str>,
    /// The sensor guard's counters.
    pub guard: crate::run::session::GuardReport,
    /// Whether the estimate can be trusted ([`session::Outcome::verdict`]).
    pub verdict: crate::judge::verdict::Verdict,
    /// The lines in y ([`RunConfig::hum`]; absent when none).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub hum: Vec<HumLine>,
    /// The measurement noise's spectrum ([`RunConfig::noise_colour`]).
    pub noise_colour: NoiseColour,
    /// With events: what they did (tracking time, fault latency).
    pub scenario: Option<ScenarioReport>,
}

/// One telemetry-rate sample handed to an observer.
#[derive(Debug, Clone)]
pub struct Trace<'a> {
    /// Which law.
    pub estimator: EstimatorKind,
    /// Time of the sample (s).
    pub t_s: f64,
    /// Input u.
    pub u: f64,
    /// Measured y (with noise).
    pub y: f64,
    /// Θ̂ (physical units; NaN during the start-up window).
    pub theta: &'a [f64],
    /// Recovered modal parameters, if recovery succeeded.
    pub modal: Option<&'a ModalParams<f64>>,
    /// The estimator's λ (rad/s), once built.
    pub lambda_rad_s: Option<f64>,
    /// Largest relative ω/ζ error, when the truth is known (simulation).
    pub max_rel_error: Option<f64>,
    /// The supervisor's state (excitation flag and reason, changes).
    pub supervision: Option<SupervisionReport>,
    /// The physical-validity flags of the estimate
    /// ([`beamest::modal::Validity`] bits; 0 = valid).
    pub validity: u8,
}

/// What a run reports as it goes.
pub trait Observer {
    /// Every sample, after every estimator has been stepped (and after the
    /// [`Observer::estimate`] calls of that sample).
    fn sample(&mut self, _k: u64, _t_s: f64, _u: f64, _y: f64) {}
    /// At the evaluation rate, once per estimator (`index` in run order).
    fn estimate(&mut self, _index: usize, _trace: &Trace<'_>) {}
    /// The sensor guard's screening of sample `k`, just before
    /// [`Observer::sample`] (only when [`Observer::wants_samples`]).
    fn screening(&mut self, _k: u64, _s: &beamest::guard::Screening) {}
    /// Whether [`Observer::sample`] is wanted (it costs a call per sample).
    fn wants_samples(&self) -> bool {
        false
    }
    /// Asked after each evaluation: true stops the run with
    /// [`RunError::Interrupted`] (the Python package's Ctrl-C).
    fn stopped(&mut self) -> bool {
        false
    }
}

impl<F: FnMut(&Trace<'_>)> Observer for F {
    fn estimate(&mut self, _index: usize, trace: &Trace<'_>) {
        self(trace)
    }
}

/// Run one configuration. `observer` is called at the evaluation rate.
pub fn run(cfg: &RunConfig, observer: &mut dyn FnMut(&Trace<'_>)) -> Result<RunReport, RunError> {
    let mut obs = observer;
    let mut reports = run_many(cfg, &[cfg.kind], &mut obs)?;
    reports
        .pop()
        .ok_or_else(|| RunError::Setup("no estimator".into()))
}

/// Run several laws on the same simulated samples (`cfg.kind` is ignored),
/// side by side; one report per law, in the order of `kinds`.
pub fn run_many(
    cfg: &RunConfig,
    kinds: &[EstimatorKind],
    observer: &mut dyn Observer,
) -> Result<Vec<RunReport>, RunError> {
    let modes = cfg.plant.modes();
    match (modes, cfg.precision) {
        (1, Precision::F64) => run_sized::<f64, 2, 3, 6>(cfg, kinds, observer),
        (1, Precision::F32) => run_sized::<f32, 2, 3, 6>(cfg, kinds, observer),
        (2, Precision::F64) => run_sized::<f64, 4, 7, 28>(cfg, kinds, observer),
        (2, Precision::F32) => run_sized::<f32, 4, 7, 28>(cfg, kinds, observer),
        (3, Precision::F64) => run_sized::<f64, 6, 11, 66>(cfg, kinds, observer),
        (3, Precision::F32) => run_sized::<f32, 6, 11, 66>(cfg, kinds, observer),
        _ => Err(RunError::Plant(format!(
            "{modes} modes (supported: 1, 2, 3)"
        ))),
    }
}

/// Relative ω/ζ errors of an estimate (NaN where recovery failed).
pub fn rel_error(est: Option<&ModalParams<f64>>, truth: &ModalParams<f64>) -> RelError {
    let n = truth.modes;
    let mut e = RelError {
        omega: vec![f64::NAN; n],
        zeta: vec![f64::NAN; n],
        bbar: vec![f64::NAN; n],
    };
    if let Some(m) = est {
        if m.modes == n {
            for i in 0..n {
                e.omega[i] =
                    ((m.omega_rad_s[i] - truth.omega_rad_s[i]) / truth.omega_rad_s[i]).abs();
                e.zeta[i] = ((m.zeta[i] - truth.zeta[i]) / truth.zeta[i]).abs();
                e.bbar[i] = ((m.bbar[i] - truth.bbar[i]) / truth.bbar[i]).abs();
            }
        }
    }
    e
}

/// The filter configuration the truth-free rule ends with on this run
/// (its last build), for code that needs a fixed configuration chosen as
/// `beamctl simulate` would choose it (benchmarks, fault-injection tests).
pub fn tuned_filter(cfg: &RunConfig) -> Result<FilterConfig, RunError> {
    let report = run(cfg, &mut |_| {})?;
    let b = report
        .builds
        .last()
        .ok_or_else(|| RunError::Setup("the tuning rule never built an estimator".into()))?;
    Ok(FilterConfig {
        ts_s: cfg.ts_s,
        lambda_rad_s: b.lambda_rad_s,
        scales: SignalScales {
            u_scale: b.u_scale,
            y_scale: b.y_scale,
        },
        hold: cfg.hold,
        output: cfg.output,
        ..FilterConfig::default()
    })
}

/// The noise-free rig of a run: plant and drive ([`drive()`]).
pub(crate) fn clean_rig(cfg: &RunConfig) -> Result<Rig<f64, Drive>, RunError> {
    Ok(Rig::new(cfg.sim_plant()?, drive(cfg)?))
}

/// σ of the run's measurement noise: `noise_sd` if given, else (with an
/// SNR) the RMS of the noise-free y over the whole run / 10^(SNR/20) — the
/// definition of the Cramér–Rao bound's SNR (`beamest::crlb`); None without
/// noise.
pub fn noise_sd(cfg: &RunConfig) -> Result<Option<f64>, RunError> {
    if let Some(sd) = cfg.noise_sd {
        return Ok(Some(sd));
    }
    let Some(snr) = cfg.snr_db else {
        return Ok(None);
    };
    Ok(Some(noise_sd_for_snr(clean_rms_y(cfg)?, snr)))
}

/// RMS of the noise-free y over the whole run (the beam as it moves).
fn clean_rms_y(cfg: &RunConfig) -> Result<f64, RunError> {
    let mut probe = events_rig(cfg, false)?;
    let n = samples(cfg).max(1);
    let mut acc = 0.0;
    for _ in 0..n {
        let y = probe.tick().y;
        acc += y * y;
    }
    Ok((acc / n as f64).sqrt())
}

/// The simulated rig of a run with its events ([`RunConfig::events`]),
/// (with an SNR or a σ) noise on y of σ = [`noise_sd`], white or coloured
/// ([`RunConfig::noise_colour`]), and the lines of [`RunConfig::hum`].
pub fn scenario_rig(cfg: &RunConfig) -> Result<DisturbedRig, RunError> {
    let rig = events_rig(cfg, true)?;
    let sd = noise_sd(cfg)?;
    let white = cfg.noise_colour == NoiseColour::White;
    let rig = match sd {
        Some(sd) if white => {
            let noise = GaussianNoise::new(sd, cfg.seed)
                .map_err(|_| RunError::Setup(format!("invalid noise level (σ = {sd})")))?;
            rig.with_noise(noise)
        }
        _ => rig,
    };
    let rms_y = if cfg.hum.is_empty() {
        0.0
    } else {
        clean_rms_y(cfg)?
    };
    DisturbedRig::new(
        rig,
        &cfg.hum,
        rms_y,
        cfg.noise_colour,
        sd,
        cfg.ts_s,
        cfg.seed,
    )
    .map_err(RunError::Setup)
}

/// The simulated rig of a run without its events: plant, drive and (with
/// an SNR or a σ) white noise on y of σ = [`noise_sd`].
pub fn rig(cfg: &RunConfig) -> Result<Rig<f64, Drive>, RunError> {
    let rig = clean_rig(cfg)?;
    Ok(match noise_sd(cfg)? {
        Some(sd) => {
            let noise = GaussianNoise::new(sd, cfg.seed)
                .map_err(|_| RunError::Setup(format!("invalid noise level (σ = {sd})")))?;
            rig.with_noise(noise)
        }
        None => rig,
    })
}

/// The Cramér–Rao bound of a run's experiment (its plant, excitation,
/// duration and noise σ) for `set`; None without noise.
pub fn run_bound(cfg: &RunConfig, set: ModelSet) -> Result<Option<ExperimentBound>, RunError> {
    let Some(sd) = noise_sd(cfg)? else {
        return Ok(None);
    };
    let truth = cfg.truth();
    let u = drive(cfg)?;
    let n = samples(cfg);
    experiment_bound(
        &truth.tf,
        &truth.modal.output_weight[..truth.modal.modes],
        cfg.ts_s,
        u.take(n as usize),
        NoiseLevel::Sd(sd),
        set,
    )
    .map(Some)
    .map_err(|e| RunError::Setup(format!("Cramér–Rao bound: {e}")))
}

/// The noise-free rig of a run with its events (`with_fault`: the sensor
/// fault too; without it, the beam as it moves, for the SNR).
pub(crate) fn events_rig(
    cfg: &RunConfig,
    with_fault: bool,
) -> Result<ScenarioRig<f64, Drive>, RunError> {
    let rig = crate::run::clean_rig(cfg)?;
    let ev = &cfg.events;
    let truth = cfg.truth();
    let setup = |e: String| RunError::Setup(e);
    let mut sc = scenario(ev, rig.plant(), &truth, cfg.ts_s, 1.0, cfg.range).map_err(setup)?;
    if with_fault && ev.fault.is_some() {
        // Default fault levels are relative to the moving beam's RMS.
        let mut probe = events_rig(cfg, false)?;
        let n = crate::run::samples(cfg).max(1);
        let acc: f64 = (0..n).map(|_| probe.tick().y.powi(2)).sum();
        let rms = (acc / n as f64).sqrt();
        sc = scenario(ev, rig.plant(), &truth, cfg.ts_s, rms, cfg.range).map_err(setup)?;
    } else {
        sc.fault = None;
    }
    let mut r = ScenarioRig::new(rig, sc).map_err(|e| RunError::Setup(e.to_string()))?;
    if let Some(m) = &ev.extra_modes {
        let p = beamest::rig::ModalPlant::from_modal(m, cfg.ts_s)
            .and_then(|p| p.with_output(cfg.output))
            .map_err(|e| RunError::Plant(format!("extra modes: {e}")))?;
        r = r
            .with_extra_modes(p)
            .map_err(|e| RunError::Setup(e.to_string()))?;
    }
    Ok(r)
}

/// The truth in force: before and (with a plant step) after it.
pub struct Truths {
    /// Before the step (or throughout).
    pub before: Truth,
    /// The step's sample and the plant after it.
    pub after: Option<(u64, Truth)>,
}

impl Truths {
    /// From the run's plant and step.
    ///
    /// # Errors
    /// An invalid plant or step.
    pub fn new(cfg: &RunConfig) -> Result<Self, RunError> {
        let before = cfg.truth();
        let after = match &cfg.events.step {
            Some(step) => {
                let n = before.modal.modes;
                let plant = cfg.sim_plant()?;
                let p = stepped_plant(&plant, step, &before).map_err(RunError::Setup)?;
                let t = truth_of(&p, &before.modal.output_weight[..n]).map_err(RunError::Setup)?;
                Some((sample_at(step.at_s, cfg.ts_s), t))
            }
            None => None,
        };
        Ok(Self { before, after })
    }

    /// The truth at sample `k`.
    pub fn at(&self, k: u64) -> &Truth {
        match &self.after {
            Some((at, t)) if k >= *at => t,
            _ => &self.before,
        }
    }
}

/// The `scenario` object of a run with events.
pub fn scenario_report(
    cfg: &RunConfig,
    tracking: (Option<f64>, Option<f64>),
    detection: &Detection,
    fault_window: Option<beamest::rig::Window>,
    total: u64,
) -> ScenarioReport {
    let ev = &cfg.events;
    let ts = cfg.ts_s;
    let stepped = ev.step.is_some();
    ScenarioReport {
        step_at_s: ev.step.as_ref().map(|s| s.at_s),
        tracking_1pct_s: tracking.0.filter(|_| stepped),
        tracking_0p1pct_s: tracking.1.filter(|_| stepped),
        excitation_off_s: ev.excitation_off.map(|(a, b)| [a, b]),
        fault: ev.fault.map(|f| f.kind.name()),
        fault_window_s: fault_window.map(|w| {
            [
                w.from as f64 * ts,
                w.until.unwrap_or(total).min(total) as f64 * ts,
            ]
        }),
        fault_detection_latency_s: match (detection.first, fault_window) {
            (Some((k, _)), Some(w)) => Some((k - w.from) as f64 * ts),
            _ => None,
        },
        fault_detected_as: detection.first.map(|(_, w)| w),
        truth_modes: cfg.plant.modes() + ev.extra_modes.map_or(0, |m| m.modes),
    }
}

/// Samples a run processes.
pub fn samples(cfg: &RunConfig) -> u64 {
    (cfg.duration_s / cfg.ts_s).round() as u64
}

/// Per-law truth metrics.
struct Score {
    s1: Settling,
    s01: Settling,
    /// Since the plant step (tracking).
    t1: Settling,
    t01: Settling,
    max_after_1s: Option<f64>,
}

fn run_sized<T: Real, const D: usize, const NP: usize, const NS: usize>(
    cfg: &RunConfig,
    kinds: &[EstimatorKind],
    observer: &mut dyn Observer,
) -> Result<Vec<RunReport>, RunError> {
    if !(cfg.duration_s > 0.0 && cfg.duration_s.is_finite()) {
        return Err(RunError::Setup("duration must be positive".into()));
    }
    if cfg.eval_every == 0 {
        return Err(RunError::Setup("eval_every must be at least 1".into()));
    }
    let truths = Truths::new(cfg)?;
    let weights = &truths.before.modal.output_weight[..truths.before.modal.modes];
    let mut session = Session::<T, D, NP, NS>::new(kinds, cfg.gains, &cfg.tuning(), weights)?
        .with_guard(&guard_config(cfg.ts_s, cfg.range, cfg.level_correction))?
        .with_monitor(cfg.residual_monitor)?;
    let mut rig = scenario_rig(cfg)?;
    let total = samples(cfg);
    let every = cfg.eval_every as u64;
    let step_s = cfg.events.step.as_ref().map_or(0.0, |s| s.at_s);
    let mut scores: Vec<Score> = kinds
        .iter()
        .map(|_| Score {
            s1: Settling::new(1e-2, 0.0),
            s01: Settling::new(1e-3, 0.0),
            t1: Settling::new(1e-2, step_s),
            t01: Settling::new(1e-3, step_s),
            max_after_1s: None,
        })
        .collect();
    let fault_window = rig.scenario().fault.map(|f| f.window);
    let mut detection = Detection::default();
    let per_sample = observer.wants_samples();
    let drift = drift_every(cfg.ts_s);
    for k in 0..total {
        let Sample { u, y } = rig.tick();
        let screening = session.step(u, y);
        if fault_window.is_some_and(|w| w.contains(k)) {
            detection.observe(k, &screening);
        }
        // Real time of the newest sample: when the estimate is available.
        let t = k as f64 * cfg.ts_s;
        if (k + 1) % every == 0 || k + 1 == total {
            let record = (k + 1) % drift == 0 || k + 1 == total;
            let truth = truths.at(k);
            for (i, score) in scores.iter_mut().enumerate() {
                let e: Eval<NP> = session.evaluate(i, t, record);
                let err = rel_error(e.modal.as_ref(), &truth.modal).max();
                for s in [&mut score.s1, &mut score.s01, &mut score.t1, &mut score.t01] {
                    s.observe(t, err);
                }
                if t >= 1.0 {
                    score.max_after_1s = Some(score.max_after_1s.unwrap_or(0.0).max(err));
                }
                observer.estimate(
                    i,
                    &Trace {
                        estimator: kinds[i],
                        t_s: t,
                        u,
                        y,
                        theta: &e.theta,
                        modal: e.modal.as_ref(),
                        lambda_rad_s: e.lambda_rad_s,
                        max_rel_error: Some(err),
                        supervision: session.supervision(i),
                        validity: e.validity,
                    },
                );
            }
            if observer.stopped() {
                return Err(RunError::Interrupted);
            }
        }
        if per_sample {
            observer.screening(k, &screening);
            observer.sample(k, t, u, y);
        }
    }
    let end_s = total.saturating_sub(1) as f64 * cfg.ts_s;
    let sd = noise_sd(cfg)?;
    let bound = match cfg.crlb {
        Some(set) => run_bound(cfg, set)?,
        None => None,
    };
    let truth = *truths.at(total.saturating_sub(1));
    let mut reports = Vec::with_capacity(kinds.len());
    let input = input_on_rig(cfg)?;
    for (i, score) in scores.into_iter().enumerate() {
        let model = session.model(i, cfg.ts_s);
        let fit = match &model {
            Some(model) => fit_on_rig(cfg, model)?,
            None => None,
        };
        let residual = match (&model, &fit) {
            (Some(m), Some(f)) => residual_on_rig(cfg, m, f)?,
            _ => None,
        };
        let o = session.outcome(
            i,
            end_s,
            &RecordEvidence {
                fit: fit.as_ref(),
                input: input.as_ref(),
                residual: residual.as_ref(),
            },
        );
        let modal =
            (o.estimate.is_valid() && o.estimate.omega.len() == truth.modal.modes).then(|| {
                let mut m = truth.modal;
                let n = m.modes;
                m.omega_rad_s[..n].copy_from_slice(&o.estimate.omega);
                m.zeta[..n].copy_from_slice(&o.estimate.zeta);
                m.bbar[..n].copy_from_slice(&o.estimate.bbar);
                m
            });
        let rel_error = rel_error(modal.as_ref(), &truth.modal);
        let error_over_crlb = bound
            .as_ref()
            .map(|b| b.ratio(&rel_error.omega, &rel_error.zeta, &rel_error.bbar));
        let scenario = (!cfg.events.is_empty()).then(|| {
            scenario_report(
                cfg,
                (score.t1.after_start(), score.t01.after_start()),
                &detection,
                fault_window,
                total,
            )
        });
        reports.push(RunReport {
            estimator: kinds[i],
            precision: cfg.precision,
            duration_s: total as f64 * cfg.ts_s,
            samples: total,
            rel_error,
            truth: ModalSummary::new(Some(&truth.modal), &truth.tf),
            time_to_1pct_s: score.s1.since(),
            time_to_0p1pct_s: score.s01.since(),
            max_error_after_1s: score.max_after_1s,
            estimate: o.estimate,
            excitation_min_eig: o.excitation_min_eig,
            feedthrough: o.feedthrough,
            rejected_samples: o.rejected_samples,
            skipped_updates: o.skipped_updates,
            law_updates: o.law_updates,
            state_ok: o.state_ok,
            lambda_rad_s: o.lambda_rad_s,
            tuning: o.tuning,
            builds: o.builds,
            fit_percent: o.fit_percent,
            drift_last_10pct: o.drift_last_10pct,
            noise_sd: sd,
            crlb: bound.clone(),
            error_over_crlb,
            robust: o.robust,
            supervision: o.supervision,
            validity: o.validity,
            guard: o.guard,
            verdict: o.verdict,
            hum: cfg.hum.clone(),
            noise_colour: cfg.noise_colour,
            scenario,
        });
    }
    Ok(reports)
}

/// The input spectrum of the run's samples (for the verdict; the rig is
/// replayed, as for [`fit_on_rig`]).
fn input_on_rig(cfg: &RunConfig) -> Result<Option<PowerSpectrum>, RunError> {
    let mut rig = scenario_rig(cfg)?;
    let n = samples(cfg);
    Ok(PowerSpectrum::of(
        (0..n).map(move |_| rig.tick().u),
        usize::try_from(n).unwrap_or(usize::MAX),
        cfg.ts_s,
    ))
}

/// The spectrum of a fit's residual over the run's samples (the rig
/// replayed, as for [`fit_on_rig`]).
fn residual_on_rig(
    cfg: &RunConfig,
    model: &Model,
    fit: &fit::Fit,
) -> Result<Option<crate::judge::verdict::ResidualSpectrum>, RunError> {
    let mut rig = scenario_rig(cfg)?;
    let n = samples(cfg);
    Ok(crate::judge::verdict::residual_spectrum(
        model,
        fit,
        (0..n).map(move |_| {
            let s = rig.tick();
            (s.u, s.y)
        }),
        usize::try_from(n).unwrap_or(usize::MAX),
        cfg.ts_s,
    ))
}

/// The model-output fit over the run's samples (the rig is deterministic:
/// it is replayed rather than stored).
fn fit_on_rig(cfg: &RunConfig, model: &Model) -> Result<Option<fit::Fit>, RunError> {
    let start = scenario_rig(cfg)?;
    let n = samples(cfg);
    Ok(fit::fit(model, || {
        let mut rig = start.clone();
        (0..n).map(move |_| {
            let s = rig.tick();
            (s.u, s.y)
        })
    }))
}
