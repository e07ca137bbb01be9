//! The drive u of a simulated run: the paper's square wave (the default,
//! the reference of every published figure) or, with
//! [`RunConfig::excitation`] (`beamctl simulate --wave …`), the firmware's
//! run-time generator built from the wire's excitation settings exactly as
//! the device's link builds it on a `SetExcitation`: checked against the
//! simulated bench's limits, then [`ExcitationPlan`] applied to a generator
//! at rest.

use crate::run::error::RunError;
use crate::run::RunConfig;
use beam_protocol::{self as protocol, Command, Limits, Waveform};
use beamest::bench;
use beamest::excitation::{Excitation, SafeWindow, SquareWave};
use beamest::link::ExcitationPlan;

/// u of a simulated run, one value per sample: an endless iterator, what
/// [`beamest::rig::Rig`] takes.
#[derive(Debug, Clone, PartialEq)]
pub enum Drive {
    /// u = [`RunConfig::u_amplitude`]·square([`RunConfig::u_freq_hz`]).
    Square(SquareWave<f64>),
    /// The firmware's generator for [`RunConfig::excitation`] (in f64, the
    /// rig's type; the normalised sequence is the same integer one in the
    /// f32 firmware).
    Firmware(Box<Excitation<f64>>),
}

impl Iterator for Drive {
    type Item = f64;

    #[inline]
    fn next(&mut self) -> Option<f64> {
        match self {
            Self::Square(s) => s.next(),
            Self::Firmware(e) => e.next(),
        }
    }
}

/// What the simulated device accepts at the sample period `ts_s`: the
/// bench's limits ([`bench::link_limits`]: the ±10 V piezo window, every
/// generator's range) at f_s = 1/`ts_s`.
pub fn limits(ts_s: f64) -> Limits {
    Limits {
        sample_rate_hz: (1.0 / ts_s) as f32,
        ..bench::link_limits(921_600)
    }
}

/// The run's drive from its first sample.
pub fn drive(cfg: &RunConfig) -> Result<Drive, RunError> {
    let fs = 1.0 / cfg.ts_s;
    let Some(wire) = &cfg.excitation else {
        return SquareWave::<f64>::new(cfg.u_amplitude, cfg.u_freq_hz, fs)
            .map(Drive::Square)
            .map_err(|e| RunError::Setup(format!("excitation: {e:?}")));
    };
    let limits = limits(cfg.ts_s);
    let refused = |r: protocol::RejectReason| RunError::Setup(format!("excitation {r}"));
    Command::SetExcitation(*wire)
        .validate(&limits)
        .map_err(refused)?;
    let window = SafeWindow {
        min_v: f64::from(limits.piezo_min_v),
        max_v: f64::from(limits.piezo_max_v),
    };
    firmware_drive(wire, window, fs)
}

/// A device's excitation `wire` as the device runs it (a generator at
/// rest, [`ExcitationPlan`] applied), at `fs`, without the bench's limits:
/// `wire` was accepted by that device (e.g. a self-test report's default
/// excitation), so the window is the span it covers.
pub fn device_drive(wire: &protocol::Excitation, fs: f64) -> Result<Drive, RunError> {
    let a = f64::from(wire.amplitude_v).abs();
    let o = f64::from(wire.offset_v);
    let window = SafeWindow {
        min_v: o - a,
        max_v: o + a,
    };
    firmware_drive(wire, window, fs)
}

fn firmware_drive(
    wire: &protocol::Excitation,
    window: SafeWindow<f64>,
    fs: f64,
) -> Result<Drive, RunError> {
    let refused = |r: protocol::RejectReason| RunError::Setup(format!("excitation {r}"));
    let rest = protocol::Excitation {
        waveform: Waveform::Off,
        amplitude_v: 0.0,
        offset_v: 0.0,
    };
    let mut e = Excitation::new(&Waveform::Off, 0.0, 0.0, window, fs)
        .map_err(|e| RunError::Setup(format!("excitation: {e:?}")))?;
    ExcitationPlan::new(wire, &rest, fs)
        .and_then(|plan| plan.apply(&mut e))
        .map_err(refused)?;
    Ok(Drive::Firmware(Box::new(e)))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::run::scenario_rig;

    /// The firmware path: the bench boots with its excitation
    /// ([`bench::excitation`]), then the link applies a `SetExcitation`.
    fn firmware(wire: &protocol::Excitation) -> Excitation<f64> {
        let mut running = bench::excitation::<f64>().unwrap();
        let boot = bench::link_settings().excitation;
        ExcitationPlan::new(wire, &boot, bench::SAMPLE_RATE_HZ)
            .unwrap()
            .apply(&mut running)
            .unwrap();
        running
    }

    #[test]
    fn the_drive_is_the_firmwares_generator() {
        for waveform in [
            Waveform::Multisine {
                f_min_hz: 2.0,
                f_max_hz: 80.0,
                tones: 8,
            },
            Waveform::Prbs {
                bit_rate_hz: 500.0,
                register_bits: 10,
            },
            Waveform::Chirp {
                f_start_hz: 1.0,
                f_end_hz: 80.0,
                sweep_s: 4.0,
            },
            Waveform::Square { freq_hz: 11.0 },
            Waveform::Off,
        ] {
            let wire = protocol::Excitation {
                waveform,
                amplitude_v: 0.2,
                offset_v: 0.05,
            };
            let cfg = RunConfig {
                excitation: Some(wire),
                ..RunConfig::default()
            };
            let mut rig = scenario_rig(&cfg).unwrap();
            let mut device = firmware(&wire);
            for k in 0..100_000 {
                let u = rig.tick().u;
                assert_eq!(
                    u.to_bits(),
                    device.next_sample().to_bits(),
                    "{waveform:?} k={k}"
                );
            }
        }
    }

    #[test]
    fn without_an_excitation_the_drive_is_the_papers_square_wave() {
        let Drive::Square(s) = drive(&RunConfig::default()).unwrap() else {
            panic!("square wave expected")
        };
        assert_eq!(s, SquareWave::paper());
    }

    #[test]
    fn refused_settings_are_reasons() {
        let cfg = |waveform, amplitude_v| RunConfig {
            excitation: Some(protocol::Excitation {
                waveform,
                amplitude_v,
                offset_v: 0.0,
            }),
            ..RunConfig::default()
        };
        let e = drive(&cfg(Waveform::Square { freq_hz: 7.0 }, 20.0)).unwrap_err();
        assert!(e.to_string().contains("rejected (3)"), "{e}");
        let e = drive(&cfg(Waveform::Square { freq_hz: 6000.0 }, 0.1)).unwrap_err();
        assert!(e.to_string().contains("rejected (4)"), "{e}");
        // Off ignores the amplitude, as on the device.
        assert!(drive(&cfg(Waveform::Off, 20.0)).is_ok());
    }
}
