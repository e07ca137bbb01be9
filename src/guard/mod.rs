//! The sensor guard: float-level checks of each (u, y) pair before it may
//! reach an estimator, and the removal of sensor offsets and drift —
//! one implementation, used by the pipeline after its conversion
//! ([`crate::pipeline`]) and by the host tools, which feed floats.
//!
//! Each pair is classified when it arrives ([`SensorGuard::push`]):
//!
//! | fault | seen as | decided |
//! |---|---|---|
//! | [`SampleFault::NonFinite`] | u or y NaN or ±∞ | at once |
//! | [`SampleFault::Saturated`] | y at or beyond a rail of the configured range (the converter's full scale in units of y), approached continuously, or an episode at the rails that moves from one rail to the other | at once (the samples of an episode before its first switch count as open) |
//! | [`SampleFault::Open`] | y *jumps* to a rail from more than half of full scale away and stays there | at once |
//! | [`SampleFault::Stuck`] | y repeats exactly `stuck_after` more times (2.5 ms at the default 25) | after the run; the run's earlier samples are caught in the delay line |
//! | [`SampleFault::Upstream`] | the caller says the sample is bad (a converter error) | at once |
//! | [`LevelEvent::Offset`] | a step of y: its matched estimate d̂ (a quadratic plus a step fitted to `STEP_BEFORE` + `STEP_AFTER` samples) beyond `STEP_FACTOR` × d̂'s running RMS | 1.4–2.2 ms (≤ `STEP_LATENCY` samples); the step is subtracted from its first sample on (inside the delay line) |
//! | [`LevelEvent::Drift`] | y's slow level moves by more than `DRIFT_FRACTION` of y's RMS | when it has (latency ∝ 1/rate) |
//! | [`LevelEvent::Offset`], [`LevelEvent::Drift`] (opt-in: [`SensorGuard::push_monitored`]) | a step, or a ramp's onset, in the model's equation error ε ([`ResidualMonitor`], fed the estimator's Θ̂) | a step as above, down to 0.1·Y0 at 40 dB; a drift's onset after 5 ms noise-free |
//!
//! A faulty sample is handed on with y = NaN ([`Guarded::for_estimator`];
//! u kept when finite), which the estimators reject and follow with their
//! quarantine
//! ([`crate::estimator`], *Bad input*): nothing of it reaches Θ̂. Level
//! events are not faults: the sample is good once its offset is removed.
//!
//! # Open bridge, in the reading
//! The rig's gauge is one arm of a quarter bridge excited with 2.0 V: the
//! gauge node sits at ≈ V_exc/2 and the ADS131M02 sees the bridge's few
//! hundred µV. If the gauge opens, its node is pulled to a supply rail
//! through the completion resistor, the differential input becomes
//! ±V_exc/2 = ±1 V, far beyond the ±9.4 mV range at PGA 128 (docs/RIG.md):
//! the converter reads its positive or negative full-scale code, constant,
//! and the pipeline converts that to the y of the rail. An overload, by
//! contrast, grows into the rail with the signal. Without a configured
//! range (the host tools on recorded floats) neither can be told from a
//! stuck sensor: both show as [`SampleFault::Stuck`] (and the jump into an
//! open rail as an offset step first).
//!
//! # Offsets and drift do not bias
//! * **Offset steps** are removed where they happen: for each sample
//!   `STEP_AFTER` − 1 back, the least-squares size d̂ of a step there is
//!   fitted with a quadratic to the window around it (module `step`: the
//!   step averaged over both sides, white noise σ entering as 0.82σ); a
//!   d̂ beyond `STEP_FACTOR` × its running RMS is followed to its peak
//!   (the step's sample) and subtracted from that sample on — the samples
//!   since are still in the delay line and are corrected there. With the
//!   high-pass on, the estimate's error (the residual offset, ~σ) would
//!   become the filter's transient, so the estimator is held over it as
//!   after a gap ([`SensorGuard::take_hold`]). Noise-free the residual is
//!   ~1e-4 of the step.
//! * **Slow offsets and drift** are removed by a second-order high-pass
//!   applied identically to u and y (`HighPass`, on by default at
//!   [`DEFAULT_HIGHPASS_RAD_S`]): identical filtering commutes with the
//!   plant, so the estimate is unchanged (see its module docs), and its
//!   double zero at DC removes a constant and a ramp exactly.
//! * **Lines in y** (the mains) are removed by a separate stage after the
//!   guard, the line canceller of [`lines`], also identical on u and y;
//!   the host's replay sets its lines from the record (docs/REPLAY.md,
//!   "Lines in y"); no board runs it yet.
//!
//! Measured bias with and without: docs/ROBUSTNESS.md.
//!
//! # Gaps
//! Faulty samples never reach the high-pass: its states hold the slow
//! level across the gap. After it, the filter's memory mixes both sides
//! of the gap, and the filtered pair is not a plant input/output pair
//! until that memory has passed: the guard then asks the caller to hold
//! the estimator ([`SensorGuard::take_hold`], for
//! `GAP_SETTLE_TIME_CONSTANTS`/ω_c), which keeps the estimate it had
//! before the fault. Without the high-pass no hold is needed (the
//! estimator's own quarantine covers its filter bank).
//!
//! # Order
//! Classification at entry; a delay line of `stuck_after + 1` samples,
//! and at least `STEP_LATENCY` + 1 with offset-step removal on (the
//! estimate lags by 2.6 ms at the default); then the high-pass, fed
//! only good samples (a faulty sample leaves its states as they were: they
//! hold the slow level, which a millisecond's gap does not move).
#![deny(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::panic,
    clippy::indexing_slicing
)]

pub(crate) mod delay;
pub(crate) mod highpass;
mod level;
pub mod lines;
pub(crate) mod monitor;
pub(crate) mod residual;
mod step;

pub(crate) use delay::MAX_DELAY;
pub(crate) use highpass::HighPass;
pub(crate) use monitor::MonitorEvent;
pub use monitor::{model_for_monitor, ResidualMonitor, CHANGE_QUIET_S};
pub use residual::{ResidualFilter, RESIDUAL_LAG};
pub(crate) use step::{STEP_LATENCY, STEP_PEAK_WAIT};

use crate::scalar::Real;
use delay::DelayLine;
use step::StepDetector;

/// The delay line's length: the stuck run's (`stuck_after` + 1), and at
/// least [`STEP_LATENCY`] + 1 with offset-step removal on (the step is
/// found that many samples after it and corrected inside the line).
fn line_delay(stuck_after: u16, offset_steps: bool) -> usize {
    let stuck = if stuck_after > 0 {
        usize::from(stuck_after) + 1
    } else {
        0
    };
    if offset_steps {
        stuck.max(STEP_LATENCY + 1)
    } else {
        stuck
    }
}

/// Default stuck run: 25 repeats (2.5 ms at 10 kHz; a live sensor's
/// readings never repeat that often, a noise-free simulated beam's a few
/// times at most).
pub(crate) const DEFAULT_STUCK_AFTER: u16 = 25;
/// Default corner of the DC-removing high-pass (rad/s): 4× below the
/// lowest mode the rig is built for (the paper's beam: 39 rad/s) and the
/// paper's 7 Hz drive (44 rad/s, whose power it passes at 95%). Identical
/// filtering of u and y leaves the identified plant unchanged, so the
/// corner trades only what the filter leaves of a drift — the transient
/// r/(e·ω_c) of a ramp r — and the hold after a gap (12/ω_c) against the
/// excitation it removes below ω_c. Measured on the paper's plant at
/// 0.02·Y0/s (`robustness_table`, docs/ROBUSTNESS.md §1): at 3 rad/s the
/// drift left 0.70% error (0.18% from 1 s after its end, which is an
/// offset step and held over), at 6 rad/s 0.14% (0.021%), at 10 rad/s
/// 0.057% (0.0036%), at 20 rad/s 0.028%; the estimate after a gap
/// was within 2.6e-5, 4.7e-5, 8.2e-5, 1.5e-4. A beam whose first mode
/// (or drive) is below ~40 rad/s wants a lower corner.
pub const DEFAULT_HIGHPASS_RAD_S: f64 = 10.0;
/// An offset step is a matched step estimate d̂ (module `step`: a
/// least-squares fit of a quadratic plus a step to [`STEP_BEFORE`] +
/// [`STEP_AFTER`] samples) beyond this many times d̂'s running RMS. With
/// white noise alone d̂ is Gaussian: 8σ is exceeded with probability
/// 1.2e-15 per sample.
pub(crate) const STEP_FACTOR: f64 = 8.0;
/// Time constant of d̂'s running mean square (s); also its learning time
/// at the start.
pub(crate) const STEP_REFERENCE_S: f64 = 0.1;
/// A jump to a rail from more than this fraction of full scale (half the
/// range's span) away is an open bridge, not an overload: an overload
/// reaches the rail within one sample's motion of the signal, an open gauge
/// from wherever the signal was (3% of full scale on the rig).
pub(crate) const OPEN_JUMP_FRACTION: f64 = 0.5;
/// A drift is flagged when y's slow level has moved by this fraction of
/// y's RMS since the last flag.
pub(crate) const DRIFT_FRACTION: f64 = 0.05;
/// Time constant of the slow level (two stages) and of y's RMS (s).
pub(crate) const LEVEL_S: f64 = 0.25;
/// After a gap (faulty samples that never reached the high-pass) the
/// estimator is asked to hold for this many high-pass time constants 1/ω_c
/// ([`SensorGuard::take_hold`]): the filter's memory then mixes the signal
/// before and after the gap, which no plant input/output pair explains; the
/// mismatch starts at the filter's low-frequency share of y (~ω_c/ω of it,
/// ~20% for the paper's 7 Hz drive at the default corner) and decays as
/// the four-stage filter's tail (1 + x + x²/2 + x³/6)·e^{−x}, x = ω_c·t:
/// to 1e-4 of that after 18/ω_c (1.8 s at 10 rad/s; the two-stage filter's
/// (1 + x)·e^{−x} got there after 12/ω_c). Measured with two stages (at
/// 3 rad/s): resuming after 7/ω_c left a 0.2% error on the paper's plant
/// for a second; after 12/ω_c 2.6e-5 (docs/ROBUSTNESS.md).
pub(crate) const GAP_SETTLE_TIME_CONSTANTS: f64 = 18.0;

/// Why a sample was not passed on.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum SampleFault {
    /// u or y not finite.
    NonFinite,
    /// y at a rail of the range.
    Saturated,
    /// y repeated too long.
    Stuck,
    /// y jumped to a rail and stays (open gauge).
    Open,
    /// Rejected by the caller (a converter error).
    Upstream,
}

/// A change of y's level (the sample itself is good).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum LevelEvent {
    /// A step; removed from this sample on.
    Offset,
    /// A slow drift (removed by the high-pass).
    Drift,
}

/// Invalid guard settings.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum GuardError {
    /// Ts not positive and finite.
    SamplePeriod,
    /// Range not finite with min < max.
    Range,
    /// `stuck_after` ≥ `MAX_DELAY`.
    StuckAfter,
    /// High-pass corner not in (0, π/Ts).
    Highpass,
}

impl core::fmt::Display for GuardError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(match self {
            Self::SamplePeriod => "guard: sample period not positive and finite",
            Self::Range => "guard: range must be finite with min < max",
            Self::StuckAfter => "guard: stuck_after exceeds the delay line",
            Self::Highpass => "guard: high-pass corner must be in (0, pi/Ts)",
        })
    }
}

impl core::error::Error for GuardError {}

/// Settings.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct GuardConfig {
    /// Sample period Ts (s).
    pub ts_s: f64,
    /// The converter's rails in units of y, [min, max] (`None`: unknown,
    /// saturation and open bridges are then seen as stuck readings).
    pub range: Option<[f64; 2]>,
    /// Repeats that make a stuck reading (0: off; < `MAX_DELAY`).
    pub stuck_after: u16,
    /// Corner of the DC-removing high-pass on u and y (rad/s; `None`:
    /// off).
    pub highpass_rad_s: Option<f64>,
    /// Detect and remove offset steps.
    pub offset_steps: bool,
}

impl GuardConfig {
    /// The defaults at sample period `ts_s`: no range, stuck after
    /// `DEFAULT_STUCK_AFTER`, high-pass at [`DEFAULT_HIGHPASS_RAD_S`],
    /// offset steps removed.
    pub fn new(ts_s: f64) -> Self {
        Self {
            ts_s,
            range: None,
            stuck_after: DEFAULT_STUCK_AFTER,
            highpass_rad_s: Some(DEFAULT_HIGHPASS_RAD_S),
            offset_steps: true,
        }
    }
}

/// Samples per fault kind and level events (saturating; each sample is
/// counted once, by its final classification).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct GuardCounts {
    /// [`SampleFault::NonFinite`] samples.
    pub non_finite: u32,
    /// [`SampleFault::Saturated`] samples.
    pub saturated: u32,
    /// [`SampleFault::Stuck`] samples.
    pub stuck: u32,
    /// [`SampleFault::Open`] samples.
    pub open: u32,
    /// [`SampleFault::Upstream`] samples.
    pub upstream: u32,
    /// Offset steps removed.
    pub offset: u32,
    /// Drift flags.
    pub drift: u32,
}

impl GuardCounts {
    /// Samples not passed on.
    pub fn rejected(&self) -> u32 {
        [
            self.non_finite,
            self.saturated,
            self.stuck,
            self.open,
            self.upstream,
        ]
        .iter()
        .fold(0u32, |a, &v| a.saturating_add(v))
    }

    fn bump(&mut self, f: SampleFault, n: u32) {
        let c = match f {
            SampleFault::NonFinite => &mut self.non_finite,
            SampleFault::Saturated => &mut self.saturated,
            SampleFault::Stuck => &mut self.stuck,
            SampleFault::Open => &mut self.open,
            SampleFault::Upstream => &mut self.upstream,
        };
        *c = c.saturating_add(n);
    }
}

/// A sample leaving the guard.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Guarded<T> {
    /// Its index (pushes since the start; the guard's output lags its
    /// input by the delay line).
    pub index: u64,
    /// u, high-passed (also for a faulty sample with a finite u: u's
    /// channel runs on).
    pub u: T,
    /// y with its offset steps removed, high-passed (the raw y if faulty).
    pub y: T,
    /// Why it is not to be used, if so.
    pub fault: Option<SampleFault>,
}

impl<T: Real> Guarded<T> {
    /// The pair to give an estimator: (u, y), or y = NaN for a faulty
    /// sample (rejected there and followed by its quarantine). u is kept
    /// when it is finite: the faults are y's, and an estimator that
    /// simulates the plant from u (the robust estimator's output-error
    /// model) must see the input the plant saw, or it carries a transient
    /// as long as the slowest mode after the gap.
    pub fn for_estimator(&self) -> (T, T) {
        let nan = T::from_f64(f64::NAN);
        match self.fault {
            None => (self.u, self.y),
            Some(_) if self.u.is_finite() => (self.u, nan),
            Some(_) => (nan, nan),
        }
    }
}

/// What the latest push saw, at once (before the delay line).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Screening {
    /// Its fault at entry (a stuck run is reported from the sample that
    /// completes it).
    pub fault: Option<SampleFault>,
    /// A level event at this sample.
    pub level: Option<LevelEvent>,
}

/// The guard's state (see the module docs).
#[derive(Debug, Clone)]
pub struct SensorGuard<T> {
    range: Option<(T, T)>,
    open_jump: T,
    stuck_after: u16,
    offset_steps: bool,
    delay: DelayLine<T>,
    hp: Option<HighPass<T>>,
    /// Samples to hold the estimator for after a gap (see
    /// [`GAP_SETTLE_TIME_CONSTANTS`]).
    gap_hold: u32,
    /// A faulty sample left the delay line since the last good one.
    in_gap: bool,
    /// Hold requested and not yet taken ([`SensorGuard::take_hold`]).
    hold_pending: u32,
    /// The current fault episode at a rail has switched rails (an
    /// overload, not an open gauge).
    rail_switched: bool,
    index: u64,
    counts: GuardCounts,
    last: Screening,
    // Stuck runs.
    last_y: T,
    repeats: u16,
    /// The caller drives nothing ([`SensorGuard::set_input_quiet`]): a
    /// repeated reading is no stuck run.
    quiet: bool,
    // Open episodes: the rail being held.
    open_rail: Option<T>,
    /// The last accepted raw y (for the open test).
    last_good_y: Option<T>,
    // Offset steps.
    offset: T,
    step: StepDetector<T>,
    // Drift.
    alpha_level: T,
    level1: T,
    level2: T,
    level_ms: T,
    level_ref: Option<T>,
    level_learn: u32,
    /// [`LEVEL_S`]·8 in samples: the drift test's learning time (at the
    /// start and after a gap).
    level_learn_len: u32,
    drift_fraction2: T,
}

impl<T: Real> SensorGuard<T> {
    /// A guard with `cfg`.
    ///
    /// # Errors
    /// [`GuardError`] naming the invalid setting.
    pub fn new(cfg: &GuardConfig) -> Result<Self, GuardError> {
        let ts = cfg.ts_s;
        if !(ts > 0.0 && ts.is_finite()) {
            return Err(GuardError::SamplePeriod);
        }
        let range = match cfg.range {
            Some([lo, hi]) if lo.is_finite() && hi.is_finite() && lo < hi => {
                Some((T::from_f64(lo), T::from_f64(hi)))
            }
            Some(_) => return Err(GuardError::Range),
            None => None,
        };
        if usize::from(cfg.stuck_after) >= MAX_DELAY {
            return Err(GuardError::StuckAfter);
        }
        let hp = match cfg.highpass_rad_s {
            Some(w) => Some(HighPass::new(w, ts).ok_or(GuardError::Highpass)?),
            None => None,
        };
        let alpha = |tau: f64| T::from_f64(-libm::expm1(-ts / tau));
        let span = cfg.range.map_or(0.0, |[lo, hi]| hi - lo);
        let samples = |s: f64| libm::ceil(s / ts).min(u32::MAX as f64) as u32;
        let gap_hold = cfg
            .highpass_rad_s
            .map_or(0, |w| samples(GAP_SETTLE_TIME_CONSTANTS / w));
        Ok(Self {
            range,
            open_jump: T::from_f64(OPEN_JUMP_FRACTION * 0.5 * span),
            stuck_after: cfg.stuck_after,
            offset_steps: cfg.offset_steps,
            // No stuck test, no delay.
            delay: DelayLine::new(line_delay(cfg.stuck_after, cfg.offset_steps), T::ZERO),
            hp,
            gap_hold,
            in_gap: false,
            hold_pending: 0,
            rail_switched: false,
            index: 0,
            counts: GuardCounts::default(),
            last: Screening::default(),
            last_y: T::ZERO,
            repeats: 0,
            quiet: false,
            open_rail: None,
            last_good_y: None,
            offset: T::ZERO,
            step: StepDetector::new(
                alpha(STEP_REFERENCE_S),
                samples(STEP_REFERENCE_S),
                STEP_FACTOR,
            ),
            alpha_level: alpha(LEVEL_S),
            level1: T::ZERO,
            level2: T::ZERO,
            level_ms: T::ZERO,
            level_ref: None,
            level_learn: samples(8.0 * LEVEL_S),
            level_learn_len: samples(8.0 * LEVEL_S),
            drift_fraction2: T::from_f64(DRIFT_FRACTION * DRIFT_FRACTION),
        })
    }

    /// Take one raw pair (u held over the coming period, y sampled now);
    /// returns the pair leaving the delay line, once it is full.
    #[inline]
    pub fn push(&mut self, u: T, y: T) -> Option<Guarded<T>> {
        self.push_checked(u, y, true)
    }

    /// [`SensorGuard::push`] for a caller that has already judged the
    /// sample (`valid` false: a converter error, counted as
    /// [`SampleFault::Upstream`] and otherwise ignored).
    #[inline]
    pub(crate) fn push_checked(&mut self, u: T, y: T, valid: bool) -> Option<Guarded<T>> {
        let index = self.index;
        self.push_at(u, y, valid, index)
    }

    /// [`SensorGuard::push_checked`] with the caller's sample index (a
    /// pipeline whose index skips ticks lost to an overrun); the next
    /// default index follows it.
    #[inline]
    pub(crate) fn push_at(&mut self, u: T, y: T, valid: bool, index: u64) -> Option<Guarded<T>> {
        self.push_inner(u, y, valid, index, None)
    }

    /// `SensorGuard::push_at` with the tests on the model's residual
    /// ([`ResidualMonitor`], given the estimator's Θ̂ by the caller): an
    /// offset step it finds is removed as the raw test's are, a drift's
    /// onset is flagged ([`LevelEvent::Drift`]). `None`: as
    /// `SensorGuard::push_at`. The monitor costs a second filter bank and
    /// two matched tests per sample (docs/ROBUSTNESS.md §1): the firmware's
    /// pipeline runs without it.
    #[inline]
    pub fn push_monitored(
        &mut self,
        u: T,
        y: T,
        valid: bool,
        index: u64,
        monitor: Option<&mut ResidualMonitor<T>>,
    ) -> Option<Guarded<T>> {
        self.push_inner(u, y, valid, index, monitor)
    }

    /// Both pushes (inlined into each: without a monitor the code is the
    /// guard's alone).
    #[inline(always)]
    fn push_inner(
        &mut self,
        u: T,
        y: T,
        valid: bool,
        index: u64,
        monitor: Option<&mut ResidualMonitor<T>>,
    ) -> Option<Guarded<T>> {
        self.index = index.wrapping_add(1);
        let (fault, mut level, stuck_started) = self.classify(u, y, valid, index);
        if let Some(m) = monitor {
            level = match fault {
                // A faulty sample is not pushed: the monitor rests.
                Some(_) => {
                    m.interrupt();
                    level
                }
                // `repeats` > 0: this reading repeats the previous one.
                None => self.monitored(m, u, y, self.repeats > 0, index, level),
            };
        }
        self.last = Screening { fault, level };
        if let Some(f) = fault {
            self.counts.bump(f, 1);
        }
        let entry = (u, y - self.offset, fault, index);
        let out = if self.delay.delay() == 0 {
            Some(entry)
        } else {
            self.delay.push(entry)
        };
        if stuck_started {
            // The run's earlier samples are still in the line.
            let n = usize::from(self.stuck_after);
            // (This sample itself was marked and counted at entry.)
            let flipped = self.delay.invalidate_recent(n + 1, SampleFault::Stuck);
            self.counts.bump(SampleFault::Stuck, flipped);
        }
        let (u, y, fault, index) = out?;
        if fault.is_some() {
            self.in_gap = true;
        } else if self.in_gap {
            self.in_gap = false;
            self.hold_pending = self.gap_hold;
            // The level after a gap is learnt afresh (the high-pass's
            // settling is not a drift).
            self.level_learn = self.level_learn_len.max(self.gap_hold);
        }
        let (u, y) = match (fault, self.hp.as_mut()) {
            (None, Some(hp)) => hp.push(u, y),
            // y is faulty, u is not: u's channel runs on.
            (Some(_), Some(hp)) if u.is_finite() => (hp.push_u(u), y),
            _ => (u, y),
        };
        if fault.is_none() {
            self.drift(y);
        }
        Some(Guarded { index, u, y, fault })
    }

    /// Classify at entry: (fault, level event, a stuck run completes now).
    #[inline]
    fn classify(
        &mut self,
        u: T,
        y: T,
        valid: bool,
        index: u64,
    ) -> (Option<SampleFault>, Option<LevelEvent>, bool) {
        if !valid {
            self.interrupt();
            return (Some(SampleFault::Upstream), None, false);
        }
        if !(u.is_finite() && y.is_finite()) {
            self.interrupt();
            return (Some(SampleFault::NonFinite), None, false);
        }
        if let Some((lo, hi)) = self.range {
            if y <= lo || y >= hi {
                let rail = if y >= hi { hi } else { lo };
                let jumped = self
                    .last_good_y
                    .is_some_and(|g| (rail - g).abs() > self.open_jump);
                if self.open_rail.is_some_and(|r| r != rail) {
                    // An open gauge holds one rail: a reading that moves
                    // from one rail to the other is an overload.
                    self.rail_switched = true;
                }
                let open = !self.rail_switched && (self.open_rail == Some(rail) || jumped);
                self.interrupt();
                if self.rail_switched {
                    self.open_rail = Some(rail);
                    return (Some(SampleFault::Saturated), None, false);
                }
                if open {
                    self.open_rail = Some(rail);
                    return (Some(SampleFault::Open), None, false);
                }
                return (Some(SampleFault::Saturated), None, false);
            }
        }
        self.open_rail = None;
        self.rail_switched = false;
        let repeat = y == self.last_y;
        if repeat {
            self.repeats = self.repeats.saturating_add(1);
        } else {
            self.repeats = 0;
            self.last_y = y;
        }
        if self.quiet {
            // A beam left at rest reads one code on a noise-free converter.
            self.repeats = 0;
        }
        if self.stuck_after > 0 && self.repeats >= self.stuck_after {
            let started = self.repeats == self.stuck_after;
            self.step.interrupt();
            return (Some(SampleFault::Stuck), None, started);
        }
        self.last_good_y = Some(y);
        let level = if self.offset_steps {
            self.offset_step(y, repeat, index)
        } else {
            None
        };
        (None, level, false)
    }

    /// Tell the guard whether the caller drives the beam (`quiet`: the
    /// excitation is off, its input constant). While it is quiet a repeated
    /// reading does not count towards a stuck run: a beam left at rest reads
    /// one code on a noise-free converter (the simulated bench: 82,000
    /// samples flagged stuck in 20 s at rest), and the estimators learn
    /// nothing from those samples anyway (no input: adaptation is frozen).
    /// The count starts afresh when the drive returns, so a sensor that
    /// stuck meanwhile is flagged `stuck_after` samples later. A live bridge
    /// never repeats that long, driven or not; call this before each push.
    pub(crate) fn set_input_quiet(&mut self, quiet: bool) {
        self.quiet = quiet;
    }

    /// A faulty sample breaks the runs and the second-difference history.
    fn interrupt(&mut self) {
        self.repeats = 0;
        self.step.interrupt();
    }

    /// What the latest push saw at entry (flags for telemetry: these are
    /// known at once, before the sample leaves the delay line).
    pub fn last_screening(&self) -> Screening {
        self.last
    }

    /// Samples the estimator fed by this guard should hold for now
    /// ([`crate::estimator::Estimator::hold`]), once: nonzero at the first
    /// good sample after a gap, and at the push that finds an offset step
    /// (whose first sample is then still in the delay line), when the
    /// high-pass is on (see `GAP_SETTLE_TIME_CONSTANTS`); 0 otherwise.
    /// Call after each push.
    #[inline]
    pub fn take_hold(&mut self) -> u32 {
        core::mem::take(&mut self.hold_pending)
    }

    /// Samples to hold an estimator that has just detected a plant change
    /// ([`crate::supervise`]: its change count went up), 0 without the
    /// high-pass. The high-pass's memory still holds the old plant's
    /// response, so for ~`GAP_SETTLE_TIME_CONSTANTS`/ω_c after the change
    /// the filtered pair is no input/output pair of either plant (the
    /// argument of the gap hold); data the law learnt from then would stay
    /// in P and Q for its whole memory. Measured on the paper's plant with
    /// an ω1 +10% step (`beamctl simulate --level-correction --step-at 10
    /// --step-omega 43.07,245.37`): without this hold 1% after 3.3 s and
    /// 0.1% not within 6 s; with it, docs/ROBUSTNESS.md §3.
    #[inline]
    pub fn change_hold(&self) -> u32 {
        self.gap_hold
    }

    /// The counters.
    pub fn counts(&self) -> GuardCounts {
        self.counts
    }

    /// Total offset removed by the step detector (units of y).
    pub fn offset(&self) -> T {
        self.offset
    }

    /// Samples between a push and its output.
    pub fn delay_samples(&self) -> usize {
        self.delay.delay()
    }

    /// Counters back to zero.
    pub(crate) fn reset_counts(&mut self) {
        self.counts = GuardCounts::default();
    }

    /// Turn the level corrections on or off between samples: the
    /// high-pass (a new corner restarts it) and the offset-step removal.
    ///
    /// # Errors
    /// [`GuardError::Highpass`] for an invalid corner (nothing changed).
    pub fn set_level_correction(
        &mut self,
        highpass_rad_s: Option<f64>,
        offset_steps: bool,
        ts_s: f64,
    ) -> Result<(), GuardError> {
        self.hp = match highpass_rad_s {
            Some(w) => Some(HighPass::new(w, ts_s).ok_or(GuardError::Highpass)?),
            None => None,
        };
        self.gap_hold = highpass_rad_s.map_or(0, |w| {
            libm::ceil(GAP_SETTLE_TIME_CONSTANTS / (w * ts_s)).min(u32::MAX as f64) as u32
        });
        if offset_steps && !self.offset_steps {
            // Learn the step statistic's level afresh; the step is found
            // up to STEP_LATENCY samples after it: the delay line must
            // still hold it.
            self.step.relearn();
            self.delay
                .lengthen(line_delay(self.stuck_after, offset_steps));
        }
        self.offset_steps = offset_steps;
        Ok(())
    }

    /// A new time series (the caller restarted its estimator and lost the
    /// samples in the line): the delay line is emptied and the runs and
    /// histories restart; the high-pass, the removed offset and the
    /// counters are kept.
    pub fn clear(&mut self) {
        self.delay.clear();
        self.repeats = 0;
        self.step.interrupt();
        self.open_rail = None;
        self.rail_switched = false;
        self.in_gap = false;
        self.hold_pending = 0;
    }
}

#[cfg(test)]
mod tests;
