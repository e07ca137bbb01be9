//! Scratch probe (not a figure source).
use beamest::estimator::{Adaptive2, AdaptiveConfig, Estimator};
use beamest::model::{PAPER_OMEGA, PAPER_ZETA};
use beamest::rig::{PlantStep, Scenario};
use beamest::Real;
use host_tests::scenario_run::*;

fn go<T: Real>(name: &str, scenario: Scenario, snr: Option<f64>, secs: f64) {
    let mut rig = paper_rig(scenario, snr, 1, None);
    let f = startup_filter(&rig);
    let mut est = Adaptive2::<T>::new(&f, &AdaptiveConfig::default()).unwrap();
    let tr = run(&mut est, &mut rig, (secs / TS_S) as u64, 10, &mut direct);
    let s = tr.sup.last().unwrap().unwrap();
    println!("{name} {} snr {snr:?}: changes {} last {:?} final err {:.2e} max err 5..: {:.2e} ratio {:?} reason {} steps {:?} ref_rms?",
        T::NAME, s.changes, s.last_change_sample, tr.err.last().unwrap(), tr.max_err(5.0, 1e9), s.lemma1_ratio, s.reason, tr.steps);
    if let Some(st) = scenario.step {
        let t0 = st.at as f64 * TS_S;
        println!("   step at {t0}: max err before {:.2e}, 1% after {:?}, 0.1% after {:?}, 1e-4 after {:?}", tr.max_err(2.0, t0), tr.settled_after(t0, 1e9, 1e-2).map(|t| t - t0), tr.settled_after(t0, 1e9, 1e-3).map(|t| t-t0), tr.settled_after(t0, 1e9, 1e-4).map(|t| t-t0));
    }
    // lemma1 ratio trace
    let mut line = String::new();
    for (i, s) in tr.sup.iter().enumerate() {
        if i % 500 == 0 {
            if let Some(s) = s {
                line += &format!("{:.1}:{:.1e} ", tr.t[i], s.lemma1_ratio.unwrap_or(f64::NAN));
            }
        }
    }
    println!("   ratio: {line}");
}

fn main() {
    if std::env::var("TRACE").is_ok() {
        trace_step();
        return;
    }
    let args: Vec<String> = std::env::args().collect();
    let secs: f64 = args.get(1).and_then(|s| s.parse().ok()).unwrap_or(20.0);
    for snr in [None, Some(40.0), Some(20.0)] {
        go::<f64>("steady", Scenario::default(), snr, secs);
        go::<f32>("steady", Scenario::default(), snr, secs);
    }
    let w = Scenario {
        step: Some(PlantStep {
            at: 100_000,
            omega_rad_s: [PAPER_OMEGA[0] * 1.1, PAPER_OMEGA[1], 0.0],
            zeta: [PAPER_ZETA[0], PAPER_ZETA[1], 0.0],
            bbar: None,
        }),
        ..Scenario::default()
    };
    let z = Scenario {
        step: Some(PlantStep {
            at: 100_000,
            omega_rad_s: [PAPER_OMEGA[0], PAPER_OMEGA[1], 0.0],
            zeta: [PAPER_ZETA[0] * 1.5, PAPER_ZETA[1], 0.0],
            bbar: None,
        }),
        ..Scenario::default()
    };
    for sc in [w, z] {
        for snr in [None, Some(40.0)] {
            go::<f64>("step", sc, snr, 20.0);
            go::<f32>("step", sc, snr, 20.0);
        }
    }
}
#[allow(dead_code)]
pub fn trace_step() {
    let w = Scenario {
        step: Some(PlantStep {
            at: 100_000,
            omega_rad_s: [PAPER_OMEGA[0] * 1.1, PAPER_OMEGA[1], 0.0],
            zeta: [PAPER_ZETA[0], PAPER_ZETA[1], 0.0],
            bbar: None,
        }),
        ..Scenario::default()
    };
    let mut rig = paper_rig(w, None, 1, None);
    let f = startup_filter(&rig);
    let mut est = Adaptive2::<f64>::new(&f, &AdaptiveConfig::default()).unwrap();
    let tr = run(&mut est, &mut rig, 140_000, 10, &mut direct);
    for i in (0..tr.t.len()).filter(|&i| tr.t[i] > 9.99 && (i % 20 == 0 || tr.t[i] < 10.03)) {
        println!(
            "{:.4} err {:.3e} est {:?} ch {}",
            tr.t[i],
            tr.err[i],
            tr.est[i],
            tr.sup[i].unwrap().changes
        );
    }
}
