//! The noise model of replay's prewhitening pass (docs/REPLAY.md,
//! "Coloured noise"): an autoregressive (AR) model of a fit's residual,
//! its order chosen by the Bayesian information criterion, and the
//! whitening filter A(q) it defines, applied identically to u and y.
//!
//! # Why an identical filter on u and y
//! With y = G(q)u + v and v = A(q)⁻¹e (e white: the AR model of v),
//! A(q)y = G(q)A(q)u + e: the same FIR filter on both leaves the u → y
//! transfer function unchanged (it commutes with G; both start from zero
//! history, as a beam at rest before the record) and makes the output
//! error white. An output-error estimator on the filtered pair then
//! minimizes Σ e², the Gaussian likelihood of the coloured-noise problem
//! (prediction-error form of a Box–Jenkins model with the noise model held
//! fixed), so its covariance reaches the Cramér–Rao bound for that noise
//! spectrum: F = Jᵀ Σ⁻¹ J = (A·J)ᵀ(A·J)/σ_e², the information of the
//! prewhitened output error. An output-error estimator on the raw pair is
//! consistent too, but weights every frequency alike, which is not
//! efficient when the noise spectrum is not flat.
//!
//! # The model
//! * **AR fit**: Yule–Walker on the residual's biased autocorrelation
//!   (mean removed), Levinson–Durbin ([`levinson`]), orders 0..=[`MAX_ORDER`].
//! * **Order**: the one that minimizes BIC(p) = N·ln σ²_p + p·ln N (σ²_p
//!   the order-p one-step prediction error variance; [`NoiseModel::fit`]).
//! * **When it is used** ([`NoiseModel::coloured`]): an order ≥ 1 chosen,
//!   a prediction gain σ²_0/σ²_p of at least [`COLOUR_GAIN`] (the AR model
//!   predicts at least 1 − 1/[`COLOUR_GAIN`] of the residual's power), and
//!   the colour is not the model's: a least-squares FIR of [`INPUT_LAGS`]
//!   taps on the whitened u explains no more of the whitened residual's
//!   power than independent noise would ([`input_share`] R² with N·R² ≤
//!   [`INPUT_EXPLAINED_MAX`], [`input_share_max`]). Noise is independent
//!   of u; a model error (a missing mode, a wrong numerator) is u filtered,
//!   and whitening it away would hide it from the verdict, which then
//!   tests the whitened record.

use serde::Serialize;

/// Highest AR order tried.
pub const MAX_ORDER: usize = 32;

/// The AR model is used when its prediction gain reaches this (it predicts
/// at least half of the residual's power). Below it the noise spectrum
/// varies little and an output-error estimate loses little by ignoring
/// it, while a model's own small error often reads so (docs/REPLAY.md,
/// "Coloured noise").
pub const COLOUR_GAIN: f64 = 2.0;

/// ... and the FIR of the whitened u explains at most this many
/// innovation variances of the whitened residual: N·R² ≤ 100, R² the
/// [`input_share`] over N samples. For a residual independent of u, N·R²
/// is χ² with [`INPUT_LAGS`] degrees of freedom (mean 16; above 100 with
/// probability 3.5e-14); a model error that is u filtered grows with N.
/// The threshold's margins on the lab records: docs/REPLAY.md, "Coloured
/// noise".
pub const INPUT_EXPLAINED_MAX: f64 = 100.0;

/// Taps of the FIR of u in [`input_share`].
pub const INPUT_LAGS: usize = 16;

/// Levinson–Durbin on the autocorrelation `r` (`r[0]` > 0): the one-step
/// prediction error variance of every order `0..r.len()` (as `r[0]` is the
/// order-0 one; same units), and the predictor a_1..a_p of the last
/// order reached (x̂_k = Σ a_i x_{k−i}). The recursion stops at the first
/// order whose reflection coefficient is not within (−1, 1) (numerical
/// breakdown): the errors then have fewer entries than `r`.
pub fn levinson(r: &[f64]) -> (Vec<f64>, Vec<f64>) {
    let mut errs = Vec::with_capacity(r.len());
    let Some(&r0) = r.first() else {
        return (errs, Vec::new());
    };
    if !(r0 > 0.0 && r0.is_finite()) {
        return (errs, Vec::new());
    }
    let mut a: Vec<f64> = Vec::with_capacity(r.len());
    let mut err = r0;
    errs.push(err);
    for m in 1..r.len() {
        let acc: f64 = r[m] - (1..m).map(|i| a[i - 1] * r[m - i]).sum::<f64>();
        let kappa = acc / err;
        if !(kappa.abs() < 1.0) {
            break;
        }
        let prev = a.clone();
        a.push(kappa);
        for i in 1..m {
            a[i - 1] = prev[i - 1] - kappa * prev[m - i - 1];
        }
        err *= 1.0 - kappa * kappa;
        errs.push(err);
    }
    (errs, a)
}

/// The AR model of a residual, as reported (`noise_model` of a replay
/// report) and as the whitening filter.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct NoiseModel {
    /// Its order p (0: white).
    pub order: usize,
    /// The whitening filter A(q) = 1 + c_1 q⁻¹ + … + c_p q⁻ᵖ: [1, c_1, …,
    /// c_p] (c_i = −a_i of the predictor).
    pub whitening: Vec<f64>,
    /// The residual's variance ÷ the model's one-step prediction error
    /// variance (1: white).
    pub prediction_gain: f64,
    /// RMS of the residual (units of y).
    pub residual_rms: f64,
    /// RMS of the innovation e = A(q)·residual (units of y): σ_e.
    pub innovation_rms: f64,
    /// Share of the whitened residual's power a FIR of the whitened u
    /// explains ([`input_share`]); `None` until computed.
    pub input_share: Option<f64>,
    /// The largest `input_share` that counts as independent of u for this
    /// record's length ([`input_share_max`]); `None` until computed.
    pub input_share_max: Option<f64>,
}

impl NoiseModel {
    /// The AR model of `residual` (non-finite samples count as 0, after the
    /// mean), its order by BIC up to `max_order`; `None` for fewer than
    /// 4·`max_order` finite samples or a zero residual.
    pub fn fit(residual: &[f64], max_order: usize) -> Option<Self> {
        let finite: Vec<f64> = residual.iter().copied().filter(|v| v.is_finite()).collect();
        let n = finite.len();
        if n < 4 * max_order.max(1) {
            return None;
        }
        let mean = finite.iter().sum::<f64>() / n as f64;
        let x: Vec<f64> = residual
            .iter()
            .map(|&v| if v.is_finite() { v - mean } else { 0.0 })
            .collect();
        let r: Vec<f64> = (0..=max_order)
            .map(|j| {
                x.get(j..)
                    .unwrap_or_default()
                    .iter()
                    .zip(&x)
                    .map(|(a, b)| a * b)
                    .sum::<f64>()
            })
            .collect();
        let (errs, _) = levinson(&r);
        let nf = n as f64;
        let bic = |p: usize, e: f64| nf * (e / nf).ln() + p as f64 * nf.ln();
        let (order, _) = errs
            .iter()
            .enumerate()
            .map(|(p, &e)| (p, bic(p, e)))
            .min_by(|a, b| a.1.total_cmp(&b.1))?;
        let (errs, a) = levinson(r.get(..=order)?);
        let err = *errs.last()?;
        let r0 = *r.first()?;
        let mut whitening = vec![1.0];
        whitening.extend(a.iter().map(|v| -v));
        Some(Self {
            order: a.len(),
            whitening,
            prediction_gain: r0 / err,
            residual_rms: (r0 / nf).sqrt(),
            innovation_rms: (err / nf).sqrt(),
            input_share: None,
            input_share_max: None,
        })
    }

    /// Whether this model's colour is the noise's and worth removing (the
    /// module docs, "When it is used"); the input share must have been
    /// computed.
    pub fn coloured(&self) -> bool {
        self.order >= 1
            && self.prediction_gain >= COLOUR_GAIN
            && matches!((self.input_share, self.input_share_max), (Some(s), Some(m)) if s <= m)
    }

    /// [`input_share`] of the whitened `residual` on the whitened `u`, and
    /// its limit for their length, set on this model.
    pub fn set_input_share(&mut self, residual: &[f64], u: &[f64]) {
        let (share, rows) = input_share(&self.whiten(residual), &self.whiten(u));
        self.input_share = Some(share);
        self.input_share_max = Some(input_share_max(rows));
    }

    /// `x` through the whitening filter (zero history; a non-finite
    /// sample is NaN in the output and its last finite value in the
    /// history, as [`Whitener`] does).
    pub fn whiten(&self, x: &[f64]) -> Vec<f64> {
        let mut w = Whitener::new(&self.whitening);
        x.iter().map(|&v| w.push(v, v).1).collect()
    }
}

/// The largest [`input_share`] of a regression on `rows` samples that
/// counts as independent of u: [`INPUT_EXPLAINED_MAX`]/`rows` (1 for no
/// rows).
pub fn input_share_max(rows: usize) -> f64 {
    if rows == 0 {
        1.0
    } else {
        (INPUT_EXPLAINED_MAX / rows as f64).min(1.0)
    }
}

/// The share of `e`'s power (after its mean) that a least-squares FIR of
/// [`INPUT_LAGS`] taps on `u` (after its mean) explains: R² of e_k on
/// u_k, …, u_{k−15}, and the samples (rows) it was computed on. Samples
/// with a non-finite e are left out (a non-finite u counts as its mean).
/// R² 0 for a constant u.
pub fn input_share(e: &[f64], u: &[f64]) -> (f64, usize) {
    const L: usize = INPUT_LAGS;
    let ok = |v: f64| v.is_finite();
    let mean = |x: &[f64]| {
        let (s, n) = x
            .iter()
            .filter(|v| ok(**v))
            .fold((0.0, 0usize), |(s, n), v| (s + v, n + 1));
        if n == 0 {
            0.0
        } else {
            s / n as f64
        }
    };
    let (me, mu) = (mean(e), mean(u));
    let mut g = [[0.0f64; L]; L];
    let mut h = [0.0f64; L];
    let mut ee = 0.0;
    let mut rows = 0usize;
    let mut lag = [0.0f64; L];
    for (k, (&ek, &uk)) in e.iter().zip(u).enumerate() {
        lag.rotate_right(1);
        lag[0] = if ok(uk) { uk - mu } else { 0.0 };
        if k + 1 < L || !ok(ek) {
            continue;
        }
        let ev = ek - me;
        ee += ev * ev;
        rows += 1;
        for i in 0..L {
            h[i] += lag[i] * ev;
            for j in 0..=i {
                g[i][j] += lag[i] * lag[j];
            }
        }
    }
    if !(ee > 0.0) {
        return (0.0, rows);
    }
    // Cholesky of G (lower part), with a ridge relative to its trace: lags
    // of a slow u are nearly collinear.
    let trace: f64 = (0..L).map(|i| g[i][i]).sum();
    if !(trace > 0.0) {
        return (0.0, rows);
    }
    for (i, row) in g.iter_mut().enumerate() {
        row[i] += 1e-12 * trace;
    }
    let mut l = [[0.0f64; L]; L];
    for i in 0..L {
        for j in 0..=i {
            let s: f64 = g[i][j] - (0..j).map(|k| l[i][k] * l[j][k]).sum::<f64>();
            if i == j {
                if !(s > 0.0) {
                    return (0.0, rows);
                }
                l[i][i] = s.sqrt();
            } else {
                l[i][j] = s / l[j][j];
            }
        }
    }
    // hᵀG⁻¹h = |L⁻¹h|².
    let mut z = [0.0f64; L];
    for i in 0..L {
        z[i] = (h[i] - (0..i).map(|k| l[i][k] * z[k]).sum::<f64>()) / l[i][i];
    }
    let r2 = (z.iter().map(|v| v * v).sum::<f64>() / ee).clamp(0.0, 1.0);
    (r2, rows)
}

/// The whitening filter on u and y, one pair at a time (zero history: the
/// record's samples before the first taken as 0). A non-finite sample
/// gives a NaN output on its channel (the estimator rejects it) and enters
/// the history as its channel's last finite value.
#[derive(Debug, Clone, PartialEq)]
pub struct Whitener {
    coeffs: Vec<f64>,
    /// Past inputs per channel, newest first.
    past_u: Vec<f64>,
    past_y: Vec<f64>,
}

impl Whitener {
    /// The filter [1, c_1, …, c_p] (as [`NoiseModel::whitening`]).
    pub fn new(coeffs: &[f64]) -> Self {
        let p = coeffs.len().saturating_sub(1);
        Self {
            coeffs: coeffs.to_vec(),
            past_u: vec![0.0; p],
            past_y: vec![0.0; p],
        }
    }

    /// Filter one pair.
    #[inline]
    pub fn push(&mut self, u: f64, y: f64) -> (f64, f64) {
        (
            Self::channel(&self.coeffs, &mut self.past_u, u),
            Self::channel(&self.coeffs, &mut self.past_y, y),
        )
    }

    fn channel(coeffs: &[f64], past: &mut [f64], x: f64) -> f64 {
        let (head, tail) = coeffs.split_first().unwrap_or((&1.0, &[]));
        let mut out = head * x;
        for (c, p) in tail.iter().zip(past.iter()) {
            out += c * p;
        }
        let keep = if x.is_finite() {
            x
        } else {
            past.first().copied().unwrap_or(0.0)
        };
        if !past.is_empty() {
            past.rotate_right(1);
            if let Some(first) = past.first_mut() {
                *first = keep;
            }
        }
        if x.is_finite() {
            out
        } else {
            f64::NAN
        }
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used, clippy::indexing_slicing)]
mod tests {
    use super::*;
    use beamest::rig::GaussianNoise;

    fn ar1(n: usize, a: f64, seed: u64) -> Vec<f64> {
        let mut g = GaussianNoise::<f64>::new(1.0, seed).unwrap();
        let mut x = 0.0;
        (0..n)
            .map(|_| {
                x = a * x + g.sample();
                x
            })
            .collect()
    }

    /// White noise: order 0, gain 1, not coloured; an AR(1) of pole 0.9:
    /// order 1 (BIC), its coefficient, gain 1/(1 − a²), and the whitened
    /// series is white again.
    #[test]
    fn bic_finds_the_order_and_the_filter_whitens() {
        let white = ar1(50_000, 0.0, 1);
        let m = NoiseModel::fit(&white, MAX_ORDER).unwrap();
        assert_eq!(m.order, 0, "{m:?}");
        assert!((m.prediction_gain - 1.0).abs() < 1e-9);
        let x = ar1(50_000, 0.9, 2);
        let mut m = NoiseModel::fit(&x, MAX_ORDER).unwrap();
        assert_eq!(m.order, 1, "{m:?}");
        assert!((m.whitening[1] + 0.9).abs() < 0.01, "{m:?}");
        assert!(
            (m.prediction_gain - 1.0 / (1.0 - 0.81)).abs() < 0.3,
            "{m:?}"
        );
        let w = m.whiten(&x);
        let again = NoiseModel::fit(&w, MAX_ORDER).unwrap();
        assert_eq!(again.order, 0, "{again:?}");
        m.set_input_share(&x, &ar1(50_000, 0.5, 3));
        // Independent of u: N·R² of the order of its 16 degrees of freedom.
        let n_r2 = m.input_share.unwrap() * 50_000.0;
        assert!(n_r2 < INPUT_EXPLAINED_MAX, "{m:?}");
        assert!(m.coloured());
    }

    /// A residual that is u filtered (a model error) is explained by the
    /// FIR of u; independent noise is not: over ten seeds its N·R² stays
    /// near its 16 degrees of freedom, far below the limit. A small model
    /// error, about 1% of the residual's power (N·R² ≈ 260), is above it.
    #[test]
    fn input_share_tells_model_error_from_noise() {
        let n = 20_000;
        let u = ar1(n, 0.5, 4);
        let noise = ar1(n, 0.0, 5);
        let err: Vec<f64> = (0..n)
            .map(|k| 0.7 * u[k] - 0.2 * u[k.saturating_sub(3)] + 0.1 * noise[k])
            .collect();
        let (share, rows) = input_share(&err, &u);
        assert!(share > 0.9);
        assert_eq!(rows, n - INPUT_LAGS + 1);
        let max = input_share_max(rows);
        assert!((max * rows as f64 - INPUT_EXPLAINED_MAX).abs() < 1e-9);
        let mut worst: f64 = 0.0;
        for seed in 10..20 {
            let (s, rows) = input_share(&ar1(n, 0.0, seed), &u);
            worst = worst.max(s * rows as f64);
        }
        assert!(worst < 0.5 * INPUT_EXPLAINED_MAX, "{worst}");
        let small: Vec<f64> = (0..n)
            .map(|k| 0.1 * u[k.saturating_sub(2)] + noise[k])
            .collect();
        let (s, rows) = input_share(&small, &u);
        assert!(s > input_share_max(rows), "{s}");
        assert_eq!(input_share(&noise, &vec![1.0; n]).0, 0.0);
        assert_eq!(input_share_max(0), 1.0);
    }

    /// Levinson–Durbin against an AR(2)'s exact autocorrelation: the
    /// predictor and the innovation variance; the fit's own prediction
    /// gain as [`crate::judge::fit`] reads it.
    #[test]
    fn levinson_recovers_an_ar2() {
        let (a1, a2) = (1.2, -0.5);
        // r(1) = a1 r(0)/(1 − a2); r(k) = a1 r(k−1) + a2 r(k−2).
        let mut r = vec![1.0, a1 / (1.0 - a2)];
        for k in 2..6 {
            r.push(a1 * r[k - 1] + a2 * r[k - 2]);
        }
        let (errs, a) = levinson(&r);
        assert_eq!(errs.len(), 6);
        assert!((a[0] - a1).abs() < 1e-12 && (a[1] - a2).abs() < 1e-12);
        assert!(a[2..].iter().all(|v| v.abs() < 1e-12));
        let var_e = 1.0 - a1 * r[1] - a2 * r[2];
        assert!((errs[2] - var_e).abs() < 1e-12 && (errs[5] - var_e).abs() < 1e-12);
    }

    #[test]
    fn whitener_passes_bad_samples_as_nan_and_keeps_the_history() {
        let mut w = Whitener::new(&[1.0, -0.5]);
        assert_eq!(w.push(2.0, 4.0), (2.0, 4.0));
        let (u, y) = w.push(1.0, f64::NAN);
        assert_eq!(u, 0.0);
        assert!(y.is_nan());
        // y's history holds its last finite value, 4.
        assert_eq!(w.push(0.0, 6.0), (-0.5, 4.0));
    }
}
