//! The rig firmware for the reference board (NUCLEO-H743ZI2 + ADS131M02 +
//! AD5761R): `cargo nucleo` (or `cargo xtask flash`) builds it for the
//! Cortex-M7, flashes it through probe-rs and shows its defmt log.
//!
//! * **`EXTI3` (DRDY, 10 kHz, highest priority):** one
//!   [`Pipeline::tick`] per conversion — read the ADS131M02 frame, write
//!   the next excitation value to the AD5761R, screen and convert, step the
//!   `f64` estimator, push telemetry — timed with the DWT cycle counter.
//!   Missed conversions (gaps between entries) are reported to the
//!   pipeline as overruns; DRDY pending again at the end of the handler
//!   (the next conversion came before the work was done) is counted as a
//!   late tick.
//! * **`USART3` (below it):** moves bytes between the link's rings and the
//!   USART FIFOs.
//! * **Thread mode (lowest):** start-up (bridge null offset), the
//!   truth-free tuning rule (U0, Y0, λ0 from the start-up window, λ
//!   re-centred on the estimated band: `beamest::tuning`, docs/SETTINGS.md),
//!   and the serial link ([`beamest::link::DeviceLink`] on USART3,
//!   docs/PROTOCOL.md, the same code as the QEMU image): each record
//!   recovered (eqs. 30–32, λmin(P)) and sent as an Estimate at the
//!   estimate rate, Status at the status rate, raw samples when enabled,
//!   commands decoded, validated, applied between samples ([`link`]) and
//!   acknowledged; the robust estimator's model updates when it runs
//!   (`SetEstimator` kind Robust: `f64`, its two slots in the AXI SRAM and
//!   SRAM1–3, `robust_slots`; `RobustUpdates` in chunks of
//!   `ROBUST_CHUNK` units per lock); a defmt log once a second; ADC
//!   re-initialisation after a
//!   device reset; a warning when no sample has come for 0.5 s (SysTick
//!   wakes it even then).
//!
//! # Start-up
//! 1. Board (after a boot log line): clocks, CLKIN, pins, buses (chip
//!    selects high first); converters reset by their pins.
//! 2. AD5761R: software reset, ±10 V, output at mid-scale (0 V); the
//!    control register read back at 1.5625 MHz.
//! 3. ADS131M02: software reset (reply and ID checked), configuration read
//!    back: OSR 256, high resolution → 10 kSPS from the 5.12 MHz CLKIN.
//! 4. Bridge null offset: the ADC's output FIFO drained (configuration was
//!    a pause in reading: [`resync`]), then the mean of
//!    [`rig::NULL_SAMPLES`] conversions, read by polling DRDY, with the DAC
//!    at 0 V (the paper's "bridge offset nulling").
//! 5. The FIFO drained again (the pipeline and the link took milliseconds
//!    to build), the DRDY interrupt enabled.
//! 6. The pipeline starts in the sample interrupt with the excitation on
//!    and adaptation frozen; while the tuning rule's start-up window is
//!    open (0.2 s) the interrupt copies the fed (u, y) pairs into blocks
//!    for thread mode ([`beamest::link::StartupCollector`]); thread mode
//!    computes U0, Y0, λ0 from them, builds the estimator (outside the
//!    lock), swaps it in and resumes adaptation (`DeviceLink::poll`), with
//!    the law held while its filters settle on the moving beam (the quarantine).
//!    Re-centrings of λ are built and swapped in the same way.
//!
//! Any start-up failure drives the DAC to 0 V (CLEAR), lights LD3 and
//! halts with a defmt error saying what failed.

#![no_std]
#![no_main]
#![deny(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::panic,
    clippy::indexing_slicing
)]

// The estimator runs in f64: without the M7's double-precision FPU
// (`-C target-cpu=cortex-m7`) every f64 operation would be a library call
// (measured: 24,842 instructions per step instead of 716, `cargo xtask
// fp-bench`). Clippy only checks, so it may go without.
#[cfg(not(any(beamest_cortex_m7, clippy)))]
compile_error!(
    "nucleo-rig must be built with `-C target-cpu=cortex-m7` (the estimator runs in f64 on \
     the M7's double-precision FPU): use `cargo nucleo`, `cargo xtask flash` or \
     `cargo xtask firmware`"
);

mod link;
mod rig;

use ad5761r::Ad5761r;
use beam_protocol::EstimatorKind;
use beamest::board::nucleo::converters::{resync, Adc};
use beamest::board::nucleo::cycles::{self, Spans};
use beamest::board::nucleo::shared::Shared;
use beamest::board::nucleo::{self as board, clocks, drdy, uart, Board, SpiDev};
use beamest::estimator::robust::{ExternalUpdates, Phase, RobustEstimator};
use beamest::estimator::{Adaptive2, Either};
use beamest::link::{
    robust_configs, BuildKind, DeviceLink, RobustUpdates, StartupCollector, Tuned,
};
use beamest::pipeline::{recover, Counters, Pipeline, RawBlock, Recovered, TelemetryRecord};
use beamest::selftest::{Collector, SelfTestBlock};
use core::mem::MaybeUninit;
use core::sync::atomic::{AtomicBool, AtomicU32, Ordering};
use cortex_m_rt::{entry, exception, ExceptionFrame};
use defmt::{error, info, warn, Debug2Format};
use defmt_rtt as _;
use embassy_stm32::interrupt;
use heapless::spsc::{Producer, Queue};
use panic_probe as _;

use link::NucleoDevice;

/// Θ entries for two modes (eq. 29: 4n − 1).
pub(crate) const NP: usize = 7;
/// Packed upper triangle of P: NP(NP + 1)/2.
const NS: usize = NP * (NP + 1) / 2;
/// Telemetry queue (holds 7 records: 70 ms at 100 Hz).
const TELEMETRY_QUEUE: usize = 8;
/// Raw-block queue (holds 7 blocks: 22 ms at one block per 32 samples).
const RAW_QUEUE: usize = 8;
/// Start-up pair queue (holds 7 blocks of 32 pairs: 22 ms).
const STARTUP_QUEUE: usize = 8;
/// Self-test block queue (holds 7 blocks of 32 ticks: 22 ms).
const SELF_TEST_QUEUE: usize = 8;
/// Polling DRDY at start-up gives up after this long (µs). The longest
/// wait is the first, right after `Ads131m02::configure`: a conversion
/// still running at the reset-default OSR 1024 takes up to
/// 2·1024/5.12 MHz = 400 µs (CLOCK reset value 030Eh, ADS131M02 data sheet
/// Table 8-12; f_DATA = f_CLKIN/(2·OSR), §8.3.7), and if the CLOCK write
/// restarts the filter the sinc3 needs three periods at OSR 256 to fill,
/// 3·100 µs (§8.3.7.1; whether the write restarts it is not stated in what
/// could be read): 700 µs at worst, so 2 ms leaves a margin of 2.8. The
/// timeout only ever ends a boot that has no DRDY at all (no CLKIN, no
/// ADC), so a long one costs nothing.
const DRDY_TIMEOUT_US: u32 = 2_000;
/// The longest thread mode waits for a sample tick before a log frame
/// ([`between_samples`]): two sample periods (cycles).
const LOG_WAIT_CYCLES: u32 = 2 * clocks::CYCLES_PER_SAMPLE;
/// Records per status log line (1 s at 100 Hz).
const LOG_EVERY_RECORDS: u32 = 100;
/// No telemetry record for this long (cycles, 0.5 s): DRDY has stopped.
const STALL_CYCLES: u32 = clocks::CPU_HZ / 2;
/// Conversions discarded after the ADC's reset before the null-offset
/// average: the first two come from its fast-settling filter, the sinc3
/// then needs three conversions to fill (ADS131M02 §8.3.7.1).
const SETTLE_FRAMES: u32 = 4;

/// The robust estimator's start-up record on this board: 1.8 s at 10 kHz
/// (the host's default is 2 s). Two slots of `f64` are needed (one runs, the
/// next is built beside it), 292,856 B each: one fills most of the AXI
/// SRAM (512 KiB), the other most of SRAM1–3 (288 KiB = 294,912 B), and 2 s
/// (324,856 B) would not fit the second. `f64` because the M7's FPU is
/// double precision and the pipeline runs in `f64` (the `f32` form needs
/// double-word sums for the same accuracy, `beamest::estimator::robust`).
pub(crate) const ROBUST_RECORD: usize = 18_000;
/// The robust estimator of this board (two modes).
pub(crate) type RobustSlot = RobustEstimator<f64, 4, NP, NS, ROBUST_RECORD>;
/// The estimator the pipeline steps: the adaptive law by value, or the
/// robust estimator in its static slot, its model updates in thread mode
/// (`ExternalUpdates`: none inside the sample interrupt).
pub(crate) type Est = Either<Adaptive2<f64>, ExternalUpdates<&'static mut RobustSlot>>;
/// Units (a replayed or fitted sample, or a refinement step) per catch-up
/// lock of a robust model update. Not measured on the board: on the
/// Cortex-M4F in `f32` a unit is 2,000–4,000 instructions
/// (`cargo xtask robust-bench`); 4 of them at that count is ≲ 16,000 of
/// the 40,000 cycles of a sample period at 400 MHz, beside the sample
/// interrupt's few thousand. The status line's late-sample counter shows
/// whether a lock ever pushed a tick past its period.
const ROBUST_CHUNK: usize = 4;
/// Most units left to do inside the installing lock.
const ROBUST_APPLY_MAX: usize = 4;

type Record = TelemetryRecord<f64, NP, NS>;
pub(crate) type RigPipeline = Pipeline<
    f64,
    Est,
    Adc<SpiDev>,
    Ad5761r<SpiDev>,
    Producer<'static, Record>,
    Producer<'static, RawBlock<f64>>,
    NP,
    NS,
>;

/// Everything the sample interrupt owns.
pub(crate) struct SampleTask {
    pub(crate) pipeline: RigPipeline,
    /// The start-up window's pairs for thread mode's tuning rule.
    startup: StartupCollector<f64>,
    startup_out: Producer<'static, RawBlock<f64>>,
    /// The self-test's copy of each tick.
    selftest: Collector<f64>,
    selftest_out: Producer<'static, SelfTestBlock<f64>>,
    last_entry: Option<u32>,
    isr: Spans,
    late: u32,
}

/// The serial interrupt's two ring ends.
struct SerialIsr {
    drain: uart::TxDrain,
    fill: uart::RxFill,
}

// The task (kilobytes) lives in `singleton!` storage and is shared by
// reference: an empty `Option<&mut _>` is zero, so this static stays in
// .bss instead of carrying the task's size of .data initialiser.
pub(crate) static SAMPLE: Shared<&'static mut SampleTask> = Shared::new();
static SERIAL: Shared<SerialIsr> = Shared::new();
/// Thread mode's tuning rule wants start-up pairs (set from
/// `DeviceLink::collecting_startup`: after the self-test at start-up).
static COLLECTING: AtomicBool = AtomicBool::new(false);
/// A self-test runs: each tick is copied for it (set from
/// `DeviceLink::self_test_running`).
static SELF_TEST: AtomicBool = AtomicBool::new(false);
/// Sample ticks completed (wraps): thread mode's cue that a sample period
/// has just begun and the sample interrupt is done with it.
static TICKS: AtomicU32 = AtomicU32::new(0);

#[interrupt]
fn EXTI3() {
    let entry = cycles::now();
    drdy::clear_pending();
    SAMPLE.with(|task| {
        let mut gap = 0;
        if let Some(last) = task.last_entry {
            gap = cycles::between(last, entry);
            let missed = cycles::missed_periods(gap, clocks::CYCLES_PER_SAMPLE);
            if missed > 0 {
                task.pipeline.note_overrun(missed);
                // The missed conversions may still be queued in the ADC's
                // FIFO: this tick's read catches up (one extra frame).
                task.pipeline.converters_mut().0.driver().note_pause();
            }
        }
        task.last_entry = Some(entry);
        let tick = task.pipeline.tick();
        if COLLECTING.load(Ordering::Relaxed) {
            if let Some((u, y)) = tick.fed {
                let out = &mut task.startup_out;
                task.startup.push(u, y, |b| out.enqueue(b).is_ok());
            }
        }
        // Each entry is a DRDY edge; the self-test times them on the DWT.
        if SELF_TEST.load(Ordering::Relaxed) {
            let out = &mut task.selftest_out;
            task.selftest.push(&tick, gap, |b| out.enqueue(b).is_ok());
        } else {
            task.selftest.stop();
        }
        if drdy::is_pending() {
            task.late = task.late.saturating_add(1);
        }
        task.isr.add(cycles::between(entry, cycles::now()));
    });
    TICKS.fetch_add(1, Ordering::Release);
}

#[interrupt]
fn USART3() {
    SERIAL.with(|s| {
        s.fill.on_interrupt();
        s.drain.on_interrupt();
    });
}

#[exception]
fn SysTick() {
    // Only wakes thread mode from `wfi` (see `board::WAKE_HZ`).
}

#[exception]
unsafe fn HardFault(_frame: &ExceptionFrame) -> ! {
    // A fault (panic-probe ends in one too): piezo to 0 V, then stop.
    board::safe_state();
    loop {
        cortex_m::asm::nop();
    }
}

#[entry]
fn main() -> ! {
    // Before the clock set-up: Board::init waits for the HSE, the ST-LINK's
    // 8 MHz MCO on PH0, without a timeout; this line shows it got that far.
    info!("beamest nucleo-rig: boot; clock set-up next (HSE = ST-LINK MCO, 8 MHz on PH0)");
    let mut b = match Board::init() {
        Ok(b) => b,
        Err(e) => fatal("board", Debug2Format(&e)),
    };
    info!(
        "beamest nucleo-rig: CPU {} Hz, CLKIN {} Hz, OSR {} -> {} SPS, {} cycles/sample, \
         USART3 {} Bd (BRR {}), ADC SCLK {} Hz, DAC SCLK {} Hz",
        clocks::CPU_HZ,
        clocks::CLKIN_HZ,
        clocks::ADC_OSR,
        clocks::SAMPLE_RATE_HZ,
        clocks::CYCLES_PER_SAMPLE,
        clocks::BAUD,
        clocks::USART3_BRR,
        clocks::ADC_SCLK_HZ,
        clocks::DAC_SCLK_HZ
    );

    let mut dac = Ad5761r::new(b.dac_spi);
    let readback = match dac.init(rig::dac_config()) {
        Ok(r) => r,
        Err(e) => fatal("AD5761R init", Debug2Format(&e)),
    };
    info!("AD5761R: control read back {}", readback);
    if let Err(e) = board::dac_write_clock(dac.spi_mut()) {
        fatal("AD5761R write clock", Debug2Format(&e));
    }

    let mut adc = match Adc::new(b.adc_spi, rig::adc_config(), &mut b.delay) {
        Ok(a) => a,
        Err(e) => fatal("ADS131M02 reset/configure", Debug2Format(&e)),
    };
    info!("ADS131M02: reset, configured {}", rig::adc_config());

    let null_offset_v = match measure_null(&mut adc, &b.drdy) {
        Ok(v) => v,
        Err(e) => fatal("bridge null offset", e),
    };

    let (Some(telemetry), Some(raw), Some(startup), Some(tests), Some(tx_ring), Some(rx_ring)) = (
        cortex_m::singleton!(: Queue<Record, TELEMETRY_QUEUE> = Queue::new()),
        cortex_m::singleton!(: Queue<RawBlock<f64>, RAW_QUEUE> = Queue::new()),
        cortex_m::singleton!(: Queue<RawBlock<f64>, STARTUP_QUEUE> = Queue::new()),
        cortex_m::singleton!(: Queue<SelfTestBlock<f64>, SELF_TEST_QUEUE> = Queue::new()),
        cortex_m::singleton!(: uart::TxRing = Queue::new()),
        cortex_m::singleton!(: uart::RxRing = Queue::new()),
    ) else {
        fatal("static buffers", "taken twice")
    };
    let (telemetry_tx, mut telemetry_rx) = telemetry.split();
    let (raw_tx, mut raw_rx) = raw.split();
    let (startup_tx, mut startup_rx) = startup.split();
    let (test_tx, mut test_rx) = tests.split();

    let mut link =
        match DeviceLink::new(link::link_config(), link::start_settings(), &link::tuning()) {
            Ok(l) => l,
            Err(e) => fatal("tuning settings", e),
        };
    let pipeline = match build_pipeline(null_offset_v, &link, adc, dac, telemetry_tx, raw_tx) {
        Ok(p) => p,
        Err(e) => fatal("pipeline", e),
    };
    let task = SampleTask {
        pipeline,
        startup: StartupCollector::new(),
        startup_out: startup_tx,
        selftest: Collector::new(),
        selftest_out: test_tx,
        last_entry: None,
        isr: Spans::default(),
        late: 0,
    };
    let Some(task) = cortex_m::singleton!(: SampleTask = task) else {
        fatal("sample task", "placed twice")
    };
    if SAMPLE.put(task).is_err() {
        fatal("sample task", "not placed");
    }

    let (mut tx, drain, fill, mut rx) = b.uart.split(tx_ring, rx_ring);
    if SERIAL.put(SerialIsr { drain, fill }).is_err() {
        fatal("serial task", "not placed");
    }
    let mut device = NucleoDevice::new(robust_slots());
    let mut robust_updates = RobustUpdates::<f64, Spans>::new(ROBUST_CHUNK, ROBUST_APPLY_MAX);
    board::enable_serial_interrupt();
    // Milliseconds have passed since the null measurement's last read: the
    // ADC's FIFO is full. Drain it and drop the old DRDY edges right before
    // the sample interrupt starts, or every tick would read the conversion
    // before the one it was raised for.
    match SAMPLE.with(|t| resync(t.pipeline.converters_mut().0.driver(), &b.drdy)) {
        Some(Ok(_)) => {}
        Some(Err(e)) => fatal(
            "ADS131M02 drain before the sample interrupt",
            Debug2Format(&e),
        ),
        None => fatal("sample task", "not placed"),
    }
    board::enable_sample_interrupt();
    between_samples();
    info!(
        "sample interrupt running; serial link on USART3 at {} Bd, protocol version {}; \
         self-test, then the tuning rule's start-up window {} s",
        clocks::BAUD,
        beam_protocol::VERSION,
        link.tuner().rule().config().startup_s
    );
    // The self-test first (docs/RIG.md, "Bring-up"); the window opens
    // after it.
    if let Err(e) = link.start_self_test(&mut device, true) {
        fatal("self-test start", e);
    }
    SELF_TEST.store(true, Ordering::Relaxed);

    let mut records: u32 = 0;
    let mut last_record = cycles::now();
    loop {
        while let Some(block) = test_rx.dequeue() {
            if let Some(r) = link.on_self_test_block(&block, &mut device, &mut tx) {
                report_self_test(&r, &mut b.led_fault);
            }
        }
        while let Some(block) = startup_rx.dequeue() {
            link.on_startup_block(&block);
        }
        SELF_TEST.store(link.self_test_running(), Ordering::Relaxed);
        COLLECTING.store(link.collecting_startup(), Ordering::Relaxed);
        while let Some(record) = telemetry_rx.dequeue() {
            last_record = cycles::now();
            records = records.wrapping_add(1);
            let recovered = link.on_record(&record, &rig::OUTPUT_WEIGHT, &mut tx);
            if records % LOG_EVERY_RECORDS == 0 {
                report(&record, recovered, &link);
                if link.settings().estimator.kind == EstimatorKind::Robust {
                    report_robust(&robust_updates, &mut device);
                }
                b.led_heartbeat.toggle();
                if record.counters != Counters::default() {
                    b.led_fault.set_high();
                }
                service_adc(&mut b.delay, &b.drdy);
            }
        }
        while let Some(block) = raw_rx.dequeue() {
            link.on_raw(&block, &mut tx);
        }
        link.receive(core::iter::from_fn(|| rx.read()), &mut device, &mut tx);
        if link.settings().estimator.kind == EstimatorKind::Robust {
            robust_updates.poll(&mut device);
        }
        match link.poll(&mut device) {
            Ok(Some(t)) => {
                between_samples();
                log_build(&t, &link);
            }
            Ok(None) => {}
            Err(e) => fatal("estimator start", e),
        }
        if cycles::between(last_record, cycles::now()) > STALL_CYCLES {
            // Re-armed every 0.5 s, so the difference never wraps.
            last_record = cycles::now();
            b.led_fault.set_high();
            between_samples();
            warn!("no sample for 0.5 s: DRDY stopped (CLKIN, ADC supply, wiring?)");
            // A self-test waiting for samples ends with what it has.
            if let Some(r) = link.abort_self_test(&mut device, &mut tx) {
                report_self_test(&r, &mut b.led_fault);
            }
        }
        // Woken by the next interrupt (DRDY every 100 µs, SysTick every 10 ms).
        cortex_m::asm::wfi();
    }
}

/// The pipeline, adaptation frozen until the tuning rule's first estimator
/// is swapped in (the placeholder estimator uses the front end's a priori
/// scale and is never stepped); records and raw samples at the link's
/// rates.
fn build_pipeline(
    null_offset_v: f64,
    link: &DeviceLink,
    adc: Adc<SpiDev>,
    dac: Ad5761r<SpiDev>,
    telemetry: Producer<'static, Record>,
    raw: Producer<'static, RawBlock<f64>>,
) -> Result<RigPipeline, &'static str> {
    let placeholder = rig::estimator(rig::nominal_y_scale())
        .map(Either::Left)
        .map_err(|_| "estimator settings")?;
    let excitation = rig::excitation().map_err(|_| "excitation settings")?;
    let config = beamest::pipeline::PipelineConfig {
        telemetry_every: link.record_every(),
        raw_decimation: link.settings().telemetry.raw_decimation,
        ..rig::pipeline_config(null_offset_v)
    };
    let mut pipeline = Pipeline::new(&config, placeholder, excitation, adc, dac, telemetry, raw)
        .map_err(|_| "pipeline settings")?;
    pipeline.freeze();
    Ok(pipeline)
}

/// The robust estimator's two slots, one in the AXI SRAM (`.axisram`), one
/// in SRAM1–3 (`.sram123`); both sections are zeroed at boot
/// (`Board::init`), so the singletons' `taken` flags start false. Each
/// holds a placeholder (the default settings) until `SetEstimator` kind
/// Robust rebuilds it in place ([`NucleoDevice`]). The placeholder is
/// written where it lies (`RobustEstimator::new_in`): `cargo xtask
/// firmware` checks that no stack frame of the image is as large as a slot.
fn robust_slots() -> [Option<&'static mut RobustSlot>; 2] {
    let (filter, law) = robust_configs::<NP>(
        &beam_protocol::EstimatorSettings::default(),
        rig::PLACEHOLDER_LAMBDA_RAD_S,
        &beamest::filter_bank::FilterConfig {
            ts_s: rig::TS_S,
            ..beamest::filter_bank::FilterConfig::default()
        },
    );
    let (Some(a), Some(b)) = (
        cortex_m::singleton!(#[link_section = ".axisram"] : MaybeUninit<RobustSlot> =
            MaybeUninit::uninit()),
        cortex_m::singleton!(#[link_section = ".sram123"] : MaybeUninit<RobustSlot> =
            MaybeUninit::uninit()),
    ) else {
        fatal("robust estimator slots", "placed twice")
    };
    let (Ok(a), Ok(b)) = (
        RobustSlot::new_in(a, &filter, &law),
        RobustSlot::new_in(b, &filter, &law),
    ) else {
        fatal("robust estimator slots", "settings")
    };
    [Some(a), Some(b)]
}

/// The robust estimator's phase and model updates (with a status line).
fn report_robust(u: &RobustUpdates<f64, Spans>, dev: &mut NucleoDevice) {
    use beamest::link::RobustAccess;
    let Some((phase, updates, recorded)) =
        dev.with_robust(|r| (r.phase(), r.updates(), r.recorded()))
    else {
        return;
    };
    let phase = match phase {
        Phase::Startup => "startup",
        Phase::Refining => "refining",
        Phase::Steady => "steady",
    };
    between_samples();
    info!(
        "robust: phase {}, {} model updates, {} of {} samples recorded; updates {} seeded, {} \
         installed, {} still moving, {} refused, {} chunks; longest lock {} cycles",
        phase,
        updates,
        recorded,
        ROBUST_RECORD,
        u.seeded,
        u.applied,
        u.not_converged,
        u.refused,
        u.chunks,
        u.locks.max
    );
}

/// A self-test's report on the log (docs/RIG.md, "Bring-up"); LD3 on if a
/// check did not pass.
fn report_self_test(
    r: &beam_protocol::SelfTestReport,
    led_fault: &mut embassy_stm32::gpio::Output<'static>,
) {
    between_samples();
    if r.passed() {
        info!(
            "self-test (samples {}-{}): every check passed",
            r.first_sample, r.last_sample
        );
    } else {
        warn!(
            "self-test (samples {}-{}): failed {=u16:#x}, not measured {=u16:#x} (bits: adc_id, \
             adc_registers, drdy_rate, loopback, noise)",
            r.first_sample, r.last_sample, r.failed.0, r.not_measured.0
        );
        led_fault.set_high();
    }
    between_samples();
    info!(
        "self-test: ADC ID {=u16:#x}, MODE CLOCK GAIN1 {:#x} (configured {:#x}); DRDY {} Hz ({} \
         conversions in {} ticks)",
        r.adc.id, r.adc.registers, r.adc.expected, r.drdy.rate_hz, r.drdy.conversions, r.drdy.ticks
    );
    between_samples();
    info!(
        "self-test: loopback gain {} offset {} V delay {} samples (expected {}); noise {} (floor \
         {}), RMS {} under the start-up excitation, SNR {} dB (at least {})",
        r.loopback.gain,
        r.loopback.offset_v,
        r.loopback.delay_samples,
        r.loopback.expected_delay_samples,
        r.noise.noise_sd,
        r.noise.floor_sd,
        r.noise.signal_rms,
        r.noise.snr_db,
        r.noise.snr_min_db
    );
}

/// Log an estimator the tuning rule swapped in.
fn log_build(t: &Tuned, link: &DeviceLink) {
    let f = &t.filter;
    match t.kind {
        BuildKind::First => info!(
            "start-up: U0 = {} V, Y0 = {} (RMS of u, y over {} samples, {} rejected); lambda = {} \
             rad/s ({}); estimator running from sample {}",
            f.scales.u_scale,
            f.scales.y_scale,
            link.tuner().rule().stats().samples(),
            link.tuner().rule().stats().rejected(),
            f.lambda_rad_s,
            if link.is_automatic() {
                "automatic"
            } else {
                "commanded"
            },
            t.at
        ),
        BuildKind::Recentre => info!(
            "tuning: lambda re-centred on the estimated band: {} rad/s, estimate carried over; \
             running from sample {}",
            f.lambda_rad_s, t.at
        ),
    }
}

/// One status line: the recovered modes, λmin(P), the counters, the
/// sample interrupt's cycles (since the previous line) and the link.
fn report(record: &Record, recovered: Option<Recovered<f64>>, link: &DeviceLink) {
    let r = recovered.unwrap_or_else(|| recover(record, &rig::OUTPUT_WEIGHT));
    let t_s = record.sample_index as f64 * rig::TS_S;
    between_samples();
    match r.modal {
        Ok(m) => {
            let [w1, w2, ..] = m.omega_rad_s;
            let [z1, z2, ..] = m.zeta;
            info!(
                "t = {} s: omega = [{}, {}] rad/s, zeta = [{}, {}], lambda_min(P) = {}",
                t_s, w1, w2, z1, z2, r.excitation_min_eig
            );
        }
        Err(e) => info!("t = {} s: no modes ({})", t_s, e),
    }
    let stats = SAMPLE.with(|t| {
        let s = (t.isr, t.late);
        t.isr = Spans::default();
        s
    });
    if let Some((isr, late)) = stats {
        between_samples();
        info!(
            "sample isr: mean {} max {} cycles of {} ({} late); counters {}",
            isr.mean(),
            isr.max,
            clocks::CYCLES_PER_SAMPLE,
            late,
            Debug2Format(&record.counters)
        );
    }
    let (accepted, rejected) = link.commands();
    let tx = link.tx_stats();
    between_samples();
    info!(
        "link: {} frames ({} bytes) sent, {} dropped; uart {}; received {} frames, {} bad; \
         commands {} accepted, {} rejected; lambda {} rad/s",
        tx.frames_sent,
        tx.bytes_sent,
        tx.frames_dropped,
        uart::link_stats(),
        link.rx_counters().frames_ok,
        link.rx_counters().errors(),
        accepted,
        rejected,
        link.lambda_rad_s()
    );
}

/// Re-initialise the ADC between samples if it reset itself (at most once
/// per status line). The interrupt is locked out for about ten frames; the
/// conversions it misses are counted as an overrun by the next tick. The
/// pause leaves conversions in the ADC's FIFO: [`resync`] drains them in
/// the same lock, so the next tick reads its own conversion.
fn service_adc(delay: &mut board::cycles::CycleDelay, drdy: &drdy::Drdy) {
    let needed = SAMPLE
        .with(|t| t.pipeline.converters_mut().0.needs_reinit())
        .unwrap_or(false);
    if !needed {
        return;
    }
    between_samples();
    warn!("ADS131M02 lost its settings: re-initialising");
    let result = SAMPLE.with(|t| {
        let adc = &mut t.pipeline.converters_mut().0;
        adc.reinit(delay).is_ok() && resync(adc.driver(), drdy).is_ok()
    });
    if result != Some(true) {
        between_samples();
        error!("ADS131M02 re-initialisation failed; retrying in 1 s");
    }
}

/// Why the null-offset measurement failed.
#[derive(Debug, defmt::Format)]
enum NullError {
    /// DRDY never went low: no CLKIN, ADC unpowered or miswired.
    NoDrdy,
    /// Too many bad frames.
    Frames,
    /// The configured scale is invalid.
    Scale,
    /// Draining the ADC's FIFO after configuration failed (the logged
    /// error line before says why).
    Drain,
}

/// Mean bridge voltage over [`rig::NULL_SAMPLES`] conversions, each read
/// after a DRDY edge (polled: the sample interrupt is not enabled yet).
/// Configuration was a pause in reading: the ADC's FIFO is drained first,
/// so each frame carries the conversion its edge announced.
fn measure_null(adc: &mut Adc<SpiDev>, drdy: &drdy::Drdy) -> Result<f64, NullError> {
    let volts_per_code = rig::conversion(0.0)
        .bridge_adc
        .volts_per_code()
        .map_err(|_| NullError::Scale)?;
    let mut sum: i64 = 0;
    let mut monitor: i64 = 0;
    let mut n: u32 = 0;
    let mut bad: u32 = 0;
    if let Err(e) = resync(adc.driver(), drdy) {
        error!("ADS131M02 drain after configuration: {}", Debug2Format(&e));
        return Err(NullError::Drain);
    }
    for _ in 0..SETTLE_FRAMES {
        wait_drdy()?;
        // Only to advance the converter; a failed frame is as good here.
        let _ = adc.driver().read_frame();
    }
    while n < rig::NULL_SAMPLES {
        wait_drdy()?;
        match adc.driver().read_frame() {
            Ok(frame) => {
                let [bridge, mon] = frame.channels;
                sum += i64::from(bridge.code());
                monitor += i64::from(mon.code());
                n += 1;
            }
            Err(_) => {
                bad += 1;
                if bad > rig::NULL_SAMPLES / 10 {
                    return Err(NullError::Frames);
                }
            }
        }
    }
    let mean = sum as f64 / f64::from(n);
    let null_v = mean * volts_per_code;
    let full_scale_codes = f64::from(beamest::pipeline::ADC_CODE_MAX);
    info!(
        "bridge null: mean code {} = {} V at the ADC ({} % of full scale); monitor mean code {}; \
         {} bad frames",
        mean,
        null_v,
        100.0 * mean / full_scale_codes,
        monitor as f64 / f64::from(n),
        bad
    );
    if libm::fabs(mean) > 0.5 * full_scale_codes {
        warn!("bridge offset above half the ADC range: balance the bridge");
    }
    Ok(null_v)
}

/// Wait for DRDY's next falling edge (the EXTI pending flag, set with the
/// NVIC line still off), for at most [`DRDY_TIMEOUT_US`]; clear it.
fn wait_drdy() -> Result<(), NullError> {
    let start = cycles::now();
    let limit = DRDY_TIMEOUT_US * (clocks::CPU_HZ / 1_000_000);
    while !drdy::is_pending() {
        if cycles::between(start, cycles::now()) > limit {
            return Err(NullError::NoDrdy);
        }
    }
    drdy::clear_pending();
    Ok(())
}

/// Wait until the sample interrupt has just finished a tick (or two sample
/// periods have passed: DRDY stopped), so that the defmt log frame thread
/// mode writes next runs in the idle rest of a sample period. defmt-rtt
/// writes each frame inside a critical section that masks the DRDY
/// interrupt; started right after a tick, a frame (a few µs) ends long
/// before the next conversion, so it delays no sample (the late-sample
/// counter of the status line would count one that did). Call before
/// every log line once the sample interrupt runs. With probe-rs attached,
/// defmt-rtt blocks (still masked) while its 1 KiB buffer is full: at the
/// status report's three lines a second it is far from full unless the
/// host stops reading (then logging, and the samples with it, stall).
pub(crate) fn between_samples() {
    let seen = TICKS.load(Ordering::Acquire);
    let start = cycles::now();
    while TICKS.load(Ordering::Acquire) == seen {
        if cycles::between(start, cycles::now()) > LOG_WAIT_CYCLES {
            return;
        }
    }
}

/// Start-up failure: piezo to 0 V, LD3 on, say why, stop.
pub(crate) fn fatal(what: &str, why: impl defmt::Format) -> ! {
    board::disable_sample_interrupt();
    board::safe_state();
    error!("halted: {}: {}", what, why);
    loop {
        cortex_m::asm::wfi();
    }
}
