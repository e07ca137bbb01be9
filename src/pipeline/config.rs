//! The pipeline's settings, its errors and what one tick reports.

use super::convert::{ConversionConfig, ConversionError};
use super::prefilter::{PrefilterConfig, PrefilterError};
use crate::estimator::StepStatus;

/// Where the estimator's u comes from (see the module doc).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum InputSource {
    /// The DAC's held value times the amplifier gain.
    #[default]
    Commanded,
    /// The amplifier's monitor output (ADC channel 1).
    Monitored,
}

/// When a DAC write reaches the output.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum DacLatch {
    /// At the write (shortly after data-ready).
    #[default]
    Immediate,
    /// At the next data-ready (hardware latch); the pipeline computes one
    /// sample ahead.
    NextTick,
}

/// Invalid pipeline settings.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PipelineError {
    /// See [`ConversionError`].
    Conversion(ConversionError),
    /// See [`PrefilterError`].
    Prefilter(PrefilterError),
    /// Amplifier gain zero or not finite.
    AmplifierGain,
    /// Telemetry interval of 0 samples.
    TelemetryRate,
    /// λ not positive and finite.
    Lambda,
    /// `stuck_after` ≥ `crate::guard::MAX_DELAY`.
    StuckAfter,
}

impl core::fmt::Display for PipelineError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Self::Conversion(e) => write!(f, "conversion: {e}"),
            Self::Prefilter(e) => write!(f, "prefilter: {e}"),
            Self::AmplifierGain => f.write_str("amplifier gain zero or not finite"),
            Self::TelemetryRate => f.write_str("telemetry interval must be at least 1 sample"),
            Self::Lambda => f.write_str("filter pole lambda not positive and finite"),
            Self::StuckAfter => f.write_str("stuck_after exceeds the delay line"),
        }
    }
}

impl core::error::Error for PipelineError {}

impl From<ConversionError> for PipelineError {
    fn from(e: ConversionError) -> Self {
        Self::Conversion(e)
    }
}

impl From<PrefilterError> for PipelineError {
    fn from(e: PrefilterError) -> Self {
        Self::Prefilter(e)
    }
}

/// Everything the pipeline needs besides its parts.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PipelineConfig {
    /// Codes → y and u_mon.
    pub conversion: ConversionConfig,
    /// Which u the estimator gets.
    pub input: InputSource,
    /// Actuator volts per DAC volt (the paper's amplifier: ±10 V → ±100 V,
    /// i.e. 10). The excitation is in actuator volts.
    pub amplifier_gain: f64,
    /// When a DAC write takes effect.
    pub dac_latch: DacLatch,
    /// Optional low-pass on u and y.
    pub prefilter: Option<PrefilterConfig>,
    /// A telemetry record every this many samples (≥ 1; 100 → 100 Hz at
    /// 10 kHz).
    pub telemetry_every: u32,
    /// A raw (u, y) pair every this many samples; 0 = no raw blocks.
    pub raw_decimation: u16,
    /// A bridge code repeated this many more times is stuck, and so is the
    /// whole run of identical codes: 0 = no check, at most `crate::guard::MAX_DELAY` − 1.
    /// The estimator then lags by `stuck_after + 1` samples (a delay line,
    /// so the run's first samples are rejected too). A live 24-bit bridge
    /// never repeats for long; a noise-free simulation at rest does.
    pub stuck_after: u16,
    /// The estimator's filter pole λ (rad/s), copied into each record.
    pub lambda_rad_s: f64,
}

/// What one tick did (for the board's diagnostics and for tests).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Tick<T> {
    /// Index of this tick's conversion.
    pub sample_index: u64,
    /// Actuator volts sent to the DAC at this tick (after the window).
    pub commanded_v: T,
    /// The pair handed to the prefilter/estimator (NaN if invalid), if any.
    pub fed: Option<(T, T)>,
    /// The estimator's verdict, if it was stepped.
    pub step: Option<StepStatus>,
    /// Actuator volts the DAC holds from this tick on (its quantised
    /// value × the amplifier gain; NaN if the write failed or, with
    /// [`DacLatch::NextTick`], before the first latch).
    pub held_v: T,
    /// This tick's conversion, before the estimator's pairing, guard and
    /// holds (what the self-test measures).
    pub reading: TickReading<T>,
}

/// One tick's conversion as the converter delivered it (converted to
/// physical units; no pairing, guard or prefilter).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TickReading<T> {
    /// A new conversion was there to read: the converter did not report
    /// the data stale (ADS131M02: STATUS.DRDY clear). A frame that failed
    /// its CRC or on the bus counts: DRDY had announced a conversion.
    pub fresh: bool,
    /// The bridge channel as y (NaN: no valid conversion, or saturated).
    pub y: T,
    /// The monitor channel as actuator volts (NaN: no valid conversion,
    /// or at full scale).
    pub monitor_v: T,
}
