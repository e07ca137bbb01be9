//! Names and one-line descriptions of protocol values, shared by the plain
//! output, the terminal view, the record files and `beamctl send`. Commands
//! as text are the grammar's ([`super::grammar::command_text`]).

use super::grammar::{estimator_text, excitation_text, telemetry_text};
use beam_protocol::{
    AckResult, LinkCounters, SelfTestChecks, SelfTestReport, SelfTestState, Status, StatusFlags,
    Waveform,
};

/// Every defined status flag with its name (`docs/PROTOCOL.md` §4.1).
pub const FLAG_NAMES: [(StatusFlags, &str); 14] = [
    (StatusFlags::EXCITED, "EXCITED"),
    (StatusFlags::FROZEN_BY_COMMAND, "FROZEN_BY_COMMAND"),
    (StatusFlags::FROZEN_AUTO, "FROZEN_AUTO"),
    (StatusFlags::CONVERGED, "CONVERGED"),
    (StatusFlags::PHYSICALLY_VALID, "PHYSICALLY_VALID"),
    (StatusFlags::SENSOR_FAULT, "SENSOR_FAULT"),
    (StatusFlags::ADC_SATURATED, "ADC_SATURATED"),
    (StatusFlags::DAC_SATURATED, "DAC_SATURATED"),
    (StatusFlags::TELEMETRY_DROPPED, "TELEMETRY_DROPPED"),
    (StatusFlags::STATE_DEGRADED, "STATE_DEGRADED"),
    (StatusFlags::INPUT_GONE, "INPUT_GONE"),
    (StatusFlags::CHANGE_DETECTED, "CHANGE_DETECTED"),
    (StatusFlags::SENSOR_LEVEL, "SENSOR_LEVEL"),
    (StatusFlags::SELF_TEST, "SELF_TEST"),
];

/// The names of the flags set, in bit order (reserved bits are ignored, as
/// the protocol says).
pub fn flag_names(flags: StatusFlags) -> Vec<&'static str> {
    FLAG_NAMES
        .iter()
        .filter(|(f, _)| flags.contains(*f))
        .map(|(_, n)| *n)
        .collect()
}

/// The flags set, joined by `sep`; `-` if none.
pub fn flags_text(flags: StatusFlags, sep: &str) -> String {
    let names = flag_names(flags);
    if names.is_empty() {
        "-".to_string()
    } else {
        names.join(sep)
    }
}

/// The waveform's parameters as `key=value` pairs joined by `;` (record
/// files); empty for `off`. The keys are the wire's field names
/// ([`Waveform::params`]).
pub fn waveform_params(w: &Waveform) -> String {
    w.params()
        .iter()
        .map(|(name, value)| format!("{name}={value}"))
        .collect::<Vec<_>>()
        .join(";")
}

/// `accepted`, or the reject reason's name (`SafeWindow`, …).
pub fn result_name(r: AckResult) -> String {
    match r {
        AckResult::Accepted => "accepted".to_string(),
        AckResult::Rejected(reason) => format!("{reason:?}"),
    }
}

/// `accepted`, or `rejected (3 SafeWindow): offset ± amplitude outside the
/// piezo's safe window`.
pub fn result_text(r: AckResult) -> String {
    match r {
        AckResult::Accepted => "accepted".to_string(),
        AckResult::Rejected(reason) => format!(
            "rejected ({} {reason:?}): {}",
            reason as u8,
            reason.describe()
        ),
    }
}

/// A Status as lines of text (`beamctl send status`).
pub fn status_lines(s: &Status) -> Vec<String> {
    let c = &s.counters;
    let fw = s.firmware;
    let fs = f64::from(s.sample_rate_hz);
    let uptime = if fs > 0.0 {
        format!("{:.3} s", s.uptime_samples as f64 / fs)
    } else {
        "?".to_string()
    };
    vec![
        format!(
            "firmware {}.{}.{}, {} mode(s), sample rate {} Hz, uptime {} samples ({uptime})",
            fw.major, fw.minor, fw.patch, s.modes, s.sample_rate_hz, s.uptime_samples
        ),
        format!(
            "adaptation: {}",
            if s.adaptation_frozen {
                "frozen by command"
            } else {
                "running"
            }
        ),
        excitation_text(&s.excitation),
        estimator_text(&s.estimator),
        telemetry_text(&s.telemetry),
        format!("self-test: {}", self_test_state_text(s.self_test)),
        format!(
            "counters: overruns {}, ADC CRC errors {}, ADC status errors {}, ADC stuck {}, ADC saturations {}, DAC saturations {}, rejected samples {}, telemetry dropped {}, commands accepted {}, commands rejected {}, rx frame errors {}",
            c.overruns,
            c.adc_crc_errors,
            c.adc_status_errors,
            c.adc_stuck,
            c.adc_saturations,
            c.dac_saturations,
            c.rejected_samples,
            c.telemetry_dropped,
            c.commands_accepted,
            c.commands_rejected,
            c.rx_frame_errors
        ),
    ]
}

/// The names of the self-test's checks in `checks` (`adc_id`, …),
/// joined by `sep`; `-` if none.
pub fn checks_text(checks: SelfTestChecks, sep: &str) -> String {
    let names: Vec<&str> = SelfTestChecks::ALL
        .iter()
        .filter(|(c, _)| checks.contains(*c))
        .map(|(_, n)| *n)
        .collect();
    if names.is_empty() {
        "-".to_string()
    } else {
        names.join(sep)
    }
}

/// A Status's self-test field: `not run`, `running`, `passed`, or
/// `failed: adc_id|…` and `not measured: …`.
pub fn self_test_state_text(s: SelfTestState) -> String {
    match s {
        SelfTestState::NotRun => "not run".to_string(),
        SelfTestState::Running => "running".to_string(),
        SelfTestState::Done {
            failed,
            not_measured,
        } if failed.is_empty() && not_measured.is_empty() => "passed".to_string(),
        SelfTestState::Done {
            failed,
            not_measured,
        } => {
            let mut parts = Vec::new();
            if !failed.is_empty() {
                parts.push(format!("failed: {}", checks_text(failed, "|")));
            }
            if !not_measured.is_empty() {
                parts.push(format!("not measured: {}", checks_text(not_measured, "|")));
            }
            parts.join("; ")
        }
    }
}

/// `PASS`, `FAIL` or `not measured` for one check of a report.
fn verdict(r: &SelfTestReport, check: SelfTestChecks) -> &'static str {
    if r.failed.contains(check) {
        "FAIL"
    } else if r.not_measured.contains(check) {
        "not measured"
    } else {
        "pass"
    }
}

/// A self-test report as lines of text (`beamctl selftest`): one line per
/// check with its verdict, the value measured and what passes.
pub fn self_test_lines(r: &SelfTestReport) -> Vec<String> {
    let a = &r.adc;
    let d = &r.drdy;
    let l = &r.loopback;
    let n = &r.noise;
    let regs = |v: &[u16; 3]| format!("{:04X}h {:04X}h {:04X}h", v[0], v[1], v[2]);
    vec![
        format!(
            "self-test {} samples {}–{}: {}",
            if r.at_boot { "at start-up," } else { "on command," },
            r.first_sample,
            r.last_sample,
            if r.passed() {
                "every check passed".to_string()
            } else {
                self_test_state_text(SelfTestState::Done {
                    failed: r.failed,
                    not_measured: r.not_measured,
                })
            }
        ),
        format!(
            "adc_id         {:<12} ID {:04X}h (a two-channel ADS131M0x reads 22xxh)",
            verdict(r, SelfTestChecks::ADC_ID),
            a.id
        ),
        format!(
            "adc_registers  {:<12} MODE CLOCK GAIN1 read {}, configured {}",
            verdict(r, SelfTestChecks::ADC_REGISTERS),
            regs(&a.registers),
            regs(&a.expected)
        ),
        format!(
            "drdy_rate      {:<12} {} Hz against the MCU clock (expected {} Hz ± {:e} relative); {} new conversions in {} ticks",
            verdict(r, SelfTestChecks::DRDY_RATE),
            d.rate_hz,
            d.expected_hz,
            d.tolerance,
            d.conversions,
            d.ticks
        ),
        format!(
            "loopback       {:<12} tone {} Hz, {} V: gain {} (expected {} ± {}), offset {} V (± {} V), delay {} samples (expected {} ± {})",
            verdict(r, SelfTestChecks::LOOPBACK),
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
        ),
        format!(
            "noise          {:<12} σ(y) {:e} with the drive at zero (quantisation floor {:e}); RMS(y) {:e} under {}; SNR {} dB (at least {} dB)",
            verdict(r, SelfTestChecks::NOISE),
            n.noise_sd,
            n.floor_sd,
            n.signal_rms,
            excitation_text(&n.excitation),
            n.snr_db,
            n.snr_min_db
        ),
    ]
}

/// The decoder's counters on one line.
pub fn counters_text(c: &LinkCounters) -> String {
    format!(
        "{} frames, {} lost (sequence gaps), {} CRC errors, {} framing errors, {} oversize, {} malformed, {} version mismatches, {} duplicates, {} out of order, {} bytes ({} skipped while joining)",
        c.frames_ok,
        c.lost,
        c.crc_errors,
        c.framing_errors,
        c.oversize,
        c.malformed,
        c.version_mismatches,
        c.duplicates,
        c.out_of_order,
        c.bytes,
        c.skipped_bytes
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use beam_protocol::RejectReason;

    #[test]
    fn flags_by_name() {
        let f = StatusFlags(0x19);
        assert_eq!(flag_names(f), ["EXCITED", "CONVERGED", "PHYSICALLY_VALID"]);
        assert_eq!(flags_text(StatusFlags(0), ","), "-");
        // Reserved bits are ignored.
        assert_eq!(flags_text(StatusFlags(0xC000), ","), "-");
        // Every defined bit (0–13) has a name.
        assert_eq!(flag_names(StatusFlags(0x3FFF)).len(), 14);
        assert_eq!(
            flags_text(StatusFlags(0x1C00), ","),
            "INPUT_GONE,CHANGE_DETECTED,SENSOR_LEVEL"
        );
    }

    #[test]
    fn waveform_parameters_by_field_name() {
        let params = |w| waveform_params(&w);
        assert_eq!(params(Waveform::Off), "");
        assert_eq!(params(Waveform::Square { freq_hz: 7.0 }), "freq_hz=7");
        assert_eq!(
            params(Waveform::Multisine {
                f_min_hz: 5.0,
                f_max_hz: 50.5,
                tones: 8
            }),
            "f_min_hz=5;f_max_hz=50.5;tones=8"
        );
        assert_eq!(
            params(Waveform::Prbs {
                bit_rate_hz: 1250.0,
                register_bits: 31
            }),
            "bit_rate_hz=1250;register_bits=31"
        );
        assert_eq!(
            params(Waveform::Chirp {
                f_start_hz: 0.1,
                f_end_hz: 80.0,
                sweep_s: 2.5
            }),
            "f_start_hz=0.1;f_end_hz=80;sweep_s=2.5"
        );
    }

    #[test]
    fn results_in_text() {
        assert_eq!(
            result_text(AckResult::Rejected(RejectReason::SafeWindow)),
            "rejected (3 SafeWindow): offset ± amplitude outside the piezo's safe window"
        );
    }
}
