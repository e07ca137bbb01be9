//! `beamctl selftest`: run the device's bring-up self-test over the serial
//! link (the `SelfTest` command, docs/PROTOCOL.md §5, §9.7) and print its
//! report: each check's verdict with the value measured and what passes,
//! and the Cramér–Rao bound the rig can reach with its default excitation
//! at the noise it measured.
//!
//! The bound is computed here, not on the device (it needs a model of the
//! beam, and the Fisher information in `f64`): from the report's noise σ
//! (or the quantisation floor, whichever is larger) and default
//! excitation, and the device's own latest physically valid estimate
//! (Θ̂ and λ → B(s)/A(s)), by `beamctl crlb`'s code
//! ([`crate::judge::bound::experiment_bound`], the estimators'
//! transfer-function set) over `--duration` seconds from rest. Nothing
//! comes from a simulated truth.

use crate::cli::send::{DeviceArgs, Session, Wanted};
use crate::error::{write_stdout, CliError};
use crate::io::report;
use crate::io::table::{rel, sig, Column, Table};
use crate::judge::bound::{experiment_bound, ExperimentBound, NoiseLevel};
use crate::link::text;
use crate::run::drive::device_drive;
use beam_protocol::{AckResult, Command, Estimate, Frame, Message, SelfTestChecks, SelfTestReport};
use beamest::crlb::ModelSet;
use beamest::model::TransferFunction;
use clap::{ArgGroup, Args};
use serde::Serialize;
use std::time::{Duration, Instant};

/// Options of `beamctl selftest`.
#[derive(Debug, Clone, Args)]
#[command(group(ArgGroup::new("device").args(["port", "tcp"]).required(true)))]
pub struct SelfTestArgs {
    /// The device.
    #[command(flatten)]
    pub device: DeviceArgs,

    /// Seconds to wait for the acknowledgement of the command (> 0).
    #[arg(long, value_name = "SECONDS", default_value_t = 1.0)]
    pub timeout: f64,

    /// Seconds to wait for the report after the acknowledgement (> 0; the
    /// test takes 0.66 s of device time on a 10 kHz device).
    #[arg(long, value_name = "SECONDS", default_value_t = 30.0)]
    pub report_timeout: f64,

    /// Length of the experiment the Cramér–Rao bound is computed for (s,
    /// > 0): the default excitation from rest for this long.
    #[arg(long, value_name = "SECONDS", default_value_t = 20.0)]
    pub duration: f64,

    /// Print the report and the bound as JSON.
    #[arg(long)]
    pub json: bool,
}

/// The bound at the device's noise, and what it was computed from.
#[derive(Debug, Clone, Serialize)]
pub struct DeviceBound {
    /// The estimate whose model the bound is for: its sample index.
    pub estimate_sample_index: u64,
    /// … and its λ (rad/s).
    pub lambda_rad_s: f32,
    /// The bound.
    #[serde(flatten)]
    pub bound: ExperimentBound,
}

/// What `beamctl selftest --json` prints.
#[derive(Debug, Serialize)]
struct Doc<'a> {
    device: String,
    passed: bool,
    /// Each check's verdict: `pass`, `fail`, `not_measured`.
    checks: Vec<(&'static str, &'static str)>,
    report: &'a SelfTestReport,
    /// None: no physically valid estimate to take a model from, or the
    /// bound could not be computed (`crb_error`).
    crb: Option<DeviceBound>,
    #[serde(skip_serializing_if = "Option::is_none")]
    crb_error: Option<String>,
}

fn seconds(flag: &str, v: f64) -> Result<Duration, CliError> {
    if v.is_finite() && v > 0.0 {
        Ok(Duration::from_secs_f64(v))
    } else {
        Err(CliError::usage(
            flag,
            format!("must be a number of seconds > 0 (got {v})"),
        ))
    }
}

/// Run `beamctl selftest`: exit 0 if every check passed, 1 otherwise (after
/// the report), or if the device refused or did not answer.
pub fn run(args: &SelfTestArgs) -> Result<(), CliError> {
    let ack_timeout = seconds("--timeout", args.timeout)?;
    let report_timeout = seconds("--report-timeout", args.report_timeout)?;
    seconds("--duration", args.duration)?;
    let endpoint = args
        .device
        .endpoint()
        .ok_or_else(|| CliError::usage("--port/--tcp", "name the device"))?;
    let mut s = Session::open(&endpoint)?;
    let seq = s.send(Command::SelfTest)?;
    match s.wait(Wanted::Ack(seq), Instant::now() + ack_timeout)? {
        Some(Frame {
            message: Message::Ack(a),
            ..
        }) if a.result == AckResult::Accepted => {}
        Some(Frame {
            message: Message::Ack(a),
            ..
        }) => {
            return Err(CliError::failure(format!(
                "the device {} (self-test, command seq {seq})",
                text::result_text(a.result)
            )))
        }
        _ => {
            return Err(CliError::failure(format!(
                "no acknowledgement from the device within {} s (self-test, command seq {seq})",
                args.timeout
            )))
        }
    }
    let report = match s.wait(Wanted::SelfTestReport, Instant::now() + report_timeout)? {
        Some(Frame {
            message: Message::SelfTestReport(r),
            ..
        }) => r,
        _ => {
            return Err(CliError::failure(format!(
                "the device started its self-test but sent no report within {} s",
                args.report_timeout
            )))
        }
    };
    if s.last_valid.is_none() {
        // Estimates continue through the test; give one a moment.
        s.wait(Wanted::ValidEstimate, Instant::now() + ack_timeout)?;
    }
    let fs = s
        .host
        .sample_rate_hz()
        .unwrap_or(f64::from(report.drdy.expected_hz));
    let crb = s
        .last_valid
        .as_ref()
        .map(|e| device_bound(&report, e, fs, args.duration));
    let (crb, crb_error) = match crb {
        Some(Ok(b)) => (Some(b), None),
        Some(Err(m)) => (None, Some(m)),
        None => (
            None,
            Some("no physically valid estimate from the device: no model to bound".into()),
        ),
    };
    let out = if args.json {
        report::to_json(&[Doc {
            device: endpoint.to_string(),
            passed: report.passed(),
            checks: verdicts(&report),
            report: &report,
            crb,
            crb_error,
        }])?
    } else {
        render(&report, crb.as_ref(), crb_error.as_deref())
    };
    write_stdout(&out)?;
    if report.passed() {
        Ok(())
    } else {
        Err(CliError::failure(format!(
            "self-test: {}",
            text::self_test_state_text(beam_protocol::SelfTestState::Done {
                failed: report.failed,
                not_measured: report.not_measured,
            })
        )))
    }
}

/// Each check by name with `pass`, `fail` or `not_measured`.
fn verdicts(r: &SelfTestReport) -> Vec<(&'static str, &'static str)> {
    SelfTestChecks::ALL
        .iter()
        .map(|&(c, name)| {
            let v = if r.failed.contains(c) {
                "fail"
            } else if r.not_measured.contains(c) {
                "not_measured"
            } else {
                "pass"
            };
            (name, v)
        })
        .collect()
}

/// The Cramér–Rao bound of `duration_s` of the report's default
/// excitation from rest, at the report's noise, for the model of the
/// estimate `e` (transfer-function set).
pub fn device_bound(
    report: &SelfTestReport,
    e: &Estimate,
    fs: f64,
    duration_s: f64,
) -> Result<DeviceBound, String> {
    let theta: Vec<f64> = e.theta.iter().map(|&v| f64::from(v)).collect();
    let tf = TransferFunction::<f64>::from_theta(&theta, f64::from(e.lambda_rad_s))
        .ok_or("the estimate's Θ̂ has no valid length")?;
    let sigma = f64::from(report.noise.noise_sd).max(f64::from(report.noise.floor_sd));
    if !(sigma > 0.0 && sigma.is_finite()) {
        return Err("the noise floor was not measured".into());
    }
    let drive = device_drive(&report.noise.excitation, fs).map_err(|e| e.to_string())?;
    let n = (duration_s * fs).round() as usize;
    // The bounds reported are relative (ω, ζ) or relative of b̄, which
    // does not depend on the output weights' scale: unit weights.
    let weights = vec![1.0; tf.modes];
    let bound = experiment_bound(
        &tf,
        &weights,
        1.0 / fs,
        drive.take(n),
        NoiseLevel::Sd(sigma),
        ModelSet::TransferFunction,
    )
    .map_err(|e| format!("the bound: {e}"))?;
    Ok(DeviceBound {
        estimate_sample_index: e.sample_index,
        lambda_rad_s: e.lambda_rad_s,
        bound,
    })
}

fn render(r: &SelfTestReport, crb: Option<&DeviceBound>, crb_error: Option<&str>) -> String {
    let mut out = text::self_test_lines(r).join("\n");
    out.push('\n');
    match crb {
        Some(b) => {
            let bound = &b.bound;
            out.push_str(&format!(
                "\nCramér–Rao bound with the default excitation for {} s from rest at σ = {} \
                 (SNR {:.1} dB over that record), for the model of the device's estimate at \
                 sample {} (λ = {} rad/s; the estimators' transfer-function set):\n",
                bound.samples as f64 * bound.ts_s,
                sig(bound.sigma, 4),
                bound.snr_db,
                b.estimate_sample_index,
                b.lambda_rad_s
            ));
            let mut t = Table::new();
            t.group(
                "",
                vec![
                    Column::text("parameter"),
                    Column::num("value"),
                    Column::num("CRB (1σ)"),
                    Column::num("relative"),
                ],
            );
            for (sym, p) in [("ω", &bound.omega), ("ζ", &bound.zeta)] {
                for i in 0..bound.modes {
                    t.row([
                        format!("{sym}{}", i + 1),
                        sig(p.value[i], 7),
                        format!("{:.3e}", p.sd[i]),
                        rel(p.rel[i]),
                    ]);
                }
            }
            for i in 0..bound.modes {
                t.row([
                    format!("b̄{}", i + 1),
                    "-".to_string(),
                    "-".to_string(),
                    rel(bound.bbar.rel[i]),
                ]);
            }
            out.push_str(&t.render());
        }
        None => {
            out.push_str(&format!(
                "\nCramér–Rao bound: not computed ({})\n",
                crb_error.unwrap_or("no estimate")
            ));
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::link::fake::{FakeConfig, FakeDevice};

    /// The fake device's report and its estimate: every check passes, and
    /// the bound for the paper's plant at σ = 1e-8 over 20 s is far below
    /// 1e-3 (its ζ2 bound at 40 dB is 3.4e-3, BENCHMARKS.md; this σ is
    /// ≈ 110 dB).
    #[test]
    fn the_report_and_the_bound_from_the_fake_device() {
        let mut d = FakeDevice::new(FakeConfig::default());
        let mut out = Vec::new();
        d.advance(20_000, &mut out);
        let report = d.self_test_report();
        assert!(report.passed());
        let mut dec = beam_protocol::Decoder::<{ beam_protocol::MAX_ENCODED_LEN }>::new();
        let e = dec
            .feed(&out)
            .filter_map(|f| match f.ok()?.message {
                Message::Estimate(e) => Some(e),
                _ => None,
            })
            .last()
            .unwrap();
        let b = device_bound(&report, &e, 1e4, 20.0).unwrap();
        assert_eq!(b.bound.modes, 2);
        assert!(
            b.bound.zeta.rel.iter().all(|r| *r > 0.0 && *r < 1e-5),
            "{b:?}"
        );
        let text = render(&report, Some(&b), None);
        assert!(text.contains("every check passed"), "{text}");
        assert!(text.contains("ζ2"), "{text}");
        assert_eq!(verdicts(&report).len(), 5);
    }
}
