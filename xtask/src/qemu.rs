//! `cargo xtask qemu`: the QEMU image in `qemu-system-arm -machine
//! mps2-an386`, with UART0 (the serial link, `docs/PROTOCOL.md`) on a file,
//! on a loopback socket to the end-to-end test ([`crate::e2e`]), or on a
//! loopback socket with `beamctl monitor` attached.
//!
//! QEMU's options: `-icount shift=0,sleep=off` (one instruction per
//! nanosecond of virtual time: the firmware's instruction counts and its
//! 10 kHz timer are deterministic), semihosting for the firmware's log and
//! exit status, and the run length as a semihosting argument
//! (`seconds=S`, read by the firmware at boot).

use std::fs::{self, File};
use std::io::{self, BufRead, BufReader, Read};
use std::net::TcpListener;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::thread;
use std::time::{Duration, Instant};

use crate::emulator::{command, wait, Serial};
use crate::{
    build, e2e, e2e_hum, e2e_robust, hostile, require_tool, rig_report, selftest_faults, stream,
    workspace_root, IMAGES, QEMU, QEMU_IMAGE,
};

/// Default wall-clock limit for one emulated run, s.
const TIMEOUT_S: u64 = 300;
/// Default simulated run length of `--monitor`, s.
const MONITOR_SECONDS: &str = "60";

/// Options of `cargo xtask qemu`.
struct Options {
    timeout: Duration,
    uart0: PathBuf,
    seconds: Option<String>,
    e2e: bool,
    robust: bool,
    hum: bool,
    no_remover: bool,
    selftest_faults: bool,
    hostile: bool,
    soak: bool,
    monitor: bool,
    beamctl: Option<PathBuf>,
    monitor_args: Vec<String>,
}

fn parse(args: &[String]) -> Result<Options, String> {
    let mut o = Options {
        timeout: Duration::from_secs(TIMEOUT_S),
        uart0: workspace_root().join("target/qemu/uart0.bin"),
        seconds: None,
        e2e: false,
        robust: false,
        hum: false,
        no_remover: false,
        selftest_faults: false,
        hostile: false,
        soak: false,
        monitor: false,
        beamctl: None,
        monitor_args: Vec::new(),
    };
    let mut it = args.iter();
    while let Some(a) = it.next() {
        match a.as_str() {
            "--timeout" => {
                let v = it.next().ok_or("--timeout needs seconds")?;
                let s: u64 = v
                    .parse()
                    .map_err(|_| format!("--timeout: bad number `{v}`"))?;
                o.timeout = Duration::from_secs(s);
            }
            "--uart0" => o.uart0 = PathBuf::from(it.next().ok_or("--uart0 needs a path")?),
            "--seconds" => {
                let v = it.next().ok_or("--seconds needs a number")?;
                let ok = !v.is_empty()
                    && v.chars().all(|c| c.is_ascii_digit() || c == '.')
                    && v.matches('.').count() <= 1
                    && v != ".";
                if !ok {
                    return Err(format!(
                        "--seconds: `{v}` is not a number of seconds (e.g. 60 or 2.5)"
                    ));
                }
                o.seconds = Some(v.clone());
            }
            "--e2e" => o.e2e = true,
            "--robust" => o.robust = true,
            "--hum" => o.hum = true,
            "--no-remover" => o.no_remover = true,
            "--selftest-faults" => o.selftest_faults = true,
            "--hostile" => o.hostile = true,
            "--monitor" => o.monitor = true,
            "--beamctl" => {
                o.beamctl = Some(PathBuf::from(it.next().ok_or("--beamctl needs a path")?))
            }
            "--" => {
                o.monitor_args = it.by_ref().cloned().collect();
            }
            other => {
                return Err(format!(
                    "qemu: unknown option `{other}`\n\n{}",
                    crate::USAGE
                ))
            }
        }
    }
    if o.robust && (o.e2e || o.monitor || o.seconds.is_some()) {
        return Err("qemu --robust runs alone (its own 27 s run on the link)".into());
    }
    if o.hum
        && (o.robust || o.e2e || o.monitor || o.hostile || o.selftest_faults || o.seconds.is_some())
    {
        return Err("qemu --hum runs alone (its own 8 s run on the link)".into());
    }
    if o.no_remover && !o.hum {
        return Err("qemu: --no-remover needs --hum".into());
    }
    if (o.hostile || o.soak) && (o.e2e || o.monitor || o.robust || o.selftest_faults) {
        return Err("qemu --hostile (and soak) run alone".into());
    }
    if o.selftest_faults && (o.e2e || o.monitor || o.robust || o.seconds.is_some()) {
        return Err("qemu --selftest-faults runs alone (1 s per fault)".into());
    }
    if o.e2e && o.monitor {
        return Err("qemu: --e2e and --monitor exclude each other".into());
    }
    if o.e2e && o.seconds.is_some() {
        return Err("qemu --e2e runs the default 5 s; --seconds does not apply".into());
    }
    if !o.monitor && (o.beamctl.is_some() || !o.monitor_args.is_empty()) {
        return Err("qemu: --beamctl and `-- MONITOR-ARGS` need --monitor".into());
    }
    Ok(o)
}

/// `cargo xtask soak [--seconds S] [--timeout S]`: the hostile run with
/// the soak's periodic commands ([`hostile`]), 600 simulated s by default.
pub fn soak(args: &[String]) -> Result<(), String> {
    let mut o = parse(args)?;
    o.soak = true;
    // Ten simulated minutes take about ten on this machine.
    o.timeout = o.timeout.max(Duration::from_secs(3_600));
    run_options(o)
}

/// `cargo xtask qemu …`: every mode that ends a run judges it from the
/// firmware's log ([`rig_report::judge`]).
pub fn run(args: &[String]) -> Result<(), String> {
    run_options(parse(args)?)
}

fn run_options(o: Options) -> Result<(), String> {
    require_tool(
        QEMU,
        &["--version"],
        "qemu-system-arm is not installed (Debian/Ubuntu: apt-get install qemu-system-arm)",
    )?;
    // Every mode runs the one QEMU image (the robust estimator is one of
    // its estimators).
    let image = IMAGES
        .iter()
        .find(|i| i.bin == QEMU_IMAGE)
        .ok_or("no QEMU image in the image table")?;
    let elf = build(image)?;
    if o.robust {
        e2e_robust::run(&elf, o.timeout)
    } else if o.hum {
        e2e_hum::run(&elf, o.timeout, !o.no_remover)
    } else if o.selftest_faults {
        selftest_faults::run(&elf, o.timeout)
    } else if o.hostile || o.soak {
        let default = if o.soak { 600 } else { 60 };
        let seconds = match &o.seconds {
            Some(s) => s
                .parse::<u64>()
                .map_err(|_| format!("--seconds {s}: whole seconds for --hostile and soak"))?,
            None => default,
        };
        let opts = hostile::Options {
            seconds,
            schedule: o.soak,
            seed: 18,
        };
        hostile::run(&elf, opts, o.timeout)
    } else if o.e2e {
        e2e::run(&elf, o.timeout)
    } else if o.monitor {
        monitor(&elf, &o)
    } else {
        plain(&elf, &o)
    }
}

/// The plain run: UART0 to a file, decoded and checked afterwards.
fn plain(elf: &Path, o: &Options) -> Result<(), String> {
    if let Some(dir) = o.uart0.parent() {
        fs::create_dir_all(dir).map_err(|e| format!("creating {}: {e}", dir.display()))?;
    }
    let mut cmd = command(
        elf,
        &Serial::File(o.uart0.clone()),
        o.seconds.as_deref(),
        &[],
    );
    cmd.stdout(Stdio::piped()).stderr(Stdio::piped());
    println!("running: {cmd:?}");
    println!("UART0 → {}", o.uart0.display());
    let start = Instant::now();
    let mut child = cmd.spawn().map_err(|e| format!("starting {QEMU}: {e}"))?;
    let out = child.stdout.take().map(|s| stream(s, io::stdout()));
    let err = child.stderr.take().map(|s| stream(s, io::stderr()));
    let status = wait(&mut child, o.timeout, start)?;
    let log = out.and_then(|t| t.join().ok()).unwrap_or_default();
    if let Some(t) = err {
        let _ = t.join();
    }
    println!(
        "{QEMU} exited with {status} after {:.2} s wall time",
        start.elapsed().as_secs_f64()
    );
    let verdict = rig_report::judge(&String::from_utf8_lossy(&log));
    let bytes = fs::read(&o.uart0).map_err(|e| format!("reading {}: {e}", o.uart0.display()))?;
    let link = e2e::decode_capture(&bytes);
    println!("UART0: {}", link.summary());
    // The estimates that arrive before any Status names λ (the estimator
    // starts at 0.2 s, the first Status with λ rides the 1 s record) must
    // be among those checked from their own Θ̂ and λ: else the check of
    // PROTOCOL.md §4.0 on them tested nothing.
    // The self-test at start-up reached the host, every check passed.
    let boot_report_ok = matches!(link.reports.as_slice(), [r] if r.at_boot && r.passed());
    println!(
        "UART0: self-test reports {} ({})",
        link.reports.len(),
        if boot_report_ok {
            "one, at start-up, every check passed"
        } else {
            "expected one, at start-up, every check passed"
        }
    );
    let link_ok = link.is_clean()
        && link.tally.estimates > 0
        && link.tally.status > 0
        && link.tally.with_modes_before_lambda_status > 0
        && boot_report_ok;
    match (status.success(), verdict, link_ok) {
        (true, Ok(()), true) => Ok(()),
        (false, _, _) => Err(format!("the emulated firmware failed ({status})")),
        (true, Err(f), _) => Err(format!("the emulated run failed: {}", f.join("; "))),
        (true, Ok(()), false) => Err(format!(
            "UART0's frames are not a clean protocol stream: {}",
            link.summary()
        )),
    }
}

/// A free loopback port (bound, read, released; QEMU takes it next).
fn free_port() -> Result<u16, String> {
    let l = TcpListener::bind("127.0.0.1:0").map_err(|e| format!("finding a free port: {e}"))?;
    l.local_addr()
        .map(|a| a.port())
        .map_err(|e| format!("finding a free port: {e}"))
}

/// `--monitor`: QEMU listens on a loopback port and waits; once it says so
/// on stderr, `beamctl monitor --tcp` connects and the CPU starts. The
/// firmware's semihosting log goes to a file (the monitor owns the
/// terminal); its last lines are printed when the run ends.
fn monitor(elf: &Path, o: &Options) -> Result<(), String> {
    let root = workspace_root();
    let log_path = root.join("target/qemu/semihosting.log");
    if let Some(dir) = log_path.parent() {
        fs::create_dir_all(dir).map_err(|e| format!("creating {}: {e}", dir.display()))?;
    }
    // Build the monitor first, so the emulated clock does not wait for it.
    let mut monitor_cmd = match &o.beamctl {
        Some(path) => Command::new(path),
        None => {
            let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
            let status = Command::new(&cargo)
                .current_dir(&root)
                .args(["build", "--release", "-p", "beamctl"])
                .status()
                .map_err(|e| format!("running cargo: {e}"))?;
            if !status.success() {
                return Err(format!("building beamctl failed ({status})"));
            }
            let mut c = Command::new(cargo);
            c.current_dir(&root)
                .args(["run", "--quiet", "--release", "-p", "beamctl", "--"]);
            c
        }
    };
    let port = free_port()?;
    let seconds = o.seconds.as_deref().unwrap_or(MONITOR_SECONDS);
    let mut qemu = command(elf, &Serial::Listen(port), Some(seconds), &[]);
    let log =
        File::create(&log_path).map_err(|e| format!("creating {}: {e}", log_path.display()))?;
    qemu.stdout(Stdio::from(log)).stderr(Stdio::piped());
    let start = Instant::now();
    let mut child = qemu.spawn().map_err(|e| format!("starting {QEMU}: {e}"))?;
    // QEMU announces the listening socket on stderr before it waits.
    let stderr = child.stderr.take().ok_or("no stderr from QEMU")?;
    let mut lines = BufReader::new(stderr);
    let mut line = String::new();
    loop {
        line.clear();
        let n = lines
            .read_line(&mut line)
            .map_err(|e| format!("reading QEMU's stderr: {e}"))?;
        if n == 0 {
            let status = child.wait().map_err(|e| e.to_string())?;
            return Err(format!(
                "{QEMU} exited before listening on port {port} ({status})"
            ));
        }
        if line.contains("waiting for connection") {
            break;
        }
        eprint!("{line}");
    }
    // Pass the rest of QEMU's stderr through.
    let err = thread::spawn(move || {
        let mut rest = String::new();
        let _ = lines.read_to_string(&mut rest);
        eprint!("{rest}");
    });
    let addr = format!("127.0.0.1:{port}");
    monitor_cmd
        .args(["monitor", "--tcp", &addr])
        .args(&o.monitor_args);
    println!(
        "emulated rig: {seconds} simulated s{}, UART0 on {addr}; firmware log → {}",
        if seconds == "0" {
            " (until the monitor quits)"
        } else {
            ""
        },
        log_path.display()
    );
    println!("running: {monitor_cmd:?}");
    let monitor_status = monitor_cmd
        .status()
        .map_err(|e| format!("starting beamctl monitor: {e}"))?;
    // The monitor is done: the emulation ends on its own (its run length),
    // or now if the user quit first.
    let qemu_status = match child.try_wait().map_err(|e| e.to_string())? {
        Some(s) => Some(s),
        None => {
            thread::sleep(Duration::from_millis(500));
            match child.try_wait().map_err(|e| e.to_string())? {
                Some(s) => Some(s),
                None => {
                    let _ = child.kill();
                    let _ = child.wait();
                    None
                }
            }
        }
    };
    let _ = err.join();
    let log_text = fs::read_to_string(&log_path).unwrap_or_default();
    let tail: Vec<&str> = log_text.lines().rev().take(12).collect();
    println!("\nfirmware log (last lines of {}):", log_path.display());
    for l in tail.iter().rev() {
        println!("  {l}");
    }
    println!(
        "beamctl monitor exited with {monitor_status}; {} after {:.1} s wall time",
        match qemu_status {
            Some(s) => format!("{QEMU} exited with {s}"),
            None => format!("{QEMU} stopped (the monitor quit first)"),
        },
        start.elapsed().as_secs_f64()
    );
    match qemu_status {
        // The run ended: the firmware's verdict. The monitor then saw the
        // device disappear, which it reports (non-zero) by design.
        Some(s) if s.success() => Ok(()),
        Some(s) => Err(format!("the emulated firmware failed ({s})")),
        None if monitor_status.success() => Ok(()),
        None => Err(format!("beamctl monitor failed ({monitor_status})")),
    }
}
