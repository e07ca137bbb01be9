//! A fake device: it speaks the serial-link protocol (`docs/PROTOCOL.md`)
//! like the firmware must, over any byte stream, so that the host tools
//! can be tested end to end, and tried, without a rig or an emulator.
//!
//! What it sends, paced in real time by [`FakeDevice::serve`] (or sample by
//! sample with [`FakeDevice::advance`]):
//! * an Estimate every round(f_s / estimate rate) samples. Its ω̂, ζ̂, b̂̄
//!   are **not estimated**: they approach [`FakeConfig::targets`]
//!   exponentially (time constant [`CONVERGENCE_TAU_S`]) from 20 % above,
//!   from start-up and again after each Reset or SetEstimator, and hold
//!   while frozen (by command, or because the excitation is off). Θ̂ is the
//!   Θ of eq. 29 of Wang, Costa-Castelló, Na et al., *Modelling and
//!   Adaptive Parameter Estimation for a Piezoelectric Cantilever Beam*,
//!   for those modes (so it is consistent with them);
//! * raw samples in blocks of 64 when the raw decimation d > 0: every
//!   sample whose index is a multiple of d, with u and y from
//!   [`FakeDevice::signals`] (a pure function of the sample index and the
//!   excitation, so a test can recompute every value it should have
//!   received);
//! * a Status at start-up (sample 0), then every round(f_s / status rate)
//!   samples, and after the Ack of each RequestStatus;
//! * an Ack for every command frame it decodes: checked by the core's
//!   `Command::validate` against [`FakeConfig::limits`], applied only if
//!   accepted. Frames that do not decode are counted in `rx_frame_errors`
//!   and not answered, as the protocol says;
//! * after the Ack of a `SelfTest`, at once, a [`SelfTestReport`] in which
//!   every check passes with the values of a healthy rig
//!   ([`FakeDevice::self_test_report`]: not measured, made up); its Status
//!   reports the self-test done from then on.

use beam_protocol::{
    budget::MAX_COMMAND_ENCODED_LEN, Ack, AckResult, Command, Decoder, DeviceCounters, Estimate,
    EstimatorKind, EstimatorSettings, Excitation, FirmwareVersion, Limits, ModeEstimate,
    RawSamples, SelfTestReport, SelfTestState, Status, StatusFlags, TelemetryRates, UySample,
    Waveform, MAX_ENCODED_LEN, MAX_MODES, MAX_RAW_SAMPLES, MAX_THETA,
};
use beam_protocol::{Encoder, Payload};
use beamest::model::ModalParams;
use std::io::{self, Read, Write};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{mpsc, Arc};
use std::time::{Duration, Instant};

/// Time constant of the fake convergence (s).
pub const CONVERGENCE_TAU_S: f64 = 0.5;
/// λ reported when the settings ask for the automatic rule (rad/s).
pub const AUTO_LAMBDA_RAD_S: f32 = 100.0;
/// The excitation level at which EXCITED is set: the firmware's threshold
/// (docs/PROTOCOL.md §9.3).
const EXCITED_LEVEL: f32 = 1e-7;

/// What the fake device is.
#[derive(Debug, Clone, PartialEq)]
pub struct FakeConfig {
    /// Its modes' parameters, ascending ω; the length is the model's mode
    /// count (1..=3).
    pub targets: Vec<ModeEstimate>,
    /// What it accepts. `sample_rate_hz` is its sample rate; `modes` must
    /// equal `targets.len()`.
    pub limits: Limits,
    /// Telemetry rates at start-up.
    pub rates: TelemetryRates,
    /// Excitation at start-up.
    pub excitation: Excitation,
    /// Estimator settings at start-up.
    pub estimator: EstimatorSettings,
    /// Answer commands (false: decode and count them, never answer: the
    /// host must time out).
    pub answers_commands: bool,
    /// The version it reports.
    pub firmware: FirmwareVersion,
}

impl Default for FakeConfig {
    /// Two modes at the values the paper reports for its beam simulation
    /// (Table III), 10 kHz, a piezo window of [−1, 2] V, the adaptive,
    /// gradient and least-squares laws, 921,600 baud, the protocol's
    /// default rates and excitation.
    fn default() -> Self {
        Self {
            targets: vec![
                ModeEstimate {
                    omega_rad_s: 39.1533,
                    zeta: 0.0207,
                    b_bar: 9.6293,
                },
                ModeEstimate {
                    omega_rad_s: 245.3711,
                    zeta: 0.13,
                    b_bar: 16.1458,
                },
            ],
            limits: Limits {
                sample_rate_hz: 10_000.0,
                piezo_min_v: -1.0,
                piezo_max_v: 2.0,
                max_multisine_tones: 16,
                prbs_bits_min: 3,
                prbs_bits_max: 31,
                estimators: EstimatorKind::Adaptive.bit()
                    | EstimatorKind::Gradient.bit()
                    | EstimatorKind::LeastSquares.bit(),
                modes: 2,
                link_bytes_per_s: beam_protocol::budget::uart_bytes_per_s(921_600) as f32,
            },
            rates: TelemetryRates::default(),
            excitation: Excitation::default(),
            estimator: EstimatorSettings::default(),
            answers_commands: true,
            firmware: FirmwareVersion {
                major: 0,
                minor: 1,
                patch: 0,
            },
        }
    }
}

/// What the fake device sent and received.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct FakeLog {
    /// Estimate frames sent.
    pub estimates: u64,
    /// RawSamples frames sent.
    pub raw_frames: u64,
    /// Raw sample pairs sent.
    pub raw_samples: u64,
    /// Status frames sent.
    pub statuses: u64,
    /// Every command decoded, with its sequence number and the answer
    /// (sent or not).
    pub commands: Vec<(u32, Command, AckResult)>,
}

/// The fake device. See the module docs.
#[derive(Debug)]
pub struct FakeDevice {
    cfg: FakeConfig,
    excitation: Excitation,
    estimator: EstimatorSettings,
    rates: TelemetryRates,
    frozen: bool,
    counters: DeviceCounters,
    /// Next sample index to produce.
    next: u64,
    /// Sample index of the last (re)start of the estimate.
    restart: u64,
    /// Convergence time reached when adaptation stopped (frozen), if it is.
    held: Option<f64>,
    raw: Vec<UySample>,
    raw_first: u64,
    encoder: Encoder,
    rx: Decoder<MAX_COMMAND_ENCODED_LEN>,
    log: FakeLog,
    self_test: SelfTestState,
}

fn period(fs: f32, rate_hz: f32) -> Option<u64> {
    (rate_hz > 0.0).then(|| (f64::from(fs) / f64::from(rate_hz)).round().max(1.0) as u64)
}

impl FakeDevice {
    /// A device at start-up (sample 0, sequence number 0).
    pub fn new(cfg: FakeConfig) -> Self {
        let mut dev = Self {
            excitation: cfg.excitation,
            estimator: cfg.estimator,
            rates: cfg.rates,
            frozen: false,
            counters: DeviceCounters::default(),
            next: 0,
            restart: 0,
            held: None,
            raw: Vec::new(),
            raw_first: 0,
            encoder: Encoder::new(),
            rx: Decoder::new(),
            log: FakeLog::default(),
            self_test: SelfTestState::NotRun,
            cfg,
        };
        dev.hold(0);
        dev
    }

    /// What it sent and received so far.
    pub fn log(&self) -> &FakeLog {
        &self.log
    }

    /// Its sample rate (Hz).
    pub fn sample_rate_hz(&self) -> f32 {
        self.cfg.limits.sample_rate_hz
    }

    /// The excitation in force.
    pub fn excitation(&self) -> &Excitation {
        &self.excitation
    }

    /// u (V) and y of sample `index` under `excitation` at `fs` Hz: u is
    /// the waveform (square: offset ± amplitude at its frequency; off: the
    /// offset; multisine, PRBS and chirp: a sine at the centre of their band
    /// or at their bit rate / 2: this is a fake), y is a fixed two-tone
    /// signal (3 Hz and 60 Hz) plus 10⁻³·u.
    pub fn signals(excitation: &Excitation, fs: f32, index: u64) -> (f32, f32) {
        let t = index as f64 / f64::from(fs);
        let a = f64::from(excitation.amplitude_v);
        let sine = |f: f32| (std::f64::consts::TAU * f64::from(f) * t).sin();
        let wave = match excitation.waveform {
            Waveform::Off => 0.0,
            Waveform::Square { freq_hz } => {
                if sine(freq_hz) >= 0.0 {
                    a
                } else {
                    -a
                }
            }
            Waveform::Multisine {
                f_min_hz, f_max_hz, ..
            } => a * sine(0.5 * (f_min_hz + f_max_hz)),
            Waveform::Prbs { bit_rate_hz, .. } => a * sine(0.5 * bit_rate_hz),
            Waveform::Chirp {
                f_start_hz,
                f_end_hz,
                ..
            } => a * sine(0.5 * (f_start_hz + f_end_hz)),
        };
        let u = f64::from(excitation.offset_v) + wave;
        let y = 2e-3 * (std::f64::consts::TAU * 3.0 * t).sin()
            + 5e-4 * (std::f64::consts::TAU * 60.0 * t).cos()
            + 1e-3 * u;
        (u as f32, y as f32)
    }

    fn limits(&self) -> Limits {
        self.cfg.limits
    }

    fn send<M: Payload>(&mut self, msg: &M, out: &mut Vec<u8>) {
        let mut buf = [0u8; MAX_ENCODED_LEN];
        // Every message built here is well formed and fits the buffer.
        if let Ok(n) = self.encoder.encode(msg, &mut buf) {
            out.extend_from_slice(buf.get(..n).unwrap_or_default());
        }
    }

    /// The Status now.
    pub fn status(&self) -> Status {
        let lambda = self.estimator.lambda_rad_s.unwrap_or(AUTO_LAMBDA_RAD_S);
        Status {
            uptime_samples: self.next,
            sample_rate_hz: self.sample_rate_hz(),
            firmware: self.cfg.firmware,
            modes: self.cfg.limits.modes,
            counters: self.counters,
            adaptation_frozen: self.frozen,
            excitation: self.excitation,
            estimator: EstimatorSettings {
                lambda_rad_s: Some(lambda),
                ..self.estimator
            },
            telemetry: self.rates,
            lambda_automatic: self.estimator.lambda_rad_s.is_none(),
            self_test: self.self_test,
        }
    }

    /// The report of its self-test, ending at the current sample: every
    /// check passes, with the values a healthy emulated rig reports (ID
    /// 2203h, the emulated bench's ADC registers, the sample rate, a
    /// loopback of gain 1 and 2.15 samples, noise 1e-8 against an RMS of
    /// 3e-3 under its excitation). Made up, not measured.
    pub fn self_test_report(&self) -> SelfTestReport {
        use beam_protocol::{AdcCheck, DrdyCheck, LoopbackCheck, NoiseCheck, SelfTestChecks};
        let registers = beamest::bench::adc_config().expected_registers();
        let fs = self.sample_rate_hz();
        let samples: u32 = 6_656;
        SelfTestReport {
            first_sample: self.next.saturating_sub(u64::from(samples)),
            last_sample: self.next.saturating_sub(1),
            at_boot: false,
            failed: SelfTestChecks::default(),
            not_measured: SelfTestChecks::default(),
            adc: AdcCheck {
                id: 0x2203,
                registers,
                expected: registers,
            },
            drdy: DrdyCheck {
                rate_hz: fs,
                expected_hz: fs,
                tolerance: 1e-4,
                conversions: samples,
                ticks: samples,
            },
            loopback: LoopbackCheck {
                tone_hz: fs * 10.0 / 2048.0,
                amplitude_v: 1.0,
                gain: 1.0,
                expected_gain: 1.0,
                gain_tolerance: 0.05,
                offset_v: 0.0,
                offset_tolerance_v: 0.02,
                delay_samples: 2.15,
                expected_delay_samples: 2.15,
                delay_tolerance_samples: 0.02,
            },
            noise: NoiseCheck {
                noise_sd: 1e-8,
                floor_sd: 1e-8,
                signal_rms: 3e-3,
                snr_db: 109.5,
                snr_min_db: 60.0,
                excitation: self.excitation,
            },
        }
    }

    fn send_status(&mut self, out: &mut Vec<u8>) {
        let s = self.status();
        self.send(&s, out);
        self.log.statuses += 1;
    }

    /// Seconds of convergence behind the estimate at sample `k`.
    fn converged_for(&self, k: u64) -> f64 {
        self.held
            .unwrap_or((k - self.restart.min(k)) as f64 / f64::from(self.sample_rate_hz()))
    }

    /// The estimate at sample `k` (see the module docs).
    pub fn estimate(&self, k: u64) -> Estimate {
        let t = self.converged_for(k);
        let off = 1.0 + 0.2 * (-t / CONVERGENCE_TAU_S).exp();
        let modes: beam_protocol::heapless::Vec<ModeEstimate, MAX_MODES> = self
            .cfg
            .targets
            .iter()
            .map(|m| ModeEstimate {
                omega_rad_s: (f64::from(m.omega_rad_s) * off) as f32,
                zeta: (f64::from(m.zeta) * off) as f32,
                b_bar: (f64::from(m.b_bar) * off) as f32,
            })
            .collect();
        let n = modes.len();
        let w: Vec<f64> = modes.iter().map(|m| f64::from(m.omega_rad_s)).collect();
        let z: Vec<f64> = modes.iter().map(|m| f64::from(m.zeta)).collect();
        let b: Vec<f64> = modes.iter().map(|m| f64::from(m.b_bar)).collect();
        let lambda = self.estimator.lambda_rad_s.unwrap_or(AUTO_LAMBDA_RAD_S);
        let mut theta = [0.0f64; MAX_THETA];
        let np = 4 * n - 1;
        if let Some(p) = ModalParams::new(&w, &z, &b, None) {
            let _ = p
                .transfer_function()
                .to_theta(f64::from(lambda), &mut theta[..np]);
        }
        let mut flags = StatusFlags::PHYSICALLY_VALID;
        let driven = !matches!(self.excitation.waveform, Waveform::Off);
        // The level λmin(P)/tr(P) grows while driven; EXCITED is the
        // protocol's test of it (§4.1: ≥ 1e-7, the input present).
        let level = if driven {
            (1e-3 * (1.0 - (-t).exp())) as f32
        } else {
            0.0
        };
        let excited = level >= EXCITED_LEVEL;
        flags.set(StatusFlags::EXCITED, excited);
        flags.set(StatusFlags::FROZEN_BY_COMMAND, self.frozen);
        flags.set(StatusFlags::FROZEN_AUTO, !driven);
        flags.set(StatusFlags::CONVERGED, t > 5.0 * CONVERGENCE_TAU_S);
        // Every field the fake models today; a field added to `Estimate`
        // later takes its default here until the fake models it.
        #[allow(clippy::needless_update)]
        Estimate {
            sample_index: k,
            estimator: self.estimator.kind,
            flags,
            modes,
            lambda_rad_s: lambda,
            theta: theta[..np].iter().map(|&v| v as f32).collect(),
            excitation_level: Some(level),
            ..Estimate::default()
        }
    }

    fn hold(&mut self, k: u64) {
        let frozen = self.frozen || matches!(self.excitation.waveform, Waveform::Off);
        match (frozen, self.held) {
            (true, None) => self.held = Some(self.converged_for(k)),
            (false, Some(t)) => {
                // Resume where it stopped.
                let fs = f64::from(self.sample_rate_hz());
                self.restart = k.saturating_sub((t * fs).round() as u64);
                self.held = None;
            }
            _ => {}
        }
    }

    /// Produce `samples` more samples, appending the frames they complete
    /// to `out`.
    pub fn advance(&mut self, samples: u64, out: &mut Vec<u8>) {
        let fs = self.sample_rate_hz();
        for _ in 0..samples {
            let k = self.next;
            self.next += 1;
            if period(fs, self.rates.status_rate_hz).is_some_and(|p| k.is_multiple_of(p)) {
                self.send_status(out);
            }
            let d = u64::from(self.rates.raw_decimation);
            if d > 0 && k.is_multiple_of(d) {
                if self.raw.is_empty() {
                    self.raw_first = k;
                }
                let (u_v, y) = Self::signals(&self.excitation, fs, k);
                self.raw.push(UySample { u_v, y });
                if self.raw.len() == MAX_RAW_SAMPLES {
                    self.flush_raw(out);
                }
            }
            if period(fs, self.rates.estimate_rate_hz).is_some_and(|p| (k + 1).is_multiple_of(p)) {
                let e = self.estimate(k);
                self.send(&e, out);
                self.log.estimates += 1;
            }
        }
    }

    fn flush_raw(&mut self, out: &mut Vec<u8>) {
        if self.raw.is_empty() {
            return;
        }
        let block = RawSamples {
            first_sample_index: self.raw_first,
            decimation: self.rates.raw_decimation.max(1),
            samples: self.raw.drain(..).collect(),
        };
        self.log.raw_samples += block.samples.len() as u64;
        self.send(&block, out);
        self.log.raw_frames += 1;
    }

    /// Bytes from the host: decode, check and apply the commands they
    /// complete, appending the answers to `out`.
    pub fn receive(&mut self, bytes: &[u8], out: &mut Vec<u8>) {
        // As the device: commands only, every one executed whatever its
        // sequence number (a repeat included, docs/PROTOCOL.md §5.4).
        let frames: Vec<_> = bytes
            .iter()
            .filter_map(|&b| self.rx.push_command(b))
            .collect();
        for f in frames {
            let cmd = match f {
                Ok(c) => c,
                Err(_) => {
                    self.counters.rx_frame_errors = self.counters.rx_frame_errors.saturating_add(1);
                    continue;
                }
            };
            let (seq, command) = cmd;
            let result: AckResult = command.validate(&self.limits()).into();
            if result == AckResult::Accepted {
                self.apply(command, out);
                self.counters.commands_accepted = self.counters.commands_accepted.saturating_add(1);
            } else {
                self.counters.commands_rejected = self.counters.commands_rejected.saturating_add(1);
            }
            self.log.commands.push((seq, command, result));
            if self.cfg.answers_commands {
                let ack = Ack {
                    command_seq: seq,
                    result,
                };
                self.send(&ack, out);
                if result == AckResult::Accepted && command == Command::RequestStatus {
                    self.send_status(out);
                }
                if result == AckResult::Accepted && command == Command::SelfTest {
                    let report = self.self_test_report();
                    self.send(&report, out);
                    self.self_test = SelfTestState::Done {
                        failed: report.failed,
                        not_measured: report.not_measured,
                    };
                }
            }
        }
    }

    fn apply(&mut self, command: Command, out: &mut Vec<u8>) {
        let k = self.next;
        match command {
            Command::SetExcitation(e) => self.excitation = e,
            Command::SetEstimator(s) => {
                self.estimator = s;
                self.restart = k;
                self.held = None;
            }
            Command::SetTelemetry(t) => {
                self.flush_raw(out);
                self.rates = t;
            }
            Command::Reset => {
                self.restart = k;
                self.held = None;
            }
            Command::Freeze => self.frozen = true,
            Command::Resume => self.frozen = false,
            Command::RequestStatus | Command::SelfTest | Command::SetLineRemoval(_) => {}
        }
        self.hold(k);
    }

    /// Run in real time over a byte stream until `opts` says stop or the
    /// host goes away; see [`ServeOptions`]. `reader` must return within
    /// about 100 ms when no bytes arrive (a read timeout), so that the
    /// reader thread can be stopped.
    pub fn serve<R, W>(&mut self, reader: R, mut writer: W, opts: &ServeOptions) -> ServeEnd
    where
        R: Read + Send + 'static,
        W: Write,
    {
        let stop_reader = Arc::new(AtomicBool::new(false));
        let (tx, rx) = mpsc::channel::<Vec<u8>>();
        let flag = Arc::clone(&stop_reader);
        let thread = std::thread::spawn(move || {
            let mut reader = reader;
            let mut buf = [0u8; 1024];
            while !flag.load(Ordering::Relaxed) {
                match reader.read(&mut buf) {
                    Ok(0) => break,
                    Ok(n) => {
                        if tx.send(buf[..n].to_vec()).is_err() {
                            break;
                        }
                    }
                    Err(e)
                        if matches!(
                            e.kind(),
                            io::ErrorKind::TimedOut
                                | io::ErrorKind::WouldBlock
                                | io::ErrorKind::Interrupted
                        ) => {}
                    Err(_) => break,
                }
            }
        });
        let start = Instant::now();
        let fs = f64::from(self.sample_rate_hz());
        let mut out = vec![beam_protocol::DELIMITER];
        let end = loop {
            while let Ok(bytes) = rx.try_recv() {
                self.receive(&bytes, &mut out);
            }
            let elapsed = start.elapsed();
            let due = (elapsed.as_secs_f64() * fs) as u64;
            if due > self.next {
                self.advance(due - self.next, &mut out);
            }
            if !out.is_empty() {
                if writer
                    .write_all(&out)
                    .and_then(|()| writer.flush())
                    .is_err()
                {
                    break ServeEnd::HostGone;
                }
                out.clear();
            }
            if opts.stop.load(Ordering::Relaxed) {
                break ServeEnd::Stopped;
            }
            if opts.close_after.is_some_and(|d| elapsed >= d) {
                break ServeEnd::Closed;
            }
            std::thread::sleep(opts.tick);
        };
        stop_reader.store(true, Ordering::Relaxed);
        let _ = thread.join();
        end
    }
}

/// How [`FakeDevice::serve`] runs.
#[derive(Debug, Clone)]
pub struct ServeOptions {
    /// Stop after this long (the caller then closes the stream: the
    /// device "disappears").
    pub close_after: Option<Duration>,
    /// Stop when set.
    pub stop: Arc<AtomicBool>,
    /// Time between two rounds of sending (frames are sent in bursts of one
    /// tick's worth).
    pub tick: Duration,
}

impl Default for ServeOptions {
    fn default() -> Self {
        Self {
            close_after: None,
            stop: Arc::new(AtomicBool::new(false)),
            tick: Duration::from_millis(2),
        }
    }
}

/// Why [`FakeDevice::serve`] returned.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ServeEnd {
    /// `close_after` elapsed.
    Closed,
    /// The stop flag was set.
    Stopped,
    /// Writing failed: the host closed the stream.
    HostGone,
}

#[cfg(test)]
mod tests {
    use super::*;
    use beam_protocol::{Frame, Message, RejectReason};

    fn decode(bytes: &[u8]) -> Vec<Frame> {
        let mut d: Decoder = Decoder::new();
        let frames: Vec<_> = d.feed(bytes).collect();
        assert_eq!(d.counters().errors(), 0);
        assert_eq!(d.counters().lost, 0);
        frames.into_iter().map(Result::unwrap).collect()
    }

    fn command_bytes(seq: u32, c: Command) -> Vec<u8> {
        let mut buf = [0u8; MAX_ENCODED_LEN];
        let n = Encoder::starting_at(seq).encode(&c, &mut buf).unwrap();
        buf[..n].to_vec()
    }

    #[test]
    fn one_second_at_the_default_rates() {
        let mut dev = FakeDevice::new(FakeConfig::default());
        let mut out = Vec::new();
        dev.advance(10_000, &mut out);
        let frames = decode(&out);
        let estimates: Vec<&Estimate> = frames
            .iter()
            .filter_map(|f| match &f.message {
                Message::Estimate(e) => Some(e),
                _ => None,
            })
            .collect();
        assert_eq!(estimates.len(), 100);
        assert_eq!(estimates[0].sample_index, 99);
        assert_eq!(estimates[99].sample_index, 9_999);
        assert!(matches!(frames[0].message, Message::Status(_)));
        assert_eq!(frames.len(), 101);
        // Converging from above towards the targets.
        let w = |e: &Estimate| e.modes[0].omega_rad_s;
        assert!(w(estimates[0]) > w(estimates[99]));
        assert!(w(estimates[99]) > 39.1533 && w(estimates[99]) < 39.1533 * 1.03);
        assert!(estimates[99].is_consistent());
    }

    #[test]
    fn raw_blocks_follow_the_decimation() {
        let cfg = FakeConfig {
            rates: TelemetryRates {
                estimate_rate_hz: 0.0,
                raw_decimation: 10,
                status_rate_hz: 0.0,
            },
            ..FakeConfig::default()
        };
        let mut dev = FakeDevice::new(cfg);
        let mut out = Vec::new();
        dev.advance(10_000, &mut out);
        let frames = decode(&out);
        assert_eq!(frames.len(), 15, "1000 samples: 15 full blocks of 64");
        let Message::RawSamples(r) = &frames[1].message else {
            panic!()
        };
        assert_eq!(r.first_sample_index, 640);
        assert_eq!(r.decimation, 10);
        let want = FakeDevice::signals(&Excitation::default(), 10_000.0, 650);
        assert_eq!((r.samples[1].u_v, r.samples[1].y), want);
    }

    #[test]
    fn commands_are_checked_applied_and_answered() {
        let mut dev = FakeDevice::new(FakeConfig::default());
        let mut out = Vec::new();
        let bad = Command::SetExcitation(Excitation {
            amplitude_v: 5.0,
            ..Excitation::default()
        });
        dev.receive(&command_bytes(0, bad), &mut out);
        dev.receive(&command_bytes(1, Command::RequestStatus), &mut out);
        dev.receive(&command_bytes(2, Command::Freeze), &mut out);
        // Garbage: counted, not answered.
        dev.receive(&[1, 2, 3, 0], &mut out);
        let frames = decode(&out);
        let acks: Vec<Ack> = frames
            .iter()
            .filter_map(|f| match f.message {
                Message::Ack(a) => Some(a),
                _ => None,
            })
            .collect();
        assert_eq!(
            acks,
            [
                Ack {
                    command_seq: 0,
                    result: AckResult::Rejected(RejectReason::SafeWindow)
                },
                Ack {
                    command_seq: 1,
                    result: AckResult::Accepted
                },
                Ack {
                    command_seq: 2,
                    result: AckResult::Accepted
                },
            ]
        );
        assert!(matches!(frames[2].message, Message::Status(_)));
        assert_eq!(dev.excitation(), &Excitation::default(), "nothing changed");
        let s = dev.status();
        assert!(s.adaptation_frozen);
        assert_eq!(s.counters.commands_accepted, 2);
        assert_eq!(s.counters.commands_rejected, 1);
        assert_eq!(s.counters.rx_frame_errors, 1);
        // Frozen: the estimate holds.
        let e0 = dev.estimate(1_000);
        let e1 = dev.estimate(9_000);
        assert_eq!(e0.modes, e1.modes);
        assert!(e1.flags.contains(StatusFlags::FROZEN_BY_COMMAND));
    }

    #[test]
    fn the_sensor_output_kind_is_a_setting_it_reports() {
        let mut dev = FakeDevice::new(FakeConfig::default());
        assert_eq!(
            dev.status().estimator.output,
            beam_protocol::OutputKind::Strain
        );
        let mut out = Vec::new();
        let s = EstimatorSettings {
            output: beam_protocol::OutputKind::Acceleration,
            ..EstimatorSettings::default()
        };
        dev.receive(&command_bytes(0, Command::SetEstimator(s)), &mut out);
        let acks: Vec<AckResult> = decode(&out)
            .iter()
            .filter_map(|f| match f.message {
                Message::Ack(a) => Some(a.result),
                _ => None,
            })
            .collect();
        assert_eq!(acks, [AckResult::Accepted]);
        assert_eq!(
            dev.status().estimator.output,
            beam_protocol::OutputKind::Acceleration
        );
    }
}
