//! The bring-up self-test: what a user's first hour with a new rig needs
//! to know, measured by the firmware itself through the same drivers and
//! sample path it runs on. Run at start-up on every board and on the
//! serial link's `SelfTest` command (`docs/PROTOCOL.md` §5, §9.7); its
//! result is a [`SelfTestReport`] frame and the Status's `self_test`
//! field; docs/RIG.md, "Bring-up", says what each check means and what to
//! do when it fails.
//!
//! | check | measured | passes when |
//! |---|---|---|
//! | ADC ID | the ADS131M02's ID register | 22xxh (a two-channel ADS131M0x) |
//! | ADC registers | MODE, CLOCK, GAIN1 read back (one multi-register read) | equal to the configuration, under the writable masks |
//! | DRDY rate | new conversions per second of the MCU's clock | within `DRDY_TOLERANCE` of the sample rate |
//! | loopback | a tone on the drive read back on the monitor channel: gain, offset, delay | gain within `GAIN_TOLERANCE` of 1, \|offset\| ≤ `OFFSET_TOLERANCE` × the tone's amplitude, delay within `DELAY_TOLERANCE_SAMPLES` of the timing model's |
//! | noise | σ of y with the drive at zero, and the RMS of y under the default excitation | SNR ≥ `SNR_MIN_DB` |
//!
//! # How it runs, and what it leaves alone
//! Three phases of the drive, each set between two samples like any
//! command (the link's lock), over [`TOTAL_SAMPLES`] samples (0.66 s at
//! 10 kHz):
//!
//! 1. **Start** (one lock): adaptation frozen ([`crate::pipeline::Pipeline::freeze`]: the
//!    estimator is not stepped, so Θ̂, P and its filters keep their state
//!    and none of the test's samples reaches them), the ADC's ID and
//!    configuration read back (two SPI frames right after a sample, so no
//!    conversion is in flight), the drive set to 0 V.
//! 2. **Quiet** (`QUIET_SETTLE` + `QUIET_SAMPLES`): the noise floor of
//!    y. The beam may still ring from the excitation it had: the noise is
//!    estimated from fourth differences of y, which remove a smooth signal
//!    (a mode at ω is attenuated by (ωTs)⁴: 3.6e-7 at 245 rad/s, 10 kHz)
//!    and leave white noise's variance × 70 (`NoiseFloor`).
//! 3. **Tone** (`TONE_SETTLE` + `TONE_SAMPLES`): a sine of
//!    [`SelfTestConfig::tone_amplitude_v`] at [`tone_hz`] (10 periods of
//!    the multisine generator's 2048-sample grid, so the window holds
//!    whole periods); the monitor channel and the DAC's held value are
//!    each fitted with a constant, a sine and a cosine at the tone
//!    (`ToneFit`): the ratio of their phasors is the loopback's gain and
//!    delay, the difference of the constants its offset.
//! 4. **Signal** (`SIGNAL_SAMPLES`): the device's default excitation
//!    ([`SelfTestConfig::excitation`]); the RMS of y over this window is
//!    the signal the SNR is taken against (conservative: the beam starts
//!    it near rest, below its steady level).
//!
//! Then (one lock) the excitation in force before the test is set again
//! (from its phase 0) and adaptation resumes unless it was frozen before
//! (by a `Freeze`, or at start-up where the tuning rule's first estimator
//! resumes it), with the law held for its settling time as after any
//! `Resume`. The sample interrupt keeps its guarantees: it only copies each
//! tick's values into fixed blocks ([`Collector::push`], no arithmetic
//! beyond counting), the rest runs in thread mode; the estimator's state
//! is never written. The DRDY rate is measured over all phases.
//!
//! Not on the device: the Cramér–Rao bound. It needs a model of the beam,
//! which the device has only once it has an estimate, and its Fisher
//! information in `f64`; `beamctl selftest` computes it from the report's
//! σ and excitation and the device's own latest estimate (`beamctl
//! crlb`'s code, `beamctl::judge::bound`).
//!
//! # Tolerances (why these numbers)
//! See each constant. They flag wiring and configuration faults, and the
//! effects that would bias the estimate beyond the rig's 1e-3; none is a
//! data-sheet specification.

#![deny(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::panic,
    clippy::indexing_slicing
)]

use crate::pipeline::{FaultKind, Tick};
use crate::scalar::Real;
use beam_protocol::{
    AdcCheck, DrdyCheck, Excitation, LoopbackCheck, NoiseCheck, SelfTestChecks, SelfTestReport,
    Waveform,
};

/// Samples per [`SelfTestBlock`].
pub const BLOCK_LEN: usize = 32;

/// Samples after the drive goes to zero before the noise is measured
/// (50 ms at 10 kHz: the drive's step through the converters' timing and
/// the amplifier is long over).
pub(crate) const QUIET_SETTLE: u64 = 500;
/// Samples of y the noise floor is estimated from (0.2 s at 10 kHz).
pub(crate) const QUIET_SAMPLES: u64 = 2_000;
/// Samples after the tone starts before it is fitted (the monitor sees
/// the drive's change after ≈ 2 samples; 64 leaves a margin for the
/// amplifier).
pub(crate) const TONE_SETTLE: u64 = 64;
/// The tone's fitted window: one period of the multisine generator's grid
/// at `TONE_PERIOD_LOG2`, `TONE_HARMONIC` whole periods of the tone.
pub(crate) const TONE_SAMPLES: u64 = 1 << TONE_PERIOD_LOG2;
/// Samples of y under the default excitation for the signal's RMS (0.2 s
/// at 10 kHz, the tuning rule's start-up window).
pub(crate) const SIGNAL_SAMPLES: u64 = 2_000;
/// The whole test, in samples.
pub const TOTAL_SAMPLES: u64 =
    QUIET_SETTLE + QUIET_SAMPLES + TONE_SETTLE + TONE_SAMPLES + SIGNAL_SAMPLES;

/// The multisine generator's period for the tone: 2^11 samples, the
/// period it chooses for a tone of [`tone_hz`] (`excitation`, the grid
/// f_s/2^k at most f_min/8).
pub(crate) const TONE_PERIOD_LOG2: u32 = 11;
/// The tone is this harmonic of the grid f_s/2^11 (48.828125 Hz at
/// 10 kHz): above the paper beam's modes (6.2 and 39 Hz), far below the
/// converters' droop (sinc⁴ of the hold and the sinc³: 1 − 1.6e-4).
pub(crate) const TONE_HARMONIC: u32 = 10;

/// Relative tolerance of the DRDY rate: 1e-4. An error ε of the sample
/// rate is an error ε of every ω̂ (the estimator takes Ts as given) and
/// none of ζ̂, so 1e-4 keeps it a tenth of the rig's 1e-3; a crystal's
/// ±50 ppm passes, a wrong OSR, CLKIN divider or power mode (factors of 2
/// and more) and a missing or extra DRDY edge per 10,000 fail. The
/// measurement's own error is the interrupt latency's jitter over the
/// 0.66 s window (a few cycles in 26 million on the reference board).
pub(crate) const DRDY_TOLERANCE: f64 = 1e-4;
/// Relative tolerance of the loopback gain: 5 %. With the commanded input
/// (the firmware's `InputSource::Commanded`) a gain error of the amplifier
/// or the monitor scales b̄ only, not ω or ζ; 5 % passes resistor and
/// amplifier tolerances and flags a wrong `AMPLIFIER_GAIN` or
/// `MONITOR_V_PER_V` setting (factors of 2 or 10) and a missing loopback
/// (gain 0).
pub(crate) const GAIN_TOLERANCE: f64 = 0.05;
/// Largest |offset| of the loopback as a fraction of the tone's
/// amplitude: 2 %. A constant input is absorbed by the model (the beam's
/// static deflection) and biases neither ω nor ζ; this flags a floating
/// or mis-referenced monitor input or a DAC not at mid-scale.
pub(crate) const OFFSET_TOLERANCE: f64 = 0.02;
/// Tolerance of the loopback delay: 0.02 sample (2 µs at 10 kHz). The ζ
/// bias of a wrong delay in the estimator's timing model is nearly linear
/// in the error: 2.1e-5 on the paper beam's ζ2 and 2.2e-4 on a
/// 1520 rad/s mode per 0.006 sample (docs/RIG.md, "What remains on the
/// board"), so 0.02 sample keeps it below 1e-3 up to that mode.
pub(crate) const DELAY_TOLERANCE_SAMPLES: f64 = 0.02;
/// The lowest SNR that passes: 60 dB. The default (equation-error) law is
/// biased by noise on y (errors in variables): at 60 dB its largest error
/// over five seeds is 1.4e-3 (ζ2), at 40 dB 3.6e-2 to 6.0e-2
/// (BENCHMARKS.md, "Accuracy under measurement noise"). Below 60 dB use
/// the noise-robust estimator (`SetEstimator` kind Robust), within 2× the
/// Cramér–Rao bound down to 40 dB.
pub(crate) const SNR_MIN_DB: f64 = 60.0;
/// A fit or a noise estimate needs at least this share of its window's
/// samples; with fewer the check is reported not measured.
const MIN_SHARE: f64 = 0.5;

/// The tone's frequency at sample rate `fs`: `TONE_HARMONIC` periods in
/// `TONE_SAMPLES`.
pub fn tone_hz(sample_rate_hz: f64) -> f64 {
    sample_rate_hz * f64::from(TONE_HARMONIC) / (TONE_SAMPLES as f64)
}

/// What a board tells the self-test about itself.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SelfTestConfig {
    /// Sample rate (Hz): the rate DRDY must run at.
    pub sample_rate_hz: f64,
    /// The clock the board times the sample interrupt's entries with (Hz):
    /// the unit of [`Collector::push`]'s `elapsed` (QEMU: SysTick at the
    /// 25 MHz core clock; the reference board: the DWT cycle counter).
    pub clock_hz: f64,
    /// The ADC's configuration: what its registers must read back.
    pub adc: ads131m02::Config,
    /// The loopback tone's amplitude on the actuator (V).
    pub tone_amplitude_v: f32,
    /// The delay (samples) of the monitor behind the value the DAC is
    /// written at the same tick, as the estimator's timing model has it:
    /// its `OutputTiming::delay_samples` (the ADC's sinc³ and the DAC's
    /// latency) plus half a sample (the hold's centre).
    pub expected_delay_samples: f64,
    /// One ADC code of y (units of y): the quantisation floor is this
    /// over √12.
    pub y_code: f64,
    /// The device's default excitation: the SNR's signal.
    pub excitation: Excitation,
}

impl SelfTestConfig {
    /// The tone's excitation (a one-tone multisine).
    pub(crate) fn tone(&self) -> Excitation {
        let f = tone_hz(self.sample_rate_hz) as f32;
        Excitation {
            waveform: Waveform::Multisine {
                f_min_hz: f,
                f_max_hz: f,
                tones: 1,
            },
            amplitude_v: self.tone_amplitude_v,
            offset_v: 0.0,
        }
    }
}

/// The drive at zero.
pub(crate) const QUIET: Excitation = Excitation {
    waveform: Waveform::Off,
    amplitude_v: 0.0,
    offset_v: 0.0,
};

/// One block of ticks, copied by the sample interrupt for thread mode.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SelfTestBlock<T> {
    /// Sample index of the first tick.
    pub first_index: u64,
    /// Ticks in the block (≤ [`BLOCK_LEN`]).
    pub len: u8,
    /// [`Tick::held_v`] per tick.
    pub held_v: [T; BLOCK_LEN],
    /// The monitor channel per tick (actuator V, NaN: none).
    pub monitor_v: [T; BLOCK_LEN],
    /// y per tick (NaN: none).
    pub y: [T; BLOCK_LEN],
    /// Bit i: tick i read a new conversion.
    pub fresh: u32,
    /// Intervals between two consecutive new conversions that ended in
    /// this block …
    pub intervals: u32,
    /// … and their total length in board clock ticks.
    pub interval_ticks: u64,
}

impl<T: Real> SelfTestBlock<T> {
    fn empty(first_index: u64) -> Self {
        Self {
            first_index,
            len: 0,
            held_v: [T::ZERO; BLOCK_LEN],
            monitor_v: [T::ZERO; BLOCK_LEN],
            y: [T::ZERO; BLOCK_LEN],
            fresh: 0,
            intervals: 0,
            interval_ticks: 0,
        }
    }
}

/// The sample interrupt's side: copies each tick into blocks while the
/// self-test collects (a few stores per tick, no arithmetic on the values).
#[derive(Debug, Clone)]
pub struct Collector<T> {
    block: SelfTestBlock<T>,
    /// Clock ticks since the last new conversion (none before the first).
    since_fresh: Option<u64>,
    dropped: u32,
}

impl<T: Real> Default for Collector<T> {
    fn default() -> Self {
        Self::new()
    }
}

impl<T: Real> Collector<T> {
    /// Empty.
    pub fn new() -> Self {
        Self {
            block: SelfTestBlock::empty(0),
            since_fresh: None,
            dropped: 0,
        }
    }

    /// One tick, `elapsed` board clock ticks after the previous tick's
    /// interrupt entry; a full block goes to `out` (false: refused,
    /// counted). Never panics, never blocks.
    #[inline]
    pub fn push(
        &mut self,
        tick: &Tick<T>,
        elapsed: u32,
        out: impl FnOnce(SelfTestBlock<T>) -> bool,
    ) {
        let b = &mut self.block;
        let i = usize::from(b.len);
        if i == 0 {
            b.first_index = tick.sample_index;
        }
        if let (Some(u), Some(m), Some(y)) =
            (b.held_v.get_mut(i), b.monitor_v.get_mut(i), b.y.get_mut(i))
        {
            *u = tick.held_v;
            *m = tick.reading.monitor_v;
            *y = tick.reading.y;
        }
        if let Some(s) = self.since_fresh.as_mut() {
            *s = s.saturating_add(u64::from(elapsed));
        }
        if tick.reading.fresh {
            b.fresh |= 1u32.checked_shl(u32::from(b.len)).unwrap_or(0);
            if let Some(s) = self.since_fresh.replace(0) {
                b.intervals = b.intervals.saturating_add(1);
                b.interval_ticks = b.interval_ticks.saturating_add(s);
            }
        }
        b.len = b.len.saturating_add(1);
        if usize::from(b.len) >= BLOCK_LEN {
            let full = core::mem::replace(b, SelfTestBlock::empty(0));
            if !out(full) {
                self.dropped = self.dropped.saturating_add(1);
            }
        }
    }

    /// The self-test stopped collecting: the partial block and the
    /// interval timing are dropped (the next test starts afresh).
    #[inline]
    pub fn stop(&mut self) {
        self.block.len = 0;
        self.block.fresh = 0;
        self.block.intervals = 0;
        self.block.interval_ticks = 0;
        self.since_fresh = None;
    }

    /// Blocks the queue refused.
    pub fn dropped(&self) -> u32 {
        self.dropped
    }
}

/// The noise floor from fourth differences: for white noise of variance
/// σ², d = y_k − 4y_{k−1} + 6y_{k−2} − 4y_{k−3} + y_{k−4} has variance
/// 70σ² (the sum of the squared binomial coefficients C(8, 4)); a smooth
/// signal contributes (ωTs)⁴ of its amplitude. Only runs of five
/// consecutive valid samples count. (Noise correlated between successive
/// samples, such as white analog noise through the ADC's sinc³, is
/// under-estimated by this formula; the simulated bench's noise is white
/// at the output rate.)
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub(crate) struct NoiseFloor {
    /// The last valid samples, newest first, and how many are consecutive.
    history: [f64; 4],
    run: u8,
    last_index: Option<u64>,
    sum_d2: f64,
    count: u64,
}

impl NoiseFloor {
    /// Sample `index` of y (`None`: no valid conversion).
    pub fn push(&mut self, index: u64, y: Option<f64>) {
        let continues = self.last_index.is_some_and(|l| l.wrapping_add(1) == index);
        let Some(y) = y.filter(|v| v.is_finite()) else {
            self.run = 0;
            self.last_index = None;
            return;
        };
        if !continues {
            self.run = 0;
        }
        if self.run >= 4 {
            let [a, b, c, d] = self.history;
            let diff = y - 4.0 * a + 6.0 * b - 4.0 * c + d;
            self.sum_d2 += diff * diff;
            self.count += 1;
        }
        let [a, b, c, _] = self.history;
        self.history = [y, a, b, c];
        self.run = self.run.saturating_add(1).min(4);
        self.last_index = Some(index);
    }

    /// Differences taken.
    pub fn count(&self) -> u64 {
        self.count
    }

    /// σ of the noise (units of y), if any difference was taken.
    pub fn sd(&self) -> Option<f64> {
        (self.count > 0).then(|| libm::sqrt(self.sum_d2 / (70.0 * self.count as f64)))
    }
}

/// Least-squares fit of x_k ≈ c + a·sin φ_k + b·cos φ_k for two signals
/// on the same samples (the monitor and the drive), φ_k = 2π·h·k/N: their
/// phasors b + j·a and constants. sin φ_k and cos φ_k come from one
/// rotation per sample (exact `sin`/`cos` again after a gap): 2048 steps
/// drift by ≈ 2048 ε, far below what is measured.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct ToneFit {
    /// Σ of the basis' outer products (1, sin, cos), upper triangle.
    gram: [f64; 6],
    monitor: [f64; 3],
    drive: [f64; 3],
    count: u64,
    /// The sample the rotation is at, and (sin, cos) there.
    at: Option<(u64, f64, f64)>,
    /// (sin, cos) of one sample's step, 2π·h/N.
    step: (f64, f64),
}

impl Default for ToneFit {
    fn default() -> Self {
        Self {
            gram: [0.0; 6],
            monitor: [0.0; 3],
            drive: [0.0; 3],
            count: 0,
            at: None,
            step: tone_phase(1),
        }
    }
}

/// sin and cos of the tone's phase at sample `k` of the window.
fn tone_phase(k: u64) -> (f64, f64) {
    let phase = (k * u64::from(TONE_HARMONIC)) % TONE_SAMPLES;
    let phi = 2.0 * core::f64::consts::PI * phase as f64 / TONE_SAMPLES as f64;
    (libm::sin(phi), libm::cos(phi))
}

/// The loopback's gain, offset and delay (delay `None`: no phase to read,
/// the monitor's tone is nil).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Loopback {
    /// |monitor phasor| / |drive phasor|.
    pub gain: f64,
    /// Monitor constant − drive constant.
    pub offset: f64,
    /// The monitor's phase lag behind the drive, in samples.
    pub delay_samples: Option<f64>,
}

impl ToneFit {
    /// Sample `k` of the window (from the tone's start), monitor `m` and
    /// drive `u` (skipped unless both are finite).
    pub fn push(&mut self, k: u64, m: f64, u: f64) {
        if !(m.is_finite() && u.is_finite()) {
            return;
        }
        let (s, c) = match self.at {
            Some((at, s, c)) if at.wrapping_add(1) == k => {
                let (ds, dc) = self.step;
                (s * dc + c * ds, c * dc - s * ds)
            }
            _ => tone_phase(k),
        };
        self.at = Some((k, s, c));
        let basis = [1.0, s, c];
        let [g0, g1, g2, g3, g4, g5] = &mut self.gram;
        *g0 += 1.0;
        *g1 += s;
        *g2 += c;
        *g3 += s * s;
        *g4 += s * c;
        *g5 += c * c;
        for ((rm, ru), b) in self
            .monitor
            .iter_mut()
            .zip(self.drive.iter_mut())
            .zip(basis)
        {
            *rm += m * b;
            *ru += u * b;
        }
        self.count += 1;
    }

    /// Samples fitted.
    pub fn count(&self) -> u64 {
        self.count
    }

    /// Solve the 3×3 normal equations for `rhs` (Cramer's rule; the
    /// basis is nearly orthogonal over whole periods, so well
    /// conditioned): (constant, sine, cosine).
    fn solve(&self, rhs: &[f64; 3]) -> Option<[f64; 3]> {
        let [a, b, c, d, e, f] = self.gram;
        // Symmetric [[a, b, c], [b, d, e], [c, e, f]].
        let det3 = |m: [[f64; 3]; 3]| {
            let [[m00, m01, m02], [m10, m11, m12], [m20, m21, m22]] = m;
            m00 * (m11 * m22 - m12 * m21) - m01 * (m10 * m22 - m12 * m20)
                + m02 * (m10 * m21 - m11 * m20)
        };
        let g = [[a, b, c], [b, d, e], [c, e, f]];
        let det = det3(g);
        if !(det.abs() > 0.0) {
            return None;
        }
        let mut x = [0.0; 3];
        for (col, xi) in x.iter_mut().enumerate() {
            let mut m = g;
            for (row, r) in m.iter_mut().enumerate() {
                if let (Some(slot), Some(v)) = (r.get_mut(col), rhs.get(row)) {
                    *slot = *v;
                }
            }
            *xi = det3(m) / det;
        }
        Some(x)
    }

    /// Gain, offset and delay, if the drive's tone was fitted.
    pub fn loopback(&self) -> Option<Loopback> {
        let [cm, sm, km] = self.solve(&self.monitor)?;
        let [cu, su, ku] = self.solve(&self.drive)?;
        // x = c + a·sin φ + b·cos φ = c + Re{(b − j·a)·e^{jφ}}: its phase
        // lead is arg(b − j·a); the monitor's lag is the difference.
        let mag_u = libm::hypot(su, ku);
        if !(mag_u > 0.0) {
            return None;
        }
        let mag_m = libm::hypot(sm, km);
        let gain = mag_m / mag_u;
        let delay_samples = (gain > 1e-3).then(|| {
            let lead_m = libm::atan2(-sm, km);
            let lead_u = libm::atan2(-su, ku);
            let mut lag = lead_u - lead_m;
            let two_pi = 2.0 * core::f64::consts::PI;
            lag -= two_pi * libm::floor(lag / two_pi + 0.5);
            // One period of the tone is N/h samples.
            lag / two_pi * (TONE_SAMPLES as f64 / f64::from(TONE_HARMONIC))
        });
        Some(Loopback {
            gain,
            offset: cm - cu,
            delay_samples,
        })
    }
}

/// Which part of the test runs.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Phase {
    /// Drive at zero: the noise floor.
    Quiet,
    /// The loopback tone.
    Tone,
    /// The default excitation: the signal's RMS.
    Signal,
}

/// What the link must do after a block: set the next phase's drive, or
/// end the test.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Next {
    /// Set this phase's drive and call `SelfTestRun::begin`.
    Begin(Phase),
    /// Every phase is done: restore the drive, then
    /// `SelfTestRun::report`.
    Finish,
}

/// One self-test from its start to its report (thread mode).
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct SelfTestRun {
    config: SelfTestConfig,
    at_boot: bool,
    first_sample: u64,
    phase: Phase,
    /// The first sample of the current phase's drive.
    phase_start: u64,
    adc: Result<ads131m02::ReadBack, FaultKind>,
    /// Ticks seen and new conversions among them.
    ticks: u64,
    conversions: u64,
    intervals: u64,
    interval_ticks: u64,
    /// The newest sample index seen (gaps: dropped blocks).
    last_index: Option<u64>,
    noise: NoiseFloor,
    tone: ToneFit,
    signal_sum_y2: f64,
    signal_count: u64,
    finished: bool,
}

impl SelfTestRun {
    /// A test whose quiet drive takes effect at sample `first_sample`,
    /// with the ADC's read-back `adc` (taken in the same lock).
    pub fn new(
        config: &SelfTestConfig,
        at_boot: bool,
        first_sample: u64,
        adc: Result<ads131m02::ReadBack, FaultKind>,
    ) -> Self {
        Self {
            config: *config,
            at_boot,
            first_sample,
            phase: Phase::Quiet,
            phase_start: first_sample,
            adc,
            ticks: 0,
            conversions: 0,
            intervals: 0,
            interval_ticks: 0,
            last_index: None,
            noise: NoiseFloor::default(),
            tone: ToneFit::default(),
            signal_sum_y2: 0.0,
            signal_count: 0,
            finished: false,
        }
    }

    /// The first sample of the test.
    pub fn first_sample(&self) -> u64 {
        self.first_sample
    }

    /// The phase running.
    #[cfg(test)]
    pub(crate) fn phase(&self) -> Phase {
        self.phase
    }

    /// The phase `phase` has started: its drive takes effect at `at`.
    pub(crate) fn begin(&mut self, phase: Phase, at: u64) {
        self.phase = phase;
        self.phase_start = at;
    }

    /// The current phase's measured window: [start, end).
    fn window(&self) -> (u64, u64) {
        let (settle, len) = match self.phase {
            Phase::Quiet => (QUIET_SETTLE, QUIET_SAMPLES),
            Phase::Tone => (TONE_SETTLE, TONE_SAMPLES),
            Phase::Signal => (0, SIGNAL_SAMPLES),
        };
        let from = self.phase_start.saturating_add(settle);
        (from, from.saturating_add(len))
    }

    /// One block from the sample interrupt; `Some` when the current phase
    /// is complete (the rest of the block precedes the next drive, which
    /// takes effect after every sample already taken).
    pub fn push<T: Real>(&mut self, block: &SelfTestBlock<T>) -> Option<Next> {
        if self.finished || block.first_index < self.first_sample {
            return None;
        }
        self.intervals += u64::from(block.intervals);
        self.interval_ticks = self.interval_ticks.saturating_add(block.interval_ticks);
        let (from, to) = self.window();
        let n = usize::from(block.len).min(BLOCK_LEN);
        let mut next = None;
        for i in 0..n {
            let index = block.first_index + i as u64;
            self.ticks += 1;
            let fresh = block.fresh & 1u32.checked_shl(i as u32).unwrap_or(0) != 0;
            if fresh {
                self.conversions += 1;
            }
            self.last_index = Some(index);
            if next.is_some() || index < from {
                continue;
            }
            let at = |v: &[T; BLOCK_LEN]| v.get(i).map_or(f64::NAN, |x| x.to_f64());
            let y = at(&block.y);
            match self.phase {
                Phase::Quiet => self.noise.push(index, Some(y)),
                Phase::Tone => {
                    self.tone
                        .push(index - from, at(&block.monitor_v), at(&block.held_v))
                }
                Phase::Signal => {
                    if y.is_finite() {
                        self.signal_sum_y2 += y * y;
                        self.signal_count += 1;
                    }
                }
            }
            if index + 1 >= to {
                next = Some(match self.phase {
                    Phase::Quiet => Next::Begin(Phase::Tone),
                    Phase::Tone => Next::Begin(Phase::Signal),
                    Phase::Signal => {
                        self.finished = true;
                        Next::Finish
                    }
                });
            }
        }
        next
    }

    /// The report, the test having ended with sample `last_sample`.
    pub fn report(&self, last_sample: u64) -> SelfTestReport {
        let c = &self.config;
        let mut failed = SelfTestChecks::default();
        let mut not_measured = SelfTestChecks::default();
        let mut judge = |check: SelfTestChecks, verdict: Option<bool>| match verdict {
            Some(true) => {}
            Some(false) => failed = failed.with(check),
            None => not_measured = not_measured.with(check),
        };

        let expected = c.adc.expected_registers();
        let adc = match &self.adc {
            Ok(r) => {
                judge(SelfTestChecks::ADC_ID, Some(r.id_ok()));
                judge(SelfTestChecks::ADC_REGISTERS, Some(r.matches(&c.adc)));
                AdcCheck {
                    id: r.id,
                    registers: r.registers(),
                    expected,
                }
            }
            Err(_) => {
                judge(SelfTestChecks::ADC_ID, Some(false));
                judge(SelfTestChecks::ADC_REGISTERS, Some(false));
                AdcCheck {
                    id: 0,
                    registers: [0; 3],
                    expected,
                }
            }
        };

        let rate_hz = if self.intervals > 0 && self.interval_ticks > 0 {
            self.intervals as f64 * c.clock_hz / self.interval_ticks as f64
        } else {
            0.0
        };
        judge(
            SelfTestChecks::DRDY_RATE,
            Some((rate_hz / c.sample_rate_hz - 1.0).abs() <= DRDY_TOLERANCE),
        );
        let drdy = DrdyCheck {
            rate_hz: rate_hz as f32,
            expected_hz: c.sample_rate_hz as f32,
            tolerance: DRDY_TOLERANCE as f32,
            conversions: u32::try_from(self.conversions).unwrap_or(u32::MAX),
            ticks: u32::try_from(self.ticks).unwrap_or(u32::MAX),
        };

        let amplitude = f64::from(c.tone_amplitude_v);
        let enough = |n: u64, window: u64| n as f64 >= MIN_SHARE * window as f64;
        let fit = self
            .tone
            .loopback()
            .filter(|_| enough(self.tone.count(), TONE_SAMPLES));
        let nan = f32::NAN;
        let mut loopback = LoopbackCheck {
            tone_hz: tone_hz(c.sample_rate_hz) as f32,
            amplitude_v: c.tone_amplitude_v,
            gain: nan,
            expected_gain: 1.0,
            gain_tolerance: GAIN_TOLERANCE as f32,
            offset_v: nan,
            offset_tolerance_v: (OFFSET_TOLERANCE * amplitude) as f32,
            delay_samples: nan,
            expected_delay_samples: c.expected_delay_samples as f32,
            delay_tolerance_samples: DELAY_TOLERANCE_SAMPLES as f32,
        };
        match fit {
            Some(l) => {
                loopback.gain = l.gain as f32;
                loopback.offset_v = l.offset as f32;
                loopback.delay_samples = l.delay_samples.map_or(nan, |d| d as f32);
                let gain_ok = (l.gain - 1.0).abs() <= GAIN_TOLERANCE;
                let offset_ok = l.offset.abs() <= OFFSET_TOLERANCE * amplitude;
                let delay_ok = l.delay_samples.is_some_and(|d| {
                    (d - c.expected_delay_samples).abs() <= DELAY_TOLERANCE_SAMPLES
                });
                judge(
                    SelfTestChecks::LOOPBACK,
                    Some(gain_ok && offset_ok && delay_ok),
                );
            }
            None => judge(SelfTestChecks::LOOPBACK, None),
        }

        let floor = c.y_code.abs() / libm::sqrt(12.0);
        let sd = self
            .noise
            .sd()
            .filter(|_| enough(self.noise.count(), QUIET_SAMPLES));
        let rms = (enough(self.signal_count, SIGNAL_SAMPLES))
            .then(|| libm::sqrt(self.signal_sum_y2 / self.signal_count as f64));
        let snr = match (sd, rms) {
            (Some(sd), Some(rms)) => Some(20.0 * libm::log10(rms / sd.max(floor))),
            _ => None,
        };
        judge(SelfTestChecks::NOISE, snr.map(|s| s >= SNR_MIN_DB));
        let noise = NoiseCheck {
            noise_sd: sd.map_or(nan, |v| v as f32),
            floor_sd: floor as f32,
            signal_rms: rms.map_or(nan, |v| v as f32),
            snr_db: snr.map_or(nan, |v| v as f32),
            snr_min_db: SNR_MIN_DB as f32,
            excitation: c.excitation,
        };

        SelfTestReport {
            first_sample: self.first_sample,
            last_sample,
            at_boot: self.at_boot,
            failed,
            not_measured,
            adc,
            drdy,
            loopback,
            noise,
        }
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used, clippy::indexing_slicing)]
mod tests;
