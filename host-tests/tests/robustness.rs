//! Bad input never corrupts estimator state and never panics.

use beamctl::run::plant::PlantSpec;
use beamctl::run::{tuned_filter, RunConfig};
use beamest::estimator::{
    Adaptive2, AdaptiveConfig, Estimator, GradientConfig, GradientEstimator, LeastSquaresConfig,
    LeastSquaresEstimator, StepStatus,
};
use beamest::excitation::SquareWave;
use beamest::filter_bank::FilterConfig;
use beamest::modal::modal_from_tf;
use beamest::Real;
use proptest::prelude::*;

/// The λ and scales the truth-free rule settles on for the paper's run
/// (its last build over 3 s of the same simulation).
fn paper_filter() -> FilterConfig {
    tuned_filter(&RunConfig {
        duration_s: 3.0,
        ..RunConfig::default()
    })
    .expect("the rule builds an estimator")
}

/// Largest relative ω/ζ error of an estimator against the paper's truth.
fn paper_error<T: Real, E: Estimator<T, 7>>(est: &E) -> f64 {
    let truth = PlantSpec::Paper.truth().modal;
    let w = [T::from_f64(-2.0), T::from_f64(2.0)];
    let m = modal_from_tf(&est.transfer_function(), &w).expect("recoverable");
    (0..2)
        .map(|i| {
            let ew = (m.omega_rad_s[i].to_f64() / truth.omega_rad_s[i] - 1.0).abs();
            let ez = (m.zeta[i].to_f64() / truth.zeta[i] - 1.0).abs();
            ew.max(ez)
        })
        .fold(0.0, f64::max)
}

/// Run the paper's plant for `seconds`, replacing y by `bad(k)` where it
/// returns Some.
fn run_with_faults<T: Real, E: Estimator<T, 7>>(
    est: &mut E,
    seconds: f64,
    bad: impl Fn(usize) -> Option<f64>,
) -> Vec<StepStatus> {
    let mut plant = PlantSpec::Paper.plant(1e-4).expect("paper plant");
    let mut square = SquareWave::<f64>::paper();
    let mut statuses = Vec::new();
    for k in 0..(seconds / 1e-4) as usize {
        let u = square.next_sample();
        let y = plant.sample(u);
        let y = bad(k).unwrap_or(y);
        statuses.push(est.step(T::from_f64(u), T::from_f64(y)));
    }
    statuses
}

#[test]
fn nan_inf_and_absurd_samples_are_rejected_without_corrupting_the_estimate() {
    let fault = |k: usize| match k {
        30_000 => Some(f64::NAN),
        30_001 => Some(f64::INFINITY),
        50_000..=50_009 => Some(f64::NEG_INFINITY),
        70_000 => Some(1e30), // absurd but finite: beyond INPUT_LIMIT scales
        _ => None,
    };
    let filter = paper_filter();
    let mut est = Adaptive2::<f64>::new(&filter, &AdaptiveConfig::default()).expect("valid");
    let statuses = run_with_faults(&mut est, 10.0, fault);
    assert_eq!(statuses[30_000], StepStatus::Rejected);
    assert_eq!(statuses[50_005], StepStatus::Rejected);
    assert_eq!(statuses[70_000], StepStatus::Rejected);
    // The law is frozen until the filters have forgotten the substitute.
    let q = est.quarantine_samples() as usize;
    let expect = (40.0 / (filter.lambda_rad_s * 1e-4)).ceil() as usize;
    assert_eq!(q, expect, "40 time constants of λ at 10 kHz");
    assert_eq!(statuses[70_001], StepStatus::Frozen);
    assert_eq!(statuses[70_000 + q], StepStatus::Frozen);
    assert_eq!(statuses[70_000 + q + 1], StepStatus::Updated);
    let h = est.health();
    assert!(h.state_ok);
    assert_eq!(h.rejected, 13);
    assert_eq!(h.samples, 100_000);
    let err = paper_error(&est);
    assert!(
        err < 1e-6,
        "estimate corrupted by rejected samples: {err:e}"
    );
    assert!(est
        .excitation_level()
        .is_some_and(|v| v > 0.0 && v.is_finite()));
}

#[test]
fn f32_estimator_rejects_the_same_faults() {
    let mut est =
        Adaptive2::<f32>::new(&paper_filter(), &AdaptiveConfig::default()).expect("valid");
    run_with_faults(&mut est, 5.0, |k| {
        (k % 7919 == 0 && k > 0).then_some(f64::NAN)
    });
    assert_eq!(est.health().rejected, 6);
    assert!(paper_error(&est) < 1e-4);
}

#[test]
fn reset_restores_the_initial_state_exactly() {
    let filter = paper_filter();
    let mut used = Adaptive2::<f64>::new(&filter, &AdaptiveConfig::default()).expect("valid");
    run_with_faults(&mut used, 0.5, |_| None);
    used.reset();
    let mut fresh = Adaptive2::<f64>::new(&filter, &AdaptiveConfig::default()).expect("valid");
    run_with_faults(&mut used, 0.3, |_| None);
    run_with_faults(&mut fresh, 0.3, |_| None);
    assert_eq!(used.theta(), fresh.theta());
    assert_eq!(used.health(), fresh.health());
}

#[test]
fn no_excitation_means_no_update_and_no_garbage() {
    // u = 0, y = 0 forever: P stays zero; Θ must stay at its initial value.
    let mut est =
        Adaptive2::<f32>::new(&paper_filter(), &AdaptiveConfig::default()).expect("valid");
    for _ in 0..20_000 {
        est.step(0.0, 0.0);
    }
    assert!(est.theta().iter().all(|t| *t == 0.0));
    assert!(est.excitation_level().is_some_and(|v| v.abs() < 1e-30));
}

fn any_sample() -> impl Strategy<Value = f64> {
    prop_oneof![
        -1.0f64..1.0,
        -1e3f64..1e3,
        Just(0.0),
        Just(f64::NAN),
        Just(f64::INFINITY),
        Just(f64::MIN_POSITIVE),
        Just(1e30),
        Just(-1e300),
    ]
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    /// Any input sequence: no panic, and Θ stays finite for every law and type.
    #[test]
    fn arbitrary_input_never_panics_or_produces_non_finite_theta(
        samples in prop::collection::vec((any_sample(), any_sample()), 1..400)
    ) {
        let filter = paper_filter();
        let mut a64 = Adaptive2::<f64>::new(&filter, &AdaptiveConfig::default()).expect("valid");
        let mut a32 = Adaptive2::<f32>::new(&filter, &AdaptiveConfig::default()).expect("valid");
        let mut g32 = GradientEstimator::<f32, 4, 7>::new(&filter, &GradientConfig::default()).expect("valid");
        let mut l64 = LeastSquaresEstimator::<f64, 4, 7>::new(&filter, &LeastSquaresConfig::default()).expect("valid");
        for &(u, y) in &samples {
            a64.step(u, y);
            a32.step(u as f32, y as f32);
            g32.step(u as f32, y as f32);
            l64.step(u, y);
        }
        prop_assert!(a64.theta().iter().all(|t| t.is_finite()));
        prop_assert!(a32.theta().iter().all(|t| t.is_finite()));
        prop_assert!(g32.theta().iter().all(|t| t.is_finite()));
        prop_assert!(l64.theta().iter().all(|t| t.is_finite()));
        let _ = a32.excitation_level();
        let _ = modal_from_tf(&a32.transfer_function(), &[-2.0f32, 2.0]);
    }
}
