//! Thread-mode reporting of the QEMU image (semihosting; the serial link
//! carries the protocol): a log line every 0.25 s of simulated time while
//! the estimate converges, from the recovery the link made for its
//! Estimate; at the end the instruction counts, the link's counters and the
//! cost of producing an Estimate frame, then what was measured as `rig:`
//! lines, and exit status 0 (1 only for a boot error). The image reads no
//! truth and judges nothing: `cargo xtask qemu` parses the `rig:` lines
//! and decides (`xtask/src/rig_report.rs`).
//!
//! The `rig:` lines, one each at the end of a run unless said otherwise,
//! each `rig: <what>` and then `key=value` words (numbers in decimal;
//! floats as `d.ddddddddde±x`, `nan` if absent):
//!
//! * `rig: fault at=<sample> kind=bad_crc|saturate|stuck|dropped n=<count>
//!   done_by=<sample>` — one per fault of the schedule injected into the
//!   ADC model (`sample::FAULTS`), and the sample by which all of them and
//!   their quarantines are over;
//! * `rig: counters adc_crc= adc_status= adc_bus= adc_other=
//!   bridge_saturated= monitor_saturated= stuck= rejected= dac_errors=
//!   dac_saturated= dropped_records=` — the pipeline's counters;
//! * `rig: robust running=true phase=startup|refining|steady updates=<n>
//!   lock_max_instructions=<n>` (or `running=false`) — only when the link
//!   switched to the robust estimator;
//! * `rig: recentre at=<sample> lambda=<rad/s>` — one per re-centring of
//!   λ by the tuning rule;
//! * `rig: tuning automatic=true|false lambda0= lambda= phase=startup|
//!   reviewing|converged|fixed|max_recentres|timeout recentre_threshold=
//!   lost_pairs= startup_dropped=` — the tuning rule at the end (λ0 of the
//!   first estimator, λ in use, relative re-centring threshold, start-up
//!   pairs lost by the rule and blocks refused by its queue);
//! * `rig: hum f1= a1= f2= a2=` — at boot, with `hum=1` on the command
//!   line: the lines added to y (Hz, m; `beamest::bench::HUM`);
//! * `rig: lines n=<lines> mains_hz= tau_s= a1= …` — the line remover at
//!   the end (`n=0`: off): per line (the mains' harmonics in order) the
//!   amplitude in y its weights hold (m);
//! * `rig: modes n=<modes> omega1= zeta1= omega2= zeta2=` — the final
//!   estimate's recovery (eqs. 30-32; `n=0` and nothing else without one);
//! * `rig: selftest at_boot=true|false failed= not_measured= first= last=
//!   fault=<bench fault>|none id= drdy_hz= gain= offset_v= delay= noise_sd=
//!   snr_db=` — one per self-test report, when it is made (the bit sets
//!   of `SelfTestChecks` in decimal);
//! * `rig: link rx_bytes= rx_frames= rx_errors= accepted= rejected=
//!   tx_frames= tx_dropped_frames= uart_rx_dropped= uart_tx_dropped=
//!   uart_rx_overruns=` — the serial link's counters at the end (bytes
//!   decoded, frames delivered and refused by the command decoder,
//!   commands, frames sent and dropped, bytes lost by the UART's rings and
//!   its receive overruns);
//! * `rig: end samples= overruns= rig_errors= started_at=<sample>|none
//!   estimator=adaptive|robust` — last: the run is over and reported.

#![deny(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::panic,
    clippy::indexing_slicing
)]

use beam_protocol::{encode, EstimatorKind, Message, SelfTestReport, StatusFlags, MAX_ENCODED_LEN};
use beamest::bench;
use beamest::board::qemu as board;
use beamest::board::qemu::cycles::{self, Calibration, SpanSum};
use beamest::board::qemu::uart::{self, UartTx};
use beamest::filter_bank::FilterConfig;
use beamest::link::{estimate, Convergence, EstimateContext};
use beamest::link::{BuildKind, DeviceLink, Sent, Transmitter, Tuned, TxSink};
use beamest::modal::modal_from_tf;
use beamest::model::ModalParams;
use beamest::pipeline::{recover, Recovered};
use beamest::tuning::{Phase, Settled};
use cortex_m_semihosting::hprintln;
use heapless::spsc::Queue;

use crate::device::QemuDevice;
use crate::numfmt::{Fixed, Sci};
use crate::robust::{self, RobustUpdates};
use crate::sample::{self, Fault, Record, Summary, PERIODS};

/// Output weights C̄ (eq. 24), for b̄.
pub const OUTPUT_WEIGHT: [f32; 2] = [-2.0, 2.0];
/// Semihosting log interval while converging, samples (0.25 s).
pub const LOG_EVERY: u64 = 2_500;
/// Repetitions of the timed Estimate-frame production.
const FRAME_REPS: u32 = 100;

/// A log line at the first recovered record from `next_log` on;
/// `estimating`: the law has updated since it started (else Θ̂ is its
/// initial value, not an estimate).
pub fn log(
    record: &Record,
    recovered: Option<&Recovered<f32>>,
    estimating: bool,
    next_log: &mut u64,
) {
    let Some(rec) = recovered else {
        return;
    };
    if record.sample_index < *next_log {
        return;
    }
    *next_log = (record.sample_index / LOG_EVERY + 1) * LOG_EVERY;
    let t_s = Fixed(record.sample_index as f64 * bench::TS_S, 2);
    if !estimating {
        hprintln!(
            "t = {} s  no estimate yet: the new law is held while its filters settle \
             (last 100 steps: {} held)",
            t_s,
            record.steps.frozen
        );
        return;
    }
    let lmin = rec.excitation_min_eig.map_or(f64::NAN, f64::from);
    let Ok(m) = rec.modal else {
        hprintln!(
            "t = {} s  no modes recovered  lambda_min(P) = {}",
            t_s,
            Sci(lmin, 2)
        );
        return;
    };
    let [w1, w2, ..] = m.omega_rad_s.map(f64::from);
    let [z1, z2, ..] = m.zeta.map(f64::from);
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

/// Log an estimator the tuning rule swapped in, and note it in `run`.
pub fn on_build(t: &Tuned, link: &DeviceLink, run: &mut Run) {
    let f: &FilterConfig = &t.filter;
    match t.kind {
        BuildKind::First => {
            run.started_at = Some(t.at);
            run.first_lambda = Some(f.lambda_rad_s);
            hprintln!(
                "start-up: U0 = {} V, Y0 = {} m (RMS of u, y over {} samples, excitation \
                 running); lambda = {} rad/s ({}); estimator running from sample {}",
                Sci(f.scales.u_scale, 4),
                Sci(f.scales.y_scale, 4),
                link.tuner().rule().stats().samples(),
                Fixed(f.lambda_rad_s, 1),
                if link.is_automatic() {
                    "automatic: twice the frequency centroid of y"
                } else {
                    "commanded"
                },
                t.at
            );
        }
        BuildKind::Recentre => {
            let _ = run.recentred.push((t.at, f.lambda_rad_s));
            hprintln!(
                "tuning: lambda re-centred on the estimated band: {} rad/s, estimate carried \
                 over; running from sample {}",
                Fixed(f.lambda_rad_s, 1),
                t.at
            );
        }
    }
}

/// What thread mode saw of the tuning rule's builds.
#[derive(Debug, Clone)]
pub struct Run {
    /// First sample of the first estimator.
    pub started_at: Option<u64>,
    /// Its λ (rad/s).
    pub first_lambda: Option<f64>,
    /// Re-centrings: (first sample, λ).
    pub recentred: heapless::Vec<(u64, f64), 4>,
    /// The first start-up block (for the cost of the rule's window).
    pub first_block: Option<crate::sample::Raw>,
    /// The robust estimator's model updates (when it runs).
    pub robust: RobustUpdates,
    /// Thread mode's handling of each self-test block.
    pub selftest_blocks: SpanSum,
    /// Thread mode's passes over received bytes (decoding, commands,
    /// Acks; the sample interrupt's preemptions included) …
    pub receive: SpanSum,
    /// … and the bytes they took.
    pub received: u64,
}

impl Default for Run {
    fn default() -> Self {
        Self {
            started_at: None,
            first_lambda: None,
            recentred: heapless::Vec::new(),
            first_block: None,
            robust: robust::updates(),
            selftest_blocks: SpanSum::default(),
            receive: SpanSum::default(),
            received: 0,
        }
    }
}

/// A self-test's report: the log lines and `rig: selftest`.
pub fn self_test(r: &SelfTestReport, fault: Option<bench::BenchFault>) {
    hprintln!(
        "self-test ({}, samples {} to {}): failed {:#06x}, not measured {:#06x}; ADC ID {:04X}h, \
         registers {:04X}h {:04X}h {:04X}h (configured {:04X}h {:04X}h {:04X}h); DRDY {} Hz ({} \
         conversions in {} ticks); loopback gain {}, offset {} V, delay {} samples (expected {}); \
         noise sd {} (floor {}), signal RMS {}, SNR {} dB",
        if r.at_boot { "at boot" } else { "on command" },
        r.first_sample,
        r.last_sample,
        r.failed.0,
        r.not_measured.0,
        r.adc.id,
        r.adc.registers[0],
        r.adc.registers[1],
        r.adc.registers[2],
        r.adc.expected[0],
        r.adc.expected[1],
        r.adc.expected[2],
        Sci(f64::from(r.drdy.rate_hz), 6),
        r.drdy.conversions,
        r.drdy.ticks,
        Sci(f64::from(r.loopback.gain), 6),
        Sci(f64::from(r.loopback.offset_v), 3),
        Sci(f64::from(r.loopback.delay_samples), 6),
        Sci(f64::from(r.loopback.expected_delay_samples), 6),
        Sci(f64::from(r.noise.noise_sd), 3),
        Sci(f64::from(r.noise.floor_sd), 3),
        Sci(f64::from(r.noise.signal_rms), 4),
        Sci(f64::from(r.noise.snr_db), 4)
    );
    hprintln!(
        "rig: selftest at_boot={} failed={} not_measured={} first={} last={} fault={} id={} \
         drdy_hz={} gain={} offset_v={} delay={} noise_sd={} snr_db={}",
        r.at_boot,
        r.failed.0,
        r.not_measured.0,
        r.first_sample,
        r.last_sample,
        fault.map_or("none", bench::BenchFault::name),
        r.adc.id,
        Sci(f64::from(r.drdy.rate_hz), 9),
        Sci(f64::from(r.loopback.gain), 9),
        Sci(f64::from(r.loopback.offset_v), 9),
        Sci(f64::from(r.loopback.delay_samples), 9),
        Sci(f64::from(r.noise.noise_sd), 9),
        Sci(f64::from(r.noise.snr_db), 9)
    );
}

/// Mean instructions of a span sum.
fn mean(s: &SpanSum, ipt: f32) -> f64 {
    f64::from(s.mean_instructions(ipt))
}

/// End of run: report, exit.
pub fn finish(
    s: &Summary,
    last: Option<&Record>,
    cal: &Calibration,
    run: &Run,
    link: &DeviceLink,
    device: &mut QemuDevice,
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
         {} rejected, {} skipped; overruns: {}; rig errors: {}",
        s.samples,
        Fixed(f64::from(s.samples) * bench::TS_S, 1),
        run.started_at.unwrap_or(0),
        updated,
        held,
        rejected,
        skipped,
        s.overruns,
        s.rig_errors
    );
    let ts = link.tx_stats();
    let rc = link.rx_counters();
    let (accepted, refused) = link.commands();
    let uart = uart::link_stats();
    hprintln!(
        "serial link: {} frames ({} bytes) sent, {} dropped on a full TX ring; commands: {} \
         accepted, {} rejected; received {} bytes, {} frames, {} bad frames; uart0 ring \
         overflows: tx {} B, rx {} B; receive overruns {}",
        ts.frames_sent,
        ts.bytes_sent,
        ts.frames_dropped,
        accepted,
        refused,
        rc.bytes,
        rc.frames_ok,
        rc.errors(),
        uart.tx_dropped,
        uart.rx_dropped,
        uart.rx_overruns
    );
    hprintln!(
        "rig: link rx_bytes={} rx_frames={} rx_errors={} accepted={} rejected={} tx_frames={} \
         tx_dropped_frames={} uart_rx_dropped={} uart_tx_dropped={} uart_rx_overruns={}",
        rc.bytes,
        rc.frames_ok,
        rc.errors(),
        accepted,
        refused,
        ts.frames_sent,
        ts.frames_dropped,
        uart.rx_dropped,
        uart.tx_dropped,
        uart.rx_overruns
    );
    if run.received > 0 {
        hprintln!(
            "serial link receive: {} instructions per byte received (mean over {} bytes in {} \
             passes of thread mode: decoding, the commands and their Acks, the sample \
             interrupt's preemptions included)",
            Fixed(
                run.receive.ticks as f64 * f64::from(ipt) / run.received as f64,
                1
            ),
            run.received,
            run.receive.count
        );
    }
    let locks = device.locks();
    hprintln!(
        "pipeline locks from thread mode (commands, start-up): {}, longest {} instructions \
         (the most any of them delayed a sample)",
        locks.count,
        (locks.max_ticks as f32 * ipt) as u32
    );
    hprintln!(
        "self-test: the sample interrupt's copy of a tick {} instructions (mean over {} \
         ticks, max {}), {} blocks refused; thread mode per 32-tick block {} instructions \
         (mean over {} blocks, max {})",
        Fixed(mean(&s.selftest, ipt), 0),
        s.selftest.count,
        (s.selftest.max_ticks as f32 * ipt) as u32,
        s.selftest_dropped,
        Fixed(mean(&run.selftest_blocks, ipt), 0),
        run.selftest_blocks.count,
        (run.selftest_blocks.max_ticks as f32 * ipt) as u32
    );
    rig_faults(s);
    let robust_running = link.settings().estimator.kind == EstimatorKind::Robust;

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
    let modes = modal_from_tf(&s.tf, &OUTPUT_WEIGHT).ok();
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
    if let Some(r) = last {
        frame_cost(r, ipt);
    }
    tuning_cost(run, link, device, &s.tf, ipt);
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

    if robust_running {
        robust::report(&run.robust, device, ipt);
    }
    rig_tuning(run, link, s.startup_dropped);
    rig_modes(modes.as_ref());
    rig_lines(s, link);
    hprintln!(
        "rig: end samples={} overruns={} rig_errors={} started_at={} estimator={}",
        s.samples,
        s.overruns,
        s.rig_errors,
        Opt(run.started_at),
        if robust_running { "robust" } else { "adaptive" }
    );
    // Let the TX interrupt hand the last frames to the UART (≤ 40 ms).
    let mut spins = 0u32;
    while !tx.is_drained() && spins < 20_000 {
        spins += 1;
        board::idle();
    }
    // The last byte leaves the UART's one-byte buffer.
    board::idle();
    board::exit(true)
}

/// `rig: fault` (the schedule injected into the ADC model) and `rig:
/// counters` (the pipeline's counters at the end).
fn rig_faults(s: &Summary) {
    for (at, fault) in sample::FAULTS {
        let (kind, n) = match fault {
            Fault::BadCrc(n) => ("bad_crc", n),
            Fault::Saturate(n) => ("saturate", n),
            Fault::Stuck(n) => ("stuck", n),
            Fault::Dropped(n) => ("dropped", n),
        };
        hprintln!(
            "rig: fault at={} kind={} n={} done_by={}",
            at,
            kind,
            n,
            sample::FAULTS_DONE_BY
        );
    }
    let c = &s.counters;
    hprintln!(
        "rig: counters adc_crc={} adc_status={} adc_bus={} adc_other={} bridge_saturated={} \
         monitor_saturated={} stuck={} rejected={} dac_errors={} dac_saturated={} \
         dropped_records={}",
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
}

/// `rig: tuning` (the rule's state at the end) and one `rig: recentre`
/// per re-centring.
fn rig_tuning(run: &Run, link: &DeviceLink, startup_dropped: u32) {
    for (at, lambda) in &run.recentred {
        hprintln!("rig: recentre at={} lambda={}", at, Sci(*lambda, 9));
    }
    hprintln!(
        "rig: tuning automatic={} lambda0={} lambda={} phase={} recentre_threshold={} \
         lost_pairs={} startup_dropped={}",
        link.is_automatic(),
        Sci(run.first_lambda.unwrap_or(f64::NAN), 9),
        Sci(link.lambda_rad_s().unwrap_or(f64::NAN), 9),
        match link.tuner().phase() {
            Phase::Startup => "startup",
            Phase::Reviewing => "reviewing",
            Phase::Settled(Settled::Converged) => "converged",
            Phase::Settled(Settled::Fixed) => "fixed",
            Phase::Settled(Settled::MaxRecentres) => "max_recentres",
            Phase::Settled(Settled::Timeout) => "timeout",
        },
        Sci(link.tuner().rule().config().recentre_threshold, 9),
        link.tuner().lost_pairs(),
        startup_dropped
    );
}

/// `rig: lines` (the line remover at the end: its lines and the
/// amplitude in y each one's weights hold).
fn rig_lines(s: &Summary, link: &DeviceLink) {
    let l = link.line_removal();
    let mut text: heapless::String<256> = heapless::String::new();
    for (i, a) in s.line_amplitudes.iter().take(s.lines).enumerate() {
        let _ = core::fmt::Write::write_fmt(
            &mut text,
            format_args!(" a{}={}", i + 1, Sci(f64::from(*a), 4)),
        );
    }
    hprintln!(
        "rig: lines n={} mains_hz={} tau_s={}{}",
        s.lines,
        Fixed(f64::from(l.mains_hz), 3),
        Fixed(f64::from(l.time_constant_s), 3),
        text.as_str()
    );
}

/// `rig: modes` (the final estimate; `n=0` without one).
fn rig_modes(modes: Option<&ModalParams<f32>>) {
    let Some(m) = modes else {
        hprintln!("rig: modes n=0");
        return;
    };
    let [w1, w2, ..] = m.omega_rad_s.map(f64::from);
    let [z1, z2, ..] = m.zeta.map(f64::from);
    hprintln!(
        "rig: modes n={} omega1={} zeta1={} omega2={} zeta2={}",
        m.modes,
        Sci(w1, 9),
        Sci(z1, 9),
        Sci(w2, 9),
        Sci(z2, 9)
    );
}

/// An optional count: the number or `none`.
struct Opt(Option<u64>);

impl core::fmt::Display for Opt {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self.0 {
            Some(v) => write!(f, "{v}"),
            None => f.write_str("none"),
        }
    }
}

/// The cost of producing one Estimate frame from a recovered record
/// (`recover()` itself is timed above): the message with its flags, and
/// postcard + COBS + CRC-32 encoding and queuing into a byte ring like the
/// UART's, each averaged over [`FRAME_REPS`] dithered spans (timer
/// stopped, so nothing preempts). A separate transmitter and ring: the
/// link's sequence numbers are untouched.
fn frame_cost(r: &Record, ipt: f32) {
    let rec = recover(r, &OUTPUT_WEIGHT);
    let rules = link_rules();
    let ctx = EstimateContext {
        estimator: EstimatorKind::Adaptive,
        model_modes: 2,
        rules: &rules,
        previous: &r.counters,
        dropped_elsewhere: false,
        earlier_events: StatusFlags::default(),
        no_update_yet: false,
    };
    let mut ring: Queue<u8, 256> = Queue::new();
    let (mut p, mut c) = ring.split();
    let mut sender = Transmitter::new();
    let mut build = SpanSum::default();
    let mut send = SpanSum::default();
    let mut encode_only = SpanSum::default();
    let mut buf = [0u8; MAX_ENCODED_LEN];
    let mut bytes = 0;
    for k in 0..FRAME_REPS {
        let mut conv = Convergence::default();
        cycles::dither(k);
        let t0 = cycles::now();
        let msg = Message::Estimate(estimate(r, &rec, &ctx, &mut conv));
        let t1 = cycles::now();
        build.add(t0, t1);
        cycles::dither(k);
        let t2 = cycles::now();
        let sent = sender.send(&msg, 0, &mut p);
        let t3 = cycles::now();
        send.add(t2, t3);
        if let Sent::Queued(n) = sent {
            bytes = n;
        }
        cycles::dither(k);
        let t4 = cycles::now();
        let n = encode(&msg, 0, &mut buf);
        let t5 = cycles::now();
        encode_only.add(t4, t5);
        let _ = core::hint::black_box(n);
        while c.dequeue().is_some() {}
        core::hint::black_box(p.free());
    }
    let (b, e, c) = (
        build.mean_instructions(ipt),
        send.mean_instructions(ipt),
        encode_only.mean_instructions(ipt),
    );
    hprintln!(
        "estimate_frame_instructions: {} (message from the recovered record {}; encoding and \
         queuing {}: postcard + COBS + CRC-32 into a buffer {}, the copy into the byte ring \
         the rest; {} bytes on the wire; recover() not included)",
        libm::roundf(b + e) as u32,
        libm::roundf(b) as u32,
        libm::roundf(e) as u32,
        libm::roundf(c) as u32,
        bytes
    );
}

/// Thread-mode costs of the tuning rule (timer stopped, nothing preempts):
/// one start-up block of 32 pairs (`AutoTune::startup_sample`, f64 in
/// software), one review of the final estimate (its poles), the carry-over
/// to a new λ, and one estimator build (the matrix exponentials) into the
/// spare slot, which is given back.
fn tuning_cost(
    run: &Run,
    link: &DeviceLink,
    device: &mut QemuDevice,
    tf: &beamest::model::TransferFunction<f32>,
    ipt: f32,
) {
    let cfg = *link.tuner().rule().config();
    let ticks = |t0: u32| (cycles::ticks_between(t0, cycles::now()) as f32 * ipt) as u32;
    let block = run.first_block.map_or(0, |b| {
        let Ok(mut t) = beamest::link::Tuner::new(&cfg) else {
            return 0;
        };
        let t0 = cycles::now();
        core::hint::black_box(t.startup_block(&b));
        ticks(t0)
    });
    let Some(filter) = link.filter().copied() else {
        return;
    };
    let mut rule = beamest::tuning::AutoTune::new(&beamest::tuning::TuningConfig {
        scales: Some(filter.scales),
        lambda: beamest::tuning::LambdaSource::Band {
            lo_rad_s: filter.lambda_rad_s,
            hi_rad_s: filter.lambda_rad_s,
        },
        ..cfg
    })
    .ok();
    let review = rule.as_mut().map_or(0, |r| {
        let t0 = cycles::now();
        core::hint::black_box(r.review(tf));
        ticks(t0)
    });
    let moved = beamest::filter_bank::FilterConfig {
        lambda_rad_s: filter.lambda_rad_s * 1.2,
        ..filter
    };
    let t0 = cycles::now();
    let theta0 = beamest::tuning::carry_over::<f32, { crate::sample::NP }>(tf, &moved);
    let carry = ticks(t0);
    let t0 = cycles::now();
    let built = beamest::link::Device::build_estimator(
        device,
        &link.settings().estimator,
        &moved,
        theta0.as_ref().map_or(&[][..], |t| &t[..]),
    );
    let build = ticks(t0);
    let ok = built.is_ok();
    if let Ok(e) = built {
        beamest::link::Device::recycle_estimator(device, e);
    }
    hprintln!(
        "tuning_thread_instructions: startup_block={} (32 pairs) review={} carry_over={} \
         build={} (estimator {}built at lambda {} rad/s)",
        block,
        review,
        carry,
        build,
        if ok { "" } else { "NOT " },
        Fixed(moved.lambda_rad_s, 1)
    );
}

/// The link's flag thresholds (the same as the running link's).
fn link_rules() -> beamest::link::FlagRules {
    bench::link_config(board::UART_BAUD).rules
}
