//! The serial link's plumbing on the reference board: frames of the
//! project's protocol (`beamest::protocol`, docs/PROTOCOL.md) into the
//! USART3 TX ring, received bytes from the RX ring into the protocol's
//! stream decoder. Thread mode only.
//!
//! What goes over the link — estimates, status, acknowledgements, and
//! which commands are applied — is the serial-link work (issue 7); this
//! module provides the two ends it plugs into: [`Link::send`] for any
//! device → host message and [`Link::poll`] for host → device frames. It
//! already forwards raw-sample blocks ([`Link::send_raw`]) when raw
//! recording is switched on.

use beamest::board::nucleo::uart::{UartRx, UartTx};
use beamest::pipeline::RawBlock;
use beamest::protocol::heapless::Vec;
use beamest::protocol::{
    Decoder, Encoder, Frame, LinkCounters, Payload, RawSamples, UySample, MAX_ENCODED_LEN,
    MAX_RAW_SAMPLES,
};

/// Frames the link could not send, by reason.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, defmt::Format)]
pub struct SendStats {
    /// Frames queued whole.
    pub sent: u32,
    /// Frames dropped because the TX ring lacked room.
    pub ring_full: u32,
    /// Messages the encoder refused (malformed, too large).
    pub encode_errors: u32,
}

/// Both directions of the link.
pub struct Link {
    tx: UartTx,
    rx: UartRx,
    encoder: Encoder,
    decoder: Decoder,
    buf: [u8; MAX_ENCODED_LEN],
    stats: SendStats,
}

impl Link {
    /// The link over USART3's rings; the device's sequence numbers start
    /// at 0 and the decoder at a frame boundary.
    pub fn new(tx: UartTx, rx: UartRx) -> Self {
        Self {
            tx,
            rx,
            encoder: Encoder::new(),
            decoder: Decoder::new(),
            buf: [0; MAX_ENCODED_LEN],
            stats: SendStats::default(),
        }
    }

    /// Encode `msg` as one frame and queue it whole, or count why not.
    pub fn send<M: Payload + ?Sized>(&mut self, msg: &M) -> bool {
        match self.encoder.encode(msg, &mut self.buf) {
            Ok(n) => {
                let frame = self.buf.get(..n).unwrap_or(&[]);
                if self.tx.write_all_or_nothing(frame) {
                    self.stats.sent = self.stats.sent.saturating_add(1);
                    true
                } else {
                    self.stats.ring_full = self.stats.ring_full.saturating_add(1);
                    false
                }
            }
            Err(_) => {
                self.stats.encode_errors = self.stats.encode_errors.saturating_add(1);
                false
            }
        }
    }

    /// Forward a raw block as a `RawSamples` message: the (u, y) pairs
    /// exactly as the estimator received them (u in actuator volts, y in
    /// strain; NaN marks a rejected sample).
    pub fn send_raw(&mut self, block: &RawBlock<f64>) -> bool {
        let mut samples: Vec<UySample, MAX_RAW_SAMPLES> = Vec::new();
        let len = usize::from(block.len);
        for (u, y) in block.u_v.iter().zip(block.y.iter()).take(len) {
            if samples
                .push(UySample {
                    u_v: *u as f32,
                    y: *y as f32,
                })
                .is_err()
            {
                break;
            }
        }
        let msg = RawSamples {
            first_sample_index: block.first_index,
            decimation: block.decimation.max(1),
            samples,
        };
        self.send(&msg)
    }

    /// The next complete host → device frame, if the received bytes hold
    /// one (bad frames are counted by the decoder and skipped).
    pub fn poll(&mut self) -> Option<Frame> {
        while let Some(byte) = self.rx.read() {
            if let Some(Ok(frame)) = self.decoder.push(byte) {
                return Some(frame);
            }
        }
        None
    }

    /// Send-side counters.
    pub fn send_stats(&self) -> SendStats {
        self.stats
    }

    /// Receive-side counters (the protocol decoder's).
    pub fn receive_stats(&self) -> LinkCounters {
        *self.decoder.counters()
    }
}
