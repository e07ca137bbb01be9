//! Modes beyond the model (issue 9): the two-mode estimator with a
//! feedthrough term against the plain two-mode and the three-mode law.
//!
//! cargo run --release -p host-tests --example extra_modes
use beamest::estimator::{Adaptive2, AdaptiveConfig, Estimator, Feedthrough2};
use beamest::model::{PAPER_OMEGA, PAPER_ZETA};
use beamest::rig::Scenario;
use beamest::Real;
use host_tests::scenario_run::*;

fn run<T: Real>(truth_modes: usize, lambda: f64) {
    let extra = (truth_modes > 2).then(|| paper_extra_modes(truth_modes));
    let rig = paper_rig(Scenario::default(), None, 1, extra.as_ref());
    let mut f = startup_filter(&rig);
    f.lambda_rad_s = lambda;
    let mut r2 = rig.clone();
    let mut e2 = Adaptive2::<T>::new(&f, &AdaptiveConfig::default()).expect("valid");
    let mut rf = rig;
    let mut ef = Feedthrough2::<T>::with_default_gains(&f).expect("valid");
    for _ in 0..200_000 {
        let s = r2.tick();
        e2.step(T::from_f64(s.u), T::from_f64(s.y));
        let s = rf.tick();
        ef.step(T::from_f64(s.u), T::from_f64(s.y));
    }
    let cells = |tf| {
        modal_errors(&tf, &WEIGHTS, &PAPER_OMEGA, &PAPER_ZETA)
            .map_or("not recovered".into(), |(w, z)| {
                format!("{:.1e} / {:.1e} | {:.1e} / {:.1e}", w[0], w[1], z[0], z[1])
            })
    };
    let r = ef.residual();
    println!(
        "| {truth_modes} | {} | {lambda} | {} | {} | D = {:.3e}, b3 = {:.3e} |",
        T::NAME,
        cells(e2.transfer_function()),
        cells(ef.transfer_function()),
        r.feedthrough.to_f64(),
        r.b3.to_f64()
    );
}

fn main() {
    println!("| truth modes | type | λ | 2-mode law ω1 / ω2 | ζ1 / ζ2 | feedthrough ω1 / ω2 | ζ1 / ζ2 | residual |");
    println!("|---|---|---|---|---|---|---|---|");
    for n in [2usize, 3, 4] {
        for lam in [50.0, 70.0, 100.0] {
            run::<f64>(n, lam);
            run::<f32>(n, lam);
        }
    }
}
