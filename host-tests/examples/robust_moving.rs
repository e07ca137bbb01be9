//! The robust estimator started on a moving beam, with the QEMU bench's
//! settings (`link::robust_configs`), on the bench's plant with or without
//! its converter timing.
//!
//! `cargo run --release -p host-tests --example robust_moving -- [start_s] [off_s] [timing|ideal] [f32|f64] [seconds] [modelled|unmodelled]`
//!
//! (`timing`: the bench's converters simulated; `modelled`: the estimator
//! models them, `FilterConfig::timing`.)

use beam_protocol::{EstimatorKind, EstimatorSettings};
use beamest::bench;
use beamest::estimator::robust::Robust2;
use beamest::estimator::Estimator;
use beamest::excitation::SquareWave;
use beamest::filter_bank::{FilterConfig, SignalScales};
use beamest::link::robust_configs;
use beamest::modal::modal_from_tf;
use beamest::model::{PAPER_OMEGA, PAPER_ZETA};
use beamest::rig::{ConverterTiming, TimedPlant};
use beamest::Real;

fn err<T: Real>(est: &Robust2<T>) -> (f64, f64) {
    let w = [T::from_f64(-2.0), T::from_f64(2.0)];
    match modal_from_tf(&est.transfer_function(), &w) {
        Ok(m) => {
            let mut ew = 0.0f64;
            let mut ez = 0.0f64;
            for i in 0..2 {
                ew = ew.max((m.omega_rad_s[i].to_f64() / PAPER_OMEGA[i] - 1.0).abs());
                ez = ez.max((m.zeta[i].to_f64() / PAPER_ZETA[i] - 1.0).abs());
            }
            (ew, ez)
        }
        Err(_) => (f64::INFINITY, f64::INFINITY),
    }
}

fn run<T: Real>(start_s: f64, off_s: f64, timing: bool, seconds: f64, model_timing: bool) {
    let plant = bench::plant().unwrap();
    let t = if timing {
        bench::converter_timing()
    } else {
        ConverterTiming::IDEAL
    };
    let mut p = TimedPlant::new(&plant, t).unwrap();
    let mut sq = SquareWave::<f64>::paper();
    let settings = EstimatorSettings {
        kind: EstimatorKind::Robust,
        forgetting_p: 0.01,
        forgetting_h: 0.01,
        ..EstimatorSettings::default()
    };
    let base = FilterConfig {
        ts_s: bench::TS_S,
        lambda_rad_s: 94.15,
        scales: SignalScales {
            u_scale: 0.1007,
            y_scale: 2.3195e-3,
        },
        timing: if model_timing {
            bench::output_timing()
        } else {
            beamest::filter_bank::OutputTiming::IDEAL
        },
        ..FilterConfig::default()
    };
    let (filter, mut law) = robust_configs::<7>(&settings, 94.15, &base);
    law.update_every = 1_000;
    let mut est = Box::new(Robust2::<T>::new(&filter, &law).unwrap());
    let start = (start_s * 1e4) as usize;
    let off = (off_s * 1e4) as usize;
    let total = start + (seconds * 1e4) as usize;
    let mut u_prev = 0.0;
    for k in 0..total {
        p.advance(u_prev);
        let y = p.measured();
        // The excitation: on until 0.5 s if off_s > 0, off for off_s, then on.
        let on = off == 0 || k < 5_000 || k >= 5_000 + off;
        let s = sq.next_sample();
        let u = if on { s } else { 0.0 };
        if k >= start {
            est.step(T::from_f64(u), T::from_f64(y));
            let n = k - start + 1;
            if n.is_multiple_of(2_000) || n == 32 {
                let (ew, ez) = err(&est);
                println!(
                    "t {:6.2} s (est {:5.2} s) phase {:?} updates {} initial {:?} ω {:.2e} ζ {:.2e}",
                    k as f64 * 1e-4,
                    n as f64 * 1e-4,
                    est.phase(),
                    est.updates(),
                    est.initial_state_significance().map(|(c, m)| (c.to_f64(), m)),
                    ew,
                    ez
                );
            }
        }
        u_prev = u;
    }
}

fn main() {
    let a: Vec<String> = std::env::args().collect();
    let start: f64 = a.get(1).and_then(|s| s.parse().ok()).unwrap_or(1.0);
    let off: f64 = a.get(2).and_then(|s| s.parse().ok()).unwrap_or(0.0);
    let timing = a.get(3).is_none_or(|s| s != "ideal");
    let f32 = a.get(4).is_some_and(|s| s == "f32");
    let secs: f64 = a.get(5).and_then(|s| s.parse().ok()).unwrap_or(8.0);
    let model = a.get(6).is_none_or(|s| s != "unmodelled");
    if f32 {
        run::<f32>(start, off, timing, secs, model);
    } else {
        run::<f64>(start, off, timing, secs, model);
    }
}
