//! One frame ↔ bytes: the encoder (message → delimited COBS frame in the
//! caller's buffer, in one pass, without a scratch buffer) and the frame
//! parser (unstuffed bytes → checked [`Frame`]).
//!
//! The encoder streams the header, the postcard payload and the CRC through
//! a COBS encoder straight into the output, updating the CRC on the way, so
//! its only memory is the caller's buffer.

use core::fmt;

use cobs::CobsEncoder;
use serde::Serialize;

use super::budget::MAX_PAYLOAD_LEN;
use super::{
    Ack, Command, Estimate, Frame, Kind, Message, RawSamples, SelfTestReport, Status, CRC, CRC_LEN,
    DELIMITER, HEADER_LEN, MAGIC, VERSION,
};

/// The fixed frame header (8 bytes, little-endian).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Header {
    /// Bytes 0–1: [`MAGIC`].
    pub magic: u16,
    /// Byte 2: protocol version.
    pub version: u8,
    /// Byte 3: message kind ([`Kind`] as `u8`).
    pub kind: u8,
    /// Bytes 4–7: the sender's sequence number in this direction.
    pub seq: u32,
}

impl Header {
    /// This protocol's header for a message of `kind`.
    pub const fn new(kind: Kind, seq: u32) -> Self {
        Self {
            magic: MAGIC,
            version: VERSION,
            kind: kind as u8,
            seq,
        }
    }

    /// The 8 header bytes.
    pub const fn to_bytes(&self) -> [u8; HEADER_LEN] {
        let m = self.magic.to_le_bytes();
        let s = self.seq.to_le_bytes();
        [m[0], m[1], self.version, self.kind, s[0], s[1], s[2], s[3]]
    }

    /// Read a header from the first 8 bytes.
    pub const fn from_bytes(b: &[u8; HEADER_LEN]) -> Self {
        Self {
            magic: u16::from_le_bytes([b[0], b[1]]),
            version: b[2],
            kind: b[3],
            seq: u32::from_le_bytes([b[4], b[5], b[6], b[7]]),
        }
    }
}

/// Why a message could not be encoded.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum EncodeError {
    /// The output buffer is too small for the frame
    /// ([`MAX_ENCODED_LEN`](super::MAX_ENCODED_LEN) always suffices).
    BufferTooSmall,
    /// The message breaks a structural rule that receivers check (an
    /// [`Estimate`] whose Θ and mode counts disagree, a [`RawSamples`]
    /// with decimation 0, a [`Status`] with a mode count outside 1..=3).
    Malformed,
    /// A raw payload longer than [`MAX_PAYLOAD_LEN`].
    TooLarge,
}

impl fmt::Display for EncodeError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Self::BufferTooSmall => "output buffer too small for the frame",
            Self::Malformed => "message breaks a structural rule of the protocol",
            Self::TooLarge => "payload longer than the protocol's maximum",
        })
    }
}

impl core::error::Error for EncodeError {}

/// Why a frame was not delivered.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum DecodeError {
    /// More bytes than the decoder's buffer before a delimiter.
    Oversize,
    /// Not valid COBS.
    Cobs,
    /// Shorter than a header and a CRC.
    TooShort,
    /// The CRC does not match: the frame was corrupted.
    Crc,
    /// CRC good but the magic number is wrong: not this protocol.
    BadMagic(u16),
    /// CRC and magic good, but another protocol version. The receiver must
    /// not interpret the frame; a host should say so and stop.
    VersionMismatch {
        /// The version in the frame.
        got: u8,
        /// The version this build speaks ([`VERSION`]).
        expected: u8,
    },
    /// CRC, magic and version good, but an unknown kind byte.
    UnknownKind(u8),
    /// The payload does not decode as its kind's message (bad varint,
    /// unknown enum tag, too long a vector, trailing bytes, a varint not in
    /// its shortest form, or a broken structural rule).
    Payload,
    /// An intact frame with the same sequence number as the frame
    /// delivered before it (the sender numbers every frame once, so it is a
    /// copy made on the way): dropped, not delivered again. Only the
    /// stream decoder ([`Decoder::push`](super::Decoder::push)) reports it.
    Duplicate(u32),
}

impl fmt::Display for DecodeError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Oversize => f.write_str("frame longer than the receive buffer"),
            Self::Cobs => f.write_str("invalid COBS encoding"),
            Self::TooShort => f.write_str("frame shorter than header and CRC"),
            Self::Crc => f.write_str("CRC mismatch (corrupted frame)"),
            Self::BadMagic(m) => write!(f, "bad magic number {m:#06x}"),
            Self::VersionMismatch { got, expected } => write!(
                f,
                "protocol version mismatch: the peer speaks version {got}, this build {expected}"
            ),
            Self::UnknownKind(k) => write!(f, "unknown message kind {k:#04x}"),
            Self::Payload => f.write_str("payload does not decode"),
            Self::Duplicate(seq) => write!(
                f,
                "duplicate frame (seq {seq} again, same as the previous frame): dropped"
            ),
        }
    }
}

impl core::error::Error for DecodeError {}

mod sealed {
    pub trait Sealed {}
}

/// A message that can be sent as a frame: [`Message`] or any one message
/// struct (so the firmware can encode an [`Estimate`] without wrapping it).
pub trait Payload: Serialize + sealed::Sealed {
    /// The header kind.
    fn kind(&self) -> Kind;
    /// The structural rules receivers check (see [`EncodeError::Malformed`]).
    fn is_well_formed(&self) -> bool {
        true
    }
}

macro_rules! payload {
    ($($ty:ident),*) => {$(
        impl sealed::Sealed for $ty {}
        impl Payload for $ty {
            fn kind(&self) -> Kind {
                Kind::$ty
            }
            fn is_well_formed(&self) -> bool {
                well_formed::$ty(self)
            }
        }
    )*};
}
payload!(Estimate, RawSamples, Status, Ack, SelfTestReport, Command);

/// Structural rules per message, shared by the encoder and the parser.
#[allow(non_snake_case)]
mod well_formed {
    use super::super::{Ack, Command, Estimate, RawSamples, SelfTestReport, Status, MAX_MODES};

    pub fn Estimate(m: &Estimate) -> bool {
        m.is_consistent()
    }
    pub fn RawSamples(m: &RawSamples) -> bool {
        m.decimation >= 1
    }
    pub fn Status(m: &Status) -> bool {
        (1..=MAX_MODES).contains(&usize::from(m.modes))
    }
    pub fn Ack(_: &Ack) -> bool {
        true
    }
    pub fn SelfTestReport(_: &SelfTestReport) -> bool {
        true
    }
    pub fn Command(_: &Command) -> bool {
        true
    }
}

impl sealed::Sealed for Message {}
impl Payload for Message {
    fn kind(&self) -> Kind {
        Message::kind(self)
    }
    fn is_well_formed(&self) -> bool {
        match self {
            Self::Estimate(m) => m.is_well_formed(),
            Self::RawSamples(m) => m.is_well_formed(),
            Self::Status(m) => m.is_well_formed(),
            Self::Ack(m) => m.is_well_formed(),
            Self::SelfTestReport(m) => m.is_well_formed(),
            Self::Command(m) => m.is_well_formed(),
        }
    }
}

/// A [`Message`] serializes as its content alone: on the wire the variant
/// travels as the header's kind byte.
impl Serialize for Message {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        match self {
            Self::Estimate(m) => m.serialize(s),
            Self::RawSamples(m) => m.serialize(s),
            Self::Status(m) => m.serialize(s),
            Self::Ack(m) => m.serialize(s),
            Self::SelfTestReport(m) => m.serialize(s),
            Self::Command(m) => m.serialize(s),
        }
    }
}

/// A postcard flavor that feeds every byte to the CRC and to a COBS encoder
/// writing into the output buffer.
struct FrameWriter<'a> {
    cobs: CobsEncoder<'a>,
    digest: crc::Digest<'static, u32>,
}

impl<'a> FrameWriter<'a> {
    fn new(out: &'a mut [u8]) -> Self {
        Self {
            cobs: CobsEncoder::new(out),
            digest: CRC.digest(),
        }
    }

    fn write(&mut self, data: &[u8]) -> Result<(), EncodeError> {
        self.digest.update(data);
        self.cobs
            .push(data)
            .map_err(|_| EncodeError::BufferTooSmall)
    }

    /// Append the CRC and close the COBS encoding: the encoded length,
    /// delimiter not included.
    fn finish(mut self) -> Result<usize, EncodeError> {
        let crc = self.digest.finalize();
        self.cobs
            .push(&crc.to_le_bytes())
            .map_err(|_| EncodeError::BufferTooSmall)?;
        Ok(self.cobs.finalize())
    }
}

impl postcard::ser_flavors::Flavor for FrameWriter<'_> {
    type Output = Self;

    fn try_push(&mut self, data: u8) -> postcard::Result<()> {
        self.try_extend(&[data])
    }

    fn try_extend(&mut self, data: &[u8]) -> postcard::Result<()> {
        self.write(data)
            .map_err(|_| postcard::Error::SerializeBufferFull)
    }

    fn finalize(self) -> postcard::Result<Self> {
        Ok(self)
    }
}

/// Encode `msg` with sequence number `seq` as one complete frame, delimiter
/// included, at the start of `out`; returns the number of bytes written.
/// `out` of [`MAX_ENCODED_LEN`](super::MAX_ENCODED_LEN) bytes always
/// suffices. Never allocates or panics.
pub fn encode<M: Payload + ?Sized>(
    msg: &M,
    seq: u32,
    out: &mut [u8],
) -> Result<usize, EncodeError> {
    if !msg.is_well_formed() {
        return Err(EncodeError::Malformed);
    }
    let n = {
        let mut w = FrameWriter::new(out);
        w.write(&Header::new(msg.kind(), seq).to_bytes())?;
        let w = postcard::serialize_with_flavor(msg, w).map_err(|_| EncodeError::BufferTooSmall)?;
        w.finish()?
    };
    terminate(out, n)
}

/// Encode a frame with an arbitrary header and payload bytes (for tests,
/// tools and other protocol versions; [`encode`] is the normal path).
pub fn encode_raw(header: &Header, payload: &[u8], out: &mut [u8]) -> Result<usize, EncodeError> {
    if payload.len() > MAX_PAYLOAD_LEN {
        return Err(EncodeError::TooLarge);
    }
    let n = {
        let mut w = FrameWriter::new(out);
        w.write(&header.to_bytes())?;
        w.write(payload)?;
        w.finish()?
    };
    terminate(out, n)
}

fn terminate(out: &mut [u8], n: usize) -> Result<usize, EncodeError> {
    *out.get_mut(n).ok_or(EncodeError::BufferTooSmall)? = DELIMITER;
    Ok(n + 1)
}

/// Keeps the sequence number of one direction: each successful
/// [`Encoder::encode`] uses the next number (wrapping at 2³²).
#[derive(Debug, Clone, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Encoder {
    next_seq: u32,
}

impl Encoder {
    /// Start at sequence number 0.
    pub const fn new() -> Self {
        Self { next_seq: 0 }
    }

    /// Start at `seq` (tests, or resuming a stream).
    pub const fn starting_at(seq: u32) -> Self {
        Self { next_seq: seq }
    }

    /// The number the next frame will carry.
    pub const fn next_seq(&self) -> u32 {
        self.next_seq
    }

    /// Encode `msg` into `out` (see [`encode`]); the sequence number
    /// advances only if the frame was written.
    pub fn encode<M: Payload + ?Sized>(
        &mut self,
        msg: &M,
        out: &mut [u8],
    ) -> Result<usize, EncodeError> {
        let n = encode(msg, self.next_seq, out)?;
        self.next_seq = self.next_seq.wrapping_add(1);
        Ok(n)
    }
}

/// Check one frame given its COBS-decoded bytes (header, payload, CRC; no
/// delimiter): length, CRC, magic, version, kind, in this order. Returns
/// the sequence number, the kind and the payload bytes.
fn check_frame(raw: &[u8]) -> Result<(u32, Kind, &[u8]), DecodeError> {
    let body_len = raw
        .len()
        .checked_sub(CRC_LEN)
        .filter(|&n| n >= HEADER_LEN)
        .ok_or(DecodeError::TooShort)?;
    let (body, crc) = raw
        .split_at_checked(body_len)
        .ok_or(DecodeError::TooShort)?;
    let (header, payload) = body
        .split_first_chunk::<HEADER_LEN>()
        .ok_or(DecodeError::TooShort)?;
    let crc: [u8; CRC_LEN] = crc.try_into().map_err(|_| DecodeError::TooShort)?;
    if CRC.checksum(body) != u32::from_le_bytes(crc) {
        return Err(DecodeError::Crc);
    }
    let h = Header::from_bytes(header);
    if h.magic != MAGIC {
        return Err(DecodeError::BadMagic(h.magic));
    }
    if h.version != VERSION {
        return Err(DecodeError::VersionMismatch {
            got: h.version,
            expected: VERSION,
        });
    }
    let kind = Kind::from_u8(h.kind).ok_or(DecodeError::UnknownKind(h.kind))?;
    Ok((h.seq, kind, payload))
}

/// Check and decode one frame given its COBS-decoded bytes (header,
/// payload, CRC; no delimiter). The checks run in this order: length, CRC,
/// magic, version, kind, payload; the first that fails is the error.
pub fn parse_frame(raw: &[u8]) -> Result<Frame, DecodeError> {
    let (seq, kind, payload) = check_frame(raw)?;
    let message = match kind {
        Kind::Estimate => Message::Estimate(payload_as(payload)?),
        Kind::RawSamples => Message::RawSamples(payload_as(payload)?),
        Kind::Status => Message::Status(payload_as(payload)?),
        Kind::Ack => Message::Ack(payload_as(payload)?),
        Kind::SelfTestReport => Message::SelfTestReport(payload_as(payload)?),
        Kind::Command => Message::Command(payload_as(payload)?),
    };
    Ok(Frame { seq, message })
}

/// [`parse_frame`] for a receiver of commands (the device): the same
/// checks, but a kind other than [`Kind::Command`] is
/// [`DecodeError::UnknownKind`], and only the command's payload decoder
/// is used. Returns the sequence number and the command.
pub fn parse_command_frame(raw: &[u8]) -> Result<(u32, Command), DecodeError> {
    match check_frame(raw)? {
        (seq, Kind::Command, payload) => Ok((seq, payload_as(payload)?)),
        (_, kind, _) => Err(DecodeError::UnknownKind(kind as u8)),
    }
}

/// Deserialize a whole payload as `T`: every byte used, rules kept, and
/// the bytes exactly the encoder's (so a varint in a longer form than the
/// shortest, which postcard itself would accept, is refused).
fn payload_as<T: Payload + serde::de::DeserializeOwned>(payload: &[u8]) -> Result<T, DecodeError> {
    match postcard::take_from_bytes::<T>(payload) {
        Ok((m, [])) if m.is_well_formed() && is_canonical(&m, payload) => Ok(m),
        _ => Err(DecodeError::Payload),
    }
}

/// `payload` is the encoding of `m` byte for byte. Every value has one
/// encoding in this protocol (bool, Option tags and f32 bit patterns are
/// exact), except that postcard's decoder accepts non-shortest varints;
/// re-encoding without a buffer, against the received bytes, finds those.
fn is_canonical<T: Serialize>(m: &T, payload: &[u8]) -> bool {
    let same = postcard::serialize_with_flavor(m, Compare { rest: payload });
    matches!(same, Ok(rest) if rest.is_empty())
}

/// A postcard flavor that checks each byte against the expected ones.
struct Compare<'a> {
    rest: &'a [u8],
}

impl<'a> postcard::ser_flavors::Flavor for Compare<'a> {
    type Output = &'a [u8];

    fn try_push(&mut self, data: u8) -> postcard::Result<()> {
        match self.rest.split_first() {
            Some((&b, rest)) if b == data => {
                self.rest = rest;
                Ok(())
            }
            _ => Err(postcard::Error::SerializeBufferFull),
        }
    }

    fn finalize(self) -> postcard::Result<Self::Output> {
        Ok(self.rest)
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used, clippy::indexing_slicing)]
mod tests {
    use super::super::budget::{
        encoded_len_max, estimate_payload_max, ACK_PAYLOAD_MAX, COMMAND_PAYLOAD_MAX,
        RAW_PAYLOAD_MAX, SELF_TEST_PAYLOAD_MAX, STATUS_PAYLOAD_MAX,
    };
    use super::super::{
        AckResult, AdcCheck, DeviceCounters, DrdyCheck, EstimatorKind, EstimatorSettings,
        Excitation, FirmwareVersion, LoopbackCheck, ModeEstimate, NoiseCheck, RejectReason,
        SelfTestChecks, SelfTestState, StatusFlags, TelemetryRates, UySample, Waveform,
        MAX_ENCODED_LEN, MAX_RAW_SAMPLES,
    };
    use super::*;

    /// Encode, check the wire invariants, COBS-decode, parse.
    fn round_trip(msg: &Message, seq: u32) -> (Frame, usize, usize) {
        let mut out = [0u8; MAX_ENCODED_LEN];
        let n = encode(msg, seq, &mut out).unwrap();
        assert_eq!(out[n - 1], 0, "ends with the delimiter");
        assert!(!out[..n - 1].contains(&0), "no 0x00 inside a frame");
        let raw_len = cobs::decode_in_place(&mut out[..n - 1]).unwrap();
        (parse_frame(&out[..raw_len]).unwrap(), raw_len, n)
    }

    /// Every field at its longest encoding.
    fn worst_estimate(modes: usize) -> Estimate {
        Estimate {
            sample_index: u64::MAX,
            estimator: EstimatorKind::Robust,
            flags: StatusFlags(u16::MAX),
            modes: (0..modes).map(|_| ModeEstimate::default()).collect(),
            lambda_rad_s: 100.0,
            theta: (0..4 * modes - 1).map(|i| i as f32).collect(),
            excitation_level: Some(1.0),
        }
    }

    fn worst_raw() -> RawSamples {
        RawSamples {
            first_sample_index: u64::MAX,
            decimation: u16::MAX,
            samples: (0..MAX_RAW_SAMPLES)
                .map(|i| UySample {
                    u_v: 1.0 + i as f32,
                    y: -1.0,
                })
                .collect(),
        }
    }

    fn worst_status() -> Status {
        Status {
            uptime_samples: u64::MAX,
            sample_rate_hz: 1e4,
            firmware: FirmwareVersion::default(),
            modes: 3,
            counters: DeviceCounters {
                overruns: u32::MAX,
                adc_crc_errors: u32::MAX,
                adc_status_errors: u32::MAX,
                adc_stuck: u32::MAX,
                adc_saturations: u32::MAX,
                dac_saturations: u32::MAX,
                rejected_samples: u32::MAX,
                telemetry_dropped: u32::MAX,
                commands_accepted: u32::MAX,
                commands_rejected: u32::MAX,
                rx_frame_errors: u32::MAX,
            },
            adaptation_frozen: true,
            excitation: Excitation {
                waveform: Waveform::Chirp {
                    f_start_hz: 1.0,
                    f_end_hz: 2.0,
                    sweep_s: 3.0,
                },
                ..Excitation::default()
            },
            estimator: EstimatorSettings {
                lambda_rad_s: Some(100.0),
                ..EstimatorSettings::default()
            },
            telemetry: TelemetryRates {
                raw_decimation: u16::MAX,
                ..TelemetryRates::default()
            },
            lambda_automatic: true,
            self_test: SelfTestState::Done {
                failed: SelfTestChecks(u16::MAX),
                not_measured: SelfTestChecks(u16::MAX),
            },
        }
    }

    /// Every varint at its longest, the longest waveform.
    fn worst_report() -> SelfTestReport {
        SelfTestReport {
            first_sample: u64::MAX,
            last_sample: u64::MAX,
            at_boot: true,
            failed: SelfTestChecks(u16::MAX),
            not_measured: SelfTestChecks(u16::MAX),
            adc: AdcCheck {
                id: u16::MAX,
                registers: [u16::MAX; 3],
                expected: [u16::MAX; 3],
            },
            drdy: DrdyCheck {
                rate_hz: 1e4,
                expected_hz: 1e4,
                tolerance: 1e-4,
                conversions: u32::MAX,
                ticks: u32::MAX,
            },
            loopback: LoopbackCheck::default(),
            noise: NoiseCheck {
                noise_sd: 2e-5,
                floor_sd: 1e-8,
                signal_rms: 1e-3,
                snr_db: 60.0,
                snr_min_db: 60.0,
                excitation: worst_status().excitation,
            },
        }
    }

    #[test]
    fn crc_is_crc32_iso_hdlc() {
        assert_eq!(CRC.checksum(b"123456789"), 0xCBF4_3926);
    }

    #[test]
    fn header_layout() {
        let h = Header::new(Kind::Status, 0x0403_0201);
        assert_eq!(
            h.to_bytes(),
            [0x57, 0xBE, VERSION, 0x03, 0x01, 0x02, 0x03, 0x04]
        );
        assert_eq!(Header::from_bytes(&h.to_bytes()), h);
        for k in [
            Kind::Estimate,
            Kind::RawSamples,
            Kind::Status,
            Kind::Ack,
            Kind::SelfTestReport,
            Kind::Command,
        ] {
            assert_eq!(Kind::from_u8(k as u8), Some(k));
        }
        assert_eq!(Kind::from_u8(0), None);
    }

    #[test]
    fn worst_case_sizes_are_reached_exactly() {
        let cases: [(Message, usize); 8] = [
            (worst_estimate(1).into(), estimate_payload_max(1)),
            (worst_estimate(2).into(), estimate_payload_max(2)),
            (worst_estimate(3).into(), estimate_payload_max(3)),
            (worst_raw().into(), RAW_PAYLOAD_MAX),
            (worst_status().into(), STATUS_PAYLOAD_MAX),
            (worst_report().into(), SELF_TEST_PAYLOAD_MAX),
            (
                Ack {
                    command_seq: u32::MAX,
                    result: AckResult::Rejected(RejectReason::LinkBudget),
                }
                .into(),
                ACK_PAYLOAD_MAX,
            ),
            (
                Command::SetEstimator(worst_status().estimator).into(),
                COMMAND_PAYLOAD_MAX,
            ),
        ];
        for (msg, payload_max) in cases {
            let (frame, raw_len, wire_len) = round_trip(&msg, 7);
            assert_eq!(frame.message, msg);
            assert_eq!(
                raw_len,
                HEADER_LEN + payload_max + CRC_LEN,
                "{:?}",
                msg.kind()
            );
            assert!(wire_len <= encoded_len_max(payload_max));
        }
    }

    #[test]
    fn small_buffers_are_refused_not_overrun() {
        let msg: Message = worst_raw().into();
        let mut out = [0u8; MAX_ENCODED_LEN];
        let n = encode(&msg, 0, &mut out).unwrap();
        for len in 0..n {
            let mut small = [0u8; MAX_ENCODED_LEN];
            assert_eq!(
                encode(&msg, 0, &mut small[..len]),
                Err(EncodeError::BufferTooSmall),
                "len {len}"
            );
        }
        let mut exact = [0u8; MAX_ENCODED_LEN];
        assert_eq!(encode(&msg, 0, &mut exact[..n]), Ok(n));
        assert_eq!(exact[..n], out[..n]);
    }

    #[test]
    fn malformed_messages_are_refused() {
        let mut e = worst_estimate(2);
        e.modes.pop();
        let mut out = [0u8; MAX_ENCODED_LEN];
        assert_eq!(encode(&e, 0, &mut out), Err(EncodeError::Malformed));
        let mut r = worst_raw();
        r.decimation = 0;
        assert_eq!(encode(&r, 0, &mut out), Err(EncodeError::Malformed));
        let mut s = worst_status();
        s.modes = 0;
        assert_eq!(encode(&s, 0, &mut out), Err(EncodeError::Malformed));
        let long = [1u8; MAX_PAYLOAD_LEN + 1];
        let h = Header::new(Kind::Ack, 0);
        assert_eq!(encode_raw(&h, &long, &mut out), Err(EncodeError::TooLarge));
    }

    /// COBS's corner cases are runs of 254 non-zero bytes: every payload
    /// length of non-zero bytes, up to the largest, survives the trip.
    #[test]
    fn cobs_runs_of_every_length() {
        let payload = [0xA5u8; MAX_PAYLOAD_LEN];
        for len in 0..=MAX_PAYLOAD_LEN {
            let h = Header::new(Kind::Ack, 0x0101_0101);
            let mut out = [0u8; MAX_ENCODED_LEN];
            let n = encode_raw(&h, &payload[..len], &mut out).unwrap();
            assert!(n <= encoded_len_max(len), "len {len}");
            assert!(!out[..n - 1].contains(&0));
            let m = cobs::decode_in_place(&mut out[..n - 1]).unwrap();
            assert_eq!(m, HEADER_LEN + len + CRC_LEN);
            assert_eq!(out[..HEADER_LEN], h.to_bytes());
            assert_eq!(out[HEADER_LEN..HEADER_LEN + len], payload[..len]);
            assert_eq!(CRC.checksum(&out[..m]), 0x2144_DF1C, "CRC-32 residue");
        }
    }

    #[test]
    fn parse_errors_in_check_order() {
        let h = Header::new(Kind::Ack, 9);
        let frame = |h: &Header, payload: &[u8]| {
            let mut out = [0u8; MAX_ENCODED_LEN];
            let n = encode_raw(h, payload, &mut out).unwrap();
            let m = cobs::decode_in_place(&mut out[..n - 1]).unwrap();
            out[..m].to_vec()
        };
        let good = frame(&h, &[9, 0]);
        assert_eq!(
            parse_frame(&good).unwrap().message,
            Message::Ack(Ack {
                command_seq: 9,
                result: AckResult::Accepted
            })
        );
        assert_eq!(parse_frame(&good[..11]), Err(DecodeError::TooShort));
        assert_eq!(parse_frame(&[]), Err(DecodeError::TooShort));
        let mut bad = good.clone();
        bad[9] ^= 1;
        assert_eq!(parse_frame(&bad), Err(DecodeError::Crc));
        let other = Header { magic: 0x1234, ..h };
        assert_eq!(
            parse_frame(&frame(&other, &[9, 0])),
            Err(DecodeError::BadMagic(0x1234))
        );
        for v in [VERSION - 1, VERSION + 1] {
            let other = Header { version: v, ..h };
            assert_eq!(
                parse_frame(&frame(&other, &[])),
                Err(DecodeError::VersionMismatch {
                    got: v,
                    expected: VERSION
                })
            );
        }
        let k = Header { kind: 0x7F, ..h };
        assert_eq!(
            parse_frame(&frame(&k, &[])),
            Err(DecodeError::UnknownKind(0x7F))
        );
        // Trailing byte, truncated payload, undefined result code (17 and
        // up), the command seq 9 as a non-shortest varint (`89 00`, `89 80
        // 00`): malformed.
        for p in [
            &[9u8, 0, 0][..],
            &[9],
            &[9, 17],
            &[9, 0xFF],
            &[0x89, 0x00, 0],
            &[0x89, 0x80, 0x00, 0],
        ] {
            assert_eq!(
                parse_frame(&frame(&h, p)),
                Err(DecodeError::Payload),
                "{p:?}"
            );
        }
        // The same in a command: Freeze's variant index 4 as `84 00`;
        // an undefined variant index (9), waveform index (5) or output
        // kind (3); an Option tag or bool byte other than 00/01.
        let c = Header::new(Kind::Command, 1);
        assert_eq!(
            parse_frame(&frame(&c, &[4])).unwrap().message,
            Message::Command(Command::Freeze)
        );
        let mut settings = [0u8; 24];
        let n = postcard::to_slice(
            &Command::SetEstimator(EstimatorSettings::default()),
            &mut settings,
        )
        .unwrap()
        .len();
        // λ's Option tag, then the output kind's tag (0..=2) last.
        let mut bad_option = settings[..n].to_vec();
        bad_option[n - 2] = 2;
        let mut bad_output = settings[..n].to_vec();
        bad_output[n - 1] = 3;
        let mut bad_bool = worst_status_payload();
        let frozen_at = bad_bool.len() - worst_status_tail() - 1;
        bad_bool[frozen_at] = 2;
        for p in [
            vec![0x84, 0x00],
            vec![9],
            vec![0, 5, 0, 0, 0, 0, 0, 0, 0, 0],
            bad_option,
            bad_output,
        ] {
            assert_eq!(
                parse_frame(&frame(&c, &p)),
                Err(DecodeError::Payload),
                "{p:?}"
            );
        }
        assert_eq!(
            parse_frame(&frame(&c, &[7])).unwrap().message,
            Message::Command(Command::SelfTest)
        );
        let st = Header::new(Kind::Status, 1);
        assert!(parse_frame(&frame(&st, &worst_status_payload())).is_ok());
        assert_eq!(
            parse_frame(&frame(&st, &bad_bool)),
            Err(DecodeError::Payload)
        );
    }

    /// PROTOCOL.md §3.1–§3.2, rule by rule: a varint is valid only in its
    /// shortest form, within its type's length (u16 3, u32 5, u64 10
    /// bytes) and width; a sequence length is a varint too, and above the
    /// sequence's maximum it is invalid.
    #[test]
    fn varint_and_length_rules() {
        let frame = |kind: Kind, payload: &[u8]| {
            let mut out = [0u8; MAX_ENCODED_LEN];
            let n = encode_raw(&Header::new(kind, 1), payload, &mut out).unwrap();
            let m = cobs::decode_in_place(&mut out[..n - 1]).unwrap();
            parse_frame(&out[..m])
        };
        // An Estimate of one mode's model (Θ̂ of 3 entries), no modes:
        // sample_index (u64), estimator 0, flags (u16), modes' length,
        // λ = 100, Θ̂'s length and entries, no level.
        let estimate = |index: &[u8], flags: &[u8], modes: &[u8], theta: &[u8], n: usize| {
            let mut p = index.to_vec();
            p.push(0);
            p.extend(flags);
            p.extend(modes);
            p.extend(100f32.to_le_bytes());
            p.extend(theta);
            for _ in 0..n {
                p.extend(1f32.to_le_bytes());
            }
            p.push(0);
            frame(Kind::Estimate, &p)
        };
        let index = |r: Result<Frame, DecodeError>| match r {
            Ok(Frame {
                message: Message::Estimate(e),
                ..
            }) => Ok((e.sample_index, e.flags.0, e.theta.len())),
            // Kind 01 decodes only as an Estimate; any other answer fails.
            Ok(_) => Err(DecodeError::UnknownKind(0)),
            Err(e) => Err(e),
        };
        let ok = |i: &[u8], f: &[u8], m: &[u8], t: &[u8], n| index(estimate(i, f, m, t, n));
        assert_eq!(ok(&[0], &[0], &[0], &[3], 3), Ok((0, 0, 3)));
        // u64: the largest value in 10 bytes; more bits, more bytes, or a
        // non-shortest form are invalid.
        let max64 = [0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0x01];
        assert_eq!(ok(&max64, &[0], &[0], &[3], 3), Ok((u64::MAX, 0, 3)));
        let mut wide = max64;
        wide[9] = 0x02;
        let mut long = max64.to_vec();
        long[9] = 0x81;
        long.push(0x00);
        for i in [&wide[..], &long, &[0x80, 0x00], &[0x89, 0x80, 0x00]] {
            assert_eq!(
                ok(i, &[0], &[0], &[3], 3),
                Err(DecodeError::Payload),
                "{i:x?}"
            );
        }
        // u16 (flags): 3 bytes at most, the last ≤ 03.
        assert_eq!(
            ok(&[0], &[0xFF, 0xFF, 0x03], &[0], &[3], 3),
            Ok((0, 0xFFFF, 3))
        );
        for f in [
            &[0xFF, 0xFF, 0x04][..],
            &[0x80, 0x80, 0x80, 0x00],
            &[0x90, 0x00],
        ] {
            assert_eq!(
                ok(&[0], f, &[0], &[3], 3),
                Err(DecodeError::Payload),
                "{f:x?}"
            );
        }
        // Lengths: a non-shortest form, or above the maximum (Θ̂ 11, modes
        // 3), is invalid.
        assert_eq!(ok(&[0], &[0], &[0], &[11], 11), Ok((0, 0, 11)));
        for (m, t, n) in [
            (&[0u8][..], &[0x83, 0x00][..], 3),
            (&[0], &[12], 12),
            (&[0x80, 0x00], &[3], 3),
            (&[4], &[3], 3),
        ] {
            assert_eq!(
                ok(&[0], &[0], m, t, n),
                Err(DecodeError::Payload),
                "{m:x?} {t:x?}"
            );
        }
        // u32 (an Ack's command_seq): 5 bytes at most, the last ≤ 0F.
        let ack = |seq: &[u8]| {
            let mut p = seq.to_vec();
            p.push(0);
            frame(Kind::Ack, &p).map(|f| f.message)
        };
        assert_eq!(
            ack(&[0xFF, 0xFF, 0xFF, 0xFF, 0x0F]),
            Ok(Message::Ack(Ack {
                command_seq: u32::MAX,
                result: AckResult::Accepted
            }))
        );
        for seq in [
            &[0xFF, 0xFF, 0xFF, 0xFF, 0x10][..],
            &[0x80, 0x80, 0x80, 0x80, 0x80, 0x00],
            &[0x81, 0x00],
        ] {
            assert_eq!(ack(seq), Err(DecodeError::Payload), "{seq:x?}");
        }
    }

    /// The worst status's payload bytes.
    fn worst_status_payload() -> Vec<u8> {
        let mut out = [0u8; MAX_PAYLOAD_LEN];
        postcard::to_slice(&worst_status(), &mut out)
            .unwrap()
            .to_vec()
    }

    /// Bytes after `adaptation_frozen` in [`worst_status_payload`]: the
    /// excitation (chirp: tag 1 + waveform tag 1 + 3 f32, amplitude,
    /// offset), the estimator settings (kind 1, 4 f32, Some(λ) 5, output
    /// 1), the rates (f32, u16 max 3, f32), lambda_automatic (1) and the
    /// self-test state (tag 1, two u16 of 3).
    fn worst_status_tail() -> usize {
        (1 + 12 + 8) + (1 + 16 + 5 + 1) + (4 + 3 + 4) + 1 + 7
    }

    #[test]
    fn encoder_counts_only_written_frames() {
        let mut enc = Encoder::starting_at(u32::MAX);
        let mut out = [0u8; MAX_ENCODED_LEN];
        let ack = Ack {
            command_seq: 1,
            result: AckResult::Accepted,
        };
        assert!(enc.encode(&ack, &mut out[..3]).is_err());
        assert_eq!(enc.next_seq(), u32::MAX);
        let n = enc.encode(&ack, &mut out).unwrap();
        assert_eq!(enc.next_seq(), 0, "wraps");
        let m = cobs::decode_in_place(&mut out[..n - 1]).unwrap();
        assert_eq!(parse_frame(&out[..m]).unwrap().seq, u32::MAX);
    }
}
