//! Deterministic per-sample cost of the pipeline and the excitation
//! generators, as instruction counts under valgrind (wall-clock timing on a
//! shared VM is too noisy to resolve the pipeline's overhead).
//!
//! Every mode does the same set-up (record the codes, build and warm up
//! both an estimator and a pipeline for 1 s); only the measured loop of
//! `N` samples differs, so
//! instructions per sample = (Ir(mode) − Ir(none)) / N:
//!
//! ```sh
//! cargo build --release -p host-tests --example pipeline_cost
//! for m in none bare bare_feedthrough bare_three tick tick_prefilter; do for t in f32 f64; do
//!   valgrind --tool=cachegrind --cache-sim=no --cachegrind-out-file=/dev/null \
//!     target/release/examples/pipeline_cost $m $t 2>&1 | grep 'I *refs'
//! done; done
//! ```
//! Excitation modes (f32): `square`, `multisine1`, `multisine8`, `prbs`,
//! `chirp_lin`, `chirp_log`, and `sinf` (a float phase and `libm::sinf`).

use std::hint::black_box;

use beam_protocol::Waveform;
use beamest::bench::conversion;
use beamest::estimator::{Adaptive2, Adaptive3, AdaptiveConfig, Estimator, Feedthrough2};
use beamest::excitation::{Excitation, SafeWindow, SquareWave};
use beamest::filter_bank::{FilterConfig, SignalScales};
use beamest::model::{PAPER_B, PAPER_OMEGA, PAPER_ZETA};
use beamest::pipeline::{
    AdcFlags, AdcReading, DacLatch, DacOutcome, FaultKind, InputSource, NoSink, PiezoDac, Pipeline,
    PipelineConfig, PrefilterConfig, Sink, StrainAdc,
};
use beamest::rig::ModalPlant;
use beamest::Real;

/// Samples in the measured loop.
const N: usize = 100_000;
const WARMUP: usize = 10_000;

struct Replay {
    codes: std::rc::Rc<Vec<i32>>,
    at: usize,
}

impl StrainAdc for Replay {
    type Error = FaultKind;
    #[inline]
    fn read(&mut self) -> Result<AdcReading, FaultKind> {
        let c = self.codes.get(self.at).copied().unwrap_or(0);
        self.at += 1;
        Ok(AdcReading {
            bridge: c,
            monitor: 0,
            flags: AdcFlags::default(),
        })
    }
}

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

struct Accept;

impl<M> Sink<M> for Accept {
    #[inline]
    fn try_push(&mut self, m: M) -> Result<(), M> {
        black_box(&m);
        Ok(())
    }
}

fn run<T: Real>(mode: &str) {
    let cfg = conversion();
    let mut plant = ModalPlant::<f64>::with_numerator(&PAPER_OMEGA, &PAPER_ZETA, &PAPER_B, 1e-4)
        .expect("plant");
    let mut sq = SquareWave::<f64>::paper();
    let codes: Vec<i32> = (0..WARMUP + N)
        .map(|_| {
            let c = cfg.bridge_code_for(plant.output()).expect("finite");
            plant.advance(sq.next_sample());
            c
        })
        .collect();
    let codes = std::rc::Rc::new(codes);
    let conv = cfg.compile::<T>().expect("conversion");
    let mut sq = SquareWave::<T>::paper();
    let pairs: Vec<(T, T)> = codes
        .iter()
        .map(|&k| (sq.next_sample(), conv.y_from_code(k)))
        .collect();
    let filter = FilterConfig {
        ts_s: 1e-4,
        lambda_rad_s: 100.0,
        scales: SignalScales {
            u_scale: 0.1,
            y_scale: 1e-3,
        },
        ..FilterConfig::default()
    };
    // `bare_nosup`: the same law without its supervisor (issue 9).
    let law = if mode == "bare_nosup" {
        AdaptiveConfig {
            supervision: beamest::supervise::SupervisorConfig::OFF,
            ..AdaptiveConfig::default()
        }
    } else {
        AdaptiveConfig::default()
    };
    let mut est = Adaptive2::<T>::new(&filter, &law).expect("estimator");
    // `bare_feedthrough`: the two-mode estimator with a feedthrough term
    // (issue 9, modes beyond the model), built and warmed up in every mode.
    // `bare_three`: the three-mode law on the same data, for comparison.
    let mut ft = Feedthrough2::<T>::with_default_gains(&filter).expect("estimator");
    let mut three = Adaptive3::<T>::new(&filter, &AdaptiveConfig::default()).expect("estimator");
    for &(u, y) in &pairs[..WARMUP] {
        est.step(u, y);
        ft.step(u, y);
        three.step(u, y);
    }
    let pcfg = PipelineConfig {
        conversion: cfg,
        input: InputSource::Commanded,
        amplifier_gain: 1.0,
        dac_latch: DacLatch::Immediate,
        prefilter: (mode == "tick_prefilter").then_some(PrefilterConfig {
            order: 4,
            cutoff_hz: 1000.0,
            sample_rate_hz: 1e4,
        }),
        telemetry_every: 100,
        raw_decimation: 0,
        stuck_after: 0,
        lambda_rad_s: 100.0,
    };
    let window = SafeWindow {
        min_v: T::from_f64(-10.0),
        max_v: T::from_f64(10.0),
    };
    let exc = Excitation::new(
        &Waveform::Square { freq_hz: 7.0 },
        T::from_f64(0.1),
        T::ZERO,
        window,
        1e4,
    )
    .expect("excitation");
    let adc = Replay {
        codes: codes.clone(),
        at: 0,
    };
    let mut p = Pipeline::<T, _, _, _, _, NoSink, 7, 28>::new(
        &pcfg,
        Adaptive2::<T>::new(&filter, &AdaptiveConfig::default()).expect("estimator"),
        exc,
        adc,
        Hold,
        Accept,
        NoSink,
    )
    .expect("pipeline");
    for _ in 0..WARMUP {
        p.tick();
    }
    let shapes = host_tests::excitation_cost::generators();
    // Build every generator in every mode (the multisine scan is set-up).
    let mut gens: Vec<(&str, Excitation<T>)> = shapes
        .iter()
        .map(|(n, s)| {
            (
                *n,
                Excitation::with_generator(*s, T::ONE, T::ZERO, window).expect("shape"),
            )
        })
        .collect();
    match mode {
        "none" => {}
        "bare" | "bare_nosup" => {
            for &(u, y) in &pairs[WARMUP..] {
                black_box(est.step(black_box(u), black_box(y)));
            }
        }
        "bare_feedthrough" => {
            for &(u, y) in &pairs[WARMUP..] {
                black_box(ft.step(black_box(u), black_box(y)));
            }
        }
        "bare_three" => {
            for &(u, y) in &pairs[WARMUP..] {
                black_box(three.step(black_box(u), black_box(y)));
            }
        }
        "tick" | "tick_prefilter" => {
            for _ in 0..N {
                black_box(p.tick());
            }
        }
        "sinf" => {
            let mut phase = 0.0f32;
            let step = 2.0 * std::f32::consts::PI * 7.0 / 1e4;
            for _ in 0..N {
                black_box(libm::sinf(black_box(phase)));
                phase += step;
                if phase > std::f32::consts::PI {
                    phase -= 2.0 * std::f32::consts::PI;
                }
            }
        }
        other => {
            let Some((_, g)) = gens.iter_mut().find(|(n, _)| *n == other) else {
                eprintln!("unknown mode {other}");
                std::process::exit(2);
            };
            for _ in 0..N {
                black_box(g.next_sample());
            }
        }
    }
    black_box((&est, &ft, &three, &p, &gens));
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let mode = args.get(1).map_or("none", |s| s.as_str());
    match args.get(2).map_or("f32", |s| s.as_str()) {
        "f64" => run::<f64>(mode),
        _ => run::<f32>(mode),
    }
}
