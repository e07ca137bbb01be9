//! Issue 9, modes beyond the model and physical validity.
//!
//! * The paper's plant plus the physical beam's 3rd (and 4th) bending mode
//!   (`scenario_run::paper_extra_modes`: ω, ζ, c of the Euler–Bernoulli
//!   model of the paper's beam, b̄ in proportion to mode 1), noise-free,
//!   20 s. Target: a 2-mode estimator within 1% on ω1, ω2 and 5% on ζ1,
//!   ζ2. **Not met** by the 2-mode law at the truth-free default λ = 100
//!   rad/s (3 modes: ω1 3.9%, ω2 2.1%, ζ1 37%, ζ2 8.0%; no λ or low-pass
//!   prefilter tried meets all four, see `robustness_table modes`): the
//!   extra modes are strong (b̄3 ≈ 7·b̄1) and inside the square wave's
//!   band (with weaker extra modes, scaled to the paper's mode 2, ζ2 still
//!   misses: 8.8–11%). The 3-mode law meets it (3 modes: exact to 1e-7; 4 modes: ω1,
//!   ω2 within 2e-4, ζ1, ζ2 within 1.5e-3). The tests assert both.
//! * The two-mode estimator with a feedthrough (residual) term and a
//!   sixth-order filter ([`Feedthrough2`], truth-free defaults, λ = 100
//!   rad/s) meets the target in `f64` and `f32` (3 modes: ω1 4.3e-6, ω2
//!   4.3e-3, ζ1 1.9e-4, ζ2 2.8e-2; 4 modes: ω2 3.2e-3, ζ2 2.5e-2) and stays
//!   exact on the two-mode plant. Figures: `cargo run --release -p
//!   host-tests --example extra_modes`.
//! * An unphysical estimate is flagged (`modal::Validity`) and what is
//!   reported (`modal::ModalHold`) is never NaN.
//!
//! Figures: `cargo run --release -p host-tests --example robustness_table modes`.

use beamest::estimator::{Adaptive2, Adaptive3, AdaptiveConfig, Estimator, Feedthrough2};
use beamest::modal::{modal_from_tf, ModalHold, Validity};
use beamest::model::{ModalParams, PAPER_OMEGA, PAPER_ZETA};
use beamest::rig::Scenario;
use beamest::Real;
use host_tests::scenario_run::*;

/// Errors (ω1, ω2, ζ1, ζ2) of the 2-mode law and of the 3-mode law after
/// 20 s on a beam with `truth_modes` modes.
fn errors<T: Real>(truth_modes: usize) -> ([f64; 4], [f64; 4]) {
    let extra = paper_extra_modes(truth_modes);
    let rig = paper_rig(Scenario::default(), None, 1, Some(&extra));
    let f = startup_filter(&rig);
    let mut r2 = rig.clone();
    let mut e2 = Adaptive2::<T>::new(&f, &AdaptiveConfig::default()).expect("valid");
    let mut r3 = rig;
    let mut e3 = Box::new(Adaptive3::<T>::new(&f, &AdaptiveConfig::default()).expect("valid"));
    for _ in 0..200_000 {
        let s = r2.tick();
        e2.step(T::from_f64(s.u), T::from_f64(s.y));
        let s = r3.tick();
        e3.step(T::from_f64(s.u), T::from_f64(s.y));
    }
    let four = |(w, z): (Vec<f64>, Vec<f64>)| [w[0], w[1], z[0], z[1]];
    let two = modal_errors(&e2.transfer_function(), &WEIGHTS, &PAPER_OMEGA, &PAPER_ZETA)
        .expect("2-mode recovery");
    let three = modal_errors(
        &e3.transfer_function(),
        &[WEIGHTS[0], WEIGHTS[1], extra.output_weight[0]],
        &PAPER_OMEGA,
        &PAPER_ZETA,
    )
    .expect("3-mode recovery");
    (four(two), four(three))
}

fn check<T: Real>(truth_modes: usize, reached_2: [f64; 4]) {
    let (two, three) = errors::<T>(truth_modes);
    let ty = T::NAME;
    // The 3-mode law meets the target.
    assert!(
        three[0] <= 1e-2 && three[1] <= 1e-2 && three[2] <= 5e-2 && three[3] <= 5e-2,
        "{truth_modes} modes {ty}: 3-mode law {three:?}"
    );
    // The 2-mode law: what is reached (the gap is documented).
    for (i, (e, r)) in two.iter().zip(reached_2).enumerate() {
        assert!(
            e <= &r,
            "{truth_modes} modes {ty}: 2-mode law [{i}] {e:e} > {r:e}"
        );
    }
}

#[test]
fn three_mode_beam_two_and_three_mode_laws() {
    let reached = [4.5e-2, 2.5e-2, 0.4, 0.1];
    check::<f64>(3, reached);
    check::<f32>(3, reached);
}

#[test]
fn four_mode_beam_two_and_three_mode_laws() {
    let reached = [4.0e-2, 2.5e-2, 0.35, 0.1];
    check::<f64>(4, reached);
    check::<f32>(4, reached);
}

/// Errors (ω1, ω2, ζ1, ζ2) of the feedthrough estimator after 20 s on a
/// beam with `truth_modes` modes (2: the paper's plant alone), and its
/// feedthrough D.
fn feedthrough_errors<T: Real>(truth_modes: usize) -> ([f64; 4], f64) {
    let extra = (truth_modes > 2).then(|| paper_extra_modes(truth_modes));
    let mut rig = paper_rig(Scenario::default(), None, 1, extra.as_ref());
    let f = startup_filter(&rig);
    let mut e = Feedthrough2::<T>::with_default_gains(&f).expect("valid");
    for _ in 0..200_000 {
        let s = rig.tick();
        e.step(T::from_f64(s.u), T::from_f64(s.y));
    }
    let (w, z) = modal_errors(&e.transfer_function(), &WEIGHTS, &PAPER_OMEGA, &PAPER_ZETA)
        .expect("2-mode recovery");
    // Θ (eq. 29, two-mode) describes the same model as the transfer function.
    let back = beamest::model::TransferFunction::from_theta(&e.theta(), f.lambda_rad_s)
        .expect("7 entries");
    let tf = e.transfer_function();
    for (x, y) in back.a[..4].iter().zip(&tf.a[..4]) {
        let (x, y) = (x.to_f64(), y.to_f64());
        assert!((x - y).abs() <= 1e-5 * y.abs().max(1.0), "{x} {y}");
    }
    (
        [w[0], w[1], z[0], z[1]],
        e.residual().map_or(f64::NAN, |r| r.feedthrough.to_f64()),
    )
}

/// The target with the feedthrough estimator, 3 and 4 truth
/// modes, `f64` and `f32`; the residual's D is the extra modes' static
/// gain's sign and order (Σ c_i·b̄_i/ω_i² = −2.9e-4 for mode 3, −2.4e-4
/// with mode 4: D within a factor 2 of it).
#[test]
fn feedthrough_estimator_meets_the_target_with_3_and_4_truth_modes() {
    for n in [3usize, 4] {
        let extra = paper_extra_modes(n);
        let static_gain: f64 = (0..extra.modes)
            .map(|i| extra.output_weight[i] * extra.bbar[i] / extra.omega_rad_s[i].powi(2))
            .sum();
        for (ty, (e, d)) in [
            ("f64", feedthrough_errors::<f64>(n)),
            ("f32", feedthrough_errors::<f32>(n)),
        ] {
            assert!(
                e[0] <= 1e-2 && e[1] <= 1e-2 && e[2] <= 5e-2 && e[3] <= 5e-2,
                "{n} modes {ty}: {e:?}"
            );
            // Measured: ω2 ≤ 4.3e-3, ζ2 ≤ 2.8e-2 (a 1.8× margin); ω1 ≤ 4.4e-6.
            assert!(
                e[0] <= 1e-4 && e[1] <= 6e-3 && e[3] <= 3.5e-2,
                "{n} {ty}: {e:?}"
            );
            let r = d / static_gain;
            assert!(
                (0.5..2.0).contains(&r),
                "{n} {ty}: D = {d:e}, static {static_gain:e}"
            );
        }
    }
}

/// On the paper's two-mode plant the feedthrough estimator is exact to
/// its precision floor (D → 0): the extra term costs no accuracy there.
#[test]
fn feedthrough_estimator_is_exact_on_the_two_mode_plant() {
    let (e, d) = feedthrough_errors::<f64>(2);
    assert!(e.iter().all(|v| *v <= 1e-7), "f64: {e:?}");
    assert!(d.abs() <= 1e-9, "f64 D = {d:e}");
    let (e, d) = feedthrough_errors::<f32>(2);
    assert!(e.iter().all(|v| *v <= 1e-4), "f32: {e:?}");
    assert!(d.abs() <= 1e-6, "f32 D = {d:e}");
}

fn params(w: [f64; 2], z: [f64; 2]) -> ModalParams<f64> {
    ModalParams::new(&w, &z, &[9.6, 16.1], None).expect("valid parameters")
}

/// Unphysical estimates are flagged with their reason, and the reported
/// ω, ζ stay finite and physical.
#[test]
fn unphysical_estimates_are_flagged_and_never_reported() {
    // From the transfer function of an unstable or overdamped "beam".
    for (w, z, flag) in [
        ([39.0, 245.0], [-0.02, 0.13], Validity::ZETA_OUT_OF_RANGE),
        ([39.0, 245.0], [0.02, 1.5], Validity::ZETA_OUT_OF_RANGE),
    ] {
        let tf = params(w, z).transfer_function();
        let r = modal_from_tf(&tf, &WEIGHTS);
        let v = Validity::of_result(&r, 2);
        assert!(
            v.contains(flag) || v.contains(Validity::NOT_RECOVERED),
            "{w:?} {z:?}: {v:?}"
        );
        assert!(!v.is_valid());
    }
    // An estimator from its first samples: its early estimates are not
    // physical; the hold reports only valid ones, never a NaN.
    let mut rig = paper_rig(Scenario::default(), None, 1, None);
    let f = startup_filter(&rig);
    let mut est = Adaptive2::<f32>::new(&f, &AdaptiveConfig::default()).expect("valid");
    let mut hold = ModalHold::<f32>::new();
    let (mut invalid, mut reported) = (0, 0);
    for k in 0..30_000u32 {
        let s = rig.tick();
        est.step(s.u as f32, s.y as f32);
        if k % 10 == 0 {
            let w = [WEIGHTS[0] as f32, WEIGHTS[1] as f32];
            let r = modal_from_tf(&est.transfer_function(), &w);
            let rep = hold.update(&r, 2);
            if !rep.validity.is_valid() {
                invalid += 1;
            }
            if let Some(m) = rep.modal {
                reported += 1;
                assert!(Validity::of(&m, 2).is_valid(), "{k}: {m:?}");
                assert!(m.omega_rad_s.iter().chain(&m.zeta).all(|v| v.is_finite()));
            } else {
                assert!(!rep.current);
            }
        }
    }
    assert!(invalid > 0, "no unphysical estimate seen at the start");
    assert!(reported > 2_000, "{reported}");
    let last = hold.last().expect("a valid estimate");
    let e = (last.omega_rad_s[0] as f64 / PAPER_OMEGA[0] - 1.0).abs();
    assert!(e < 1e-4, "{e:e}");
}
