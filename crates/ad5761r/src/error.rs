//! Errors of the AD5761R driver.

use core::fmt;

/// Everything that can go wrong driving the AD5761R. `E` is the SPI
/// device's error.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Error<E> {
    /// The SPI transaction failed.
    Spi(E),
    /// A voltage was requested before [`crate::Ad5761r::init`]: the
    /// transfer function (range, coding) is unknown.
    NotConfigured,
    /// The requested voltage is NaN or infinite; nothing was written.
    NotFinite,
    /// The configuration cannot be used (see [`ConfigError`]).
    InvalidConfig(ConfigError),
    /// The control register read back differs from what was written
    /// (bits 10:0).
    ConfigMismatch {
        /// Bits written.
        wrote: u16,
        /// Bits read back.
        read: u16,
    },
    /// A readback word did not echo the readback command in DB19:16 with
    /// DB20 = 0 (Table 15), or carried an undefined field encoding.
    UnexpectedReadback {
        /// The readback command nibble sent.
        command: u8,
        /// The 24-bit word received.
        word: u32,
    },
}

/// Why a configuration was refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum ConfigError {
    /// The external reference voltage is not a finite positive number.
    ReferenceVoltage,
}

impl<E> From<E> for Error<E> {
    fn from(e: E) -> Self {
        Error::Spi(e)
    }
}

impl<E: fmt::Debug> fmt::Display for Error<E> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Error::Spi(e) => write!(f, "AD5761R: SPI error: {e:?}"),
            Error::NotConfigured => f.write_str("AD5761R: not configured"),
            Error::NotFinite => f.write_str("AD5761R: requested voltage is not finite"),
            Error::InvalidConfig(ConfigError::ReferenceVoltage) => {
                f.write_str("AD5761R: external reference voltage must be finite and positive")
            }
            Error::ConfigMismatch { wrote, read } => write!(
                f,
                "AD5761R: control register wrote {wrote:03X}h, read back {read:03X}h"
            ),
            Error::UnexpectedReadback { command, word } => write!(
                f,
                "AD5761R: readback {word:06X}h does not answer command {command:X}h"
            ),
        }
    }
}

impl<E: fmt::Debug> core::error::Error for Error<E> {}
