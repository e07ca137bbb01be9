//! `beamctl`, the host side of the beam estimator: everything but the
//! argument parsing and dispatch of `src/main.rs`. The host tests depend on
//! this library.
//!
//! * [`run`] — the run machinery: one estimator session fed sample by
//!   sample ([`run::session`]), the truth-free tuning rule around each
//!   estimator ([`run::tuned`]), the simulated rig and its events, and the
//!   run loop that measures the estimates against the truth
//!   (`beamctl simulate`, the host tests and the examples) — `beamctl
//!   replay` feeds the same session from a file;
//! * [`judge`] — how an estimate is judged: model output fit, the
//!   Cramér–Rao bound, and the report tables;
//! * [`io`] — files: recorded samples in (CSV), time series out (CSV),
//!   text tables, plots;
//! * [`link`] — the host end of the serial link and a fake device that
//!   speaks the protocol;
//! * [`cli`] — the command-line front ends: one module per subcommand
//!   and the option types they share;
//! * [`error`] — one-line errors and exit codes, shared by all of them.

// Same numerical-code conventions as the core (see the root src/lib.rs).
#![allow(clippy::needless_range_loop)]
#![allow(clippy::neg_cmp_op_on_partial_ord)]
#![warn(missing_docs)]

pub mod cli;
pub mod error;
pub mod io;
pub mod judge;
pub mod link;
pub mod run;
