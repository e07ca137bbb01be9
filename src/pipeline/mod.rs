//! The per-sample pipeline: one ADC conversion in, one DAC value out, the
//! estimator stepped in between, telemetry every K samples — the whole
//! 10 kHz sample task, hardware-free and generic over the converters
//! ([`StrainAdc`], [`PiezoDac`]), the estimator ([`Estimator`]) and the
//! scalar type.
//!
//! The real converter drivers plug in through `adapters` (and are
//! brought up by [`bring_up`]).
//!
//! # One tick, in order ([`Pipeline::tick`], called on each data-ready)
//! 1. **Read the conversion** of both channels: y at t_k (bridge) and the
//!    amplifier monitor.
//! 2. **Next excitation value → DAC write.** Done before any arithmetic, so
//!    the delay from data-ready to the DAC update is short and does not
//!    depend on the estimator's cost (a variable delay would be a variable
//!    phase on u).
//! 3. **Screen the conversion:** converter errors by kind, readings the
//!    driver flagged stale or stuck, full-scale codes
//!    (saturation), a bridge code repeated `stuck_after` times (stuck: the
//!    whole run, through a delay line of `stuck_after` + 1 samples: the
//!    run's early samples would otherwise reach the estimator and corrupt
//!    P and Q for as long as they are remembered), a non-finite conversion.
//! 4. **Convert** codes → volts → strain → y (`convert`: quarter bridge,
//!    optionally eq. 17's deflection), monitor code → actuator volts.
//! 5. **Pair u with y** as the estimator's contract requires ([`Estimator::step`]:
//!    u held over the coming period, y sampled now) — see *Alignment*.
//! 6. **Line remover** and **prefilter** on u and y identically (both
//!    optional: the mains and its harmonics, [`Pipeline::set_line_removal`],
//!    [`crate::guard::lines`]; a low-pass, `prefilter`).
//! 7. **Estimator step**; an invalid sample is passed as NaN (see *Bad
//!    samples*).
//! 8. **Raw block** of the (u, y) pairs (optional, decimated) and, every K
//!    samples, a **telemetry record** — both pushed into bounded
//!    single-producer queues ([`Sink`]); a full queue drops and counts,
//!    nothing waits.
//!
//! # Alignment
//! The host reference loop (`host-tests` runner) does `u = excitation();
//! y = plant.sample(u); est.step(u, y)`: y(t_k) is read *before* u_k is
//! applied, and u_k is held over [t_k, t_{k+1}). At tick k the conversion
//! gives y(t_k); with [`DacLatch::Immediate`] the value written now is u_k,
//! so the estimator gets `step(u_k, y_k)`. With [`DacLatch::NextTick`] (the
//! DAC's latch is pulsed by the next data-ready, e.g. AD5761R LDAC, so
//! the update instant is exact) the value written now is u_{k+1} and the
//! value written at the previous tick is u_k. With
//! [`InputSource::Monitored`] the monitor sampled at t_k measures the
//! voltage held over [t_{k−1}, t_k), so it is paired with y_{k−1}: the
//! estimator runs one sample behind. Host test: the pipeline over the
//! simulated plant reproduces the directly fed estimator bit for bit.
//!
//! # Which u
//! [`InputSource::Commanded`] (default): the voltage the DAC holds (its
//! reported, quantised value) times the amplifier gain. It is exactly what
//! the estimator's zero-order-hold model assumes (a piecewise-constant
//! input, eq. 28–29 filtered exactly) and carries no measurement noise.
//! The amplifier's own dynamics and gain error then become part of the
//! identified plant: a gain error scales b̄ only (ω, ζ are unaffected), and
//! a piezo amplifier's bandwidth (kHz) is far above the beam's modes.
//! [`InputSource::Monitored`] uses the monitor channel instead (as the
//! paper monitored the amplified signal): it removes the amplifier from the
//! model but brings ADC noise onto u (errors in variables) and a waveform
//! that is no longer exactly held between samples.
//!
//! # Bad samples
//! A sample with a converter error, a saturated, stuck or non-finite
//! bridge conversion (with `Monitored`: also a bad monitor conversion), or
//! a failed DAC write (with `Commanded`: the held value is unknown) is
//! *invalid*. The estimator is then stepped with y = NaN (and u = NaN
//! unless u is known: a sample rejected for its y alone carries the u the
//! beam saw, which the robust estimator's model simulation needs): it keeps
//! its time base, substitutes its last good sample into the filters and
//! freezes its law for 40 filter time constants (the quarantine of
//! [`crate::estimator`]), so nothing of the bad sample ever reaches Θ̂.
//! Skipping the step instead would shift the filters' time base by one
//! sample. The prefilter is fed the known u and the last good y (the last
//! good u too when u is not known).
//!
//! # Deliberate holds
//! When the estimator's filters are out of step with the beam through no
//! fault of the data — after a reported overrun ([`Pipeline::note_overrun`]:
//! the filters missed samples), a resume from freeze, or a new or reset
//! estimator while the beam moves ([`Pipeline::replace_estimator`],
//! [`Pipeline::reset_estimator`]) — the pipeline holds the law for the
//! estimator's settling time ([`Estimator::hold`] with
//! [`Estimator::settling_samples`]): the filters keep taking the real
//! samples, Θ̂ and P stay, and nothing is counted as rejected. (Without the
//! hold, an estimator started on the moving paper beam in `f32` was measured
//! 71% off on ω2 after 5 s; with it, 9e-8.)
//!
//! # Concurrency (RTIC-like)
//! The sample task (data-ready interrupt, highest priority) owns the
//! pipeline and calls [`Pipeline::tick`]. The low-priority task owns the
//! consumer ends of the queues and calls [`telemetry::recover`], and
//! changes settings through the `set_*`/`freeze`/`reset_*`/
//! `replace_estimator` methods while holding the pipeline's lock (the
//! sample interrupt masked for the few hundred cycles a setter takes): a
//! change is therefore always applied between two ticks and takes effect at
//! the next one. Everything expensive — a multisine's construction, a new
//! estimator (its matrix exponentials), modal recovery, λmin(P) — is done
//! in the low-priority task *outside* the lock and handed over by value.

#![deny(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::panic,
    clippy::indexing_slicing
)]

pub(crate) mod adapters;
mod config;
pub(crate) mod convert;
pub(crate) mod converters;
pub(crate) mod prefilter;
pub(crate) mod telemetry;

pub(crate) use adapters::adc_scales;
pub use adapters::{bring_up, lost_configuration, BringUp, BringUpError};
pub use config::{DacLatch, InputSource, PipelineConfig, PipelineError, Tick, TickReading};
pub use convert::{
    AdcScale, AnalogFrontEnd, BridgeConfig, Conversion, ConversionConfig, ConversionError, Eq17,
    Linearisation, OutputQuantity, ADS131M02_VREF_V,
};
pub(crate) use converters::ADC_CODE_MIN;
pub use converters::{
    AdcFlags, AdcReading, DacOutcome, Fault, FaultKind, PiezoDac, StrainAdc, ADC_CODE_MAX,
};
pub use prefilter::{Prefilter, PrefilterConfig, PrefilterError, PrefilterState};
pub use telemetry::{
    recover, unpack_symmetric, Counters, NoSink, RawBlock, Recovered, Sink, StepCounts,
    TelemetryRecord, RAW_BLOCK_LEN,
};

use crate::estimator::Estimator;
use crate::excitation::Excitation;
use crate::guard::lines::{LineCanceller, MAX_LINES};
use crate::guard::MAX_DELAY;
use crate::guard::{GuardConfig, GuardError, SensorGuard};
use crate::scalar::Real;
use crate::supervise::ExcitationReason;
use beam_protocol::{StatusFlags, WaveformKind};

/// The sample task's state: converters, excitation, estimator, telemetry.
///
/// `NP` = 4n − 1 parameters, `NS` = NP(NP + 1)/2; `S` receives telemetry
/// records, `R` raw blocks.
pub struct Pipeline<T, E, A, D, S, R, const NP: usize, const NS: usize> {
    estimator: E,
    adc: A,
    dac: D,
    telemetry: S,
    raw: R,
    excitation: Excitation<T>,
    conv: Conversion<T>,
    prefilter: Option<Prefilter<T>>,
    /// The line remover on u and y after the guard (`None`: off).
    lines: Option<LineCanceller<T, MAX_LINES>>,
    pf_u: PrefilterState<T>,
    pf_y: PrefilterState<T>,
    input: InputSource,
    latch: DacLatch,
    dac_per_actuator: T,
    actuator_per_dac: T,
    telemetry_every: u32,
    since_record: u32,
    raw_decimation: u16,
    raw_phase: u16,
    raw_block: RawBlock<T>,
    /// Float-level checks (saturation, stuck, open bridge), the delay line
    /// and the level corrections, after conversion ([`crate::guard`]).
    guard: SensorGuard<T>,
    ts_s: f64,
    /// The estimator's detected changes at the previous record.
    changes_seen: u32,
    /// ... and when the last change hold was given (the high-pass on).
    changes_held: u32,
    lambda_rad_s: f64,
    next_index: u64,
    frozen: bool,
    /// NextTick: the held u the DAC latches at this tick, and whether valid.
    pending: Option<(T, bool)>,
    /// Monitored: the previous y and whether it was valid.
    prev_y: Option<(T, bool)>,
    last_good: (T, T),
    counters: Counters,
    flags: StatusFlags,
    steps: StepCounts,
    last_fed: (T, T),
}

fn bump(c: &mut u32) {
    *c = c.saturating_add(1);
}

impl<T, E, A, D, S, R, const NP: usize, const NS: usize> Pipeline<T, E, A, D, S, R, NP, NS>
where
    T: Real,
    E: Estimator<T, NP>,
    A: StrainAdc,
    D: PiezoDac<T>,
    S: Sink<TelemetryRecord<T, NP, NS>>,
    R: Sink<RawBlock<T>>,
{
    /// Assemble a pipeline (validates `config`).
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        config: &PipelineConfig,
        estimator: E,
        excitation: Excitation<T>,
        adc: A,
        dac: D,
        telemetry: S,
        raw: R,
    ) -> Result<Self, PipelineError> {
        let conv = config.conversion.compile::<T>()?;
        let prefilter = match &config.prefilter {
            Some(c) => Some(Prefilter::new(c)?),
            None => None,
        };
        let g = config.amplifier_gain;
        if !(g != 0.0 && g.is_finite()) {
            return Err(PipelineError::AmplifierGain);
        }
        if config.telemetry_every == 0 {
            return Err(PipelineError::TelemetryRate);
        }
        if !(config.lambda_rad_s > 0.0 && config.lambda_rad_s.is_finite()) {
            return Err(PipelineError::Lambda);
        }
        if usize::from(config.stuck_after) >= MAX_DELAY {
            return Err(PipelineError::StuckAfter);
        }
        // The rails in units of y: what a full-scale code converts to.
        let rails = [
            conv.y_from_code(ADC_CODE_MIN).to_f64(),
            conv.y_from_code(ADC_CODE_MAX).to_f64(),
        ];
        let ts_s = 1.0 / excitation.generator().sample_rate_hz();
        let guard = SensorGuard::new(&GuardConfig {
            ts_s,
            range: Some([rails[0].min(rails[1]), rails[0].max(rails[1])]),
            stuck_after: config.stuck_after,
            highpass_rad_s: None,
            offset_steps: false,
        })
        .map_err(|_| PipelineError::StuckAfter)?;
        Ok(Self {
            estimator,
            adc,
            dac,
            telemetry,
            raw,
            excitation,
            conv,
            prefilter,
            lines: None,
            pf_u: PrefilterState::default(),
            pf_y: PrefilterState::default(),
            input: config.input,
            latch: config.dac_latch,
            dac_per_actuator: T::from_f64(1.0 / g),
            actuator_per_dac: T::from_f64(g),
            telemetry_every: config.telemetry_every,
            since_record: 0,
            raw_decimation: config.raw_decimation,
            raw_phase: 0,
            raw_block: empty_block(0, config.raw_decimation),
            guard,
            ts_s,
            changes_seen: 0,
            changes_held: 0,
            lambda_rad_s: config.lambda_rad_s,
            next_index: 0,
            frozen: false,
            pending: None,
            prev_y: None,
            last_good: (T::ZERO, T::ZERO),
            counters: Counters::default(),
            flags: StatusFlags::default(),
            steps: StepCounts::default(),
            last_fed: (T::ZERO, T::ZERO),
        })
    }

    /// One sample period's work (see the module doc). Never panics, never
    /// blocks beyond the converters' own transactions.
    pub fn tick(&mut self) -> Tick<T> {
        let index = self.next_index;
        self.next_index = self.next_index.wrapping_add(1);

        // 1. The conversion that just completed.
        let reading = self.adc.read();

        // 2. Next excitation value → DAC (actuator volts → DAC volts).
        let commanded_v = self.excitation.next_sample();
        let written = match self.dac.write_volts(commanded_v * self.dac_per_actuator) {
            Ok(out) => {
                if out.saturated {
                    bump(&mut self.counters.dac_saturated);
                }
                (out.held_v * self.actuator_per_dac, true)
            }
            Err(_) => {
                bump(&mut self.counters.dac_errors);
                (T::ZERO, false)
            }
        };
        // The u held from now until the next tick.
        let held_now = match self.latch {
            DacLatch::Immediate => Some(written),
            DacLatch::NextTick => self.pending.replace(written),
        };

        // 3.–4. Screen the converter's report and convert.
        // A new conversion unless the converter said there was none (a
        // frame that failed its CRC or on the bus still had one behind it).
        let fresh = !matches!(&reading, Ok(r) if r.flags.stale);
        let (y, y_ok, u_mon, mon_ok) = self.screen(reading);
        let nan = T::from_f64(f64::NAN);
        let held_v = match held_now {
            Some((u, true)) => u,
            _ => nan,
        };
        let read = TickReading {
            fresh,
            y: if y_ok { y } else { nan },
            monitor_v: if mon_ok { u_mon } else { nan },
        };

        // 5. The pair for step(u held over the coming period, y now).
        // A u that is not known (the DAC write failed, the monitor
        // saturated) travels as NaN, so that a sample rejected for its y
        // alone still carries its true u (below).
        let known = |u: T, u_ok: bool| if u_ok { u } else { nan };
        let pair = match self.input {
            InputSource::Commanded => held_now.map(|(u, u_ok)| (known(u, u_ok), y, u_ok && y_ok)),
            InputSource::Monitored => self
                .prev_y
                .replace((y, y_ok))
                .map(|(py, py_ok)| (known(u_mon, mon_ok), py, mon_ok && py_ok)),
        };
        let Some((u, y, ok)) = pair else {
            // Start-up: nothing held yet to pair with.
            return idle(index, commanded_v, held_v, read);
        };
        // The float-level checks (rails, stuck runs through the delay
        // line, so a run is rejected from its first sample) and the level
        // corrections, one implementation with the host tools
        // ([`crate::guard`]).
        // A beam left without drive settles: its repeated readings are no
        // stuck sensor ([`SensorGuard::set_input_quiet`]).
        self.guard.set_input_quiet(
            self.excitation.kind() == WaveformKind::Off || self.excitation.amplitude() == T::ZERO,
        );
        let out = self.guard.push_at(u, y, ok, index);
        if self.guard.last_screening().level.is_some() {
            self.flags = self.flags.with(StatusFlags::SENSOR_LEVEL);
        }
        // After a gap with the high-pass on, hold while its memory settles
        // (the estimate before the fault is kept).
        let hold = self.guard.take_hold();
        if hold > 0 {
            self.estimator.hold(hold);
        }
        let Some(g) = out else {
            return idle(index, commanded_v, held_v, read);
        };
        let (u, y, ok, fed_index) = (g.u, g.y, g.fault.is_none(), g.index);

        // 6. Line remover and prefilter (fed the last good values across
        // a bad sample; a known u is fed as it is).
        let (u_in, y_in) = if ok {
            self.last_good = (u, y);
            (u, y)
        } else if u.is_finite() {
            (u, self.last_good.1)
        } else {
            self.last_good
        };
        let (u_in, y_in) = match self.lines.as_mut() {
            Some(c) => c.push(u_in, y_in),
            None => (u_in, y_in),
        };
        let (u_f, y_f) = match &self.prefilter {
            Some(p) => (
                p.process(&mut self.pf_u, u_in),
                p.process(&mut self.pf_y, y_in),
            ),
            None => (u_in, y_in),
        };

        // 7. Estimator: a rejected sample as y = NaN, with its u when that
        // is known (an estimator that simulates its model, the robust one,
        // needs the input the beam saw; the others ignore it).
        if !ok {
            bump(&mut self.counters.rejected);
        }
        let step = if self.frozen {
            None
        } else {
            let s = if ok {
                self.estimator.step(u_f, y_f)
            } else if u.is_finite() {
                self.estimator.step(u_f, nan)
            } else {
                self.estimator.step(nan, nan)
            };
            self.steps.count(s);
            self.hold_after_change();
            Some(s)
        };
        let fed = if ok { (u, y) } else { (nan, nan) };
        self.last_fed = fed;

        // 8. Raw block and telemetry record.
        self.record_raw(fed_index, fed);
        self.since_record += 1;
        if self.since_record >= self.telemetry_every {
            self.since_record = 0;
            self.emit_record(fed_index);
        }
        Tick {
            sample_index: index,
            commanded_v,
            fed: Some(fed),
            step,
            held_v,
            reading: read,
        }
    }

    /// Classify the converter's report and convert: (y, y valid, u_mon,
    /// u_mon valid). Converter errors and the driver's stale/stuck flags
    /// are judged here; the readings themselves (rails, stuck runs) by the
    /// guard.
    fn screen(&mut self, reading: Result<AdcReading, A::Error>) -> (T, bool, T, bool) {
        let r = match reading {
            Ok(r) if !r.flags.stale && !r.flags.stuck => r,
            Ok(r) => {
                bump(if r.flags.stuck {
                    &mut self.counters.stuck
                } else {
                    &mut self.counters.adc_other
                });
                return (T::ZERO, false, T::ZERO, false);
            }
            Err(e) => {
                let c = &mut self.counters;
                bump(match e.kind() {
                    FaultKind::Crc => &mut c.adc_crc,
                    FaultKind::Status => &mut c.adc_status,
                    FaultKind::Bus => &mut c.adc_bus,
                    FaultKind::Other => &mut c.adc_other,
                });
                return (T::ZERO, false, T::ZERO, false);
            }
        };
        // A rail code converts to a rail of the guard's range, where the
        // guard tells an overload from an open gauge; a conversion the
        // driver flags saturated (its frame says so) is taken as such.
        if r.flags.bridge_saturated {
            bump(&mut self.counters.bridge_saturated);
        }
        let y = self.conv.y_from_code(r.bridge);
        let at_rail = |c: i32| c >= ADC_CODE_MAX || c <= ADC_CODE_MIN;
        let u_mon = self.conv.u_from_monitor(r.monitor);
        let mon_ok = !(r.flags.monitor_saturated || at_rail(r.monitor));
        if !mon_ok {
            bump(&mut self.counters.monitor_saturated);
        }
        (y, !r.flags.bridge_saturated, u_mon, mon_ok)
    }

    fn record_raw(&mut self, index: u64, fed: (T, T)) {
        if self.raw_decimation == 0 {
            return;
        }
        if self.raw_phase > 0 {
            self.raw_phase -= 1;
            return;
        }
        self.raw_phase = self.raw_decimation - 1;
        let b = &mut self.raw_block;
        if b.len == 0 {
            b.first_index = index;
        }
        let i = usize::from(b.len);
        if let (Some(u), Some(y)) = (b.u_v.get_mut(i), b.y.get_mut(i)) {
            *u = fed.0;
            *y = fed.1;
            b.len += 1;
        }
        if usize::from(b.len) >= RAW_BLOCK_LEN {
            self.flush_raw();
        }
    }

    fn flush_raw(&mut self) {
        if self.raw_block.len == 0 {
            return;
        }
        let block = self.raw_block;
        self.raw_block = empty_block(0, self.raw_decimation);
        if self.raw.try_push(block).is_err() {
            bump(&mut self.counters.dropped_raw_blocks);
        }
    }

    fn emit_record(&mut self, index: u64) {
        let mut flags = self.flags;
        let sup = self.estimator.supervision();
        let input_gone = sup.is_some_and(|s| s.reason == ExcitationReason::InputGone);
        flags.set(StatusFlags::FROZEN_BY_COMMAND, self.frozen);
        // `self.flags` may carry FROZEN_AUTO and CHANGE_DETECTED from a
        // dropped record: kept, not cleared.
        let held = self.steps.frozen > 0;
        flags.set(
            StatusFlags::FROZEN_AUTO,
            flags.contains(StatusFlags::FROZEN_AUTO) || held || input_gone,
        );
        flags.set(
            StatusFlags::STATE_DEGRADED,
            !self.estimator.health().state_ok,
        );
        if let Some(sup) = sup {
            flags.set(StatusFlags::EXCITED, sup.reason.is_excited());
            flags.set(StatusFlags::INPUT_GONE, input_gone);
            flags.set(
                StatusFlags::CHANGE_DETECTED,
                flags.contains(StatusFlags::CHANGE_DETECTED) || sup.changes != self.changes_seen,
            );
            self.changes_seen = sup.changes;
        }
        let record = TelemetryRecord {
            sample_index: index,
            lambda_rad_s: self.lambda_rad_s,
            u_v: self.last_fed.0,
            y: self.last_fed.1,
            flags,
            supervised: sup.is_some(),
            lemma1_ratio: sup.and_then(|s| s.lemma1_ratio),
            steps: self.steps,
            counters: self.counters(),
            ..TelemetryRecord::from_estimator(&self.estimator)
        };
        if self.telemetry.try_push(record).is_ok() {
            self.flags = StatusFlags::default();
        } else {
            bump(&mut self.counters.dropped_records);
            // Keep this block's events for the next record that gets
            // through: a hold since the previous record, a detected change
            // (its count is already taken), a level correction.
            self.flags = self.flags.with(StatusFlags::TELEMETRY_DROPPED);
            if held {
                self.flags = self.flags.with(StatusFlags::FROZEN_AUTO);
            }
            if flags.contains(StatusFlags::CHANGE_DETECTED) {
                self.flags = self.flags.with(StatusFlags::CHANGE_DETECTED);
            }
        }
        self.steps = StepCounts::default();
    }

    // ----- Between samples (low-priority task, sample interrupt masked) -----

    /// A late interrupt: `missed_ticks` conversions were lost. Counted; the
    /// sample index skips them, and if any were lost the law is held for the
    /// settling time (its filters did not see those samples; see
    /// *Deliberate holds*).
    pub fn note_overrun(&mut self, missed_ticks: u32) {
        bump(&mut self.counters.overruns);
        self.counters.missed_ticks = self.counters.missed_ticks.saturating_add(missed_ticks);
        self.next_index = self.next_index.wrapping_add(u64::from(missed_ticks));
        if missed_ticks > 0 {
            self.settle();
        }
    }

    /// Hold the law until the filters have settled on real samples.
    fn settle(&mut self) {
        let n = self.estimator.settling_samples();
        self.estimator.hold(n);
    }

    /// Stop adapting: the estimator is no longer stepped (Θ̂ and P hold);
    /// the excitation, DAC and telemetry keep running.
    pub fn freeze(&mut self) {
        self.frozen = true;
    }

    /// Adapt again, holding the law for the settling time first (the
    /// filters missed the frozen interval).
    pub fn resume(&mut self) {
        if self.frozen {
            self.frozen = false;
            self.settle();
        }
    }

    /// Whether adaptation is frozen.
    pub fn is_frozen(&self) -> bool {
        self.frozen
    }

    /// Estimator and prefilter back to their initial state; the next tick
    /// starts a new time series (counters and excitation are kept), with the
    /// law held for the settling time (the beam may be moving).
    pub fn reset_estimator(&mut self) {
        self.estimator.reset();
        self.restart_series();
    }

    /// Swap in a new estimator (built outside the lock), with its λ; the
    /// old one is returned. Starts a new time series with the new law held
    /// for its settling time (its filters start at rest, the beam may be
    /// moving).
    pub fn replace_estimator(&mut self, estimator: E, lambda_rad_s: f64) -> Result<E, E> {
        if !(lambda_rad_s > 0.0 && lambda_rad_s.is_finite()) {
            return Err(estimator);
        }
        self.lambda_rad_s = lambda_rad_s;
        let old = core::mem::replace(&mut self.estimator, estimator);
        self.restart_series();
        Ok(old)
    }

    /// [`Pipeline::replace_estimator`] for a new estimator built where the
    /// running one lies (a board with one slot for a large estimator):
    /// `rebuild` turns the running estimator into the new one, which then
    /// starts as a swapped-in one would (its λ, a new time series, the
    /// settling hold). With an invalid λ nothing happens (`false`).
    pub fn rebuild_estimator(&mut self, lambda_rad_s: f64, rebuild: impl FnOnce(&mut E)) -> bool {
        if !(lambda_rad_s > 0.0 && lambda_rad_s.is_finite()) {
            return false;
        }
        self.lambda_rad_s = lambda_rad_s;
        rebuild(&mut self.estimator);
        self.restart_series();
        true
    }

    fn restart_series(&mut self) {
        self.pf_u = PrefilterState::default();
        self.pf_y = PrefilterState::default();
        self.prev_y = None;
        self.last_good = (T::ZERO, T::ZERO);
        self.guard.clear();
        self.changes_seen = 0;
        self.changes_held = 0;
        self.settle();
    }

    /// With the level corrections' high-pass on: when the estimator has
    /// just detected a plant change, hold it while the high-pass's memory
    /// of the old plant settles ([`SensorGuard::change_hold`]). Nothing
    /// to do (one compare) with the high-pass off, the firmware default.
    #[inline]
    fn hold_after_change(&mut self) {
        let hold = self.guard.change_hold();
        if hold == 0 {
            return;
        }
        if let Some(sup) = self.estimator.supervision() {
            // A new estimator (swapped in) counts from 0 again.
            if sup.changes > self.changes_held {
                self.estimator.hold(hold);
            }
            self.changes_held = sup.changes;
        }
    }

    /// The line remover (built outside the lock; `None`: off): from the
    /// next tick u and y pass it after the guard, its weights from zero,
    /// and the law is held for `hold` samples (with the estimator's
    /// settling time, the longer), while a line already in y decays in
    /// its output (`crate::link`'s rule: five time constants).
    pub fn set_line_removal(&mut self, lines: Option<LineCanceller<T, MAX_LINES>>, hold: u32) {
        self.lines = lines;
        let n = self.estimator.settling_samples().max(hold);
        self.estimator.hold(n);
    }

    /// The line remover's view of each line it removes: the amplitude in y
    /// its weights hold now, in the order of its lines (none when off).
    pub fn line_amplitudes(&self) -> impl Iterator<Item = T> + '_ {
        self.lines.iter().flat_map(|c| c.y_amplitudes())
    }

    /// Counters back to zero (the excitation's clamp counter is read
    /// through, not reset).
    pub fn reset_counters(&mut self) {
        self.counters = Counters::default();
        self.guard.reset_counts();
    }

    /// A telemetry record every `every` samples (≥ 1).
    pub fn set_telemetry_every(&mut self, every: u32) -> Result<(), PipelineError> {
        if every == 0 {
            return Err(PipelineError::TelemetryRate);
        }
        self.telemetry_every = every;
        self.since_record = self.since_record.min(every - 1);
        Ok(())
    }

    /// A raw pair every `decimation` samples (0 = off). A partly filled
    /// block is sent first.
    pub fn set_raw_decimation(&mut self, decimation: u16) {
        self.flush_raw();
        self.raw_decimation = decimation;
        self.raw_phase = 0;
        self.raw_block = empty_block(0, decimation);
    }

    /// The excitation (read).
    pub fn excitation(&self) -> &Excitation<T> {
        &self.excitation
    }

    /// The excitation, to change its level, frequency, window or waveform
    /// (each setter validates and changes nothing on error).
    pub fn excitation_mut(&mut self) -> &mut Excitation<T> {
        &mut self.excitation
    }

    /// The estimator (read).
    pub fn estimator(&self) -> &E {
        &self.estimator
    }

    /// The estimator, mutably (thread mode, inside the lock: e.g. to
    /// install a model update prepared off the sample path).
    pub fn estimator_mut(&mut self) -> &mut E {
        &mut self.estimator
    }

    /// The counters now.
    pub fn counters(&self) -> Counters {
        let g = self.guard.counts();
        let c = &self.counters;
        Counters {
            excitation_clamped: self.excitation.clamped_samples(),
            bridge_saturated: c.bridge_saturated.saturating_add(g.saturated),
            // A non-finite conversion (never expected from finite codes).
            adc_other: c.adc_other.saturating_add(g.non_finite),
            stuck: c.stuck.saturating_add(g.stuck),
            open: g.open,
            offset_steps: g.offset,
            drift: g.drift,
            ..self.counters
        }
    }

    /// The sensor guard's level corrections (off by default): the
    /// DC-removing high-pass on u and y (corner in rad/s) and the removal
    /// of offset steps of y ([`crate::guard`]). Applied between samples;
    /// a new corner restarts the high-pass.
    ///
    /// # Errors
    /// An invalid corner (nothing changed).
    pub fn set_level_correction(
        &mut self,
        highpass_rad_s: Option<f64>,
        offset_steps: bool,
    ) -> Result<(), GuardError> {
        self.guard
            .set_level_correction(highpass_rad_s, offset_steps, self.ts_s)
    }

    /// Index the next tick will carry.
    pub fn next_sample_index(&self) -> u64 {
        self.next_index
    }

    /// The converters, e.g. to reconfigure them between samples.
    pub fn converters_mut(&mut self) -> (&mut A, &mut D) {
        (&mut self.adc, &mut self.dac)
    }

    /// Take the pipeline apart.
    pub fn into_parts(self) -> (E, A, D, S, R) {
        (self.estimator, self.adc, self.dac, self.telemetry, self.raw)
    }
}

/// A tick that fed nothing to the estimator.
fn idle<T>(index: u64, commanded_v: T, held_v: T, reading: TickReading<T>) -> Tick<T> {
    Tick {
        sample_index: index,
        commanded_v,
        fed: None,
        step: None,
        held_v,
        reading,
    }
}

fn empty_block<T: Real>(first_index: u64, decimation: u16) -> RawBlock<T> {
    RawBlock {
        first_index,
        decimation,
        len: 0,
        u_v: [T::ZERO; RAW_BLOCK_LEN],
        y: [T::ZERO; RAW_BLOCK_LEN],
    }
}

#[cfg(test)]
#[allow(
    clippy::unwrap_used,
    clippy::indexing_slicing,
    clippy::panic,
    clippy::expect_used
)]
mod tests;
