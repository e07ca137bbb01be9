//! Print the naive (paper-literal) law's error over time in f64 and f32.
use beamest::excitation::SquareWave;
use beamest::modal::modal_from_tf;
use beamest::Real;
use host_tests::naive::NaiveAdaptive;
use host_tests::scenario::PlantSpec;
fn go<T: Real>() {
    let truth = PlantSpec::Paper.truth();
    let mut plant = PlantSpec::Paper.plant(1e-4).unwrap();
    let mut sq = SquareWave::<f64>::paper();
    let mut est = NaiveAdaptive::<T>::paper(1e-4, 100.0);
    for k in 0..200_000 {
        let u = sq.next_sample();
        let y = plant.sample(u);
        est.step(T::from_f64(u), T::from_f64(y));
        if k % 10_000 == 9999 {
            let tf = est.transfer_function().unwrap();
            let w = [T::from_f64(-2.0), T::from_f64(2.0)];
            let e = match modal_from_tf(&tf, &w) {
                Ok(m) => {
                    let mut e: f64 = 0.0;
                    for i in 0..2 {
                        e = e
                            .max(
                                ((m.omega_rad_s[i].to_f64() - truth.modal.omega_rad_s[i])
                                    / truth.modal.omega_rad_s[i])
                                    .abs(),
                            )
                            .max(
                                ((m.zeta[i].to_f64() - truth.modal.zeta[i]) / truth.modal.zeta[i])
                                    .abs(),
                            );
                    }
                    e
                }
                Err(_) => f64::INFINITY,
            };
            print!("{:.0}s:{:.1e} ", (k + 1) as f64 * 1e-4, e);
        }
    }
    println!(" [{}]", T::NAME);
}
fn main() {
    go::<f64>();
    go::<f32>();
}
