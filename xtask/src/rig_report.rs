//! The verdict on a run of the QEMU image, from its semihosting log: the
//! firmware measures and prints (`rig:` lines, their format in the image's
//! `src/bin/qemu-rig/report.rs`), this module judges. Used by every
//! `cargo xtask qemu` mode that ends a run ([`crate::qemu`], [`crate::e2e`],
//! [`crate::e2e_robust`]).
//!
//! The checks, with the adaptive law (the default run, `--e2e`):
//!
//! * ω1, ω2, ζ1, ζ2 of the final estimate within [`TOLERANCE`] of the
//!   simulated truth (`beamest::model::PAPER_OMEGA`, `PAPER_ZETA`), two
//!   modes recovered;
//! * the tuning rule judged without the truth: automatic, settled
//!   (converged) with λ within its re-centring threshold of the final
//!   estimate's band centre √(ω̂1·ω̂2), no start-up pair lost or refused
//!   (the truth's band centre is printed beside it for the reader only);
//! * the pipeline's counters equal to what the fault schedule must
//!   produce — every injected bad conversion counted once by kind and
//!   rejected (a stuck run of n repeats is n + 1 identical codes, all
//!   rejected), nothing else — for runs that outlast the schedule;
//! * no overrun, no rig error, an estimator started;
//! * the self-test at start-up (and every one commanded) reported, every
//!   check passed (`rig: selftest`, no bench fault injected).
//!
//! Runs with a bench fault (`cargo xtask qemu --selftest-faults`) are
//! judged by [`judge_self_test_fault`] instead: exactly the fault's check
//! failed.
//!
//! With the robust estimator (`--robust`): converged within
//! [`ROBUST_OMEGA_TOLERANCE`] / [`ROBUST_ZETA_TOLERANCE`], at least one
//! model update installed and none of their locks longer than
//! [`LOCK_BOUND`], no overrun, no rig error; the counters are printed, not
//! compared (the host switches the drive off from 0.5 s to 20.5 s, where
//! a repeated reading is the guard's quiet input, not a stuck run).

use std::collections::HashMap;

use beamest::bench;
use beamest::model::{PAPER_OMEGA, PAPER_ZETA};

/// Pass criterion: relative error of every ω and ζ after the default run.
pub const TOLERANCE: f64 = 1e-3;
/// Pass criterion on ω with the robust estimator (relative error): the
/// default run's. The estimator models the converters' timing
/// (`FilterConfig::timing`, as the adaptive law); on the host, the same
/// sequence ends within 8.3e-7 on ω and 1.0e-5 on ζ
/// (`host-tests/tests/robust_firmware_path.rs`).
pub const ROBUST_OMEGA_TOLERANCE: f64 = 1e-3;
/// Pass criterion on ζ with the robust estimator (relative error).
pub const ROBUST_ZETA_TOLERANCE: f64 = 1e-3;
/// Bound on any lock the robust estimator's model updates take
/// (instructions): one sample period (100 µs at one instruction per ns
/// under `-icount shift=0`), so a sample is at worst delayed, never lost.
pub const LOCK_BOUND: u64 = 100_000;

/// One `rig: <what> key=value …` line.
#[derive(Debug, Clone, Default)]
struct Line {
    what: String,
    values: HashMap<String, String>,
}

impl Line {
    fn parse(text: &str) -> Option<Self> {
        let rest = text.trim().strip_prefix("rig: ")?;
        let mut words = rest.split_whitespace();
        let what = words.next()?.to_string();
        let values = words
            .filter_map(|w| w.split_once('='))
            .map(|(k, v)| (k.to_string(), v.to_string()))
            .collect();
        Some(Line { what, values })
    }

    fn text(&self, key: &str) -> &str {
        self.values.get(key).map_or("", String::as_str)
    }

    /// A count (0 if absent or not a number).
    fn u64(&self, key: &str) -> u64 {
        self.text(key).parse().unwrap_or(0)
    }

    /// A float (NaN if absent or not a number).
    fn f64(&self, key: &str) -> f64 {
        self.text(key).parse().unwrap_or(f64::NAN)
    }
}

/// The pipeline's counters, by the names of `rig: counters`.
const COUNTERS: [&str; 11] = [
    "adc_crc",
    "adc_status",
    "adc_bus",
    "adc_other",
    "bridge_saturated",
    "monitor_saturated",
    "stuck",
    "rejected",
    "dac_errors",
    "dac_saturated",
    "dropped_records",
];

/// The counters the schedule's faults must produce (see the module doc).
fn expected_counters(faults: &[&Line]) -> HashMap<&'static str, u64> {
    let mut c: HashMap<&'static str, u64> = COUNTERS.iter().map(|&k| (k, 0)).collect();
    let mut add = |k: &'static str, n: u64| *c.entry(k).or_default() += n;
    for f in faults {
        let n = f.u64("n");
        let rejected = match f.text("kind") {
            "bad_crc" => {
                add("adc_crc", n);
                n
            }
            "saturate" => {
                add("bridge_saturated", n);
                add("monitor_saturated", n);
                n
            }
            "stuck" => {
                add("stuck", n + 1);
                n + 1
            }
            _ => {
                add("adc_other", n);
                n
            }
        };
        add("rejected", rejected);
    }
    c
}

/// `--hum`: the `rig: hum` line (the lines injected) and the line
/// remover's `rig: lines` at the end. Every injected line (f, amplitude,
/// phase) of `hum` must be a harmonic of the remover's mains whose weights
/// hold its amplitude within `tolerance` (relative), and every other
/// harmonic less than `empty_share` of the smallest injected line. `Ok`:
/// what was found, in words.
pub fn judge_hum(
    log: &str,
    hum: &[(f64, f64, f64)],
    tolerance: f64,
    empty_share: f64,
) -> Result<String, String> {
    let lines: Vec<Line> = log.lines().filter_map(Line::parse).collect();
    if !lines.iter().any(|l| l.what == "hum") {
        return Err("the firmware's log has no `rig: hum` line: no hum injected".into());
    }
    let Some(r) = lines.iter().rev().find(|l| l.what == "lines") else {
        return Err("the firmware's log has no `rig: lines` line".into());
    };
    let n = r.u64("n") as usize;
    let mains = r.f64("mains_hz");
    if n == 0 || mains.is_nan() || mains <= 0.0 {
        return Err(format!(
            "the line remover is off at the end (n={n}, mains {mains} Hz)"
        ));
    }
    let amp = |k: usize| r.f64(&format!("a{k}"));
    let smallest = hum.iter().map(|h| h.1).fold(f64::INFINITY, f64::min);
    let mut words = Vec::new();
    let mut injected = vec![false; n + 1];
    for &(f, a, _) in hum {
        let k = (f / mains).round() as usize;
        if k == 0 || k > n || (k as f64 * mains - f).abs() > 1e-6 * f {
            return Err(format!(
                "the injected {f} Hz line is no harmonic the remover holds"
            ));
        }
        injected[k] = true;
        let found = amp(k);
        let off = (found / a - 1.0).abs();
        if off.is_nan() || off > tolerance {
            return Err(format!(
                "{f} Hz: the remover holds amplitude {found:.4e}, injected {a:.4e} (more than \
                 {:.0}% off)",
                100.0 * tolerance
            ));
        }
        words.push(format!("{f} Hz found at {found:.4e} (injected {a:.4e})"));
    }
    for (k, _) in injected.iter().enumerate().skip(1).filter(|(_, i)| !**i) {
        let a = amp(k);
        if a.is_nan() || a >= empty_share * smallest {
            return Err(format!(
                "harmonic {k} ({} Hz) carries no hum but the remover holds {a:.4e} (≥ {:.0}% of \
                 {smallest:.4e})",
                k as f64 * mains,
                100.0 * empty_share
            ));
        }
    }
    words.push(format!(
        "the other {} harmonics below {:.0}% of the smallest line",
        n - hum.len(),
        100.0 * empty_share
    ));
    Ok(words.join("; "))
}

/// Judge a run from its log (printing what it judged, as the firmware did
/// before it only measured); `Err` lists the failed checks.
pub fn judge(log: &str) -> Result<(), Vec<String>> {
    let lines: Vec<Line> = log.lines().filter_map(Line::parse).collect();
    let all = |what: &str| lines.iter().filter(|l| l.what == what).collect::<Vec<_>>();
    let one = |what: &str| lines.iter().rev().find(|l| l.what == what);
    let Some(end) = one("end") else {
        return Err(vec![
            "the firmware's log has no `rig: end` line: the run was not reported".into(),
        ]);
    };
    let empty = Line::default();
    let counters = one("counters").unwrap_or(&empty);
    let faults = all("fault");
    let modes = one("modes").unwrap_or(&empty);
    let samples = end.u64("samples");
    let seconds = samples as f64 * bench::TS_S;
    let robust_running = end.text("estimator") == "robust";
    let mut failures = Vec::new();

    println!("\nxtask: the run judged from the firmware's `rig:` lines:");
    let expected = expected_counters(&faults);
    let ex = |k: &str| expected.get(k).copied().unwrap_or(0);
    println!(
        "faults injected in the ADC model: {} bad-CRC frames, {} saturated, {}-repeat stuck run, \
         {} dropped conversions",
        ex("adc_crc"),
        ex("bridge_saturated"),
        ex("stuck").saturating_sub(1),
        ex("adc_other")
    );
    let c = |k: &str| counters.u64(k);
    println!(
        "pipeline counters: crc {} status {} bus {} other {} | saturated bridge {} monitor {} | \
         stuck {} | rejected {} | dac errors {} saturated {} | records dropped {}",
        c("adc_crc"),
        c("adc_status"),
        c("adc_bus"),
        c("adc_other"),
        c("bridge_saturated"),
        c("monitor_saturated"),
        c("stuck"),
        c("rejected"),
        c("dac_errors"),
        c("dac_saturated"),
        c("dropped_records")
    );
    // A run shorter than the fault schedule cannot be checked against it.
    let done_by = faults.iter().map(|f| f.u64("done_by")).max().unwrap_or(0);
    let schedule_done = samples >= done_by;
    if !schedule_done {
        println!(
            "the run ended before the fault schedule (until {:.1} s): fault counters not checked",
            done_by as f64 * bench::TS_S
        );
    }
    let counters_match = !counters.values.is_empty()
        && COUNTERS
            .iter()
            .all(|&k| counters.values.contains_key(k) && c(k) == ex(k));
    let counters_ok = counters_match || !schedule_done || robust_running;

    let (first_ok, modes_ok) = if robust_running {
        let ok = check_robust(one("robust"));
        let converged = check_modes(modes, ROBUST_OMEGA_TOLERANCE, ROBUST_ZETA_TOLERANCE);
        println!(
            "robust estimator convergence (omega within {ROBUST_OMEGA_TOLERANCE:.0e}, zeta within \
             {ROBUST_ZETA_TOLERANCE:.0e}): {}",
            if converged { "yes" } else { "NO" }
        );
        if !ok {
            failures.push("robust model updates: none installed, or a lock too long".into());
        }
        if !converged {
            failures.push("the robust estimator did not converge".into());
        }
        (ok, converged)
    } else {
        let tuning_ok = check_tuning(one("tuning").unwrap_or(&empty), &all("recentre"), modes);
        let ok = check_modes(modes, TOLERANCE, TOLERANCE);
        if !tuning_ok {
            failures.push("the automatic rule did not settle on the estimated band".into());
        }
        if !ok {
            failures.push(format!(
                "omega, zeta not within {TOLERANCE:.0e} of the truth"
            ));
        }
        (tuning_ok, ok)
    };
    let tests = all("selftest");
    let self_test_ok = check_self_tests(&tests);
    if !self_test_ok {
        failures.push("the self-test: not reported at start-up, or a check did not pass".into());
    }
    let started = end.text("started_at") != "none" && end.values.contains_key("started_at");
    let others_ok = end.u64("overruns") == 0 && end.u64("rig_errors") == 0 && started;
    if !others_ok {
        failures.push(format!(
            "overruns {}, rig errors {}, estimator started at {}",
            end.text("overruns"),
            end.text("rig_errors"),
            end.text("started_at")
        ));
    }
    if !counters_ok {
        println!("fault counters differ from the injected faults");
        failures.push("fault counters differ from the injected faults".into());
    }
    let pass = modes_ok && counters_ok && others_ok && first_ok && self_test_ok;
    let verdict = if pass { "PASS" } else { "FAIL" };
    if robust_running {
        println!(
            "result: {verdict} (robust estimator: converged within the bounds above, model updates \
             installed, every lock of theirs within one sample period; no overrun; after \
             {seconds:.1} s; fault counters reported above, not checked)"
        );
    } else {
        println!(
            "result: {verdict} (all of omega, zeta within {TOLERANCE:.0e} after {seconds:.1} s; \
             lambda settled by the automatic rule on the estimated band; fault counters {}; no \
             overrun)",
            if schedule_done {
                "as injected"
            } else {
                "not checked (short run)"
            }
        );
    }
    if pass {
        Ok(())
    } else {
        Err(failures)
    }
}

/// The self-tests of a run without a bench fault: the first at start-up,
/// every check of every one passed.
fn check_self_tests(tests: &[&Line]) -> bool {
    for t in tests {
        println!(
            "self-test ({}, samples {}–{}): failed {} not measured {}; ADC ID {}, DRDY {} Hz, \
             loopback gain {} delay {} samples, noise σ {} SNR {} dB",
            if t.text("at_boot") == "true" {
                "at start-up"
            } else {
                "on command"
            },
            t.text("first"),
            t.text("last"),
            t.text("failed"),
            t.text("not_measured"),
            t.text("id"),
            t.f64("drdy_hz"),
            t.f64("gain"),
            t.f64("delay"),
            t.f64("noise_sd"),
            t.f64("snr_db")
        );
    }
    let first_at_boot = tests.first().is_some_and(|t| t.text("at_boot") == "true");
    let all_passed = tests.iter().all(|t| {
        t.text("fault") == "none"
            && t.values.contains_key("failed")
            && t.u64("failed") == 0
            && t.values.contains_key("not_measured")
            && t.u64("not_measured") == 0
    });
    if !(first_at_boot && all_passed) {
        println!("the self-test at start-up missing, or a check of a self-test did not pass");
    }
    first_at_boot && all_passed
}

/// A run with the bench fault `fault` injected before the self-test at
/// start-up: its report must name exactly `failed` as failed and
/// `not_measured` as not measured (bit sets of `SelfTestChecks`).
pub fn judge_self_test_fault(
    log: &str,
    fault: &str,
    failed: u16,
    not_measured: u16,
) -> Result<(), String> {
    let lines: Vec<Line> = log.lines().filter_map(Line::parse).collect();
    let Some(t) = lines
        .iter()
        .find(|l| l.what == "selftest" && l.text("at_boot") == "true")
    else {
        return Err(format!("fault {fault}: no self-test report at start-up"));
    };
    let got = (t.u64("failed"), t.u64("not_measured"));
    let want = (u64::from(failed), u64::from(not_measured));
    if t.text("fault") == fault && got == want {
        Ok(())
    } else {
        Err(format!(
            "fault {fault}: the self-test reported fault={} failed={} not_measured={}, expected \
             failed={} not_measured={}",
            t.text("fault"),
            got.0,
            got.1,
            want.0,
            want.1
        ))
    }
}

/// The robust estimator's real-time properties: running at the end, at
/// least one model update installed, no lock of theirs over [`LOCK_BOUND`].
fn check_robust(line: Option<&Line>) -> bool {
    let Some(r) = line.filter(|r| r.text("running") == "true") else {
        return false;
    };
    let locks_ok = r.values.contains_key("lock_max_instructions")
        && r.u64("lock_max_instructions") <= LOCK_BOUND;
    if !locks_ok {
        println!("a model update's lock exceeded {LOCK_BOUND} instructions");
    }
    r.u64("updates") >= 1 && locks_ok
}

/// The tuning rule, judged without the truth (see the module doc).
fn check_tuning(t: &Line, recentres: &[&Line], modes: &Line) -> bool {
    let lambda = t.f64("lambda");
    let centre = (modes.f64("omega1") * modes.f64("omega2")).sqrt();
    let truth_centre = (PAPER_OMEGA[0] * PAPER_OMEGA[1]).sqrt();
    let list: Vec<String> = recentres
        .iter()
        .map(|r| format!("at sample {}: {:.1}", r.text("at"), r.f64("lambda")))
        .collect();
    let phase = t.text("phase");
    println!(
        "tuning: automatic {}; lambda0 = {:.1} rad/s from the data, {} re-centring(s){}; final \
         lambda = {lambda:.1} rad/s, phase {}; estimated band centre sqrt(w1*w2) = {centre:.1} \
         rad/s (the truth's: {truth_centre:.1}); start-up pairs lost {}",
        t.text("automatic"),
        t.f64("lambda0"),
        recentres.len(),
        if list.is_empty() {
            String::new()
        } else {
            format!(" ({})", list.join(", "))
        },
        match phase {
            "startup" | "reviewing" => phase.to_string(),
            "max_recentres" => "settled (most re-centrings)".into(),
            p => format!("settled ({p})"),
        },
        t.text("lost_pairs")
    );
    let ratio = lambda / centre;
    let centred = ratio.max(1.0 / ratio) < 1.0 + t.f64("recentre_threshold");
    let ok = t.text("automatic") == "true"
        && phase == "converged"
        && centred
        && t.values.contains_key("startup_dropped")
        && t.u64("startup_dropped") == 0
        && t.values.contains_key("lost_pairs")
        && t.u64("lost_pairs") == 0;
    if !ok {
        println!("the automatic rule did not settle on the estimated band");
    }
    ok
}

/// The only comparison with the simulated truth: two modes, ω within
/// `tol_omega`, ζ within `tol_zeta`.
fn check_modes(m: &Line, tol_omega: f64, tol_zeta: f64) -> bool {
    if m.u64("n") == 0 {
        println!("no modal estimate at the end of the run");
        return false;
    }
    let mut ok = true;
    for (i, (&tw, &tz)) in PAPER_OMEGA.iter().zip(PAPER_ZETA.iter()).enumerate() {
        let w = m.f64(&format!("omega{}", i + 1));
        let z = m.f64(&format!("zeta{}", i + 1));
        let ew = (w / tw - 1.0).abs();
        let ez = (z / tz - 1.0).abs();
        println!(
            "mode {}: omega = {w:.5} rad/s (truth {tw:.4}, rel. error {ew:.1e}), zeta = {z:.7} \
             (truth {tz:.4}, rel. error {ez:.1e})",
            i + 1
        );
        // `!(e <= tol)` fails NaN too.
        if !(ew <= tol_omega && ez <= tol_zeta) {
            ok = false;
        }
    }
    ok && m.u64("n") == 2
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The `rig:` lines of a passing default run (5 s).
    const RUN: &str = "\
t = 4.75 s  omega = [39.1533, 245.3713] rad/s
rig: fault at=20000 kind=bad_crc n=10 done_by=40000
rig: fault at=25000 kind=saturate n=50 done_by=40000
rig: fault at=30000 kind=stuck n=100 done_by=40000
rig: fault at=35000 kind=dropped n=5 done_by=40000
rig: counters adc_crc=10 adc_status=0 adc_bus=0 adc_other=5 bridge_saturated=50 \
monitor_saturated=50 stuck=101 rejected=166 dac_errors=0 dac_saturated=0 dropped_records=0
rig: tuning automatic=true lambda0=9.415307000e1 lambda=9.415307000e1 phase=converged \
recentre_threshold=1.000000000e-1 lost_pairs=0 startup_dropped=0
rig: modes n=2 omega1=3.915330124e1 zeta1=2.070002262e-2 omega2=2.453712616e2 zeta2=1.300003827e-1
rig: selftest at_boot=true failed=0 not_measured=0 first=0 last=6687 fault=none id=8704 \
drdy_hz=1.000000000e4 gain=9.998430610e-1 offset_v=4.656612873e-9 delay=2.149998426e0 \
noise_sd=0.000000000e0 snr_db=1.063805847e2
rig: end samples=50000 overruns=0 rig_errors=0 started_at=2074 estimator=adaptive
";

    #[test]
    fn a_passing_run_passes() {
        assert_eq!(judge(RUN), Ok(()));
    }

    #[test]
    fn each_check_fails_on_its_own() {
        let fails = |from: &str, to: &str| {
            let log = RUN.replace(from, to);
            assert_ne!(log, RUN, "{from}");
            judge(&log).expect_err(from)
        };
        fails("stuck=101", "stuck=100");
        fails("omega2=2.453712616e2", "omega2=2.46e2");
        fails("phase=converged", "phase=timeout");
        fails("lambda=9.415307000e1", "lambda=1.2e2");
        fails("overruns=0", "overruns=1");
        fails("started_at=2074", "started_at=none");
        fails("lost_pairs=0", "lost_pairs=3");
        fails("n=2 omega1", "n=0 omega1");
        fails("rig: end", "rig: ended");
        fails("at_boot=true", "at_boot=false");
        fails("failed=0 not_measured=0", "failed=16 not_measured=0");
        fails("failed=0 not_measured=0", "failed=0 not_measured=8");
        fails("rig: selftest", "rig: selftests");
        // A short run skips the counter comparison only.
        let short = RUN
            .replace("samples=50000", "samples=30000")
            .replace("stuck=101", "stuck=0");
        assert_eq!(judge(&short), Ok(()));
    }

    #[test]
    fn a_fault_run_passes_only_with_exactly_its_check_failed() {
        let log = RUN
            .replace("failed=0 not_measured=0", "failed=16 not_measured=0")
            .replace("fault=none", "fault=noise");
        assert_eq!(judge_self_test_fault(&log, "noise", 16, 0), Ok(()));
        assert!(judge_self_test_fault(&log, "noise", 16, 8).is_err());
        assert!(judge_self_test_fault(&log, "noise", 4, 0).is_err());
        assert!(judge_self_test_fault(&log, "drdy_rate", 16, 0).is_err());
        assert!(judge_self_test_fault(RUN, "noise", 16, 0).is_err());
    }

    #[test]
    fn the_robust_run_checks_its_updates_and_not_the_counters() {
        let robust = RUN
            .replace("estimator=adaptive", "estimator=robust")
            .replace("stuck=101", "stuck=0")
            .replace("phase=converged", "phase=timeout")
            + "rig: robust running=true phase=steady updates=14 lock_max_instructions=87200\n";
        assert_eq!(judge(&robust), Ok(()));
        let long_lock = robust.replace(
            "lock_max_instructions=87200",
            "lock_max_instructions=100001",
        );
        assert!(judge(&long_lock).is_err());
        let no_update = robust.replace("updates=14", "updates=0");
        assert!(judge(&no_update).is_err());
        let stopped = robust.replace(
            "rig: robust running=true phase=steady updates=14 lock_max_instructions=87200",
            "rig: robust running=false",
        );
        assert!(judge(&stopped).is_err());
    }
}
