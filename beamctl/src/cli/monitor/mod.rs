//! `beamctl monitor`: watch a device's estimates live, record them, send it
//! commands.
//!
//! The bytes come from a serial port, a TCP socket or a capture file
//! (`crate::link::transport`), read on a thread; this module's event loop
//! decodes them (`crate::link::Host`), records them (`--record`,
//! `--capture`), shows them (the terminal view of `tui` on a terminal,
//! else one line per estimate on stdout), sends the commands typed (keys
//! and `:` in the terminal view, `--stdin-commands` in plain mode) and
//! times out the ones that get no acknowledgement.
//!
//! # How a run ends
//! * `--duration` elapsed, `q` or Ctrl-C: exit 0;
//! * the end of a `--file`: the end of the capture, exit 0 (bytes after
//!   the last delimiter, a frame cut short by the end of the capture, are
//!   reported in the summary, not counted as an error);
//! * a live device that disappears (TCP peer closed, serial port hung up,
//!   USB unplugged): said on stderr, exit 1;
//! * a frame of another protocol version: said on stderr (both versions),
//!   exit 1, without interpreting it.
//!
//! Whatever the end, the record files are flushed and closed first, the
//! plot is drawn from what arrived, and a summary of the link's counters
//! goes to stderr.

mod event;
pub mod live;
mod plot;
pub mod state;
mod tui;

use crate::cli::send::{self, DeviceArgs};
use crate::error::CliError;
use crate::link::grammar::{self, command_text, CommandArgs};
use crate::link::{text, transport, Endpoint, Host, Incoming, Recorder, StreamEnd};
use beam_protocol::{Command, DecodeError, Message};
use clap::{ArgGroup, Args};
use event::{Event, KeyAction};
use state::State;
use std::fs::File;
use std::io::{BufWriter, IsTerminal, Write};
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{self, RecvTimeoutError, SyncSender};
use std::sync::Arc;
use std::time::{Duration, Instant};

/// Redraw period of the terminal view.
const DRAW_EVERY: Duration = Duration::from_millis(100);
/// Longest wait for an event (so deadlines are checked).
const TICK: Duration = Duration::from_millis(50);
/// Plain mode: at most one line about link errors per this interval.
const ERROR_LINE_EVERY: Duration = Duration::from_secs(1);

/// Options of `beamctl monitor`.
#[derive(Debug, Clone, Args)]
#[command(group(ArgGroup::new("source").args(["port", "tcp", "file"]).required(true)))]
pub struct MonitorArgs {
    /// The device to watch.
    #[command(flatten)]
    pub device: DeviceArgs,

    /// A file of bytes captured from a device (e.g. by --capture): decoded
    /// from its start; its end ends the run (exit 0).
    #[arg(long, value_name = "PATH")]
    pub file: Option<PathBuf>,

    /// One line per estimate on stdout, even on a terminal (the default
    /// when stdout or stdin is not a terminal).
    #[arg(long)]
    pub plain: bool,

    /// Write every frame, command and decoding error to this CSV file, and
    /// the raw samples to FILE.raw.csv (header t,u,y, for `beamctl
    /// replay`); see docs/RECORDING.md.
    #[arg(long, value_name = "FILE.csv")]
    pub record: Option<PathBuf>,

    /// Write every byte received, as received, to this file (readable
    /// again with --file).
    #[arg(long, value_name = "FILE")]
    pub capture: Option<PathBuf>,

    /// At the end, plot ω̂_i and ζ̂_i vs device time to this PNG file.
    #[arg(long, value_name = "FILE.png")]
    pub plot: Option<PathBuf>,

    /// Stop after this many seconds (host clock; > 0) [default: until the
    /// device or the file ends, q or Ctrl-C].
    #[arg(long, value_name = "SECONDS", allow_negative_numbers = true)]
    pub duration: Option<f64>,

    /// Sample rate (Hz) for times until the device's first Status (e.g. a
    /// --file capture without Status frames).
    #[arg(long, value_name = "HZ", allow_negative_numbers = true)]
    pub sample_rate: Option<f64>,

    /// Seconds to wait for a command's acknowledgement (> 0).
    #[arg(long, value_name = "SECONDS", default_value_t = 1.0)]
    pub timeout: f64,

    /// Send nothing to the device: no status request at the start, no
    /// commands.
    #[arg(long)]
    pub listen_only: bool,

    /// The verdict on the last estimate (docs/CLI.md, "The verdict, live")
    /// judges this many seconds of the stream (device time; > 0): the
    /// model-output fit over the raw samples (every sample must be sent:
    /// `telemetry --raw-decimation 1`), the drift over its last tenth.
    #[arg(long, value_name = "SECONDS", default_value_t = live::DEFAULT_WINDOW_S, allow_negative_numbers = true)]
    pub verdict_window: f64,

    /// Plain mode: read commands from stdin, one per line, in the syntax of
    /// `beamctl send` (e.g. `excitation --amplitude 0.2`); answers go to
    /// stderr.
    #[arg(long)]
    pub stdin_commands: bool,
}

/// Why the loop stopped.
#[derive(Debug)]
enum End {
    Duration,
    User,
    Stream(StreamEnd),
    Version { got: u8, expected: u8 },
    Failure(String),
}

fn check_seconds(flag: &str, v: f64) -> Result<(), CliError> {
    if v.is_finite() && v > 0.0 {
        Ok(())
    } else {
        Err(CliError::usage(flag, format!("must be > 0 (got {v})")))
    }
}

/// Run `beamctl monitor`.
pub fn run(args: &MonitorArgs) -> Result<(), CliError> {
    if let Some(d) = args.duration {
        check_seconds("--duration", d)?;
    }
    if let Some(f) = args.sample_rate {
        check_seconds("--sample-rate", f)?;
    }
    check_seconds("--timeout", args.timeout)?;
    check_seconds("--verdict-window", args.verdict_window)?;
    let endpoint = match (&args.file, args.device.endpoint()) {
        (Some(p), _) => Endpoint::File(p.clone()),
        (None, Some(e)) => e,
        (None, None) => return Err(CliError::usage("--port/--tcp/--file", "name a source")),
    };
    let tui = !args.plain && std::io::stdout().is_terminal() && std::io::stdin().is_terminal();
    if args.stdin_commands && tui {
        return Err(CliError::usage(
            "--stdin-commands",
            "is for plain mode (use --plain); the terminal view has its own command line (:)",
        ));
    }
    if let Some(p) = &args.plot {
        crate::io::plot::check_writable(p)?;
    }
    let mut recorder = match &args.record {
        Some(p) => Some(Recorder::create(p).map_err(|m| CliError::usage("--record", m))?),
        None => None,
    };
    let mut capture = match &args.capture {
        Some(p) => Some(BufWriter::new(File::create(p).map_err(|e| {
            CliError::usage("--capture", format!("cannot create {}: {e}", p.display()))
        })?)),
        None => None,
    };
    let conn = transport::open(&endpoint).map_err(|m| match endpoint {
        Endpoint::File(_) => CliError::usage("--file", m),
        _ => CliError::failure(m),
    })?;
    let writable = conn.writable() && !args.listen_only;

    let stop = Arc::new(AtomicBool::new(false));
    {
        let stop = Arc::clone(&stop);
        // Without a handler Ctrl-C would kill the process before the
        // record is flushed; failing to install one is not fatal.
        let _ = ctrlc::set_handler(move || stop.store(true, Ordering::SeqCst));
    }
    let (tx, rx) = mpsc::sync_channel::<Event>(1024);
    if args.stdin_commands {
        spawn_stdin(tx.clone());
    }
    if tui {
        tui::spawn_keys(tx.clone());
    }
    let (_reader, writer) = conn.start(tx);
    let writer = if writable { writer } else { None };

    let mut host = Host::new(endpoint.is_live());
    host.set_sample_rate_fallback(args.sample_rate);
    let mut st = State::new(endpoint.to_string(), host, writable, args.verdict_window);
    let mut lp = Loop {
        args,
        endpoint: &endpoint,
        writer,
        recorder: recorder.as_mut(),
        tui,
        stdout_ok: true,
        last_error_line: None,
        errors_unreported: 0,
        verdict_printed: None,
    };
    if writable {
        lp.submit(&mut st, Command::RequestStatus, Instant::now());
    }

    let mut terminal = if tui { Some(ratatui::init()) } else { None };
    let end = lp.run(&mut st, &rx, &stop, capture.as_mut(), terminal.as_mut());
    if terminal.is_some() {
        ratatui::restore();
    }
    finish(args, &endpoint, &mut st, end, recorder, capture)
}

/// The event loop's context.
struct Loop<'a> {
    args: &'a MonitorArgs,
    endpoint: &'a Endpoint,
    writer: Option<Box<dyn Write + Send>>,
    recorder: Option<&'a mut Recorder>,
    tui: bool,
    stdout_ok: bool,
    last_error_line: Option<Instant>,
    errors_unreported: u64,
    /// Plain mode: the verdict summary last printed.
    verdict_printed: Option<String>,
}

impl Loop<'_> {
    fn run(
        &mut self,
        st: &mut State,
        rx: &mpsc::Receiver<Event>,
        stop: &AtomicBool,
        mut capture: Option<&mut BufWriter<File>>,
        mut terminal: Option<&mut ratatui::DefaultTerminal>,
    ) -> End {
        let timeout = Duration::from_secs_f64(self.args.timeout);
        let deadline = self
            .args
            .duration
            .map(|d| st.start + Duration::from_secs_f64(d));
        let mut next_draw = Instant::now();
        let mut next_capture_flush = Instant::now();
        loop {
            let now = Instant::now();
            if deadline.is_some_and(|d| now >= d) {
                return End::Duration;
            }
            if stop.load(Ordering::SeqCst) || !self.stdout_ok {
                return End::User;
            }
            if let Some(t) = terminal.as_deref_mut() {
                if now >= next_draw {
                    // A failed draw (terminal gone) is not worth stopping for.
                    let _ = t.draw(|f| tui::draw(f, st, now));
                    next_draw = now + DRAW_EVERY;
                }
            }
            let mut wait = TICK;
            if let Some(d) = deadline {
                wait = wait.min(d.saturating_duration_since(now));
            }
            match rx.recv_timeout(wait) {
                Ok(Event::Link(Incoming::Bytes(bytes, at))) => {
                    if let Some(c) = capture.as_deref_mut() {
                        if let Err(e) = c.write_all(&bytes) {
                            return End::Failure(format!("--capture: {e}"));
                        }
                    }
                    if let Some(end) = self.bytes(st, &bytes, at) {
                        return end;
                    }
                }
                Ok(Event::Link(Incoming::End(e))) => return End::Stream(e),
                Ok(Event::Key(k)) => match tui::key(st, k) {
                    KeyAction::Quit => return End::User,
                    KeyAction::Send(c) => self.submit_args(st, &c, Instant::now()),
                    KeyAction::None => next_draw = Instant::now(),
                },
                Ok(Event::Line(line)) => self.line(st, &line),
                Err(RecvTimeoutError::Timeout) => {}
                Err(RecvTimeoutError::Disconnected) => {
                    return End::Failure("the reader thread stopped".into())
                }
            }
            let now = Instant::now();
            for p in st.host.expire(now, timeout) {
                let msg = format!(
                    "#{} {}: no acknowledgement within {} s",
                    p.seq,
                    command_text(&p.command),
                    self.args.timeout
                );
                self.note(st, msg);
                let host_s = st.host_s(now);
                if let Some(r) = self.recorder.as_deref_mut() {
                    if let Err(m) = r.timeout(host_s, p.seq, &p.command) {
                        return End::Failure(format!("--record: {m}"));
                    }
                }
            }
            if let Some(r) = self.recorder.as_deref_mut() {
                if let Err(m) = r.flush_if_due(now) {
                    return End::Failure(format!("--record: {m}"));
                }
            }
            if now >= next_capture_flush {
                if let Some(c) = capture.as_deref_mut() {
                    if let Err(e) = c.flush() {
                        return End::Failure(format!("--capture: {e}"));
                    }
                }
                next_capture_flush = now + crate::link::record::FLUSH_EVERY;
            }
        }
    }

    /// Decode and handle received bytes.
    fn bytes(&mut self, st: &mut State, bytes: &[u8], at: Instant) -> Option<End> {
        let host_s = st.host_s(at);
        let results = st.host.receive(bytes, at);
        for r in results {
            match r {
                Ok(f) => {
                    st.frame(&f, at);
                    if let Some(rec) = self.recorder.as_deref_mut() {
                        if let Err(m) = rec.frame(host_s, &f, &st.host) {
                            return Some(End::Failure(format!("--record: {m}")));
                        }
                    }
                    match &f.message {
                        Message::Estimate(e) if !self.tui => {
                            let line = state::estimate_line(e, f.seq, &st.host);
                            let mut out = std::io::stdout().lock();
                            if writeln!(out, "{line}").is_err() {
                                self.stdout_ok = false;
                            }
                            drop(out);
                            // A verdict line (stderr) when the verdict changes.
                            if let Some((k, v)) = st.live.last() {
                                let summary = v.summary();
                                if self.verdict_printed.as_ref() != Some(&summary) {
                                    eprintln!("{}", state::verdict_line(*k, v, &st.host));
                                    self.verdict_printed = Some(summary);
                                }
                            }
                        }
                        Message::Ack(a) => {
                            let msg = match st.host.answer(a) {
                                Some(p) => format!(
                                    "#{} {}: {}",
                                    p.seq,
                                    command_text(&p.command),
                                    text::result_text(a.result)
                                ),
                                None => format!(
                                    "#{}: {} (no such command pending)",
                                    a.command_seq,
                                    text::result_text(a.result)
                                ),
                            };
                            self.note(st, msg);
                        }
                        Message::SelfTestReport(r) => {
                            for line in text::self_test_lines(r) {
                                self.note(st, line);
                            }
                        }
                        _ => {}
                    }
                }
                Err(e) => {
                    if let Some(rec) = self.recorder.as_deref_mut() {
                        if let Err(m) = rec.error(host_s, &e) {
                            return Some(End::Failure(format!("--record: {m}")));
                        }
                    }
                    if let DecodeError::VersionMismatch { got, expected } = e {
                        return Some(End::Version { got, expected });
                    }
                    self.link_error(st, &e, at);
                }
            }
        }
        None
    }

    /// Plain mode: a line about link errors, at most once per second.
    fn link_error(&mut self, st: &State, e: &DecodeError, now: Instant) {
        if self.tui {
            return;
        }
        self.errors_unreported += 1;
        if self
            .last_error_line
            .is_some_and(|t| now.duration_since(t) < ERROR_LINE_EVERY)
        {
            return;
        }
        let more = self.errors_unreported - 1;
        let c = st.host.counters();
        eprintln!(
            "link: {e}{} (so far: {} CRC errors, {} framing, {} lost by sequence gaps)",
            if more > 0 {
                format!(" and {more} more")
            } else {
                String::new()
            },
            c.crc_errors,
            c.framing_errors,
            c.lost
        );
        self.errors_unreported = 0;
        self.last_error_line = Some(now);
    }

    /// A message for the user: the log (terminal view) or stderr (plain).
    fn note(&mut self, st: &mut State, msg: String) {
        if !self.tui {
            eprintln!("{msg}");
        }
        st.log(msg);
    }

    fn line(&mut self, st: &mut State, line: &str) {
        let line = line.trim();
        if line.is_empty() || line.starts_with('#') {
            return;
        }
        match grammar::parse_line(line) {
            Ok(c) => self.submit_args(st, &c, Instant::now()),
            Err(m) => self.note(st, format!("'{line}': {m}")),
        }
    }

    fn submit_args(&mut self, st: &mut State, c: &CommandArgs, now: Instant) {
        match c.build(st.host.status()) {
            Ok(cmd) => self.submit(st, cmd, now),
            Err(m) => self.note(st, m),
        }
    }

    /// Check, send and record a command.
    fn submit(&mut self, st: &mut State, command: Command, now: Instant) {
        let text = command_text(&command);
        if self.writer.is_none() {
            let why = if self.endpoint.is_live() {
                "--listen-only"
            } else {
                "a --file capture is read-only"
            };
            self.note(st, format!("{text}: not sent ({why})"));
            return;
        };
        if let Err(reason) = send::check_locally(&command, &st.host, self.endpoint) {
            let warning = send::local_refusal(reason, &st.host);
            self.note(st, format!("{text}: {warning}"));
        }
        let (seq, bytes) = match st.host.command(command, now) {
            Ok(x) => x,
            Err(e) => return self.note(st, format!("{text}: cannot encode: {e}")),
        };
        let written = match self.writer.as_mut() {
            Some(w) => w.write_all(&bytes).and_then(|()| w.flush()),
            None => return,
        };
        if let Err(e) = written {
            self.note(st, format!("#{seq} {text}: writing failed: {e}"));
            return;
        }
        let host_s = st.host_s(now);
        if let Some(r) = self.recorder.as_deref_mut() {
            // A write error here shows again at the next flush, which stops.
            let _ = r.command(host_s, seq, &command);
        }
        if command != Command::RequestStatus || self.tui {
            self.note(st, format!("#{seq} {text}: sent"));
        }
    }
}

fn spawn_stdin(tx: SyncSender<Event>) {
    std::thread::spawn(move || {
        let stdin = std::io::stdin();
        let mut line = String::new();
        while stdin.read_line(&mut line).is_ok_and(|n| n > 0) {
            if tx.send(Event::Line(std::mem::take(&mut line))).is_err() {
                break;
            }
        }
    });
}

/// Close the record, draw the plot, print the summary; the exit status.
fn finish(
    args: &MonitorArgs,
    endpoint: &Endpoint,
    st: &mut State,
    end: End,
    recorder: Option<Recorder>,
    capture: Option<BufWriter<File>>,
) -> Result<(), CliError> {
    let now = Instant::now();
    let (reason, error) = match end {
        End::Duration => ("--duration elapsed".to_string(), None),
        End::User => ("stopped by the user".to_string(), None),
        End::Stream(StreamEnd::Eof) => (format!("end of {endpoint}"), None),
        End::Stream(e) => {
            let m = e.describe(endpoint);
            (m.clone(), Some(m))
        }
        End::Version { got, expected } => {
            let m = format!(
                "{endpoint}: protocol version mismatch: the peer speaks version {got}, this build {expected}; stopped without interpreting its frames (use a beamctl and a firmware of the same protocol version)"
            );
            (m.clone(), Some(m))
        }
        End::Failure(m) => (m.clone(), Some(m)),
    };
    let mut problems: Vec<String> = error.into_iter().collect();
    let mut kept = Vec::new();
    if let Some(mut r) = recorder {
        let host_s = st.host_s(now);
        let path = r.path().to_path_buf();
        let result = r.end(host_s, &reason).and_then(|()| r.finish());
        match result {
            Ok(stats) => {
                kept.push(format!("{} ({} rows)", path.display(), stats.rows));
                if let Some(raw) = &stats.raw_path {
                    kept.push(format!(
                        "{} ({} raw samples{}{})",
                        raw.display(),
                        stats.raw_samples,
                        if stats.raw_gaps > 0 {
                            format!(", {} gaps in the sample index", stats.raw_gaps)
                        } else {
                            String::new()
                        },
                        if stats.raw_without_rate {
                            ", by sample index: no sample rate known (--sample-rate)"
                        } else {
                            ""
                        }
                    ));
                }
            }
            Err(m) => problems.push(format!("--record: {m}")),
        }
    }
    if let Some(mut c) = capture {
        match c.flush() {
            Ok(()) => kept.push(format!(
                "{} ({} bytes)",
                args.capture
                    .as_ref()
                    .map_or_else(String::new, |p| p.display().to_string()),
                st.host.counters().bytes
            )),
            Err(e) => problems.push(format!("--capture: {e}")),
        }
    }
    if let Some(p) = &args.plot {
        match plot::write(p, st) {
            Ok(text) => {
                let note = if text {
                    ""
                } else {
                    ", without text: no font found"
                };
                kept.push(format!("{}{note}", p.display()));
            }
            Err(e) => problems.push(e.message),
        }
    }
    summary(st, &reason, &kept);
    if problems.is_empty() {
        Ok(())
    } else {
        Err(CliError::failure(problems.join("; ")))
    }
}

/// The end-of-run summary on stderr.
fn summary(st: &State, reason: &str, kept: &[String]) {
    let k = st.kinds;
    let mut err = std::io::stderr().lock();
    let _ = writeln!(
        err,
        "monitor: {reason} after {:.1} s",
        st.start.elapsed().as_secs_f64()
    );
    let _ = writeln!(
        err,
        "link: {} (estimates {}, raw blocks {}, status {}, acks {}, self-test reports {})",
        text::counters_text(st.host.counters()),
        k.estimates,
        k.raw,
        k.status,
        k.acks,
        k.self_tests
    );
    if st.host.partial_bytes() > 0 {
        let _ = writeln!(
            err,
            "link: {} bytes after the last frame delimiter were not decoded (a frame cut short)",
            st.host.partial_bytes()
        );
    }
    if let Some(seq) = st.host.first_seq().filter(|s| *s > 0) {
        let _ = writeln!(
            err,
            "link: the first frame decoded has sequence number {seq}: the device sent {seq} frames before"
        );
    }
    if let Some(s) = st.host.status() {
        let c = &s.counters;
        let _ = writeln!(
            err,
            "device: overruns {}, ADC CRC errors {}, telemetry dropped {}, rejected samples {}, commands accepted {} / rejected {}, rx frame errors {}",
            c.overruns,
            c.adc_crc_errors,
            c.telemetry_dropped,
            c.rejected_samples,
            c.commands_accepted,
            c.commands_rejected,
            c.rx_frame_errors
        );
    }
    match st.live.last() {
        Some((k, v)) => {
            let t = st
                .host
                .time_s(*k)
                .map_or_else(|| "?".to_string(), |t| format!("{t:.3}"));
            let _ = writeln!(
                err,
                "verdict on the last estimate judged (sample {k}, t = {t} s, over the last {} s: {} raw samples): trusted {}",
                st.live.window_s(),
                st.live.pairs(),
                v.summary()
            );
            for r in &v.reasons {
                let _ = writeln!(err, "  {}: {}", r.code, r.detail);
            }
        }
        None => {
            let _ = writeln!(err, "verdict: no estimate judged");
        }
    }
    let pending: Vec<String> = st.host.pending().map(|p| format!("#{}", p.seq)).collect();
    if !pending.is_empty() {
        let _ = writeln!(err, "commands still unanswered: {}", pending.join(", "));
    }
    for k in kept {
        let _ = writeln!(err, "wrote {k}");
    }
}
