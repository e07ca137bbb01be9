//! The simulated rig on the emulated board (QEMU `mps2-an386`, Cortex-M4F,
//! `f32`): run with `cargo xtask qemu`.
//!
//! * Timer 0 interrupt, 10 kHz, highest priority: one [`RigPipeline::step`]
//!   (the simulated beam, excitation and estimator), instrumented with
//!   SysTick.
//! * UART0 interrupts, below it: move bytes between the UART and its rings.
//! * Thread mode, lowest: reads the telemetry queue, recovers ω, ζ (eqs.
//!   30–32) from each Θ, streams them out of UART0 as text lines, logs them
//!   through semihosting as they converge, and after 5 s of simulated time
//!   prints `instructions_per_sample: estimator=N isr=M` and exits with
//!   status 0 only if ω1, ω2, ζ1, ζ2 are all within 1e-3 of the simulated
//!   truth (the one place that reads it).

#![no_std]
#![no_main]
#![deny(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::panic,
    clippy::indexing_slicing
)]

mod numfmt;
mod provisional;

use core::fmt::Write as _;

use beamest::board::qemu::cycles::{self, Calibration, SpanSum};
use beamest::board::qemu::uart::{self, RxFill, RxRing, TxDrain, TxRing, UartTx};
use beamest::board::qemu::{self as board, interrupt, timer, Board, Handoff};
use beamest::estimator::{Adaptive2, AdaptiveConfig, Estimator};
use beamest::filter_bank::{FilterConfig, SignalScales};
use beamest::modal::modal_from_tf;
use beamest::model::{ModalParams, TransferFunction, PAPER_OMEGA, PAPER_ZETA};
use cortex_m::peripheral::NVIC;
use cortex_m_rt::entry;
use cortex_m_semihosting::hprintln;
use heapless::spsc::Queue;
use panic_semihosting as _;

use numfmt::{Fixed, Sci};
use provisional::{Record, RigPipeline, Spans, NP, TELEMETRY_QUEUE, TS_S};

/// Simulated run length: 5 s at 10 kHz.
const RUN_SAMPLES: u32 = 50_000;
/// Filter pole λ, rad/s (the paper's Section IV.A choice).
const LAMBDA_RAD_S: f64 = 100.0;
/// U0: the excitation amplitude, known to the user (V).
const U_SCALE: f64 = 0.1;
/// Output weights c_i of the paper's two-mode beam (eq. 24), for b̄.
const OUTPUT_WEIGHT: [f32; 2] = [-2.0, 2.0];
/// Pass criterion: relative error of every ω and ζ after the run.
const TOLERANCE: f64 = 1e-3;
/// Semihosting log interval while converging, samples (0.25 s).
const LOG_EVERY: u32 = 2_500;
/// Timer-period check: SysTick across this many periods, from sample
/// `PERIOD_FROM` (the interval stays below SysTick's 0.67 s wrap).
const PERIOD_FROM: u32 = 10;
const PERIODS: u32 = 6_000;

/// Everything the sample interrupt owns.
struct SampleIsr {
    pipeline: RigPipeline,
    isr: SpanSum,
    period_start: u32,
    period_ticks: u32,
    overruns: u32,
    finished: bool,
}

/// The end-of-run message: the sample interrupt's totals.
struct Summary {
    samples: u32,
    spans: Spans,
    isr: SpanSum,
    period_ticks: u32,
    overruns: u32,
    dropped: u32,
    theta: Option<[f32; NP]>,
}

// The large states are handed over by `&'static mut` into `singleton!`
// storage: an `Option` of a reference is zero when empty, so these statics
// stay in .bss instead of carrying kilobytes of .data initialisers.
static SAMPLE_TASK: Handoff<&'static mut SampleIsr> = Handoff::new();
static ESTIMATOR: Handoff<&'static mut Adaptive2<f32>> = Handoff::new();
static SUMMARY: Handoff<Summary> = Handoff::new();
static TX_DRAIN: Handoff<TxDrain> = Handoff::new();
static RX_FILL: Handoff<RxFill> = Handoff::new();

#[interrupt]
fn TIMER0() {
    static mut TASK: Option<&'static mut SampleIsr> = None;
    let entry = cycles::now();
    timer::clear_interrupt();
    if TASK.is_none() {
        *TASK = SAMPLE_TASK.take();
    }
    let Some(task) = TASK.as_mut() else { return };
    if task.finished {
        return;
    }
    let k = task.pipeline.samples();
    if k == RUN_SAMPLES {
        task.finished = true;
        SUMMARY.put(Summary {
            samples: k,
            spans: task.pipeline.spans(),
            isr: task.isr,
            period_ticks: task.period_ticks,
            overruns: task.overruns,
            dropped: task.pipeline.dropped(),
            theta: task.pipeline.theta(),
        });
        return;
    }
    if k == PERIOD_FROM {
        task.period_start = entry;
    } else if k == PERIOD_FROM + PERIODS {
        task.period_ticks = cycles::ticks_between(task.period_start, entry);
    }

    // Spread the start over SysTick's 40-instruction tick (see `cycles`).
    cycles::dither(k);
    let t0 = cycles::now();
    task.pipeline.step();
    task.isr.add(t0, cycles::now());

    if NVIC::is_pending(board::Interrupt::TIMER0) {
        task.overruns = task.overruns.saturating_add(1);
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
    hprintln!("beamest qemu-rig: mps2-an386, 10 kHz sample interrupt, f32 estimator");

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
    let pipeline = match RigPipeline::new(&ESTIMATOR, producer) {
        Ok(p) => p,
        Err(_) => fail("plant construction"),
    };
    let Some(task) = cortex_m::singleton!(: SampleIsr = SampleIsr {
        pipeline,
        isr: SpanSum::default(),
        period_start: 0,
        period_ticks: 0,
        overruns: 0,
        finished: false,
    }) else {
        fail("sample task already placed")
    };
    SAMPLE_TASK.put(task);
    Board::unmask();
    b.timer.start(board::SAMPLE_RELOAD);
    let _ = writeln!(tx, "# t_s,omega1_rad_s,omega2_rad_s,zeta1,zeta2");

    let mut rx_bytes: u32 = 0;
    let mut last: Option<ModalParams<f32>> = None;
    loop {
        while let Some(record) = consumer.dequeue() {
            handle(record, &mut tx, &mut last);
        }
        while rx.read().is_some() {
            rx_bytes = rx_bytes.saturating_add(1);
        }
        if let Some(summary) = SUMMARY.take() {
            b.timer.stop();
            // Records pushed before the summary are still queued.
            while let Some(record) = consumer.dequeue() {
                handle(record, &mut tx, &mut last);
            }
            finish(&summary, &cal, rx_bytes, &mut tx);
        }
        // Idle by executing, never WFI: under `-icount sleep=off` QEMU 7.2
        // warps virtual time past the next timer deadline while the CPU
        // sleeps, and the sample interrupt then comes every ~200 µs
        // (measured: 4,972.5 SysTick ticks per period instead of 2,500).
        board::idle();
    }
}

/// Thread-mode handling of one telemetry record.
fn handle(record: Record, tx: &mut UartTx, last: &mut Option<ModalParams<f32>>) {
    match record {
        Record::Startup { y_rms } => {
            hprintln!(
                "start-up: y_rms = {} over 0.1 s -> Y0; estimator starts",
                Sci(y_rms.into(), 4)
            );
            let filter = FilterConfig {
                ts_s: TS_S,
                lambda_rad_s: LAMBDA_RAD_S,
                scales: SignalScales {
                    u_scale: U_SCALE,
                    y_scale: f64::from(y_rms),
                },
                ..FilterConfig::default()
            };
            match Adaptive2::<f32>::new(&filter, &AdaptiveConfig::default()) {
                Ok(mut est) => {
                    // The beam is already moving: hold the law while the
                    // filters settle (one invalid sample arms the input
                    // quarantine, 40/λ; see `provisional`).
                    est.step(f32::NAN, f32::NAN);
                    match cortex_m::singleton!(: Adaptive2<f32> = est) {
                        Some(e) => ESTIMATOR.put(e),
                        None => fail("a second start-up record"),
                    }
                }
                Err(e) => {
                    hprintln!("error: estimator configuration: {:?}", e);
                    board::exit(false);
                }
            }
        }
        Record::Estimate {
            sample,
            theta,
            not_updated,
        } => {
            let t_s = Fixed(f64::from(sample) * TS_S, 2);
            let modes = TransferFunction::from_theta(&theta, LAMBDA_RAD_S)
                .and_then(|tf| modal_from_tf(&tf, &OUTPUT_WEIGHT).ok());
            let Some(m) = modes else {
                let _ = writeln!(tx, "{t_s},nan,nan,nan,nan");
                return;
            };
            let [w1, w2, ..] = m.omega_rad_s;
            let [z1, z2, ..] = m.zeta;
            let (w1, w2, z1, z2) = (f64::from(w1), f64::from(w2), f64::from(z1), f64::from(z2));
            let _ = writeln!(
                tx,
                "{t_s},{},{},{},{}",
                Fixed(w1, 6),
                Fixed(w2, 5),
                Fixed(z1, 7),
                Fixed(z2, 6)
            );
            if sample % LOG_EVERY == 0 {
                hprintln!(
                    "t = {} s  omega = [{}, {}] rad/s  zeta = [{}, {}]  (law held {} samples)",
                    t_s,
                    Fixed(w1, 4),
                    Fixed(w2, 4),
                    Fixed(z1, 6),
                    Fixed(z2, 5),
                    not_updated
                );
            }
            *last = Some(m);
        }
    }
}

/// End of run: report, check against the simulated truth, exit.
fn finish(s: &Summary, cal: &Calibration, rx_bytes: u32, tx: &mut UartTx) -> ! {
    let ipt = cal.instructions_per_tick();
    let period = f64::from(s.period_ticks) / f64::from(PERIODS);
    hprintln!(
        "timer period: {} periods = {} SysTick ticks ({} ticks = {} us each; expected 2500)",
        PERIODS,
        s.period_ticks,
        Fixed(period, 3),
        Fixed(period * 0.04, 3)
    );

    // Final estimate and one timed recovery (timer stopped: no preemption).
    let theta = s.theta.unwrap_or([f32::NAN; NP]);
    let t0 = cycles::now();
    let modes = TransferFunction::from_theta(&theta, LAMBDA_RAD_S)
        .and_then(|tf| modal_from_tf(&tf, &OUTPUT_WEIGHT).ok());
    let recovery_ticks = cycles::ticks_between(t0, cycles::now());

    hprintln!(
        "samples: {} ({} s); estimator steps: {}; overruns: {}; telemetry dropped: {}; \
         uart0 tx dropped: {}, rx bytes: {}",
        s.samples,
        Fixed(f64::from(s.samples) * TS_S, 1),
        s.spans.estimator.count,
        s.overruns,
        s.dropped,
        uart::link_stats().tx_dropped,
        rx_bytes
    );
    hprintln!(
        "instruction breakdown per sample: plant (simulated rig, f64) = {}, estimator = {}, \
         isr = {} (max {}); modal recovery = {} per call",
        Fixed(s.spans.plant.mean_instructions(ipt).into(), 0),
        Fixed(s.spans.estimator.mean_instructions(ipt).into(), 0),
        Fixed(s.isr.mean_instructions(ipt).into(), 0),
        (s.isr.max_ticks as f32 * ipt) as u32,
        (recovery_ticks as f32 * ipt) as u32,
    );
    hprintln!(
        "instructions_per_sample: estimator={} isr={}",
        libm::roundf(s.spans.estimator.mean_instructions(ipt)) as u32,
        libm::roundf(s.isr.mean_instructions(ipt)) as u32
    );

    // The only read of the simulated truth: the pass/fail check.
    let pass = match modes {
        Some(m) => {
            let mut ok = true;
            for i in 0..2 {
                let (w, z) = (m.omega_rad_s.get(i), m.zeta.get(i));
                let (tw, tz) = (PAPER_OMEGA.get(i), PAPER_ZETA.get(i));
                let (Some(&w), Some(&z), Some(&tw), Some(&tz)) = (w, z, tw, tz) else {
                    fail("mode index");
                };
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
            ok
        }
        None => {
            hprintln!("no modal estimate at the end of the run");
            false
        }
    };
    let _ = writeln!(tx, "# end: {}", if pass { "pass" } else { "fail" });
    // Let the TX interrupt hand the last line to the UART.
    let mut spins = 0u32;
    while !tx.is_drained() && spins < 1_000_000 {
        spins += 1;
        cortex_m::asm::nop();
    }
    hprintln!(
        "result: {} (all of omega, zeta within {} after {} s)",
        if pass { "PASS" } else { "FAIL" },
        Sci(TOLERANCE, 0),
        Fixed(f64::from(s.samples) * TS_S, 1)
    );
    board::exit(pass)
}

/// Log and exit with failure (boot errors).
fn fail(what: &str) -> ! {
    hprintln!("error: {}", what);
    board::exit(false)
}
