//! Errors of the ADS131M02 driver.

use core::fmt;

use super::command::Command;
use super::registers::{Register, Status};

/// Everything that can go wrong talking to the ADS131M02. `E` is the SPI
/// device's error. No variant ever carries a sample: a frame that fails a
/// check is never returned as data.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Error<E> {
    /// The SPI transaction failed.
    Spi(E),
    /// The output CRC of a frame did not match its contents (§8.3.12).
    Crc {
        /// CRC word the device sent.
        received: u16,
        /// CRC computed over the frame.
        computed: u16,
    },
    /// The first word of a frame was not the answer (Table 8-11) to the
    /// command sent in the previous frame.
    UnexpectedResponse {
        /// The command the word should have answered.
        command: Command,
        /// The word received.
        response: u16,
    },
    /// The frame carried the (checked) answer to a command latched before a
    /// failed operation, not STATUS: it holds no sample.
    OwedResponse {
        /// The command answered.
        command: Command,
    },
    /// The frame after RESET did not carry the reset reply FF22h.
    ResetReply(u16),
    /// The ID register's high byte is not 22h (reserved 2h, CHANCNT = 2):
    /// not an ADS131M02. Carries the ID read.
    IdMismatch(u16),
    /// STATUS.CRC_ERR: the device saw a bad input CRC; the command of that
    /// frame was not executed (WREG excepted, §8.3.12).
    InputCrc(Status),
    /// STATUS.F_RESYNC: the device reports a resynchronisation fault.
    ResyncFault(Status),
    /// STATUS.RESET is set although the driver had cleared it: the device
    /// reset on its own (brown-out, SYNC/RESET pin) and lost its settings.
    UnexpectedReset(Status),
    /// STATUS reports a word length or CRC type other than the one the
    /// driver frames with, or a LOCK state it did not set: the frame cannot
    /// be trusted.
    StatusMismatch(Status),
    /// No new conversion since the last frame (STATUS.DRDY clear for an
    /// enabled channel): the data are a repeat, not a sample.
    NoNewData(Status),
    /// Both channel codes were bit-identical for this many consecutive
    /// frames (the driver's optional stuck-data check).
    StuckData {
        /// Consecutive identical frames seen.
        frames: u16,
    },
    /// A register read back differs from what was written.
    ConfigMismatch {
        /// The register.
        register: Register,
        /// Value written (compared bits).
        wrote: u16,
        /// Value read (compared bits).
        read: u16,
    },
    /// A request the driver cannot encode (e.g. RREG of 0 or more than
    /// [`crate::MAX_READ_REGISTERS`] registers).
    InvalidArgument,
}

impl<E> From<E> for Error<E> {
    fn from(e: E) -> Self {
        Error::Spi(e)
    }
}

impl<E: fmt::Debug> fmt::Display for Error<E> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Error::Spi(e) => write!(f, "ADS131M02: SPI error: {e:?}"),
            Error::Crc { received, computed } => write!(
                f,
                "ADS131M02: frame CRC {received:04X}h, computed {computed:04X}h"
            ),
            Error::UnexpectedResponse { command, response } => write!(
                f,
                "ADS131M02: response {response:04X}h does not answer {command:?} ({:04X}h)",
                command.word()
            ),
            Error::OwedResponse { command } => write!(
                f,
                "ADS131M02: frame answered an earlier {command:?}, no sample"
            ),
            Error::ResetReply(w) => {
                write!(f, "ADS131M02: reset reply {w:04X}h, expected FF22h")
            }
            Error::IdMismatch(id) => {
                write!(
                    f,
                    "ADS131M02: ID {id:04X}h is not a two-channel ADS131M0x (22xxh)"
                )
            }
            Error::InputCrc(s) => {
                write!(
                    f,
                    "ADS131M02: device saw an input CRC error (STATUS {:04X}h)",
                    s.to_bits()
                )
            }
            Error::ResyncFault(s) => {
                write!(
                    f,
                    "ADS131M02: resynchronisation fault (STATUS {:04X}h)",
                    s.to_bits()
                )
            }
            Error::UnexpectedReset(s) => write!(
                f,
                "ADS131M02: device reset unexpectedly, settings lost (STATUS {:04X}h)",
                s.to_bits()
            ),
            Error::StatusMismatch(s) => write!(
                f,
                "ADS131M02: STATUS {:04X}h disagrees with the driver's frame format",
                s.to_bits()
            ),
            Error::NoNewData(s) => {
                write!(
                    f,
                    "ADS131M02: no new conversion (STATUS {:04X}h)",
                    s.to_bits()
                )
            }
            Error::StuckData { frames } => {
                write!(f, "ADS131M02: channel data unchanged for {frames} frames")
            }
            Error::ConfigMismatch {
                register,
                wrote,
                read,
            } => write!(
                f,
                "ADS131M02: {register:?} wrote {wrote:04X}h, read back {read:04X}h"
            ),
            Error::InvalidArgument => f.write_str("ADS131M02: invalid request"),
        }
    }
}

impl<E: fmt::Debug> core::error::Error for Error<E> {}
