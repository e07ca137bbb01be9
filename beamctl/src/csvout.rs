//! `--csv`: the telemetry-rate time series of a simulation.
//!
//! One row per [`Trace`] (every `eval_every` = 10 samples, i.e. 1 kHz at
//! Ts = 0.1 ms): `t_s, u, y, theta_0..theta_{NP−1}, omega_1..omega_N,
//! zeta_1..zeta_N`, preceded by an `estimator` column when several
//! estimators share the file. Θ is in physical units (eq. 29); ω in rad/s.
//! An estimate whose modal recovery failed leaves its ω/ζ fields empty.

use crate::error::CliError;
use beamctl::Trace;
use std::fs::File;
use std::io::BufWriter;
use std::path::{Path, PathBuf};

/// A CSV file being written.
pub struct CsvOut {
    writer: csv::Writer<BufWriter<File>>,
    path: PathBuf,
    modes: usize,
    with_estimator: bool,
    rows: u64,
    /// The first write error; later rows are dropped.
    failed: Option<csv::Error>,
    record: Vec<String>,
}

/// The header for `modes` modes.
pub fn header(modes: usize, with_estimator: bool) -> Vec<String> {
    let np = 4 * modes - 1;
    let mut h = Vec::with_capacity(4 + np + 2 * modes);
    if with_estimator {
        h.push("estimator".to_string());
    }
    h.extend(["t_s", "u", "y"].map(String::from));
    h.extend((0..np).map(|i| format!("theta_{i}")));
    h.extend((1..=modes).map(|i| format!("omega_{i}")));
    h.extend((1..=modes).map(|i| format!("zeta_{i}")));
    h
}

impl CsvOut {
    /// Create (truncate) the file and write the header. Errors name `--csv`.
    pub fn create(path: &Path, modes: usize, with_estimator: bool) -> Result<Self, CliError> {
        let file = File::create(path).map_err(|e| {
            CliError::usage("--csv", format!("cannot create {}: {e}", path.display()))
        })?;
        let mut writer = csv::Writer::from_writer(BufWriter::new(file));
        writer
            .write_record(header(modes, with_estimator))
            .map_err(|e| write_error(path, &e))?;
        Ok(Self {
            writer,
            path: path.to_path_buf(),
            modes,
            with_estimator,
            rows: 0,
            failed: None,
            record: Vec::new(),
        })
    }

    /// Append one trace (errors are kept for [`finish`](Self::finish)).
    pub fn push(&mut self, estimator: &str, t: &Trace<'_>) {
        if self.failed.is_some() {
            return;
        }
        let n = self.modes;
        self.record.clear();
        if self.with_estimator {
            self.record.push(estimator.to_string());
        }
        // t = k·Ts carries rounding noise (0.0009000000000000001).
        self.record.push(num((t.t_s * 1e9).round() / 1e9));
        self.record.push(num(t.u));
        self.record.push(num(t.y));
        self.record.extend(t.theta.iter().map(|v| num(*v)));
        match t.modal {
            Some(m) if m.modes == n => {
                self.record
                    .extend(m.omega_rad_s[..n].iter().map(|v| num(*v)));
                self.record.extend(m.zeta[..n].iter().map(|v| num(*v)));
            }
            _ => self
                .record
                .extend(std::iter::repeat_n(String::new(), 2 * n)),
        }
        match self.writer.write_record(&self.record) {
            Ok(()) => self.rows += 1,
            Err(e) => self.failed = Some(e),
        }
    }

    /// Flush; report the first write error, if any. Returns the row count.
    pub fn finish(mut self) -> Result<u64, CliError> {
        if let Some(e) = self.failed.take() {
            return Err(write_error(&self.path, &e));
        }
        self.writer.flush().map_err(|e| {
            CliError::failure(format!("--csv: writing {}: {e}", self.path.display()))
        })?;
        Ok(self.rows)
    }
}

fn write_error(path: &Path, e: &csv::Error) -> CliError {
    CliError::failure(format!("--csv: writing {}: {e}", path.display()))
}

/// Shortest round-trip representation (scientific outside [1e-4, 1e9));
/// empty for NaN/inf.
fn num(v: f64) -> String {
    if !v.is_finite() {
        String::new()
    } else if v == 0.0 || (1e-4..1e9).contains(&v.abs()) {
        format!("{v}")
    } else {
        format!("{v:e}")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn header_for_two_modes() {
        let h = header(2, false).join(",");
        assert_eq!(
            h,
            "t_s,u,y,theta_0,theta_1,theta_2,theta_3,theta_4,theta_5,theta_6,omega_1,omega_2,zeta_1,zeta_2"
        );
        assert_eq!(header(1, true)[0], "estimator");
        assert_eq!(header(3, false).len(), 3 + 11 + 6);
        assert_eq!(num(4.978767555286603e-7), "4.978767555286603e-7");
        assert_eq!(num(0.0009), "0.0009");
        assert_eq!(num(-1.11e6), "-1110000");
        assert_eq!(num(f64::NAN), "");
    }
}
