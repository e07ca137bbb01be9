//! Roots of real monic polynomials of degree 1..=[`MAX_ORDER`]: the step
//! "characteristic polynomial s^{2n} + a_{2n−1}s^{2n−1} + … + a_0 → poles
//! p_1 … p_{2n}" between eq. 25 and eq. 30 of the paper (and its n-mode
//! generalisation in [`crate::modal`]).
//!
//! Coefficients are taken in the paper's order, highest power first, with the
//! leading 1 implied: `a = [a_{d−1}, …, a_0]` is s^d + a_{d−1}s^{d−1} + … + a_0,
//! the same layout as [`TransferFunction::a`](crate::model::TransferFunction).
//!
//! # Design
//! * **Exact scaling.** The variable is scaled, s = ρ·σ, with ρ a power of two
//!   close to the Fujiwara-type bound max_k |a_k|^{1/(d−k)}, so that the scaled
//!   coefficients are O(1) and all roots lie in |σ| ≲ 2. Because ρ is a power
//!   of two the scaling and unscaling are exact: they change nothing but the
//!   exponent range, which is what lets `f32` handle a_0 ≈ 10⁸ … 10¹⁸ and
//!   `f64` handle 10^±300 without overflow or underflow in the iteration.
//! * **Exact zero roots.** Trailing zero coefficients (a_0 = 0, …) are roots at
//!   s = 0 and are deflated exactly before scaling.
//! * **The solver** for the scaled polynomial (closed forms for degree 1
//!   and 2, Aberth–Ehrlich with Newton-polygon starting points, conjugate
//!   symmetrisation, Newton polishing) is in `poly/solve.rs`, whose header
//!   gives the details. [`Complex`] (`poly/complex.rs`) is the small complex
//!   type it works in.
//!
//! Accuracy is that of a backward-stable method: relative root error
//! ≈ κ·ε with κ = Σ|a_k||r|^k / |r·p′(r)| the root's condition number.
//! Measured (host-tests `roots.rs`, 1–3 modes, ω 1…1000 rad/s, spread ≤ 100,
//! ζ 0.001…0.9 or real pairs): worst root error 3e-12 in `f64`; in `f32`
//! worst ω error 2e-4 against 6e-5 from rounding the coefficients alone.
//!
//! Nothing here allocates or panics: bad input gives a [`PolyError`].

mod complex;
mod solve;

pub use complex::Complex;

use crate::model::MAX_ORDER;
use crate::scalar::{pow2_nearest, Real};

/// Largest number of Aberth–Ehrlich sweeps before giving up.
pub(crate) const MAX_ITERATIONS: usize = 100;
/// Largest number of Newton polishing steps per root.
pub(crate) const POLISH_STEPS: usize = 3;

/// Why no roots could be returned.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum PolyError {
    /// The degree (number of coefficients) is 0 or exceeds [`MAX_ORDER`].
    InvalidDegree,
    /// A coefficient is NaN or infinite.
    NonFinite,
    /// The iteration did not reach a backward-stable set of roots within
    /// `MAX_ITERATIONS`, or a root overflowed when unscaled.
    NoConvergence,
}

impl core::fmt::Display for PolyError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Self::InvalidDegree => {
                write!(f, "invalid polynomial degree: must be 1..={MAX_ORDER}")
            }
            Self::NonFinite => f.write_str("polynomial coefficient is nan or infinite"),
            Self::NoConvergence => f.write_str("root finder did not converge"),
        }
    }
}

impl core::error::Error for PolyError {}

/// The roots of a degree-d polynomial, d ≤ [`MAX_ORDER`].
///
/// Ordering: by ascending modulus (ties by ascending real part); a complex
/// pair appears as two adjacent entries, the one with positive imaginary part
/// first, and its partner is its exact conjugate. Real roots have an
/// imaginary part of exactly zero.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Roots<T> {
    len: usize,
    z: [Complex<T>; MAX_ORDER],
}

impl<T: Real> Roots<T> {
    /// Number of roots (the degree).
    pub fn len(&self) -> usize {
        self.len
    }

    /// True for a degree-0 result (never returned by [`roots_monic`]).
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// The roots as a slice.
    pub fn as_slice(&self) -> &[Complex<T>] {
        &self.z[..self.len]
    }
}

/// Evaluate the monic polynomial s^d + a_{d−1}s^{d−1} + … + a_0 (coefficients
/// highest power first, leading 1 implied) at `z` by Horner's rule.
pub(crate) fn eval_monic<T: Real>(a: &[T], z: Complex<T>) -> Complex<T> {
    let mut p = Complex::from_real(T::ONE);
    for &ak in a {
        p = p * z + Complex::from_real(ak);
    }
    p
}

/// All d roots of the real monic polynomial s^d + a_{d−1}s^{d−1} + … + a_0,
/// with `a = [a_{d−1}, …, a_0]` (highest power first, leading 1 implied) and
/// 1 ≤ d ≤ [`MAX_ORDER`]. See the module documentation for the method.
///
/// # Errors
/// [`PolyError::InvalidDegree`] if `a` is empty or longer than
/// [`MAX_ORDER`]; [`PolyError::NonFinite`] if a coefficient is NaN or
/// infinite; [`PolyError::NoConvergence`] if no backward-stable root set was
/// found (not seen for finite input in testing, but never ruled out).
pub fn roots_monic<T: Real>(a: &[T]) -> Result<Roots<T>, PolyError> {
    let d = a.len();
    if d == 0 || d > MAX_ORDER {
        return Err(PolyError::InvalidDegree);
    }
    if a.iter().any(|v| !v.is_finite()) {
        return Err(PolyError::NonFinite);
    }
    let mut out = Roots {
        len: d,
        z: [Complex::default(); MAX_ORDER],
    };
    // Deflate exact zero roots: trailing zero coefficients.
    let mut dz = 0;
    while dz < d && a[d - 1 - dz] == T::ZERO {
        dz += 1;
    }
    let m = d - dz; // degree of the remaining polynomial, whose a_0 ≠ 0
    if m > 0 {
        // Ascending-power coefficients of the scaled polynomial:
        // c[k] = a_k / ρ^{m−k}, c[m] = 1.
        let rho = scale_factor(&a[..m]);
        let mut c = [T::ZERO; MAX_ORDER + 1];
        c[m] = T::ONE;
        for (k, ck) in c.iter_mut().enumerate().take(m) {
            // a_k sits at index m−1−k (highest power first).
            let mut v = a[m - 1 - k];
            for _ in 0..(m - k) {
                v /= rho; // exact (power of two) unless it underflows
            }
            *ck = v;
        }
        let mut z = [Complex::default(); MAX_ORDER];
        solve::solve_scaled(&c, m, &mut z)?;
        for (o, zi) in out.z.iter_mut().zip(z.iter()).take(m) {
            *o = zi.scale(rho);
            if !o.is_finite() {
                return Err(PolyError::NoConvergence);
            }
        }
    }
    // Zero roots (modulus 0) go first; the rest is sorted below anyway.
    sort_roots(&mut out.z, d);
    Ok(out)
}

/// A power of two near max_k |a_k|^{1/(m−k)} (the Fujiwara-type root bound
/// without its factor 2), computed through logarithms so that nothing
/// overflows. Requires finite `a` with a nonzero last element.
fn scale_factor<T: Real>(a: &[T]) -> T {
    let ln2 = T::from_f64(core::f64::consts::LN_2);
    let mut best = -T::MAX;
    for (i, &ai) in a.iter().enumerate() {
        if ai != T::ZERO {
            // a[i] multiplies s^{m−1−i}: exponent gap m − (m−1−i) = i + 1.
            let l = ai.abs().ln() / T::from_usize(i + 1);
            best = best.max(l);
        }
    }
    // Keep ρ a normal number well inside the exponent range.
    pow2_nearest(best / ln2)
}

/// Sort into the documented [`Roots`] order: groups (a real root, or a
/// conjugate pair represented by its upper member) by ascending modulus then
/// real part; each upper member is followed by its conjugate.
fn sort_roots<T: Real>(z: &mut [Complex<T>; MAX_ORDER], d: usize) {
    let mut reps = [Complex::default(); MAX_ORDER];
    let mut n = 0;
    let mut n_lower = 0;
    for zi in z.iter().take(d) {
        if zi.im >= T::ZERO {
            reps[n] = *zi;
            n += 1;
        } else {
            n_lower += 1;
        }
    }
    // Conjugate symmetry makes #upper = #lower; anything else would be a bug,
    // in which case keep the input order rather than lose roots.
    let n_upper = reps[..n].iter().filter(|r| r.im > T::ZERO).count();
    if n_upper != n_lower {
        return;
    }
    // Insertion sort by (|z|, re).
    for i in 1..n {
        let mut j = i;
        while j > 0 && root_less(&reps[j], &reps[j - 1]) {
            reps.swap(j, j - 1);
            j -= 1;
        }
    }
    let mut k = 0;
    for r in reps.iter().take(n) {
        if k < d {
            z[k] = *r;
            k += 1;
        }
        if r.im > T::ZERO && k < d {
            z[k] = r.conj();
            k += 1;
        }
    }
}

fn root_less<T: Real>(a: &Complex<T>, b: &Complex<T>) -> bool {
    let (na, nb) = (a.norm(), b.norm());
    na < nb || (na == nb && a.re < b.re)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Monic real coefficients [a_{d−1}, …, a_0] of Π (s − r_k) for a
    /// conjugate-closed root list (f64, tests only).
    fn poly_from_roots(roots: &[Complex<f64>]) -> [f64; MAX_ORDER] {
        let mut c = [Complex::<f64>::default(); MAX_ORDER + 1];
        c[0] = Complex::from_real(1.0);
        for (n, r) in roots.iter().enumerate() {
            for k in (1..=n + 1).rev() {
                c[k] = c[k] - *r * c[k - 1];
            }
        }
        let mut a = [0.0; MAX_ORDER];
        for k in 0..roots.len() {
            a[k] = c[k + 1].re;
        }
        a
    }

    fn max_rel_err(got: &[Complex<f64>], want: &[Complex<f64>]) -> f64 {
        assert_eq!(got.len(), want.len());
        let mut used = [false; MAX_ORDER];
        let mut worst = 0.0f64;
        for w in want {
            let mut best = (f64::INFINITY, 0);
            for (j, g) in got.iter().enumerate() {
                let e = (*g - *w).norm();
                if !used[j] && e < best.0 {
                    best = (e, j);
                }
            }
            used[best.1] = true;
            let scale = if w.norm() > 0.0 { w.norm() } else { 1.0 };
            worst = worst.max(best.0 / scale);
        }
        worst
    }

    fn c(re: f64, im: f64) -> Complex<f64> {
        Complex::new(re, im)
    }

    #[test]
    fn linear_and_quadratic() {
        let r = roots_monic(&[3.0f64]).unwrap();
        assert_eq!(r.as_slice(), &[c(-3.0, 0.0)]);
        // s² + 2s + 5 = (s + 1 ∓ 2j)
        let r = roots_monic(&[2.0f64, 5.0]).unwrap();
        assert_eq!(r.as_slice(), &[c(-1.0, 2.0), c(-1.0, -2.0)]);
        // s² − 1e8 s + 1: roots 1e8 and 1e-8 (cancellation-prone), both to 1 ulp-ish.
        let r = roots_monic(&[-1e8f64, 1.0]).unwrap();
        let s = r.as_slice();
        assert!((s[0].re - 1e-8).abs() < 1e-22 && s[0].im == 0.0);
        assert!((s[1].re - 1e8).abs() < 1e-7 && s[1].im == 0.0);
        // Double root.
        let r = roots_monic(&[4.0f64, 4.0]).unwrap();
        assert!(max_rel_err(r.as_slice(), &[c(-2.0, 0.0), c(-2.0, 0.0)]) < 1e-7);
    }

    #[test]
    fn quartic_known_roots() {
        let want = [c(-0.5, 3.0), c(-0.5, -3.0), c(-2.0, 0.0), c(7.0, 0.0)];
        let a = poly_from_roots(&want);
        let r = roots_monic(&a[..4]).unwrap();
        assert!(max_rel_err(r.as_slice(), &want) < 1e-14);
        // Order: ascending modulus, pair adjacent with positive imaginary first.
        let s = r.as_slice();
        assert_eq!(s[0], c(-2.0, 0.0));
        assert!(s[1].im > 0.0 && s[2] == s[1].conj());
        assert!((s[3].re - 7.0).abs() < 1e-13 && s[3].im == 0.0);
    }

    #[test]
    fn paper_plant_poles_f64_and_f32() {
        let w = [39.1533f64, 245.3711];
        let z = [0.0207f64, 0.13];
        let mut want = [Complex::default(); 4];
        for i in 0..2 {
            let re = -z[i] * w[i];
            let im = w[i] * (1.0 - z[i] * z[i]).sqrt();
            want[2 * i] = c(re, im);
            want[2 * i + 1] = c(re, -im);
        }
        let a = poly_from_roots(&want);
        let r = roots_monic(&a[..4]).unwrap();
        let e64 = max_rel_err(r.as_slice(), &want);
        assert!(e64 < 1e-14, "{e64}");
        let a32 = [a[0] as f32, a[1] as f32, a[2] as f32, a[3] as f32];
        let r32 = roots_monic(&a32).unwrap();
        let got: [Complex<f64>; 4] =
            core::array::from_fn(|k| c(r32.as_slice()[k].re as f64, r32.as_slice()[k].im as f64));
        let e32 = max_rel_err(&got, &want);
        assert!(e32 < 2e-6, "{e32}");
    }

    #[test]
    fn sextic_wide_spread_and_mixed() {
        // Three modes 10, 1000 (ratio 100) and one real pair.
        let mut want = [Complex::default(); 6];
        let modes = [(10.0f64, 0.001), (1000.0, 0.9)];
        for (i, (w, z)) in modes.iter().enumerate() {
            want[2 * i] = c(-z * w, w * (1.0 - z * z).sqrt());
            want[2 * i + 1] = want[2 * i].conj();
        }
        want[4] = c(-50.0, 0.0);
        want[5] = c(-70.0, 0.0);
        let a = poly_from_roots(&want);
        let r = roots_monic(&a[..6]).unwrap();
        let e = max_rel_err(r.as_slice(), &want);
        assert!(e < 1e-13, "{e}");
        // Conjugate symmetry is exact.
        let s = r.as_slice();
        let mut i = 0;
        while i < 6 {
            if s[i].im != 0.0 {
                assert_eq!(s[i + 1], s[i].conj());
                i += 2;
            } else {
                i += 1;
            }
        }
    }

    #[test]
    fn odd_degrees_and_clusters() {
        let want = [c(-1.0, 0.0), c(-3.0, 4.0), c(-3.0, -4.0)];
        let a = poly_from_roots(&want);
        let r = roots_monic(&a[..3]).unwrap();
        assert!(max_rel_err(r.as_slice(), &want) < 1e-14);
        let want5 = [
            c(0.5, 0.0),
            c(-2.0, 1.0),
            c(-2.0, -1.0),
            c(4.0, 0.0),
            c(-8.0, 0.0),
        ];
        let a = poly_from_roots(&want5);
        let r = roots_monic(&a[..5]).unwrap();
        assert!(max_rel_err(r.as_slice(), &want5) < 1e-13);
        // (s+1)^6: a six-fold root; accuracy ε^{1/6}, but it must not fail.
        let a6 = [6.0f64, 15.0, 20.0, 15.0, 6.0, 1.0];
        let r = roots_monic(&a6).unwrap();
        for z in r.as_slice() {
            assert!((*z - c(-1.0, 0.0)).norm() < 1e-2);
        }
        let a6f = [6.0f32, 15.0, 20.0, 15.0, 6.0, 1.0];
        let r = roots_monic(&a6f).unwrap();
        for z in r.as_slice() {
            assert!((*z - Complex::new(-1.0f32, 0.0)).norm() < 0.2);
        }
    }

    #[test]
    fn clustered_real_roots_f32() {
        // Six real poles within a factor 2.4 (three over-damped modes): with
        // a plain worst-case residual stop one root stopped 6% off in f32.
        let want = [
            -186.05128, -245.02028, -275.11283, -312.73093, -405.36376, -451.31125,
        ]
        .map(|r| c(r, 0.0));
        let a = poly_from_roots(&want);
        let a32: [f32; 6] = core::array::from_fn(|k| a[k] as f32);
        let r = roots_monic(&a32).unwrap();
        let got: [Complex<f64>; 6] =
            core::array::from_fn(|k| c(r.as_slice()[k].re as f64, r.as_slice()[k].im as f64));
        let e = max_rel_err(&got, &want);
        // Measured 3.1e-4: the f32 rounding noise of Horner's rule near the
        // cluster (κ ≈ 10³), not the stopping rule.
        assert!(e < 1e-3, "{e}");
    }

    #[test]
    fn zero_roots_and_extreme_scales() {
        // s^4 exactly.
        let r = roots_monic(&[0.0f64; 4]).unwrap();
        assert!(r.as_slice().iter().all(|z| *z == c(0.0, 0.0)));
        // s²(s² + 2s + 5).
        let r = roots_monic(&[2.0f64, 5.0, 0.0, 0.0]).unwrap();
        assert_eq!(r.as_slice()[0], c(0.0, 0.0));
        assert_eq!(r.as_slice()[1], c(0.0, 0.0));
        assert!(max_rel_err(&r.as_slice()[2..], &[c(-1.0, 2.0), c(-1.0, -2.0)]) < 1e-15);
        // Huge and tiny scales: roots 1e100·{paper-like} and 1e-100·{…}.
        for scale in [1e70f64, 1e-70, 1e-75] {
            let want = [
                c(-1.0, 40.0),
                c(-1.0, -40.0),
                c(-30.0, 240.0),
                c(-30.0, -240.0),
            ]
            .map(|z| z.scale(scale));
            let a = poly_from_roots(&want);
            let r = roots_monic(&a[..4]).unwrap();
            let e = max_rel_err(r.as_slice(), &want);
            assert!(e < 1e-13, "scale {scale}: {e}");
        }
        // f32 with a_0 ~ 1e18 (three modes up to 1000 rad/s).
        let w = [10.0f64, 100.0, 1000.0];
        let mut want = [Complex::default(); 6];
        for i in 0..3 {
            want[2 * i] = c(-0.05 * w[i], w[i] * (1.0f64 - 0.0025).sqrt());
            want[2 * i + 1] = want[2 * i].conj();
        }
        let a = poly_from_roots(&want);
        let a32: [f32; 6] = core::array::from_fn(|k| a[k] as f32);
        let r = roots_monic(&a32).unwrap();
        let got: [Complex<f64>; 6] =
            core::array::from_fn(|k| c(r.as_slice()[k].re as f64, r.as_slice()[k].im as f64));
        assert!(max_rel_err(&got, &want) < 1e-5);
    }

    #[test]
    fn degenerate_inputs_are_errors() {
        assert_eq!(roots_monic::<f64>(&[]), Err(PolyError::InvalidDegree));
        assert_eq!(roots_monic(&[0.0f64; 7]), Err(PolyError::InvalidDegree));
        assert_eq!(roots_monic(&[1.0, f64::NAN]), Err(PolyError::NonFinite));
        assert_eq!(
            roots_monic(&[f32::INFINITY, 1.0, 1.0]),
            Err(PolyError::NonFinite)
        );
        // Extreme but finite: must not panic; result either Ok with finite
        // roots or a typed error.
        for a in [
            [f64::MAX, f64::MAX, 1.0, f64::MIN_POSITIVE],
            [1e-300, 1e300, -1e300, 5e-324],
            [0.0, 0.0, 0.0, 1e-320],
        ] {
            if let Ok(r) = roots_monic(&a) {
                assert!(r.as_slice().iter().all(|z| z.is_finite()));
            }
        }
    }
}
