//! A simulated rig for the per-sample pipeline: the plant behind two mock
//! converters that implement the pipeline's [`StrainAdc`] and [`PiezoDac`]
//! traits (the register-level chip models are elsewhere; these act at the
//! traits' level: codes in, volts out).
//!
//! * [`SimAdc`] converts the plant's output y(t_k) to the bridge code an
//!   ideal 24-bit converter gives ([`ConversionConfig::bridge_code_for`]:
//!   the inverse chain, rounded, clipped at full scale) and the actuator
//!   voltage held over the last period to a monitor code; faults can be
//!   injected per tick.
//! * [`SimDac`] holds the written voltage, ideally (held = written) or as a
//!   bipolar DAC of `bits` over ±`range_v` would (quantised, saturating).
//!
//! One tick of the loop: [`SimRig::latch`] (for a next-tick DAC latch),
//! `pipeline.tick()`, [`SimRig::advance`] (the plant integrates over the
//! period with the held voltage).

use std::cell::RefCell;
use std::collections::BTreeMap;
use std::rc::Rc;

use beamest::pipeline::{
    AdcFlags, AdcReading, ConversionConfig, DacOutcome, FaultKind, PiezoDac, StrainAdc,
};
use beamest::rig::ModalPlant;
use beamest::Real;

/// A fault the ADC mock produces at one tick.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Injected {
    /// The read fails with this kind (CRC, status, bus…).
    Error(FaultKind),
    /// The bridge code repeats the previous one (a stuck sensor).
    Stuck,
    /// The bridge code is at positive full scale.
    Saturate,
}

/// The shared state of the simulated rig.
#[derive(Debug, Clone)]
pub struct SimRig {
    /// The beam.
    pub plant: ModalPlant<f64>,
    /// Code conversion (the inverse of the pipeline's).
    pub conversion: ConversionConfig,
    /// Actuator volts per DAC volt.
    pub amplifier_gain: f64,
    /// DAC volts held now.
    pub held_v: f64,
    /// DAC volts written but not yet latched (next-tick latch).
    pub pending_v: Option<f64>,
    /// Faults by tick index.
    pub faults: BTreeMap<u64, Injected>,
    /// Ticks read so far.
    pub tick: u64,
    last_code: i32,
}

impl SimRig {
    /// A rig at rest.
    pub fn new(plant: ModalPlant<f64>, conversion: ConversionConfig, amplifier_gain: f64) -> Self {
        Self {
            plant,
            conversion,
            amplifier_gain,
            held_v: 0.0,
            pending_v: None,
            faults: BTreeMap::new(),
            tick: 0,
            last_code: 0,
        }
    }

    /// Shared handle.
    pub fn shared(self) -> Rc<RefCell<Self>> {
        Rc::new(RefCell::new(self))
    }

    /// Next-tick latch: the pending write becomes the held voltage.
    pub fn latch(&mut self) {
        if let Some(v) = self.pending_v.take() {
            self.held_v = v;
        }
    }

    /// Integrate one period with the held voltage.
    pub fn advance(&mut self) {
        self.plant.advance(self.held_v * self.amplifier_gain);
    }

    /// The bridge code for the plant's current output.
    pub fn bridge_code(&self) -> i32 {
        self.conversion
            .bridge_code_for(self.plant.output())
            .unwrap_or(0)
    }
}

/// The ADC mock.
#[derive(Debug, Clone)]
pub struct SimAdc(pub Rc<RefCell<SimRig>>);

impl StrainAdc for SimAdc {
    type Error = FaultKind;
    fn read(&mut self) -> Result<AdcReading, FaultKind> {
        let mut r = self.0.borrow_mut();
        let k = r.tick;
        r.tick += 1;
        let mut bridge = r.bridge_code();
        let monitor = r
            .conversion
            .monitor_code_for(r.held_v * r.amplifier_gain)
            .unwrap_or(0);
        match r.faults.get(&k).copied() {
            Some(Injected::Error(kind)) => return Err(kind),
            Some(Injected::Stuck) => bridge = r.last_code,
            Some(Injected::Saturate) => bridge = beamest::pipeline::ADC_CODE_MAX,
            None => {}
        }
        r.last_code = bridge;
        Ok(AdcReading {
            bridge,
            monitor,
            flags: AdcFlags::default(),
        })
    }
}

/// The DAC mock: ideal, or `bits` over ±`range_v` (bipolar, offset binary).
#[derive(Debug, Clone)]
pub struct SimDac {
    /// The rig.
    pub rig: Rc<RefCell<SimRig>>,
    /// `None`: held = written exactly; `Some((bits, range_v))`: quantised.
    pub resolution: Option<(u32, f64)>,
    /// Writes go to `pending_v` (next-tick latch) instead of `held_v`.
    pub next_tick: bool,
}

impl<T: Real> PiezoDac<T> for SimDac {
    type Error = FaultKind;
    fn write_volts(&mut self, volts: T) -> Result<DacOutcome<T>, FaultKind> {
        let v = volts.to_f64();
        let (held, saturated) = match self.resolution {
            None => (v, false),
            Some((bits, range)) => {
                let lsb = 2.0 * range / f64::from(1u32 << bits);
                let max_code = f64::from((1u32 << bits) - 1);
                let code = ((v + range) / lsb).round();
                let clipped = code.clamp(0.0, max_code);
                (clipped * lsb - range, clipped != code)
            }
        };
        let mut r = self.rig.borrow_mut();
        if self.next_tick {
            r.pending_v = Some(held);
        } else {
            r.held_v = held;
        }
        let held_t = if self.resolution.is_none() {
            volts
        } else {
            T::from_f64(held)
        };
        Ok(DacOutcome {
            held_v: held_t,
            saturated,
        })
    }
}
