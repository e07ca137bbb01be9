//! Print the memory footprint of every estimator configuration (bytes).
//! `cargo run --release -p host-tests --example footprint`
use beamest::estimator::*;
use std::mem::size_of;

fn main() {
    println!("| estimator | modes | f32 bytes | f64 bytes |");
    println!("|---|---|---|---|");
    macro_rules! row {
        ($name:literal, $modes:literal, $t32:ty, $t64:ty) => {
            println!(
                "| {} | {} | {} | {} |",
                $name,
                $modes,
                size_of::<$t32>(),
                size_of::<$t64>()
            );
        };
    }
    row!("adaptive", 1, Adaptive1<f32>, Adaptive1<f64>);
    row!("adaptive", 2, Adaptive2<f32>, Adaptive2<f64>);
    row!("adaptive", 3, Adaptive3<f32>, Adaptive3<f64>);
    row!(
        "feedthrough (2 modes + D)",
        2,
        Feedthrough2<f32>,
        Feedthrough2<f64>
    );
    row!("gradient", 1, GradientEstimator<f32, 2, 3>, GradientEstimator<f64, 2, 3>);
    row!("gradient", 2, GradientEstimator<f32, 4, 7>, GradientEstimator<f64, 4, 7>);
    row!("gradient", 3, GradientEstimator<f32, 6, 11>, GradientEstimator<f64, 6, 11>);
    row!("ls", 1, LeastSquaresEstimator<f32, 2, 3>, LeastSquaresEstimator<f64, 2, 3>);
    row!("ls", 2, LeastSquaresEstimator<f32, 4, 7>, LeastSquaresEstimator<f64, 4, 7>);
    row!("ls", 3, LeastSquaresEstimator<f32, 6, 11>, LeastSquaresEstimator<f64, 6, 11>);
    use beamest::estimator::robust::{CompactRecord, Head, Pending, Robust2, Robust2Compact};
    row!("robust, 2 s record", 2, Robust2<f32>, Robust2<f64>);
    row!(
        "robust, 2 s compact record (the QEMU image's)",
        2,
        Robust2Compact<f32>,
        Robust2Compact<f64>
    );
    row!(
        "- of which the compact record",
        2,
        CompactRecord<f32>,
        CompactRecord<f64>
    );
    row!(
        "robust without record (a head, `Head`)",
        2,
        Head<f32, 4, 7, 28>,
        Head<f64, 4, 7, 28>
    );
    row!(
        "a robust model update in progress (`Pending`)",
        2,
        Pending<f32, 4, 7, 28>,
        Pending<f64, 4, 7, 28>
    );
}
