//! Commands → changes of the sample task: what the link may change
//! ([`Control`], implemented by [`Pipeline`]), what the board provides
//! ([`Device`]: the lock and the estimator storage), and the translation of
//! the protocol's settings into the core's ([`ExcitationPlan`],
//! [`estimator_configs`]; a waveform is built from the wire's own type,
//! [`Generator::new`]).
//!
//! # Between samples, expensive work outside the lock
//! A command is validated first ([`Command::validate`](beam_protocol::Command::validate)),
//! then everything expensive is prepared in the low-priority context with
//! the sample interrupt running: a new waveform ([`Generator::new`] scans a
//! multisine's whole period), a new estimator (its matrix exponentials).
//! Only then does the link take the lock ([`Device::with_pipeline`]: the
//! sample interrupt masked, so the change lands between two samples) for a
//! few setters or a swap. An excitation change is made on a copy of the
//! running generator inside the lock and written back only if every
//! setter accepted it, so a refused change leaves the output untouched.

use crate::estimator::robust::{Head, RecordStore, RobustConfig, RobustEstimator};
use crate::estimator::{AdaptiveConfig, ConfigError, Estimator};
use crate::excitation::{self, Excitation, ExcitationError, Generator};
use crate::filter_bank::{FilterConfig, FilterConfigError};
use crate::guard::lines::{LineCanceller, LineSpec, MAX_LINES};
use crate::pipeline::{Counters, PiezoDac, Pipeline, PipelineError, Sink, StrainAdc};
use crate::pipeline::{RawBlock, TelemetryRecord};
use crate::scalar::Real;
use beam_protocol::{self as protocol, EstimatorSettings, RejectReason, Waveform, WaveformKind};

/// The line canceller a [`protocol::LineRemoval`] asks for at sample rate
/// `fs_hz` (validated already): the mains and its harmonics
/// 1..=`harmonics` below the Nyquist frequency, weights from zero; `None`
/// when off.
///
/// # Errors
/// [`RejectReason::LineRemoval`] for settings the canceller refuses.
pub(crate) fn line_canceller<T: Real>(
    l: &protocol::LineRemoval,
    fs_hz: f64,
) -> Result<Option<LineCanceller<T, MAX_LINES>>, RejectReason> {
    if l.is_off() {
        return Ok(None);
    }
    let mains = f64::from(l.mains_hz);
    let mut specs = [LineSpec {
        freq_hz: mains,
        y_phasor: [0.0, 0.0],
    }; MAX_LINES];
    let mut n = 0;
    for k in 1..=l.harmonics.min(protocol::LineRemoval::MAX_HARMONICS) {
        let f = f64::from(k) * mains;
        if f < 0.5 * fs_hz {
            if let Some(s) = specs.get_mut(n) {
                s.freq_hz = f;
                n += 1;
            }
        }
    }
    LineCanceller::new(
        specs.get(..n).unwrap_or_default(),
        1.0 / fs_hz,
        f64::from(l.time_constant_s),
    )
    .map(Some)
    .map_err(|_| RejectReason::LineRemoval)
}

/// How long the law is held after the line remover is switched
/// (samples): five time constants (a line present at the switch is then
/// down to e^(−5) ≈ 0.7% of itself in y, the weights starting from zero;
/// [`crate::guard::lines`]). 0 when switched off.
pub(crate) fn line_settling_samples(l: &protocol::LineRemoval, fs_hz: f64) -> u32 {
    if l.is_off() {
        return 0;
    }
    let n = libm::round(5.0 * f64::from(l.time_constant_s) * fs_hz);
    if n >= f64::from(u32::MAX) {
        u32::MAX
    } else {
        n as u32
    }
}

/// What the link changes in the running sample task. Implemented by
/// [`Pipeline`]; each call is made with the sample interrupt masked
/// ([`Device::with_pipeline`]) and costs at most a few hundred
/// instructions (a swap, a copy of the excitation).
pub trait Control<T> {
    /// The estimator type the pipeline steps.
    type Estimator;
    /// [`Pipeline::freeze`].
    fn freeze(&mut self);
    /// [`Pipeline::resume`].
    fn resume(&mut self);
    /// [`Pipeline::reset_estimator`].
    fn reset_estimator(&mut self);
    /// [`Pipeline::replace_estimator`].
    fn replace_estimator(
        &mut self,
        estimator: Self::Estimator,
        lambda_rad_s: f64,
    ) -> Result<Self::Estimator, Self::Estimator>;
    /// [`Pipeline::set_telemetry_every`].
    fn set_telemetry_every(&mut self, every: u32) -> Result<(), PipelineError>;
    /// [`Pipeline::set_raw_decimation`].
    fn set_raw_decimation(&mut self, decimation: u16);
    /// [`Pipeline::excitation_mut`].
    fn excitation_mut(&mut self) -> &mut Excitation<T>;
    /// [`Pipeline::counters`].
    fn counters(&self) -> Counters;
    /// [`Pipeline::next_sample_index`].
    fn next_sample_index(&self) -> u64;
    /// [`Pipeline::set_line_removal`].
    fn set_line_removal(&mut self, lines: Option<LineCanceller<T, MAX_LINES>>, hold: u32);
    /// [`Pipeline::is_frozen`].
    fn is_frozen(&self) -> bool;
    /// The ADC's ID and configuration registers read back
    /// ([`StrainAdc::read_back`]): two SPI frames, for the self-test.
    fn adc_read_back(&mut self) -> Result<ads131m02::ReadBack, crate::pipeline::FaultKind>;
}

impl<T, E, A, D, S, R, const NP: usize, const NS: usize> Control<T>
    for Pipeline<T, E, A, D, S, R, NP, NS>
where
    T: Real,
    E: Estimator<T, NP>,
    A: StrainAdc,
    D: PiezoDac<T>,
    S: Sink<TelemetryRecord<T, NP, NS>>,
    R: Sink<RawBlock<T>>,
{
    type Estimator = E;
    fn freeze(&mut self) {
        Pipeline::freeze(self);
    }
    fn resume(&mut self) {
        Pipeline::resume(self);
    }
    fn reset_estimator(&mut self) {
        Pipeline::reset_estimator(self);
    }
    fn replace_estimator(&mut self, estimator: E, lambda_rad_s: f64) -> Result<E, E> {
        Pipeline::replace_estimator(self, estimator, lambda_rad_s)
    }
    fn set_telemetry_every(&mut self, every: u32) -> Result<(), PipelineError> {
        Pipeline::set_telemetry_every(self, every)
    }
    fn set_raw_decimation(&mut self, decimation: u16) {
        Pipeline::set_raw_decimation(self, decimation);
    }
    fn excitation_mut(&mut self) -> &mut Excitation<T> {
        Pipeline::excitation_mut(self)
    }
    fn set_line_removal(&mut self, lines: Option<LineCanceller<T, MAX_LINES>>, hold: u32) {
        Pipeline::set_line_removal(self, lines, hold);
    }
    fn counters(&self) -> Counters {
        Pipeline::counters(self)
    }
    fn next_sample_index(&self) -> u64 {
        Pipeline::next_sample_index(self)
    }
    fn is_frozen(&self) -> bool {
        Pipeline::is_frozen(self)
    }
    fn adc_read_back(&mut self) -> Result<ads131m02::ReadBack, crate::pipeline::FaultKind> {
        self.converters_mut().0.read_back()
    }
}

/// What the board gives the link: exclusive access to the sample task's
/// pipeline between two samples, and storage for estimators.
pub trait Device {
    /// The scalar type of the pipeline.
    type Real: Real;
    /// The estimator type the pipeline steps.
    type Estimator;
    /// The pipeline.
    type Pipeline: Control<Self::Real, Estimator = Self::Estimator>;

    /// Run `f` on the pipeline with the sample interrupt masked (a change
    /// then lands between two samples). Keep `f` short: the link only calls
    /// setters and swaps inside.
    fn with_pipeline<R>(&mut self, f: impl FnOnce(&mut Self::Pipeline) -> R) -> R;

    /// Build an estimator for `settings` on the filter bank `filter` (λ,
    /// U0, Y0 from the tuning rule; Ts, hold and timing the board's),
    /// starting from θ(0) = `theta0` in `filter`'s scaled coordinates
    /// (empty: zero; otherwise exactly the estimator's parameter count, else
    /// refuse with `EstimatorUnavailable`). Called outside the lock;
    /// [`estimator_configs`] maps the settings, [`with_theta0`] the start.
    fn build_estimator(
        &mut self,
        settings: &EstimatorSettings,
        filter: &FilterConfig,
        theta0: &[f64],
    ) -> Result<Self::Estimator, RejectReason>;

    /// Take back an estimator the pipeline no longer runs (e.g. to reuse
    /// its static storage for the next [`Device::build_estimator`]).
    fn recycle_estimator(&mut self, old: Self::Estimator);

    /// Put `estimator` (from [`Device::build_estimator`]) in the running
    /// one's place at λ = `lambda_rad_s`, adaptation resumed if `resume`,
    /// inside one lock; returns the estimator to recycle (the replaced one,
    /// or `estimator` itself refused: an invalid λ) and the index of the
    /// next sample. The default swaps ([`Control::replace_estimator`]); a
    /// board that builds a new estimator into the running one's storage
    /// (one slot for a large record) overrides it.
    fn swap_estimator(
        &mut self,
        estimator: Self::Estimator,
        lambda_rad_s: f64,
        resume: bool,
    ) -> (Result<Self::Estimator, Self::Estimator>, u64) {
        self.with_pipeline(|pl| {
            let swap = pl.replace_estimator(estimator, lambda_rad_s);
            if swap.is_ok() && resume {
                pl.resume();
            }
            (swap, pl.next_sample_index())
        })
    }
    /// Return when a sample tick has just ended, so that the next lock
    /// (the self-test's register read-back: two SPI frames) ends before
    /// the next conversion completes; a conversion completing during it
    /// would be output by the read's frame and missed by the next tick.
    /// The default returns at once: right for a board whose converter
    /// converts only inside the sample interrupt (the QEMU models).
    fn align_to_sample(&mut self) {}
}

/// The core's estimator settings for the protocol's: the board's filter
/// bank `base` (its sample period, signal scales, output hold and
/// converter timing: properties of the device, not of the command) at
/// `lambda_rad_s` for the commanded sensor output kind
/// ([`FilterConfig::output`]: the model s^r·B/A), and the adaptive law with
/// Γ = gain, l = forgetting_p, γ = forgetting_h, R(0) = H(0)⁻¹ =
/// I/initial_gain (eqs. 33–41), θ(0) = 0 and the default θ-step interval
/// ([`AdaptiveConfig::default`]). Nothing of the running estimator is
/// carried over: a new λ changes Θ's meaning (eq. 29), new gains change P
/// and R.
pub fn estimator_configs<const NP: usize>(
    settings: &EstimatorSettings,
    lambda_rad_s: f64,
    base: &FilterConfig,
) -> (FilterConfig, AdaptiveConfig<NP>) {
    let filter = FilterConfig {
        lambda_rad_s,
        output: settings.output,
        ..*base
    };
    let law = AdaptiveConfig {
        gain: f64::from(settings.gain),
        forgetting_p: f64::from(settings.forgetting_p),
        forgetting_h: f64::from(settings.forgetting_h),
        r0_diag: [1.0 / f64::from(settings.initial_gain); NP],
        ..AdaptiveConfig::default()
    };
    (filter, law)
}

/// The core's settings of the robust estimator
/// ([`crate::estimator::robust`], `EstimatorKind::Robust`) for the
/// protocol's: [`estimator_configs`]' filter bank, converter timing
/// included (the output-error model simulates it on its u like the bank's
/// u channel), Γ = gain (eq. 41), l = forgetting_p (eq. 33; γ is tied to
/// it, forgetting_h is unused), R(0) = I/initial_gain; its start-up law is
/// the adaptive law of the same settings; model updates only when the
/// caller applies them (`update_every = 0`: firmware prepares them off the
/// sample path).
pub fn robust_configs<const NP: usize>(
    settings: &EstimatorSettings,
    lambda_rad_s: f64,
    base: &FilterConfig,
) -> (FilterConfig, RobustConfig<NP>) {
    let (filter, startup) = estimator_configs::<NP>(settings, lambda_rad_s, base);
    let law = RobustConfig {
        gain: f64::from(settings.gain),
        forgetting: f64::from(settings.forgetting_p),
        r0_diag: [1.0 / f64::from(settings.initial_gain); NP],
        startup,
        update_every: 0,
        ..RobustConfig::default()
    };
    (filter, law)
}

/// Rebuild the two-mode robust estimator in `slot` for `settings` on the
/// filter bank `filter` ([`robust_configs`], u kept in the record on the
/// grid `input_step`, [`RobustConfig::input_step`]: the board's DAC step in
/// actuator volts), its start-up law from θ(0) = `theta0`
/// ([`with_theta0`]), in place ([`RobustEstimator::rebuild`]: a board's
/// static slot is larger than its stack). On a refusal `slot` is
/// unchanged.
///
/// # Errors
/// `EstimatorUnavailable` for a `theta0` of another length than 7, and
/// [`reject_config`]'s reason for settings the estimator refuses.
pub fn rebuild_robust<T: Real, const B: usize, R: RecordStore<T>>(
    slot: &mut RobustEstimator<T, 4, 7, 28, B, R>,
    settings: &EstimatorSettings,
    filter: &FilterConfig,
    theta0: &[f64],
    input_step: f64,
) -> Result<(), RejectReason> {
    let (filter, law) = robust_law(settings, filter, theta0, input_step)?;
    slot.rebuild(&filter, &law).map_err(reject_config)
}

/// What [`rebuild_robust`] builds, without the record: the head a board
/// with one record slot installs into the running estimator
/// ([`RobustEstimator::install`], inside its lock).
///
/// # Errors
/// As [`rebuild_robust`].
pub fn robust_head<T: Real>(
    settings: &EstimatorSettings,
    filter: &FilterConfig,
    theta0: &[f64],
    input_step: f64,
) -> Result<Head<T, 4, 7, 28>, RejectReason> {
    let (filter, law) = robust_law(settings, filter, theta0, input_step)?;
    Head::new(&filter, &law).map_err(reject_config)
}

/// [`robust_configs`] with the start and the record's u grid.
fn robust_law(
    settings: &EstimatorSettings,
    filter: &FilterConfig,
    theta0: &[f64],
    input_step: f64,
) -> Result<(FilterConfig, RobustConfig<7>), RejectReason> {
    let (filter, mut law) = robust_configs::<7>(settings, filter.lambda_rad_s, filter);
    law.startup = with_theta0(law.startup, theta0).ok_or(RejectReason::EstimatorUnavailable)?;
    law.input_step = input_step;
    Ok((filter, law))
}

/// `law` starting from θ(0) = `theta0` (scaled; empty: unchanged);
/// `None` if `theta0` has another length than `NP`.
pub fn with_theta0<const NP: usize>(
    mut law: AdaptiveConfig<NP>,
    theta0: &[f64],
) -> Option<AdaptiveConfig<NP>> {
    if theta0.is_empty() {
        return Some(law);
    }
    law.theta0 = theta0.try_into().ok()?;
    Some(law)
}

/// The reason to refuse an estimator the core would not build.
pub fn reject_config(e: ConfigError) -> RejectReason {
    match e {
        ConfigError::Filter(FilterConfigError::Lambda) => RejectReason::Lambda,
        ConfigError::Filter(_) | ConfigError::Dimensions => RejectReason::EstimatorUnavailable,
        ConfigError::Gain => RejectReason::Gain,
    }
}

/// The reason to refuse an excitation the generators would not build.
pub(crate) fn reject_excitation(e: ExcitationError) -> RejectReason {
    match e {
        ExcitationError::Frequency | ExcitationError::SampleRate | ExcitationError::Unsupported => {
            RejectReason::Frequency
        }
        ExcitationError::Amplitude => RejectReason::Amplitude,
        ExcitationError::Offset => RejectReason::NotFinite,
        ExcitationError::Window | ExcitationError::OutsideWindow => RejectReason::SafeWindow,
        ExcitationError::Tones => RejectReason::ToneCount,
        ExcitationError::Period => RejectReason::SweepTime,
        ExcitationError::PrbsOrder => RejectReason::PrbsLength,
    }
}

/// How the waveform changes. `Replace` carries a whole generator (a
/// multisine's tables, ~200 bytes) by value: there is no allocator, and
/// one plan exists per command.
#[derive(Debug, Clone, Copy, PartialEq)]
#[allow(clippy::large_enum_variant)]
enum WaveChange {
    /// Same waveform: only the level changes, the phase runs on.
    Keep,
    /// A square wave's new frequency (Hz; its phase runs on).
    SquareFrequency(f32),
    /// A new generator, built outside the lock.
    Replace(Generator),
}

/// A validated excitation change, prepared outside the lock.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ExcitationPlan<T> {
    wave: WaveChange,
    amplitude_v: T,
    offset_v: T,
}

impl<T: Real> ExcitationPlan<T> {
    /// Prepare `new` (already validated against the limits) given the
    /// waveform in force, `current`: the same waveform keeps its phase; a
    /// square wave's new frequency keeps its phase; anything else builds a
    /// new generator here (a multisine scans its period now).
    pub fn new(
        new: &protocol::Excitation,
        current: &protocol::Excitation,
        sample_rate_hz: f64,
    ) -> Result<Self, RejectReason> {
        let wave = match (&new.waveform, &current.waveform) {
            (a, b) if a == b => WaveChange::Keep,
            (Waveform::Square { freq_hz }, Waveform::Square { .. }) => {
                WaveChange::SquareFrequency(*freq_hz)
            }
            (w, _) => {
                WaveChange::Replace(Generator::new(w, sample_rate_hz).map_err(reject_excitation)?)
            }
        };
        let (amplitude_v, offset_v) = excitation::level(new);
        Ok(Self {
            wave,
            amplitude_v,
            offset_v,
        })
    }

    /// Apply to the running generator (inside the lock): on a copy, written
    /// back only if every setter accepts. A few hundred instructions.
    pub fn apply(&self, running: &mut Excitation<T>) -> Result<(), RejectReason> {
        let mut e = *running;
        match self.wave {
            WaveChange::Keep => {}
            WaveChange::SquareFrequency(f) if e.kind() == WaveformKind::Square => {
                e.set_frequency(f64::from(f)).map_err(reject_excitation)?;
            }
            WaveChange::SquareFrequency(freq_hz) => {
                let w = Generator::new(
                    &Waveform::Square { freq_hz },
                    e.generator().sample_rate_hz(),
                )
                .map_err(reject_excitation)?;
                e.set_generator(w).map_err(reject_excitation)?;
            }
            WaveChange::Replace(w) => e.set_generator(w).map_err(reject_excitation)?,
        }
        e.set_level(self.amplitude_v, self.offset_v)
            .map_err(reject_excitation)?;
        *running = e;
        Ok(())
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used, clippy::indexing_slicing)]
mod tests {
    use super::*;
    use crate::excitation::SafeWindow;
    use crate::filter_bank::SignalScales;
    use beam_protocol::OutputKind;

    const FS: f64 = 10_000.0;

    fn running() -> Excitation<f32> {
        Excitation::new(
            &Waveform::Square { freq_hz: 7.0 },
            0.1,
            0.0,
            SafeWindow {
                min_v: -10.0,
                max_v: 10.0,
            },
            FS,
        )
        .unwrap()
    }

    fn px(waveform: protocol::Waveform, a: f32, o: f32) -> protocol::Excitation {
        protocol::Excitation {
            waveform,
            amplitude_v: a,
            offset_v: o,
        }
    }

    const SQ7: protocol::Waveform = protocol::Waveform::Square { freq_hz: 7.0 };

    #[test]
    fn level_change_keeps_the_phase() {
        let mut a = running();
        let mut b = running();
        for _ in 0..300 {
            a.next_sample();
            b.next_sample();
        }
        let plan = ExcitationPlan::<f32>::new(&px(SQ7, 0.2, 0.5), &px(SQ7, 0.1, 0.0), FS).unwrap();
        plan.apply(&mut a).unwrap();
        b.set_level(0.2, 0.5).unwrap();
        for _ in 0..2000 {
            assert_eq!(a.next_sample(), b.next_sample());
        }
        assert_eq!(a.amplitude(), 0.2);
    }

    #[test]
    fn square_frequency_and_new_waveforms() {
        let mut e = running();
        let plan = ExcitationPlan::<f32>::new(
            &px(protocol::Waveform::Square { freq_hz: 11.0 }, 0.1, 0.0),
            &px(SQ7, 0.1, 0.0),
            FS,
        )
        .unwrap();
        assert_eq!(plan.wave, WaveChange::SquareFrequency(11.0));
        plan.apply(&mut e).unwrap();
        let ms = protocol::Waveform::Multisine {
            f_min_hz: 2.0,
            f_max_hz: 80.0,
            tones: 6,
        };
        let plan = ExcitationPlan::<f32>::new(&px(ms, 0.3, 0.0), &px(SQ7, 0.1, 0.0), FS).unwrap();
        plan.apply(&mut e).unwrap();
        assert_eq!(e.kind(), WaveformKind::Multisine);
        let peak = (0..70_000)
            .map(|_| e.next_sample().abs())
            .fold(0.0, f32::max);
        assert!(peak <= 0.3 && peak > 0.29, "{peak}");
        for (w, kind) in [
            (protocol::Waveform::Off, WaveformKind::Off),
            (
                protocol::Waveform::Prbs {
                    bit_rate_hz: 500.0,
                    register_bits: 10,
                },
                WaveformKind::Prbs,
            ),
            (
                protocol::Waveform::Chirp {
                    f_start_hz: 1.0,
                    f_end_hz: 80.0,
                    sweep_s: 4.0,
                },
                WaveformKind::Chirp,
            ),
        ] {
            ExcitationPlan::<f32>::new(&px(w, 0.1, 0.0), &px(ms, 0.3, 0.0), FS)
                .unwrap()
                .apply(&mut e)
                .unwrap();
            assert_eq!(e.kind(), kind);
        }
        // Off: only the offset counts.
        assert_eq!(e.kind(), WaveformKind::Chirp);
        ExcitationPlan::<f32>::new(
            &px(protocol::Waveform::Off, 50.0, 9.0),
            &px(SQ7, 0.1, 0.0),
            FS,
        )
        .unwrap()
        .apply(&mut e)
        .unwrap();
        assert_eq!(e.next_sample(), 9.0);
    }

    #[test]
    fn a_refused_change_changes_nothing() {
        let mut e = running();
        for _ in 0..123 {
            e.next_sample();
        }
        let before = e;
        // Past the window: the core refuses at set_level, after the
        // waveform was replaced on the copy.
        let plan = ExcitationPlan::<f32>::new(
            &px(protocol::Waveform::Square { freq_hz: 30.0 }, 9.0, 2.0),
            &px(SQ7, 0.1, 0.0),
            FS,
        )
        .unwrap();
        assert_eq!(plan.apply(&mut e), Err(RejectReason::SafeWindow));
        assert_eq!(e, before);
        // A multisine band the generator cannot place (validated ranges
        // pass, but 16 tones do not fit below Nyquist on the grid).
        let bad = protocol::Waveform::Multisine {
            f_min_hz: 4_990.0,
            f_max_hz: 4_999.0,
            tones: 16,
        };
        assert_eq!(
            ExcitationPlan::<f32>::new(&px(bad, 0.1, 0.0), &px(SQ7, 0.1, 0.0), FS),
            Err(RejectReason::Frequency)
        );
    }

    #[test]
    fn estimator_settings_map_to_the_core() {
        let s = EstimatorSettings {
            gain: 2e4,
            forgetting_p: 0.1,
            forgetting_h: 0.2,
            initial_gain: 1e8,
            ..EstimatorSettings::default()
        };
        let scales = SignalScales {
            u_scale: 0.1,
            y_scale: 1e-3,
        };
        let base = FilterConfig {
            ts_s: 1e-4,
            scales,
            ..FilterConfig::default()
        };
        let (f, l) = estimator_configs::<7>(&s, 150.0, &base);
        assert_eq!(f.lambda_rad_s, 150.0);
        assert_eq!(f.scales, scales);
        assert_eq!(f.output, OutputKind::Strain);
        for output in OutputKind::ALL {
            let s = EstimatorSettings { output, ..s };
            assert_eq!(estimator_configs::<7>(&s, 150.0, &base).0.output, output);
            assert_eq!(robust_configs::<7>(&s, 150.0, &base).0.output, output);
        }
        assert_eq!(l.gain, 2e4);
        assert_eq!(l.forgetting_p, f64::from(0.1f32));
        assert_eq!(l.forgetting_h, f64::from(0.2f32));
        assert_eq!(l.r0_diag, [1e-8; 7]);
        assert_eq!(l.theta0, [0.0; 7]);
        // The protocol's defaults are the core's defaults.
        let (_, d) = estimator_configs::<7>(&EstimatorSettings::default(), 100.0, &base);
        let core = AdaptiveConfig::<7>::default();
        assert_eq!(d.gain, core.gain);
        assert!((d.forgetting_p / core.forgetting_p - 1.0).abs() < 1e-7);
        assert!((d.r0_diag[0] / core.r0_diag[0] - 1.0).abs() < 1e-7);
        assert_eq!(d.theta_update_every, core.theta_update_every);
        assert_eq!(reject_config(ConfigError::Gain), RejectReason::Gain);
        assert_eq!(
            reject_config(ConfigError::Filter(FilterConfigError::Lambda)),
            RejectReason::Lambda
        );
    }
}
