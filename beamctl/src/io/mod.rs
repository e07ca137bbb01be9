//! Files and text: recorded samples in ([`csv_in`], `beamctl replay`), the
//! time series of a run out ([`csv_out`], `--csv`), the report of a run's
//! estimates as tables and JSON ([`report`]), aligned text tables
//! ([`table`]) and PNG plots ([`plot`]). (The monitor's recordings are
//! written by [`crate::link::record`].)

pub mod csv_in;
pub mod csv_out;
pub mod plot;
pub mod report;
pub mod table;
