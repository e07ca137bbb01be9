//! The sample interrupt's work (timer 0 at 10 kHz, standing in for the
//! ADS131M02's DRDY): [`SampleTask::on_interrupt`].
//!
//! 1. **The rig** ([`ConverterRig::tick`]): the simulated beam advances one
//!    period with the AD5761R model's held voltage, the ADS131M02 model
//!    converts y(t_k) and the monitor (one DRDY period).
//! 2. **The product** ([`Pipeline::tick`]): the ADS131M02 driver reads that
//!    conversion over its `SpiDevice` (the model), the AD5761R driver writes
//!    the next excitation value, the estimator steps, a telemetry record
//!    goes into the SPSC queue every 100 samples.
//! 3. **Start-up**: the pipeline starts frozen; while thread mode's
//!    tuning rule is in its start-up window ([`COLLECTING`]) every fed
//!    (u, y) pair is copied into blocks of 32 for it
//!    ([`StartupCollector`]: a few stores per sample, no arithmetic). Thread
//!    mode computes U0, Y0 and λ0 from them (`beamest::tuning`, in `f64`),
//!    builds the estimator and swaps it in between two samples
//!    (`DeviceLink::poll`, inside the [`Shared`](beamest::board::qemu::Shared) lock); adaptation then
//!    resumes with the law held until its filters have settled
//!    (`Pipeline::resume`). Re-centrings of λ are built and swapped in the
//!    same way; this handler never builds or reviews anything.
//!
//! Thread mode changes the pipeline only inside the [`Shared`](beamest::board::qemu::Shared) lock that
//! this handler also runs in (the serial link's commands), so every change
//! lands between two samples.
//! 4. **Faults** ([`FAULTS`]): injected into the ADC model at fixed
//!    samples, so the drivers' and the pipeline's fault paths run here too.
//!
//! Instruction spans (SysTick, dithered start): the rig, the chip models'
//! SPI transactions inside the tick ([`MeteredSpi`]), the estimator's step
//! ([`TimedEstimator`]), and the handler from after the dither to the
//! overrun check (fault injection and the book-keeping of these spans come
//! after it). The product's cost is that span minus the rig and the
//! models.

#![deny(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::panic,
    clippy::indexing_slicing
)]

use ad5761r::Ad5761r;
use ads131m02::{Ads131m02, Rail};
use beamest::bench::ConverterRig;
use beamest::board::qemu::cycles::{self, SpanSum};
use beamest::board::qemu::meter::{MeteredSpi, SpiMeter, TimedEstimator};
use beamest::board::qemu::{self as board, Handoff};
use beamest::estimator::robust::{Head, Robust2Compact};
use beamest::estimator::{Adaptive2, Either, Estimator, Health, StepStatus};
use beamest::link::StartupCollector;
use beamest::model::TransferFunction;
use beamest::pipeline::{Counters, Pipeline, RawBlock, TelemetryRecord};
use beamest::rig::chips::{Ad5761rModel, Ads131m02Model, Shared};
use beamest::selftest::{Collector, SelfTestBlock};
use beamest::supervise::Supervision;
use core::sync::atomic::{AtomicBool, Ordering};
use cortex_m::peripheral::NVIC;
use heapless::spsc::Producer;

/// Thread mode's tuning rule wants start-up pairs (set by thread mode
/// from `DeviceLink::collecting_startup`: after the boot self-test, until
/// its window closes).
pub static COLLECTING: AtomicBool = AtomicBool::new(false);
/// A self-test runs: every tick is copied for it (set by thread mode from
/// `DeviceLink::self_test_running`).
pub static SELF_TEST: AtomicBool = AtomicBool::new(false);

/// Parameters of Θ for two modes (eq. 29: 4n − 1) and of packed P.
pub const NP: usize = 7;
/// NP(NP + 1)/2.
pub const NS: usize = 28;
/// Default simulated run length: 5 s at 10 kHz (the CI run).
pub const RUN_SAMPLES: u32 = 50_000;
/// Timer-period check: SysTick across this many periods from sample
/// `PERIOD_FROM` (the interval stays below SysTick's 0.67 s wrap).
pub const PERIOD_FROM: u32 = 10;
/// See [`PERIOD_FROM`].
pub const PERIODS: u32 = 6_000;

/// The robust estimator as the pipeline holds it: the image's one slot, or
/// (only on its way to [`QemuDevice::swap_estimator`](crate::device::QemuDevice::swap_estimator), never stepped by
/// the pipeline) a new estimator's head to be installed into the running
/// slot.
#[derive(Debug)]
pub enum RobustSlot {
    /// The slot: the estimator with its record.
    Slot(&'static mut Robust2Compact<f32>),
    /// A new estimator without a record.
    Head(&'static mut Head<f32, 4, NP, 28>),
}

/// Forward `$call` to the slot's or the head's estimator.
macro_rules! slot {
    ($self:expr, $e:ident => $call:expr) => {
        match $self {
            RobustSlot::Slot($e) => $call,
            RobustSlot::Head($e) => $call,
        }
    };
}

impl Estimator<f32, NP> for RobustSlot {
    /// Out of line: the adaptive law's step, in the same dispatch, keeps
    /// its registers (BENCHMARKS.md, "Firmware on the emulated board").
    #[inline(never)]
    fn step(&mut self, u: f32, y: f32) -> StepStatus {
        slot!(self, e => e.step(u, y))
    }
    fn theta(&self) -> [f32; NP] {
        slot!(self, e => e.theta())
    }
    fn transfer_function(&self) -> TransferFunction<f32> {
        slot!(self, e => e.transfer_function())
    }
    fn reset(&mut self) {
        slot!(self, e => e.reset())
    }
    fn excitation_level(&self) -> Option<f32> {
        slot!(self, e => e.excitation_level())
    }
    fn health(&self) -> Health {
        slot!(self, e => e.health())
    }
    fn information(&self) -> Option<[[f32; NP]; NP]> {
        slot!(self, e => Estimator::information(&**e))
    }
    fn hold(&mut self, samples: u32) {
        slot!(self, e => e.hold(samples))
    }
    fn settling_samples(&self) -> u32 {
        slot!(self, e => e.settling_samples())
    }
    fn supervision(&self) -> Option<Supervision<f32>> {
        slot!(self, e => e.supervision())
    }
}

/// The estimators this image runs (`EstimatorKind` Adaptive or Robust),
/// each in static storage.
pub type Choice = Either<&'static mut Adaptive2<f32>, RobustSlot>;
/// The estimator the pipeline steps: one of [`Choice`], timed.
pub type Est = TimedEstimator<Choice>;
/// The ADS131M02 driver on its model.
pub type AdcDriver = Ads131m02<MeteredSpi<Shared<'static, Ads131m02Model>>>;
/// The AD5761R driver on its model.
pub type DacDriver = Ad5761r<MeteredSpi<Shared<'static, Ad5761rModel>>>;
/// A telemetry record.
pub type Record = TelemetryRecord<f32, NP, NS>;
/// A raw-sample block.
pub type Raw = RawBlock<f32>;
/// A block of the self-test's ticks.
pub type TestBlock = SelfTestBlock<f32>;
/// The pipeline of this image.
pub type RigPipeline = Pipeline<
    f32,
    Est,
    AdcDriver,
    DacDriver,
    Producer<'static, Record>,
    Producer<'static, Raw>,
    NP,
    NS,
>;

/// A fault injected into the ADC model after the tick of `at`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Fault {
    /// The next `n` frames carry a corrupted bit after their CRC.
    BadCrc(u32),
    /// `n` conversions at positive full scale.
    Saturate(u32),
    /// `n` conversions repeat the last one.
    Stuck(u32),
    /// The next `n` conversions do not happen (DRDY stays clear).
    Dropped(u32),
}

/// The schedule: (sample, fault), after convergence and ≥ 0.5 s apart so
/// each quarantine (0.4 s) ends before the next fault.
pub const FAULTS: [(u32, Fault); 4] = [
    (20_000, Fault::BadCrc(10)),
    (25_000, Fault::Saturate(50)),
    (30_000, Fault::Stuck(100)),
    (35_000, Fault::Dropped(5)),
];

/// Every fault of the schedule has been injected, and its quarantine has
/// ended, by this sample (4 s): `cargo xtask qemu` compares the counters
/// with the schedule only for runs at least this long.
pub const FAULTS_DONE_BY: u32 = 40_000;

// Each fault's run plus the 0.4 s quarantine fits before FAULTS_DONE_BY.
const _: () = {
    let mut rest: &[(u32, Fault)] = &FAULTS;
    while let [(at, f), tail @ ..] = rest {
        let n = match *f {
            Fault::BadCrc(n) | Fault::Saturate(n) | Fault::Stuck(n) | Fault::Dropped(n) => n,
        };
        assert!(*at + n + 4_000 <= FAULTS_DONE_BY);
        rest = tail;
    }
};

/// Instruction spans, in SysTick ticks.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Spans {
    /// The simulated beam and the ADC model's conversion (`rig.tick()`).
    pub rig: SpanSum,
    /// The chip models' SPI transactions inside `pipeline.tick()`.
    pub models: SpanSum,
    /// `pipeline.tick()`, models included.
    pub tick: SpanSum,
    /// The estimator's step.
    pub estimator: SpanSum,
    /// The whole handler minus the rig and the models: the product.
    pub product: SpanSum,
}

/// What the handler hands to thread mode at the end of the run.
#[derive(Debug, Clone, Copy)]
pub struct Summary {
    /// Samples run.
    pub samples: u32,
    /// Spans of the samples whose estimator step updated the law.
    pub steady: Spans,
    /// Spans of every sample (start-up, held and rejected samples too).
    pub all: Spans,
    /// SysTick ticks over [`PERIODS`] timer periods.
    pub period_ticks: u32,
    /// Samples whose handler ended with the next one already pending.
    pub overruns: u32,
    /// Rig ticks that failed (a model was busy; never expected).
    pub rig_errors: u32,
    /// The pipeline's counters.
    pub counters: Counters,
    /// The estimate at the end (at the running estimator's λ).
    pub tf: TransferFunction<f32>,
    /// Start-up blocks the queue refused (thread mode too slow).
    pub startup_dropped: u32,
    /// The steps' statuses: [updated, held (frozen), rejected, skipped].
    pub step_counts: [u32; 4],
    /// The line remover's amplitude of each line in y at the end (its
    /// weights), `lines` of them (0: off).
    pub line_amplitudes: [f32; beamest::guard::lines::MAX_LINES],
    /// Lines the remover holds.
    pub lines: usize,
    /// The self-test's copy of each tick (its cost in the handler), over
    /// the ticks it collected.
    pub selftest: SpanSum,
    /// Self-test blocks the queue refused.
    pub selftest_dropped: u32,
}

/// Everything the sample interrupt owns.
pub struct SampleTask {
    rig: ConverterRig<'static>,
    pipeline: RigPipeline,
    startup: StartupCollector<f32>,
    startup_out: Producer<'static, Raw>,
    selftest: Collector<f32>,
    selftest_out: Producer<'static, TestBlock>,
    selftest_span: SpanSum,
    /// SysTick at the previous handler entry.
    last_entry: Option<u32>,
    meter: &'static SpiMeter,
    summary_out: &'static Handoff<Summary>,
    run_samples: u32,
    samples: u32,
    steady: Spans,
    all: Spans,
    period_start: u32,
    period_ticks: u32,
    overruns: u32,
    rig_errors: u32,
    step_counts: [u32; 4],
    finished: bool,
}

impl SampleTask {
    /// The task around a rig and a frozen pipeline (see the module docs),
    /// ending after `run_samples` samples (0: never).
    pub fn new(
        rig: ConverterRig<'static>,
        mut pipeline: RigPipeline,
        meter: &'static SpiMeter,
        startup_out: Producer<'static, Raw>,
        selftest_out: Producer<'static, TestBlock>,
        summary_out: &'static Handoff<Summary>,
        run_samples: u32,
    ) -> Self {
        pipeline.freeze();
        Self {
            rig,
            pipeline,
            startup: StartupCollector::new(),
            startup_out,
            selftest: Collector::new(),
            selftest_out,
            selftest_span: SpanSum::default(),
            last_entry: None,
            meter,
            summary_out,
            run_samples,
            samples: 0,
            steady: Spans::default(),
            all: Spans::default(),
            period_start: 0,
            period_ticks: 0,
            overruns: 0,
            rig_errors: 0,
            step_counts: [0; 4],
            finished: false,
        }
    }

    /// One sample period; `entry` is SysTick at the handler's entry.
    #[inline(never)]
    pub fn on_interrupt(&mut self, entry: u32) {
        if self.finished {
            return;
        }
        let k = self.samples;
        if k == self.run_samples && k > 0 {
            self.finish();
            return;
        }
        if k == PERIOD_FROM {
            self.period_start = entry;
        } else if k == PERIOD_FROM + PERIODS {
            self.period_ticks = cycles::ticks_between(self.period_start, entry);
        }
        // Spread the start over SysTick's 40-instruction tick (see `cycles`).
        cycles::dither(k);
        let t0 = cycles::now();

        // 1. The rig: the beam and the ADC model's conversion.
        if self.rig.tick().is_err() {
            self.rig_errors = self.rig_errors.saturating_add(1);
        }
        let t1 = cycles::now();
        // 2. The product: drivers, pipeline, estimator.
        let m0 = self.meter.ticks();
        let tick = self.pipeline.tick();
        let t2 = cycles::now();
        let models = self.meter.ticks().wrapping_sub(m0);
        // 3. Start-up: the fed pairs out to thread mode's tuning rule;
        // the self-test's copy of the tick (timed on the handler's entry).
        if COLLECTING.load(Ordering::Relaxed) {
            if let Some((u, y)) = tick.fed {
                let out = &mut self.startup_out;
                self.startup.push(u, y, |b| out.enqueue(b).is_ok());
            }
        }
        let elapsed = self
            .last_entry
            .map_or(0, |last| cycles::ticks_between(last, entry));
        self.last_entry = Some(entry);
        if SELF_TEST.load(Ordering::Relaxed) {
            let c0 = cycles::now();
            let out = &mut self.selftest_out;
            self.selftest
                .push(&tick, elapsed, |b| out.enqueue(b).is_ok());
            self.selftest_span.add(c0, cycles::now());
        } else {
            self.selftest.stop();
        }
        if NVIC::is_pending(board::Interrupt::TIMER0) {
            self.overruns = self.overruns.saturating_add(1);
        }
        let t3 = cycles::now();

        // 4. Faults for the next conversions (the rig's; not measured).
        self.inject(k);
        // Book-keeping (not measured).
        let rig = cycles::ticks_between(t0, t1);
        let whole = cycles::ticks_between(t0, t3);
        let est = self.pipeline.estimator().last_ticks();
        let slot = match tick.step {
            Some(StepStatus::Updated) => Some(0),
            Some(StepStatus::Frozen) => Some(1),
            Some(StepStatus::Rejected) => Some(2),
            Some(StepStatus::Skipped) => Some(3),
            None => None,
        };
        if let Some(c) = slot.and_then(|i| self.step_counts.get_mut(i)) {
            *c = c.saturating_add(1);
        }
        let stepped = tick.step.is_some();
        let product = whole.saturating_sub(rig).saturating_sub(models);
        let book = |s: &mut Spans| {
            s.rig.add_ticks(rig);
            s.models.add_ticks(models);
            s.tick.add(t1, t2);
            if stepped {
                s.estimator.add_ticks(est);
            }
            s.product.add_ticks(product);
        };
        book(&mut self.all);
        if slot == Some(0) {
            book(&mut self.steady);
        }
        self.samples = k.wrapping_add(1);
    }

    /// The pipeline (thread mode, inside the [`Shared`](beamest::board::qemu::Shared) lock).
    pub fn pipeline_mut(&mut self) -> &mut RigPipeline {
        &mut self.pipeline
    }

    /// The simulated bench (thread mode, inside the lock: a fault for the
    /// self-test, `selftest_fault=NAME`).
    pub fn rig_mut(&mut self) -> &mut ConverterRig<'static> {
        &mut self.rig
    }

    fn inject(&self, k: u32) {
        for (at, fault) in FAULTS {
            let Ok(mut m) = self.rig.models().adc.try_borrow_mut() else {
                return;
            };
            match fault {
                Fault::BadCrc(n) if k == at => m.inject_bad_crc(n),
                Fault::Saturate(_) if k == at => m.set_saturation(Some(Rail::High)),
                Fault::Saturate(n) if k == at + n => m.set_saturation(None),
                Fault::Stuck(_) if k == at => m.set_stuck(true),
                Fault::Stuck(n) if k == at + n => m.set_stuck(false),
                Fault::Dropped(n) if k == at => m.drop_conversions(n),
                _ => {}
            }
        }
    }

    fn finish(&mut self) {
        self.finished = true;
        let mut line_amplitudes = [0.0; beamest::guard::lines::MAX_LINES];
        let mut lines = 0;
        for (slot, a) in line_amplitudes
            .iter_mut()
            .zip(self.pipeline.line_amplitudes())
        {
            *slot = a;
            lines += 1;
        }
        self.summary_out.put(Summary {
            samples: self.samples,
            steady: self.steady,
            all: self.all,
            period_ticks: self.period_ticks,
            overruns: self.overruns,
            rig_errors: self.rig_errors,
            counters: self.pipeline.counters(),
            tf: self.pipeline.estimator().transfer_function(),
            startup_dropped: self.startup.dropped(),
            step_counts: self.step_counts,
            line_amplitudes,
            lines,
            selftest: self.selftest_span,
            selftest_dropped: self.selftest.dropped(),
        });
    }
}
