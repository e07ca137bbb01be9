//! Ad-hoc per-sample timing (criterion benches are the reference).
use beamest::estimator::*;
use beamest::filter_bank::*;
use std::time::Instant;
fn go<T: beamest::Real>(k_every: u32) {
    let f = FilterConfig {
        scales: SignalScales {
            u_scale: 0.1,
            y_scale: 1.2e-3,
        },
        ..Default::default()
    };
    let cfg = AdaptiveConfig {
        theta_update_every: k_every,
        ..AdaptiveConfig::default()
    };
    let mut e = Adaptive2::<T>::new(&f, &cfg).unwrap();
    let n = 2_000_000;
    let t0 = Instant::now();
    let mut acc = 0.0;
    for k in 0..n {
        let u = if (k / 714) % 2 == 0 { 0.1 } else { -0.1 };
        let y = 1e-3 * ((k as f64) * 0.01).sin();
        e.step(T::from_f64(u), T::from_f64(y));
        if k % 100_000 == 0 {
            acc += e.theta()[0].to_f64();
        }
    }
    println!(
        "{} K={k_every}: {:.1} ns/sample ({acc:.3})",
        T::NAME,
        t0.elapsed().as_nanos() as f64 / n as f64
    );
}
fn main() {
    fb_only();
    for k in [1, 10] {
        go::<f64>(k);
        go::<f32>(k);
    }
}
#[allow(dead_code)]
fn fb_only() {
    let f = FilterConfig {
        scales: SignalScales {
            u_scale: 0.1,
            y_scale: 1.2e-3,
        },
        ..Default::default()
    };
    let mut b = FilterBank::<f64, 4, 7>::new(&f).unwrap();
    let n = 2_000_000;
    let t0 = Instant::now();
    let mut acc = 0.0;
    for k in 0..n {
        let u = if (k / 714) % 2 == 0 { 0.1 } else { -0.1 };
        let y = 1e-3 * ((k as f64) * 0.01).sin();
        let r = b.push(u, y);
        acc += r.phi[3];
    }
    println!(
        "filter bank f64: {:.1} ns ({acc:.3})",
        t0.elapsed().as_nanos() as f64 / n as f64
    );
    let t0 = Instant::now();
    for k in 0..n {
        let y = 1e-3 * ((k as f64) * 0.01).sin();
        acc += y;
    }
    println!(
        "loop overhead (sin): {:.1} ns ({acc:.3})",
        t0.elapsed().as_nanos() as f64 / n as f64
    );
}
