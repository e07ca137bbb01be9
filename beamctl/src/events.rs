//! The events of a simulated run (`beamctl simulate --step-at …
//! --excitation-off … --fault … --truth-modes …`), in seconds, and what
//! they become on the core's scenario rig ([`beamest::rig::ScenarioRig`]):
//! a plant change, an excitation pause, a sensor fault on the measured y,
//! and modes of the physical beam beyond the estimator's model.
//!
//! Only the simulated world is built from the truth here (the plant after
//! a step, the default fault levels, the scale of the extra modes); the
//! estimators and the sensor guard see the samples only.

use crate::runner::{RunConfig, RunError};
use crate::scenario::Truth;
use beamest::beam::BeamParams;
use beamest::modal::modal_from_tf;
use beamest::model::{ModalParams, MAX_MODES};
use beamest::rig::{
    beam_modes, ExcitationOff, FaultKind, ModalPlant, PlantStep, Scenario, ScenarioRig,
    SensorFault, Window,
};
use serde::Serialize;

/// What a faulty sensor does (`--fault`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum FaultChoice {
    /// y reads NaN.
    Nan,
    /// y reads ± the converter's full scale (needs the range).
    Saturate,
    /// y freezes at its last value.
    Stuck,
    /// y reads the positive rail (open gauge; needs the range).
    Open,
    /// A step of y's offset.
    Offset,
    /// A ramp of y's offset.
    Drift,
}

impl FaultChoice {
    /// Its name on the command line and in the reports.
    pub fn name(self) -> &'static str {
        match self {
            Self::Nan => "nan",
            Self::Saturate => "saturate",
            Self::Stuck => "stuck",
            Self::Open => "open",
            Self::Offset => "offset",
            Self::Drift => "drift",
        }
    }

    /// Whether it needs the converter's range (the rails it reads).
    pub fn needs_range(self) -> bool {
        matches!(self, Self::Saturate | Self::Open)
    }
}

/// Default offset step of `--fault offset`, as a fraction of the
/// noise-free y's RMS over the run.
pub const DEFAULT_OFFSET_OF_RMS: f64 = 0.5;
/// Default slope of `--fault drift` (fraction of the noise-free y's RMS
/// per second).
pub const DEFAULT_DRIFT_OF_RMS_PER_S: f64 = 0.1;

/// A sensor fault in seconds.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FaultEvent {
    /// What the sensor reads.
    pub kind: FaultChoice,
    /// Start (s).
    pub at_s: f64,
    /// Length (s); `None`: to the end of the run.
    pub for_s: Option<f64>,
    /// Offset step (units of y) or drift slope (units of y per s); `None`:
    /// [`DEFAULT_OFFSET_OF_RMS`] / [`DEFAULT_DRIFT_OF_RMS_PER_S`] of the
    /// noise-free y's RMS.
    pub level: Option<f64>,
}

/// A plant change in seconds: new ω and/or ζ per mode (b̄ kept).
#[derive(Debug, Clone, PartialEq)]
pub struct StepEvent {
    /// When (s).
    pub at_s: f64,
    /// New ω (rad/s), one per mode; `None`: unchanged.
    pub omega_rad_s: Option<Vec<f64>>,
    /// New ζ, one per mode; `None`: unchanged.
    pub zeta: Option<Vec<f64>>,
}

/// The events of a run (all optional; the default is none).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Events {
    /// A plant change.
    pub step: Option<StepEvent>,
    /// The drive replaced by 0 over [from, to) (s).
    pub excitation_off: Option<(f64, f64)>,
    /// A sensor fault.
    pub fault: Option<FaultEvent>,
    /// Modes of the physical beam beyond the estimator's model, added to
    /// y ([`extra_beam_modes`]).
    pub extra_modes: Option<ModalParams<f64>>,
}

impl Events {
    /// True without any event.
    pub fn is_empty(&self) -> bool {
        *self == Self::default()
    }

    /// True if the beam seen by the sensor is not the stationary model
    /// plant (a step or extra modes): the Cramér–Rao bound of the plain
    /// experiment does not apply.
    pub fn changes_the_experiment(&self) -> bool {
        !self.is_empty()
    }
}

/// Sample index of time `t_s`.
pub fn sample_at(t_s: f64, ts_s: f64) -> u64 {
    (t_s / ts_s).round().max(0.0) as u64
}

/// The plant after `step` (the simulated truth in force after it).
///
/// # Errors
/// A message if the new values do not make a valid plant.
pub fn stepped_plant(
    plant: &ModalPlant<f64>,
    step: &StepEvent,
    before: &Truth,
) -> Result<ModalPlant<f64>, String> {
    let n = plant.modes();
    let omega = step
        .omega_rad_s
        .clone()
        .unwrap_or_else(|| before.modal.omega_rad_s[..n].to_vec());
    let zeta = step
        .zeta
        .clone()
        .unwrap_or_else(|| before.modal.zeta[..n].to_vec());
    let mut p = plant.clone();
    p.retune(&omega, &zeta, None)
        .map_err(|e| format!("plant step: {e}"))?;
    Ok(p)
}

/// The truth of a plant (ω, ζ, b̄ recovered from its transfer function with
/// the model's output weights).
pub fn truth_of(plant: &ModalPlant<f64>, weights: &[f64]) -> Result<Truth, String> {
    let tf = plant.transfer_function();
    let modal = modal_from_tf(&tf, weights).map_err(|e| format!("plant step: {e:?}"))?;
    Ok(Truth { modal, tf })
}

/// The core scenario of `events` on a run of sample period `ts_s`;
/// `rms_y` (the noise-free y's RMS) sets the default fault levels and
/// `range` ([min, max] in units of y) the rails a saturated or open sensor
/// reads.
///
/// # Errors
/// A message naming the flag whose values cannot be used.
pub fn scenario(
    events: &Events,
    plant: &ModalPlant<f64>,
    before: &Truth,
    ts_s: f64,
    rms_y: f64,
    range: Option<[f64; 2]>,
) -> Result<Scenario, String> {
    let mut sc = Scenario::default();
    if let Some(s) = &events.step {
        let p = stepped_plant(plant, s, before)?;
        let n = plant.modes().min(MAX_MODES);
        let mut w = [0.0; MAX_MODES];
        let mut z = [0.0; MAX_MODES];
        let t = truth_of(&p, &before.modal.output_weight[..n])?;
        w[..n].copy_from_slice(&t.modal.omega_rad_s[..n]);
        z[..n].copy_from_slice(&t.modal.zeta[..n]);
        sc.step = Some(PlantStep {
            at: sample_at(s.at_s, ts_s),
            omega_rad_s: w,
            zeta: z,
            bbar: None,
        });
    }
    if let Some((from, to)) = events.excitation_off {
        sc.excitation_off = Some(ExcitationOff {
            window: Window::new(sample_at(from, ts_s), Some(sample_at(to, ts_s))),
            level: 0.0,
        });
    }
    if let Some(f) = &events.fault {
        let rail = |what: &str| {
            range.map(|[lo, hi]| (lo, hi)).ok_or_else(|| {
                format!("--fault {what}: needs --range LO,HI (the converter's rails)")
            })
        };
        let kind = match f.kind {
            FaultChoice::Nan => FaultKind::Nan,
            FaultChoice::Stuck => FaultKind::Stuck,
            FaultChoice::Saturate => {
                let (lo, hi) = rail("saturate")?;
                FaultKind::Saturate {
                    full_scale: hi.max(-lo),
                }
            }
            FaultChoice::Open => FaultKind::Open {
                reading: rail("open")?.1,
            },
            FaultChoice::Offset => FaultKind::Offset {
                step: f.level.unwrap_or(DEFAULT_OFFSET_OF_RMS * rms_y),
            },
            FaultChoice::Drift => FaultKind::Drift {
                per_s: f.level.unwrap_or(DEFAULT_DRIFT_OF_RMS_PER_S * rms_y),
            },
        };
        let from = sample_at(f.at_s, ts_s);
        sc.fault = Some(SensorFault {
            kind,
            window: Window::new(from, f.for_s.map(|d| from + sample_at(d, ts_s))),
        });
    }
    Ok(sc)
}

/// Modes `first..=last` (1-based) of the Euler–Bernoulli beam `beam`
/// (Wang, Costa-Castelló, Na et al., *Modelling and Adaptive Parameter
/// Estimation for a Piezoelectric Cantilever Beam*, eqs. 19–24, 49–57:
/// ω_i, ζ_i, b̄_i, c_i), in the units of the simulated plant: b̄ is scaled
/// so that the beam's first mode has the plant's first-mode gain c_1·b̄_1
/// (the beam model's b̄ is per metre of patch width and in deflection
/// units; the plant's are the paper's identified ones). For
/// `--truth-modes`: the physical beam's 3rd and 4th modes beyond a
/// 2-mode model.
///
/// # Errors
/// A message if the beam cannot give those modes.
pub fn extra_beam_modes(
    beam: &BeamParams,
    first: usize,
    last: usize,
    plant: &Truth,
) -> Result<ModalParams<f64>, String> {
    let count = last + 1 - first;
    let m1 = beam
        .mode_model(1)
        .map_err(|e| format!("beam mode 1: {e}"))?;
    let plant_gain = plant.modal.output_weight[0] * plant.modal.bbar[0];
    let beam_gain = m1.output_weight * m1.bbar;
    let scale = plant_gain / beam_gain;
    if !scale.is_finite() || scale == 0.0 {
        return Err("the beam's first mode has no input gain".into());
    }
    beam_modes(beam, first, count, scale).map_err(|e| format!("beam modes {first}–{last}: {e}"))
}

/// What a run's events did (the `scenario` object of a report).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ScenarioReport {
    /// Time of the plant change (s).
    pub step_at_s: Option<f64>,
    /// Time after the plant change until the largest relative ω/ζ error
    /// (against the new plant) stays below 1% to the end (None: never).
    pub tracking_1pct_s: Option<f64>,
    /// Same for 0.1%.
    pub tracking_0p1pct_s: Option<f64>,
    /// The excitation pause [from, to) (s).
    pub excitation_off_s: Option<[f64; 2]>,
    /// The sensor fault (`nan`, `saturate`, `stuck`, `open`, `offset`,
    /// `drift`).
    pub fault: Option<&'static str>,
    /// Its window [from, to) (s; `to` = the run's end if open).
    pub fault_window_s: Option<[f64; 2]>,
    /// Time from the fault's first sample until the sensor guard first
    /// flagged a sample or a level event (None: not flagged).
    pub fault_detection_latency_s: Option<f64>,
    /// What the guard flagged it as (`non_finite`, `saturated`, `stuck`,
    /// `open`, `offset`, `drift`).
    pub fault_detected_as: Option<&'static str>,
    /// Modes of the simulated beam (model modes plus `--truth-modes`
    /// extras).
    pub truth_modes: usize,
}

/// Tracks "the time after which the error stays below a threshold" from a
/// start time on.
#[derive(Debug, Clone, Copy)]
pub struct Settling {
    threshold: f64,
    from_s: f64,
    since: Option<f64>,
}

impl Settling {
    /// Below `threshold`, counting from `from_s`.
    pub fn new(threshold: f64, from_s: f64) -> Self {
        Self {
            threshold,
            from_s,
            since: None,
        }
    }

    /// One evaluation.
    pub fn observe(&mut self, t: f64, err: f64) {
        if t < self.from_s {
            return;
        }
        if err < self.threshold {
            if self.since.is_none() {
                self.since = Some(t);
            }
        } else {
            self.since = None;
        }
    }

    /// The time it settled at (absolute).
    pub fn since(&self) -> Option<f64> {
        self.since
    }

    /// The time it took from the start.
    pub fn after_start(&self) -> Option<f64> {
        self.since.map(|t| (t - self.from_s).max(0.0))
    }
}

/// The first flag of the sensor guard inside a fault window.
#[derive(Debug, Clone, Copy, Default)]
pub struct Detection {
    /// (sample index, what) of the first flag.
    pub first: Option<(u64, &'static str)>,
}

impl Detection {
    /// Look at the guard's screening of sample `k` (inside the window).
    pub fn observe(&mut self, k: u64, s: &beamest::guard::Screening) {
        if self.first.is_some() {
            return;
        }
        let what = match (s.fault, s.level) {
            (Some(f), _) => Some(crate::session::fault_name(f)),
            (None, Some(l)) => Some(crate::session::level_name(l)),
            (None, None) => None,
        };
        if let Some(w) = what {
            self.first = Some((k, w));
        }
    }
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
        let before = cfg.plant.truth();
        let after = match &cfg.events.step {
            Some(step) => {
                let n = before.modal.modes;
                let plant = cfg
                    .plant
                    .plant(cfg.ts_s)
                    .map_err(|e| RunError::Plant(format!("{e:?}")))?;
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

/// The noise-free rig of a run with its events (`with_fault`: the sensor
/// fault too; without it, the beam as it moves, for the SNR).
pub(crate) fn events_rig(
    cfg: &RunConfig,
    with_fault: bool,
) -> Result<ScenarioRig<f64, crate::drive::Drive>, RunError> {
    let rig = crate::runner::clean_rig(cfg)?;
    let ev = &cfg.events;
    let truth = cfg.plant.truth();
    let setup = |e: String| RunError::Setup(e);
    let mut sc = scenario(ev, rig.plant(), &truth, cfg.ts_s, 1.0, cfg.range).map_err(setup)?;
    if with_fault && ev.fault.is_some() {
        // Default fault levels are relative to the moving beam's RMS.
        let mut probe = events_rig(cfg, false)?;
        let n = crate::runner::samples(cfg).max(1);
        let acc: f64 = (0..n).map(|_| probe.tick().y.powi(2)).sum();
        let rms = (acc / n as f64).sqrt();
        sc = scenario(ev, rig.plant(), &truth, cfg.ts_s, rms, cfg.range).map_err(setup)?;
    } else {
        sc.fault = None;
    }
    let mut r = ScenarioRig::new(rig, sc).map_err(|e| RunError::Setup(e.to_string()))?;
    if let Some(m) = &ev.extra_modes {
        let p = beamest::rig::ModalPlant::from_modal(m, cfg.ts_s)
            .map_err(|e| RunError::Plant(format!("extra modes: {e}")))?;
        r = r
            .with_extra_modes(p)
            .map_err(|e| RunError::Setup(e.to_string()))?;
    }
    Ok(r)
}
