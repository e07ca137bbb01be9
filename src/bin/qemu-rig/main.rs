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
//!   that reads it) and exits with status 0 only if all pass.

#![no_std]
#![no_main]
#![deny(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::panic,
    clippy::indexing_slicing
)]

mod numfmt;
mod sample;

use core::fmt::Write as _;

use beamest::board::qemu::cycles::{self, Calibration, SpanSum, SpinDelay};
use beamest::board::qemu::meter::{MeteredSpi, SpiMeter, TimedEstimator};
use beamest::board::qemu::uart::{self, RxFill, RxRing, TxDrain, TxRing, UartTx};
use beamest::board::qemu::{self as board, interrupt, timer, Board, Handoff, IsrOwned};
use beamest::drivers::ad5761r::Ad5761r;
use beamest::drivers::ads131m02::Ads131m02;
use beamest::estimator::{Adaptive2, AdaptiveConfig};
use beamest::modal::modal_from_tf;
use beamest::model::{ModalParams, TransferFunction, PAPER_OMEGA, PAPER_ZETA};
use beamest::pipeline::{bring_up, recover, NoSink, Pipeline, StatusFlags};
use beamest::rig::{bench, ConverterModels, ConverterRig};
use cortex_m_rt::entry;
use cortex_m_semihosting::hprintln;
use heapless::spsc::{Producer, Queue};
use panic_semihosting as _;

use numfmt::{Fixed, Sci};
use sample::{Record, SampleTask, Summary, PERIODS, RUN_SAMPLES};

/// Telemetry queue size (holds `TELEMETRY_QUEUE − 1` records: 150 ms).
const TELEMETRY_QUEUE: usize = 16;
/// Output weights C̄ (eq. 24), for b̄.
const OUTPUT_WEIGHT: [f32; 2] = [-2.0, 2.0];
/// Pass criterion: relative error of every ω and ζ after the run.
const TOLERANCE: f64 = 1e-3;
/// Semihosting log interval while converging, samples (0.25 s).
const LOG_EVERY: u64 = 2_500;

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
    let Ok(plant) = bench::plant() else {
        fail("plant construction")
    };
    let Ok(rig) = ConverterRig::new(models, plant, &bench::conversion(), bench::AMPLIFIER_GAIN)
    else {
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

/// Thread-mode handling of one telemetry record: recovery, UART line, and
/// a log line at the first record from `next_log` on.
fn handle(record: &Record, tx: &mut UartTx, next_log: &mut u64) {
    if record.flags.has(StatusFlags::FROZEN) {
        // The start-up window: the stand-in estimator is not running.
        return;
    }
    let rec = recover(record, &OUTPUT_WEIGHT);
    let t_s = Fixed(record.sample_index as f64 * bench::TS_S, 2);
    let lmin = rec.excitation_min_eig.map_or(f64::NAN, f64::from);
    let Ok(m) = rec.modal else {
        let _ = writeln!(tx, "{t_s},nan,nan,nan,nan,{}", Sci(lmin, 3));
        return;
    };
    let [w1, w2, ..] = m.omega_rad_s.map(f64::from);
    let [z1, z2, ..] = m.zeta.map(f64::from);
    let _ = writeln!(
        tx,
        "{t_s},{},{},{},{},{}",
        Fixed(w1, 6),
        Fixed(w2, 5),
        Fixed(z1, 7),
        Fixed(z2, 6),
        Sci(lmin, 3)
    );
    if record.sample_index >= *next_log {
        *next_log = (record.sample_index / LOG_EVERY + 1) * LOG_EVERY;
        hprintln!(
            "t = {} s  omega = [{}, {}] rad/s  zeta = [{}, {}]  lambda_min(P) = {}  \
             (last 100 steps: {} held, {} rejected; rejected so far {})",
            t_s,
            Fixed(w1, 4),
            Fixed(w2, 4),
            Fixed(z1, 6),
            Fixed(z2, 5),
            Sci(lmin, 2),
            record.steps.frozen,
            record.steps.rejected,
            record.counters.rejected
        );
    }
}

/// Mean instructions of a span sum.
fn mean(s: &SpanSum, ipt: f32) -> f64 {
    f64::from(s.mean_instructions(ipt))
}

/// End of run: report, check, exit.
fn finish(
    s: &Summary,
    last: Option<&Record>,
    cal: &Calibration,
    rx_bytes: u32,
    tx: &mut UartTx,
) -> ! {
    let ipt = cal.instructions_per_tick();
    let period = f64::from(s.period_ticks) / f64::from(PERIODS);
    hprintln!(
        "timer period: {} periods = {} SysTick ticks ({} ticks = {} us each; expected 2500)",
        PERIODS,
        s.period_ticks,
        Fixed(period, 3),
        Fixed(period * 0.04, 3)
    );
    let [updated, held, rejected, skipped] = s.step_counts;
    hprintln!(
        "samples: {} ({} s); estimator swapped in at sample {}; steps: {} updated, {} held, \
         {} rejected, {} skipped; overruns: {}; rig errors: {}; uart0 tx dropped: {}, rx bytes: {}",
        s.samples,
        Fixed(f64::from(s.samples) * bench::TS_S, 1),
        s.started_at.unwrap_or(0),
        updated,
        held,
        rejected,
        skipped,
        s.overruns,
        s.rig_errors,
        uart::link_stats().tx_dropped,
        rx_bytes
    );
    let c = s.counters;
    let expected = sample::expected_counters();
    hprintln!(
        "faults injected in the ADC model: {} bad-CRC frames, {} saturated, {}-repeat stuck run, \
         {} dropped conversions",
        expected.adc_crc,
        expected.bridge_saturated,
        expected.stuck.saturating_sub(1),
        expected.adc_other
    );
    hprintln!(
        "pipeline counters: crc {} status {} bus {} other {} | saturated bridge {} monitor {} | \
         stuck {} | rejected {} | dac errors {} saturated {} | records dropped {}",
        c.adc_crc,
        c.adc_status,
        c.adc_bus,
        c.adc_other,
        c.bridge_saturated,
        c.monitor_saturated,
        c.stuck,
        c.rejected,
        c.dac_errors,
        c.dac_saturated,
        c.dropped_records
    );
    let counters_ok = c == expected;

    // Instruction counts: steady state = samples whose step updated the law.
    let st = &s.steady;
    let est = mean(&st.estimator, ipt);
    let tick_product = mean(&st.tick, ipt) - mean(&st.models, ipt);
    hprintln!(
        "instructions per sample, mean over the {} samples whose estimator step updated the law:",
        st.product.count
    );
    hprintln!(
        "  rig (not the product): beam + ADC conversion = {}, chip models' SPI = {}, total = {}",
        Fixed(mean(&st.rig, ipt), 0),
        Fixed(mean(&st.models, ipt), 0),
        Fixed(mean(&st.rig, ipt) + mean(&st.models, ipt), 0)
    );
    hprintln!(
        "  pipeline tick without the models = {}: estimator step = {}, pipeline overhead = {} \
         (drivers' framing and CRC, conversion, screening, excitation, telemetry)",
        Fixed(tick_product, 0),
        Fixed(est, 0),
        Fixed(tick_product - est, 0)
    );
    hprintln!(
        "  isr excluding the rig = {} (max {}; over all {} samples incl. start-up, held and \
         rejected: mean {}, max {})",
        Fixed(mean(&st.product, ipt), 0),
        (st.product.max_ticks as f32 * ipt) as u32,
        s.all.product.count,
        Fixed(mean(&s.all.product, ipt), 0),
        (s.all.product.max_ticks as f32 * ipt) as u32
    );

    // Final estimate; one timed recovery (timer stopped: no preemption).
    let t0 = cycles::now();
    let modes = TransferFunction::from_theta(&s.theta, bench::LAMBDA_RAD_S)
        .and_then(|tf| modal_from_tf(&tf, &OUTPUT_WEIGHT).ok());
    let recovery = cycles::ticks_between(t0, cycles::now());
    let record_ticks = last.map_or(0, |r| {
        let t0 = cycles::now();
        let rec = recover(r, &OUTPUT_WEIGHT);
        let t = cycles::ticks_between(t0, cycles::now());
        core::hint::black_box(rec);
        t
    });
    hprintln!(
        "  thread mode, per call: modal recovery (eqs. 30-32) = {}; recover() of a record \
         (modal recovery + lambda_min(P)) = {}",
        (recovery as f32 * ipt) as u32,
        (record_ticks as f32 * ipt) as u32
    );
    hprintln!(
        "instructions_per_sample: estimator={} isr={}",
        libm::round(est) as u32,
        libm::round(mean(&st.product, ipt)) as u32
    );
    hprintln!(
        "rig_instructions_per_sample: {} (beam + ADC conversion {}, chip models' SPI {}); \
         pipeline_overhead_per_sample: {}",
        libm::round(mean(&st.rig, ipt) + mean(&st.models, ipt)) as u32,
        libm::round(mean(&st.rig, ipt)) as u32,
        libm::round(mean(&st.models, ipt)) as u32,
        libm::round(tick_product - est) as u32
    );

    let modes_ok = check_modes(modes.as_ref());
    let others_ok = s.overruns == 0 && s.rig_errors == 0 && s.started_at.is_some();
    if !counters_ok {
        hprintln!("fault counters differ from the injected faults");
    }
    let pass = modes_ok && counters_ok && others_ok;
    let _ = writeln!(tx, "# end: {}", if pass { "pass" } else { "fail" });
    // Let the TX interrupt hand the last line to the UART.
    let mut spins = 0u32;
    while !tx.is_drained() && spins < 1_000_000 {
        spins += 1;
        cortex_m::asm::nop();
    }
    hprintln!(
        "result: {} (all of omega, zeta within {} after {} s; fault counters as injected; \
         no overrun)",
        if pass { "PASS" } else { "FAIL" },
        Sci(TOLERANCE, 0),
        Fixed(f64::from(RUN_SAMPLES) * bench::TS_S, 1)
    );
    board::exit(pass)
}

/// The only read of the simulated truth: ω, ζ within [`TOLERANCE`].
fn check_modes(modes: Option<&ModalParams<f32>>) -> bool {
    let Some(m) = modes else {
        hprintln!("no modal estimate at the end of the run");
        return false;
    };
    let mut ok = true;
    let pairs = m
        .omega_rad_s
        .iter()
        .zip(m.zeta.iter())
        .zip(PAPER_OMEGA.iter().zip(PAPER_ZETA.iter()))
        .take(2);
    for (i, ((&w, &z), (&tw, &tz))) in pairs.enumerate() {
        let ew = (f64::from(w) / tw - 1.0).abs();
        let ez = (f64::from(z) / tz - 1.0).abs();
        hprintln!(
            "mode {}: omega = {} rad/s (truth {}, rel. error {}), zeta = {} (truth {}, rel. error {})",
            i + 1,
            Fixed(w.into(), 5),
            Fixed(tw, 4),
            Sci(ew, 1),
            Fixed(z.into(), 7),
            Fixed(tz, 4),
            Sci(ez, 1)
        );
        // `!(e <= tol)` fails NaN too.
        if !(ew <= TOLERANCE && ez <= TOLERANCE) {
            ok = false;
        }
    }
    ok && m.modes == 2
}

/// Log and exit with failure (boot errors).
fn fail(what: &str) -> ! {
    hprintln!("error: {}", what);
    board::exit(false)
}
