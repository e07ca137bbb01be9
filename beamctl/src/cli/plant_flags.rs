//! The plant flags of `simulate` and `crlb` (`--modes`, `--omega`,
//! `--zeta`, `--bbar`, `--weights`), validated into a [`PlantSpec`].
//!
//! A list that is not given is taken from the default plant for N modes
//! ([`PlantSpec::default_for_modes`]); with none given the default plant is
//! used as is (for N = 2 the paper's plant with eq. 46's numerator, which
//! is not exactly a modal model with rounded b̄). Every message names the
//! flag it is about.

use crate::cli::args::PlantArgs;
use crate::error::CliError;
use crate::run::plant::PlantSpec;
use beamest::model::ModalParams;

/// Pick the plant and its mode count from `--modes` and the lists.
pub fn resolve(args: &PlantArgs, ts_s: f64) -> Result<(PlantSpec, usize, String), CliError> {
    let lists: [(&str, &Option<Vec<f64>>); 4] = [
        ("--omega", &args.omega),
        ("--zeta", &args.zeta),
        ("--bbar", &args.bbar),
        ("--weights", &args.weights),
    ];
    // Element checks first: they do not depend on N.
    for (flag, list) in &lists {
        for &v in list.iter().flatten() {
            if !v.is_finite() {
                return Err(CliError::usage(
                    flag,
                    format!("values must be finite numbers (got {v})"),
                ));
            }
        }
    }
    let nyquist = std::f64::consts::PI / ts_s;
    if let Some(w) = &args.omega {
        if let Some(&bad) = w.iter().find(|&&v| v <= 0.0) {
            return Err(CliError::usage(
                "--omega",
                format!("natural frequencies must be > 0 rad/s (got {bad})"),
            ));
        }
        if let Some(&bad) = w.iter().find(|&&v| v >= nyquist) {
            return Err(CliError::usage(
                "--omega",
                format!(
                    "natural frequencies must be below the Nyquist frequency π/Ts = {nyquist:.1} rad/s (got {bad})"
                ),
            ));
        }
        if w.windows(2).any(|p| p[1] <= p[0]) {
            return Err(CliError::usage(
                "--omega",
                format!(
                    "natural frequencies must be strictly ascending (got {})",
                    join(w)
                ),
            ));
        }
    }
    if let Some(z) = &args.zeta {
        if let Some(&bad) = z.iter().find(|&&v| v <= 0.0) {
            return Err(CliError::usage(
                "--zeta",
                format!("damping ratios must be > 0 (got {bad})"),
            ));
        }
    }
    for (flag, list, what) in [
        ("--bbar", &args.bbar, "modal input gains"),
        ("--weights", &args.weights, "output weights"),
    ] {
        if list.iter().flatten().any(|&v| v == 0.0) {
            return Err(CliError::usage(
                flag,
                format!("{what} must be non-zero (a zero makes its mode unidentifiable)"),
            ));
        }
    }

    // The mode count: --modes, else the first list given, else 2.
    let first = lists
        .iter()
        .find_map(|(flag, l)| l.as_ref().map(|l| (*flag, l.len())));
    let (modes, source) = match (args.modes, first) {
        (Some(m), _) => (usize::from(m), format!("--modes {m}")),
        (None, Some((flag, len))) => {
            if len > beamest::model::MAX_MODES {
                return Err(CliError::usage(
                    flag,
                    format!(
                        "at most {} modes are supported (got {len} values)",
                        beamest::model::MAX_MODES
                    ),
                ));
            }
            (len, format!("{len} from {flag}"))
        }
        (None, None) => (2, "default 2".to_string()),
    };
    for (flag, list) in &lists {
        if let Some(l) = list {
            if l.len() != modes {
                return Err(CliError::usage(
                    flag,
                    format!(
                        "expected {modes} value{} (one per mode; N = {source}), got {}",
                        if modes == 1 { "" } else { "s" },
                        l.len()
                    ),
                ));
            }
        }
    }

    let default = PlantSpec::default_for_modes(modes)
        .ok_or_else(|| CliError::usage("--modes", format!("{modes} modes (supported: 1, 2, 3)")))?;
    if first.is_none() {
        let label = match modes {
            2 => "the paper's plant (Table III ω, ζ; eq. 46 numerator)".to_string(),
            1 => "the paper plant's first mode".to_string(),
            _ => "the paper's two modes plus a third (687.4 rad/s, ζ = 0.05)".to_string(),
        };
        return Ok((default, modes, label));
    }
    let d = default.truth().modal;
    let pick = |list: &Option<Vec<f64>>, dflt: &[f64]| -> Vec<f64> {
        list.clone().unwrap_or_else(|| dflt[..modes].to_vec())
    };
    let omega = pick(&args.omega, &d.omega_rad_s);
    let zeta = pick(&args.zeta, &d.zeta);
    let bbar = pick(&args.bbar, &d.bbar);
    let weights = pick(&args.weights, &d.output_weight);
    if args.omega.is_none() && omega.windows(2).any(|p| p[1] <= p[0]) {
        // Cannot happen with the shipped defaults; kept as a guard.
        return Err(CliError::usage(
            "--omega",
            "default frequencies are not ascending",
        ));
    }
    let m = ModalParams::new(&omega, &zeta, &bbar, Some(&weights))
        .ok_or_else(|| CliError::usage("--modes", "inconsistent modal parameters"))?;
    let given: Vec<&str> = lists
        .iter()
        .filter(|(_, l)| l.is_some())
        .map(|(f, _)| *f)
        .collect();
    Ok((
        PlantSpec::Modal(m),
        modes,
        format!("modal model (eq. 23) from {}", given.join(", ")),
    ))
}

fn join(v: &[f64]) -> String {
    v.iter()
        .map(|x| x.to_string())
        .collect::<Vec<_>>()
        .join(", ")
}
