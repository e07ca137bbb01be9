//! Plain-text tables and number formatting for the terminal.
//!
//! A [`Table`] has a label column followed by column groups (one per
//! estimator, say), each with its own header; groups are separated by a
//! vertical rule. Widths count characters, ignoring combining marks, so
//! labels like "b̄1" line up.

use std::fmt::Write as _;

/// Horizontal alignment of a column.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Align {
    /// Pad on the right.
    Left,
    /// Pad on the left (numbers).
    Right,
}

/// A column: header and alignment.
#[derive(Debug, Clone)]
pub struct Column {
    /// Header text.
    pub header: String,
    /// Alignment of header and cells.
    pub align: Align,
}

impl Column {
    /// A right-aligned (numeric) column.
    pub fn num(header: &str) -> Self {
        Self {
            header: header.to_string(),
            align: Align::Right,
        }
    }

    /// A left-aligned (text) column.
    pub fn text(header: &str) -> Self {
        Self {
            header: header.to_string(),
            align: Align::Left,
        }
    }
}

/// One row of a table.
#[derive(Debug, Clone)]
enum Row {
    /// Cells, one per column (missing trailing cells are blank).
    Cells(Vec<String>),
    /// A horizontal rule.
    Rule,
}

/// A text table made of column groups.
#[derive(Debug, Clone, Default)]
pub struct Table {
    groups: Vec<(String, Vec<Column>)>,
    rows: Vec<Row>,
}

/// Space between columns inside a group.
const GAP: &str = "  ";
/// Separator between groups.
const GROUP_SEP: &str = " │ ";

impl Table {
    /// An empty table.
    pub fn new() -> Self {
        Self::default()
    }

    /// Append a column group with a (possibly empty) title.
    pub fn group(&mut self, title: &str, columns: Vec<Column>) -> &mut Self {
        self.groups.push((title.to_string(), columns));
        self
    }

    /// Append a row of cells, left to right across all groups.
    pub fn row<S: Into<String>>(&mut self, cells: impl IntoIterator<Item = S>) -> &mut Self {
        self.rows
            .push(Row::Cells(cells.into_iter().map(Into::into).collect()));
        self
    }

    /// Append a horizontal rule.
    pub fn rule(&mut self) -> &mut Self {
        self.rows.push(Row::Rule);
        self
    }

    /// Render to a string (lines end with '\n', no trailing spaces).
    pub fn render(&self) -> String {
        let columns: Vec<&Column> = self.groups.iter().flat_map(|(_, c)| c.iter()).collect();
        let mut widths: Vec<usize> = columns.iter().map(|c| width(&c.header)).collect();
        for row in &self.rows {
            if let Row::Cells(cells) = row {
                for (w, cell) in widths.iter_mut().zip(cells) {
                    *w = (*w).max(width(cell));
                }
            }
        }
        // Widen the last column of a group whose title does not fit.
        let mut start = 0;
        for (title, cols) in &self.groups {
            let end = start + cols.len();
            if end > start {
                let span = group_width(&widths[start..end]);
                let need = width(title);
                if need > span {
                    widths[end - 1] += need - span;
                }
            }
            start = end;
        }
        let mut out = String::new();
        let has_titles = self.groups.iter().any(|(t, _)| !t.is_empty());
        if has_titles {
            let mut line = String::new();
            let mut start = 0;
            for (g, (title, cols)) in self.groups.iter().enumerate() {
                if g > 0 {
                    line.push_str(GROUP_SEP);
                }
                let span = group_width(&widths[start..start + cols.len()]);
                line.push_str(&center(title, span));
                start += cols.len();
            }
            push_line(&mut out, &line);
        }
        let headers: Vec<String> = columns.iter().map(|c| c.header.clone()).collect();
        push_line(&mut out, &self.line(&headers, &columns, &widths));
        let total = width(&self.line(&[], &columns, &widths));
        push_line(&mut out, &"─".repeat(total));
        for row in &self.rows {
            match row {
                Row::Cells(cells) => push_line(&mut out, &self.line(cells, &columns, &widths)),
                Row::Rule => push_line(&mut out, &"─".repeat(total)),
            }
        }
        out
    }

    fn line(&self, cells: &[String], columns: &[&Column], widths: &[usize]) -> String {
        let mut line = String::new();
        let mut idx = 0;
        for (g, (_, cols)) in self.groups.iter().enumerate() {
            if g > 0 {
                line.push_str(GROUP_SEP);
            }
            for k in 0..cols.len() {
                if k > 0 {
                    line.push_str(GAP);
                }
                let cell = cells.get(idx).map(String::as_str).unwrap_or("");
                line.push_str(&pad(cell, widths[idx], columns[idx].align));
                idx += 1;
            }
        }
        line
    }
}

fn group_width(widths: &[usize]) -> usize {
    widths.iter().sum::<usize>() + GAP.len() * widths.len().saturating_sub(1)
}

fn push_line(out: &mut String, line: &str) {
    let _ = writeln!(out, "{}", line.trim_end());
}

/// Display width: characters, not counting combining diacritical marks.
pub fn width(s: &str) -> usize {
    s.chars()
        .filter(|c| !('\u{300}'..='\u{36f}').contains(c))
        .count()
}

fn pad(s: &str, w: usize, align: Align) -> String {
    let fill = " ".repeat(w.saturating_sub(width(s)));
    match align {
        Align::Left => format!("{s}{fill}"),
        Align::Right => format!("{fill}{s}"),
    }
}

fn center(s: &str, w: usize) -> String {
    let extra = w.saturating_sub(width(s));
    let left = extra / 2;
    format!("{}{s}{}", " ".repeat(left), " ".repeat(extra - left))
}

/// `v` with `digits` significant digits: fixed notation for magnitudes in
/// [1e-3, 1e6), scientific otherwise; "n/a" for NaN or infinity.
pub fn sig(v: f64, digits: usize) -> String {
    if !v.is_finite() {
        return "n/a".to_string();
    }
    if v == 0.0 {
        return "0".to_string();
    }
    let digits = digits.max(1);
    let mag = v.abs().log10().floor() as i32;
    if (-3..6).contains(&mag) {
        let decimals = (digits as i32 - 1 - mag).max(0) as usize;
        format!("{v:.decimals$}")
    } else {
        format!("{v:.*e}", digits - 1)
    }
}

/// A relative error in scientific notation ("1.23e-9"); "n/a" if NaN,
/// "∞" if infinite (the runner's mark for a failed modal recovery).
pub fn rel(v: f64) -> String {
    if v.is_finite() {
        format!("{v:.2e}")
    } else if v.is_infinite() {
        "∞".to_string()
    } else {
        "n/a".to_string()
    }
}

/// `v` with up to `digits` significant digits and no trailing zeros
/// ("100", "0.0207").
pub fn short(v: f64, digits: usize) -> String {
    let s = sig(v, digits);
    let (mantissa, exp) = match s.split_once('e') {
        Some((m, e)) => (m, Some(e)),
        None => (s.as_str(), None),
    };
    let mantissa = if mantissa.contains('.') {
        mantissa.trim_end_matches('0').trim_end_matches('.')
    } else {
        mantissa
    };
    match exp {
        Some(e) => format!("{mantissa}e{e}"),
        None => mantissa.to_string(),
    }
}

/// A settling time in seconds, or "never".
pub fn seconds(t: Option<f64>) -> String {
    match t {
        Some(t) => format!("{t:.3} s"),
        None => "never".to_string(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sig_formats() {
        assert_eq!(sig(39.1533, 7), "39.15330");
        assert_eq!(sig(0.0207, 4), "0.02070");
        assert_eq!(sig(1.11e6, 3), "1.11e6");
        assert_eq!(sig(-1.18e3, 4), "-1180");
        assert_eq!(sig(f64::NAN, 4), "n/a");
        assert_eq!(sig(0.0, 4), "0");
        assert_eq!(rel(1.234e-9), "1.23e-9");
        assert_eq!(seconds(None), "never");
        assert_eq!(short(100.0, 4), "100");
        assert_eq!(short(98.06, 3), "98.1");
        assert_eq!(short(8.0e-5, 6), "8e-5");
        assert_eq!(short(-1.8e-10, 6), "-1.8e-10");
        assert_eq!(rel(f64::INFINITY), "∞");
        assert_eq!(seconds(Some(0.1534)), "0.153 s");
    }

    #[test]
    fn width_ignores_combining_marks() {
        assert_eq!(width("b̄1"), 2);
        assert_eq!(width("ω1"), 2);
    }

    #[test]
    fn table_aligns_groups() {
        let mut t = Table::new();
        t.group("", vec![Column::text("p")])
            .group("adaptive", vec![Column::num("est"), Column::num("err")]);
        t.row(["b̄1", "9.6", "1e-3"]).rule().row(["x", "10.25"]);
        let s = t.render();
        let lines: Vec<&str> = s.lines().collect();
        assert_eq!(lines.len(), 6);
        assert!(lines[0].ends_with("│  adaptive"), "{}", lines[0]);
        assert!(lines[2].chars().all(|c| c == '─'));
        // "b̄1" pads to the width of "p" column (2 chars).
        assert_eq!(lines[3], "b̄1 │   9.6  1e-3");
        assert_eq!(lines[5], "x  │ 10.25");
    }
}
