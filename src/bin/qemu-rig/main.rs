//! The firmware on the emulated board (QEMU `mps2-an386`, Cortex-M4F,
//! `f32`) with the simulated bench behind the real converter drivers: run
//! with `cargo xtask qemu`.
//!
//! * Boot (thread mode): SysTick calibration; both converters brought up
//!   through their drivers against the chip models (AD5761R reset, control
//!   written and read back; ADS131M02 reset with the ID check, configured
//!   and read back); the rig, a frozen pipeline and the sample task built
//!   from `beamest::rig::bench`.
//! * Timer 0 interrupt, 10 kHz, highest priority: [`sample::SampleTask`] —
//!   rig tick, then `Pipeline::tick` (the drivers' SPI frames to the
//!   models, the estimator step, telemetry into the SPSC queue).
//! * UART0 interrupts, below it: move bytes between the UART and its rings
//!   (the serial link of issue 7 will use them; today one CSV line per
//!   record goes out).
//! * Thread mode, lowest: builds the estimator when the start-up window
//!   reports Y0, turns each telemetry record into ω, ζ, b̄ and λmin(P)
//!   (`pipeline::recover`), logs through semihosting as the estimate
//!   converges, and at the end prints the instruction counts, checks the
//!   fault counters and ω, ζ against the simulated truth (the one place
//!   that reads it) and exits with status 0 only if all pass ([`report`]).

#![no_std]
#![no_main]
#![deny(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::panic,
    clippy::indexing_slicing
)]

mod numfmt;
mod report;
mod sample;

use core::fmt::Write as _;

use beamest::board::qemu::cycles::{self, SpinDelay};
use beamest::board::qemu::meter::{MeteredSpi, SpiMeter, TimedEstimator};
use beamest::board::qemu::uart::{RxFill, RxRing, TxDrain, TxRing};
use beamest::board::qemu::{self as board, interrupt, timer, Board, Handoff, IsrOwned};
use beamest::drivers::ad5761r::Ad5761r;
use beamest::drivers::ads131m02::Ads131m02;
use beamest::estimator::{Adaptive2, AdaptiveConfig};
use beamest::pipeline::{bring_up, NoSink, Pipeline};
use beamest::rig::{bench, ConverterModels};
use cortex_m_rt::entry;
use cortex_m_semihosting::hprintln;
use heapless::spsc::{Producer, Queue};
use panic_semihosting as _;

use numfmt::{Fixed, Sci};
use report::{finish, handle, LOG_EVERY};
use sample::{Record, SampleTask, Summary};

/// Telemetry queue size (holds `TELEMETRY_QUEUE − 1` records: 150 ms).
const TELEMETRY_QUEUE: usize = 16;

static SPI_METER: SpiMeter = SpiMeter::new();
// Large states are handed over by `&'static mut` into `singleton!` storage:
// an `Option` of a reference is zero when empty, so these stay in .bss.
static SAMPLE_TASK: Handoff<IsrOwned<&'static mut SampleTask>> = Handoff::new();
static Y0: Handoff<f32> = Handoff::new();
static ESTIMATOR: Handoff<&'static mut Adaptive2<f32>> = Handoff::new();
static SUMMARY: Handoff<Summary> = Handoff::new();
static TX_DRAIN: Handoff<TxDrain> = Handoff::new();
static RX_FILL: Handoff<RxFill> = Handoff::new();

#[interrupt]
fn TIMER0() {
    static mut TASK: Option<IsrOwned<&'static mut SampleTask>> = None;
    let entry = cycles::now();
    timer::clear_interrupt();
    if TASK.is_none() {
        *TASK = SAMPLE_TASK.take();
    }
    if let Some(task) = TASK.as_mut() {
        task.get_mut().on_interrupt(entry);
    }
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

    let (Some(tx_ring), Some(rx_ring), Some(queue)) = (
        cortex_m::singleton!(: TxRing = Queue::new()),
        cortex_m::singleton!(: RxRing = Queue::new()),
        cortex_m::singleton!(: Queue<Record, TELEMETRY_QUEUE> = Queue::new()),
    ) else {
        fail("static buffers already taken")
    };
    let (mut tx, drain, fill, mut rx) =
        b.uart0
            .split(timer::PCLK_HZ, board::UART_BAUD, tx_ring, rx_ring);
    TX_DRAIN.put(drain);
    RX_FILL.put(fill);
    let (producer, mut consumer) = queue.split();
    let task = build_sample_task(producer);
    // SAFETY: the chip models were created inside `build_sample_task` and
    // only the task (its rig and its drivers) refers to them.
    SAMPLE_TASK.put(unsafe { IsrOwned::new(task) });
    Board::unmask();
    b.timer.start(board::SAMPLE_RELOAD);
    let _ = writeln!(
        tx,
        "# t_s,omega1_rad_s,omega2_rad_s,zeta1,zeta2,lambda_min_p"
    );

    let mut rx_bytes: u32 = 0;
    let mut next_log: u64 = LOG_EVERY;
    let mut last: Option<Record> = None;
    loop {
        while let Some(record) = consumer.dequeue() {
            handle(&record, &mut tx, &mut next_log);
            last = Some(record);
        }
        while rx.read().is_some() {
            rx_bytes = rx_bytes.saturating_add(1);
        }
        if let Some(y0) = Y0.take() {
            start_estimator(y0);
        }
        if let Some(summary) = SUMMARY.take() {
            b.timer.stop();
            // Records pushed before the summary are still queued.
            while let Some(record) = consumer.dequeue() {
                handle(&record, &mut tx, &mut next_log);
                last = Some(record);
            }
            finish(&summary, last.as_ref(), &cal, rx_bytes, &mut tx);
        }
        // Idle by executing, never WFI: under `-icount sleep=off` QEMU 7.2
        // warps virtual time past the next timer deadline while the CPU
        // sleeps, and the sample interrupt then comes every ~200 µs
        // (measured: 4,972.5 SysTick ticks per period instead of 2,500).
        board::idle();
    }
}

/// Boot the simulated bench: the chip models, both converters brought up
/// through their drivers, the rig, a frozen pipeline with a stand-in
/// estimator (never stepped, replaced once Y0 is known) and the sample
/// task. Nothing that refers to the models leaves this function except the
/// task.
fn build_sample_task(producer: Producer<'static, Record>) -> &'static mut SampleTask {
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
    let Ok(stand_in) =
        Adaptive2::<f32>::new(&bench::filter_config(1.0), &AdaptiveConfig::default())
    else {
        fail("estimator settings")
    };
    let Some(stand_in) = cortex_m::singleton!(: Adaptive2<f32> = stand_in) else {
        fail("stand-in estimator already placed")
    };
    let Ok(excitation) = bench::excitation::<f32>() else {
        fail("excitation settings")
    };
    let Ok(pipeline) = Pipeline::new(
        &bench::pipeline_config(),
        TimedEstimator::new(stand_in),
        excitation,
        adc,
        dac,
        producer,
        NoSink,
    ) else {
        fail("pipeline settings")
    };
    let task = SampleTask::new(rig, pipeline, &SPI_METER, &Y0, &ESTIMATOR, &SUMMARY);
    let Some(task) = cortex_m::singleton!(: SampleTask = task) else {
        fail("sample task already placed")
    };
    task
}

/// Y0 from the start-up window: build the estimator (its matrix
/// exponentials run here, not in the interrupt) and hand it over.
fn start_estimator(y0: f32) {
    hprintln!(
        "start-up: Y0 = {} m (RMS of y over {} samples, excitation running); \
         U0 = {} V, lambda = {} rad/s",
        Sci(y0.into(), 4),
        bench::STARTUP_SAMPLES,
        Fixed(bench::EXCITATION_V, 2),
        Fixed(bench::LAMBDA_RAD_S, 0)
    );
    match Adaptive2::<f32>::new(
        &bench::filter_config(f64::from(y0)),
        &AdaptiveConfig::default(),
    ) {
        Ok(est) => match cortex_m::singleton!(: Adaptive2<f32> = est) {
            Some(e) => ESTIMATOR.put(e),
            None => fail("a second start-up window"),
        },
        Err(_) => {
            hprintln!("error: estimator configuration rejected Y0");
            board::exit(false);
        }
    }
}

/// Log and exit with failure (boot errors).
fn fail(what: &str) -> ! {
    hprintln!("error: {}", what);
    board::exit(false)
}
