//! [`ConverterRig`]: the simulated beam behind the real converter drivers —
//! what the QEMU image and the host tests run in place of the hardware.
//!
//! ```text
//!  AD5761R model ──held V──▶ × amplifier gain ──u──▶ ModalPlant ──y──▶ (+ noise)
//!   ▲ SPI (driver)                  │                                  │
//!   │                               ▼ monitor V/V          bridge, amplifier (inverse
//!   │                                                       of ConversionConfig)
//!   │                         ADS131M02 model ch1 ◀──────────── ch0 ◀──┘
//!   └──── pipeline ◀── SPI (driver) ── convert() = one DRDY period
//! ```
//!
//! # One tick ([`ConverterRig::tick`], at each sample instant t_k)
//! 1. u = the DAC model's held output × the amplifier gain: the voltage on
//!    the piezo over the period [t_{k−1}, t_k) that just ended (with a DAC
//!    latency δ, [`ConverterTiming`]: from t_{k−1} + δ on, the previous
//!    value before);
//! 2. the plant advances over that period (exact, `f64`,
//!    [`TimedPlant`]) and the ADC's view of it is formed: y(t_k), or with
//!    [`ConverterTiming::sinc3`] the ADS131M02's sinc³ average of y over
//!    the last three periods; plus measurement noise if configured;
//! 3. the ADC model's inputs are set through the analog front end (the
//!    pipeline's [`ConversionConfig`] run backwards, [`AnalogFrontEnd`]):
//!    channel 0 the bridge volts for that y, channel 1 the monitor volts
//!    for the drive (point sample: the voltage held just before t_k;
//!    sinc3: its sinc³ average);
//! 4. `convert()`: one DRDY period, the model quantises both inputs.
//!
//! The pipeline's tick then reads that conversion through the ADS131M02
//! driver and writes u_k through the AD5761R driver, so the pair it hands
//! the estimator is (u_k held over [t_k, t_{k+1}), y(t_k)) — the pairing of
//! `Rig::tick` and of the host runner (test
//! `host-tests/tests/firmware_pipeline.rs`, sample for sample) when the
//! timing is [`ConverterTiming::IDEAL`] (the default of
//! [`ConverterRig::new`]); [`crate::bench::converter_rig`] sets the board's
//! timing, which the estimator then models (`FilterConfig::timing`).
//!
//! Faults are injected in the models ([`ConverterModels::adc`]: bad CRC,
//! stuck data, saturation, dropped conversions, a slow or missing data
//! rate, another part's ID, a register that reads back wrong, bus errors,
//! brown-out) and in the rig's front end ([`ConverterRig::set_noise`],
//! [`ConverterRig::set_monitor_connected`]); the self-test's faults are
//! [`crate::bench::BenchFault`].
//!
//! # Ownership
//! The models sit in [`ConverterModels`] (`RefCell`s); each driver owns a
//! [`Shared`] handle to its model as its `SpiDevice`, and the rig borrows
//! the models between frames. A model found borrowed (a transaction in
//! progress) is an error ([`RigError::Busy`]), never a panic.

use core::cell::RefCell;
use core::fmt;

use ads131m02::VREF_VOLTS;

use crate::pipeline::{AnalogFrontEnd, ConversionConfig, ConversionError};
use crate::rig::chips::{Ad5761rModel, Ads131m02Model, Shared};
use crate::rig::{ConverterTiming, GaussianNoise, ModalPlant, TimedPlant};

/// The two converter models of the rig.
#[derive(Debug, Default)]
pub struct ConverterModels {
    /// The ADS131M02 (channel 0 bridge, channel 1 monitor).
    pub adc: RefCell<Ads131m02Model>,
    /// The AD5761R driving the piezo amplifier.
    pub dac: RefCell<Ad5761rModel>,
}

impl ConverterModels {
    /// Both chips just powered on.
    pub fn new() -> Self {
        Self::default()
    }

    /// The SPI device the ADS131M02 driver owns.
    pub fn adc_spi(&self) -> Shared<'_, Ads131m02Model> {
        Shared(&self.adc)
    }

    /// The SPI device the AD5761R driver owns.
    pub fn dac_spi(&self) -> Shared<'_, Ad5761rModel> {
        Shared(&self.dac)
    }
}

/// Why a [`ConverterRig`] cannot be built or ticked.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RigError {
    /// The conversion settings are invalid.
    Conversion(ConversionError),
    /// An ADC scale's reference is not the ADS131M02's internal 1.2 V,
    /// which the model converts with.
    Reference,
    /// The amplifier gain is zero or not finite.
    AmplifierGain,
    /// A model was borrowed (a driver transaction in progress).
    Busy,
    /// The converter timing is invalid (DAC latency outside 0 ≤ δ < Ts).
    Timing,
}

impl fmt::Display for RigError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Conversion(e) => write!(f, "simulated front end: {e}"),
            Self::Reference => {
                f.write_str("simulated front end: the ADC model's reference is 1.2 V")
            }
            Self::AmplifierGain => f.write_str("amplifier gain zero or not finite"),
            Self::Busy => f.write_str("a converter model is in use (transaction in progress)"),
            Self::Timing => {
                f.write_str("converter timing: the DAC latency must be finite, >= 0 and < Ts")
            }
        }
    }
}

impl core::error::Error for RigError {
    fn source(&self) -> Option<&(dyn core::error::Error + 'static)> {
        match self {
            Self::Conversion(e) => Some(e),
            _ => None,
        }
    }
}

/// What one tick simulated.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct RigTick {
    /// Actuator (piezo) volts the DAC held at the end of the period that
    /// just ended (from δ after its start on, [`ConverterTiming`]).
    pub u_v: f64,
    /// Output as the ADC converts it at this tick, noise included (strain
    /// or m): y(t_k), or its sinc³ average with [`ConverterTiming::sinc3`].
    pub y: f64,
    /// Actuator volts as the monitor channel converts them (the held value,
    /// or its sinc³ average).
    pub monitor_v: f64,
}

/// Plant + analog front end + converter models; see the module docs.
#[derive(Debug, Clone)]
pub struct ConverterRig<'a> {
    models: &'a ConverterModels,
    plant: TimedPlant,
    front_end: AnalogFrontEnd,
    amplifier_gain: f64,
    noise: Option<GaussianNoise<f64>>,
    /// Lines added to y (mains hum): amplitude, phase step per tick and
    /// phase now (rad); `hum_len` of them.
    hum: [(f64, f64, f64); MAX_HUM_LINES],
    hum_len: usize,
    /// The monitor channel sees the amplifier (false: its input is
    /// grounded, a fault).
    monitor_connected: bool,
    ticks: u64,
}

/// Lines a [`ConverterRig`] can add to y.
const MAX_HUM_LINES: usize = 4;

impl<'a> ConverterRig<'a> {
    /// A rig around `plant` (at its current state), converting y and u to
    /// ADC volts as `conversion` expects them back, with an amplifier of
    /// `amplifier_gain` actuator volts per DAC volt (the pipeline's
    /// [`crate::pipeline::PipelineConfig::amplifier_gain`]).
    pub fn new(
        models: &'a ConverterModels,
        plant: ModalPlant<f64>,
        conversion: &ConversionConfig,
        amplifier_gain: f64,
    ) -> Result<Self, RigError> {
        let front_end = conversion
            .analog_front_end()
            .map_err(RigError::Conversion)?;
        if conversion.bridge_adc.vref_v != VREF_VOLTS || conversion.monitor_adc.vref_v != VREF_VOLTS
        {
            return Err(RigError::Reference);
        }
        if !(amplifier_gain != 0.0 && amplifier_gain.is_finite()) {
            return Err(RigError::AmplifierGain);
        }
        let plant =
            TimedPlant::new(&plant, ConverterTiming::IDEAL).map_err(|_| RigError::Timing)?;
        Ok(Self {
            models,
            plant,
            front_end,
            amplifier_gain,
            noise: None,
            hum: [(0.0, 0.0, 0.0); MAX_HUM_LINES],
            hum_len: 0,
            monitor_connected: true,
            ticks: 0,
        })
    }

    /// The same rig with lines in y that u does not drive, as a strain
    /// gauge picks up the mains: each (frequency Hz, amplitude in units of
    /// y, phase at the first tick rad) adds amplitude·sin(2πf·t + phase)
    /// before the bridge, at sample period `ts_s`; at most
    /// four (more are ignored).
    pub fn with_hum(mut self, lines: &[(f64, f64, f64)], ts_s: f64) -> Self {
        for (slot, &(f, a, p)) in self.hum.iter_mut().zip(lines) {
            *slot = (a, core::f64::consts::TAU * f * ts_s, p);
        }
        self.hum_len = lines.len().min(MAX_HUM_LINES);
        self
    }

    /// The same rig with white noise added to y before the bridge (an
    /// analog disturbance the ADC quantises with the signal).
    pub fn with_noise(self, noise: GaussianNoise<f64>) -> Self {
        Self {
            noise: Some(noise),
            ..self
        }
    }

    /// Set or remove the white noise on y at run time (a fault: a noisy
    /// bridge, interference).
    pub(crate) fn set_noise(&mut self, noise: Option<GaussianNoise<f64>>) {
        self.noise = noise;
    }

    /// Connect or disconnect the monitor channel (disconnected: its input
    /// reads 0 V, as an open monitor wire into a grounded divider — no
    /// DAC → ADC loopback).
    pub(crate) fn set_monitor_connected(&mut self, connected: bool) {
        self.monitor_connected = connected;
    }

    /// The same rig with the converters' `timing` (the ADC's sinc³, the
    /// DAC's latency; [`ConverterTiming::IDEAL`] unless set).
    pub(crate) fn with_timing(self, timing: ConverterTiming) -> Result<Self, RigError> {
        let plant = self
            .plant
            .with_timing(timing)
            .map_err(|_| RigError::Timing)?;
        Ok(Self { plant, ..self })
    }

    /// One sample instant (see the module docs). Never panics.
    #[inline]
    pub fn tick(&mut self) -> Result<RigTick, RigError> {
        let mut adc = self
            .models
            .adc
            .try_borrow_mut()
            .map_err(|_| RigError::Busy)?;
        let held_v = self
            .models
            .dac
            .try_borrow()
            .map_err(|_| RigError::Busy)?
            .output_volts();
        let u_v = held_v * self.amplifier_gain;
        self.plant.advance(u_v);
        let mut y = self.plant.measured();
        if let Some(n) = self.noise.as_mut() {
            y += n.sample();
        }
        for (amp, step, phase) in self.hum.iter_mut().take(self.hum_len) {
            y += *amp * libm::sin(*phase);
            *phase = libm::fmod(*phase + *step, core::f64::consts::TAU);
        }
        let monitor_v = self.plant.measured_drive();
        let monitor_in = if self.monitor_connected {
            self.front_end.monitor_volts(monitor_v)
        } else {
            0.0
        };
        adc.set_inputs([self.front_end.bridge_volts(y), monitor_in]);
        adc.convert();
        self.ticks = self.ticks.wrapping_add(1);
        Ok(RigTick { u_v, y, monitor_v })
    }

    /// The beam (with the converters' timing).
    pub fn plant(&self) -> &TimedPlant {
        &self.plant
    }

    /// The converter models (to inject faults, read their state).
    pub fn models(&self) -> &'a ConverterModels {
        self.models
    }

    /// Ticks simulated.
    pub fn ticks(&self) -> u64 {
        self.ticks
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used, clippy::indexing_slicing)]
mod tests {
    use super::*;
    use crate::bench::{adc_config, conversion};
    use crate::model::{PAPER_B, PAPER_OMEGA, PAPER_ZETA};
    use crate::pipeline::{bring_up, PiezoDac, StrainAdc};
    use crate::rig::chips::ads131m02::quantize;
    use ad5761r::Ad5761r;
    use ads131m02::Ads131m02;

    struct NoDelay;

    impl embedded_hal::delay::DelayNs for NoDelay {
        fn delay_ns(&mut self, _ns: u32) {}
    }

    fn plant() -> ModalPlant<f64> {
        ModalPlant::with_numerator(&PAPER_OMEGA, &PAPER_ZETA, &PAPER_B, 1e-4).unwrap()
    }

    /// The rig's tick against an independent computation, through the real
    /// drivers: u from the DAC model, the plant advanced with it, both
    /// channels quantised as the front end says.
    #[test]
    fn tick_drives_the_plant_with_the_dac_and_the_adc_with_the_plant() {
        let models = ConverterModels::new();
        let mut adc = Ads131m02::new(models.adc_spi());
        let mut dac = Ad5761r::new(models.dac_spi());
        bring_up(
            &mut adc,
            &mut dac,
            &adc_config(),
            ad5761r::Config::default(),
            &mut NoDelay,
        )
        .unwrap();
        let cfg = conversion();
        let gain = 10.0;
        let mut rig = ConverterRig::new(&models, plant(), &cfg, gain).unwrap();
        let mut reference = plant();
        let fe = cfg.analog_front_end().unwrap();
        let mut held = 0.0;
        for k in 0..3000 {
            let t = rig.tick().unwrap();
            reference.advance(held * gain);
            assert_eq!(t.u_v, held * gain);
            assert_eq!(t.y, reference.output());
            let r = adc.read().unwrap();
            assert_eq!(r.bridge, quantize(fe.bridge_volts(t.y), 128), "{k}");
            assert_eq!(r.monitor, quantize(fe.monitor_volts(t.u_v), 1), "{k}");
            // The DAC volts of a ±0.1 V square at 7 Hz on the piezo.
            let cmd = if (k / 714) % 2 == 0 { 0.01 } else { -0.01 };
            held = PiezoDac::<f64>::write_volts(&mut dac, cmd).unwrap().held_v;
        }
        assert_eq!(rig.ticks(), 3000);
        assert!(rig.plant().output().abs() > 1e-4, "the beam moved");
        // A model borrowed elsewhere: an error, not a panic.
        let guard = models.adc.borrow();
        assert_eq!(rig.tick().unwrap_err(), RigError::Busy);
        drop(guard);
        assert!(rig.tick().is_ok());
    }

    #[test]
    fn noise_is_added_before_the_bridge() {
        let models = ConverterModels::new();
        let cfg = conversion();
        let sd = 1e-6;
        let mut rig = ConverterRig::new(&models, plant(), &cfg, 10.0)
            .unwrap()
            .with_noise(GaussianNoise::new(sd, 7).unwrap());
        let n = 20_000;
        let mut acc = 0.0;
        for _ in 0..n {
            let t = rig.tick().unwrap();
            // The DAC is clamped at 0 V (never configured): y is noise only.
            assert_eq!(t.u_v, 0.0);
            acc += t.y * t.y;
        }
        let rms = (acc / f64::from(n)).sqrt();
        assert!((rms / sd - 1.0).abs() < 0.03, "{rms}");
    }

    #[test]
    fn rejects_bad_settings() {
        let models = ConverterModels::new();
        let mut cfg = conversion();
        assert_eq!(
            ConverterRig::new(&models, plant(), &cfg, 0.0).unwrap_err(),
            RigError::AmplifierGain
        );
        cfg.monitor_adc.vref_v = 2.5;
        assert_eq!(
            ConverterRig::new(&models, plant(), &cfg, 1.0).unwrap_err(),
            RigError::Reference
        );
        cfg.bridge.excitation_v = 0.0;
        let e = ConverterRig::new(&models, plant(), &cfg, 1.0).unwrap_err();
        assert_eq!(e, RigError::Conversion(ConversionError::Excitation));
        assert!(core::error::Error::source(&e).is_some());
        assert!(std::format!("{e}").contains("excitation"));
    }
}
