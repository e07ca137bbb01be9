//! How an estimate is judged: against the measurement (model output fit,
//! [`fit`]) and against the best any unbiased estimator can do (the
//! Cramér–Rao bound, [`bound`]), and the measured frequency response
//! ([`frf`]), and which of several candidate models a record supports
//! best ([`select`]), which lines of a residual to remove
//! ([`lines`]), the AR noise model that prewhitens a record ([`noise`]),
//! how much an estimate still moves ([`drift`]) and whether it can be
//! trusted ([`verdict`]). The tables and JSON that report it are
//! [`crate::io::report`].

pub mod bound;
pub mod drift;
pub mod fit;
pub mod frf;
pub mod lines;
pub mod noise;
pub mod select;
pub mod verdict;
