//! Host-side tests around the `beamest` core: the paper-literal reference
//! law ([`naive`]), integration tests, examples and criterion benchmarks.
//!
//! The run loop and the simulated beams live in the `beamctl` library
//! (`beamctl::run`, `beamctl::run::plant`), so the CLI does not depend on
//! this crate; the tests use them from there.

// Same numerical-code conventions as the core (see src/lib.rs).
#![allow(clippy::needless_range_loop)]
#![allow(clippy::neg_cmp_op_on_partial_ord)]

pub mod excitation_cost;
pub mod naive;
pub mod noise_study;
pub mod scenario;
pub mod scenario_run;
pub mod sim_rig;
