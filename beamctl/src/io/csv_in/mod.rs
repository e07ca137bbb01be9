//! Reading recorded (u, y) samples for `beamctl replay`: a CSV file with a
//! header (plain or gzip-compressed), the sample interval from its t
//! column or given, every problem a one-line error with its line number.
//! The format is documented in docs/REPLAY.md.
//!
//! # Design
//! * **No allocation per row.** The file is read in 4 MiB blocks; the
//!   delimiters of a block are found 8 bytes at a time (`Delimiters`,
//!   SWAR) and only the two or three needed fields are
//!   parsed, with `fast-float2` (Lemire's algorithm; correctly rounded, so
//!   a shortest round-trip decimal reads back as the same f64). Samples
//!   come out in caller-provided batches.
//! * **Every row is checked**: its field count against the header's (a
//!   row with the wrong count is an error), each needed field for a
//!   number (text is an error; an empty field, `nan` or `inf` is a missing
//!   sample, passed on as NaN for the estimator to reject and count), and
//!   the t column for a uniform, increasing time base.
//! * **The sample interval** is the mean spacing of the first
//!   [`TS_PREFIX_ROWS`] rows, rounded to 9 significant digits (so a file
//!   written by `beamctl simulate --csv` gives back Ts = 1e-4 exactly).
//!   Every interval must be within 1% of it (in the first rows: of their
//!   median, so that one outlier cannot shift the reference and the error
//!   names the outlier's line).

mod fields;

use fields::{clean, number, quick_decimal, show, Delimiters};
use flate2::read::MultiGzDecoder;
use std::fmt;
use std::fs::File;
use std::io::{Read, Seek};
use std::path::Path;

/// Rows averaged for the sample interval.
pub const TS_PREFIX_ROWS: usize = 10_000;
/// Largest relative deviation of a t interval from the sample interval.
pub const TS_TOLERANCE: f64 = 0.01;
/// Read block size.
const BLOCK: usize = 4 << 20;

/// Ts from the times of the first rows (at most [`TS_PREFIX_ROWS`], at
/// least two, increasing): their intervals checked against their median
/// (robust to the very outlier being looked for), then the mean spacing
/// rounded to 9 significant digits. The error names the index in `t` of
/// the row that ends the offending interval.
fn prefix_ts(t: &[f64]) -> Result<f64, (usize, String)> {
    let mut dts: Vec<f64> = t.windows(2).map(|w| w[1] - w[0]).collect();
    dts.sort_by(f64::total_cmp);
    let median = dts[dts.len() / 2];
    for (i, w) in t.windows(2).enumerate() {
        let dt = w[1] - w[0];
        if (dt - median).abs() > TS_TOLERANCE * median {
            return Err((
                i + 1,
                format!(
                    "non-uniform sampling: interval {dt:e} s differs from the sample interval {median:e} s by more than 1%"
                ),
            ));
        }
    }
    let ts = (t[t.len() - 1] - t[0]) / (t.len() - 1) as f64;
    Ok(format!("{ts:.8e}").parse().unwrap_or(ts))
}

/// The sample interval of a whole time column already in memory, by the
/// file's rules (docs/REPLAY.md): every t finite and increasing, Ts the
/// rounded mean spacing of the first [`TS_PREFIX_ROWS`] rows, every
/// interval within 1% of it. The error is the index in `t` of the
/// offending value and the message a file would give for its row.
pub fn time_base(t: &[f64]) -> Result<f64, (usize, String)> {
    if t.len() < 2 {
        return Err((
            0,
            "fewer than two times: the sample interval cannot be found from the time column (give ts)".into(),
        ));
    }
    for (i, &v) in t.iter().enumerate() {
        if !v.is_finite() {
            return Err((i, "the time column is empty or not a finite number".into()));
        }
        if i > 0 && !(v - t[i - 1] > 0.0) {
            return Err((
                i,
                format!("the time column does not increase ({} then {v})", t[i - 1]),
            ));
        }
    }
    let prefix = t.len().min(TS_PREFIX_ROWS);
    let ts = prefix_ts(&t[..prefix])?;
    for i in prefix.max(1)..t.len() {
        let dt = t[i] - t[i - 1];
        if (dt - ts).abs() > TS_TOLERANCE * ts {
            return Err((
                i,
                format!(
                    "non-uniform sampling: interval {dt:e} s differs from the sample interval {ts:e} s by more than 1%"
                ),
            ));
        }
    }
    Ok(ts)
}

/// A problem with the input, with the 1-based line it was found on.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct CsvError {
    /// The line (1 = the header), if the problem is on one.
    pub line: Option<u64>,
    /// What is wrong.
    pub message: String,
}

impl CsvError {
    fn at(line: u64, message: impl Into<String>) -> Self {
        Self {
            line: Some(line),
            message: message.into(),
        }
    }
    fn file(message: impl Into<String>) -> Self {
        Self {
            line: None,
            message: message.into(),
        }
    }
}

impl fmt::Display for CsvError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.line {
            Some(l) => write!(f, "line {l}: {}", self.message),
            None => f.write_str(&self.message),
        }
    }
}

impl std::error::Error for CsvError {}

/// Which columns hold t, u and y.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Columns {
    /// The time column's name (`None`: no time column, Ts is given).
    pub t: Option<String>,
    /// The input column's name.
    pub u: String,
    /// The output column's name.
    pub y: String,
    /// Another name tried for the time column if `t` is not in the header.
    pub t_alias: Option<String>,
}

impl Columns {
    /// `t,u,y` (the time column may also be `t_s`, as `beamctl simulate
    /// --csv` writes it), or `u,y` when the sample interval is given.
    pub fn default_for(ts_given: bool) -> Self {
        Self {
            t: (!ts_given).then(|| "t".to_string()),
            u: "u".to_string(),
            y: "y".to_string(),
            t_alias: (!ts_given).then(|| "t_s".to_string()),
        }
    }

    /// Columns named by the user.
    pub fn named(t: Option<&str>, u: &str, y: &str) -> Self {
        Self {
            t: t.map(str::to_string),
            u: u.to_string(),
            y: y.to_string(),
            t_alias: None,
        }
    }
}

/// Positions of the needed fields in a row.
#[derive(Debug, Clone, Copy)]
struct Layout {
    fields: usize,
    t: Option<usize>,
    u: usize,
    y: usize,
}

/// A reader of samples.
pub struct Reader {
    src: Box<dyn Read + Send>,
    /// Read buffer, zero-initialised once: valid bytes are `buf[..end]`.
    buf: Vec<u8>,
    /// End of the valid bytes in `buf`.
    end: usize,
    /// Start of the unparsed bytes in `buf`.
    pos: usize,
    eof: bool,
    /// 1-based number of the last line read.
    line: u64,
    layout: Layout,
    ts_s: f64,
    /// Samples read ahead to find Ts, handed out first.
    prefix: Vec<(f64, f64)>,
    prefix_pos: usize,
    /// t of the previous row and its line.
    last_t: Option<f64>,
    rows: u64,
}

/// Find a header name: exact, else ASCII case-insensitive.
fn find(names: &[&str], want: &str) -> Option<usize> {
    names
        .iter()
        .position(|n| *n == want)
        .or_else(|| names.iter().position(|n| n.eq_ignore_ascii_case(want)))
}

impl Reader {
    /// Open `path` (gzip-compressed if it starts with the gzip magic),
    /// read the header and, unless `ts_s` is given, enough rows to find the
    /// sample interval.
    pub fn open(path: &Path, columns: &Columns, ts_s: Option<f64>) -> Result<Self, CsvError> {
        let mut file = File::open(path)
            .map_err(|e| CsvError::file(format!("cannot open {}: {e}", path.display())))?;
        let mut magic = [0u8; 2];
        let n = file.read(&mut magic).unwrap_or(0);
        file.rewind()
            .map_err(|e| CsvError::file(format!("cannot read {}: {e}", path.display())))?;
        let src: Box<dyn Read + Send> = if n == 2 && magic == [0x1f, 0x8b] {
            Box::new(MultiGzDecoder::new(file))
        } else {
            Box::new(file)
        };
        Self::from_reader(src, columns, ts_s)
    }

    /// As [`Reader::open`], from any byte source.
    pub fn from_reader(
        src: Box<dyn Read + Send>,
        columns: &Columns,
        ts_s: Option<f64>,
    ) -> Result<Self, CsvError> {
        if let Some(ts) = ts_s {
            if !(ts > 0.0 && ts.is_finite()) {
                return Err(CsvError::file(format!(
                    "the sample interval must be a finite number > 0 s (got {ts})"
                )));
            }
        }
        let mut r = Self {
            src,
            buf: vec![0; 2 * BLOCK],
            end: 0,
            pos: 0,
            eof: false,
            line: 0,
            layout: Layout {
                fields: 0,
                t: None,
                u: 0,
                y: 0,
            },
            ts_s: ts_s.unwrap_or(f64::NAN),
            prefix: Vec::new(),
            prefix_pos: 0,
            last_t: None,
            rows: 0,
        };
        r.read_header(columns)?;
        if ts_s.is_none() {
            r.find_ts()?;
        } else if r.layout.t.is_some() {
            return Err(CsvError::file(
                "give either a time column or --ts, not both (use --columns U,Y with --ts)",
            ));
        }
        Ok(r)
    }

    /// The sample interval (s).
    pub fn ts_s(&self) -> f64 {
        self.ts_s
    }

    /// Data rows read so far.
    pub fn rows(&self) -> u64 {
        self.rows
    }

    /// Refill the buffer, keeping the unparsed tail. False at end of input.
    fn fill(&mut self) -> Result<bool, CsvError> {
        if self.eof {
            return Ok(false);
        }
        // Move the unparsed tail to the front and read behind it; the
        // buffer is zero-filled once, never again.
        self.buf.copy_within(self.pos..self.end, 0);
        self.end -= self.pos;
        self.pos = 0;
        if self.buf.len() - self.end < BLOCK {
            // A line longer than the buffer: grow it.
            let grown = 2 * self.buf.len();
            self.buf.resize(grown, 0);
        }
        let mut got = 0;
        while got < BLOCK {
            match self
                .src
                .read(&mut self.buf[self.end + got..self.end + BLOCK])
            {
                Ok(0) => {
                    self.eof = true;
                    break;
                }
                Ok(k) => got += k,
                Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
                Err(e) => {
                    return Err(CsvError::at(self.line + 1, format!("cannot read: {e}")));
                }
            }
        }
        self.end += got;
        Ok(got > 0)
    }

    /// The next line (without its terminator), or `None` at the end.
    /// Borrow-free: returns the byte range in `buf`.
    fn next_line(&mut self) -> Result<Option<(usize, usize)>, CsvError> {
        loop {
            if let Some(i) = memchr::memchr(b'\n', &self.buf[self.pos..self.end]) {
                let (s, mut e) = (self.pos, self.pos + i);
                self.pos = e + 1;
                if e > s && self.buf[e - 1] == b'\r' {
                    e -= 1;
                }
                self.line += 1;
                return Ok(Some((s, e)));
            }
            if !self.fill()? {
                if self.pos < self.end {
                    // Last line without a terminator.
                    let (s, mut e) = (self.pos, self.end);
                    self.pos = e;
                    if e > s && self.buf[e - 1] == b'\r' {
                        e -= 1;
                    }
                    self.line += 1;
                    return Ok(Some((s, e)));
                }
                return Ok(None);
            }
        }
    }

    fn read_header(&mut self, columns: &Columns) -> Result<(), CsvError> {
        let Some((s, e)) = self.next_line()? else {
            return Err(CsvError::file("the file is empty (no header line)"));
        };
        let mut raw = &self.buf[s..e];
        if raw.starts_with(&[0xEF, 0xBB, 0xBF]) {
            raw = &raw[3..]; // UTF-8 byte-order mark
        }
        let text = std::str::from_utf8(raw)
            .map_err(|_| CsvError::at(1, "the header is not UTF-8 text"))?;
        let names: Vec<&str> = text
            .split(',')
            .map(|n| std::str::from_utf8(clean(n.as_bytes())).unwrap_or(""))
            .collect();
        let need = |want: &str| {
            find(&names, want).ok_or_else(|| {
                CsvError::at(
                    1,
                    format!(
                        "no column named {want:?} in the header ({}); choose columns with --columns",
                        names.join(",")
                    ),
                )
            })
        };
        let t = match (columns.t.as_deref(), columns.t_alias.as_deref()) {
            (Some(t), Some(alias)) => Some(
                find(&names, t)
                    .or_else(|| find(&names, alias))
                    .ok_or_else(|| {
                        CsvError::at(
                            1,
                            format!(
                                "no column named {t:?} (or {alias:?}) in the header ({}); choose columns with --columns, or give --ts",
                                names.join(",")
                            ),
                        )
                    })?,
            ),
            (Some(t), None) => Some(need(t)?),
            (None, _) => None,
        };
        self.layout = Layout {
            fields: names.len(),
            t,
            u: need(&columns.u)?,
            y: need(&columns.y)?,
        };
        Ok(())
    }

    /// Parse one data row into (t, u, y); `None` for a blank line.
    fn parse_row(&self, s: usize, e: usize) -> Result<Option<(f64, f64, f64)>, CsvError> {
        let row = &self.buf[s..e];
        if row.trim_ascii().is_empty() {
            return Ok(None);
        }
        let l = self.layout;
        let mut t = f64::NAN;
        let (mut u, mut y) = (f64::NAN, f64::NAN);
        let mut start = 0;
        let mut idx = 0;
        let mut field = |idx: usize, f: &[u8]| -> Result<(), CsvError> {
            let which = if Some(idx) == l.t {
                Some(('t', &mut t))
            } else if idx == l.u {
                Some(('u', &mut u))
            } else if idx == l.y {
                Some(('y', &mut y))
            } else {
                None
            };
            if let Some((name, slot)) = which {
                *slot = number(f).map_err(|()| {
                    CsvError::at(
                        self.line,
                        format!("field {} ({name}) is not a number: {:?}", idx + 1, show(f)),
                    )
                })?;
            }
            Ok(())
        };
        for comma in memchr::memchr_iter(b',', row) {
            if idx < l.fields {
                field(idx, &row[start..comma])?;
            }
            idx += 1;
            start = comma + 1;
        }
        if idx < l.fields {
            field(idx, &row[start..])?;
        }
        let count = idx + 1;
        if count != l.fields {
            return Err(CsvError::at(
                self.line,
                format!("{count} fields, the header has {}", l.fields),
            ));
        }
        Ok(Some((t, u, y)))
    }

    /// Check the time base of a row's t against the previous row's.
    fn check_t(&mut self, t: f64) -> Result<(), CsvError> {
        if !t.is_finite() {
            return Err(CsvError::at(
                self.line,
                "the time column is empty or not a finite number",
            ));
        }
        if let Some(prev) = self.last_t {
            let dt = t - prev;
            if !(dt > 0.0) {
                return Err(CsvError::at(
                    self.line,
                    format!("the time column does not increase ({prev} then {t})"),
                ));
            }
            if self.ts_s.is_finite() && (dt - self.ts_s).abs() > TS_TOLERANCE * self.ts_s {
                return Err(CsvError::at(
                    self.line,
                    format!(
                        "non-uniform sampling: interval {dt:e} s differs from the sample interval {:e} s by more than 1%",
                        self.ts_s
                    ),
                ));
            }
        }
        self.last_t = Some(t);
        Ok(())
    }

    /// Read up to [`TS_PREFIX_ROWS`] rows to fix Ts, then check their
    /// intervals against it.
    fn find_ts(&mut self) -> Result<(), CsvError> {
        let mut times: Vec<(f64, u64)> = Vec::with_capacity(TS_PREFIX_ROWS);
        while times.len() < TS_PREFIX_ROWS {
            let Some((s, e)) = self.next_line()? else {
                break;
            };
            let Some((t, u, y)) = self.parse_row(s, e)? else {
                continue;
            };
            // Order only: Ts is not known yet.
            self.check_t(t)?;
            times.push((t, self.line));
            self.prefix.push((u, y));
        }
        if times.is_empty() {
            return Err(CsvError::file("no data rows after the header"));
        }
        if times.len() < 2 {
            return Err(CsvError::file(
                "only one data row: the sample interval cannot be found from the time column (give --ts)",
            ));
        }
        let t: Vec<f64> = times.iter().map(|&(t, _)| t).collect();
        self.ts_s = prefix_ts(&t).map_err(|(i, m)| CsvError::at(times[i].1, m))?;
        self.rows = times.len() as u64;
        Ok(())
    }

    /// Parse the complete rows in `buf[pos..end]` (`end` just after a
    /// newline) into `out` until it holds `max` samples: one pass over the
    /// bytes for both delimiters, only the needed fields parsed. Same rules
    /// and messages as [`Reader::parse_row`] and [`Reader::check_t`].
    fn fast_rows(
        &mut self,
        end: usize,
        out: &mut Vec<(f64, f64)>,
        max: usize,
    ) -> Result<(), CsvError> {
        let l = self.layout;
        let t_col = l.t.unwrap_or(usize::MAX);
        let ts = self.ts_s;
        let mut line = self.line;
        let mut last_t = self.last_t;
        let mut rows = self.rows;
        let base = self.pos;
        let block = &self.buf[base..end];
        let (mut t, mut u, mut y) = (f64::NAN, f64::NAN, f64::NAN);
        let mut idx = 0usize;
        let mut field_start = 0usize;
        let mut row_start = 0usize;
        let mut consumed = block.len();
        for d in Delimiters::new(block) {
            let newline = block[d] == b'\n';
            let mut f = &block[field_start..d];
            if newline {
                if let [rest @ .., b'\r'] = f {
                    f = rest;
                }
            }
            if idx < l.fields && (idx == l.u || idx == l.y || idx == t_col) {
                let bad = |name: char| {
                    CsvError::at(
                        line + 1,
                        format!("field {} ({name}) is not a number: {:?}", idx + 1, show(f)),
                    )
                };
                if idx == t_col {
                    t = match quick_decimal(f) {
                        Some(v) => v,
                        None => number(f).map_err(|()| bad('t'))?,
                    };
                } else if idx == l.u {
                    u = number(f).map_err(|()| bad('u'))?;
                } else {
                    y = number(f).map_err(|()| bad('y'))?;
                }
            }
            field_start = d + 1;
            if !newline {
                idx += 1;
                continue;
            }
            line += 1;
            let row = &block[row_start..d];
            row_start = d + 1;
            let count = idx + 1;
            idx = 0;
            if row.trim_ascii().is_empty() {
                (t, u, y) = (f64::NAN, f64::NAN, f64::NAN);
                continue;
            }
            if count != l.fields {
                return Err(CsvError::at(
                    line,
                    format!("{count} fields, the header has {}", l.fields),
                ));
            }
            if l.t.is_some() {
                if !t.is_finite() {
                    return Err(CsvError::at(
                        line,
                        "the time column is empty or not a finite number",
                    ));
                }
                if let Some(prev) = last_t {
                    let dt = t - prev;
                    if !(dt > 0.0) {
                        return Err(CsvError::at(
                            line,
                            format!("the time column does not increase ({prev} then {t})"),
                        ));
                    }
                    if (dt - ts).abs() > TS_TOLERANCE * ts {
                        return Err(CsvError::at(
                            line,
                            format!(
                                "non-uniform sampling: interval {dt:e} s differs from the sample interval {ts:e} s by more than 1%"
                            ),
                        ));
                    }
                }
                last_t = Some(t);
            }
            rows += 1;
            out.push((u, y));
            (t, u, y) = (f64::NAN, f64::NAN, f64::NAN);
            if out.len() >= max {
                consumed = d + 1;
                break;
            }
        }
        self.pos = base + consumed;
        self.line = line;
        self.last_t = last_t;
        self.rows = rows;
        Ok(())
    }

    /// Fill `out` (cleared first) with up to `max` samples (u, y). Returns
    /// false when the input is exhausted and nothing was added.
    pub fn next_batch(&mut self, out: &mut Vec<(f64, f64)>, max: usize) -> Result<bool, CsvError> {
        out.clear();
        while self.prefix_pos < self.prefix.len() && out.len() < max {
            out.push(self.prefix[self.prefix_pos]);
            self.prefix_pos += 1;
        }
        if self.prefix_pos == self.prefix.len() && !self.prefix.is_empty() {
            self.prefix = Vec::new();
            self.prefix_pos = 0;
        }
        while out.len() < max {
            // Complete lines in the buffer go through the fast path; the
            // last line of a file without a final newline, through the
            // line-by-line one.
            match memchr::memrchr(b'\n', &self.buf[self.pos..self.end]) {
                Some(last) => {
                    let end = self.pos + last + 1;
                    self.fast_rows(end, out, max)?;
                }
                None => {
                    if self.fill()? {
                        continue;
                    }
                    if let Some((s, e)) = self.next_line()? {
                        if let Some((t, u, y)) = self.parse_row(s, e)? {
                            if self.layout.t.is_some() {
                                self.check_t(t)?;
                            }
                            self.rows += 1;
                            out.push((u, y));
                        }
                    }
                    break;
                }
            }
        }
        if self.rows == 0 && out.is_empty() && self.eof {
            return Err(CsvError::file("no data rows after the header"));
        }
        Ok(!out.is_empty())
    }
}
