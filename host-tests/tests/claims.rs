//! Statements the documentation makes about the laws' discretisation,
//! checked (BENCHMARKS.md, docs/ARCHITECTURE.md, the `# Design`
//! notes of src/estimator/).

// Index loops mirror the matrix algebra.
#![allow(clippy::needless_range_loop)]

use beamctl::run::{rig, tuned_filter, RunConfig};
use beamest::estimator::{Adaptive2, AdaptiveConfig, Estimator, GradientConfig, UpdateLaw};
use beamest::filter_bank::{FilterBank, FilterConfig, Scaling};
use beamest::rig::Sample;
use beamest::tuning::LambdaSource;

const TS: f64 = 1e-4;

/// The paper's run with its filter Λ(s) = (s+100)^4 and scales from the
/// data (every quantity below is invariant under the scales).
fn paper_run() -> (RunConfig, FilterConfig) {
    let cfg = RunConfig {
        lambda: LambdaSource::Fixed(100.0),
        ..RunConfig::default()
    };
    let filter = tuned_filter(&RunConfig {
        duration_s: 1.0,
        ..cfg.clone()
    })
    .expect("built");
    (cfg, filter)
}

type M = [[f64; 7]; 7];

/// Solve A·x = b (Gaussian elimination, partial pivoting).
fn solve(a: &M, b: &[f64; 7]) -> [f64; 7] {
    let mut a = *a;
    let mut b = *b;
    for c in 0..7 {
        let p = (c..7)
            .max_by(|&i, &j| a[i][c].abs().total_cmp(&a[j][c].abs()))
            .expect("rows");
        a.swap(c, p);
        b.swap(c, p);
        for r in c + 1..7 {
            let f = a[r][c] / a[c][c];
            for k in c..7 {
                a[r][k] -= f * a[c][k];
            }
            b[r] -= f * b[c];
        }
    }
    let mut x = [0.0; 7];
    for r in (0..7).rev() {
        let s: f64 = (r + 1..7).map(|k| a[r][k] * x[k]).sum();
        x[r] = (b[r] - s) / a[r][r];
    }
    x
}

/// λmax(R⁻¹P) by power iteration (R, P symmetric positive definite, so
/// R⁻¹P has real positive eigenvalues).
fn lambda_max_hp(r: &M, p: &M) -> f64 {
    let mut v = [1.0; 7];
    let mut lam = 0.0;
    for _ in 0..500 {
        let pv: [f64; 7] = std::array::from_fn(|i| (0..7).map(|j| p[i][j] * v[j]).sum());
        let w = solve(r, &pv);
        let n = w.iter().map(|x| x * x).sum::<f64>().sqrt();
        lam = n / v.iter().map(|x| x * x).sum::<f64>().sqrt();
        v = w.map(|x| x / n);
    }
    lam
}

/// With the paper's gains (Γ = 80, l = 0.01, γ = 0.1) λmax(HP) stays
/// below e^{(γ−l)t} (≈ 6 at 20 s), so the explicit step
/// θ ← θ − Ts·Γ·H(Pθ − Q), stable while Ts·Γ·λmax(HP) < 2 (λmax < 250),
/// would be stable over the paper's whole 20 s run — it would cross the
/// limit only after ln(250)/0.09 ≈ 61 s. With the default gains (θ step
/// K·Ts·Γ = 10, γ = l) λmax(HP) → 1 as soon as the data outweighs R(0):
/// the explicit step is unstable from the first milliseconds, hence the
/// implicit one.
#[test]
fn explicit_step_stability_as_stated() {
    let (cfg, filter) = paper_run();
    let scaling = Scaling::<7>::new(&filter);
    let paper = AdaptiveConfig::paper(&scaling, &AdaptiveConfig::<7>::PAPER_H0_2_MODES);
    let mut est = Adaptive2::<f64>::new(&filter, &paper).expect("valid");
    let mut r = rig(&cfg).expect("rig");
    let mut worst: f64 = 0.0;
    for k in 1..=200_000u32 {
        let Sample { u, y } = r.tick();
        est.step(u, y);
        if k % 20_000 == 0 {
            let t = f64::from(k) * TS;
            let law = est.law();
            let lam = lambda_max_hp(&law.h_inverse(), &law.p());
            let bound = ((0.1 - 0.01) * t).exp();
            assert!(
                lam <= bound * (1.0 + 1e-6),
                "t = {t}: λmax(HP) = {lam} > {bound}"
            );
            worst = worst.max(lam);
        }
    }
    assert!(worst <= 6.05 && TS * 80.0 * worst < 2.0, "{worst}");
    assert!(((250.0f64).ln() / 0.09 - 61.3).abs() < 0.1);

    let mut est = Adaptive2::<f64>::new(&filter, &AdaptiveConfig::default()).expect("valid");
    let mut r = rig(&cfg).expect("rig");
    for _ in 0..50 {
        let Sample { u, y } = r.tick();
        est.step(u, y);
    }
    let law = est.law();
    let lam = lambda_max_hp(&law.h_inverse(), &law.p());
    let k_ts_gamma = 10.0 * TS * 1e4;
    assert!(
        lam > 0.5 && k_ts_gamma * lam > 2.0,
        "λmax(HP) = {lam} after 5 ms"
    );
}

/// Explicit Euler of the gradient law (47) needs Ts·ΨᵀΓ1Ψ < 2; with the
/// paper's Γ1 the largest value over its 20 s run is 0.57 (the product is
/// the same in physical and scaled coordinates), so explicit Euler would be
/// stable there; the law uses the exact rank-one step, stable for any Γ1.
#[test]
fn explicit_euler_of_the_gradient_law_is_stable_at_the_papers_gain() {
    let (cfg, filter) = paper_run();
    let scaling = Scaling::<7>::new(&filter);
    let g = GradientConfig::from_physical(&scaling, &GradientConfig::<7>::PAPER_GAIN_2_MODES);
    let mut bank = FilterBank::<f64, 4, 7>::new(&filter).expect("valid");
    let mut r = rig(&cfg).expect("rig");
    let mut worst: f64 = 0.0;
    for _ in 0..200_000 {
        let Sample { u, y } = r.tick();
        let reg = bank.push(u, y);
        let c: f64 = (0..7)
            .map(|j| g.gain_diag[j] * reg.phi[j] * reg.phi[j])
            .sum();
        worst = worst.max(TS * c);
    }
    println!("max Ts·ΨᵀΓ1Ψ = {worst:.4}");
    assert!(worst > 0.5 && worst < 0.65, "{worst}");
}

/// With the default gains the proposed law's θ is the exponentially
/// weighted least-squares solution P⁻¹Q of the data so far: 1e-2 off 50 ms
/// after the law starts (while P is still weaker than R(0) in some
/// directions), 1e-12 from 0.1 s on. Each implicit θ step (every 1 ms,
/// K·Ts·Γ = 10) solves (R + 10·P)Δ = −10·(Pθ − Q) with R ≈ P (γ = l), so it
/// removes 10/11 of the gap to P⁻¹Q.
#[test]
fn default_gains_make_the_law_the_least_squares_solution_from_0p1_s() {
    let (cfg, filter) = paper_run();
    let mut est = Adaptive2::<f64>::new(&filter, &AdaptiveConfig::default()).expect("valid");
    let mut r = rig(&cfg).expect("rig");
    let mut gaps = Vec::new();
    for k in 1..=20_000u32 {
        let Sample { u, y } = r.tick();
        est.step(u, y);
        if [10, 20, 50, 100, 200, 500, 1000, 2000, 10_000, 20_000].contains(&k) {
            let law = est.law();
            let ls = solve(&law.p(), &law.q());
            let th = law.theta_scaled();
            let num: f64 = (0..7).map(|i| (th[i] - ls[i]).powi(2)).sum::<f64>().sqrt();
            let den: f64 = ls.iter().map(|v| v * v).sum::<f64>().sqrt();
            gaps.push((f64::from(k) * TS * 1e3, num / den));
        }
    }
    println!("(ms, ‖θ − P⁻¹Q‖/‖P⁻¹Q‖): {gaps:?}");
    for &(ms, gap) in &gaps {
        if ms >= 50.0 {
            assert!(gap < 2e-2, "{ms} ms: {gap:e}");
        }
        if ms >= 100.0 {
            assert!(gap < 1e-10, "{ms} ms: {gap:e}");
        }
    }
}
