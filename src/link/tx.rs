//! The sending side: frames encoded into a fixed buffer, then queued whole
//! into a bounded byte ring ([`TxSink`]) or dropped and counted — never
//! waited for, never queued in part.
//!
//! # Exact loss accounting
//! [`Encoder`] advances the sequence number for every frame it writes into
//! its buffer. [`Transmitter::send`] always encodes into its own buffer of
//! [`MAX_ENCODED_LEN`] bytes (enough for any frame), so every well-formed
//! message consumes exactly one sequence number; only then is the frame
//! queued or, if the ring lacks room, dropped. Every dropped frame is
//! therefore one missing sequence number at the receiver, and
//! [`TxStats::frames_dropped`] equals the receiver's loss count when the
//! wire itself loses nothing (host test `link`). A message that breaks a
//! structural rule is refused by the encoder before it takes a number
//! ([`TxStats::encode_errors`]; the link never builds one).
//!
//! The first frame is preceded by a delimiter (`docs/PROTOCOL.md` §1.1),
//! so a receiver that joins the stream at its start, not knowing it is the
//! start (e.g. `beamctl monitor --tcp`), does not take the first frame for
//! the tail of an earlier one.

use beam_protocol::frame::EncodeError;
use beam_protocol::{Encoder, Message, MAX_ENCODED_LEN};

/// A bounded byte queue towards the wire (a UART's TX ring, a DMA buffer).
///
/// The link calls [`TxSink::push`] only with at most [`TxSink::free`]
/// bytes, and the sink must then queue all of them. Free space may grow
/// between the two calls (the consumer drains), never shrink: the link is
/// the only producer.
pub trait TxSink {
    /// Bytes that can be queued now.
    fn free(&self) -> usize;
    /// Queue `bytes` (never more than [`TxSink::free`]) and start the
    /// transmitter if it is idle.
    fn push(&mut self, bytes: &[u8]);
}

impl TxSink for heapless::spsc::Producer<'_, u8> {
    fn free(&self) -> usize {
        self.capacity() - self.len()
    }

    fn push(&mut self, bytes: &[u8]) {
        for &b in bytes {
            // Cannot fail: the caller checked `free()` and we are the only
            // producer.
            let _ = self.enqueue(b);
        }
    }
}

/// What [`Transmitter::send`] did with one message.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Sent {
    /// Queued: this many bytes, delimiter included.
    Queued(usize),
    /// Encoded (its sequence number is used) but the ring lacked room.
    Dropped,
    /// Not encoded: the message breaks a structural rule.
    Refused(EncodeError),
}

/// Counters of the sending side, since start-up (saturating).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct TxStats {
    /// Frames queued.
    pub frames_sent: u32,
    /// Frames encoded and then dropped for lack of room (each one a gap in
    /// the sequence numbers the host sees).
    pub frames_dropped: u32,
    /// Bytes queued.
    pub bytes_sent: u64,
    /// Messages the encoder refused (malformed; no sequence number used).
    pub encode_errors: u32,
}

/// The device → host stream: sequence numbers, an encode buffer, counters.
#[derive(Debug, Clone)]
pub struct Transmitter {
    encoder: Encoder,
    buf: [u8; MAX_ENCODED_LEN],
    stats: TxStats,
    /// A frame has been queued (the leading delimiter is sent).
    started: bool,
}

impl Default for Transmitter {
    fn default() -> Self {
        Self::new()
    }
}

impl Transmitter {
    /// Sequence numbers from 0.
    pub const fn new() -> Self {
        Self {
            encoder: Encoder::new(),
            buf: [0; MAX_ENCODED_LEN],
            stats: TxStats {
                frames_sent: 0,
                frames_dropped: 0,
                bytes_sent: 0,
                encode_errors: 0,
            },
            started: false,
        }
    }

    /// Encode `msg` and queue it into `tx` if the frame and `reserve` more
    /// bytes fit; otherwise drop it (counted). `reserve` keeps room for
    /// answers (acknowledgements) that must not be crowded out by
    /// telemetry.
    ///
    /// Takes a [`Message`], not each message type: one copy of the
    /// encoder's frame logic serves every kind (a generic version costs
    /// the firmware ~4 KB of flash per kind).
    #[inline(never)]
    pub fn send(&mut self, msg: &Message, reserve: usize, tx: &mut impl TxSink) -> Sent {
        let n = match self.encoder.encode(msg, &mut self.buf) {
            Ok(n) => n,
            Err(e) => {
                self.stats.encode_errors = self.stats.encode_errors.saturating_add(1);
                return Sent::Refused(e);
            }
        };
        let Some(frame) = self.buf.get(..n) else {
            // `encode` returned a length within the buffer it wrote.
            self.stats.encode_errors = self.stats.encode_errors.saturating_add(1);
            return Sent::Refused(EncodeError::BufferTooSmall);
        };
        let lead = usize::from(!self.started);
        if tx.free() < n.saturating_add(lead).saturating_add(reserve) {
            self.stats.frames_dropped = self.stats.frames_dropped.saturating_add(1);
            return Sent::Dropped;
        }
        if !self.started {
            tx.push(&[beam_protocol::DELIMITER]);
            self.started = true;
        }
        tx.push(frame);
        self.stats.frames_sent = self.stats.frames_sent.saturating_add(1);
        self.stats.bytes_sent = self.stats.bytes_sent.saturating_add((n + lead) as u64);
        Sent::Queued(n)
    }

    /// The counters.
    pub const fn stats(&self) -> &TxStats {
        &self.stats
    }

    /// The sequence number the next frame will carry.
    pub const fn next_seq(&self) -> u32 {
        self.encoder.next_seq()
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used, clippy::indexing_slicing)]
mod tests {
    use super::*;
    use beam_protocol::{Ack, AckResult, Decoder};
    use heapless::spsc::Queue;

    fn ack(n: u32) -> Message {
        Message::Ack(Ack {
            command_seq: n,
            result: AckResult::Accepted,
        })
    }

    #[test]
    fn a_delimiter_leads_so_a_joining_receiver_keeps_the_first_frame() {
        let mut q: Queue<u8, 64> = Queue::new();
        let (mut p, mut c) = q.split();
        let mut t = Transmitter::new();
        assert_eq!(t.send(&ack(0), 0, &mut p), Sent::Queued(16));
        assert_eq!(t.send(&ack(1), 0, &mut p), Sent::Queued(16));
        let mut bytes = Vec::new();
        while let Some(b) = c.dequeue() {
            bytes.push(b);
        }
        assert_eq!((bytes[0], bytes.len()), (0, 33));
        assert_eq!(t.stats().bytes_sent, 33);
        let mut joining: Decoder = Decoder::joining();
        let seqs: Vec<u32> = joining.feed(&bytes).map(|f| f.unwrap().seq).collect();
        assert_eq!(seqs, [0, 1]);
        assert_eq!(joining.counters().skipped_bytes, 0);
    }

    #[test]
    fn whole_frames_or_nothing_and_gaps_equal_drops() {
        let mut q: Queue<u8, 64> = Queue::new();
        let (mut p, mut c) = q.split();
        let mut t = Transmitter::new();
        let mut dec: Decoder = Decoder::new();
        let mut got = Vec::new();
        // A 16-byte Ack frame (the first with its leading delimiter): 3
        // fit in 63 bytes, the 4th and 5th are dropped; after draining,
        // the 6th goes through.
        let mut outcomes = Vec::new();
        for i in 0..5 {
            outcomes.push(t.send(&ack(i), 0, &mut p));
        }
        assert_eq!(
            outcomes,
            [
                Sent::Queued(16),
                Sent::Queued(16),
                Sent::Queued(16),
                Sent::Dropped,
                Sent::Dropped
            ]
        );
        assert_eq!(p.free(), 63 - 49);
        while let Some(b) = c.dequeue() {
            if let Some(f) = dec.push(b) {
                got.push(f.unwrap());
            }
        }
        assert_eq!(t.send(&ack(5), 0, &mut p), Sent::Queued(16));
        while let Some(b) = c.dequeue() {
            if let Some(f) = dec.push(b) {
                got.push(f.unwrap());
            }
        }
        let seqs: Vec<u32> = got.iter().map(|f| f.seq).collect();
        assert_eq!(seqs, [0, 1, 2, 5]);
        assert_eq!(got[3].message, ack(5), "the frame after the gap is intact");
        assert_eq!(dec.counters().lost, 2);
        assert_eq!(u64::from(t.stats().frames_dropped), dec.counters().lost);
        assert_eq!(t.stats().frames_sent, 4);
        assert_eq!(t.stats().bytes_sent, 65);
        assert_eq!(dec.counters().errors(), 0);
    }

    #[test]
    fn reserve_keeps_room() {
        let mut q: Queue<u8, 64> = Queue::new();
        let (mut p, _c) = q.split();
        let mut t = Transmitter::new();
        assert_eq!(t.send(&ack(0), 40, &mut p), Sent::Queued(16));
        // 46 free (frame and leading delimiter): a frame with a 32-byte
        // reserve no longer fits, an answer without reserve does.
        assert_eq!(t.send(&ack(1), 32, &mut p), Sent::Dropped);
        assert_eq!(t.send(&ack(2), 0, &mut p), Sent::Queued(16));
        assert_eq!(t.next_seq(), 3);
    }

    #[test]
    fn malformed_messages_use_no_sequence_number() {
        use beam_protocol::RawSamples;
        let mut q: Queue<u8, 64> = Queue::new();
        let (mut p, _c) = q.split();
        let mut t = Transmitter::new();
        let bad = RawSamples {
            first_sample_index: 0,
            decimation: 0,
            samples: heapless::Vec::new(),
        };
        assert_eq!(
            t.send(&Message::RawSamples(bad), 0, &mut p),
            Sent::Refused(EncodeError::Malformed)
        );
        assert_eq!(t.next_seq(), 0);
        assert_eq!(t.stats().encode_errors, 1);
        assert_eq!(p.free(), 63);
    }
}
