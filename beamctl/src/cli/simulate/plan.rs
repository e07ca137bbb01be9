//! What a `beamctl simulate` invocation will do ([`Plan`]), validated
//! from its flags before anything runs, and how every output describes it:
//! the "run:" and "bound:" heading lines and the settings of each JSON
//! object. Shared by one run ([`crate::cli::simulate`]) and `--seeds`
//! ([`crate::cli::simulate::seeds`]).

use crate::cli::args::{EstimatorArgs, EstimatorChoice, SimulateArgs};
use crate::cli::estimator_flags::{self, EstimatorPlan};
use crate::error::CliError;
use crate::io::plot;
use crate::link::grammar::ExcitationArgs;
use crate::run::estimator::EstimatorKind;
use crate::run::{samples, RunConfig, RunReport};
use beam_protocol as protocol;
use serde::Serialize;

/// Largest accepted `--duration` (s); 10¹⁰ samples already take hours.
const MAX_DURATION_S: f64 = 1.0e6;

/// Everything a `simulate` invocation will do, validated.
#[derive(Debug, Clone)]
pub struct Plan {
    /// Estimator settings (laws, precision, gains, λ source).
    pub est: EstimatorPlan,
    /// Run configuration (its `kind` is not used: `est.kinds` run side by
    /// side).
    pub base: RunConfig,
    /// Number of modes N.
    pub modes: usize,
    /// Human description of the plant.
    pub plant_label: String,
    /// `--seeds`: run every one of these seeds.
    pub seeds: Option<Vec<u64>>,
}

impl Plan {
    /// Samples one run processes (as the runner counts them).
    pub fn samples_per_run(&self) -> u64 {
        samples(&self.base)
    }
}

/// Runs longer than this (simulated seconds) evaluate modal parameters at
/// 100 Hz instead of 1 kHz unless a CSV is requested.
const LONG_RUN_S: f64 = 60.0;

/// Check `--duration` (s) against the sample period `ts`.
pub fn check_duration(duration: f64, ts: f64) -> Result<(), CliError> {
    finite("--duration", duration)?;
    if duration <= 0.0 {
        return Err(CliError::usage(
            "--duration",
            format!("must be > 0 s (got {duration})"),
        ));
    }
    if duration < ts {
        return Err(CliError::usage(
            "--duration",
            format!("must be at least one sample period, {ts} s (got {duration})"),
        ));
    }
    if duration > MAX_DURATION_S {
        return Err(CliError::usage(
            "--duration",
            format!("must be at most {MAX_DURATION_S} s (got {duration})"),
        ));
    }
    Ok(())
}

/// Check a noise level: `--snr-db` finite, `--noise-sd` finite and > 0.
pub fn check_noise(snr_db: Option<f64>, noise_sd: Option<f64>) -> Result<(), CliError> {
    if let Some(snr) = snr_db {
        finite("--snr-db", snr)?;
    }
    if let Some(sd) = noise_sd {
        if !(sd.is_finite() && sd > 0.0) {
            return Err(CliError::usage(
                "--noise-sd",
                format!("the noise standard deviation must be a finite number > 0 (got {sd})"),
            ));
        }
    }
    Ok(())
}

/// `--ts`: a finite number of seconds > 0.
pub(crate) fn check_ts(ts: f64) -> Result<(), CliError> {
    if !(ts.is_finite() && ts > 0.0) {
        return Err(CliError::usage(
            "--ts",
            format!("the sample interval must be a finite number of seconds > 0 (got {ts})"),
        ));
    }
    Ok(())
}

/// `--estimator auto` (the default) for a simulated experiment: the
/// robust estimator when y carries measurement noise (`--snr-db`,
/// `--noise-sd`: its output-error law is consistent under noise, where the
/// paper's law is biased: BENCHMARKS.md, "The noise-robust estimator
/// against the Cramér–Rao bound"), the paper's adaptive law
/// (the firmware's default) on a noise-free run, where both converge to the
/// plant and the adaptive law is the cheaper. A plant that changes during
/// the run (`--step-at`) is the adaptive law's too: the robust estimator's
/// linearization point stops moving when its record is full, so it follows
/// a change with a bias (its module docs, "Limits"). The rule reads the
/// flags that describe the experiment, never the simulated truth; a named
/// estimator or `all` is kept.
pub fn resolve_auto(est: &EstimatorArgs, noisy: bool, plant_changes: bool) -> EstimatorArgs {
    let mut est = est.clone();
    if est.estimator == EstimatorChoice::Auto {
        est.estimator = EstimatorChoice::One(if noisy && !plant_changes {
            EstimatorKind::Robust
        } else {
            EstimatorKind::Adaptive
        });
    }
    est
}

/// Validate the flags.
pub fn plan(args: &SimulateArgs) -> Result<Plan, CliError> {
    let base_default = RunConfig::default();
    let ts = args.ts;
    check_ts(ts)?;

    check_duration(args.duration, ts)?;
    check_noise(args.snr_db, args.noise_sd)?;
    let noisy = args.snr_db.is_some() || args.noise_sd.is_some();
    if !noisy {
        if args.seeds.is_some() {
            return Err(CliError::usage(
                "--seeds",
                "needs measurement noise (--snr-db or --noise-sd): without it every seed is the same run",
            ));
        }
        if args.model_set.is_some() {
            return Err(CliError::usage(
                "--model-set",
                "the Cramér–Rao bound needs measurement noise (--snr-db or --noise-sd); `beamctl crlb` computes it before a run",
            ));
        }
    }
    let hum = args.hum.as_ref().map(|h| h.0.clone()).unwrap_or_default();
    let colour = args.noise_colour.unwrap_or_default();
    let nyquist = 0.5 / ts;
    if let Some(l) = hum.iter().find(|l| l.freq_hz >= nyquist) {
        return Err(CliError::usage(
            "--hum",
            format!(
                "{} Hz is at or above the Nyquist frequency {nyquist} Hz of --ts",
                l.freq_hz
            ),
        ));
    }
    if colour != crate::run::disturbance::NoiseColour::White && !noisy {
        return Err(CliError::usage(
            "--noise-colour",
            "needs measurement noise (--snr-db or --noise-sd) to colour",
        ));
    }
    let white_only = hum.is_empty() && colour == crate::run::disturbance::NoiseColour::White;
    if !white_only && args.model_set.is_some() {
        return Err(CliError::usage(
            "--model-set",
            "the Cramér–Rao bound is computed for white noise only, not with --hum or a coloured --noise-colour",
        ));
    }
    if let Some(seeds) = &args.seeds {
        if seeds.0.is_empty() {
            return Err(CliError::usage("--seeds", "no seed given"));
        }
    }
    if let Some(p) = &args.plot {
        plot::check_extension(p)?;
    }

    let (plant, modes, plant_label) = crate::cli::plant_flags::resolve(&args.plant, ts)?;
    let est = estimator_flags::plan(
        &resolve_auto(&args.est, noisy, args.scenario.step_at.is_some()),
        modes,
    )?;
    let range = crate::cli::event_flags::range(&args.guard)?;
    let events = crate::cli::event_flags::events(
        &args.scenario,
        args.duration,
        &plant,
        range,
        args.est.beam.as_deref(),
    )?;
    if !events.is_empty() && args.model_set.is_some() {
        return Err(CliError::usage(
            "--model-set",
            "the Cramér–Rao bound is not computed with a scenario (plant step, excitation pause, fault, extra modes): the experiment is not the stationary one it describes",
        ));
    }
    let base = RunConfig {
        plant,
        precision: est.precision,
        gains: est.gains,
        duration_s: args.duration,
        ts_s: ts,
        excitation: drive_excitation(&args.excitation)?,
        lambda: est.lambda,
        snr_db: args.snr_db,
        noise_sd: args.noise_sd,
        crlb: (noisy && events.is_empty() && white_only).then(|| {
            args.model_set
                .unwrap_or(crate::cli::args::ModelSetChoice::Tf)
                .set()
        }),
        seed: args.seed,
        // Modal recovery costs ~4–7 µs: at 1 kHz it would dominate an hour
        // of simulation, so long runs without --csv evaluate at 100 Hz
        // (convergence times are then resolved to 10 ms).
        eval_every: if args.csv.is_none() && args.duration > LONG_RUN_S {
            100
        } else {
            base_default.eval_every
        },
        events,
        range,
        level_correction: args.guard.level_correction,
        residual_monitor: args.guard.residual_monitor,
        hum,
        noise_colour: colour,
        output: est.output.or_strain(),
        ..base_default
    };
    if base.excitation.is_some() {
        // Refused settings are named before anything runs.
        crate::run::drive::drive(&base).map_err(|e| CliError::usage("--wave", e))?;
    }
    Ok(Plan {
        est,
        base,
        modes,
        plant_label,
        seeds: args.seeds.as_ref().map(|s| s.0.clone()),
    })
}

/// The firmware's excitation the drive flags describe (None without any:
/// the paper's square wave), what is not given taken from the paper's
/// 0.1 V square wave at 7 Hz ([`protocol::Excitation::default`]).
pub(crate) fn drive_excitation(
    args: &ExcitationArgs,
) -> Result<Option<protocol::Excitation>, CliError> {
    if !args.is_given() {
        return Ok(None);
    }
    args.build(Some(&protocol::Excitation::default()))
        .map(Some)
        .map_err(|e| CliError::usage("--wave", e))
}

/// The drive part of the "run:" line.
pub(crate) fn drive_text(cfg: &RunConfig) -> String {
    match &cfg.excitation {
        None => format!("{}·square({} Hz)", cfg.u_amplitude, cfg.u_freq_hz),
        Some(e) => {
            let text = crate::link::grammar::excitation_text(e);
            format!(
                "the firmware's {}",
                text.strip_prefix("excitation ").unwrap_or(&text)
            )
        }
    }
}

fn finite(flag: &str, v: f64) -> Result<(), CliError> {
    if v.is_finite() {
        Ok(())
    } else {
        Err(CliError::usage(
            flag,
            format!("must be a finite number (got {v})"),
        ))
    }
}

/// One run's report with the settings that produced it (the JSON object).
#[derive(Debug, Serialize)]
pub struct JsonRun<'a> {
    /// What the run measured.
    #[serde(flatten)]
    pub report: &'a RunReport,
    /// Modes of the estimator's model.
    pub modes: usize,
    /// The gain set ([`crate::run::estimator::Gains::name`]).
    pub gains: &'static str,
    /// Sample interval (s).
    pub ts_s: f64,
    /// SNR of the noise on y (dB), if given.
    pub snr_db: Option<f64>,
    /// Noise seed.
    pub seed: u64,
    /// The firmware's excitation driving the run (absent: the paper's
    /// square wave).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub excitation: Option<protocol::Excitation>,
}

/// The noise part of the heading: "none", or the level and σ (and the
/// seed, unless several run).
pub fn noise_text(cfg: &RunConfig, sigma: Option<f64>, seed: Option<u64>) -> String {
    let sigma = sigma.map_or(String::new(), |s| {
        format!("σ = {}", crate::io::table::sig(s, 4))
    });
    let seed = seed.map_or(String::new(), |s| format!(", seed {s}"));
    let colour = match cfg.noise_colour {
        crate::run::disturbance::NoiseColour::White => "white".to_string(),
        crate::run::disturbance::NoiseColour::LowPass { corner_hz } => {
            format!("low-passed at {corner_hz} Hz")
        }
    };
    let mut text = match (cfg.snr_db, cfg.noise_sd) {
        (_, Some(_)) => format!("{colour}, {sigma}{seed}"),
        (Some(snr), None) => format!("{colour}, SNR {snr} dB ({sigma}){seed}"),
        (None, None) => "none".to_string(),
    };
    if !cfg.hum.is_empty() {
        let lines: Vec<String> = cfg
            .hum
            .iter()
            .map(|l| format!("{} Hz at {}", l.freq_hz, l.level))
            .collect();
        text.push_str(&format!("; lines in y (RMS ÷ y's): {}", lines.join(", ")));
    }
    text
}

/// The line naming the bound's model set, σ and SNR.
pub fn bound_line(b: &crate::judge::bound::ExperimentBound, modes: usize) -> String {
    let set = match b.model_set {
        "modal" => beamest::crlb::ModelSet::Modal,
        _ => beamest::crlb::ModelSet::TransferFunction,
    };
    format!(
        "bound:  Cramér–Rao, {}; σ = {}, SNR {:.1} dB over the run\n",
        crate::judge::bound::model_set_description(set, modes),
        crate::io::table::sig(b.sigma, 4),
        b.snr_db
    )
}

/// The "run:" heading line.
pub fn run_line(plan: &Plan, samples: u64, sigma: Option<f64>, seed: Option<u64>) -> String {
    let cfg = &plan.base;
    format!(
        "run:    {} s at Ts = {} ms ({} samples), u = {}, {}, {}, {} gains, noise: {}\n",
        cfg.duration_s,
        cfg.ts_s * 1e3,
        samples,
        drive_text(cfg),
        plan.est.lambda_label,
        match cfg.precision {
            crate::run::Precision::F64 => "f64",
            crate::run::Precision::F32 => "f32",
        },
        cfg.gains.name(),
        noise_text(cfg, sigma, seed)
    )
}
