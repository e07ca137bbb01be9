//! `--csv`: every sample of a run, replayable, with the estimates at the
//! evaluation rate.
//!
//! One row per sample: `t_s, u, y` (exactly the values the estimators
//! received, shortest round-trip decimal, so `beamctl replay` reads back
//! the same f64), `guard` (what the sensor guard flagged in this sample,
//! or for `replay`, whose rows are the evaluations, since the last row:
//! `non_finite`, `saturated`, `stuck`, `open`, `offset`, `drift`, or
//! empty), then per estimator `theta_0..theta_{NP−1}` (Θ of eq. 29,
//! physical units), `omega_1..omega_N` (rad/s), `zeta_1..zeta_N`,
//! `lambda_rad_s`, `excited` (1/0, the supervisor's flag),
//! `excitation_reason`, `changes` (detected so far), `validity` (the
//! physical-validity bits of the estimate, 0 = valid; see
//! `beamest::modal::validity`) — prefixed `<name>_` when several
//! estimators share the file. The estimate fields are filled on evaluation rows (every
//! `eval_every` = 10 samples, 1 kHz) and empty elsewhere, and empty where
//! there is no estimate (start-up window, failed recovery).

use crate::error::CliError;
use crate::run::Trace;
use std::fmt::Write as _;
use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

/// The per-estimator columns after `lambda_rad_s`.
pub const SUPERVISION_COLUMNS: [&str; 4] = ["excited", "excitation_reason", "changes", "validity"];

/// A CSV file being written.
pub struct CsvOut {
    writer: BufWriter<File>,
    path: PathBuf,
    modes: usize,
    estimators: usize,
    rows: u64,
    /// The first write error; later rows are dropped.
    failed: Option<std::io::Error>,
    /// The estimate cells of the current row, per estimator (empty = none).
    pending: Vec<String>,
    line: String,
    /// The estimate cells of one estimator without an estimate.
    empty: String,
    /// The guard's flag of the current row.
    guard: &'static str,
}

/// The header for `modes` modes and the estimators `names`.
pub fn header(modes: usize, names: &[&str]) -> Vec<String> {
    let np = 4 * modes - 1;
    let mut h: Vec<String> = ["t_s", "u", "y", "guard"].map(String::from).to_vec();
    for name in names {
        let prefix = if names.len() > 1 {
            format!("{name}_")
        } else {
            String::new()
        };
        h.extend((0..np).map(|i| format!("{prefix}theta_{i}")));
        h.extend((1..=modes).map(|i| format!("{prefix}omega_{i}")));
        h.extend((1..=modes).map(|i| format!("{prefix}zeta_{i}")));
        h.push(format!("{prefix}lambda_rad_s"));
        for c in SUPERVISION_COLUMNS {
            h.push(format!("{prefix}{c}"));
        }
    }
    h
}

impl CsvOut {
    /// Create (truncate) the file and write the header. Errors name `--csv`.
    pub fn create(path: &Path, modes: usize, names: &[&str]) -> Result<Self, CliError> {
        let file = File::create(path).map_err(|e| {
            CliError::usage("--csv", format!("cannot create {}: {e}", path.display()))
        })?;
        let mut writer = BufWriter::with_capacity(1 << 20, file);
        writeln!(writer, "{}", header(modes, names).join(","))
            .map_err(|e| write_error(path, &e))?;
        Ok(Self {
            writer,
            path: path.to_path_buf(),
            modes,
            estimators: names.len(),
            rows: 0,
            failed: None,
            pending: vec![String::new(); names.len()],
            line: String::with_capacity(256),
            empty: ",".repeat(4 * modes - 1 + 2 * modes + 1 + SUPERVISION_COLUMNS.len()),
            guard: "",
        })
    }

    /// What the sensor guard flagged in a sample since the last row (a
    /// flag is kept until the row is written: replay writes one row per
    /// evaluation).
    pub fn screening(&mut self, s: &beamest::guard::Screening) {
        let flag = match (s.fault, s.level) {
            (Some(f), _) => crate::run::session::fault_name(f),
            (None, Some(l)) => crate::run::session::level_name(l),
            (None, None) => return,
        };
        self.guard = flag;
    }

    /// The estimate of estimator `index` for the current row.
    pub fn estimate(&mut self, index: usize, t: &Trace<'_>) {
        let n = self.modes;
        let Some(cell) = self.pending.get_mut(index) else {
            return;
        };
        cell.clear();
        for v in t.theta {
            cell.push(',');
            num(cell, *v);
        }
        match t.modal {
            Some(m) if m.modes == n => {
                for v in m.omega_rad_s[..n].iter().chain(&m.zeta[..n]) {
                    cell.push(',');
                    num(cell, *v);
                }
            }
            _ => cell.push_str(&",".repeat(2 * n)),
        }
        cell.push(',');
        num(cell, t.lambda_rad_s.unwrap_or(f64::NAN));
        match &t.supervision {
            Some(s) => {
                let _ = write!(
                    cell,
                    ",{},{},{}",
                    u8::from(s.excited),
                    s.excitation_reason,
                    s.changes_detected
                );
            }
            None => cell.push_str(",,,"),
        }
        let _ = write!(cell, ",{}", t.validity);
    }

    /// Write the row of one sample (with the estimates given since the
    /// last row).
    pub fn row(&mut self, t_s: f64, u: f64, y: f64) {
        if self.failed.is_some() {
            return;
        }
        self.line.clear();
        // t = k·Ts carries rounding noise (0.0009000000000000001).
        num(&mut self.line, (t_s * 1e9).round() / 1e9);
        self.line.push(',');
        num(&mut self.line, u);
        self.line.push(',');
        num(&mut self.line, y);
        self.line.push(',');
        self.line.push_str(self.guard);
        self.guard = "";
        for cell in self.pending.iter_mut().take(self.estimators) {
            if cell.is_empty() {
                self.line.push_str(&self.empty);
            } else {
                self.line.push_str(cell);
                cell.clear();
            }
        }
        self.line.push('\n');
        match self.writer.write_all(self.line.as_bytes()) {
            Ok(()) => self.rows += 1,
            Err(e) => self.failed = Some(e),
        }
    }

    /// Flush; report the first write error, if any. Returns the row count.
    pub fn finish(mut self) -> Result<u64, CliError> {
        if let Some(e) = self.failed.take() {
            return Err(write_error(&self.path, &e));
        }
        self.writer
            .flush()
            .map_err(|e| write_error(&self.path, &e))?;
        Ok(self.rows)
    }
}

fn write_error(path: &Path, e: &std::io::Error) -> CliError {
    CliError::failure(format!("--csv: writing {}: {e}", path.display()))
}

/// Append the shortest round-trip representation (scientific outside
/// [1e-4, 1e9)); nothing for NaN/inf.
pub fn num(out: &mut String, v: f64) {
    if !v.is_finite() {
        return;
    }
    let _ = if v == 0.0 || (1e-4..1e9).contains(&v.abs()) {
        write!(out, "{v}")
    } else {
        write!(out, "{v:e}")
    };
}

#[cfg(test)]
mod tests {
    use super::*;

    fn s(v: f64) -> String {
        let mut o = String::new();
        num(&mut o, v);
        o
    }

    #[test]
    fn header_for_two_modes() {
        let h = header(2, &["adaptive"]).join(",");
        assert_eq!(
            h,
            "t_s,u,y,guard,theta_0,theta_1,theta_2,theta_3,theta_4,theta_5,theta_6,omega_1,omega_2,zeta_1,zeta_2,lambda_rad_s,excited,excitation_reason,changes,validity"
        );
        let all = header(1, &["adaptive", "gradient", "ls"]);
        assert_eq!(all[4], "adaptive_theta_0");
        assert_eq!(all.len(), 4 + 3 * (3 + 2 + 1 + 4));
        assert_eq!(header(3, &["ls"]).len(), 4 + 11 + 6 + 1 + 4);
        assert_eq!(s(4.978767555286603e-7), "4.978767555286603e-7");
        assert_eq!(s(0.0009), "0.0009");
        assert_eq!(s(-1.11e6), "-1110000");
        assert_eq!(s(f64::NAN), "");
        // Shortest round trip: parsing gives the same f64 back.
        for v in [0.1, -1.2345678901234567e-5, 1.0 / 3.0, 1e300] {
            assert_eq!(s(v).parse::<f64>().unwrap(), v);
        }
    }
}
