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
                for precision in ["f32", "f64"] {
                    let prefix = format!("fp_bench: {precision} omega=");
                    if let Err(e) = judge_estimate(&out, &prefix) {
                        println!("  FAIL: {precision}: {e}");
                        failures.push(format!("{}: {precision}: {e}", m.name));
                    }
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
    judge_estimate(&out, "robust_bench: omega=").map_err(|e| format!("robust-bench failed: {e}"))
}

/// Largest relative error of each ω and ζ the benches accept against the
/// paper's plant, which they simulate.
const TOLERANCE: f64 = 1e-3;

/// Judge the estimate a bench printed on the line starting with `prefix`
/// (`… omega=ω1,ω2 zeta=ζ1,ζ2`, or `omega=none`) against the paper's ω, ζ
/// (the only read of the simulated truth: the images print, xtask judges).
fn judge_estimate(out: &str, prefix: &str) -> Result<(), String> {
    let line = out
        .lines()
        .find(|l| l.starts_with(prefix))
        .ok_or_else(|| format!("no line `{prefix}…`"))?;
    let worst = estimate_error(&line[prefix.len() - "omega=".len()..])?;
    println!("  worst relative error of omega, zeta: {worst:.1e} (limit {TOLERANCE:.0e})");
    if worst <= TOLERANCE {
        Ok(())
    } else {
        Err(format!(
            "estimate off by {worst:.1e} (> {TOLERANCE:.0e}): {line}"
        ))
    }
}

/// The largest relative error of `omega=ω1,ω2 zeta=ζ1,ζ2` against the
/// paper's plant.
fn estimate_error(text: &str) -> Result<f64, String> {
    let field = |key: &str| -> Result<Vec<f64>, String> {
        let v = text
            .split_whitespace()
            .find_map(|w| w.strip_prefix(key))
            .ok_or_else(|| format!("no {key} in `{text}`"))?;
        if v == "none" {
            return Err("no estimate recovered".to_string());
        }
        v.split(',')
            .map(|x| x.parse::<f64>().map_err(|e| format!("{key}{x}: {e}")))
            .collect()
    };
    let omega = field("omega=")?;
    let zeta = field("zeta=")?;
    let truth = beamest::model::PAPER_OMEGA
        .iter()
        .chain(beamest::model::PAPER_ZETA.iter());
    if omega.len() != 2 || zeta.len() != 2 {
        return Err(format!("expected 2 modes in `{text}`"));
    }
    let errors: Vec<f64> = omega
        .iter()
        .chain(zeta.iter())
        .zip(truth)
        .map(|(e, t)| (e / t - 1.0).abs())
        .collect();
    if errors.iter().all(|r| r.is_finite()) {
        Ok(errors.into_iter().fold(0.0, f64::max))
    } else {
        Err(format!("non-finite estimate in `{text}`"))
    }
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_bench_estimate_is_judged_against_the_paper_plant() {
        let [w1, w2] = beamest::model::PAPER_OMEGA;
        let [z1, z2] = beamest::model::PAPER_ZETA;
        let line = |k: f64| {
            format!(
                "fp_bench: f32 omega={:.9e},{:.9e} zeta={:.9e},{:.9e}",
                w1,
                w2 * k,
                z1,
                z2
            )
        };
        assert!(judge_estimate(&line(1.0 + 5e-4), "fp_bench: f32 omega=").is_ok());
        assert!(judge_estimate(&line(1.0 + 2e-3), "fp_bench: f32 omega=").is_err());
        assert!(judge_estimate("fp_bench: f32 omega=none", "fp_bench: f32 omega=").is_err());
        assert!(judge_estimate("fp_bench: f64 omega=none", "fp_bench: f32 omega=").is_err());
        assert!(estimate_error("omega=NaN,1 zeta=1,1").is_err());
    }
}
