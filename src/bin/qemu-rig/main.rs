//! The firmware on the emulated board (QEMU `mps2-an386`, Cortex-M4F,
//! `f32`) with the simulated bench behind the real converter drivers: run
//! with `cargo xtask qemu` (`--e2e`: with the host on the serial link;
//! `--monitor`: with `beamctl monitor` attached).
//!
//! * Boot (thread mode): SysTick calibration; the run length from the
//!   semihosting command line (`seconds=S`, 0 = until stopped; default
//!   5 s); both converters brought up through their drivers against the
//!   chip models (AD5761R reset, control written and read back; ADS131M02
//!   reset with the ID check, configured and read back); the rig, a frozen
//!   pipeline and the sample task built from `beamest::bench`.
//! * Timer 0 interrupt, 10 kHz, highest priority: [`sample::SampleTask`] —
//!   rig tick, then `Pipeline::tick` (the drivers' SPI frames to the
//!   models, the estimator step, telemetry records and raw blocks into
//!   their SPSC queues), inside the [`Shared`] lock.
//! * UART0 interrupts, below it: move bytes between the UART and its rings.
//! * Thread mode, lowest: the serial link ([`beamest::link::DeviceLink`],
//!   `docs/PROTOCOL.md`) on UART0 at 921,600 baud — each record recovered
//!   (ω, ζ, b̄, λmin(P)) and sent as an Estimate at the estimate rate
//!   (default 100 Hz), Status at the status rate (default 1 Hz), raw
//!   samples when enabled, commands decoded, validated, applied between
//!   samples (inside the lock, [`device`]) and acknowledged; the
//!   truth-free tuning rule (`beamest::tuning`, docs/SETTINGS.md): U0, Y0
//!   and λ0 from the start-up window's pairs, the estimator built and
//!   swapped in, λ re-centred on the estimated band with the estimate
//!   carried over (`DeviceLink::poll`); a
//!   human-readable log through semihosting as the estimate converges;
//!   at the end the instruction counts, the link's counters, the cost of an
//!   Estimate frame, and the measured values as `rig:` lines ([`report`]),
//!   which `cargo xtask qemu` judges (fault counters against the schedule,
//!   ω, ζ against the simulated truth); exit status 0 once reported.

#![no_std]
#![no_main]
#![deny(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::panic,
    clippy::indexing_slicing
)]

mod device;
mod numfmt;
mod report;
mod robust;
mod sample;

use ad5761r::Ad5761r;
use ads131m02::Ads131m02;
use beam_protocol::{EstimatorKind, EstimatorSettings};
use beamest::bench::{self, ConverterModels};
use beamest::board::qemu::cycles::{self, SpinDelay};
use beamest::board::qemu::meter::{MeteredSpi, SpiMeter, TimedEstimator};
use beamest::board::qemu::uart::{RxFill, RxRing, TxDrain, TxRing};
use beamest::board::qemu::{self as board, interrupt, timer, Board, Handoff, IsrOwned, Shared};
use beamest::estimator::robust::{Head, Robust2Compact, RobustConfig};
use beamest::estimator::{Adaptive2, AdaptiveConfig, Either};
use beamest::link::{DeviceLink, Settings};
use beamest::pipeline::{bring_up, Pipeline, PipelineConfig};
use beamest::tuning::{LambdaSource, TuningConfig};
use core::mem::MaybeUninit;
use cortex_m_rt::entry;
use cortex_m_semihosting::hprintln;
use heapless::spsc::{Producer, Queue};
use panic_semihosting as _;

use device::QemuDevice;
use numfmt::{Fixed, Sci};
use report::{finish, log, on_build, Run, LOG_EVERY, OUTPUT_WEIGHT};
use sample::{Raw, Record, SampleTask, Summary, TestBlock, COLLECTING, RUN_SAMPLES, SELF_TEST};

/// Telemetry queue size (holds `TELEMETRY_QUEUE − 1` records: 130 ms).
const TELEMETRY_QUEUE: usize = 14;
/// Raw-block queue size (holds 7 blocks of 32 pairs: 22 ms at 10 kHz).
const RAW_QUEUE: usize = 8;
/// Start-up pair queue size (3 blocks of 32 pairs: 9.6 ms at 10 kHz; thread
/// mode's cost per block, under one period's share: BENCHMARKS.md,
/// "Firmware on the emulated board").
/// A refused block is counted and its gap handled (`link::tune`).
const STARTUP_QUEUE: usize = 4;
/// Self-test block queue size (holds 7 blocks of 32 ticks: 22 ms at
/// 10 kHz; thread mode's cost per block: BENCHMARKS.md, "The self-test").
const SELF_TEST_QUEUE: usize = 8;

static SPI_METER: SpiMeter = SpiMeter::new();
// Large states are handed over by `&'static mut` into `singleton!` storage:
// an `Option` of a reference is zero when empty, so these stay in .bss.
static SAMPLE_TASK: Shared<IsrOwned<&'static mut SampleTask>> = Shared::new();
static SUMMARY: Handoff<Summary> = Handoff::new();
static TX_DRAIN: Handoff<TxDrain> = Handoff::new();
static RX_FILL: Handoff<RxFill> = Handoff::new();

#[interrupt]
fn TIMER0() {
    let entry = cycles::now();
    timer::clear_interrupt();
    SAMPLE_TASK.lock(|task| task.get_mut().on_interrupt(entry));
}

#[interrupt]
fn UART0TX() {
    static mut DRAIN: Option<TxDrain> = None;
    if DRAIN.is_none() {
        *DRAIN = TX_DRAIN.take();
    }
    if let Some(d) = DRAIN.as_mut() {
        d.on_interrupt();
    }
}

#[interrupt]
fn UART0RX() {
    static mut FILL: Option<RxFill> = None;
    if FILL.is_none() {
        *FILL = RX_FILL.take();
    }
    if let Some(f) = FILL.as_mut() {
        f.on_interrupt();
    }
}

#[entry]
fn main() -> ! {
    let Some(mut b) = Board::take() else {
        fail("board already taken")
    };
    hprintln!(
        "beamest qemu-rig: mps2-an386, 10 kHz sample interrupt, f32 estimator, \
         ADS131M02/AD5761R drivers on the chip models"
    );
    let cal = cycles::calibrate();
    hprintln!(
        "systick calibration: {} instructions = {} ticks ({} instructions/tick); \
         dithered {}-instruction span measured as {}",
        cal.instructions,
        cal.ticks,
        Fixed(cal.instructions_per_tick().into(), 3),
        cal.dither_instructions,
        Fixed(cal.dither_measured.into(), 2)
    );
    if !cal.is_as_expected() {
        hprintln!(
            "error: expected {} instructions per tick (run QEMU with -icount shift=0,sleep=off)",
            cycles::EXPECTED_INSTRUCTIONS_PER_TICK
        );
        board::exit(false);
    }
    fma_self_check();
    let run_samples = run_length();
    let fault = selftest_fault();

    let (
        Some(tx_ring),
        Some(rx_ring),
        Some(queue),
        Some(raw_queue),
        Some(startup_queue),
        Some(test_queue),
    ) = (
        cortex_m::singleton!(: TxRing = Queue::new()),
        cortex_m::singleton!(: RxRing = Queue::new()),
        cortex_m::singleton!(: Queue<Record, TELEMETRY_QUEUE> = Queue::new()),
        cortex_m::singleton!(: Queue<Raw, RAW_QUEUE> = Queue::new()),
        cortex_m::singleton!(: Queue<Raw, STARTUP_QUEUE> = Queue::new()),
        cortex_m::singleton!(: Queue<TestBlock, SELF_TEST_QUEUE> = Queue::new()),
    )
    else {
        fail("static buffers already taken")
    };
    let (mut tx, drain, fill, mut rx) =
        b.uart0
            .split(timer::PCLK_HZ, board::UART_BAUD, tx_ring, rx_ring);
    TX_DRAIN.put(drain);
    RX_FILL.put(fill);
    // The bench's link, with the robust estimator selectable too.
    let mut link_config = bench::link_config(board::UART_BAUD);
    link_config.limits.estimators |= EstimatorKind::Robust.bit();
    let Ok(mut link) = DeviceLink::new(link_config, default_settings(), &tuning()) else {
        fail("tuning settings")
    };
    let config = PipelineConfig {
        telemetry_every: link.record_every(),
        raw_decimation: link.settings().telemetry.raw_decimation,
        ..bench::pipeline_config()
    };
    let (producer, mut consumer) = queue.split();
    let (raw_producer, mut raw_consumer) = raw_queue.split();
    let (startup_producer, mut startup_consumer) = startup_queue.split();
    let (test_producer, mut test_consumer) = test_queue.split();
    let (task, spare) = build_sample_task(
        &config,
        producer,
        raw_producer,
        startup_producer,
        test_producer,
        run_samples,
    );
    // SAFETY: the chip models were created inside `build_sample_task` and
    // only the task (its rig and its drivers) refers to them.
    SAMPLE_TASK.put(unsafe { IsrOwned::new(task) });
    let (slot, head) = robust_storage();
    let mut device = QemuDevice::new(&SAMPLE_TASK, spare, slot, head);
    // The self-test's fault (`selftest_fault=NAME`), after the bring-up
    // (a wrong ID would stop it), before the self-test.
    if let Some(f) = fault {
        device.with_rig(|rig| f.apply(rig));
        hprintln!("self-test fault injected: {}", f.name());
    }
    // The self-test first: the tuning rule's window opens after it.
    if let Err(e) = link.start_self_test(&mut device, true) {
        hprintln!("error: the self-test could not start: {}", e);
        board::exit(false);
    }
    SELF_TEST.store(true, core::sync::atomic::Ordering::Relaxed);
    hprintln!(
        "serial link: UART0 at {} baud, protocol version {}; estimates {} Hz, status {} Hz, \
         raw samples off (settable by command); run length {} s{}",
        board::UART_BAUD,
        beam_protocol::VERSION,
        Fixed(link.settings().telemetry.estimate_rate_hz.into(), 0),
        Fixed(link.settings().telemetry.status_rate_hz.into(), 0),
        Fixed(f64::from(run_samples) * bench::TS_S, 1),
        if run_samples == 0 {
            " (0: until stopped)"
        } else {
            ""
        }
    );
    Board::unmask();
    b.timer.start(board::SAMPLE_RELOAD);

    let mut next_log: u64 = LOG_EVERY;
    let mut last: Option<Record> = None;
    let mut run = Run::default();
    loop {
        while let Some(record) = consumer.dequeue() {
            let recovered = link.on_record(&record, &OUTPUT_WEIGHT, &mut tx);
            log(
                &record,
                recovered.as_ref(),
                link.has_estimate(),
                &mut next_log,
            );
            last = Some(record);
        }
        while let Some(block) = raw_consumer.dequeue() {
            link.on_raw(&block, &mut tx);
        }
        while let Some(block) = test_consumer.dequeue() {
            let t0 = cycles::now();
            let report = link.on_self_test_block(&block, &mut device, &mut tx);
            run.selftest_blocks.add(t0, cycles::now());
            if let Some(r) = report {
                report::self_test(&r, fault);
            }
        }
        while let Some(block) = startup_consumer.dequeue() {
            if run.first_block.is_none() {
                run.first_block = Some(block);
            }
            link.on_startup_block(&block);
        }
        SELF_TEST.store(
            link.self_test_running(),
            core::sync::atomic::Ordering::Relaxed,
        );
        COLLECTING.store(
            link.collecting_startup(),
            core::sync::atomic::Ordering::Relaxed,
        );
        let (t0, bytes0) = (cycles::now(), link.rx_counters().bytes);
        link.receive(core::iter::from_fn(|| rx.read()), &mut device, &mut tx);
        let bytes = link.rx_counters().bytes - bytes0;
        if bytes > 0 {
            run.receive.add(t0, cycles::now());
            run.received = run.received.saturating_add(bytes);
        }
        // The summary first: nothing is swapped in after the last sample.
        if let Some(summary) = SUMMARY.take() {
            b.timer.stop();
            // Records and raw blocks pushed before the summary are still
            // queued: they go out too.
            while let Some(record) = consumer.dequeue() {
                let recovered = link.on_record(&record, &OUTPUT_WEIGHT, &mut tx);
                log(
                    &record,
                    recovered.as_ref(),
                    link.has_estimate(),
                    &mut next_log,
                );
                last = Some(record);
            }
            while let Some(block) = raw_consumer.dequeue() {
                link.on_raw(&block, &mut tx);
            }
            finish(
                &summary,
                last.as_ref(),
                &cal,
                &run,
                &link,
                &mut device,
                &mut tx,
            );
        }
        if link.settings().estimator.kind == EstimatorKind::Robust {
            run.robust.poll(&mut device);
        }
        match link.poll(&mut device) {
            Ok(Some(t)) => on_build(&t, &link, &mut run),
            Ok(None) => {}
            Err(e) => {
                hprintln!("error: the estimator could not be started: {}", e);
                board::exit(false)
            }
        }
        // Idle by executing, never WFI: under `-icount sleep=off` QEMU 7.2
        // warps virtual time past the next timer deadline while the CPU
        // sleeps, and the sample interrupt then comes every ~200 µs
        // (measured: 4,972.5 SysTick ticks per period instead of 2,500).
        board::idle();
    }
}

/// The run length in samples from the semihosting command line: the word
/// `seconds=S` (S a decimal number of seconds, 0 = run until stopped);
/// [`RUN_SAMPLES`] (5 s) without it.
fn run_length() -> u32 {
    let mut buf = [0u8; 128];
    let line = board::command_line(&mut buf).unwrap_or("");
    let Some(value) = line
        .split_ascii_whitespace()
        .find_map(|w| w.strip_prefix("seconds="))
    else {
        return RUN_SAMPLES;
    };
    match parse_seconds_as_samples(value) {
        Some(n) => n,
        None => {
            hprintln!("error: seconds={}: expected a number of seconds", value);
            board::exit(false)
        }
    }
}

/// The word `hum=1` on the semihosting command line (`cargo xtask qemu
/// --hum`): the rig adds [`bench::HUM`] to y.
fn hum_requested() -> bool {
    let mut buf = [0u8; 128];
    board::command_line(&mut buf)
        .unwrap_or("")
        .split_ascii_whitespace()
        .any(|w| w == "hum=1")
}

/// The self-test's bench fault from the semihosting command line: the word
/// `selftest_fault=NAME` (`beamest::bench::BenchFault`'s names); none
/// without it.
fn selftest_fault() -> Option<bench::BenchFault> {
    let mut buf = [0u8; 128];
    let line = board::command_line(&mut buf).unwrap_or("");
    let name = line
        .split_ascii_whitespace()
        .find_map(|w| w.strip_prefix("selftest_fault="))?;
    match bench::BenchFault::from_name(name) {
        Some(f) => Some(f),
        None => {
            hprintln!("error: selftest_fault={}: no such fault", name);
            board::exit(false)
        }
    }
}

/// "12" or "2.5" seconds → samples at 10 kHz (whole samples, saturating).
fn parse_seconds_as_samples(s: &str) -> Option<u32> {
    let (whole, frac) = s.split_once('.').unwrap_or((s, ""));
    let digits = |t: &str| t.bytes().all(|c| c.is_ascii_digit());
    if whole.is_empty() && frac.is_empty() || !digits(whole) || !digits(frac) {
        return None;
    }
    let rate = u64::from(board::SAMPLE_RATE_HZ);
    let mut samples: u64 = if whole.is_empty() {
        0
    } else {
        whole.parse::<u64>().ok()?.checked_mul(rate)?
    };
    // Fraction digits: at most 4 matter at 10 kHz (0.1 ms).
    let mut scale = rate / 10;
    for c in frac.bytes().take(4) {
        samples = samples.checked_add(u64::from(c - b'0') * scale)?;
        scale /= 10;
    }
    u32::try_from(samples).ok()
}

/// Boot the simulated bench: the chip models, both converters brought up
/// through their drivers, the rig, a frozen pipeline with a stand-in
/// estimator (never stepped, replaced by the tuning rule's first) and the sample
/// task; returns the task and the spare estimator slot. Nothing that
/// refers to the models leaves this function except the task.
fn build_sample_task(
    config: &PipelineConfig,
    producer: Producer<'static, Record>,
    raw_producer: Producer<'static, Raw>,
    startup_producer: Producer<'static, Raw>,
    test_producer: Producer<'static, TestBlock>,
    run_samples: u32,
) -> (&'static mut SampleTask, &'static mut Adaptive2<f32>) {
    let Some(models) = cortex_m::singleton!(: ConverterModels = ConverterModels::new()) else {
        fail("chip models already placed")
    };
    let models: &'static ConverterModels = models;
    let mut adc = Ads131m02::new(MeteredSpi::new(models.adc_spi(), &SPI_METER));
    let mut dac = Ad5761r::new(MeteredSpi::new(models.dac_spi(), &SPI_METER));
    match bring_up(
        &mut adc,
        &mut dac,
        &bench::adc_config(),
        bench::dac_config(),
        &mut SpinDelay,
    ) {
        Ok(up) => hprintln!(
            "converters: ADS131M02 ID {:04X}h, CLOCK/GAIN1/MODE read back; \
             AD5761R control {:03X}h read back (+/-10 V, 0 V)",
            up.adc_id,
            up.dac_control.control.to_bits()
        ),
        Err(e) => {
            hprintln!("error: {}", e);
            board::exit(false);
        }
    }
    let Ok(rig) = bench::converter_rig(models) else {
        fail("rig settings")
    };
    let rig = if hum_requested() {
        hprintln!(
            "rig: hum f1={} a1={} f2={} a2={}",
            Fixed(bench::HUM[0].0, 1),
            Sci(bench::HUM[0].1, 4),
            Fixed(bench::HUM[1].0, 1),
            Sci(bench::HUM[1].1, 4)
        );
        rig.with_hum(&bench::HUM, bench::TS_S)
    } else {
        rig
    };
    // Two estimator slots: the stand-in the frozen pipeline holds, and the
    // spare the real estimator is built into (then they alternate).
    let stand_in = || Adaptive2::<f32>::new(&bench::filter_config(1.0), &AdaptiveConfig::default());
    let (Ok(a), Ok(b)) = (stand_in(), stand_in()) else {
        fail("estimator settings")
    };
    let (Some(stand_in), Some(spare)) = (
        cortex_m::singleton!(: Adaptive2<f32> = a),
        cortex_m::singleton!(: Adaptive2<f32> = b),
    ) else {
        fail("estimator slots already placed")
    };
    let Ok(excitation) = bench::excitation::<f32>() else {
        fail("excitation settings")
    };
    let Ok(pipeline) = Pipeline::new(
        config,
        TimedEstimator::new(Either::Left(stand_in)),
        excitation,
        adc,
        dac,
        producer,
        raw_producer,
    ) else {
        fail("pipeline settings")
    };
    let task = SampleTask::new(
        rig,
        pipeline,
        &SPI_METER,
        startup_producer,
        test_producer,
        &SUMMARY,
        run_samples,
    );
    let Some(task) = cortex_m::singleton!(: SampleTask = task) else {
        fail("sample task already placed")
    };
    (task, spare)
}

/// The robust estimator's slot (its compact record, written where it lies:
/// `new_in`) and head workspace (sizes: BENCHMARKS.md; placeholders until
/// `SetEstimator` builds one, see [`device`]).
fn robust_storage() -> (
    &'static mut Robust2Compact<f32>,
    &'static mut Head<f32, 4, 7, 28>,
) {
    let filter = beamest::filter_bank::FilterConfig {
        timing: beamest::filter_bank::OutputTiming::IDEAL,
        ..bench::filter_config(1.0)
    };
    let cfg = RobustConfig::default();
    let (Some(slot), Ok(head)) = (
        cortex_m::singleton!(: MaybeUninit<Robust2Compact<f32>> = MaybeUninit::uninit()),
        Head::<f32, 4, 7, 28>::new(&filter, &cfg),
    ) else {
        fail("robust estimator storage")
    };
    let (Ok(slot), Some(head)) = (
        Robust2Compact::<f32>::new_in(slot, &filter, &cfg),
        cortex_m::singleton!(: Head<f32, 4, 7, 28> = head),
    ) else {
        fail("robust estimator storage")
    };
    (slot, head)
}

/// The bench's start-up settings with the estimator under the automatic
/// rule (`lambda_rad_s = None`): nothing of the simulated beam's truth.
fn default_settings() -> Settings {
    Settings {
        estimator: EstimatorSettings::default(),
        ..bench::link_settings()
    }
}

/// The tuning rule of this board: its sample period and converter-timing
/// compensation, λ0 from the data (no band known), the core's defaults
/// otherwise (0.2 s window, reviews every 10 ms, docs/SETTINGS.md).
fn tuning() -> TuningConfig {
    TuningConfig {
        timing: bench::output_timing(),
        ..TuningConfig::new(bench::TS_S, LambdaSource::Data)
    }
}

/// The fused multiply-add of the core (`Real::mul_add`, `VFMA.F32` in this
/// image) against results computed on the host by `libm::fmaf`, bit for
/// bit: rounded once, including where the unfused a·b + c gives 0 (the
/// first three, the exact errors of products) and a subnormal result.
/// Fails the run on any difference.
fn fma_self_check() {
    use beamest::Real;
    // (a, b, c, fma(a, b, c)) as bit patterns.
    const TRIPLES: [(u32, u32, u32, u32); 6] = [
        (0x3f80_0001, 0x3f80_0001, 0xbf80_0002, 0x2880_0000), // (1+2⁻²³)² − (1+2⁻²²) = 2⁻⁴⁶
        (0x3dcc_cccd, 0x4040_0000, 0xbe99_999a, 0xb200_0000), // 0.1·3 − 0.3
        (0x3f8c_cccd, 0x4053_3333, 0xc068_51ec, 0xb3bd_70a4), // 1.1·3.3 − fl(1.1·3.3)
        (0xbeaa_aaaa, 0x403f_fe5d, 0x3f80_0000, 0x380b_eaaa), // 1 − 0.3333333·2.9999
        (0x1e3c_e508, 0x1e3c_e508, 0x000a_e398, 0x000b_fa5a), // 1e-20² + 1e-39 (subnormal)
        (0x4b7f_ffff, 0x4b7f_fffd, 0xd6b5_e621, 0x5725_0cec), // 24-bit integers, product − 1e14
    ];
    for (a, b, c, want) in TRIPLES {
        let (a, b, c) = (f32::from_bits(a), f32::from_bits(b), f32::from_bits(c));
        let got = a.mul_add(b, c).to_bits();
        if got != want || a.mul_sub(b, -c).to_bits() != want {
            hprintln!(
                "error: fused multiply-add {:e}·{:e} + {:e} = bits {:#010x}, expected {:#010x}",
                a,
                b,
                c,
                got,
                want
            );
            board::exit(false);
        }
    }
    hprintln!(
        "fma self-check: {} fixed triples rounded once, as on the host",
        TRIPLES.len()
    );
}

/// Log and exit with failure (boot errors, broken invariants).
pub fn fail(what: &str) -> ! {
    hprintln!("error: {}", what);
    board::exit(false)
}
