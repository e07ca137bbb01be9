//! `beamctl send`: one command to a live device, and its answer.
//!
//! The command grammar ([`CommandArgs`]) is shared with the monitor's
//! command line (`:` in the terminal view, `--stdin-commands` in plain
//! mode), so the same text works in both. Settings not given are taken from
//! the device's last Status (`excitation --amplitude 0.2` changes only the
//! amplitude); `beamctl send` therefore asks for a Status first for the
//! three `set` commands.
//!
//! Every command is checked locally with the core's `Command::validate`,
//! against what the last Status tells (sample rate, mode count; the baud
//! rate's link budget for `--port`). The local check only informs: a
//! command it expects the device to refuse is still sent, with a warning
//! that gives the reason and the device's sample rate, because the device
//! decides. It checks the command against its full limits (the piezo's
//! safe window, its generators and estimators); its Ack is printed, and a
//! negative one (the reason code and its meaning) exits 1, as does no
//! answer within `--timeout`.

use crate::error::CliError;
use crate::link::grammar::{command_text, CommandArgs};
use crate::link::{text, transport, Connection, Endpoint, Host, Incoming, StreamEnd};
use beam_protocol::budget::uart_bytes_per_s;
use beam_protocol::{
    AckResult, Command, DecodeError, Estimate, Frame, Message, RejectReason, StatusFlags,
};
use clap::{ArgGroup, Args};

use std::io::Write;
use std::sync::mpsc::{self, Receiver};
use std::time::{Duration, Instant};

/// A live device: `--port PATH [--baud N]` or `--tcp HOST:PORT`.
#[derive(Debug, Clone, Args)]
pub struct DeviceArgs {
    /// Serial port of the device (e.g. /dev/ttyACM0, COM3).
    #[arg(long, value_name = "PATH")]
    pub port: Option<String>,

    /// Baud rate of --port (8N1, no flow control).
    #[arg(long, value_name = "N", default_value_t = 921_600)]
    pub baud: u32,

    /// TCP server that carries the device's serial stream, HOST:PORT (e.g.
    /// QEMU's `-serial tcp::4000,server`).
    #[arg(long, value_name = "HOST:PORT")]
    pub tcp: Option<String>,
}

impl DeviceArgs {
    /// The endpoint named (clap's groups guarantee at most one), if any.
    pub fn endpoint(&self) -> Option<Endpoint> {
        match (&self.port, &self.tcp) {
            (Some(path), _) => Some(Endpoint::Serial {
                path: path.clone(),
                baud: self.baud,
            }),
            (None, Some(addr)) => Some(Endpoint::Tcp(addr.clone())),
            (None, None) => None,
        }
    }
}

/// Options of `beamctl send`.
#[derive(Debug, Clone, Args)]
#[command(group(ArgGroup::new("device").args(["port", "tcp"]).required(true)))]
pub struct SendArgs {
    /// The device to send to.
    #[command(flatten)]
    pub device: DeviceArgs,

    /// Seconds to wait for the device's acknowledgement (> 0).
    #[arg(long, value_name = "SECONDS", default_value_t = 1.0)]
    pub timeout: f64,

    /// The command to send.
    #[command(subcommand)]
    pub command: CommandArgs,
}

/// The link budget the host knows: the baud rate's bytes per second for a
/// serial port (8N1), nothing for TCP.
pub fn link_budget(endpoint: &Endpoint) -> Option<f32> {
    match endpoint {
        Endpoint::Serial { baud, .. } => Some(uart_bytes_per_s(*baud) as f32),
        _ => None,
    }
}

/// Check `command` against what `host` knows of the device. `Ok(None)`:
/// nothing known to check against (no Status yet).
pub fn check_locally(
    command: &Command,
    host: &Host,
    endpoint: &Endpoint,
) -> Result<Option<()>, RejectReason> {
    match host.limits(link_budget(endpoint)) {
        Some(limits) => command.validate(&limits).map(Some),
        None => Ok(None),
    }
}

/// The warning for a command the local check expects the device to refuse.
pub fn local_refusal(reason: RejectReason, host: &Host) -> String {
    let fs = host
        .status()
        .map_or_else(|| "?".to_string(), |s| s.sample_rate_hz.to_string());
    format!(
        "the local check expects a refusal ({} {reason:?}: {}; device sample rate {fs} Hz, from its last Status); sent anyway, the device decides",
        reason as u8,
        reason.describe()
    )
}

/// A live session: the host state and the reader's channel.
pub(crate) struct Session {
    pub(crate) endpoint: Endpoint,
    pub(crate) host: Host,
    rx: Receiver<Incoming>,
    writer: Box<dyn Write + Send>,
    start: Instant,
    /// The latest physically valid estimate received.
    pub(crate) last_valid: Option<Estimate>,
    /// Frames received after the one a wait returned, in order.
    queued: std::collections::VecDeque<Frame>,
}

/// What the session waits for.
pub(crate) enum Wanted {
    /// The Ack of this command number.
    Ack(u32),
    /// A Status after this many.
    StatusAfter(u64),
    /// A self-test report.
    SelfTestReport,
    /// A physically valid estimate.
    ValidEstimate,
}

impl Session {
    pub(crate) fn open(endpoint: &Endpoint) -> Result<Self, CliError> {
        let conn: Connection = transport::open(endpoint).map_err(CliError::failure)?;
        let (tx, rx) = mpsc::sync_channel(256);
        let (_reader, writer) = conn.start(tx);
        let writer = writer.ok_or_else(|| CliError::failure("the endpoint is read-only"))?;
        Ok(Self {
            endpoint: endpoint.clone(),
            host: Host::new(true),
            rx,
            writer,
            start: Instant::now(),
            last_valid: None,
            queued: std::collections::VecDeque::new(),
        })
    }

    pub(crate) fn send(&mut self, command: Command) -> Result<u32, CliError> {
        let (seq, bytes) = self
            .host
            .command(command, Instant::now())
            .map_err(|e| CliError::failure(format!("encoding the command: {e}")))?;
        self.writer
            .write_all(&bytes)
            .and_then(|()| self.writer.flush())
            .map_err(|e| CliError::failure(format!("{}: writing: {e}", self.endpoint)))?;
        Ok(seq)
    }

    /// Read until `wanted` or `deadline`. Ok(None): the deadline passed.
    pub(crate) fn wait(
        &mut self,
        wanted: Wanted,
        deadline: Instant,
    ) -> Result<Option<Frame>, CliError> {
        // Frames that came with an earlier wanted one, not yet looked at.
        while let Some(f) = self.queued.pop_front() {
            if self.matches(&wanted, &f) {
                return Ok(Some(f));
            }
        }
        loop {
            let now = Instant::now();
            let Some(left) = deadline.checked_duration_since(now) else {
                return Ok(None);
            };
            let incoming = match self.rx.recv_timeout(left) {
                Ok(i) => i,
                Err(mpsc::RecvTimeoutError::Timeout) => return Ok(None),
                Err(mpsc::RecvTimeoutError::Disconnected) => {
                    return Err(CliError::failure(format!(
                        "{}: the reader stopped",
                        self.endpoint
                    )))
                }
            };
            let (bytes, at) = match incoming {
                Incoming::Bytes(b, at) => (b, at),
                Incoming::End(end) => {
                    let end = match end {
                        StreamEnd::Eof => StreamEnd::Closed,
                        e => e,
                    };
                    return Err(CliError::failure(end.describe(&self.endpoint)));
                }
            };
            let mut found = None;
            for r in self.host.receive(&bytes, at) {
                match r {
                    Err(e @ DecodeError::VersionMismatch { .. }) => {
                        return Err(CliError::failure(format!("{}: {e}", self.endpoint)))
                    }
                    Err(_) => {}
                    Ok(f) if found.is_some() => self.queued.push_back(f),
                    Ok(f) => {
                        if self.matches(&wanted, &f) {
                            found = Some(f);
                        }
                    }
                }
            }
            if found.is_some() {
                return Ok(found);
            }
        }
    }

    /// `f` is what `wanted` waits for (and the latest valid estimate is
    /// kept on the way).
    fn matches(&mut self, wanted: &Wanted, f: &Frame) -> bool {
        match (wanted, &f.message) {
            (wanted, Message::Estimate(e)) if e.flags.contains(StatusFlags::PHYSICALLY_VALID) => {
                self.last_valid = Some(e.clone());
                matches!(wanted, Wanted::ValidEstimate)
            }
            (Wanted::SelfTestReport, Message::SelfTestReport(_)) => true,
            (Wanted::Ack(seq), Message::Ack(a)) if a.command_seq == *seq => {
                self.host.answer(a);
                true
            }
            (Wanted::StatusAfter(n), Message::Status(_)) => self.host.statuses() > *n,
            _ => false,
        }
    }
}

/// Run `beamctl send`.
pub fn run(args: &SendArgs) -> Result<(), CliError> {
    if !(args.timeout.is_finite() && args.timeout > 0.0) {
        return Err(CliError::usage(
            "--timeout",
            format!("must be a number of seconds > 0 (got {})", args.timeout),
        ));
    }
    let timeout = Duration::from_secs_f64(args.timeout);
    let endpoint = args
        .device
        .endpoint()
        .ok_or_else(|| CliError::usage("--port/--tcp", "name the device"))?;
    let mut s = Session::open(&endpoint)?;
    let no_answer = |seq: u32| {
        CliError::failure(format!(
            "no acknowledgement from the device within {} s (command seq {seq})",
            args.timeout
        ))
    };

    // The device's current settings and limits, for the three set commands.
    if args.command.needs_status() {
        let before = s.host.statuses();
        let seq = s.send(Command::RequestStatus)?;
        let deadline = Instant::now() + timeout;
        match s.wait(Wanted::Ack(seq), deadline)? {
            Some(Frame {
                message: Message::Ack(a),
                ..
            }) if a.result != AckResult::Accepted => {
                return Err(CliError::failure(format!(
                    "the device refused a status request: {}",
                    text::result_text(a.result)
                )))
            }
            Some(_) => {}
            None => return Err(no_answer(seq)),
        }
        if s.host.statuses() == before && s.wait(Wanted::StatusAfter(before), deadline)?.is_none() {
            return Err(CliError::failure(format!(
                "the device acknowledged the status request but sent no Status within {} s",
                args.timeout
            )));
        }
    }

    let command = args
        .command
        .build(s.host.status())
        .map_err(|m| CliError::usage(command_name(&args.command), m))?;
    if let Err(reason) = check_locally(&command, &s.host, &endpoint) {
        eprintln!(
            "warning: {}: {}",
            command_name(&args.command),
            local_refusal(reason, &s.host)
        );
    }

    let before = s.host.statuses();
    let seq = s.send(command)?;
    let deadline = Instant::now() + timeout;
    let ack = match s.wait(Wanted::Ack(seq), deadline)? {
        Some(Frame {
            message: Message::Ack(a),
            ..
        }) => a,
        _ => return Err(no_answer(seq)),
    };
    match ack.result {
        AckResult::Accepted => {
            let mut out = std::io::stdout().lock();
            let _ = writeln!(
                out,
                "accepted: {} (command seq {seq}, {:.0} ms)",
                command_text(&command),
                s.start.elapsed().as_secs_f64() * 1e3
            );
            if command == Command::RequestStatus {
                if s.host.statuses() == before
                    && s.wait(Wanted::StatusAfter(before), deadline)?.is_none()
                {
                    return Err(CliError::failure(format!(
                        "the device acknowledged the status request but sent no Status within {} s",
                        args.timeout
                    )));
                }
                if let Some(st) = s.host.status() {
                    for line in text::status_lines(st) {
                        let _ = writeln!(out, "{line}");
                    }
                }
            }
            Ok(())
        }
        AckResult::Rejected(_) => Err(CliError::failure(format!(
            "the device {}: {} (command seq {seq})",
            text::result_text(ack.result),
            command_text(&command)
        ))),
    }
}

fn command_name(c: &CommandArgs) -> &'static str {
    match c {
        CommandArgs::Excitation(_) => "excitation",
        CommandArgs::Estimator(_) => "estimator",
        CommandArgs::Telemetry(_) => "telemetry",
        CommandArgs::Reset => "reset",
        CommandArgs::Freeze => "freeze",
        CommandArgs::Resume => "resume",
        CommandArgs::Status => "status",
        CommandArgs::Lines(_) => "lines",
        CommandArgs::Selftest => "selftest",
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::link::grammar::tests::{build, status};

    #[test]
    fn local_check_uses_the_status() {
        let s = status();
        let mut host = Host::new(false);
        let tcp = Endpoint::Tcp("x:1".into());
        let c = build("excitation --freq 6000", Some(&s)).unwrap();
        // No Status yet: nothing to check against.
        assert_eq!(check_locally(&c, &host, &tcp), Ok(None));
        let mut buf = [0u8; beam_protocol::MAX_ENCODED_LEN];
        let n = beam_protocol::encode(&s, 0, &mut buf).unwrap();
        host.receive(&buf[..n], Instant::now());
        assert_eq!(check_locally(&c, &host, &tcp), Err(RejectReason::Frequency));
        // The piezo window is not in a Status: left to the device.
        let c = build("excitation --amplitude 50", Some(&s)).unwrap();
        assert_eq!(check_locally(&c, &host, &tcp), Ok(Some(())));
        // Over a serial port the baud rate bounds the telemetry.
        let serial = Endpoint::Serial {
            path: "p".into(),
            baud: 115_200,
        };
        let c = build("telemetry --estimates 200", Some(&s)).unwrap();
        assert_eq!(
            check_locally(&c, &host, &serial),
            Err(RejectReason::LinkBudget)
        );
        assert_eq!(check_locally(&c, &host, &tcp), Ok(Some(())));
    }
}
