//! `beamctl` — host command line for the beam estimator.
//!
//! * `beamctl simulate` runs the proposed adaptive law (eqs. 33–41), the
//!   gradient (47) / least-squares (48) baselines or the noise-robust
//!   estimator against the simulated beam (through [`beamctl::run`]) and
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
//! This file holds the command-line definitions only; each subcommand lives
//! in its own module. Errors are reported as one line on stderr
//! (`error: --flag: what is wrong`) with exit code 2 for bad usage and 1 for
//! failures while running.

mod crlb;
mod csvout;
mod error;
mod events_cli;
mod model;
mod monitor;
mod multiseed;
mod plant;
mod plot;
mod progress;
mod replay;
mod report;
mod send;
mod settings;
mod simulate;
mod table;

use clap::{Args, Parser, Subcommand, ValueEnum};
use std::path::PathBuf;
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
    Model(ModelArgs),
    /// Watch a device's estimates live (serial port, TCP or a capture file),
    /// record them, send it commands.
    #[command(long_about = MONITOR_ABOUT)]
    Monitor(monitor::MonitorArgs),
    /// Send one command to a device (excitation, estimator settings,
    /// telemetry rates, reset, freeze, resume, status) and print its answer.
    #[command(long_about = SEND_ABOUT)]
    Send(send::SendArgs),
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

On a terminal: a live view of the current estimates (ω̂_i, ζ̂_i, b̂̄_i, λmin(P), flags), \
charts of ω̂_i and ζ̂_i over the last 60 s of device time, the link's health (frames/s, \
frames lost by sequence gaps, CRC and framing errors, the device's counters) and a \
command line (:). Otherwise, or with --plain: one line per estimate on stdout \
(sample=... t_s=... seq=... law=... omega_rad_s=... zeta=... bbar=... lambda_min=... \
flags=...), messages on stderr.

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
Cramér–Rao bound at the final estimate (see --crlb). Exit status 1 if no estimate was \
produced, 2 for bad flags or input.";

const MODEL_ABOUT: &str = "\
Print the physical beam's modal model: per mode the root β_iL of eq. 20, ω_i, ζ_i, \
the modal mass, stiffness and damping m_ii, k_ii, c_ii (eqs. 54–56), the piezo \
input z_i (eq. 57), b̄_i = z_i/m_ii and the output weight c_i, plus the transfer \
function coefficients a, b (eqs. 25–26).

The beam is the paper's (Tables I–II, BeamParams::paper()) unless --beam names a \
TOML file; see --beam for its keys.";

/// The update law(s) to run.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum EstimatorChoice {
    /// The proposed adaptive law (eqs. 33–41).
    Adaptive,
    /// The gradient baseline (eq. 47).
    Gradient,
    /// The least-squares baseline (eq. 48).
    Ls,
    /// The noise-robust estimator: the proposed law on the output error of
    /// a simulated model, refined over a 2 s start-up record (near the
    /// Cramér–Rao bound under white noise on y).
    Robust,
    /// The proposed law on the two-mode model plus a feedthrough
    /// (residual) term, filter (s+λ)^6: for a beam whose modes above the
    /// model's two act on the band (see docs/ROBUSTNESS.md §5). Two modes,
    /// default gains only.
    Feedthrough,
    /// All four (adaptive, gradient, ls, robust), side by side.
    All,
}

/// Which parameters the Cramér–Rao bound treats as unknown.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum ModelSetChoice {
    /// The estimators' transfer-function set: 4N − 1 coefficients (eq. 29).
    Tf,
    /// The paper's modal set: ω, ζ, b̄ (3N), output and velocity weights
    /// known.
    Modal,
}

impl ModelSetChoice {
    /// The core's model set.
    pub fn set(self) -> beamest::crlb::ModelSet {
        match self {
            Self::Tf => beamest::crlb::ModelSet::TransferFunction,
            Self::Modal => beamest::crlb::ModelSet::Modal,
        }
    }
}

/// A list of noise seeds: `A..B` (inclusive) or `S1,S2,...`.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SeedList(pub Vec<u64>);

/// Most seeds one `--seeds` may name.
pub const MAX_SEEDS: usize = 1000;

fn parse_seeds(s: &str) -> Result<SeedList, String> {
    let num = |v: &str| {
        v.trim()
            .parse::<u64>()
            .map_err(|_| format!("'{v}' is not a seed (a non-negative integer)"))
    };
    let seeds: Vec<u64> = if let Some((a, b)) = s.split_once("..") {
        let (a, b) = (num(a)?, num(b.strip_prefix('=').unwrap_or(b))?);
        if b < a {
            return Err(format!(
                "empty range {s} (write A..B with A <= B, both included)"
            ));
        }
        if b - a >= MAX_SEEDS as u64 {
            return Err(format!("at most {MAX_SEEDS} seeds"));
        }
        (a..=b).collect()
    } else {
        s.split(',').map(num).collect::<Result<_, _>>()?
    };
    if seeds.len() > MAX_SEEDS {
        return Err(format!("at most {MAX_SEEDS} seeds"));
    }
    Ok(SeedList(seeds))
}

/// Floating-point type of the estimator.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum PrecisionChoice {
    /// Double precision.
    F64,
    /// Single precision (Cortex-M4F class).
    F32,
}

/// Estimator settings shared by `simulate` and `replay`.
#[derive(Debug, Clone, Args)]
pub struct EstimatorArgs {
    /// Update law to run; `all` runs the four side by side on the same
    /// samples.
    #[arg(long, value_enum, value_name = "LAW", default_value_t = EstimatorChoice::Adaptive)]
    pub estimator: EstimatorChoice,

    /// Floating-point type of the estimator.
    #[arg(long, value_enum, value_name = "TYPE", default_value_t = PrecisionChoice::F64)]
    pub precision: PrecisionChoice,

    /// Filter pole λ of Λ(s) = (s+λ)^(2N), in rad/s (> 0), fixed for the
    /// whole run [default: automatic: a start-up λ from --band-hz, --beam
    /// or the data, re-centred on the estimated band √(ω̂_min·ω̂_max); see
    /// docs/SETTINGS.md].
    #[arg(long, value_name = "RAD_S", allow_negative_numbers = true, conflicts_with_all = ["band_hz", "beam"])]
    pub lambda: Option<f64>,

    /// The band the modes are known to lie in, F1,F2 in Hz (0 < F1 ≤ F2):
    /// the start-up λ is 2π·√(F1·F2), then re-centred on the estimate.
    #[arg(
        long,
        value_name = "F1,F2",
        value_delimiter = ',',
        allow_hyphen_values = true,
        conflicts_with = "beam"
    )]
    pub band_hz: Option<Vec<f64>>,

    /// A beam model (TOML, as for `beamctl model --beam`) whose N modes give
    /// the start-up band [ω_1, ω_N]; then re-centred on the estimate.
    #[arg(long, value_name = "FILE.toml")]
    pub beam: Option<PathBuf>,

    /// Use the paper's simulation gains (Section IV.A: Γ = 80, H(0),
    /// l = 0.01, γ = 0.1, Γ1, Γ2(0)) and its filter Λ(s) = (s+100)^4 unless
    /// --lambda/--band-hz/--beam is given; 2 modes only. The robust
    /// estimator's start-up law takes the proposed law's gains.
    #[arg(long, conflicts_with = "paper_exp_gains")]
    pub paper_gains: bool,

    /// Use the paper's experimental gains (Section IV.B: Γ = 10, H(0),
    /// l = 0.01, γ = 0.1, Γ1, Γ2(0)) and Λ(s) = (s+100)^4 unless
    /// --lambda/--band-hz/--beam is given; 2 modes only.
    #[arg(long)]
    pub paper_exp_gains: bool,
}

/// The simulated plant (`simulate`, `crlb`).
#[derive(Debug, Clone, Args)]
pub struct PlantArgs {
    /// Number of modes N, 1..=3 [default: 2, or the length of
    /// --omega/--zeta/--bbar/--weights when one is given].
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u8).range(1..=3))]
    pub modes: Option<u8>,

    /// True natural frequencies ω_i in rad/s, comma-separated, strictly
    /// ascending, each > 0 and below the Nyquist frequency π/Ts
    /// [default: the default plant's, see above].
    #[arg(
        long,
        value_name = "W1,W2,...",
        value_delimiter = ',',
        allow_hyphen_values = true
    )]
    pub omega: Option<Vec<f64>>,

    /// True damping ratios ζ_i (dimensionless), comma-separated, each > 0
    /// [default: the default plant's].
    #[arg(
        long,
        value_name = "Z1,Z2,...",
        value_delimiter = ',',
        allow_hyphen_values = true
    )]
    pub zeta: Option<Vec<f64>>,

    /// True modal input gains b̄_i = z_i/m_ii (y-units/(u-units·s²)),
    /// comma-separated, each finite and ≠ 0 [default: the default plant's].
    #[arg(
        long,
        value_name = "B1,B2,...",
        value_delimiter = ',',
        allow_hyphen_values = true
    )]
    pub bbar: Option<Vec<f64>>,

    /// Output weights c_i (row C̄ of eq. 24), comma-separated, each finite and
    /// ≠ 0 [default: c_i = 2·(−1)^i, i.e. −2, 2, −2].
    #[arg(
        long,
        value_name = "C1,C2,...",
        value_delimiter = ',',
        allow_hyphen_values = true
    )]
    pub weights: Option<Vec<f64>>,
}

/// Options of `beamctl simulate`.
#[derive(Debug, Clone, Args)]
pub struct SimulateArgs {
    #[command(flatten)]
    pub est: EstimatorArgs,

    /// Simulated time in seconds (> 0; sampled every --ts).
    #[arg(
        long,
        value_name = "SECONDS",
        default_value_t = 20.0,
        allow_negative_numbers = true
    )]
    pub duration: f64,

    /// Sample interval Ts in seconds (> 0): the simulated plant's, the
    /// estimators' and the drive's.
    #[arg(
        long,
        value_name = "SECONDS",
        default_value_t = 1e-4,
        allow_negative_numbers = true
    )]
    pub ts: f64,

    #[command(flatten)]
    pub plant: PlantArgs,

    #[command(flatten)]
    pub scenario: events_cli::ScenarioArgs,

    #[command(flatten)]
    pub guard: events_cli::GuardArgs,

    /// Add white Gaussian noise to y at this signal-to-noise ratio in dB,
    /// relative to the RMS of the noise-free y over the whole run (the
    /// Cramér–Rao bound's definition) [default: no noise].
    #[arg(long, value_name = "DB", allow_negative_numbers = true)]
    pub snr_db: Option<f64>,

    /// Add white Gaussian noise of this standard deviation to y (units of
    /// y, > 0) instead of giving an SNR.
    #[arg(
        long,
        value_name = "SIGMA",
        allow_hyphen_values = true,
        conflicts_with = "snr_db"
    )]
    pub noise_sd: Option<f64>,

    /// Seed of the measurement noise (used with --snr-db/--noise-sd).
    #[arg(
        long,
        value_name = "N",
        default_value_t = 1,
        allow_negative_numbers = true
    )]
    pub seed: u64,

    /// Run every seed of this list, A..B (both included) or S1,S2,..., and
    /// report per estimator the RMS and mean of the relative errors over
    /// them and RMS ÷ Cramér–Rao bound (needs --snr-db or --noise-sd; with
    /// --json: per-seed reports too).
    #[arg(
        long,
        value_name = "A..B",
        value_parser = parse_seeds,
        conflicts_with_all = ["seed", "csv", "plot"]
    )]
    pub seeds: Option<SeedList>,

    /// The model set of the Cramér–Rao bound reported with noise: tf (the
    /// estimators' 4N − 1 transfer-function coefficients) or modal (ω, ζ,
    /// b̄ with the weights known; see `beamctl crlb --help`) [default: tf].
    #[arg(long, value_enum, value_name = "SET")]
    pub model_set: Option<ModelSetChoice>,

    /// Write every sample to this CSV file: t_s (s), u, y — replayable with
    /// `beamctl replay` — and on every 10th row (1 kHz) the estimates:
    /// theta_0.. (Θ of eq. 29, physical units), omega_1.. (rad/s), zeta_1..,
    /// lambda_rad_s; prefixed by the estimator's name under --estimator all.
    /// Empty fields where there is no estimate.
    #[arg(long, value_name = "FILE")]
    pub csv: Option<PathBuf>,

    /// Plot to this PNG file: ω̂_i and ζ̂_i vs time (truth dashed, one line
    /// per estimator), the largest relative error vs time (log axis) and
    /// the model output vs the measured y over the last 0.5 s.
    #[arg(long, value_name = "FILE.png")]
    pub plot: Option<PathBuf>,

    /// Print one JSON value on stdout instead of the table: the run report
    /// object, or an array of them with --estimator all. Non-finite numbers
    /// are written as null.
    #[arg(long)]
    pub json: bool,

    // The firmware's generators instead of the paper's square wave: the
    // flags of `beamctl send excitation`, shared with it.
    #[command(
        flatten,
        next_help_heading = "Drive: the firmware's generators instead of the paper's square wave (flags of `send excitation`; what is not given is the paper's 0.1 V square at 7 Hz, offset 0)"
    )]
    pub excitation: send::ExcitationArgs,
}

/// Options of `beamctl replay`.
#[derive(Debug, Clone, Args)]
pub struct ReplayArgs {
    /// The recorded samples: a CSV file with a header, plain or
    /// gzip-compressed (see docs/REPLAY.md).
    #[arg(value_name = "FILE.csv")]
    pub file: PathBuf,

    #[command(flatten)]
    pub est: EstimatorArgs,

    #[command(flatten)]
    pub guard: events_cli::GuardArgs,

    /// Columns by header name: T,U,Y, or U,Y with --ts [default: t,u,y;
    /// u,y with --ts].
    #[arg(long, value_name = "T,U,Y", value_delimiter = ',')]
    pub columns: Option<Vec<String>>,

    /// Sample interval in seconds, for a file without a time column.
    #[arg(long, value_name = "SECONDS", allow_negative_numbers = true)]
    pub ts: Option<f64>,

    /// Number of modes N to identify, 1..=3.
    #[arg(long, value_name = "N", default_value_t = 2, value_parser = clap::value_parser!(u8).range(1..=3))]
    pub modes: u8,

    /// Output weights c_i (row C̄ of eq. 24; they set b̄ only),
    /// comma-separated, one per mode, each finite and ≠ 0 [default:
    /// −2, 2, −2].
    #[arg(
        long,
        value_name = "C1,C2,...",
        value_delimiter = ',',
        allow_hyphen_values = true
    )]
    pub weights: Option<Vec<f64>>,

    /// Write the estimates over time to this CSV file: one row per
    /// evaluation (1 kHz of record time), t_s (from the first row), u, y,
    /// then per estimator theta_0.., omega_1.., zeta_1.., lambda_rad_s (as
    /// `beamctl simulate --csv`).
    #[arg(long, value_name = "FILE")]
    pub csv: Option<PathBuf>,

    /// Plot to this PNG file: ω̂_i and ζ̂_i vs time and the model output vs
    /// the measured y over the last 0.5 s of the record.
    #[arg(long, value_name = "FILE.png")]
    pub plot: Option<PathBuf>,

    /// Print one JSON value on stdout instead of the table (an array of
    /// reports with --estimator all). Non-finite numbers are written as null.
    #[arg(long)]
    pub json: bool,

    /// Also compute the Cramér–Rao bound at each final estimate: that
    /// model driven from rest by the recorded u, with white noise of σ =
    /// --noise-sd, or else the a-posteriori noise estimate (the robust
    /// estimator's output-error residual RMS; for the other laws the RMS
    /// of y − ŷ of the model output fit).
    #[arg(long)]
    pub crlb: bool,

    /// σ of the measurement noise on y for --crlb (units of y, > 0).
    #[arg(
        long,
        value_name = "SIGMA",
        allow_hyphen_values = true,
        requires = "crlb"
    )]
    pub noise_sd: Option<f64>,

    /// The model set of --crlb: tf (the estimators' 4N − 1 coefficients) or
    /// modal (ω, ζ, b̄ with the weights known).
    #[arg(
        long,
        value_enum,
        value_name = "SET",
        default_value_t = ModelSetChoice::Tf,
        requires = "crlb"
    )]
    pub model_set: ModelSetChoice,
}

/// Options of `beamctl crlb`.
#[derive(Debug, Clone, Args)]
#[command(group(clap::ArgGroup::new("noise").required(true).args(["snr_db", "noise_sd"])))]
pub struct CrlbArgs {
    #[command(flatten)]
    pub plant: PlantArgs,

    /// Length of the experiment in seconds (> 0; sampled at Ts = 0.1 ms).
    #[arg(
        long,
        value_name = "SECONDS",
        default_value_t = 20.0,
        allow_negative_numbers = true
    )]
    pub duration: f64,

    /// Noise on y as a signal-to-noise ratio in dB, relative to the RMS of
    /// the noise-free y over the whole experiment (as `simulate --snr-db`).
    #[arg(long, value_name = "DB", allow_negative_numbers = true)]
    pub snr_db: Option<f64>,

    /// Noise on y as a standard deviation (units of y, > 0).
    #[arg(long, value_name = "SIGMA", allow_hyphen_values = true)]
    pub noise_sd: Option<f64>,

    /// Which parameters are unknown: tf (the estimators' 4N − 1
    /// transfer-function coefficients) or modal (the paper's ω, ζ, b̄, with
    /// the output and velocity weights known).
    #[arg(long, value_enum, value_name = "SET", default_value_t = ModelSetChoice::Tf)]
    pub model_set: ModelSetChoice,

    /// Print one JSON object on stdout instead of the table.
    #[arg(long)]
    pub json: bool,
}

/// Options of `beamctl model`.
#[derive(Debug, Clone, Args)]
pub struct ModelArgs {
    /// Number of modes, 1..=3.
    #[arg(long, value_name = "N", default_value_t = 2, value_parser = clap::value_parser!(u8).range(1..=3))]
    pub modes: u8,

    /// Print one JSON object on stdout instead of the tables.
    #[arg(long)]
    pub json: bool,

    /// Read the beam from a TOML file instead of the paper's Tables I–II.
    /// Keys (all optional; a missing key takes the paper's value, unknown
    /// keys are an error): density_kg_m3, area_m2, youngs_modulus_pa,
    /// inertia_m4, damping_pa_s, length_m, thickness_m [default:
    /// √(12·inertia_m4/area_m2)], piezo_modulus_pa, piezo_d31_m_v,
    /// moment_arm_m, actuator_start_m, actuator_end_m, output_position_m
    /// [default: length_m, the tip], output = "deflection" | "strain" |
    /// "strain_as_tip_deflection". See beamctl/examples/paper-beam.toml.
    #[arg(long, value_name = "FILE.toml")]
    pub beam: Option<PathBuf>,
}

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
