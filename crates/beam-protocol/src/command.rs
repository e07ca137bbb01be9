//! Host → device commands and the settings they carry, the device's
//! [`Limits`] and each waveform's own checks against them. Every command
//! is checked by [`Command::validate`] before anything changes (module
//! [`validate`](super::validate): the commands' checks, the link budget's
//! included).

use core::fmt;
use core::str::FromStr;

use serde::{Deserialize, Serialize};

use super::size::{max, tag_len, MaxSize};

/// Which update law produced an estimate. Wire value: the discriminant.
/// Default: the paper's law, as in [`EstimatorSettings::default`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[repr(u8)]
pub enum EstimatorKind {
    /// The paper's proposed law, eqs. 33–41.
    #[default]
    Adaptive = 0,
    /// The gradient baseline, eq. 47.
    Gradient = 1,
    /// The least-squares baseline, eq. 48.
    LeastSquares = 2,
    /// A noise-robust (bias-compensated) law, where the firmware has one.
    Robust = 3,
}

impl MaxSize for EstimatorKind {
    /// The enum tag.
    const MAX_SIZE: usize = tag_len(Self::ALL.len());
}

impl EstimatorKind {
    /// Every kind, in wire order.
    pub const ALL: [Self; 4] = [
        Self::Adaptive,
        Self::Gradient,
        Self::LeastSquares,
        Self::Robust,
    ];

    /// This kind's bit in [`Limits::estimators`](super::Limits::estimators).
    pub const fn bit(self) -> u8 {
        1 << (self as u8)
    }

    /// The kind's name, as the host tools write and read it: `adaptive`,
    /// `gradient`, `ls`, `robust`.
    pub const fn name(self) -> &'static str {
        match self {
            Self::Adaptive => "adaptive",
            Self::Gradient => "gradient",
            Self::LeastSquares => "ls",
            Self::Robust => "robust",
        }
    }
}

impl fmt::Display for EstimatorKind {
    /// The [`name`](Self::name).
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// A name that is no [`EstimatorKind`]'s.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct UnknownEstimator;

impl fmt::Display for UnknownEstimator {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str("not an estimator kind (adaptive, gradient, ls, robust)")
    }
}

impl core::error::Error for UnknownEstimator {}

impl FromStr for EstimatorKind {
    type Err = UnknownEstimator;

    /// The kind of this [`name`](Self::name) (exact match).
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        Self::ALL
            .into_iter()
            .find(|k| k.name() == s)
            .ok_or(UnknownEstimator)
    }
}

/// What the sensor measures, as the estimator's model sees it: the
/// output's relative degree. With A(s) the modes' denominator and B(s)
/// their numerator of degree ≤ 2n − 2 (PROTOCOL.md §4.0), the model is
/// G(s) = s^r·B(s)/A(s) with r = 2 − relative degree: a strain gauge or a
/// displacement sensor reads B/A (relative degree 2), a velocity sensor
/// s·B/A (1), an accelerometer s²·B/A (0: numerator and denominator of the
/// same degree, a direct term). B, the modes and b̄ keep their meaning
/// whatever the kind. Wire value: the discriminant. Default: `Strain`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[repr(u8)]
pub enum OutputKind {
    /// Strain or displacement (relative degree 2): G = B/A.
    #[default]
    Strain = 0,
    /// Velocity (relative degree 1): G = s·B/A.
    Velocity = 1,
    /// Acceleration (relative degree 0): G = s²·B/A.
    Acceleration = 2,
}

impl MaxSize for OutputKind {
    /// The enum tag.
    const MAX_SIZE: usize = tag_len(Self::ALL.len());
}

impl OutputKind {
    /// Every kind, in wire order.
    pub const ALL: [Self; 3] = [Self::Strain, Self::Velocity, Self::Acceleration];

    /// The kind's name, as the host tools write it: `strain`, `velocity`,
    /// `acceleration` (they also read `displacement` as `strain`).
    pub const fn name(self) -> &'static str {
        match self {
            Self::Strain => "strain",
            Self::Velocity => "velocity",
            Self::Acceleration => "acceleration",
        }
    }

    /// The output's relative degree: 2, 1 or 0.
    pub const fn relative_degree(self) -> usize {
        2 - self.numerator_shift()
    }

    /// r of G = s^r·B/A: 0, 1 or 2.
    pub const fn numerator_shift(self) -> usize {
        self as usize
    }
}

impl fmt::Display for OutputKind {
    /// The [`name`](Self::name).
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// A name that is no [`OutputKind`]'s.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct UnknownOutput;

impl fmt::Display for UnknownOutput {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str("not a sensor output kind (strain, displacement, velocity, acceleration)")
    }
}

impl core::error::Error for UnknownOutput {}

impl FromStr for OutputKind {
    type Err = UnknownOutput;

    /// The kind of this [`name`](Self::name), or `displacement` for
    /// [`OutputKind::Strain`] (exact match).
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        if s == "displacement" {
            return Ok(Self::Strain);
        }
        Self::ALL
            .into_iter()
            .find(|k| k.name() == s)
            .ok_or(UnknownOutput)
    }
}

/// The excitation waveform. Wire value of the variant: its index below
/// (postcard enum tag), then its fields.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Waveform {
    /// 0: no excitation; the output holds `offset_v`.
    Off,
    /// 1: square wave ±amplitude about the offset (the paper's excitation,
    /// Section IV.A: 0.1 V at 7 Hz).
    Square {
        /// Frequency (Hz), 0 < f < f_s/2.
        freq_hz: f32,
    },
    /// 2: a sum of `tones` sinusoids spread over [f_min, f_max], scaled so
    /// that the peak stays within ±amplitude (spacing and phases are the
    /// generator's).
    Multisine {
        /// Lowest tone (Hz), > 0.
        f_min_hz: f32,
        /// Highest tone (Hz), < f_s/2; > f_min unless `tones` = 1.
        f_max_hz: f32,
        /// Number of tones, 1..=[`Limits::max_multisine_tones`].
        tones: u8,
    },
    /// 3: a maximal-length pseudo-random binary sequence, ±amplitude about
    /// the offset.
    Prbs {
        /// Bit rate (Hz), 0 < rate ≤ f_s.
        bit_rate_hz: f32,
        /// Shift-register length n (period 2ⁿ − 1 bits), within
        /// [`Limits::prbs_bits_min`]..=[`Limits::prbs_bits_max`].
        register_bits: u8,
    },
    /// 4: a linear chirp from `f_start_hz` to `f_end_hz` over `sweep_s`,
    /// repeated.
    Chirp {
        /// Start frequency (Hz), > 0.
        f_start_hz: f32,
        /// End frequency (Hz), f_start < f_end < f_s/2.
        f_end_hz: f32,
        /// Sweep duration (s): at least 2 samples, at most 2³¹ samples.
        sweep_s: f32,
    },
}

impl MaxSize for Waveform {
    /// The tag of five variants and the longest variant's fields.
    const MAX_SIZE: usize = tag_len(5)
        + max(
            f32::MAX_SIZE,
            max(
                2 * f32::MAX_SIZE + u8::MAX_SIZE,
                max(f32::MAX_SIZE + u8::MAX_SIZE, 3 * f32::MAX_SIZE),
            ),
        );
}

impl Waveform {
    /// Which waveform this is.
    pub const fn kind(&self) -> WaveformKind {
        match self {
            Self::Off => WaveformKind::Off,
            Self::Square { .. } => WaveformKind::Square,
            Self::Multisine { .. } => WaveformKind::Multisine,
            Self::Prbs { .. } => WaveformKind::Prbs,
            Self::Chirp { .. } => WaveformKind::Chirp,
        }
    }

    /// The waveform's own parameters, each by its field's name, in
    /// declaration order (none for `Off`); integer fields as exact `f32`.
    /// Host tools write them as `name=value` (the recording's header,
    /// `docs/RECORDING.md`), so a new variant's parameters need no code
    /// there.
    pub fn params(&self) -> heapless::Vec<(&'static str, f32), 3> {
        let list: &[(&'static str, f32)] = match *self {
            Self::Off => &[],
            Self::Square { freq_hz } => &[("freq_hz", freq_hz)],
            Self::Multisine {
                f_min_hz,
                f_max_hz,
                tones,
            } => &[
                ("f_min_hz", f_min_hz),
                ("f_max_hz", f_max_hz),
                ("tones", tones as f32),
            ],
            Self::Prbs {
                bit_rate_hz,
                register_bits,
            } => &[
                ("bit_rate_hz", bit_rate_hz),
                ("register_bits", register_bits as f32),
            ],
            Self::Chirp {
                f_start_hz,
                f_end_hz,
                sweep_s,
            } => &[
                ("f_start_hz", f_start_hz),
                ("f_end_hz", f_end_hz),
                ("sweep_s", sweep_s),
            ],
        };
        // At most three parameters per variant: the capacity holds them.
        heapless::Vec::from_slice(list).unwrap_or_default()
    }
}

/// A [`Waveform`]'s variant without its fields (not sent on its own): the
/// kind a generator runs and the names the host's tools use
/// (`beamctl send excitation --wave square`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum WaveformKind {
    /// [`Waveform::Off`].
    Off,
    /// [`Waveform::Square`].
    Square,
    /// [`Waveform::Multisine`].
    Multisine,
    /// [`Waveform::Prbs`].
    Prbs,
    /// [`Waveform::Chirp`].
    Chirp,
}

impl WaveformKind {
    /// Every kind, in wire-tag order.
    pub const ALL: [Self; 5] = [
        Self::Off,
        Self::Square,
        Self::Multisine,
        Self::Prbs,
        Self::Chirp,
    ];

    /// The lower-case name: `off`, `square`, `multisine`, `prbs`, `chirp`.
    pub const fn name(self) -> &'static str {
        match self {
            Self::Off => "off",
            Self::Square => "square",
            Self::Multisine => "multisine",
            Self::Prbs => "prbs",
            Self::Chirp => "chirp",
        }
    }

    /// The kind of this [`WaveformKind::name`], if any.
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|k| k.name() == name)
    }
}

/// The excitation: waveform, peak amplitude and offset. The output stays in
/// [offset − amplitude, offset + amplitude], which must lie inside the
/// piezo's safe window ([`Limits::piezo_min_v`], [`Limits::piezo_max_v`]).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Excitation {
    /// The waveform.
    pub waveform: Waveform,
    /// Peak deviation from the offset (V), ≥ 0 (ignored for `Off`).
    pub amplitude_v: f32,
    /// DC offset (V).
    pub offset_v: f32,
}

impl MaxSize for Excitation {
    const MAX_SIZE: usize = Waveform::MAX_SIZE + f32::MAX_SIZE + f32::MAX_SIZE;
}

impl Default for Excitation {
    /// The paper's excitation (Section IV.A): 0.1 V square wave at 7 Hz.
    fn default() -> Self {
        Self {
            waveform: Waveform::Square { freq_hz: 7.0 },
            amplitude_v: 0.1,
            offset_v: 0.0,
        }
    }
}

/// Estimator settings, in the scaled coordinates of `filter_bank::Scaling`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct EstimatorSettings {
    /// The update law.
    pub kind: EstimatorKind,
    /// Learning gain (1/s), > 0: Γ of eq. 41 (adaptive law), Γ1 = gain·I
    /// of eq. 47 (gradient law); unused by least squares.
    pub gain: f32,
    /// Forgetting rate l of eq. 33 (1/s), > 0.
    pub forgetting_p: f32,
    /// Forgetting rate γ of eq. 37 (1/s), > 0.
    pub forgetting_h: f32,
    /// Initial gain, > 0: H(0) = initial_gain·I (adaptive law, so
    /// R(0) = H(0)⁻¹ = I/initial_gain), Γ2(0) = initial_gain·I (least
    /// squares, eq. 48); unused by the gradient law.
    pub initial_gain: f32,
    /// Filter pole λ of Λ(s) = (s + λ)^{2n} (rad/s), 0 < λ < π·f_s; `None`:
    /// the firmware's automatic (truth-free) rule. In a
    /// [`Status`](super::Status), the λ in use (`None` until the rule has
    /// chosen).
    pub lambda_rad_s: Option<f32>,
    /// What the sensor measures: the model's numerator degree
    /// (G = s^r·B/A, [`OutputKind`]). Every law of the firmware runs every
    /// kind (protocol version 3).
    pub output: OutputKind,
}

impl MaxSize for EstimatorSettings {
    const MAX_SIZE: usize = EstimatorKind::MAX_SIZE
        + f32::MAX_SIZE
        + f32::MAX_SIZE
        + f32::MAX_SIZE
        + f32::MAX_SIZE
        + Option::<f32>::MAX_SIZE
        + OutputKind::MAX_SIZE;
}

impl Default for EstimatorSettings {
    /// The core's defaults (`AdaptiveConfig::default`): Γ = 1e4,
    /// l = γ = 0.05 /s, R(0) = 1e-9·I, automatic λ, a strain (or
    /// displacement) output.
    fn default() -> Self {
        Self {
            kind: EstimatorKind::Adaptive,
            gain: 1e4,
            forgetting_p: 0.05,
            forgetting_h: 0.05,
            initial_gain: 1e9,
            lambda_rad_s: None,
            output: OutputKind::Strain,
        }
    }
}

/// Telemetry rates.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct TelemetryRates {
    /// Estimates per second (Hz), 0 = off; sent every round(f_s/rate)
    /// samples.
    pub estimate_rate_hz: f32,
    /// Raw samples: every `raw_decimation`-th sample; 0 = off.
    pub raw_decimation: u16,
    /// Status frames per second (Hz); 0 = only on request.
    pub status_rate_hz: f32,
}

impl MaxSize for TelemetryRates {
    const MAX_SIZE: usize = f32::MAX_SIZE + u16::MAX_SIZE + f32::MAX_SIZE;
}

impl Default for TelemetryRates {
    /// Estimates at 100 Hz, raw samples off, status at 1 Hz.
    fn default() -> Self {
        Self {
            estimate_rate_hz: 100.0,
            raw_decimation: 0,
            status_rate_hz: 1.0,
        }
    }
}

/// The line remover (issue 16): an adaptive line canceller at the mains
/// frequency and its harmonics, applied identically to u and y after the
/// sensor guard and before the estimator (the same LTI notch on both
/// leaves the u → y transfer function unchanged; docs/FIRMWARE.md, "The
/// line remover"). Its weights start from zero: a line present at the
/// switch decays as e^(−t/τ) in the estimator's y, and the device holds
/// the law meanwhile.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct LineRemoval {
    /// The mains (fundamental) frequency (Hz), 0 < f < f_s/2; 0 = off (the
    /// other fields are then not used).
    pub mains_hz: f32,
    /// Harmonics 1..=`harmonics` of it are removed (those below f_s/2),
    /// 1..=[`LineRemoval::MAX_HARMONICS`].
    pub harmonics: u8,
    /// The weights' time constant τ (s): the notch is about 1/(πτ) Hz
    /// wide; at least 10 samples, at most [`LineRemoval::MAX_TIME_CONSTANT_S`].
    pub time_constant_s: f32,
}

impl MaxSize for LineRemoval {
    const MAX_SIZE: usize = f32::MAX_SIZE + u8::MAX_SIZE + f32::MAX_SIZE;
}

impl LineRemoval {
    /// The highest harmonic a device removes (the mains' odd harmonics to
    /// the 7th, and the even ones between).
    pub const MAX_HARMONICS: u8 = 7;
    /// The longest time constant accepted (s).
    pub const MAX_TIME_CONSTANT_S: f32 = 100.0;
    /// The time constant the host tools send by default (s): a notch
    /// about 1.6 Hz wide, a line gone to 1e-3 of itself 1.4 s after the
    /// switch.
    pub const DEFAULT_TIME_CONSTANT_S: f32 = 0.2;

    /// No line removed.
    pub const OFF: Self = Self {
        mains_hz: 0.0,
        harmonics: Self::MAX_HARMONICS,
        time_constant_s: Self::DEFAULT_TIME_CONSTANT_S,
    };

    /// Whether this removes nothing (`mains_hz` = 0).
    pub fn is_off(&self) -> bool {
        self.mains_hz == 0.0
    }
}

impl Default for LineRemoval {
    /// Off.
    fn default() -> Self {
        Self::OFF
    }
}

/// A command from the host. Every command is answered by an
/// [`Ack`](super::Ack) carrying the command frame's sequence number.
/// Wire value of the variant: its index below (postcard enum tag).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Command {
    /// 0: set the excitation.
    SetExcitation(Excitation),
    /// 1: set the estimator settings (the estimator restarts with them).
    SetEstimator(EstimatorSettings),
    /// 2: set the telemetry rates.
    SetTelemetry(TelemetryRates),
    /// 3: reset the estimator to its initial state (filters at rest,
    /// initial Θ and gains); settings, counters and sample index are kept.
    Reset,
    /// 4: freeze adaptation (Θ held; the filters keep running).
    Freeze,
    /// 5: resume adaptation.
    Resume,
    /// 6: send a [`Status`](super::Status) now.
    RequestStatus,
    /// 7: run the bring-up self-test (converter ID and registers, DRDY
    /// rate, DAC → ADC loopback, noise floor and SNR) and send its
    /// [`SelfTestReport`](super::SelfTestReport) when it ends. The Ack
    /// says it started; the drive is the self-test's and adaptation is
    /// held while it runs (`docs/PROTOCOL.md` §5, §9.7).
    SelfTest,
    /// 8: set the line remover (protocol version 3).
    SetLineRemoval(LineRemoval),
}

impl MaxSize for Command {
    /// The tag of eight variants and the longest argument.
    const MAX_SIZE: usize = tag_len(8)
        + max(
            Excitation::MAX_SIZE,
            max(
                EstimatorSettings::MAX_SIZE,
                max(TelemetryRates::MAX_SIZE, LineRemoval::MAX_SIZE),
            ),
        );
}

/// Why a command was refused. Stable wire codes (the byte in
/// [`AckResult`](super::AckResult)); 0 means accepted and is not a reason.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[repr(u8)]
pub enum RejectReason {
    /// A number is NaN or infinite.
    NotFinite = 1,
    /// The amplitude is negative.
    Amplitude = 2,
    /// offset ± amplitude leaves the piezo's safe window.
    SafeWindow = 3,
    /// A frequency is ≤ 0 or at/above the Nyquist frequency (for PRBS: the
    /// bit rate above the sample rate).
    Frequency = 4,
    /// A band is empty or reversed (chirp f_start ≥ f_end; multisine
    /// f_min > f_max, or f_min = f_max with several tones).
    Band = 5,
    /// The multisine tone count is 0 or above the limit.
    ToneCount = 6,
    /// The PRBS register length is outside the supported range.
    PrbsLength = 7,
    /// The chirp sweep is shorter than 2 samples or longer than 2³¹.
    SweepTime = 8,
    /// A gain (Γ or the initial gain) is ≤ 0.
    Gain = 9,
    /// A forgetting rate (l or γ) is ≤ 0.
    Forgetting = 10,
    /// λ is ≤ 0 or at/above π·f_s.
    Lambda = 11,
    /// This firmware has no such estimator.
    EstimatorUnavailable = 12,
    /// A telemetry rate is negative or above the sample rate.
    Rate = 13,
    /// The telemetry rates would exceed the link budget.
    LinkBudget = 14,
    /// The device is busy: a self-test is running (every command but
    /// `RequestStatus` is refused until it ends), or a `SelfTest` came
    /// before the first estimator started (the start-up window).
    Busy = 15,
    /// Line removal: harmonics not in 1..=7, or the time constant shorter
    /// than 10 samples or longer than 100 s.
    LineRemoval = 16,
}

impl RejectReason {
    /// Every reason, in code order.
    pub const ALL: [Self; 16] = [
        Self::NotFinite,
        Self::Amplitude,
        Self::SafeWindow,
        Self::Frequency,
        Self::Band,
        Self::ToneCount,
        Self::PrbsLength,
        Self::SweepTime,
        Self::Gain,
        Self::Forgetting,
        Self::Lambda,
        Self::EstimatorUnavailable,
        Self::Rate,
        Self::LinkBudget,
        Self::Busy,
        Self::LineRemoval,
    ];

    /// The reason with this wire code, if any.
    pub const fn from_code(code: u8) -> Option<Self> {
        Some(match code {
            1 => Self::NotFinite,
            2 => Self::Amplitude,
            3 => Self::SafeWindow,
            4 => Self::Frequency,
            5 => Self::Band,
            6 => Self::ToneCount,
            7 => Self::PrbsLength,
            8 => Self::SweepTime,
            9 => Self::Gain,
            10 => Self::Forgetting,
            11 => Self::Lambda,
            12 => Self::EstimatorUnavailable,
            13 => Self::Rate,
            14 => Self::LinkBudget,
            15 => Self::Busy,
            16 => Self::LineRemoval,
            _ => return None,
        })
    }

    /// A short English description.
    pub const fn describe(self) -> &'static str {
        match self {
            Self::NotFinite => "a value is NaN or infinite",
            Self::Amplitude => "negative amplitude",
            Self::SafeWindow => "offset ± amplitude outside the piezo's safe window",
            Self::Frequency => "frequency not in (0, Nyquist)",
            Self::Band => "empty or reversed frequency band",
            Self::ToneCount => "multisine tone count out of range",
            Self::PrbsLength => "PRBS register length out of range",
            Self::SweepTime => "chirp sweep time out of range",
            Self::Gain => "gain not positive",
            Self::Forgetting => "forgetting rate not positive",
            Self::Lambda => "filter pole λ not in (0, π·f_s)",
            Self::EstimatorUnavailable => "estimator not available in this firmware",
            Self::Rate => "telemetry rate negative or above the sample rate",
            Self::LinkBudget => "telemetry rates exceed the link budget",
            Self::Busy => "device busy: a self-test is running, or the estimator has not started",
            Self::LineRemoval => "line removal: harmonics or time constant out of range",
        }
    }
}

impl fmt::Display for RejectReason {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "rejected ({}): {}", *self as u8, self.describe())
    }
}

impl core::error::Error for RejectReason {}

impl Serialize for RejectReason {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_u8(*self as u8)
    }
}

impl<'de> Deserialize<'de> for RejectReason {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let code = u8::deserialize(d)?;
        Self::from_code(code).ok_or_else(|| {
            serde::de::Error::invalid_value(
                serde::de::Unexpected::Unsigned(code.into()),
                &"a reject reason code",
            )
        })
    }
}

/// What the device accepts: its sample rate, the piezo's safe window, the
/// generators and estimators it has, and its link budget.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Limits {
    /// Sample rate f_s (Hz). Nyquist: f_s/2.
    pub sample_rate_hz: f32,
    /// Lowest voltage the excitation may reach (V).
    pub piezo_min_v: f32,
    /// Highest voltage the excitation may reach (V).
    pub piezo_max_v: f32,
    /// Most tones of a multisine.
    pub max_multisine_tones: u8,
    /// Shortest PRBS shift register (bits).
    pub prbs_bits_min: u8,
    /// Longest PRBS shift register (bits).
    pub prbs_bits_max: u8,
    /// The estimators this firmware has: a set of [`EstimatorKind::bit`].
    pub estimators: u8,
    /// The estimator model's mode count (sets the estimate frame size).
    pub modes: u8,
    /// Link budget (bytes/s) that the worst-case telemetry load may use,
    /// e.g. [`uart_bytes_per_s`](crate::budget::uart_bytes_per_s) of the
    /// baud rate, less any headroom the firmware wants for acknowledgements.
    pub link_bytes_per_s: f32,
}

impl Limits {
    /// True if the firmware has estimator `kind`.
    pub const fn has_estimator(&self, kind: EstimatorKind) -> bool {
        self.estimators & kind.bit() != 0
    }

    pub(crate) fn nyquist_hz(&self) -> f32 {
        0.5 * self.sample_rate_hz
    }
}

/// Finite, or [`RejectReason::NotFinite`].
pub(crate) fn finite(values: &[f32]) -> Result<(), RejectReason> {
    if values.iter().all(|v| v.is_finite()) {
        Ok(())
    } else {
        Err(RejectReason::NotFinite)
    }
}

/// `Ok` if `ok`, else `Err(reason)`.
pub(crate) fn check(ok: bool, reason: RejectReason) -> Result<(), RejectReason> {
    if ok {
        Ok(())
    } else {
        Err(reason)
    }
}

impl Waveform {
    /// The waveform's own fields, finite and in range.
    pub(crate) fn validate(&self, limits: &Limits) -> Result<(), RejectReason> {
        let nyquist = limits.nyquist_hz();
        match *self {
            Self::Off => Ok(()),
            Self::Square { freq_hz } => {
                finite(&[freq_hz])?;
                check(freq_hz > 0.0 && freq_hz < nyquist, RejectReason::Frequency)
            }
            Self::Multisine {
                f_min_hz,
                f_max_hz,
                tones,
            } => {
                finite(&[f_min_hz, f_max_hz])?;
                check(
                    tones >= 1 && tones <= limits.max_multisine_tones,
                    RejectReason::ToneCount,
                )?;
                check(
                    f_min_hz > 0.0 && f_max_hz < nyquist,
                    RejectReason::Frequency,
                )?;
                check(
                    f_min_hz < f_max_hz || (tones == 1 && f_min_hz == f_max_hz),
                    RejectReason::Band,
                )
            }
            Self::Prbs {
                bit_rate_hz,
                register_bits,
            } => {
                finite(&[bit_rate_hz])?;
                check(
                    bit_rate_hz > 0.0 && bit_rate_hz <= limits.sample_rate_hz,
                    RejectReason::Frequency,
                )?;
                check(
                    register_bits >= limits.prbs_bits_min && register_bits <= limits.prbs_bits_max,
                    RejectReason::PrbsLength,
                )
            }
            Self::Chirp {
                f_start_hz,
                f_end_hz,
                sweep_s,
            } => {
                finite(&[f_start_hz, f_end_hz, sweep_s])?;
                check(
                    f_start_hz > 0.0 && f_end_hz < nyquist,
                    RejectReason::Frequency,
                )?;
                check(f_start_hz < f_end_hz, RejectReason::Band)?;
                let samples = sweep_s * limits.sample_rate_hz;
                check(
                    (2.0..=2_147_483_648.0).contains(&samples),
                    RejectReason::SweepTime,
                )
            }
        }
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used, clippy::indexing_slicing)]
mod tests {
    use super::*;

    #[test]
    fn waveform_kinds_follow_the_wire_tags_and_names_round_trip() {
        let waves = [
            Waveform::Off,
            Waveform::Square { freq_hz: 7.0 },
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
        ];
        for (tag, (w, k)) in waves.iter().zip(WaveformKind::ALL).enumerate() {
            let mut buf = [0u8; 16];
            let bytes = postcard::to_slice(w, &mut buf).unwrap();
            assert_eq!(usize::from(bytes[0]), tag);
            assert_eq!(w.kind(), k);
            assert_eq!(WaveformKind::from_name(k.name()), Some(k));
        }
        assert_eq!(WaveformKind::from_name("sine"), None);
    }

    #[test]
    fn reason_codes_are_stable_and_dense() {
        for (i, r) in RejectReason::ALL.iter().enumerate() {
            assert_eq!(*r as usize, i + 1);
            assert_eq!(RejectReason::from_code(*r as u8), Some(*r));
        }
        assert_eq!(RejectReason::from_code(0), None);
        assert_eq!(RejectReason::from_code(17), None);
        assert_eq!(RejectReason::from_code(255), None);
    }

    #[test]
    fn estimator_names_round_trip() {
        for k in EstimatorKind::ALL {
            assert_eq!(k.name().parse(), Ok(k));
        }
        assert_eq!(
            "least-squares".parse::<EstimatorKind>(),
            Err(UnknownEstimator)
        );
        assert_eq!(EstimatorKind::LeastSquares.to_string(), "ls");
    }
}
