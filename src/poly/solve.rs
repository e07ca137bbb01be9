//! The root solver for a scaled real monic polynomial (ascending powers,
//! roots in |σ| ≲ 2 after [`roots_monic`](super::roots_monic)'s exact
//! power-of-two scaling): closed forms for degree 1 and 2, Aberth–Ehrlich for
//! degree 3..=[`MAX_ORDER`], then conjugate symmetrisation, Newton polishing
//! and a backward-error acceptance test.
//!
//! # Design
//! * **Degree 1, 2: closed form** (the quadratic uses the cancellation-free
//!   form r₁ = h + sign(h)·√(h² − c), r₂ = c/r₁).
//! * **Degree ≥ 3: Aberth–Ehrlich** simultaneous iteration (cubically
//!   convergent, all roots at once, no deflation error) in Gauss–Seidel form,
//!   started from Bini's Newton-polygon points: the upper convex hull of
//!   (k, log|c_k|) gives one circle per group of roots of similar modulus, so
//!   modes a factor 100 or more apart start on their own circles. A root is
//!   frozen once its residual is inside the *running* rounding-error bound of
//!   Horner's rule (Higham, Alg. 5.1) and its correction has stopped
//!   shrinking. The a-priori bound ε·Σ|c_k||z|^k is not used for stopping:
//!   near clustered roots it is orders of magnitude too lenient (in `f32`
//!   six real poles within a factor 2.4 stopped 6% off with it, 3e-4 now).
//!   The number of sweeps is bounded by [`MAX_ITERATIONS`].
//! * **Conjugate symmetrisation.** The polynomial is real, so its roots are
//!   real or come in conjugate pairs. Each computed root is either declared
//!   real (imaginary part set to zero) or paired with the computed root
//!   closest to its conjugate, whichever is nearer; a pair is replaced by the
//!   average of one member and the conjugate of the other. The result is
//!   exactly conjugate-symmetric, which [`crate::modal`] relies on.
//! * **Newton polishing.** Up to [`POLISH_STEPS`] Newton steps per root (in the
//!   scaled variable), each accepted only if it lowers the residual and
//!   moves the root less than half-way to its nearest neighbour (so a
//!   cluster cannot collapse). Final check: every root finite with backward
//!   error |p(z)| ≤ 64·(4d+4)·ε·Σ|c_k||z|^k, else
//!   [`PolyError::NoConvergence`].

use super::{Complex, PolyError, MAX_ITERATIONS, POLISH_STEPS};
use crate::model::MAX_ORDER;
use crate::scalar::Real;

/// Horner evaluation of the ascending-power polynomial `c[..=m]` at z:
/// returns p(z), p′(z), the a-priori scale Σ|c_k||z|^k (backward-error
/// yardstick) and a running bound on the rounding error of the computed
/// p(z) (Higham, *Accuracy and Stability*, Alg. 5.1, with a factor 6 instead
/// of 2 for complex arithmetic). Near clustered roots the running bound is
/// orders of magnitude below ε·Σ|c_k||z|^k.
fn horner<T: Real>(
    c: &[T; MAX_ORDER + 1],
    m: usize,
    z: Complex<T>,
) -> (Complex<T>, Complex<T>, T, T) {
    let az = z.norm();
    let mut p = Complex::from_real(c[m]);
    let mut dp = Complex::default();
    let mut e = c[m].abs();
    let mut mu = c[m].abs() / (T::ONE + T::ONE);
    for k in (0..m).rev() {
        dp = dp * z + p;
        p = p * z + Complex::from_real(c[k]);
        e = e * az + c[k].abs();
        mu = mu * az + p.norm();
    }
    (p, dp, e, T::from_f64(6.0) * T::EPSILON * mu)
}

/// Backward-error tolerance of the final acceptance test:
/// |p(z)| ≤ tol·Σ|c_k||z|^k.
fn residual_tol<T: Real>(m: usize) -> T {
    T::from_usize(4 * m + 4) * T::EPSILON
}

/// Roots of the scaled monic polynomial `c[..=m]` (ascending powers,
/// c[m] = 1, c[0] ≠ 0) into `z[..m]`, conjugate-symmetrised and polished.
pub(super) fn solve_scaled<T: Real>(
    c: &[T; MAX_ORDER + 1],
    m: usize,
    z: &mut [Complex<T>; MAX_ORDER],
) -> Result<(), PolyError> {
    let two = T::ONE + T::ONE;
    match m {
        1 => z[0] = Complex::from_real(-c[0]),
        2 => {
            // σ² + c1·σ + c0: h = −c1/2, σ = h ± √(h² − c0).
            let h = -c[1] / two;
            let disc = h * h - c[0];
            if disc >= T::ZERO {
                let sq = disc.sqrt();
                let r1 = if h >= T::ZERO { h + sq } else { h - sq };
                // r1 = 0 would need h = 0 and c0 = 0, excluded by deflation;
                // guard anyway (underflow).
                let r2 = if r1 != T::ZERO { c[0] / r1 } else { T::ZERO };
                z[0] = Complex::from_real(r1);
                z[1] = Complex::from_real(r2);
            } else {
                let sq = (-disc).sqrt();
                z[0] = Complex::new(h, sq);
                z[1] = Complex::new(h, -sq);
            }
        }
        _ => {
            initial_points(c, m, z);
            aberth(c, m, z);
            symmetrise(m, z);
        }
    }
    polish(c, m, z);
    // Final acceptance: every root finite and backward stable (with slack
    // for the symmetrisation and for clusters).
    let tol = residual_tol::<T>(m) * T::from_f64(64.0);
    for zi in z.iter().take(m) {
        if !zi.is_finite() {
            return Err(PolyError::NoConvergence);
        }
        let (p, _, e, _) = horner(c, m, *zi);
        if !(p.norm() <= tol * e) {
            return Err(PolyError::NoConvergence);
        }
    }
    Ok(())
}

/// Bini's starting points: the upper convex hull of (k, ln|c_k|) splits the
/// roots into groups of similar modulus; group j (hull edge k_a → k_b) gets
/// k_b − k_a points on the circle of radius (|c_{k_a}|/|c_{k_b}|)^{1/(k_b−k_a)},
/// rotated off the real axis. (Concavity of the hull makes the radii grow
/// along it; the last one is ≤ max_k |c_k|^{1/(m−k)} ≲ 1.5 after scaling,
/// so nothing overflows.) Computed in `T` so the `f32` path stays in
/// single precision.
fn initial_points<T: Real>(c: &[T; MAX_ORDER + 1], m: usize, z: &mut [Complex<T>; MAX_ORDER]) {
    // Hull over the nonzero coefficients (c_0 and c_m are nonzero).
    let mut lg = [T::ZERO; MAX_ORDER + 1];
    let mut hull = [0usize; MAX_ORDER + 1];
    let mut h = 0;
    for k in 0..=m {
        if c[k] == T::ZERO {
            continue;
        }
        lg[k] = c[k].abs().ln();
        // Pop the last hull point while it lies on or below the chord from
        // its predecessor to k (upper hull keeps only strict right turns).
        while h >= 2 {
            let (i, j) = (hull[h - 2], hull[h - 1]);
            let cross =
                T::from_usize(j - i) * (lg[k] - lg[i]) - T::from_usize(k - i) * (lg[j] - lg[i]);
            if cross >= T::ZERO {
                h -= 1;
            } else {
                break;
            }
        }
        hull[h] = k;
        h += 1;
    }
    // Angle 2π·(i/cnt + g/m) + σ = 2π·j/60 + σ with j an integer (cnt and
    // m divide 60): read from a table, no trigonometry.
    let turn = |i: usize, per: usize, g: usize| {
        let j = (TURNS / per.max(1) * i + TURNS / m.max(1) * g) % TURNS;
        let (c, s) = START_CIS.get(j).copied().unwrap_or((1.0, 0.0));
        (T::from_f32(c), T::from_f32(s))
    };
    let mut idx = 0;
    for g in 1..h {
        let (ka, kb) = (hull[g - 1], hull[g]);
        let cnt = kb - ka;
        let radius = ((lg[ka] - lg[kb]) / T::from_usize(cnt)).exp();
        for i in 0..cnt {
            if idx >= m {
                break;
            }
            let (c, s) = turn(i, cnt, g);
            z[idx] = Complex::new(radius * c, radius * s);
            idx += 1;
        }
    }
    // Defensive: if the hull were degenerate, fill the rest on the unit circle.
    while idx < m {
        let (c, s) = turn(idx, m, 0);
        z[idx] = Complex::new(c, s);
        idx += 1;
    }
}

/// Number of table angles per turn: the least common multiple of 1..=6, so
/// every start angle 2π·(i/cnt + g/m) with cnt, m ≤ [`MAX_ORDER`] is one of
/// them.
const TURNS: usize = 60;
const _: () = {
    let mut k = 1;
    while k <= MAX_ORDER {
        assert!(TURNS % k == 0, "TURNS must be a multiple of 1..=MAX_ORDER");
        k += 1;
    }
};

/// (cos, sin) of 2π·j/60 + 0.7 for j = 0..59: the start points of
/// [`initial_points`] on the unit circle, Bini's offset σ = 0.7 rad keeping
/// them off the real axis. Single precision is plenty for start values; the
/// table replaces `sin`/`cos` calls (in `f32` on a Cortex-M4F, libm's
/// `sinf`/`cosf` and their argument reduction were ~7 KB of flash). Checked
/// against `libm::cos`/`sin` in `start_table_matches_trigonometry`.
#[rustfmt::skip]
const START_CIS: [(f32, f32); TURNS] = [
    (0.7648422, 0.64421767),
    (0.69331324, 0.72063637),
    (0.61418813, 0.7891596),
    (0.52833396, 0.84903663),
    (0.43669116, 0.8996115),
    (0.34026393, 0.94032997),
    (0.24010867, 0.97074604),
    (0.13732274, 0.9905264),
    (0.033032276, 0.99945426),
    (-0.0716201, 0.997432),
    (-0.17548779, 0.98448163),
    (-0.2774328, 0.96074504),
    (-0.37633818, 0.9264824),
    (-0.47112036, 0.88206893),
    (-0.5607408, 0.82799137),
    (-0.64421767, 0.7648422),
    (-0.72063637, 0.69331324),
    (-0.7891596, 0.61418813),
    (-0.84903663, 0.52833396),
    (-0.8996115, 0.43669116),
    (-0.94032997, 0.34026393),
    (-0.97074604, 0.24010867),
    (-0.9905264, 0.13732274),
    (-0.99945426, 0.033032276),
    (-0.997432, -0.0716201),
    (-0.98448163, -0.17548779),
    (-0.96074504, -0.2774328),
    (-0.9264824, -0.37633818),
    (-0.88206893, -0.47112036),
    (-0.82799137, -0.5607408),
    (-0.7648422, -0.64421767),
    (-0.69331324, -0.72063637),
    (-0.61418813, -0.7891596),
    (-0.52833396, -0.84903663),
    (-0.43669116, -0.8996115),
    (-0.34026393, -0.94032997),
    (-0.24010867, -0.97074604),
    (-0.13732274, -0.9905264),
    (-0.033032276, -0.99945426),
    (0.0716201, -0.997432),
    (0.17548779, -0.98448163),
    (0.2774328, -0.96074504),
    (0.37633818, -0.9264824),
    (0.47112036, -0.88206893),
    (0.5607408, -0.82799137),
    (0.64421767, -0.7648422),
    (0.72063637, -0.69331324),
    (0.7891596, -0.61418813),
    (0.84903663, -0.52833396),
    (0.8996115, -0.43669116),
    (0.94032997, -0.34026393),
    (0.97074604, -0.24010867),
    (0.9905264, -0.13732274),
    (0.99945426, -0.033032276),
    (0.997432, 0.0716201),
    (0.98448163, 0.17548779),
    (0.96074504, 0.2774328),
    (0.9264824, 0.37633818),
    (0.88206893, 0.47112036),
    (0.82799137, 0.5607408),
];

/// Aberth–Ehrlich iteration, Gauss–Seidel style. A root is frozen once its
/// residual is within the *running* Horner rounding bound and its correction
/// has stopped shrinking, or once the correction is below one ulp. (The
/// a-priori bound ε·Σ|c_k||z|^k is far too lenient near clustered roots: in
/// `f32`, six real poles within a factor 2.4 stopped 6% off with it.)
fn aberth<T: Real>(c: &[T; MAX_ORDER + 1], m: usize, z: &mut [Complex<T>; MAX_ORDER]) {
    let mut done = [false; MAX_ORDER];
    let mut last_step = [T::MAX; MAX_ORDER];
    for _ in 0..MAX_ITERATIONS {
        let mut all_done = true;
        for i in 0..m {
            if done[i] {
                continue;
            }
            let (p, dp, _, noise) = horner(c, m, z[i]);
            if !p.is_finite() || !dp.is_finite() {
                // Diverged; leave it to the final residual check.
                done[i] = true;
                continue;
            }
            if p.re == T::ZERO && p.im == T::ZERO {
                done[i] = true;
                continue;
            }
            let mut s = Complex::default();
            for (j, zj) in z.iter().enumerate().take(m) {
                let diff = z[i] - *zj;
                if j != i && (diff.re != T::ZERO || diff.im != T::ZERO) {
                    s = s + Complex::from_real(T::ONE) / diff;
                }
            }
            // w = N/(1 − N·S) with N = p/p′, written as p/(p′ − p·S).
            let den = dp - p * s;
            if den.re == T::ZERO && den.im == T::ZERO {
                // Stationary point: nudge the iterate off it.
                let nudge = T::from_f64(1e-3) * (T::ONE + z[i].norm());
                z[i] = z[i] + Complex::new(nudge, nudge);
                all_done = false;
                continue;
            }
            let w = p / den;
            let step = w.norm();
            if !w.is_finite() {
                done[i] = true;
                continue;
            }
            if p.norm() <= noise && !(step < last_step[i]) {
                // In the rounding noise and no longer converging: keep z[i].
                done[i] = true;
                continue;
            }
            z[i] = z[i] - w;
            last_step[i] = step;
            if step <= T::EPSILON * z[i].norm() {
                done[i] = true;
                continue;
            }
            all_done = false;
        }
        if all_done {
            break;
        }
    }
}

/// Make the root set exactly conjugate-symmetric (see module docs).
fn symmetrise<T: Real>(m: usize, z: &mut [Complex<T>; MAX_ORDER]) {
    let mut used = [false; MAX_ORDER];
    let mut out = [Complex::default(); MAX_ORDER];
    let mut n_out = 0;
    for i in 0..m {
        if used[i] {
            continue;
        }
        used[i] = true;
        let zi = z[i];
        // Distance to its own conjugate vs. to the conjugate of a partner in
        // the other (closed) half plane.
        let mut best = None;
        let mut best_d = (zi.im + zi.im).abs();
        for j in 0..m {
            if used[j] || zi.im * z[j].im > T::ZERO {
                continue;
            }
            let dj = (zi - z[j].conj()).norm();
            if dj < best_d {
                best_d = dj;
                best = Some(j);
            }
        }
        match best {
            None => {
                out[n_out] = Complex::from_real(zi.re);
                n_out += 1;
            }
            Some(j) => {
                used[j] = true;
                let two = T::ONE + T::ONE;
                let avg = (zi + z[j].conj()).scale(T::ONE / two);
                let im = avg.im.abs();
                out[n_out] = Complex::new(avg.re, im);
                out[n_out + 1] = Complex::new(avg.re, -im);
                n_out += 2;
            }
        }
    }
    z[..m].copy_from_slice(&out[..m]);
}

/// Newton polishing; a conjugate partner (the next entry with the negated
/// imaginary part) is kept as the exact conjugate of the polished root. A
/// step is taken only if it lowers the residual and is shorter than half the
/// distance to the nearest other root, so polishing can never merge two
/// roots of a cluster.
fn polish<T: Real>(c: &[T; MAX_ORDER + 1], m: usize, z: &mut [Complex<T>; MAX_ORDER]) {
    let half = T::ONE / (T::ONE + T::ONE);
    let mut i = 0;
    while i < m {
        let mut gap = T::MAX;
        for (j, zj) in z.iter().enumerate().take(m) {
            if j != i {
                gap = gap.min((z[i] - *zj).norm());
            }
        }
        let mut zi = z[i];
        let (mut p, mut dp, _, _) = horner(c, m, zi);
        for _ in 0..POLISH_STEPS {
            let pn = p.norm();
            if pn == T::ZERO || !(dp.norm() > T::ZERO) {
                break;
            }
            let cand = zi - p / dp;
            if !cand.is_finite() || !((cand - z[i]).norm() < half * gap) {
                break;
            }
            let (p2, dp2, _, _) = horner(c, m, cand);
            if p2.norm() < pn {
                zi = cand;
                p = p2;
                dp = dp2;
            } else {
                break;
            }
        }
        let paired = z[i].im != T::ZERO && i + 1 < m && z[i + 1] == z[i].conj();
        if z[i].im == T::ZERO {
            // A real root stays real (real Newton steps).
            z[i] = Complex::from_real(zi.re);
            i += 1;
        } else if paired {
            z[i] = zi;
            z[i + 1] = zi.conj();
            i += 2;
        } else {
            z[i] = zi;
            i += 1;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn start_table_matches_trigonometry() {
        for (j, &(c, s)) in START_CIS.iter().enumerate() {
            let ang = 2.0 * core::f64::consts::PI * j as f64 / TURNS as f64 + 0.7;
            assert_eq!(c, libm::cos(ang) as f32, "cos, j = {j}");
            assert_eq!(s, libm::sin(ang) as f32, "sin, j = {j}");
        }
    }
}
