//! `cargo xtask qemu --e2e`: the QEMU image's UART0 on a loopback socket
//! to a host that decodes every frame with the core's `Decoder` (the same
//! code the firmware and `beamctl` link), sends commands, and checks:
//!
//! 1. the decoded estimates converge to the simulated beam's truth: the
//!    last physically valid estimate within 1e-3 on ω1, ω2, ζ1, ζ2 after
//!    6 s, with the EXCITED, PHYSICALLY_VALID and CONVERGED flags;
//!    estimates during the injected ADC faults carry SENSOR_FAULT and
//!    ADC_SATURATED;
//! 2. the link is clean: no sequence gap, no duplicate, no CRC or other
//!    frame error, nothing dropped on the device (Status telemetry_dropped
//!    = 0), every command answered;
//! 3. commands work: raw samples switched on at 0.5 s (SetTelemetry) arrive;
//!    at 1 s an excitation of 20 V (outside the ±10 V safe window) is
//!    refused with reason SafeWindow (3) and the Status that follows shows
//!    every setting unchanged; at 1.5 s an amplitude of 0.2 V is accepted,
//!    the next Status shows it, and the raw samples' u is at ±0.1 V before
//!    the command and at ±0.2 V from that Status on;
//! 4. the automatic tuning rule (docs/SETTINGS.md) runs on the device and
//!    follows `SetEstimator`: the first Status (before the start-up window
//!    closes) reports no λ; right after raw samples are switched on (0.5 s,
//!    before the faults, whose quarantines would hold a new law) the host
//!    fixes λ = 50 rad/s (`SetEstimator` with `lambda_rad_s = Some(50)`)
//!    and at once returns to the automatic rule (`None`); the Status that
//!    follows reports λ = 50 (the rule continues from the λ in use), and
//!    by the end the rule has re-centred λ on the band of the device's own
//!    estimate (the last Status's λ within 10% of √(ω̂1·ω̂2) and more than
//!    10% away from 50) while the estimate still meets check 1. Nothing the
//!    device uses comes from the truth; only this host compares with it.
//!
//! 5. the self-test: the one at start-up reported, every check passed; at
//!    4 s a `SelfTest` command is accepted, a `Reset` right after it is
//!    refused (Busy), the report comes with every check passed, the
//!    estimates made during it carry SELF_TEST with Θ̂ held, and the
//!    excitation in force (0.2 V) is back afterwards; the estimate meets
//!    check 1 at the end of the 6 s run.
//!
//! The schedule runs on the device's clock (the sample index in the frames),
//! so it does not depend on how fast the host runs QEMU. The run is also
//! judged from the firmware's log as the plain run is
//! ([`crate::rig_report`]). The test fails with a message naming each
//! check that failed, and if the firmware fails (its exit status).

use std::io::{self, Write};
use std::net::TcpStream;
use std::path::Path;
use std::time::{Duration, Instant};

use beam_protocol::{
    encode, AckResult, Command, Decoder, Estimate, EstimatorSettings, Excitation, Frame,
    LinkCounters, Message, RejectReason, SelfTestReport, Status, StatusFlags, TelemetryRates,
    Waveform, MAX_ENCODED_LEN,
};
use beamest::model::{PAPER_OMEGA, PAPER_ZETA};

use crate::emulator::{session, LinkHost};
use crate::QEMU;

/// What a stream of device frames contained.
#[derive(Debug, Default, Clone)]
pub struct Tally {
    pub estimates: u64,
    pub raw: u64,
    pub status: u64,
    pub acks: u64,
    pub self_tests: u64,
    pub other: u64,
    /// Estimates before the first one with modes.
    pub without_modes_first: u64,
    /// Estimates that break PROTOCOL.md §4.1's meaning: EXCITED not
    /// (excitation_level ≥ the firmware's 1e-7 and INPUT_GONE clear),
    /// modes / PHYSICALLY_VALID with Θ̂ = 0, or modes that are not the
    /// roots of the A(s) that the estimate's own Θ̂ and λ define, or gains
    /// b̄ that are not §4.0's for the emulated rig's output weights (§9.6).
    pub meaning_violations: u64,
    /// Estimates with modes whose λ no Status had named when they arrived
    /// (before the first Status with a λ, or after a re-centring before
    /// the Status that names the new λ): read (and checked) from their own
    /// Θ̂ and λ alone.
    pub with_modes_before_lambda_status: u64,
    /// The λ values (f32 bits) Statuses have named so far.
    pub lambdas_named: Vec<u32>,
}

/// How far (relative to the size of the terms) a coefficient of A(s) from
/// Θ̂ and λ may differ from the product of the sent modes' polynomials: the
/// f32 rounding of Θ̂ and the device's root finding (3e-7 of k_j measured
/// on the plain QEMU capture); a wrong λ or Θ̂ misses by percent.
const MODES_FROM_THETA_TOLERANCE: f64 = 1e-5;

/// An estimate's modes are those its own Θ̂ and λ define (PROTOCOL.md §4.0,
/// eqs. 29–30), with nothing else from the stream: A(s) = Λ(s) − (the
/// last 2n entries of Θ̂), Λ(s) = (s + λ)^{2n}, must equal
/// Π_i (s² + 2ζ_iω_i s + ω_i²) coefficient by coefficient. No modes: true.
pub fn modes_follow_from_theta(e: &Estimate) -> bool {
    let n = e.modes.len();
    if n == 0 {
        return true;
    }
    let d = 2 * n;
    if e.theta.len() != 4 * n - 1 {
        return false;
    }
    let lambda = f64::from(e.lambda_rad_s);
    // Π q_i, ascending powers, monic of degree 2n.
    let mut product = vec![1.0f64];
    for m in &e.modes {
        let (w, z) = (f64::from(m.omega_rad_s), f64::from(m.zeta));
        let q = [w * w, 2.0 * z * w, 1.0];
        let mut next = vec![0.0; product.len() + 2];
        for (i, p) in product.iter().enumerate() {
            for (j, c) in q.iter().enumerate() {
                next[i + j] += p * c;
            }
        }
        product = next;
    }
    (0..d).all(|j| {
        // k_j = C(2n, j) λ^{2n−j}; entry 4n − 2 − j of Θ̂ is k_j − a_j.
        let binom = (0..j).fold(1.0, |b, i| b * (d - i) as f64 / (i + 1) as f64);
        let k = binom * lambda.powi((d - j) as i32);
        let a = k - f64::from(e.theta[4 * n - 2 - j]);
        (a - product[j]).abs() <= MODES_FROM_THETA_TOLERANCE * (k.abs() + product[j].abs())
    })
}

/// The firmware's EXCITED threshold on excitation_level (PROTOCOL.md §9.3).
const EXCITED_LEVEL: f32 = 1e-7;

/// An estimate's flags and modes mean what PROTOCOL.md §4.1 says.
pub fn estimate_means_what_it_says(e: &Estimate) -> bool {
    let level_ok = e.excitation_level.is_some_and(|l| l >= EXCITED_LEVEL);
    let excited = level_ok && !e.flags.contains(StatusFlags::INPUT_GONE);
    let zero = e.theta.iter().all(|v| *v == 0.0);
    e.flags.contains(StatusFlags::EXCITED) == excited
        && !(zero && (!e.modes.is_empty() || e.flags.contains(StatusFlags::PHYSICALLY_VALID)))
        && modes_follow_from_theta(e)
        && gains_follow_from_theta(e, &beamest::bench::OUTPUT_WEIGHT)
}

/// How far a sent b̄_i may be from the least-squares solution of §4.0 on
/// the estimate's own Θ̂ and modes, relative to the largest |b̄|: the f32
/// rounding of Θ̂ and of the modes and the device's own solve (3e-6
/// measured on the plain QEMU capture); another sign or scale of the
/// output weights misses by a factor.
const GAINS_FROM_THETA_TOLERANCE: f64 = 1e-4;

/// An estimate's modal gains b̄ are PROTOCOL.md §4.0's (eqs. 31–32) for
/// the device's output weights `weights` (ascending ω; §9.6): the
/// least-squares solution of Σ_i c_i·b̄_i·Π_{j≠i} q_j(s) = B(s), B's
/// coefficients b_{2n−2} … b_0 being the first 2n − 1 entries of Θ̂ and
/// q_i the sent modes' polynomials. No modes: true.
pub fn gains_follow_from_theta(e: &Estimate, weights: &[f64]) -> bool {
    let n = e.modes.len();
    if n == 0 {
        return true;
    }
    if e.theta.len() != 4 * n - 1 || weights.len() != n {
        return false;
    }
    let q: Vec<[f64; 3]> = e
        .modes
        .iter()
        .map(|m| {
            let (w, z) = (f64::from(m.omega_rad_s), f64::from(m.zeta));
            [1.0, 2.0 * z * w, w * w]
        })
        .collect();
    // Column i: c_i·Π_{j≠i} q_j, descending powers s^{2n−2} … s^0.
    let columns: Vec<Vec<f64>> = (0..n)
        .map(|i| {
            let mut p = vec![weights[i]];
            for qj in q
                .iter()
                .enumerate()
                .filter(|(j, _)| *j != i)
                .map(|(_, qj)| qj)
            {
                let mut next = vec![0.0; p.len() + 2];
                for (a, pa) in p.iter().enumerate() {
                    for (b, qb) in qj.iter().enumerate() {
                        next[a + b] += pa * qb;
                    }
                }
                p = next;
            }
            p
        })
        .collect();
    let rhs: Vec<f64> = e.theta[..2 * n - 1].iter().map(|&v| f64::from(v)).collect();
    // Normal equations (n ≤ 3), Gaussian elimination with partial pivoting.
    let mut m: Vec<Vec<f64>> = (0..n)
        .map(|i| {
            let mut row: Vec<f64> = (0..n)
                .map(|j| columns[i].iter().zip(&columns[j]).map(|(a, b)| a * b).sum())
                .collect();
            row.push(columns[i].iter().zip(&rhs).map(|(a, b)| a * b).sum());
            row
        })
        .collect();
    for col in 0..n {
        let pivot = (col..n)
            .max_by(|&a, &b| m[a][col].abs().total_cmp(&m[b][col].abs()))
            .unwrap_or(col);
        m.swap(col, pivot);
        if m[col][col] == 0.0 {
            return false;
        }
        let pivot_row = m[col].clone();
        for row in m.iter_mut().skip(col + 1) {
            let f = row[col] / pivot_row[col];
            for (v, p) in row.iter_mut().zip(&pivot_row).skip(col) {
                *v -= f * p;
            }
        }
    }
    let mut x = vec![0.0; n];
    for r in (0..n).rev() {
        let tail: f64 = (r + 1..n).map(|k| m[r][k] * x[k]).sum();
        x[r] = (m[r][n] - tail) / m[r][r];
    }
    let scale = x.iter().fold(0.0f64, |a, v| a.max(v.abs()));
    e.modes.iter().zip(&x).all(|(mode, want)| {
        (f64::from(mode.b_bar) - want).abs() <= GAINS_FROM_THETA_TOLERANCE * scale
    })
}

impl Tally {
    pub(crate) fn count(&mut self, m: &Message) {
        if let Message::Estimate(e) = m {
            if self.without_modes_first == self.estimates && e.modes.is_empty() {
                self.without_modes_first += 1;
            }
            if !estimate_means_what_it_says(e) {
                self.meaning_violations += 1;
            }
            if !e.modes.is_empty() && !self.lambdas_named.contains(&e.lambda_rad_s.to_bits()) {
                self.with_modes_before_lambda_status += 1;
            }
        }
        if let Message::Status(s) = m {
            if let Some(l) = s.estimator.lambda_rad_s {
                if !self.lambdas_named.contains(&l.to_bits()) {
                    self.lambdas_named.push(l.to_bits());
                }
            }
        }
        let c = match m {
            Message::Estimate(_) => &mut self.estimates,
            Message::RawSamples(_) => &mut self.raw,
            Message::Status(_) => &mut self.status,
            Message::Ack(_) => &mut self.acks,
            Message::SelfTestReport(_) => &mut self.self_tests,
            Message::Command(_) => &mut self.other,
        };
        *c += 1;
    }
}

/// A decoded capture: the decoder's counters and the tally.
pub struct Capture {
    pub counters: LinkCounters,
    pub tally: Tally,
    pub last_status: Option<Status>,
    /// The self-test reports, in order.
    pub reports: Vec<SelfTestReport>,
}

impl Capture {
    /// No error, gap, duplicate or reordering, and every estimate means
    /// what the protocol says.
    pub fn is_clean(&self) -> bool {
        let c = &self.counters;
        c.errors() == 0
            && c.lost == 0
            && c.duplicates == 0
            && c.out_of_order == 0
            && self.tally.meaning_violations == 0
    }

    /// One line.
    pub fn summary(&self) -> String {
        let c = &self.counters;
        let t = &self.tally;
        format!(
            "{} bytes, {} frames ({} estimates, {} status, {} raw-sample blocks, {} acks); \
             {} estimates before the first with modes, {} with modes at a λ no Status had named \
             yet (read from their own Θ̂ and λ), {} estimates against PROTOCOL.md §4.0/§4.1; \
             lost {}, CRC errors {}, other frame errors {}, duplicates {}, out of order {}{}",
            c.bytes,
            c.frames_ok,
            t.estimates,
            t.status,
            t.raw,
            t.acks,
            t.without_modes_first,
            t.with_modes_before_lambda_status,
            t.meaning_violations,
            c.lost,
            c.crc_errors,
            c.errors() - c.crc_errors,
            c.duplicates,
            c.out_of_order,
            self.last_status
                .as_ref()
                .map(|s| format!(
                    "; device: telemetry dropped {}, overruns {}",
                    s.counters.telemetry_dropped, s.counters.overruns
                ))
                .unwrap_or_default()
        )
    }
}

/// Decode a capture of the device's bytes from its start.
pub fn decode_capture(bytes: &[u8]) -> Capture {
    let mut dec: Decoder = Decoder::new();
    let mut tally = Tally::default();
    let mut last_status = None;
    let mut reports = Vec::new();
    for f in dec.feed(bytes).flatten() {
        tally.count(&f.message);
        match f.message {
            Message::Status(s) => last_status = Some(s),
            Message::SelfTestReport(r) => reports.push(r),
            _ => {}
        }
    }
    Capture {
        counters: *dec.counters(),
        tally,
        last_status,
        reports,
    }
}

/// Device time (samples) at which each command is sent.
const RAW_ON_AT: u64 = 5_000;
const REFUSED_AT: u64 = 10_000;
const AMPLITUDE_AT: u64 = 15_000;
/// The self-test on command: after the fault schedule (its quarantines
/// end by 4 s), 1 s before the end of the run.
const SELF_TEST_AT: u64 = 40_000;
/// The run's simulated length (s).
const SECONDS: &str = "6";
/// The raw samples' decimation (1 kHz) and the two amplitudes (V).
const RAW_DECIMATION: u16 = 10;
const AMPLITUDE_BEFORE_V: f32 = 0.1;
const AMPLITUDE_AFTER_V: f32 = 0.2;
/// The refused amplitude: outside the ±10 V window.
const AMPLITUDE_REFUSED_V: f32 = 20.0;
use crate::e2e_tuning::FIXED_LAMBDA;
/// |u| vs the amplitude: the 16-bit DAC holds 0.1 V as 0.1007 V.
const U_TOLERANCE: f32 = 0.02;
/// Estimates vs the truth.
const TOLERANCE: f64 = 1e-3;
/// Wall time allowed for an acknowledgement.
const ACK_TIMEOUT: Duration = Duration::from_secs(10);

/// The host's progress through the schedule.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Step {
    WaitRawOn,
    RawOnSent,
    FixedSent,
    AutoSent,
    AutoStatusSent,
    WaitRefused,
    RefusedSent,
    RefusedStatusSent,
    WaitAmplitude,
    AmplitudeSent,
    AmplitudeStatusSent,
    WaitSelfTest,
    SelfTestSent,
    BusySent,
    SelfTestRunning,
    Done,
}

/// Everything the host saw and did.
struct Host {
    dec: Decoder,
    seq: u32,
    step: Step,
    sent_at: Option<Instant>,
    failures: Vec<String>,
    tally: Tally,
    estimates: Vec<Estimate>,
    raw: Vec<(u64, f32, f32)>,
    first_status: Option<Status>,
    last_status: Option<Status>,
    before_refusal: Option<Status>,
    after_refusal: Option<Status>,
    after_amplitude: Option<Status>,
    after_auto: Option<Status>,
    refused_result: Option<AckResult>,
    /// Newest raw-sample index received before the amplitude command.
    raw_before_amplitude: Option<u64>,
    acks: Vec<(u32, AckResult)>,
    /// Self-test reports (the one at boot, the one commanded).
    reports: Vec<SelfTestReport>,
    /// The last RequestStatus has been acknowledged: the next Status is its
    /// answer (a periodic Status may come between the request and its Ack).
    status_acked: bool,
}

impl Host {
    fn new() -> Self {
        Self {
            dec: Decoder::new(),
            seq: 0,
            step: Step::WaitRawOn,
            sent_at: None,
            failures: Vec::new(),
            tally: Tally::default(),
            estimates: Vec::new(),
            raw: Vec::new(),
            first_status: None,
            last_status: None,
            before_refusal: None,
            after_refusal: None,
            after_amplitude: None,
            after_auto: None,
            refused_result: None,
            raw_before_amplitude: None,
            acks: Vec::new(),
            reports: Vec::new(),
            status_acked: false,
        }
    }

    fn send(&mut self, link: &mut TcpStream, c: Command) -> io::Result<()> {
        let mut out = [0u8; MAX_ENCODED_LEN];
        let n = encode(&c, self.seq, &mut out)
            .map_err(|e| io::Error::other(format!("encoding {c:?}: {e}")))?;
        self.seq += 1;
        self.sent_at = Some(Instant::now());
        self.status_acked = false;
        link.write_all(&out[..n])
    }

    fn fail(&mut self, msg: String) {
        eprintln!("e2e: FAIL: {msg}");
        self.failures.push(msg);
    }

    /// Feed received bytes; send the schedule's commands as the device's
    /// clock reaches them.
    fn receive(&mut self, bytes: &[u8], link: &mut TcpStream) -> io::Result<()> {
        let frames: Vec<Frame> = self.dec.feed(bytes).flatten().collect();
        for f in frames {
            self.tally.count(&f.message);
            match f.message {
                Message::Estimate(e) => {
                    let now = e.sample_index;
                    self.estimates.push(e);
                    self.on_clock(now, link)?;
                }
                Message::RawSamples(r) => {
                    let d = u64::from(r.decimation);
                    for (i, s) in r.samples.iter().enumerate() {
                        self.raw
                            .push((r.first_sample_index + i as u64 * d, s.u_v, s.y));
                    }
                }
                Message::Status(s) => self.on_status(s),
                Message::Ack(a) => self.on_ack(a.command_seq, a.result, link)?,
                Message::SelfTestReport(r) => {
                    if !r.at_boot && self.step == Step::SelfTestRunning {
                        self.step = Step::Done;
                        self.sent_at = None;
                    }
                    self.reports.push(r)
                }
                Message::Command(_) => self.fail("the device sent a Command frame".into()),
            }
        }
        if let Some(t) = self.sent_at {
            if t.elapsed() > ACK_TIMEOUT && self.step != Step::Done {
                self.fail(format!(
                    "no answer within {ACK_TIMEOUT:?} at step {:?}",
                    self.step
                ));
                self.step = Step::Done;
                self.sent_at = None;
            }
        }
        Ok(())
    }

    fn on_clock(&mut self, now: u64, link: &mut TcpStream) -> io::Result<()> {
        match self.step {
            Step::WaitRawOn if now >= RAW_ON_AT => {
                self.step = Step::RawOnSent;
                self.send(
                    link,
                    Command::SetTelemetry(TelemetryRates {
                        raw_decimation: RAW_DECIMATION,
                        ..TelemetryRates::default()
                    }),
                )?;
            }
            Step::WaitRefused if now >= REFUSED_AT => {
                self.step = Step::RefusedSent;
                self.send(
                    link,
                    Command::SetExcitation(excitation(AMPLITUDE_REFUSED_V)),
                )?;
            }
            Step::WaitSelfTest if now >= SELF_TEST_AT => {
                self.step = Step::SelfTestSent;
                self.send(link, Command::SelfTest)?;
            }
            Step::WaitAmplitude if now >= AMPLITUDE_AT => {
                self.step = Step::AmplitudeSent;
                self.raw_before_amplitude = self.raw.last().map(|r| r.0);
                self.send(link, Command::SetExcitation(excitation(AMPLITUDE_AFTER_V)))?;
            }
            _ => {}
        }
        Ok(())
    }

    fn on_status(&mut self, s: Status) {
        if self.first_status.is_none() {
            self.first_status = Some(s.clone());
        }
        match self.step {
            Step::WaitRefused | Step::RefusedSent => self.before_refusal = Some(s.clone()),
            Step::RefusedStatusSent if self.after_refusal.is_none() && self.status_acked => {
                self.after_refusal = Some(s.clone());
                self.step = Step::WaitAmplitude;
                self.sent_at = None;
            }
            Step::AmplitudeStatusSent if self.after_amplitude.is_none() && self.status_acked => {
                self.after_amplitude = Some(s.clone());
                self.step = Step::WaitSelfTest;
                self.sent_at = None;
            }
            Step::AutoStatusSent if self.after_auto.is_none() && self.status_acked => {
                self.after_auto = Some(s.clone());
                self.step = Step::WaitRefused;
                self.sent_at = None;
            }
            _ => {}
        }
        self.last_status = Some(s);
    }

    fn on_ack(&mut self, seq: u32, result: AckResult, link: &mut TcpStream) -> io::Result<()> {
        self.acks.push((seq, result));
        if seq + 1 != self.seq {
            self.fail(format!("Ack for command {seq}, expected {}", self.seq - 1));
            return Ok(());
        }
        match (self.step, result) {
            (Step::RawOnSent, AckResult::Accepted) => {
                self.step = Step::FixedSent;
                self.send(link, Command::SetEstimator(estimator(Some(FIXED_LAMBDA))))?;
            }
            (Step::RefusedSent, r) => {
                self.refused_result = Some(r);
                self.step = Step::RefusedStatusSent;
                self.send(link, Command::RequestStatus)?;
            }
            (Step::AmplitudeSent, AckResult::Accepted) => {
                self.step = Step::AmplitudeStatusSent;
                self.send(link, Command::RequestStatus)?;
            }
            (Step::SelfTestSent, AckResult::Accepted) => {
                // While it runs every other command is refused.
                self.step = Step::BusySent;
                self.send(link, Command::Reset)?;
            }
            (Step::BusySent, AckResult::Rejected(RejectReason::Busy)) => {
                self.step = Step::SelfTestRunning;
                self.sent_at = Some(Instant::now());
            }
            (Step::FixedSent, AckResult::Accepted) => {
                self.step = Step::AutoSent;
                self.send(link, Command::SetEstimator(estimator(None)))?;
            }
            (Step::AutoSent, AckResult::Accepted) => {
                self.step = Step::AutoStatusSent;
                self.send(link, Command::RequestStatus)?;
            }
            (
                Step::RefusedStatusSent | Step::AmplitudeStatusSent | Step::AutoStatusSent,
                AckResult::Accepted,
            ) => self.status_acked = true,
            (step, r) => {
                self.fail(format!("command {seq} at step {step:?} answered {r:?}"));
                self.step = Step::Done;
                self.sent_at = None;
            }
        }
        Ok(())
    }
}

/// The bench's square wave at `amplitude_v`.
fn excitation(amplitude_v: f32) -> Excitation {
    Excitation {
        waveform: Waveform::Square { freq_hz: 7.0 },
        amplitude_v,
        offset_v: 0.0,
    }
}

/// The protocol's default estimator settings at `lambda_rad_s`.
fn estimator(lambda_rad_s: Option<f32>) -> EstimatorSettings {
    EstimatorSettings {
        lambda_rad_s,
        ..EstimatorSettings::default()
    }
}

impl LinkHost for Host {
    fn receive(&mut self, bytes: &[u8], link: &mut TcpStream) -> io::Result<()> {
        Host::receive(self, bytes, link)
    }
    fn fail(&mut self, msg: String) {
        Host::fail(self, msg)
    }
}

/// Run the test (see the module doc).
pub fn run(elf: &Path, timeout: Duration) -> Result<(), String> {
    let mut host = Host::new();
    let (status, wall, log) = session(elf, Some(SECONDS), timeout, &mut host)?;
    let capture = Capture {
        counters: *host.dec.counters(),
        tally: host.tally.clone(),
        last_status: host.last_status.clone(),
        reports: host.reports.clone(),
    };
    println!("\ne2e: UART0 as decoded by the host: {}", capture.summary());
    check(&mut host, &capture);
    crate::emulator::judge_firmware(&mut host, &log, status);
    println!("e2e: {QEMU} exited with {status} after {wall:.2} s wall time");
    crate::emulator::verdict("e2e", "end-to-end test", &host.failures)
}

/// The checks after the run (module doc).
fn check(h: &mut Host, capture: &Capture) {
    let mut fails: Vec<String> = Vec::new();
    let pass = |what: String| println!("e2e: ok: {what}");

    // 2. The link.
    if capture.is_clean() {
        pass(format!(
            "link clean: {} frames, sequence without gaps, no CRC or frame error",
            capture.counters.frames_ok
        ));
    } else {
        fails.push(format!("link not clean: {}", capture.summary()));
    }
    match &h.last_status {
        Some(s) if s.counters.telemetry_dropped == 0 && s.counters.rx_frame_errors == 0 => {
            pass("device counters: nothing dropped, no bad command frame".into())
        }
        Some(s) => fails.push(format!("device counters: {:?}", s.counters)),
        None => fails.push("no Status received".into()),
    }
    if h.step != Step::Done {
        fails.push(format!("the command schedule stopped at {:?}", h.step));
    }

    // 1. The estimates.
    let valid = |e: &&Estimate| e.flags.contains(StatusFlags::PHYSICALLY_VALID);
    let mut band_centre = None;
    match h.estimates.iter().rev().find(valid) {
        Some(e) => {
            if let [m1, m2] = e.modes.as_slice() {
                band_centre = Some((f64::from(m1.omega_rad_s) * f64::from(m2.omega_rad_s)).sqrt());
            }
            let mut worst: f64 = 0.0;
            for (i, m) in e.modes.iter().enumerate() {
                let ew = (f64::from(m.omega_rad_s) / PAPER_OMEGA[i] - 1.0).abs();
                let ez = (f64::from(m.zeta) / PAPER_ZETA[i] - 1.0).abs();
                println!(
                    "e2e: mode {}: omega = {:.5} rad/s (truth {}, rel. error {ew:.1e}), \
                     zeta = {:.7} (truth {}, rel. error {ez:.1e})",
                    i + 1,
                    m.omega_rad_s,
                    PAPER_OMEGA[i],
                    m.zeta,
                    PAPER_ZETA[i]
                );
                worst = worst.max(ew).max(ez);
            }
            let t = e.sample_index as f64 * 1e-4;
            if e.modes.len() == 2 && worst <= TOLERANCE {
                pass(format!(
                    "estimate at t = {t:.2} s within {worst:.1e} of the truth (≤ {TOLERANCE:.0e})"
                ));
            } else {
                fails.push(format!(
                    "estimate at t = {t:.2} s off the truth by {worst:.1e}"
                ));
            }
            if e.sample_index < 59_000 {
                fails.push(format!(
                    "the last valid estimate is from t = {t:.2} s, not 6 s"
                ));
            }
            let want = StatusFlags::EXCITED
                .with(StatusFlags::PHYSICALLY_VALID)
                .with(StatusFlags::CONVERGED);
            if e.flags.contains(want) {
                pass(format!(
                    "final flags {:#06x}: excited, valid, converged",
                    e.flags.0
                ));
            } else {
                fails.push(format!(
                    "final flags {:#06x} lack excited/valid/converged",
                    e.flags.0
                ));
            }
        }
        None => fails.push("no physically valid estimate".into()),
    }
    // 100 Hz from the estimator's start (after the self-test at start-up,
    // 0.67 s, and the 0.2 s start-up window) to 6 s.
    if h.estimates.len() >= 510 {
        pass(format!(
            "{} estimates (100 Hz after the self-test and the 0.2 s start-up window)",
            h.estimates.len()
        ));
    } else {
        fails.push(format!("only {} estimates", h.estimates.len()));
    }
    for (bit, name) in [
        (StatusFlags::SENSOR_FAULT, "SENSOR_FAULT"),
        (StatusFlags::ADC_SATURATED, "ADC_SATURATED"),
        (StatusFlags::FROZEN_AUTO, "FROZEN_AUTO"),
    ] {
        let n = h.estimates.iter().filter(|e| e.flags.contains(bit)).count();
        if n > 0 {
            pass(format!(
                "{n} estimates flagged {name} around the injected faults"
            ));
        } else {
            fails.push(format!("no estimate flagged {name}"));
        }
    }

    // 3. The commands.
    match h.refused_result {
        Some(AckResult::Rejected(RejectReason::SafeWindow)) => {
            pass("20 V excitation refused: reason 3, SafeWindow".into())
        }
        r => fails.push(format!(
            "20 V excitation answered {r:?}, expected SafeWindow"
        )),
    }
    match (&h.before_refusal, &h.after_refusal) {
        (Some(b), Some(a)) => {
            // λ is the automatic rule's to change at any time; the
            // commanded settings must not change.
            let commanded = |s: &Status| EstimatorSettings {
                lambda_rad_s: None,
                ..s.estimator
            };
            let same = a.excitation == b.excitation
                && commanded(a) == commanded(b)
                && a.telemetry == b.telemetry
                && a.adaptation_frozen == b.adaptation_frozen;
            let counted = a.counters.commands_rejected == b.counters.commands_rejected + 1;
            if same && counted && a.excitation.amplitude_v == AMPLITUDE_BEFORE_V {
                pass(
                    "after the refusal every setting is unchanged (Status), the refusal counted"
                        .into(),
                );
            } else {
                fails.push(format!(
                    "the refused command changed something: before {b:?}, after {a:?}"
                ));
            }
        }
        _ => fails.push("no Status around the refused command".into()),
    }
    let switched_at = match &h.after_amplitude {
        Some(s) if s.excitation.amplitude_v == AMPLITUDE_AFTER_V => {
            pass(format!(
                "amplitude 0.2 V accepted; Status at sample {} shows it",
                s.uptime_samples
            ));
            Some(s.uptime_samples)
        }
        s => {
            fails.push(format!("no Status with the new amplitude: {s:?}"));
            None
        }
    };
    // 5. The self-test: at start-up and on command, every check passed;
    // while it ran the estimate was held and flagged, another command
    // refused (Busy), and the drive restored after it.
    let commanded = h.reports.iter().find(|r| !r.at_boot).cloned();
    match h.reports.as_slice() {
        [boot, cmd] if boot.at_boot && !cmd.at_boot && boot.passed() && cmd.passed() => {
            pass(format!(
                "self-tests: at start-up (samples {}–{}) and on command (samples {}–{}), every \
                 check passed; on command: DRDY {} Hz, loopback gain {} delay {} samples, noise \
                 σ {:e} (floor {:e}), SNR {} dB",
                boot.first_sample,
                boot.last_sample,
                cmd.first_sample,
                cmd.last_sample,
                cmd.drdy.rate_hz,
                cmd.loopback.gain,
                cmd.loopback.delay_samples,
                cmd.noise.noise_sd,
                cmd.noise.floor_sd,
                cmd.noise.snr_db
            ))
        }
        r => fails.push(format!("self-test reports: {r:?}")),
    }
    let test_span = commanded
        .as_ref()
        .map_or(0..=0, |r| r.first_sample..=r.last_sample);
    let during: Vec<&Estimate> = h
        .estimates
        .iter()
        .filter(|e| test_span.contains(&e.sample_index))
        .collect();
    let held = during.iter().all(|e| {
        e.flags.contains(StatusFlags::SELF_TEST)
            && during.first().is_some_and(|f| f.theta == e.theta)
    });
    let flagged_outside = h
        .estimates
        .iter()
        .filter(|e| !test_span.contains(&e.sample_index))
        .filter(|e| e.flags.contains(StatusFlags::SELF_TEST))
        .count();
    if during.len() >= 60 && held && flagged_outside == 0 {
        pass(format!(
            "{} estimates during the commanded self-test, all flagged SELF_TEST with Θ̂ held; \
             none flagged outside it",
            during.len()
        ));
    } else {
        fails.push(format!(
            "estimates during the self-test: {} (held and flagged: {held}), {flagged_outside} \
             flagged outside it",
            during.len()
        ));
    }
    if h.acks
        .iter()
        .any(|(_, r)| *r == AckResult::Rejected(RejectReason::Busy))
    {
        pass("a command during the self-test refused: Busy (15)".into());
    } else {
        fails.push("no command refused Busy during the self-test".into());
    }
    match &h.last_status {
        Some(s) if s.excitation.amplitude_v == AMPLITUDE_AFTER_V => {
            pass("after the self-test the excitation in force is back (Status: 0.2 V)".into())
        }
        s => fails.push(format!("the excitation after the self-test: {s:?}")),
    }
    // Raw samples: u at the old level before the command, the new after
    // (except during the commanded self-test: its own drive).
    let level = |lo: u64, hi: u64, amp: f32| {
        let pairs: Vec<f32> = h
            .raw
            .iter()
            .filter(|r| r.0 >= lo && r.0 < hi && r.1.is_finite())
            .filter(|r| !test_span.contains(&r.0))
            .map(|r| r.1)
            .collect();
        let off = pairs
            .iter()
            .filter(|u| (u.abs() / amp - 1.0).abs() > U_TOLERANCE)
            .count();
        (pairs.len(), off)
    };
    match (h.raw_before_amplitude, switched_at) {
        (Some(before), Some(after)) => {
            let (n0, off0) = level(0, before + 1, AMPLITUDE_BEFORE_V);
            let (n1, off1) = level(after, u64::MAX, AMPLITUDE_AFTER_V);
            if n0 >= 100 && n1 >= 100 && off0 == 0 && off1 == 0 {
                pass(format!(
                    "raw samples: |u| = 0.1 V in all {n0} pairs up to sample {before}, \
                     0.2 V in all {n1} pairs from sample {after}"
                ));
            } else {
                fails.push(format!(
                    "raw samples: {off0} of {n0} pairs off 0.1 V before the command, {off1} \
                     of {n1} off 0.2 V after it"
                ));
            }
        }
        _ => fails.push(format!(
            "no raw samples before the amplitude command ({} pairs in all)",
            h.raw.len()
        )),
    }
    // 4. The automatic rule.
    crate::e2e_tuning::check(
        h.first_status.as_ref(),
        h.after_auto.as_ref(),
        h.last_status.as_ref(),
        band_centre,
        &mut fails,
    );

    let expected_acks = 10;
    if h.acks.len() == expected_acks {
        pass(format!(
            "{expected_acks} commands sent, {expected_acks} acknowledgements"
        ));
    } else {
        fails.push(format!("acknowledgements: {:?}", h.acks));
    }
    for f in fails {
        h.fail(f);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use beam_protocol::{EstimatorKind, ModeEstimate};

    /// PROTOCOL.md §6's Estimate example: the paper's plant, Θ̂ at
    /// λ = 100 rad/s rounded to f32.
    fn example() -> Estimate {
        let mode = |omega_rad_s, zeta, b_bar| ModeEstimate {
            omega_rad_s,
            zeta,
            b_bar,
        };
        Estimate {
            estimator: EstimatorKind::Adaptive,
            modes: [mode(39.1533, 0.0207, 9.6293), mode(245.3711, 0.13, 16.1458)]
                .into_iter()
                .collect(),
            lambda_rad_s: 100.0,
            theta: [
                13.02,
                -1180.0,
                -1_110_000.0,
                334.58257,
                -1843.3683,
                3_804_609.0,
                7_703_854.5,
            ]
            .into_iter()
            .collect(),
            ..Estimate::default()
        }
    }

    #[test]
    fn modes_are_checked_against_the_estimates_own_theta_and_lambda() {
        let e = example();
        assert!(modes_follow_from_theta(&e));
        // Read with another λ (say, an older Status's), Θ̂ means other modes.
        for lambda in [99.0, 100.1, 113.0] {
            let other = Estimate {
                lambda_rad_s: lambda,
                ..e.clone()
            };
            assert!(!modes_follow_from_theta(&other), "λ {lambda}");
        }
        // A mode 1e-4 off, or the modes of λ's own poles for this Θ̂.
        let mut off = e.clone();
        off.modes[1].omega_rad_s *= 1.0001;
        assert!(!modes_follow_from_theta(&off));
        let mut poles = e.clone();
        for m in poles.modes.iter_mut() {
            (m.omega_rad_s, m.zeta) = (100.0, 1.0);
        }
        assert!(!modes_follow_from_theta(&poles));
        // ... which are right for Θ̂ = 0 (and still refused there: §4.1).
        poles.theta.iter_mut().for_each(|t| *t = 0.0);
        assert!(modes_follow_from_theta(&poles));
        assert!(!estimate_means_what_it_says(&poles));
        // No modes: nothing to check.
        let none = Estimate {
            modes: Default::default(),
            ..e
        };
        assert!(modes_follow_from_theta(&none));
    }

    #[test]
    fn gains_are_checked_against_the_definition_and_the_weights() {
        // §6's example with its b̄ (9.6293, 16.1458 for C̄ = (−2, 2)).
        let e = example();
        assert!(gains_follow_from_theta(&e, &[-2.0, 2.0]));
        assert!(estimate_means_what_it_says(&e));
        // Other weights (the reference board's), the modal residues β_i
        // themselves, a flipped sign or a gain 1e-3 off: not §4.0's b̄.
        assert!(!gains_follow_from_theta(&e, &[1.0, 1.0]));
        let mut beta = e.clone();
        beta.modes[0].b_bar *= -2.0;
        beta.modes[1].b_bar *= 2.0;
        assert!(!gains_follow_from_theta(&beta, &[-2.0, 2.0]));
        assert!(gains_follow_from_theta(&beta, &[1.0, 1.0]));
        let mut off = e.clone();
        off.modes[1].b_bar *= 1.001;
        assert!(!gains_follow_from_theta(&off, &[-2.0, 2.0]));
    }

    #[test]
    fn estimates_with_modes_before_a_status_with_lambda_are_counted() {
        let mut t = Tally::default();
        let e = Message::Estimate(example());
        t.count(&e);
        t.count(&e);
        assert_eq!(
            (t.with_modes_before_lambda_status, t.meaning_violations),
            (2, 0)
        );
    }
}
