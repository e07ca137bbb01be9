//! The simulated bench, assembled: the rig's beam and converter chip models
//! ([`crate::rig`]) behind the sample task's front end ([`ConverterRig`]),
//! with one set of settings for the QEMU image and the host tests that run
//! the firmware's data path (pipeline, link), so both simulate the same
//! bench. It stands above the simulator and the sample task, which know
//! nothing of each other.
//!
//! * [`ConverterRig`] — the plant between the two chip models with the
//!   analog front end (amplifier, bridge, monitor: the pipeline's
//!   conversion run backwards), one DRDY period per tick;
//! * the settings below: the paper's beam (Section IV.A), the converters'
//!   configuration and timing, the front end, the excitation, the
//!   estimator's filter, the pipeline and the link.
//!
//! | part | setting | why |
//! |---|---|---|
//! | plant | Table III ω, ζ with eq. 46's numerator, Ts = 0.1 ms | the paper's simulation |
//! | DAC | AD5761R ±10 V, straight binary, mid-scale at power-up | the rig's piezo DAC (driver default) |
//! | amplifier | 10 V/V: ±10 V → ±100 V | a piezo amplifier's span |
//! | bridge | quarter bridge, GF 2.1 (WFLA-6-11 class), 5 V, no amplifier, exact linearisation | the paper's gauge |
//! | y | eq. 17 deflection, L = 0.36 m (Table I), L₁ = 0.34 m, h = 1 mm | the paper's output |
//! | ADC | ADS131M02, bridge at PGA 128 (±9.4 mV), monitor at PGA 1, 24-bit words, CRC both ways | the rig's ADC (driver default but the gain) |
//! | converter timing | each conversion the sinc³ average of the last three periods; the DAC updated 15 µs after DRDY ([`converter_timing`]) | the chip's sinc3 filter (SBAS853A §8.3.7) and the board's SPI timing (docs/RIG.md, "Timing") |
//! | monitor | 100 V → 1 V (0.01 V/V) | inside the ±1.2 V input |
//! | excitation | 0.1 V·square(7 Hz) on the piezo, window ±10 V | the paper's input |
//! | estimator | λ = 100 rad/s, U0 = the commanded amplitude, Y0 = RMS of y over the first 0.1 s, output timing: sinc3 kernel, delay 1.5 + 0.15 samples ([`output_timing`]) | settings from what the user knows (data sheet, board timing) and from the data |
//!
//! The beam's peak |y| under the square wave, ≈ 10.4 mm of deflection, is
//! ≈ 267,000 codes of the bridge channel (1 code = 3.9e-8 m of y; 3% of
//! full scale), and the 0.1 V square is ±33 codes of the DAC (held
//! ±0.1007 V). Both figures are checked by
//! `host-tests/tests/firmware_pipeline.rs`.
//!
//! Only the plant reads the paper's truth (it *is* the simulated beam); the
//! estimator's settings come from [`filter_config`] with the measured Y0.
//! The converter timing is simulated ([`converter_timing`]) and compensated
//! ([`output_timing`]) from the same two facts a user has for the board:
//! the sinc3's group delay and the DAC's latency. Without the compensation
//! the timing biases ζ by +0.5 % (docs/RIG.md, "The ADS131M02's filter
//! delay"; `host-tests/tests/firmware_pipeline.rs` checks both ways).

#![deny(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::panic,
    clippy::indexing_slicing
)]

mod converter;

pub use converter::{ConverterModels, ConverterRig, RigError, RigTick};

use crate::excitation::{
    Excitation, ExcitationError, SafeWindow, MULTISINE_MAX_TONES, PRBS_MAX_ORDER, PRBS_MIN_ORDER,
};
use crate::filter_bank::{FilterConfig, OutputTiming, SignalScales};
use crate::link::{FlagRules, LinkConfig, Settings, FIRMWARE_VERSION};
use crate::model::{PAPER_B, PAPER_OMEGA, PAPER_ZETA};
use crate::pipeline::{
    adc_scales, BridgeConfig, ConversionConfig, DacLatch, Eq17, InputSource, Linearisation,
    OutputQuantity, PipelineConfig,
};
use crate::rig::{ConverterTiming, GaussianNoise, ModalPlant, PlantError};
use crate::scalar::Real;
use crate::selftest::SelfTestConfig;
use ads131m02::PgaGain;
use beam_protocol::budget::uart_bytes_per_s;
use beam_protocol::{self as protocol, EstimatorKind, EstimatorSettings, Limits, TelemetryRates};

/// Sample rate (Hz): the paper's Ts = 0.1 ms.
pub const SAMPLE_RATE_HZ: f64 = 10_000.0;
/// Sample period (s).
pub const TS_S: f64 = 1.0 / SAMPLE_RATE_HZ;
/// Actuator volts per DAC volt.
pub const AMPLIFIER_GAIN: f64 = 10.0;

/// The mains hum `cargo xtask qemu --hum` injects into the ADC model's
/// bridge input ([`ConverterRig::with_hum`]): (frequency Hz, amplitude m,
/// phase rad). 50 Hz at 3% and 150 Hz at 1% of y's RMS under the bench's
/// excitation (4.73e-3 m: the paper's 0.1 V square wave at 7 Hz); the
/// bench beam's second mode (245.4 rad/s, 39.1 Hz) lies 11 Hz below the
/// first line.
pub const HUM: [(f64, f64, f64); 2] = [(50.0, 2.0e-4, 0.3), (150.0, 6.7e-5, 1.1)];
/// Excitation amplitude on the piezo (V): the paper's 0.1; also U0.
pub const EXCITATION_V: f64 = 0.1;
/// Excitation frequency (Hz): the paper's 7.
pub const EXCITATION_HZ: f64 = 7.0;
/// Safe window of the piezo voltage (V).
pub(crate) const WINDOW_V: f64 = 10.0;
/// Filter pole λ (rad/s): the paper's choice for its beam.
pub const LAMBDA_RAD_S: f64 = 100.0;
/// Start-up window for Y0 (valid samples: 0.1 s).
pub const STARTUP_SAMPLES: u32 = 1_000;
/// Telemetry record interval (samples: 100 Hz).
pub const TELEMETRY_EVERY: u32 = 100;
/// A bridge code repeated this many more times is stuck (2.5 ms; the
/// noise-free beam under the square wave never repeats a code more than a
/// few times, and a live bridge never does).
pub const STUCK_AFTER: u16 = 25;
/// Output weights C̄ (eq. 24) of the two modes, for b̄ (eq. 32).
pub const OUTPUT_WEIGHT: [f64; 2] = [-2.0, 2.0];
/// The clock the emulated board times its sample interrupt with (Hz):
/// QEMU `mps2-an386`'s 25 MHz core clock (SysTick), 2,500 per sample;
/// host tests that run the bench's self-test count their ticks in it too.
pub const CLOCK_HZ: f64 = 25e6;
/// The loopback tone of the self-test on the actuator (V): ten times the
/// default excitation, inside the ±10 V window.
pub const SELF_TEST_TONE_V: f32 = 1.0;
/// The white noise on y of [`BenchFault::Noise`] (m): about 40 dB below
/// the y of the self-test's signal phase.
pub(crate) const NOISE_FAULT_SD_M: f64 = 2e-5;

/// The DAC's new value takes effect this long after DRDY (s): the board
/// writes it after reading the ADC frame, ≈ 15 µs at its SPI clocks
/// (docs/RIG.md, "Timing": 12 bytes at 10 MHz, then 3 at 12.5 MHz).
pub const DAC_LATENCY_S: f64 = 15e-6;

/// The paper's simulation plant at rest.
pub fn plant() -> Result<ModalPlant<f64>, PlantError> {
    ModalPlant::with_numerator(&PAPER_OMEGA, &PAPER_ZETA, &PAPER_B, TS_S)
}

/// The board's converter timing, simulated: the ADS131M02's sinc³ and the
/// DAC [`DAC_LATENCY_S`] after DRDY.
pub fn converter_timing() -> ConverterTiming {
    ConverterTiming {
        sinc3: true,
        dac_latency_s: DAC_LATENCY_S,
    }
}

/// The estimator's model of that timing, from the data sheet (a sinc3 at
/// the data rate: group delay 1.5 samples) and the board's DAC latency:
/// the sinc³ kernel on u, delay 1.5 + 0.15 samples.
pub fn output_timing() -> OutputTiming {
    OutputTiming::sinc3_adc(DAC_LATENCY_S, TS_S)
}

/// The simulated bench behind `models`: the paper's plant at rest, the
/// front end of [`conversion`], the amplifier, the board's
/// [`converter_timing`].
pub fn converter_rig(models: &ConverterModels) -> Result<ConverterRig<'_>, RigError> {
    let plant = plant().map_err(|_| RigError::Timing)?;
    ConverterRig::new(models, plant, &conversion(), AMPLIFIER_GAIN)?.with_timing(converter_timing())
}

/// The ADS131M02 settings: bridge at PGA 128, monitor at PGA 1, the rest
/// the driver's defaults (OSR 256, 24-bit words, CCITT CRC both ways).
pub fn adc_config() -> ads131m02::Config {
    ads131m02::Config {
        gains: [PgaGain::G128, PgaGain::G1],
        ..ads131m02::Config::default()
    }
}

/// The AD5761R settings: ±10 V, straight binary, 0 V at power-up.
pub fn dac_config() -> ad5761r::Config {
    ad5761r::Config::default()
}

/// One step of the DAC in actuator volts (its LSB × [`AMPLIFIER_GAIN`]):
/// every u the pipeline commands is a multiple of it, so the robust
/// estimator's compact record keeps u exactly on this grid
/// (`RobustConfig::input_step`).
pub fn input_step_v() -> f64 {
    f64::from(dac_config().transfer().lsb_volts()) * AMPLIFIER_GAIN
}

/// Codes → y (eq. 17 deflection, m) and → actuator volts, at the ADC
/// scales of [`adc_config`].
pub fn conversion() -> ConversionConfig {
    let [bridge_adc, monitor_adc] = adc_scales(&adc_config());
    ConversionConfig {
        bridge_adc,
        bridge: BridgeConfig {
            excitation_v: 5.0,
            gauge_factor: 2.1,
            amplifier_gain: 1.0,
            null_offset_v: 0.0,
            linearisation: Linearisation::Exact,
            invert: false,
        },
        output: OutputQuantity::Deflection(Eq17 {
            length_m: 0.36,
            gauge_lever_arm_m: 0.34,
            thickness_m: 1e-3,
        }),
        monitor_adc,
        monitor_v_per_v: 0.01,
    }
}

/// The pipeline: commanded u, immediate DAC update, no prefilter, a record
/// every [`TELEMETRY_EVERY`] samples, stuck check after [`STUCK_AFTER`].
pub fn pipeline_config() -> PipelineConfig {
    PipelineConfig {
        conversion: conversion(),
        input: InputSource::Commanded,
        amplifier_gain: AMPLIFIER_GAIN,
        dac_latch: DacLatch::Immediate,
        prefilter: None,
        telemetry_every: TELEMETRY_EVERY,
        raw_decimation: 0,
        stuck_after: STUCK_AFTER,
        lambda_rad_s: LAMBDA_RAD_S,
    }
}

/// The paper's excitation, 0.1 V·square(7 Hz), inside ±`WINDOW_V`.
pub fn excitation<T: Real>() -> Result<Excitation<T>, ExcitationError> {
    Excitation::new(
        &protocol::Waveform::Square {
            freq_hz: EXCITATION_HZ as f32,
        },
        T::from_f64(EXCITATION_V),
        T::ZERO,
        SafeWindow {
            min_v: T::from_f64(-WINDOW_V),
            max_v: T::from_f64(WINDOW_V),
        },
        SAMPLE_RATE_HZ,
    )
}

/// The estimator's filter settings for output scale `y0` (measured):
/// λ = [`LAMBDA_RAD_S`], U0 = [`EXCITATION_V`], the default output hold,
/// the converters' [`output_timing`].
pub fn filter_config(y0: f64) -> FilterConfig {
    FilterConfig {
        ts_s: TS_S,
        lambda_rad_s: LAMBDA_RAD_S,
        scales: SignalScales {
            u_scale: EXCITATION_V,
            y_scale: y0,
        },
        timing: output_timing(),
        ..FilterConfig::default()
    }
}

/// What the bench's firmware accepts over the serial link at `baud`
/// (8N1): its sample rate, the piezo window ±`WINDOW_V`, every
/// generator's range (multisine ≤ 16 tones, PRBS orders 2–24), the
/// adaptive law only, two modes, and the whole line rate as the link
/// budget (`docs/PROTOCOL.md` §7).
pub fn link_limits(baud: u32) -> Limits {
    Limits {
        sample_rate_hz: SAMPLE_RATE_HZ as f32,
        piezo_min_v: -WINDOW_V as f32,
        piezo_max_v: WINDOW_V as f32,
        max_multisine_tones: MULTISINE_MAX_TONES as u8,
        prbs_bits_min: PRBS_MIN_ORDER,
        prbs_bits_max: PRBS_MAX_ORDER,
        estimators: EstimatorKind::Adaptive.bit(),
        modes: 2,
        link_bytes_per_s: uart_bytes_per_s(baud) as f32,
    }
}

/// The link's fixed properties for the bench at `baud`.
pub fn link_config(baud: u32) -> LinkConfig {
    LinkConfig {
        limits: link_limits(baud),
        firmware: FIRMWARE_VERSION,
        rules: FlagRules::default(),
        self_test: self_test_config(),
    }
}

/// What the self-test expects of the bench: its sample rate against
/// [`CLOCK_HZ`], the ADC's configuration [`adc_config`], the loopback at
/// the converters' timing ([`output_timing`]'s delay plus the hold's half
/// sample: 2.15 samples), one code of y from [`conversion`], and the
/// default excitation of [`link_settings`] as the SNR's signal.
pub fn self_test_config() -> SelfTestConfig {
    let y_code = conversion()
        .compile::<f64>()
        .map_or(f64::NAN, |c| c.y_from_code(1) - c.y_from_code(0));
    SelfTestConfig {
        sample_rate_hz: SAMPLE_RATE_HZ,
        clock_hz: CLOCK_HZ,
        adc: adc_config(),
        tone_amplitude_v: SELF_TEST_TONE_V,
        expected_delay_samples: output_timing().delay_samples + 0.5,
        y_code,
        excitation: link_settings().excitation,
    }
}

/// A fault of the bench that one check of the self-test must catch (and
/// no other fail): QEMU's `selftest_fault=NAME` and the host tests.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BenchFault {
    /// The ADC answers with another part's ID (an ADS131M04, 24xxh).
    AdcId,
    /// GAIN1 reads back with bit 0 flipped.
    AdcRegisters,
    /// No conversions at all (no CLKIN, DRDY missing).
    DrdyMissing,
    /// Conversions at 95 % of the sample rate (a slow clock).
    DrdyRate,
    /// The monitor channel's input grounded: no DAC → ADC loopback.
    NoLoopback,
    /// White noise of `NOISE_FAULT_SD_M` on y.
    Noise,
}

impl BenchFault {
    /// Every fault, with its name.
    pub const ALL: [(Self, &'static str); 6] = [
        (Self::AdcId, "adc_id"),
        (Self::AdcRegisters, "adc_registers"),
        (Self::DrdyMissing, "drdy_missing"),
        (Self::DrdyRate, "drdy_rate"),
        (Self::NoLoopback, "no_loopback"),
        (Self::Noise, "noise"),
    ];

    /// The fault of this name.
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.iter().find(|(_, n)| *n == name).map(|(f, _)| *f)
    }

    /// The fault's name.
    pub fn name(self) -> &'static str {
        Self::ALL
            .iter()
            .find(|(f, _)| *f == self)
            .map_or("", |(_, n)| n)
    }

    /// The check that must fail, and those that cannot be measured with
    /// it (no conversions: neither the loopback nor the noise).
    pub fn expected(self) -> (beam_protocol::SelfTestChecks, beam_protocol::SelfTestChecks) {
        use beam_protocol::SelfTestChecks as C;
        match self {
            Self::AdcId => (C::ADC_ID, C::default()),
            Self::AdcRegisters => (C::ADC_REGISTERS, C::default()),
            Self::DrdyMissing => (C::DRDY_RATE, C::LOOPBACK.with(C::NOISE)),
            Self::DrdyRate => (C::DRDY_RATE, C::default()),
            Self::NoLoopback => (C::LOOPBACK, C::default()),
            Self::Noise => (C::NOISE, C::default()),
        }
    }

    /// Inject the fault into `rig` (its models and front end), from the
    /// next tick on.
    pub fn apply(self, rig: &mut ConverterRig<'_>) {
        match self {
            Self::NoLoopback => rig.set_monitor_connected(false),
            // The seed is arbitrary; σ > 0 is valid.
            Self::Noise => rig.set_noise(GaussianNoise::new(NOISE_FAULT_SD_M, 7).ok()),
            Self::AdcId | Self::AdcRegisters | Self::DrdyMissing | Self::DrdyRate => {
                let Ok(mut adc) = rig.models().adc.try_borrow_mut() else {
                    return;
                };
                match self {
                    Self::AdcId => adc.set_id(0x2400),
                    Self::AdcRegisters => {
                        adc.set_register_fault(Some((ads131m02::Register::Gain, 0x0001)))
                    }
                    Self::DrdyMissing => adc.set_data_rate(0, 1),
                    _ => adc.set_data_rate(19, 20),
                }
            }
        }
    }
}

/// The bench's start-up settings as the protocol states them: the
/// excitation of [`excitation`], the core's default gains with
/// λ = [`LAMBDA_RAD_S`], the default telemetry rates (estimates 100 Hz —
/// one record every [`TELEMETRY_EVERY`] samples —, status 1 Hz, no raw
/// samples).
pub fn link_settings() -> Settings {
    Settings {
        excitation: beam_protocol::Excitation {
            waveform: beam_protocol::Waveform::Square {
                freq_hz: EXCITATION_HZ as f32,
            },
            amplitude_v: EXCITATION_V as f32,
            offset_v: 0.0,
        },
        estimator: EstimatorSettings {
            lambda_rad_s: Some(LAMBDA_RAD_S as f32),
            ..EstimatorSettings::default()
        },
        telemetry: TelemetryRates::default(),
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;

    #[test]
    fn settings_are_valid_and_consistent() {
        assert!(plant().is_ok());
        assert!(excitation::<f32>().is_ok());
        assert!(filter_config(1e-3).validate(4, 7).is_ok());
        assert!((output_timing().delay_samples - 1.65).abs() < 1e-12);
        assert!(converter_timing().is_valid(TS_S));
        let models = ConverterModels::new();
        assert_eq!(
            converter_rig(&models).unwrap().plant().timing(),
            converter_timing()
        );
        let c = conversion();
        assert_eq!((c.bridge_adc.pga_gain, c.monitor_adc.pga_gain), (128, 1));
        assert!(c.compile::<f32>().is_ok());
        // The monitor at the amplifier's full ±100 V stays inside ±1.2 V.
        let fe = c.analog_front_end().unwrap();
        assert!(fe.monitor_volts(10.0 * AMPLIFIER_GAIN).abs() < 1.2);
        assert_eq!(pipeline_config().conversion, c);
    }

    #[test]
    fn link_settings_describe_the_bench() {
        let s = link_settings();
        let l = link_limits(921_600);
        assert!(beam_protocol::Command::SetExcitation(s.excitation)
            .validate(&l)
            .is_ok());
        assert!(beam_protocol::Command::SetEstimator(s.estimator)
            .validate(&l)
            .is_ok());
        assert!(beam_protocol::Command::SetTelemetry(s.telemetry)
            .validate(&l)
            .is_ok());
        assert_eq!(
            crate::link::record_interval(&s.telemetry, l.sample_rate_hz),
            TELEMETRY_EVERY
        );
        assert_eq!(pipeline_config().raw_decimation, s.telemetry.raw_decimation);
        // The protocol's estimator defaults are the core's.
        let (filter, law) =
            crate::link::estimator_configs::<7>(&s.estimator, LAMBDA_RAD_S, &filter_config(1.0));
        assert_eq!(filter, filter_config(1.0));
        let core = crate::estimator::AdaptiveConfig::<7>::default();
        assert_eq!(law.gain, core.gain);
        assert_eq!(law.theta_update_every, core.theta_update_every);
        // The same excitation as the generator the pipeline starts with.
        let mut built = excitation::<f32>().unwrap();
        let window = SafeWindow {
            min_v: -WINDOW_V as f32,
            max_v: WINDOW_V as f32,
        };
        let mut planned = Excitation::<f32>::new(
            &beam_protocol::Waveform::Off,
            0.0,
            0.0,
            window,
            SAMPLE_RATE_HZ,
        )
        .unwrap();
        let off = beam_protocol::Excitation {
            waveform: beam_protocol::Waveform::Off,
            amplitude_v: 0.0,
            offset_v: 0.0,
        };
        crate::link::ExcitationPlan::<f32>::new(&s.excitation, &off, SAMPLE_RATE_HZ)
            .unwrap()
            .apply(&mut planned)
            .unwrap();
        for _ in 0..5000 {
            assert_eq!(built.next_sample(), planned.next_sample());
        }
    }
}
