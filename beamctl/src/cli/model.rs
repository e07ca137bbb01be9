//! `beamctl model`: the physical beam's modal model (Section II, Appendix).
//!
//! [`BeamParams::paper`] (Tables I–II plus its documented assumptions) or a
//! TOML file mirroring [`BeamParams`]' fields goes through
//! [`BeamParams::modal`] (eqs. 19–24, 49–57) to β_iL, ω_i, ζ_i, m_ii, k_ii,
//! c_ii, z_i, b̄_i, c_i and the transfer function a, b (eqs. 25–26).
//!
//! # TOML
//! Every key is optional; a missing key takes the paper's value, except two
//! derived ones that follow the file's other keys: `thickness_m` defaults to
//! √(12·inertia_m4/area_m2) (solid rectangle, as for the paper) and
//! `output_position_m` to `length_m` (the tip). Unknown keys are an error.
//! The mirror struct lives here so the core stays serde-free.

use crate::error::write_stdout;
use crate::error::CliError;
use crate::io::table::{short, sig, Column, Table};
use beamest::beam::{
    rectangular_thickness_m, BeamError, BeamModal, BeamOutput, BeamParam, BeamParams,
};
use clap::Args;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// [`BeamOutput`] as spelled in TOML and JSON.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum OutputKind {
    /// Deflection w(x_s) (m).
    Deflection,
    /// Surface strain at x_s.
    Strain,
    /// Eq. 17 applied to the strain at x_s (m).
    StrainAsTipDeflection,
}

impl From<OutputKind> for BeamOutput {
    fn from(k: OutputKind) -> Self {
        match k {
            OutputKind::Deflection => BeamOutput::Deflection,
            OutputKind::Strain => BeamOutput::Strain,
            OutputKind::StrainAsTipDeflection => BeamOutput::StrainAsTipDeflection,
        }
    }
}

impl From<BeamOutput> for OutputKind {
    fn from(k: BeamOutput) -> Self {
        match k {
            BeamOutput::Deflection => OutputKind::Deflection,
            BeamOutput::Strain => OutputKind::Strain,
            BeamOutput::StrainAsTipDeflection => OutputKind::StrainAsTipDeflection,
        }
    }
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

/// The beam file: [`BeamParams`]' fields, all optional.
#[derive(Debug, Clone, Default, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct BeamFile {
    /// ρ (kg/m³).
    pub density_kg_m3: Option<f64>,
    /// A (m²).
    pub area_m2: Option<f64>,
    /// E (Pa).
    pub youngs_modulus_pa: Option<f64>,
    /// I (m⁴).
    pub inertia_m4: Option<f64>,
    /// Kelvin–Voigt C (Pa·s).
    pub damping_pa_s: Option<f64>,
    /// L (m).
    pub length_m: Option<f64>,
    /// h (m).
    pub thickness_m: Option<f64>,
    /// E_p (Pa).
    pub piezo_modulus_pa: Option<f64>,
    /// d31 (m/V).
    pub piezo_d31_m_v: Option<f64>,
    /// r_a (m).
    pub moment_arm_m: Option<f64>,
    /// x_a (m).
    pub actuator_start_m: Option<f64>,
    /// x_b (m).
    pub actuator_end_m: Option<f64>,
    /// x_s (m).
    pub output_position_m: Option<f64>,
    /// Output quantity.
    pub output: Option<OutputKind>,
}

impl BeamFile {
    /// Fill the missing keys (see the module docs).
    pub fn resolve(&self) -> BeamParams {
        let p = BeamParams::paper();
        let area_m2 = self.area_m2.unwrap_or(p.area_m2);
        let inertia_m4 = self.inertia_m4.unwrap_or(p.inertia_m4);
        let length_m = self.length_m.unwrap_or(p.length_m);
        BeamParams {
            density_kg_m3: self.density_kg_m3.unwrap_or(p.density_kg_m3),
            area_m2,
            youngs_modulus_pa: self.youngs_modulus_pa.unwrap_or(p.youngs_modulus_pa),
            inertia_m4,
            damping_pa_s: self.damping_pa_s.unwrap_or(p.damping_pa_s),
            length_m,
            thickness_m: self
                .thickness_m
                .unwrap_or_else(|| rectangular_thickness_m(area_m2, inertia_m4)),
            piezo_modulus_pa: self.piezo_modulus_pa.unwrap_or(p.piezo_modulus_pa),
            piezo_d31_m_v: self.piezo_d31_m_v.unwrap_or(p.piezo_d31_m_v),
            moment_arm_m: self.moment_arm_m.unwrap_or(p.moment_arm_m),
            actuator_start_m: self.actuator_start_m.unwrap_or(p.actuator_start_m),
            actuator_end_m: self.actuator_end_m.unwrap_or(p.actuator_end_m),
            output_position_m: self.output_position_m.unwrap_or(length_m),
            output: self.output.map_or(p.output, BeamOutput::from),
        }
    }

    /// Every field of `p`, for printing.
    pub fn from_params(p: &BeamParams) -> Self {
        Self {
            density_kg_m3: Some(p.density_kg_m3),
            area_m2: Some(p.area_m2),
            youngs_modulus_pa: Some(p.youngs_modulus_pa),
            inertia_m4: Some(p.inertia_m4),
            damping_pa_s: Some(p.damping_pa_s),
            length_m: Some(p.length_m),
            thickness_m: Some(p.thickness_m),
            piezo_modulus_pa: Some(p.piezo_modulus_pa),
            piezo_d31_m_v: Some(p.piezo_d31_m_v),
            moment_arm_m: Some(p.moment_arm_m),
            actuator_start_m: Some(p.actuator_start_m),
            actuator_end_m: Some(p.actuator_end_m),
            output_position_m: Some(p.output_position_m),
            output: Some(p.output.into()),
        }
    }
}

/// Parse a beam file's text; `origin` names it in messages.
pub fn parse_beam(text: &str, origin: &str) -> Result<BeamParams, CliError> {
    let file: BeamFile = toml::from_str(text).map_err(|e| {
        let at = e
            .span()
            .map(|s| {
                let (line, col) = line_col(text, s.start);
                format!("line {line}, column {col}: ")
            })
            .unwrap_or_default();
        CliError::usage("--beam", format!("{origin}: {at}{}", e.message()))
    })?;
    Ok(file.resolve())
}

fn line_col(text: &str, offset: usize) -> (usize, usize) {
    let before = &text[..offset.min(text.len())];
    let line = before.matches('\n').count() + 1;
    let col = before.rsplit('\n').next().map_or(0, |l| l.chars().count()) + 1;
    (line, col)
}

/// The TOML key a [`BeamParam`] comes from.
fn key(p: BeamParam) -> &'static str {
    match p {
        BeamParam::Density => "density_kg_m3",
        BeamParam::Area => "area_m2",
        BeamParam::YoungsModulus => "youngs_modulus_pa",
        BeamParam::Inertia => "inertia_m4",
        BeamParam::Damping => "damping_pa_s",
        BeamParam::Length => "length_m",
        BeamParam::Thickness => "thickness_m",
        BeamParam::PiezoModulus => "piezo_modulus_pa",
        BeamParam::PiezoD31 => "piezo_d31_m_v",
        BeamParam::MomentArm => "moment_arm_m",
        BeamParam::GaugeLeverArm => "output_position_m",
        BeamParam::Measurement => "(measurement)",
    }
}

/// A one-line explanation of a [`BeamError`] in terms of the file's keys.
pub fn explain(e: BeamError, p: &BeamParams) -> String {
    match e {
        BeamError::InvalidParameter(BeamParam::Damping) => format!(
            "damping_pa_s must be finite and ≥ 0 (got {})",
            p.damping_pa_s
        ),
        BeamError::InvalidParameter(BeamParam::PiezoD31) => format!(
            "piezo_d31_m_v must be finite and non-zero (got {})",
            p.piezo_d31_m_v
        ),
        BeamError::InvalidParameter(which) => {
            let v = match which {
                BeamParam::Density => p.density_kg_m3,
                BeamParam::Area => p.area_m2,
                BeamParam::YoungsModulus => p.youngs_modulus_pa,
                BeamParam::Inertia => p.inertia_m4,
                BeamParam::Length => p.length_m,
                BeamParam::Thickness => p.thickness_m,
                BeamParam::PiezoModulus => p.piezo_modulus_pa,
                BeamParam::MomentArm => p.moment_arm_m,
                _ => f64::NAN,
            };
            format!("{} must be finite and > 0 (got {v})", key(which))
        }
        BeamError::ActuatorSpan => format!(
            "the actuator span needs 0 ≤ actuator_start_m < actuator_end_m ≤ length_m (got {} .. {} with length_m = {})",
            p.actuator_start_m, p.actuator_end_m, p.length_m
        ),
        BeamError::OutputPosition => format!(
            "output_position_m must be within [0, length_m] (and < length_m for strain_as_tip_deflection) (got {} with length_m = {})",
            p.output_position_m, p.length_m
        ),
        BeamError::ModeCount => "the mode count must be 1..=3".to_string(),
        BeamError::ModeNumber => "mode numbers are 1-based".to_string(),
        BeamError::RootNotConverged => {
            "the frequency equation (eq. 20) did not converge".to_string()
        }
        BeamError::NonFinite => {
            "the parameters are too extreme: a modal quantity is not finite".to_string()
        }
    }
}

/// The JSON document of `model --json`.
#[derive(Debug, Serialize)]
struct ModelJson {
    source: String,
    beam: BeamFile,
    width_m: f64,
    modes: usize,
    beta_l: Vec<f64>,
    omega_rad_s: Vec<f64>,
    frequency_hz: Vec<f64>,
    zeta: Vec<f64>,
    mass_kg: Vec<f64>,
    stiffness_n_m: Vec<f64>,
    damping_n_s_m: Vec<f64>,
    input_z: Vec<f64>,
    bbar: Vec<f64>,
    output_weight: Vec<f64>,
    tf: TfJson,
}

/// Transfer function coefficients, highest power first (eq. 25).
#[derive(Debug, Serialize)]
struct TfJson {
    a: Vec<f64>,
    b: Vec<f64>,
}

/// Run `beamctl model`.
pub fn run(args: &ModelArgs) -> Result<(), CliError> {
    write_stdout(&output(args)?)
}

/// What `beamctl model` prints (the JSON document with `--json`).
pub fn output(args: &ModelArgs) -> Result<String, CliError> {
    let (params, source) = match &args.beam {
        None => (
            BeamParams::paper(),
            "the paper's beam (Tables I–II)".to_string(),
        ),
        Some(path) => (load(path)?, path.display().to_string()),
    };
    let modes = usize::from(args.modes);
    let modal = params.modal(modes).map_err(|e| match &args.beam {
        Some(path) => CliError::usage(
            "--beam",
            format!("{}: {}", path.display(), explain(e, &params)),
        ),
        None => CliError::failure(format!("the paper's beam: {}", explain(e, &params))),
    })?;
    let text = if args.json {
        let doc = json_doc(&params, &modal, source);
        serde_json::to_string_pretty(&doc).map_err(|e| CliError::failure(format!("--json: {e}")))?
            + "\n"
    } else {
        render(&params, &modal, &source)
    };
    Ok(text)
}

/// The beam of a TOML file (`--beam`; keys: [`BeamFile`]).
pub fn load(path: &Path) -> Result<BeamParams, CliError> {
    let text = std::fs::read_to_string(path)
        .map_err(|e| CliError::usage("--beam", format!("cannot read {}: {e}", path.display())))?;
    parse_beam(&text, &path.display().to_string())
}

fn json_doc(p: &BeamParams, m: &BeamModal, source: String) -> ModelJson {
    let n = m.modes;
    let v = |a: &[f64]| a[..n].to_vec();
    let tf = m.transfer_function();
    ModelJson {
        source,
        beam: BeamFile::from_params(p),
        width_m: p.width_m(),
        modes: n,
        beta_l: v(&m.beta_l),
        omega_rad_s: v(&m.omega_rad_s),
        frequency_hz: m.omega_rad_s[..n]
            .iter()
            .map(|w| w / std::f64::consts::TAU)
            .collect(),
        zeta: v(&m.zeta),
        mass_kg: v(&m.mass_kg),
        stiffness_n_m: v(&m.stiffness_n_m),
        damping_n_s_m: v(&m.damping_n_s_m),
        input_z: v(&m.input_z),
        bbar: v(&m.bbar),
        output_weight: v(&m.output_weight),
        tf: TfJson {
            a: tf.a[..2 * n].to_vec(),
            b: tf.b[..2 * n - 1].to_vec(),
        },
    }
}

/// A polynomial of degree `deg` written out with coefficient names
/// `prefix{k}`: "a3·s^3 + … + a0", monic ("s^4 + a3·s^3 + …") if asked.
fn poly(prefix: &str, deg: usize, monic: bool) -> String {
    let power = |k: usize| match k {
        0 => String::new(),
        1 => "s".to_string(),
        _ => format!("s^{k}"),
    };
    let mut terms = Vec::new();
    if monic {
        terms.push(power(deg));
    }
    let top = if monic { deg.saturating_sub(1) } else { deg };
    for k in (0..=top).rev() {
        let p = power(k);
        terms.push(if p.is_empty() {
            format!("{prefix}{k}")
        } else {
            format!("{prefix}{k}·{p}")
        });
    }
    terms.join(" + ")
}

/// The text report: beam data, per-mode table, transfer function.
fn render(p: &BeamParams, m: &BeamModal, source: &str) -> String {
    let n = m.modes;
    let mut out = format!("beam: {source}\n");
    let output = match p.output {
        BeamOutput::Deflection => "deflection w(x_s) (m)",
        BeamOutput::Strain => "surface strain at x_s",
        BeamOutput::StrainAsTipDeflection => "eq. 17 tip deflection from the strain at x_s (m)",
    };
    let data: [(&str, String); 14] = [
        ("density ρ", format!("{} kg/m³", short(p.density_kg_m3, 6))),
        ("area A", format!("{} m²", short(p.area_m2, 6))),
        (
            "Young's modulus E",
            format!("{} Pa", short(p.youngs_modulus_pa, 6)),
        ),
        ("inertia I", format!("{} m⁴", short(p.inertia_m4, 6))),
        ("damping C", format!("{} Pa·s", short(p.damping_pa_s, 6))),
        ("length L", format!("{} m", short(p.length_m, 6))),
        (
            "thickness h (width b)",
            format!(
                "{} m ({} m)",
                short(p.thickness_m, 6),
                short(p.width_m(), 6)
            ),
        ),
        (
            "piezo modulus E_p",
            format!("{} Pa", short(p.piezo_modulus_pa, 6)),
        ),
        ("piezo d31", format!("{} m/V", short(p.piezo_d31_m_v, 6))),
        ("moment arm r_a", format!("{} m", short(p.moment_arm_m, 6))),
        (
            "actuator x_a",
            format!("{} m", short(p.actuator_start_m, 6)),
        ),
        ("actuator x_b", format!("{} m", short(p.actuator_end_m, 6))),
        (
            "output position x_s",
            format!("{} m", short(p.output_position_m, 6)),
        ),
        ("output", output.to_string()),
    ];
    for (k, v) in data {
        out.push_str(&format!("  {k:<22} {v}\n"));
    }
    out.push('\n');

    let mut t = Table::new();
    t.group("", vec![Column::text("quantity"), Column::text("unit")]);
    t.group(
        "",
        (1..=n).map(|i| Column::num(&format!("mode {i}"))).collect(),
    );
    let rows: [(&str, &str, &[f64]); 10] = [
        ("β_iL (eq. 20)", "", &m.beta_l),
        ("ω_i", "rad/s", &m.omega_rad_s),
        ("ζ_i", "", &m.zeta),
        ("m_ii (eq. 54)", "kg", &m.mass_kg),
        ("k_ii (eq. 56)", "N/m", &m.stiffness_n_m),
        ("c_ii (eq. 55)", "N·s/m", &m.damping_n_s_m),
        ("z_i (eq. 57)", "N/(V·m)", &m.input_z),
        ("b̄_i = z_i/m_ii", "1/(V·s²)", &m.bbar),
        ("c_i (output weight)", "", &m.output_weight),
        ("f_i = ω_i/2π", "Hz", &m.omega_rad_s),
    ];
    for (name, unit, vals) in rows {
        let scale = if unit == "Hz" {
            1.0 / std::f64::consts::TAU
        } else {
            1.0
        };
        let mut row = vec![name.to_string(), unit.to_string()];
        row.extend(vals[..n].iter().map(|v| sig(v * scale, 7)));
        t.row(row);
    }
    out.push_str(&t.render());
    out.push_str(
        "z_i and b̄_i are per metre of patch width: eq. 8's actuator moment omits the width.\n",
    );

    let tf = m.transfer_function();
    let d = 2 * n;
    let names = |prefix: &str, top: usize| -> String {
        (0..=top)
            .rev()
            .map(|k| format!("{prefix}{k}"))
            .collect::<Vec<_>>()
            .join(", ")
    };
    let vals = |v: &[f64]| v.iter().map(|x| sig(*x, 7)).collect::<Vec<_>>().join(", ");
    out.push_str(&format!(
        "\ntransfer function (eqs. 25–26): G(s) = ({}) / ({})\n",
        poly("b", d - 2, false),
        poly("a", d, true)
    ));
    out.push_str(&format!(
        "  a = [{}] = [{}]\n",
        names("a", d - 1),
        vals(&tf.a[..d])
    ));
    out.push_str(&format!(
        "  b = [{}] = [{}]\n",
        names("b", d - 2),
        vals(&tf.b[..d - 1])
    ));
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn empty_file_is_the_paper_beam() {
        assert_eq!(parse_beam("", "x").unwrap(), BeamParams::paper());
    }

    #[test]
    fn sample_file_is_the_paper_beam() {
        let text = include_str!("../../examples/paper-beam.toml");
        let p = parse_beam(text, "paper-beam.toml").unwrap();
        let q = BeamParams::paper();
        assert_eq!(p.output, q.output);
        assert!((p.thickness_m / q.thickness_m - 1.0).abs() < 1e-12);
        assert_eq!(
            BeamParams {
                thickness_m: q.thickness_m,
                ..p
            },
            q
        );
    }

    #[test]
    fn derived_defaults_follow_the_file() {
        let p = parse_beam("length_m = 0.5\narea_m2 = 1.2e-4", "x").unwrap();
        assert_eq!(p.output_position_m, 0.5);
        assert_eq!(p.thickness_m, rectangular_thickness_m(1.2e-4, 6.67e-12));
        let p = parse_beam("output = \"strain\"\noutput_position_m = 0.02", "x").unwrap();
        assert_eq!(p.output, BeamOutput::Strain);
    }

    #[test]
    fn unknown_keys_and_bad_types_name_the_line() {
        let e = parse_beam("length_m = 0.36\nlenght_m = 1", "f.toml").unwrap_err();
        assert!(
            e.message.starts_with("--beam: f.toml: line 2"),
            "{}",
            e.message
        );
        assert!(e.message.contains("lenght_m"), "{}", e.message);
        let e = parse_beam("density_kg_m3 = \"heavy\"", "f.toml").unwrap_err();
        assert!(e.message.contains("line 1"), "{}", e.message);
    }

    #[test]
    fn invalid_values_are_explained() {
        let p = parse_beam("density_kg_m3 = -1", "x").unwrap();
        let e = p.modal(2).unwrap_err();
        assert_eq!(
            explain(e, &p),
            "density_kg_m3 must be finite and > 0 (got -1)"
        );
    }

    #[test]
    fn polynomials_are_written_out() {
        assert_eq!(poly("a", 4, true), "s^4 + a3·s^3 + a2·s^2 + a1·s + a0");
        assert_eq!(poly("b", 2, false), "b2·s^2 + b1·s + b0");
        assert_eq!(poly("b", 0, false), "b0");
        assert_eq!(poly("a", 2, true), "s^2 + a1·s + a0");
    }

    #[test]
    fn paper_beam_frequencies() {
        let m = BeamParams::paper().modal(2).unwrap();
        let doc = json_doc(&BeamParams::paper(), &m, String::new());
        assert!((doc.omega_rad_s[0] / 39.1603 - 1.0).abs() < 1e-4);
        assert!((doc.omega_rad_s[1] / 245.4132 - 1.0).abs() < 1e-4);
        assert_eq!(doc.tf.a.len(), 4);
        assert_eq!(doc.tf.b.len(), 3);
    }
}
