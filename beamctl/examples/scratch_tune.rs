use beamctl::runner::*;
use beamctl::scenario::PlantSpec;
use beamest::model::ModalParams;
use beamest::tuning::LambdaSource;
fn main() {
    let args: Vec<String> = std::env::args().collect();
    let snr: Option<f64> = args.get(1).and_then(|s| s.parse().ok());
    let factor: f64 = args.get(2).and_then(|s| s.parse().ok()).unwrap_or(2.0);
    let dur: f64 = args.get(3).and_then(|s| s.parse().ok()).unwrap_or(20.0);
    let prec = if args.get(4).map(|s| s == "f32").unwrap_or(false) { Precision::F32 } else { Precision::F64 };
    let plants: Vec<(Vec<f64>, Vec<f64>)> = vec![
        (vec![39.1533, 245.3711], vec![0.0207, 0.13]),
        (vec![52.7, 318.0], vec![0.0207, 0.13]),
        (vec![154.7, 1520.5], vec![0.087, 0.197]),
        (vec![27.0, 102.3], vec![0.166, 0.181]),
        (vec![10.0, 100.0], vec![0.02, 0.05]),
        (vec![200.0, 2000.0], vec![0.02, 0.05]),
        (vec![123.9, 499.7], vec![0.013, 0.041]),
        (vec![39.1533], vec![0.0207]),
        (vec![39.1533, 245.3711, 687.4], vec![0.0207, 0.13, 0.05]),
    ];
    for (w, z) in plants {
        let n = w.len();
        let b = [9.6, 16.1, 20.0];
        let m = ModalParams::new(&w, &z, &b[..n], None).unwrap();
        let gm = (w[0] * w[n - 1]).sqrt();
        for (label, lam) in [("data", LambdaSource::Data), ("truthλ", LambdaSource::Fixed(gm))] {
            let cfg = RunConfig { plant: PlantSpec::Modal(m), snr_db: snr, duration_s: dur, precision: prec, lambda: lam, ..RunConfig::default() };
            let mut tc = cfg.tuning();
            tc.data_lambda_factor = factor;
            let r = run(&cfg, &mut |_| {}).unwrap();
            let lams: Vec<String> = r.builds.iter().map(|b| format!("{:.0}@{:.2}", b.lambda_rad_s, b.sample as f64 * 1e-4)).collect();
            println!("{:?} {label:7} gm={gm:.0} λ=[{}] {} err={:.1e} t01={:?} fit={:.4} drift={:.1e}", w, lams.join(" "), r.tuning, r.rel_error.max(), r.time_to_0p1pct_s, r.fit_percent.unwrap_or(f64::NAN), r.drift_last_10pct.unwrap_or(f64::NAN));
        }
    }
}
