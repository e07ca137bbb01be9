//! Scratch: excitation off.
use beamest::estimator::{Adaptive2, AdaptiveConfig, Estimator, Robust2, RobustConfig};
use beamest::rig::{ExcitationOff, Scenario, Window};
use beamest::supervise::SupervisorConfig;
use beamest::Real;
use host_tests::scenario_run::*;

fn report<T: Real>(name: &str, tr: &RunTrace) {
    let i0 = tr.t.iter().position(|&t| t >= 9.99).unwrap();
    let before = tr.est[i0];
    let dev =
        tr.t.iter()
            .zip(&tr.est)
            .filter(|(t, _)| **t >= 10.0 && **t < 70.0)
            .map(|(_, e)| max_rel_error(e, &before))
            .fold(0.0, f64::max);
    let reasons: Vec<_> = tr
        .sup
        .iter()
        .zip(&tr.t)
        .filter(|(_, t)| {
            [5.0, 10.05, 20.0, 69.9, 70.05, 71.0]
                .iter()
                .any(|x| (*t - x).abs() < 5e-4)
        })
        .map(|(s, t)| format!("{t:.2}:{}", s.map(|s| s.reason.as_str()).unwrap_or("-")))
        .collect();
    println!("{name} {}: err before {:.2e}, max err off {:.2e}, max dev from pre-off {:.2e}, after resume 1% {:?} 0.1% {:?}, max|θ| {:.3e}, steps {:?}, {:?}", T::NAME,
        tr.max_err(5.0, 10.0), tr.max_err(10.0, 70.0), dev, tr.settled_after(70.0, 1e9, 1e-2).map(|t| t - 70.0), tr.settled_after(70.0, 1e9, 1e-3).map(|t| t - 70.0), tr.largest_theta, tr.steps, reasons);
}

fn main() {
    for level in [0.0, 1e-3] {
        let sc = Scenario {
            excitation_off: Some(ExcitationOff {
                window: Window::new(100_000, Some(700_000)),
                level,
            }),
            ..Scenario::default()
        };
        for snr in [None, Some(40.0)] {
            for sup in [true, false] {
                let cfg = if sup {
                    AdaptiveConfig::default()
                } else {
                    AdaptiveConfig {
                        supervision: SupervisorConfig::OFF,
                        ..AdaptiveConfig::default()
                    }
                };
                let mut rig = paper_rig(sc, snr, 1, None);
                let f = startup_filter(&rig);
                let mut est = Adaptive2::<f64>::new(&f, &cfg).unwrap();
                let tr = run(&mut est, &mut rig, 750_000, 100, &mut direct);
                report::<f64>(
                    &format!("adaptive level {level} snr {snr:?} sup {sup}"),
                    &tr,
                );
                if sup {
                    let mut rig = paper_rig(sc, snr, 1, None);
                    let mut est = Adaptive2::<f32>::new(&f, &cfg).unwrap();
                    let tr = run(&mut est, &mut rig, 750_000, 100, &mut direct);
                    report::<f32>(
                        &format!("adaptive level {level} snr {snr:?} sup {sup}"),
                        &tr,
                    );
                }
            }
            let mut rig = paper_rig(sc, snr, 1, None);
            let f = startup_filter(&rig);
            let mut est = Box::new(Robust2::<f64>::new(&f, &RobustConfig::default()).unwrap());
            let tr = run(&mut *est, &mut rig, 750_000, 100, &mut direct);
            report::<f64>(&format!("robust level {level} snr {snr:?}"), &tr);
        }
    }
}
