//! `cargo xtask qemu --selftest-faults`: the self-test against each of the
//! simulated bench's faults (`beamest::bench::BenchFault`). For each, the
//! QEMU image runs 1 simulated second with `selftest_fault=NAME` (the
//! fault injected after the converters' bring-up, before the self-test at
//! start-up), UART0 to a file; the run passes when the firmware's `rig:
//! selftest` line and the report decoded from UART0 both name exactly the
//! fault's check as failed (and, for DRDY missing, the loopback and the
//! noise as not measured: no conversion to measure them from), every
//! other check passing. The healthy case is the plain run's
//! ([`crate::rig_report`]: the report at start-up, every check passed).

use std::fs;
use std::io;
use std::path::Path;
use std::process::Stdio;
use std::time::{Duration, Instant};

use beamest::bench::BenchFault;

use crate::emulator::{command, wait, Serial};
use crate::{e2e, rig_report, stream, workspace_root, QEMU};

/// Run every fault (see the module doc).
pub fn run(elf: &Path, timeout: Duration) -> Result<(), String> {
    let dir = workspace_root().join("target/qemu");
    fs::create_dir_all(&dir).map_err(|e| format!("creating {}: {e}", dir.display()))?;
    let mut failures = Vec::new();
    let start = Instant::now();
    for (fault, name) in BenchFault::ALL {
        let uart0 = dir.join(format!("selftest-{name}.bin"));
        let arg = format!("selftest_fault={name}");
        let mut cmd = command(elf, &Serial::File(uart0.clone()), Some("1"), &[&arg]);
        cmd.stdout(Stdio::piped()).stderr(Stdio::piped());
        let t0 = Instant::now();
        let mut child = cmd.spawn().map_err(|e| format!("starting {QEMU}: {e}"))?;
        let out = child.stdout.take().map(|s| stream(s, io::sink()));
        let err = child.stderr.take().map(|s| stream(s, io::stderr()));
        let status = wait(&mut child, timeout, t0)?;
        let log = out.and_then(|t| t.join().ok()).unwrap_or_default();
        if let Some(t) = err {
            let _ = t.join();
        }
        let log = String::from_utf8_lossy(&log);
        let (failed, not_measured) = fault.expected();
        let mut verdict = Vec::new();
        if !status.success() {
            verdict.push(format!("the firmware failed ({status})"));
        }
        if let Err(e) = rig_report::judge_self_test_fault(&log, name, failed.0, not_measured.0) {
            verdict.push(e);
        }
        let bytes = fs::read(&uart0).map_err(|e| format!("reading {}: {e}", uart0.display()))?;
        let capture = e2e::decode_capture(&bytes);
        match capture.reports.as_slice() {
            [r] if r.at_boot && r.failed == failed && r.not_measured == not_measured => {}
            reports => verdict.push(format!(
                "UART0: {} report(s) {:?}, expected one at start-up with failed {:#06x}, not \
                 measured {:#06x}",
                reports.len(),
                reports
                    .iter()
                    .map(|r| (r.failed.0, r.not_measured.0))
                    .collect::<Vec<_>>(),
                failed.0,
                not_measured.0
            )),
        }
        if !capture.is_clean() {
            verdict.push(format!("UART0 not clean: {}", capture.summary()));
        }
        let line = log
            .lines()
            .find(|l| l.starts_with("self-test ("))
            .unwrap_or("(no self-test line)");
        if verdict.is_empty() {
            println!(
                "selftest-faults: ok: {name} ({fault:?}): failed {:#06x}, not measured {:#06x} \
                 ({:.1} s wall)\n  {line}",
                failed.0,
                not_measured.0,
                t0.elapsed().as_secs_f64()
            );
        } else {
            println!(
                "selftest-faults: FAIL: {name}: {}\n  {line}",
                verdict.join("; ")
            );
            failures.push(format!("{name}: {}", verdict.join("; ")));
        }
    }
    println!(
        "selftest-faults: {} faults in {:.1} s wall time",
        BenchFault::ALL.len(),
        start.elapsed().as_secs_f64()
    );
    if failures.is_empty() {
        println!("selftest-faults: PASS");
        Ok(())
    } else {
        Err(format!("self-test faults:\n  {}", failures.join("\n  ")))
    }
}
