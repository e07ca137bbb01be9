//! The command-line front ends: one module per subcommand (its checks of
//! the flags, its run and its output), the flags several of them share
//! validated into the library's types, and the one-line error reporting.
//!
//! * [`args`] — the options of `simulate`, `replay`, `crlb`;
//! * [`simulate`] (its flags validated in [`simulate::plan`], `--seeds` in
//!   [`simulate::seeds`]), [`replay`],
//!   [`crlb`], [`model`], [`monitor`], [`send`], [`selftest`] — the
//!   subcommands;
//! * [`estimator_flags`], [`plant_flags`], [`event_flags`] — the estimator,
//!   plant and event/guard flags, validated;
//! * [`progress`] — the progress bar of long runs. (The one-line errors
//!   and exit codes: [`crate::error`].)

pub mod args;
pub mod crlb;
pub mod estimator_flags;
pub mod event_flags;
pub mod model;
pub mod monitor;
pub mod plant_flags;
pub mod progress;
pub mod replay;
pub mod selftest;
pub mod send;
pub mod simulate;
