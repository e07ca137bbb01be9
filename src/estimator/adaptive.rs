//! The proposed adaptive law (Section III.B, eqs. 33–41), discretized
//! exactly where the paper's ODEs allow it and implicitly where they do not,
//! in a form that holds its accuracy in `f32` for hours.
//!
//! Continuous law, in scaled coordinates (φ, y_s, θ_s; see
//! `filter_bank::Scaling`):
//!
//! * P' = −lP + φφᵀ, Q' = −lQ + φy (eq. 33),
//! * W = Pθ − Q (eq. 35),
//! * H' = γH − HφφᵀH, i.e. (H⁻¹)' = −γH⁻¹ + φφᵀ (eqs. 37, 39, 44),
//! * θ' = −ΓHW (eq. 41).
//!
//! # Design
//! * **P, Q: exponential decay plus a rectangle rule.** P ← e^{−lTs}P +
//!   Ts·φφᵀ (Q likewise) decays exactly but adds each sample's increment by
//!   the rectangle rule; it is not the exact solution of eq. 34 (that would
//!   weight the increment by (1 − e^{−lTs})/l and integrate φ between
//!   samples). Both P and Q get the same weights, so the fixed point
//!   PΘ = Q is that of the exact sums. It is applied as a *lazy decay*: we store
//!   P̃ = P/g and let the scalar g carry the decay (g ← g·e^{−lTs}); P̃ only
//!   receives the increments Ts·φφᵀ/g, and whenever g < ½ both g and P̃ are
//!   rescaled by exactly 2. The matrices are then plain sums (no per-step
//!   multiplication to round), which makes compensated summation cheap.
//! * **H in information form.** We keep R = H⁻¹, updated like P by eq. 39
//!   (R ← e^{−γTs}R + Ts·φφᵀ, lazy decay likewise), and never form H. With
//!   the paper's H0, explicit Euler and classical RK4 of eq. 37 make H
//!   indefinite at the 5th sample and then overflow (test
//!   `estimator::tests::explicit_riccati_steps_break_down_with_the_paper_gains`).
//!   R stays positive definite by construction: a decayed
//!   R(0) > 0 plus sums of φφᵀ ⪰ 0, accumulated exactly enough that
//!   rounding cannot make it indefinite.
//! * **θ by a backward-Euler step.** The explicit step
//!   θ ← θ − TsΓH(Pθ − Q) is stable only while TsΓλmax(HP) < 2. With the
//!   paper's gains (Γ = 80, l = 0.01, γ = 0.1) λmax(HP) ≤ e^{(γ−l)t}, ≈ 6
//!   at 20 s: the explicit step would be stable over the paper's 20 s run
//!   and would cross its limit (λmax < 250) only after ~61 s. With the
//!   default gains (θ step K·Ts·Γ = 10, γ = l) λmax(HP) → 1 within
//!   milliseconds, so the explicit step is unstable from the start (test
//!   `explicit_step_stability_as_stated`, host-tests/tests/claims.rs). The
//!   implicit step
//!   θ⁺ = θ − TsΓH(Pθ⁺ − Q) ⇔ (R + TsΓP)·Δ = −TsΓ·W, θ⁺ = θ + Δ
//!   is unconditionally stable for any Γ, H0, l, γ and has the same fixed
//!   point Pθ = Q; it costs one root-free LDLᵀ solve per θ step
//!   (`theta_step.rs`, shared with the robust estimator's output-error
//!   law; this file forms S and W).
//! * **θ stepped every K samples** (`theta_update_every`, default 10: 1 kHz
//!   at Ts = 0.1 ms) with step K·Ts, while P, Q, R are updated every sample.
//!   Backward Euler stays stable at any step and keeps the fixed point, so
//!   accuracy is unchanged (measured: identical ω, ζ errors for K = 1 and
//!   10 on the paper's plant) and the per-sample cost drops
//!   (BENCHMARKS.md, "Speed: ns per sample").
//! * **Precision where the fixed point lives.** θ is determined by W = 0;
//!   an error δ in P, Q or W moves θ by cond(P)·δ, and cond(P) ≈ 9e5 for the
//!   paper's plant. So P̃, Q̃ (and R̃) are double-word sums and W is
//!   evaluated with a double-word dot product (`src/scalar/compensated.rs`) when
//!   `T::COMPENSATED` (`f32`). Per sample, each of the NS + NP increments
//!   is a near-exact double-word product (`product_dd`: the product's
//!   exact error and its cross terms by fused multiply-adds) added
//!   lazily (`add_lazy`); P̃, Q̃ are renormalized inside the W pass at each
//!   θ step (`residual_exact`); the cost/accuracy trade-offs behind this
//!   are measured in docs/NUMERICS.md. The step matrix only sets the
//!   speed, so it is formed and factored in working precision, with a
//!   pivot floor so a rounding-level indefiniteness slows a direction
//!   instead of stopping the law. In `f64` the same code compiles to plain
//!   arithmetic.
//! * **Storage.** Symmetric matrices are packed (upper triangle, row by row:
//!   `NS = NP(NP+1)/2` entries instead of NP²; the estimators' sizes are
//!   in BENCHMARKS.md, "Memory: estimator state".
//! * If the step matrix is not positive definite even after flooring (no
//!   excitation at all and R decayed to zero), θ is held and the step
//!   reports [`LawError::Singular`].

use super::theta_step::ThetaStep;
use super::{all_finite_f64, all_positive, positive, ConfigError, LawError, UpdateLaw};
use crate::filter_bank::{Regressor, Scaling};
use crate::scalar::compensated::{
    add_fast, add_lazy, each_row, packed_index, product_dd, product_dw, residual_exact,
    Compensated, CompensatedArray, Dot2, UNROLLED_ROWS,
};
use crate::scalar::Real;
use crate::supervise::{InLoopLemma1, SupervisorConfig};

/// With `T::COMPENSATED`, the trailing words of P̃ and Q̃ are renormalized
/// every this many samples (they are accumulated lazily, see
/// `compensated::add_lazy`; after 64 additions they hold at most ~8 ulp of
/// the leading words, typically ~2: the trailing word stays far below the
/// leading one, as `compensated::product_dd` assumes).
const RENORMALIZE_EVERY: u8 = 64;

/// Gains of the proposed law, in scaled coordinates.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct AdaptiveConfig<const NP: usize> {
    /// Learning gain Γ of eq. 41 (1/s).
    pub gain: f64,
    /// Forgetting factor l of eq. 33 (1/s).
    pub forgetting_p: f64,
    /// Forgetting factor γ of eq. 37 (1/s).
    pub forgetting_h: f64,
    /// Diagonal of H(0)⁻¹ = R(0) (scaled). Must be positive.
    pub r0_diag: [f64; NP],
    /// Initial scaled estimate θ_s(0).
    pub theta0: [f64; NP],
    /// Apply the θ step (eq. 41) every this many samples, with step K·Ts.
    /// P, Q and R are always updated every sample. 1 = every sample.
    pub theta_update_every: u32,
    /// Excitation monitor, anti-windup and detected-change tracking
    /// ([`crate::supervise`]); on by default, off for the paper's presets.
    pub supervision: SupervisorConfig,
}

impl<const NP: usize> Default for AdaptiveConfig<NP> {
    /// Defaults for scaled coordinates (measured in BENCHMARKS.md): Γ = 1e4,
    /// θ stepped every 10 samples (1 kHz at Ts = 0.1 ms; same accuracy,
    /// cheaper per sample than every sample),
    /// l = γ = 0.05, R(0) = 1e-9·I, θ(0) = 0.
    fn default() -> Self {
        Self {
            gain: 1e4,
            forgetting_p: 0.05,
            forgetting_h: 0.05,
            r0_diag: [1e-9; NP],
            theta0: [0.0; NP],
            theta_update_every: 10,
            supervision: SupervisorConfig::default(),
        }
    }
}

impl<const NP: usize> AdaptiveConfig<NP> {
    /// The paper's simulation gains (Section IV.A), given in physical units
    /// and mapped exactly to scaled coordinates: Γ = 80, l = 0.01, γ = 0.1,
    /// H(0) = `h0_physical` (for two modes, 1e22·diag(1, 1, 10, 10, 10, 10, 10)).
    /// R_s(0) = E·H(0)⁻¹·E with E from [`Scaling`]. The paper's law as
    /// published: no supervision ([`SupervisorConfig::OFF`]).
    pub fn paper(scaling: &Scaling<NP>, h0_physical: &[f64; NP]) -> Self {
        let r0_diag = scaling.gain_to_scaled(h0_physical).map(|h| 1.0 / h);
        Self {
            gain: 80.0,
            forgetting_p: 0.01,
            forgetting_h: 0.1,
            r0_diag,
            theta0: [0.0; NP],
            theta_update_every: 1,
            supervision: SupervisorConfig::OFF,
        }
    }

    /// The paper's H(0) for two modes: 1e22·diag(1, 1, 10, 10, 10, 10, 10).
    pub const PAPER_H0_2_MODES: [f64; 7] = [1e22, 1e22, 1e23, 1e23, 1e23, 1e23, 1e23];
}

/// An exponentially forgotten sum M ← a·M + increment, stored lazily as
/// `scale·(Σ)` with a double-word Σ (see the module docs).
#[derive(Debug, Clone, Copy)]
struct DecayingSum<T, const N: usize> {
    sum: CompensatedArray<T, N>,
    scale: T,
    decay: T,
}

impl<T: Real, const N: usize> DecayingSum<T, N> {
    fn new(decay: T) -> Self {
        Self {
            sum: CompensatedArray::default(),
            scale: T::ONE,
            decay,
        }
    }

    /// Advance the decay by one sample. Returns the weight 1/scale that this
    /// sample's increment must carry, and whether the stored sum was halved
    /// (so that sums sharing this scale can follow).
    #[inline(always)]
    fn tick(&mut self) -> (T, bool) {
        self.scale *= self.decay;
        let half = T::from_f64(0.5);
        let halved = self.scale < half;
        if halved {
            self.halve();
        }
        (T::ONE / self.scale, halved)
    }

    /// scale·2, sum/2 (exact); every ln 2/(decay rate) seconds.
    #[cold]
    #[inline(never)]
    fn halve(&mut self) {
        self.scale += self.scale;
        self.sum.halve();
    }
}

/// State of the proposed law. `NS = NP(NP+1)/2` (packed symmetric size).
#[derive(Debug, Clone)]
pub struct AdaptiveLaw<T, const NP: usize, const NS: usize> {
    /// The θ step of eq. 41 (gain K·Ts·Γ, K = samples per θ step) and its
    /// by-product, Lemma 1 in the loop.
    step: ThetaStep<T, NP, InLoopLemma1<T, NP>>,
    /// Samples since the trailing words of P̃, Q̃ were last renormalized
    /// (`T::COMPENSATED` only, see `compensated::add_lazy`; ≤
    /// [`RENORMALIZE_EVERY`], a byte that shares the padding of `tied`).
    unnormalized: u8,
    ts: T,
    r0_diag: [T; NP],
    theta0: [T; NP],
    p: DecayingSum<T, NS>,
    /// Q/scale of P (P and Q share the forgetting factor l).
    q: CompensatedArray<T, NP>,
    r: DecayingSum<T, NS>,
    /// γ = l: then R = e^{−lt}R(0) + P exactly, so R is not accumulated but
    /// formed from P̃ and `r0_weight`·R(0) (saves a third of the per-sample
    /// work; the default gains tie γ to l).
    tied: bool,
    /// e^{−lt}/g_P: halves whenever P̃ is halved (tied case only).
    r0_weight: T,
    /// θ_s, double-word when `T::COMPENSATED`: for an ill-conditioned P
    /// (cond ≈ 1e8 on a plant with a weak high mode) the rounding of θ to
    /// `f32` in the strong directions would otherwise drive a 1e-2 error
    /// along the weak one.
    theta: CompensatedArray<T, NP>,
    /// P, Q (and R) decay with l (γ); false while the supervisor suspends
    /// forgetting (Lemma 1 failed after having passed: the directions the
    /// input no longer excites keep what they know instead of decaying).
    forgetting: bool,
}

/// Expand a packed upper triangle into a full symmetric matrix, times `k`.
fn unpack<T: Real, const NP: usize, const NS: usize>(
    packed: &CompensatedArray<T, NS>,
    k: T,
) -> [[T; NP]; NP] {
    let mut m = [[T::ZERO; NP]; NP];
    let mut idx = 0;
    for i in 0..NP {
        for j in i..NP {
            let v = packed.get(idx).value() * k;
            m[i][j] = v;
            m[j][i] = v;
            idx += 1;
        }
    }
    m
}

impl<T: Real, const NP: usize, const NS: usize> AdaptiveLaw<T, NP, NS> {
    /// Auxiliary matrix P (eq. 33), scaled, rounded to working precision.
    pub fn p(&self) -> [[T; NP]; NP] {
        unpack(&self.p.sum, self.p.scale)
    }

    /// R = H⁻¹ (eq. 39), scaled, rounded to working precision.
    pub fn h_inverse(&self) -> [[T; NP]; NP] {
        if self.tied {
            let mut r = self.p();
            for i in 0..NP {
                r[i][i] += self.p.scale * self.r0_weight * self.r0_diag[i];
            }
            r
        } else {
            unpack(&self.r.sum, self.r.scale)
        }
    }

    /// R/g_P (g_P: P's lazy scale), entry `idx` of the packed upper
    /// triangle, which is diagonal entry `i` when `diag` is `Some(i)`.
    #[inline(always)]
    fn r_over_p_scale(&self, idx: usize, diag: Option<usize>) -> T {
        let at = |a: &[T; NS]| a.get(idx).copied().unwrap_or(T::ZERO);
        if self.tied {
            let r0 = |i: usize| self.r0_diag.get(i).copied().unwrap_or(T::ZERO);
            let d = diag.map_or(T::ZERO, |i| self.r0_weight * r0(i));
            at(&self.p.sum.hi) + d
        } else {
            self.r.scale / self.p.scale * at(&self.r.sum.hi)
        }
    }

    /// Auxiliary vector Q (eq. 33), scaled.
    pub fn q(&self) -> [T; NP] {
        let mut q = [T::ZERO; NP];
        for (i, qi) in q.iter_mut().enumerate() {
            *qi = self.q.get(i).value() * self.p.scale;
        }
        q
    }

    /// P̃ += w·φφᵀ, Q̃ += w·φ·y with every increment formed from the
    /// double-word φ as a near-exact product ([`product_dd`], fused
    /// multiply-adds) and added by an exact two-sum into lazily
    /// renormalized double words ([`add_lazy`]). `T::COMPENSATED` only.
    #[inline(always)]
    fn accumulate_exact(&mut self, w: T, reg: &Regressor<T, NP>) {
        if NP > UNROLLED_ROWS {
            self.accumulate_exact_loop(w, reg);
            return;
        }
        // Each row a function with a constant row index: every loop below
        // has compile-time bounds and unrolls completely (docs/NUMERICS.md,
        // "The step at 1,200 instructions").
        // (Local copies: their entries can stay in registers.)
        let (phi, phi_lo, y) = (reg.phi, reg.phi_lo, reg.y);
        each_row!(I => self.accumulate_row::<I>(w, &phi, &phi_lo, y));
    }

    /// Row `I` of [`Self::accumulate_exact`]: P̃_Ij += w·φ_I·φ_j (j ≥ I) and
    /// Q̃_I += w·φ_I·y; nothing for I ≥ NP.
    #[inline(always)]
    fn accumulate_row<const I: usize>(&mut self, w: T, phi: &[T; NP], phi_lo: &[T; NP], y: T) {
        let (Some(&ph), Some(&pl)) = (phi.get(I), phi_lo.get(I)) else {
            return;
        };
        // a = w·φ_I, itself a double word, once per row.
        let (ah, al) = product_dw(ph, pl, w);
        for j in I..NP {
            let k = packed_index::<NP>(I, j);
            if let (Some(h), Some(l), Some(&ch), Some(&cl)) = (
                self.p.sum.hi.get_mut(k),
                self.p.sum.lo.get_mut(k),
                phi.get(j),
                phi_lo.get(j),
            ) {
                let (p, e) = product_dd(ah, al, ch, cl);
                // Neighbouring states of one channel, z_k and
                // z_{k+1} = s·z_k/λ: their sum ∫z_k·ż_k/λ = z_k²/(2λ) is a
                // boundary term, small against its own increments, so
                // Fast2Sum's precondition fails there; the exact two-sum.
                if j == I + 1 {
                    add_lazy(h, l, p, e);
                } else {
                    add_fast(h, l, p, e);
                }
            }
        }
        if let (Some(qh), Some(ql)) = (self.q.hi.get_mut(I), self.q.lo.get_mut(I)) {
            let (p, e) = product_dw(ah, al, y);
            add_fast(qh, ql, p, e);
        }
    }

    /// [`Self::accumulate_exact`] for more than [`UNROLLED_ROWS`] rows.
    #[inline(always)]
    fn accumulate_exact_loop(&mut self, w: T, reg: &Regressor<T, NP>) {
        // Row i of the packed upper triangle is the next NP − i entries.
        let mut rest_h: &mut [T] = &mut self.p.sum.hi;
        let mut rest_l: &mut [T] = &mut self.p.sum.lo;
        let rows = self
            .q
            .hi
            .iter_mut()
            .zip(self.q.lo.iter_mut())
            .zip(reg.phi.iter().zip(reg.phi_lo.iter()));
        for (i, ((qh, ql), (&ph, &pl))) in rows.enumerate() {
            // a = w·φ_i, itself a double word, once per row.
            let (ah, al) = product_dw(ph, pl, w);
            let (Some((row_h, tail_h)), Some((row_l, tail_l))) = (
                core::mem::take(&mut rest_h).split_at_mut_checked(NP - i),
                core::mem::take(&mut rest_l).split_at_mut_checked(NP - i),
            ) else {
                return;
            };
            let cols = reg.phi.iter().zip(reg.phi_lo.iter()).skip(i);
            for ((h, l), (&ch, &cl)) in row_h.iter_mut().zip(row_l.iter_mut()).zip(cols) {
                let (p, e) = product_dd(ah, al, ch, cl);
                add_fast(h, l, p, e);
            }
            let (p, e) = product_dw(ah, al, reg.y);
            add_fast(qh, ql, p, e);
            rest_h = tail_h;
            rest_l = tail_l;
        }
    }

    /// W = Pθ − Q (eq. 35) divided by the lazy scale of P, evaluated with a
    /// double-word dot product when `T::COMPENSATED` (P̃ and Q̃ must be
    /// renormalized).
    fn w_unscaled(&self) -> [T; NP] {
        if T::COMPENSATED {
            let (mut p, mut q) = (self.p.sum, self.q);
            return residual_exact(&mut p, &mut q, &self.theta);
        }
        let mut acc = [Dot2::<T>::new(); NP];
        let mut idx = 0;
        for i in 0..NP {
            for j in i..NP {
                let pij = self.p.sum.get(idx);
                acc[i].add_product_dd(pij, self.theta.get(j));
                if j != i {
                    acc[j].add_product_dd(pij, self.theta.get(i));
                }
                idx += 1;
            }
        }
        let mut w = [T::ZERO; NP];
        for i in 0..NP {
            let mut a = acc[i];
            a.add_value(Compensated {
                hi: -self.q.hi[i],
                lo: -self.q.lo[i],
            });
            w[i] = a.value();
        }
        w
    }

    /// One backward-Euler θ step (eq. 41, see the module docs):
    /// (R + K·TsΓ·P)Δ = −K·TsΓ·W, divided through by P's lazy scale, by
    /// [`ThetaStep::apply`] on this law's S and W. Runs every K samples;
    /// kept out of line so that the per-sample path stays small (its
    /// registers are not spent on this).
    #[inline(never)]
    fn theta_step(&mut self) -> Result<(), LawError> {
        // (R + K·TsΓ·P)Δ = −K·TsΓ·W, divided through by P's lazy scale.
        let w = if T::COMPENSATED {
            self.unnormalized = 0;
            residual_exact(&mut self.p.sum, &mut self.q, &self.theta)
        } else {
            self.w_unscaled()
        };
        let step_gain = self.step.gain();
        // S = R/g_P + K·TsΓ·P̃, packed like P̃ (diagonal: see below).
        // (Built entry by entry: a zeroed array first was a memset call.)
        let (p_hi, r_hi) = (&self.p.sum.hi, &self.r.sum.hi);
        let mut s: [T; NS] = if self.tied {
            core::array::from_fn(|k| {
                let h = p_hi.get(k).copied().unwrap_or(T::ZERO);
                h + step_gain * h
            })
        } else {
            let ratio = self.r.scale / self.p.scale;
            core::array::from_fn(|k| {
                let (h, r) = (
                    p_hi.get(k).copied().unwrap_or(T::ZERO),
                    r_hi.get(k).copied().unwrap_or(T::ZERO),
                );
                ratio * r + step_gain * h
            })
        };
        if self.tied {
            // R/g_P = P̃ + e^{−lt}/g_P·R(0) on the diagonal.
            let mut idx = 0;
            for i in 0..NP {
                if let (Some(v), Some(&h), Some(&r0)) =
                    (s.get_mut(idx), self.p.sum.hi.get(idx), self.r0_diag.get(i))
                {
                    *v = (h + self.r0_weight * r0) + step_gain * h;
                }
                idx += NP - i;
            }
        }
        // Lemma 1's inputs: tr(P̃) and the smallest R(0) share of S's
        // diagonal, which with γ = l and R(0) ∝ I is exactly λmin(S)'s
        // (`InLoopLemma1`).
        let (p_hi, r0_diag) = (&self.p.sum.hi, &self.r0_diag);
        let (tied, r0_weight) = (self.tied, self.r0_weight);
        let lemma1_inputs = || {
            let (mut trace, mut r0_min) = (T::ZERO, T::MAX);
            let mut idx = 0;
            for i in 0..NP {
                trace += p_hi.get(idx).copied().unwrap_or(T::ZERO);
                r0_min = r0_min.min(r0_diag.get(i).copied().unwrap_or(T::ZERO));
                idx += NP - i;
            }
            (trace, if tied { r0_weight * r0_min } else { T::ZERO })
        };
        self.step.apply(&mut s, &w, &mut self.theta, lemma1_inputs)
    }

    /// Set θ̂_s (e.g. an estimate carried over), keeping P, Q and R.
    pub(crate) fn set_theta_scaled(&mut self, theta: &[T; NP]) {
        self.theta = CompensatedArray::default();
        for (i, t) in theta.iter().enumerate() {
            self.theta.set(i, *t);
        }
    }

    /// W = Pθ − Q (eq. 35), scaled.
    pub fn w(&self) -> [T; NP] {
        let mut w = self.w_unscaled();
        for wi in w.iter_mut() {
            *wi *= self.p.scale;
        }
        w
    }
}

impl<T: Real, const NP: usize, const NS: usize> UpdateLaw<T, NP> for AdaptiveLaw<T, NP, NS> {
    type Config = AdaptiveConfig<NP>;

    fn new(cfg: &Self::Config, ts_s: f64) -> Result<Self, ConfigError> {
        // Dimensions, Γ, Ts and K first (the θ step's assumptions); Lemma 1
        // in the loop is its by-product.
        let step = ThetaStep::new::<NS>(
            cfg.gain,
            ts_s,
            cfg.theta_update_every,
            InLoopLemma1::default(),
        )?;
        positive(cfg.forgetting_p)?;
        positive(cfg.forgetting_h)?;
        all_positive(&cfg.r0_diag)?;
        all_finite_f64(&cfg.theta0)?;
        let r0_diag = cfg.r0_diag.map(T::from_f64);
        let theta0 = cfg.theta0.map(T::from_f64);
        let decay_p = T::from_f64(libm::exp(-cfg.forgetting_p * ts_s));
        let decay_h = T::from_f64(libm::exp(-cfg.forgetting_h * ts_s));
        let mut law = Self {
            step,
            unnormalized: 0,
            ts: T::from_f64(ts_s),
            r0_diag,
            theta0,
            p: DecayingSum::new(decay_p),
            q: CompensatedArray::default(),
            r: DecayingSum::new(decay_h),
            tied: cfg.forgetting_h == cfg.forgetting_p,
            r0_weight: T::ONE,
            theta: CompensatedArray::default(),
            forgetting: true,
        };
        law.reset();
        Ok(law)
    }

    #[inline]
    fn update(&mut self, reg: &Regressor<T, NP>) -> Result<(), LawError> {
        let phi = &reg.phi;
        // P and Q share the decay l, hence one lazy scale; R has its own.
        // With forgetting suspended nothing decays: the increment carries
        // the current weight.
        let (inv_p, halved) = if self.forgetting {
            self.p.tick()
        } else {
            (T::ONE / self.p.scale, false)
        };
        if halved {
            self.q.halve();
            self.r0_weight *= T::from_f64(0.5);
        }
        let wp = self.ts * inv_p;
        if T::COMPENSATED {
            self.accumulate_exact(wp, reg);
        } else {
            let mut idx = 0;
            for i in 0..NP {
                let pi = wp * phi[i];
                for j in i..NP {
                    self.p.sum.add(idx, pi * phi[j]);
                    idx += 1;
                }
                self.q.add(i, pi * reg.y);
            }
        }
        if !self.tied {
            // R only sets the speed: working-precision increments suffice.
            let inv_r = if self.forgetting {
                self.r.tick().0
            } else {
                T::ONE / self.r.scale
            };
            let wr = self.ts * inv_r;
            let mut idx = 0;
            for i in 0..NP {
                let ri = wr * phi[i];
                for j in i..NP {
                    self.r.sum.add(idx, ri * phi[j]);
                    idx += 1;
                }
            }
        }
        if T::COMPENSATED {
            self.unnormalized += 1;
            if self.unnormalized >= RENORMALIZE_EVERY {
                self.unnormalized = 0;
                self.p.sum.renormalize();
                self.q.renormalize();
            }
        }
        if !self.step.due() {
            return Ok(());
        }
        self.theta_step()
    }

    fn theta_scaled(&self) -> [T; NP] {
        self.theta.values()
    }

    fn supervision_config(cfg: &Self::Config) -> SupervisorConfig {
        cfg.supervision
    }

    fn reset(&mut self) {
        self.p = DecayingSum::new(self.p.decay);
        self.q = CompensatedArray::default();
        self.r = DecayingSum::new(self.r.decay);
        self.r0_weight = T::ONE;
        let mut idx = 0;
        for i in 0..NP {
            self.r.sum.set(idx, self.r0_diag[i]);
            idx += NP - i;
        }
        self.theta = CompensatedArray::default();
        for (i, t) in self.theta0.iter().enumerate() {
            self.theta.set(i, *t);
        }
        self.step.reset();
        self.unnormalized = 0;
        self.forgetting = true;
    }

    fn information(&self) -> Option<[[T; NP]; NP]> {
        Some(self.p())
    }

    /// e = y/Y0 − θ̂ᵀφ with the leading words of θ̂ (a detector's input,
    /// not the fixed point's).
    #[inline]
    fn prediction_error(&self, reg: &Regressor<T, NP>) -> T {
        let mut e = reg.y;
        for (t, p) in self.theta.hi.iter().zip(reg.phi.iter()) {
            e -= *t * *p;
        }
        e
    }

    /// P, Q and R × `factor` (a power of two: exact, so the old data's
    /// fixed point and R's definiteness are kept).
    fn discount(&mut self, factor: T) {
        self.p.sum.scale_by(factor);
        self.q.scale_by(factor);
        self.r.sum.scale_by(factor);
        // Tied: R = P̃ + w·R(0) is formed from P̃ and w; untied: R̃.
        self.r0_weight *= factor;
    }

    fn set_forgetting(&mut self, on: bool) {
        self.forgetting = on;
    }

    const MEASURES_LEMMA1: bool = true;

    fn lemma1(&self) -> Option<T> {
        self.step.lemma1_ratio()
    }

    /// Every stored word finite, diagonals of P non-negative and of R
    /// positive.
    fn is_healthy(&self) -> bool {
        let mut idx = 0;
        for i in 0..NP {
            let (pd, rd) = (self.p.sum.hi[idx], self.r_over_p_scale(idx, Some(i)));
            if !(pd >= T::ZERO && rd > T::ZERO) {
                return false;
            }
            idx += NP - i;
        }
        self.theta.is_finite()
            && self.p.sum.is_finite()
            && self.r.sum.is_finite()
            && self.q.is_finite()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::estimator::{Adaptive2, Estimator};
    use crate::excitation::SquareWave;
    use crate::filter_bank::{FilterConfig, SignalScales};
    use crate::model::{PAPER_B, PAPER_OMEGA, PAPER_ZETA};
    use crate::rig::ModalPlant;

    fn run(cfg: &AdaptiveConfig<7>, seconds: f64) -> Adaptive2<f64> {
        let filter = FilterConfig {
            scales: SignalScales {
                u_scale: 0.1,
                y_scale: 1.2e-3,
            },
            ..FilterConfig::default()
        };
        let mut est = Adaptive2::<f64>::new(&filter, cfg).unwrap();
        let mut plant =
            ModalPlant::<f64>::with_numerator(&PAPER_OMEGA, &PAPER_ZETA, &PAPER_B, 1e-4).unwrap();
        let mut u = SquareWave::<f64>::paper();
        for _ in 0..(seconds / 1e-4) as usize {
            let uk = u.next_sample();
            est.step(uk, plant.sample(uk));
        }
        est
    }

    /// The increments of P̃, Q̃ are added by Fast2Sum ([`add_fast`]), exact
    /// when the accumulator is at least as large as the increment. On the
    /// paper's plant in `f32` that fails only while P̃ is still small (the
    /// first second: a few hundred of 290,000 additions) and never after:
    /// the neighbouring-state entries, whose sums stay small, take the
    /// exact two-sum.
    #[test]
    fn fast2sum_precondition_holds_after_the_first_second() {
        use crate::scalar::compensated::fast2sum_audit;
        let filter = FilterConfig {
            scales: SignalScales {
                u_scale: 0.1,
                y_scale: 1.2e-3,
            },
            ..FilterConfig::default()
        };
        let mut est = Adaptive2::<f32>::new(&filter, &AdaptiveConfig::default()).unwrap();
        let mut plant =
            ModalPlant::<f64>::with_numerator(&PAPER_OMEGA, &PAPER_ZETA, &PAPER_B, 1e-4).unwrap();
        let mut u = SquareWave::<f64>::paper();
        fast2sum_audit::take();
        let mut step = |n: usize| {
            for _ in 0..n {
                let uk = u.next_sample();
                est.step(uk as f32, plant.sample(uk) as f32);
            }
            fast2sum_audit::take()
        };
        let (n1, bad1) = step(10_000);
        let (n, bad) = step(190_000);
        std::println!("first second: {bad1} of {n1}; then {bad} of {n}");
        assert!(n1 > 0 && bad1 < n1 / 100, "{bad1} of {n1}");
        assert_eq!((n, bad), (190_000 * 29, 0));
    }

    #[test]
    fn tied_forgetting_matches_separately_accumulated_r() {
        // γ = l takes the shortcut R = e^{−lt}R(0) + P; a γ one part in
        // 1e12 away accumulates R separately. Both must agree. (Without
        // the supervisor, whose in-loop Lemma 1 reads each form's own step
        // matrix.)
        let tied = AdaptiveConfig::<7> {
            supervision: SupervisorConfig::OFF,
            ..AdaptiveConfig::default()
        };
        let untied = AdaptiveConfig {
            forgetting_h: tied.forgetting_p * (1.0 + 1e-12),
            ..tied
        };
        // 30 s crosses a halving of the lazy scale (every ln2/l ≈ 13.9 s).
        let (a, b) = (run(&tied, 30.0), run(&untied, 30.0));
        assert!(a.law().tied && !b.law().tied);
        let (ra, rb) = (a.law().h_inverse(), b.law().h_inverse());
        for i in 0..7 {
            for j in 0..7 {
                assert!((ra[i][j] - rb[i][j]).abs() <= 1e-9 * ra[i][i].abs().max(rb[j][j].abs()));
            }
        }
        let (ta, tb) = (a.theta(), b.theta());
        for i in 0..7 {
            assert!(
                (ta[i] - tb[i]).abs() <= 1e-9 * ta[i].abs(),
                "θ{i}: {} vs {}",
                ta[i],
                tb[i]
            );
        }
    }

    #[test]
    fn implicit_step_is_stable_where_the_explicit_one_is_not() {
        // Ts·Γ·λmax(HP) ≫ 2 (huge Γ, tiny R(0)): an explicit Euler step would
        // diverge; the implicit one converges to the same fixed point.
        let cfg = AdaptiveConfig::<7> {
            gain: 1e9,
            r0_diag: [1e-15; 7],
            theta_update_every: 1,
            ..AdaptiveConfig::default()
        };
        let est = run(&cfg, 2.0);
        let truth = run(&AdaptiveConfig::default(), 2.0).theta();
        let th = est.theta();
        for i in 0..7 {
            assert!((th[i] - truth[i]).abs() <= 1e-6 * truth[i].abs(), "θ{i}");
        }
        assert_eq!(est.health().skipped, 0);
    }

    #[test]
    fn rejects_invalid_gains() {
        let bad = [
            AdaptiveConfig::<7> {
                gain: 0.0,
                ..AdaptiveConfig::default()
            },
            AdaptiveConfig::<7> {
                forgetting_p: f64::NAN,
                ..AdaptiveConfig::default()
            },
            AdaptiveConfig::<7> {
                theta_update_every: 0,
                ..AdaptiveConfig::default()
            },
            AdaptiveConfig::<7> {
                r0_diag: [-1.0; 7],
                ..AdaptiveConfig::default()
            },
        ];
        for cfg in &bad {
            assert_eq!(
                AdaptiveLaw::<f32, 7, 28>::new(cfg, 1e-4).err(),
                Some(ConfigError::Gain)
            );
        }
        assert_eq!(
            AdaptiveLaw::<f32, 7, 27>::new(&AdaptiveConfig::default(), 1e-4).err(),
            Some(ConfigError::Dimensions)
        );
    }
}
