//! Names and one-line descriptions of protocol values, shared by the plain
//! output, the terminal view, the record files and `beamctl send`.
//!
//! [`command_text`] writes a command in the syntax `beamctl send` accepts,
//! so a line of a record or of the monitor's log can be sent again as is.

use beam_protocol::{
    AckResult, Command, EstimatorSettings, Excitation, LinkCounters, Status, StatusFlags,
    TelemetryRates, Waveform,
};
use std::fmt::Write as _;

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

/// The waveform's own parameters as `beamctl send` flags
/// (`--freq 7`, `--band 5:50 --tones 8`, …); empty for `off`.
pub fn waveform_flags(w: &Waveform) -> String {
    match *w {
        Waveform::Off => String::new(),
        Waveform::Square { freq_hz } => format!("--freq {freq_hz}"),
        Waveform::Multisine {
            f_min_hz,
            f_max_hz,
            tones,
        } => format!("--band {f_min_hz}:{f_max_hz} --tones {tones}"),
        Waveform::Prbs {
            bit_rate_hz,
            register_bits,
        } => format!("--bit-rate {bit_rate_hz} --bits {register_bits}"),
        Waveform::Chirp {
            f_start_hz,
            f_end_hz,
            sweep_s,
        } => format!("--band {f_start_hz}:{f_end_hz} --sweep {sweep_s}"),
    }
}

/// The waveform's parameters as `key=value` pairs joined by `;` (record
/// files); empty for `off`.
pub fn waveform_params(w: &Waveform) -> String {
    match *w {
        Waveform::Off => String::new(),
        Waveform::Square { freq_hz } => format!("freq_hz={freq_hz}"),
        Waveform::Multisine {
            f_min_hz,
            f_max_hz,
            tones,
        } => format!("f_min_hz={f_min_hz};f_max_hz={f_max_hz};tones={tones}"),
        Waveform::Prbs {
            bit_rate_hz,
            register_bits,
        } => format!("bit_rate_hz={bit_rate_hz};register_bits={register_bits}"),
        Waveform::Chirp {
            f_start_hz,
            f_end_hz,
            sweep_s,
        } => format!("f_start_hz={f_start_hz};f_end_hz={f_end_hz};sweep_s={sweep_s}"),
    }
}

/// `excitation --wave … --amplitude … --offset …`.
pub fn excitation_text(e: &Excitation) -> String {
    let mut s = format!("excitation --wave {}", e.waveform.kind().name());
    let flags = waveform_flags(&e.waveform);
    if !flags.is_empty() {
        let _ = write!(s, " {flags}");
    }
    let _ = write!(s, " --amplitude {} --offset {}", e.amplitude_v, e.offset_v);
    s
}

/// `estimator --law … --gain … --forgetting-p … --forgetting-h …
/// --initial-gain … --lambda …`.
pub fn estimator_text(e: &EstimatorSettings) -> String {
    let lambda = e
        .lambda_rad_s
        .map_or_else(|| "auto".to_string(), |l| l.to_string());
    format!(
        "estimator --law {} --gain {} --forgetting-p {} --forgetting-h {} --initial-gain {} --lambda {lambda}",
        e.kind.name(),
        e.gain,
        e.forgetting_p,
        e.forgetting_h,
        e.initial_gain,
    )
}

/// `telemetry --estimates … --raw-decimation … --status …`.
pub fn telemetry_text(t: &TelemetryRates) -> String {
    format!(
        "telemetry --estimates {} --raw-decimation {} --status {}",
        t.estimate_rate_hz, t.raw_decimation, t.status_rate_hz
    )
}

/// The command in `beamctl send` syntax (without `beamctl send` and the
/// connection flags).
pub fn command_text(c: &Command) -> String {
    match c {
        Command::SetExcitation(e) => excitation_text(e),
        Command::SetEstimator(e) => estimator_text(e),
        Command::SetTelemetry(t) => telemetry_text(t),
        Command::Reset => "reset".to_string(),
        Command::Freeze => "freeze".to_string(),
        Command::Resume => "resume".to_string(),
        Command::RequestStatus => "status".to_string(),
    }
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
    fn commands_in_send_syntax() {
        let e = Excitation {
            waveform: Waveform::Multisine {
                f_min_hz: 5.0,
                f_max_hz: 50.0,
                tones: 8,
            },
            amplitude_v: 0.2,
            offset_v: 0.5,
        };
        assert_eq!(
            command_text(&Command::SetExcitation(e)),
            "excitation --wave multisine --band 5:50 --tones 8 --amplitude 0.2 --offset 0.5"
        );
        assert_eq!(
            command_text(&Command::SetEstimator(EstimatorSettings::default())),
            "estimator --law adaptive --gain 10000 --forgetting-p 0.05 --forgetting-h 0.05 --initial-gain 1000000000 --lambda auto"
        );
        assert_eq!(
            command_text(&Command::SetTelemetry(TelemetryRates::default())),
            "telemetry --estimates 100 --raw-decimation 0 --status 1"
        );
        assert_eq!(command_text(&Command::RequestStatus), "status");
        assert_eq!(
            result_text(AckResult::Rejected(RejectReason::SafeWindow)),
            "rejected (3 SafeWindow): offset ± amplitude outside the piezo's safe window"
        );
    }
}
