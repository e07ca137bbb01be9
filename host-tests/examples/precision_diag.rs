//! Diagnostic behind docs/NUMERICS.md (row 5–6): on random plant #3 (a weak
//! high mode, cond(P) ~ 1e8) compare the `f32` adaptive law fed with
//! (a) the `f64` regressor split into double words and (b) its own `f32`
//! filter bank, against the `f64` law.
//! `cargo run --release -p host-tests --example precision_diag`
use beamctl::run::plant::*;
use beamctl::run::*;
use beamest::estimator::*;
use beamest::excitation::SquareWave;
use beamest::filter_bank::*;
use host_tests::scenario::*;
fn main() {
    let m = random_two_mode_plants(5, 2026)[3];
    let cfg = RunConfig {
        plant: PlantSpec::Modal(m),
        ..Default::default()
    };
    let f = tuned_filter(&RunConfig {
        duration_s: 5.0,
        ..cfg.clone()
    })
    .unwrap();
    let mut plant = cfg.plant.plant(1e-4).unwrap();
    let mut sq = SquareWave::<f64>::paper();
    let mut fb64 = FilterBank::<f64, 4, 7>::new(&f).unwrap();
    let mut fb32 = FilterBank::<f32, 4, 7>::new(&f).unwrap();
    let acfg = AdaptiveConfig::default();
    let mut law_a = AdaptiveLaw::<f32, 7, 28>::new(&acfg, 1e-4).unwrap(); // f64 φ → f32 law
    let mut law_b = AdaptiveLaw::<f32, 7, 28>::new(&acfg, 1e-4).unwrap(); // f32 φ → f32 law
    let mut law_c = AdaptiveLaw::<f64, 7, 28>::new(&acfg, 1e-4).unwrap(); // f64
    let mut maxdphi: f64 = 0.0;
    for k in 0..200_000 {
        let u = sq.next_sample();
        let y = plant.sample(u);
        let r64 = fb64.push(u, y);
        let r32 = fb32.push(u as f32, y as f32);
        for i in 0..7 {
            maxdphi = maxdphi.max((r32.phi[i] as f64 - r64.phi[i]).abs());
        }
        let hi = r64.phi.map(|v| v as f32);
        let mut lo = [0f32; 7];
        for i in 0..7 {
            lo[i] = (r64.phi[i] - hi[i] as f64) as f32;
        }
        let r64_32 = Regressor {
            phi: hi,
            phi_lo: lo,
            y: r64.y as f32,
        };
        law_a.update(&r64_32).unwrap();
        law_b.update(&r32).unwrap();
        law_c.update(&r64).unwrap();
        if k % 40000 == 39999 {
            let c = law_c.theta_scaled();
            let da: f64 = law_a
                .theta_scaled()
                .iter()
                .zip(c.iter())
                .map(|(a, b)| (*a as f64 - b).abs())
                .fold(0.0, f64::max);
            let db: f64 = law_b
                .theta_scaled()
                .iter()
                .zip(c.iter())
                .map(|(a, b)| (*a as f64 - b).abs())
                .fold(0.0, f64::max);
            println!(
                "t={:.0} max|dθ| f64φ→f32law {:.1e}  f32φ→f32law {:.1e}  max|dφ| {:.1e}",
                (k + 1) as f64 * 1e-4,
                da,
                db,
                maxdphi
            );
        }
    }
}
