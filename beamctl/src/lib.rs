//! The library half of `beamctl`: the simulation run loop and the simulated
//! beams that `beamctl simulate` (and the host tests, which depend on this
//! library) use.
//!
//! * [`runner`] — run one estimator against the simulated rig
//!   ([`beamest::rig::Rig`]) and measure it against the truth;
//! * [`scenario`] — which beam is simulated and its true parameters;
//! * [`link`] — the host end of the serial link (`beamctl monitor`,
//!   `beamctl send`) and a fake device that speaks the protocol.
//!
//! The command-line front end is `src/main.rs`.

// Same numerical-code conventions as the core (see the root src/lib.rs).
#![allow(clippy::needless_range_loop)]
#![allow(clippy::neg_cmp_op_on_partial_ord)]
#![warn(missing_docs)]

pub mod link;
pub mod runner;
pub mod scenario;

pub use runner::{run, EstimatorKind, Gains, Precision, RunConfig, RunError, RunReport, Trace};
pub use scenario::{PlantSpec, Truth, PAPER_BBAR};
