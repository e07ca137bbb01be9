//! The two converter interfaces the pipeline is generic over, kept minimal
//! so a driver needs only a small adapter: the strain-gauge ADC
//! ([`StrainAdc`], e.g. the ADS131M02) and the piezo DAC ([`PiezoDac`],
//! e.g. the AD5761R). Errors are classified into [`FaultKind`] for the
//! pipeline's counters; the driver's own error type stays available to
//! whoever implements the adapter.

use crate::scalar::Real;

/// Positive full-scale code of a 24-bit two's-complement conversion
/// (ADS131M02 datasheet, "Data Format" and its table "Ideal Output Code
/// versus Input Signal": inputs at or beyond full scale give 7FFFFFh and
/// 800000h — the output clips at these codes).
pub const ADC_CODE_MAX: i32 = 0x7F_FFFF;
/// Negative full-scale code of a 24-bit word (−2²³).
pub(crate) const ADC_CODE_MIN: i32 = -0x80_0000;

/// One conversion of both channels, as the converter delivered it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct AdcReading {
    /// Channel 0: the strain-gauge bridge (24-bit code, sign-extended).
    pub bridge: i32,
    /// Channel 1: the piezo amplifier's voltage monitor (24-bit code).
    pub monitor: i32,
    /// What the converter itself flagged about this conversion.
    pub flags: AdcFlags,
}

/// Per-conversion flags a driver may set (all `false` = nothing to say).
/// The pipeline also detects saturation and stuck data from the codes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct AdcFlags {
    /// The bridge channel is over range.
    pub bridge_saturated: bool,
    /// The monitor channel is over range.
    pub monitor_saturated: bool,
    /// The data are not new (e.g. a channel's DRDY bit not set in the
    /// ADS131M02 status word): the sample is unusable and the codes carry
    /// nothing.
    pub stale: bool,
    /// The driver found the data stuck (e.g. the ADS131M02 driver's
    /// `StuckData`: both codes bit-identical for too many frames): the
    /// sample is unusable, the codes carry nothing, and it counts as stuck.
    pub stuck: bool,
}

/// What went wrong with a converter transaction, for the counters.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FaultKind {
    /// The frame's CRC did not match (ADS131M02 datasheet, "Cyclic
    /// Redundancy Check (CRC)").
    Crc,
    /// The status word or a command response was not what the protocol
    /// requires (e.g. a reset, a lost frame).
    Status,
    /// The bus itself reported an error.
    Bus,
    /// Anything else.
    Other,
}

/// An error that can say which [`FaultKind`] it is.
pub trait Fault {
    /// The kind, for the pipeline's counters.
    fn kind(&self) -> FaultKind;
}

impl Fault for FaultKind {
    fn kind(&self) -> FaultKind {
        *self
    }
}

/// The strain-gauge ADC as the sample task sees it.
pub trait StrainAdc {
    /// The driver's error.
    type Error: Fault;
    /// Read the conversion that has just completed (called once per tick,
    /// right after data-ready).
    fn read(&mut self) -> Result<AdcReading, Self::Error>;

    /// Read the converter's ID and configuration registers back, between
    /// two samples (the self-test). `Err`: the read failed (its kind), or
    /// this converter cannot (the default, [`FaultKind::Other`]).
    fn read_back(&mut self) -> Result<ads131m02::ReadBack, FaultKind> {
        Err(FaultKind::Other)
    }
}

/// Result of a DAC write.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DacOutcome<T> {
    /// The voltage the DAC holds (or will hold after its latch) for the
    /// written code: the request, quantised and limited to the rails (V).
    pub held_v: T,
    /// The request was beyond a rail and was limited.
    pub saturated: bool,
}

/// The piezo DAC as the sample task sees it.
pub trait PiezoDac<T: Real> {
    /// The driver's error.
    type Error: Fault;
    /// Write `volts` (DAC output volts) and report what is held.
    fn write_volts(&mut self, volts: T) -> Result<DacOutcome<T>, Self::Error>;
}
