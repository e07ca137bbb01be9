//! Cortex-M7 tasks: flash the reference board, and measure what `f32` and
//! `f64` cost on a single-precision and a double-precision FPU.

use std::io::Read;
use std::path::Path;
use std::process::{Command, Stdio};
use std::thread;
use std::time::{Duration, Instant};

use crate::{build_bin, check, require_tool, workspace_root, Cpu, IMAGES, QEMU};

/// The reference board's firmware binary.
pub const NUCLEO_IMAGE: &str = "nucleo-rig";
/// probe-rs's name for the NUCLEO-H743ZI2's MCU (as in the runner of
/// `.cargo/config.toml`).
const PROBE_CHIP: &str = "STM32H743ZITx";
/// The f32/f64 bench binary.
const FP_BENCH: &str = "fp-bench";
/// The robust estimator's bench binary.
const ROBUST_BENCH: &str = "robust-bench";
/// Wall-clock limit for one emulated bench run, s.
const FP_BENCH_TIMEOUT_S: u64 = 300;

/// `cargo xtask flash`: build and check the NUCLEO image, then hand it to
/// `probe-rs run` (flash, reset, stream the defmt log until Ctrl-C).
pub fn flash() -> Result<(), String> {
    let image = IMAGES
        .iter()
        .find(|i| i.bin == NUCLEO_IMAGE)
        .ok_or("no NUCLEO image in the image table")?;
    let elf = crate::build(image)?;
    println!("\n{} — {} ({})", image.bin, image.board, elf.display());
    check(image, &workspace_root(), &elf)?;
    require_tool(
        "probe-rs",
        &["--version"],
        "probe-rs is not installed (docs/RIG.md, one-time tools):\n  \
         cargo install probe-rs-tools --locked",
    )?;
    let status = Command::new("probe-rs")
        .args(["run", "--chip", PROBE_CHIP])
        .arg(&elf)
        .status()
        .map_err(|e| format!("running probe-rs: {e}"))?;
    if status.success() {
        Ok(())
    } else {
        Err(format!("probe-rs run ended with {status}"))
    }
}

/// One emulated machine for the bench.
struct Machine {
    name: &'static str,
    qemu_cpu: &'static str,
    build: Cpu,
    about: &'static str,
}

const MACHINES: [Machine; 2] = [
    Machine {
        name: "mps2-an386",
        qemu_cpu: "cortex-m4",
        build: Cpu::Generic,
        about: "Cortex-M4F, single-precision FPU (f64 in software)",
    },
    Machine {
        name: "mps2-an500",
        qemu_cpu: "cortex-m7",
        build: Cpu::CortexM7,
        about: "Cortex-M7, -C target-cpu=cortex-m7 (FPv5-D16, f64 in hardware)",
    },
];

/// `cargo xtask fp-bench`: build the bench for each core, run it in QEMU
/// with deterministic instruction counting, print its figures.
pub fn fp_bench() -> Result<(), String> {
    require_tool(
        QEMU,
        &["--version"],
        "qemu-system-arm is not installed (Debian/Ubuntu: apt-get install qemu-system-arm)",
    )?;
    let mut failures = Vec::new();
    for m in &MACHINES {
        let elf = build_bin("board-qemu", FP_BENCH, m.build)?;
        println!("\n{FP_BENCH} on {} — {}", m.name, m.about);
        match run_qemu(m, &elf) {
            Ok(out) => {
                for line in out.lines().filter(|l| l.starts_with("fp_bench:")) {
                    println!("  {line}");
                }
            }
            Err(e) => {
                println!("  FAIL: {e}");
                failures.push(format!("{}: {e}", m.name));
            }
        }
    }
    if failures.is_empty() {
        Ok(())
    } else {
        Err(format!("fp-bench failed:\n  {}", failures.join("\n  ")))
    }
}

/// `cargo xtask robust-bench`: the robust estimator's costs on the
/// Cortex-M4F (`src/bin/robust-bench/`), its `robust_bench:` lines.
pub fn robust_bench() -> Result<(), String> {
    require_tool(
        QEMU,
        &["--version"],
        "qemu-system-arm is not installed (Debian/Ubuntu: apt-get install qemu-system-arm)",
    )?;
    let m = MACHINES.first().ok_or("no machine")?;
    let elf = build_bin("board-qemu", ROBUST_BENCH, m.build)?;
    println!(
        "
{ROBUST_BENCH} on {} — {}",
        m.name, m.about
    );
    let out = run_qemu(m, &elf).map_err(|e| format!("robust-bench failed: {e}"))?;
    for line in out.lines().filter(|l| l.starts_with("robust_bench:")) {
        println!("  {line}");
    }
    Ok(())
}

/// Run `elf` on machine `m` to its semihosting exit; its stdout, or why
/// it failed (non-zero exit, time-out).
fn run_qemu(m: &Machine, elf: &Path) -> Result<String, String> {
    let mut child = Command::new(QEMU)
        .args(["-machine", m.name, "-cpu", m.qemu_cpu, "-nographic"])
        .args(["-monitor", "none", "-serial", "null"])
        .args(["-semihosting-config", "enable=on,target=native"])
        .args(["-icount", "shift=0,sleep=off"])
        .arg("-kernel")
        .arg(elf)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::inherit())
        .spawn()
        .map_err(|e| format!("starting {QEMU}: {e}"))?;
    let mut stdout = child.stdout.take().ok_or("no stdout pipe")?;
    let reader = thread::spawn(move || {
        let mut s = String::new();
        let _ = stdout.read_to_string(&mut s);
        s
    });
    let start = Instant::now();
    let status = loop {
        if let Some(status) = child.try_wait().map_err(|e| e.to_string())? {
            break status;
        }
        if start.elapsed() > Duration::from_secs(FP_BENCH_TIMEOUT_S) {
            let _ = child.kill();
            let _ = child.wait();
            return Err(format!(
                "still running after {FP_BENCH_TIMEOUT_S} s: killed"
            ));
        }
        thread::sleep(Duration::from_millis(20));
    };
    let out = reader.join().map_err(|_| "reader thread panicked")?;
    if status.success() {
        Ok(out)
    } else {
        Err(format!("exited with {status}:\n{out}"))
    }
}
