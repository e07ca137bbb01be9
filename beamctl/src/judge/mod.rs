//! How an estimate is judged: against the measurement (model output fit,
//! [`fit`]), against the best any unbiased estimator can do (the
//! Cramér–Rao bound, [`bound`]), and the tables and JSON that report it
//! ([`report`]).

pub mod bound;
pub mod fit;
pub mod report;
