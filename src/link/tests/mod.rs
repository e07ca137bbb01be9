//! The link's command and scheduling logic against a mock pipeline that
//! records every call (the real pipeline and bench: host test `link`).

use super::*;
use crate::excitation::{Excitation, SafeWindow};
use crate::pipeline::{PipelineError, StepCounts, RAW_BLOCK_LEN};
use beam_protocol::budget::uart_bytes_per_s;
use beam_protocol::{
    encode, Estimate, EstimatorKind, Excitation as PExcitation, Frame, Message, Waveform,
    MAX_ENCODED_LEN,
};
use heapless::spsc::Queue;

const LIMITS: Limits = Limits {
    sample_rate_hz: 10_000.0,
    piezo_min_v: -10.0,
    piezo_max_v: 10.0,
    max_multisine_tones: 16,
    prbs_bits_min: 2,
    prbs_bits_max: 24,
    estimators: 1, // adaptive only
    modes: 2,
    link_bytes_per_s: uart_bytes_per_s(921_600) as f32,
};

struct MockPipeline {
    calls: Vec<String>,
    excitation: Excitation<f32>,
    estimator: u32,
    counters: Counters,
    next: u64,
    frozen: bool,
    read_back: Result<ads131m02::ReadBack, crate::pipeline::FaultKind>,
}

impl Control<f32> for MockPipeline {
    type Estimator = u32;
    fn freeze(&mut self) {
        self.calls.push("freeze".into());
        self.frozen = true;
    }
    fn resume(&mut self) {
        self.calls.push("resume".into());
        self.frozen = false;
    }
    fn reset_estimator(&mut self) {
        self.calls.push("reset".into());
    }
    fn replace_estimator(&mut self, e: u32, lambda: f64) -> Result<u32, u32> {
        self.calls.push(format!("replace {e} {lambda}"));
        Ok(core::mem::replace(&mut self.estimator, e))
    }
    fn set_telemetry_every(&mut self, every: u32) -> Result<(), PipelineError> {
        self.calls.push(format!("every {every}"));
        Ok(())
    }
    fn set_raw_decimation(&mut self, d: u16) {
        self.calls.push(format!("raw {d}"));
    }
    fn excitation_mut(&mut self) -> &mut Excitation<f32> {
        &mut self.excitation
    }
    fn counters(&self) -> Counters {
        self.counters
    }
    fn next_sample_index(&self) -> u64 {
        self.next
    }
    fn set_line_removal(
        &mut self,
        lines: Option<crate::guard::lines::LineCanceller<f32, { crate::guard::lines::MAX_LINES }>>,
        hold: u32,
    ) {
        self.calls.push(format!(
            "lines {} hold {hold}",
            lines.as_ref().map_or(0, |l| l.len())
        ));
    }
    fn is_frozen(&self) -> bool {
        self.frozen
    }
    fn adc_read_back(&mut self) -> Result<ads131m02::ReadBack, crate::pipeline::FaultKind> {
        self.calls.push("read back".into());
        self.read_back
    }
}

struct MockDevice {
    p: MockPipeline,
    next_id: u32,
    /// (settings, λ, U0, Y0, θ(0) length) of each build.
    built: Vec<(EstimatorSettings, f64, f64, f64, usize)>,
    recycled: Vec<u32>,
    refuse_build: Option<RejectReason>,
}

impl Device for MockDevice {
    type Real = f32;
    type Estimator = u32;
    type Pipeline = MockPipeline;
    fn with_pipeline<R>(&mut self, f: impl FnOnce(&mut MockPipeline) -> R) -> R {
        f(&mut self.p)
    }
    fn build_estimator(
        &mut self,
        s: &EstimatorSettings,
        f: &FilterConfig,
        theta0: &[f64],
    ) -> Result<u32, RejectReason> {
        if let Some(r) = self.refuse_build {
            return Err(r);
        }
        self.built.push((
            *s,
            f.lambda_rad_s,
            f.scales.u_scale,
            f.scales.y_scale,
            theta0.len(),
        ));
        self.next_id += 1;
        Ok(self.next_id)
    }
    fn recycle_estimator(&mut self, old: u32) {
        self.recycled.push(old);
    }
}

fn device() -> MockDevice {
    MockDevice {
        p: MockPipeline {
            calls: Vec::new(),
            excitation: Excitation::new(
                &Waveform::Square { freq_hz: 7.0 },
                0.1,
                0.0,
                SafeWindow {
                    min_v: -10.0,
                    max_v: 10.0,
                },
                10_000.0,
            )
            .unwrap(),
            estimator: 0,
            counters: Counters::default(),
            next: 1234,
            frozen: false,
            read_back: Err(crate::pipeline::FaultKind::Bus),
        },
        next_id: 0,
        built: Vec::new(),
        recycled: Vec::new(),
        refuse_build: None,
    }
}

fn settings() -> Settings {
    Settings {
        excitation: PExcitation::default(),
        estimator: EstimatorSettings {
            lambda_rad_s: Some(100.0),
            ..EstimatorSettings::default()
        },
        telemetry: TelemetryRates::default(),
    }
}

/// The rule with a 0.05 s start-up window.
fn tuning() -> TuningConfig {
    TuningConfig {
        startup_s: 0.05,
        ..TuningConfig::new(1e-4, crate::tuning::LambdaSource::Data)
    }
}

fn link_with(settings: Settings) -> DeviceLink {
    DeviceLink::new(
        LinkConfig {
            limits: LIMITS,
            firmware: FIRMWARE_VERSION,
            rules: FlagRules::default(),
            self_test: crate::bench::self_test_config(),
        },
        settings,
        &tuning(),
    )
    .unwrap()
}

fn link() -> DeviceLink {
    link_with(settings())
}

/// The start-up window's pairs: u = ±0.1 (RMS 0.1), y = 2e-3·sin (RMS
/// √2·1e-3), in blocks as the sample task hands them over, until the
/// window closes.
fn feed_startup(l: &mut DeviceLink) -> usize {
    let mut c = StartupCollector::<f32>::new();
    let mut blocks = Vec::new();
    let mut k = 0u32;
    while l.collecting_startup() {
        let t = k as f32 * 1e-4;
        let u = if (t * 7.0).fract() < 0.5 { 0.1 } else { -0.1 };
        c.push(u, 2e-3 * libm::sinf(300.0 * t), |b| {
            blocks.push(b);
            true
        });
        for b in blocks.drain(..) {
            l.on_startup_block(&b);
        }
        k += 1;
    }
    k as usize
}

/// Start-up window, then the first build swapped in; its first sample.
fn start(l: &mut DeviceLink, d: &mut MockDevice) -> u64 {
    feed_startup(l);
    let t = l.poll(d).unwrap().unwrap();
    assert_eq!(t.kind, BuildKind::First);
    t.at
}

/// A host: encodes commands, decodes everything the device queued.
struct Host {
    seq: u32,
    dec: Decoder,
    frames: Vec<Frame>,
}

impl Host {
    fn new() -> Self {
        Self {
            seq: 0,
            dec: Decoder::new(),
            frames: Vec::new(),
        }
    }
    fn command(&mut self, c: Command) -> Vec<u8> {
        let mut out = [0u8; MAX_ENCODED_LEN];
        let n = encode(&c, self.seq, &mut out).unwrap();
        self.seq += 1;
        out[..n].to_vec()
    }
    fn drain(&mut self, c: &mut heapless::spsc::Consumer<'_, u8>) -> Vec<Message> {
        let mut got = Vec::new();
        while let Some(b) = c.dequeue() {
            if let Some(f) = self.dec.push(b) {
                let f = f.unwrap();
                got.push(f.message.clone());
                self.frames.push(f);
            }
        }
        got
    }
}

fn acks(msgs: &[Message]) -> Vec<(u32, AckResult)> {
    msgs.iter()
        .filter_map(|m| match m {
            Message::Ack(a) => Some((a.command_seq, a.result)),
            _ => None,
        })
        .collect()
}

fn statuses(msgs: &[Message]) -> Vec<Status> {
    msgs.iter()
        .filter_map(|m| match m {
            Message::Status(s) => Some(s.clone()),
            _ => None,
        })
        .collect()
}

#[test]
fn every_command_is_acknowledged_and_applied() {
    let mut q: Queue<u8, 2048> = Queue::new();
    let (mut tx, mut rx) = q.split();
    let (mut l, mut d, mut h) = (link(), device(), Host::new());
    assert_eq!(start(&mut l, &mut d), 1234);
    assert_eq!(d.p.calls, ["replace 1 100", "resume"]);
    assert_eq!(d.recycled, [0], "the stand-in comes back");
    d.p.calls.clear();

    let amp = PExcitation {
        amplitude_v: 0.2,
        ..PExcitation::default()
    };
    let est = EstimatorSettings {
        gain: 2e4,
        lambda_rad_s: Some(150.0),
        ..EstimatorSettings::default()
    };
    let rates = TelemetryRates {
        estimate_rate_hz: 50.0,
        raw_decimation: 4,
        status_rate_hz: 2.0,
    };
    let mut bytes = Vec::new();
    for c in [
        Command::SetExcitation(amp),
        Command::SetEstimator(est),
        Command::SetTelemetry(rates),
        Command::Reset,
        Command::Freeze,
        Command::Resume,
        Command::SetLineRemoval(beam_protocol::LineRemoval {
            mains_hz: 50.0,
            harmonics: 7,
            time_constant_s: 0.2,
        }),
        Command::RequestStatus,
    ] {
        bytes.extend(h.command(c));
    }
    l.receive(bytes, &mut d, &mut tx);
    let msgs = h.drain(&mut rx);
    assert_eq!(
        acks(&msgs),
        (0..8).map(|i| (i, AckResult::Accepted)).collect::<Vec<_>>()
    );
    assert_eq!(
        d.p.calls,
        [
            "replace 2 150",
            "every 200",
            "raw 4",
            "reset",
            "freeze",
            "resume",
            // Harmonics 1–7 of 50 Hz, all below 5 kHz; held 5τ = 1 s.
            "lines 7 hold 10000"
        ]
    );
    assert_eq!(l.line_removal().mains_hz, 50.0);
    assert_eq!(d.p.excitation.amplitude(), 0.2);
    assert_eq!(d.built.last().unwrap().0, est);
    assert_eq!(d.recycled, [0, 1]);
    assert_eq!(
        l.record_every(),
        200,
        "estimates at 50 Hz drive the records"
    );
    // RequestStatus: the Ack, then a Status with the counters read now.
    let st = statuses(&msgs);
    assert_eq!(st.len(), 1);
    assert!(matches!(msgs.last(), Some(Message::Status(_))));
    let s = &st[0];
    assert_eq!(s.uptime_samples, 1234);
    assert_eq!(s.excitation, amp);
    assert_eq!(s.estimator, est);
    assert_eq!(s.telemetry, rates);
    assert!(!s.adaptation_frozen);
    assert_eq!(s.counters.commands_accepted, 8);
    assert_eq!(s.firmware, FIRMWARE_VERSION);
    assert_eq!(s.modes, 2);
    assert_eq!(h.dec.counters().lost, 0);
}

#[test]
fn a_rejected_command_changes_nothing() {
    let mut q: Queue<u8, 2048> = Queue::new();
    let (mut tx, mut rx) = q.split();
    let (mut l, mut d, mut h) = (link(), device(), Host::new());
    start(&mut l, &mut d);
    d.p.calls.clear();
    for _ in 0..77 {
        d.p.excitation.next_sample();
    }
    let before = (l.settings, l.lambda_rad_s(), d.p.excitation);
    let outside = PExcitation {
        amplitude_v: 20.0,
        ..PExcitation::default()
    };
    let cases = [
        (
            Command::SetLineRemoval(beam_protocol::LineRemoval {
                mains_hz: 50.0,
                harmonics: 0,
                time_constant_s: 0.2,
            }),
            RejectReason::LineRemoval,
        ),
        (Command::SetExcitation(outside), RejectReason::SafeWindow),
        (
            Command::SetExcitation(PExcitation {
                amplitude_v: f32::NAN,
                ..PExcitation::default()
            }),
            RejectReason::NotFinite,
        ),
        (
            Command::SetExcitation(PExcitation {
                waveform: Waveform::Square { freq_hz: 6000.0 },
                ..PExcitation::default()
            }),
            RejectReason::Frequency,
        ),
        (
            Command::SetEstimator(EstimatorSettings {
                kind: EstimatorKind::Gradient,
                ..EstimatorSettings::default()
            }),
            RejectReason::EstimatorUnavailable,
        ),
        (
            Command::SetEstimator(EstimatorSettings {
                gain: 0.0,
                ..EstimatorSettings::default()
            }),
            RejectReason::Gain,
        ),
        (
            Command::SetEstimator(EstimatorSettings {
                lambda_rad_s: Some(40_000.0),
                ..EstimatorSettings::default()
            }),
            RejectReason::Lambda,
        ),
        (
            Command::SetTelemetry(TelemetryRates {
                estimate_rate_hz: 100.0,
                raw_decimation: 1,
                status_rate_hz: 1.0,
            }),
            RejectReason::LinkBudget,
        ),
        (
            Command::SetTelemetry(TelemetryRates {
                estimate_rate_hz: -1.0,
                ..TelemetryRates::default()
            }),
            RejectReason::Rate,
        ),
    ];
    let mut bytes = Vec::new();
    for (c, _) in &cases {
        bytes.extend(h.command(*c));
    }
    l.receive(bytes, &mut d, &mut tx);
    let got = acks(&h.drain(&mut rx));
    let want: Vec<_> = cases
        .iter()
        .enumerate()
        .map(|(i, (_, r))| (i as u32, AckResult::Rejected(*r)))
        .collect();
    assert_eq!(got, want);
    assert!(d.p.calls.is_empty(), "{:?}", d.p.calls);
    assert_eq!((l.settings, l.lambda_rad_s(), d.p.excitation), before);
    assert_eq!(l.commands(), (0, 9));
    // The core refuses what validation let through: still nothing changes.
    d.refuse_build = Some(RejectReason::Gain);
    let c = Command::SetEstimator(EstimatorSettings {
        gain: 1e38,
        ..EstimatorSettings::default()
    });
    assert_eq!(l.execute(&c, &mut d), Err(RejectReason::Gain));
    assert!(d.p.calls.is_empty());
    assert_eq!((l.settings, l.lambda_rad_s()), (before.0, before.1));
}

#[test]
fn raw_decimation_two_fits_next_to_the_defaults() {
    // docs/PROTOCOL.md §7 at 921,600 baud: 5 kHz of raw samples next to
    // estimates at 100 Hz and status at 1 Hz, not 10 kHz.
    let (mut l, mut d) = (link(), device());
    let rates = |raw_decimation| {
        Command::SetTelemetry(TelemetryRates {
            raw_decimation,
            ..TelemetryRates::default()
        })
    };
    assert_eq!(l.execute(&rates(1), &mut d), Err(RejectReason::LinkBudget));
    assert_eq!(l.execute(&rates(2), &mut d), Ok(()));
    assert_eq!(d.p.calls, ["every 100", "raw 2"]);
}

#[test]
fn freeze_during_start_up_survives_the_start() {
    let mut q: Queue<u8, 512> = Queue::new();
    let (mut tx, mut rx) = q.split();
    let (mut l, mut d, mut h) = (link(), device(), Host::new());
    // Before start: Resume must not resume the (frozen) start-up pipeline,
    // Reset has nothing to reset, SetEstimator is checked by a trial build.
    let est = EstimatorSettings {
        lambda_rad_s: None,
        ..EstimatorSettings::default()
    };
    let mut bytes = h.command(Command::Resume);
    bytes.extend(h.command(Command::Reset));
    bytes.extend(h.command(Command::Freeze));
    bytes.extend(h.command(Command::SetEstimator(est)));
    l.receive(bytes, &mut d, &mut tx);
    assert_eq!(acks(&h.drain(&mut rx)).len(), 4);
    assert_eq!(d.p.calls, ["freeze"]);
    assert_eq!(d.recycled, [1], "the trial build is returned");
    // λ = None: the automatic rule; no λ until it has chosen.
    assert!(l.is_automatic());
    assert_eq!(l.lambda_rad_s(), None);
    assert_eq!(
        l.status(0, &Counters::default()).estimator.lambda_rad_s,
        None
    );
    d.p.calls.clear();
    start(&mut l, &mut d);
    let lambda = l.lambda_rad_s().unwrap();
    assert_eq!(
        d.p.calls,
        [format!("replace 2 {lambda}")],
        "no resume: frozen by command"
    );
    assert!(l.status(0, &Counters::default()).adaptation_frozen);
}

/// Θ̂ of a two-mode plant at λ = 100 rad/s (an estimate, not the initial
/// Θ̂ = 0, which is never sent with modes).
fn plant_theta() -> [f32; 7] {
    let tf = crate::model::ModalParams::new(&[40.0, 250.0], &[0.02, 0.13], &[10.0, 15.0], None)
        .unwrap()
        .transfer_function();
    let mut theta = [0.0f64; 7];
    tf.to_theta(100.0, &mut theta).unwrap();
    theta.map(|v| v as f32)
}

fn record(index: u64, counters: Counters) -> TelemetryRecord<f32, 7, 28> {
    TelemetryRecord {
        sample_index: index,
        theta: plant_theta(),
        information: [0.0; 28],
        has_information: false,
        lambda_rad_s: 100.0,
        u_v: 0.0,
        y: 0.0,
        flags: beam_protocol::StatusFlags::default(),
        supervised: false,
        lemma1_ratio: None,
        steps: StepCounts::default(),
        counters,
    }
}

fn estimates(msgs: &[Message]) -> Vec<Estimate> {
    msgs.iter()
        .filter_map(|m| match m {
            Message::Estimate(e) => Some(e.clone()),
            _ => None,
        })
        .collect()
}

#[test]
fn estimates_and_status_follow_the_record_clock() {
    let mut q: Queue<u8, 4096> = Queue::new();
    let (mut tx, mut rx) = q.split();
    let (mut l, mut d, mut h) = (link(), device(), Host::new());
    let w = [-2.0f32, 2.0];
    // Start-up records: Status only.
    for k in 1..=5u64 {
        assert!(l
            .on_record(&record(k * 100 - 1, Counters::default()), &w, &mut tx)
            .is_none());
    }
    let msgs = h.drain(&mut rx);
    assert!(estimates(&msgs).is_empty());
    assert_eq!(statuses(&msgs).len(), 1, "the first record brings a Status");
    d.p.next = 500;
    start(&mut l, &mut d);
    // 2 s of records at 100 Hz: 200 estimates, 2 more Status (1 Hz).
    let mut msgs = Vec::new();
    for k in 6..206u64 {
        l.on_record(&record(k * 100 - 1, Counters::default()), &w, &mut tx);
        msgs.extend(h.drain(&mut rx));
    }
    let e = estimates(&msgs);
    assert_eq!(e.len(), 200);
    assert_eq!(e[0].sample_index, 599);
    // The law has not updated (the records' step counts are 0): no modes,
    // not valid; λ travels with Θ̂.
    assert!(e.iter().all(|e| e.is_consistent()
        && e.modes.is_empty()
        && e.lambda_rad_s == 100.0
        && !e
            .flags
            .contains(beam_protocol::StatusFlags::PHYSICALLY_VALID)));
    // A periodic Status rides the record of sample k: uptime_samples =
    // k + 1, the samples taken (PROTOCOL.md §4.3).
    let s = statuses(&msgs);
    assert_eq!(
        s.iter().map(|s| s.uptime_samples).collect::<Vec<_>>(),
        [10_100, 20_100]
    );
    // Records run at the faster of the two streams: every 400 samples for
    // estimates at 25 Hz and status at 10 Hz, and the other way round.
    let rates = TelemetryRates {
        estimate_rate_hz: 25.0,
        raw_decimation: 0,
        status_rate_hz: 10.0,
    };
    l.execute(&Command::SetTelemetry(rates), &mut d).unwrap();
    assert_eq!(l.record_every(), 400);
    let rates = TelemetryRates {
        estimate_rate_hz: 10.0,
        raw_decimation: 0,
        status_rate_hz: 25.0,
    };
    l.execute(&Command::SetTelemetry(rates), &mut d).unwrap();
    assert_eq!(l.record_every(), 400);
    for k in 0..25u64 {
        l.on_record(&record(100_000 + k * 400, Counters::default()), &w, &mut tx);
    }
    let msgs = h.drain(&mut rx);
    let idx: Vec<u64> = estimates(&msgs).iter().map(|e| e.sample_index).collect();
    assert_eq!(idx.len(), 10, "{idx:?}");
    assert_eq!(statuses(&msgs).len(), 25);
    // Both off: no estimates, no status; the records keep 100 Hz.
    l.execute(
        &Command::SetTelemetry(TelemetryRates {
            estimate_rate_hz: 0.0,
            raw_decimation: 0,
            status_rate_hz: 0.0,
        }),
        &mut d,
    )
    .unwrap();
    assert_eq!(l.record_every(), 100);
    for k in 0..50u64 {
        l.on_record(&record(200_000 + k * 100, Counters::default()), &w, &mut tx);
    }
    assert!(h.drain(&mut rx).is_empty());
    assert_eq!(h.dec.counters().lost, 0);
}

#[test]
fn no_modes_before_the_laws_first_update() {
    let mut q: Queue<u8, 4096> = Queue::new();
    let (mut tx, mut rx) = q.split();
    let (mut l, mut d, mut h) = (link(), device(), Host::new());
    let w = [-2.0f32, 2.0];
    let rec = |index, updated| TelemetryRecord {
        steps: StepCounts {
            updated,
            ..StepCounts::default()
        },
        ..record(index, Counters::default())
    };
    d.p.next = 500;
    start(&mut l, &mut d);
    let mut modes = Vec::new();
    let mut feed = |l: &mut DeviceLink, r, tx: &mut _, h: &mut Host, rx: &mut _| {
        l.on_record(&r, &w, tx);
        let e = estimates(&h.drain(rx));
        modes.push(e[0].modes.len());
    };
    // Held (no update), then updates.
    feed(&mut l, rec(599, 0), &mut tx, &mut h, &mut rx);
    feed(&mut l, rec(699, 100), &mut tx, &mut h, &mut rx);
    // A Reset at sample 750: the record at 799 spans it, its updates may
    // be the old law's; the one at 899 is all new law.
    d.p.next = 750;
    l.execute(&Command::Reset, &mut d).unwrap();
    feed(&mut l, rec(799, 100), &mut tx, &mut h, &mut rx);
    feed(&mut l, rec(899, 0), &mut tx, &mut h, &mut rx);
    feed(&mut l, rec(999, 100), &mut tx, &mut h, &mut rx);
    feed(&mut l, rec(1099, 0), &mut tx, &mut h, &mut rx);
    assert_eq!(modes, [0, 2, 0, 0, 2, 2]);
}

/// PROTOCOL.md §4.1: SENSOR_FAULT, ADC_SATURATED, DAC_SATURATED,
/// CHANGE_DETECTED, SENSOR_LEVEL and FROZEN_AUTO's holds are "since the
/// previous estimate": an event in a record that made no estimate (Status
/// faster than the estimates) or whose estimate was lost on a full TX ring
/// shows on the next estimate, once.
#[test]
fn events_between_estimates_show_on_the_next_estimate() {
    use beam_protocol::StatusFlags as F;
    let mut q: Queue<u8, 4096> = Queue::new();
    let (mut tx, mut rx) = q.split();
    let (mut l, mut d, mut h) = (link(), device(), Host::new());
    let w = [-2.0f32, 2.0];
    d.p.next = 0;
    start(&mut l, &mut d);
    // Estimates at 10 Hz, Status at 25 Hz: a record every 400 samples, an
    // estimate at every 1000th sample (the first record at or after it).
    let rates = TelemetryRates {
        estimate_rate_hz: 10.0,
        raw_decimation: 0,
        status_rate_hz: 25.0,
    };
    l.execute(&Command::SetTelemetry(rates), &mut d).unwrap();
    assert_eq!(l.record_every(), 400);
    let event_bits = F::CHANGE_DETECTED
        .with(F::SENSOR_LEVEL)
        .with(F::FROZEN_AUTO);
    let mut counters = Counters::default();
    // (record's sample index, estimates expected from it, an event in it)
    let mut seen = Vec::new();
    for k in 0..15u64 {
        let index = 10_000 + k * 400;
        // An ADC CRC error, a saturation, a DAC clamp and the record's own
        // event bits in the records at 10_400 and 13_600, neither of which
        // makes an estimate.
        let event = index == 10_400 || index == 13_600;
        if event {
            counters.adc_crc += 1;
            counters.bridge_saturated += 1;
            counters.excitation_clamped += 1;
        }
        let r = TelemetryRecord {
            flags: if event { event_bits } else { F::default() },
            ..record(index, counters)
        };
        l.on_record(&r, &w, &mut tx);
        for e in estimates(&h.drain(&mut rx)) {
            seen.push((e.sample_index, e.flags));
        }
    }
    let all = F::SENSOR_FAULT
        .with(F::ADC_SATURATED)
        .with(F::DAC_SATURATED)
        .with(event_bits);
    let flagged: Vec<u64> = seen
        .iter()
        .filter(|(_, f)| f.contains(all))
        .map(|(i, _)| *i)
        .collect();
    let quiet = seen.iter().filter(|(_, f)| f.0 & all.0 == 0).count();
    assert_eq!(flagged, [11_200, 14_000], "{seen:?}");
    assert_eq!(quiet + 2, seen.len(), "{seen:?}");

    // An estimate lost on a full TX ring: its record's events go with the
    // next estimate that gets through.
    let mut q: Queue<u8, 512> = Queue::new();
    let (mut tx, mut rx) = q.split();
    let (mut l, mut d, mut h) = (link(), device(), Host::new());
    d.p.next = 0;
    start(&mut l, &mut d);
    let mut counters = Counters::default();
    // Nobody drains: from some record on, the estimates are dropped.
    for k in 1..=20u64 {
        if k == 15 {
            counters.adc_crc += 1;
        }
        let r = TelemetryRecord {
            flags: if k == 15 {
                F::CHANGE_DETECTED
            } else {
                F::default()
            },
            ..record(k * 100, counters)
        };
        l.on_record(&r, &w, &mut tx);
    }
    assert!(l.tx_stats().frames_dropped > 10);
    let _ = h.drain(&mut rx);
    l.on_record(&record(2_100, counters), &w, &mut tx);
    let e = estimates(&h.drain(&mut rx));
    assert_eq!(e.len(), 1);
    assert!(e[0].flags.contains(
        F::SENSOR_FAULT
            .with(F::CHANGE_DETECTED)
            .with(F::TELEMETRY_DROPPED)
    ));
    l.on_record(&record(2_200, counters), &w, &mut tx);
    let e = estimates(&h.drain(&mut rx));
    assert_eq!(e[0].flags.0 & F::SENSOR_FAULT.with(F::CHANGE_DETECTED).0, 0);
}

#[test]
fn full_tx_ring_drops_whole_frames_counted_as_gaps_and_flagged() {
    let mut q: Queue<u8, 512> = Queue::new();
    let (mut tx, mut rx) = q.split();
    let (mut l, mut d, mut h) = (link(), device(), Host::new());
    let w = [-2.0f32, 2.0];
    d.p.next = 0;
    start(&mut l, &mut d);
    // Nobody drains: the ring fills, later frames are dropped whole.
    for k in 1..=20u64 {
        l.on_record(&record(k * 100, Counters::default()), &w, &mut tx);
    }
    let dropped = l.tx_stats().frames_dropped;
    assert!(dropped > 10, "{dropped}");
    // The reserve stays free for answers.
    assert!(tx.free() >= ANSWER_RESERVE_BYTES);
    let bytes = h.command(Command::Freeze);
    l.receive(bytes, &mut d, &mut tx);
    let msgs = h.drain(&mut rx);
    assert_eq!(acks(&msgs), [(0, AckResult::Accepted)]);
    // Then an estimate gets through, flagged.
    l.on_record(&record(2_100, Counters::default()), &w, &mut tx);
    let msgs = h.drain(&mut rx);
    let e = estimates(&msgs);
    assert_eq!(e.len(), 1);
    assert!(e[0]
        .flags
        .contains(beam_protocol::StatusFlags::TELEMETRY_DROPPED));
    // Every dropped frame is exactly one lost sequence number.
    assert_eq!(
        h.dec.counters().lost,
        u64::from(l.tx_stats().frames_dropped)
    );
    assert_eq!(h.dec.counters().errors(), 0);
    // And the Status reports them.
    let s = l.status(0, &Counters::default());
    assert_eq!(s.counters.telemetry_dropped, l.tx_stats().frames_dropped);
}

#[test]
fn wrong_direction_and_broken_frames_are_counted_not_answered() {
    let mut q: Queue<u8, 512> = Queue::new();
    let (mut tx, mut rx) = q.split();
    let (mut l, mut d, mut h) = (link(), device(), Host::new());
    let mut out = [0u8; MAX_ENCODED_LEN];
    let ack = Ack {
        command_seq: 1,
        result: AckResult::Accepted,
    };
    let n = encode(&ack, 0, &mut out).unwrap();
    let mut bytes = out[..n].to_vec();
    let mut bad = h.command(Command::Freeze);
    bad[5] ^= 0x40;
    bytes.extend(bad);
    bytes.extend([0x11; 100]);
    bytes.push(0);
    bytes.extend(h.command(Command::RequestStatus));
    l.receive(bytes, &mut d, &mut tx);
    let msgs = h.drain(&mut rx);
    assert_eq!(acks(&msgs), [(1, AckResult::Accepted)]);
    let s = statuses(&msgs);
    assert_eq!(s[0].counters.rx_frame_errors, 3);
    assert!(d.p.calls.is_empty());
}

/// PROTOCOL.md §5.4: the device executes every command it decodes, and
/// answers each with the command's own number, whatever that number: a
/// repeated one (a host re-sending, or a new host session counting from 0
/// again) and an older one are executed like any other.
#[test]
fn repeated_and_older_command_numbers_are_executed_and_answered() {
    let mut q: Queue<u8, 2048> = Queue::new();
    let (mut tx, mut rx) = q.split();
    let (mut l, mut d, mut h) = (link(), device(), Host::new());
    start(&mut l, &mut d);
    d.p.calls.clear();
    let reset = h.command(Command::Reset);
    let mut bytes = reset.clone();
    bytes.extend(reset.clone());
    bytes.extend(h.command(Command::Freeze));
    bytes.extend(reset);
    l.receive(bytes, &mut d, &mut tx);
    let msgs = h.drain(&mut rx);
    assert_eq!(
        acks(&msgs),
        [
            (0, AckResult::Accepted),
            (0, AckResult::Accepted),
            (1, AckResult::Accepted),
            (0, AckResult::Accepted)
        ]
    );
    assert_eq!(d.p.calls, ["reset", "reset", "freeze", "reset"]);
    assert_eq!(l.commands(), (4, 0));
    // The Acks are device frames numbered in turn: none is a duplicate.
    assert_eq!(h.dec.counters().duplicates, 0);
}

#[test]
fn firmware_version_is_the_crate_version() {
    let v = env!("CARGO_PKG_VERSION");
    assert_eq!(
        format!(
            "{}.{}.{}",
            FIRMWARE_VERSION.major, FIRMWARE_VERSION.minor, FIRMWARE_VERSION.patch
        ),
        v
    );
    assert_eq!(parse_u8("256"), 255);
    assert_eq!(parse_u8("1x"), 255);
    assert_eq!(interval_samples(100.0, 10_000.0), Some(100));
    assert_eq!(interval_samples(3.0, 10_000.0), Some(3333));
    assert_eq!(interval_samples(20_000.0, 10_000.0), Some(1));
    assert_eq!(interval_samples(0.0, 10_000.0), None);
    assert_eq!(interval_samples(f32::NAN, 10_000.0), None);
    assert_eq!(interval_samples(1e-9, 10_000.0), Some(u32::MAX));
}

mod tune;

/// The self-test through the link (PROTOCOL.md §9.7): refused before the
/// estimator starts, then adaptation frozen, the ADC read back and the
/// drive at zero in one lock; every command but RequestStatus refused
/// (Busy) while it runs; the tone and the default excitation as its
/// phases end; the excitation in force restored and adaptation resumed;
/// the report sent, Status's state and the estimates' SELF_TEST bit.
#[test]
fn the_self_test_owns_the_drive_and_leaves_the_estimator_as_it_was() {
    use crate::excitation::Excitation as Ex;
    use crate::selftest::{SelfTestBlock, BLOCK_LEN, TOTAL_SAMPLES};
    use beam_protocol::{SelfTestChecks, SelfTestState, StatusFlags, WaveformKind};
    let mut q: Queue<u8, 4096> = Queue::new();
    let (mut tx, mut rx) = q.split();
    let (mut l, mut d, mut h) = (link(), device(), Host::new());
    let w = [-2.0f32, 2.0];
    l.receive(h.command(Command::SelfTest), &mut d, &mut tx);
    assert_eq!(
        acks(&h.drain(&mut rx)),
        [(0, AckResult::Rejected(RejectReason::Busy))],
        "no self-test command during the start-up window"
    );
    d.p.next = 0;
    start(&mut l, &mut d);
    d.p.calls.clear();
    let square = |e: &Ex<f32>| e.kind();
    assert_eq!(square(&d.p.excitation), WaveformKind::Square);
    d.p.next = 10_000;
    l.receive(h.command(Command::SelfTest), &mut d, &mut tx);
    assert_eq!(acks(&h.drain(&mut rx)), [(1, AckResult::Accepted)]);
    assert_eq!(d.p.calls, ["freeze", "read back"]);
    assert_eq!(d.p.excitation.kind(), WaveformKind::Off);
    assert!(l.self_test_running());
    assert_eq!(l.self_test_state(), SelfTestState::Running);
    let mut bytes = h.command(Command::Reset);
    bytes.extend(h.command(Command::SelfTest));
    bytes.extend(h.command(Command::RequestStatus));
    l.receive(bytes, &mut d, &mut tx);
    let msgs = h.drain(&mut rx);
    assert_eq!(
        acks(&msgs),
        [
            (2, AckResult::Rejected(RejectReason::Busy)),
            (3, AckResult::Rejected(RejectReason::Busy)),
            (4, AckResult::Accepted)
        ]
    );
    assert_eq!(statuses(&msgs)[0].self_test, SelfTestState::Running);
    // The tuning rule builds nothing while the test runs.
    assert_eq!(l.poll(&mut d), Ok(None));

    // The sample interrupt's blocks: a clean bench (the drive read back
    // 2.15 samples late, as the bench's timing model says).
    let mut kinds = Vec::new();
    let mut report = None;
    let mut index = 10_000u64;
    while report.is_none() {
        let mut b = SelfTestBlock {
            first_index: index,
            len: BLOCK_LEN as u8,
            held_v: [0.0; BLOCK_LEN],
            monitor_v: [0.0; BLOCK_LEN],
            y: [0.0; BLOCK_LEN],
            fresh: u32::MAX,
            intervals: BLOCK_LEN as u32,
            interval_ticks: BLOCK_LEN as u64 * 2_500,
        };
        for i in 0..BLOCK_LEN {
            b.y[i] = 1e-3 * libm::sinf((index + i as u64) as f32 * 0.01);
        }
        index += BLOCK_LEN as u64;
        d.p.next = index;
        report = l.on_self_test_block(&b, &mut d, &mut tx);
        if kinds.last() != Some(&d.p.excitation.kind()) {
            kinds.push(d.p.excitation.kind());
        }
        assert!(index < 20_000 + TOTAL_SAMPLES);
    }
    assert_eq!(
        kinds,
        [
            WaveformKind::Off,
            WaveformKind::Multisine,
            WaveformKind::Square
        ]
    );
    assert_eq!(d.p.calls.last().map(String::as_str), Some("resume"));
    assert!(!d.p.frozen);
    assert!(!l.self_test_running());
    let report = report.unwrap();
    // The mock's read-back fails; these blocks carry no tone (held and
    // monitor 0): nothing to fit.
    assert_eq!(
        report.failed,
        SelfTestChecks::ADC_ID.with(SelfTestChecks::ADC_REGISTERS)
    );
    assert_eq!(report.not_measured, SelfTestChecks::LOOPBACK);
    assert_eq!(
        (report.first_sample, report.last_sample),
        (10_000, index - 1)
    );
    let msgs = h.drain(&mut rx);
    // (NaN, the values not measured, is not equal to itself: compare the
    // encodings.)
    let sent: Vec<_> = msgs
        .iter()
        .filter_map(|m| match m {
            Message::SelfTestReport(r) => Some(format!("{r:?}")),
            _ => None,
        })
        .collect();
    assert_eq!(sent, [format!("{report:?}")]);
    assert_eq!(
        l.status(0, &Counters::default()).self_test,
        SelfTestState::Done {
            failed: report.failed,
            not_measured: report.not_measured
        }
    );
    // A record made during the test carries SELF_TEST, one after it not.
    l.on_record(&record(15_099, Counters::default()), &w, &mut tx);
    l.on_record(&record(index + 1_000, Counters::default()), &w, &mut tx);
    let e = estimates(&h.drain(&mut rx));
    assert_eq!(e.len(), 2);
    assert!(e[0].flags.contains(StatusFlags::SELF_TEST));
    assert!(!e[1].flags.contains(StatusFlags::SELF_TEST));
    // Frozen by command before: still frozen after.
    l.receive(h.command(Command::Freeze), &mut d, &mut tx);
    l.receive(h.command(Command::SelfTest), &mut d, &mut tx);
    d.p.calls.clear();
    let b = SelfTestBlock {
        first_index: index,
        len: BLOCK_LEN as u8,
        held_v: [0.0; BLOCK_LEN],
        monitor_v: [0.0; BLOCK_LEN],
        y: [0.0; BLOCK_LEN],
        fresh: 0,
        intervals: 0,
        interval_ticks: 0,
    };
    assert!(l.on_self_test_block(&b, &mut d, &mut tx).is_none());
    let aborted = l.abort_self_test(&mut d, &mut tx).unwrap();
    assert!(aborted.failed.contains(SelfTestChecks::DRDY_RATE));
    assert!(aborted
        .not_measured
        .contains(SelfTestChecks::LOOPBACK.with(SelfTestChecks::NOISE)));
    assert!(d.p.frozen && !d.p.calls.contains(&"resume".to_string()));
}
