//! The options of `beamctl simulate`, `replay` and `crlb` (clap
//! definitions), and the option types they share: the estimator settings
//! of `simulate` and `replay`, the simulated plant of `simulate` and
//! `crlb`, the Cramér–Rao model set and the noise seeds. (`model`,
//! `monitor` and `send` define theirs next to their code:
//! [`crate::cli::model`], [`crate::cli::monitor`], [`crate::cli::send`].)

use crate::cli::event_flags;
use crate::run::estimator::EstimatorKind;
use beam_protocol::OutputKind;
use clap::builder::PossibleValue;
use clap::{Args, ValueEnum};
use std::path::PathBuf;

/// The update law(s) to run: chosen from the data, one estimator, or `all`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum EstimatorChoice {
    /// `replay`: the model chosen from the data
    /// ([`crate::judge::select`]); `simulate`: the robust estimator with
    /// measurement noise, else the adaptive law
    /// ([`crate::cli::simulate::plan::resolve_auto`]).
    Auto,
    /// One estimator.
    One(EstimatorKind),
    /// [`EstimatorKind::ALL`], side by side.
    All,
}

impl ValueEnum for EstimatorChoice {
    fn value_variants<'a>() -> &'a [Self] {
        use EstimatorKind as K;
        &[
            Self::Auto,
            Self::One(K::Adaptive),
            Self::One(K::Gradient),
            Self::One(K::LeastSquares),
            Self::One(K::Robust),
            Self::One(K::Feedthrough),
            Self::All,
        ]
    }

    fn to_possible_value(&self) -> Option<PossibleValue> {
        match self {
            Self::Auto => Some(PossibleValue::new("auto").help(
                "replay: run the candidate models (robust, adaptive and feedthrough laws; 1–3 \
                 modes; level correction off and on) and keep the one the data supports best \
                 (docs/REPLAY.md, \"Model selection\"); simulate: the robust estimator with \
                 --snr-db/--noise-sd, else the adaptive law",
            )),
            Self::One(k) => k.to_possible_value(),
            Self::All => Some(
                PossibleValue::new("all")
                    .help("All four (adaptive, gradient, ls, robust), side by side"),
            ),
        }
    }
}

/// What the sensor measures (`--output`): given, or chosen from the data.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum OutputChoice {
    /// `replay`: chosen from the data, one dimension of the model
    /// selection (docs/REPLAY.md, "Model selection"); `simulate`, `crlb`:
    /// strain.
    #[default]
    Auto,
    /// This kind.
    Given(OutputKind),
}

impl OutputChoice {
    /// The kind, strain for `auto` (where nothing chooses).
    pub fn or_strain(self) -> OutputKind {
        match self {
            Self::Auto => OutputKind::Strain,
            Self::Given(k) => k,
        }
    }
}

impl ValueEnum for OutputChoice {
    fn value_variants<'a>() -> &'a [Self] {
        &[
            Self::Auto,
            Self::Given(OutputKind::Strain),
            Self::Given(OutputKind::Velocity),
            Self::Given(OutputKind::Acceleration),
        ]
    }

    fn to_possible_value(&self) -> Option<PossibleValue> {
        Some(match self {
            Self::Auto => PossibleValue::new("auto").help(
                "replay: chosen from the data (a dimension of the model selection);                  simulate, crlb: strain",
            ),
            Self::Given(OutputKind::Strain) => PossibleValue::new("strain")
                .alias("displacement")
                .help("strain or displacement (relative degree 2): G = B/A, the paper's model"),
            Self::Given(OutputKind::Velocity) => {
                PossibleValue::new("velocity").help("velocity (relative degree 1): G = s·B/A")
            }
            Self::Given(OutputKind::Acceleration) => PossibleValue::new("acceleration")
                .help("acceleration (relative degree 0, a direct term): G = s²·B/A"),
        })
    }
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

/// `--hum HZ:LEVEL,...`: lines in y.
#[derive(Debug, Clone, PartialEq)]
pub struct HumList(pub Vec<crate::run::disturbance::HumLine>);

fn parse_hum(s: &str) -> Result<HumList, String> {
    s.split(',')
        .map(|item| {
            let (f, l) = item
                .split_once(':')
                .ok_or_else(|| format!("'{item}': write HZ:LEVEL (e.g. 50:0.03)"))?;
            let freq_hz: f64 = f
                .trim()
                .parse()
                .map_err(|_| format!("'{f}' is not a frequency in Hz"))?;
            let level: f64 = l.trim().parse().map_err(|_| {
                format!("'{l}' is not a level (the line's RMS ÷ the noise-free y's)")
            })?;
            if !(freq_hz.is_finite() && freq_hz > 0.0) {
                return Err(format!("the frequency must be > 0 Hz (got {f})"));
            }
            if !(level.is_finite() && level >= 0.0) {
                return Err(format!("the level must be a finite number ≥ 0 (got {l})"));
            }
            Ok(crate::run::disturbance::HumLine { freq_hz, level })
        })
        .collect::<Result<_, _>>()
        .map(HumList)
}

/// `--noise-colour white|lowpass:HZ`.
fn parse_colour(s: &str) -> Result<crate::run::disturbance::NoiseColour, String> {
    use crate::run::disturbance::NoiseColour;
    if s == "white" {
        return Ok(NoiseColour::White);
    }
    let hz = s
        .strip_prefix("lowpass:")
        .ok_or_else(|| format!("'{s}': write white or lowpass:HZ"))?;
    let corner_hz: f64 = hz
        .parse()
        .map_err(|_| format!("'{hz}' is not a corner frequency in Hz"))?;
    if !(corner_hz.is_finite() && corner_hz > 0.0) {
        return Err(format!("the corner must be > 0 Hz (got {hz})"));
    }
    Ok(NoiseColour::LowPass { corner_hz })
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
    #[arg(long, value_enum, value_name = "LAW", default_value_t = EstimatorChoice::Auto)]
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

    /// What the sensor measures: the model is s^r·B(s)/A(s), r = 0 for
    /// strain or displacement, 1 for velocity, 2 for acceleration (ω, ζ
    /// and b̄ keep their meaning); `simulate` also simulates that sensor.
    #[arg(long, value_enum, value_name = "KIND", default_value_t = OutputChoice::Auto)]
    pub output: OutputChoice,
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
    /// The estimator settings.
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

    /// The simulated plant.
    #[command(flatten)]
    pub plant: PlantArgs,

    /// The run's events.
    #[command(flatten)]
    pub scenario: event_flags::ScenarioArgs,

    /// The sensor guard's settings.
    #[command(flatten)]
    pub guard: event_flags::GuardArgs,

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

    /// Lines in y that u does not drive (mains hum): HZ:LEVEL,..., LEVEL the
    /// line's RMS ÷ the noise-free y's RMS (e.g. 50:0.03,150:0.01); their
    /// phases come from --seed. No Cramér–Rao bound is computed with them.
    #[arg(long, value_name = "HZ:LEVEL,...", value_parser = parse_hum)]
    pub hum: Option<HumList>,

    /// Spectrum of the measurement noise: white, or lowpass:HZ (the white
    /// noise through a first-order low-pass at HZ with unit power gain:
    /// same σ, flat below HZ, −20 dB/decade above). Needs --snr-db or
    /// --noise-sd; no Cramér–Rao bound is computed with a coloured noise.
    #[arg(long, value_name = "SPECTRUM", value_parser = parse_colour)]
    pub noise_colour: Option<crate::run::disturbance::NoiseColour>,

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
    /// per estimator), the largest relative error vs time (log axis), the
    /// model output vs the measured y over the last 0.5 s, and the
    /// frequency response (the run's measured H1 and coherence under each
    /// model's response, modes marked).
    #[arg(long, value_name = "FILE.png")]
    pub plot: Option<PathBuf>,

    /// Print one JSON value on stdout instead of the table: the run report
    /// object, or an array of them with --estimator all. Non-finite numbers
    /// are written as null.
    #[arg(long)]
    pub json: bool,

    /// The firmware's generators instead of the paper's square wave: the
    /// flags of `beamctl send excitation`, shared with it.
    #[command(
        flatten,
        next_help_heading = "Drive: the firmware's generators instead of the paper's square wave (flags of `send excitation`; what is not given is the paper's 0.1 V square at 7 Hz, offset 0)"
    )]
    pub excitation: crate::link::grammar::ExcitationArgs,
}

/// Options of `beamctl replay`.
#[derive(Debug, Clone, Args)]
pub struct ReplayArgs {
    /// The recorded samples: a CSV file with a header, plain or
    /// gzip-compressed (see docs/REPLAY.md).
    #[arg(value_name = "FILE.csv")]
    pub file: PathBuf,

    /// The estimator settings.
    #[command(flatten)]
    pub est: EstimatorArgs,

    /// The sensor guard's settings.
    #[command(flatten)]
    pub guard: event_flags::GuardArgs,

    /// Columns by header name: T,U,Y, or U,Y with --ts [default: t,u,y;
    /// u,y with --ts].
    #[arg(long, value_name = "T,U,Y", value_delimiter = ',')]
    pub columns: Option<Vec<String>>,

    /// Sample interval in seconds, for a file without a time column.
    #[arg(long, value_name = "SECONDS", allow_negative_numbers = true)]
    pub ts: Option<f64>,

    /// Number of modes N to identify, 1..=3 [default: chosen from the
    /// data with --estimator auto (docs/REPLAY.md, "Model selection"),
    /// else 2].
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u8).range(1..=3))]
    pub modes: Option<u8>,

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

    /// Plot to this PNG file: ω̂_i and ζ̂_i vs time, the model output vs
    /// the measured y over the last 0.5 s of the record, and the frequency
    /// response (the record's measured H1 and coherence under each model's
    /// response, modes marked).
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

    /// Narrow lines in y that u does not drive (the mains): `auto` finds
    /// steady lines in a first fit's residual and removes them (docs/REPLAY.md,
    /// "Lines in y"), `off` leaves y as it is, or a list of frequencies HZ,...
    /// names the lines to remove (each refined within ±1% from the record).
    #[arg(long, value_name = "auto|off|HZ,...", default_value = "auto", value_parser = parse_lines)]
    pub lines: LinesChoice,

    /// The mains frequency (e.g. 50 or 60): remove its harmonics 1–7 below
    /// the Nyquist frequency, each refined within ±1% (as `--lines` with
    /// those frequencies).
    #[arg(long, value_name = "HZ", conflicts_with = "lines")]
    pub mains: Option<f64>,

    /// The lines the second pass removes (set by the line pass, not a flag).
    #[arg(skip)]
    pub removing: Vec<(
        beamest::guard::lines::LineSpec,
        crate::judge::lines::RemovedLine,
    )>,

    /// Coloured measurement noise: `auto` fits an AR model to a first
    /// fit's residual and, when the residual is coloured and not explained
    /// by u, runs again with u and y through the same whitening filter
    /// (docs/REPLAY.md, "Coloured noise"); `off` never does.
    #[arg(long, value_enum, value_name = "auto|off", default_value_t = PrewhitenChoice::Auto)]
    pub prewhiten: PrewhitenChoice,

    /// The noise model whose whitening filter the run applies (set by the
    /// prewhitening pass, not a flag).
    #[arg(skip)]
    pub whitening: Option<crate::judge::noise::NoiseModel>,
}

/// `replay --prewhiten`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum PrewhitenChoice {
    /// Prewhiten when the residual is coloured (the default).
    Auto,
    /// Never.
    Off,
}

/// `replay --lines`.
#[derive(Debug, Clone, PartialEq)]
pub enum LinesChoice {
    /// Detect and remove (the default).
    Auto,
    /// Remove none.
    Off,
    /// Remove these (Hz).
    Named(Vec<f64>),
}

fn parse_lines(s: &str) -> Result<LinesChoice, String> {
    match s {
        "auto" => Ok(LinesChoice::Auto),
        "off" => Ok(LinesChoice::Off),
        _ => {
            let freqs = s
                .split(',')
                .map(|v| {
                    v.trim()
                        .parse::<f64>()
                        .ok()
                        .filter(|f| f.is_finite() && *f > 0.0)
                        .ok_or_else(|| {
                            format!("expected auto, off or frequencies HZ,... > 0 (got `{v}`)")
                        })
                })
                .collect::<Result<Vec<f64>, String>>()?;
            if freqs.len() > beamest::guard::lines::MAX_LINES {
                return Err(format!(
                    "at most {} lines (got {})",
                    beamest::guard::lines::MAX_LINES,
                    freqs.len()
                ));
            }
            Ok(LinesChoice::Named(freqs))
        }
    }
}

/// Options of `beamctl crlb`.
#[derive(Debug, Clone, Args)]
#[command(group(clap::ArgGroup::new("noise").required(true).args(["snr_db", "noise_sd"])))]
pub struct CrlbArgs {
    /// The simulated plant.
    #[command(flatten)]
    pub plant: PlantArgs,

    /// What the sensor measures (as `simulate --output`; `auto` is strain).
    #[arg(long, value_enum, value_name = "KIND", default_value_t = OutputChoice::Auto)]
    pub output: OutputChoice,

    /// Sample interval Ts in seconds (> 0), as `simulate --ts`.
    #[arg(
        long,
        value_name = "SECONDS",
        default_value_t = 1e-4,
        allow_negative_numbers = true
    )]
    pub ts: f64,

    /// Length of the experiment in seconds (> 0).
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

    /// The firmware's generators instead of the paper's square wave, as
    /// `simulate`'s drive flags.
    #[command(
        flatten,
        next_help_heading = "Drive: the firmware's generators instead of the paper's square wave (flags of `send excitation`; what is not given is the paper's 0.1 V square at 7 Hz, offset 0)"
    )]
    pub excitation: crate::link::grammar::ExcitationArgs,
}
