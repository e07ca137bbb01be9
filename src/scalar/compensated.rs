//! Compensated (double-word) arithmetic for the sums that single precision
//! cannot hold: the exponentially weighted P, Q, H⁻¹ of eqs. 33 and 39, and
//! the residual W = PΘ − Q of eq. 35.
//!
//! # Why
//! The fixed point of the law is PΘ = Q. In scaled coordinates P of the
//! paper's plant has cond(P) ≈ 9e5, so an error δ (relative to ‖P‖) in P, Q
//! or in the evaluation of PΘ − Q moves Θ by ≈ cond(P)·δ. Plain `f32`
//! (δ ≈ 6e-8 per operation, and far more after millions of recursive
//! updates) therefore cannot reach 1e-4: a straightforward `f32` port of
//! the paper's law gives no estimate at all, and the scaled law with plain
//! `f32` sums ends 0.24 off after 20 s (docs/NUMERICS.md, rows 0–1; test
//! `plain_f32_port_of_the_paper_law_fails_where_f64_succeeds` in
//! `host-tests/tests/precision.rs`). Double-word arithmetic gives
//! δ ≈ 1e-14 for a few extra instructions per term, all in single
//! precision, which fits a Cortex-M4F (no software `f64`).
//!
//! # What
//! * [`two_sum`] (Knuth), [`fast_two_sum`] (Dekker) and [`two_prod`] (the
//!   product's error by a fused multiply-add, [`Real::mul_sub`]) are
//!   error-free transformations.
//! * [`product_dd`] and [`product_dw`] multiply double words (exact up to
//!   ~2⁻⁴⁷ in `f32`; 4 and 3 instructions on the Cortex-M4F's FPU): the
//!   adaptive law's per-sample increments and its residual W
//!   ([`residual_exact`]).
//! * [`add_lazy`] adds such a product to a double word without
//!   renormalizing it ([`CompensatedArray::renormalize`] does that later).
//! * [`Compensated`] is a (hi, lo) accumulator: `add` is exact up to the
//!   second-order term.
//! * [`Dot2`] is the Ogita–Rump–Oishi dot product "as if in twice the
//!   working precision".
//!
//! When `T::COMPENSATED` is `false` (`f64`) every operation degrades to the
//! plain one at compile time: the low words stay zero and cost nothing in
//! the hot path beyond their storage.

use crate::scalar::Real;

/// s + e = a + b exactly, with s = fl(a + b) (Knuth's TwoSum, 6 flops).
#[inline(always)]
pub(crate) fn two_sum<T: Real>(a: T, b: T) -> (T, T) {
    let s = a + b;
    let bb = s - a;
    let e = (a - (s - bb)) + (b - bb);
    (s, e)
}

/// s + e = a + b exactly when |a| ≥ |b| (Dekker's Fast2Sum, 3 flops).
/// Used to renormalize a double word (hi, lo) whose trailing word is a few
/// ulp of hi; should hi have been cancelled below |lo|, the result is still
/// hi + lo to within ulp(lo)·2⁻ᵖ.
#[inline(always)]
pub(crate) fn fast_two_sum<T: Real>(a: T, b: T) -> (T, T) {
    let s = a + b;
    (s, b - (s - a))
}

/// p + e = a·b exactly, with p = fl(a·b): the product and its exact
/// error, e = fl(a·b − p) with one rounding of an exactly representable
/// value ([`Real::mul_sub`]; 2 instructions with the FPU's fused
/// multiply-add, where Dekker's product with Veltkamp splitting took 17).
/// The same p and e as Dekker's on every target (both are exact).
#[inline(always)]
pub(crate) fn two_prod<T: Real>(a: T, b: T) -> (T, T) {
    let p = a * b;
    (p, a.mul_sub(b, p))
}

/// A double-word accumulator: the value is `hi + lo`.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub(crate) struct Compensated<T> {
    /// Leading word.
    pub hi: T,
    /// Trailing word (rounding error of `hi`); zero when `T` is not compensated.
    pub lo: T,
}

impl<T: Real> Compensated<T> {
    /// A plain value. (Only the tests construct one from a value today; the
    /// laws start from `Default`.)
    #[inline(always)]
    #[cfg_attr(not(test), allow(dead_code))]
    pub fn new(x: T) -> Self {
        Self { hi: x, lo: T::ZERO }
    }

    /// self += x, renormalized so that |lo| ≤ ulp(hi)/2 (otherwise a long
    /// run of increments below ulp(hi) would stagnate in `lo` instead).
    #[inline(always)]
    pub fn add(&mut self, x: T) {
        if T::COMPENSATED {
            let (s, e) = two_sum(self.hi, x);
            let lo = self.lo + e;
            // Fast two-sum: |s| ≥ |lo| holds after a two-sum.
            let hi = s + lo;
            self.lo = lo - (hi - s);
            self.hi = hi;
        } else {
            self.hi += x;
        }
    }

    /// The value rounded to one word.
    #[inline(always)]
    pub fn value(self) -> T {
        self.hi + self.lo
    }
}

/// hi + lo += p + e for a double word (hi, lo) and an unevaluated sum
/// p + e: the two-sum of the leading words is exact and its error joins `e`
/// in the trailing word, which is **not** renormalized (3 flops fewer than
/// [`CompensatedArray::add`]). The trailing word then grows like a random
/// walk of half-ulps of the leading one, ~√n·ulp(hi) after n additions;
/// call [`CompensatedArray::renormalize`] every few dozen additions and
/// before the words are read one at a time.
#[inline(always)]
pub(crate) fn add_lazy<T: Real>(hi: &mut T, lo: &mut T, p: T, e: T) {
    let (s, err) = two_sum(*hi, p);
    *hi = s;
    *lo += err + e;
}

/// [`add_lazy`] with Dekker's Fast2Sum for the leading words (3 flops
/// instead of [`two_sum`]'s 6): exact when |hi| ≥ |p| (or hi = 0), which
/// holds for an accumulator that is large against each of its increments
/// — P̃ and Q̃ of the adaptive law sum ~10⁵ increments over their memory.
/// Where it fails (|hi| < |p|: the first samples, an entry passing through
/// zero) the sum is still hi + lo + p + e to within ulp(p)·2⁻ᵖ; how often
/// that happens on the paper's and the random plants, and what it costs:
/// docs/NUMERICS.md, "The step at 1,200 instructions".
#[inline(always)]
pub(crate) fn add_fast<T: Real>(hi: &mut T, lo: &mut T, p: T, e: T) {
    #[cfg(test)]
    fast2sum_audit::note(*hi, p);
    let (s, err) = fast_two_sum(*hi, p);
    *hi = s;
    *lo += err + e;
}

/// Test builds only: counts [`add_fast`]'s calls and those whose Fast2Sum
/// precondition |hi| ≥ |p| fails (per thread, so parallel tests do not
/// mix), for the tests that measure how rare the failures are.
#[cfg(test)]
pub(crate) mod fast2sum_audit {
    use crate::scalar::Real;
    use std::cell::Cell;

    std::thread_local! {
        static COUNTS: Cell<(u64, u64)> = const { Cell::new((0, 0)) };
    }

    pub(crate) fn note<T: Real>(hi: T, p: T) {
        let bad = hi != T::ZERO && hi.abs() < p.abs();
        COUNTS.with(|c| {
            let (n, b) = c.get();
            c.set((n + 1, b + u64::from(bad)));
        });
    }

    /// (calls, failed preconditions) since the last `take` on this thread.
    pub(crate) fn take() -> (u64, u64) {
        COUNTS.with(|c| c.replace((0, 0)))
    }
}

/// (xh + xl)·(yh + yl) as an unevaluated sum p + e with p = fl(xh·yh):
/// the exact error of p ([`two_prod`]), then the cross terms xh·yl and
/// xl·yh each added by a fused multiply-add (xl·yl, below the working
/// precision squared, is dropped). e is exact up to those two roundings,
/// ≲ 2⁻²ᵖ⁺¹·|p| (2⁻⁴⁷ in `f32`), in 4 instructions with the FPU's fused
/// multiply-add: the near-exact increments of P, Q (eq. 33) and the terms
/// of W (eq. 35) in single precision.
#[inline(always)]
pub(crate) fn product_dd<T: Real>(xh: T, xl: T, yh: T, yl: T) -> (T, T) {
    let (p, e) = two_prod(xh, yh);
    (p, xl.mul_add(yh, xh.mul_add(yl, e)))
}

/// (xh + xl)·y for a double word and a word: [`product_dd`] with yl = 0,
/// one fused multiply-add fewer.
#[inline(always)]
pub(crate) fn product_dw<T: Real>(xh: T, xl: T, y: T) -> (T, T) {
    let (p, e) = two_prod(xh, y);
    (p, xl.mul_add(y, e))
}

/// An array of double-word accumulators stored as two word arrays
/// (structure of arrays), so that with `T::COMPENSATED = false` the update
/// loops touch one contiguous array and vectorize.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct CompensatedArray<T, const N: usize> {
    /// Leading words.
    pub hi: [T; N],
    /// Trailing words (all zero when `T` is not compensated).
    pub lo: [T; N],
}

impl<T: Real, const N: usize> Default for CompensatedArray<T, N> {
    fn default() -> Self {
        Self {
            hi: [T::ZERO; N],
            lo: [T::ZERO; N],
        }
    }
}

impl<T: Real, const N: usize> CompensatedArray<T, N> {
    /// Element `i` += x (see [`Compensated::add`]).
    #[inline(always)]
    pub fn add(&mut self, i: usize, x: T) {
        if T::COMPENSATED {
            let mut c = self.get(i);
            c.add(x);
            self.hi[i] = c.hi;
            self.lo[i] = c.lo;
        } else {
            self.hi[i] += x;
        }
    }

    /// Element `i` += (p + e), a double word, renormalized at once (see
    /// [`Compensated::add`]; the adaptive law adds lazily instead, with
    /// [`add_lazy`], and renormalizes at its θ step).
    #[inline(always)]
    pub(crate) fn add_dw(&mut self, i: usize, p: T, e: T) {
        if T::COMPENSATED {
            let (s, e2) = two_sum(self.hi[i], p);
            let lo = self.lo[i] + (e + e2);
            let hi = s + lo;
            self.lo[i] = lo - (hi - s);
            self.hi[i] = hi;
        } else {
            self.hi[i] += p + e;
        }
    }

    /// [`CompensatedArray::renormalize`] by Fast2Sum (for trailing words
    /// of a few ulp of the leading ones: exact, see [`fast_two_sum`]), out
    /// of line (inlined into [`residual_exact`], the compiler kept the
    /// renormalized words in registers for the products and spilled them).
    #[inline(never)]
    pub(crate) fn renormalize_fast(&mut self) {
        for (h, l) in self.hi.iter_mut().zip(self.lo.iter_mut()) {
            (*h, *l) = fast_two_sum(*h, *l);
        }
    }

    /// Restore |lo| ≤ ulp(hi)/2 for every element (exact: a two-sum).
    #[inline(always)]
    pub(crate) fn renormalize(&mut self) {
        for (h, l) in self.hi.iter_mut().zip(self.lo.iter_mut()) {
            let (s, err) = two_sum(*h, *l);
            *h = s;
            *l = err;
        }
    }

    /// Element `i` as a double word.
    #[inline(always)]
    pub fn get(&self, i: usize) -> Compensated<T> {
        Compensated {
            hi: self.hi[i],
            lo: self.lo[i],
        }
    }

    /// All elements rounded to one word.
    pub fn values(&self) -> [T; N] {
        let mut v = [T::ZERO; N];
        for i in 0..N {
            v[i] = self.hi[i] + self.lo[i];
        }
        v
    }

    /// Element `i` := x.
    pub fn set(&mut self, i: usize, x: T) {
        self.hi[i] = x;
        self.lo[i] = T::ZERO;
    }

    /// Every element *= 1/2 (exact).
    #[inline(always)]
    pub(crate) fn halve(&mut self) {
        let half = T::from_f64(0.5);
        for (h, l) in self.hi.iter_mut().zip(self.lo.iter_mut()) {
            *h *= half;
            *l *= half;
        }
    }

    /// Every element × `k` (exact when `k` is a power of two and nothing
    /// underflows).
    pub(crate) fn scale_by(&mut self, k: T) {
        for (h, l) in self.hi.iter_mut().zip(self.lo.iter_mut()) {
            *h *= k;
            *l *= k;
        }
    }

    /// True if every word is finite.
    pub fn is_finite(&self) -> bool {
        self.hi.iter().chain(self.lo.iter()).all(|v| v.is_finite())
    }
}

/// Dot product accumulator "as if computed in twice the working precision"
/// (Ogita, Rump & Oishi 2005, Algorithm Dot2) when `T::COMPENSATED`.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub(crate) struct Dot2<T> {
    p: T,
    s: T,
}

impl<T: Real> Dot2<T> {
    /// Start at zero.
    #[inline(always)]
    pub fn new() -> Self {
        Self {
            p: T::ZERO,
            s: T::ZERO,
        }
    }

    /// Accumulate the product of two double words (the lo·lo term is below
    /// the working precision squared and dropped).
    #[inline(always)]
    pub(crate) fn add_product_dd(&mut self, x: Compensated<T>, y: Compensated<T>) {
        if T::COMPENSATED {
            let (h, r) = two_prod(x.hi, y.hi);
            let (p, q) = two_sum(self.p, h);
            self.p = p;
            self.s += q + r + (x.lo * y.hi + x.hi * y.lo);
        } else {
            self.p += x.hi * y.hi;
        }
    }

    /// Start at the double word hi + lo.
    #[inline(always)]
    pub(crate) fn from_dw(hi: T, lo: T) -> Self {
        Self { p: hi, s: lo }
    }

    /// Accumulate the unevaluated sum p + e (a product from
    /// [`product_dd`]): an exact two-sum of the leading words, whose error
    /// joins `e` in the trailing sum.
    #[inline(always)]
    pub(crate) fn add_dw(&mut self, p: T, e: T) {
        let (s, q) = two_sum(self.p, p);
        self.p = s;
        self.s += q + e;
    }

    /// Accumulate a double-word value.
    #[inline(always)]
    pub(crate) fn add_value(&mut self, x: Compensated<T>) {
        if T::COMPENSATED {
            let (p, q) = two_sum(self.p, x.hi);
            self.p = p;
            self.s += q + x.lo;
        } else {
            self.p += x.hi;
        }
    }

    /// The result rounded to one word.
    #[inline(always)]
    pub fn value(self) -> T {
        self.p + self.s
    }
}

/// Rows of a packed symmetric matrix that [`each_row!`] unrolls: laws of
/// up to 11 parameters (three modes).
pub(crate) const UNROLLED_ROWS: usize = 11;

/// `$body` once for each row index `$i` = 0, 1, …, [`UNROLLED_ROWS`] − 1,
/// `$i` a constant in each (so a row function generic over it has
/// compile-time loop bounds and unrolls completely; rows past the
/// matrix's size return at once).
macro_rules! each_row {
    ($i:ident => $body:expr) => {{
        {
            const $i: usize = 0;
            $body;
        }
        {
            const $i: usize = 1;
            $body;
        }
        {
            const $i: usize = 2;
            $body;
        }
        {
            const $i: usize = 3;
            $body;
        }
        {
            const $i: usize = 4;
            $body;
        }
        {
            const $i: usize = 5;
            $body;
        }
        {
            const $i: usize = 6;
            $body;
        }
        {
            const $i: usize = 7;
            $body;
        }
        {
            const $i: usize = 8;
            $body;
        }
        {
            const $i: usize = 9;
            $body;
        }
        {
            const $i: usize = 10;
            $body;
        }
    }};
}
pub(crate) use each_row;

/// Index of entry (i, j), i ≤ j, in a packed upper triangle of NP rows
/// (row i starts after the i rows above it, of NP, NP − 1, … entries).
#[inline(always)]
pub(crate) const fn packed_index<const NP: usize>(i: usize, j: usize) -> usize {
    i * NP - i * i.saturating_sub(1) / 2 + (j - i)
}

/// The residual W = Pθ − Q of eq. 35 (the adaptive law's W̃ over its lazy
/// scale) for a symmetric P stored as a packed upper triangle (row by row,
/// `NS = NP(NP+1)/2`) of double words, and double-word Q and θ: P and Q
/// are renormalized in place on the way (the law accumulates them lazily
/// with [`add_fast`], and renormalizing them at every θ step keeps its
/// accuracy: leaving the trailing words at ~√64 ulp cost up to 2.5× in the
/// ω, ζ errors of the worst-conditioned plants, docs/NUMERICS.md). Every
/// term P_ij·θ_j is a product of two double words exact up to ~2⁻⁴⁷
/// ([`product_dd`]), summed by [`Dot2::add_dw`] from −Q_i over j = 0, 1,
/// … in order. One W_i at a time (its accumulator in registers; each
/// entry above the diagonal is read twice, renormalized at its first
/// read). Meant for `T::COMPENSATED` (in `f64` it is merely exact and
/// slow). Out of line: inlined, the compiler carried the renormalized
/// words in registers (and spilled them) into the caller's use of P.
#[inline(never)]
pub(crate) fn residual_exact<T: Real, const NP: usize, const NS: usize>(
    p: &mut CompensatedArray<T, NS>,
    q: &mut CompensatedArray<T, NP>,
    theta: &CompensatedArray<T, NP>,
) -> [T; NP] {
    p.renormalize_fast();
    q.renormalize_fast();
    let mut w = [T::ZERO; NP];
    if NP > UNROLLED_ROWS {
        for i in 0..NP {
            residual_row(i, p, q, theta, &mut w);
        }
    } else {
        each_row!(I => residual_row(I, p, q, theta, &mut w));
    }
    w
}

/// W_i of [`residual_exact`] (nothing for i ≥ NP).
#[inline(always)]
fn residual_row<T: Real, const NP: usize, const NS: usize>(
    i: usize,
    p: &CompensatedArray<T, NS>,
    q: &CompensatedArray<T, NP>,
    theta: &CompensatedArray<T, NP>,
    w: &mut [T; NP],
) {
    let (Some(&qh), Some(&ql), Some(wi)) = (q.hi.get(i), q.lo.get(i), w.get_mut(i)) else {
        return;
    };
    let mut acc = Dot2::from_dw(-qh, -ql);
    for j in 0..NP {
        let k = packed_index::<NP>(i.min(j), i.max(j));
        let (Some(&h), Some(&l), Some(&th), Some(&tl)) =
            (p.hi.get(k), p.lo.get(k), theta.hi.get(j), theta.lo.get(j))
        else {
            break;
        };
        let (pr, e) = product_dd(h, l, th, tl);
        acc.add_dw(pr, e);
    }
    *wi = acc.value();
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn two_prod_is_exact_in_f32() {
        for &(a, b) in &[(1.1f32, 3.3f32), (1.0e-3, 7.77e5), (-0.3333333, 2.9999)] {
            let (p, e) = two_prod(a, b);
            let exact = a as f64 * b as f64;
            assert_eq!(p as f64 + e as f64, exact);
        }
    }

    /// Dekker's product with Veltkamp splitting (what `two_prod` was before
    /// the fused multiply-add): the reference it must equal bit for bit.
    fn dekker_two_prod(a: f32, b: f32) -> (f32, f32) {
        let split = |x: f32| {
            let c = 4097.0 * x;
            let hi = c - (c - x);
            (hi, x - hi)
        };
        let p = a * b;
        let ((ah, al), (bh, bl)) = (split(a), split(b));
        (p, ((ah * bh - p) + ah * bl + al * bh) + al * bl)
    }

    #[test]
    fn two_prod_equals_dekkers_product() {
        let mut next = rng(19);
        for _ in 0..200_000 {
            let (a, _, _) = random_dw(&mut next);
            let (b, _, _) = random_dw(&mut next);
            let (p, e) = two_prod(a, b);
            assert_eq!((p.to_bits(), e.to_bits()), {
                let (p, e) = dekker_two_prod(a, b);
                (p.to_bits(), e.to_bits())
            });
            assert_eq!(p as f64 + e as f64, a as f64 * b as f64);
        }
    }

    #[test]
    fn two_sum_is_exact_in_f32() {
        let (s, e) = two_sum(1.0f32, 1e-9f32);
        assert_eq!(s, 1.0);
        assert_eq!(s as f64 + e as f64, 1.0 + 1e-9f32 as f64);
    }

    #[test]
    fn compensated_sum_of_many_small_terms() {
        // 1 + 1e6 × 1e-8: plain f32 stagnates at 1.0.
        let mut c = Compensated::new(1.0f32);
        let mut plain = 1.0f32;
        for _ in 0..1_000_000 {
            c.add(1e-8);
            plain += 1e-8;
        }
        assert_eq!(plain, 1.0);
        let expect = 1.0 + 1e6 * (1e-8f32 as f64);
        assert!((c.hi as f64 + c.lo as f64 - expect).abs() < 1e-9);
    }

    /// xorshift64 in [-1, 1) (tests only).
    fn rng(seed: u64) -> impl FnMut() -> f64 {
        let mut s = seed;
        move || {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            (s >> 11) as f64 / (1u64 << 52) as f64 - 1.0
        }
    }

    /// A random f32 double word (h, l) with |l| ≤ ulp(h)/2, and its value.
    fn random_dw(next: &mut impl FnMut() -> f64) -> (f32, f32, f64) {
        let v = next() * 2f64.powi((next() * 20.0) as i32);
        let h = v as f32;
        let l = (v - h as f64) as f32;
        (h, l, h as f64 + l as f64)
    }

    #[test]
    fn double_word_products_are_as_accurate_as_documented() {
        let mut next = rng(7);
        for _ in 0..100_000 {
            let (ah, al, a) = random_dw(&mut next);
            let (bh, bl, b) = random_dw(&mut next);
            let exact = a * b; // exact in f64 up to 2^-53 relative
            let (p, e) = product_dd(ah, al, bh, bl);
            let err = ((p as f64 + e as f64) - exact).abs() / exact.abs();
            assert!(err < 2f64.powi(-45), "product_dd: {err:e}");
            assert_eq!(p, ah * bh);
            let (p, e) = product_dw(ah, al, bh);
            let exact = a * f64::from(bh);
            let err = ((p as f64 + e as f64) - exact).abs() / exact.abs();
            assert!(err < 2f64.powi(-45), "product_dw: {err:e}");
        }
    }

    #[test]
    fn lazy_accumulation_keeps_the_exact_sum() {
        // 10 000 near-exact increments into a lazily renormalized double
        // word, renormalized every 10 additions as the law does.
        let mut next = rng(11);
        let (mut h, mut l) = (0.0f32, 0.0f32);
        let mut exact = 0.0f64;
        let w = 1.0e-4f32;
        for k in 0..10_000 {
            let (xh, xl, _) = random_dw(&mut next);
            let (p, e) = product_dw(xh, xl, w);
            exact += (p as f64) + (e as f64);
            add_lazy(&mut h, &mut l, p, e);
            if k % 10 == 9 {
                (h, l) = fast_two_sum(h, l);
            }
        }
        let got = h as f64 + l as f64;
        assert!(
            (got - exact).abs() <= 1e-13 * exact.abs().max(1e-3),
            "{got} vs {exact}"
        );
    }

    #[test]
    fn exact_residual_of_a_packed_symmetric_system() {
        // W = Pθ − Q for a random symmetric 7×7 P (packed double words) and
        // Q = Pθ* with θ ≠ θ*: compared with the same sum in f64 from the
        // exact values; P and Q come back renormalized with the same value.
        let mut next = rng(3);
        let mut p = CompensatedArray::<f32, 28>::default();
        let mut dense = [[0.0f64; 7]; 7];
        let mut idx = 0;
        for i in 0..7 {
            for j in i..7 {
                let (h, l, v) = random_dw(&mut next);
                p.hi[idx] = h;
                p.lo[idx] = l + l; // unnormalized trailing word
                let v = v + l as f64;
                dense[i][j] = v;
                dense[j][i] = v;
                idx += 1;
            }
        }
        let mut theta = CompensatedArray::<f32, 7>::default();
        let mut q = CompensatedArray::<f32, 7>::default();
        let mut th64 = [0.0f64; 7];
        for i in 0..7 {
            let (h, l, v) = random_dw(&mut next);
            (theta.hi[i], theta.lo[i], th64[i]) = (h, l, v);
        }
        for i in 0..7 {
            let pq: f64 = (0..7).map(|j| dense[i][j] * (th64[j] * (1.0 + 1e-6))).sum();
            let h = pq as f32;
            q.hi[i] = h;
            q.lo[i] = (pq - h as f64) as f32;
        }
        let q_before = q;
        let w = residual_exact(&mut p, &mut q, &theta);
        for i in 0..7 {
            let terms: Vec<f64> = (0..7).map(|j| dense[i][j] * th64[j]).collect();
            let q64 = q_before.hi[i] as f64 + q_before.lo[i] as f64;
            let want = terms.iter().sum::<f64>() - q64;
            let scale: f64 = terms.iter().map(|t| t.abs()).sum();
            assert!(
                ((w[i] as f64) - want).abs() <= 2f64.powi(-42) * scale,
                "W{i}"
            );
            assert_eq!(q.hi[i] as f64 + q.lo[i] as f64, q64);
        }
        let mut idx = 0;
        for i in 0..7 {
            for j in i..7 {
                assert_eq!(p.hi[idx] as f64 + p.lo[idx] as f64, dense[i][j]);
                assert!(p.lo[idx].abs() <= p.hi[idx].abs() * f32::EPSILON);
                idx += 1;
            }
        }
    }

    #[test]
    fn dot2_recovers_cancelling_dot_product() {
        // x·y with heavy cancellation: (1e4, 1, −1e4)·(1e4 + 1, 1, 1e4).
        let x = [1e4f32, 1.0, -1e4];
        let y = [1e4f32 + 1.0, 1.0, 1e4];
        let mut d = Dot2::new();
        for i in 0..3 {
            d.add_product_dd(Compensated::new(x[i]), Compensated::new(y[i]));
        }
        assert_eq!(d.value(), 1e4 + 1.0);
        let mut d64 = Dot2::<f64>::new();
        d64.add_product_dd(Compensated::new(2.0), Compensated::new(3.0));
        d64.add_value(Compensated::new(1.0));
        assert_eq!(d64.value(), 7.0);
    }
}
