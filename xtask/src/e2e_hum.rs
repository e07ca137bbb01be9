//! `cargo xtask qemu --hum`: the line remover on the emulated device. The
//! image adds mains hum to the ADC model's bridge input (`hum=1` on its
//! command line: `beamest::bench::HUM`, 50 Hz at 3% and 150 Hz at 1% of
//! y's RMS, the bench beam's second mode at 39 Hz); the
//! host on UART0 (as `--e2e`) selects the line remover over the link as
//! soon as the boot self-test has reported (it refuses commands as Busy
//! while it runs), and the run is judged:
//!
//! 1. the link: a `SetLineRemoval` with no harmonic is refused
//!    (`LineRemoval`), `SetLineRemoval { mains 50 Hz, 7 harmonics, τ
//!    0.2 s }` is accepted; no gap, no bad frame;
//! 2. found: the remover's weights at the end hold the injected lines'
//!    amplitudes (50 and 150 Hz within [`FOUND_TOLERANCE`]), and each
//!    harmonic that carries no hum less than [`EMPTY_SHARE`] of the
//!    150 Hz line;
//! 3. removed: the run judged as the default one ([`crate::rig_report::judge`]:
//!    ω, ζ within 1e-3 of the truth, counters, tuning, no overrun).
//!
//! The sample interrupt's cost with the remover on (`instructions_per_sample:
//! … isr=`) is printed. `--hum --no-remover` makes the same run with only
//! the refused command sent (the remover stays off): a measurement, not
//! judged, of what the hum does to the estimate and of the interrupt's
//! cost without the remover; the difference of the two `isr=` figures is
//! the remover's (BENCHMARKS.md, "The line remover's cost").

use std::io::{self, Write};
use std::net::TcpStream;
use std::path::Path;
use std::time::Duration;

use beam_protocol::{
    encode, AckResult, Command, Decoder, Frame, LineRemoval, Message, RejectReason, MAX_ENCODED_LEN,
};
use beamest::bench::HUM;

use crate::emulator::{session_with, LinkHost};

/// Simulated run length (s).
pub const SECONDS: &str = "8";
/// The remover the host selects.
pub const REMOVER: LineRemoval = LineRemoval {
    mains_hz: 50.0,
    harmonics: 7,
    time_constant_s: LineRemoval::DEFAULT_TIME_CONSTANT_S,
};
/// A found line's amplitude within this relative error of the injected one.
/// The weights' amplitude at the end is an instantaneous reading: the
/// bench's 7 Hz square wave has a harmonic at 49 Hz, 1 Hz from the 50 Hz
/// line and inside the notch's skirt (about 1.6 Hz wide at τ = 0.2 s),
/// whose response beats in the weights (measured: the 50 Hz line read 10%
/// low, the 150 Hz one 5%).
pub const FOUND_TOLERANCE: f64 = 0.25;
/// A harmonic without hum holds less than this share of the 150 Hz line.
pub const EMPTY_SHARE: f64 = 0.5;

struct Host {
    dec: Decoder,
    seq: u32,
    sent: bool,
    /// Whether the remover is selected (else only the refused command).
    remover: bool,
    /// Whether the remover's command went (after the boot self-test, which
    /// refuses commands as Busy while it runs).
    remover_sent: bool,
    acks: Vec<(u32, AckResult)>,
    failures: Vec<String>,
}

impl Host {
    fn send(&mut self, link: &mut TcpStream, c: Command) -> io::Result<u32> {
        let mut out = [0u8; MAX_ENCODED_LEN];
        let n = encode(&c, self.seq, &mut out)
            .map_err(|e| io::Error::other(format!("encoding {c:?}: {e}")))?;
        self.seq += 1;
        link.write_all(&out[..n])?;
        Ok(self.seq - 1)
    }
}

impl LinkHost for Host {
    fn receive(&mut self, bytes: &[u8], link: &mut TcpStream) -> io::Result<()> {
        if !self.sent {
            self.sent = true;
            let bad = LineRemoval {
                harmonics: 0,
                ..REMOVER
            };
            // Refused by its own check, which comes before Busy.
            self.send(link, Command::SetLineRemoval(bad))?;
        }
        let frames: Vec<Frame> = self.dec.feed(bytes).flatten().collect();
        for f in frames {
            match f.message {
                Message::Ack(a) => self.acks.push((a.command_seq, a.result)),
                // The boot self-test has ended: the device takes commands.
                Message::SelfTestReport(_) if self.remover && !self.remover_sent => {
                    self.remover_sent = true;
                    self.send(link, Command::SetLineRemoval(REMOVER))?;
                }
                _ => {}
            }
        }
        Ok(())
    }

    fn fail(&mut self, msg: String) {
        eprintln!("hum: FAIL: {msg}");
        self.failures.push(msg);
    }
}

/// The `--hum` run (module docs); `remover` false: `--no-remover`.
pub fn run(elf: &Path, timeout: Duration, remover: bool) -> Result<(), String> {
    let mut host = Host {
        dec: Decoder::new(),
        seq: 0,
        sent: false,
        remover,
        remover_sent: false,
        acks: Vec::new(),
        failures: Vec::new(),
    };
    let (status, _wall, log) = session_with(elf, Some(SECONDS), &["hum=1"], timeout, &mut host)?;
    if !remover {
        return measure_without(&mut host, status, &log);
    }
    let pass = |what: String| println!("hum: ok: {what}");
    let ack = |seq: u32| host.acks.iter().find(|a| a.0 == seq).map(|a| a.1);
    match (ack(0), ack(1)) {
        (Some(AckResult::Rejected(RejectReason::LineRemoval)), Some(AckResult::Accepted)) => pass(
            "SetLineRemoval with 0 harmonics refused (LineRemoval); 50 Hz, 7 harmonics, tau 0.2 s \
             accepted"
                .into(),
        ),
        other => host.fail(format!(
            "acknowledgements {other:?}, expected (Rejected(LineRemoval), Accepted)"
        )),
    }
    let c = *host.dec.counters();
    if c.errors() != 0 || c.lost != 0 {
        host.fail(format!("the link is not clean: {c:?}"));
    }
    match crate::rig_report::judge_hum(&log, &HUM, FOUND_TOLERANCE, EMPTY_SHARE) {
        Ok(found) => pass(found),
        Err(f) => host.fail(f),
    }
    crate::emulator::judge_firmware(&mut host, &log, status);
    crate::emulator::verdict("hum", "line remover test", &host.failures)
}

/// `--hum --no-remover`: the run printed as the default one is
/// ([`crate::rig_report::judge`], its verdict on the estimate not taken:
/// a measurement); fails only when the run itself did not work (the
/// refused command not refused, the remover on at the end, a dirty link,
/// the firmware's failure).
fn measure_without(
    host: &mut Host,
    status: std::process::ExitStatus,
    log: &str,
) -> Result<(), String> {
    let acks = host.acks.clone();
    if acks.as_slice() != [(0, AckResult::Rejected(RejectReason::LineRemoval))] {
        host.fail(format!(
            "acknowledgements {acks:?}, expected only (0, Rejected(LineRemoval))"
        ));
    }
    let c = *host.dec.counters();
    if c.errors() != 0 || c.lost != 0 {
        host.fail(format!("the link is not clean: {c:?}"));
    }
    if !log
        .lines()
        .any(|l| l.trim_start().starts_with("rig: lines n=0"))
    {
        host.fail("the log has no `rig: lines n=0`: the remover was not off".into());
    }
    if !status.success() {
        host.fail(format!("the firmware failed ({status})"));
    }
    let verdict = crate::rig_report::judge(log);
    println!(
        "hum (no remover): measured, not judged: the estimate {} within the default run's \
         tolerance",
        if verdict.is_ok() { "is" } else { "is not" }
    );
    if host.failures.is_empty() {
        Ok(())
    } else {
        Err(format!(
            "the run without the line remover did not work:\n  {}",
            host.failures.join("\n  ")
        ))
    }
}
