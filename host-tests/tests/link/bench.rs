//! The QEMU image's device on the host: the simulated bench behind the real
//! drivers (`bench`, `ConverterRig`), the per-sample pipeline in
//! `f32`, the truth-free tuning rule (start-up window, automatic λ), and
//! the device end of the serial link (`beamest::link::DeviceLink`) — the
//! same sequence and settings the firmware runs, with a host on the other
//! end of the byte rings that decodes with the core's `Decoder`.
//!
//! One sample: `rig.tick()`, `pipeline.tick()`, the start-up pairs and
//! (while a self-test runs) the self-test's copy of the tick into their
//! bounded queues (the sample interrupt); the link runs after every
//! [`SERVICE_EVERY`] samples, as thread mode would between interrupts
//! (start-up blocks, builds and swaps, records, raw blocks). The lock of the
//! firmware is trivial here: the tick and the link never interleave.

use std::collections::VecDeque;

use ad5761r::Ad5761r;
use ads131m02::Ads131m02;
use beam_protocol::{
    encode, Command, Decoder, EstimatorSettings, Frame, Message, RejectReason, SelfTestReport,
    MAX_ENCODED_LEN,
};
use beamest::bench::{self, BenchFault, ConverterModels, ConverterRig};
use beamest::estimator::{Adaptive2, AdaptiveConfig};
use beamest::filter_bank::FilterConfig;
use beamest::link::reject_config;
use beamest::link::{
    estimator_configs, with_theta0, Device, DeviceLink, Settings, StartupCollector, Tuned, TxSink,
};
use beamest::pipeline::{bring_up, Pipeline, RawBlock, TelemetryRecord, Tick};
use beamest::rig::chips::{Ad5761rModel, Ads131m02Model, Shared};
use beamest::selftest::{Collector, SelfTestBlock};
use beamest::tuning::{LambdaSource, TuningConfig};
use heapless::spsc::{Consumer, Producer, Queue};

pub type Rec = TelemetryRecord<f32, 7, 28>;
pub type Raw = RawBlock<f32>;
pub type Adc<'a> = Ads131m02<Shared<'a, Ads131m02Model>>;
pub type Dac<'a> = Ad5761r<Shared<'a, Ad5761rModel>>;
pub type Pipe<'a> =
    Pipeline<f32, Adaptive2<f32>, Adc<'a>, Dac<'a>, Producer<'a, Rec>, Producer<'a, Raw>, 7, 28>;

/// The link runs every this many samples (thread mode between interrupts).
pub const SERVICE_EVERY: u64 = 10;
/// The QEMU image's baud rate.
pub const BAUD: u32 = 921_600;

struct NoDelay;

impl embedded_hal::delay::DelayNs for NoDelay {
    fn delay_ns(&mut self, _ns: u32) {}
}

/// A bounded TX byte ring of any capacity (the UART's).
pub struct Ring {
    pub bytes: VecDeque<u8>,
    pub capacity: usize,
}

impl Ring {
    pub fn new(capacity: usize) -> Self {
        Self {
            bytes: VecDeque::new(),
            capacity,
        }
    }
}

impl TxSink for Ring {
    fn free(&self) -> usize {
        self.capacity - self.bytes.len()
    }
    fn push(&mut self, bytes: &[u8]) {
        assert!(
            bytes.len() <= self.free(),
            "the link pushed more than free()"
        );
        self.bytes.extend(bytes);
    }
}

/// The board side: the pipeline.
pub struct SimDevice<'a> {
    pub pipeline: Pipe<'a>,
    /// Estimators built (including trial builds before start-up).
    pub built: usize,
}

impl<'a> Device for SimDevice<'a> {
    type Real = f32;
    type Estimator = Adaptive2<f32>;
    type Pipeline = Pipe<'a>;
    fn with_pipeline<R>(&mut self, f: impl FnOnce(&mut Pipe<'a>) -> R) -> R {
        f(&mut self.pipeline)
    }
    fn build_estimator(
        &mut self,
        settings: &EstimatorSettings,
        filter: &FilterConfig,
        theta0: &[f64],
    ) -> Result<Adaptive2<f32>, RejectReason> {
        let (f, l) = estimator_configs::<7>(settings, filter.lambda_rad_s, filter);
        let l = with_theta0(l, theta0).ok_or(RejectReason::EstimatorUnavailable)?;
        self.built += 1;
        Adaptive2::new(&f, &l).map_err(reject_config)
    }
    fn recycle_estimator(&mut self, _old: Adaptive2<f32>) {}
}

/// The firmware's settings: the bench's, the estimator under the automatic
/// rule (λ = none).
pub fn firmware_settings() -> Settings {
    Settings {
        estimator: EstimatorSettings::default(),
        ..bench::link_settings()
    }
}

/// The firmware's tuning rule: λ0 from the data, the board's converter
/// timing compensated.
pub fn tuning() -> TuningConfig {
    TuningConfig {
        timing: bench::output_timing(),
        ..TuningConfig::new(bench::TS_S, LambdaSource::Data)
    }
}

/// The host: encodes commands, decodes every device frame.
pub struct Host {
    pub seq: u32,
    pub dec: Decoder,
    pub frames: Vec<Frame>,
}

impl Host {
    pub fn new() -> Self {
        Self {
            seq: 0,
            dec: Decoder::new(),
            frames: Vec::new(),
        }
    }

    pub fn command(&mut self, c: &Command) -> Vec<u8> {
        let mut out = [0u8; MAX_ENCODED_LEN];
        let n = encode(c, self.seq, &mut out).unwrap();
        self.seq += 1;
        out[..n].to_vec()
    }

    /// Decode everything waiting in the ring; returns the new messages.
    pub fn drain(&mut self, ring: &mut Ring) -> Vec<Message> {
        let bytes: Vec<u8> = ring.bytes.drain(..).collect();
        let mut new = Vec::new();
        for r in self.dec.feed(&bytes) {
            let f = r.expect("the device's frames decode");
            new.push(f.message.clone());
            self.frames.push(f);
        }
        new
    }

    pub fn messages(&self) -> impl Iterator<Item = &Message> {
        self.frames.iter().map(|f| &f.message)
    }
}

/// The device: rig, sample task, queues, start-up window, link.
pub struct Bench<'a> {
    pub rig: ConverterRig<'a>,
    pub device: SimDevice<'a>,
    pub records: Consumer<'a, Rec>,
    pub raws: Consumer<'a, Raw>,
    /// The sample task's half of the start-up window.
    pub collector: StartupCollector<f32>,
    pub startup_out: Producer<'a, Raw>,
    pub startup_in: Consumer<'a, Raw>,
    pub link: DeviceLink,
    pub samples: u64,
    pub started_at: Option<u64>,
    /// Every estimator the tuning rule swapped in.
    pub builds: Vec<Tuned>,
    /// Skip the link's servicing (a stalled thread mode).
    pub stalled: bool,
    pub last_tick: Option<Tick<f32>>,
    /// The sample task's half of the self-test.
    pub test_collector: Collector<f32>,
    pub test_out: Producer<'a, SelfTestBlock<f32>>,
    pub test_in: Consumer<'a, SelfTestBlock<f32>>,
    /// Every self-test report the link made.
    pub reports: Vec<SelfTestReport>,
}

/// Clock ticks per sample of the bench's self-test timing
/// ([`bench::CLOCK_HZ`] at 10 kHz).
pub const CLOCK_PER_SAMPLE: u32 = (bench::CLOCK_HZ / bench::SAMPLE_RATE_HZ) as u32;

/// Build the bench with `excitation` instead of the bench's square wave
/// (if given) and run `f` on it.
pub fn with_bench<R>(
    excitation: Option<beam_protocol::Excitation>,
    f: impl FnOnce(&mut Bench<'_>) -> R,
) -> R {
    with_bench_opts(excitation, None, false, f)
}

/// [`with_bench`], with `fault` injected into the rig after the
/// converters' bring-up and, with `boot_self_test`, the self-test started
/// before the first sample as the firmware does at start-up (the tuning
/// rule's window opens after it).
pub fn with_bench_opts<R>(
    excitation: Option<beam_protocol::Excitation>,
    fault: Option<BenchFault>,
    boot_self_test: bool,
    f: impl FnOnce(&mut Bench<'_>) -> R,
) -> R {
    let models = ConverterModels::new();
    let mut adc: Adc<'_> = Ads131m02::new(models.adc_spi());
    let mut dac: Dac<'_> = Ad5761r::new(models.dac_spi());
    bring_up(
        &mut adc,
        &mut dac,
        &bench::adc_config(),
        bench::dac_config(),
        &mut NoDelay,
    )
    .unwrap();
    // The board's converter timing (sinc³, DAC latency), which the
    // estimator's filter bank compensates (`bench::filter_config`).
    let mut rig = bench::converter_rig(&models).unwrap();
    if let Some(fault) = fault {
        fault.apply(&mut rig);
    }
    let mut settings = firmware_settings();
    let mut gen = bench::excitation::<f32>().unwrap();
    if let Some(x) = excitation {
        beamest::link::ExcitationPlan::<f32>::new(&x, &settings.excitation, bench::SAMPLE_RATE_HZ)
            .unwrap()
            .apply(&mut gen)
            .unwrap();
        settings.excitation = x;
    }
    let link = DeviceLink::new(bench::link_config(BAUD), settings, &tuning()).unwrap();
    let stand_in =
        Adaptive2::<f32>::new(&bench::filter_config(1.0), &AdaptiveConfig::default()).unwrap();
    let mut q: Queue<Rec, 16> = Queue::new();
    let mut rq: Queue<Raw, 8> = Queue::new();
    let mut sq: Queue<Raw, 8> = Queue::new();
    let mut tq: Queue<SelfTestBlock<f32>, 8> = Queue::new();
    let (test_out, test_in) = tq.split();
    let (prod, records) = q.split();
    let (raw_prod, raws) = rq.split();
    let (startup_out, startup_in) = sq.split();
    let config = beamest::pipeline::PipelineConfig {
        telemetry_every: link.record_every(),
        ..bench::pipeline_config()
    };
    let mut pipeline = Pipeline::new(&config, stand_in, gen, adc, dac, prod, raw_prod).unwrap();
    pipeline.freeze();
    let mut b = Bench {
        rig,
        device: SimDevice { pipeline, built: 0 },
        records,
        raws,
        collector: StartupCollector::new(),
        startup_out,
        startup_in,
        link,
        samples: 0,
        started_at: None,
        builds: Vec::new(),
        stalled: false,
        last_tick: None,
        test_collector: Collector::new(),
        test_out,
        test_in,
        reports: Vec::new(),
    };
    if boot_self_test {
        b.link.start_self_test(&mut b.device, true).unwrap();
    }
    f(&mut b)
}

impl Bench<'_> {
    /// One sample (the sample interrupt), then the link every
    /// [`SERVICE_EVERY`] samples unless stalled.
    pub fn step(&mut self, tx: &mut Ring) {
        self.rig.tick().unwrap();
        let tick = self.device.pipeline.tick();
        assert_eq!(tick.sample_index, self.samples, "every tick runs");
        if self.link.collecting_startup() {
            if let Some((u, y)) = tick.fed {
                let out = &mut self.startup_out;
                self.collector.push(u, y, |b| out.enqueue(b).is_ok());
            }
        }
        if self.link.self_test_running() {
            let out = &mut self.test_out;
            self.test_collector
                .push(&tick, CLOCK_PER_SAMPLE, |b| out.enqueue(b).is_ok());
        } else {
            self.test_collector.stop();
        }
        self.last_tick = Some(tick);
        self.samples += 1;
        if !self.stalled && self.samples.is_multiple_of(SERVICE_EVERY) {
            self.service(tx);
        }
    }

    /// Thread mode's tuning: start-up blocks to the rule, what it asked
    /// for built and swapped in.
    pub fn tune(&mut self) {
        while let Some(b) = self.startup_in.dequeue() {
            self.link.on_startup_block(&b);
        }
        if let Some(t) = self.link.poll(&mut self.device).unwrap() {
            if self.started_at.is_none() {
                self.started_at = Some(t.at);
            }
            self.builds.push(t);
        }
    }

    /// Thread mode's pass: the self-test's blocks, tuning, records and raw
    /// blocks to the link.
    pub fn service(&mut self, tx: &mut Ring) {
        while let Some(b) = self.test_in.dequeue() {
            if let Some(r) = self.link.on_self_test_block(&b, &mut self.device, tx) {
                self.reports.push(r);
            }
        }
        self.tune();
        while let Some(r) = self.records.dequeue() {
            self.link
                .on_record(&r, &bench::OUTPUT_WEIGHT.map(|w| w as f32), tx);
        }
        while let Some(b) = self.raws.dequeue() {
            self.link.on_raw(&b, tx);
        }
    }

    /// Run until sample `until`, the host draining the ring every
    /// `drain_every` samples (0: never) and calling `on` with each batch.
    pub fn run_until(
        &mut self,
        until: u64,
        tx: &mut Ring,
        host: &mut Host,
        drain_every: u64,
        mut on: impl FnMut(&mut Self, &[Message], &mut Ring, &mut Host),
    ) {
        while self.samples < until {
            self.step(tx);
            if drain_every > 0 && self.samples.is_multiple_of(drain_every) {
                let new = host.drain(tx);
                on(self, &new, tx, host);
            }
        }
    }

    /// Send a command as bytes on the RX side (thread mode decodes it).
    pub fn command(&mut self, host: &mut Host, c: &Command, tx: &mut Ring) {
        let bytes = host.command(c);
        self.link.receive(bytes, &mut self.device, tx);
    }
}
