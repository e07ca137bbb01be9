//! The device end of the serial link (`docs/PROTOCOL.md`), hardware-free:
//! telemetry records and raw blocks from the sample task become frames in
//! a bounded TX byte ring; command frames from an RX byte stream are
//! validated, applied to the pipeline between samples and acknowledged.
//! Every board uses it the same way ([`DeviceLink`], the QEMU image and the NUCLEO-H743ZI2);
//! the board supplies the byte rings ([`TxSink`], any byte iterator) and
//! the lock and estimator storage ([`Device`]).
//!
//! * `tx`: whole frames or nothing into the TX ring, exact drop counts;
//! * [`estimate`]: record → [`Estimate`](beam_protocol::Estimate) with its
//!   flags, counters → [`DeviceCounters`](beam_protocol::DeviceCounters);
//! * `raw`: raw blocks → 64-pair frames;
//! * `control`: what a command changes and how it is prepared.
//!
//! # Where it runs
//! In the low-priority context (thread mode on the QEMU board), never in the
//! sample interrupt: [`DeviceLink::on_record`] (recovery, estimate and
//! periodic status), [`DeviceLink::on_raw`], [`DeviceLink::receive`]
//! (commands). The sample interrupt only pushes records and raw blocks into
//! its bounded queues (`pipeline`); the TX ring is drained by the UART's
//! interrupt or DMA. Nothing here blocks: a frame that does not fit is
//! dropped and counted, and shows as a sequence gap at the host.
//!
//! # Timing
//! * Estimates: one per telemetry record, at the estimate rate
//!   (round(f_s/rate) samples apart), from the record at which the
//!   first estimator was swapped in ([`DeviceLink::poll`]) on; none while
//!   the start-up window measures U0, Y0 and λ0.
//! * Status: at the status rate on the record clock (the pipeline's record
//!   interval is the shorter of the two streams' intervals,
//!   [`DeviceLink::record_every`]), the first with the first record; and
//!   right after the Ack of a `RequestStatus`, with the counters read
//!   then.
//! * Commands: applied when [`DeviceLink::receive`] decodes them, between
//!   two samples (inside [`Device::with_pipeline`]), effective from the next
//!   sample; the Ack follows the change, so every frame after the Ack was
//!   produced under the new settings, except estimates and raw samples
//!   already waiting in the sample task's queues (at most their depth).
//!
//! # λ = None: the automatic rule
//! The estimator's settings come from the truth-free rule of
//! [`crate::tuning`] (docs/SETTINGS.md), run by [`tune::Tuner`]: U0, Y0 are
//! the RMS of u and y over the start-up window (fed by the board with
//! [`DeviceLink::on_startup_block`]), λ0 comes from the data (or a band the
//! board knows), and while `lambda_rad_s` is `None` (the default) λ is
//! re-centred on the estimated band with the estimate carried over. Every
//! build happens in [`DeviceLink::poll`] (low-priority context, outside the
//! lock) and is swapped in between two samples.
//!
//! * `SetEstimator` with `lambda_rad_s = Some(λ)`: that λ, fixed (the rule
//!   stops re-centring), the start-up window's scales.
//! * `SetEstimator` with `lambda_rad_s = None`: the new gains at the λ in
//!   use, and the rule reviews the new estimate again (it re-centres if the
//!   band moved).
//! * Before the window closes a `SetEstimator` is checked (a trial build)
//!   and remembered; the first build uses it.
//!
//! Status reports the λ in use (none before the first build under the
//! automatic rule).
#![deny(
    clippy::indexing_slicing,
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::panic,
    clippy::unreachable,
    clippy::todo
)]

pub(crate) mod control;
pub(crate) mod estimate;
pub(crate) mod raw;
pub(crate) mod robust_updates;
pub(crate) mod tune;
pub(crate) mod tx;

pub use control::{
    estimator_configs, rebuild_robust, reject_config, robust_configs, robust_head, with_theta0,
    Control, Device, ExcitationPlan,
};
pub use estimate::{estimate, Convergence, EstimateContext, FlagRules};
pub(crate) use raw::RawAssembler;
pub use robust_updates::{LockSpans, RobustAccess, RobustUpdates, UPDATE_EVERY};
pub use tune::{BuildKind, Pending, StartupCollector, Tuner};
pub use tx::{Sent, Transmitter, TxSink, TxStats};

use crate::filter_bank::{FilterConfig, SignalScales};
use crate::pipeline::{recover, Counters, RawBlock, Recovered, TelemetryRecord};
use crate::scalar::Real;
use crate::selftest::{Next, Phase, SelfTestBlock, SelfTestConfig, SelfTestRun, QUIET};
use crate::tuning::{TuningConfig, TuningError};
use beam_protocol::budget::MAX_COMMAND_ENCODED_LEN;
use beam_protocol::{
    Ack, AckResult, Command, Decoder, EstimatorSettings, FirmwareVersion, Limits, LinkCounters,
    Message, RejectReason, SelfTestReport, SelfTestState, Status, StatusFlags, TelemetryRates,
};

/// This crate's version, for [`Status::firmware`].
pub const FIRMWARE_VERSION: FirmwareVersion = FirmwareVersion {
    major: parse_u8(env!("CARGO_PKG_VERSION_MAJOR")),
    minor: parse_u8(env!("CARGO_PKG_VERSION_MINOR")),
    patch: parse_u8(env!("CARGO_PKG_VERSION_PATCH")),
};

/// A decimal version component (255 if longer or not a number).
const fn parse_u8(s: &str) -> u8 {
    let mut b = s.as_bytes();
    let mut v: u32 = 0;
    while let [d, rest @ ..] = b {
        if !d.is_ascii_digit() || v > 25 {
            return u8::MAX;
        }
        v = v * 10 + (*d - b'0') as u32;
        b = rest;
    }
    if v > 255 {
        u8::MAX
    } else {
        v as u8
    }
}

/// Bytes kept free in the TX ring for acknowledgements: two Ack frames at
/// their longest (20 bytes each, whatever the command's sequence number;
/// `docs/PROTOCOL.md` §9.1). Telemetry frames that would eat into it are
/// dropped instead.
pub const ANSWER_RESERVE_BYTES: usize = 2 * beam_protocol::budget::MAX_ACK_ENCODED_LEN;

/// The device's fixed properties.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LinkConfig {
    /// What commands are checked against (sample rate, piezo window,
    /// generators, estimators, mode count, link budget at the baud rate).
    pub limits: Limits,
    /// Reported in Status.
    pub firmware: FirmwareVersion,
    /// Thresholds of the EXCITED and CONVERGED flags.
    pub rules: FlagRules,
    /// What the self-test expects of this board.
    pub self_test: SelfTestConfig,
}

/// The settings in force, as the protocol states them.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Settings {
    /// The excitation.
    pub excitation: beam_protocol::Excitation,
    /// The estimator settings as commanded (`lambda_rad_s = None`: the
    /// automatic rule; see the module doc).
    pub estimator: EstimatorSettings,
    /// The telemetry rates.
    pub telemetry: TelemetryRates,
}

/// Samples between two events at `rate_hz` (round(f_s/rate), at least 1);
/// `None` when the rate is 0 (off) or not positive.
pub(crate) fn interval_samples(rate_hz: f32, sample_rate_hz: f32) -> Option<u32> {
    if !(rate_hz > 0.0) {
        return None;
    }
    let n = libm::roundf(sample_rate_hz / rate_hz);
    Some(if n >= 4_294_967_040.0 {
        u32::MAX
    } else if n >= 1.0 {
        n as u32
    } else {
        1
    })
}

/// The pipeline's record interval for `rates`: the shorter of the estimate
/// and status intervals (records are the link's clock); f_s/100 (the
/// default estimate rate, 100 Hz) when both are off.
pub(crate) fn record_interval(rates: &TelemetryRates, sample_rate_hz: f32) -> u32 {
    let e = interval_samples(rates.estimate_rate_hz, sample_rate_hz);
    let s = interval_samples(rates.status_rate_hz, sample_rate_hz);
    match (e, s) {
        (Some(a), Some(b)) => a.min(b),
        (Some(a), None) | (None, Some(a)) => a,
        (None, None) => interval_samples(100.0, sample_rate_hz).unwrap_or(1),
    }
}

/// Next due index after `due`, every `every` samples, at least past `now`.
fn next_due(due: u64, every: u32, now: u64) -> u64 {
    let next = due.saturating_add(u64::from(every));
    if next > now {
        next
    } else {
        now.saturating_add(u64::from(every))
    }
}

/// An estimator [`DeviceLink::poll`] swapped in.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Tuned {
    /// Why it was built.
    pub kind: BuildKind,
    /// Its filter bank.
    pub filter: FilterConfig,
    /// The first sample it runs on.
    pub at: u64,
}

/// The device end of the link (see the module doc).
#[derive(Debug, Clone)]
pub struct DeviceLink {
    config: LinkConfig,
    settings: Settings,
    /// The running estimator's filter bank (λ, U0, Y0), once built.
    filter: Option<FilterConfig>,
    tuner: Tuner,
    tx: Transmitter,
    rx: Decoder<MAX_COMMAND_ENCODED_LEN>,
    accepted: u32,
    rejected: u32,
    frozen_by_command: bool,
    /// The line remover as last commanded (off at boot).
    line_removal: beam_protocol::LineRemoval,
    started_at: Option<u64>,
    /// The first sample of an estimator (re)start whose law has not
    /// updated yet (see `EstimateContext::no_update_yet`).
    fresh_since: Option<u64>,
    /// Sample index of the previous record.
    last_record: Option<u64>,
    /// Counters of the record of the last estimate queued for the wire:
    /// the flags' "since the previous estimate" baseline.
    at_last_estimate: Counters,
    /// [`estimate::SINCE_PREVIOUS_RECORD`] bits of the records since the
    /// last estimate queued (records without an estimate, or whose
    /// estimate was dropped), for the next estimate.
    events_since_estimate: StatusFlags,
    convergence: Convergence,
    raw: RawAssembler,
    next_estimate_at: u64,
    next_status_at: u64,
    /// TX frames dropped when the last estimate got through.
    drops_at_last_estimate: u32,
    /// The self-test running, if one is.
    self_test: Option<SelfTestRun>,
    /// Adaptation resumes when the self-test ends (it was not frozen
    /// when the test started).
    resume_after_test: bool,
    /// The self-test as Status reports it.
    self_test_state: SelfTestState,
    /// The first and last samples of the latest self-test that ended.
    last_test_span: Option<(u64, u64)>,
}

impl DeviceLink {
    /// The link for a pipeline built with `settings` (its record interval
    /// must be `record_interval` of the rates, its raw decimation
    /// theirs), frozen until the first estimator is built. `tuning` is the
    /// board's rule: its sample period, output hold and converter timing
    /// go into every estimator; its λ source (`Data`, or a `Band` the board
    /// knows) is the automatic λ0. `settings.estimator.lambda_rad_s` =
    /// `None` runs the automatic rule, `Some(λ)` fixes λ.
    pub fn new(
        config: LinkConfig,
        settings: Settings,
        tuning: &TuningConfig,
    ) -> Result<Self, TuningError> {
        // The settings name the sensor's output kind; the rule's filters
        // carry it.
        let tuning = TuningConfig {
            output: settings.estimator.output,
            ..*tuning
        };
        Ok(Self {
            config,
            settings,
            filter: None,
            tuner: Tuner::new(&tuning)?,
            tx: Transmitter::new(),
            rx: Decoder::new(),
            accepted: 0,
            rejected: 0,
            frozen_by_command: false,
            line_removal: beam_protocol::LineRemoval::OFF,
            started_at: None,
            fresh_since: None,
            last_record: None,
            at_last_estimate: Counters::default(),
            events_since_estimate: StatusFlags::default(),
            convergence: Convergence::default(),
            raw: RawAssembler::default(),
            next_estimate_at: 0,
            next_status_at: 0,
            drops_at_last_estimate: 0,
            self_test: None,
            resume_after_test: false,
            self_test_state: SelfTestState::NotRun,
            last_test_span: None,
        })
    }

    /// The settings in force.
    pub fn settings(&self) -> &Settings {
        &self.settings
    }

    /// The filter pole in use (rad/s): the running estimator's, else the
    /// commanded one (`None` before the first build under the automatic
    /// rule).
    pub fn lambda_rad_s(&self) -> Option<f64> {
        self.filter
            .map(|f| f.lambda_rad_s)
            .or(self.settings.estimator.lambda_rad_s.map(f64::from))
    }

    /// The running estimator's filter bank (λ, U0, Y0), once built.
    pub fn filter(&self) -> Option<&FilterConfig> {
        self.filter.as_ref()
    }

    /// The tuning rule (its phase, re-centrings, start-up statistics).
    pub fn tuner(&self) -> &Tuner {
        &self.tuner
    }

    /// λ is chosen by the automatic rule (`lambda_rad_s = None`).
    pub fn is_automatic(&self) -> bool {
        self.settings.estimator.lambda_rad_s.is_none()
    }

    /// The sample task should hand start-up pairs over: the tuning rule's
    /// window is open and no self-test runs (at start-up the self-test
    /// comes first, so the window sees the default excitation alone).
    pub fn collecting_startup(&self) -> bool {
        self.tuner.collecting() && self.self_test.is_none()
    }

    /// One block of start-up pairs from the sample task (see `tune`).
    /// Returns true when it closed the window: the first estimator is then
    /// built by the next [`DeviceLink::poll`].
    pub fn on_startup_block<T: Real>(&mut self, block: &RawBlock<T>) -> bool {
        self.tuner.startup_block(block)
    }

    /// The fixed properties.
    pub fn config(&self) -> &LinkConfig {
        &self.config
    }

    /// The record interval the pipeline must run at for the current rates.
    pub fn record_every(&self) -> u32 {
        record_interval(&self.settings.telemetry, self.config.limits.sample_rate_hz)
    }

    /// Sample index at which the estimator was started, if it was.
    pub fn started_at(&self) -> Option<u64> {
        self.started_at
    }

    /// The estimator's law has updated since it (re)started: its Θ̂ is an
    /// estimate, and Estimates carry modes (PROTOCOL.md §9.3).
    pub fn has_estimate(&self) -> bool {
        self.started_at.is_some() && self.fresh_since.is_none()
    }

    /// The sending side's counters.
    pub fn tx_stats(&self) -> &TxStats {
        self.tx.stats()
    }

    /// The command decoder's counters (bytes, frames, errors).
    pub fn rx_counters(&self) -> &LinkCounters {
        self.rx.counters()
    }

    /// Commands accepted and rejected.
    pub fn commands(&self) -> (u32, u32) {
        (self.accepted, self.rejected)
    }

    /// Build what the tuning rule asked for, if anything (low-priority
    /// context): the first estimator after the start-up window (swapped in,
    /// adaptation resumed unless a `Freeze` came first) or a re-centred one
    /// with the estimate carried over. The build runs outside the lock,
    /// the swap inside it. Returns what was swapped in and from which
    /// sample. A failed first build is an error (nothing runs); a failed
    /// re-centring keeps the running estimator and stops the rule.
    pub fn poll<D: Device>(&mut self, dev: &mut D) -> Result<Option<Tuned>, RejectReason> {
        // Nothing is swapped in while the self-test owns the drive: the
        // build waits for its end.
        if self.self_test.is_some() {
            return Ok(None);
        }
        let Some(p) = self.tuner.take_pending() else {
            return Ok(None);
        };
        let mut filter = p.filter;
        if p.kind == BuildKind::First {
            if let Some(l) = self.settings.estimator.lambda_rad_s {
                filter.lambda_rad_s = f64::from(l);
            }
        }
        let est = match dev.build_estimator(&self.settings.estimator, &filter, p.theta0()) {
            Ok(e) => e,
            Err(e) => {
                self.tuner.stop();
                return match p.kind {
                    BuildKind::First => Err(e),
                    BuildKind::Recentre => Ok(None),
                };
            }
        };
        let resume = p.kind == BuildKind::First && !self.frozen_by_command;
        let (swap, at) = dev.swap_estimator(est, filter.lambda_rad_s, resume);
        match swap {
            Ok(old) => dev.recycle_estimator(old),
            Err(refused) => {
                dev.recycle_estimator(refused);
                self.tuner.stop();
                return match p.kind {
                    BuildKind::First => Err(RejectReason::Lambda),
                    BuildKind::Recentre => Ok(None),
                };
            }
        }
        self.filter = Some(filter);
        self.tuner.swapped_in(at);
        match p.kind {
            BuildKind::First => {
                self.started_at = Some(at);
                self.restarted(at);
            }
            // Θ̂ carried over is an estimate: modes stay on the wire. Without
            // a carry-over the law starts from zero.
            BuildKind::Recentre if p.theta0_len == 0 => self.restarted(at),
            BuildKind::Recentre => {}
        }
        Ok(Some(Tuned {
            kind: p.kind,
            filter,
            at,
        }))
    }

    /// The estimator (re)started at sample `at`: no modes until its law has
    /// updated, a new CONVERGED window.
    fn restarted(&mut self, at: u64) {
        self.fresh_since = Some(at);
        self.convergence.reset();
    }

    /// One telemetry record from the sample task: recovers it (eqs. 30–32,
    /// Lemma 1) and sends an [`Estimate`](beam_protocol::Estimate) if one
    /// is due, and a Status if one is due. Returns the recovery when it
    /// was made (for the board's own log).
    pub fn on_record<T: Real, const NP: usize, const NS: usize>(
        &mut self,
        record: &TelemetryRecord<T, NP, NS>,
        output_weight: &[T],
        tx: &mut impl TxSink,
    ) -> Option<Recovered<T>> {
        let index = record.sample_index;
        let fs = self.config.limits.sample_rate_hz;
        // The record's step counts cover the samples after the previous
        // record: once those all follow the restart, an update is the new
        // law's.
        if let Some(since) = self.fresh_since {
            let after = self
                .last_record
                .is_some_and(|p| p.saturating_add(1) >= since);
            if after && record.steps.updated > 0 {
                self.fresh_since = None;
            }
        }
        self.last_record = Some(index);
        if self.is_automatic() && !self.frozen_by_command && self.self_test.is_none() {
            self.tuner
                .on_record(index, &record.theta, record.lambda_rad_s);
        } else {
            // Not reviewing: these samples do not count towards its
            // settling, stability window or timeout.
            self.tuner.skip_to(index);
        }
        let running = self.started_at.is_some_and(|s| index >= s);
        let due = interval_samples(self.settings.telemetry.estimate_rate_hz, fs)
            .filter(|_| running && index >= self.next_estimate_at);
        let recovered = due.map(|every| {
            self.next_estimate_at = next_due(self.next_estimate_at, every, index);
            let rec = recover(record, output_weight);
            self.send_estimate(record, &rec, tx);
            rec
        });
        if recovered.is_none() {
            self.note_events(record.flags);
        }
        if let Some(every) = interval_samples(self.settings.telemetry.status_rate_hz, fs) {
            if index >= self.next_status_at {
                self.next_status_at = next_due(self.next_status_at, every, index);
                let status = self.status(index.saturating_add(1), &record.counters);
                self.tx.send(&status.into(), ANSWER_RESERVE_BYTES, tx);
            }
        }
        recovered
    }

    fn send_estimate<T: Real, const NP: usize, const NS: usize>(
        &mut self,
        record: &TelemetryRecord<T, NP, NS>,
        rec: &Recovered<T>,
        tx: &mut impl TxSink,
    ) {
        let dropped = self.tx.stats().frames_dropped;
        let ctx = EstimateContext {
            estimator: self.settings.estimator.kind,
            model_modes: usize::from(self.config.limits.modes),
            rules: &self.config.rules,
            previous: &self.at_last_estimate,
            earlier_events: self.events_since_estimate,
            dropped_elsewhere: dropped != self.drops_at_last_estimate,
            no_update_yet: self.fresh_since.is_some(),
        };
        let mut msg = estimate::estimate(record, rec, &ctx, &mut self.convergence);
        if self.in_self_test(record.sample_index) {
            msg.flags = msg.flags.with(StatusFlags::SELF_TEST);
        }
        // A dropped estimate is flagged by the next one that gets through.
        if let Sent::Queued(_) = self.tx.send(&msg.into(), ANSWER_RESERVE_BYTES, tx) {
            self.drops_at_last_estimate = dropped;
            self.at_last_estimate = record.counters;
            self.events_since_estimate = StatusFlags::default();
        } else {
            // Its events and counter steps go with the next estimate.
            self.note_events(record.flags);
        }
    }

    /// Keep a record's event bits for the next estimate: its own estimate
    /// was not made or did not get through.
    fn note_events(&mut self, record_flags: StatusFlags) {
        self.events_since_estimate = self.events_since_estimate.with(StatusFlags(
            record_flags.0 & estimate::SINCE_PREVIOUS_RECORD.0,
        ));
    }

    /// One raw block from the sample task: sent in frames of up to 64 pairs
    /// (`raw`).
    pub fn on_raw<T: Real>(&mut self, block: &RawBlock<T>, tx: &mut impl TxSink) {
        let sender = &mut self.tx;
        self.raw.push(block, |frame| {
            sender.send(&Message::RawSamples(frame), ANSWER_RESERVE_BYTES, tx);
        });
    }

    /// Feed received bytes: every complete command frame is validated,
    /// applied and answered (see `DeviceLink::execute`). Frames that fail
    /// to decode are counted (Status `rx_frame_errors`) and not answered.
    pub fn receive<D: Device>(
        &mut self,
        bytes: impl IntoIterator<Item = u8>,
        dev: &mut D,
        tx: &mut impl TxSink,
    ) {
        for b in bytes {
            // Frames of other kinds are refused as malformed (counted).
            if let Some(Ok((seq, c))) = self.rx.push_command(b) {
                self.answer(&c, seq, dev, tx);
            }
        }
    }

    fn answer<D: Device>(&mut self, c: &Command, seq: u32, dev: &mut D, tx: &mut impl TxSink) {
        let result = self.execute(c, dev);
        match result {
            Ok(()) => self.accepted = self.accepted.saturating_add(1),
            Err(_) => self.rejected = self.rejected.saturating_add(1),
        }
        let ack = Ack {
            command_seq: seq,
            result: AckResult::from(result),
        };
        self.tx.send(&ack.into(), 0, tx);
        if result.is_ok() && *c == Command::RequestStatus {
            self.send_status_now(dev, tx);
        }
    }

    /// The line remover as last commanded ([`Command::SetLineRemoval`]).
    pub fn line_removal(&self) -> beam_protocol::LineRemoval {
        self.line_removal
    }

    /// Send a Status with the counters read now (inside the lock).
    pub(crate) fn send_status_now<D: Device>(&mut self, dev: &mut D, tx: &mut impl TxSink) {
        let (counters, uptime) = dev.with_pipeline(|p| (p.counters(), p.next_sample_index()));
        let status = self.status(uptime, &counters);
        self.tx.send(&status.into(), 0, tx);
    }

    /// The Status for `uptime_samples` and the pipeline's `counters`.
    pub fn status(&self, uptime_samples: u64, counters: &Counters) -> Status {
        let rx_errors = self.rx.counters().errors();
        Status {
            uptime_samples,
            sample_rate_hz: self.config.limits.sample_rate_hz,
            firmware: self.config.firmware,
            modes: self.config.limits.modes,
            counters: estimate::device_counters(
                counters,
                self.accepted,
                self.rejected,
                u32::try_from(rx_errors).unwrap_or(u32::MAX),
                self.tx.stats().frames_dropped,
            ),
            adaptation_frozen: self.frozen_by_command,
            excitation: self.settings.excitation,
            estimator: EstimatorSettings {
                lambda_rad_s: self.lambda_rad_s().map(|l| l as f32),
                ..self.settings.estimator
            },
            telemetry: self.settings.telemetry,
            lambda_automatic: self.is_automatic(),
            self_test: self.self_test_state,
        }
    }

    /// `SetEstimator` (see the module doc, "λ = None").
    fn set_estimator<D: Device>(
        &mut self,
        s: &EstimatorSettings,
        dev: &mut D,
    ) -> Result<(), RejectReason> {
        let Some(current) = self.filter else {
            // Before the first build: a trial build checks that the core
            // accepts it (unit scales; the window's replace them), at the
            // commanded λ or, automatic, at the middle (log scale) of the
            // range the rule picks from.
            let base = self.tuner.rule().config();
            let middle = libm::sqrt(crate::tuning::MIN_LAMBDA_TS * crate::tuning::MAX_LAMBDA_TS);
            let lambda = s.lambda_rad_s.map_or(middle / base.ts_s, f64::from);
            let trial = FilterConfig {
                ts_s: base.ts_s,
                lambda_rad_s: lambda,
                scales: SignalScales::default(),
                hold: base.hold,
                timing: base.timing,
                output: s.output,
            };
            let est = dev.build_estimator(s, &trial, &[])?;
            dev.recycle_estimator(est);
            self.settings.estimator = *s;
            self.tuner.set_output(s.output);
            return Ok(());
        };
        let filter = FilterConfig {
            lambda_rad_s: s.lambda_rad_s.map_or(current.lambda_rad_s, f64::from),
            output: s.output,
            ..current
        };
        let est = dev.build_estimator(s, &filter, &[])?;
        let (swap, at) = dev.swap_estimator(est, filter.lambda_rad_s, false);
        match swap {
            Ok(old) => dev.recycle_estimator(old),
            Err(refused) => {
                dev.recycle_estimator(refused);
                return Err(RejectReason::Lambda);
            }
        }
        self.restarted(at);
        self.filter = Some(filter);
        self.settings.estimator = *s;
        self.tuner.set_output(s.output);
        if s.lambda_rad_s.is_none() {
            self.tuner.rebuilt(filter, at);
        } else {
            self.tuner.cancel_pending();
            self.tuner.swapped_in(at);
        }
        Ok(())
    }

    /// Validate `c` against the limits and apply it; on `Err` nothing has
    /// changed. Expensive preparation (a multisine, a new estimator) runs
    /// here, outside the lock; the lock is held for the setters only.
    pub(crate) fn execute<D: Device>(
        &mut self,
        c: &Command,
        dev: &mut D,
    ) -> Result<(), RejectReason> {
        c.validate(&self.config.limits)?;
        if self.self_test.is_some() && *c != Command::RequestStatus {
            return Err(RejectReason::Busy);
        }
        let fs = self.config.limits.sample_rate_hz;
        match c {
            Command::SetExcitation(x) => {
                let plan =
                    ExcitationPlan::<D::Real>::new(x, &self.settings.excitation, f64::from(fs))?;
                dev.with_pipeline(|p| plan.apply(p.excitation_mut()))?;
                self.settings.excitation = *x;
            }
            Command::SetEstimator(s) => self.set_estimator(s, dev)?,
            Command::SetTelemetry(t) => {
                let every = record_interval(t, fs);
                dev.with_pipeline(|p| {
                    p.set_telemetry_every(every)?;
                    p.set_raw_decimation(t.raw_decimation);
                    Ok(())
                })
                .map_err(|_: crate::pipeline::PipelineError| RejectReason::Rate)?;
                self.settings.telemetry = *t;
                self.next_estimate_at = 0;
                self.next_status_at = 0;
            }
            Command::Reset => {
                if self.started_at.is_some() {
                    let at = dev.with_pipeline(|p| {
                        p.reset_estimator();
                        p.next_sample_index()
                    });
                    self.restarted(at);
                }
            }
            Command::Freeze => {
                self.frozen_by_command = true;
                dev.with_pipeline(|p| p.freeze());
            }
            Command::Resume => {
                self.frozen_by_command = false;
                if self.started_at.is_some() {
                    dev.with_pipeline(|p| p.resume());
                }
            }
            Command::RequestStatus => {}
            Command::SetLineRemoval(l) => {
                let canceller = control::line_canceller::<D::Real>(l, f64::from(fs))?;
                let hold = control::line_settling_samples(l, f64::from(fs));
                dev.with_pipeline(|p| p.set_line_removal(canceller, hold));
                self.line_removal = *l;
            }
            Command::SelfTest => {
                if self.started_at.is_none() {
                    return Err(RejectReason::Busy);
                }
                self.start_self_test(dev, false)?;
            }
        }
        Ok(())
    }

    // ----- The self-test (`crate::selftest`) -----

    /// A self-test is running: the board's sample interrupt copies its
    /// ticks ([`crate::selftest::Collector`]) and hands the blocks to
    /// [`DeviceLink::on_self_test_block`].
    pub fn self_test_running(&self) -> bool {
        self.self_test.is_some()
    }

    /// The self-test as Status reports it.
    pub fn self_test_state(&self) -> SelfTestState {
        self.self_test_state
    }

    /// Sample `index` lies in the running or the latest self-test.
    fn in_self_test(&self, index: u64) -> bool {
        let running = self
            .self_test
            .as_ref()
            .is_some_and(|r| index >= r.first_sample());
        let last = self
            .last_test_span
            .is_some_and(|(a, b)| (a..=b).contains(&index));
        running || last
    }

    /// Start the self-test (`at_boot`: the one at start-up, before the
    /// tuning rule's window; otherwise the `SelfTest` command): one lock
    /// freezes adaptation, reads the ADC's ID and configuration back and
    /// sets the drive to zero. `Busy` if one runs already.
    pub fn start_self_test<D: Device>(
        &mut self,
        dev: &mut D,
        at_boot: bool,
    ) -> Result<(), RejectReason> {
        if self.self_test.is_some() {
            return Err(RejectReason::Busy);
        }
        let fs = f64::from(self.config.limits.sample_rate_hz);
        let quiet = ExcitationPlan::<D::Real>::new(&QUIET, &self.settings.excitation, fs)?;
        dev.align_to_sample();
        let (was_frozen, read_back, applied, at) = dev.with_pipeline(|p| {
            let was_frozen = p.is_frozen();
            let applied = quiet.apply(p.excitation_mut());
            if applied.is_ok() {
                p.freeze();
            }
            (
                was_frozen,
                p.adc_read_back(),
                applied,
                p.next_sample_index(),
            )
        });
        applied?;
        self.resume_after_test = !was_frozen;
        self.self_test = Some(SelfTestRun::new(
            &self.config.self_test,
            at_boot,
            at,
            read_back,
        ));
        self.self_test_state = SelfTestState::Running;
        Ok(())
    }

    /// One block of the self-test's ticks from the sample interrupt: the
    /// next phase's drive is set when one ends; after the last the
    /// excitation in force is restored, adaptation resumed (unless it was
    /// frozen before), the [`SelfTestReport`] queued on `tx` and returned.
    pub fn on_self_test_block<D: Device>(
        &mut self,
        block: &SelfTestBlock<D::Real>,
        dev: &mut D,
        tx: &mut impl TxSink,
    ) -> Option<SelfTestReport> {
        let next = self.self_test.as_mut()?.push(block)?;
        let (phase, drive, from) = match next {
            Next::Begin(Phase::Tone) => (Phase::Tone, self.config.self_test.tone(), QUIET),
            Next::Begin(Phase::Signal) => (
                Phase::Signal,
                self.config.self_test.excitation,
                self.config.self_test.tone(),
            ),
            Next::Begin(Phase::Quiet) | Next::Finish => {
                let run = self.self_test.take()?;
                return Some(self.finish_self_test(run, dev, tx));
            }
        };
        let fs = f64::from(self.config.limits.sample_rate_hz);
        let applied = ExcitationPlan::<D::Real>::new(&drive, &from, fs).and_then(|plan| {
            dev.with_pipeline(|p| {
                plan.apply(p.excitation_mut())
                    .map(|()| p.next_sample_index())
            })
        });
        match applied {
            Ok(at) => {
                if let Some(run) = self.self_test.as_mut() {
                    run.begin(phase, at);
                }
                None
            }
            // The board's settings refuse the test's drive: end it with
            // what it has (the rest is reported not measured).
            Err(_) => {
                let run = self.self_test.take()?;
                Some(self.finish_self_test(run, dev, tx))
            }
        }
    }

    /// End the running self-test now with what it has measured (the board
    /// has seen no sample for long: DRDY stopped). `None` if none runs.
    pub fn abort_self_test<D: Device>(
        &mut self,
        dev: &mut D,
        tx: &mut impl TxSink,
    ) -> Option<SelfTestReport> {
        let run = self.self_test.take()?;
        Some(self.finish_self_test(run, dev, tx))
    }

    /// Restore the excitation in force (from its phase 0) and adaptation,
    /// report.
    fn finish_self_test<D: Device>(
        &mut self,
        run: SelfTestRun,
        dev: &mut D,
        tx: &mut impl TxSink,
    ) -> SelfTestReport {
        let fs = f64::from(self.config.limits.sample_rate_hz);
        let restore = ExcitationPlan::<D::Real>::new(
            &self.settings.excitation,
            &self.config.self_test.excitation,
            fs,
        );
        let resume = self.resume_after_test;
        let at = dev.with_pipeline(|p| {
            // The settings in force were accepted when they were set.
            let _ = restore.and_then(|plan| plan.apply(p.excitation_mut()));
            if resume {
                p.resume();
            }
            p.next_sample_index()
        });
        let first = run.first_sample();
        let last = at.saturating_sub(1).max(first);
        let report = run.report(last);
        self.last_test_span = Some((first, last));
        self.self_test_state = SelfTestState::Done {
            failed: report.failed,
            not_measured: report.not_measured,
        };
        self.tx.send(&report.clone().into(), 0, tx);
        report
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
