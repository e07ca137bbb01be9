//! Property tests of the polynomial root finder (`beamest::poly`) and the
//! modal recovery built on it (`beamest::modal`, eq. 25–32 for n modes).
//!
//! Pole sets are drawn the way a beam model can look: 1–3 modes, ω in
//! 1..1000 rad/s with up to a factor 100 between the lowest and the highest,
//! ζ in 0.001..0.9, some modes replaced by a pair of real poles (ζ > 1).
//! Neighbouring modes are kept at least a factor 1.3 apart: coinciding modes
//! make the roots ill-conditioned (error ~ √ε), which no root finder fixes,
//! and interleaved real pairs make the modal pairing non-unique.

use beam_protocol::OutputKind;
use beamest::modal::{
    modal_from_tf, modal_from_tf_weighted, modal_from_theta, modes_from_denominator, GainWeighting,
    ModalError,
};
use beamest::model::{ModalParams, TransferFunction, MAX_MODES, MAX_ORDER};
use beamest::poly::{roots_monic, Complex};
use beamest::supervise::{excitation_min_eig, excitation_ratio};
use proptest::prelude::*;

/// Root and ω/ζ tolerance (relative) in f64.
const TOL_F64: f64 = 1e-9;
/// b̄ tolerance (relative) in f64: b̄ is a least-squares solution whose
/// condition number grows with the mode spread, see `accuracy_summary`.
const TOL_BBAR_F64: f64 = 1e-7;
/// f32 bounds (coefficients rounded to f32). Smoke-level: the worst cases are
/// three over-damped modes whose six real poles sit within a factor ~2, where
/// f32 Horner noise alone moves a pole by ~1e-3 (see `accuracy_summary` for
/// typical numbers).
const TOL_F32_OMEGA: f64 = 3e-3;
const TOL_F32_ZETA: f64 = 2e-2;
/// b̄ error relative to max|b̄| in f32 with the balanced weighting.
const TOL_F32_BBAR_BALANCED: f64 = 1e-1;

/// One drawn case: n modes (ascending ω), their ζ (> 1 for a real pair) and b̄.
#[derive(Debug, Clone)]
struct Case {
    n: usize,
    omega: [f64; MAX_MODES],
    zeta: [f64; MAX_MODES],
    real_pair: [bool; MAX_MODES],
    bbar: [f64; MAX_MODES],
}

impl Case {
    /// Build from unit-interval draws (shared by proptest and the summary
    /// sweep so both cover the same distribution).
    fn from_unit(n: usize, u: &[f64; 14]) -> Self {
        let ln = f64::ln;
        let (gmin, spread) = (ln(1.3), ln(100.0));
        let gmax = if n > 1 { spread / (n - 1) as f64 } else { 0.0 };
        let mut gaps = [0.0; MAX_MODES];
        let mut total = 0.0;
        for i in 1..n {
            gaps[i] = gmin + u[i] * (gmax - gmin);
            total += gaps[i];
        }
        // ω_min ∈ [1, 1000/e^total], log-uniform.
        let mut lw = u[0] * (ln(1000.0) - total);
        let mut omega = [0.0; MAX_MODES];
        for i in 0..n {
            lw += gaps[i];
            omega[i] = lw.exp();
        }
        let mut zeta = [0.0; MAX_MODES];
        let mut real_pair = [false; MAX_MODES];
        let mut bbar = [0.0; MAX_MODES];
        for i in 0..n {
            real_pair[i] = u[3 + i] < 0.25;
            if real_pair[i] {
                // Poles −ω·t, −ω/t with t small enough that neighbouring real
                // pairs cannot interleave: t ≤ R^0.45, R the nearest ratio.
                let mut r: f64 = 4.0;
                if i > 0 {
                    r = r.min(omega[i] / omega[i - 1]);
                }
                if i + 1 < n {
                    r = r.min(omega[i + 1] / omega[i]);
                }
                let t = 1.0 + (0.2 + 0.8 * u[6 + i]) * (r.powf(0.45) - 1.0);
                zeta[i] = 0.5 * (t + 1.0 / t);
            } else {
                zeta[i] = (ln(0.001) + u[6 + i] * (ln(0.9) - ln(0.001))).exp();
            }
            let mag = (ln(0.1) + u[9 + i] * (ln(100.0) - ln(0.1))).exp();
            bbar[i] = if u[12] < 0.5 || i != (u[13] * n as f64) as usize % n.max(1) {
                mag
            } else {
                -mag
            };
        }
        Case {
            n,
            omega,
            zeta,
            real_pair,
            bbar,
        }
    }

    fn modal(&self) -> ModalParams<f64> {
        let n = self.n;
        ModalParams::new(&self.omega[..n], &self.zeta[..n], &self.bbar[..n], None).unwrap()
    }

    /// The exact poles (highest accuracy formulas).
    fn poles(&self) -> ([Complex<f64>; MAX_ORDER], usize) {
        let mut p = [Complex::default(); MAX_ORDER];
        for i in 0..self.n {
            let (w, z) = (self.omega[i], self.zeta[i]);
            if self.real_pair[i] {
                // ζ = (t + 1/t)/2 → t = ζ + √(ζ² − 1).
                let t = z + (z * z - 1.0).sqrt();
                p[2 * i] = Complex::new(-w * t, 0.0);
                p[2 * i + 1] = Complex::new(-w / t, 0.0);
            } else {
                let im = w * (1.0 - z * z).sqrt();
                p[2 * i] = Complex::new(-z * w, im);
                p[2 * i + 1] = Complex::new(-z * w, -im);
            }
        }
        (p, 2 * self.n)
    }
}

fn case_strategy() -> impl Strategy<Value = Case> {
    (1usize..=MAX_MODES, prop::array::uniform14(0.0f64..1.0))
        .prop_map(|(n, u)| Case::from_unit(n, &u))
}

/// Largest relative error matching each wanted root to its nearest unused
/// computed root.
fn root_error(got: &[Complex<f64>], want: &[Complex<f64>]) -> f64 {
    assert_eq!(got.len(), want.len());
    let mut used = [false; MAX_ORDER];
    let mut worst = 0.0f64;
    for w in want {
        let mut best = (f64::INFINITY, usize::MAX);
        for (j, g) in got.iter().enumerate() {
            let e = (*g - *w).norm();
            if !used[j] && e < best.0 {
                best = (e, j);
            }
        }
        if best.1 == usize::MAX {
            return f64::INFINITY;
        }
        used[best.1] = true;
        worst = worst.max(best.0 / w.norm());
    }
    worst
}

/// max_i |b̄_i − b̄_i,true| / max_i |b̄_i,true|.
fn bbar_normwise_error<T: Copy + Into<f64>>(got: &[T; MAX_MODES], c: &Case) -> f64 {
    let bmax = c.bbar[..c.n].iter().fold(0.0f64, |a, b| a.max(b.abs()));
    (0..c.n).fold(0.0f64, |e, i| {
        e.max((got[i].into() - c.bbar[i]).abs() / bmax)
    })
}

/// Errors of one case: (roots, ω, ζ, b̄), all relative, max over modes.
fn case_errors(c: &Case) -> Result<[f64; 4], String> {
    let m = c.modal();
    let tf = m.transfer_function();
    let d = 2 * c.n;
    let roots = roots_monic(&tf.a[..d]).map_err(|e| format!("roots: {e:?}"))?;
    let (want, _) = c.poles();
    let r = roots.as_slice();
    // Conjugate symmetry is exact.
    let mut i = 0;
    while i < d {
        if r[i].im != 0.0 {
            if i + 1 >= d || r[i + 1] != r[i].conj() {
                return Err(format!("not conjugate-symmetric: {r:?}"));
            }
            i += 2;
        } else {
            i += 1;
        }
    }
    let e_root = root_error(r, &want[..d]);
    let back = modal_from_tf(&tf, &m.output_weight[..c.n]).map_err(|e| format!("modal: {e:?}"))?;
    let modes = modes_from_denominator(&tf.a[..d]).map_err(|e| format!("modes: {e:?}"))?;
    let mut e = [e_root, 0.0, 0.0, 0.0];
    for i in 0..c.n {
        if modes.real_poles[i] != c.real_pair[i] {
            return Err(format!("mode {i}: real_poles flag {}", modes.real_poles[i]));
        }
        e[1] = e[1].max((back.omega_rad_s[i] / c.omega[i] - 1.0).abs());
        e[2] = e[2].max((back.zeta[i] / c.zeta[i] - 1.0).abs());
        e[3] = e[3].max((back.bbar[i] / c.bbar[i] - 1.0).abs());
    }
    Ok(e)
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 512, ..ProptestConfig::default() })]

    /// Random pole sets → polynomial → roots: every root to 1e-9 relative.
    #[test]
    fn roots_of_random_mode_sets(c in case_strategy()) {
        let e = case_errors(&c).map_err(TestCaseError::fail)?;
        prop_assert!(e[0] <= TOL_F64, "root error {:e} for {:?}", e[0], c);
    }

    /// Modal round trip ModalParams → TF → ModalParams: ω, ζ to 1e-9
    /// relative, b̄ to 1e-7.
    #[test]
    fn modal_round_trip(c in case_strategy()) {
        let e = case_errors(&c).map_err(TestCaseError::fail)?;
        prop_assert!(e[1] <= TOL_F64, "ω error {:e} for {:?}", e[1], c);
        prop_assert!(e[2] <= TOL_F64, "ζ error {:e} for {:?}", e[2], c);
        prop_assert!(e[3] <= TOL_BBAR_F64, "b̄ error {:e} for {:?}", e[3], c);
    }

    /// The same in f32 (coefficients rounded from f64): poles always
    /// recovered; b̄ normwise with the balanced weighting; the paper's
    /// weighting may report rank deficiency (cond up to ~1e6 for 3 modes)
    /// but never anything else.
    #[test]
    fn modal_round_trip_f32(c in case_strategy()) {
        let n = c.n;
        let tf = c.modal().transfer_function();
        let tf32 = TransferFunction { modes: tf.modes, a: tf.a.map(|v| v as f32), b: tf.b.map(|v| v as f32), output: tf.output };
        let w32 = [-2.0f32, 2.0, -2.0];
        let modes = modes_from_denominator(&tf32.a[..2 * n])
            .map_err(|e| TestCaseError::fail(format!("{e:?}")))?;
        for i in 0..n {
            let ew = (modes.omega_rad_s[i] as f64 / c.omega[i] - 1.0).abs();
            let ez = (modes.zeta[i] as f64 / c.zeta[i] - 1.0).abs();
            prop_assert!(ew < TOL_F32_OMEGA, "ω{i} error {ew:e} for {c:?}");
            prop_assert!(ez < TOL_F32_ZETA, "ζ{i} error {ez:e} for {c:?}");
        }
        let bal = modal_from_tf_weighted(&tf32, &w32[..n], GainWeighting::Balanced)
            .map_err(|e| TestCaseError::fail(format!("{e:?}")))?;
        let e = bbar_normwise_error(&bal.bbar, &c);
        prop_assert!(e < TOL_F32_BBAR_BALANCED, "b̄ normwise error {e:e} for {c:?}");
        match modal_from_tf(&tf32, &w32[..n]) {
            Ok(_) | Err(ModalError::GainsRankDeficient) => {}
            Err(e) => prop_assert!(false, "paper weighting: {e:?}"),
        }
    }

    /// Arbitrary coefficient vectors (NaN, ±∞, subnormal, huge, zero) never
    /// panic; a success always carries finite numbers.
    #[test]
    fn arbitrary_coefficients_never_panic(
        v in prop::collection::vec(
            prop_oneof![
                3 => any::<f64>(),
                3 => -1e3f64..1e3,
                1 => Just(0.0f64),
                1 => prop::sample::select(vec![f64::NAN, f64::INFINITY, f64::MAX, -f64::MAX, 5e-324, 1e-300, 1e300]),
            ],
            0..=12,
        ),
        modes in 0usize..=4,
        lambda in prop_oneof![Just(100.0f64), any::<f64>()],
    ) {
        let k = v.len().min(MAX_ORDER);
        if let Ok(r) = roots_monic(&v[..k]) {
            prop_assert_eq!(r.len(), k);
            prop_assert!(r.as_slice().iter().all(|z| z.is_finite()));
        }
        let v32: Vec<f32> = v.iter().map(|&x| x as f32).collect();
        if let Ok(r) = roots_monic(&v32[..k]) {
            prop_assert!(r.as_slice().iter().all(|z| z.is_finite()));
        }
        let _ = roots_monic(&v[..]);
        let _ = modes_from_denominator(&v[..]);
        // As a transfer function with a possibly invalid mode count.
        let mut a = [0.0; MAX_ORDER];
        let mut b = [0.0; MAX_ORDER];
        for (i, x) in v.iter().enumerate() {
            if i < MAX_ORDER { a[i] = *x } else if i < 2 * MAX_ORDER { b[i - MAX_ORDER] = *x }
        }
        let tf = TransferFunction { modes, a, b, output: OutputKind::Strain };
        let w = [-2.0, 2.0, -2.0, 2.0];
        for weights in [&w[..modes.min(4)], &w[..1]] {
            if let Ok(m) = modal_from_tf(&tf, weights) {
                for i in 0..m.modes {
                    prop_assert!(m.omega_rad_s[i] > 0.0 && m.omega_rad_s[i].is_finite());
                    prop_assert!(m.zeta[i].is_finite() && m.bbar[i].is_finite());
                }
            }
        }
        let tf32 = TransferFunction { modes, a: a.map(|x| x as f32), b: b.map(|x| x as f32), output: OutputKind::Strain };
        let _ = modal_from_tf(&tf32, &[-2.0f32, 2.0, -2.0][..modes.clamp(1, 3)]);
        let _ = modal_from_theta(&v[..], lambda, &w[..(v.len() + 1) / 4]);
        let _ = modal_from_theta(&v32[..], lambda, &[-2.0f32, 2.0, -2.0][..modes.clamp(1, 3)]);
        // Excitation monitor on a symmetric matrix made of the values.
        let x = |i: usize, j: usize| v.get(i.min(j) * 3 + i.max(j)).copied().unwrap_or(1.0);
        let p: [[f64; 3]; 3] = core::array::from_fn(|i| core::array::from_fn(|j| x(i, j)));
        let _ = excitation_min_eig(&p);
        let r = excitation_ratio(&p);
        prop_assert!(!r.is_nan());
    }
}

/// Deterministic sweep over the same distribution that prints the worst
/// errors (run with `--nocapture` to see them) and checks the f64 bounds.
#[test]
fn accuracy_summary() {
    let mut state = 0x9E37_79B9_7F4A_7C15u64;
    let mut next = || {
        // xorshift64*
        state ^= state >> 12;
        state ^= state << 25;
        state ^= state >> 27;
        (state.wrapping_mul(0x2545_F491_4F6C_DD1D) >> 11) as f64 / (1u64 << 53) as f64
    };
    const CASES: usize = 4000;
    for n in 1..=MAX_MODES {
        let mut worst = [0.0f64; 4];
        let mut bal64 = 0.0f64;
        let mut w32 = [0.0f64; 2];
        let mut floor32 = [0.0f64; 2];
        let (mut paper32, mut bal32, mut paper32_rank_fail) = (0.0f64, 0.0f64, 0usize);
        for _ in 0..CASES {
            let u: [f64; 14] = core::array::from_fn(|_| next());
            let c = Case::from_unit(n, &u);
            let e = case_errors(&c).unwrap_or_else(|s| panic!("{s} for {c:?}"));
            for k in 0..4 {
                worst[k] = worst[k].max(e[k]);
            }
            let tf = c.modal().transfer_function();
            let w = [-2.0, 2.0, -2.0];
            let b = modal_from_tf_weighted(&tf, &w[..n], GainWeighting::Balanced).unwrap();
            for i in 0..n {
                bal64 = bal64.max((b.bbar[i] / c.bbar[i] - 1.0).abs());
            }
            let tf32 = TransferFunction {
                modes: tf.modes,
                a: tf.a.map(|v| v as f32),
                b: tf.b.map(|v| v as f32),
                output: tf.output,
            };
            let wf = [-2.0f32, 2.0, -2.0];
            let m = modes_from_denominator(&tf32.a[..2 * n]).unwrap();
            // Floor: f64 arithmetic on the f32-rounded coefficients.
            let a_rounded = tf32.a.map(f64::from);
            let mf = modes_from_denominator(&a_rounded[..2 * n]).unwrap();
            for i in 0..n {
                floor32[0] = floor32[0].max((mf.omega_rad_s[i] / c.omega[i] - 1.0).abs());
                floor32[1] = floor32[1].max((mf.zeta[i] / c.zeta[i] - 1.0).abs());
            }
            for i in 0..n {
                w32[0] = w32[0].max((m.omega_rad_s[i] as f64 / c.omega[i] - 1.0).abs());
                w32[1] = w32[1].max((m.zeta[i] as f64 / c.zeta[i] - 1.0).abs());
            }
            match modal_from_tf(&tf32, &wf[..n]) {
                Ok(p) => paper32 = paper32.max(bbar_normwise_error(&p.bbar, &c)),
                Err(_) => paper32_rank_fail += 1,
            }
            let b = modal_from_tf_weighted(&tf32, &wf[..n], GainWeighting::Balanced).unwrap();
            bal32 = bal32.max(bbar_normwise_error(&b.bbar, &c));
        }
        println!(
            "n={n} ({CASES} cases) f64 worst rel: roots {:.1e}, ω {:.1e}, ζ {:.1e}, b̄ paper {:.1e}, b̄ balanced {:.1e}",
            worst[0], worst[1], worst[2], worst[3], bal64
        );
        println!(
            "      f32 worst rel: ω {:.1e}, ζ {:.1e} (f64 on f32-rounded coefficients: {:.1e}, {:.1e}); b̄ normwise paper {:.1e} ({} rank-deficient), balanced {:.1e}",
            w32[0], w32[1], floor32[0], floor32[1], paper32, paper32_rank_fail, bal32
        );
        assert!(worst[0] <= TOL_F64 && worst[1] <= TOL_F64 && worst[2] <= TOL_F64);
        assert!(worst[3] <= TOL_BBAR_F64 && bal64 <= TOL_BBAR_F64);
    }
}
