//! The scenario flags of `beamctl simulate` (`--step-at`, `--step-omega`,
//! `--step-zeta`, `--excitation-off`, `--fault`, `--fault-at`,
//! `--fault-for`, `--fault-level`, `--truth-modes`) and the sensor-guard
//! flags of `simulate` and `replay` (`--range`, `--level-correction`),
//! validated into [`crate::run::events::Events`] and the guard's settings.
//! Every message is one line naming the flag it is about.

use crate::error::CliError;
use crate::run::events::{extra_beam_modes, Events, FaultChoice, FaultEvent, StepEvent};
use crate::run::plant::PlantSpec;
use beamest::beam::BeamParams;
use clap::{Args, ValueEnum};
use std::path::Path;

/// Most modes `--truth-modes` simulates (the beam's 1st to 4th).
pub const MAX_TRUTH_MODES: usize = 4;

/// `--fault` on the command line.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum FaultArg {
    /// y reads NaN.
    Nan,
    /// y reads ± the converter's full scale (needs --range).
    Saturate,
    /// y freezes at its last value.
    Stuck,
    /// y reads the positive rail of --range (open gauge).
    Open,
    /// A step of y's offset (--fault-level, units of y).
    Offset,
    /// A ramp of y's offset (--fault-level, units of y per second).
    Drift,
}

impl FaultArg {
    fn choice(self) -> FaultChoice {
        match self {
            Self::Nan => FaultChoice::Nan,
            Self::Saturate => FaultChoice::Saturate,
            Self::Stuck => FaultChoice::Stuck,
            Self::Open => FaultChoice::Open,
            Self::Offset => FaultChoice::Offset,
            Self::Drift => FaultChoice::Drift,
        }
    }
}

/// Events of a simulated run.
#[derive(Debug, Clone, Args)]
pub struct ScenarioArgs {
    /// Change the plant at this time (s, inside the run): its ω and/or ζ
    /// become --step-omega / --step-zeta (b̄ and the state kept); the
    /// report's truth and errors are the new plant's, and it gives the
    /// tracking time (to 1% and 0.1% of the new plant).
    #[arg(long, value_name = "SECONDS", allow_negative_numbers = true)]
    pub step_at: Option<f64>,

    /// The natural frequencies after --step-at (rad/s, one per mode,
    /// ascending, each > 0).
    #[arg(
        long,
        value_name = "W1,W2,...",
        value_delimiter = ',',
        allow_hyphen_values = true
    )]
    pub step_omega: Option<Vec<f64>>,

    /// The damping ratios after --step-at (one per mode, each in (0, 1)).
    #[arg(
        long,
        value_name = "Z1,Z2,...",
        value_delimiter = ',',
        allow_hyphen_values = true
    )]
    pub step_zeta: Option<Vec<f64>>,

    /// Replace the drive by 0 over [FROM, TO) (s, inside the run): the
    /// supervisor flags the input as gone and freezes adaptation.
    #[arg(
        long,
        value_name = "FROM,TO",
        value_delimiter = ',',
        allow_hyphen_values = true
    )]
    pub excitation_off: Option<Vec<f64>>,

    /// A sensor fault on the measured y, from --fault-at for --fault-for:
    /// nan, saturate (± the full scale of --range), stuck, open (the
    /// positive rail of --range), offset (a step of --fault-level), drift
    /// (a ramp of --fault-level per second).
    #[arg(long, value_enum, value_name = "KIND", requires = "fault_at")]
    pub fault: Option<FaultArg>,

    /// When the sensor fault starts (s, inside the run).
    #[arg(
        long,
        value_name = "SECONDS",
        allow_negative_numbers = true,
        requires = "fault"
    )]
    pub fault_at: Option<f64>,

    /// How long the sensor fault lasts (s, > 0) [default: to the end].
    #[arg(
        long,
        value_name = "SECONDS",
        allow_negative_numbers = true,
        requires = "fault"
    )]
    pub fault_for: Option<f64>,

    /// The offset step (units of y) of --fault offset, or the slope (units
    /// of y per second) of --fault drift [default: 0.5 × (offset) or 0.1 ×
    /// (drift, per second) the RMS of the noise-free y over the run].
    #[arg(
        long,
        value_name = "VALUE",
        allow_negative_numbers = true,
        requires = "fault"
    )]
    pub fault_level: Option<f64>,

    /// Simulate a beam of N modes for the estimator's model of fewer
    /// (N ≥ the model's modes, ≤ 4): the extra modes are the physical
    /// beam's (Euler–Bernoulli model, eqs. 19–24, 49–57) — from --beam if
    /// given, else the paper's beam (Tables I–II), e.g. its 3rd and 4th for
    /// a 2-mode model — with b̄ scaled so that the beam's first mode has
    /// the simulated plant's gain c_1·b̄_1.
    #[arg(long, value_name = "N")]
    pub truth_modes: Option<usize>,
}

/// The sensor guard's settings (`simulate`, `replay`).
#[derive(Debug, Clone, Args)]
pub struct GuardArgs {
    /// The converter's rails in units of y, LO,HI (LO < HI): samples at or
    /// beyond them are counted as saturated (reached with the signal) or
    /// open (jumped to) and kept from the estimator [default: unknown; a
    /// reading held at a rail then counts as stuck].
    #[arg(
        long,
        value_name = "LO,HI",
        value_delimiter = ',',
        allow_hyphen_values = true
    )]
    pub range: Option<Vec<f64>>,

    /// Remove y's offset steps and filter u and y by the guard's DC-removing
    /// high-pass (3 rad/s, second order; identical on u and y, so the
    /// estimate is unchanged), so that an offset or a drift of the gauge
    /// does not bias the estimate [default: replay --estimator auto: chosen
    /// from the data (docs/REPLAY.md, "Model selection"); otherwise off, as
    /// on the firmware].
    #[arg(long, conflicts_with = "no_level_correction")]
    pub level_correction: bool,

    /// Never correct the level (see --level-correction).
    #[arg(long)]
    pub no_level_correction: bool,

    /// Also test for sensor faults on the model's equation error (the
    /// guard's residual monitor, 2-mode models): offset steps below the
    /// raw test's threshold and drift onsets within milliseconds, with the
    /// first estimator's Θ̂ once it is excited and settled. Host only
    /// [default: off, as on the firmware].
    #[arg(long)]
    pub residual_monitor: bool,
}

/// `--range` as [min, max].
pub fn range(args: &GuardArgs) -> Result<Option<[f64; 2]>, CliError> {
    let Some(r) = &args.range else {
        return Ok(None);
    };
    match r.as_slice() {
        [lo, hi] if lo.is_finite() && hi.is_finite() && lo < hi => Ok(Some([*lo, *hi])),
        [_, _] => Err(CliError::usage(
            "--range",
            format!("need finite LO < HI (got {})", join(r)),
        )),
        _ => Err(CliError::usage(
            "--range",
            format!("expected two values LO,HI (got {})", r.len()),
        )),
    }
}

fn join(v: &[f64]) -> String {
    v.iter().map(f64::to_string).collect::<Vec<_>>().join(",")
}

/// A time inside the run: 0 ≤ t < duration.
fn inside(flag: &str, t: f64, duration: f64) -> Result<(), CliError> {
    if !(t.is_finite() && t >= 0.0 && t < duration) {
        return Err(CliError::usage(
            flag,
            format!("must be a time inside the run, 0 ≤ t < {duration} s (got {t})"),
        ));
    }
    Ok(())
}

/// Validate the scenario flags for a run of `duration` s on `plant`
/// (`modes` modes), with the guard's `range` and the `--beam` file.
pub fn events(
    args: &ScenarioArgs,
    duration: f64,
    plant: &PlantSpec,
    range: Option<[f64; 2]>,
    beam: Option<&Path>,
) -> Result<Events, CliError> {
    let modes = plant.modes();
    let mut ev = Events::default();
    match (args.step_at, &args.step_omega, &args.step_zeta) {
        (None, Some(_), _) => {
            return Err(CliError::usage("--step-omega", "needs --step-at SECONDS"));
        }
        (None, None, Some(_)) => {
            return Err(CliError::usage("--step-zeta", "needs --step-at SECONDS"));
        }
        (Some(_), None, None) => {
            return Err(CliError::usage(
                "--step-at",
                "needs the new plant: --step-omega and/or --step-zeta",
            ));
        }
        (Some(at), w, z) => {
            inside("--step-at", at, duration)?;
            if at == 0.0 {
                return Err(CliError::usage(
                    "--step-at",
                    "must be after the start (> 0 s); to simulate another plant use --omega/--zeta",
                ));
            }
            if let Some(w) = w {
                check_list("--step-omega", w, modes)?;
                if let Some(&bad) = w.iter().find(|v| **v <= 0.0) {
                    return Err(CliError::usage(
                        "--step-omega",
                        format!("natural frequencies must be > 0 rad/s (got {bad})"),
                    ));
                }
                if w.windows(2).any(|p| p[1] <= p[0]) {
                    return Err(CliError::usage(
                        "--step-omega",
                        format!("must be strictly ascending (got {})", join(w)),
                    ));
                }
            }
            if let Some(z) = z {
                check_list("--step-zeta", z, modes)?;
                if let Some(&bad) = z.iter().find(|v| **v <= 0.0 || **v >= 1.0) {
                    return Err(CliError::usage(
                        "--step-zeta",
                        format!("damping ratios must be in (0, 1) (got {bad})"),
                    ));
                }
            }
            ev.step = Some(StepEvent {
                at_s: at,
                omega_rad_s: w.clone(),
                zeta: z.clone(),
            });
        }
        (None, None, None) => {}
    }
    if let Some(w) = &args.excitation_off {
        let [from, to] = w.as_slice() else {
            return Err(CliError::usage(
                "--excitation-off",
                format!("expected two times FROM,TO in s (got {} values)", w.len()),
            ));
        };
        if !(from.is_finite() && to.is_finite() && *from >= 0.0 && from < to && *to <= duration) {
            return Err(CliError::usage(
                "--excitation-off",
                format!(
                    "the window must lie inside the run, 0 ≤ FROM < TO ≤ {duration} s (got {})",
                    join(w)
                ),
            ));
        }
        ev.excitation_off = Some((*from, *to));
    }
    if let (Some(kind), Some(at)) = (args.fault, args.fault_at) {
        inside("--fault-at", at, duration)?;
        if let Some(d) = args.fault_for {
            if !(d.is_finite() && d > 0.0) {
                return Err(CliError::usage(
                    "--fault-for",
                    format!("must be a duration > 0 s (got {d})"),
                ));
            }
            if at + d > duration + 1e-12 {
                return Err(CliError::usage(
                    "--fault-for",
                    format!(
                        "the fault window {at}–{} s ends after the run ({duration} s)",
                        at + d
                    ),
                ));
            }
        }
        let choice = kind.choice();
        if let Some(l) = args.fault_level {
            if !matches!(choice, FaultChoice::Offset | FaultChoice::Drift) {
                return Err(CliError::usage(
                    "--fault-level",
                    "only for --fault offset or --fault drift",
                ));
            }
            if !(l.is_finite() && l != 0.0) {
                return Err(CliError::usage(
                    "--fault-level",
                    format!("must be a finite non-zero number (got {l})"),
                ));
            }
        }
        if choice.needs_range() && range.is_none() {
            return Err(CliError::usage(
                "--fault",
                format!(
                    "{} needs --range LO,HI (the converter's rails, in units of y)",
                    choice.name()
                ),
            ));
        }
        ev.fault = Some(FaultEvent {
            kind: choice,
            at_s: at,
            for_s: args.fault_for,
            level: args.fault_level,
        });
    }
    if let Some(n) = args.truth_modes {
        if n < modes {
            return Err(CliError::usage(
                "--truth-modes",
                format!("must be at least the estimator's {modes} modes (got {n})"),
            ));
        }
        if n > MAX_TRUTH_MODES {
            return Err(CliError::usage(
                "--truth-modes",
                format!("at most {MAX_TRUTH_MODES} modes (got {n})"),
            ));
        }
        if n > modes {
            let params = match beam {
                Some(p) => crate::cli::model::load(p)?,
                None => BeamParams::paper(),
            };
            let extra = extra_beam_modes(&params, modes + 1, n, &plant.truth())
                .map_err(|e| CliError::usage("--truth-modes", e))?;
            ev.extra_modes = Some(extra);
        }
    }
    Ok(ev)
}

fn check_list(flag: &str, v: &[f64], modes: usize) -> Result<(), CliError> {
    if v.len() != modes {
        return Err(CliError::usage(
            flag,
            format!("expected {modes} values (one per mode), got {}", v.len()),
        ));
    }
    if let Some(&bad) = v.iter().find(|x| !x.is_finite()) {
        return Err(CliError::usage(
            flag,
            format!("values must be finite numbers (got {bad})"),
        ));
    }
    Ok(())
}
