//! The measured frequency response of a record, as structural-dynamics
//! tools estimate it: H1 = G_yu/G_uu with Welch averaging, and the
//! coherence γ² = |G_yu|²/(G_uu·G_yy). Drawn under the identified model's
//! response ([`crate::judge::fit::Model::response`]) by `--plot`
//! (`crate::io::plot`) and by the Python package's `plot_frf`.
//!
//! # Method
//! * The record is cut into segments of `segment_s` seconds overlapping
//!   by half (default: an eighth of the record, at least 1 s when the
//!   record is that long); each segment has its mean removed (missing
//!   samples, NaN, count as 0 after that) and a Hann window applied; the
//!   cross- and auto-spectra are summed over the segments.
//! * **Only frequencies where u has power are kept**: G_uu above 1e-6 of
//!   its peak, and not below half of a neighbouring bin's. A square wave or
//!   a multisine excites a comb of lines; between them H1 is noise, and
//!   the Hann window spreads each line into its two neighbouring bins at a
//!   quarter of its power, where H1 repeats the line's value at the wrong
//!   frequency. A broadband input (steps, PRBS, chirp) keeps almost every
//!   bin.

use rustfft::num_complex::Complex64;
use rustfft::FftPlanner;

/// An H1 estimate on the frequencies where u has power.
#[derive(Debug, Clone, PartialEq)]
pub struct H1 {
    /// Frequency (Hz), increasing.
    pub f_hz: Vec<f64>,
    /// H1 = G_yu/G_uu, real part (units of y per unit of u).
    pub re: Vec<f64>,
    /// Imaginary part.
    pub im: Vec<f64>,
    /// Coherence γ², 0..1.
    pub coherence: Vec<f64>,
    /// Segments averaged.
    pub segments: usize,
    /// Segment length (s).
    pub segment_s: f64,
}

/// Bins either side of a bin whose median is a line's background
/// ([`PowerSpectrum::lines`]).
pub const LINE_NEIGHBOURHOOD: usize = 16;

/// Fewest samples a segment may have.
pub const MIN_SEGMENT: usize = 16;

/// H1 and the coherence of `u`, `y` (equal lengths) sampled every `ts_s`;
/// `segment_s` the Welch segment length (see the module docs for the
/// default). `None` for fewer than [`MIN_SEGMENT`] samples, or no
/// frequency where u has power.
pub fn h1(u: &[f64], y: &[f64], ts_s: f64, segment_s: Option<f64>) -> Option<H1> {
    let n = u.len().min(y.len());
    if n < MIN_SEGMENT || !(ts_s > 0.0) {
        return None;
    }
    let welch = Welch::new(n, ts_s, segment_s);
    let len = welch.len;
    let bins = len / 2 + 1;
    let (mut guu, mut gyy) = (vec![0.0; bins], vec![0.0; bins]);
    let mut gyu = vec![Complex64::new(0.0, 0.0); bins];
    let mut fu = vec![Complex64::new(0.0, 0.0); len];
    let mut fy = vec![Complex64::new(0.0, 0.0); len];
    let mut segments = 0;
    for start in welch.starts(n) {
        welch.transform(&mut fu, &u[start..start + len]);
        welch.transform(&mut fy, &y[start..start + len]);
        for k in 0..bins {
            guu[k] += fu[k].norm_sqr();
            gyy[k] += fy[k].norm_sqr();
            gyu[k] += fy[k] * fu[k].conj();
        }
        segments += 1;
    }
    let peak = guu.iter().copied().fold(0.0, f64::max);
    let mut out = H1 {
        f_hz: Vec::new(),
        re: Vec::new(),
        im: Vec::new(),
        coherence: Vec::new(),
        segments,
        segment_s: len as f64 * ts_s,
    };
    for k in 1..bins {
        let neighbour = guu[k - 1].max(guu.get(k + 1).copied().unwrap_or(0.0));
        if !(guu[k] > 1e-6 * peak && guu[k] >= 0.5 * neighbour) {
            continue;
        }
        let h = gyu[k] / guu[k];
        let coh = gyu[k].norm_sqr() / (guu[k] * gyy[k]);
        out.f_hz.push(k as f64 / (len as f64 * ts_s));
        out.re.push(h.re);
        out.im.push(h.im);
        out.coherence.push(if coh.is_finite() {
            coh.clamp(0.0, 1.0)
        } else {
            0.0
        });
    }
    (!out.f_hz.is_empty()).then_some(out)
}

/// Welch's segmenting: Hann-windowed segments overlapping by half.
struct Welch {
    len: usize,
    window: Vec<f64>,
    fft: std::sync::Arc<dyn rustfft::Fft<f64>>,
}

impl Welch {
    /// Segments of `segment_s` seconds (default: an eighth of the record,
    /// at least 1 s when the record is that long) of a record of `n ≥`
    /// [`MIN_SEGMENT`] samples.
    fn new(n: usize, ts_s: f64, segment_s: Option<f64>) -> Self {
        let record_s = n as f64 * ts_s;
        let segment_s = segment_s.unwrap_or_else(|| record_s.min(1.0).max(record_s / 8.0));
        let len = ((segment_s / ts_s).round() as usize).clamp(MIN_SEGMENT, n);
        let window = (0..len)
            .map(|k| 0.5 - 0.5 * (2.0 * std::f64::consts::PI * k as f64 / (len - 1) as f64).cos())
            .collect();
        Self {
            len,
            window,
            fft: FftPlanner::<f64>::new().plan_fft_forward(len),
        }
    }

    /// The first sample of each segment.
    fn starts(&self, n: usize) -> impl Iterator<Item = usize> {
        let len = self.len;
        (0..).step_by(len / 2).take_while(move |s| s + len <= n)
    }

    /// The spectrum of segment `x` (its mean removed; a missing sample,
    /// NaN, counts as 0 after that; Hann-windowed) into `buf`.
    fn transform(&self, buf: &mut [Complex64], x: &[f64]) {
        let finite = x.iter().filter(|v| v.is_finite());
        let count = finite.clone().count().max(1);
        let mean = finite.sum::<f64>() / count as f64;
        for ((b, &v), w) in buf.iter_mut().zip(x).zip(&self.window) {
            let d = if v.is_finite() { v - mean } else { 0.0 };
            *b = Complex64::new(d * w, 0.0);
        }
        self.fft.process(buf);
    }
}

/// The power spectrum of a signal (Welch, the segmenting of [`h1`]),
/// accumulated from a stream of samples, to ask what share of its power
/// lies in a band (the input's, for the verdict) and which narrow lines
/// stand out of it (the residual's).
#[derive(Debug, Clone)]
pub struct PowerSpectrum {
    /// Bin spacing (Hz).
    df: f64,
    /// Summed |U_k|² of bins 0..=len/2.
    guu: Vec<f64>,
    /// The sum of `guu` over the non-zero frequencies.
    total: f64,
}

impl PowerSpectrum {
    /// The spectrum of the `n` samples `u` yields (its first `n`); `None`
    /// for fewer than [`MIN_SEGMENT`] samples.
    pub fn of(u: impl IntoIterator<Item = f64>, n: usize, ts_s: f64) -> Option<Self> {
        if n < MIN_SEGMENT || !(ts_s > 0.0) {
            return None;
        }
        let welch = Welch::new(n, ts_s, None);
        let len = welch.len;
        let mut guu = vec![0.0; len / 2 + 1];
        let mut buf = vec![Complex64::new(0.0, 0.0); len];
        let mut segment: Vec<f64> = Vec::with_capacity(len);
        for x in u.into_iter().take(n) {
            segment.push(x);
            if segment.len() == len {
                welch.transform(&mut buf, &segment);
                for (g, b) in guu.iter_mut().zip(&buf) {
                    *g += b.norm_sqr();
                }
                segment.drain(..len / 2);
            }
        }
        let total = guu[1..].iter().sum();
        Some(Self {
            df: 1.0 / (len as f64 * ts_s),
            guu,
            total,
        })
    }

    /// Bin spacing (Hz).
    pub fn bin_hz(&self) -> f64 {
        self.df
    }

    /// Whether a bin within one of `freq_hz` is a line by the test of
    /// [`PowerSpectrum::lines`] (`ratio` times its neighbourhood's median).
    pub fn has_line_at(&self, freq_hz: f64, ratio: f64) -> bool {
        let g = &self.guu;
        let k = (freq_hz / self.df).round() as usize;
        (k.saturating_sub(1).max(1)..=(k + 1).min(g.len() - 1)).any(|j| {
            let lo = j.saturating_sub(LINE_NEIGHBOURHOOD).max(1);
            let hi = (j + LINE_NEIGHBOURHOOD).min(g.len() - 1);
            let mut window: Vec<f64> = g[lo..=hi].to_vec();
            window.sort_by(f64::total_cmp);
            g[j] > 0.0 && g[j] >= ratio * window[window.len() / 2]
        })
    }

    /// Narrow lines: bins whose power is at least `ratio` times the median
    /// of the bins within ±[`LINE_NEIGHBOURHOOD`] of them and the largest
    /// of their neighbours (a Hann-windowed line covers about three bins),
    /// as (frequency of the peak bin, Hz; the share of the power at every
    /// non-zero frequency in the peak and its two neighbours), strongest
    /// first.
    pub fn lines(&self, ratio: f64) -> Vec<(f64, f64)> {
        let g = &self.guu;
        let total = self.total;
        if !(total > 0.0 && total.is_finite()) || g.len() < 2 * LINE_NEIGHBOURHOOD + 3 {
            return Vec::new();
        }
        let mut found = Vec::new();
        let mut window = Vec::with_capacity(2 * LINE_NEIGHBOURHOOD + 1);
        for k in 2..g.len() - 1 {
            if !(g[k] >= g[k - 1] && g[k] > g[k + 1]) {
                continue;
            }
            let lo = k.saturating_sub(LINE_NEIGHBOURHOOD).max(1);
            let hi = (k + LINE_NEIGHBOURHOOD).min(g.len() - 1);
            window.clear();
            window.extend_from_slice(&g[lo..=hi]);
            window.sort_by(f64::total_cmp);
            let median = window[window.len() / 2];
            if g[k] >= ratio * median && median >= 0.0 {
                let power = g[k - 1] + g[k] + g[k + 1];
                found.push((k as f64 * self.df, power / total));
            }
        }
        found.sort_by(|a, b| b.1.total_cmp(&a.1));
        found
    }

    /// The share of the power at every non-zero frequency that lies in
    /// `[lo_hz, hi_hz]`; `None` for an input without power (constant).
    pub fn share(&self, lo_hz: f64, hi_hz: f64) -> Option<f64> {
        if !(self.total > 0.0 && self.total.is_finite()) {
            return None;
        }
        // The bins k with lo ≤ k·Δf ≤ hi (k ≥ 1).
        let last = self.guu.len() - 1;
        let first = ((lo_hz / self.df).ceil().max(1.0) as usize).min(last + 1);
        let end = ((hi_hz / self.df).floor().max(0.0) as usize).min(last);
        let in_band: f64 = self.guu.get(first..=end).map_or(0.0, |b| b.iter().sum());
        Some(in_band / self.total)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::judge::fit::Model;
    use beamest::model::{TransferFunction, MAX_ORDER};

    /// A sampled one-mode model driven by a square wave and a broadband
    /// input: H1 on the kept lines is the model's exact-ZOH response.
    #[test]
    fn h1_of_a_simulated_record_is_the_models_response() {
        let ts = 1e-4;
        let (w, z) = (2.0 * std::f64::consts::PI * 12.0, 0.05);
        let mut tf = TransferFunction {
            modes: 1,
            a: [0.0; MAX_ORDER],
            b: [0.0; MAX_ORDER],
            output: Default::default(),
        };
        tf.a[..2].copy_from_slice(&[2.0 * z * w, w * w]);
        tf.b[0] = 3.0e3;
        let model = Model::new(&tf, ts).unwrap();
        for input in ["square", "steps"] {
            let n = 40_000u64;
            let mut state = 0x2545_f491_4f6c_dd1du64;
            let mut level = 0.0;
            let u: Vec<f64> = (0..n)
                .map(|k| match input {
                    "square" => {
                        if (k as f64 * ts * 5.0).fract() < 0.5 {
                            1.0
                        } else {
                            -1.0
                        }
                    }
                    _ => {
                        if k % 50 == 0 {
                            state ^= state << 13;
                            state ^= state >> 7;
                            state ^= state << 17;
                            level = (state >> 11) as f64 / (1u64 << 53) as f64 - 0.5;
                        }
                        level
                    }
                })
                .collect();
            // The model from rest (no free response) driven by u.
            let rest = crate::judge::fit::Fit {
                percent: 0.0,
                initial: vec![0.0; 2],
                residual_rms: 0.0,
                residual_prediction_gain: 1.0,
                free_response: Vec::new(),
                output_energy: 0.0,
            };
            let y: Vec<f64> =
                crate::judge::fit::model_output(&model, &rest, u.iter().map(|&v| (v, 0.0)), 0..n)
                    .into_iter()
                    .map(|o| o.2)
                    .collect();
            let m = h1(&u, &y, ts, None).unwrap();
            assert_eq!(m.segments, 7, "{input}");
            let mut checked = 0;
            for k in 0..m.f_hz.len() {
                if m.coherence[k] < 0.999 || m.f_hz[k] > 500.0 {
                    continue;
                }
                let (re, im) = model.response(m.f_hz[k], ts);
                let err = (re - m.re[k]).hypot(im - m.im[k]) / re.hypot(im);
                assert!(err < 0.02, "{input} at {} Hz: {err}", m.f_hz[k]);
                checked += 1;
            }
            assert!(checked >= 10, "{input}: {checked}");
        }
    }

    #[test]
    fn too_short_or_silent_records_have_no_frf() {
        assert_eq!(h1(&[1.0; 8], &[1.0; 8], 1e-3, None), None);
        assert_eq!(h1(&[0.0; 100], &[1.0; 100], 1e-3, None), None);
    }
}
