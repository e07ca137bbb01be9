//! The output-error model of the robust estimator: a simulation of the
//! current estimate ŷ = B̂(s)/Â(s)·u driven by the held input only, and its
//! gradient ψ = ∂ŷ/∂θ, both in the normalized coordinates of
//! `filter_bank` (σ = s/ρ, ρ = λ; u/U0, y/Y0).
//!
//! * **Simulation.** ξ_k = σ^k/Ã(σ)·u (k = 0..D−1) are the states of the
//!   normalized 1/Â filter on the held u (exact zero-order hold), and
//!   ŷ = Σ_j θ_u,j·ξ_{D−2−j}. With θ = [θ_u, c] (c the normalized
//!   denominator, c_k = â_k/ρ^{D−k}) the u-part of the gradient is ξ itself.
//! * **Gradient of the denominator.** ∂ŷ/∂c_k = −σ^k/Ã·ŷ: the same 1/Â
//!   filter on the sampled ŷ with the interpolating hold of the bank.
//!
//! * **Output kinds.** For a velocity or acceleration sensor
//!   (`FilterConfig::output`, r = 1 or 2) the model is s^r·B̂/Â and
//!   ŷ = Σ_j θ_u,j·ξ_{D−2−j+r}, where ξ_D = σ^D/Ã·u = u − Σ_k c_k·ξ_k is
//!   the input itself (as the sample sees it: held from the sample before,
//!   or through the converters' timing kernel) less the states — the direct
//!   term. ŷ then jumps where u does, and the interpolating hold of the
//!   gradient filter assumes a smooth signal, so the filter is fed the
//!   strictly proper part ŷ − θ_u,0·u instead and the direct part's share
//!   of the gradient, θ_u,0·σ^k/Ã·u = θ_u,0·ξ_k, is added from the exact
//!   states.
//!
//! Everything is aligned at t_{n−2}, like `FilterBank::push`. Only the
//! simulated ŷ decides the fixed point (the residual y − ŷ), so ξ is a
//! double word when `T::COMPENSATED`; the gradient only sets the search
//! direction (an error in it costs efficiency, never bias: it is built from
//! u alone) and runs in plain working precision.

use crate::filter_bank::{FilterMatrices, InputTaps, OutputTiming, U_HIST, U_TAPS, WINDOW};
use crate::linalg::mat_vec;
use crate::scalar::compensated::{two_prod, Compensated, CompensatedArray, Dot2};
use crate::scalar::Real;
use beam_protocol::OutputKind;

/// One discretized normalized filter 1/Ã: Φ − I, the held-input gain and
/// the interpolating-hold taps, in working precision; with a converter
/// timing ([`OutputTiming`], not ideal) the held input's gain is replaced
/// by the timing's gains on the last inputs (the filter bank's u channel,
/// `filter_bank::timing`: the measured y_k is the model's output for the
/// input seen through the converters' kernel).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Filters<T, const D: usize> {
    phi_minus_i: [[T; D]; D],
    gain_u: [T; D],
    taps: [[T; D]; WINDOW],
    /// The timing's gains on u_{n−first−k}, k < `u_count`, over
    /// [t_n, t_{n+1}]; `u_count` = 0: the zero-order hold (`gain_u`).
    u_taps: [[T; D]; U_TAPS],
    u_first: usize,
    u_count: usize,
    /// r of the output kind (module docs, *Output kinds*).
    shift: usize,
    /// For r = 2: the normalized denominator c_k (ξ_D = u − Σ c_k·ξ_k) and
    /// the weights of the input history (u_{n−1} first) that give the
    /// input as the sample at t_n sees it.
    c: [T; D],
    direct_u: [T; U_KEEP],
}

/// Inputs the model keeps (newest first): the timing's reach.
pub(crate) const U_KEEP: usize = U_HIST;

impl<T: Real, const D: usize> Filters<T, D> {
    /// Discretize 1/Ã for normalized coefficients `c` (power k at index k)
    /// at ρ·Ts = `rho_ts` with the converters' `timing` (start-up or off the
    /// sample path: matrix exponentials). `None` for a timing whose kernel
    /// reaches a later input than the interval's own (an output less
    /// delayed than the sinc³'s group delay): the simulation runs forward
    /// without look-ahead.
    pub(crate) fn new(
        c: &[f64; D],
        rho_ts: f64,
        hold: crate::filter_bank::OutputHold,
        timing: &OutputTiming,
        output: OutputKind,
    ) -> Option<Self> {
        let m = FilterMatrices::<D>::new(c, rho_ts, hold);
        // The bank's weights are for t_{n−2} with u_n first; here the
        // output is read at t_n before u_n enters: u_{n−1−i} is the bank's
        // history entry i + 3.
        let w = timing.direct_weights();
        let mut f = Self {
            phi_minus_i: m.phi_minus_i.map(|r| r.map(T::from_f64)),
            gain_u: m.gain_u.map(T::from_f64),
            taps: m.taps_y.map(|r| r.map(T::from_f64)),
            u_taps: [[T::ZERO; D]; U_TAPS],
            u_first: 0,
            u_count: 0,
            shift: output.numerator_shift(),
            c: c.map(T::from_f64),
            direct_u: core::array::from_fn(|i| T::from_f64(w.get(i + 3).copied().unwrap_or(0.0))),
        };
        if !timing.is_ideal() {
            let (aug, n) = FilterMatrices::<D>::augmented(c, rho_ts);
            let t = InputTaps::<D>::new(&aug, n, timing);
            // The bank's taps are for the interval [t_{j}, t_{j+1}] with
            // j = n − 3 (its look-ahead): u_{j−i} is its history entry
            // 3 + i; here j = n.
            let first = t.first.checked_sub(3)?;
            if first + t.count > U_KEEP || t.count == 0 {
                return None;
            }
            for (dst, src) in f.u_taps.iter_mut().zip(t.gains.iter()).take(t.count) {
                *dst = src.map(T::from_f64);
            }
            f.u_first = first;
            f.u_count = t.count;
        }
        Some(f)
    }
}

/// Gradient ψ and residual ε = y − ŷ at t_{n−2}.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct OeSample<T, const NP: usize> {
    pub psi: [T; NP],
    pub eps: T,
}

/// Simulation and gradient states.
#[derive(Debug, Clone)]
pub(crate) struct OeModel<T, const D: usize, const NP: usize> {
    f: Filters<T, D>,
    /// θ_u of the simulated model (first D − 1 entries).
    num: [Compensated<T>; NP],
    /// ξ at t_n (before the push of u_n).
    xi: CompensatedArray<T, D>,
    /// ξ at t_{n−2}, t_{n−1}, t_n (working precision; the gradient).
    ring: [[T; D]; 3],
    /// Gradient filter states σ^k/Ã·ŷ at t_{n−2}.
    g: [T; D],
    yhat_win: [T; WINDOW],
    /// Measured y_{n−2}, y_{n−1}, y_n (scaled).
    y_delay: [T; 3],
    /// The held input the direct term acts on (r = 2; zero otherwise) at
    /// t_{n−2}, t_{n−1}, t_n.
    direct_ring: [T; 3],
    /// Inputs u_n, u_{n−1}, … (scaled, newest first; zero before the
    /// first): the timing's taps read them.
    u_hist: [T; U_KEEP],
}

impl<T: Real, const D: usize, const NP: usize> OeModel<T, D, NP> {
    /// The model with filters `f` (its 1/Ã) and numerator θ_u (the first
    /// D − 1 entries of `theta`), at rest: the plant is assumed at rest
    /// before the first sample, so a simulation started with it is exact.
    pub fn new(f: Filters<T, D>, theta: &CompensatedArray<T, NP>) -> Self {
        Self {
            f,
            num: core::array::from_fn(|j| {
                if j < D - 1 {
                    theta.get(j)
                } else {
                    Compensated::default()
                }
            }),
            xi: CompensatedArray::default(),
            ring: [[T::ZERO; D]; 3],
            g: [T::ZERO; D],
            yhat_win: [T::ZERO; WINDOW],
            y_delay: [T::ZERO; 3],
            direct_ring: [T::ZERO; 3],
            u_hist: [T::ZERO; U_KEEP],
        }
    }

    /// The input as the sample at t_n sees it (held from the sample
    /// before, or through the timing's kernel), from the history `hist`
    /// (u_{n−1} first): the direct term's input (module docs, *Output
    /// kinds*).
    #[inline]
    fn held_input(f: &Filters<T, D>, hist: &[T; U_KEEP]) -> T {
        let mut v = T::ZERO;
        for (w, u) in f.direct_u.iter().zip(hist.iter()) {
            v += *w * *u;
        }
        v
    }

    /// Σ c_k·ξ_k (ξ_D = u − this).
    #[inline]
    fn lambda_part(f: &Filters<T, D>, xi: &[T; D]) -> T {
        let mut v = T::ZERO;
        for (c, x) in f.c.iter().zip(xi.iter()) {
            v += *c * *x;
        }
        v
    }

    /// ŷ from the double-word ξ, split into its strictly proper part and,
    /// for a direct term (r = 2), θ_u,0·u with `u` the held input
    /// ([`OeModel::held_input`]; zero for r < 2).
    #[inline]
    fn output_parts(&self, xi: &CompensatedArray<T, D>, u: T) -> (T, T) {
        let r = self.f.shift;
        let mut acc = Dot2::<T>::new();
        for j in 0..D - 1 {
            if let Some(k) = (D - 2 + r).checked_sub(j).filter(|&k| k < D) {
                acc.add_product_dd(self.num[j], xi.get(k));
            }
        }
        if r < 2 {
            return (acc.value(), T::ZERO);
        }
        // θ_u,0·ξ_D = θ_u,0·u − θ_u,0·Σ c_k·ξ_k: the second term belongs
        // to the strictly proper part.
        let b = self.num[0].value();
        acc.add_value(Compensated::new(-(b * Self::lambda_part(&self.f, &xi.hi))));
        (acc.value(), b * u)
    }

    /// ŷ (both parts of [`OeModel::output_parts`]).
    #[inline]
    fn output(&self, xi: &CompensatedArray<T, D>, hist: &[T; U_KEEP]) -> T {
        let u = Self::held_input(&self.f, hist);
        let (sp, d) = self.output_parts(xi, u);
        sp + d
    }

    /// Shift the (scaled) input `u` in as u_n.
    #[inline]
    fn shift_in(hist: &mut [T; U_KEEP], u: T) {
        let h = *hist;
        *hist = core::array::from_fn(|k| match k.checked_sub(1) {
            Some(i) => h.get(i).copied().unwrap_or(T::ZERO),
            None => u,
        });
    }

    /// Advance ξ over [t_n, t_{n+1}] with the inputs `hist` (u_n first:
    /// held, or through the timing's taps).
    #[inline]
    fn advance(f: &Filters<T, D>, xi: &mut CompensatedArray<T, D>, hist: &[T; U_KEEP]) {
        let mut d = mat_vec(&f.phi_minus_i, &xi.hi);
        if T::COMPENSATED {
            let l = mat_vec(&f.phi_minus_i, &xi.lo);
            for i in 0..D {
                d[i] += l[i];
            }
        }
        if f.u_count == 0 {
            let u = hist[0];
            for i in 0..D {
                d[i] += f.gain_u[i] * u;
            }
        } else {
            for (g, uv) in f
                .u_taps
                .iter()
                .zip(hist.iter().skip(f.u_first))
                .take(f.u_count)
            {
                for i in 0..D {
                    d[i] += g[i] * *uv;
                }
            }
        }
        for i in 0..D {
            xi.add(i, d[i]);
        }
    }

    /// Set the simulation state at the first sample (before any push): ξ(t_0)
    /// = `xi0`. The gradient filter and the windows stay at rest.
    pub(crate) fn start_at(&mut self, xi0: &[T; D]) {
        for (i, v) in xi0.iter().enumerate() {
            self.xi.set(i, *v);
        }
    }

    /// The measured y_{n−2}, y_{n−1}, y_n (scaled) the next pushes compare
    /// the model with (after a replay that pushed other values).
    pub(crate) fn set_measured(&mut self, y: [T; 3]) {
        self.y_delay = y;
    }

    /// Push sample n (`u` held over [t_n, t_{n+1}), `y` sampled at t_n,
    /// both scaled); returns ψ and ε at t_{n−2}.
    #[inline]
    pub fn push(&mut self, u: T, y: T) -> OeSample<T, NP> {
        self.y_delay = [self.y_delay[1], self.y_delay[2], y];
        let r = self.f.shift;
        let held = if r == 2 {
            Self::held_input(&self.f, &self.u_hist)
        } else {
            T::ZERO
        };
        // The gradient filter takes the strictly proper part (module docs).
        let (yhat, _) = self.output_parts(&self.xi, held);
        self.yhat_win.copy_within(1.., 0);
        self.yhat_win[WINDOW - 1] = yhat;
        self.direct_ring = [self.direct_ring[1], self.direct_ring[2], held];
        let held_old = self.direct_ring[0];
        self.ring = [self.ring[1], self.ring[2], self.xi.values()];
        Self::shift_in(&mut self.u_hist, u);
        Self::advance(&self.f, &mut self.xi, &self.u_hist);
        let mut dg = mat_vec(&self.f.phi_minus_i, &self.g);
        for (tap, v) in self.f.taps.iter().zip(self.yhat_win.iter()) {
            for i in 0..D {
                dg[i] += tap[i] * *v;
            }
        }
        for i in 0..D {
            self.g[i] += dg[i];
        }
        let mut psi = [T::ZERO; NP];
        let xi_old = &self.ring[0];
        if r == 0 {
            for j in 0..D - 1 {
                psi[j] = xi_old[D - 2 - j];
            }
            for j in 0..D {
                psi[D - 1 + j] = -self.g[D - 1 - j];
            }
            return OeSample {
                psi,
                eps: self.y_delay[0] - self.yhat_win[3],
            };
        }
        // ξ_D = u − Σ c_k·ξ_k at t_{n−2} (r = 2).
        let xi_top = held_old - Self::lambda_part(&self.f, xi_old);
        for (j, p) in psi.iter_mut().enumerate().take(D - 1) {
            *p = xi_old.get(D - 2 + r - j).copied().unwrap_or(xi_top);
        }
        // ∂ŷ/∂c_k = −σ^k/Ã·ŷ: the strictly proper part's filter plus the
        // direct part's θ_u,0·σ^k/Ã·u = θ_u,0·ξ_k (r = 2).
        let b_top = if r == 2 { self.num[0].value() } else { T::ZERO };
        for j in 0..D {
            psi[D - 1 + j] = -(self.g[D - 1 - j] + b_top * xi_old[D - 1 - j]);
        }
        OeSample {
            psi,
            eps: self.y_delay[0] - (self.yhat_win[3] + b_top * held_old),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::excitation::SquareWave;
    use crate::filter_bank::OutputHold;
    use crate::model::{paper_plant_tf, PAPER_B, PAPER_OMEGA, PAPER_ZETA};
    use crate::rig::ModalPlant;

    /// θ = [θ_u, c] of the paper's plant for ρ = 100, U0 = 0.1, Y0 = 1e-3,
    /// read by a sensor of kind `output`.
    fn paper_theta(output: OutputKind) -> [f64; 7] {
        let tf = paper_plant_tf();
        let (u0, y0, rho) = (0.1, 1e-3, 100.0f64);
        let r = output.numerator_shift() as i32;
        let mut th = [0.0; 7];
        for j in 0..3 {
            let k = 2 - j; // power of b
            th[j] = tf.b[j] * u0 / (y0 * rho.powi(4 - k as i32 - r));
        }
        for j in 0..4 {
            let k = 3 - j; // power of a
            th[3 + j] = tf.a[j] / rho.powi(4 - k as i32);
        }
        th
    }

    fn model(th: &[f64; 7], output: OutputKind) -> OeModel<f64, 4, 7> {
        let c: [f64; 4] = core::array::from_fn(|k| th[6 - k]);
        let mut t = CompensatedArray::default();
        for (j, v) in th.iter().enumerate() {
            t.set(j, *v);
        }
        OeModel::new(
            Filters::new(&c, 1e-2, OutputHold::Quintic, &OutputTiming::IDEAL, output).unwrap(),
            &t,
        )
    }

    #[test]
    fn simulation_reproduces_the_plant() {
        for output in OutputKind::ALL {
            let mut plant =
                ModalPlant::<f64>::with_numerator(&PAPER_OMEGA, &PAPER_ZETA, &PAPER_B, 1e-4)
                    .unwrap()
                    .with_output(output)
                    .unwrap();
            let mut m = model(&paper_theta(output), output);
            let mut sq = SquareWave::<f64>::paper();
            let (mut worst, mut size) = (0.0f64, 0.0f64);
            for _ in 0..20_000 {
                let u = sq.next_sample();
                let y = plant.sample(u) / 1e-3;
                let s = m.push(u / 0.1, y);
                worst = worst.max(s.eps.abs());
                size = size.max(y.abs());
            }
            // The residual is rounding-level.
            assert!(worst < 1e-12 * size, "{output}: {worst} of {size}");
        }
    }

    #[test]
    fn gradient_matches_finite_differences() {
        for output in OutputKind::ALL {
            gradient_matches_finite_differences_for(output);
        }
    }

    fn gradient_matches_finite_differences_for(output: OutputKind) {
        let th = paper_theta(output);
        let run = |t: &[f64; 7]| {
            let mut m = model(t, output);
            let mut sq = SquareWave::<f64>::paper();
            let mut last = m.push(0.0, 0.0);
            for _ in 0..3_000 {
                last = m.push(sq.next_sample() / 0.1, 0.0);
            }
            last
        };
        let base = run(&th);
        for j in 0..7 {
            let h = 1e-6 * th[j].abs().max(1e-3);
            let (mut lo, mut hi) = (th, th);
            lo[j] -= h;
            hi[j] += h;
            // With y = 0 the residual is −ŷ, so ∂ŷ/∂θ_j = −∂ε/∂θ_j.
            let fd = -(run(&hi).eps - run(&lo).eps) / (2.0 * h);
            let g = base.psi[j];
            // A velocity or acceleration output's strictly proper part has
            // kinks where the held u steps, which the gradient filter's
            // interpolating hold smooths (an error in efficiency, never in
            // the fixed point): 2e-5 measured.
            let tol = if output == OutputKind::Strain {
                1e-5
            } else {
                1e-4
            };
            assert!(
                (fd - g).abs() <= tol * g.abs().max(1e-3),
                "{output} θ{j}: finite difference {fd}, gradient {g}"
            );
        }
    }
}

/// The initial state x0 that best explains `y` given the model (least
/// squares over the record, the model's free responses as regressors):
/// ŷ_n = ŷ0_n + F_n·x0 with ŷ0 the response from rest and F_n =
/// ∂ŷ_n/∂ξ(t_0). The normal equations are accumulated over consecutive
/// slices of the record (scaled `u`, `y`, as recorded; bit-identical to one
/// pass over the whole) and solved at the end.
#[derive(Debug, Clone)]
pub(crate) struct InitialFit<T, const D: usize> {
    /// The response from rest.
    rest: CompensatedArray<T, D>,
    /// Free responses from ξ(t_0) = e_k, k = 0..D−1.
    free: [CompensatedArray<T, D>; D],
    /// Normal equations Σf·fᵀ, Σf·r, by rows (double words when
    /// `T::COMPENSATED`: the sums run over the whole record, 20,000 terms,
    /// and in plain `f32` their rounding left a moving start 1.8e-3 off on
    /// ζ; solved in `f64`, off the sample path).
    g: [CompensatedArray<T, D>; D],
    h: CompensatedArray<T, D>,
    /// The inputs so far (newest first), for the response from rest.
    u_hist: [T; U_KEEP],
    /// Samples accumulated.
    pub pos: usize,
    /// A record of block means ([`InitialFit::push_blocks`]): the response
    /// from rest and the free responses summed over the readings of the
    /// block in progress, and their count.
    block_rest: T,
    block_free: [T; D],
    block_count: u32,
}

impl<T: Real, const D: usize> InitialFit<T, D> {
    /// Nothing accumulated.
    pub fn new() -> Self {
        Self {
            rest: CompensatedArray::default(),
            free: core::array::from_fn(|k| {
                let mut c = CompensatedArray::default();
                c.set(k, T::ONE);
                c
            }),
            g: [CompensatedArray::default(); D],
            h: CompensatedArray::default(),
            u_hist: [T::ZERO; U_KEEP],
            pos: 0,
            block_rest: T::ZERO,
            block_free: [T::ZERO; D],
            block_count: 0,
        }
    }

    /// Accumulate the next samples of the record (scaled `u`, `y`) through
    /// the model `m`.
    pub fn push<const NP: usize>(&mut self, m: &OeModel<T, D, NP>, u: &[T], y: &[T]) {
        for (&uk, &yk) in u.iter().zip(y) {
            // A rejected reading (NaN in the record) adds nothing.
            if yk.is_finite() {
                let r = yk - m.output(&self.rest, &self.u_hist);
                let none = [T::ZERO; U_KEEP];
                let f: [T; D] = core::array::from_fn(|k| m.output(&self.free[k], &none));
                for a in 0..D {
                    if T::COMPENSATED {
                        let (p, e) = two_prod(f[a], r);
                        self.h.add_dw(a, p, e);
                        for b in 0..D {
                            let (p, e) = two_prod(f[a], f[b]);
                            self.g[a].add_dw(b, p, e);
                        }
                    } else {
                        self.h.hi[a] += f[a] * r;
                        for b in 0..D {
                            self.g[a].hi[b] += f[a] * f[b];
                        }
                    }
                }
            }
            OeModel::<T, D, NP>::shift_in(&mut self.u_hist, uk);
            OeModel::<T, D, NP>::advance(&m.f, &mut self.rest, &self.u_hist);
            let none = [T::ZERO; U_KEEP];
            for fk in self.free.iter_mut() {
                OeModel::<T, D, NP>::advance(&m.f, fk, &none);
            }
            self.pos += 1;
        }
    }

    /// [`InitialFit::push`] on a record of block means, from the next
    /// sample up to `to` (a block boundary where the fit ends): the
    /// responses are summed over each block's readings and the block adds
    /// count·f̄·f̄ᵀ and count·f̄·r̄ (r̄ = the block's mean y − the mean
    /// response from rest) to the normal equations.
    pub fn push_blocks<const NP: usize, R: super::RecordStore<T>>(
        &mut self,
        m: &OeModel<T, D, NP>,
        rec: &R,
        to: usize,
    ) {
        for n in self.pos..to {
            if rec.valid(n) {
                self.block_rest += m.output(&self.rest, &self.u_hist);
                let none = [T::ZERO; U_KEEP];
                for (s, f) in self.block_free.iter_mut().zip(self.free.iter()) {
                    *s += m.output(f, &none);
                }
                self.block_count += 1;
            }
            OeModel::<T, D, NP>::shift_in(&mut self.u_hist, rec.u(n));
            OeModel::<T, D, NP>::advance(&m.f, &mut self.rest, &self.u_hist);
            let none = [T::ZERO; U_KEEP];
            for fk in self.free.iter_mut() {
                OeModel::<T, D, NP>::advance(&m.f, fk, &none);
            }
            self.pos = n + 1;
            if (n + 1) % R::BLOCK == 0 {
                let (mean, count) = rec.block(n / R::BLOCK);
                if count > 0 && self.block_count == count {
                    let c = T::from_usize(count as usize);
                    let r = mean - self.block_rest / c;
                    let fbar = self.block_free.map(|v| v / c);
                    for a in 0..D {
                        let fa = self.block_free[a];
                        if T::COMPENSATED {
                            let (p, e) = two_prod(fa, r);
                            self.h.add_dw(a, p, e);
                            for b in 0..D {
                                let (p, e) = two_prod(fa, fbar[b]);
                                self.g[a].add_dw(b, p, e);
                            }
                        } else {
                            self.h.hi[a] += fa * r;
                            for b in 0..D {
                                self.g[a].hi[b] += fa * fbar[b];
                            }
                        }
                    }
                }
                self.block_rest = T::ZERO;
                self.block_free = [T::ZERO; D];
                self.block_count = 0;
            }
        }
    }

    /// The least-squares initial state; `None` if the normal matrix is
    /// singular or the solution not finite.
    pub fn solve(&self) -> Option<[T; D]> {
        let dw = |c: &CompensatedArray<T, D>, i: usize| c.hi[i].to_f64() + c.lo[i].to_f64();
        let mut g: [[f64; D]; D] =
            core::array::from_fn(|a| core::array::from_fn(|b| dw(&self.g[a], b)));
        let h: [f64; D] = core::array::from_fn(|a| dw(&self.h, a));
        let x = crate::linalg::ldlt_solve_floored(&mut g, &h).ok()?;
        crate::linalg::all_finite(&x).then(|| x.map(T::from_f64))
    }
}
