//! Criterion benchmarks of the per-sample pipeline and the excitation
//! generators (results in BENCHMARKS.md).
//!
//! * `pipeline/bare_step/<float>`: `Adaptive2::step` alone on the (u, y)
//!   the pipeline would feed it (the paper's plant through the 24-bit
//!   conversion chain of the host test), from a state warmed up for 1 s.
//! * `pipeline/tick/<float>`: `Pipeline::tick` on the same data: converter
//!   mocks that replay recorded codes and hold the written voltage, the
//!   excitation, screening, conversion (exact quarter bridge + eq. 17), the
//!   estimator step and a telemetry record every 100 samples into a sink
//!   that accepts everything. tick − bare_step = the pipeline's overhead.
//! * `pipeline/tick_prefilter/<float>`: the same with a 4th-order prefilter.
//! * `excitation/<kind>`: one sample of each waveform (f32), and a sine
//!   by `libm::sinf` for comparison with the table.
//!
//! `cargo bench -p host-tests --bench pipeline` measures;
//! `cargo test -p host-tests --benches` runs each once as a test.

use std::hint::black_box;
use std::time::{Duration, Instant};

use beam_protocol::Waveform;
use beamest::bench::conversion;
use beamest::estimator::{Adaptive2, AdaptiveConfig, Estimator};
use beamest::excitation::{Excitation, SafeWindow, SquareWave};
use beamest::filter_bank::{FilterConfig, SignalScales};
use beamest::model::{PAPER_B, PAPER_OMEGA, PAPER_ZETA};
use beamest::pipeline::{
    AdcFlags, AdcReading, DacLatch, DacOutcome, FaultKind, InputSource, NoSink, PiezoDac, Pipeline,
    PipelineConfig, PrefilterConfig, Sink, StrainAdc,
};
use beamest::rig::ModalPlant;
use beamest::Real;
use criterion::{criterion_group, criterion_main, Criterion, Throughput};

const WARMUP: usize = 10_000;
/// 2 s: 14 whole periods of the 7 Hz square wave, so the replayed codes
/// stay consistent with the excitation when they wrap around.
const MEASURED: usize = 20_000;

/// Bridge codes of the paper's plant under 0.1·square(7 Hz), WARMUP + MEASURED.
fn codes() -> Vec<i32> {
    let cfg = conversion();
    let mut p = ModalPlant::<f64>::with_numerator(&PAPER_OMEGA, &PAPER_ZETA, &PAPER_B, 1e-4)
        .expect("plant");
    let mut sq = SquareWave::<f64>::paper();
    (0..WARMUP + MEASURED)
        .map(|_| {
            let c = cfg.bridge_code_for(p.output()).expect("finite");
            p.advance(sq.next_sample());
            c
        })
        .collect()
}

fn estimator<T: Real>() -> Adaptive2<T> {
    let filter = FilterConfig {
        ts_s: 1e-4,
        lambda_rad_s: 100.0,
        scales: SignalScales {
            u_scale: 0.1,
            y_scale: 1e-3,
        },
        ..FilterConfig::default()
    };
    Adaptive2::new(&filter, &AdaptiveConfig::default()).expect("config")
}

#[derive(Clone)]
struct Replay {
    codes: std::rc::Rc<Vec<i32>>,
    at: usize,
}

impl StrainAdc for Replay {
    type Error = FaultKind;
    #[inline]
    fn read(&mut self) -> Result<AdcReading, FaultKind> {
        let c = self.codes[WARMUP + (self.at % MEASURED)];
        self.at += 1;
        Ok(AdcReading {
            bridge: c,
            monitor: 0,
            flags: AdcFlags::default(),
        })
    }
}

#[derive(Clone)]
struct Hold;

impl<T: Real> PiezoDac<T> for Hold {
    type Error = FaultKind;
    #[inline]
    fn write_volts(&mut self, v: T) -> Result<DacOutcome<T>, FaultKind> {
        Ok(DacOutcome {
            held_v: v,
            saturated: false,
        })
    }
}

#[derive(Clone)]
struct Accept;

impl<M> Sink<M> for Accept {
    #[inline]
    fn try_push(&mut self, m: M) -> Result<(), M> {
        black_box(&m);
        Ok(())
    }
}

type Pipe<T> = Pipeline<T, Adaptive2<T>, Replay, Hold, Accept, NoSink, 7, 28>;

fn pipeline<T: Real>(codes: &std::rc::Rc<Vec<i32>>, prefilter: bool) -> Pipe<T> {
    let cfg = PipelineConfig {
        conversion: conversion(),
        input: InputSource::Commanded,
        amplifier_gain: 1.0,
        dac_latch: DacLatch::Immediate,
        prefilter: prefilter.then_some(PrefilterConfig {
            order: 4,
            cutoff_hz: 1000.0,
            sample_rate_hz: 1e4,
        }),
        telemetry_every: 100,
        raw_decimation: 0,
        stuck_after: 0,
        lambda_rad_s: 100.0,
    };
    let exc = Excitation::new(
        &Waveform::Square { freq_hz: 7.0 },
        T::from_f64(0.1),
        T::ZERO,
        SafeWindow {
            min_v: T::from_f64(-10.0),
            max_v: T::from_f64(10.0),
        },
        1e4,
    )
    .expect("excitation");
    let adc = Replay {
        codes: codes.clone(),
        at: 0,
    };
    let mut p =
        Pipeline::new(&cfg, estimator::<T>(), exc, adc, Hold, Accept, NoSink).expect("pipeline");
    for _ in 0..WARMUP {
        p.tick();
    }
    p
}

fn bench_float<T: Real>(c: &mut Criterion, codes: &std::rc::Rc<Vec<i32>>) {
    let conv = conversion().compile::<T>().expect("conversion");
    let mut sq = SquareWave::<T>::paper();
    let pairs: Vec<(T, T)> = codes
        .iter()
        .map(|&k| (sq.next_sample(), conv.y_from_code(k)))
        .collect();
    let mut warm = estimator::<T>();
    for &(u, y) in &pairs[..WARMUP] {
        warm.step(u, y);
    }
    let mut g = c.benchmark_group("pipeline");
    g.throughput(Throughput::Elements(MEASURED as u64));
    g.bench_function(format!("bare_step/{}", T::NAME), |b| {
        b.iter_custom(|iters| {
            let mut total = Duration::ZERO;
            for _ in 0..iters {
                let mut e = warm.clone();
                let t = Instant::now();
                for &(u, y) in &pairs[WARMUP..] {
                    black_box(e.step(black_box(u), black_box(y)));
                }
                total += t.elapsed();
            }
            total
        })
    });
    for (name, pf) in [("tick", false), ("tick_prefilter", true)] {
        g.bench_function(format!("{name}/{}", T::NAME), |b| {
            b.iter_custom(|iters| {
                let mut total = Duration::ZERO;
                for _ in 0..iters {
                    // A fresh pipeline warmed up for 1 s (not timed).
                    let mut p = pipeline::<T>(codes, pf);
                    let t = Instant::now();
                    for _ in 0..MEASURED {
                        black_box(p.tick());
                    }
                    total += t.elapsed();
                }
                total
            })
        });
    }
    g.finish();
}

fn pipeline_benches(c: &mut Criterion) {
    let codes = std::rc::Rc::new(codes());
    bench_float::<f32>(c, &codes);
    bench_float::<f64>(c, &codes);
}

fn excitation_benches(c: &mut Criterion) {
    let w = SafeWindow {
        min_v: -10.0f32,
        max_v: 10.0,
    };
    let shapes = host_tests::excitation_cost::generators();
    let mut g = c.benchmark_group("excitation");
    const N: usize = 10_000;
    g.throughput(Throughput::Elements(N as u64));
    for (name, shape) in shapes {
        let mut e = Excitation::with_generator(shape, 1.0f32, 0.0, w).expect("shape");
        g.bench_function(name, |b| {
            b.iter(|| {
                for _ in 0..N {
                    black_box(e.next_sample());
                }
            })
        });
    }
    // The alternative the table replaces: a float phase and libm::sinf.
    let mut phase = 0.0f32;
    let step = 2.0 * std::f32::consts::PI * 7.0 / 1e4;
    g.bench_function("libm_sinf_1", |b| {
        b.iter(|| {
            for _ in 0..N {
                black_box(libm::sinf(phase));
                phase += step;
                if phase > std::f32::consts::PI {
                    phase -= 2.0 * std::f32::consts::PI;
                }
            }
        })
    });
    g.finish();
}

fn config() -> Criterion {
    Criterion::default()
        .warm_up_time(Duration::from_millis(500))
        .measurement_time(Duration::from_secs(3))
        .sample_size(20)
}

criterion_group! { name = benches; config = config(); targets = pipeline_benches, excitation_benches }
criterion_main!(benches);
