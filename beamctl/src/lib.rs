//! The library half of `beamctl`: the simulation run loop, the simulated
//! beams and the estimator driver that `beamctl simulate` and `beamctl
//! replay` (and the host tests, which depend on this library) share.
//!
//! * [`runner`] — run estimators against the simulated rig
//!   ([`beamest::rig::Rig`]) and measure them against the truth;
//! * [`scenario`] — which beam is simulated and its true parameters;
//! * [`tuned`] — an estimator under the truth-free tuning rule
//!   ([`beamest::tuning`]);
//! * [`session`] — several estimators fed the same samples and evaluated;
//! * [`gains`] — the laws and their gain sets (defaults, the paper's);
//! * [`fit`] — model output vs measured output (fit %);
//! * [`bound`] — the Cramér–Rao bound of an experiment, and error ÷ bound;
//! * [`seeds`] — one configuration over several noise seeds: RMS errors
//!   and RMS ÷ bound;
//! * [`events`] — the events of a simulated run (plant change, excitation
//!   pause, sensor fault, modes beyond the model) and what they did;
//! * [`drive`] — the input u of a simulated run: the paper's square wave or
//!   the firmware's generators (`--wave`);
//! * [`csvin`] — reading recorded samples for `beamctl replay`.
//! * [`link`] — the host end of the serial link (`beamctl monitor`,
//!   `beamctl send`) and a fake device that speaks the protocol.
//!
//! The command-line front end is `src/main.rs`.

// Same numerical-code conventions as the core (see the root src/lib.rs).
#![allow(clippy::needless_range_loop)]
#![allow(clippy::neg_cmp_op_on_partial_ord)]
#![warn(missing_docs)]

pub mod bound;
pub mod csvin;
pub mod drive;
pub mod events;
pub mod fit;
pub mod gains;
pub mod link;
pub mod runner;
pub mod scenario;
pub mod seeds;
pub mod session;
pub mod tuned;

pub use runner::{
    run, run_many, EstimatorKind, Gains, Observer, Precision, RunConfig, RunError, RunReport, Trace,
};
pub use scenario::{PlantSpec, Truth, PAPER_BBAR};
