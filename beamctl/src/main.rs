//! `beamctl` — host command line for the beam estimator.
//!
//! * `beamctl simulate` runs the proposed adaptive law (eqs. 33–41), the
//!   gradient (47) / least-squares (48) baselines or the noise-robust
//!   estimator against the simulated beam (through [`beamctl::run::run`]) and
//!   reports the estimates against the truth, like the paper's Table III
//!   (with noise: also against the Cramér–Rao bound, over one seed or
//!   several); optionally writes the time series (CSV) and a plot of the
//!   estimates vs time (PNG, like Fig. 4).
//! * `beamctl crlb` prints the Cramér–Rao bound of an experiment before
//!   it is run.
//! * `beamctl model` prints the physical beam's modal model (Section II and
//!   Appendix: Tables I–II → β_iL, ω_i, ζ_i, m_ii, k_ii, c_ii, z_i, b̄_i, c_i,
//!   and the transfer function of eqs. 25–26).
//! * `beamctl monitor` watches a device over the serial link
//!   (docs/PROTOCOL.md): live view or one line per estimate, record, plot,
//!   commands.
//! * `beamctl send` sends one command to a device and prints its answer.
//!
//! This file holds the top-level command definitions and the dispatch only;
//! each subcommand's options and code live in the library
//! (`beamctl::cli`). Errors are reported as one line on stderr
//! (`error: --flag: what is wrong`) with exit code 2 for bad usage and 1 for
//! failures while running.

use beamctl::cli::args::{CrlbArgs, ReplayArgs, SimulateArgs};
use beamctl::cli::{crlb, model, monitor, replay, selftest, send, simulate};
use beamctl::error;
use clap::{Parser, Subcommand};
use std::process::ExitCode;

/// Host tools for the online modal-parameter estimator of a piezo-actuated
/// cantilever beam.
#[derive(Debug, Parser)]
#[command(name = "beamctl", version, propagate_version = true)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

// Parsed once per run: the size of the largest variant does not matter.
#[allow(clippy::large_enum_variant)]
#[derive(Debug, Subcommand)]
enum Command {
    /// Run an estimator against the simulated beam and compare its estimates
    /// with the truth (like the paper's Table III).
    #[command(long_about = SIMULATE_ABOUT)]
    Simulate(SimulateArgs),
    /// Print the physical beam's modal model (Tables I–II → ω_i, ζ_i, b̄_i,
    /// transfer function).
    #[command(long_about = MODEL_ABOUT)]
    Model(model::ModelArgs),
    /// Watch a device's estimates live (serial port, TCP or a capture file),
    /// record them, send it commands.
    #[command(long_about = MONITOR_ABOUT)]
    Monitor(monitor::MonitorArgs),
    /// Send one command to a device (excitation, estimator settings,
    /// telemetry rates, reset, freeze, resume, status) and print its answer.
    #[command(long_about = SEND_ABOUT)]
    Send(send::SendArgs),
    /// Run the device's self-test (converter ID and registers, DRDY rate,
    /// DAC → ADC loopback, noise floor and SNR) and print its report with
    /// the Cramér–Rao bound the rig can reach.
    #[command(long_about = SELFTEST_ABOUT)]
    Selftest(selftest::SelfTestArgs),
    /// Run the estimator over recorded samples (a CSV of t, u, y) and
    /// judge the estimate without the truth (model output fit, drift).
    #[command(long_about = REPLAY_ABOUT)]
    Replay(ReplayArgs),
    /// The Cramér–Rao bound of an experiment: the best accuracy of ω, ζ, b̄
    /// any unbiased estimator can reach on it.
    #[command(long_about = CRLB_ABOUT)]
    Crlb(CrlbArgs),
}

const CRLB_ABOUT: &str = "\
The Cramér–Rao bound (CRB) of an experiment: the smallest standard deviation of ω_i, ζ_i, \
b̄_i that any unbiased estimator can reach, from the Fisher information of the sampled y \
(white Gaussian noise of σ on y, the held input known; beamest::crlb). Run it before an \
experiment to learn what accuracy it can give at best; `beamctl simulate` with noise \
reports each estimator's error ÷ this bound.

The experiment is the one `beamctl simulate` runs with the same flags: the plant (the \
plant flags as for simulate), u = 0.1·square(7 Hz) from rest at Ts = 0.1 ms, for \
--duration, with noise given as --snr-db (relative to the RMS of the noise-free y over \
the whole record, as simulate defines it) or --noise-sd.

The bound depends on what is unknown: by default the estimators' own transfer-function \
set (the 4N − 1 coefficients of B(s)/A(s), eq. 29, which every estimator here \
identifies); --model-set modal bounds the paper's 3N parameters ω, ζ, b̄ with the output \
and velocity weights known (smaller: on the paper's plant half on ζ1). Output: per \
parameter its value, the absolute 1σ bound and the relative one.";

const MONITOR_ABOUT: &str = "\
Watch a device's estimates live over the serial link (docs/PROTOCOL.md): from a serial \
port (--port, --baud), a TCP socket (--tcp, e.g. QEMU's -serial tcp:...) or a file of \
captured bytes (--file).

On a terminal: a live view of the current estimates (ω̂_i, ζ̂_i, b̂̄_i, λ, λmin(P)/tr(P), flags), \
charts of ω̂_i and ζ̂_i over the last 60 s of device time, the link's health (frames/s, \
frames lost by sequence gaps, CRC and framing errors, the device's counters) and a \
command line (:). Otherwise, or with --plain: one line per estimate on stdout \
(sample=... t_s=... seq=... law=... omega_rad_s=... zeta=... bbar=... lambda_rad_s=... \
excitation_level=... flags=...), messages on stderr.

At start-up the monitor asks a live device for a Status (its sample rate and settings) \
unless --listen-only. It stops after --duration, on q or Ctrl-C, at the end of a --file \
(exit 0), when a live device disappears (exit 1) or when it meets another protocol \
version (exit 1); the --record and --capture files are flushed at least every 0.25 s and \
kept in every case.";

const SEND_ABOUT: &str = "\
Send one command to a device and print its acknowledgement, or the reason the device \
refused it (exit 1), or that no acknowledgement came within --timeout (exit 1).

Settings not given are kept from the device's current ones, read from a Status that \
send asks for first (so `excitation --amplitude 0.2` changes only the amplitude). The \
command is checked locally with the device's own rules against what its Status tells \
(sample rate, mode count, and the baud rate's link budget with --port); a command that \
check expects to be refused is still sent, with a warning on stderr, because the device \
decides: it checks the command against its full limits (piezo safe window, generators, \
estimators) and answers.";

const SELFTEST_ABOUT: &str = "\
Run the device's bring-up self-test over the serial link (the SelfTest command) and print \
its report: the ADC's ID and configuration registers read back, the conversion (DRDY) rate \
against the MCU's clock, the DAC → ADC loopback on the monitor channel (gain, offset, delay \
against the device's timing model), the noise floor of y with the drive at zero and the SNR \
against y under the default excitation; per check its verdict, the value measured and what \
passes (docs/RIG.md, \"Bring-up\", says what to do when one fails).

Then the Cramér–Rao bound the rig can reach with its default excitation at the measured \
noise (see `beamctl crlb`), over --duration seconds from rest, for the model of the \
device's own latest physically valid estimate (nothing from a simulation).

While the test runs (0.66 s of device time at 10 kHz) the device holds adaptation and \
drives its own test signals, then restores its excitation; it refuses other commands \
(Busy). Exit status 0 if every check passed, 1 if one failed or could not be measured \
(after the report), if the device refused the test, or no answer came in time.";

const SIMULATE_ABOUT: &str = "\
Run an estimator against the simulated beam and compare its estimates with the truth \
(like the paper's Table III). With noise (--snr-db or --noise-sd) the Cramér–Rao bound of \
the experiment (see `beamctl crlb`) is reported too, and each estimator's relative error \
÷ that bound; --seeds runs several noise realisations and reports the RMS error over them \
and RMS ÷ bound.

The estimator sees only what the firmware would: the held input \
u = 0.1·square(7 Hz) and the sampled output y (plus optional white noise) at \
Ts = 0.1 ms, through its own filter bank Λ(s) = (s+λ)^(2N). Modal parameters are \
recovered every 10 samples (1 kHz) from the estimated transfer function; runs longer \
than 60 s without --csv recover them every 100 samples (100 Hz).

Plant: with none of --omega/--zeta/--bbar/--weights, the default plant for N modes \
is used: N = 2 is the paper's simulation plant (Table III ω, ζ with eq. 46's \
numerator), N = 1 its first mode, N = 3 the paper's two modes plus a third at \
ω3 = 687.4 rad/s, ζ3 = 0.05, b̄3 = 20. Otherwise the plant is the modal model of \
eq. 23 built from the lists given; a list that is not given is taken from the \
default plant for N modes (so `--zeta 0.05,0.1` changes only the damping).

Output: a table of estimate, truth and relative error per parameter, the time after \
which the largest relative ω/ζ error stays below 1% and 0.1%, the excitation level \
λmin(P) of Lemma 1 (scaled coordinates; adaptive law only) and the estimator's \
rejected/skipped counters. A progress bar is shown on stderr for runs that take \
longer than about a second (only when stderr is a terminal and not with --json).

Robustness: every sample passes the sensor guard (non-finite, saturated and open with \
--range, stuck; offset steps and drift flagged), whose rejections are counted by kind; \
the report gives the supervisor's excitation flag and its reason, the changes it \
detected and the physical-validity flags of the final estimate. Scenarios: a plant \
change (--step-at with --step-omega/--step-zeta; the truth is then the new plant's and \
the tracking time is reported), an excitation pause (--excitation-off), a sensor fault \
(--fault, --fault-at, --fault-for; its detection latency is reported) and modes beyond \
the model (--truth-modes). With an event the Cramér–Rao bound is not computed (the \
experiment is not the stationary one it describes).";

const REPLAY_ABOUT: &str = "\
Run the estimator over recorded samples, exactly as the firmware would run it on the \
rig: u held over each sample period, y sampled, through the same filter bank, update \
law and truth-free tuning rule (start-up window for the signal scales and λ, then λ \
re-centred on the estimated band; docs/SETTINGS.md).

Input: a CSV file with a header (gzip-compressed if it starts with the gzip magic), \
columns t,u,y by default or chosen by name with --columns; the sample interval is the \
mean spacing of the time column, which must be increasing and uniform within 1%; \
--ts gives it for a file without a time column. A row with the wrong number of fields \
or a non-numeric field stops the replay with an error naming its line; an empty, NaN \
or infinite u or y is a missing sample: skipped by the estimator (its filters hold, \
its law is frozen while they settle) and counted as rejected. See docs/REPLAY.md.

Output: the estimate (ω, ζ, b̄ per mode), the model output fit \
100·(1 − ‖y − ŷ‖/‖y − ȳ‖) of the final model driven by the recorded u (initial state \
fitted), how much the estimate moved over the last 10% of the record, λ and the \
tuning rule's outcome, λmin(P) (adaptive law), samples, rejected samples and skipped \
updates; for the robust estimator its phase and a-posteriori noise RMS; with --crlb the \
Cramér–Rao bound at the final estimate (see --crlb); the verdict (trusted, or the reasons \
why not). With no flags the estimator, the number of modes and the level correction are \
chosen from the data (--estimator auto; docs/REPLAY.md, \"Model selection\"). Exit status 1 \
if no estimate was produced or none is trusted (after the report), 2 for bad flags or input.";

const MODEL_ABOUT: &str = "\
Print the physical beam's modal model: per mode the root β_iL of eq. 20, ω_i, ζ_i, \
the modal mass, stiffness and damping m_ii, k_ii, c_ii (eqs. 54–56), the piezo \
input z_i (eq. 57), b̄_i = z_i/m_ii and the output weight c_i, plus the transfer \
function coefficients a, b (eqs. 25–26).

The beam is the paper's (Tables I–II, BeamParams::paper()) unless --beam names a \
TOML file; see --beam for its keys.";

fn main() -> ExitCode {
    let cli = match Cli::try_parse() {
        Ok(cli) => cli,
        Err(e) => return error::clap_exit(e),
    };
    let result = match &cli.command {
        Command::Simulate(args) => simulate::run(args),
        Command::Model(args) => model::run(args),
        Command::Monitor(args) => monitor::run(args),
        Command::Send(args) => send::run(args),
        Command::Selftest(args) => selftest::run(args),
        Command::Replay(args) => replay::run(args),
        Command::Crlb(args) => crlb::run(args),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => e.report(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::CommandFactory;

    #[test]
    fn clap_definitions_are_consistent() {
        Cli::command().debug_assert();
    }
}
