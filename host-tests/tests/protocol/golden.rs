//! Golden vectors: the exact bytes of one frame of each kind, pinned here
//! and shown in `docs/PROTOCOL.md`, and the document's link-budget table;
//! the tests check that the document holds exactly the text generated here.
//! Print it with `cargo test -p host-tests --test protocol golden -- --nocapture`.

use std::fmt::Write as _;

use beam_protocol::budget::{
    encoded_len_max, estimate_payload_max, min_raw_decimation, raw_bytes_per_sample,
    uart_bytes_per_s, LinkLoad, RAW_PAYLOAD_MAX, STATUS_PAYLOAD_MAX,
};
use beam_protocol::{
    encode, Ack, AckResult, AdcCheck, Command, DeviceCounters, DrdyCheck, Estimate, EstimatorKind,
    EstimatorSettings, Excitation, FirmwareVersion, LoopbackCheck, Message, ModeEstimate,
    NoiseCheck, OutputKind, RawSamples, RejectReason, SelfTestChecks, SelfTestReport,
    SelfTestState, Status, StatusFlags, TelemetryRates, UySample, Waveform, CRC_LEN, HEADER_LEN,
    MAX_ENCODED_LEN,
};
use beamest::modal::modal_from_theta;
use beamest::model::paper_plant_tf;

const DOC: &str = include_str!("../../../docs/PROTOCOL.md");

/// The estimate of the golden frame: the paper's plant after one hour at
/// 10 kHz, Θ for λ = 100 rad/s rounded to `f32`.
fn golden_estimate() -> Estimate {
    Estimate {
        sample_index: 36_000_000,
        estimator: EstimatorKind::Adaptive,
        flags: StatusFlags::EXCITED
            .with(StatusFlags::CONVERGED)
            .with(StatusFlags::PHYSICALLY_VALID),
        modes: [
            ModeEstimate {
                omega_rad_s: 39.1533,
                zeta: 0.0207,
                b_bar: 9.6293,
            },
            ModeEstimate {
                omega_rad_s: 245.3711,
                zeta: 0.13,
                b_bar: 16.1458,
            },
        ]
        .into_iter()
        .collect(),
        lambda_rad_s: 100.0,
        theta: [
            13.02,
            -1180.0,
            -1_110_000.0,
            334.58257,
            -1843.3683,
            3_804_609.0,
            7_703_854.5,
        ]
        .into_iter()
        .collect(),
        excitation_level: Some(2.5e-3),
    }
}

/// The golden frames: (title, message, sequence number).
fn golden() -> Vec<(&'static str, Message, u32)> {
    let status = Status {
        uptime_samples: 36_000_000,
        sample_rate_hz: 10_000.0,
        firmware: FirmwareVersion {
            major: 0,
            minor: 1,
            patch: 0,
        },
        modes: 2,
        counters: DeviceCounters {
            adc_crc_errors: 3,
            rejected_samples: 3,
            commands_accepted: 2,
            commands_rejected: 1,
            ..DeviceCounters::default()
        },
        adaptation_frozen: false,
        excitation: Excitation::default(),
        estimator: EstimatorSettings {
            lambda_rad_s: Some(100.0),
            ..EstimatorSettings::default()
        },
        telemetry: TelemetryRates::default(),
        lambda_automatic: false,
        self_test: SelfTestState::Done {
            failed: SelfTestChecks::default(),
            not_measured: SelfTestChecks::default(),
        },
    };
    vec![
        ("Estimate", golden_estimate().into(), 360_000),
        (
            "RawSamples",
            RawSamples {
                first_sample_index: 36_000_000,
                decimation: 1,
                samples: [(0.1, 1.2e-3), (0.1, 1.25e-3), (-0.1, 1.3e-3)]
                    .into_iter()
                    .map(|(u_v, y)| UySample { u_v, y })
                    .collect(),
            }
            .into(),
            360_001,
        ),
        ("Status", status.into(), 360_002),
        (
            "Ack (accepted)",
            Ack {
                command_seq: 7,
                result: AckResult::Accepted,
            }
            .into(),
            360_003,
        ),
        (
            "Ack (rejected: SafeWindow)",
            Ack {
                command_seq: 8,
                result: AckResult::Rejected(RejectReason::SafeWindow),
            }
            .into(),
            360_004,
        ),
        (
            "Command::SetExcitation (chirp)",
            Command::SetExcitation(Excitation {
                waveform: Waveform::Chirp {
                    f_start_hz: 1.0,
                    f_end_hz: 100.0,
                    sweep_s: 10.0,
                },
                amplitude_v: 0.2,
                offset_v: 0.5,
            })
            .into(),
            7,
        ),
        (
            "Command::SetEstimator",
            Command::SetEstimator(EstimatorSettings {
                lambda_rad_s: Some(100.0),
                output: OutputKind::Acceleration,
                ..EstimatorSettings::default()
            })
            .into(),
            8,
        ),
        (
            "Command::SetTelemetry",
            Command::SetTelemetry(TelemetryRates {
                estimate_rate_hz: 100.0,
                raw_decimation: 2,
                status_rate_hz: 1.0,
            })
            .into(),
            9,
        ),
        ("SelfTestReport", golden_report().into(), 360_005),
        ("Command::Freeze", Command::Freeze.into(), 10),
        ("Command::SelfTest", Command::SelfTest.into(), 11),
    ]
}

/// The report of the golden frame: the QEMU image's self-test at start-up
/// with the bench's noise fault (`cargo xtask qemu --selftest-faults`),
/// its values rounded: NOISE failed, every other check passed.
fn golden_report() -> SelfTestReport {
    SelfTestReport {
        first_sample: 0,
        last_sample: 6_687,
        at_boot: true,
        failed: SelfTestChecks::NOISE,
        not_measured: SelfTestChecks::default(),
        adc: AdcCheck {
            id: 0x2200,
            registers: [0x1110, 0x0306, 0x0007],
            expected: [0x1110, 0x0306, 0x0007],
        },
        drdy: DrdyCheck {
            rate_hz: 10_000.0,
            expected_hz: 10_000.0,
            tolerance: 1e-4,
            conversions: 6_688,
            ticks: 6_688,
        },
        loopback: LoopbackCheck {
            tone_hz: 48.828125,
            amplitude_v: 1.0,
            gain: 0.99984,
            expected_gain: 1.0,
            gain_tolerance: 0.05,
            offset_v: 0.0,
            offset_tolerance_v: 0.02,
            delay_samples: 2.15,
            expected_delay_samples: 2.15,
            delay_tolerance_samples: 0.02,
        },
        noise: NoiseCheck {
            noise_sd: 1.954e-5,
            floor_sd: 1.124e-8,
            signal_rms: 2.343e-3,
            snr_db: 41.58,
            snr_min_db: 60.0,
            excitation: Excitation::default(),
        },
    }
}

/// Pinned wire bytes of each golden frame (in `golden()` order).
const PINNED: &[&str] = &[
    "08 57 BE 03 01 40 7E 05 05 80 A2 95 11 0F 19 02 FB 9C 1C 42 0C 93 A9 3C 9D 11 1A 41 0C 5F 75 43 B8 1E 05 3E 99 2A 81 41 01 08 C8 42 07 EC 51 50 41 21 80 93 C4 80 7F 87 C9 92 4A A7 43 C9 6B E6 C4 04 37 68 4A 5D 1A EB 4A 01 0A D7 23 3B 4F 13 FA B1 00",
    "08 57 BE 03 02 41 7E 05 23 80 A2 95 11 01 03 CD CC CC 3D 52 49 9D 3A CD CC CC 3D 0A D7 A3 3A CD CC CC BD C3 64 AA 3A 65 34 C3 EC 00",
    "08 57 BE 03 03 42 7E 05 05 80 A2 95 11 04 40 1C 46 02 01 02 02 02 03 01 01 01 02 03 03 02 01 01 02 01 01 07 E0 40 CD CC CC 3D 01 01 01 01 01 11 40 1C 46 CD CC 4C 3D CD CC 4C 3D 28 6B 6E 4E 01 01 03 C8 42 01 01 03 C8 42 01 01 03 80 3F 02 02 01 05 86 04 E4 1F 00",
    "08 57 BE 03 04 43 7E 05 02 07 05 21 8D 95 F5 00",
    "08 57 BE 03 04 44 7E 05 07 08 03 EC F0 01 F6 00",
    "06 57 BE 03 80 07 01 01 01 02 04 01 03 80 3F 01 03 C8 42 01 07 20 41 CD CC 4C 3E 01 01 06 3F 9A 82 30 C8 00",
    "06 57 BE 03 80 08 01 01 02 01 01 11 40 1C 46 CD CC 4C 3D CD CC 4C 3D 28 6B 6E 4E 01 01 08 C8 42 02 58 E7 5A 7E 00",
    "06 57 BE 03 80 09 01 01 02 02 01 04 C8 42 02 01 07 80 3F 01 86 EA 57 00",
    "08 57 BE 03 05 45 7E 05 01 05 9F 34 01 10 0D 80 44 90 22 86 06 07 90 22 86 06 07 04 40 1C 46 0C 40 1C 46 17 B7 D1 38 A0 34 A0 34 04 50 43 42 01 07 80 3F 84 F5 7F 3F 01 07 80 3F CD CC 4C 3D 01 01 01 21 0A D7 A3 3C 9A 99 09 40 9A 99 09 40 0A D7 A3 3C D5 E9 A3 37 0B 1A 41 32 04 8D 19 3B EC 51 26 42 01 04 70 42 01 01 07 E0 40 CD CC CC 3D 01 01 01 05 2B 8D 2D 27 00",
    "06 57 BE 03 80 0A 01 01 06 04 79 2E C3 51 00",
    "06 57 BE 03 80 0B 01 01 06 07 73 56 AA F5 00",
];

fn hex(bytes: &[u8]) -> String {
    bytes
        .iter()
        .map(|b| format!("{b:02X}"))
        .collect::<Vec<_>>()
        .join(" ")
}

/// `label` then the bytes, 16 per line, continuation lines indented.
fn rows(out: &mut String, label: &str, bytes: &[u8]) {
    for (i, chunk) in bytes.chunks(16).enumerate() {
        let l = if i == 0 { label } else { "" };
        writeln!(out, "{l:<9}{}", hex(chunk)).unwrap();
    }
    if bytes.is_empty() {
        writeln!(out, "{label:<9}(none)").unwrap();
    }
}

/// The document's text block for one frame, and its wire bytes.
fn block(title: &str, msg: &Message, seq: u32) -> (String, Vec<u8>) {
    let mut buf = [0u8; MAX_ENCODED_LEN];
    let n = encode(msg, seq, &mut buf).unwrap();
    let wire = buf[..n].to_vec();
    let raw = independent::unstuff(&wire).unwrap();
    let raw_len = raw.len();
    let mut s = String::new();
    writeln!(
        s,
        "{title}, seq {seq}: {raw_len} bytes before COBS, {n} on the wire"
    )
    .unwrap();
    rows(&mut s, "header", &raw[..HEADER_LEN]);
    rows(&mut s, "payload", &raw[HEADER_LEN..raw_len - CRC_LEN]);
    rows(&mut s, "crc", &raw[raw_len - CRC_LEN..]);
    rows(&mut s, "wire", &wire);
    (s, wire)
}

#[test]
fn golden_frames_are_pinned_and_documented() {
    let blocks: Vec<_> = golden()
        .iter()
        .map(|(title, msg, seq)| (*title, block(title, msg, *seq)))
        .collect();
    for (_, (text, _)) in &blocks {
        println!("```text\n{text}```\n");
    }
    let wires: Vec<String> = blocks.iter().map(|(_, (_, w))| hex(w)).collect();
    assert_eq!(wires, PINNED, "the bytes of a golden frame changed");
    let missing: Vec<_> = blocks
        .iter()
        .filter(|(_, (text, _))| !DOC.contains(text.as_str()))
        .map(|(title, _)| *title)
        .collect();
    assert!(
        missing.is_empty(),
        "docs/PROTOCOL.md lacks the blocks of {missing:?}"
    );
}

/// The link-budget table of the document, from the frame sizes.
fn budget_table() -> String {
    let fs = 10_000.0;
    let link = uart_bytes_per_s(921_600) as f32;
    let est = encoded_len_max(estimate_payload_max(2));
    let status = encoded_len_max(STATUS_PAYLOAD_MAX);
    let raw = encoded_len_max(RAW_PAYLOAD_MAX);
    let typical = {
        let mut buf = [0u8; MAX_ENCODED_LEN];
        encode(&golden_estimate(), 360_000, &mut buf).unwrap()
    };
    let defaults = TelemetryRates::default();
    let load = LinkLoad::new(&defaults, fs, 2);
    let d = min_raw_decimation(&defaults, fs, 2, link).unwrap();
    let with_raw = LinkLoad::new(
        &TelemetryRates {
            raw_decimation: d,
            ..defaults
        },
        fs,
        2,
    );
    let raw_alone = TelemetryRates {
        estimate_rate_hz: 0.0,
        raw_decimation: 1,
        status_rate_hz: 0.0,
    };
    let raw_10k = LinkLoad::new(&raw_alone, fs, 2).total_b_s();
    let est_room = (link - raw_10k - load.status_b_s) / est as f32;
    let pct = |b: f32| 100.0 * b / link;
    let mut s = String::new();
    writeln!(s, "| quantity | value |").unwrap();
    writeln!(s, "|---|---|").unwrap();
    writeln!(
        s,
        "| estimate frame, 2 modes (worst case / golden example) | {est} B / {typical} B |"
    )
    .unwrap();
    writeln!(s, "| status frame (worst case) | {status} B |").unwrap();
    writeln!(
        s,
        "| raw-sample frame, {} pairs (worst case) | {raw} B = {:.3} B per pair |",
        64,
        raw_bytes_per_sample()
    )
    .unwrap();
    writeln!(s, "| link at 921,600 baud, 8N1 | {link:.0} B/s |").unwrap();
    writeln!(
        s,
        "| defaults (estimates 100 Hz, status 1 Hz) | {:.0} B/s = {:.1} % |",
        load.total_b_s(),
        pct(load.total_b_s())
    )
    .unwrap();
    writeln!(
        s,
        "| highest raw rate next to the defaults | {:.0} Hz (decimation {d}): {:.0} B/s = {:.1} % |",
        fs / f32::from(d),
        with_raw.total_b_s(),
        pct(with_raw.total_b_s())
    )
    .unwrap();
    writeln!(
        s,
        "| raw at 10 kHz, estimates and status off | {raw_10k:.0} B/s = {:.1} % |",
        pct(raw_10k)
    )
    .unwrap();
    writeln!(
        s,
        "| estimate rate that still fits next to raw at 10 kHz and status at 1 Hz | {:.0} Hz |",
        est_room.floor()
    )
    .unwrap();
    s
}

/// The walk through the Estimate example's COBS encoding names the code
/// bytes and the bytes they cover exactly as the wire has them.
#[test]
fn cobs_walk_through_matches_the_estimate_example() {
    let (title, msg, seq) = golden().into_iter().next().unwrap();
    assert_eq!(title, "Estimate");
    let (_, wire) = block(title, &msg, seq);
    let first = usize::from(wire[0]);
    let second = usize::from(wire[first]);
    let walk = format!(
        "the first code byte `{:02X}` covers the {} bytes `{}` and stands for the `00` \
         that follows them (the high byte of seq); the next code `{:02X}` covers `{}` and \
         the `00` of the estimator field",
        wire[0],
        first - 1,
        hex(&wire[1..first]),
        wire[first],
        hex(&wire[first + 1..first + second]),
    );
    let doc = DOC.split_whitespace().collect::<Vec<_>>().join(" ");
    assert!(
        doc.contains(&walk),
        "docs/PROTOCOL.md §6 should say: {walk}"
    );
}

#[test]
fn link_budget_table_is_documented() {
    let t = budget_table();
    println!("{t}");
    assert!(
        DOC.contains(&t),
        "docs/PROTOCOL.md lacks the budget table:\n{t}"
    );
}

/// Θ̂ travels as `f32`: the modes recovered from the rounded Θ of the
/// paper's plant (λ = 100 rad/s) stay within 2e-6 of those from the exact Θ
/// (measured: ω 5.6e-10, ζ 7.3e-7, b̄ 1.4e-7, as docs/PROTOCOL.md quotes).
#[test]
fn theta_in_f32_keeps_the_modes() {
    let tf = paper_plant_tf();
    let mut theta = [0.0f64; 7];
    tf.to_theta(100.0, &mut theta).unwrap();
    let rounded = theta.map(|t| f64::from(t as f32));
    let w = [-2.0, 2.0];
    let exact = modal_from_theta(&theta, 100.0, &w).unwrap();
    let wire = modal_from_theta(&rounded, 100.0, &w).unwrap();
    let rel = |a: f64, b: f64| (a / b - 1.0).abs();
    let mut worst = [0.0f64; 3];
    for i in 0..2 {
        worst[0] = worst[0].max(rel(wire.omega_rad_s[i], exact.omega_rad_s[i]));
        worst[1] = worst[1].max(rel(wire.zeta[i], exact.zeta[i]));
        worst[2] = worst[2].max(rel(wire.bbar[i], exact.bbar[i]));
    }
    println!("theta: {theta:?}");
    println!(
        "relative change from f32 Θ: ω {:.1e}, ζ {:.1e}, b̄ {:.1e}",
        worst[0], worst[1], worst[2]
    );
    assert!(worst.iter().all(|&e| e < 2e-6), "{worst:?}");
}

/// An independent reading of the wire format, written from
/// docs/PROTOCOL.md alone (no code shared with the encoder): COBS, the
/// CRC from its parameters, the header, and postcard's varints and floats.
mod independent {
    /// COBS-decode one frame (delimiter included at the end).
    pub fn unstuff(wire: &[u8]) -> Option<Vec<u8>> {
        let (&0, body) = wire.split_last()? else {
            return None;
        };
        let mut out = Vec::new();
        let mut i = 0;
        while i < body.len() {
            let code = usize::from(body[i]);
            if code == 0 || i + code > body.len() {
                return None;
            }
            out.extend_from_slice(&body[i + 1..i + code]);
            i += code;
            if code < 0xFF && i < body.len() {
                out.push(0);
            }
        }
        Some(out)
    }

    /// CRC-32/ISO-HDLC bit by bit: reflected poly 0xEDB88320, init and
    /// xorout 0xFFFFFFFF.
    pub fn crc32(data: &[u8]) -> u32 {
        let mut c = 0xFFFF_FFFFu32;
        for &b in data {
            c ^= u32::from(b);
            for _ in 0..8 {
                c = if c & 1 != 0 {
                    (c >> 1) ^ 0xEDB8_8320
                } else {
                    c >> 1
                };
            }
        }
        c ^ 0xFFFF_FFFF
    }

    /// A cursor over a payload, reading postcard's encodings.
    pub struct Reader<'a>(pub &'a [u8]);

    impl Reader<'_> {
        pub fn byte(&mut self) -> u8 {
            let (&b, rest) = self.0.split_first().expect("payload too short");
            self.0 = rest;
            b
        }
        /// LEB128: 7 bits per byte, least significant group first, bit 7
        /// set on every byte but the last.
        pub fn varint(&mut self) -> u64 {
            let mut v = 0u64;
            for shift in (0..70).step_by(7) {
                let b = self.byte();
                v |= u64::from(b & 0x7F) << shift;
                if b & 0x80 == 0 {
                    return v;
                }
            }
            panic!("varint too long")
        }
        pub fn f32(&mut self) -> f32 {
            f32::from_le_bytes([self.byte(), self.byte(), self.byte(), self.byte()])
        }
        pub fn f32s(&mut self) -> Vec<f32> {
            let n = self.varint();
            (0..n).map(|_| self.f32()).collect()
        }
        pub fn option_f32(&mut self) -> Option<f32> {
            match self.byte() {
                0 => None,
                1 => Some(self.f32()),
                b => panic!("bad option tag {b}"),
            }
        }
    }
}

/// The golden frames read back by the independent reader: framing, CRC,
/// header, and the payloads of an estimate and a command field by field.
#[test]
fn golden_frames_read_by_an_independent_decoder() {
    use independent::{crc32, unstuff, Reader};
    for (title, msg, seq) in golden() {
        let mut buf = [0u8; MAX_ENCODED_LEN];
        let n = encode(&msg, seq, &mut buf).unwrap();
        let raw = unstuff(&buf[..n]).unwrap();
        let (body, crc) = raw.split_at(raw.len() - 4);
        assert_eq!(crc32(body).to_le_bytes(), crc, "{title}");
        assert_eq!(crc32(b"123456789"), 0xCBF4_3926);
        assert_eq!(&body[..3], &[0x57, 0xBE, 3], "{title}: magic, version");
        assert_eq!(body[3], msg.kind() as u8);
        assert_eq!(u32::from_le_bytes(body[4..8].try_into().unwrap()), seq);
        let mut r = Reader(&body[8..]);
        match &msg {
            Message::Estimate(e) => {
                assert_eq!(r.varint(), e.sample_index);
                assert_eq!(r.varint(), e.estimator as u64);
                assert_eq!(r.varint(), u64::from(e.flags.0));
                let n = r.varint() as usize;
                for m in &e.modes[..n] {
                    assert_eq!(
                        [r.f32(), r.f32(), r.f32()],
                        [m.omega_rad_s, m.zeta, m.b_bar]
                    );
                }
                assert_eq!(r.f32(), e.lambda_rad_s);
                assert_eq!(r.f32s(), e.theta.to_vec());
                assert_eq!(r.option_f32(), e.excitation_level);
            }
            Message::Command(Command::SetExcitation(x)) => {
                assert_eq!(r.varint(), 0, "SetExcitation tag");
                let Waveform::Chirp {
                    f_start_hz,
                    f_end_hz,
                    sweep_s,
                } = x.waveform
                else {
                    panic!()
                };
                assert_eq!(r.varint(), 4, "Chirp tag");
                assert_eq!([r.f32(), r.f32(), r.f32()], [f_start_hz, f_end_hz, sweep_s]);
                assert_eq!([r.f32(), r.f32()], [x.amplitude_v, x.offset_v]);
            }
            Message::Command(Command::SetEstimator(e)) => {
                assert_eq!(r.varint(), 1, "SetEstimator tag");
                assert_eq!(r.varint(), e.kind as u64);
                assert_eq!(
                    [r.f32(), r.f32(), r.f32(), r.f32()],
                    [e.gain, e.forgetting_p, e.forgetting_h, e.initial_gain]
                );
                assert_eq!(r.option_f32(), e.lambda_rad_s);
                // The output kind's code: 0 strain, 1 velocity, 2 acceleration.
                assert_eq!(r.varint(), 2, "output: acceleration");
                assert_eq!(e.output, OutputKind::Acceleration);
            }
            Message::Ack(a) => {
                assert_eq!(r.varint(), u64::from(a.command_seq));
                assert_eq!(r.byte(), a.result.code());
            }
            Message::SelfTestReport(t) => {
                assert_eq!([r.varint(), r.varint()], [t.first_sample, t.last_sample]);
                assert_eq!(r.byte(), u8::from(t.at_boot));
                assert_eq!(
                    [r.varint(), r.varint()],
                    [u64::from(t.failed.0), u64::from(t.not_measured.0)]
                );
                let adc: Vec<u64> = (0..7).map(|_| r.varint()).collect();
                let mut want = vec![u64::from(t.adc.id)];
                want.extend(t.adc.registers.iter().map(|&v| u64::from(v)));
                want.extend(t.adc.expected.iter().map(|&v| u64::from(v)));
                assert_eq!(adc, want);
                let d = &t.drdy;
                assert_eq!(
                    [r.f32(), r.f32(), r.f32()],
                    [d.rate_hz, d.expected_hz, d.tolerance]
                );
                assert_eq!(
                    [r.varint(), r.varint()],
                    [u64::from(d.conversions), u64::from(d.ticks)]
                );
                let l = &t.loopback;
                let loopback: Vec<f32> = (0..10).map(|_| r.f32()).collect();
                assert_eq!(
                    loopback,
                    [
                        l.tone_hz,
                        l.amplitude_v,
                        l.gain,
                        l.expected_gain,
                        l.gain_tolerance,
                        l.offset_v,
                        l.offset_tolerance_v,
                        l.delay_samples,
                        l.expected_delay_samples,
                        l.delay_tolerance_samples
                    ]
                );
                let n = &t.noise;
                let noise: Vec<f32> = (0..5).map(|_| r.f32()).collect();
                assert_eq!(
                    noise,
                    [n.noise_sd, n.floor_sd, n.signal_rms, n.snr_db, n.snr_min_db]
                );
                assert_eq!(r.varint(), 1, "Square tag");
                assert_eq!(
                    [r.f32(), r.f32(), r.f32()],
                    [7.0, n.excitation.amplitude_v, n.excitation.offset_v]
                );
            }
            _ => continue,
        }
        assert!(r.0.is_empty(), "{title}: trailing bytes");
    }
}

/// The independent COBS reading (§1.1 of the document) agrees with the
/// encoder on every payload length, around every 254-byte boundary.
#[test]
fn independent_cobs_reads_every_length() {
    use beam_protocol::{encode_raw, Header, Kind, MAX_PAYLOAD_LEN};
    for fill in [0xA5u8, 0x00] {
        let payload = vec![fill; MAX_PAYLOAD_LEN];
        for len in 0..=MAX_PAYLOAD_LEN {
            let h = Header::new(Kind::Ack, 0x0101_0101);
            let mut buf = [0u8; MAX_ENCODED_LEN];
            let n = encode_raw(&h, &payload[..len], &mut buf).unwrap();
            let raw = independent::unstuff(&buf[..n]).unwrap();
            assert_eq!(raw.len(), HEADER_LEN + len + CRC_LEN, "len {len}");
            assert_eq!(&raw[HEADER_LEN..HEADER_LEN + len], &payload[..len]);
            assert_eq!(independent::crc32(&raw), 0x2144_DF1C, "residue");
        }
    }
}
