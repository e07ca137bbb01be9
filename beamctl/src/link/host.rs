//! The host's view of the link: the stream decoder and its counters, the
//! device's last [`Status`], frame and byte rates, and the commands sent
//! that still wait for their [`Ack`].
//!
//! [`Host`] does no I/O: the caller feeds it the bytes it read
//! ([`Host::receive`]) and writes the frames it encodes
//! ([`Host::command`]), so the same logic serves the terminal view, the
//! plain output, `beamctl send` and the tests.

use beam_protocol::{
    Ack, Command, DecodeError, Decoder, EncodeError, Encoder, Frame, Limits, LinkCounters, Message,
    Status, MAX_ENCODED_LEN,
};
use std::collections::VecDeque;
use std::time::{Duration, Instant};

/// The window over which [`Host::rates`] averages.
pub const RATE_WINDOW: Duration = Duration::from_secs(1);

/// A command sent and not yet answered.
#[derive(Debug, Clone, PartialEq)]
pub struct Pending {
    /// The command frame's sequence number (host → device counter).
    pub seq: u32,
    /// The command.
    pub command: Command,
    /// When it was sent.
    pub sent: Instant,
}

/// Host-side link state. See the module docs.
#[derive(Debug)]
pub struct Host {
    decoder: Decoder,
    encoder: Encoder,
    status: Option<Status>,
    statuses: u64,
    first_seq: Option<u32>,
    pending: VecDeque<Pending>,
    /// (time, frames delivered, bytes) samples for the rates.
    history: VecDeque<(Instant, u64, u64)>,
    sample_rate_fallback: Option<f64>,
    partial: u64,
}

impl Host {
    /// A host for a stream read from a frame boundary (a capture file, a
    /// TCP connection opened before the device starts) if `joining` is
    /// false, or for a running stream (a serial port, where the bytes
    /// before the first delimiter end a frame sent before we listened, and
    /// are skipped and counted, not taken as errors) if true.
    pub fn new(joining: bool) -> Self {
        Self {
            decoder: if joining {
                Decoder::joining()
            } else {
                Decoder::new()
            },
            encoder: Encoder::new(),
            status: None,
            statuses: 0,
            first_seq: None,
            pending: VecDeque::new(),
            history: VecDeque::new(),
            sample_rate_fallback: None,
            partial: 0,
        }
    }

    /// Use `hz` as the sample rate until the device's first Status.
    pub fn set_sample_rate_fallback(&mut self, hz: Option<f64>) {
        self.sample_rate_fallback = hz;
    }

    /// Feed bytes read at `now`; returns what they completed, in order:
    /// the frames delivered and the frames dropped (already counted in
    /// [`counters`](Self::counters)). A Status updates
    /// [`status`](Self::status) before it is returned.
    pub fn receive(&mut self, bytes: &[u8], now: Instant) -> Vec<Result<Frame, DecodeError>> {
        let out: Vec<_> = self.decoder.feed(bytes).collect();
        self.partial = match bytes.iter().rposition(|&b| b == beam_protocol::DELIMITER) {
            Some(p) => (bytes.len() - p - 1) as u64,
            None => self.partial + bytes.len() as u64,
        };
        for f in out.iter().flatten() {
            self.first_seq.get_or_insert(f.seq);
            if let Message::Status(s) = &f.message {
                self.status = Some(s.clone());
                self.statuses += 1;
            }
        }
        self.sample_rates(now);
        out
    }

    fn sample_rates(&mut self, now: Instant) {
        let c = self.decoder.counters();
        self.history.push_back((now, c.frames_ok, c.bytes));
        // Keep one sample older than the window, so the window is covered.
        while self
            .history
            .get(1)
            .is_some_and(|(t, _, _)| now.duration_since(*t) >= RATE_WINDOW)
        {
            self.history.pop_front();
        }
    }

    /// Frames per second and bytes per second received over about the
    /// last [`RATE_WINDOW`] up to `now` (0 before two reads).
    pub fn rates(&self, now: Instant) -> (f64, f64) {
        let (Some(first), Some(last)) = (self.history.front(), self.history.back()) else {
            return (0.0, 0.0);
        };
        let dt = now.duration_since(first.0).as_secs_f64();
        if dt <= 0.0 {
            return (0.0, 0.0);
        }
        (
            (last.1 - first.1) as f64 / dt,
            (last.2 - first.2) as f64 / dt,
        )
    }

    /// Bytes received since the last delimiter: the start of a frame not
    /// yet complete (at the end of a capture, a frame cut short).
    pub fn partial_bytes(&self) -> u64 {
        self.partial
    }

    /// The decoder's counters.
    pub fn counters(&self) -> &LinkCounters {
        self.decoder.counters()
    }

    /// The last Status received.
    pub fn status(&self) -> Option<&Status> {
        self.status.as_ref()
    }

    /// Status frames received.
    pub fn statuses(&self) -> u64 {
        self.statuses
    }

    /// The sequence number of the first frame delivered: the device numbers
    /// its frames from 0 at start-up, so this many were sent before we
    /// listened (or were lost before the first one we decoded).
    pub fn first_seq(&self) -> Option<u32> {
        self.first_seq
    }

    /// The device's sample rate: from its last Status, else the fallback.
    pub fn sample_rate_hz(&self) -> Option<f64> {
        self.status
            .as_ref()
            .map(|s| f64::from(s.sample_rate_hz))
            .filter(|f| f.is_finite() && *f > 0.0)
            .or(self.sample_rate_fallback)
    }

    /// Device time of a sample index (s), if the sample rate is known.
    pub fn time_s(&self, sample_index: u64) -> Option<f64> {
        self.sample_rate_hz().map(|fs| sample_index as f64 / fs)
    }

    /// Encode `command` as the next host → device frame and remember it as
    /// pending from `now`. Returns its sequence number and the bytes to
    /// write (a leading delimiter, so the device drops any noise before
    /// it, then the frame).
    pub fn command(
        &mut self,
        command: Command,
        now: Instant,
    ) -> Result<(u32, Vec<u8>), EncodeError> {
        let mut buf = [0u8; MAX_ENCODED_LEN];
        let seq = self.encoder.next_seq();
        let n = self.encoder.encode(&command, &mut buf)?;
        let mut bytes = Vec::with_capacity(n + 1);
        bytes.push(beam_protocol::DELIMITER);
        bytes.extend_from_slice(buf.get(..n).unwrap_or_default());
        self.pending.push_back(Pending {
            seq,
            command,
            sent: now,
        });
        Ok((seq, bytes))
    }

    /// The pending command that `ack` answers (removed), if any. An Ack
    /// for no pending command (answered twice, or already timed out)
    /// returns `None`.
    pub fn answer(&mut self, ack: &Ack) -> Option<Pending> {
        let i = self.pending.iter().position(|p| p.seq == ack.command_seq)?;
        self.pending.remove(i)
    }

    /// Remove and return the commands sent more than `timeout` before `now`.
    pub fn expire(&mut self, now: Instant, timeout: Duration) -> Vec<Pending> {
        let (old, young): (Vec<_>, Vec<_>) = self
            .pending
            .drain(..)
            .partition(|p| now.duration_since(p.sent) > timeout);
        self.pending = young.into();
        old
    }

    /// Commands waiting for an answer.
    pub fn pending(&self) -> impl Iterator<Item = &Pending> {
        self.pending.iter()
    }

    /// The limits the host can check a command against before sending it:
    /// the sample rate and mode count of the device's last Status, the
    /// link budget if known (`link_bytes_per_s`, e.g. from the baud rate),
    /// and, for what a Status does not tell (the piezo's safe window, the
    /// generators' and estimators' ranges), nothing: those the device
    /// checks. `None` before the first Status.
    pub fn limits(&self, link_bytes_per_s: Option<f32>) -> Option<Limits> {
        let s = self.status.as_ref()?;
        Some(Limits {
            sample_rate_hz: s.sample_rate_hz,
            piezo_min_v: f32::NEG_INFINITY,
            piezo_max_v: f32::INFINITY,
            max_multisine_tones: u8::MAX,
            prbs_bits_min: 0,
            prbs_bits_max: u8::MAX,
            estimators: u8::MAX,
            modes: s.modes,
            link_bytes_per_s: link_bytes_per_s.unwrap_or(f32::INFINITY),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use beam_protocol::{AckResult, Encoder};

    fn ack(seq: u32, command_seq: u32) -> Vec<u8> {
        let mut buf = [0u8; MAX_ENCODED_LEN];
        let n = Encoder::starting_at(seq)
            .encode(
                &Ack {
                    command_seq,
                    result: AckResult::Accepted,
                },
                &mut buf,
            )
            .unwrap();
        buf[..n].to_vec()
    }

    #[test]
    fn commands_are_numbered_and_answered_once() {
        let t0 = Instant::now();
        let mut h = Host::new(false);
        let (s0, b0) = h.command(Command::Freeze, t0).unwrap();
        let (s1, _) = h.command(Command::Resume, t0).unwrap();
        assert_eq!((s0, s1), (0, 1));
        assert_eq!(b0[0], 0, "leading delimiter");
        assert_eq!(*b0.last().unwrap(), 0);
        let got = h.receive(&ack(5, 1), t0);
        let Ok(Frame {
            message: Message::Ack(a),
            ..
        }) = &got[0]
        else {
            panic!("{got:?}")
        };
        assert_eq!(h.answer(a).map(|p| p.command), Some(Command::Resume));
        assert_eq!(h.answer(a), None, "answered once");
        assert_eq!(h.first_seq(), Some(5));
        let late = t0 + Duration::from_secs(2);
        let expired = h.expire(late, Duration::from_secs(1));
        assert_eq!(expired.len(), 1);
        assert_eq!(expired[0].command, Command::Freeze);
        assert_eq!(h.pending().count(), 0);
    }

    #[test]
    fn rates_over_the_window() {
        let t0 = Instant::now();
        let mut h = Host::new(false);
        let frame = ack(0, 0);
        for i in 0..=20u64 {
            let mut bytes = frame.clone();
            // Renumber so that nothing counts as a duplicate.
            bytes = if i == 0 { bytes } else { ack(i as u32, 0) };
            h.receive(&bytes, t0 + Duration::from_millis(100 * i));
        }
        let (fps, bps) = h.rates(t0 + Duration::from_millis(2000));
        // 10 frames in the last second (one per 100 ms).
        assert!((fps - 10.0).abs() < 1e-9, "{fps}");
        assert!((bps - 10.0 * frame.len() as f64).abs() < 1e-6, "{bps}");
        assert_eq!(h.counters().lost, 0);
    }
}
