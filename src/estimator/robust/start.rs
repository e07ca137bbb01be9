//! The start test of the robust estimator: was the beam at rest when the
//! first sample was taken? (See [`InitialState`].)

use crate::scalar::Real;

/// What the estimator assumes about the beam at its first sample.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum InitialState {
    /// At rest (the excitation starts with the estimator): the start-up
    /// replay is exact and the bound's start-up information is fully used.
    Rest,
    /// Unknown: each replay fits the model's initial state to the record
    /// (its free responses, by least squares) and starts from it. Costs
    /// efficiency on a beam that was at rest (the fitted state absorbs part
    /// of the start-up ring-down).
    Estimate,
    /// Decide from the first `START_TEST_SAMPLES` samples of y: a beam at
    /// rest has y(0) = y'(0) = 0 (its forced response grows like t²; for a
    /// velocity or acceleration output, `start_test`, y(0) = 0 only), a
    /// moving one does not. A cubic is fitted and its value and slope at the
    /// first sample are tested against the fit's residual (floored at
    /// `START_TEST_NOISE_FLOOR`): χ²(2) (χ²(1)) above `START_TEST_CHI2` means
    /// moving ([`InitialState::Estimate`]), otherwise at rest.
    Auto,
}

/// Samples of the start test of [`InitialState::Auto`] (3.2 ms at 10 kHz).
pub(crate) const START_TEST_SAMPLES: usize = 32;
/// χ² threshold of that test (p ≈ 4e-6 for a beam at rest with χ²(2), the
/// strain output's two tested coefficients; p ≈ 6e-7 with χ²(1)).
pub(crate) const START_TEST_CHI2: f64 = 25.0;
/// Floor of the test's noise estimate, relative to the output scale Y0
/// (−60 dB). The forced response from rest is not exactly a cubic (the
/// paper's plant leaves ~1e-4·Y0 over the window); without the floor a
/// clean record would read that misfit as noise and a quiet start as
/// moving. A motion below this level is not worth an initial state.
pub(crate) const START_TEST_NOISE_FLOOR: f64 = 1e-3;

/// The start test of [`InitialState::Auto`] on the first samples of y
/// (`y`) and of the input held before each (`u`: u_{n−1} at sample n, 0
/// before the first; scaled like y): a beam at rest starts its forced
/// response like t^(relative degree) — a strain or displacement output
/// like t² (value and slope zero at the first sample), a velocity output
/// like t (value zero), an acceleration output with a jump where the input
/// steps (its direct term) and a smooth part that starts at zero. A cubic
/// y_n ≈ a + b·t + c·t² + d·t³ (t = n/(N−1)), plus for an acceleration
/// output e·u_{n−1}, is fitted, and the coefficients a beam at rest has at
/// zero — a, b (relative degree 2: `shift` 0), a (`shift` 1 or 2) — are
/// tested against the fit's residual: χ²(2) or χ²(1). Rejected readings
/// (NaN) are left out. `None` if fewer than [`START_TEST_SAMPLES`]
/// samples, fewer than 2 per fitted coefficient valid among them, or a
/// degenerate fit (the caller then assumes the beam was moving).
pub(super) fn start_test<T: Real>(y: &[T], u: impl Fn(usize) -> T, shift: usize) -> Option<T> {
    let y = y.get(..START_TEST_SAMPLES)?;
    let span = T::from_usize(START_TEST_SAMPLES - 1);
    let cubic = |n: usize| {
        let t = T::from_usize(n) / span;
        [T::ONE, t, t * t, t * t * t]
    };
    let tested = if shift == 0 { 2 } else { 1 };
    if shift == 2 {
        let held = |n: usize| n.checked_sub(1).map_or(T::ZERO, &u);
        let basis = |n: usize| {
            let c = cubic(n);
            [c[0], c[1], c[2], c[3], held(n)]
        };
        chi2_of_first(y, basis, tested)
    } else {
        chi2_of_first(y, cubic, tested)
    }
}

/// Least squares of `y` on `basis` (`K` functions of the sample index):
/// χ² of its first `tested` (1 or 2) coefficients against zero, with the
/// residual's variance (floored at [`START_TEST_NOISE_FLOOR`]).
fn chi2_of_first<T: Real, const K: usize>(
    y: &[T],
    basis: impl Fn(usize) -> [T; K],
    tested: usize,
) -> Option<T> {
    let mut xtx = [[T::ZERO; K]; K];
    let mut xty = [T::ZERO; K];
    // Rejected readings (NaN in the record) are left out of the fit.
    let valid = y.iter().filter(|v| v.is_finite()).count();
    if valid < 2 * K {
        return None;
    }
    for (n, &v) in y.iter().enumerate().filter(|(_, v)| v.is_finite()) {
        let x = basis(n);
        for i in 0..K {
            xty[i] += x[i] * v;
            for j in 0..K {
                xtx[i][j] += x[i] * x[j];
            }
        }
    }
    // (XᵀX)⁻¹ by columns; its leading block scales Cov(a, b).
    let mut inv = [[T::ZERO; K]; K];
    for c in 0..K {
        let mut e = [T::ZERO; K];
        e[c] = T::ONE;
        let col = crate::linalg::ldlt_solve_floored(&mut xtx.clone(), &e).ok()?;
        for r in 0..K {
            inv[r][c] = col[r];
        }
    }
    let coef: [T; K] =
        core::array::from_fn(|i| (0..K).fold(T::ZERO, |s, j| s + inv[i][j] * xty[j]));
    let mut rss = T::ZERO;
    for (n, &v) in y.iter().enumerate().filter(|(_, v)| v.is_finite()) {
        let x = basis(n);
        let fit = (0..K).fold(T::ZERO, |s, j| s + coef[j] * x[j]);
        rss += (v - fit) * (v - fit);
    }
    let floor = T::from_f64(START_TEST_NOISE_FLOOR);
    let var = (rss / T::from_usize(valid - K)).max(floor * floor);
    let a = coef[0];
    if tested == 1 {
        let p = inv[0][0];
        if !(p > T::ZERO) {
            return None;
        }
        let chi2 = a * a / p / var;
        return chi2.is_finite().then_some(chi2);
    }
    // χ² = [a b]·(σ²·inv₂ₓ₂)⁻¹·[a b]ᵀ.
    let (p, q, r) = (inv[0][0], inv[0][1], inv[1][1]);
    let det = p * r - q * q;
    if !(det > T::ZERO) {
        return None;
    }
    let b = coef[1];
    let chi2 = (r * a * a - (q + q) * a * b + p * b * b) / det / var;
    chi2.is_finite().then_some(chi2)
}
