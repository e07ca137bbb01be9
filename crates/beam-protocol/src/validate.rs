//! Validation of commands on the device: range, finiteness and consistency
//! against the device's [`Limits`]. A command that fails is answered with
//! its [`RejectReason`] and changes nothing; one that passes is safe to
//! apply as it is.
//!
//! Checks run in a fixed order (finiteness first, then each field in wire
//! order), so a command with several faults always gets the same reason.
//! Comparisons are made in `f32`, as the values travel.

use core::f32::consts::PI;

use super::budget::LinkLoad;
use super::command::{check, finite, Limits};
use super::command::{
    Command, EstimatorSettings, Excitation, LineRemoval, RejectReason, TelemetryRates, Waveform,
};

impl Excitation {
    /// Check the waveform, the amplitude and that offset ± amplitude stays
    /// inside the piezo's safe window.
    pub fn validate(&self, limits: &Limits) -> Result<(), RejectReason> {
        finite(&[self.amplitude_v, self.offset_v])?;
        self.waveform.validate(limits)?;
        check(self.amplitude_v >= 0.0, RejectReason::Amplitude)?;
        let peak = match self.waveform {
            Waveform::Off => 0.0,
            _ => self.amplitude_v,
        };
        check(
            self.offset_v - peak >= limits.piezo_min_v
                && self.offset_v + peak <= limits.piezo_max_v,
            RejectReason::SafeWindow,
        )
    }
}

impl EstimatorSettings {
    /// Check that the estimator exists here and that its gains, forgetting
    /// rates and λ are positive (what `UpdateLaw::new` and
    /// `FilterConfig::validate` require), and λ below π·f_s.
    pub fn validate(&self, limits: &Limits) -> Result<(), RejectReason> {
        finite(&[
            self.gain,
            self.forgetting_p,
            self.forgetting_h,
            self.initial_gain,
            self.lambda_rad_s.unwrap_or(1.0),
        ])?;
        check(
            limits.has_estimator(self.kind),
            RejectReason::EstimatorUnavailable,
        )?;
        check(
            self.gain > 0.0 && self.initial_gain > 0.0,
            RejectReason::Gain,
        )?;
        check(
            self.forgetting_p > 0.0 && self.forgetting_h > 0.0,
            RejectReason::Forgetting,
        )?;
        match self.lambda_rad_s {
            Some(l) => check(
                l > 0.0 && l < PI * limits.sample_rate_hz,
                RejectReason::Lambda,
            ),
            None => Ok(()),
        }
    }
}

impl TelemetryRates {
    /// Check that the rates are within [0, f_s] and that their worst-case
    /// load ([`LinkLoad`]) fits in the link budget.
    pub fn validate(&self, limits: &Limits) -> Result<(), RejectReason> {
        finite(&[self.estimate_rate_hz, self.status_rate_hz])?;
        let fs = limits.sample_rate_hz;
        check(
            (0.0..=fs).contains(&self.estimate_rate_hz)
                && (0.0..=fs).contains(&self.status_rate_hz),
            RejectReason::Rate,
        )?;
        let load = LinkLoad::new(self, fs, usize::from(limits.modes));
        check(
            load.total_b_s() <= limits.link_bytes_per_s,
            RejectReason::LinkBudget,
        )
    }
}

impl LineRemoval {
    /// Check that the numbers are finite and, unless off, that the mains
    /// frequency is in (0, f_s/2), the harmonics in 1..=[`LineRemoval::MAX_HARMONICS`]
    /// and the time constant between 10 samples and
    /// [`LineRemoval::MAX_TIME_CONSTANT_S`].
    pub fn validate(&self, limits: &Limits) -> Result<(), RejectReason> {
        finite(&[self.mains_hz, self.time_constant_s])?;
        if self.is_off() {
            return Ok(());
        }
        check(
            self.mains_hz > 0.0 && self.mains_hz < limits.nyquist_hz(),
            RejectReason::Frequency,
        )?;
        check(
            (1..=Self::MAX_HARMONICS).contains(&self.harmonics)
                && self.time_constant_s >= 10.0 / limits.sample_rate_hz
                && self.time_constant_s <= Self::MAX_TIME_CONSTANT_S,
            RejectReason::LineRemoval,
        )
    }
}

impl Command {
    /// Check the command against the device's limits. `Ok` means it can be
    /// applied as it is; `Err` carries the reason for the negative
    /// acknowledgement, and the device must then change nothing.
    pub fn validate(&self, limits: &Limits) -> Result<(), RejectReason> {
        match self {
            Self::SetExcitation(e) => e.validate(limits),
            Self::SetEstimator(s) => s.validate(limits),
            Self::SetTelemetry(t) => t.validate(limits),
            Self::SetLineRemoval(l) => l.validate(limits),
            Self::Reset | Self::Freeze | Self::Resume | Self::RequestStatus | Self::SelfTest => {
                Ok(())
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::budget::uart_bytes_per_s;
    use crate::command::EstimatorKind;
    use RejectReason as R;

    const LIMITS: Limits = Limits {
        sample_rate_hz: 10_000.0,
        piezo_min_v: -1.0,
        piezo_max_v: 2.0,
        max_multisine_tones: 16,
        prbs_bits_min: 3,
        prbs_bits_max: 31,
        estimators: 0b0111,
        modes: 2,
        link_bytes_per_s: uart_bytes_per_s(921_600) as f32,
    };

    fn excitation(waveform: Waveform, amplitude_v: f32, offset_v: f32) -> Result<(), R> {
        Command::SetExcitation(Excitation {
            waveform,
            amplitude_v,
            offset_v,
        })
        .validate(&LIMITS)
    }

    #[test]
    fn excitation_table() {
        let sq = |f| Waveform::Square { freq_hz: f };
        let ms = |a, b, n| Waveform::Multisine {
            f_min_hz: a,
            f_max_hz: b,
            tones: n,
        };
        let prbs = |r, n| Waveform::Prbs {
            bit_rate_hz: r,
            register_bits: n,
        };
        let chirp = |a, b, t| Waveform::Chirp {
            f_start_hz: a,
            f_end_hz: b,
            sweep_s: t,
        };
        let nan = f32::NAN;
        let inf = f32::INFINITY;
        let cases: &[(Waveform, f32, f32, Result<(), R>)] = &[
            (sq(7.0), 0.1, 0.0, Ok(())),
            (Waveform::Off, 0.0, 0.5, Ok(())),
            // Off ignores the amplitude for the window, not for finiteness.
            (Waveform::Off, 5.0, 1.9, Ok(())),
            (Waveform::Off, nan, 0.0, Err(R::NotFinite)),
            (Waveform::Off, 0.0, 2.5, Err(R::SafeWindow)),
            (sq(nan), 0.1, 0.0, Err(R::NotFinite)),
            (sq(7.0), 0.1, inf, Err(R::NotFinite)),
            (sq(0.0), 0.1, 0.0, Err(R::Frequency)),
            (sq(-3.0), 0.1, 0.0, Err(R::Frequency)),
            (sq(5_000.0), 0.1, 0.0, Err(R::Frequency)),
            (sq(4_999.0), 0.1, 0.0, Ok(())),
            (sq(7.0), -0.1, 0.0, Err(R::Amplitude)),
            // Window: [−1, 2] V.
            (sq(7.0), 1.0, 0.0, Ok(())),
            (sq(7.0), 1.0, 1.0, Ok(())),
            (sq(7.0), 1.5, 0.0, Err(R::SafeWindow)),
            (sq(7.0), 0.5, 1.6, Err(R::SafeWindow)),
            (ms(5.0, 50.0, 8), 0.5, 0.0, Ok(())),
            (ms(5.0, 5.0, 1), 0.5, 0.0, Ok(())),
            (ms(5.0, 5.0, 2), 0.5, 0.0, Err(R::Band)),
            (ms(50.0, 5.0, 2), 0.5, 0.0, Err(R::Band)),
            (ms(5.0, 50.0, 0), 0.5, 0.0, Err(R::ToneCount)),
            (ms(5.0, 50.0, 17), 0.5, 0.0, Err(R::ToneCount)),
            (ms(0.0, 50.0, 4), 0.5, 0.0, Err(R::Frequency)),
            (ms(5.0, 6_000.0, 4), 0.5, 0.0, Err(R::Frequency)),
            (ms(5.0, nan, 4), 0.5, 0.0, Err(R::NotFinite)),
            (prbs(1_000.0, 10), 0.5, 0.0, Ok(())),
            (prbs(10_000.0, 31), 0.5, 0.0, Ok(())),
            (prbs(10_001.0, 10), 0.5, 0.0, Err(R::Frequency)),
            (prbs(0.0, 10), 0.5, 0.0, Err(R::Frequency)),
            (prbs(1_000.0, 2), 0.5, 0.0, Err(R::PrbsLength)),
            (prbs(1_000.0, 32), 0.5, 0.0, Err(R::PrbsLength)),
            (chirp(1.0, 100.0, 10.0), 0.5, 0.0, Ok(())),
            (chirp(100.0, 1.0, 10.0), 0.5, 0.0, Err(R::Band)),
            (chirp(100.0, 100.0, 10.0), 0.5, 0.0, Err(R::Band)),
            (chirp(1.0, 5_000.0, 10.0), 0.5, 0.0, Err(R::Frequency)),
            (chirp(0.0, 100.0, 10.0), 0.5, 0.0, Err(R::Frequency)),
            (chirp(1.0, 100.0, 1e-4), 0.5, 0.0, Err(R::SweepTime)),
            (chirp(1.0, 100.0, 3e-4), 0.5, 0.0, Ok(())),
            (chirp(1.0, 100.0, 1e6), 0.5, 0.0, Err(R::SweepTime)),
            (chirp(1.0, 100.0, -1.0), 0.5, 0.0, Err(R::SweepTime)),
            (chirp(1.0, 100.0, inf), 0.5, 0.0, Err(R::NotFinite)),
        ];
        for (i, &(w, a, o, want)) in cases.iter().enumerate() {
            assert_eq!(excitation(w, a, o), want, "case {i}: {w:?} a={a} o={o}");
        }
    }

    #[test]
    fn estimator_table() {
        let base = EstimatorSettings::default();
        let with = |f: &dyn Fn(&mut EstimatorSettings)| {
            let mut s = base;
            f(&mut s);
            Command::SetEstimator(s).validate(&LIMITS)
        };
        assert_eq!(with(&|_| ()), Ok(()));
        assert_eq!(with(&|s| s.lambda_rad_s = Some(100.0)), Ok(()));
        assert_eq!(
            with(&|s| s.lambda_rad_s = Some(f32::NAN)),
            Err(R::NotFinite)
        );
        assert_eq!(with(&|s| s.lambda_rad_s = Some(0.0)), Err(R::Lambda));
        assert_eq!(with(&|s| s.lambda_rad_s = Some(31_416.0)), Err(R::Lambda));
        assert_eq!(with(&|s| s.lambda_rad_s = Some(31_415.0)), Ok(()));
        assert_eq!(with(&|s| s.gain = f32::INFINITY), Err(R::NotFinite));
        assert_eq!(with(&|s| s.gain = 0.0), Err(R::Gain));
        assert_eq!(with(&|s| s.initial_gain = -1.0), Err(R::Gain));
        assert_eq!(with(&|s| s.forgetting_p = 0.0), Err(R::Forgetting));
        assert_eq!(with(&|s| s.forgetting_h = -0.1), Err(R::Forgetting));
        assert_eq!(with(&|s| s.forgetting_h = f32::NAN), Err(R::NotFinite));
        assert_eq!(with(&|s| s.kind = EstimatorKind::LeastSquares), Ok(()));
        // LIMITS has no robust estimator.
        assert_eq!(
            with(&|s| s.kind = EstimatorKind::Robust),
            Err(R::EstimatorUnavailable)
        );
    }

    #[test]
    fn telemetry_table() {
        let t = |e: f32, d: u16, s: f32| {
            Command::SetTelemetry(TelemetryRates {
                estimate_rate_hz: e,
                raw_decimation: d,
                status_rate_hz: s,
            })
            .validate(&LIMITS)
        };
        assert_eq!(t(100.0, 0, 1.0), Ok(()));
        assert_eq!(t(0.0, 0, 0.0), Ok(()));
        assert_eq!(t(100.0, 2, 1.0), Ok(()));
        assert_eq!(t(100.0, 1, 1.0), Err(R::LinkBudget));
        assert_eq!(t(0.0, 1, 1.0), Ok(()));
        assert_eq!(t(10_000.0, 0, 0.0), Err(R::LinkBudget));
        assert_eq!(t(10_001.0, 0, 0.0), Err(R::Rate));
        assert_eq!(t(-1.0, 0, 0.0), Err(R::Rate));
        assert_eq!(t(100.0, 0, -1.0), Err(R::Rate));
        assert_eq!(t(f32::NAN, 0, 1.0), Err(R::NotFinite));
    }

    #[test]
    fn line_removal_table() {
        let l = |mains_hz: f32, harmonics: u8, time_constant_s: f32| {
            Command::SetLineRemoval(LineRemoval {
                mains_hz,
                harmonics,
                time_constant_s,
            })
            .validate(&LIMITS)
        };
        assert_eq!(l(50.0, 7, 0.2), Ok(()));
        assert_eq!(l(60.0, 1, 100.0), Ok(()));
        assert_eq!(l(49.6, 3, 1e-3), Ok(()));
        // Off: the other fields are not used, but must be finite.
        assert_eq!(l(0.0, 0, 0.0), Ok(()));
        assert_eq!(l(0.0, 7, f32::NAN), Err(R::NotFinite));
        assert_eq!(l(f32::INFINITY, 7, 0.2), Err(R::NotFinite));
        assert_eq!(l(-50.0, 7, 0.2), Err(R::Frequency));
        assert_eq!(l(5_000.0, 1, 0.2), Err(R::Frequency));
        assert_eq!(l(50.0, 0, 0.2), Err(R::LineRemoval));
        assert_eq!(l(50.0, 8, 0.2), Err(R::LineRemoval));
        assert_eq!(l(50.0, 7, 9e-4), Err(R::LineRemoval));
        assert_eq!(l(50.0, 7, 101.0), Err(R::LineRemoval));
        assert_eq!(LineRemoval::default(), LineRemoval::OFF);
        assert!(LineRemoval::OFF.is_off());
    }

    #[test]
    fn plain_commands_always_pass() {
        for c in [
            Command::Reset,
            Command::Freeze,
            Command::Resume,
            Command::RequestStatus,
            Command::SelfTest,
        ] {
            assert_eq!(c.validate(&LIMITS), Ok(()));
        }
    }
}
