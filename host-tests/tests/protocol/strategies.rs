//! proptest strategies for every protocol message, with arbitrary field
//! values: every `f32` bit pattern (NaN payloads, infinities, subnormals,
//! −0), every integer, every enum variant, vectors of every allowed length.

use beam_protocol::{
    Ack, AckResult, AdcCheck, Command, DeviceCounters, DrdyCheck, Estimate, EstimatorKind,
    EstimatorSettings, Excitation, FirmwareVersion, LineRemoval, LoopbackCheck, Message,
    ModeEstimate, NoiseCheck, OutputKind, RawSamples, RejectReason, SelfTestChecks, SelfTestReport,
    SelfTestState, Status, StatusFlags, TelemetryRates, UySample, Waveform, MAX_RAW_SAMPLES,
};
use proptest::collection::vec;
use proptest::option;
use proptest::prelude::*;

/// Any `f32`, special values often.
pub fn f32_bits() -> impl Strategy<Value = f32> {
    prop_oneof![
        6 => any::<u32>().prop_map(f32::from_bits),
        1 => Just(f32::NAN),
        1 => Just(f32::from_bits(0x7F80_0001)), // signalling NaN
        1 => Just(f32::from_bits(0xFFC1_2345)), // negative NaN with payload
        1 => Just(f32::INFINITY),
        1 => Just(-0.0f32),
        1 => Just(f32::MIN_POSITIVE / 2.0),
        2 => -1e6f32..1e6,
    ]
}

pub fn estimator_kind() -> impl Strategy<Value = EstimatorKind> {
    proptest::sample::select(EstimatorKind::ALL.to_vec())
}

pub fn mode() -> impl Strategy<Value = ModeEstimate> {
    (f32_bits(), f32_bits(), f32_bits()).prop_map(|(omega_rad_s, zeta, b_bar)| ModeEstimate {
        omega_rad_s,
        zeta,
        b_bar,
    })
}

/// A well-formed estimate: n = 1..=3 modes, Θ of 4n − 1, modes empty or n.
pub fn estimate() -> impl Strategy<Value = Estimate> {
    (1usize..=3)
        .prop_flat_map(|n| {
            (
                any::<u64>(),
                estimator_kind(),
                any::<u16>(),
                any::<bool>(),
                vec(mode(), n),
                (1e-3f32..1e5, vec(f32_bits(), 4 * n - 1)),
                option::of(0.0f32..=1.0),
            )
        })
        .prop_map(
            |(
                sample_index,
                estimator,
                flags,
                with_modes,
                modes,
                (lambda_rad_s, theta),
                excitation_level,
            )| {
                Estimate {
                    sample_index,
                    estimator,
                    flags: StatusFlags(flags),
                    modes: if with_modes {
                        modes.into_iter().collect()
                    } else {
                        Default::default()
                    },
                    lambda_rad_s,
                    theta: theta.into_iter().collect(),
                    excitation_level,
                }
            },
        )
}

pub fn raw_samples() -> impl Strategy<Value = RawSamples> {
    (
        any::<u64>(),
        1..=u16::MAX,
        vec((f32_bits(), f32_bits()), 0..=MAX_RAW_SAMPLES),
    )
        .prop_map(|(first_sample_index, decimation, s)| RawSamples {
            first_sample_index,
            decimation,
            samples: s.into_iter().map(|(u_v, y)| UySample { u_v, y }).collect(),
        })
}

pub fn waveform() -> impl Strategy<Value = Waveform> {
    prop_oneof![
        Just(Waveform::Off),
        f32_bits().prop_map(|freq_hz| Waveform::Square { freq_hz }),
        (f32_bits(), f32_bits(), any::<u8>()).prop_map(|(f_min_hz, f_max_hz, tones)| {
            Waveform::Multisine {
                f_min_hz,
                f_max_hz,
                tones,
            }
        }),
        (f32_bits(), any::<u8>()).prop_map(|(bit_rate_hz, register_bits)| Waveform::Prbs {
            bit_rate_hz,
            register_bits
        }),
        (f32_bits(), f32_bits(), f32_bits()).prop_map(|(f_start_hz, f_end_hz, sweep_s)| {
            Waveform::Chirp {
                f_start_hz,
                f_end_hz,
                sweep_s,
            }
        }),
    ]
}

pub fn excitation() -> impl Strategy<Value = Excitation> {
    (waveform(), f32_bits(), f32_bits()).prop_map(|(waveform, amplitude_v, offset_v)| Excitation {
        waveform,
        amplitude_v,
        offset_v,
    })
}

pub fn estimator_settings() -> impl Strategy<Value = EstimatorSettings> {
    (
        estimator_kind(),
        f32_bits(),
        f32_bits(),
        f32_bits(),
        f32_bits(),
        option::of(f32_bits()),
        proptest::sample::select(OutputKind::ALL.to_vec()),
    )
        .prop_map(
            |(kind, gain, forgetting_p, forgetting_h, initial_gain, lambda_rad_s, output)| {
                EstimatorSettings {
                    kind,
                    gain,
                    forgetting_p,
                    forgetting_h,
                    initial_gain,
                    lambda_rad_s,
                    output,
                }
            },
        )
}

pub fn telemetry_rates() -> impl Strategy<Value = TelemetryRates> {
    (f32_bits(), any::<u16>(), f32_bits()).prop_map(
        |(estimate_rate_hz, raw_decimation, status_rate_hz)| TelemetryRates {
            estimate_rate_hz,
            raw_decimation,
            status_rate_hz,
        },
    )
}

pub fn status() -> impl Strategy<Value = Status> {
    (
        (any::<u64>(), f32_bits(), any::<[u8; 3]>(), 1u8..=3),
        any::<[u32; 11]>(),
        any::<bool>(),
        excitation(),
        estimator_settings(),
        (telemetry_rates(), any::<bool>(), self_test_state()),
    )
        .prop_map(
            |(
                (uptime_samples, sample_rate_hz, fw, modes),
                c,
                frozen,
                excitation,
                est,
                (tel, auto, self_test),
            )| {
                Status {
                    uptime_samples,
                    sample_rate_hz,
                    firmware: FirmwareVersion {
                        major: fw[0],
                        minor: fw[1],
                        patch: fw[2],
                    },
                    modes,
                    counters: DeviceCounters {
                        overruns: c[0],
                        adc_crc_errors: c[1],
                        adc_status_errors: c[2],
                        adc_stuck: c[3],
                        adc_saturations: c[4],
                        dac_saturations: c[5],
                        rejected_samples: c[6],
                        telemetry_dropped: c[7],
                        commands_accepted: c[8],
                        commands_rejected: c[9],
                        rx_frame_errors: c[10],
                    },
                    adaptation_frozen: frozen,
                    excitation,
                    estimator: est,
                    telemetry: tel,
                    lambda_automatic: auto,
                    self_test,
                }
            },
        )
}

pub fn self_test_state() -> impl Strategy<Value = SelfTestState> {
    prop_oneof![
        Just(SelfTestState::NotRun),
        Just(SelfTestState::Running),
        (any::<u16>(), any::<u16>()).prop_map(|(f, n)| SelfTestState::Done {
            failed: SelfTestChecks(f),
            not_measured: SelfTestChecks(n),
        }),
    ]
}

pub fn self_test_report() -> impl Strategy<Value = SelfTestReport> {
    (
        (any::<u64>(), any::<u64>(), any::<bool>()),
        (any::<u16>(), any::<u16>()),
        (any::<u16>(), any::<[u16; 3]>(), any::<[u16; 3]>()),
        (vec(f32_bits(), 3), any::<u32>(), any::<u32>()),
        vec(f32_bits(), 10),
        (vec(f32_bits(), 5), excitation()),
    )
        .prop_map(
            |(
                (first, last, at_boot),
                (failed, nm),
                (id, registers, expected),
                (d, conv, ticks),
                l,
                (n, excitation),
            )| {
                SelfTestReport {
                    first_sample: first,
                    last_sample: last,
                    at_boot,
                    failed: SelfTestChecks(failed),
                    not_measured: SelfTestChecks(nm),
                    adc: AdcCheck {
                        id,
                        registers,
                        expected,
                    },
                    drdy: DrdyCheck {
                        rate_hz: d[0],
                        expected_hz: d[1],
                        tolerance: d[2],
                        conversions: conv,
                        ticks,
                    },
                    loopback: LoopbackCheck {
                        tone_hz: l[0],
                        amplitude_v: l[1],
                        gain: l[2],
                        expected_gain: l[3],
                        gain_tolerance: l[4],
                        offset_v: l[5],
                        offset_tolerance_v: l[6],
                        delay_samples: l[7],
                        expected_delay_samples: l[8],
                        delay_tolerance_samples: l[9],
                    },
                    noise: NoiseCheck {
                        noise_sd: n[0],
                        floor_sd: n[1],
                        signal_rms: n[2],
                        snr_db: n[3],
                        snr_min_db: n[4],
                        excitation,
                    },
                }
            },
        )
}

pub fn ack() -> impl Strategy<Value = Ack> {
    let result = prop_oneof![
        Just(AckResult::Accepted),
        proptest::sample::select(RejectReason::ALL.to_vec()).prop_map(AckResult::Rejected),
    ];
    (any::<u32>(), result).prop_map(|(command_seq, result)| Ack {
        command_seq,
        result,
    })
}

pub fn command() -> impl Strategy<Value = Command> {
    prop_oneof![
        excitation().prop_map(Command::SetExcitation),
        estimator_settings().prop_map(Command::SetEstimator),
        telemetry_rates().prop_map(Command::SetTelemetry),
        Just(Command::Reset),
        Just(Command::Freeze),
        Just(Command::Resume),
        Just(Command::RequestStatus),
        (f32_bits(), any::<u8>(), f32_bits()).prop_map(|(mains_hz, harmonics, time_constant_s)| {
            Command::SetLineRemoval(LineRemoval {
                mains_hz,
                harmonics,
                time_constant_s,
            })
        }),
        Just(Command::SelfTest),
    ]
}

/// A frame of the device → host stream (what a host's decoder counts in
/// one sequence).
pub fn device_message() -> impl Strategy<Value = Message> {
    prop_oneof![
        estimate().prop_map(Message::Estimate),
        raw_samples().prop_map(Message::RawSamples),
        status().prop_map(Message::Status),
        ack().prop_map(Message::Ack),
        self_test_report().prop_map(Message::SelfTestReport),
    ]
}

pub fn message() -> impl Strategy<Value = Message> {
    prop_oneof![
        estimate().prop_map(Message::Estimate),
        raw_samples().prop_map(Message::RawSamples),
        status().prop_map(Message::Status),
        ack().prop_map(Message::Ack),
        self_test_report().prop_map(Message::SelfTestReport),
        command().prop_map(Message::Command),
    ]
}
