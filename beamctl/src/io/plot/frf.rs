//! The frequency-response row of `--plot`: the record's measured FRF (H1
//! with its coherence, [`crate::judge::frf`]) as points and each
//! identified model's exact-ZOH response ([`Model::response`]) as a line,
//! magnitude (log–log), phase and coherence on a log frequency axis, each
//! mode of each model marked by a dashed line and listed with its ω and ζ
//! in the legend.

use super::color;
use crate::judge::fit::Model;
use crate::judge::frf::H1;
use plotters::coord::combinators::LogCoord;
use plotters::coord::ranged1d::Ranged;
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::series::DashedLineSeries;
use std::f64::consts::PI;

/// Points of each model's response line.
const GRID: usize = 600;

/// One identified model over the measured FRF.
#[derive(Debug, Clone)]
pub struct FrfModel {
    /// Estimator name (legend, colour).
    pub name: String,
    /// Model-output fit (%), for the legend.
    pub fit_percent: Option<f64>,
    /// |H| at [`FrfPanel::grid_hz`].
    pub magnitude: Vec<f64>,
    /// Phase (°, unwrapped along the grid).
    pub phase_deg: Vec<f64>,
    /// (ω_i rad/s, ζ_i) of each mode.
    pub modes: Vec<(f64, f64)>,
}

/// An estimator's model as [`FrfPanel::new`] takes it.
#[derive(Debug, Clone)]
pub struct FrfInput<'a> {
    /// Estimator name.
    pub name: String,
    /// Its identified model, if any.
    pub model: Option<&'a Model>,
    /// Its model-output fit (%).
    pub fit_percent: Option<f64>,
    /// (ω_i rad/s, ζ_i) of each mode of its estimate.
    pub modes: Vec<(f64, f64)>,
}

/// What the frequency-response row draws.
#[derive(Debug, Clone)]
pub struct FrfPanel {
    /// The measured FRF.
    pub measured: H1,
    /// Frequencies of the model lines (Hz, log-spaced).
    pub grid_hz: Vec<f64>,
    /// One per estimator with a stable model.
    pub models: Vec<FrfModel>,
}

impl FrfPanel {
    /// The panel for `measured` and the estimators' models at sample
    /// interval `ts_s`: the frequency axis spans the measured lines and a
    /// third of the lowest to ten times the highest mode, within Nyquist.
    pub fn new(measured: H1, models: &[FrfInput<'_>], ts_s: f64) -> Self {
        let nyquist = 0.5 / ts_s;
        let (mut lo, mut hi) = (
            measured.f_hz.first().copied().unwrap_or(1.0) / 1.5,
            measured.f_hz.last().copied().unwrap_or(nyquist) * 1.5,
        );
        let f_modes: Vec<f64> = models
            .iter()
            .flat_map(|m| m.modes.iter().map(|&(w, _)| w / (2.0 * PI)))
            .filter(|f| f.is_finite() && *f > 0.0)
            .collect();
        if !f_modes.is_empty() {
            let (fmin, fmax) = f_modes
                .iter()
                .fold((f64::INFINITY, 0.0f64), |(a, b), &f| (a.min(f), b.max(f)));
            lo = lo.min(fmin / 3.0);
            hi = (fmax * 10.0).max(lo * 10.0);
        }
        let hi = hi.min(nyquist);
        let lo = lo.min(hi / 10.0).max(f64::MIN_POSITIVE);
        let grid_hz: Vec<f64> = (0..GRID)
            .map(|k| lo * (hi / lo).powf(k as f64 / (GRID - 1) as f64))
            .collect();
        let models = models
            .iter()
            .filter_map(|input| {
                let model = input.model?;
                if !model.is_stable() {
                    return None;
                }
                let h: Vec<(f64, f64)> = grid_hz.iter().map(|&f| model.response(f, ts_s)).collect();
                let magnitude = h.iter().map(|&(re, im)| re.hypot(im)).collect();
                let mut phase_deg = Vec::with_capacity(h.len());
                let mut last: Option<f64> = None;
                for &(re, im) in &h {
                    let mut p = im.atan2(re).to_degrees();
                    if let Some(l) = last {
                        p += 360.0 * ((l - p) / 360.0).round();
                    }
                    phase_deg.push(p);
                    last = Some(p);
                }
                Some(FrfModel {
                    name: input.name.clone(),
                    fit_percent: input.fit_percent,
                    magnitude,
                    phase_deg,
                    modes: input.modes.clone(),
                })
            })
            .collect();
        Self {
            measured,
            grid_hz,
            models,
        }
    }

    /// The measured points shown (within the axis): (f, |H1|, phase on the
    /// first model's branch, coherence).
    fn points(&self) -> Vec<(f64, f64, f64, f64)> {
        let (lo, hi) = self.x_range();
        let m = &self.measured;
        (0..m.f_hz.len())
            .filter(|&k| m.f_hz[k] >= lo && m.f_hz[k] <= hi)
            .map(|k| {
                let f = m.f_hz[k];
                let mut p = m.im[k].atan2(m.re[k]).to_degrees();
                if let Some(model) = self.models.first() {
                    let near = interp(&self.grid_hz, &model.phase_deg, f);
                    p += 360.0 * ((near - p) / 360.0).round();
                }
                (f, m.re[k].hypot(m.im[k]), p, m.coherence[k])
            })
            .collect()
    }

    fn x_range(&self) -> (f64, f64) {
        (
            self.grid_hz.first().copied().unwrap_or(1.0),
            self.grid_hz.last().copied().unwrap_or(10.0),
        )
    }
}

/// Linear interpolation of `y` over increasing `x` at `at`.
fn interp(x: &[f64], y: &[f64], at: f64) -> f64 {
    let i = x.partition_point(|&v| v < at).clamp(1, x.len() - 1);
    let t = (at - x[i - 1]) / (x[i] - x[i - 1]);
    y[i - 1] + t * (y[i] - y[i - 1])
}

fn builder<'a, 'b>(
    area: &'a DrawingArea<BitMapBackend<'b>, Shift>,
    caption: &str,
    text: bool,
) -> ChartBuilder<'a, 'b, BitMapBackend<'b>> {
    let mut b = ChartBuilder::on(area);
    b.margin(12);
    if text {
        b.caption(caption, ("sans-serif", 18))
            .x_label_area_size(36)
            .y_label_area_size(80);
    } else {
        b.x_label_area_size(4).y_label_area_size(4);
    }
    b
}

/// Rows of the plot the panel takes.
pub const ROWS: usize = 2;

/// Draw the panel into `area` ([`ROWS`] rows high): the magnitude across
/// the width, then phase (left) and coherence (right).
pub fn draw(
    area: &DrawingArea<BitMapBackend<'_>, Shift>,
    panel: &FrfPanel,
    text: bool,
) -> Result<(), Box<dyn std::error::Error>> {
    let (_, h) = area.dim_in_pixel();
    let (left, lower) = area.split_vertically(h / 2);
    let right = lower.split_evenly((1, 2));
    let (lo, hi) = panel.x_range();
    let pts = panel.points();
    // Black: the estimators' colours are those of the other panels.
    let black = RGBColor(0, 0, 0);
    let dot = |c: RGBColor| move |(x, y): (f64, f64)| Circle::new((x, y), 3, c.filled());
    // Magnitude.
    let mags = pts
        .iter()
        .map(|p| p.1)
        .chain(
            panel
                .models
                .iter()
                .flat_map(|m| m.magnitude.iter().copied()),
        )
        .filter(|v| v.is_finite() && *v > 0.0);
    let (mlo, mhi) = mags.fold((f64::INFINITY, 0.0f64), |(a, b), v| (a.min(v), b.max(v)));
    let (mlo, mhi) = if mlo.is_finite() && mhi > mlo {
        (mlo / 2.0, mhi * 4.0)
    } else {
        (1e-6, 1.0)
    };
    let mut chart = builder(
        &left,
        "frequency response |H| (measured H1 and models)",
        text,
    )
    .build_cartesian_2d((lo..hi).log_scale(), (mlo..mhi).log_scale())?;
    let mut mesh = chart.configure_mesh();
    if text {
        mesh.x_desc("f (Hz)")
            .y_desc("|H| (units of y per unit of u)")
            .label_style(("sans-serif", 14))
            .y_label_formatter(&|v| format!("{v:.0e}"))
            .x_label_formatter(&|v| super::format_tick(*v));
    } else {
        mesh.x_labels(0).y_labels(0);
    }
    mesh.draw()?;
    marks(&mut chart, panel, mlo, mhi)?;
    let m = &panel.measured;
    chart
        .draw_series(pts.iter().map(|p| dot(black)((p.0, p.1))))?
        .label(format!(
            "measured H1 ({} Hann segments of {} s, 50 % overlap)",
            m.segments,
            super::format_tick(m.segment_s)
        ))
        .legend(move |(x, y)| Circle::new((x + 10, y), 3, black.filled()));
    for (k, model) in panel.models.iter().enumerate() {
        let style = color(&model.name, k).stroke_width(2);
        let modes: Vec<String> = model
            .modes
            .iter()
            .enumerate()
            .map(|(i, &(w, z))| {
                format!(
                    "mode {}: {} Hz (ω = {} rad/s, ζ = {})",
                    i + 1,
                    sig(w / (2.0 * PI)),
                    sig(w),
                    sig(z)
                )
            })
            .collect();
        let fit = model
            .fit_percent
            .map_or(String::new(), |f| format!(", fit {f:.2} %"));
        chart
            .draw_series(LineSeries::new(
                panel
                    .grid_hz
                    .iter()
                    .copied()
                    .zip(model.magnitude.iter().copied()),
                style,
            ))?
            .label(format!(
                "{}: model, exact ZOH{fit}; {}",
                model.name,
                modes.join("; ")
            ))
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], style));
    }
    // The first model's modes numbered at the top of their lines.
    if let (true, Some(model)) = (text, panel.models.first()) {
        for (i, &(w, _)) in model.modes.iter().enumerate() {
            let f = w / (2.0 * PI);
            if f.is_finite() && f >= lo && f <= hi {
                chart.draw_series(std::iter::once(Text::new(
                    format!(" mode {}", i + 1),
                    (f, mhi / 1.6),
                    ("sans-serif", 14),
                )))?;
            }
        }
    }
    if text {
        chart
            .configure_series_labels()
            .label_font(("sans-serif", 13))
            .position(SeriesLabelPosition::LowerLeft)
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK)
            .draw()?;
    }

    // Phase.
    let phases = pts
        .iter()
        .map(|p| p.2)
        .chain(
            panel
                .models
                .iter()
                .flat_map(|m| m.phase_deg.iter().copied()),
        )
        .filter(|v| v.is_finite());
    let (plo, phi) = phases.fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
        (a.min(v), b.max(v))
    });
    let (plo, phi) = if plo.is_finite() {
        (
            (plo / 90.0).floor() * 90.0 - 20.0,
            (phi / 90.0).ceil() * 90.0 + 20.0,
        )
    } else {
        (-200.0, 200.0)
    };
    let mut chart =
        builder(&right[0], "phase", text).build_cartesian_2d((lo..hi).log_scale(), plo..phi)?;
    let mut mesh = chart.configure_mesh();
    if text {
        mesh.x_desc("f (Hz)")
            .y_desc("phase (°)")
            .label_style(("sans-serif", 14))
            .y_label_formatter(&|v| format!("{v:.0}"))
            .x_label_formatter(&|v| super::format_tick(*v));
    } else {
        mesh.x_labels(0).y_labels(0);
    }
    mesh.draw()?;
    marks(&mut chart, panel, plo, phi)?;
    chart.draw_series(pts.iter().map(|p| dot(black)((p.0, p.2))))?;
    for (k, model) in panel.models.iter().enumerate() {
        let style = color(&model.name, k).stroke_width(2);
        chart.draw_series(LineSeries::new(
            panel
                .grid_hz
                .iter()
                .copied()
                .zip(model.phase_deg.iter().copied()),
            style,
        ))?;
    }

    // Coherence.
    let mut chart = builder(&right[1], "coherence γ² of H1", text)
        .build_cartesian_2d((lo..hi).log_scale(), 0.0..1.05)?;
    let mut mesh = chart.configure_mesh();
    if text {
        mesh.x_desc("f (Hz)")
            .y_desc("γ² (1)")
            .label_style(("sans-serif", 14))
            .x_label_formatter(&|v| super::format_tick(*v));
    } else {
        mesh.x_labels(0).y_labels(0);
    }
    mesh.draw()?;
    marks(&mut chart, panel, 0.0, 1.05)?;
    chart.draw_series(pts.iter().map(|p| dot(black)((p.0, p.3))))?;
    Ok(())
}

/// Each model's modes as dashed vertical lines from `y0` to `y1`.
fn marks<Y: Ranged<ValueType = f64>>(
    chart: &mut ChartContext<'_, BitMapBackend<'_>, Cartesian2d<LogCoord<f64>, Y>>,
    panel: &FrfPanel,
    y0: f64,
    y1: f64,
) -> Result<(), Box<dyn std::error::Error>> {
    let (lo, hi) = panel.x_range();
    for (k, m) in panel.models.iter().enumerate() {
        let style = color(&m.name, k).mix(0.8).stroke_width(1);
        for &(w, _) in &m.modes {
            let f = w / (2.0 * PI);
            if f.is_finite() && f >= lo && f <= hi {
                chart.draw_series(DashedLineSeries::new([(f, y0), (f, y1)], 6, 4, style))?;
            }
        }
    }
    Ok(())
}

/// Four significant digits.
fn sig(v: f64) -> String {
    if !v.is_finite() {
        return "–".into();
    }
    let digits = (3 - v.abs().log10().floor() as i32).max(0) as usize;
    format!("{v:.digits$}")
}
