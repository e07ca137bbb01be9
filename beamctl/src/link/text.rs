//! Names and one-line descriptions of protocol values, shared by the plain
//! output, the terminal view, the record files and `beamctl send`. Commands
//! as text are the grammar's ([`super::grammar::command_text`]).

use super::grammar::{estimator_text, excitation_text, telemetry_text};
use beam_protocol::{AckResult, LinkCounters, Status, StatusFlags, Waveform};

/// Every defined status flag with its name (`docs/PROTOCOL.md` §4.1).
pub const FLAG_NAMES: [(StatusFlags, &str); 13] = [
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
        assert_eq!(flags_text(StatusFlags(0xE000), ","), "-");
        // Every defined bit (0–12) has a name.
        assert_eq!(flag_names(StatusFlags(0x1FFF)).len(), 13);
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
