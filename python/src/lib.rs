//! `beamest._beamest`: the compiled half of the Python package `beamest`.
//!
//! Every function here calls beamctl's library, the code `beamctl
//! replay|simulate|crlb|model|monitor` runs: the options arrive as that
//! command's own argument list (built by the Python half from keyword
//! arguments, `beamest/_options.py`) and are parsed by the same clap
//! definitions, so names, defaults and checks are the CLI's. Reports come
//! back as the JSON text `--json` prints.
//!
//! Arrays are read in place when they are contiguous `float64` (the Python
//! half makes them so, copying only what is not); long runs release the
//! interpreter's lock and look for signals (Ctrl-C) between chunks of
//! [`CHUNK`] samples. Bad input raises `ValueError` (a bad value) or
//! `TypeError` (a wrong type, raised by PyO3's conversions), never a panic.

use beamctl::cli::args::ReplayArgs;
use beamctl::cli::replay::{self, ArrayOptions, EstimateLog, Stream};
use beamctl::error::EXIT_INTERRUPTED;
use beamctl::error::{CliError, EXIT_USAGE};
use numpy::{PyArray1, PyArrayMethods, PyReadonlyArray1, PyUntypedArrayMethods};
use pyo3::exceptions::{PyFileNotFoundError, PyRuntimeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};
use std::borrow::Cow;

mod link;
mod tools;

/// Samples stepped between two looks for a pending signal.
pub const CHUNK: usize = 1 << 16;

/// `--band-hz` → `band_hz`: flag names in messages as the keyword
/// arguments that set them.
pub(crate) fn python_names(message: &str) -> String {
    let mut out = String::with_capacity(message.len());
    let mut rest = message;
    while let Some(i) = rest.find("--") {
        out.push_str(&rest[..i]);
        let tail = &rest[i + 2..];
        let end = tail
            .find(|c: char| !(c.is_ascii_alphanumeric() || c == '-'))
            .unwrap_or(tail.len());
        if end == 0 {
            out.push_str("--");
        } else {
            out.push_str(&tail[..end].replace('-', "_"));
        }
        rest = &tail[end..];
    }
    out.push_str(rest);
    out
}

/// A beamctl error as the Python exception: a bad flag or input is a
/// `ValueError`, anything else a `RuntimeError`.
pub(crate) fn to_py(e: CliError) -> PyErr {
    let msg = python_names(&beamctl::error::one_line(&e.message));
    if e.code == EXIT_USAGE {
        PyValueError::new_err(msg)
    } else {
        PyRuntimeError::new_err(msg)
    }
}

/// Parse a command's argument list (`argv[0]` is the program name) with
/// its clap definition; the first line of clap's message, flags renamed.
pub(crate) fn parse<P: clap::Parser>(argv: Vec<String>) -> PyResult<P> {
    P::try_parse_from(argv).map_err(|e| {
        // clap's message up to its usage line, on one line.
        let text = e.render().to_string();
        let text = text.split("\nUsage:").next().unwrap_or("");
        let text = text.split("\nFor more information").next().unwrap_or("");
        let line = beamctl::error::one_line(text);
        let line = line.strip_prefix("error: ").unwrap_or(&line);
        PyValueError::new_err(python_names(line))
    })
}

/// `beamctl replay`'s options.
#[derive(clap::Parser)]
#[command(name = "replay")]
pub(crate) struct ReplayCmd {
    #[command(flatten)]
    args: ReplayArgs,
}

/// A 1-D float64 array's values: in place when contiguous, else copied.
pub(crate) fn values<'a>(a: &'a PyReadonlyArray1<'_, f64>) -> Cow<'a, [f64]> {
    match a.as_slice() {
        Ok(s) => Cow::Borrowed(s),
        Err(_) => Cow::Owned(a.as_array().iter().copied().collect()),
    }
}

/// One estimator's evaluations as a dict of numpy arrays.
fn log_dict<'py>(py: Python<'py>, log: EstimateLog) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    let n = log.len();
    let (modes, params) = (log.modes, log.params);
    d.set_item("sample", PyArray1::from_vec(py, log.sample))?;
    d.set_item("t", PyArray1::from_vec(py, log.t_s))?;
    d.set_item(
        "theta",
        PyArray1::from_vec(py, log.theta).reshape([n, params])?,
    )?;
    d.set_item(
        "omega",
        PyArray1::from_vec(py, log.omega).reshape([n, modes])?,
    )?;
    d.set_item(
        "zeta",
        PyArray1::from_vec(py, log.zeta).reshape([n, modes])?,
    )?;
    d.set_item(
        "bbar",
        PyArray1::from_vec(py, log.bbar).reshape([n, modes])?,
    )?;
    d.set_item("lambda_rad_s", PyArray1::from_vec(py, log.lambda_rad_s))?;
    d.set_item("validity", PyArray1::from_vec(py, log.validity))?;
    d.set_item("excited", PyArray1::from_vec(py, log.excited))?;
    Ok(d)
}

/// Look for a pending signal from a thread that does not hold the lock;
/// keep the exception it raised.
fn signalled(pending: &mut Option<PyErr>) -> bool {
    if let Err(e) = Python::attach(|py| py.check_signals()) {
        *pending = Some(e);
        true
    } else {
        false
    }
}

/// A [`beamctl::error::CliError`] as the Python exception: the pending
/// signal's (KeyboardInterrupt) for an interrupted run.
pub(crate) fn interrupted_or(e: CliError, pending: Option<PyErr>) -> PyErr {
    if e.code == EXIT_INTERRUPTED {
        pending.unwrap_or_else(|| PyRuntimeError::new_err("interrupted"))
    } else {
        to_py(e)
    }
}

/// `replay(argv, u, y, ts, label, log_hz)` → (JSON text of the list of
/// reports, one dict of arrays per estimator, per report the reason it
/// has no estimate or None: the message `beamctl replay` exits 1 with).
#[pyfunction]
#[pyo3(signature = (argv, u, y, ts, label, log_hz=None))]
fn replay_arrays<'py>(
    py: Python<'py>,
    argv: Vec<String>,
    u: PyReadonlyArray1<'py, f64>,
    y: PyReadonlyArray1<'py, f64>,
    ts: f64,
    label: String,
    log_hz: Option<f64>,
) -> PyResult<(String, Bound<'py, PyList>, Vec<Option<String>>)> {
    let args = parse::<ReplayCmd>(argv)?.args;
    if let Some(hz) = log_hz {
        if !(hz.is_finite() && hz > 0.0) {
            return Err(PyValueError::new_err(format!(
                "series_hz: must be a finite number > 0 (got {hz})"
            )));
        }
    }
    let (u, y) = (values(&u), values(&y));
    let (u, y): (&[f64], &[f64]) = (&u, &y);
    let mut pending: Option<PyErr> = None;
    let out = py.detach(|| {
        let mut interrupt = || signalled(&mut pending);
        replay::replay_arrays(
            &args,
            u,
            y,
            ArrayOptions {
                label,
                ts_s: ts,
                log_every: log_hz.map(|hz| replay::every_for_rate(hz, ts)),
                chunk: CHUNK,
                interrupt: &mut interrupt,
            },
        )
    });
    let out = out.map_err(|e| interrupted_or(e, pending))?;
    let json =
        serde_json::to_string(&out.reports).map_err(|e| PyRuntimeError::new_err(e.to_string()))?;
    let logs = PyList::empty(py);
    for l in out.logs {
        logs.append(log_dict(py, l)?)?;
    }
    let verdicts = out
        .reports
        .chunks(1)
        .map(|r| replay::require_estimates(r).err().map(|e| e.message))
        .collect();
    Ok((json, logs, verdicts))
}

/// The sample interval of a time column by `beamctl replay`'s rules.
#[pyfunction]
fn time_base(t: PyReadonlyArray1<'_, f64>) -> PyResult<f64> {
    let t = values(&t);
    beamctl::io::csv_in::time_base(&t)
        .map_err(|(i, m)| PyValueError::new_err(format!("t[{i}]: {m}")))
}

/// The measured FRF of a record (beamctl's `judge::frf::h1`, what
/// `--plot` draws): (f_hz, re, im, coherence, segments, segment_s), or
/// None when u has power at no frequency.
#[pyfunction]
#[pyo3(signature = (u, y, ts, segment_s=None))]
fn frf_h1<'py>(
    py: Python<'py>,
    u: PyReadonlyArray1<'py, f64>,
    y: PyReadonlyArray1<'py, f64>,
    ts: f64,
    segment_s: Option<f64>,
) -> PyResult<Option<Bound<'py, PyDict>>> {
    if let Some(s) = segment_s {
        if !(s.is_finite() && s > 0.0) {
            return Err(PyValueError::new_err(format!(
                "segment_s: must be a finite number > 0 s (got {s})"
            )));
        }
    }
    let (u, y) = (values(&u), values(&y));
    let (u, y): (&[f64], &[f64]) = (&u, &y);
    let Some(h) = py.detach(|| beamctl::judge::frf::h1(u, y, ts, segment_s)) else {
        return Ok(None);
    };
    let d = PyDict::new(py);
    d.set_item("f_hz", PyArray1::from_vec(py, h.f_hz))?;
    d.set_item("re", PyArray1::from_vec(py, h.re))?;
    d.set_item("im", PyArray1::from_vec(py, h.im))?;
    d.set_item("coherence", PyArray1::from_vec(py, h.coherence))?;
    d.set_item("segments", h.segments)?;
    d.set_item("segment_s", h.segment_s)?;
    Ok(Some(d))
}

/// u, y and Ts of a record.
type Samples<'py> = (Bound<'py, PyArray1<f64>>, Bound<'py, PyArray1<f64>>, f64);

/// Read a replay CSV with beamctl's reader: (u, y, ts).
#[pyfunction]
#[pyo3(signature = (path, columns=None, ts=None))]
fn read_replay_csv<'py>(
    py: Python<'py>,
    path: std::path::PathBuf,
    columns: Option<Vec<String>>,
    ts: Option<f64>,
) -> PyResult<Samples<'py>> {
    use beamctl::io::csv_in::{Columns, Reader};
    if !path.exists() {
        return Err(PyFileNotFoundError::new_err(format!(
            "no such file: {}",
            path.display()
        )));
    }
    if let Some(ts) = ts {
        if !(ts.is_finite() && ts > 0.0) {
            return Err(PyValueError::new_err(format!(
                "ts: the sample interval must be a finite number > 0 s (got {ts})"
            )));
        }
    }
    let cols = match (&columns, ts.is_some()) {
        (None, given) => Columns::default_for(given),
        (Some(c), false) if c.len() == 3 => Columns::named(Some(&c[0]), &c[1], &c[2]),
        (Some(c), true) if c.len() == 2 => Columns::named(None, &c[0], &c[1]),
        (Some(c), given) => {
            return Err(PyValueError::new_err(format!(
                "columns: expected {} names (got {})",
                if given {
                    "two, U,Y with ts,"
                } else {
                    "three, T,U,Y,"
                },
                c.len()
            )))
        }
    };
    let file_err = |e: beamctl::io::csv_in::CsvError| {
        PyValueError::new_err(format!("{}: {e}", path.display()))
    };
    let (u, y, ts) = py
        .detach(|| -> Result<_, beamctl::io::csv_in::CsvError> {
            let mut reader = Reader::open(&path, &cols, ts)?;
            let mut batch = Vec::with_capacity(replay::BATCH);
            let (mut u, mut y) = (Vec::new(), Vec::new());
            while reader.next_batch(&mut batch, replay::BATCH)? {
                u.extend(batch.iter().map(|s| s.0));
                y.extend(batch.iter().map(|s| s.1));
                batch.clear();
            }
            Ok((u, y, reader.ts_s()))
        })
        .map_err(file_err)?;
    Ok((PyArray1::from_vec(py, u), PyArray1::from_vec(py, y), ts))
}

/// The streaming estimator: beamctl's replay session fed chunk by chunk.
#[pyclass(module = "beamest._beamest")]
struct StreamCore {
    /// A mutex only to make the class `Sync` (PyO3 asks it of every
    /// class); `&mut self` reaches it without locking.
    inner: std::sync::Mutex<Stream>,
}

#[pymethods]
impl StreamCore {
    #[new]
    fn new(argv: Vec<String>, ts: f64, every: u64) -> PyResult<Self> {
        let args = parse::<ReplayCmd>(argv)?.args;
        if every == 0 {
            return Err(PyValueError::new_err("every: must be at least 1 sample"));
        }
        Ok(Self {
            inner: std::sync::Mutex::new(Stream::new(&args, ts, every).map_err(to_py)?),
        })
    }

    /// Step the chunk; the evaluations in it, one dict per estimator.
    fn feed<'py>(
        &mut self,
        py: Python<'py>,
        u: PyReadonlyArray1<'py, f64>,
        y: PyReadonlyArray1<'py, f64>,
    ) -> PyResult<Bound<'py, PyList>> {
        if u.len() != y.len() {
            return Err(PyValueError::new_err(format!(
                "y: u and y must have the same length (got {} and {})",
                u.len(),
                y.len()
            )));
        }
        let (u, y) = (values(&u), values(&y));
        let (u, y): (&[f64], &[f64]) = (&u, &y);
        let inner = self.inner.get_mut().map_err(|_| poisoned())?;
        let mut pending: Option<PyErr> = None;
        let logs = py.detach(|| {
            let mut logs: Option<Vec<EstimateLog>> = None;
            for (cu, cy) in u.chunks(CHUNK).zip(y.chunks(CHUNK)) {
                let got = inner.feed(cu, cy)?;
                match logs.as_mut() {
                    None => logs = Some(got),
                    Some(all) => {
                        for (a, g) in all.iter_mut().zip(got) {
                            append(a, g);
                        }
                    }
                }
                if signalled(&mut pending) {
                    break;
                }
            }
            Ok::<_, CliError>(logs)
        });
        let logs = logs.map_err(to_py)?;
        if let Some(e) = pending {
            return Err(e);
        }
        let out = PyList::empty(py);
        let logs = match logs {
            Some(l) => l,
            None => inner.feed(&[], &[]).map_err(to_py)?,
        };
        for l in logs {
            out.append(log_dict(py, l)?)?;
        }
        Ok(out)
    }

    /// Samples stepped so far.
    #[getter]
    fn samples(&self) -> PyResult<u64> {
        Ok(self.inner.lock().map_err(|_| poisoned())?.samples())
    }

    /// JSON text of the list of reports now; the model-output fit over
    /// `record` (`u`, `y`) when given.
    #[pyo3(signature = (label, u=None, y=None))]
    fn reports<'py>(
        &self,
        py: Python<'py>,
        label: &str,
        u: Option<PyReadonlyArray1<'py, f64>>,
        y: Option<PyReadonlyArray1<'py, f64>>,
    ) -> PyResult<String> {
        let record = match (&u, &y) {
            (Some(u), Some(y)) => Some((values(u), values(y))),
            (None, None) => None,
            (Some(_), None) => return Err(PyValueError::new_err("y: required with u")),
            (None, Some(_)) => return Err(PyValueError::new_err("u: required with y")),
        };
        let stream = &self.inner;
        let reports = py.detach(|| {
            let inner = stream.lock().map_err(|_| poisoned())?;
            inner
                .reports(label, record.as_ref().map(|(u, y)| replay::Record { u, y }))
                .map_err(to_py)
        })?;
        serde_json::to_string(&reports).map_err(|e| PyRuntimeError::new_err(e.to_string()))
    }
}

fn poisoned() -> PyErr {
    PyRuntimeError::new_err("the estimator's state was lost in an earlier failure")
}

/// Append `b`'s evaluations to `a`'s.
fn append(a: &mut EstimateLog, b: EstimateLog) {
    a.sample.extend(b.sample);
    a.t_s.extend(b.t_s);
    a.theta.extend(b.theta);
    a.omega.extend(b.omega);
    a.zeta.extend(b.zeta);
    a.bbar.extend(b.bbar);
    a.lambda_rad_s.extend(b.lambda_rad_s);
    a.validity.extend(b.validity);
    a.excited.extend(b.excited);
}

#[pymodule]
fn _beamest(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(replay_arrays, m)?)?;
    m.add_function(wrap_pyfunction!(time_base, m)?)?;
    m.add_function(wrap_pyfunction!(read_replay_csv, m)?)?;
    m.add_function(wrap_pyfunction!(frf_h1, m)?)?;
    m.add_class::<StreamCore>()?;
    tools::register(m)?;
    link::register(m)?;
    Ok(())
}
