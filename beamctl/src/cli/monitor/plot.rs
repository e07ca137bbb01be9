//! `--plot`: ω̂_i (left) and ζ̂_i (right) vs device time, one row per mode,
//! from every estimate received (at most [`MAX_POINTS`] per line). There
//! is no truth on a live device: the y range is the 1st–99th percentile of
//! the values after the first 5 % of the run (the start-up transient),
//! widened by 10 % (at least ±0.5 % of the median).
//!
//! The font is found as for `beamctl simulate --plot` (`crate::io::plot`).

use super::state::{Point, State};
use crate::error::CliError;
use plotters::prelude::*;
use std::path::Path;

/// Most points per line.
const MAX_POINTS: usize = 5000;
const COLOR: RGBColor = RGBColor(31, 119, 180);

/// Draw the plot; returns whether text was drawn (a font was found).
pub fn write(path: &Path, st: &State) -> Result<bool, CliError> {
    let fail = |e: &dyn std::fmt::Display| {
        CliError::failure(format!("--plot: drawing {}: {e}", path.display()))
    };
    let Some(fs) = st.host.sample_rate_hz() else {
        return Err(CliError::failure(
            "--plot: no sample rate known (no Status received; give --sample-rate)",
        ));
    };
    if st.history.is_empty() {
        return Err(CliError::failure("--plot: no estimates received"));
    }
    let text = crate::io::plot::ensure_font();
    let n = st.modes().max(1);
    let stride = st.history.len().div_ceil(MAX_POINTS).max(1);
    let pts: Vec<&Point> = st.history.iter().step_by(stride).collect();
    let t = |p: &Point| p.sample_index as f64 / fs;
    let t0 = pts.first().map_or(0.0, |p| t(p));
    let t1 = pts.last().map_or(1.0, |p| t(p)).max(t0 + 1e-6);
    let (w, h) = (1400u32, 60 + 330 * n as u32);
    let root = BitMapBackend::new(path, (w, h)).into_drawing_area();
    root.fill(&WHITE).map_err(|e| fail(&e))?;
    let body = if text {
        let title = format!("beamctl monitor: {}", st.source);
        root.titled(&title, ("sans-serif", 22))
            .map_err(|e| fail(&e))?
    } else {
        root.margin(40, 0, 0, 0)
    };
    let panels = body.split_evenly((n, 2));
    for i in 0..n {
        for (k, (label, get)) in [
            (
                format!("estimated ω{} (rad/s)", i + 1),
                (|p: &Point, i: usize| p.omega[i]) as fn(&Point, usize) -> f64,
            ),
            (format!("estimated ζ{}", i + 1), |p: &Point, i: usize| {
                p.zeta[i]
            }),
        ]
        .into_iter()
        .enumerate()
        {
            let line: Vec<(f64, f64)> = pts.iter().map(|p| (t(p), get(p, i))).collect();
            panel(&panels[2 * i + k], &label, &line, (t0, t1), text).map_err(|e| fail(&e))?;
        }
    }
    root.present().map_err(|e| fail(&e))?;
    Ok(text)
}

/// The y range (see the module docs).
pub fn y_range(line: &[(f64, f64)], (t0, t1): (f64, f64)) -> (f64, f64) {
    let skip = t0 + 0.05 * (t1 - t0);
    let mut v: Vec<f64> = line
        .iter()
        .filter(|(t, v)| *t >= skip && v.is_finite())
        .map(|p| p.1)
        .collect();
    if v.is_empty() {
        v = line.iter().map(|p| p.1).filter(|v| v.is_finite()).collect();
    }
    if v.is_empty() {
        return (0.0, 1.0);
    }
    v.sort_by(f64::total_cmp);
    let q = |p: f64| v[((v.len() - 1) as f64 * p).round() as usize];
    let (lo, hi, mid) = (q(0.01), q(0.99), q(0.5));
    let half = (0.55 * (hi - lo)).max(0.005 * mid.abs()).max(1e-12);
    let c = 0.5 * (lo + hi);
    (c - half, c + half)
}

fn panel(
    area: &DrawingArea<BitMapBackend<'_>, plotters::coord::Shift>,
    label: &str,
    line: &[(f64, f64)],
    (t0, t1): (f64, f64),
    text: bool,
) -> Result<(), Box<dyn std::error::Error>> {
    let (lo, hi) = y_range(line, (t0, t1));
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
    let mut chart = builder.build_cartesian_2d(t0..t1, lo..hi)?;
    let mut mesh = chart.configure_mesh();
    if text {
        mesh.x_desc("device time t (s)")
            .label_style(("sans-serif", 14))
            .x_labels(8)
            .y_labels(6);
    } else {
        mesh.x_labels(0).y_labels(0);
    }
    mesh.draw()?;
    for segment in line.split(|(_, v)| !v.is_finite()) {
        if segment.is_empty() {
            continue;
        }
        let clamped = segment.iter().map(|&(t, v)| (t, v.clamp(lo, hi)));
        chart.draw_series(LineSeries::new(clamped, COLOR.stroke_width(1)))?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn y_range_skips_the_transient() {
        let line: Vec<(f64, f64)> = (0..100)
            .map(|k| {
                (
                    k as f64 * 0.1,
                    if k < 3 { 1e6 } else { 40.0 + 0.01 * k as f64 },
                )
            })
            .collect();
        let (lo, hi) = y_range(&line, (0.0, 9.9));
        assert!(
            lo < 40.05 && lo > 39.0 && hi > 40.98 && hi < 42.0,
            "{lo} {hi}"
        );
        // Flat: still a visible band around the value.
        let flat: Vec<(f64, f64)> = (0..10).map(|k| (k as f64, 0.02)).collect();
        let (lo, hi) = y_range(&flat, (0.0, 9.0));
        assert!(lo < 0.02 && hi > 0.02 && hi - lo >= 1e-4);
    }
}
