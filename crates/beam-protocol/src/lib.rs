//! The serial-link protocol between the rig and the host: typed messages,
//! framing, and a resynchronising stream decoder. Both ends (the firmware
//! and the host tools) use this crate, so they cannot drift apart; it
//! depends on nothing of the estimator's. `docs/PROTOCOL.md` specifies
//! every byte.
//!
//! * [`telemetry`]: device → host messages ([`Estimate`], [`RawSamples`],
//!   [`Status`], [`Ack`], [`SelfTestReport`]);
//! * [`command`]: host → device [`Command`]s;
//! * [`validate`]: [`Command::validate`] against the device's [`Limits`],
//!   which the device runs on every command before it applies it;
//! * [`frame`]: one frame ↔ bytes ([`encode`], [`Encoder`], [`parse_frame`]);
//! * [`decoder`]: a byte stream → frames, with [`LinkCounters`];
//! * [`budget`]: worst-case frame sizes and the link load they imply.
//!
//! # Frame
//! ```text
//! COBS( magic u16 LE | version u8 | kind u8 | seq u32 LE | postcard payload | CRC-32 LE ) 0x00
//! ```
//!
//! # Design
//! * **A fixed binary header, outside the payload.** Magic, version, kind and
//!   sequence number sit at fixed offsets, so any decoder (or a person with a
//!   hex dump) checks them before it knows the payload's schema, and a
//!   decoder of another version still finds the version byte. The kind byte
//!   says which struct the payload is; the payload is the postcard encoding
//!   of that struct alone (no enum tag of its own).
//! * **A u32 sequence number per direction** (device → host and host →
//!   device count separately, from 0 at start-up), as in quartiq/stabilizer's
//!   stream header: the receiver counts lost frames exactly from the gaps,
//!   including across the 2³² wrap, whatever destroyed them.
//! * **postcard** for the payload: compact (varints), `no_std`, no
//!   allocation, and a documented wire format that an independent decoder can
//!   follow (`docs/PROTOCOL.md` states the subset used).
//! * **COBS with a 0x00 delimiter**: a receiver that joins mid-stream, or
//!   loses bytes, resynchronises at the next 0x00, because no 0x00 occurs
//!   inside a frame. Overhead: one byte per frame up to 254 bytes.
//! * **CRC-32/ISO-HDLC** (the CRC of Ethernet, zlib and PNG) over the header
//!   and the payload. The checked data is at most 534 bytes (4,272 bits,
//!   [`MAX_FRAME_LEN`] less the CRC). This polynomial detects every error of
//!   up to 3 bits in any of our frames, and of up to 4 bits in frames of up
//!   to 2,974 data bits (every frame but a raw-sample block): Hamming
//!   distance 4 and 5 (P. Koopman, *32-Bit Cyclic Redundancy Codes for
//!   Internet Applications*, DSN 2002; both checked by host tests), and
//!   every burst of up to 32 bits; a random corruption passes with
//!   probability 2⁻³². A CRC-16 would pass one random corruption in 65,536:
//!   at 300 corrupted frames a day, a wrong frame delivered every 218 days.
//!   CRC-32/ISO-HDLC is also the CRC every language has built in
//!   (`zlib.crc32`, `java.util.zip.CRC32`), which helps independent decoders.
//! * **f32 on the wire.** The estimates are computed from 24-bit ADC data;
//!   f32's 24-bit significand (relative rounding 6e-8) is below the
//!   estimator's own noise floor (`docs/PROTOCOL.md` quantifies it for Θ̂).
//! * **Validation before action.** [`Command::validate`] checks ranges,
//!   finiteness and consistency against the device's [`Limits`]; a rejected
//!   command is answered by an [`Ack`] with a [`RejectReason`] and changes
//!   nothing.
//! * Nothing here allocates or panics, whatever the input: encoding writes
//!   into the caller's buffer, decoding works in a fixed buffer, and the
//!   crate denies indexing, `unwrap` and `panic!` through clippy.
#![cfg_attr(not(test), no_std)]
#![forbid(unsafe_code)]
#![warn(missing_docs)]
#![deny(
    clippy::indexing_slicing,
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::panic,
    clippy::unreachable,
    clippy::todo
)]

pub mod budget;
pub mod command;
pub mod decoder;
pub mod frame;
pub mod size;
pub mod telemetry;
pub mod validate;

/// The `heapless` crate whose `Vec` the messages hold, so users build
/// messages without depending on it themselves (and on the same version).
pub use heapless;

pub use budget::{LinkLoad, MAX_ENCODED_LEN, MAX_FRAME_LEN, MAX_PAYLOAD_LEN};
pub use command::{
    Command, EstimatorKind, EstimatorSettings, Excitation, Limits, LineRemoval, OutputKind,
    RejectReason, TelemetryRates, UnknownEstimator, UnknownOutput, Waveform, WaveformKind,
};
pub use decoder::{Decoder, Feed, LinkCounters};
pub use frame::{
    encode, encode_raw, parse_command_frame, parse_frame, DecodeError, EncodeError, Encoder,
    Header, Payload,
};
pub use telemetry::{
    Ack, AckResult, AdcCheck, DeviceCounters, DrdyCheck, Estimate, FirmwareVersion, LoopbackCheck,
    ModeEstimate, NoiseCheck, RawSamples, SelfTestChecks, SelfTestReport, SelfTestState, Status,
    StatusFlags, UySample,
};

/// First two header bytes: 0xBE57 ("BEST"), sent little-endian (`57 BE`).
pub const MAGIC: u16 = 0xBE57;
/// The protocol version this build speaks. Any change to a message's
/// layout or meaning increments it; a receiver meeting another version
/// reports [`DecodeError::VersionMismatch`] and must not interpret the frame.
pub const VERSION: u8 = 3;
/// The frame delimiter (COBS removes every 0x00 from the frame body).
pub const DELIMITER: u8 = 0x00;
/// Header bytes: magic (2), version (1), kind (1), sequence number (4).
pub const HEADER_LEN: usize = 8;
/// Trailing CRC-32 bytes.
pub const CRC_LEN: usize = 4;
/// The most modes a message can carry. The estimator's model must fit
/// (the core checks its own mode limit against this one at compile time).
pub const MAX_MODES: usize = 3;
/// The most Θ entries: 2D − 1 with D = 2·[`MAX_MODES`] (eq. 29).
pub const MAX_THETA: usize = 4 * MAX_MODES - 1;
/// The most (u, y) pairs in one [`RawSamples`] block.
pub const MAX_RAW_SAMPLES: usize = 64;

/// The CRC on every frame: CRC-32/ISO-HDLC (poly 0x04C11DB7, init and xorout
/// 0xFFFFFFFF, reflected in and out; check value 0xCBF43926).
pub const CRC: crc::Crc<u32> = crc::Crc::<u32>::new(&crc::CRC_32_ISO_HDLC);

/// The message kind: header byte 3. Device → host kinds have bit 7 clear,
/// host → device kinds have it set.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[repr(u8)]
pub enum Kind {
    /// [`Estimate`], device → host.
    Estimate = 0x01,
    /// [`RawSamples`], device → host.
    RawSamples = 0x02,
    /// [`Status`], device → host.
    Status = 0x03,
    /// [`Ack`], device → host.
    Ack = 0x04,
    /// [`SelfTestReport`], device → host.
    SelfTestReport = 0x05,
    /// [`Command`], host → device.
    Command = 0x80,
}

impl Kind {
    /// The kind with this header byte, if any.
    pub const fn from_u8(byte: u8) -> Option<Self> {
        match byte {
            0x01 => Some(Self::Estimate),
            0x02 => Some(Self::RawSamples),
            0x03 => Some(Self::Status),
            0x04 => Some(Self::Ack),
            0x05 => Some(Self::SelfTestReport),
            0x80 => Some(Self::Command),
            _ => None,
        }
    }
}

/// Any message of the protocol. On the wire the variant is the header's
/// [`Kind`] byte, and the payload is the variant's content.
///
/// Its size is that of the largest variant, a raw-sample block (~540
/// bytes): without an allocator the decoder returns messages by value.
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[allow(clippy::large_enum_variant)]
pub enum Message {
    /// Device → host: the current estimate.
    Estimate(Estimate),
    /// Device → host: a block of raw (u, y) samples.
    RawSamples(RawSamples),
    /// Device → host: counters and current settings.
    Status(Status),
    /// Device → host: the answer to a command.
    Ack(Ack),
    /// Device → host: the result of a self-test.
    SelfTestReport(SelfTestReport),
    /// Host → device: a command.
    Command(Command),
}

impl Message {
    /// The header kind of this message.
    pub const fn kind(&self) -> Kind {
        match self {
            Self::Estimate(_) => Kind::Estimate,
            Self::RawSamples(_) => Kind::RawSamples,
            Self::Status(_) => Kind::Status,
            Self::Ack(_) => Kind::Ack,
            Self::SelfTestReport(_) => Kind::SelfTestReport,
            Self::Command(_) => Kind::Command,
        }
    }
}

macro_rules! message_from {
    ($($variant:ident),*) => {$(
        impl From<$variant> for Message {
            fn from(m: $variant) -> Self {
                Self::$variant(m)
            }
        }
    )*};
}
message_from!(Estimate, RawSamples, Status, Ack, SelfTestReport, Command);

/// A decoded frame: the sender's sequence number and the message.
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Frame {
    /// The sender's sequence number for this direction.
    pub seq: u32,
    /// The message.
    pub message: Message,
}
