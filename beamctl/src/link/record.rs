//! `--record FILE.csv`: every frame the monitor receives, every command it
//! sends and every frame it could not decode, one row each, in one CSV
//! file; and the raw samples in a second file, `FILE.raw.csv`, in the form
//! `beamctl replay` reads (header `t,u,y`). `docs/RECORDING.md` documents
//! both formats column by column.
//!
//! # Never losing what was recorded
//! Both files are flushed at least every [`FLUSH_EVERY`] and when the
//! recorder finishes, whatever ended the run (duration, the user, a device
//! that disappeared, a protocol version mismatch): at most the last
//! [`FLUSH_EVERY`] of data is lost if the process is killed.
//!
//! # Raw samples
//! A raw sample's time is t = sample_index / f_s, with f_s the device's
//! sample rate from its Status (`docs/PROTOCOL.md` §4.2–4.3). Samples that
//! arrive before the first Status wait in memory (at most
//! [`RAW_WAIT_LIMIT`] of them); if the run ends, or the limit is reached,
//! with the sample rate still unknown, the raw file is written with the
//! header `sample_index,u,y` instead, and [`RecordStats::raw_without_rate`]
//! says so. u and y are written as the exact decimal value of the f32 the
//! device sent, so a replay reads back the same bits.

use super::host::Host;
use super::{grammar, text};
use beam_protocol::{
    Command, DecodeError, Estimate, Frame, Message, RawSamples, Status, MAX_MODES, MAX_THETA,
};
use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

/// Longest time between flushes.
pub const FLUSH_EVERY: Duration = Duration::from_millis(250);
/// Most raw samples kept in memory while the sample rate is unknown.
pub const RAW_WAIT_LIMIT: usize = 1 << 20;

/// Columns of the frames file, in order (see `docs/RECORDING.md`).
pub fn columns() -> Vec<String> {
    let mut c: Vec<String> = [
        "host_s",
        "kind",
        "seq",
        "sample_index",
        "t_s",
        "estimator",
        "flags",
    ]
    .iter()
    .map(|s| s.to_string())
    .collect();
    for i in 1..=MAX_MODES {
        c.extend([
            format!("omega_{i}"),
            format!("zeta_{i}"),
            format!("bbar_{i}"),
        ]);
    }
    c.push("excitation_level".into());
    c.extend((1..=MAX_THETA).map(|i| format!("theta_{i}")));
    c.extend(
        [
            "decimation",
            "samples",
            "sample_rate_hz",
            "firmware",
            "modes",
            "overruns",
            "adc_crc_errors",
            "adc_status_errors",
            "adc_stuck",
            "adc_saturations",
            "dac_saturations",
            "rejected_samples",
            "telemetry_dropped",
            "commands_accepted",
            "commands_rejected",
            "rx_frame_errors",
            "adaptation_frozen",
            "waveform",
            "waveform_params",
            "amplitude_v",
            "offset_v",
            "gain",
            "forgetting_p",
            "forgetting_h",
            "initial_gain",
            "lambda_rad_s",
            "lambda_automatic",
            "output",
            "estimate_rate_hz",
            "raw_decimation",
            "status_rate_hz",
            "self_test",
            "command_seq",
            "result",
            "detail",
        ]
        .iter()
        .map(|s| s.to_string()),
    );
    c
}

/// What the recorder wrote.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct RecordStats {
    /// Rows in the frames file (header not counted).
    pub rows: u64,
    /// Rows of frames delivered by the decoder.
    pub frame_rows: u64,
    /// Raw samples written to the raw file.
    pub raw_samples: u64,
    /// Places where the raw samples' indices jump (a block lost, the
    /// decimation changed, raw samples switched off and on).
    pub raw_gaps: u64,
    /// The raw file, if any raw samples arrived.
    pub raw_path: Option<PathBuf>,
    /// The raw file was written by sample index: no sample rate was known.
    pub raw_without_rate: bool,
}

/// `FILE.raw.csv` for `FILE.csv` (or `FILE.raw.csv` for `FILE`).
pub fn raw_path_for(path: &Path) -> PathBuf {
    let stem = match path.extension() {
        Some(e) if e.eq_ignore_ascii_case("csv") => path.with_extension(""),
        _ => path.to_path_buf(),
    };
    let mut s = stem.into_os_string();
    s.push(".raw.csv");
    PathBuf::from(s)
}

/// One row of the frames file, filled by column name.
struct Row {
    fields: Vec<String>,
}

impl Row {
    fn new(width: usize, host_s: f64, kind: &str) -> Self {
        let mut r = Self {
            fields: vec![String::new(); width],
        };
        r.fields[0] = format!("{host_s:.6}");
        r.fields[1] = kind.to_string();
        r
    }

    fn set(&mut self, columns: &[String], name: &str, value: impl ToString) {
        if let Some(i) = columns.iter().position(|c| c == name) {
            self.fields[i] = value.to_string();
        }
    }
}

/// Writes the record files. See the module docs.
#[derive(Debug)]
pub struct Recorder {
    path: PathBuf,
    columns: Vec<String>,
    frames: csv::Writer<BufWriter<File>>,
    raw_path: PathBuf,
    raw: Option<BufWriter<File>>,
    raw_waiting: Vec<(u64, f32, f32)>,
    raw_rate: Option<f64>,
    raw_next: Option<u64>,
    last_flush: Instant,
    stats: RecordStats,
}

fn io_error(path: &Path, e: impl std::fmt::Display) -> String {
    format!("writing {}: {e}", path.display())
}

impl Recorder {
    /// Create (truncate) `path` and write the header. The raw file
    /// ([`raw_path_for`]) is created when the first raw samples arrive.
    pub fn create(path: &Path) -> Result<Self, String> {
        let file =
            File::create(path).map_err(|e| format!("cannot create {}: {e}", path.display()))?;
        let mut frames = csv::Writer::from_writer(BufWriter::new(file));
        let columns = columns();
        frames
            .write_record(&columns)
            .map_err(|e| io_error(path, e))?;
        let mut r = Self {
            path: path.to_path_buf(),
            columns,
            frames,
            raw_path: raw_path_for(path),
            raw: None,
            raw_waiting: Vec::new(),
            raw_rate: None,
            raw_next: None,
            last_flush: Instant::now(),
            stats: RecordStats::default(),
        };
        r.flush()?;
        Ok(r)
    }

    /// The frames file.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// What was written so far.
    pub fn stats(&self) -> &RecordStats {
        &self.stats
    }

    fn row(&self, host_s: f64, kind: &str) -> Row {
        Row::new(self.columns.len(), host_s, kind)
    }

    fn write(&mut self, row: Row) -> Result<(), String> {
        self.frames
            .write_record(&row.fields)
            .map_err(|e| io_error(&self.path, e))?;
        self.stats.rows += 1;
        Ok(())
    }

    /// A frame delivered by the decoder, received `host_s` after the start.
    /// `host` gives the sample rate for `t_s` (it has already seen the
    /// frame, so a Status row carries its own rate).
    pub fn frame(&mut self, host_s: f64, frame: &Frame, host: &Host) -> Result<(), String> {
        let cols = &self.columns;
        let (kind, index) = match &frame.message {
            Message::Estimate(e) => ("estimate", Some(e.sample_index)),
            Message::RawSamples(r) => ("raw", Some(r.first_sample_index)),
            Message::Status(s) => ("status", Some(s.uptime_samples)),
            Message::Ack(_) => ("ack", None),
            Message::SelfTestReport(r) => ("selftest", Some(r.first_sample)),
            Message::Command(_) => ("command_echo", None),
        };
        let mut row = self.row(host_s, kind);
        row.set(cols, "seq", frame.seq);
        if let Some(i) = index {
            row.set(cols, "sample_index", i);
            if let Some(t) = host.time_s(i) {
                row.set(cols, "t_s", t);
            }
        }
        match &frame.message {
            Message::Estimate(e) => estimate_fields(&mut row, cols, e),
            Message::RawSamples(r) => {
                row.set(cols, "decimation", r.decimation);
                row.set(cols, "samples", r.samples.len());
            }
            Message::Status(s) => status_fields(&mut row, cols, s),
            Message::Ack(a) => {
                row.set(cols, "command_seq", a.command_seq);
                row.set(cols, "result", text::result_name(a.result));
                if let beam_protocol::AckResult::Rejected(r) = a.result {
                    row.set(cols, "detail", r.describe());
                }
            }
            Message::SelfTestReport(r) => {
                row.set(
                    cols,
                    "self_test",
                    text::self_test_state_text(beam_protocol::SelfTestState::Done {
                        failed: r.failed,
                        not_measured: r.not_measured,
                    }),
                );
                row.set(cols, "detail", text::self_test_lines(r).join(" / "));
            }
            Message::Command(c) => row.set(cols, "detail", grammar::command_text(c)),
        }
        self.write(row)?;
        self.stats.frame_rows += 1;
        match &frame.message {
            Message::RawSamples(r) => self.raw_samples(r, host)?,
            Message::Status(_) => self.raw_rate_known(host)?,
            _ => {}
        }
        Ok(())
    }

    /// A command the host sent (`seq` from the host's counter).
    pub fn command(&mut self, host_s: f64, seq: u32, command: &Command) -> Result<(), String> {
        let cols = &self.columns;
        let mut row = self.row(host_s, "command");
        row.set(cols, "seq", seq);
        row.set(cols, "detail", grammar::command_text(command));
        self.write(row)
    }

    /// A command that got no acknowledgement in time.
    pub fn timeout(&mut self, host_s: f64, seq: u32, command: &Command) -> Result<(), String> {
        let cols = &self.columns;
        let mut row = self.row(host_s, "timeout");
        row.set(cols, "command_seq", seq);
        row.set(cols, "detail", grammar::command_text(command));
        self.write(row)
    }

    /// A frame the decoder dropped.
    pub fn error(&mut self, host_s: f64, error: &DecodeError) -> Result<(), String> {
        let cols = &self.columns;
        let mut row = self.row(host_s, "error");
        row.set(cols, "detail", error);
        self.write(row)
    }

    /// The last row: why the run ended.
    pub fn end(&mut self, host_s: f64, reason: &str) -> Result<(), String> {
        let cols = &self.columns;
        let mut row = self.row(host_s, "end");
        row.set(cols, "detail", reason);
        self.write(row)
    }

    fn raw_samples(&mut self, r: &RawSamples, host: &Host) -> Result<(), String> {
        let d = u64::from(r.decimation.max(1));
        if let Some(next) = self.raw_next {
            if next != r.first_sample_index {
                self.stats.raw_gaps += 1;
            }
        }
        self.raw_next = Some(r.first_sample_index + d * r.samples.len() as u64);
        for (i, s) in r.samples.iter().enumerate() {
            self.raw_waiting
                .push((r.first_sample_index + d * i as u64, s.u_v, s.y));
        }
        if self.raw_rate.is_none() {
            self.raw_rate = host.sample_rate_hz();
        }
        if self.raw_rate.is_some() || self.raw_waiting.len() >= RAW_WAIT_LIMIT {
            self.drain_raw()?;
        }
        Ok(())
    }

    fn raw_rate_known(&mut self, host: &Host) -> Result<(), String> {
        if self.raw_rate.is_none() && self.raw.is_none() {
            self.raw_rate = host.sample_rate_hz();
            if self.raw_rate.is_some() && !self.raw_waiting.is_empty() {
                self.drain_raw()?;
            }
        }
        Ok(())
    }

    /// Write the waiting raw samples (creating the file, its header chosen
    /// by whether the sample rate is known).
    fn drain_raw(&mut self) -> Result<(), String> {
        if self.raw.is_none() {
            let f = File::create(&self.raw_path)
                .map_err(|e| format!("cannot create {}: {e}", self.raw_path.display()))?;
            let mut w = BufWriter::new(f);
            let header = if self.raw_rate.is_some() {
                "t,u,y"
            } else {
                self.stats.raw_without_rate = true;
                "sample_index,u,y"
            };
            writeln!(w, "{header}").map_err(|e| io_error(&self.raw_path, e))?;
            self.raw = Some(w);
            self.stats.raw_path = Some(self.raw_path.clone());
        }
        let rate = if self.stats.raw_without_rate {
            None
        } else {
            self.raw_rate
        };
        let Some(w) = self.raw.as_mut() else {
            return Ok(());
        };
        for (index, u, y) in self.raw_waiting.drain(..) {
            // f32 → f64 is exact, and f64's shortest round-trip decimal
            // reads back as the same f64: a replay gets the device's bits.
            let (u, y) = (f64::from(u), f64::from(y));
            let r = match rate {
                Some(fs) => writeln!(w, "{},{u},{y}", index as f64 / fs),
                None => writeln!(w, "{index},{u},{y}"),
            };
            r.map_err(|e| io_error(&self.raw_path, e))?;
            self.stats.raw_samples += 1;
        }
        Ok(())
    }

    /// Flush both files if the last flush is [`FLUSH_EVERY`] old.
    pub fn flush_if_due(&mut self, now: Instant) -> Result<(), String> {
        if now.duration_since(self.last_flush) >= FLUSH_EVERY {
            self.flush()?;
            self.last_flush = now;
        }
        Ok(())
    }

    /// Flush both files now.
    pub fn flush(&mut self) -> Result<(), String> {
        self.frames.flush().map_err(|e| io_error(&self.path, e))?;
        if let Some(w) = self.raw.as_mut() {
            w.flush().map_err(|e| io_error(&self.raw_path, e))?;
        }
        Ok(())
    }

    /// Write any raw samples still waiting for the sample rate (by sample
    /// index if it never came), flush, and return what was written.
    pub fn finish(mut self) -> Result<RecordStats, String> {
        if !self.raw_waiting.is_empty() {
            self.drain_raw()?;
        }
        self.flush()?;
        Ok(self.stats)
    }
}

fn estimate_fields(row: &mut Row, cols: &[String], e: &Estimate) {
    row.set(cols, "estimator", e.estimator.name());
    row.set(cols, "flags", e.flags.0);
    for (i, m) in e.modes.iter().enumerate() {
        let i = i + 1;
        row.set(cols, &format!("omega_{i}"), m.omega_rad_s);
        row.set(cols, &format!("zeta_{i}"), m.zeta);
        row.set(cols, &format!("bbar_{i}"), m.b_bar);
    }
    if let Some(l) = e.excitation_level {
        row.set(cols, "excitation_level", l);
    }
    row.set(cols, "lambda_rad_s", e.lambda_rad_s);
    for (i, v) in e.theta.iter().enumerate() {
        row.set(cols, &format!("theta_{}", i + 1), v);
    }
    row.set(cols, "detail", text::flags_text(e.flags, "|"));
}

fn status_fields(row: &mut Row, cols: &[String], s: &Status) {
    let c = &s.counters;
    let fw = s.firmware;
    row.set(cols, "sample_rate_hz", s.sample_rate_hz);
    row.set(
        cols,
        "firmware",
        format!("{}.{}.{}", fw.major, fw.minor, fw.patch),
    );
    row.set(cols, "modes", s.modes);
    for (name, v) in c.named() {
        row.set(cols, name, v);
    }
    row.set(cols, "adaptation_frozen", u8::from(s.adaptation_frozen));
    row.set(cols, "waveform", s.excitation.waveform.kind().name());
    row.set(
        cols,
        "waveform_params",
        text::waveform_params(&s.excitation.waveform),
    );
    row.set(cols, "amplitude_v", s.excitation.amplitude_v);
    row.set(cols, "offset_v", s.excitation.offset_v);
    let e = &s.estimator;
    row.set(cols, "estimator", e.kind.name());
    row.set(cols, "gain", e.gain);
    row.set(cols, "forgetting_p", e.forgetting_p);
    row.set(cols, "forgetting_h", e.forgetting_h);
    row.set(cols, "initial_gain", e.initial_gain);
    if let Some(l) = e.lambda_rad_s {
        row.set(cols, "lambda_rad_s", l);
    }
    row.set(cols, "lambda_automatic", u8::from(s.lambda_automatic));
    row.set(cols, "output", e.output.name());
    let t = &s.telemetry;
    row.set(cols, "estimate_rate_hz", t.estimate_rate_hz);
    row.set(cols, "raw_decimation", t.raw_decimation);
    row.set(cols, "status_rate_hz", t.status_rate_hz);
    row.set(cols, "self_test", text::self_test_state_text(s.self_test));
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn raw_path_next_to_the_record() {
        assert_eq!(
            raw_path_for(Path::new("/x/run.csv")),
            PathBuf::from("/x/run.raw.csv")
        );
        assert_eq!(
            raw_path_for(Path::new("run.CSV")),
            PathBuf::from("run.raw.csv")
        );
        assert_eq!(raw_path_for(Path::new("run")), PathBuf::from("run.raw.csv"));
    }

    #[test]
    fn columns_are_unique() {
        let c = columns();
        let mut s = c.clone();
        s.sort();
        s.dedup();
        assert_eq!(s.len(), c.len());
        assert_eq!(c.len(), 7 + 3 * MAX_MODES + 1 + MAX_THETA + 35);
    }
}
