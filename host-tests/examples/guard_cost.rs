//! Per-sample cost of the sensor guard with and without the residual
//! monitor, as deterministic instruction counts (docs/ROBUSTNESS.md §1).
//!
//! ```text
//! cargo build --release -p host-tests --example guard_cost
//! valgrind --tool=cachegrind --cache-sim=no --cachegrind-out-file=/dev/null \
//!   target/release/examples/guard_cost monitor f32     # none | guard | monitor | lines; f32 | f64
//! ```
//!
//! The samples (the paper's plant under 0.1·square(7 Hz), noise-free, 20 s)
//! and the settings (`startup_filter`) are computed first in every mode;
//! (count(mode) − count(none))/200,000 is the guard's cost per sample
//! (the monitor's construction included: ≈ 10 per sample). The monitor is given the plant's own Θ
//! (a cost measurement: any converged model costs the same). `lines`: the
//! guard and the line remover after it, the mains at 50 Hz and its
//! harmonics 1–7 (`beamest::guard::lines`, as the firmware runs it after
//! `SetLineRemoval`); (count(lines) − count(guard))/200,000 is the
//! remover's cost per sample.

use beamest::guard::lines::{LineCanceller, LineSpec, MAX_LINES};
use beamest::guard::{GuardConfig, ResidualMonitor, SensorGuard};
use beamest::model::paper_plant_tf;
use beamest::rig::Scenario;
use beamest::Real;
use host_tests::scenario_run::{paper_rig, startup_filter, TS_S};
use std::hint::black_box;

const N: usize = 200_000;

fn run<T: Real>(mode: &str, samples: &[(f64, f64)]) {
    let f = startup_filter(&paper_rig(Scenario::default(), None, 1, None));
    let mut g = SensorGuard::<T>::new(&GuardConfig::new(TS_S)).expect("valid");
    // The monitor is built (two filter-bank discretizations) in its mode
    // only, so that the guard's figure carries none of it.
    let mut m = (mode == "monitor").then(|| {
        let mut m = ResidualMonitor::<T>::new(&f).expect("valid");
        let tf = paper_plant_tf();
        let k = beamest::model::lambda_poly(4, f.lambda_rad_s);
        // Θ = (b, k − a) (eq. 29).
        let theta: [T; 7] = core::array::from_fn(|j| {
            T::from_f64(if j < 3 {
                tf.b[j]
            } else {
                k[j - 3] - tf.a[j - 3]
            })
        });
        m.set_theta(Some(&theta));
        m
    });
    let mut lines = (mode == "lines").then(|| {
        let specs: Vec<LineSpec> = (1..=7)
            .map(|k| LineSpec {
                freq_hz: 50.0 * f64::from(k),
                y_phasor: [0.0, 0.0],
            })
            .collect();
        LineCanceller::<T, MAX_LINES>::new(&specs, TS_S, 0.2).expect("valid")
    });
    let mut acc = T::ZERO;
    for (i, (u, y)) in samples.iter().enumerate() {
        let (u, y) = (T::from_f64(*u), T::from_f64(*y));
        let out = match m.as_mut() {
            None => g.push(u, y),
            Some(m) => g.push_monitored(u, y, true, i as u64, Some(m)),
        };
        if let Some(o) = out {
            let (ou, oy) = match lines.as_mut() {
                Some(c) => c.push(o.u, o.y),
                None => (o.u, o.y),
            };
            acc += oy + ou;
        }
    }
    black_box(acc);
    eprintln!("{mode} {}: counts {:?}", T::NAME, g.counts());
}

fn main() {
    let mode = std::env::args().nth(1).unwrap_or_else(|| "monitor".into());
    let ty = std::env::args().nth(2).unwrap_or_else(|| "f32".into());
    let mut rig = paper_rig(Scenario::default(), None, 1, None);
    let samples: Vec<(f64, f64)> = (0..N)
        .map(|_| {
            let s = rig.tick();
            (s.u, s.y)
        })
        .collect();
    let samples = black_box(samples);
    match (mode.as_str(), ty.as_str()) {
        ("none", _) => {
            black_box(startup_filter(&paper_rig(
                Scenario::default(),
                None,
                1,
                None,
            )));
        }
        (_, "f64") => run::<f64>(&mode, &samples),
        _ => run::<f32>(&mode, &samples),
    }
}
