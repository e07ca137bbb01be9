//! The rig's settings: the analog front end, the excitation, the estimator
//! and the pipeline, in one place (docs/RIG.md explains each number).
//!
//! None of these is derived from a simulated plant: the front-end numbers
//! describe the hardware (gauge, bridge, PGA, amplifier); the estimator's
//! U0, Y0 and λ come from the data through the truth-free tuning rule
//! (`beamest::tuning`, set up in `link::tuning`).

use beam_protocol::Waveform;
use beamest::estimator::{Adaptive2, AdaptiveConfig, ConfigError};
use beamest::excitation::{Excitation, ExcitationError, SafeWindow};
use beamest::filter_bank::{FilterConfig, OutputTiming, SignalScales};
use beamest::pipeline::{
    AdcScale, BridgeConfig, ConversionConfig, DacLatch, InputSource, Linearisation, OutputQuantity,
    PipelineConfig, ADS131M02_VREF_V,
};
use beamest::selftest::SelfTestConfig;

/// Sample rate (Hz): the ADC's data rate (board clock plan).
pub const SAMPLE_RATE_HZ: f64 = 10_000.0;
/// Sample period (s).
pub const TS_S: f64 = 1.0 / SAMPLE_RATE_HZ;

/// When the DAC's new value reaches the actuator after DRDY (s): the
/// pipeline writes it right after the ADC frame (12 bytes at 10 MHz), the
/// AD5761R updates at SYNC's rising edge after its 3 bytes at 12.5 MHz:
/// ≈ 14–15 µs (docs/RIG.md, "Timing"; scope it and set it here).
pub const DAC_LATENCY_S: f64 = 15e-6;

/// Filter pole λ (rad/s) of the placeholder estimator the frozen pipeline
/// holds until the tuning rule's first one is swapped in (never stepped):
/// the paper's value (Wang, Costa-Castelló, Na et al., *Modelling and
/// Adaptive Parameter Estimation for a Piezoelectric Cantilever Beam*,
/// Section IV). The running estimators' λ is the rule's.
pub const PLACEHOLDER_LAMBDA_RAD_S: f64 = 100.0;

/// Piezo amplifier gain, actuator volts per DAC volt: the paper's
/// ±10 V → ±100 V amplifier (Section V).
pub const AMPLIFIER_GAIN: f64 = 10.0;
/// The voltage window the actuator may see (V): the amplifier's ±100 V,
/// inside the PI P-876.A12's rated −100 V … +250 V.
pub const SAFE_WINDOW: SafeWindow<f64> = SafeWindow {
    min_v: -100.0,
    max_v: 100.0,
};
/// Start-up excitation: the paper's square wave at 7 Hz (Section IV.A),
/// at a cautious ±10 V on the actuator (10 % of the window); the serial
/// link's commands (issue 7) change it at run time.
pub const EXCITATION_HZ: f64 = 7.0;
/// Start-up excitation amplitude (actuator volts); also U0.
pub const EXCITATION_AMPLITUDE_V: f64 = 10.0;

/// Quarter-bridge excitation (V), from a 2.0 V reference.
pub const BRIDGE_EXCITATION_V: f64 = 2.0;
/// Gauge factor of the paper's Tokyo Measuring Instruments WFLA-6-11
/// (nominal; use the lot's value from its data sheet).
pub const GAUGE_FACTOR: f64 = 2.1;
/// PGA gain of the bridge channel: FSR ±1.2 V/128 = ±9.375 mV, i.e. a
/// bridge ratio of ±4.69 mV/V at 2.0 V excitation, ±8,900 µε (ADS131M02
/// data sheet §8.3.3 "Programmable Gain Amplifier": FSR = ±1.2 V/gain).
pub const BRIDGE_PGA: ads131m02::PgaGain = ads131m02::PgaGain::G128;
/// PGA gain of the monitor channel (±1.2 V).
pub const MONITOR_PGA: ads131m02::PgaGain = ads131m02::PgaGain::G1;
/// ADC volts per actuator volt on the monitor channel: a ÷10 monitor
/// output followed by a ÷10 divider (±100 V → ±1.0 V). Set to the
/// amplifier actually used.
pub const MONITOR_V_PER_V: f64 = 0.01;

/// A telemetry record every this many samples (100 Hz).
pub const TELEMETRY_EVERY: u32 = 100;
/// A bridge code repeated this many more times is stuck (2 ms; a live
/// 24-bit bridge never repeats that long).
pub const STUCK_AFTER: u16 = 20;
/// Output weights C̄ of eq. 24 for b̄ (eqs. 31–32): unknown for this beam
/// (they depend on the mode shapes at the gauge), so 1; ω and ζ do not
/// depend on them.
pub const OUTPUT_WEIGHT: [f64; 2] = [1.0, 1.0];

/// Samples averaged for the bridge null offset at boot (0.1 s).
pub const NULL_SAMPLES: u32 = 1_000;

/// The ADS131M02 settings: the driver's defaults (OSR 256, high-resolution
/// mode, 24-bit words, CCITT CRC both ways, DRDY a logic level) with the
/// bridge channel's PGA.
pub fn adc_config() -> ads131m02::Config {
    ads131m02::Config {
        gains: [BRIDGE_PGA, MONITOR_PGA],
        ..ads131m02::Config::default()
    }
}

/// The AD5761R settings: ±10 V, straight binary, power-up and clear at
/// mid-scale (0 V), internal reference (the driver's defaults).
pub fn dac_config() -> ad5761r::Config {
    ad5761r::Config::default()
}

fn gain(g: ads131m02::PgaGain) -> u8 {
    u8::try_from(g.factor()).unwrap_or(u8::MAX)
}

/// Codes → strain (bridge) and actuator volts (monitor), with the bridge
/// output at zero strain `null_offset_v` (V at the ADC input).
pub fn conversion(null_offset_v: f64) -> ConversionConfig {
    ConversionConfig {
        bridge_adc: AdcScale {
            vref_v: ADS131M02_VREF_V,
            pga_gain: gain(BRIDGE_PGA),
        },
        bridge: BridgeConfig {
            excitation_v: BRIDGE_EXCITATION_V,
            gauge_factor: GAUGE_FACTOR,
            amplifier_gain: 1.0,
            null_offset_v,
            linearisation: Linearisation::Exact,
            invert: false,
        },
        output: OutputQuantity::Strain,
        monitor_adc: AdcScale {
            vref_v: ADS131M02_VREF_V,
            pga_gain: gain(MONITOR_PGA),
        },
        monitor_v_per_v: MONITOR_V_PER_V,
    }
}

/// The pipeline: commanded u, immediate DAC update (command 0011, LDAC
/// tied low), no prefilter, telemetry at 100 Hz, no raw samples (the
/// serial link's rates replace both at boot).
pub fn pipeline_config(null_offset_v: f64) -> PipelineConfig {
    PipelineConfig {
        conversion: conversion(null_offset_v),
        input: InputSource::Commanded,
        amplifier_gain: AMPLIFIER_GAIN,
        dac_latch: DacLatch::Immediate,
        prefilter: None,
        telemetry_every: TELEMETRY_EVERY,
        raw_decimation: 0,
        stuck_after: STUCK_AFTER,
        lambda_rad_s: PLACEHOLDER_LAMBDA_RAD_S,
    }
}

/// The start-up excitation.
pub fn excitation() -> Result<Excitation<f64>, ExcitationError> {
    Excitation::new(
        &Waveform::Square {
            freq_hz: EXCITATION_HZ as f32,
        },
        EXCITATION_AMPLITUDE_V,
        0.0,
        SAFE_WINDOW,
        SAMPLE_RATE_HZ,
    )
}

/// A priori output scale: a tenth of the bridge channel's full scale in
/// strain (used only if the start-up measurement fails).
pub fn nominal_y_scale() -> f64 {
    let fs_ratio = ADS131M02_VREF_V / f64::from(gain(BRIDGE_PGA)) / BRIDGE_EXCITATION_V;
    0.1 * 4.0 * fs_ratio / GAUGE_FACTOR
}

/// The converters' timing as the estimator models it: the ADS131M02's
/// sinc3 (OSR 256; group delay 1.5 samples, SBAS853A §8.3.7) and the DAC
/// [`DAC_LATENCY_S`] after DRDY — 1.65 samples in all. Without it ζ comes
/// out ≈ 0.5 % high (docs/RIG.md, "The ADS131M02's filter delay").
pub fn output_timing() -> OutputTiming {
    OutputTiming::sinc3_adc(DAC_LATENCY_S, TS_S)
}

/// The placeholder estimator (never stepped): the paper's adaptive law
/// (eqs. 33–41) with the default gains, U0 = the excitation amplitude,
/// Y0 = `y_scale`, [`PLACEHOLDER_LAMBDA_RAD_S`] and the converters'
/// [`output_timing`].
pub fn estimator(y_scale: f64) -> Result<Adaptive2<f64>, ConfigError> {
    let filter = FilterConfig {
        ts_s: TS_S,
        lambda_rad_s: PLACEHOLDER_LAMBDA_RAD_S,
        scales: SignalScales {
            u_scale: EXCITATION_AMPLITUDE_V,
            y_scale,
        },
        timing: output_timing(),
        ..FilterConfig::default()
    };
    Adaptive2::<f64>::new(&filter, &AdaptiveConfig::default())
}

/// The self-test's loopback tone on the actuator (V): the start-up
/// excitation's amplitude, 10 % of the safe window.
pub const SELF_TEST_TONE_V: f32 = EXCITATION_AMPLITUDE_V as f32;

/// What the self-test expects of this board: DRDY at the sample rate
/// against the CPU clock (DWT, 400 MHz), the ADC configuration's
/// registers, the loopback at the converters' timing ([`output_timing`]'s
/// delay plus the hold's half sample: 2.15 samples), one code of strain at
/// the bridge's balance, and the start-up excitation as the SNR's signal.
pub fn self_test_config() -> SelfTestConfig {
    let y_code = conversion(0.0)
        .compile::<f64>()
        .map_or(f64::NAN, |c| c.y_from_code(1) - c.y_from_code(0));
    SelfTestConfig {
        sample_rate_hz: SAMPLE_RATE_HZ,
        clock_hz: f64::from(beamest::board::nucleo::clocks::CPU_HZ),
        adc: adc_config(),
        tone_amplitude_v: SELF_TEST_TONE_V,
        expected_delay_samples: output_timing().delay_samples + 0.5,
        y_code,
        excitation: start_excitation(),
    }
}

/// The start-up excitation as the serial link states it (the generator:
/// [`excitation`]).
pub fn start_excitation() -> beam_protocol::Excitation {
    beam_protocol::Excitation {
        waveform: Waveform::Square {
            freq_hz: EXCITATION_HZ as f32,
        },
        amplitude_v: EXCITATION_AMPLITUDE_V as f32,
        offset_v: 0.0,
    }
}
