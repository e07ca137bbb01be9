//! Scenario helpers for the tests: random plants for convergence sweeps
//! (the simulated beams themselves are `beamctl::run::plant`).

use beamest::model::ModalParams;
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// Random two-mode plants for convergence tests: ω1 ∈ [10, 200] rad/s,
/// ω2/ω1 ∈ [2, 10], ζ ∈ [0.005, 0.2], b̄ ∈ ±[1, 20], default output weights.
pub fn random_two_mode_plants(count: usize, seed: u64) -> Vec<ModalParams<f64>> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    (0..count)
        .map(|_| {
            let w1 = rng.random_range(10.0..200.0);
            let w2 = w1 * rng.random_range(2.0..10.0);
            let z1 = rng.random_range(0.005..0.2);
            let z2 = rng.random_range(0.005..0.2);
            let mut gain = || {
                let sign = if rng.random_bool(0.5) { 1.0 } else { -1.0 };
                sign * rng.random_range(1.0..20.0)
            };
            let (b1, b2) = (gain(), gain());
            ModalParams::new(&[w1, w2], &[z1, z2], &[b1, b2], None).expect("two modes")
        })
        .collect()
}
