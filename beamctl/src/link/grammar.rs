//! The text form of the link's commands, both ways: the grammar shared by
//! `beamctl send`, the monitor's command line and `beamctl simulate`'s
//! excitation flags — clap definitions ([`CommandArgs`]) and how they become
//! a protocol [`Command`], with the settings not given taken from the
//! device's last Status — and [`command_text`], which writes a command back
//! in this grammar, so a line of a record or of the monitor's log can be
//! sent again as is.

use beam_protocol::{
    Command, EstimatorKind, EstimatorSettings, Excitation, LineRemoval, OutputKind, Status,
    TelemetryRates, Waveform, WaveformKind,
};
use clap::builder::{PossibleValue, PossibleValuesParser, TypedValueParser};
use clap::{Args, Parser, Subcommand};
use std::fmt::Write as _;

/// A command to the device.
#[derive(Debug, Clone, Subcommand)]
pub enum CommandArgs {
    /// Set the excitation: waveform, amplitude, offset; what is not given
    /// is kept from the device's current excitation.
    Excitation(ExcitationArgs),
    /// Set the estimator settings (the estimator restarts with them); what
    /// is not given is kept from the device's current settings.
    Estimator(EstimatorArgs),
    /// Set the telemetry rates; what is not given is kept.
    Telemetry(TelemetryArgs),
    /// Reset the estimator to its initial state (settings kept).
    Reset,
    /// Freeze adaptation (Θ̂ held, filters running).
    Freeze,
    /// Resume adaptation.
    Resume,
    /// Ask for a Status and print it.
    Status,
    /// Set the line remover: the mains and its harmonics removed from u
    /// and y before the estimator (docs/FIRMWARE.md, "The line remover").
    Lines(LinesArgs),
    /// Run the device's self-test (its report arrives later; `beamctl
    /// selftest` waits for it and prints it).
    Selftest,
}

/// Options of `lines`.
#[derive(Debug, Clone, Args)]
#[command(group(clap::ArgGroup::new("which").required(true).args(["mains", "off"])))]
pub struct LinesArgs {
    /// The mains frequency (Hz; e.g. 50, 60, or the measured 49.6 that
    /// `beamctl replay` reports): its harmonics 1..=--harmonics below the
    /// Nyquist frequency are removed.
    #[arg(long, value_name = "HZ", allow_negative_numbers = true)]
    pub mains: Option<f32>,
    /// Remove no line.
    #[arg(long)]
    pub off: bool,
    /// Harmonics removed, 1..=7.
    #[arg(long, value_name = "N", default_value_t = LineRemoval::MAX_HARMONICS)]
    pub harmonics: u8,
    /// The weights' time constant τ (s): the notch is about 1/(πτ) Hz
    /// wide, a line present at the switch decays as e^(−t/τ).
    #[arg(long, value_name = "SECONDS", default_value_t = LineRemoval::DEFAULT_TIME_CONSTANT_S, allow_negative_numbers = true)]
    pub time_constant: f32,
}

impl LinesArgs {
    fn build(&self) -> LineRemoval {
        LineRemoval {
            mains_hz: if self.off {
                0.0
            } else {
                self.mains.unwrap_or(0.0)
            },
            harmonics: self.harmonics,
            time_constant_s: self.time_constant,
        }
    }
}

/// The values of `--wave`: the waveform kinds by their names
/// ([`WaveformKind::name`]), each with the flags of its parameters.
pub fn wave_kind() -> impl TypedValueParser<Value = WaveformKind> {
    PossibleValuesParser::new(WaveformKind::ALL.map(|k| {
        PossibleValue::new(k.name()).help(match k {
            WaveformKind::Off => "No excitation: the output holds the offset",
            WaveformKind::Square => "Square wave (--freq)",
            WaveformKind::Multisine => "Sum of sines over a band (--band, --tones)",
            WaveformKind::Prbs => "Maximal-length PRBS (--bit-rate, --bits)",
            WaveformKind::Chirp => "Linear chirp, repeated (--band, --sweep)",
        })
    }))
    .try_map(|name| WaveformKind::from_name(&name).ok_or(format!("no waveform '{name}'")))
}

/// Options of `excitation` (and of `beamctl simulate`'s firmware
/// generators).
#[derive(Debug, Clone, Default, Args)]
pub struct ExcitationArgs {
    /// Waveform [default: the current one].
    #[arg(long, value_parser = wave_kind(), value_name = "KIND")]
    pub wave: Option<WaveformKind>,
    /// Square wave frequency (Hz).
    #[arg(long, value_name = "HZ", allow_negative_numbers = true)]
    pub freq: Option<f32>,
    /// Band LO:HI (Hz): multisine f_min:f_max, chirp f_start:f_end.
    #[arg(long, value_name = "LO:HI", value_parser = parse_band, allow_hyphen_values = true)]
    pub band: Option<(f32, f32)>,
    /// Multisine tone count.
    #[arg(long, value_name = "N")]
    pub tones: Option<u8>,
    /// PRBS bit rate (Hz).
    #[arg(long, value_name = "HZ", allow_negative_numbers = true)]
    pub bit_rate: Option<f32>,
    /// PRBS shift-register length (bits).
    #[arg(long, value_name = "N")]
    pub bits: Option<u8>,
    /// Chirp sweep time (s).
    #[arg(long, value_name = "SECONDS", allow_negative_numbers = true)]
    pub sweep: Option<f32>,
    /// Peak deviation from the offset (V).
    #[arg(long, value_name = "V", allow_negative_numbers = true)]
    pub amplitude: Option<f32>,
    /// DC offset (V).
    #[arg(long, value_name = "V", allow_negative_numbers = true)]
    pub offset: Option<f32>,
}

/// `estimator --law`: the protocol's [`EstimatorKind`] by its name, each
/// with its help line.
fn law_parser() -> impl TypedValueParser<Value = EstimatorKind> {
    let help = |k: EstimatorKind| match k {
        EstimatorKind::Adaptive => "The paper's adaptive law (eqs. 33–41)",
        EstimatorKind::Gradient => "Gradient (eq. 47)",
        EstimatorKind::LeastSquares => "Least squares (eq. 48)",
        EstimatorKind::Robust => "Bias-compensated law, where the firmware has one",
    };
    PossibleValuesParser::new(
        EstimatorKind::ALL.map(|k| PossibleValue::new(k.name()).help(help(k))),
    )
    .try_map(|name| name.parse::<EstimatorKind>())
}

/// `estimator --output`: the protocol's [`OutputKind`] by its name
/// (`displacement` reads as `strain`), each with its help line.
fn output_parser() -> impl TypedValueParser<Value = OutputKind> {
    let help = |k: OutputKind| match k {
        OutputKind::Strain => "Strain or displacement (relative degree 2): G = B/A",
        OutputKind::Velocity => "Velocity (relative degree 1): G = s·B/A",
        OutputKind::Acceleration => "Acceleration (relative degree 0): G = s²·B/A",
    };
    let mut values: Vec<PossibleValue> = OutputKind::ALL
        .iter()
        .map(|&k| PossibleValue::new(k.name()).help(help(k)))
        .collect();
    values.insert(
        1,
        PossibleValue::new("displacement").help("The same as strain"),
    );
    PossibleValuesParser::new(values).try_map(|name| name.parse::<OutputKind>())
}

/// Options of `estimator`.
#[derive(Debug, Clone, Default, Args)]
pub struct EstimatorArgs {
    /// Update law.
    #[arg(long, value_name = "LAW", value_parser = law_parser())]
    pub law: Option<EstimatorKind>,
    /// Γ of eq. 41 (1/s) (gradient law: Γ1 = gain·I of eq. 47).
    #[arg(long, value_name = "G", allow_negative_numbers = true)]
    pub gain: Option<f32>,
    /// Forgetting rate l of eq. 33 (1/s).
    #[arg(long, value_name = "L", allow_negative_numbers = true)]
    pub forgetting_p: Option<f32>,
    /// Forgetting rate γ of eq. 37 (1/s).
    #[arg(long, value_name = "GAMMA", allow_negative_numbers = true)]
    pub forgetting_h: Option<f32>,
    /// Initial gain: H(0) = value·I (adaptive), Γ2(0) = value·I (ls).
    #[arg(long, value_name = "H0", allow_negative_numbers = true)]
    pub initial_gain: Option<f32>,
    /// Filter pole λ (rad/s), or `auto` for the firmware's rule [default:
    /// the λ in use, from the device's Status].
    #[arg(long, value_name = "RAD_S|auto", value_parser = parse_lambda, allow_hyphen_values = true)]
    pub lambda: Option<Lambda>,
    /// What the sensor measures: the model's numerator degree.
    #[arg(long, value_name = "KIND", value_parser = output_parser())]
    pub output: Option<OutputKind>,
}

/// `--lambda`: a value or the automatic rule.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Lambda {
    /// The firmware's automatic rule.
    Auto,
    /// This λ (rad/s).
    Value(f32),
}

/// Options of `telemetry`.
#[derive(Debug, Clone, Default, Args)]
pub struct TelemetryArgs {
    /// Estimates per second (Hz), 0 = off.
    #[arg(long, value_name = "HZ", allow_negative_numbers = true)]
    pub estimates: Option<f32>,
    /// Raw samples: every d-th sample, 0 = off.
    #[arg(long, value_name = "D")]
    pub raw_decimation: Option<u16>,
    /// Status frames per second (Hz), 0 = only on request.
    #[arg(long, value_name = "HZ", allow_negative_numbers = true)]
    pub status: Option<f32>,
}

fn parse_band(s: &str) -> Result<(f32, f32), String> {
    let (lo, hi) = s
        .split_once(':')
        .ok_or_else(|| format!("expected LO:HI, got '{s}'"))?;
    let num = |v: &str| {
        v.trim()
            .parse::<f32>()
            .map_err(|e| format!("'{v}' in '{s}': {e}"))
    };
    Ok((num(lo)?, num(hi)?))
}

fn parse_lambda(s: &str) -> Result<Lambda, String> {
    if s.eq_ignore_ascii_case("auto") {
        Ok(Lambda::Auto)
    } else {
        s.parse::<f32>()
            .map(Lambda::Value)
            .map_err(|e| format!("expected a number or 'auto', got '{s}': {e}"))
    }
}

/// A command typed in the monitor (`excitation --amplitude 0.2`, `freeze`).
#[derive(Debug, Parser)]
#[command(name = "command", no_binary_name = true, disable_help_flag = true)]
struct CommandLine {
    #[command(subcommand)]
    command: CommandArgs,
}

/// Parse a typed command line (words separated by white space).
pub fn parse_line(line: &str) -> Result<CommandArgs, String> {
    CommandLine::try_parse_from(line.split_whitespace())
        .map(|c| c.command)
        .map_err(|e| crate::error::one_line(&e.render().to_string()))
}

impl CommandArgs {
    /// True if building the command takes settings from a Status.
    pub fn needs_status(&self) -> bool {
        matches!(
            self,
            Self::Excitation(_) | Self::Estimator(_) | Self::Telemetry(_)
        )
    }

    /// The command, with what is not given taken from `current` (the
    /// device's last Status). The error names the missing or misplaced
    /// flag.
    pub fn build(&self, current: Option<&Status>) -> Result<Command, String> {
        Ok(match self {
            Self::Excitation(a) => Command::SetExcitation(a.build(current.map(|s| &s.excitation))?),
            Self::Estimator(a) => Command::SetEstimator(a.build(current.map(|s| &s.estimator))?),
            Self::Telemetry(a) => Command::SetTelemetry(a.build(current.map(|s| &s.telemetry))?),
            Self::Reset => Command::Reset,
            Self::Freeze => Command::Freeze,
            Self::Resume => Command::Resume,
            Self::Status => Command::RequestStatus,
            Self::Lines(a) => Command::SetLineRemoval(a.build()),
            Self::Selftest => Command::SelfTest,
        })
    }
}

const UNKNOWN: &str = "is needed: the device's current setting is unknown (no Status yet)";

fn pick<T: Copy>(given: Option<T>, current: Option<T>, flag: &str) -> Result<T, String> {
    given.or(current).ok_or_else(|| format!("{flag} {UNKNOWN}"))
}

impl ExcitationArgs {
    /// True if any flag is given.
    pub fn is_given(&self) -> bool {
        let Self {
            wave,
            freq,
            band,
            tones,
            bit_rate,
            bits,
            sweep,
            amplitude,
            offset,
        } = self;
        wave.is_some()
            || freq.is_some()
            || band.is_some()
            || tones.is_some()
            || bit_rate.is_some()
            || bits.is_some()
            || sweep.is_some()
            || amplitude.is_some()
            || offset.is_some()
    }

    /// The excitation, with what is not given taken from `current`. The
    /// error names the missing or misplaced flag.
    pub fn build(&self, current: Option<&Excitation>) -> Result<Excitation, String> {
        let current_wave = current.map(|e| e.waveform);
        let wave = match (self.wave, current_wave) {
            (Some(w), _) => w,
            (None, Some(w)) => w.kind(),
            (None, None) => return Err(format!("--wave {UNKNOWN}")),
        };
        // The current waveform's parameters, if it is of the same kind.
        let same = current_wave.filter(|w| w.kind() == wave);
        let not_for = |flag: &str, given: bool| -> Result<(), String> {
            if given {
                Err(format!("{flag} does not apply to --wave {}", wave.name()))
            } else {
                Ok(())
            }
        };
        let needed = |flag: &str| format!("{flag} is needed for --wave {}", wave.name());
        let waveform = match wave {
            WaveformKind::Off => {
                not_for("--freq", self.freq.is_some())?;
                not_for("--band", self.band.is_some())?;
                not_for("--tones", self.tones.is_some())?;
                not_for("--bit-rate", self.bit_rate.is_some())?;
                not_for("--bits", self.bits.is_some())?;
                not_for("--sweep", self.sweep.is_some())?;
                Waveform::Off
            }
            WaveformKind::Square => {
                not_for("--band", self.band.is_some())?;
                not_for("--tones", self.tones.is_some())?;
                not_for("--bit-rate", self.bit_rate.is_some())?;
                not_for("--bits", self.bits.is_some())?;
                not_for("--sweep", self.sweep.is_some())?;
                let cur = match same {
                    Some(Waveform::Square { freq_hz }) => Some(freq_hz),
                    _ => None,
                };
                Waveform::Square {
                    freq_hz: self.freq.or(cur).ok_or_else(|| needed("--freq"))?,
                }
            }
            WaveformKind::Multisine => {
                not_for("--freq", self.freq.is_some())?;
                not_for("--bit-rate", self.bit_rate.is_some())?;
                not_for("--bits", self.bits.is_some())?;
                not_for("--sweep", self.sweep.is_some())?;
                let cur = match same {
                    Some(Waveform::Multisine {
                        f_min_hz,
                        f_max_hz,
                        tones,
                    }) => Some(((f_min_hz, f_max_hz), tones)),
                    _ => None,
                };
                let (f_min_hz, f_max_hz) = self
                    .band
                    .or(cur.map(|c| c.0))
                    .ok_or_else(|| needed("--band"))?;
                Waveform::Multisine {
                    f_min_hz,
                    f_max_hz,
                    tones: self
                        .tones
                        .or(cur.map(|c| c.1))
                        .ok_or_else(|| needed("--tones"))?,
                }
            }
            WaveformKind::Prbs => {
                not_for("--freq", self.freq.is_some())?;
                not_for("--band", self.band.is_some())?;
                not_for("--tones", self.tones.is_some())?;
                not_for("--sweep", self.sweep.is_some())?;
                let cur = match same {
                    Some(Waveform::Prbs {
                        bit_rate_hz,
                        register_bits,
                    }) => Some((bit_rate_hz, register_bits)),
                    _ => None,
                };
                Waveform::Prbs {
                    bit_rate_hz: self
                        .bit_rate
                        .or(cur.map(|c| c.0))
                        .ok_or_else(|| needed("--bit-rate"))?,
                    register_bits: self
                        .bits
                        .or(cur.map(|c| c.1))
                        .ok_or_else(|| needed("--bits"))?,
                }
            }
            WaveformKind::Chirp => {
                not_for("--freq", self.freq.is_some())?;
                not_for("--tones", self.tones.is_some())?;
                not_for("--bit-rate", self.bit_rate.is_some())?;
                not_for("--bits", self.bits.is_some())?;
                let cur = match same {
                    Some(Waveform::Chirp {
                        f_start_hz,
                        f_end_hz,
                        sweep_s,
                    }) => Some(((f_start_hz, f_end_hz), sweep_s)),
                    _ => None,
                };
                let (f_start_hz, f_end_hz) = self
                    .band
                    .or(cur.map(|c| c.0))
                    .ok_or_else(|| needed("--band"))?;
                Waveform::Chirp {
                    f_start_hz,
                    f_end_hz,
                    sweep_s: self
                        .sweep
                        .or(cur.map(|c| c.1))
                        .ok_or_else(|| needed("--sweep"))?,
                }
            }
        };
        let amplitude_v = match wave {
            WaveformKind::Off => self
                .amplitude
                .or(current.map(|c| c.amplitude_v))
                .unwrap_or(0.0),
            _ => pick(
                self.amplitude,
                current.map(|c| c.amplitude_v),
                "--amplitude",
            )?,
        };
        Ok(Excitation {
            waveform,
            amplitude_v,
            offset_v: pick(self.offset, current.map(|c| c.offset_v), "--offset")?,
        })
    }
}

impl EstimatorArgs {
    fn build(&self, current: Option<&EstimatorSettings>) -> Result<EstimatorSettings, String> {
        Ok(EstimatorSettings {
            kind: pick(self.law, current.map(|c| c.kind), "--law")?,
            gain: pick(self.gain, current.map(|c| c.gain), "--gain")?,
            forgetting_p: pick(
                self.forgetting_p,
                current.map(|c| c.forgetting_p),
                "--forgetting-p",
            )?,
            forgetting_h: pick(
                self.forgetting_h,
                current.map(|c| c.forgetting_h),
                "--forgetting-h",
            )?,
            initial_gain: pick(
                self.initial_gain,
                current.map(|c| c.initial_gain),
                "--initial-gain",
            )?,
            lambda_rad_s: match self.lambda {
                Some(Lambda::Auto) => None,
                Some(Lambda::Value(v)) => Some(v),
                None => pick(None, current.map(|c| c.lambda_rad_s), "--lambda")?,
            },
            output: pick(self.output, current.map(|c| c.output), "--output")?,
        })
    }
}

impl TelemetryArgs {
    fn build(&self, current: Option<&TelemetryRates>) -> Result<TelemetryRates, String> {
        Ok(TelemetryRates {
            estimate_rate_hz: pick(
                self.estimates,
                current.map(|c| c.estimate_rate_hz),
                "--estimates",
            )?,
            raw_decimation: pick(
                self.raw_decimation,
                current.map(|c| c.raw_decimation),
                "--raw-decimation",
            )?,
            status_rate_hz: pick(self.status, current.map(|c| c.status_rate_hz), "--status")?,
        })
    }
}

// ----- The other direction: a command as text in this grammar -----

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
/// --initial-gain … --lambda … --output …`.
pub fn estimator_text(e: &EstimatorSettings) -> String {
    let lambda = e
        .lambda_rad_s
        .map_or_else(|| "auto".to_string(), |l| l.to_string());
    format!(
        "estimator --law {} --gain {} --forgetting-p {} --forgetting-h {} --initial-gain {} --lambda {lambda} --output {}",
        e.kind.name(),
        e.gain,
        e.forgetting_p,
        e.forgetting_h,
        e.initial_gain,
        e.output.name(),
    )
}

/// `telemetry --estimates … --raw-decimation … --status …`.
pub fn telemetry_text(t: &TelemetryRates) -> String {
    format!(
        "telemetry --estimates {} --raw-decimation {} --status {}",
        t.estimate_rate_hz, t.raw_decimation, t.status_rate_hz
    )
}

/// `lines --mains … --harmonics … --time-constant …`, or `lines --off`.
pub fn lines_text(l: &LineRemoval) -> String {
    if l.is_off() {
        return "lines --off".to_string();
    }
    format!(
        "lines --mains {} --harmonics {} --time-constant {}",
        l.mains_hz, l.harmonics, l.time_constant_s
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
        Command::SetLineRemoval(l) => lines_text(l),
        Command::SelfTest => "selftest".to_string(),
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::link::fake::FakeDevice;

    /// The fake device's Status (what `build` fills unspecified fields from).
    pub(crate) fn status() -> Status {
        FakeDevice::new(crate::link::fake::FakeConfig::default()).status()
    }

    /// A typed line as the command it becomes.
    pub(crate) fn build(line: &str, current: Option<&Status>) -> Result<Command, String> {
        parse_line(line)?.build(current)
    }

    #[test]
    fn unspecified_fields_come_from_the_status() {
        let s = status();
        let c = build("excitation --amplitude 0.3", Some(&s)).unwrap();
        assert_eq!(
            c,
            Command::SetExcitation(Excitation {
                amplitude_v: 0.3,
                ..s.excitation
            })
        );
        let c = build("excitation --wave chirp --band 1:100 --sweep 10", Some(&s)).unwrap();
        assert_eq!(
            command_text(&c),
            "excitation --wave chirp --band 1:100 --sweep 10 --amplitude 0.1 --offset 0"
        );
        let c = build("estimator --gain 2e4", Some(&s)).unwrap();
        let Command::SetEstimator(e) = c else {
            panic!()
        };
        assert_eq!(e.gain, 2e4);
        assert_eq!(e.lambda_rad_s, s.estimator.lambda_rad_s, "λ in use kept");
        let c = build("estimator --lambda auto", Some(&s)).unwrap();
        let Command::SetEstimator(e) = c else {
            panic!()
        };
        assert_eq!(e.lambda_rad_s, None);
        let c = build("telemetry --raw-decimation 4", Some(&s)).unwrap();
        assert_eq!(
            c,
            Command::SetTelemetry(TelemetryRates {
                raw_decimation: 4,
                ..s.telemetry
            })
        );
    }

    /// One of each waveform kind, with parameters a device accepts.
    fn every_waveform() -> [Waveform; 5] {
        [
            Waveform::Off,
            Waveform::Square { freq_hz: 7.0 },
            Waveform::Multisine {
                f_min_hz: 5.0,
                f_max_hz: 50.5,
                tones: 8,
            },
            Waveform::Prbs {
                bit_rate_hz: 1250.0,
                register_bits: 11,
            },
            Waveform::Chirp {
                f_start_hz: 1.0,
                f_end_hz: 80.0,
                sweep_s: 2.5,
            },
        ]
    }

    #[test]
    fn every_waveform_reads_back_from_its_text() {
        // The printer and the parser are inverses: a new waveform's flags
        // are checked here as soon as its kind is in `WaveformKind::ALL`.
        let waves = every_waveform();
        assert_eq!(
            waves.map(|w| w.kind()),
            WaveformKind::ALL,
            "one waveform per kind, in tag order"
        );
        for waveform in waves {
            let c = Command::SetExcitation(Excitation {
                waveform,
                amplitude_v: 0.25,
                offset_v: -0.5,
            });
            let text = command_text(&c);
            assert_eq!(build(&text, None), Ok(c), "{text}");
        }
    }

    #[test]
    fn every_estimator_setting_reads_back_from_its_text() {
        // Every law and every output kind, fixed and automatic λ.
        for kind in EstimatorKind::ALL {
            for output in OutputKind::ALL {
                for lambda_rad_s in [None, Some(123.5)] {
                    let c = Command::SetEstimator(EstimatorSettings {
                        kind,
                        gain: 2.5e4,
                        forgetting_p: 0.125,
                        forgetting_h: 0.0625,
                        initial_gain: 1e8,
                        lambda_rad_s,
                        output,
                    });
                    let text = command_text(&c);
                    assert_eq!(build(&text, None), Ok(c), "{text}");
                }
            }
        }
        // `--output` alone changes only the kind; `displacement` is strain.
        let s = status();
        let c = build("estimator --output acceleration", Some(&s)).unwrap();
        assert_eq!(
            c,
            Command::SetEstimator(EstimatorSettings {
                output: OutputKind::Acceleration,
                ..s.estimator
            })
        );
        let c = build("estimator --output displacement", Some(&s)).unwrap();
        let Command::SetEstimator(e) = c else {
            panic!()
        };
        assert_eq!(e.output, OutputKind::Strain);
        assert!(parse_line("estimator --output jerk").is_err());
    }

    #[test]
    fn missing_and_misplaced_flags_are_named() {
        let s = status();
        assert_eq!(
            build("excitation --amplitude 0.3", None).unwrap_err(),
            format!("--wave {UNKNOWN}")
        );
        assert_eq!(
            build("excitation --wave prbs --bits 7", Some(&s)).unwrap_err(),
            "--bit-rate is needed for --wave prbs"
        );
        assert_eq!(
            build("excitation --wave square --tones 3", Some(&s)).unwrap_err(),
            "--tones does not apply to --wave square"
        );
        assert_eq!(
            build("telemetry --estimates 50", None).unwrap_err(),
            format!("--raw-decimation {UNKNOWN}")
        );
        // Complete without a Status.
        assert!(build(
            "excitation --wave square --freq 7 --amplitude 0.1 --offset 0",
            None
        )
        .is_ok());
        assert_eq!(build("freeze", None).unwrap(), Command::Freeze);
        assert!(parse_line("excitation --band 5").is_err());
        assert!(parse_line("launch").is_err());
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
            "estimator --law adaptive --gain 10000 --forgetting-p 0.05 --forgetting-h 0.05 --initial-gain 1000000000 --lambda auto --output strain"
        );
        assert_eq!(
            command_text(&Command::SetTelemetry(TelemetryRates::default())),
            "telemetry --estimates 100 --raw-decimation 0 --status 1"
        );
        assert_eq!(command_text(&Command::RequestStatus), "status");
        // Lines: written and read back, off and on.
        for l in [
            LineRemoval::OFF,
            LineRemoval {
                mains_hz: 49.6,
                harmonics: 3,
                time_constant_s: 0.5,
            },
        ] {
            let c = Command::SetLineRemoval(l);
            let text = command_text(&c);
            assert_eq!(build(&text, None).unwrap(), c, "{text}");
        }
        assert_eq!(
            build("lines --mains 50", None).unwrap(),
            Command::SetLineRemoval(LineRemoval {
                mains_hz: 50.0,
                ..LineRemoval::OFF
            })
        );
        assert!(build("lines", None).is_err());
        assert!(build("lines --mains 50 --off", None).is_err());
    }
}
