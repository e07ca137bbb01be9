//! Why a run (or a session, or an estimator build) could not start.

/// Why a run could not start.
#[derive(Debug, Clone, PartialEq)]
pub enum RunError {
    /// Invalid plant.
    Plant(String),
    /// Invalid estimator configuration.
    Estimator(String),
    /// Invalid excitation or timing.
    Setup(String),
    /// Stopped by its observer ([`crate::run::Observer::stopped`]).
    Interrupted,
}

impl std::fmt::Display for RunError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::Plant(s) => write!(f, "invalid plant: {s}"),
            Self::Estimator(s) => write!(f, "invalid estimator settings: {s}"),
            Self::Setup(s) => write!(f, "invalid run settings: {s}"),
            Self::Interrupted => f.write_str("interrupted"),
        }
    }
}

impl std::error::Error for RunError {}
