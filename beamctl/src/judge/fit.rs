//! Model output vs measured output, as in the paper's Figs. 5 and 8 and
//! MATLAB's `compare`: the identified transfer function B(s)/A(s) driven by
//! the recorded u (held over each sample, as the DAC holds it), against the
//! recorded y, as a fit percentage 100·(1 − ‖y − ŷ‖/‖y − ȳ‖). This is how a
//! user without the truth judges an estimate.
//!
//! # Method
//! * The model is simulated in its diagonal (partial-fraction) form,
//!   ŷ = Σ_i Re(r_i·x_i), x_i' = p_i·x_i + u with the poles p_i (roots of A)
//!   and residues r_i = B(p_i)/A'(p_i), discretised exactly under zero-order
//!   hold: x_i ← e^{p_iTs}·x_i + (e^{p_iTs} − 1)/p_i·u. A conjugate pair is
//!   one complex state (ŷ gets 2·Re). ŷ_k is read before u_k is applied,
//!   as the rig samples y.
//! * **Initial state.** A record need not start at rest, so the model's
//!   free response Σ_j c_j·b_j(k) (b_j: Re and Im of e^{p_i·kTs} per pair,
//!   e^{p·kTs} per real pole) is fitted by least squares in the same pass
//!   (normal equations of 2n unknowns, MATLAB's `compare` does the same by
//!   default). On a record that does start at rest it fits ≈ 0.
//! * Two passes, O(n) work per sample: the first forms the normal
//!   equations of the initial state (while the free response lives, until
//!   it is below 1e-30) and sums the residual after that; the second, over
//!   the live part only, the residual y − ŷ itself (not from the normal
//!   equations, which cancel badly when the free response is large). Samples with a non-finite y are left out
//!   of the sums; a non-finite u is replaced by the last finite one (as the
//!   estimator does).
//! * An unstable model has no meaningful fit (its output grows without
//!   bound): `None`.

use beamest::model::{TransferFunction, MAX_ORDER};
use beamest::poly::{roots_monic, Complex};

type C = Complex<f64>;

fn cexp(z: C) -> C {
    let m = z.re.exp();
    C::new(m * z.im.cos(), m * z.im.sin())
}

/// One first-order section of the diagonal form.
#[derive(Debug, Clone, Copy)]
struct Section {
    /// e^{pTs}.
    phi: C,
    /// (e^{pTs} − 1)/p.
    gamma: C,
    /// Output weight: 2r for a pair (ŷ += Re(weight·x)), r for a real pole.
    weight: C,
    /// A real pole (one basis function) or a pair (two).
    real: bool,
    /// |p| (rad/s): the mode's ω for a pair.
    omega_rad_s: f64,
}

/// The identified model, discretised for simulation.
#[derive(Debug, Clone)]
pub struct Model {
    sections: Vec<Section>,
    /// Number of free-response basis functions (= model order).
    basis: usize,
    /// Direct term D: ŷ_k gains D·u_{k−1}, the input held when y_k is read.
    direct: f64,
}

impl Model {
    /// Discretise `tf` = s^r·B(s)/A(s) (r of its output kind) at `ts_s`;
    /// `None` for an empty model, a pole at s = 0, repeated poles or
    /// non-finite coefficients. An acceleration output (r = 2) is biproper:
    /// its direct term is B's leading coefficient and the rest
    /// s²·B − b_{2n−2}·A is of degree 2n − 1.
    pub fn new(tf: &TransferFunction<f64>, ts_s: f64) -> Option<Self> {
        let d = tf.order();
        let b = tf.b.get(..d.checked_sub(1)?)?;
        let mut num = b.to_vec();
        num.extend(std::iter::repeat_n(0.0, tf.output.numerator_shift()));
        if num.len() == d + 1 {
            let direct = num[0];
            let rest: Vec<f64> = (0..d).map(|i| num[i + 1] - direct * tf.a[i]).collect();
            return Self::build(tf, ts_s, &rest, direct);
        }
        Self::build(tf, ts_s, &num, 0.0)
    }

    /// As [`Model::new`] for the model D + (s3·s^{d−1} + B(s))/A(s) of an
    /// estimator with residual terms (the feedthrough model: `s3` the
    /// numerator coefficient its modes cannot hold, `direct` = D; a strain
    /// output only, else `None`).
    pub fn with_residual(
        tf: &TransferFunction<f64>,
        ts_s: f64,
        s3: f64,
        direct: f64,
    ) -> Option<Self> {
        if tf.output != beam_protocol::OutputKind::Strain {
            return None;
        }
        let d = tf.order();
        let mut b = vec![s3];
        b.extend_from_slice(tf.b.get(..d.checked_sub(1)?)?);
        if !direct.is_finite() {
            return None;
        }
        Self::build(tf, ts_s, &b, direct)
    }

    /// The sections of B(s)/A(s), `b` the numerator (highest power first,
    /// degree < that of A), plus `direct`.
    fn build(tf: &TransferFunction<f64>, ts_s: f64, b: &[f64], direct: f64) -> Option<Self> {
        let d = tf.order();
        if d == 0 || d > MAX_ORDER || !(ts_s > 0.0) {
            return None;
        }
        let roots = roots_monic(&tf.a[..d]).ok()?;
        let poles = roots.as_slice();
        let mut sections = Vec::new();
        for (i, &p) in poles.iter().enumerate() {
            if p.im < 0.0 {
                continue; // the conjugate of the pole before it
            }
            // A'(p) = Π_{j≠i} (p − p_j); B(p) by Horner.
            let mut da = C::from_real(1.0);
            for (j, &q) in poles.iter().enumerate() {
                if j != i {
                    da = da * (p - q);
                }
            }
            let mut bp = C::from_real(0.0);
            for &bk in b {
                bp = bp * p + C::from_real(bk);
            }
            let r = bp / da;
            let real = p.im == 0.0;
            let phi = cexp(p.scale(ts_s));
            let gamma = (phi - C::from_real(1.0)) / p;
            let weight = if real { r } else { r.scale(2.0) };
            if !(phi.is_finite() && gamma.is_finite() && weight.is_finite()) || p.norm() == 0.0 {
                return None;
            }
            sections.push(Section {
                phi,
                gamma,
                weight,
                real,
                omega_rad_s: p.norm(),
            });
        }
        Some(Self {
            sections,
            basis: d,
            direct,
        })
    }

    /// True if every pole is in the open left half plane.
    pub fn is_stable(&self) -> bool {
        self.sections.iter().all(|s| s.phi.norm() < 1.0)
    }

    /// The frequency response of this sampled model (u held over each
    /// sample, y read at its start) at `f_hz`, for the sample interval
    /// `ts_s` it was made with: H(z) at z = e^{j2πf·Ts}, as (re, im). Each
    /// section x ← φx + γu contributes its weight·γ/(z − φ) (a pair: the
    /// real part taken as the sum with the conjugate pole's term).
    pub fn response(&self, f_hz: f64, ts_s: f64) -> (f64, f64) {
        let w = 2.0 * std::f64::consts::PI * f_hz * ts_s;
        let z = C::new(w.cos(), w.sin());
        // The direct term acts on the input held when y is read: D·z⁻¹.
        let mut h = C::from_real(self.direct) / z;
        for s in &self.sections {
            let term = |phi: C, gamma: C, weight: C| weight * gamma / (z - phi);
            if s.real {
                h = h + term(s.phi, s.gamma, s.weight);
            } else {
                let half = s.weight.scale(0.5);
                h = h
                    + term(s.phi, s.gamma, half)
                    + term(s.phi.conj(), s.gamma.conj(), half.conj());
            }
        }
        (h.re, h.im)
    }
}

/// Running state of one simulation pass (fixed-size: at most
/// [`MAX_ORDER`] sections).
struct Pass<'m> {
    model: &'m Model,
    /// Forced-response states.
    x: [C; MAX_ORDER],
    /// Free-response basis values e^{p·kTs} per section.
    z: [C; MAX_ORDER],
    last_u: f64,
}

impl<'m> Pass<'m> {
    fn new(model: &'m Model) -> Self {
        Self {
            model,
            x: [C::from_real(0.0); MAX_ORDER],
            z: [C::from_real(1.0); MAX_ORDER],
            last_u: 0.0,
        }
    }

    /// ŷ_forced(k), then advance with u_k; the basis is not needed (it has
    /// decayed below 1e-30).
    #[inline]
    fn step_forced(&mut self, u: f64) -> f64 {
        let mut y = self.model.direct * self.last_u;
        if u.is_finite() {
            self.last_u = u;
        }
        let u = self.last_u;
        for (s, x) in self.model.sections.iter().zip(self.x.iter_mut()) {
            y += s.weight.re * x.re - s.weight.im * x.im;
            *x = C::new(
                s.phi.re * x.re - s.phi.im * x.im + s.gamma.re * u,
                s.phi.re * x.im + s.phi.im * x.re + s.gamma.im * u,
            );
        }
        y
    }

    /// ŷ_forced(k) and the basis b_j(k) into `b`; then advance with u_k.
    fn step(&mut self, u: f64, b: &mut [f64]) -> f64 {
        let mut y = self.model.direct * self.last_u;
        let mut j = 0;
        for ((s, x), z) in self.model.sections.iter().zip(&self.x).zip(&self.z) {
            y += (s.weight * *x).re;
            b[j] = z.re;
            j += 1;
            if !s.real {
                b[j] = z.im;
                j += 1;
            }
        }
        if u.is_finite() {
            self.last_u = u;
        }
        let u = self.last_u;
        for ((s, x), z) in self.model.sections.iter().zip(&mut self.x).zip(&mut self.z) {
            *x = s.phi * *x + s.gamma.scale(u);
            *z = s.phi * *z;
        }
        y
    }
}

/// Result of [`fit`].
#[derive(Debug, Clone, PartialEq)]
pub struct Fit {
    /// 100·(1 − ‖y − ŷ‖/‖y − ȳ‖) (can be negative: worse than the mean).
    pub percent: f64,
    /// Coefficients of the fitted free response (the initial state).
    pub initial: Vec<f64>,
    /// RMS of the residual y − ŷ over the finite samples (units of y): an
    /// a-posteriori estimate of the measurement noise's σ when the model is
    /// right (it also holds any model error).
    pub residual_rms: f64,
    /// How much of the residual its own past predicts: var(ε) ÷ the
    /// one-step prediction error variance of an AR([`WHITENESS_LAGS`])
    /// model of ε (Yule–Walker, Levinson–Durbin). 1 for a white residual;
    /// a residual with structure (unmodelled dynamics, a line, an offset,
    /// coloured noise) reads more. Lags across a non-finite y are left out.
    pub residual_prediction_gain: f64,
    /// Per complex pole pair (a mode) of the model: its ω (rad/s) and the
    /// energy Σ_k of its fitted free response (the initial state's part of
    /// ŷ; units of y², ≈ (c_re² + c_im²)/2 ÷ (1 − |e^{pTs}|²)).
    pub free_response: Vec<(f64, f64)>,
    /// Σ (y − ȳ)² over the finite samples (units of y²).
    pub output_energy: f64,
}

/// Lags of the residual's AR model in [`Fit::residual_prediction_gain`].
pub const WHITENESS_LAGS: usize = 10;

/// Running lag products Σ ε_k·ε_{k−j}, j = 0..=[`WHITENESS_LAGS`], of a
/// residual sequence (a run of finite samples; a non-finite y restarts
/// the run).
#[derive(Debug, Clone, Default)]
struct LagSums {
    sums: [f64; WHITENESS_LAGS + 1],
    /// The last residuals, newest at `(head + WHITENESS_LAGS) % len`.
    last: [f64; WHITENESS_LAGS],
    /// Finite residuals in the current run (up to the ring's length).
    run: usize,
    head: usize,
}

impl LagSums {
    fn push(&mut self, r: f64) {
        self.sums[0] += r * r;
        for j in 1..=self.run.min(WHITENESS_LAGS) {
            let idx = (self.head + WHITENESS_LAGS - j) % WHITENESS_LAGS;
            self.sums[j] += r * self.last[idx];
        }
        self.last[self.head] = r;
        self.head = (self.head + 1) % WHITENESS_LAGS;
        self.run = (self.run + 1).min(WHITENESS_LAGS);
    }

    fn gap(&mut self) {
        self.run = 0;
    }

    fn add(&mut self, other: &Self) {
        for (a, b) in self.sums.iter_mut().zip(&other.sums) {
            *a += b;
        }
    }

    /// r(0) ÷ the AR model's prediction error variance (Levinson–Durbin on
    /// the autocorrelation r(j)); 1 when r(0) is zero or the recursion
    /// breaks down numerically.
    fn prediction_gain(&self) -> f64 {
        let r = &self.sums;
        if !(r[0] > 0.0 && r[0].is_finite()) {
            return 1.0;
        }
        let (errs, _) = super::noise::levinson(r);
        errs.last().map_or(1.0, |e| r[0] / e)
    }
}

/// Fit of `model` driven by the u of the record against its y (see the
/// module docs); `samples` gives the record from its start each time it is
/// called (it is read twice). `None` for an unstable model, fewer than two
/// finite y, a constant y, or a non-finite result.
pub fn fit<I: IntoIterator<Item = (f64, f64)>>(
    model: &Model,
    samples: impl Fn() -> I,
) -> Option<Fit> {
    if !model.is_stable() {
        return None;
    }
    let m = model.basis;
    let mut pass = Pass::new(model);
    let mut b = vec![0.0; m];
    let mut g = vec![0.0; m * m];
    let mut h = vec![0.0; m];
    // Sums of y and y² about the first finite y (no cancellation when the
    // mean is large), and of the squared residual after the free response
    // has died out (there the two passes would agree: it is taken here).
    let (mut n, mut shift, mut sy, mut syy, mut sse_tail) = (0u64, None, 0.0, 0.0, 0.0);
    // The free response decays: once every basis value is negligible the
    // normal equations are complete, and `dead` is where that happened.
    let mut basis_live = true;
    let mut dead = u64::MAX;
    let mut tail_lags = LagSums::default();
    let sections = model.sections.len();
    for (k, (u, y)) in (0u64..).zip(samples()) {
        let yf = if basis_live {
            if k % 1024 == 0 {
                basis_live = pass.z[..sections].iter().any(|z| z.norm() > 1e-30);
                if !basis_live {
                    dead = k;
                }
            }
            pass.step(u, &mut b)
        } else {
            pass.step_forced(u)
        };
        if !y.is_finite() {
            tail_lags.gap();
            continue;
        }
        n += 1;
        let y0 = *shift.get_or_insert(y);
        sy += y - y0;
        syy += (y - y0) * (y - y0);
        let r = y - yf;
        if basis_live {
            for i in 0..m {
                h[i] += b[i] * r;
                for j in 0..=i {
                    g[i * m + j] += b[i] * b[j];
                }
            }
        } else {
            sse_tail += r * r;
            tail_lags.push(r);
        }
    }
    if n < 2 {
        return None;
    }
    let mean = sy / n as f64;
    let sst = syy - n as f64 * mean * mean;
    let c = solve_spd(&mut g, &h, m).unwrap_or_else(|| vec![0.0; m]);
    // Second pass, only while the free response lives: the residual itself,
    // not from the normal equations (which cancel badly when the free
    // response is large).
    let mut pass = Pass::new(model);
    let mut sse_head = 0.0;
    let mut lags = LagSums::default();
    for (u, y) in samples()
        .into_iter()
        .take(usize::try_from(dead).unwrap_or(usize::MAX))
    {
        let yf = pass.step(u, &mut b);
        if y.is_finite() {
            let free: f64 = c.iter().zip(&b).map(|(c, b)| c * b).sum();
            let r = y - yf - free;
            sse_head += r * r;
            lags.push(r);
        } else {
            lags.gap();
        }
    }
    lags.add(&tail_lags);
    let percent = 100.0 * (1.0 - ((sse_head + sse_tail) / sst).sqrt());
    (sst > 0.0 && percent.is_finite()).then_some(Fit {
        percent,
        residual_rms: ((sse_head + sse_tail) / n as f64).sqrt(),
        residual_prediction_gain: lags.prediction_gain(),
        free_response: free_energies(model, &c),
        output_energy: sst,
        initial: c,
    })
}

/// Per pole pair of `model`: (|p|, energy of the free response with the
/// basis coefficients `c`); see [`Fit::free_response`].
fn free_energies(model: &Model, c: &[f64]) -> Vec<(f64, f64)> {
    let mut out = Vec::new();
    let mut j = 0;
    for s in &model.sections {
        if s.real {
            j += 1;
            continue;
        }
        let (a, b) = (
            c.get(j).copied().unwrap_or(0.0),
            c.get(j + 1).copied().unwrap_or(0.0),
        );
        j += 2;
        let r2 = s.phi.norm() * s.phi.norm();
        out.push((
            s.omega_rad_s,
            0.5 * (a * a + b * b) / (1.0 - r2).max(f64::MIN_POSITIVE),
        ));
    }
    out
}

/// The residual y_k − ŷ_k (ŷ with the fitted initial state) of every
/// sample, in order (NaN where y is not finite).
pub fn residuals<'a, I: IntoIterator<Item = (f64, f64)> + 'a>(
    model: &'a Model,
    fit: &'a Fit,
    samples: I,
) -> impl Iterator<Item = f64> + 'a {
    let mut pass = Pass::new(model);
    let mut b = vec![0.0; model.basis];
    let sections = model.sections.len();
    let mut live = true;
    (0u64..).zip(samples).map(move |(k, (u, y))| {
        if live && k % 1024 == 0 {
            live = pass.z[..sections].iter().any(|z| z.norm() > 1e-30);
        }
        if live {
            let yf = pass.step(u, &mut b);
            let free: f64 = fit.initial.iter().zip(&b).map(|(c, b)| c * b).sum();
            y - yf - free
        } else {
            y - pass.step_forced(u)
        }
    })
}

/// The model output ŷ_k (with the fitted initial state) for the samples
/// with index in `keep`, as (index, y, ŷ).
pub fn model_output(
    model: &Model,
    fit: &Fit,
    samples: impl IntoIterator<Item = (f64, f64)>,
    keep: std::ops::Range<u64>,
) -> Vec<(u64, f64, f64)> {
    let mut pass = Pass::new(model);
    let mut b = vec![0.0; model.basis];
    let mut out = Vec::with_capacity((keep.end.saturating_sub(keep.start)) as usize);
    for (k, (u, y)) in (0u64..).zip(samples) {
        if k >= keep.end {
            break;
        }
        let yf = pass.step(u, &mut b);
        if k >= keep.start {
            let free: f64 = fit.initial.iter().zip(&b).map(|(c, b)| c * b).sum();
            out.push((k, y, yf + free));
        }
    }
    out
}

/// Solve G·c = h for a symmetric positive semi-definite G given by its
/// lower triangle (row-major m×m), by Cholesky with a relative pivot floor;
/// `None` if G is empty or numerically zero.
fn solve_spd(g: &mut [f64], h: &[f64], m: usize) -> Option<Vec<f64>> {
    let scale = (0..m).map(|i| g[i * m + i]).fold(0.0, f64::max);
    if !(scale > 0.0 && scale.is_finite()) {
        return None;
    }
    let floor = 1e-12 * scale;
    let mut l = vec![0.0; m * m];
    for i in 0..m {
        for j in 0..=i {
            let mut s = g[i * m + j];
            for k in 0..j {
                s -= l[i * m + k] * l[j * m + k];
            }
            if i == j {
                l[i * m + i] = s.max(floor).sqrt();
            } else {
                l[i * m + j] = s / l[j * m + j];
            }
        }
    }
    let mut z = vec![0.0; m];
    for i in 0..m {
        let mut s = h[i];
        for k in 0..i {
            s -= l[i * m + k] * z[k];
        }
        z[i] = s / l[i * m + i];
    }
    let mut c = vec![0.0; m];
    for i in (0..m).rev() {
        let mut s = z[i];
        for k in i + 1..m {
            s -= l[k * m + i] * c[k];
        }
        c[i] = s / l[i * m + i];
    }
    c.iter().all(|v| v.is_finite()).then_some(c)
}

#[cfg(test)]
mod tests {
    use super::*;
    use beamest::excitation::SquareWave;
    use beamest::model::{paper_plant_tf, PAPER_B, PAPER_OMEGA, PAPER_ZETA};
    use beamest::rig::ModalPlant;

    fn paper_record(n: usize, skip: usize) -> Vec<(f64, f64)> {
        let mut p =
            ModalPlant::<f64>::with_numerator(&PAPER_OMEGA, &PAPER_ZETA, &PAPER_B, 1e-4).unwrap();
        let mut sq = SquareWave::<f64>::paper();
        let all: Vec<(f64, f64)> = (0..n + skip)
            .map(|_| {
                let u = sq.next_sample();
                (u, p.sample(u))
            })
            .collect();
        all[skip..].to_vec()
    }

    #[test]
    fn the_true_model_fits_its_own_output() {
        let model = Model::new(&paper_plant_tf(), 1e-4).unwrap();
        assert!(model.is_stable());
        let rec = paper_record(50_000, 0);
        let f = fit(&model, || rec.iter().copied()).unwrap();
        assert!(f.percent > 100.0 - 1e-6, "{}", f.percent);
        assert!(f.initial.iter().all(|c| c.abs() < 1e-9), "{:?}", f.initial);
    }

    /// A velocity or acceleration sensor's model s^r·B/A fits its own
    /// output exactly (the acceleration output's direct term included).
    #[test]
    fn each_output_kind_fits_its_own_output() {
        use beam_protocol::OutputKind;
        for output in OutputKind::ALL {
            let mut tf = paper_plant_tf();
            tf.output = output;
            let model = Model::new(&tf, 1e-4).unwrap();
            let mut p =
                ModalPlant::<f64>::with_numerator(&PAPER_OMEGA, &PAPER_ZETA, &PAPER_B, 1e-4)
                    .unwrap()
                    .with_output(output)
                    .unwrap();
            let mut sq = SquareWave::<f64>::paper();
            let rec: Vec<(f64, f64)> = (0..30_000)
                .map(|_| {
                    let u = sq.next_sample();
                    (u, p.sample(u))
                })
                .collect();
            let f = fit(&model, || rec.iter().copied()).unwrap();
            assert!(f.percent > 100.0 - 1e-6, "{output}: {}", f.percent);
            // The strain model does not explain an accelerometer.
            if output == OutputKind::Acceleration {
                let wrong = Model::new(&paper_plant_tf(), 1e-4).unwrap();
                assert!(fit(&wrong, || rec.iter().copied()).unwrap().percent < 50.0);
            }
        }
    }

    #[test]
    fn a_record_that_starts_in_motion_still_fits() {
        // 0.3 s in: the beam is moving; the initial state is fitted.
        let model = Model::new(&paper_plant_tf(), 1e-4).unwrap();
        let rec = paper_record(50_000, 3_000);
        let f = fit(&model, || rec.iter().copied()).unwrap();
        assert!(f.percent > 100.0 - 1e-4, "{}", f.percent);
        let out = model_output(&model, &f, rec.iter().copied(), 0..10);
        assert_eq!(out.len(), 10);
        for (_, y, yh) in out {
            assert!((y - yh).abs() < 1e-6 * y.abs().max(1e-4), "{y} {yh}");
        }
    }

    #[test]
    fn a_wrong_model_fits_worse_and_bad_rows_are_skipped() {
        let mut tf = paper_plant_tf();
        tf.a[3] *= 1.2; // ω1ω2 off by 20%
        let model = Model::new(&tf, 1e-4).unwrap();
        let mut rec = paper_record(50_000, 0);
        let good = fit(&model, || rec.iter().copied()).unwrap().percent;
        assert!(good < 90.0, "{good}");
        rec[100].1 = f64::NAN;
        rec[200].0 = f64::INFINITY;
        let f = fit(&model, || rec.iter().copied()).unwrap();
        assert!((f.percent - good).abs() < 1.0);
        // Degenerate inputs.
        assert_eq!(fit(&model, || vec![(0.0, 1.0)]), None);
        assert_eq!(fit(&model, || vec![(0.0, 1.0); 10]), None);
        // An unstable model has no fit.
        let mut tf = paper_plant_tf();
        tf.a[0] = -tf.a[0];
        let unstable = Model::new(&tf, 1e-4).unwrap();
        assert!(!unstable.is_stable());
        assert_eq!(fit(&unstable, || rec.iter().copied()), None);
        let empty = TransferFunction::<f64> {
            modes: 0,
            a: [0.0; 6],
            b: [0.0; 6],
            output: Default::default(),
        };
        assert!(Model::new(&empty, 1e-4).is_none());
    }
}
