//! Which narrow lines of a fit's residual to remove before the estimate
//! is made again (replay's line pass, docs/REPLAY.md "Lines in y"), and
//! each one's frequency and phasor, from the record alone.
//!
//! A line the verdict lists ([`super::verdict::LineFound`]: a residual bin
//! [`super::verdict::LINE_RATIO`] times its neighbourhood's median, at
//! least [`super::verdict::LINE_LEVEL`] of y's RMS, where u has no line) is
//! removed when it is also
//! 1. **coherent**: one sinusoid of fixed amplitude and phase over the
//!    whole record holds at least [`COHERENT_SHARE`] of the line's RMS in
//!    the Welch spectrum. The mains is a fixed sinusoid; the response of a
//!    lightly damped mode to a random input, or a mode's free decay after
//!    an impact, is not (a decay of time constant τ keeps about 2τ/T of
//!    its power in such a sinusoid);
//! 2. **steady**: its amplitude in each quarter of the record is within a
//!    factor [`STEADY_FACTOR`] of the whole record's.
//!
//! Its frequency is refined to the maximum of the residual's discrete-time
//! Fourier transform within one Welch bin of the peak (golden-section
//! search, to 1e-6 of a bin), and its phasor (a, b) at the first sample is
//! the least-squares projection of the residual on cos and sin there: the
//! line canceller's initial weights for y ([`beamest::guard::lines`]).

use beamest::guard::lines::{LineSpec, MAX_LINES};
use serde::Serialize;
use std::f64::consts::TAU;

/// A line is removed only if one sinusoid over the record holds at least
/// this share of its RMS (module docs, 1).
pub const COHERENT_SHARE: f64 = 0.5;

/// A line is removed only if each quarter's amplitude is within this factor
/// of the record's (module docs, 2).
pub const STEADY_FACTOR: f64 = 2.0;

/// A line the replay removed, as reported.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct RemovedLine {
    /// Its refined frequency (Hz).
    pub freq_hz: f64,
    /// Its RMS in y (units of y), from the first pass's residual.
    pub rms: f64,
    /// The first pass's mode (1-based) in whose band it lay, if any.
    pub near_mode: Option<usize>,
    /// `detected` (found in the residual) or `named` (`--lines`, `--mains`).
    pub source: &'static str,
}

/// The phasor (a, b) of a·cos(2πf t_k) + b·sin(2πf t_k), t_k = k·Ts, that
/// best fits `x` (non-finite samples skipped): 2/n Σ x_k (cos, sin), the
/// least-squares fit when the record holds many periods.
pub fn phasor(x: &[f64], ts_s: f64, freq_hz: f64) -> [f64; 2] {
    let step = TAU * freq_hz * ts_s;
    let (cs, ss) = (step.cos(), step.sin());
    let (mut c, mut s) = (1.0f64, 0.0f64);
    let (mut a, mut b, mut n) = (0.0, 0.0, 0usize);
    for (k, &v) in x.iter().enumerate() {
        if v.is_finite() {
            a += v * c;
            b += v * s;
            n += 1;
        }
        let (nc, ns) = (c * cs - s * ss, s * cs + c * ss);
        // Resynchronize the rotation now and then (rounding of a long run).
        if k % 4096 == 4095 {
            let t = (k + 1) as f64 * step;
            (c, s) = (t.cos(), t.sin());
        } else {
            (c, s) = (nc, ns);
        }
    }
    if n == 0 {
        return [0.0, 0.0];
    }
    let g = 2.0 / n as f64;
    [a * g, b * g]
}

/// The frequency in [f0 − half, f0 + half] (Hz) where `x`'s phasor is
/// largest (golden-section search).
pub fn refine(x: &[f64], ts_s: f64, f0: f64, half_hz: f64) -> f64 {
    let power = |f: f64| {
        let [a, b] = phasor(x, ts_s, f);
        a * a + b * b
    };
    let r = 0.5 * (5f64.sqrt() - 1.0);
    let (mut lo, mut hi) = (f0 - half_hz, f0 + half_hz);
    let mut c = hi - r * (hi - lo);
    let mut d = lo + r * (hi - lo);
    let (mut pc, mut pd) = (power(c), power(d));
    while hi - lo > 1e-6 * half_hz {
        if pc > pd {
            hi = d;
            d = c;
            pd = pc;
            c = hi - r * (hi - lo);
            pc = power(c);
        } else {
            lo = c;
            c = d;
            pc = pd;
            d = lo + r * (hi - lo);
            pd = power(d);
        }
    }
    0.5 * (lo + hi)
}

/// Whether the line (frequency, whole-record amplitude) keeps its
/// amplitude in each quarter of `x` (module docs, 2).
fn steady(x: &[f64], ts_s: f64, freq_hz: f64, amplitude: f64) -> bool {
    let q = x.len() / 4;
    q > 0
        && (0..4).all(|i| {
            let part = &x[i * q..(i + 1) * q];
            let [a, b] = phasor(part, ts_s, freq_hz);
            let amp = a.hypot(b);
            amp <= STEADY_FACTOR * amplitude && amp * STEADY_FACTOR >= amplitude
        })
}

/// The lines of `found` ((frequency, Welch RMS, near mode) of the verdict's
/// lines, strongest first) that are coherent and steady in the residual
/// `x`, at most [`MAX_LINES`], with their canceller settings; `bin_hz` the
/// Welch bin spacing.
pub fn to_remove(
    found: &[(f64, f64, Option<usize>)],
    x: &[f64],
    ts_s: f64,
    bin_hz: f64,
) -> Vec<(LineSpec, RemovedLine)> {
    let nyquist = 0.5 / ts_s;
    let mut out: Vec<(LineSpec, RemovedLine)> = Vec::new();
    for &(f0, welch_rms, near_mode) in found {
        if out.len() == MAX_LINES {
            break;
        }
        let f = refine(x, ts_s, f0, bin_hz);
        if !(f > 0.0 && f < nyquist) || out.iter().any(|(s, _)| (s.freq_hz - f).abs() < bin_hz) {
            continue;
        }
        let p = phasor(x, ts_s, f);
        let amplitude = p[0].hypot(p[1]);
        let rms = amplitude / 2f64.sqrt();
        if rms < COHERENT_SHARE * welch_rms || !steady(x, ts_s, f, amplitude) {
            continue;
        }
        out.push((
            LineSpec {
                freq_hz: f,
                y_phasor: p,
            },
            RemovedLine {
                freq_hz: f,
                rms,
                near_mode,
                source: "detected",
            },
        ));
    }
    out
}

/// Named lines (`--lines`, `--mains`) with their phasors in the residual
/// `x` (each frequency refined within ± `half_hz`, e.g. the mains' ±1%).
pub fn named(
    freqs: &[f64],
    x: &[f64],
    ts_s: f64,
    half_hz: impl Fn(f64) -> f64,
) -> Vec<(LineSpec, RemovedLine)> {
    freqs
        .iter()
        .take(MAX_LINES)
        .map(|&f0| {
            let f = refine(x, ts_s, f0, half_hz(f0));
            let p = phasor(x, ts_s, f);
            (
                LineSpec {
                    freq_hz: f,
                    y_phasor: p,
                },
                RemovedLine {
                    freq_hz: f,
                    rms: p[0].hypot(p[1]) / 2f64.sqrt(),
                    near_mode: None,
                    source: "named",
                },
            )
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Gaussian noise of σ `sd` (xorshift64 and Box–Muller).
    fn noise(n: usize, seed: u64, sd: f64) -> Vec<f64> {
        let mut state = seed | 1;
        let mut uniform = move || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            ((state >> 11) as f64 + 0.5) / (1u64 << 53) as f64
        };
        (0..n)
            .map(|_| {
                let (u1, u2) = (uniform(), uniform());
                sd * (-2.0 * u1.ln()).sqrt() * (TAU * u2).cos()
            })
            .collect()
    }

    /// A steady line is found at its frequency and phasor; a decaying one
    /// (a mode's free decay) and a narrowband random process are not.
    #[test]
    fn a_steady_line_is_removed_and_a_decay_is_not() {
        let ts = 1e-4;
        let n = 100_000;
        let w = noise(n, 7, 0.01);
        let line: Vec<f64> = (0..n)
            .map(|k| {
                let t = k as f64 * ts;
                0.03 * (TAU * 50.37 * t).cos() - 0.02 * (TAU * 50.37 * t).sin() + w[k]
            })
            .collect();
        let got = to_remove(&[(50.0, 0.025, None)], &line, ts, 1.0);
        assert_eq!(got.len(), 1);
        let (spec, rep) = &got[0];
        assert!((spec.freq_hz - 50.37).abs() < 1e-3, "{}", spec.freq_hz);
        assert!(
            (spec.y_phasor[0] - 0.03).abs() < 5e-4,
            "{:?}",
            spec.y_phasor
        );
        assert!(
            (spec.y_phasor[1] + 0.02).abs() < 5e-4,
            "{:?}",
            spec.y_phasor
        );
        assert!(
            (rep.rms - 0.036_06 / 2f64.sqrt()).abs() < 5e-4,
            "{}",
            rep.rms
        );
        // A free decay of 0.5 s time constant in a 10 s record.
        let decay: Vec<f64> = (0..n)
            .map(|k| {
                let t = k as f64 * ts;
                (-t / 0.5).exp() * (TAU * 80.0 * t).sin() + w[k]
            })
            .collect();
        assert!(to_remove(&[(80.0, 0.16, Some(1))], &decay, ts, 1.0).is_empty());
        // A line that switches on halfway.
        let half: Vec<f64> = (0..n)
            .map(|k| {
                let t = k as f64 * ts;
                if k > n / 2 {
                    0.03 * (TAU * 60.0 * t).sin()
                } else {
                    0.0
                }
            })
            .collect();
        assert!(to_remove(&[(60.0, 0.015, None)], &half, ts, 1.0).is_empty());
    }
}
