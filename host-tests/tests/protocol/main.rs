//! The serial-link protocol, end to end on the host: every message
//! survives the trip bit for bit, no input makes the decoder or the command
//! parser panic, corruption is always detected and never costs more than
//! the frames it touched, and loss is counted exactly.
//!
//! `golden.rs` pins the exact bytes of one frame of each kind and checks
//! that `docs/PROTOCOL.md` shows the same bytes.

mod golden;
mod strategies;

use std::ops::Range;

use beam_protocol::budget::uart_bytes_per_s;
use beam_protocol::{
    encode, encode_raw, parse_frame, Ack, AckResult, Command, DecodeError, Decoder, Frame, Header,
    Kind, Limits, Message, MAX_ENCODED_LEN, VERSION,
};
use proptest::collection::vec;
use proptest::prelude::*;
use proptest::sample::Index;

use strategies::{command, device_message, message};

type Dec = Decoder<MAX_ENCODED_LEN>;

fn encode_vec(msg: &Message, seq: u32) -> Vec<u8> {
    let mut buf = [0u8; MAX_ENCODED_LEN];
    let n = encode(msg, seq, &mut buf).expect("every generated message encodes");
    buf[..n].to_vec()
}

/// A captured stream: frame i carries sequence number i; `spans[i]` is its
/// byte range, delimiter included.
fn capture(msgs: &[Message]) -> (Vec<u8>, Vec<Range<usize>>) {
    let mut bytes = Vec::new();
    let mut spans = Vec::new();
    for (i, m) in msgs.iter().enumerate() {
        let start = bytes.len();
        bytes.extend(encode_vec(m, i as u32));
        spans.push(start..bytes.len());
    }
    (bytes, spans)
}

/// Bitwise equality of two messages: the encoding writes every field, `f32`
/// as its exact bit pattern, so equal bytes ⇔ equal bits in every field
/// (NaN payloads included, where `PartialEq` cannot tell).
fn same_bits(a: &Message, b: &Message) -> bool {
    encode_vec(a, 0) == encode_vec(b, 0)
}

/// Decode `bytes` and check what was delivered against `msgs`: every
/// delivered frame is one of the originals with its exact content, in
/// order. Returns the delivered sequence numbers and the decoder.
fn decode_checked(bytes: &[u8], msgs: &[Message]) -> (Vec<usize>, Dec, usize) {
    let mut d = Dec::new();
    let mut delivered = Vec::new();
    let mut errors = 0;
    for r in d.feed(bytes) {
        match r {
            Ok(Frame { seq, message }) => {
                let i = seq as usize;
                assert!(i < msgs.len(), "sequence number {seq} was never sent");
                assert!(
                    same_bits(&message, &msgs[i]),
                    "frame {i} delivered with wrong content"
                );
                assert!(delivered.last() < Some(&i), "frames out of order");
                delivered.push(i);
            }
            Err(_) => errors += 1,
        }
    }
    (delivered, d, errors)
}

/// Runs of consecutive indices in a sorted list.
fn runs(sorted: &[usize]) -> usize {
    sorted.windows(2).filter(|w| w[1] != w[0] + 1).count() + usize::from(!sorted.is_empty())
}

/// Frames touched by a change at byte `p`: the frame whose span holds it,
/// and the next one if `p` is the delimiter (the two merge).
fn touched_by(p: usize, spans: &[Range<usize>]) -> impl Iterator<Item = usize> + '_ {
    spans
        .iter()
        .enumerate()
        .filter(move |(_, s)| s.contains(&p) || s.start == p + 1)
        .map(|(i, _)| i)
}

/// The checks shared by the corruption properties, for a stream in which
/// the frames `touched` were damaged: every other frame is delivered, what
/// is delivered is exact, every frame not delivered is counted as lost, and
/// if `errors_required`, each damaged stretch is reported as at least one
/// error. A damaged frame is delivered only if its bytes still decode to
/// the very same content.
fn assert_exact_loss(bytes: &[u8], msgs: &[Message], touched: &[usize], errors_required: bool) {
    let (delivered, d, errors) = decode_checked(bytes, msgs);
    let missing: Vec<usize> = (0..msgs.len()).filter(|i| !delivered.contains(i)).collect();
    assert!(
        missing.iter().all(|i| touched.contains(i)),
        "untouched frames lost: {missing:?} (touched {touched:?})"
    );
    let c = d.counters();
    assert_eq!(c.frames_ok, delivered.len() as u64);
    assert_eq!(c.lost, missing.len() as u64, "every lost frame is counted");
    assert_eq!(c.errors(), errors as u64);
    if errors_required {
        assert!(
            errors >= runs(&missing),
            "every damaged stretch is reported"
        );
    }
    assert_eq!((c.duplicates, c.out_of_order), (0, 0));
}

/// Bytes that damage may hit: after frame 0's delimiter and before the
/// delimiter that precedes the last frame, so the first and the last
/// frame always arrive and the loss between them is visible.
fn damageable(spans: &[Range<usize>]) -> Range<usize> {
    spans[0].end..spans[spans.len() - 1].start - 1
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(512))]

    #[test]
    fn every_message_round_trips_bitwise(msg in message(), seq in any::<u32>()) {
        let bytes = encode_vec(&msg, seq);
        prop_assert!(bytes.len() <= MAX_ENCODED_LEN);
        let mut d = Dec::new();
        let frames: Vec<_> = d.feed(&bytes).collect();
        prop_assert_eq!(frames.len(), 1);
        let f = frames[0].as_ref().expect("decodes");
        prop_assert_eq!(f.seq, seq);
        prop_assert!(same_bits(&f.message, &msg));
        prop_assert_eq!(f.message.kind(), msg.kind());
        #[allow(clippy::eq_op)] // false for messages holding a NaN
        if msg == msg {
            prop_assert_eq!(&f.message, &msg);
        }
    }

    #[test]
    fn decoder_never_panics_on_arbitrary_bytes(
        bytes in prop_oneof![
            vec(any::<u8>(), 0..4096),
            // Frame-like: short runs between delimiters.
            vec(prop_oneof![3 => any::<u8>(), 1 => Just(0u8)], 0..4096),
        ],
        chunk in 1usize..100,
    ) {
        let mut d = Dec::joining();
        let mut results = 0u64;
        for c in bytes.chunks(chunk) {
            results += d.feed(c).count() as u64;
        }
        let c = d.counters();
        prop_assert_eq!(c.bytes, bytes.len() as u64);
        prop_assert_eq!(c.frames_ok + c.errors(), results);
        // A small decoder too (the device's command receiver).
        let mut small = Decoder::<16>::new();
        let _ = small.feed(&bytes).count();
        let _ = parse_frame(&bytes);
    }

    /// The command parser: a valid frame around an arbitrary payload, of
    /// every kind; whatever decodes also validates without panicking.
    #[test]
    fn parsers_never_panic_on_arbitrary_payloads(
        payload in vec(any::<u8>(), 0..600),
        kind in proptest::sample::select(vec![
            Kind::Command, Kind::Estimate, Kind::RawSamples, Kind::Status, Kind::Ack,
        ]),
        seq in any::<u32>(),
    ) {
        let mut buf = [0u8; MAX_ENCODED_LEN];
        let Ok(n) = encode_raw(&Header::new(kind, seq), &payload, &mut buf) else {
            prop_assert!(payload.len() > beam_protocol::MAX_PAYLOAD_LEN);
            return Ok(());
        };
        let mut d = Dec::new();
        for r in d.feed(&buf[..n]) {
            match r {
                Ok(f) => {
                    prop_assert_eq!(f.seq, seq);
                    prop_assert_eq!(f.message.kind(), kind);
                    if let Message::Command(c) = f.message {
                        let _ = c.validate(&limits());
                    }
                }
                Err(e) => prop_assert_eq!(e, DecodeError::Payload),
            }
        }
    }

    #[test]
    fn validation_never_panics(c in command(), l in limits_any()) {
        let _ = c.validate(&l);
        let _ = c.validate(&limits());
    }

    /// Replace random bytes of a captured stream of many frames.
    #[test]
    fn corrupted_bytes_are_detected_and_cost_only_their_frames(
        msgs in vec(device_message(), 3..24),
        hits in vec((any::<Index>(), 1u8..=255), 1..6),
    ) {
        let (mut bytes, spans) = capture(&msgs);
        let region = damageable(&spans);
        prop_assume!(!region.is_empty());
        let mut touched = Vec::new();
        for (at, xor) in &hits {
            let p = region.start + at.index(region.len());
            bytes[p] ^= xor;
            touched.extend(touched_by(p, &spans));
        }
        touched.sort_unstable();
        touched.dedup();
        assert_exact_loss(&bytes, &msgs, &touched, true);
    }

    /// Drop a random stretch of bytes (a receive overrun): the loss is
    /// counted exactly.
    #[test]
    fn dropped_bytes_are_detected_and_cost_only_their_frames(
        msgs in vec(device_message(), 3..24),
        at in any::<Index>(),
        len in 1usize..200,
    ) {
        let (bytes, spans) = capture(&msgs);
        let region = damageable(&spans);
        prop_assume!(!region.is_empty());
        let start = region.start + at.index(region.len());
        let end = (start + len).min(region.end);
        let mut touched: Vec<usize> = (start..end).flat_map(|p| touched_by(p, &spans)).collect();
        touched.sort_unstable();
        touched.dedup();
        let mut cut = bytes[..start].to_vec();
        cut.extend_from_slice(&bytes[end..]);
        // A cut can leave only whole frames and empty ones (e.g. it removed
        // a frame's bytes but not its delimiter): then no frame is corrupt
        // and only the sequence numbers reveal the loss, so `lost` is the
        // guarantee here, not an error count.
        assert_exact_loss(&cut, &msgs, &touched, false);
    }

    /// Insert garbage (which may hold delimiters) anywhere: frames it does
    /// not land in still arrive, and nothing wrong is ever delivered.
    #[test]
    fn garbage_never_costs_other_frames(
        msgs in vec(device_message(), 2..16),
        at in any::<Index>(),
        garbage in vec(any::<u8>(), 1..300),
    ) {
        let (bytes, spans) = capture(&msgs);
        // Before any byte; the stream's last delimiter then ends it.
        let p = at.index(bytes.len());
        let mut noisy = bytes[..p].to_vec();
        noisy.extend_from_slice(&garbage);
        noisy.extend_from_slice(&bytes[p..]);
        // Only the frame the garbage lands in (or just before) is at risk.
        let hit: Vec<usize> = spans
            .iter()
            .enumerate()
            .filter(|(_, s)| s.start <= p && p < s.end)
            .map(|(i, _)| i)
            .collect();
        let (delivered, d, _) = decode_checked(&noisy, &msgs);
        for i in (0..msgs.len()).filter(|i| !hit.contains(i)) {
            prop_assert!(delivered.contains(&i), "untouched frame {} lost", i);
        }
        prop_assert!(d.counters().errors() >= 1 || !garbage.iter().any(|&b| b != 0));
    }

    /// Gaps are counted exactly, across the 2³² wrap.
    #[test]
    fn sequence_gaps_are_counted_exactly(
        start in prop_oneof![any::<u32>(), (u32::MAX - 20_000)..=u32::MAX],
        steps in vec(1u32..5_000, 1..60),
    ) {
        let mut seq = start;
        let mut bytes = encode_vec(&ack(0), seq);
        for s in &steps {
            seq = seq.wrapping_add(*s);
            bytes.extend(encode_vec(&ack(0), seq));
        }
        let mut d = Dec::new();
        prop_assert!(d.feed(&bytes).all(|r| r.is_ok()));
        let c = d.counters();
        let expected: u64 = steps.iter().map(|&s| u64::from(s - 1)).sum();
        prop_assert_eq!(c.lost, expected);
        prop_assert_eq!(c.frames_ok, steps.len() as u64 + 1);
        prop_assert_eq!((c.duplicates, c.out_of_order), (0, 0));
        prop_assert_eq!(d.last_seq(), Some(seq));
    }
}

fn ack(command_seq: u32) -> Message {
    Message::Ack(Ack {
        command_seq,
        result: AckResult::Accepted,
    })
}

/// A device's limits: 10 kHz, a −1…+2 V piezo window, a 921,600-baud link.
fn limits() -> Limits {
    Limits {
        sample_rate_hz: 10_000.0,
        piezo_min_v: -1.0,
        piezo_max_v: 2.0,
        max_multisine_tones: 16,
        prbs_bits_min: 3,
        prbs_bits_max: 31,
        estimators: 0b1111,
        modes: 2,
        link_bytes_per_s: uart_bytes_per_s(921_600) as f32,
    }
}

fn limits_any() -> impl Strategy<Value = Limits> {
    use strategies::f32_bits;
    (
        (f32_bits(), f32_bits(), f32_bits(), f32_bits()),
        any::<[u8; 5]>(),
    )
        .prop_map(|((fs, lo, hi, link), b)| Limits {
            sample_rate_hz: fs,
            piezo_min_v: lo,
            piezo_max_v: hi,
            max_multisine_tones: b[0],
            prbs_bits_min: b[1],
            prbs_bits_max: b[2],
            estimators: b[3],
            modes: b[4],
            link_bytes_per_s: link,
        })
}

/// Another protocol version is reported as such, distinctly, with both
/// numbers, and the frames after it are still decoded.
#[test]
fn version_mismatch_is_reported_distinctly() {
    let mut buf = [0u8; MAX_ENCODED_LEN];
    let future = Header {
        version: VERSION + 1,
        ..Header::new(Kind::Estimate, 0)
    };
    let n = encode_raw(&future, &[1, 2, 3], &mut buf).unwrap();
    let mut bytes = buf[..n].to_vec();
    bytes.extend(encode_vec(&ack(5), 1));
    let mut d = Dec::new();
    let r: Vec<_> = d.feed(&bytes).collect();
    let e = r[0].clone().unwrap_err();
    assert_eq!(
        e,
        DecodeError::VersionMismatch {
            got: VERSION + 1,
            expected: VERSION
        }
    );
    assert_eq!(
        e.to_string(),
        format!(
            "protocol version mismatch: the peer speaks version {}, this build {}",
            VERSION + 1,
            VERSION
        )
    );
    assert_eq!(r[1].as_ref().unwrap().message, ack(5));
    assert_eq!(d.counters().version_mismatches, 1);
    assert_eq!(d.counters().malformed + d.counters().crc_errors, 0);
}

/// A rejected command maps to a negative acknowledgement that carries the
/// command frame's sequence number and the reason code, on the wire.
#[test]
fn rejected_command_gets_a_negative_ack() {
    let mut buf = [0u8; MAX_ENCODED_LEN];
    let bad = Command::SetExcitation(beam_protocol::Excitation {
        amplitude_v: 5.0,
        ..Default::default()
    });
    // Host → device.
    let n = encode(&bad, 41, &mut buf).unwrap();
    let mut device_rx = Decoder::<{ beam_protocol::budget::MAX_COMMAND_ENCODED_LEN }>::new();
    let frame = device_rx.feed(&buf[..n]).next().unwrap().unwrap();
    let Message::Command(cmd) = frame.message else {
        panic!("not a command")
    };
    let result: AckResult = cmd.validate(&limits()).into();
    // Device → host.
    let reply = Ack {
        command_seq: frame.seq,
        result,
    };
    let n = encode(&reply, 0, &mut buf).unwrap();
    let got = Dec::new().feed(&buf[..n]).next().unwrap().unwrap();
    assert_eq!(
        got.message,
        Message::Ack(Ack {
            command_seq: 41,
            result: AckResult::Rejected(beam_protocol::RejectReason::SafeWindow)
        })
    );
}

/// x^n mod G(x) for n = 0..bits, G the CRC-32 polynomial 0x04C11DB7: an
/// error pattern with bits at positions {n} of a codeword goes undetected
/// iff the XOR of its remainders is 0 (init, reflection and xorout do not
/// change which patterns a CRC of fixed-length frames misses).
fn remainders(bits: usize) -> Vec<u32> {
    let mut r = 1u32;
    (0..bits)
        .map(|_| {
            let out = r;
            r = (r << 1) ^ if r & 0x8000_0000 != 0 { 0x04C1_1DB7 } else { 0 };
            out
        })
        .collect()
}

/// Every error of 1, 2 or 3 bits in the longest frame (538 bytes, CRC
/// included) is detected: Hamming distance ≥ 4, as docs/PROTOCOL.md states.
#[test]
fn crc_detects_every_3_bit_error_in_the_longest_frame() {
    let n = beam_protocol::MAX_FRAME_LEN * 8;
    let r = remainders(n);
    let set: std::collections::HashSet<u32> = r.iter().copied().collect();
    assert_eq!(set.len(), n, "2-bit errors: remainders distinct");
    assert!(!set.contains(&0), "1-bit errors");
    for i in 0..n {
        for j in i + 1..n {
            assert!(!set.contains(&(r[i] ^ r[j])), "3-bit error {i} {j}");
        }
    }
}

/// Every 4-bit error is detected up to 2,974 data bits (371 bytes: every
/// frame but a raw-sample block), and not beyond: Koopman's figure for this
/// polynomial, which docs/PROTOCOL.md quotes.
#[test]
fn crc_detects_every_4_bit_error_up_to_2974_data_bits() {
    // An undetected 4-bit pattern {i, j, k, l} is two disjoint pairs with
    // equal r_i ^ r_j; pairs sharing a bit cannot collide (distinct r).
    let has_4_bit_blind_spot = |data_bits: usize| {
        let r = remainders(data_bits + 32);
        let mut x: Vec<u32> = Vec::with_capacity(r.len() * r.len() / 2);
        for i in 0..r.len() {
            for j in i + 1..r.len() {
                x.push(r[i] ^ r[j]);
            }
        }
        x.sort_unstable();
        x.windows(2).any(|w| w[0] == w[1])
    };
    assert!(!has_4_bit_blind_spot(2974));
    assert!(has_4_bit_blind_spot(2975));
}
