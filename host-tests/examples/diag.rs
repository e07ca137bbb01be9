use beamest::estimator::*;
use beamest::excitation::SquareWave;
use beamest::modal::modal_from_tf;
use beamest::model::TransferFunction;
use host_tests::runner::*;
use host_tests::scenario::*;
fn main() {
    let m = random_two_mode_plants(5, 2026)[3];
    let cfg = RunConfig {
        plant: PlantSpec::Modal(m),
        ..Default::default()
    };
    let truth = cfg.plant.truth();
    let f = filter_config(&cfg, &truth);
    let mut plant = cfg.plant.plant(1e-4).unwrap();
    let mut sq = SquareWave::<f64>::paper();
    let mut e32 = Adaptive2::<f32>::new(&f, &AdaptiveConfig::default()).unwrap();
    let mut e64 = Adaptive2::<f64>::new(&f, &AdaptiveConfig::default()).unwrap();
    let w = [-2.0, 2.0];
    for k in 0..200_000 {
        let u = sq.next_sample();
        let y = plant.sample(u);
        e32.step(u as f32, y as f32);
        e64.step(u as f32 as f64, y as f32 as f64);
        if k % 20000 == 19999 {
            let th32: Vec<f64> = e32.law().theta_scaled().iter().map(|&v| v as f64).collect();
            let th64 = e64.law().theta_scaled();
            let dth: Vec<String> = th32
                .iter()
                .zip(th64.iter())
                .map(|(a, b)| format!("{:.1e}", (a - b).abs()))
                .collect();
            let t32 = e32.transfer_function();
            let tf = TransferFunction {
                modes: 2,
                a: t32.a.map(|v| v as f64),
                b: t32.b.map(|v| v as f64),
            };
            let m_f64rec = modal_from_tf(&tf, &w).unwrap();
            let m_f32rec = modal_from_tf(&t32, &[-2.0f32, 2.0]).unwrap();
            let m64 = modal_from_tf(&e64.transfer_function(), &w).unwrap();
            println!(
                "t={:.0} dθs {:?} ω2 rel: f32θ+f64rec {:.1e} f32θ+f32rec {:.1e} f64 {:.1e}",
                (k + 1) as f64 * 1e-4,
                dth,
                (m_f64rec.omega_rad_s[1] / m.omega_rad_s[1] - 1.0).abs(),
                (m_f32rec.omega_rad_s[1] as f64 / m.omega_rad_s[1] - 1.0).abs(),
                (m64.omega_rad_s[1] / m.omega_rad_s[1] - 1.0).abs()
            );
        }
    }
    println!("theta64 {:?}", e64.law().theta_scaled());
}
