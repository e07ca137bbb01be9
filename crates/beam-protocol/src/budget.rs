//! Worst-case frame sizes and the link load they imply.
//!
//! Every payload size here is the [`MaxSize`] of its message, derived next
//! to the message's struct from its fields' sizes: an upper bound that the
//! encoder can reach (all varints at their longest, all vectors full); COBS
//! adds its worst case. The unit tests in `frame` encode messages that reach
//! each bound exactly. The device refuses telemetry rates whose worst-case
//! load exceeds its link budget
//! ([`RejectReason::LinkBudget`](super::RejectReason::LinkBudget)), so an
//! accepted setting never overruns the link, whatever the values sent.
//!

use super::command::TelemetryRates;
use super::size::{max, MaxSize};
use super::telemetry::{Ack, Estimate, ModeEstimate, RawSamples, SelfTestReport, Status};
use super::{Command, CRC_LEN, HEADER_LEN, MAX_MODES, MAX_RAW_SAMPLES};

/// Longest [`Estimate`] payload for a model of `modes` modes (clamped to
/// [`MAX_MODES`]): each mode fewer than [`MAX_MODES`] leaves out one
/// [`ModeEstimate`] and four Θ entries (Θ has 4·modes − 1). 73 bytes for 2
/// modes.
pub const fn estimate_payload_max(modes: usize) -> usize {
    let fewer = MAX_MODES.saturating_sub(modes);
    Estimate::MAX_SIZE - fewer * (ModeEstimate::MAX_SIZE + 4 * f32::MAX_SIZE)
}

/// Longest [`RawSamples`] payload: first index, decimation,
/// [`MAX_RAW_SAMPLES`] pairs of `f32` (526 bytes).
pub const RAW_PAYLOAD_MAX: usize = RawSamples::MAX_SIZE;

/// Longest [`Status`] payload (136 bytes).
pub const STATUS_PAYLOAD_MAX: usize = Status::MAX_SIZE;

/// Longest [`Ack`] payload: sequence number and result byte.
pub const ACK_PAYLOAD_MAX: usize = Ack::MAX_SIZE;

/// Longest [`Command`] payload: tag and the longest argument (estimator
/// settings).
pub const COMMAND_PAYLOAD_MAX: usize = Command::MAX_SIZE;

/// Longest [`SelfTestReport`] payload (sent once per self-test, not part
/// of [`LinkLoad`]).
pub const SELF_TEST_PAYLOAD_MAX: usize = SelfTestReport::MAX_SIZE;

/// Longest payload of any message: a full raw-sample block.
pub const MAX_PAYLOAD_LEN: usize = max(
    RAW_PAYLOAD_MAX,
    max(
        estimate_payload_max(MAX_MODES),
        max(
            STATUS_PAYLOAD_MAX,
            max(
                SELF_TEST_PAYLOAD_MAX,
                max(ACK_PAYLOAD_MAX, COMMAND_PAYLOAD_MAX),
            ),
        ),
    ),
);

/// Longest frame before COBS: header, payload, CRC (538 bytes).
pub const MAX_FRAME_LEN: usize = HEADER_LEN + MAX_PAYLOAD_LEN + CRC_LEN;

/// Longest frame on the wire for a payload of at most `payload` bytes:
/// COBS adds at most one byte per 254 started (⌈n/254⌉), then the
/// delimiter.
pub const fn encoded_len_max(payload: usize) -> usize {
    let n = HEADER_LEN + payload + CRC_LEN;
    cobs::max_encoding_length(n) + 1
}

/// Longest frame on the wire, delimiter included (542 bytes): the size of
/// a buffer that holds any encoded frame.
pub const MAX_ENCODED_LEN: usize = encoded_len_max(MAX_PAYLOAD_LEN);

/// Longest command frame on the wire, delimiter included: a device that
/// only receives commands can size its decoder with this.
pub const MAX_COMMAND_ENCODED_LEN: usize = encoded_len_max(COMMAND_PAYLOAD_MAX);

/// The longest Ack frame on the wire, delimiter included: 20 bytes (a
/// command seq of 2²⁸ or more takes a 5-byte varint; below 128, one byte
/// and the frame is 16 bytes).
pub const MAX_ACK_ENCODED_LEN: usize = encoded_len_max(ACK_PAYLOAD_MAX);

/// Bytes per second of a UART at `baud` with 8N1 framing (10 bits per
/// byte: start, 8 data, stop). 921,600 baud → 92,160 B/s.
pub const fn uart_bytes_per_s(baud: u32) -> u32 {
    baud / 10
}

/// Worst-case link load of a telemetry setting (bytes per second on the
/// wire), by stream. Acknowledgements (one per command, ≤ 10 bytes) are
/// not included.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct LinkLoad {
    /// Estimate frames.
    pub estimates_b_s: f32,
    /// Raw-sample frames (full blocks of [`MAX_RAW_SAMPLES`]).
    pub raw_b_s: f32,
    /// Status frames.
    pub status_b_s: f32,
}

impl LinkLoad {
    /// The load of `rates` at `sample_rate_hz` for a model of `modes` modes
    /// (clamped to 1..=[`MAX_MODES`]).
    pub fn new(rates: &TelemetryRates, sample_rate_hz: f32, modes: usize) -> Self {
        let modes = modes.clamp(1, MAX_MODES);
        let raw_rate_hz = if rates.raw_decimation == 0 {
            0.0
        } else {
            sample_rate_hz / f32::from(rates.raw_decimation)
        };
        Self {
            estimates_b_s: rates.estimate_rate_hz
                * bytes(encoded_len_max(estimate_payload_max(modes))),
            raw_b_s: raw_rate_hz * raw_bytes_per_sample(),
            status_b_s: rates.status_rate_hz * bytes(encoded_len_max(STATUS_PAYLOAD_MAX)),
        }
    }

    /// Total bytes per second.
    pub fn total_b_s(&self) -> f32 {
        self.estimates_b_s + self.raw_b_s + self.status_b_s
    }
}

/// Worst-case wire bytes per raw sample pair, sent in full blocks.
pub fn raw_bytes_per_sample() -> f32 {
    bytes(encoded_len_max(RAW_PAYLOAD_MAX)) / bytes(MAX_RAW_SAMPLES)
}

/// A small byte count as `f32` (exact below 2²⁴).
fn bytes(n: usize) -> f32 {
    // Every count here is below 2^16: the conversion is exact.
    u16::try_from(n).map_or(f32::MAX, f32::from)
}

/// The smallest raw-sample decimation (the highest raw rate f_s/d) that
/// fits in `link_b_s` next to the estimate and status rates of `rates`;
/// `None` if none fits (or the others alone exceed the budget).
pub fn min_raw_decimation(
    rates: &TelemetryRates,
    sample_rate_hz: f32,
    modes: usize,
    link_b_s: f32,
) -> Option<u16> {
    (1..=u16::MAX).find(|&d| {
        let r = TelemetryRates {
            raw_decimation: d,
            ..*rates
        };
        LinkLoad::new(&r, sample_rate_hz, modes).total_b_s() <= link_b_s
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sizes() {
        assert_eq!(estimate_payload_max(2), 77);
        assert_eq!(estimate_payload_max(3), 105);
        assert_eq!(RAW_PAYLOAD_MAX, 526);
        assert_eq!(STATUS_PAYLOAD_MAX, 137);
        assert_eq!(COMMAND_PAYLOAD_MAX, 24);
        assert_eq!(SELF_TEST_PAYLOAD_MAX, 151);
        assert_eq!(MAX_PAYLOAD_LEN, RAW_PAYLOAD_MAX);
        assert_eq!(MAX_FRAME_LEN, 538);
        // 538 bytes: COBS adds ⌈538/254⌉ = 3, then the delimiter.
        assert_eq!(MAX_ENCODED_LEN, 542);
        // Short frames: one COBS byte and the delimiter.
        assert_eq!(encoded_len_max(estimate_payload_max(2)), 8 + 77 + 4 + 2);
        assert_eq!(MAX_COMMAND_ENCODED_LEN, 8 + 24 + 4 + 2);
        assert_eq!(MAX_ACK_ENCODED_LEN, 8 + 6 + 4 + 2);
        assert_eq!(uart_bytes_per_s(921_600), 92_160);
    }

    #[test]
    fn default_load_and_highest_raw_rate_at_921600_baud() {
        let link = uart_bytes_per_s(921_600) as f32;
        let rates = TelemetryRates::default();
        let load = LinkLoad::new(&rates, 10_000.0, 2);
        // 100 Hz · 91 B + 1 Hz · 151 B.
        assert_eq!(load.total_b_s(), 9_251.0);
        // Next to them, raw samples fit at 5 kHz (d = 2), not at 10 kHz:
        // 10 kHz · 542/64 B = 84,688 B/s + 9,250 > 92,160.
        assert_eq!(min_raw_decimation(&rates, 10_000.0, 2, link), Some(2));
        // Alone (estimates and status off), 10 kHz raw fits.
        let quiet = TelemetryRates {
            estimate_rate_hz: 0.0,
            raw_decimation: 0,
            status_rate_hz: 0.0,
        };
        assert_eq!(min_raw_decimation(&quiet, 10_000.0, 2, link), Some(1));
        // Budget smaller than the estimates alone: nothing fits.
        assert_eq!(min_raw_decimation(&rates, 10_000.0, 2, 1_000.0), None);
    }
}
