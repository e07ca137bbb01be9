//! QEMU `mps2-an386` running an image for `cargo xtask qemu`: its command
//! line (UART0 on a file or a loopback socket, `-icount shift=0,sleep=off`
//! so instruction counts and the 10 kHz timer are deterministic,
//! semihosting for the firmware's log, exit status and run length), the
//! wait with a wall-clock limit, and a session with a host on UART0's
//! socket ([`crate::e2e`], [`crate::e2e_robust`]).

use std::io::{self, Read};
use std::net::{TcpListener, TcpStream};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, ExitStatus, Stdio};
use std::sync::mpsc;
use std::thread;
use std::time::{Duration, Instant};

use crate::{stream, QEMU};

/// Where UART0 goes.
pub enum Serial {
    /// A file (the plain run).
    File(PathBuf),
    /// QEMU connects to a host listener on this port (the end-to-end test).
    Connect(u16),
    /// QEMU listens on this port and waits for one client before starting
    /// the CPU (`beamctl monitor`).
    Listen(u16),
}

/// The QEMU command line for `elf` with UART0 on `serial`, running
/// `seconds` of simulated time (the firmware's default 5 s if `None`),
/// with the firmware's other command-line words `args` (e.g.
/// `selftest_fault=noise`).
pub fn command(elf: &Path, serial: &Serial, seconds: Option<&str>, args: &[&str]) -> Command {
    let mut semihosting = String::from("enable=on,target=native,arg=qemu-rig");
    if let Some(s) = seconds {
        semihosting.push_str(",arg=seconds=");
        semihosting.push_str(s);
    }
    for a in args {
        semihosting.push_str(",arg=");
        semihosting.push_str(a);
    }
    let serial = match serial {
        Serial::File(p) => format!("file:{}", p.display()),
        Serial::Connect(port) => format!("tcp:127.0.0.1:{port},nodelay=on"),
        Serial::Listen(port) => format!("tcp:127.0.0.1:{port},server=on,wait=on,nodelay=on"),
    };
    let mut cmd = Command::new(QEMU);
    cmd.args(["-machine", "mps2-an386", "-cpu", "cortex-m4", "-nographic"])
        .args(["-monitor", "none"])
        .arg("-semihosting-config")
        .arg(semihosting)
        .args(["-icount", "shift=0,sleep=off"])
        .arg("-serial")
        .arg(serial)
        .arg("-kernel")
        .arg(elf)
        .stdin(Stdio::null());
    cmd
}

/// Wait for `child` up to `timeout`; kill it after that.
pub fn wait(
    child: &mut Child,
    timeout: Duration,
    start: Instant,
) -> Result<std::process::ExitStatus, String> {
    loop {
        if let Some(status) = child.try_wait().map_err(|e| e.to_string())? {
            return Ok(status);
        }
        if start.elapsed() > timeout {
            let _ = child.kill();
            let _ = child.wait();
            return Err(format!(
                "{QEMU} still running after {} s: killed",
                timeout.as_secs()
            ));
        }
        thread::sleep(Duration::from_millis(20));
    }
}

/// A host end of the link test: fed every byte read from UART0's socket
/// (and an empty slice when a read times out, so it can send on time).
pub(crate) trait LinkHost {
    /// Decode `bytes`, answer on `link`.
    fn receive(&mut self, bytes: &[u8], link: &mut TcpStream) -> io::Result<()>;
    /// Record a failed check.
    fn fail(&mut self, msg: String);
}

/// The checks every link run ends with: the firmware's own measurements
/// ([`crate::rig_report::judge`] of its `rig:` lines) and its exit status,
/// each failure recorded through `host`.
pub(crate) fn judge_firmware(host: &mut impl LinkHost, log: &str, status: ExitStatus) {
    if let Err(failures) = crate::rig_report::judge(log) {
        for f in failures {
            host.fail(format!("the run (firmware's measurements): {f}"));
        }
    }
    if !status.success() {
        host.fail(format!("the firmware failed ({status})"));
    }
}

/// A link run's verdict from the failures its host recorded: `tag: PASS`
/// printed, or an error naming `test` with every failure.
pub(crate) fn verdict(tag: &str, test: &str, failures: &[String]) -> Result<(), String> {
    if failures.is_empty() {
        println!("{tag}: PASS");
        Ok(())
    } else {
        Err(format!("{test} failed:\n  {}", failures.join("\n  ")))
    }
}

/// Boot the firmware in QEMU with UART0 connected to a loopback socket,
/// pump UART0's bytes through `host` until QEMU exits (or `timeout`), and
/// return QEMU's exit status, the wall time (s) and the firmware's log
/// (semihosting: QEMU's stdout).
pub(crate) fn session(
    elf: &Path,
    seconds: Option<&str>,
    timeout: Duration,
    host: &mut impl LinkHost,
) -> Result<(std::process::ExitStatus, f64, String), String> {
    session_with(elf, seconds, &[], timeout, host)
}

/// [`session`] with more words on the firmware's command line.
pub(crate) fn session_with(
    elf: &Path,
    seconds: Option<&str>,
    words: &[&str],
    timeout: Duration,
    host: &mut impl LinkHost,
) -> Result<(std::process::ExitStatus, f64, String), String> {
    let listener =
        TcpListener::bind("127.0.0.1:0").map_err(|e| format!("listening on loopback: {e}"))?;
    let port = listener
        .local_addr()
        .map_err(|e| format!("listening on loopback: {e}"))?
        .port();
    let mut cmd = command(elf, &Serial::Connect(port), seconds, words);
    cmd.stdout(Stdio::piped()).stderr(Stdio::piped());
    println!("running: {cmd:?}");
    let start = Instant::now();
    let mut child = cmd.spawn().map_err(|e| format!("starting {QEMU}: {e}"))?;
    let out = child.stdout.take().map(|s| stream(s, io::stdout()));
    let err = child.stderr.take().map(|s| stream(s, io::stderr()));
    // QEMU connects while it starts; give up if it exits first.
    let (tx, rx) = mpsc::channel();
    thread::spawn(move || {
        let _ = tx.send(listener.accept());
    });
    let mut link = loop {
        if let Ok(r) = rx.recv_timeout(Duration::from_millis(50)) {
            break r
                .map_err(|e| format!("accepting QEMU's connection: {e}"))?
                .0;
        }
        if let Some(s) = child.try_wait().map_err(|e| e.to_string())? {
            return Err(format!(
                "{QEMU} exited ({s}) before connecting to UART0's socket"
            ));
        }
        if start.elapsed() > Duration::from_secs(30) {
            let _ = child.kill();
            return Err(format!(
                "{QEMU} did not connect to UART0's socket within 30 s"
            ));
        }
    };
    println!("UART0 connected on 127.0.0.1:{port}");
    link.set_read_timeout(Some(Duration::from_millis(50)))
        .map_err(|e| e.to_string())?;
    link.set_nodelay(true).map_err(|e| e.to_string())?;
    let mut writer = link.try_clone().map_err(|e| e.to_string())?;
    let mut buf = [0u8; 4096];
    loop {
        match link.read(&mut buf) {
            Ok(0) => break, // QEMU exited: the socket closed.
            Ok(n) => host
                .receive(&buf[..n], &mut writer)
                .map_err(|e| format!("writing a command: {e}"))?,
            Err(e)
                if matches!(
                    e.kind(),
                    io::ErrorKind::WouldBlock | io::ErrorKind::TimedOut
                ) =>
            {
                host.receive(&[], &mut writer)
                    .map_err(|e| format!("writing a command: {e}"))?;
            }
            // QEMU exited with bytes of ours unread: the checks say which
            // commands went unanswered.
            Err(e) if e.kind() == io::ErrorKind::ConnectionReset => {
                host.fail("QEMU exited with host bytes unread on UART0 (connection reset)".into());
                break;
            }
            Err(e) => return Err(format!("reading UART0's socket: {e}")),
        }
        if start.elapsed() > timeout {
            break;
        }
    }
    let status = wait(&mut child, timeout, start)?;
    let log = out.and_then(|t| t.join().ok()).unwrap_or_default();
    if let Some(t) = err {
        let _ = t.join();
    }
    let log = String::from_utf8_lossy(&log).into_owned();
    Ok((status, start.elapsed().as_secs_f64(), log))
}
