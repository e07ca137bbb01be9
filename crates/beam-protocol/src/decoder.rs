//! The stream decoder: bytes in (from a serial port, a socket, a file),
//! frames out, with counters of everything that went wrong.
//!
//! Bytes accumulate in a fixed buffer until a 0x00 delimiter; the frame is
//! then COBS-decoded in place and checked by [`parse_frame`]. Whatever
//! happens to one frame (corruption, truncation, a lost delimiter that
//! merges two frames), the decoder starts afresh after the next 0x00, so
//! the frames after it are decoded as if nothing had happened.
//!
//! Sequence numbers are checked across frames: a forward step of d > 1
//! means d − 1 frames were lost (modulo 2³², so the wrap from 2³² − 1 to 0
//! is a normal step); a step of 0 is a duplicate (the stream decoder,
//! [`Decoder::push`], drops it; the command decoder,
//! [`Decoder::push_command`], delivers it: the device executes every
//! command, docs/PROTOCOL.md §5.4); a backward step (the sender restarted,
//! or frames were reordered) is counted as out of order, and counting
//! continues from the new number. The stream decoder delivers an intact
//! frame of the host → device kind (an echo of the host's own commands)
//! without counting it in the device's sequence: each direction has its
//! own counter.

use super::budget::MAX_ENCODED_LEN;
use super::frame::{parse_command_frame, parse_frame, DecodeError};
use super::{Command, Frame, DELIMITER};

/// What the decoder has seen. All counts since creation (or
/// [`Decoder::reset_counters`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct LinkCounters {
    /// Bytes received.
    pub bytes: u64,
    /// Bytes discarded while joining a stream (before the first delimiter).
    pub skipped_bytes: u64,
    /// Frames delivered.
    pub frames_ok: u64,
    /// Frames whose CRC failed.
    pub crc_errors: u64,
    /// Frames that were not valid COBS or were shorter than header + CRC.
    pub framing_errors: u64,
    /// Frames longer than the buffer.
    pub oversize: u64,
    /// Frames with a good CRC but a bad magic number, an unknown kind, or a
    /// payload that does not decode.
    pub malformed: u64,
    /// Frames of another protocol version (good CRC and magic).
    pub version_mismatches: u64,
    /// Frames missing from the sequence numbers (lost for any reason,
    /// including the corrupted frames counted above).
    pub lost: u64,
    /// Frames with the same sequence number as the previous one (dropped
    /// by [`Decoder::push`], delivered by [`Decoder::push_command`]).
    pub duplicates: u64,
    /// Backward steps of the sequence number.
    pub out_of_order: u64,
}

impl LinkCounters {
    /// Frames received but not delivered, of every kind.
    pub const fn errors(&self) -> u64 {
        self.crc_errors
            + self.framing_errors
            + self.oversize
            + self.malformed
            + self.version_mismatches
    }

    fn count(&mut self, e: DecodeError) {
        let c = match e {
            DecodeError::Oversize => &mut self.oversize,
            DecodeError::Cobs | DecodeError::TooShort => &mut self.framing_errors,
            DecodeError::Crc => &mut self.crc_errors,
            DecodeError::BadMagic(_) | DecodeError::UnknownKind(_) | DecodeError::Payload => {
                &mut self.malformed
            }
            DecodeError::VersionMismatch { .. } => &mut self.version_mismatches,
            DecodeError::Duplicate(_) => &mut self.duplicates,
        };
        *c = c.saturating_add(1);
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum State {
    /// Discarding bytes until the first delimiter.
    Joining,
    /// Collecting a frame.
    Collecting,
    /// The frame outgrew the buffer: discarding until the delimiter.
    Overflow,
}

/// A byte-stream decoder with an `N`-byte frame buffer (default: any frame
/// of this protocol, [`MAX_ENCODED_LEN`]). A device that only receives
/// commands can use [`MAX_COMMAND_ENCODED_LEN`](super::budget::MAX_COMMAND_ENCODED_LEN).
#[derive(Debug, Clone)]
pub struct Decoder<const N: usize = MAX_ENCODED_LEN> {
    buf: [u8; N],
    len: usize,
    state: State,
    last_seq: Option<u32>,
    counters: LinkCounters,
}

impl<const N: usize> Default for Decoder<N> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const N: usize> Decoder<N> {
    /// A decoder at a frame boundary: for a stream read from its start (a
    /// capture file, a device that has just booted).
    pub const fn new() -> Self {
        Self {
            buf: [0; N],
            len: 0,
            state: State::Collecting,
            last_seq: None,
            counters: LinkCounters {
                bytes: 0,
                skipped_bytes: 0,
                frames_ok: 0,
                crc_errors: 0,
                framing_errors: 0,
                oversize: 0,
                malformed: 0,
                version_mismatches: 0,
                lost: 0,
                duplicates: 0,
                out_of_order: 0,
            },
        }
    }

    /// A decoder joining a running stream: bytes up to the first 0x00 are
    /// the tail of a frame sent before we listened, and are skipped (counted
    /// in [`LinkCounters::skipped_bytes`], not as errors).
    pub const fn joining() -> Self {
        let mut d = Self::new();
        d.state = State::Joining;
        d
    }

    /// The counters.
    pub const fn counters(&self) -> &LinkCounters {
        &self.counters
    }

    /// Zero the counters and forget the last sequence number.
    pub fn reset_counters(&mut self) {
        self.counters = LinkCounters::default();
        self.last_seq = None;
    }

    /// The last sequence number delivered, if any.
    pub const fn last_seq(&self) -> Option<u32> {
        self.last_seq
    }

    /// Feed one byte of the device → host stream (a host's receiver).
    /// Returns a result when the byte ends a frame: the frame, or why it
    /// was dropped (already counted), a duplicate
    /// ([`DecodeError::Duplicate`]) included. Empty frames (consecutive
    /// delimiters) are ignored. A frame of the host → device kind is
    /// delivered (an echo of commands) but kept out of the sequence check.
    pub fn push(&mut self, byte: u8) -> Option<Result<Frame, DecodeError>> {
        let len = match self.collect(byte)? {
            Ok(len) => len,
            Err(e) => return Some(Err(e)),
        };
        let seq = |f: &Frame| (f.message.kind() != super::Kind::Command).then_some(f.seq);
        Some(self.finish(len, parse_frame, seq, true))
    }

    /// [`Decoder::push`] for a receiver of commands only (the device): the
    /// frame must carry a [`Command`]; any other kind, although this
    /// protocol's, is refused as [`DecodeError::UnknownKind`] (counted as
    /// malformed). Only the command's payload decoder is linked, not the
    /// four device → host ones. Returns the frame's sequence number and
    /// the command.
    pub fn push_command(&mut self, byte: u8) -> Option<Result<(u32, Command), DecodeError>> {
        let len = match self.collect(byte)? {
            Ok(len) => len,
            Err(e) => return Some(Err(e)),
        };
        Some(self.finish(len, parse_command_frame, |f| Some(f.0), false))
    }

    /// The framing state machine: `Some(Ok(len))` when `byte` ends a frame
    /// of `len` collected bytes, `Some(Err)` when it ends an oversize one
    /// (counted), `None` otherwise.
    fn collect(&mut self, byte: u8) -> Option<Result<usize, DecodeError>> {
        self.counters.bytes = self.counters.bytes.saturating_add(1);
        match (self.state, byte == DELIMITER) {
            (State::Joining, false) => {
                self.counters.skipped_bytes = self.counters.skipped_bytes.saturating_add(1);
                None
            }
            (State::Joining, true) => {
                self.state = State::Collecting;
                None
            }
            (State::Overflow, false) => None,
            (State::Overflow, true) => {
                self.state = State::Collecting;
                self.len = 0;
                Some(Err(self.fail(DecodeError::Oversize)))
            }
            (State::Collecting, false) => {
                match self.buf.get_mut(self.len) {
                    Some(slot) => {
                        *slot = byte;
                        self.len += 1;
                    }
                    None => self.state = State::Overflow,
                }
                None
            }
            (State::Collecting, true) if self.len == 0 => None,
            (State::Collecting, true) => Some(Ok(core::mem::take(&mut self.len))),
        }
    }

    /// Feed a slice: an iterator over the results it completes. Consume it
    /// to the end, or the remaining bytes are not fed.
    pub fn feed<'a>(&'a mut self, bytes: &'a [u8]) -> Feed<'a, N> {
        Feed {
            decoder: self,
            bytes: bytes.iter(),
        }
    }

    fn fail(&mut self, e: DecodeError) -> DecodeError {
        self.counters.count(e);
        e
    }

    /// Decode the `len` collected bytes with `parse`; `seq` gives the
    /// number to check (`None`: the other direction's, not checked);
    /// `drop_duplicates`: a duplicate is dropped, not delivered.
    fn finish<F>(
        &mut self,
        len: usize,
        parse: fn(&[u8]) -> Result<F, DecodeError>,
        seq: fn(&F) -> Option<u32>,
        drop_duplicates: bool,
    ) -> Result<F, DecodeError> {
        let encoded = self.buf.get_mut(..len).ok_or(DecodeError::Oversize);
        let decoded = encoded.and_then(|e| cobs::decode_in_place(e).map_err(|_| DecodeError::Cobs));
        let frame = decoded.and_then(|n| parse(self.buf.get(..n).ok_or(DecodeError::Cobs)?));
        match frame {
            Ok(f) => {
                if let Some(s) = seq(&f) {
                    if self.sequence(s) && drop_duplicates {
                        return Err(DecodeError::Duplicate(s));
                    }
                }
                self.counters.frames_ok = self.counters.frames_ok.saturating_add(1);
                Ok(f)
            }
            Err(e) => Err(self.fail(e)),
        }
    }

    /// Account for a delivered frame's sequence number; true if it is a
    /// duplicate (counted).
    fn sequence(&mut self, seq: u32) -> bool {
        let mut duplicate = false;
        if let Some(last) = self.last_seq {
            let step = seq.wrapping_sub(last);
            let c = &mut self.counters;
            match step {
                0 => {
                    c.duplicates = c.duplicates.saturating_add(1);
                    duplicate = true;
                }
                1..=0x8000_0000 => c.lost = c.lost.saturating_add(u64::from(step - 1)),
                _ => c.out_of_order = c.out_of_order.saturating_add(1),
            }
        }
        self.last_seq = Some(seq);
        duplicate
    }
}

/// The results completed by a slice of bytes ([`Decoder::feed`]).
#[derive(Debug)]
pub struct Feed<'a, const N: usize> {
    decoder: &'a mut Decoder<N>,
    bytes: core::slice::Iter<'a, u8>,
}

impl<const N: usize> Iterator for Feed<'_, N> {
    type Item = Result<Frame, DecodeError>;

    fn next(&mut self) -> Option<Self::Item> {
        self.bytes.by_ref().find_map(|&b| self.decoder.push(b))
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used, clippy::indexing_slicing)]
mod tests {
    use super::super::frame::{encode, encode_raw, Header};
    use super::super::{Ack, AckResult, Command, Kind, Message};
    use super::*;

    fn ack(n: u32) -> Message {
        Message::Ack(Ack {
            command_seq: n,
            result: AckResult::Accepted,
        })
    }

    /// Frames of `ack(seq)` for each sequence number, concatenated.
    fn stream(seqs: &[u32]) -> Vec<u8> {
        let mut v = Vec::new();
        for &s in seqs {
            let mut out = [0u8; MAX_ENCODED_LEN];
            let n = encode(&ack(s), s, &mut out).unwrap();
            v.extend_from_slice(&out[..n]);
        }
        v
    }

    fn decode_all<const N: usize>(
        d: &mut Decoder<N>,
        bytes: &[u8],
    ) -> Vec<Result<Frame, DecodeError>> {
        d.feed(bytes).collect()
    }

    #[test]
    fn frames_byte_by_byte_and_in_slices_agree() {
        let bytes = stream(&[0, 1, 2, 3]);
        let mut a = Decoder::<MAX_ENCODED_LEN>::new();
        let by_byte: Vec<_> = bytes.iter().filter_map(|&b| a.push(b)).collect();
        let mut b = Decoder::<MAX_ENCODED_LEN>::new();
        let mut by_slice = Vec::new();
        for chunk in bytes.chunks(7) {
            by_slice.extend(b.feed(chunk));
        }
        assert_eq!(by_byte, by_slice);
        assert_eq!(by_byte.len(), 4);
        for (i, r) in by_byte.iter().enumerate() {
            let f = r.as_ref().unwrap();
            assert_eq!((f.seq, &f.message), (i as u32, &ack(i as u32)));
        }
        assert_eq!(a.counters(), b.counters());
        assert_eq!(a.counters().frames_ok, 4);
        assert_eq!(a.counters().bytes, bytes.len() as u64);
    }

    #[test]
    fn extra_delimiters_are_ignored() {
        let mut bytes = vec![0, 0];
        bytes.extend(stream(&[5]));
        bytes.extend([0, 0, 0]);
        bytes.extend(stream(&[6]));
        let mut d = Decoder::<MAX_ENCODED_LEN>::new();
        let r = decode_all(&mut d, &bytes);
        assert_eq!(r.len(), 2);
        assert_eq!(d.counters().errors(), 0);
        assert_eq!(d.counters().lost, 0);
    }

    #[test]
    fn joining_skips_the_partial_frame_without_error() {
        let bytes = stream(&[0, 1, 2]);
        let cut = 5; // inside frame 0
        let mut d = Decoder::<MAX_ENCODED_LEN>::joining();
        let r = decode_all(&mut d, &bytes[cut..]);
        assert_eq!(r.len(), 2);
        assert_eq!(r[0].as_ref().unwrap().seq, 1);
        let c = d.counters();
        assert_eq!(c.errors(), 0);
        assert!(c.skipped_bytes > 0);
        // The same cut through a synchronised decoder is a counted error.
        let mut s = Decoder::<MAX_ENCODED_LEN>::new();
        let r = decode_all(&mut s, &bytes[cut..]);
        assert_eq!(r.len(), 3);
        assert!(r[0].is_err());
        assert_eq!(s.counters().errors(), 1);
    }

    #[test]
    fn oversize_frames_are_dropped_and_the_next_decoded() {
        // A 16-byte decoder meets a 17-byte command frame, then short acks.
        let mut out = [0u8; MAX_ENCODED_LEN];
        let n = encode(&Command::Reset, 0, &mut out).unwrap();
        assert_eq!(n, 15);
        let big = Header::new(Kind::Ack, 1);
        let mut bytes = out[..n].to_vec();
        bytes.extend(stream(&[0]));
        let m = encode_raw(&big, &[1, 0, 0, 0], &mut out).unwrap();
        assert_eq!(m, 18);
        bytes.extend_from_slice(&out[..m]);
        bytes.extend(stream(&[2]));
        let mut d = Decoder::<16>::new();
        let r = decode_all(&mut d, &bytes);
        assert_eq!(r.len(), 4);
        assert_eq!(
            r[0].as_ref().unwrap().message,
            Message::Command(Command::Reset)
        );
        assert_eq!(r[1].as_ref().unwrap().seq, 0);
        assert_eq!(r[2], Err(DecodeError::Oversize));
        assert_eq!(r[3].as_ref().unwrap().seq, 2);
        assert_eq!(d.counters().oversize, 1);
        assert_eq!(d.counters().lost, 1);
    }

    #[test]
    fn sequence_accounting() {
        // (stream, lost, duplicates, out_of_order)
        let cases: &[(&[u32], u64, u64, u64)] = &[
            (&[0, 1, 2, 3], 0, 0, 0),
            (&[0, 2, 3, 7], 1 + 3, 0, 0),
            (&[u32::MAX - 1, u32::MAX, 0, 1], 0, 0, 0),
            (&[u32::MAX - 2, 1], 3, 0, 0),
            (&[4, 4, 5], 0, 1, 0),
            (&[10, 11, 3, 4], 0, 0, 1),
            // First frame is not a gap, whatever its number.
            (&[1_000_000, 1_000_001], 0, 0, 0),
            // The largest forward step counts as loss, one more as backward.
            (&[0, 0x8000_0000], 0x7FFF_FFFF, 0, 0),
            (&[0, 0x8000_0001], 0, 0, 1),
        ];
        for &(seqs, lost, dup, ooo) in cases {
            let mut d = Decoder::<MAX_ENCODED_LEN>::new();
            let r = decode_all(&mut d, &stream(seqs));
            // Duplicates are dropped, everything else delivered.
            let dropped: Vec<_> = r.iter().filter_map(|x| x.as_ref().err()).collect();
            assert_eq!(dropped.len() as u64, dup, "{seqs:?}");
            assert!(dropped
                .iter()
                .all(|e| matches!(e, DecodeError::Duplicate(_))));
            let c = d.counters();
            assert_eq!(
                (c.lost, c.duplicates, c.out_of_order, c.frames_ok),
                (lost, dup, ooo, seqs.len() as u64 - dup),
                "{seqs:?}"
            );
            assert_eq!(d.last_seq(), seqs.last().copied());
        }
    }

    #[test]
    fn stream_decoder_drops_duplicates_and_keeps_command_echoes_out_of_the_sequence() {
        let mut bytes = stream(&[4, 4, 5]);
        // An echo of a host command (host seq 0) between device frames 5
        // and 6: delivered, but neither a gap nor a backward step.
        let mut out = [0u8; MAX_ENCODED_LEN];
        let n = encode(&Command::Reset, 0, &mut out).unwrap();
        bytes.extend_from_slice(&out[..n]);
        bytes.extend(stream(&[6]));
        let mut d = Decoder::<MAX_ENCODED_LEN>::new();
        let r = decode_all(&mut d, &bytes);
        let seqs: Vec<_> = r
            .iter()
            .map(|x| x.as_ref().map(|f| f.seq).map_err(|e| *e))
            .collect();
        assert_eq!(
            seqs,
            [Ok(4), Err(DecodeError::Duplicate(4)), Ok(5), Ok(0), Ok(6)]
        );
        let c = d.counters();
        assert_eq!(
            (
                c.frames_ok,
                c.duplicates,
                c.lost,
                c.out_of_order,
                c.errors()
            ),
            (4, 1, 0, 0, 0)
        );
    }

    #[test]
    fn command_decoder_delivers_repeated_and_older_sequence_numbers() {
        // The device executes every command (PROTOCOL.md §5.4): a repeated
        // number (a new host session, or a host's re-send) and an older one
        // are delivered, and only counted.
        let mut bytes = Vec::new();
        let mut out = [0u8; MAX_ENCODED_LEN];
        for seq in [0u32, 0, 1, 0] {
            let n = encode(&Command::Reset, seq, &mut out).unwrap();
            bytes.extend_from_slice(&out[..n]);
        }
        let mut d = Decoder::<{ super::super::budget::MAX_COMMAND_ENCODED_LEN }>::new();
        let r: Vec<_> = bytes.iter().filter_map(|&b| d.push_command(b)).collect();
        let seqs: Vec<_> = r.into_iter().map(|x| x.unwrap().0).collect();
        assert_eq!(seqs, [0, 0, 1, 0]);
        let c = d.counters();
        assert_eq!((c.frames_ok, c.duplicates, c.out_of_order), (4, 1, 1));
    }

    #[test]
    fn command_receiver_takes_commands_only() {
        let mut bytes = Vec::new();
        let mut out = [0u8; MAX_ENCODED_LEN];
        for (seq, c) in [(7u32, Command::Freeze), (9, Command::RequestStatus)] {
            let n = encode(&c, seq, &mut out).unwrap();
            bytes.extend_from_slice(&out[..n]);
        }
        // A device → host frame in between: refused, counted malformed.
        let n = encode(&ack(3), 10, &mut out).unwrap();
        bytes.splice(15..15, out[..n].iter().copied());
        let mut d = Decoder::<{ super::super::budget::MAX_COMMAND_ENCODED_LEN }>::new();
        let r: Vec<_> = bytes.iter().filter_map(|&b| d.push_command(b)).collect();
        assert_eq!(
            r,
            [
                Ok((7, Command::Freeze)),
                Err(DecodeError::UnknownKind(Kind::Ack as u8)),
                Ok((9, Command::RequestStatus))
            ]
        );
        let c = d.counters();
        assert_eq!(
            (c.frames_ok, c.malformed, c.lost, c.out_of_order),
            (2, 1, 1, 0)
        );
    }

    #[test]
    fn error_kinds_are_counted_apart() {
        let mut bytes = Vec::new();
        let mut out = [0u8; MAX_ENCODED_LEN];
        // Version 2, unknown kind, bad payload, a corrupted CRC, bad COBS.
        for (h, p) in [
            (
                Header {
                    version: 1,
                    ..Header::new(Kind::Ack, 0)
                },
                &[0u8, 0][..],
            ),
            (
                Header {
                    kind: 0x42,
                    ..Header::new(Kind::Ack, 1)
                },
                &[0, 0],
            ),
            (Header::new(Kind::Ack, 2), &[0, 99]),
        ] {
            let n = encode_raw(&h, p, &mut out).unwrap();
            bytes.extend_from_slice(&out[..n]);
        }
        let n = encode(&ack(3), 3, &mut out).unwrap();
        out[4] ^= 0x10;
        bytes.extend_from_slice(&out[..n]);
        bytes.extend([0x05, 1, 0]);
        bytes.extend(stream(&[4]));
        let mut d = Decoder::<MAX_ENCODED_LEN>::new();
        let r = decode_all(&mut d, &bytes);
        assert_eq!(
            r[0],
            Err(DecodeError::VersionMismatch {
                got: 1,
                expected: super::super::VERSION
            })
        );
        assert_eq!(r[1], Err(DecodeError::UnknownKind(0x42)));
        assert_eq!(r[2], Err(DecodeError::Payload));
        assert_eq!(r[3], Err(DecodeError::Crc));
        assert_eq!(r[4], Err(DecodeError::Cobs));
        assert_eq!(r[5].as_ref().unwrap().seq, 4);
        let c = *d.counters();
        assert_eq!(
            (
                c.version_mismatches,
                c.malformed,
                c.crc_errors,
                c.framing_errors,
                c.frames_ok
            ),
            (1, 2, 1, 1, 1)
        );
        assert_eq!(c.errors(), 5);
        d.reset_counters();
        assert_eq!(*d.counters(), LinkCounters::default());
        assert_eq!(d.last_seq(), None);
    }
}
