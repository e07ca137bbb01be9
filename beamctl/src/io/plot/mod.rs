//! `--plot`: estimates vs time, like the paper's Fig. 4, with the panels a
//! reader needs to judge convergence: one panel per parameter (ω̂_i left,
//! ζ̂_i right, one row per mode; the truth, when known, as a dashed black
//! line; one coloured line per estimator), then a bottom row with the
//! largest relative ω/ζ error vs time on a log axis (when the truth is
//! known) and the model output vs the measured y (the paper's Figs. 5 and
//! 8), with each model's fit %; with a record at hand (`replay`,
//! `simulate`), a last row with the frequency response: the measured H1
//! and its coherence under each identified model's response, modes marked
//! (`frf.rs`).
//!
//! # Design
//! * Text needs a font (`font.rs`). plotters' `ttf` feature would link
//!   fontconfig and freetype; instead plotters renders with `ab_glyph` from
//!   a TrueType file found at run time: `$BEAMCTL_FONT` if set, else a few
//!   well-known system paths (DejaVu, Liberation, Noto, Arial), else the
//!   first `*Sans*.ttf` under the system font directories. Without any font
//!   the plot is drawn without text (and the caller says so).
//! * Traces arrive at the evaluation rate; the recorder keeps every k-th so
//!   a series has at most [`MAX_POINTS`] points (5 ms resolution for 20 s).
//! * **Every trajectory stays visible.** The y range of a parameter panel
//!   follows the data: the union over estimators of the 1st–99th
//!   percentiles after the start-up transient (the first 5% of the run, or
//!   0.1 s after a line's first estimate if later),
//!   plus the reference (the truth, or without it the median final
//!   estimate), at least ±0.5% of the reference wide. Only if that union
//!   reaches beyond reference ± |reference| is the range capped there; a
//!   line outside it is clamped to the edge *and*, after its transient,
//!   marked with triangles, and its legend entry says "off scale".

mod font;
mod frf;

pub use font::ensure_font;
pub use frf::{FrfInput, FrfModel, FrfPanel};

use crate::error::CliError;
use crate::run::Trace;
use beamest::model::{ModalParams, MAX_MODES};
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::series::DashedLineSeries;
use std::path::Path;

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
    /// Largest relative ω/ζ error per point (NaN without the truth or an
    /// estimate).
    pub err: Vec<f64>,
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
                err: Vec::with_capacity(cap),
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
        self.series.err.push(t.max_rel_error.unwrap_or(f64::NAN));
    }

    /// A recorder that keeps every trace (for a record of unknown
    /// length) and decimates to at most [`MAX_POINTS`] at the end.
    pub fn unbounded(name: &str, modes: usize) -> Self {
        let mut r = Self::new(name, modes, 0);
        r.stride = 1;
        r
    }

    /// The series collected (at most [`MAX_POINTS`] points).
    pub fn finish(self) -> Series {
        let mut s = self.series;
        let stride = (s.t.len() as u64).div_ceil(MAX_POINTS).max(1) as usize;
        if stride > 1 {
            decimate(&mut s.t, stride);
            decimate(&mut s.omega, stride);
            decimate(&mut s.zeta, stride);
            decimate(&mut s.err, stride);
        }
        s
    }
}

/// Keep every `stride`-th element.
fn decimate<T>(v: &mut Vec<T>, stride: usize) {
    let mut i = 0;
    v.retain(|_| {
        i += 1;
        (i - 1) % stride == 0
    });
}

/// The measured y and each model's output over a window (see
/// `crate::judge::fit`).
#[derive(Debug, Clone)]
pub struct OutputPanel {
    /// Time (s).
    pub t: Vec<f64>,
    /// Measured y.
    pub y: Vec<f64>,
    /// Per estimator: name, fit %, ŷ on `t` (empty without a model).
    pub models: Vec<(String, Option<f64>, Vec<f64>)>,
}

/// Fail early (naming `--plot`) if the name does not end in `.png`.
pub fn check_extension(p: &Path) -> Result<(), CliError> {
    let png = p
        .extension()
        .and_then(|e| e.to_str())
        .is_some_and(|e| e.eq_ignore_ascii_case("png"));
    if png {
        Ok(())
    } else {
        Err(CliError::usage(
            "--plot",
            format!(
                "only PNG output is supported: the file name must end in .png (got {})",
                p.display()
            ),
        ))
    }
}

/// Fail early (naming `--plot`) if the file cannot be created.
pub fn check_writable(path: &Path) -> Result<(), CliError> {
    std::fs::File::create(path)
        .map(drop)
        .map_err(|e| CliError::usage("--plot", format!("cannot create {}: {e}", path.display())))
}

/// Colour of an estimator's line (matplotlib's tab10).
pub(crate) fn color(name: &str, index: usize) -> RGBColor {
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

/// The truth drawn as dashed lines: the plant from t = 0 and, after a
/// plant step (`simulate --step-at`), the new plant from the step's time.
#[derive(Debug, Clone, Copy)]
pub struct TruthLines<'a> {
    /// The plant from the start (throughout, without a step).
    pub before: &'a ModalParams<f64>,
    /// The step's time (s) and the plant after it.
    pub after: Option<(f64, &'a ModalParams<f64>)>,
}

impl TruthLines<'_> {
    /// The dashed line of one parameter (`value` picks it) over
    /// `0..duration_s`: one segment, or two joined by a vertical at the step.
    fn line(&self, value: impl Fn(&ModalParams<f64>) -> f64, duration_s: f64) -> Vec<(f64, f64)> {
        let v0 = value(self.before);
        match self.after {
            Some((at, p)) if at > 0.0 && at < duration_s => {
                let v1 = value(p);
                vec![(0.0, v0), (at, v0), (at, v1), (duration_s, v1)]
            }
            Some((_, p)) if duration_s > 0.0 => {
                let v1 = value(p);
                vec![(0.0, v1), (duration_s, v1)]
            }
            _ => vec![(0.0, v0), (duration_s, v0)],
        }
    }

    /// The plant the run ends with (the error panel's and the report's).
    fn last(&self) -> &ModalParams<f64> {
        self.after.map_or(self.before, |(_, p)| p)
    }
}

/// Draw the plot. `truth` is `None` for recorded data; `frf` adds the
/// frequency-response row. Returns whether text was drawn (a font was
/// found).
pub fn write(
    path: &Path,
    title: &str,
    truth: Option<&TruthLines<'_>>,
    series: &[Series],
    duration_s: f64,
    output: Option<&OutputPanel>,
    frf: Option<&FrfPanel>,
) -> Result<bool, CliError> {
    let text = font::ensure_font();
    let n = series
        .first()
        .map_or(truth.map_or(1, |t| t.last().modes), |s| s.modes)
        .clamp(1, MAX_MODES);
    let bottom = truth.is_some() || output.is_some();
    let rows = n + usize::from(bottom) + if frf.is_some() { frf::ROWS } else { 0 };
    let (w, h) = (1400u32, 60 + 330 * rows as u32);
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
    let (_, body_h) = body.dim_in_pixel();
    let row_h = body_h / rows as u32;
    let (body, frf_area) = match frf {
        Some(_) => body.split_vertically(body_h - row_h * frf::ROWS as u32),
        None => body.split_vertically(body_h),
    };
    let (top, bottom_area) = body.split_vertically(row_h * n as u32);
    let panels = top.split_evenly((n, 2));
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
            truth.map(|t| t.line(|p| p.omega_rad_s[i], duration_s)),
            &omega,
            duration_s,
            text,
            i == 0,
        )
        .map_err(|e| fail(&e))?;
        panel(
            &panels[2 * i + 1],
            &zeta_label,
            truth.map(|t| t.line(|p| p.zeta[i], duration_s)),
            &zeta,
            duration_s,
            text,
            false,
        )
        .map_err(|e| fail(&e))?;
    }
    if bottom {
        // With the truth: error (left) and output (right); without: the
        // output across the whole width.
        let halves = bottom_area.split_evenly((1, 2));
        let out_area = if truth.is_some() {
            error_panel(&halves[0], series, duration_s, text).map_err(|e| fail(&e))?;
            &halves[1]
        } else {
            &bottom_area
        };
        if let Some(o) = output {
            output_panel(out_area, o, text).map_err(|e| fail(&e))?;
        }
    }
    if let Some(p) = frf {
        frf::draw(&frf_area, p, text).map_err(|e| fail(&e))?;
    }
    root.present().map_err(|e| fail(&e))?;
    Ok(text)
}

/// (t, value of mode i) pairs.
fn points(t: &[f64], v: &[[f64; MAX_MODES]], i: usize) -> Vec<(f64, f64)> {
    t.iter().zip(v).map(|(&t, v)| (t, v[i])).collect()
}

/// Where a line's start-up transient ends: 5% of the run, or 0.1 s after
/// its first estimate if that is later (the law starts only after the
/// tuning rule's start-up window and settling).
fn transient_end(pts: &[(f64, f64)], duration_s: f64) -> f64 {
    let first = pts.iter().find(|(_, v)| v.is_finite()).map_or(0.0, |p| p.0);
    (0.05 * duration_s).max(first + 0.1)
}

/// The y range shown for a parameter (see the module docs). `reference` is the truth, or `None` for recorded data.
pub fn y_range(
    reference: Option<f64>,
    lines: &[(&str, Vec<(f64, f64)>)],
    duration_s: f64,
) -> (f64, f64) {
    let reference = reference.unwrap_or_else(|| {
        let mut finals: Vec<f64> = lines
            .iter()
            .filter_map(|(_, pts)| pts.iter().rev().map(|p| p.1).find(|v| v.is_finite()))
            .collect();
        finals.sort_by(f64::total_cmp);
        finals.get(finals.len() / 2).copied().unwrap_or(0.0)
    });
    let (mut lo, mut hi) = (reference, reference);
    for (_, pts) in lines {
        let skip = transient_end(pts, duration_s);
        let mut vals: Vec<f64> = pts
            .iter()
            .filter(|(t, v)| *t >= skip && v.is_finite())
            .map(|(_, v)| *v)
            .collect();
        if vals.is_empty() {
            continue;
        }
        vals.sort_by(f64::total_cmp);
        let q = |p: f64| vals[((vals.len() - 1) as f64 * p).round() as usize];
        lo = lo.min(q(0.01));
        hi = hi.max(q(0.99));
    }
    // Follow the data unless a line strays beyond reference ± |reference|:
    // then cap there (that line is drawn clamped and marked off scale).
    let cap = reference.abs().max(f64::MIN_POSITIVE);
    lo = lo.max(reference - cap);
    hi = hi.min(reference + cap);
    let min_half = 0.005 * cap;
    let mid = 0.5 * (lo + hi);
    let half = (0.5 * (hi - lo) * 1.1).max(min_half);
    (mid - half, mid + half)
}

fn panel(
    area: &DrawingArea<BitMapBackend<'_>, Shift>,
    label: &str,
    truth: Option<Vec<(f64, f64)>>,
    lines: &[(&str, Vec<(f64, f64)>)],
    duration_s: f64,
    text: bool,
    legend: bool,
) -> Result<(), Box<dyn std::error::Error>> {
    let reference = truth.as_ref().and_then(|t| t.last()).map(|p| p.1);
    let (mut lo, mut hi) = y_range(reference, lines, duration_s);
    // Before a plant step the truth had another value: keep it in view.
    for &(_, v) in truth.iter().flatten() {
        let margin = 0.05 * (hi - lo);
        lo = lo.min(v - margin);
        hi = hi.max(v + margin);
    }
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
        // Off scale after the start-up transient (the range ignores it too).
        let skip = transient_end(pts, duration_s);
        let off: Vec<(f64, f64)> = pts
            .iter()
            .filter(|(t, v)| *t >= skip && v.is_finite() && (*v < lo || *v > hi))
            .map(|&(t, v)| (t, v.clamp(lo, hi)))
            .collect();
        let label = if off.is_empty() {
            name.to_string()
        } else {
            format!("{name} (off scale, ▲▼)")
        };
        // Split at NaN (no estimate) and clamp to the visible range.
        let mut first = true;
        for segment in pts.split(|(_, v)| !v.is_finite()) {
            if segment.is_empty() {
                continue;
            }
            let clamped = segment.iter().map(|&(t, v)| (t, v.clamp(lo, hi)));
            let drawn = chart.draw_series(LineSeries::new(clamped, style))?;
            if first {
                drawn.label(label.clone()).legend(move |(x, y)| {
                    PathElement::new(vec![(x, y), (x + 20, y)], style.stroke_width(3))
                });
                first = false;
            }
        }
        // Off-scale marks: at most ~40 triangles per line, on the edge.
        let stride = off.len().div_ceil(40).max(1);
        let fill = color(name, k).filled();
        chart.draw_series(off.iter().step_by(stride).map(|&(t, v)| {
            let up = v >= hi;
            let y = if up { hi } else { lo };
            let tip = if up { -6 } else { 6 };
            EmptyElement::at((t, y)) + Polygon::new(vec![(-5, 0), (5, 0), (0, tip)], fill)
        }))?;
    }
    if let Some(truth) = truth {
        // The truth last, on top of converged estimates.
        chart
            .draw_series(DashedLineSeries::new(truth, 10, 6, BLACK.stroke_width(2)))?
            .label("truth")
            .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], BLACK.stroke_width(2)));
    }
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

/// Largest relative ω/ζ error vs time, log axis (simulation only).
fn error_panel(
    area: &DrawingArea<BitMapBackend<'_>, Shift>,
    series: &[Series],
    duration_s: f64,
    text: bool,
) -> Result<(), Box<dyn std::error::Error>> {
    let all = series
        .iter()
        .flat_map(|s| s.err.iter().copied())
        .filter(|e| e.is_finite() && *e > 0.0);
    let (min, max) = all.fold((f64::INFINITY, 0.0f64), |(a, b), e| (a.min(e), b.max(e)));
    let lo = if min.is_finite() {
        (min / 2.0).max(1e-16)
    } else {
        1e-16
    };
    let hi = (max * 2.0).clamp(1.0, 1e6);
    let mut builder = ChartBuilder::on(area);
    builder.margin(12);
    if text {
        builder
            .caption("largest relative ω/ζ error", ("sans-serif", 18))
            .x_label_area_size(36)
            .y_label_area_size(80);
    } else {
        builder.x_label_area_size(4).y_label_area_size(4);
    }
    let mut chart = builder.build_cartesian_2d(0.0..duration_s, (lo..hi).log_scale())?;
    let mut mesh = chart.configure_mesh();
    if text {
        mesh.x_desc("t (s)")
            .label_style(("sans-serif", 14))
            .y_label_formatter(&|v| format!("{v:.0e}"))
            .x_labels(8)
            .y_labels(8);
    } else {
        mesh.x_labels(0).y_labels(0);
    }
    mesh.draw()?;
    for (k, s) in series.iter().enumerate() {
        let style = color(&s.name, k).stroke_width(1);
        // Non-finite = no estimate: drawn at the top edge.
        let pts: Vec<(f64, f64)> =
            s.t.iter()
                .zip(&s.err)
                .filter(|(_, e)| !e.is_nan())
                .map(|(&t, &e)| (t, e.clamp(lo, hi)))
                .collect();
        chart
            .draw_series(LineSeries::new(pts, style))?
            .label(s.name.clone())
            .legend(move |(x, y)| {
                PathElement::new(vec![(x, y), (x + 20, y)], style.stroke_width(3))
            });
    }
    if text {
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

/// Measured y and each model's output over the panel's window.
fn output_panel(
    area: &DrawingArea<BitMapBackend<'_>, Shift>,
    o: &OutputPanel,
    text: bool,
) -> Result<(), Box<dyn std::error::Error>> {
    let (t0, t1) = match (o.t.first(), o.t.last()) {
        (Some(&a), Some(&b)) if b > a => (a, b),
        _ => return Ok(()),
    };
    let finite = o.y.iter().copied().filter(|v| v.is_finite());
    let (lo, hi) = finite.fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
        (a.min(v), b.max(v))
    });
    if !(lo.is_finite() && hi.is_finite()) {
        return Ok(());
    }
    let pad = 0.15 * (hi - lo).max(1e-12 * lo.abs().max(1e-300));
    let (lo, hi) = (lo - pad, hi + pad);
    let mut builder = ChartBuilder::on(area);
    builder.margin(12);
    if text {
        builder
            .caption("model output ŷ vs measured y", ("sans-serif", 18))
            .x_label_area_size(36)
            .y_label_area_size(80);
    } else {
        builder.x_label_area_size(4).y_label_area_size(4);
    }
    let mut chart = builder.build_cartesian_2d(t0..t1, lo..hi)?;
    let mut mesh = chart.configure_mesh();
    if text {
        mesh.x_desc("t (s)")
            .label_style(("sans-serif", 14))
            .y_label_formatter(&|v| format!("{v:.3e}"))
            .x_labels(6)
            .y_labels(6);
    } else {
        mesh.x_labels(0).y_labels(0);
    }
    mesh.draw()?;
    let measured: Vec<(f64, f64)> =
        o.t.iter()
            .zip(&o.y)
            .filter(|(_, y)| y.is_finite())
            .map(|(&t, &y)| (t, y))
            .collect();
    chart
        .draw_series(LineSeries::new(measured, BLACK.stroke_width(2)))?
        .label("measured y")
        .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], BLACK.stroke_width(2)));
    for (k, (name, fit, yhat)) in o.models.iter().enumerate() {
        if yhat.len() != o.t.len() {
            continue;
        }
        let style = color(name, k).stroke_width(1);
        let pts =
            o.t.iter()
                .zip(yhat)
                .map(|(&t, &v)| (t, if v.is_finite() { v.clamp(lo, hi) } else { hi }));
        let label = match fit {
            Some(f) => format!("{name}: fit {f:.2} %"),
            None => format!("{name}: no fit"),
        };
        chart
            .draw_series(DashedLineSeries::new(pts, 6, 3, style))?
            .label(label)
            .legend(move |(x, y)| {
                PathElement::new(vec![(x, y), (x + 20, y)], style.stroke_width(3))
            });
    }
    if text {
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
pub(crate) fn format_tick(v: f64) -> String {
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
        let (lo, hi) = y_range(Some(39.0), &[("a", pts.clone())], 10.0);
        assert!(lo < 39.0 && hi > 40.0 && hi < 45.0, "{lo} {hi}");
        // A diverging estimate is capped at truth ± |truth| (plus margin).
        let far: Vec<(f64, f64)> = pts.iter().map(|&(t, _)| (t, 1e3)).collect();
        let (lo, hi) = y_range(Some(39.0), &[("a", far)], 10.0);
        assert!(lo > -5.0 && hi < 85.0, "{lo} {hi}");
        // A converged estimate still gets a visible band.
        let (lo, hi) = y_range(Some(0.02), &[], 1.0);
        assert!(lo < 0.02 && hi > 0.02 && hi - lo > 1e-4);
        // Within the cap the range follows every line: a baseline 30% off
        // stays on scale.
        let off: Vec<(f64, f64)> = pts.iter().map(|&(t, _)| (t, 52.0)).collect();
        let (lo, hi) = y_range(Some(39.0), &[("a", pts.clone()), ("b", off)], 10.0);
        assert!(lo < 39.0 && hi > 52.0, "{lo} {hi}");
        // Without the truth the reference is the median final estimate.
        let (lo, hi) = y_range(None, &[("a", pts)], 10.0);
        assert!(lo < 40.0 && hi > 40.0 && hi < 41.0, "{lo} {hi}");
    }

    #[test]
    fn truth_line_follows_a_plant_step() {
        let a = ModalParams::<f64> {
            modes: 2,
            omega_rad_s: [39.0, 245.0, 0.0],
            zeta: [0.02, 0.13, 0.0],
            bbar: [1.0, 1.0, 0.0],
            output_weight: [1.0, 1.0, 0.0],
        };
        let mut b = a;
        b.omega_rad_s[0] = 43.0;
        let steady = TruthLines {
            before: &a,
            after: None,
        };
        assert_eq!(
            steady.line(|p| p.omega_rad_s[0], 20.0),
            vec![(0.0, 39.0), (20.0, 39.0)]
        );
        let stepped = TruthLines {
            before: &a,
            after: Some((10.0, &b)),
        };
        assert_eq!(
            stepped.line(|p| p.omega_rad_s[0], 20.0),
            vec![(0.0, 39.0), (10.0, 39.0), (10.0, 43.0), (20.0, 43.0)]
        );
        assert_eq!(stepped.last().omega_rad_s[0], 43.0);
    }

    #[test]
    fn ticks_are_compact() {
        assert_eq!(format_tick(39.15), "39.15");
        assert_eq!(format_tick(0.0207), "0.0207");
        assert_eq!(format_tick(2.0e-5), "2.000e-5");
    }
}
