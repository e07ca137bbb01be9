//! Criterion benchmarks of the estimators (results in BENCHMARKS.md).
//!
//! * `step/<law>/<float>/<modes>`: [`Estimator::step`] (input screening,
//!   filter bank and update law) on realistic data — the simulated beam
//!   driven by 0.1·square(7 Hz) at Ts = 0.1 ms, with the runner's filter
//!   configuration — from a state warmed up for 1 s. Criterion reports the
//!   time per sample (`Throughput::Elements`).
//! * `step/filter_bank/<float>/<modes>`: the filter bank alone (shared by
//!   all laws), for the breakdown.
//! * `step/robust/<float>/<modes>`: the noise-robust estimator in its steady
//!   phase (warmed up for its 2 s start-up record instead of 1 s).
//! * `startup/robust/<float>/<modes>`: the robust estimator's start-up
//!   record from rest (2 s: start-up law, recording, and the replays of the
//!   record), per sample.
//! * `modal_from_tf/<float>/<modes>`: modal recovery (telemetry rate).
//! * `excitation_level/adaptive/<float>/2`: the Lemma 1 excitation monitor
//!   (telemetry rate).
//!
//! `cargo bench -p host-tests --bench estimators` measures;
//! `cargo test -p host-tests --benches` runs every benchmark once as a test.

use std::hint::black_box;
use std::time::{Duration, Instant};

use beamctl::run::plant::PlantSpec;
use beamctl::run::tuned_filter;
use beamctl::run::RunConfig;
use beamest::estimator::robust::RobustConfig;
use beamest::estimator::robust::{Phase, RobustEstimator, DEFAULT_RECORD};
use beamest::estimator::{
    AdaptiveConfig, AdaptiveEstimator, Estimator, GradientConfig, GradientEstimator,
    LeastSquaresConfig, LeastSquaresEstimator, StepStatus,
};
use beamest::excitation::SquareWave;
use beamest::filter_bank::{FilterBank, FilterConfig};
use beamest::modal::modal_from_tf;
use beamest::model::TransferFunction;
use beamest::supervise::SupervisorConfig;
use beamest::Real;
use criterion::measurement::WallTime;
use criterion::Throughput;
use criterion::{criterion_group, criterion_main, Bencher, BenchmarkGroup, BenchmarkId, Criterion};

/// Samples fed before measuring (1 s at 10 kHz): past the initial transient.
const WARMUP_SAMPLES: usize = 10_000;
/// Samples per measured iteration (2 s of signal).
const MEASURED_SAMPLES: usize = 20_000;

/// Precomputed signals and settings for one plant, in working precision.
struct Workload<T> {
    filter: FilterConfig,
    warm_u: Vec<T>,
    warm_y: Vec<T>,
    u: Vec<T>,
    y: Vec<T>,
    /// The plant's true transfer function and output weights (input of the
    /// modal-recovery benchmark).
    tf: TransferFunction<T>,
    weights: Vec<T>,
}

impl<T: Real> Workload<T> {
    /// The documented default beam for `modes` modes, excited as in the
    /// paper, filtered as `beamctl simulate` would.
    fn new(modes: usize) -> Self {
        Self::with_warmup(modes, WARMUP_SAMPLES)
    }

    /// The same with `warmup` samples fed before the measured ones.
    fn with_warmup(modes: usize, warmup: usize) -> Self {
        let plant_spec = PlantSpec::default_for_modes(modes).expect("1..=3 modes");
        let cfg = RunConfig {
            plant: plant_spec.clone(),
            ..RunConfig::default()
        };
        let truth = plant_spec.truth();
        // λ and scales as the truth-free rule ends up choosing them on this
        // beam (5 s of the same simulation).
        let filter = tuned_filter(&RunConfig {
            duration_s: 5.0,
            ..cfg.clone()
        })
        .expect("tuning rule builds an estimator");
        let mut plant = plant_spec.plant(cfg.ts_s).expect("valid plant");
        let mut square = SquareWave::<f64>::new(cfg.u_amplitude, cfg.u_freq_hz, 1.0 / cfg.ts_s)
            .expect("valid excitation");
        let total = warmup + MEASURED_SAMPLES;
        let mut u = Vec::with_capacity(total);
        let mut y = Vec::with_capacity(total);
        for _ in 0..total {
            let uk = square.next_sample();
            let yk = plant.sample(uk);
            u.push(T::from_f64(uk));
            y.push(T::from_f64(yk));
        }
        let (warm_u, u) = (u[..warmup].to_vec(), u[warmup..].to_vec());
        let (warm_y, y) = (y[..warmup].to_vec(), y[warmup..].to_vec());
        let tf = TransferFunction {
            modes: truth.tf.modes,
            a: truth.tf.a.map(T::from_f64),
            b: truth.tf.b.map(T::from_f64),
            output: truth.tf.output,
        };
        let weights = truth.modal.output_weight[..truth.modal.modes]
            .iter()
            .map(|&c| T::from_f64(c))
            .collect();
        Self {
            filter,
            warm_u,
            warm_y,
            u,
            y,
            tf,
            weights,
        }
    }

    /// Feed the warm-up samples.
    fn warm_up<E: Estimator<T, NP>, const NP: usize>(&self, est: &mut E) {
        for (&u, &y) in self.warm_u.iter().zip(&self.warm_y) {
            est.step(u, y);
        }
    }
}

/// Time `push` over the measured buffer, each iteration starting from the
/// same warmed-up state (the clone is not timed).
fn time_buffer<T: Real, S: Clone, R>(
    b: &mut Bencher<'_>,
    state: &S,
    work: &Workload<T>,
    push: impl Fn(&mut S, T, T) -> R,
) {
    b.iter_custom(|iters| {
        let mut elapsed = Duration::ZERO;
        for _ in 0..iters {
            let mut s = state.clone();
            let start = Instant::now();
            for (&u, &y) in work.u.iter().zip(&work.y) {
                black_box(push(&mut s, black_box(u), black_box(y)));
            }
            elapsed += start.elapsed();
            black_box(&s);
        }
        elapsed
    })
}

/// Time [`Estimator::step`] from a warmed-up state.
fn bench_step<T: Real, E: Estimator<T, NP> + Clone, const NP: usize>(
    group: &mut BenchmarkGroup<'_, WallTime>,
    law: &str,
    modes: usize,
    mut est: E,
    work: &Workload<T>,
) {
    let name = format!("{law}/{}", T::NAME);
    work.warm_up(&mut est);
    // The measured buffer must exercise the full update path every sample.
    let mut probe = est.clone();
    let updated = work
        .u
        .iter()
        .zip(&work.y)
        .filter(|(&u, &y)| probe.step(u, y) == StepStatus::Updated)
        .count();
    assert_eq!(
        updated,
        work.u.len(),
        "{name}/{modes}: not every sample updated"
    );
    group.bench_function(BenchmarkId::new(name, modes), |b| {
        time_buffer(b, &est, work, |e, u, y| e.step(u, y))
    });
}

/// The filter bank alone (the part of `step` shared by all laws).
fn bench_filter_bank<T: Real, const D: usize, const NP: usize>(
    group: &mut BenchmarkGroup<'_, WallTime>,
    modes: usize,
    work: &Workload<T>,
) {
    let mut bank = FilterBank::<T, D, NP>::new(&work.filter).expect("config");
    for (&u, &y) in work.warm_u.iter().zip(&work.warm_y) {
        bank.push(u, y);
    }
    group.bench_function(
        BenchmarkId::new(format!("filter_bank/{}", T::NAME), modes),
        |b| time_buffer(b, &bank, work, |f, u, y| f.push(u, y)),
    );
}

/// All laws for one float type and one model size.
fn step_all_laws<T: Real, const D: usize, const NP: usize, const NS: usize>(
    group: &mut BenchmarkGroup<'_, WallTime>,
    modes: usize,
) {
    let work = Workload::<T>::new(modes);
    let f = &work.filter;
    let adaptive = AdaptiveConfig::<NP>::default();
    let adaptive_k1 = AdaptiveConfig::<NP> {
        theta_update_every: 1,
        ..adaptive
    };
    let est = AdaptiveEstimator::<T, D, NP, NS>::new(f, &adaptive).expect("config");
    bench_step(group, "adaptive", modes, est, &work);
    // The same law without its supervisor (excitation monitor, in-loop
    // Lemma 1, change test): the supervisor's per-sample cost is the
    // difference.
    let unsupervised = AdaptiveConfig::<NP> {
        supervision: SupervisorConfig::OFF,
        ..adaptive
    };
    let est = AdaptiveEstimator::<T, D, NP, NS>::new(f, &unsupervised).expect("config");
    bench_step(group, "adaptive_nosup", modes, est, &work);
    let est = AdaptiveEstimator::<T, D, NP, NS>::new(f, &adaptive_k1).expect("config");
    bench_step(group, "adaptive_k1", modes, est, &work);
    let est = GradientEstimator::<T, D, NP>::new(f, &GradientConfig::default()).expect("config");
    bench_step(group, "gradient", modes, est, &work);
    let est =
        LeastSquaresEstimator::<T, D, NP>::new(f, &LeastSquaresConfig::default()).expect("config");
    bench_step(group, "ls", modes, est, &work);
    bench_filter_bank::<T, D, NP>(group, modes, &work);
    // The robust estimator is measured in its steady phase: warmed up for
    // its whole start-up record.
    let long = Workload::<T>::with_warmup(modes, DEFAULT_RECORD);
    let robust = RobustEstimator::<T, D, NP, NS, DEFAULT_RECORD>::new(
        &long.filter,
        &RobustConfig::default(),
    )
    .expect("config");
    let mut warm = robust.clone();
    long.warm_up(&mut warm);
    assert_eq!(
        warm.phase(),
        Phase::Steady,
        "robust/{modes}: record not full"
    );
    bench_step(group, "robust", modes, robust, &long);
}

/// The robust estimator's start-up record (2 s) from rest, per sample.
fn startup_one<T: Real, const D: usize, const NP: usize, const NS: usize>(
    group: &mut BenchmarkGroup<'_, WallTime>,
    modes: usize,
) {
    let work = Workload::<T>::with_warmup(modes, DEFAULT_RECORD);
    let est = RobustEstimator::<T, D, NP, NS, DEFAULT_RECORD>::new(
        &work.filter,
        &RobustConfig::default(),
    )
    .expect("config");
    group.bench_function(
        BenchmarkId::new(format!("robust/{}", T::NAME), modes),
        |b| {
            b.iter_custom(|iters| {
                let mut elapsed = Duration::ZERO;
                for _ in 0..iters {
                    let mut e = est.clone();
                    let start = Instant::now();
                    for (&u, &y) in work.warm_u.iter().zip(&work.warm_y) {
                        black_box(e.step(black_box(u), black_box(y)));
                    }
                    elapsed += start.elapsed();
                    black_box(&e);
                }
                elapsed
            })
        },
    );
}

fn startup(c: &mut Criterion) {
    let mut group = c.benchmark_group("startup");
    group.throughput(Throughput::Elements(DEFAULT_RECORD as u64));
    startup_one::<f32, 4, 7, 28>(&mut group, 2);
    startup_one::<f64, 4, 7, 28>(&mut group, 2);
    group.finish();
}

fn step(c: &mut Criterion) {
    let mut group = c.benchmark_group("step");
    group.throughput(Throughput::Elements(MEASURED_SAMPLES as u64));
    step_all_laws::<f32, 2, 3, 6>(&mut group, 1);
    step_all_laws::<f64, 2, 3, 6>(&mut group, 1);
    step_all_laws::<f32, 4, 7, 28>(&mut group, 2);
    step_all_laws::<f64, 4, 7, 28>(&mut group, 2);
    step_all_laws::<f32, 6, 11, 66>(&mut group, 3);
    step_all_laws::<f64, 6, 11, 66>(&mut group, 3);
    group.finish();
}

fn modal_one<T: Real>(group: &mut BenchmarkGroup<'_, WallTime>, modes: usize) {
    let work = Workload::<T>::new(modes);
    assert!(
        modal_from_tf(&work.tf, &work.weights).is_ok(),
        "modal recovery fails for {modes} modes in {}",
        T::NAME
    );
    group.bench_function(BenchmarkId::new(T::NAME, modes), |b| {
        b.iter(|| modal_from_tf(black_box(&work.tf), black_box(&work.weights)))
    });
}

fn modal(c: &mut Criterion) {
    let mut group = c.benchmark_group("modal_from_tf");
    for modes in 1..=3 {
        modal_one::<f32>(&mut group, modes);
        modal_one::<f64>(&mut group, modes);
    }
    group.finish();
}

fn excitation_one<T: Real>(group: &mut BenchmarkGroup<'_, WallTime>) {
    let work = Workload::<T>::new(2);
    let mut est = AdaptiveEstimator::<T, 4, 7, 28>::new(&work.filter, &AdaptiveConfig::default())
        .expect("config");
    work.warm_up(&mut est);
    assert!(est.excitation_level().is_some());
    group.bench_function(BenchmarkId::new(format!("adaptive/{}", T::NAME), 2), |b| {
        b.iter(|| black_box(&est).excitation_level())
    });
}

fn excitation(c: &mut Criterion) {
    let mut group = c.benchmark_group("excitation_level");
    excitation_one::<f32>(&mut group);
    excitation_one::<f64>(&mut group);
    group.finish();
}

fn config() -> Criterion {
    // Shared 2-core VM: short, few samples; the numbers vary ±20% anyway.
    Criterion::default()
        .warm_up_time(Duration::from_secs(1))
        .measurement_time(Duration::from_secs(2))
        .sample_size(20)
}

criterion_group! {
    name = benches;
    config = config();
    targets = step, startup, modal, excitation
}
criterion_main!(benches);
