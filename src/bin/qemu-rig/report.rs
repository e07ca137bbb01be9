//! Thread-mode reporting of the QEMU image: each telemetry record turned
//! into ω, ζ, b̄ and λmin(P) (`pipeline::recover`), a CSV line on UART0 and
//! a semihosting log line while the estimate converges; at the end the
//! instruction counts, the fault counters against what was injected, and
//! ω, ζ against the simulated truth (the one place that reads it), then the
//! exit status.

#![deny(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::panic,
    clippy::indexing_slicing
)]

use core::fmt::Write as _;

use beamest::board::qemu as board;
use beamest::board::qemu::cycles::{self, Calibration, SpanSum};
use beamest::board::qemu::uart::{self, UartTx};
use beamest::modal::modal_from_tf;
use beamest::model::{ModalParams, TransferFunction, PAPER_OMEGA, PAPER_ZETA};
use beamest::pipeline::{recover, StatusFlags};
use beamest::rig::bench;
use cortex_m_semihosting::hprintln;

use crate::numfmt::{Fixed, Sci};
use crate::sample::{self, Record, Summary, PERIODS, RUN_SAMPLES};

/// Output weights C̄ (eq. 24), for b̄.
const OUTPUT_WEIGHT: [f32; 2] = [-2.0, 2.0];
/// Pass criterion: relative error of every ω and ζ after the run.
const TOLERANCE: f64 = 1e-3;
/// Semihosting log interval while converging, samples (0.25 s).
pub const LOG_EVERY: u64 = 2_500;

/// Thread-mode handling of one telemetry record: recovery, UART line, and
/// a log line at the first record from `next_log` on.
pub fn handle(record: &Record, tx: &mut UartTx, next_log: &mut u64) {
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
pub fn finish(
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
