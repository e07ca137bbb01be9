//! Host-side scenario helpers around the `beamest` core: simulated rigs,
//! measurement noise and convergence metrics used by the integration tests,
//! the benchmarks and `beamctl`.

pub mod naive;
pub mod runner;
pub mod scenario;

pub use runner::{run, EstimatorKind, Gains, Precision, RunConfig, RunError, RunReport, Trace};
pub use scenario::{PlantSpec, Truth};
