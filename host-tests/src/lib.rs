//! Host-side scenario helpers around the `beamest` core: simulated rigs,
//! measurement noise and convergence metrics used by the integration tests,
//! the benchmarks and `beamctl`.

// Same numerical-code conventions as the core (see src/lib.rs).
#![allow(clippy::needless_range_loop)]
#![allow(clippy::neg_cmp_op_on_partial_ord)]

pub mod naive;
pub mod noise_study;
pub mod runner;
pub mod scenario;

pub use runner::{run, EstimatorKind, Gains, Precision, RunConfig, RunError, RunReport, Trace};
pub use scenario::{PlantSpec, Truth};
