//! `--plot`: estimates vs time, like the paper's Fig. 4 (with the final
//! values of Table III): one panel per parameter (ω̂_i left, ζ̂_i right, one
//! row per mode), the truth as a dashed black line and one coloured line per
//! estimator.
//!
//! # Design
//! * Text needs a font. plotters' `ttf` feature would link fontconfig and
//!   freetype; instead plotters renders with `ab_glyph` from a TrueType file
//!   found at run time: `$BEAMCTL_FONT` if set, else a few well-known system
//!   paths (DejaVu, Liberation, Noto, Arial), else the first `*Sans*.ttf`
//!   under the system font directories. Without any font the plot is drawn
//!   without text (and the caller says so).
//! * Traces arrive at 1 kHz; the recorder keeps every k-th so a series has at
//!   most [`MAX_POINTS`] points (5 ms resolution for 20 s).
//! * The y range ignores the first 5% of the run (the start-up transient,
//!   where the estimate can be orders of magnitude off) using the 1st–99th
//!   percentiles of the rest, always includes the truth, and is at least
//!   ±0.5% of the truth wide; lines outside it are clamped to its edge.

use crate::error::CliError;
use beamctl::Trace;
use beamest::model::{ModalParams, MAX_MODES};
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::series::DashedLineSeries;
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

/// Largest number of points kept per series.
pub const MAX_POINTS: u64 = 5000;

/// One estimator's ω̂, ζ̂ over time (NaN where recovery failed).
#[derive(Debug, Clone)]
pub struct Series {
    /// Estimator name (legend).
    pub name: String,
    /// Number of modes.
    pub modes: usize,
    /// Time (s).
    pub t: Vec<f64>,
    /// ω̂_i (rad/s) per point.
    pub omega: Vec<[f64; MAX_MODES]>,
    /// ζ̂_i per point.
    pub zeta: Vec<[f64; MAX_MODES]>,
}

/// Collects a decimated [`Series`] from the runner's traces.
#[derive(Debug, Clone)]
pub struct Recorder {
    series: Series,
    stride: u64,
    count: u64,
}

impl Recorder {
    /// A recorder for about `expected` traces.
    pub fn new(name: &str, modes: usize, expected: u64) -> Self {
        let stride = expected.div_ceil(MAX_POINTS).max(1);
        let cap = (expected / stride + 2) as usize;
        Self {
            series: Series {
                name: name.to_string(),
                modes,
                t: Vec::with_capacity(cap),
                omega: Vec::with_capacity(cap),
                zeta: Vec::with_capacity(cap),
            },
            stride,
            count: 0,
        }
    }

    /// Observe one trace.
    pub fn push(&mut self, t: &Trace<'_>) {
        let keep = self.count.is_multiple_of(self.stride);
        self.count += 1;
        if !keep {
            return;
        }
        let n = self.series.modes;
        let (mut w, mut z) = ([f64::NAN; MAX_MODES], [f64::NAN; MAX_MODES]);
        if let Some(m) = t.modal.filter(|m| m.modes == n) {
            w[..n].copy_from_slice(&m.omega_rad_s[..n]);
            z[..n].copy_from_slice(&m.zeta[..n]);
        }
        self.series.t.push(t.t_s);
        self.series.omega.push(w);
        self.series.zeta.push(z);
    }

    /// The series collected.
    pub fn finish(self) -> Series {
        self.series
    }
}

/// Fail early (naming `--plot`) if the file cannot be created.
pub fn check_writable(path: &Path) -> Result<(), CliError> {
    std::fs::File::create(path)
        .map(drop)
        .map_err(|e| CliError::usage("--plot", format!("cannot create {}: {e}", path.display())))
}

/// Colour of an estimator's line (matplotlib's tab10).
fn color(name: &str, index: usize) -> RGBColor {
    match name {
        "adaptive" => RGBColor(31, 119, 180),
        "gradient" => RGBColor(255, 127, 14),
        "ls" => RGBColor(44, 160, 44),
        _ => {
            let (r, g, b) = Palette99::pick(index).to_rgba().rgb();
            RGBColor(r, g, b)
        }
    }
}

/// Candidate font files, most preferred first.
const FONT_PATHS: &[&str] = &[
    "/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf",
    "/usr/share/fonts/TTF/DejaVuSans.ttf",
    "/usr/share/fonts/dejavu/DejaVuSans.ttf",
    "/usr/share/fonts/dejavu-sans-fonts/DejaVuSans.ttf",
    "/usr/share/fonts/truetype/liberation/LiberationSans-Regular.ttf",
    "/usr/share/fonts/liberation-sans/LiberationSans-Regular.ttf",
    "/usr/share/fonts/truetype/noto/NotoSans-Regular.ttf",
    "/usr/share/fonts/noto/NotoSans-Regular.ttf",
    "/System/Library/Fonts/Supplemental/Arial.ttf",
    "/Library/Fonts/Arial.ttf",
    "C:\\Windows\\Fonts\\arial.ttf",
];

/// Directories searched for any `*Sans*.ttf` when no known file exists.
const FONT_DIRS: &[&str] = &["/usr/share/fonts", "/usr/local/share/fonts"];

/// Register a sans-serif font with plotters once; true if one was found.
fn ensure_font() -> bool {
    static FOUND: OnceLock<bool> = OnceLock::new();
    *FOUND.get_or_init(|| {
        let candidates: Vec<PathBuf> = match std::env::var_os("BEAMCTL_FONT") {
            Some(p) => vec![PathBuf::from(p)],
            None => FONT_PATHS
                .iter()
                .map(PathBuf::from)
                .chain(FONT_DIRS.iter().filter_map(|d| find_ttf(Path::new(d), 4)))
                .collect(),
        };
        candidates.iter().any(|p| register(p))
    })
}

fn register(path: &Path) -> bool {
    let Ok(bytes) = std::fs::read(path) else {
        return false;
    };
    // plotters keeps fonts for the life of the process.
    let bytes: &'static [u8] = Box::leak(bytes.into_boxed_slice());
    plotters::style::register_font("sans-serif", FontStyle::Normal, bytes).is_ok()
}

/// The first `*Sans*.ttf` (not mono, not bold/italic) below `dir`.
fn find_ttf(dir: &Path, depth: usize) -> Option<PathBuf> {
    let mut entries: Vec<PathBuf> = std::fs::read_dir(dir)
        .ok()?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .collect();
    entries.sort();
    for p in &entries {
        let name = p.file_name()?.to_string_lossy().to_lowercase();
        if p.is_file()
            && name.ends_with(".ttf")
            && name.contains("sans")
            && !["mono", "bold", "italic", "oblique", "light", "condensed"]
                .iter()
                .any(|s| name.contains(s))
        {
            return Some(p.clone());
        }
    }
    if depth == 0 {
        return None;
    }
    entries
        .iter()
        .filter(|p| p.is_dir())
        .find_map(|p| find_ttf(p, depth - 1))
}

/// Draw the plot. Returns whether text was drawn (a font was found).
pub fn write(
    path: &Path,
    title: &str,
    truth: &ModalParams<f64>,
    series: &[Series],
    duration_s: f64,
) -> Result<bool, CliError> {
    let text = ensure_font();
    let n = truth.modes.clamp(1, MAX_MODES);
    let (w, h) = (1400u32, 60 + 330 * n as u32);
    let fail = |e: &dyn std::fmt::Display| {
        CliError::failure(format!("--plot: drawing {}: {e}", path.display()))
    };
    let root = BitMapBackend::new(path, (w, h)).into_drawing_area();
    root.fill(&WHITE).map_err(|e| fail(&e))?;
    let body = if text {
        root.titled(title, ("sans-serif", 22))
            .map_err(|e| fail(&e))?
    } else {
        root.margin(40, 0, 0, 0)
    };
    let panels = body.split_evenly((n, 2));
    for i in 0..n {
        let omega: Vec<(&str, Vec<(f64, f64)>)> = series
            .iter()
            .map(|s| (s.name.as_str(), points(&s.t, &s.omega, i)))
            .collect();
        let zeta: Vec<(&str, Vec<(f64, f64)>)> = series
            .iter()
            .map(|s| (s.name.as_str(), points(&s.t, &s.zeta, i)))
            .collect();
        let omega_label = format!("ω{} (rad/s)", i + 1);
        let zeta_label = format!("ζ{}", i + 1);
        panel(
            &panels[2 * i],
            &omega_label,
            truth.omega_rad_s[i],
            &omega,
            duration_s,
            text,
            i == 0,
        )
        .map_err(|e| fail(&e))?;
        panel(
            &panels[2 * i + 1],
            &zeta_label,
            truth.zeta[i],
            &zeta,
            duration_s,
            text,
            false,
        )
        .map_err(|e| fail(&e))?;
    }
    root.present().map_err(|e| fail(&e))?;
    Ok(text)
}

/// (t, value of mode i) pairs.
fn points(t: &[f64], v: &[[f64; MAX_MODES]], i: usize) -> Vec<(f64, f64)> {
    t.iter().zip(v).map(|(&t, v)| (t, v[i])).collect()
}

/// The y range shown for a parameter (see the module docs).
pub fn y_range(truth: f64, lines: &[(&str, Vec<(f64, f64)>)], duration_s: f64) -> (f64, f64) {
    let skip = 0.05 * duration_s;
    let mut vals: Vec<f64> = lines
        .iter()
        .flat_map(|(_, pts)| pts.iter())
        .filter(|(t, v)| *t >= skip && v.is_finite())
        .map(|(_, v)| *v)
        .collect();
    vals.sort_by(f64::total_cmp);
    let (mut lo, mut hi) = (truth, truth);
    if !vals.is_empty() {
        let q = |p: f64| vals[((vals.len() - 1) as f64 * p).round() as usize];
        lo = lo.min(q(0.01));
        hi = hi.max(q(0.99));
    }
    // Never wider than truth ± |truth|: a diverging baseline then hugs the
    // edge instead of flattening the others into the truth line.
    let cap = truth.abs().max(f64::MIN_POSITIVE);
    lo = lo.max(truth - cap);
    hi = hi.min(truth + cap);
    let min_half = 0.005 * cap;
    let mid = 0.5 * (lo + hi);
    let half = (0.5 * (hi - lo) * 1.1).max(min_half);
    (mid - half, mid + half)
}

fn panel(
    area: &DrawingArea<BitMapBackend<'_>, Shift>,
    label: &str,
    truth: f64,
    lines: &[(&str, Vec<(f64, f64)>)],
    duration_s: f64,
    text: bool,
    legend: bool,
) -> Result<(), Box<dyn std::error::Error>> {
    let (lo, hi) = y_range(truth, lines, duration_s);
    let mut builder = ChartBuilder::on(area);
    builder.margin(12);
    if text {
        builder
            .caption(label, ("sans-serif", 18))
            .x_label_area_size(36)
            .y_label_area_size(80);
    } else {
        builder.x_label_area_size(4).y_label_area_size(4);
    }
    let mut chart = builder.build_cartesian_2d(0.0..duration_s, lo..hi)?;
    let mut mesh = chart.configure_mesh();
    if text {
        mesh.x_desc("t (s)")
            .label_style(("sans-serif", 14))
            .y_label_formatter(&|v| format_tick(*v))
            .x_labels(8)
            .y_labels(6);
    } else {
        mesh.x_labels(0).y_labels(0);
    }
    mesh.draw()?;

    for (k, (name, pts)) in lines.iter().enumerate() {
        // One pixel wide: plotters joins wider polylines with unbounded
        // miters, which spike where an estimate zig-zags.
        let style = color(name, k).stroke_width(1);
        // Split at NaN (no estimate) and clamp to the visible range.
        let mut first = true;
        for segment in pts.split(|(_, v)| !v.is_finite()) {
            if segment.is_empty() {
                continue;
            }
            let clamped = segment.iter().map(|&(t, v)| (t, v.clamp(lo, hi)));
            let drawn = chart.draw_series(LineSeries::new(clamped, style))?;
            if first {
                drawn.label(*name).legend(move |(x, y)| {
                    PathElement::new(vec![(x, y), (x + 20, y)], style.stroke_width(3))
                });
                first = false;
            }
        }
    }
    // The truth last, on top of converged estimates.
    chart
        .draw_series(DashedLineSeries::new(
            vec![(0.0, truth), (duration_s, truth)],
            10,
            6,
            BLACK.stroke_width(2),
        ))?
        .label("truth")
        .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], BLACK.stroke_width(2)));
    if text && legend {
        chart
            .configure_series_labels()
            .label_font(("sans-serif", 14))
            .position(SeriesLabelPosition::UpperRight)
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK)
            .draw()?;
    }
    Ok(())
}

/// Tick labels with enough digits for narrow ranges.
fn format_tick(v: f64) -> String {
    if v == 0.0 {
        return "0".into();
    }
    let a = v.abs();
    if (1e-3..1e5).contains(&a) {
        let s = format!("{v:.6}");
        let s = s.trim_end_matches('0');
        s.trim_end_matches('.').to_string()
    } else {
        format!("{v:.3e}")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn y_range_contains_truth_and_ignores_start() {
        let pts: Vec<(f64, f64)> = (0..100)
            .map(|k| (k as f64 * 0.1, if k < 2 { 1e6 } else { 40.0 }))
            .collect();
        let (lo, hi) = y_range(39.0, &[("a", pts.clone())], 10.0);
        assert!(lo < 39.0 && hi > 40.0 && hi < 45.0, "{lo} {hi}");
        // A diverging estimate is capped at truth ± |truth| (plus margin).
        let far: Vec<(f64, f64)> = pts.iter().map(|&(t, _)| (t, 1e3)).collect();
        let (lo, hi) = y_range(39.0, &[("a", far)], 10.0);
        assert!(lo > -5.0 && hi < 85.0, "{lo} {hi}");
        // A converged estimate still gets a visible band.
        let (lo, hi) = y_range(0.02, &[], 1.0);
        assert!(lo < 0.02 && hi > 0.02 && hi - lo > 1e-4);
    }

    #[test]
    fn ticks_are_compact() {
        assert_eq!(format_tick(39.15), "39.15");
        assert_eq!(format_tick(0.0207), "0.0207");
        assert_eq!(format_tick(2.0e-5), "2.000e-5");
    }
}
