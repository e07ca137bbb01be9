//! Scenarios on the simulated rig: the events a real rig goes through, as a
//! wrapper around [`Rig`] rather than flags inside the plant.
//!
//! A [`Scenario`] is a set of optional events, each on a window of sample
//! indices (the first sample of a run is index 0):
//!
//! * **a plant change** ([`PlantStep`]) at one sample: new ω, ζ (and b̄ if
//!   given) with the beam's state continuous ([`ModalPlant::retune`]): a
//!   beam whose stiffness or damping changes, e.g. immersed in a liquid
//!   (the motivation of Wang, Costa-Castelló, Na et al., *Modelling and
//!   Adaptive Parameter Estimation for a Piezoelectric Cantilever Beam*);
//! * **excitation off** ([`ExcitationOff`]) over a window: the drive is
//!   replaced by a constant level (0, or the DAC's offset) while the
//!   generator keeps its phase, as a paused output stage would;
//! * **a sensor fault** ([`SensorFault`]) on the *measured* y over a window
//!   (the beam itself is unaffected): see [`FaultKind`];
//!
//! and [`ScenarioRig::with_extra_modes`] adds modes the estimator's model
//! does not have (the physical beam's 3rd and 4th bending modes: the plant
//! is linear, so a beam of more than [`MAX_MODES`] modes is the sum of two
//! plants driven by the same u).
//!
//! Each tick: the plant change (if due) takes effect, u comes from the
//! excitation (or the off level), y is the plant's y(t_k) plus the extra
//! modes' plus the noise, then the fault (if active) rewrites the measured
//! y. The truth a run is scored against after a plant change is
//! [`ScenarioRig::plant`]'s [`ModalPlant::transfer_function`].

use super::noise::GaussianNoise;
use super::plant::{ModalPlant, PlantError};
use super::sim::{Rig, Sample};
use crate::beam::{BeamError, BeamParams};
use crate::model::{ModalParams, MAX_MODES};
use crate::scalar::Real;

/// Samples [from, until): `until = None` lasts to the end of the run.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Window {
    /// First sample index inside the window.
    pub from: u64,
    /// First sample index after it (`None`: never ends).
    pub until: Option<u64>,
}

impl Window {
    /// [from, until).
    pub fn new(from: u64, until: Option<u64>) -> Self {
        Self { from, until }
    }

    /// Whether sample `k` is inside.
    pub fn contains(&self, k: u64) -> bool {
        k >= self.from && self.until.is_none_or(|u| k < u)
    }
}

/// A change of the plant's modes at sample `at` (state continuous).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PlantStep {
    /// Sample index from which the new dynamics act (the sample at `at`
    /// is still the old plant's y(t_at); it then advances with the new
    /// dynamics).
    pub at: u64,
    /// New ω per mode (rad/s); the first `modes` entries are used.
    pub omega_rad_s: [f64; MAX_MODES],
    /// New ζ per mode.
    pub zeta: [f64; MAX_MODES],
    /// New input gains b̄ per mode, or `None` to keep them.
    pub bbar: Option<[f64; MAX_MODES]>,
}

/// The drive replaced by `level` over `window` (0 V, or the DAC's offset).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ExcitationOff {
    /// When.
    pub window: Window,
    /// The input held meanwhile (input units, e.g. V).
    pub level: f64,
}

/// What a faulty sensor reads (the measured y; units of y).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum FaultKind {
    /// Not a number (a failed conversion passed on as NaN).
    Nan,
    /// Overload: the converter reads its full scale, ±`full_scale` with
    /// the sign of the true y (a shock or a gain fault driving the input
    /// beyond the range on both sides).
    Saturate {
        /// The converter's full scale in units of y (> 0).
        full_scale: f64,
    },
    /// The reading freezes at its last value before the window.
    Stuck,
    /// Open gauge in a quarter bridge: the gauge's node is pulled to a
    /// bridge-excitation rail through its completion resistor, so the
    /// bridge output is ±V_exc/2 (1 V at the rig's 2 V excitation, far
    /// beyond the ±9.4 mV input range at PGA 128): the ADS131M02 reads its
    /// positive or negative full-scale code, constant. `reading` is that
    /// code converted to y.
    Open {
        /// The reading (units of y).
        reading: f64,
    },
    /// A DC offset of `step` added from the window's first sample (a
    /// bridge imbalance appearing at once).
    Offset {
        /// The offset (units of y).
        step: f64,
    },
    /// A ramp of `per_s` per second from the window's first sample (slow
    /// thermal drift of the gauge or the bridge).
    Drift {
        /// Slope (units of y per second).
        per_s: f64,
    },
}

/// A sensor fault on the measured y over a window.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SensorFault {
    /// What the sensor reads.
    pub kind: FaultKind,
    /// When.
    pub window: Window,
}

/// The optional events of a run.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Scenario {
    /// A plant change.
    pub step: Option<PlantStep>,
    /// An excitation pause.
    pub excitation_off: Option<ExcitationOff>,
    /// A sensor fault.
    pub fault: Option<SensorFault>,
}

/// Why a scenario cannot run on a rig.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ScenarioError {
    /// The plant step's values are invalid for the plant (ω ≤ 0, ζ < 0,
    /// non-finite).
    Step(PlantError),
    /// A fault's level is not finite (or a full scale not positive).
    Fault,
    /// The excitation-off level is not finite.
    Level,
    /// The extra modes' plant has another sample period.
    SamplePeriod,
}

impl core::fmt::Display for ScenarioError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Self::Step(e) => write!(f, "invalid plant step: {e}"),
            Self::Fault => f.write_str("invalid sensor fault: its level must be finite (full scale > 0)"),
            Self::Level => f.write_str("invalid excitation-off level: must be finite"),
            Self::SamplePeriod => {
                f.write_str("the extra modes' plant must have the rig's sample period")
            }
        }
    }
}

impl core::error::Error for ScenarioError {
    fn source(&self) -> Option<&(dyn core::error::Error + 'static)> {
        match self {
            Self::Step(e) => Some(e),
            _ => None,
        }
    }
}

/// A [`Rig`] going through a [`Scenario`], optionally with modes beyond the
/// estimator's model.
#[derive(Debug, Clone)]
pub struct ScenarioRig<T, E> {
    rig: Rig<T, E>,
    extra: Option<ModalPlant<T>>,
    scenario: Scenario,
    /// The step, checked on a copy of the plant at construction.
    next: u64,
    /// Last measured y before the fault window (for `Stuck`).
    held_y: T,
}

impl<T: Real, E: Iterator<Item = T>> ScenarioRig<T, E> {
    /// Run `rig` through `scenario`. The plant step is validated here (on a
    /// copy of the plant), so [`ScenarioRig::tick`] cannot fail.
    ///
    /// # Errors
    /// [`ScenarioError`] naming the invalid event.
    pub fn new(rig: Rig<T, E>, scenario: Scenario) -> Result<Self, ScenarioError> {
        if let Some(s) = &scenario.step {
            let mut probe = rig.plant().clone();
            retune(&mut probe, s).map_err(ScenarioError::Step)?;
        }
        if let Some(off) = &scenario.excitation_off {
            if !off.level.is_finite() {
                return Err(ScenarioError::Level);
            }
        }
        if let Some(f) = &scenario.fault {
            let ok = match f.kind {
                FaultKind::Nan | FaultKind::Stuck => true,
                FaultKind::Saturate { full_scale } => full_scale > 0.0 && full_scale.is_finite(),
                FaultKind::Open { reading: v }
                | FaultKind::Offset { step: v }
                | FaultKind::Drift { per_s: v } => v.is_finite(),
            };
            if !ok {
                return Err(ScenarioError::Fault);
            }
        }
        Ok(Self {
            rig,
            extra: None,
            scenario,
            next: 0,
            held_y: T::ZERO,
        })
    }

    /// Add the output of `plant` (driven by the same u, noise-free) to y:
    /// modes beyond the estimator's model.
    ///
    /// # Errors
    /// [`ScenarioError::SamplePeriod`] if `plant`'s Ts differs from the rig's.
    pub fn with_extra_modes(mut self, plant: ModalPlant<T>) -> Result<Self, ScenarioError> {
        if plant.ts_s() != self.rig.plant().ts_s() {
            return Err(ScenarioError::SamplePeriod);
        }
        self.extra = Some(plant);
        Ok(self)
    }

    /// One sample period (see the module docs for the order of events).
    #[inline]
    pub fn tick(&mut self) -> Sample<T> {
        let k = self.next;
        self.next = self.next.wrapping_add(1);
        let drive = self.rig.excitation_mut().next().unwrap_or(T::ZERO);
        let u = match &self.scenario.excitation_off {
            Some(off) if off.window.contains(k) => T::from_f64(off.level),
            _ => drive,
        };
        // y(t_k) is sampled before the plant advances, so a step at `at`
        // changes the dynamics from t_at on: retune, then sample.
        if let Some(s) = &self.scenario.step {
            if s.at == k {
                // Validated in `new`; a failure leaves the plant unchanged.
                let _ = retune(self.rig.plant_mut(), s);
            }
        }
        let mut y = self.rig.tick_with(u);
        if let Some(extra) = self.extra.as_mut() {
            y += extra.sample(u);
        }
        let y = match &self.scenario.fault {
            Some(f) if f.window.contains(k) => {
                let elapsed_s = (k - f.window.from) as f64 * self.rig.plant().ts_s();
                fault_reading(f.kind, y, self.held_y, elapsed_s)
            }
            _ => {
                self.held_y = y;
                y
            }
        };
        Sample { u, y }
    }

    /// Index of the next sample.
    pub fn sample_index(&self) -> u64 {
        self.next
    }

    /// The scenario.
    pub fn scenario(&self) -> &Scenario {
        &self.scenario
    }

    /// The (main) plant: after the step, the changed one.
    pub fn plant(&self) -> &ModalPlant<T> {
        self.rig.plant()
    }

    /// The modes beyond the model, if any.
    pub fn extra_modes(&self) -> Option<&ModalPlant<T>> {
        self.extra.as_ref()
    }

    /// The wrapped rig.
    pub fn rig(&self) -> &Rig<T, E> {
        &self.rig
    }
}

impl<T: Real, E: Iterator<Item = T> + Clone> ScenarioRig<T, E> {
    /// A copy in the current state without noise (e.g. to measure the
    /// signal's RMS for an SNR: plant, extra modes and events included).
    pub fn noise_free(&self) -> Self {
        Self {
            rig: self.rig.noise_free(),
            extra: self.extra.clone(),
            scenario: self.scenario,
            next: self.next,
            held_y: self.held_y,
        }
    }

    /// The same scenario with white measurement noise on y.
    pub fn with_noise(self, noise: GaussianNoise<T>) -> Self {
        Self {
            rig: self.rig.with_noise(noise),
            ..self
        }
    }
}

/// Apply a plant step to `plant` (its mode count decides the slices).
fn retune<T: Real>(plant: &mut ModalPlant<T>, s: &PlantStep) -> Result<(), PlantError> {
    let n = plant.modes();
    let (w, z) = (
        s.omega_rad_s.get(..n).ok_or(PlantError::Dimensions)?,
        s.zeta.get(..n).ok_or(PlantError::Dimensions)?,
    );
    match &s.bbar {
        Some(b) => plant.retune(w, z, Some(b.get(..n).ok_or(PlantError::Dimensions)?)),
        None => plant.retune(w, z, None),
    }
}

/// The faulty reading of a true (noisy) y.
fn fault_reading<T: Real>(kind: FaultKind, y: T, held: T, elapsed_s: f64) -> T {
    match kind {
        FaultKind::Nan => T::from_f64(f64::NAN),
        FaultKind::Saturate { full_scale } => {
            let fs = T::from_f64(full_scale);
            if y >= T::ZERO {
                fs
            } else {
                -fs
            }
        }
        FaultKind::Stuck => held,
        FaultKind::Open { reading } => T::from_f64(reading),
        FaultKind::Offset { step } => y + T::from_f64(step),
        FaultKind::Drift { per_s } => y + T::from_f64(per_s * elapsed_s),
    }
}

/// Modes `first..first + count` (1-based mode numbers, `count` ≤
/// [`MAX_MODES`]) of the Euler–Bernoulli beam `beam` as modal parameters
/// (ω, ζ, b̄, c of eq. 21–24, [`BeamParams::mode_model`]), with b̄ multiplied
/// by `gain_scale` (e.g. the patch width, which eq. 8's moment omits, or a
/// factor that brings them to another plant's units). For the extra modes
/// of [`ScenarioRig::with_extra_modes`]: `ModalPlant::from_modal` of this.
///
/// # Errors
/// [`BeamError`] from the beam's data or an invalid count.
pub fn beam_modes(
    beam: &BeamParams,
    first: usize,
    count: usize,
    gain_scale: f64,
) -> Result<ModalParams<f64>, BeamError> {
    if count == 0 || count > MAX_MODES || first == 0 {
        return Err(BeamError::ModeCount);
    }
    let mut p = ModalParams {
        modes: count,
        omega_rad_s: [0.0; MAX_MODES],
        zeta: [0.0; MAX_MODES],
        bbar: [0.0; MAX_MODES],
        output_weight: [0.0; MAX_MODES],
    };
    for i in 0..count {
        let m = beam.mode_model(first + i)?;
        p.omega_rad_s[i] = m.omega_rad_s;
        p.zeta[i] = m.zeta;
        p.bbar[i] = m.bbar * gain_scale;
        p.output_weight[i] = m.output_weight;
    }
    Ok(p)
}

#[cfg(test)]
#[allow(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::panic,
    clippy::indexing_slicing
)]
mod tests {
    use super::*;
    use crate::excitation::SquareWave;
    use crate::model::{PAPER_B, PAPER_OMEGA, PAPER_ZETA};

    fn paper_rig() -> Rig<f64, SquareWave<f64>> {
        Rig::new(
            ModalPlant::with_numerator(&PAPER_OMEGA, &PAPER_ZETA, &PAPER_B, 1e-4).unwrap(),
            SquareWave::paper(),
        )
    }

    #[test]
    fn empty_scenario_is_the_rig() {
        let mut plain = paper_rig();
        let mut s = ScenarioRig::new(paper_rig(), Scenario::default()).unwrap();
        for _ in 0..5000 {
            assert_eq!(s.tick(), plain.tick());
        }
        assert_eq!(s.sample_index(), 5000);
    }

    #[test]
    fn plant_step_keeps_the_state_continuous() {
        let step = PlantStep {
            at: 3000,
            omega_rad_s: [PAPER_OMEGA[0] * 1.1, PAPER_OMEGA[1], 0.0],
            zeta: [PAPER_ZETA[0] * 1.5, PAPER_ZETA[1], 0.0],
            bbar: None,
        };
        let mut s = ScenarioRig::new(
            paper_rig(),
            Scenario {
                step: Some(step),
                ..Scenario::default()
            },
        )
        .unwrap();
        let mut plain = paper_rig();
        let mut last = 0.0;
        for k in 0..6000u64 {
            let (a, b) = (s.tick(), plain.tick());
            if k <= 3000 {
                // Up to and including y(t_3000): the old plant.
                assert_eq!(a, b, "k = {k}");
            } else {
                assert_ne!(a.y, b.y);
                // Continuous: no jump beyond a sample's motion.
                assert!((a.y - last).abs() < 0.05 * 1.2e-3 * 10.0, "jump at {k}");
            }
            last = a.y;
        }
        let (w, z) = s.plant().mode(0).unwrap();
        assert_eq!((w, z), (PAPER_OMEGA[0] * 1.1, PAPER_ZETA[0] * 1.5));
        // The new truth's denominator has the new modes.
        let tf = s.plant().transfer_function();
        let m = crate::modal::modes_from_denominator(&tf.a[..4]).unwrap();
        assert!((m.omega_rad_s[0] / (PAPER_OMEGA[0] * 1.1) - 1.0).abs() < 1e-12);
        assert!((m.zeta[0] / (PAPER_ZETA[0] * 1.5) - 1.0).abs() < 1e-10);
    }

    #[test]
    fn plant_transfer_function_is_the_papers() {
        let p = ModalPlant::<f64>::with_numerator(&PAPER_OMEGA, &PAPER_ZETA, &PAPER_B, 1e-4)
            .unwrap()
            .transfer_function();
        let want = crate::model::paper_plant_tf();
        for i in 0..4 {
            assert!((p.a[i] / want.a[i] - 1.0).abs() < 1e-12, "a{i}");
        }
        for i in 0..3 {
            assert!((p.b[i] / want.b[i] - 1.0).abs() < 1e-9, "b{i}");
        }
    }

    #[test]
    fn excitation_off_and_faults_act_on_their_windows() {
        let w = Window::new(100, Some(200));
        let cases = [
            FaultKind::Nan,
            FaultKind::Saturate { full_scale: 1e-4 },
            FaultKind::Stuck,
            FaultKind::Open { reading: 0.02 },
            FaultKind::Offset { step: 1e-3 },
            FaultKind::Drift { per_s: 0.5 },
        ];
        for kind in cases {
            let scenario = Scenario {
                fault: Some(SensorFault { kind, window: w }),
                excitation_off: Some(ExcitationOff {
                    window: Window::new(150, Some(160)),
                    level: 0.002,
                }),
                ..Scenario::default()
            };
            let mut s = ScenarioRig::new(paper_rig(), scenario).unwrap();
            let mut truth = paper_rig();
            let mut sq = SquareWave::<f64>::paper();
            let mut held = 0.0;
            for k in 0..300u64 {
                let drive = sq.next_sample();
                let u = if (150..160).contains(&k) { 0.002 } else { drive };
                let y = truth.tick_with(u);
                let got = s.tick();
                assert_eq!(got.u, u);
                if !w.contains(k) {
                    assert_eq!(got.y, y, "{kind:?} {k}");
                    held = y;
                    continue;
                }
                let t = (k - 100) as f64 * 1e-4;
                match kind {
                    FaultKind::Nan => assert!(got.y.is_nan()),
                    FaultKind::Saturate { full_scale } => {
                        assert_eq!(got.y, full_scale.copysign(y))
                    }
                    FaultKind::Stuck => assert_eq!(got.y, held),
                    FaultKind::Open { reading } => assert_eq!(got.y, reading),
                    FaultKind::Offset { step } => assert_eq!(got.y, y + step),
                    FaultKind::Drift { per_s } => assert_eq!(got.y, y + per_s * t),
                }
            }
        }
    }

    #[test]
    fn extra_modes_add_and_invalid_events_are_refused() {
        let extra = ModalPlant::<f64>::from_modal(
            &beam_modes(&BeamParams::paper(), 3, 2, 1.0).unwrap(),
            1e-4,
        )
        .unwrap();
        let mut s = ScenarioRig::new(paper_rig(), Scenario::default())
            .unwrap()
            .with_extra_modes(extra.clone())
            .unwrap();
        let (mut plain, mut e) = (paper_rig(), extra);
        for _ in 0..1000 {
            let a = s.tick();
            let b = plain.tick();
            assert_eq!(a.y, b.y + e.sample(b.u));
        }
        let bad_step = Scenario {
            step: Some(PlantStep {
                at: 1,
                omega_rad_s: [-1.0, 1.0, 0.0],
                zeta: [0.1, 0.1, 0.0],
                bbar: None,
            }),
            ..Scenario::default()
        };
        assert_eq!(
            ScenarioRig::new(paper_rig(), bad_step).err(),
            Some(ScenarioError::Step(PlantError::Value))
        );
        let bad_fault = Scenario {
            fault: Some(SensorFault {
                kind: FaultKind::Saturate { full_scale: 0.0 },
                window: Window::new(0, None),
            }),
            ..Scenario::default()
        };
        assert_eq!(
            ScenarioRig::new(paper_rig(), bad_fault).err(),
            Some(ScenarioError::Fault)
        );
        let other_ts = ModalPlant::<f64>::from_modal(
            &beam_modes(&BeamParams::paper(), 3, 1, 1.0).unwrap(),
            2e-4,
        )
        .unwrap();
        assert_eq!(
            ScenarioRig::new(paper_rig(), Scenario::default())
                .unwrap()
                .with_extra_modes(other_ts)
                .err(),
            Some(ScenarioError::SamplePeriod)
        );
    }

    #[test]
    fn beam_modes_three_and_four() {
        let m = beam_modes(&BeamParams::paper(), 3, 2, 1.0).unwrap();
        // ω_i ∝ (β_iL)²: ω3 = 687.16 rad/s (the beam's table), ω4 from β4L = 10.9955.
        assert!((m.omega_rad_s[0] - 687.1641).abs() < 1e-3, "{}", m.omega_rad_s[0]);
        let w1 = BeamParams::paper().natural_frequency_rad_s(1).unwrap();
        let ratio = (10.995_540_734_9f64 / 1.875_104_068_7).powi(2);
        assert!((m.omega_rad_s[1] / (w1 * ratio) - 1.0).abs() < 1e-6);
        // Kelvin–Voigt: ζ ∝ ω.
        assert!((m.zeta[1] / m.zeta[0] - m.omega_rad_s[1] / m.omega_rad_s[0]).abs() < 1e-9);
        assert!((m.output_weight[0] + 2.0).abs() < 1e-12 && (m.output_weight[1] - 2.0).abs() < 1e-12);
        assert!(beam_modes(&BeamParams::paper(), 1, 4, 1.0).is_err());
    }
}
