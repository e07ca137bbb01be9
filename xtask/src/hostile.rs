//! `cargo xtask qemu --hostile` and `cargo xtask soak`: hostile input at
//! the device end. The QEMU image runs with UART0 on a loopback socket; the
//! host writes into UART0 RX, at the link's full rate (92,160 B/s of the
//! device's time: 921,600 baud, 8N1, paced on the sample index of the
//! estimates it receives), a seeded random mix of
//!
//! * random bytes (delimiters included),
//! * truncated command frames (a valid frame cut short, then `00`),
//! * oversize frames (38–300 non-zero bytes: longer than any command),
//! * frames with a valid CRC and a random payload (an undefined command
//!   index; or a defined one with random bytes after it),
//! * intact frames the device must refuse: another protocol version, a
//!   device → host kind,
//! * valid commands out of range (each of §5's checks: a 20 V amplitude, a
//!   frequency above Nyquist, 0 or 17 tones, a PRBS register of 1 or 25,
//!   a reversed chirp, a gain of 0, λ ≥ π·f_s, the robust estimator on the
//!   default image, a telemetry rate above f_s, …) and status requests,
//!
//! each segment ending with a delimiter. The host runs the device's own
//! command decoder (`Decoder::push_command`, its buffer the device's) over
//! the same bytes as the reference, and checks each structured segment's
//! verdict against what it was built to be (a truncated frame is one
//! framing or CRC error, an oversize one an oversize error, a random
//! payload malformed, …). A random segment that would decode as a command
//! the device accepts is drawn again (the test must not change the
//! device's settings at random).
//!
//! `soak` (10 simulated minutes by default) adds, every 20 s of device
//! time, valid commands that change the device: the excitation's
//! amplitude, a new estimator (`SetEstimator`, automatic λ), `Freeze` and
//! `Resume`, a `SelfTest`, the amplitude back.
//!
//! Pass: QEMU exits 0 (no panic: the image's panic handler exits 1); the
//! firmware's run judged as the plain run's ([`crate::rig_report::judge`]:
//! estimates within 1e-3 of the truth at the end, no overrun, the fault
//! schedule's counters, the self-tests passed); no byte lost on the UART
//! (the device decoded exactly the bytes sent, its RX ring never full, no
//! receive overrun); the device's counters equal the reference's: frames
//! refused (Status `rx_frame_errors`, read after the hostile input
//! stops), commands accepted and rejected; every valid command answered by
//! exactly one Ack with the expected verdict; the device's own stream
//! clean (no gap, no CRC error).

use std::collections::HashMap;
use std::io::{self, Write};
use std::net::TcpStream;
use std::path::Path;
use std::time::Duration;

use beam_protocol::budget::MAX_COMMAND_ENCODED_LEN;
use beam_protocol::{
    encode, encode_raw, AckResult, Command, DecodeError, Decoder, EstimatorKind, EstimatorSettings,
    Excitation, Header, Kind, Limits, Message, SelfTestReport, Status, StatusFlags, TelemetryRates,
    Waveform, MAX_ENCODED_LEN,
};
use beamest::bench;

use crate::e2e::Tally;
use crate::emulator::{session, LinkHost};
use crate::QEMU;

/// Bytes per sample at 921,600 baud (8N1) and 10 kHz: 9.216.
const BYTES_PER_SAMPLE: f64 = 92_160.0 / 10_000.0;
/// The hostile input stops this many samples before the end (1.5 s), then
/// the host asks for the counters.
const QUIET_BEFORE_END: u64 = 15_000;
/// The period of the soak's command cycle (samples: 20 s).
const SOAK_CYCLE: u64 = 200_000;
/// The soak's last cycle starts at least this long before the end (20 s).
const SOAK_LAST: u64 = 200_000;
/// Estimates vs the truth at the end.
const TOLERANCE: f64 = 1e-3;
/// Bytes sent and not yet known consumed by the device (the end of the
/// last command it answered): 10 ms of the line. QEMU's UART model takes
/// one byte per pass of its main loop, slower than the line on this
/// machine; the window keeps its backlog to what the line would deliver
/// while the device's thread mode is busy, so the test runs at the rate
/// QEMU delivers (reported) and never more than the line's.
const WINDOW: u64 = 920;

/// What a run does.
#[derive(Debug, Clone, Copy)]
pub struct Options {
    /// Simulated seconds.
    pub seconds: u64,
    /// The soak's periodic commands.
    pub schedule: bool,
    /// The generator's seed.
    pub seed: u64,
}

/// SplitMix64: a small, seeded generator (the same bytes every run).
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    /// Uniform in 0..n.
    fn below(&mut self, n: u64) -> u64 {
        self.next() % n.max(1)
    }
    fn byte(&mut self) -> u8 {
        self.next() as u8
    }
    fn nonzero(&mut self) -> u8 {
        (self.below(255) + 1) as u8
    }
    fn f32(&mut self, lo: f32, hi: f32) -> f32 {
        lo + (hi - lo) * (self.below(1 << 24) as f32 / (1 << 24) as f32)
    }
}

/// What a segment was built to be, and so what the reference decoder must
/// make of it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Class {
    /// Random bytes: whatever the decoder makes of them (none accepted).
    Random,
    /// One framing or CRC error.
    Truncated,
    /// One oversize error.
    Oversize,
    /// One malformed frame (payload, kind).
    Malformed,
    /// One version mismatch.
    Version,
    /// One valid command, refused by the device's checks.
    OutOfRange,
    /// One valid command the device accepts without a change
    /// (`RequestStatus`).
    Harmless,
    /// One valid command of the soak's schedule.
    Scheduled,
}

/// The device's limits, as the host knows them (the bench's).
fn limits() -> Limits {
    bench::link_limits(921_600)
}

/// A valid command that the device's checks refuse (each of PROTOCOL.md
/// §5's reasons that the default image can give).
fn out_of_range(rng: &mut Rng) -> Command {
    let square = |f: f32, a: f32| Excitation {
        waveform: Waveform::Square { freq_hz: f },
        amplitude_v: a,
        offset_v: 0.0,
    };
    let est = EstimatorSettings::default();
    match rng.below(14) {
        0 => Command::SetExcitation(square(7.0, rng.f32(10.5, 1e3))),
        1 => Command::SetExcitation(square(7.0, -rng.f32(1e-3, 5.0))),
        2 => Command::SetExcitation(square(rng.f32(5_000.0, 1e6), 0.1)),
        3 => Command::SetExcitation(square(f32::NAN, 0.1)),
        4 => Command::SetExcitation(Excitation {
            waveform: Waveform::Multisine {
                f_min_hz: 2.0,
                f_max_hz: 80.0,
                tones: if rng.below(2) == 0 {
                    0
                } else {
                    17 + rng.byte() % 200
                },
            },
            amplitude_v: 0.1,
            offset_v: 0.0,
        }),
        5 => Command::SetExcitation(Excitation {
            waveform: Waveform::Prbs {
                bit_rate_hz: 500.0,
                register_bits: if rng.below(2) == 0 {
                    1
                } else {
                    25 + rng.byte() % 100
                },
            },
            amplitude_v: 0.1,
            offset_v: 0.0,
        }),
        6 => Command::SetExcitation(Excitation {
            waveform: Waveform::Chirp {
                f_start_hz: 100.0,
                f_end_hz: rng.f32(1.0, 99.0),
                sweep_s: 1.0,
            },
            amplitude_v: 0.1,
            offset_v: 0.0,
        }),
        7 => Command::SetEstimator(EstimatorSettings { gain: 0.0, ..est }),
        8 => Command::SetEstimator(EstimatorSettings {
            forgetting_p: -rng.f32(0.0, 1.0),
            ..est
        }),
        9 => Command::SetEstimator(EstimatorSettings {
            lambda_rad_s: Some(rng.f32(31_416.0, 1e6)),
            ..est
        }),
        // The QEMU image has the adaptive law and the robust estimator.
        10 => Command::SetEstimator(EstimatorSettings {
            kind: EstimatorKind::Gradient,
            ..est
        }),
        11 => Command::SetTelemetry(TelemetryRates {
            estimate_rate_hz: rng.f32(10_001.0, 1e6),
            ..TelemetryRates::default()
        }),
        12 => Command::SetTelemetry(TelemetryRates {
            estimate_rate_hz: 100.0,
            raw_decimation: 1,
            status_rate_hz: 1.0,
        }),
        _ => Command::SetExcitation(Excitation {
            waveform: Waveform::Chirp {
                f_start_hz: 1.0,
                f_end_hz: 100.0,
                sweep_s: rng.f32(0.0, 1.5e-4),
            },
            amplitude_v: 0.1,
            offset_v: 0.0,
        }),
    }
}

/// The host (see the module doc).
struct Host {
    opts: Options,
    rng: Rng,
    /// The device → host stream.
    dec: Decoder,
    tally: Tally,
    /// The device's command decoder, fed the bytes sent.
    reference: Decoder<MAX_COMMAND_ENCODED_LEN>,
    seq: u32,
    sent_bytes: u64,
    /// Device time: the newest sample index seen, and the first (the
    /// byte budget counts from there).
    now: u64,
    start: Option<u64>,
    /// Valid commands sent, by seq: the command, its expected verdict
    /// (`None`: refused, any reason) and the byte offset of its end in the
    /// stream sent.
    pending: HashMap<u32, (Command, Option<AckResult>, u64)>,
    /// The device has consumed the stream up to this offset (the end of
    /// the latest command it answered).
    consumed: u64,
    /// Acks received per seq.
    acked: HashMap<u32, u32>,
    accepted: u64,
    rejected: u64,
    segments: HashMap<&'static str, u64>,
    /// Segment verdicts that were not what the segment was built to be.
    class_errors: Vec<String>,
    redrawn: u64,
    /// The soak's schedule: next cycle start and step.
    next_cycle: u64,
    step: u64,
    /// The final RequestStatus's seq, and the Status after its Ack.
    final_request: Option<u32>,
    final_acked: bool,
    final_status: Option<Status>,
    last_valid: Option<beam_protocol::Estimate>,
    reports: Vec<SelfTestReport>,
    failures: Vec<String>,
}

impl Host {
    fn new(opts: Options) -> Self {
        Self {
            opts,
            rng: Rng(opts.seed),
            dec: Decoder::new(),
            tally: Tally::default(),
            reference: Decoder::new(),
            seq: 0,
            sent_bytes: 0,
            now: 0,
            start: None,
            pending: HashMap::new(),
            consumed: 0,
            acked: HashMap::new(),
            accepted: 0,
            rejected: 0,
            segments: HashMap::new(),
            class_errors: Vec::new(),
            redrawn: 0,
            next_cycle: SOAK_CYCLE,
            step: 0,
            final_request: None,
            final_acked: false,
            final_status: None,
            last_valid: None,
            reports: Vec::new(),
            failures: Vec::new(),
        }
    }

    fn end(&self) -> u64 {
        self.opts.seconds * 10_000
    }

    /// The encoded frame of `c` at the next sequence number.
    fn command_frame(&mut self, c: &Command) -> (u32, Vec<u8>) {
        let mut out = [0u8; MAX_ENCODED_LEN];
        let n = encode(c, self.seq, &mut out).unwrap_or(0);
        let seq = self.seq;
        self.seq = self.seq.wrapping_add(1);
        (seq, out[..n].to_vec())
    }

    /// One hostile segment: its bytes (ending with a delimiter) and class.
    fn segment(&mut self) -> (Vec<u8>, Class, Option<(u32, Command)>) {
        let draw = self.rng.below(100);
        let rng = &mut self.rng;
        match draw {
            0..=29 => {
                let n = 1 + rng.below(64) as usize;
                let mut v: Vec<u8> = (0..n)
                    .map(|_| if rng.below(16) == 0 { 0 } else { rng.byte() })
                    .collect();
                v.push(0);
                (v, Class::Random, None)
            }
            30..=44 => {
                let c = out_of_range(&mut self.rng);
                let (_, mut v) = self.command_frame(&c);
                // Without its delimiter, cut to 1 … len − 1 bytes.
                v.pop();
                let keep = 1 + self.rng.below(v.len() as u64 - 1) as usize;
                v.truncate(keep);
                v.push(0);
                (v, Class::Truncated, None)
            }
            45..=54 => {
                // Longer than the device's decoder buffer (37 bytes).
                let n = MAX_COMMAND_ENCODED_LEN + 1 + rng.below(263) as usize;
                let mut v: Vec<u8> = (0..n).map(|_| rng.nonzero()).collect();
                v.push(0);
                (v, Class::Oversize, None)
            }
            55..=74 => {
                // A valid CRC around a random payload: an undefined command
                // index (8 or more, or a varint of one), or a defined one
                // followed by random bytes.
                let len = 1 + rng.below(22) as usize;
                let mut p: Vec<u8> = (0..len).map(|_| rng.byte()).collect();
                if rng.below(2) == 0 {
                    p[0] = 8 + (rng.byte() % 248);
                } else {
                    p[0] = rng.byte() % 8;
                }
                let h = Header::new(Kind::Command, rng.next() as u32);
                let mut out = [0u8; MAX_ENCODED_LEN];
                let n = encode_raw(&h, &p, &mut out).unwrap_or(0);
                (out[..n].to_vec(), Class::Malformed, None)
            }
            75..=82 => {
                let (kind, version) = match rng.below(3) {
                    0 => (Kind::Command, beam_protocol::VERSION - 1),
                    1 => (Kind::Command, beam_protocol::VERSION + 1),
                    _ => (Kind::Estimate, beam_protocol::VERSION),
                };
                let h = Header {
                    version,
                    ..Header::new(kind, rng.next() as u32)
                };
                let p: Vec<u8> = (0..rng.below(20)).map(|_| rng.byte()).collect();
                let mut out = [0u8; MAX_ENCODED_LEN];
                let n = encode_raw(&h, &p, &mut out).unwrap_or(0);
                let class = if version == beam_protocol::VERSION {
                    Class::Malformed
                } else {
                    Class::Version
                };
                (out[..n].to_vec(), class, None)
            }
            83..=95 => {
                let c = out_of_range(&mut self.rng);
                let (seq, v) = self.command_frame(&c);
                (v, Class::OutOfRange, Some((seq, c)))
            }
            _ => {
                let c = Command::RequestStatus;
                let (seq, v) = self.command_frame(&c);
                (v, Class::Harmless, Some((seq, c)))
            }
        }
    }

    /// Does the reference decoder's verdict on `bytes` fit `class`? The
    /// decoder after them, the commands they decoded to.
    fn judge_segment(
        &self,
        bytes: &[u8],
        class: Class,
    ) -> (
        Decoder<MAX_COMMAND_ENCODED_LEN>,
        Vec<(u32, Command)>,
        Result<(), String>,
    ) {
        let mut d = self.reference.clone();
        let before = *d.counters();
        let results: Vec<Result<(u32, Command), DecodeError>> =
            bytes.iter().filter_map(|&b| d.push_command(b)).collect();
        let after = *d.counters();
        let commands: Vec<(u32, Command)> = results
            .iter()
            .filter_map(|r| r.as_ref().ok().copied())
            .collect();
        let errors: Vec<DecodeError> = results.iter().filter_map(|r| r.err()).collect();
        let one_error = |ok: &dyn Fn(&DecodeError) -> bool| {
            commands.is_empty() && errors.len() == 1 && errors.iter().all(ok)
        };
        let fits = match class {
            Class::Random => true,
            Class::Truncated => one_error(&|e| {
                matches!(
                    e,
                    DecodeError::Cobs | DecodeError::TooShort | DecodeError::Crc
                )
            }),
            Class::Oversize => one_error(&|e| *e == DecodeError::Oversize),
            Class::Malformed => {
                one_error(&|e| matches!(e, DecodeError::Payload | DecodeError::UnknownKind(_)))
            }
            Class::Version => one_error(&|e| matches!(e, DecodeError::VersionMismatch { .. })),
            Class::OutOfRange | Class::Harmless | Class::Scheduled => {
                errors.is_empty() && commands.len() == 1
            }
        };
        // Every error is counted once.
        let counted = after.errors() - before.errors() == errors.len() as u64;
        let verdict = if fits && counted {
            Ok(())
        } else {
            Err(format!(
                "{class:?} segment {bytes:02X?}: decoded {commands:?}, errors {errors:?} \
                 (counted {})",
                after.errors() - before.errors()
            ))
        };
        (d, commands, verdict)
    }

    /// The soak's command for this step of the cycle, if due.
    fn scheduled(&mut self) -> Option<Command> {
        if !self.opts.schedule || self.next_cycle + SOAK_LAST > self.end() {
            return None;
        }
        // Steps at 0, 4, 8, 9, 12, 16 s of the cycle.
        const AT: [u64; 6] = [0, 40_000, 80_000, 90_000, 120_000, 160_000];
        let at = self.next_cycle + AT[self.step as usize];
        if self.now < at {
            return None;
        }
        let amplitude = |a: f32| {
            Command::SetExcitation(Excitation {
                waveform: Waveform::Square { freq_hz: 7.0 },
                amplitude_v: a,
                offset_v: 0.0,
            })
        };
        let c = match self.step {
            0 => amplitude(0.15),
            1 => Command::SetEstimator(EstimatorSettings::default()),
            2 => Command::Freeze,
            3 => Command::Resume,
            4 => Command::SelfTest,
            _ => amplitude(0.1),
        };
        self.step += 1;
        if self.step as usize == AT.len() {
            self.step = 0;
            self.next_cycle += SOAK_CYCLE;
        }
        Some(c)
    }

    /// Bytes due by the device's clock: hostile segments up to the link's
    /// rate, the schedule's commands, the final status request.
    fn send_due(&mut self, link: &mut TcpStream) -> io::Result<()> {
        let mut out = Vec::new();
        if let Some(c) = self.scheduled() {
            let (seq, v) = self.command_frame(&c);
            let end = self.sent_bytes + v.len() as u64;
            self.commit(
                &v,
                Class::Scheduled,
                Some((seq, c)),
                Some(AckResult::Accepted),
                end,
            );
            out.extend(v);
        }
        let hostile_until = self.end().saturating_sub(QUIET_BEFORE_END);
        let Some(start) = self.start else {
            return Ok(());
        };
        let target =
            (self.now.min(hostile_until).saturating_sub(start) as f64 * BYTES_PER_SAMPLE) as u64;
        let mut last_is_command = true;
        while self.final_request.is_none()
            && self.now < hostile_until
            && self.sent_bytes + (out.len() as u64) < target
            && self.sent_bytes + (out.len() as u64) < self.consumed + WINDOW
        {
            let (bytes, class, cmd) = self.segment();
            let (d, commands, verdict) = self.judge_segment(&bytes, class);
            // A random segment must not decode as a command at all; a
            // command must be refused (or be the harmless one).
            let acceptable = match class {
                Class::Random | Class::Truncated | Class::Oversize | Class::Malformed => {
                    commands.is_empty()
                }
                _ => commands
                    .iter()
                    .all(|(_, c)| *c == Command::RequestStatus || c.validate(&limits()).is_err()),
            };
            if !acceptable {
                self.redrawn += 1;
                continue;
            }
            if let Err(e) = verdict {
                if self.class_errors.len() < 20 {
                    self.class_errors.push(e);
                }
            }
            self.reference = d;
            *self.segments.entry(class_name(class)).or_default() += 1;
            let expect = match class {
                Class::Harmless => Some(AckResult::Accepted),
                _ => None,
            };
            let end = self.sent_bytes + (out.len() + bytes.len()) as u64;
            last_is_command = cmd.is_some();
            if let Some((seq, c)) = cmd {
                self.pending.insert(seq, (c, expect, end));
            }
            out.extend(bytes);
        }
        // The window moves on the device's answers: a burst that ends
        // without a command ends with a status request.
        if !last_is_command {
            let (seq, v) = self.command_frame(&Command::RequestStatus);
            let end = self.sent_bytes + (out.len() + v.len()) as u64;
            self.commit(
                &v,
                Class::Harmless,
                Some((seq, Command::RequestStatus)),
                Some(AckResult::Accepted),
                end,
            );
            out.extend(v);
        }
        if self.final_request.is_none() && self.now >= hostile_until && self.now > 0 {
            let (seq, v) = self.command_frame(&Command::RequestStatus);
            let end = self.sent_bytes + (out.len() + v.len()) as u64;
            self.commit(
                &v,
                Class::Harmless,
                Some((seq, Command::RequestStatus)),
                Some(AckResult::Accepted),
                end,
            );
            self.final_request = Some(seq);
            out.extend(v);
        }
        if out.is_empty() {
            return Ok(());
        }
        self.sent_bytes += out.len() as u64;
        link.write_all(&out)
    }

    /// A frame the host sends on its own (not drawn): into the reference.
    fn commit(
        &mut self,
        bytes: &[u8],
        class: Class,
        cmd: Option<(u32, Command)>,
        expect: Option<AckResult>,
        end: u64,
    ) {
        let (d, _, verdict) = self.judge_segment(bytes, class);
        if let Err(e) = verdict {
            self.class_errors.push(e);
        }
        self.reference = d;
        *self.segments.entry(class_name(class)).or_default() += 1;
        if let Some((seq, c)) = cmd {
            self.pending.insert(seq, (c, expect, end));
        }
    }

    fn on_ack(&mut self, seq: u32, result: AckResult) {
        *self.acked.entry(seq).or_default() += 1;
        match result {
            AckResult::Accepted => self.accepted += 1,
            AckResult::Rejected(_) => self.rejected += 1,
        }
        match self.pending.get(&seq).copied() {
            Some((c, Some(want), _)) if want != result => self.fail(format!(
                "command {seq} ({c:?}) answered {result:?}, expected {want:?}"
            )),
            Some((c, None, _)) if result == AckResult::Accepted => {
                self.fail(format!("out-of-range command {seq} ({c:?}) accepted"))
            }
            None => self.fail(format!("an Ack for command {seq}, never sent as valid")),
            Some(_) => {}
        }
        if let Some((_, _, end)) = self.pending.get(&seq) {
            self.consumed = self.consumed.max(*end);
        }
        if Some(seq) == self.final_request {
            self.final_acked = true;
        }
    }

    fn fail(&mut self, m: String) {
        if self.failures.len() < 50 {
            eprintln!("hostile: FAIL: {m}");
        }
        self.failures.push(m);
    }
}

fn class_name(c: Class) -> &'static str {
    match c {
        Class::Random => "random bytes",
        Class::Truncated => "truncated frames",
        Class::Oversize => "oversize frames",
        Class::Malformed => "valid-CRC frames with random payloads or a device kind",
        Class::Version => "frames of another protocol version",
        Class::OutOfRange => "valid commands out of range",
        Class::Harmless => "status requests",
        Class::Scheduled => "scheduled commands",
    }
}

impl LinkHost for Host {
    fn receive(&mut self, bytes: &[u8], link: &mut TcpStream) -> io::Result<()> {
        let frames: Vec<_> = self.dec.feed(bytes).flatten().collect();
        for f in frames {
            self.tally.count(&f.message);
            match f.message {
                Message::Estimate(e) => {
                    self.now = self.now.max(e.sample_index);
                    if e.flags.contains(StatusFlags::PHYSICALLY_VALID) {
                        self.last_valid = Some(e);
                    }
                }
                Message::Status(s) => {
                    self.now = self.now.max(s.uptime_samples);
                    if self.final_acked && self.final_status.is_none() {
                        self.final_status = Some(s);
                    }
                }
                Message::Ack(a) => self.on_ack(a.command_seq, a.result),
                Message::SelfTestReport(r) => self.reports.push(r),
                Message::RawSamples(_) => {}
                Message::Command(_) => self.fail("the device sent a Command frame".into()),
            }
        }
        if self.start.is_none() && self.now > 0 {
            self.start = Some(self.now);
        }
        self.send_due(link)
    }

    fn fail(&mut self, msg: String) {
        Host::fail(self, msg)
    }
}

/// Run (see the module doc).
pub fn run(elf: &Path, opts: Options, timeout: Duration) -> Result<(), String> {
    let mut host = Host::new(opts);
    let seconds = opts.seconds.to_string();
    let (status, wall, log) = session(elf, Some(&seconds), timeout, &mut host)?;
    let name = if opts.schedule { "soak" } else { "hostile" };
    let hostile_s = (opts.seconds * 10_000)
        .saturating_sub(QUIET_BEFORE_END)
        .saturating_sub(host.start.unwrap_or(0)) as f64
        / 10_000.0;
    println!(
        "\n{name}: {} simulated s in {wall:.1} s wall time; {} bytes sent into UART0 RX over {:.1} \
         s of device time: {:.0} B/s, {:.0} % of the line's 92,160 B/s ({} segments drawn again \
         so as not to decode as a command the device would accept)",
        opts.seconds,
        host.sent_bytes,
        hostile_s,
        host.sent_bytes as f64 / hostile_s,
        100.0 * host.sent_bytes as f64 / hostile_s / 92_160.0,
        host.redrawn
    );
    let mut kinds: Vec<_> = host.segments.iter().collect();
    kinds.sort();
    for (k, n) in kinds {
        println!("{name}: sent {n} {k}");
    }
    let r = *host.reference.counters();
    println!(
        "{name}: the reference decoder: {} frames decoded, {} refused (CRC {}, framing {}, \
         oversize {}, malformed {}, version {})",
        r.frames_ok,
        r.errors(),
        r.crc_errors,
        r.framing_errors,
        r.oversize,
        r.malformed,
        r.version_mismatches
    );
    let mut fails = std::mem::take(&mut host.failures);
    for e in &host.class_errors {
        fails.push(format!("a segment's verdict: {e}"));
    }
    // Every valid command answered exactly once.
    let unanswered: Vec<u32> = host
        .pending
        .keys()
        .filter(|s| host.acked.get(s).copied().unwrap_or(0) == 0)
        .copied()
        .collect();
    let twice = host.acked.values().filter(|&&n| n > 1).count();
    if unanswered.is_empty() && twice == 0 && host.pending.len() as u64 == r.frames_ok {
        println!(
            "{name}: ok: {} valid commands, each answered by one Ack ({} accepted, {} refused)",
            host.pending.len(),
            host.accepted,
            host.rejected
        );
    } else {
        fails.push(format!(
            "commands: {} valid (reference {}), {} unanswered (e.g. {:?}), {twice} answered twice",
            host.pending.len(),
            r.frames_ok,
            unanswered.len(),
            &unanswered[..unanswered.len().min(5)]
        ));
    }
    match &host.final_status {
        Some(s) => {
            let c = &s.counters;
            let ok = u64::from(c.rx_frame_errors) == r.errors()
                && u64::from(c.commands_accepted) == host.accepted
                && u64::from(c.commands_rejected) == host.rejected
                && c.overruns == 0;
            let line = format!(
                "device counters: rx_frame_errors {} (reference {}), commands accepted {} / \
                 rejected {} (Acks {} / {}), overruns {}, telemetry dropped {}",
                c.rx_frame_errors,
                r.errors(),
                c.commands_accepted,
                c.commands_rejected,
                host.accepted,
                host.rejected,
                c.overruns,
                c.telemetry_dropped
            );
            if ok {
                println!("{name}: ok: {line}");
            } else {
                fails.push(line);
            }
        }
        None => fails.push("no Status after the final status request".into()),
    }
    // The firmware's own account of the link at the end.
    let link_line = log
        .lines()
        .find_map(|l| l.trim().strip_prefix("rig: link "));
    match link_line {
        Some(l) => {
            let v = |k: &str| {
                l.split_whitespace()
                    .find_map(|w| w.strip_prefix(k)?.strip_prefix('='))
                    .and_then(|x| x.parse::<u64>().ok())
            };
            let ok = v("rx_bytes") == Some(host.sent_bytes)
                && v("rx_errors") == Some(r.errors())
                && v("rx_frames") == Some(r.frames_ok)
                && v("uart_rx_dropped") == Some(0)
                && v("uart_rx_overruns") == Some(0)
                && v("uart_tx_dropped") == Some(0)
                && v("tx_dropped_frames") == Some(0);
            if ok {
                println!(
                    "{name}: ok: the device decoded all {} bytes sent ({} frames, {} refused); \
                     no byte lost in the UART's rings, no receive overrun, no frame dropped",
                    host.sent_bytes,
                    r.frames_ok,
                    r.errors()
                );
            } else {
                fails.push(format!(
                    "the device's link: {l} (host: {} bytes sent, reference {} frames / {} errors)",
                    host.sent_bytes,
                    r.frames_ok,
                    r.errors()
                ));
            }
        }
        None => fails.push("no `rig: link` line in the firmware's log".into()),
    }
    let c = &host.tally;
    let stream = *host.dec.counters();
    if stream.errors() == 0
        && stream.lost == 0
        && stream.duplicates == 0
        && c.meaning_violations == 0
    {
        println!(
            "{name}: ok: the device's stream: {} frames, no gap, no error, every estimate means \
             what PROTOCOL.md says",
            stream.frames_ok
        );
    } else {
        fails.push(format!("the device's stream: {stream:?}, {c:?}"));
    }
    match &host.last_valid {
        Some(e) if e.sample_index + 20_000 >= opts.seconds * 10_000 => {
            let worst = e
                .modes
                .iter()
                .zip(
                    beamest::model::PAPER_OMEGA
                        .iter()
                        .zip(beamest::model::PAPER_ZETA.iter()),
                )
                .map(|(m, (w, z))| {
                    (f64::from(m.omega_rad_s) / w - 1.0)
                        .abs()
                        .max((f64::from(m.zeta) / z - 1.0).abs())
                })
                .fold(0.0f64, f64::max);
            if e.modes.len() == 2 && worst <= TOLERANCE {
                println!(
                    "{name}: ok: the last valid estimate (t = {:.2} s) within {worst:.1e} of the \
                     truth",
                    e.sample_index as f64 * 1e-4
                );
            } else {
                fails.push(format!(
                    "the last valid estimate is {worst:.1e} off the truth"
                ));
            }
        }
        e => fails.push(format!(
            "no valid estimate near the end (last at {:?})",
            e.as_ref().map(|e| e.sample_index)
        )),
    }
    let expected_tests = 1 + if opts.schedule {
        ((opts.seconds * 10_000).saturating_sub(SOAK_LAST) / SOAK_CYCLE) as usize
    } else {
        0
    };
    if host.reports.len() == expected_tests && host.reports.iter().all(SelfTestReport::passed) {
        println!(
            "{name}: ok: {} self-test report(s), every check passed",
            host.reports.len()
        );
    } else {
        fails.push(format!(
            "self-tests: {} reports (expected {expected_tests}), {} passed",
            host.reports.len(),
            host.reports.iter().filter(|r| r.passed()).count()
        ));
    }
    if let Err(f) = crate::rig_report::judge(&log) {
        for f in f {
            fails.push(format!("the run (firmware's measurements): {f}"));
        }
    }
    if !status.success() {
        fails.push(format!("{QEMU} exited with {status} (a panic exits 1)"));
    }
    if fails.is_empty() {
        println!("{name}: PASS");
        Ok(())
    } else {
        Err(format!("{name} failed:\n  {}", fails.join("\n  ")))
    }
}
