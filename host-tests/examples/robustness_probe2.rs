//! Scratch: false alarms and detection vs drift/threshold.
use beamest::estimator::{Adaptive2, AdaptiveConfig};
use beamest::model::{PAPER_OMEGA, PAPER_ZETA};
use beamest::rig::{PlantStep, Scenario};
use beamest::supervise::{SupervisorConfig, TrackingConfig};
use host_tests::scenario_run::*;

fn main() {
    let h: f64 = std::env::args()
        .nth(1)
        .and_then(|s| s.parse().ok())
        .unwrap_or(200.0);
    let cfg = AdaptiveConfig {
        supervision: SupervisorConfig {
            tracking: TrackingConfig {
                change_threshold: h,
            },
            ..SupervisorConfig::default()
        },
        ..AdaptiveConfig::default()
    };
    for snr in [40.0, 20.0, 60.0] {
        for seed in 1..=5 {
            let mut rig = paper_rig(Scenario::default(), Some(snr), seed, None);
            let f = startup_filter(&rig);
            let mut est = Adaptive2::<f32>::new(&f, &cfg).unwrap();
            let tr = run(&mut est, &mut rig, 600_000, 100, &mut direct);
            println!(
                "steady {snr} dB seed {seed}: changes {} peak {:.1}",
                tr.changes(),
                tr.change_peak()
            );
        }
    }
    let z = Scenario {
        step: Some(PlantStep {
            at: 100_000,
            omega_rad_s: [PAPER_OMEGA[0], PAPER_OMEGA[1], 0.0],
            zeta: [PAPER_ZETA[0] * 1.5, PAPER_ZETA[1], 0.0],
            bbar: None,
        }),
        ..Scenario::default()
    };
    let w = Scenario {
        step: Some(PlantStep {
            at: 100_000,
            omega_rad_s: [PAPER_OMEGA[0] * 1.1, PAPER_OMEGA[1], 0.0],
            zeta: [PAPER_ZETA[0], PAPER_ZETA[1], 0.0],
            bbar: None,
        }),
        ..Scenario::default()
    };
    let w1 = Scenario {
        step: Some(PlantStep {
            at: 100_000,
            omega_rad_s: [PAPER_OMEGA[0] * 1.01, PAPER_OMEGA[1], 0.0],
            zeta: [PAPER_ZETA[0], PAPER_ZETA[1], 0.0],
            bbar: None,
        }),
        ..Scenario::default()
    };
    for (name, sc) in [("zeta1 +50%", z), ("omega1 +10%", w), ("omega1 +1%", w1)] {
        for snr in [None, Some(60.0), Some(40.0), Some(20.0)] {
            let mut rig = paper_rig(sc, snr, 1, None);
            let f = startup_filter(&rig);
            let mut est = Adaptive2::<f64>::new(&f, &cfg).unwrap();
            let tr = run(&mut est, &mut rig, 150_000, 10, &mut direct);
            let s = tr.sup.last().unwrap().unwrap();
            println!(
                "{name} {snr:?}: changes {} detected after {:?} s",
                s.changes,
                s.last_change_sample.map(|k| (k as f64 - 100_000.0) * 1e-4)
            );
        }
    }
}
