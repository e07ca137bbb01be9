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
//! * **Thread mode (lowest):** start-up (bridge null offset, Y0), then
//!   telemetry records → modal recovery (eqs. 30–32) and λmin(P) →
//!   defmt log once a second, raw blocks and received frames through
//!   [`link`], ADC re-initialisation after a device reset, a warning when
//!   no sample has come for 0.5 s (SysTick wakes it even then).
//!
//! # Start-up
//! 1. Board: clocks, CLKIN, pins, buses; converters reset by their pins.
//! 2. AD5761R: software reset, ±10 V, output at mid-scale (0 V).
//! 3. ADS131M02: software reset (reply and ID checked), configuration read
//!    back: OSR 256, high resolution → 10 kSPS from the 5.12 MHz CLKIN.
//! 4. Bridge null offset: the mean of [`rig::NULL_SAMPLES`] conversions,
//!    read by polling DRDY, with the DAC at 0 V (the paper's "bridge offset
//!    nulling").
//! 5. The pipeline starts in the sample interrupt with the excitation on
//!    and adaptation frozen; [`rig::STARTUP_SAMPLES`] raw samples give Y0
//!    (the RMS of y); thread mode builds the estimator with it (outside
//!    the lock), swaps it in and resumes adaptation: the first sample then
//!    re-arms the estimator's input quarantine (40/λ) while its filters
//!    settle on the moving beam.
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

use beamest::board::nucleo::converters::Adc;
use beamest::board::nucleo::cycles::{self, Spans};
use beamest::board::nucleo::shared::Shared;
use beamest::board::nucleo::{self as board, clocks, drdy, uart, Board, SpiDev};
use beamest::drivers::ad5761r::Ad5761r;
use beamest::estimator::Adaptive2;
use beamest::pipeline::{recover, Counters, Pipeline, RawBlock, TelemetryRecord};
use cortex_m_rt::{entry, exception, ExceptionFrame};
use defmt::{error, info, warn, Debug2Format};
use defmt_rtt as _;
use embassy_stm32::interrupt;
use heapless::spsc::{Producer, Queue};
use panic_probe as _;

use link::Link;

/// Θ entries for two modes (eq. 29: 4n − 1).
const NP: usize = 7;
/// Packed upper triangle of P: NP(NP + 1)/2.
const NS: usize = NP * (NP + 1) / 2;
/// Telemetry queue (holds 7 records: 70 ms at 100 Hz).
const TELEMETRY_QUEUE: usize = 8;
/// Raw-block queue (holds 7 blocks: 22 ms at one block per 32 samples).
const RAW_QUEUE: usize = 8;
/// Polling DRDY at start-up gives up after this many sample periods.
const DRDY_TIMEOUT_PERIODS: u32 = 3;
/// Records per status log line (1 s at 100 Hz).
const LOG_EVERY_RECORDS: u32 = 100;
/// No telemetry record for this long (cycles, 0.5 s): DRDY has stopped.
const STALL_CYCLES: u32 = clocks::CPU_HZ / 2;
/// Conversions discarded after the ADC's reset before the null-offset
/// average: the first two come from its fast-settling filter, the sinc3
/// then needs three conversions to fill (ADS131M02 §8.3.7.1).
const SETTLE_FRAMES: u32 = 4;

type Record = TelemetryRecord<f64, NP, NS>;
type RigPipeline = Pipeline<
    f64,
    Adaptive2<f64>,
    Adc<SpiDev>,
    Ad5761r<SpiDev>,
    Producer<'static, Record>,
    Producer<'static, RawBlock<f64>>,
    NP,
    NS,
>;

/// Everything the sample interrupt owns.
struct SampleTask {
    pipeline: RigPipeline,
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
static SAMPLE: Shared<&'static mut SampleTask> = Shared::new();
static SERIAL: Shared<SerialIsr> = Shared::new();

#[interrupt]
fn EXTI3() {
    let entry = cycles::now();
    drdy::clear_pending();
    SAMPLE.with(|task| {
        if let Some(last) = task.last_entry {
            let gap = cycles::between(last, entry);
            let missed = cycles::missed_periods(gap, clocks::CYCLES_PER_SAMPLE);
            if missed > 0 {
                task.pipeline.note_overrun(missed);
            }
        }
        task.last_entry = Some(entry);
        task.pipeline.tick();
        if drdy::is_pending() {
            task.late = task.late.saturating_add(1);
        }
        task.isr.add(cycles::between(entry, cycles::now()));
    });
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

    let mut adc = match Adc::new(b.adc_spi, rig::adc_config(), &mut b.delay) {
        Ok(a) => a,
        Err(e) => fatal("ADS131M02 reset/configure", Debug2Format(&e)),
    };
    info!("ADS131M02: reset, configured {}", rig::adc_config());

    let null_offset_v = match measure_null(&mut adc) {
        Ok(v) => v,
        Err(e) => fatal("bridge null offset", e),
    };

    let (Some(telemetry), Some(raw), Some(tx_ring), Some(rx_ring)) = (
        cortex_m::singleton!(: Queue<Record, TELEMETRY_QUEUE> = Queue::new()),
        cortex_m::singleton!(: Queue<RawBlock<f64>, RAW_QUEUE> = Queue::new()),
        cortex_m::singleton!(: uart::TxRing = Queue::new()),
        cortex_m::singleton!(: uart::RxRing = Queue::new()),
    ) else {
        fatal("static buffers", "taken twice")
    };
    let (telemetry_tx, mut telemetry_rx) = telemetry.split();
    let (raw_tx, mut raw_rx) = raw.split();

    let pipeline = match build_pipeline(null_offset_v, adc, dac, telemetry_tx, raw_tx) {
        Ok(p) => p,
        Err(e) => fatal("pipeline", e),
    };
    let task = SampleTask {
        pipeline,
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

    let (tx, drain, fill, rx) = b.uart.split(tx_ring, rx_ring);
    if SERIAL.put(SerialIsr { drain, fill }).is_err() {
        fatal("serial task", "not placed");
    }
    let mut link = Link::new(tx, rx);
    board::enable_serial_interrupt();
    board::enable_sample_interrupt();
    info!(
        "sample interrupt running; measuring Y0 over {} samples",
        rig::STARTUP_SAMPLES
    );

    let mut startup = Some(Startup::default());
    let mut records: u32 = 0;
    let mut last_record = cycles::now();
    loop {
        while let Some(block) = raw_rx.dequeue() {
            match startup.as_mut() {
                Some(s) => {
                    if s.add(&block) {
                        start_estimator(s.y_rms());
                        startup = None;
                    }
                }
                None => {
                    link.send_raw(&block);
                }
            }
        }
        while let Some(record) = telemetry_rx.dequeue() {
            last_record = cycles::now();
            records = records.wrapping_add(1);
            if records % LOG_EVERY_RECORDS == 0 {
                report(&record, &link);
                b.led_heartbeat.toggle();
                if record.counters != Counters::default() {
                    b.led_fault.set_high();
                }
                service_adc(&mut b.delay);
            }
        }
        while let Some(frame) = link.poll() {
            // Applying commands is the serial-link work (issue 7).
            info!(
                "link: frame seq {} kind {} received (not applied yet)",
                frame.seq,
                frame.message.kind()
            );
        }
        if cycles::between(last_record, cycles::now()) > STALL_CYCLES {
            // Re-armed every 0.5 s, so the difference never wraps.
            last_record = cycles::now();
            b.led_fault.set_high();
            warn!("no sample for 0.5 s: DRDY stopped (CLKIN, ADC supply, wiring?)");
        }
        // Woken by the next interrupt (DRDY every 100 µs, SysTick every 10 ms).
        cortex_m::asm::wfi();
    }
}

/// The pipeline, adaptation frozen until Y0 is known (the placeholder
/// estimator uses the front end's a priori scale and is never stepped).
fn build_pipeline(
    null_offset_v: f64,
    adc: Adc<SpiDev>,
    dac: Ad5761r<SpiDev>,
    telemetry: Producer<'static, Record>,
    raw: Producer<'static, RawBlock<f64>>,
) -> Result<RigPipeline, &'static str> {
    let placeholder = rig::estimator(rig::nominal_y_scale()).map_err(|_| "estimator settings")?;
    let excitation = rig::excitation().map_err(|_| "excitation settings")?;
    let mut pipeline = Pipeline::new(
        &rig::pipeline_config(null_offset_v),
        placeholder,
        excitation,
        adc,
        dac,
        telemetry,
        raw,
    )
    .map_err(|_| "pipeline settings")?;
    pipeline.freeze();
    Ok(pipeline)
}

/// The Y0 measurement over the first raw samples.
#[derive(Default)]
struct Startup {
    sum_sq: f64,
    n: u32,
    rejected: u32,
}

impl Startup {
    /// Add a raw block; `true` once [`rig::STARTUP_SAMPLES`] valid samples
    /// are in.
    fn add(&mut self, block: &RawBlock<f64>) -> bool {
        for y in block.y.iter().take(usize::from(block.len)) {
            if y.is_finite() {
                self.sum_sq += y * y;
                self.n += 1;
            } else {
                self.rejected += 1;
            }
        }
        self.n >= rig::STARTUP_SAMPLES
    }

    fn y_rms(&self) -> f64 {
        let y_rms = libm::sqrt(self.sum_sq / f64::from(self.n.max(1)));
        info!(
            "start-up: y_rms = {} over {} samples ({} rejected)",
            y_rms, self.n, self.rejected
        );
        y_rms
    }
}

/// Build the estimator with Y0 = `y_rms` (outside the lock), swap it in,
/// stop the raw stream (or slow it to the run-time rate), resume.
fn start_estimator(y_rms: f64) {
    let y0 = if y_rms.is_finite() && y_rms > 0.0 {
        y_rms
    } else {
        let nominal = rig::nominal_y_scale();
        warn!("start-up: no usable y_rms; Y0 = a priori {}", nominal);
        nominal
    };
    let estimator = match rig::estimator(y0) {
        Ok(e) => e,
        Err(e) => fatal("estimator", Debug2Format(&e)),
    };
    let swapped = SAMPLE.with(move |t| {
        let ok = t
            .pipeline
            .replace_estimator(estimator, rig::LAMBDA_RAD_S)
            .is_ok();
        t.pipeline.set_raw_decimation(rig::RAW_DECIMATION_RUN);
        t.pipeline.resume();
        ok
    });
    if swapped == Some(true) {
        info!(
            "estimator running: U0 = {} V, Y0 = {}, lambda = {} rad/s",
            rig::EXCITATION_AMPLITUDE_V,
            y0,
            rig::LAMBDA_RAD_S
        );
    } else {
        fatal("estimator hand-over", "refused");
    }
}

/// One status line: the recovered modes, λmin(P), the counters, the
/// sample interrupt's cycles (since the previous line) and the link.
fn report(record: &Record, link: &Link) {
    let r = recover(record, &rig::OUTPUT_WEIGHT);
    let t_s = record.sample_index as f64 * rig::TS_S;
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
        info!(
            "sample isr: mean {} max {} cycles of {} ({} late); counters {}",
            isr.mean(),
            isr.max,
            clocks::CYCLES_PER_SAMPLE,
            late,
            Debug2Format(&record.counters)
        );
    }
    info!(
        "link: sent {}, uart {}, received {}",
        link.send_stats(),
        uart::link_stats(),
        link.receive_stats()
    );
}

/// Re-initialise the ADC between samples if it reset itself (at most once
/// per status line). The interrupt is locked out for about ten frames; the
/// conversions it misses are counted as an overrun by the next tick.
fn service_adc(delay: &mut board::cycles::CycleDelay) {
    let needed = SAMPLE
        .with(|t| t.pipeline.converters_mut().0.needs_reinit())
        .unwrap_or(false);
    if !needed {
        return;
    }
    warn!("ADS131M02 lost its settings: re-initialising");
    let result = SAMPLE.with(|t| t.pipeline.converters_mut().0.reinit(delay).is_ok());
    if result != Some(true) {
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
}

/// Mean bridge voltage over [`rig::NULL_SAMPLES`] conversions, each read
/// after a DRDY edge (polled: the sample interrupt is not enabled yet).
fn measure_null(adc: &mut Adc<SpiDev>) -> Result<f64, NullError> {
    let volts_per_code = rig::conversion(0.0)
        .bridge_adc
        .volts_per_code()
        .map_err(|_| NullError::Scale)?;
    let mut sum: i64 = 0;
    let mut monitor: i64 = 0;
    let mut n: u32 = 0;
    let mut bad: u32 = 0;
    drdy::clear_pending();
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
/// NVIC line still off), for at most [`DRDY_TIMEOUT_PERIODS`]; clear it.
fn wait_drdy() -> Result<(), NullError> {
    let start = cycles::now();
    let limit = DRDY_TIMEOUT_PERIODS * clocks::CYCLES_PER_SAMPLE;
    while !drdy::is_pending() {
        if cycles::between(start, cycles::now()) > limit {
            return Err(NullError::NoDrdy);
        }
    }
    drdy::clear_pending();
    Ok(())
}

/// Start-up failure: piezo to 0 V, LD3 on, say why, stop.
fn fatal(what: &str, why: impl defmt::Format) -> ! {
    board::disable_sample_interrupt();
    board::safe_state();
    error!("halted: {}: {}", what, why);
    loop {
        cortex_m::asm::wfi();
    }
}
