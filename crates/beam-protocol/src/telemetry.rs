//! Device → host messages: estimates, raw samples, status and command
//! acknowledgements. Field order here is wire order (postcard encodes a
//! struct as its fields in declaration order); `docs/PROTOCOL.md` lists each
//! field's bytes.

use heapless::Vec;
use serde::{Deserialize, Serialize};

use super::command::{EstimatorKind, EstimatorSettings, Excitation, RejectReason, TelemetryRates};
use super::size::{fields_of, tag_len, MaxSize};
use super::{MAX_MODES, MAX_RAW_SAMPLES, MAX_THETA};

/// Status flags of an [`Estimate`]: a bit field, sent as a postcard `u16`
/// (varint). Bits 14–15 are reserved: sent as 0, ignored by receivers.
/// (Bits 10–12 were reserved in the first release of version 1; a
/// receiver of that release ignores them, docs/PROTOCOL.md §4.1.)
/// "Since the last estimate" below: since the previous Estimate the device
/// sent (an event is flagged on exactly one estimate); the other bits are
/// a state at the estimate's sample.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[serde(transparent)]
pub struct StatusFlags(pub u16);

impl MaxSize for StatusFlags {
    const MAX_SIZE: usize = u16::MAX_SIZE;
}

impl StatusFlags {
    /// The excitation level ([`Estimate::excitation_level`]) is at least
    /// the device's threshold and INPUT_GONE is clear (Lemma 1).
    pub const EXCITED: Self = Self(1 << 0);
    /// Adaptation is frozen by a [`Command::Freeze`](super::Command::Freeze).
    pub const FROZEN_BY_COMMAND: Self = Self(1 << 1);
    /// The law was held by the firmware at some sample since the last
    /// estimate, or is frozen by it now (after a rejected sample, for new
    /// filters' settling time, while the input is gone).
    pub const FROZEN_AUTO: Self = Self(1 << 2);
    /// The estimate has settled, by the firmware's convergence test.
    pub const CONVERGED: Self = Self(1 << 3);
    /// The modes were recovered and are physical: ω > 0, 0 < ζ < 1,
    /// distinct modes. When clear, [`Estimate::modes`] may be empty.
    pub const PHYSICALLY_VALID: Self = Self(1 << 4);
    /// An ADC fault (CRC, status word, stuck data) since the last estimate.
    pub const SENSOR_FAULT: Self = Self(1 << 5);
    /// An ADC conversion saturated since the last estimate.
    pub const ADC_SATURATED: Self = Self(1 << 6);
    /// The DAC clipped the excitation since the last estimate.
    pub const DAC_SATURATED: Self = Self(1 << 7);
    /// Telemetry was dropped on the device (a queue full) since the last
    /// estimate.
    pub const TELEMETRY_DROPPED: Self = Self(1 << 8);
    /// The estimator's internal state check failed (`Health::state_ok`).
    pub const STATE_DEGRADED: Self = Self(1 << 9);
    /// Adaptation is frozen because the excitation stopped (the input's
    /// short-window energy fell 20 dB below its level). With EXCITED clear
    /// and this clear, Lemma 1 fails (or is not measured yet).
    pub const INPUT_GONE: Self = Self(1 << 10);
    /// The estimator detected a change of the plant since the last
    /// estimate and discounted its past (tracking).
    pub const CHANGE_DETECTED: Self = Self(1 << 11);
    /// The sensor's level changed since the last estimate: an offset step
    /// of y was removed, or a drift flagged.
    pub const SENSOR_LEVEL: Self = Self(1 << 12);
    /// The estimate's sample fell inside a self-test
    /// ([`Command::SelfTest`](super::Command::SelfTest), or the one at
    /// start-up): the drive was the self-test's and adaptation was held.
    pub const SELF_TEST: Self = Self(1 << 13);

    /// True if every bit of `other` is set.
    pub const fn contains(self, other: Self) -> bool {
        self.0 & other.0 == other.0
    }

    /// `self` with the bits of `other` set.
    #[must_use]
    pub const fn with(self, other: Self) -> Self {
        Self(self.0 | other.0)
    }

    /// Set or clear the bits of `other`.
    pub fn set(&mut self, other: Self, on: bool) {
        if on {
            self.0 |= other.0;
        } else {
            self.0 &= !other.0;
        }
    }
}

/// One mode's parameters (eqs. 30–32).
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ModeEstimate {
    /// Natural frequency ω̂_i (rad/s).
    pub omega_rad_s: f32,
    /// Damping ratio ζ̂_i (dimensionless).
    pub zeta: f32,
    /// Modal input gain b̂̄_i of eq. 32 (units of y per volt times s⁻²).
    pub b_bar: f32,
}

impl MaxSize for ModeEstimate {
    const MAX_SIZE: usize = fields_of::<Self, f32>() * f32::MAX_SIZE;
}

/// The current estimate, sent at the estimate rate (default 100 Hz). The
/// default is an estimate of nothing (sample 0, no modes, empty Θ̂, no
/// flags): not [`Estimate::is_consistent`], a base to build on.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Estimate {
    /// Index of the newest sample included, counted from 0 at start-up
    /// (not reset by [`Command::Reset`](super::Command::Reset)); the time
    /// is `sample_index / Status::sample_rate_hz`.
    pub sample_index: u64,
    /// The law that produced it.
    pub estimator: EstimatorKind,
    /// Status bits.
    pub flags: StatusFlags,
    /// ω̂, ζ̂, b̂̄ per mode, ascending ω; empty when recovery failed or the
    /// law has not updated yet, else as many modes as the model has (Θ has
    /// 4·modes − 1 entries).
    pub modes: Vec<ModeEstimate, MAX_MODES>,
    /// λ of the filter Λ(s) = (s + λ)^{2n} that `theta` belongs to (rad/s),
    /// finite and > 0: with it Θ̂ alone gives the transfer function.
    pub lambda_rad_s: f32,
    /// Θ̂ of eq. 29 in physical units, 4n − 1 entries for n modes (3, 7 or
    /// 11): [b_{2n−2}, …, b_0, k_{2n−1} − a_{2n−1}, …, k_0 − a_0], with k_j
    /// the coefficients of Λ(s) = (s + λ)^{2n} (λ = `lambda_rad_s`).
    pub theta: Vec<f32, MAX_THETA>,
    /// The excitation level λmin(P)/tr(P) of the scaled information matrix
    /// (Lemma 1), the quantity EXCITED is tested against; in [0, 1], never
    /// negative. `None` when not measured (a law without P, or not yet).
    pub excitation_level: Option<f32>,
}

impl MaxSize for Estimate {
    const MAX_SIZE: usize = u64::MAX_SIZE
        + EstimatorKind::MAX_SIZE
        + StatusFlags::MAX_SIZE
        + Vec::<ModeEstimate, MAX_MODES>::MAX_SIZE
        + f32::MAX_SIZE
        + Vec::<f32, MAX_THETA>::MAX_SIZE
        + Option::<f32>::MAX_SIZE;
}

impl Estimate {
    /// The model's mode count n implied by Θ's length (4n − 1), if valid.
    pub fn model_modes(&self) -> Option<usize> {
        let n = self.theta.len().checked_add(1)? / 4;
        (n >= 1 && 4 * n - 1 == self.theta.len()).then_some(n)
    }

    /// Θ has 4n − 1 entries (n = 1..=3), the mode list is empty or has n
    /// entries, λ is finite and > 0, and the excitation level (if any) is
    /// in [0, 1]. The encoder refuses, and the decoder rejects, any other.
    pub fn is_consistent(&self) -> bool {
        let lambda_ok = self.lambda_rad_s.is_finite() && self.lambda_rad_s > 0.0;
        let level_ok = self
            .excitation_level
            .is_none_or(|l| (0.0..=1.0).contains(&l));
        lambda_ok
            && level_ok
            && self
                .model_modes()
                .is_some_and(|n| self.modes.is_empty() || self.modes.len() == n)
    }
}

/// One raw sample pair, exactly as the estimator received it.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct UySample {
    /// Excitation u held over the sample period (V, at the DAC's input).
    pub u_v: f32,
    /// Measured output y in the estimator's units (the firmware's
    /// conversion of the ADC channel).
    pub y: f32,
}

impl MaxSize for UySample {
    const MAX_SIZE: usize = fields_of::<Self, f32>() * f32::MAX_SIZE;
}

/// A block of raw samples, for recording and replay. Sample i of the
/// block has index `first_sample_index + i·decimation`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct RawSamples {
    /// Sample index of the first pair (same count as
    /// [`Estimate::sample_index`]).
    pub first_sample_index: u64,
    /// Every `decimation`-th sample is sent (no anti-alias filter: the
    /// pairs are the estimator's own inputs); ≥ 1.
    pub decimation: u16,
    /// Up to [`MAX_RAW_SAMPLES`] pairs.
    pub samples: Vec<UySample, MAX_RAW_SAMPLES>,
}

impl MaxSize for RawSamples {
    const MAX_SIZE: usize =
        u64::MAX_SIZE + u16::MAX_SIZE + Vec::<UySample, MAX_RAW_SAMPLES>::MAX_SIZE;
}

/// The firmware's version.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct FirmwareVersion {
    /// Major version.
    pub major: u8,
    /// Minor version.
    pub minor: u8,
    /// Patch version.
    pub patch: u8,
}

impl MaxSize for FirmwareVersion {
    /// major, minor, patch.
    const MAX_SIZE: usize = u8::MAX_SIZE + u8::MAX_SIZE + u8::MAX_SIZE;
}

/// Device counters, all since start-up, saturating at 2³² − 1.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct DeviceCounters {
    /// Sample deadlines missed (the sample task overran).
    pub overruns: u32,
    /// ADC frames whose CRC failed.
    pub adc_crc_errors: u32,
    /// ADC frames with an unexpected status word.
    pub adc_status_errors: u32,
    /// Samples flagged as stuck sensor data.
    pub adc_stuck: u32,
    /// Saturated ADC conversions.
    pub adc_saturations: u32,
    /// Excitation samples clipped at the DAC's rails.
    pub dac_saturations: u32,
    /// Samples the estimator rejected (non-finite or out of range).
    pub rejected_samples: u32,
    /// Telemetry records dropped because the queue was full.
    pub telemetry_dropped: u32,
    /// Commands accepted and applied.
    pub commands_accepted: u32,
    /// Commands rejected (negative acknowledgement sent).
    pub commands_rejected: u32,
    /// Host → device frames that failed to decode (CRC, COBS, size,
    /// payload or protocol version).
    pub rx_frame_errors: u32,
}

impl MaxSize for DeviceCounters {
    const MAX_SIZE: usize = fields_of::<Self, u32>() * u32::MAX_SIZE;
}

impl DeviceCounters {
    /// Every counter by its field's name, in declaration (wire) order: what
    /// host tools write as named columns or keys.
    pub fn named(&self) -> [(&'static str, u32); 11] {
        [
            ("overruns", self.overruns),
            ("adc_crc_errors", self.adc_crc_errors),
            ("adc_status_errors", self.adc_status_errors),
            ("adc_stuck", self.adc_stuck),
            ("adc_saturations", self.adc_saturations),
            ("dac_saturations", self.dac_saturations),
            ("rejected_samples", self.rejected_samples),
            ("telemetry_dropped", self.telemetry_dropped),
            ("commands_accepted", self.commands_accepted),
            ("commands_rejected", self.commands_rejected),
            ("rx_frame_errors", self.rx_frame_errors),
        ]
    }
}

/// Counters and the settings in force, sent on request and at the status
/// rate.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Status {
    /// Samples taken since start-up: the index the next sample will get,
    /// so the newest sample at the time of this Status has index
    /// `uptime_samples − 1` (same count as [`Estimate::sample_index`]).
    pub uptime_samples: u64,
    /// The sample rate (Hz), e.g. 10,000.
    pub sample_rate_hz: f32,
    /// The firmware's version.
    pub firmware: FirmwareVersion,
    /// The estimator model's mode count n (1..=3).
    pub modes: u8,
    /// Device counters.
    pub counters: DeviceCounters,
    /// Adaptation frozen by command.
    pub adaptation_frozen: bool,
    /// The excitation in force.
    pub excitation: Excitation,
    /// The estimator settings in force; `lambda_rad_s` is the λ in use
    /// (`None` only before the automatic rule has chosen one).
    pub estimator: EstimatorSettings,
    /// The telemetry rates in force.
    pub telemetry: TelemetryRates,
    /// λ is chosen by the device's automatic rule (it may change without a
    /// command); false: λ is fixed by a `SetEstimator` with `Some(λ)`.
    pub lambda_automatic: bool,
    /// The self-test: not run yet, running, or the result of the latest.
    pub self_test: SelfTestState,
}

impl MaxSize for Status {
    const MAX_SIZE: usize = u64::MAX_SIZE
        + f32::MAX_SIZE
        + FirmwareVersion::MAX_SIZE
        + u8::MAX_SIZE
        + DeviceCounters::MAX_SIZE
        + bool::MAX_SIZE
        + Excitation::MAX_SIZE
        + EstimatorSettings::MAX_SIZE
        + TelemetryRates::MAX_SIZE
        + bool::MAX_SIZE
        + SelfTestState::MAX_SIZE;
}

/// A set of the self-test's checks (a bit field, sent as a postcard
/// `u16`). Bits 5–15 are reserved: sent as 0, ignored by receivers.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[serde(transparent)]
pub struct SelfTestChecks(pub u16);

impl MaxSize for SelfTestChecks {
    const MAX_SIZE: usize = u16::MAX_SIZE;
}

impl SelfTestChecks {
    /// The ADC's ID register names the part the firmware drives.
    pub const ADC_ID: Self = Self(1 << 0);
    /// The ADC's configuration registers read back as written.
    pub const ADC_REGISTERS: Self = Self(1 << 1);
    /// The conversion (DRDY) rate against the MCU's clock.
    pub const DRDY_RATE: Self = Self(1 << 2);
    /// DAC → ADC loopback on the monitor channel: gain, offset, delay.
    pub const LOOPBACK: Self = Self(1 << 3);
    /// The noise floor of y with the drive at zero, as an SNR against the
    /// default excitation's y.
    pub const NOISE: Self = Self(1 << 4);
    /// Every check, in bit order, with its name (`adc_id`, …).
    pub const ALL: [(Self, &'static str); 5] = [
        (Self::ADC_ID, "adc_id"),
        (Self::ADC_REGISTERS, "adc_registers"),
        (Self::DRDY_RATE, "drdy_rate"),
        (Self::LOOPBACK, "loopback"),
        (Self::NOISE, "noise"),
    ];

    /// True if every bit of `other` is set.
    pub const fn contains(self, other: Self) -> bool {
        self.0 & other.0 == other.0
    }

    /// `self` with the bits of `other` set.
    #[must_use]
    pub const fn with(self, other: Self) -> Self {
        Self(self.0 | other.0)
    }

    /// No check in the set.
    pub const fn is_empty(self) -> bool {
        self.0 == 0
    }
}

/// The self-test as a Status reports it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum SelfTestState {
    /// 0: no self-test has run since start-up.
    #[default]
    NotRun,
    /// 1: a self-test is running.
    Running,
    /// 2: the latest self-test ended; its checks that failed and those it
    /// could not measure (both empty: every check passed).
    Done {
        /// Checks that failed.
        failed: SelfTestChecks,
        /// Checks without the data to judge them (e.g. no conversions).
        not_measured: SelfTestChecks,
    },
}

impl MaxSize for SelfTestState {
    const MAX_SIZE: usize = tag_len(3) + 2 * SelfTestChecks::MAX_SIZE;
}

/// The ADC's identity and configuration, read back by the self-test.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct AdcCheck {
    /// The ID register as read (ADS131M02: 22xxh).
    pub id: u16,
    /// MODE, CLOCK and GAIN1 as read, masked to their writable bits.
    pub registers: [u16; 3],
    /// MODE, CLOCK and GAIN1 as configured, masked the same way.
    pub expected: [u16; 3],
}

impl MaxSize for AdcCheck {
    const MAX_SIZE: usize = 7 * u16::MAX_SIZE;
}

/// The conversion (DRDY) rate measured against the MCU's clock.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct DrdyCheck {
    /// Conversions per second of the MCU's clock (0: none).
    pub rate_hz: f32,
    /// The rate the firmware is built for (the sample rate).
    pub expected_hz: f32,
    /// Largest relative deviation that passes.
    pub tolerance: f32,
    /// New conversions read during the self-test.
    pub conversions: u32,
    /// Sample ticks during the self-test (reads attempted).
    pub ticks: u32,
}

impl MaxSize for DrdyCheck {
    const MAX_SIZE: usize = 3 * f32::MAX_SIZE + 2 * u32::MAX_SIZE;
}

/// DAC → ADC loopback: a test tone on the drive, read back on the
/// monitor channel (in actuator volts) and compared with the DAC's held
/// value at the tone's frequency. NaN: not measured.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct LoopbackCheck {
    /// The tone's frequency (Hz).
    pub tone_hz: f32,
    /// The tone's amplitude on the actuator (V).
    pub amplitude_v: f32,
    /// Monitor amplitude ÷ drive amplitude at the tone.
    pub gain: f32,
    /// The gain the firmware expects.
    pub expected_gain: f32,
    /// Largest relative deviation of the gain that passes.
    pub gain_tolerance: f32,
    /// Monitor mean − drive mean (actuator V).
    pub offset_v: f32,
    /// Largest |offset| that passes (V).
    pub offset_tolerance_v: f32,
    /// How far the monitor lags the drive written at the same tick
    /// (samples, from the phase at the tone).
    pub delay_samples: f32,
    /// The delay the firmware's timing model assumes (samples).
    pub expected_delay_samples: f32,
    /// Largest deviation of the delay that passes (samples).
    pub delay_tolerance_samples: f32,
}

impl MaxSize for LoopbackCheck {
    const MAX_SIZE: usize = fields_of::<Self, f32>() * f32::MAX_SIZE;
}

/// The noise floor of y with the drive at zero and the SNR against y
/// under the default excitation. NaN: not measured.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct NoiseCheck {
    /// Standard deviation of y's noise, drive at zero (units of y).
    pub noise_sd: f32,
    /// The converter's quantisation floor (one code of y / √12).
    pub floor_sd: f32,
    /// RMS of y under `excitation` (units of y).
    pub signal_rms: f32,
    /// 20·log10(signal_rms / max(noise_sd, floor_sd)) (dB).
    pub snr_db: f32,
    /// The lowest SNR that passes (dB).
    pub snr_min_db: f32,
    /// The excitation `signal_rms` was measured under (the device's
    /// default).
    pub excitation: Excitation,
}

impl MaxSize for NoiseCheck {
    const MAX_SIZE: usize = 5 * f32::MAX_SIZE + Excitation::MAX_SIZE;
}

/// The self-test's report (kind `05`), sent when a self-test ends: which
/// checks failed or could not be measured, and every measured value with
/// what was expected.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct SelfTestReport {
    /// The first sample of the self-test (the drive left the excitation).
    pub first_sample: u64,
    /// The last sample of the self-test (the excitation was restored at
    /// the next).
    pub last_sample: u64,
    /// Run at start-up (true) or on a `SelfTest` command.
    pub at_boot: bool,
    /// Checks that failed.
    pub failed: SelfTestChecks,
    /// Checks without the data to judge them.
    pub not_measured: SelfTestChecks,
    /// ID and register read-back.
    pub adc: AdcCheck,
    /// Conversion rate.
    pub drdy: DrdyCheck,
    /// DAC → ADC loopback.
    pub loopback: LoopbackCheck,
    /// Noise floor and SNR.
    pub noise: NoiseCheck,
}

impl MaxSize for SelfTestReport {
    const MAX_SIZE: usize = 2 * u64::MAX_SIZE
        + bool::MAX_SIZE
        + 2 * SelfTestChecks::MAX_SIZE
        + AdcCheck::MAX_SIZE
        + DrdyCheck::MAX_SIZE
        + LoopbackCheck::MAX_SIZE
        + NoiseCheck::MAX_SIZE;
}

impl SelfTestReport {
    /// Every check passed.
    pub fn passed(&self) -> bool {
        self.failed.is_empty() && self.not_measured.is_empty()
    }
}

/// The outcome of a command. On the wire a single byte: 0 = accepted,
/// otherwise the [`RejectReason`] code.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum AckResult {
    /// Validated and applied.
    Accepted,
    /// Refused; nothing changed.
    Rejected(RejectReason),
}

impl MaxSize for AckResult {
    /// One byte: 0 or the reason's code.
    const MAX_SIZE: usize = u8::MAX_SIZE;
}

impl AckResult {
    /// The wire byte.
    pub const fn code(self) -> u8 {
        match self {
            Self::Accepted => 0,
            Self::Rejected(r) => r as u8,
        }
    }

    /// The result for a wire byte, if the byte is defined.
    pub const fn from_code(code: u8) -> Option<Self> {
        if code == 0 {
            Some(Self::Accepted)
        } else {
            match RejectReason::from_code(code) {
                Some(r) => Some(Self::Rejected(r)),
                None => None,
            }
        }
    }
}

impl From<Result<(), RejectReason>> for AckResult {
    fn from(r: Result<(), RejectReason>) -> Self {
        match r {
            Ok(()) => Self::Accepted,
            Err(e) => Self::Rejected(e),
        }
    }
}

impl Serialize for AckResult {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_u8(self.code())
    }
}

impl<'de> Deserialize<'de> for AckResult {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let code = u8::deserialize(d)?;
        Self::from_code(code).ok_or_else(|| {
            serde::de::Error::invalid_value(
                serde::de::Unexpected::Unsigned(code.into()),
                &"0 or a reject reason code",
            )
        })
    }
}

/// The device's answer to one command frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Ack {
    /// The sequence number of the command frame (host → device stream).
    pub command_seq: u32,
    /// Accepted, or why not.
    pub result: AckResult,
}

impl MaxSize for Ack {
    const MAX_SIZE: usize = u32::MAX_SIZE + AckResult::MAX_SIZE;
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;

    fn estimate(theta_len: usize, modes: usize) -> Estimate {
        Estimate {
            sample_index: 0,
            estimator: EstimatorKind::Adaptive,
            flags: StatusFlags::default(),
            modes: (0..modes).map(|_| ModeEstimate::default()).collect(),
            lambda_rad_s: 100.0,
            theta: (0..theta_len).map(|i| i as f32).collect(),
            excitation_level: None,
        }
    }

    #[test]
    fn estimate_lambda_and_level_rules() {
        let ok = estimate(7, 2);
        assert!(ok.is_consistent());
        for l in [0.0, -1.0, f32::NAN, f32::INFINITY] {
            let e = Estimate {
                lambda_rad_s: l,
                ..ok.clone()
            };
            assert!(!e.is_consistent(), "λ {l}");
        }
        for (level, good) in [
            (0.0, true),
            (1e-7, true),
            (1.0, true),
            (-1e-9, false),
            (1.5, false),
            (f32::NAN, false),
        ] {
            let e = Estimate {
                excitation_level: Some(level),
                ..ok.clone()
            };
            assert_eq!(e.is_consistent(), good, "level {level}");
        }
    }

    #[test]
    fn estimate_consistency() {
        for (theta, modes, ok) in [
            (3, 0, true),
            (3, 1, true),
            (7, 2, true),
            (7, 0, true),
            (11, 3, true),
            (7, 1, false),
            (7, 3, false),
            (11, 2, false),
            (0, 0, false),
            (4, 1, false),
            (10, 0, false),
        ] {
            assert_eq!(
                estimate(theta, modes).is_consistent(),
                ok,
                "{theta} {modes}"
            );
        }
    }

    #[test]
    fn flags() {
        let mut f = StatusFlags::EXCITED.with(StatusFlags::CONVERGED);
        assert_eq!(f.0, 0b1001);
        assert!(f.contains(StatusFlags::EXCITED));
        assert!(!f.contains(StatusFlags::EXCITED.with(StatusFlags::SENSOR_FAULT)));
        f.set(StatusFlags::EXCITED, false);
        f.set(StatusFlags::STATE_DEGRADED, true);
        assert_eq!(f.0, 0b10_0000_1000);
    }

    #[test]
    fn ack_codes_round_trip() {
        assert_eq!(AckResult::from_code(0), Some(AckResult::Accepted));
        for code in 1..=u8::MAX {
            match AckResult::from_code(code) {
                Some(r) => assert_eq!(r.code(), code),
                None => assert!(RejectReason::from_code(code).is_none()),
            }
        }
        let r: AckResult = Err(RejectReason::LinkBudget).into();
        assert_eq!(r, AckResult::Rejected(RejectReason::LinkBudget));
    }
}
