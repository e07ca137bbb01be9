//! The serial link from Python: the core's stream decoder
//! ([`beam_protocol::decoder::Decoder`], the one `beamctl monitor` uses)
//! fed with bytes, each frame handed out as a dict of its fields (the
//! Python half turns them into dataclasses, `beamest/link.py`), and
//! commands encoded from `beamctl send`'s grammar.

use beam_protocol::decoder::Decoder;
use beam_protocol::{Frame, Message, Status};
use beamctl::link::{grammar, text};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::{PyBytes, PyDict, PyList};

/// The decoder and the last Status it delivered.
#[pyclass(module = "beamest._beamest")]
struct DecoderCore {
    decoder: Decoder,
    status: Option<Status>,
    keep_errors: bool,
    /// Bytes after the last delimiter (a frame cut short so far).
    partial: u64,
}

fn f32s(v: impl IntoIterator<Item = f32>) -> Vec<f64> {
    v.into_iter().map(f64::from).collect()
}

fn frame_dict<'py>(py: Python<'py>, f: &Frame) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("seq", f.seq)?;
    match &f.message {
        Message::Estimate(e) => {
            d.set_item("kind", "estimate")?;
            d.set_item("sample_index", e.sample_index)?;
            d.set_item("estimator", e.estimator.name())?;
            d.set_item("flags", e.flags.0)?;
            d.set_item("flag_names", text::flag_names(e.flags))?;
            d.set_item("omega", f32s(e.modes.iter().map(|m| m.omega_rad_s)))?;
            d.set_item("zeta", f32s(e.modes.iter().map(|m| m.zeta)))?;
            d.set_item("bbar", f32s(e.modes.iter().map(|m| m.b_bar)))?;
            d.set_item("lambda_rad_s", f64::from(e.lambda_rad_s))?;
            d.set_item("theta", f32s(e.theta.iter().copied()))?;
            d.set_item("excitation_level", e.excitation_level.map(f64::from))?;
        }
        Message::RawSamples(r) => {
            d.set_item("kind", "raw")?;
            d.set_item("first_sample_index", r.first_sample_index)?;
            d.set_item("decimation", r.decimation)?;
            d.set_item("u", f32s(r.samples.iter().map(|s| s.u_v)))?;
            d.set_item("y", f32s(r.samples.iter().map(|s| s.y)))?;
        }
        Message::Status(s) => {
            d.set_item("kind", "status")?;
            d.set_item("uptime_samples", s.uptime_samples)?;
            d.set_item("sample_rate_hz", f64::from(s.sample_rate_hz))?;
            let fw = s.firmware;
            d.set_item(
                "firmware",
                format!("{}.{}.{}", fw.major, fw.minor, fw.patch),
            )?;
            d.set_item("modes", s.modes)?;
            let c = &s.counters;
            let counters = PyDict::new(py);
            for (k, v) in c.named() {
                counters.set_item(k, v)?;
            }
            d.set_item("counters", counters)?;
            d.set_item("adaptation_frozen", s.adaptation_frozen)?;
            d.set_item("waveform", s.excitation.waveform.kind().name())?;
            d.set_item(
                "waveform_params",
                text::waveform_params(&s.excitation.waveform),
            )?;
            d.set_item("amplitude_v", f64::from(s.excitation.amplitude_v))?;
            d.set_item("offset_v", f64::from(s.excitation.offset_v))?;
            let e = &s.estimator;
            d.set_item("estimator", e.kind.name())?;
            d.set_item("gain", f64::from(e.gain))?;
            d.set_item("forgetting_p", f64::from(e.forgetting_p))?;
            d.set_item("forgetting_h", f64::from(e.forgetting_h))?;
            d.set_item("initial_gain", f64::from(e.initial_gain))?;
            d.set_item("lambda_rad_s", e.lambda_rad_s.map(f64::from))?;
            d.set_item("output", e.output.name())?;
            let t = &s.telemetry;
            d.set_item("estimate_rate_hz", f64::from(t.estimate_rate_hz))?;
            d.set_item("raw_decimation", t.raw_decimation)?;
            d.set_item("status_rate_hz", f64::from(t.status_rate_hz))?;
            d.set_item("lambda_automatic", s.lambda_automatic)?;
            d.set_item("self_test", text::self_test_state_text(s.self_test))?;
        }
        Message::Ack(a) => {
            d.set_item("kind", "ack")?;
            d.set_item("command_seq", a.command_seq)?;
            d.set_item("result", text::result_name(a.result))?;
            d.set_item("detail", text::result_text(a.result))?;
        }
        Message::SelfTestReport(r) => {
            let names = |c: beam_protocol::SelfTestChecks| {
                beam_protocol::SelfTestChecks::ALL
                    .iter()
                    .filter(|(b, _)| c.contains(*b))
                    .map(|(_, n)| *n)
                    .collect::<Vec<_>>()
            };
            d.set_item("kind", "selftest")?;
            d.set_item("first_sample", r.first_sample)?;
            d.set_item("last_sample", r.last_sample)?;
            d.set_item("at_boot", r.at_boot)?;
            d.set_item("passed", r.passed())?;
            d.set_item("failed", names(r.failed))?;
            d.set_item("not_measured", names(r.not_measured))?;
            d.set_item("adc_id", r.adc.id)?;
            d.set_item("adc_registers", r.adc.registers.to_vec())?;
            d.set_item("adc_expected", r.adc.expected.to_vec())?;
            let f = |v: f32| f64::from(v);
            let dr = &r.drdy;
            d.set_item("drdy_rate_hz", f(dr.rate_hz))?;
            d.set_item("drdy_expected_hz", f(dr.expected_hz))?;
            d.set_item("drdy_tolerance", f(dr.tolerance))?;
            d.set_item("conversions", dr.conversions)?;
            d.set_item("ticks", dr.ticks)?;
            let l = &r.loopback;
            for (k, v) in [
                ("tone_hz", l.tone_hz),
                ("tone_amplitude_v", l.amplitude_v),
                ("loopback_gain", l.gain),
                ("expected_gain", l.expected_gain),
                ("gain_tolerance", l.gain_tolerance),
                ("offset_v", l.offset_v),
                ("offset_tolerance_v", l.offset_tolerance_v),
                ("delay_samples", l.delay_samples),
                ("expected_delay_samples", l.expected_delay_samples),
                ("delay_tolerance_samples", l.delay_tolerance_samples),
                ("noise_sd", r.noise.noise_sd),
                ("floor_sd", r.noise.floor_sd),
                ("signal_rms", r.noise.signal_rms),
                ("snr_db", r.noise.snr_db),
                ("snr_min_db", r.noise.snr_min_db),
            ] {
                d.set_item(k, f(v))?;
            }
            d.set_item("excitation", grammar::excitation_text(&r.noise.excitation))?;
        }
        Message::Command(c) => {
            d.set_item("kind", "command_echo")?;
            d.set_item("command", grammar::command_text(c))?;
        }
    }
    Ok(d)
}

#[pymethods]
impl DecoderCore {
    #[new]
    #[pyo3(signature = (joining=false, keep_errors=false))]
    fn new(joining: bool, keep_errors: bool) -> Self {
        Self {
            decoder: if joining {
                Decoder::joining()
            } else {
                Decoder::new()
            },
            status: None,
            keep_errors,
            partial: 0,
        }
    }

    /// Feed bytes; the frames they completed, in order, as dicts (and,
    /// with `keep_errors`, one `{"kind": "error", "detail": …}` per frame
    /// dropped).
    fn feed<'py>(&mut self, py: Python<'py>, data: &[u8]) -> PyResult<Bound<'py, PyList>> {
        let out = PyList::empty(py);
        for r in self.decoder.feed(data) {
            match r {
                Ok(f) => {
                    if let Message::Status(s) = &f.message {
                        self.status = Some(s.clone());
                    }
                    out.append(frame_dict(py, &f)?)?;
                }
                Err(e) if self.keep_errors => {
                    let d = PyDict::new(py);
                    d.set_item("kind", "error")?;
                    d.set_item("detail", e.to_string())?;
                    out.append(d)?;
                }
                Err(_) => {}
            }
        }
        self.partial = match data.iter().rposition(|&b| b == beam_protocol::DELIMITER) {
            Some(p) => (data.len() - p - 1) as u64,
            None => self.partial + data.len() as u64,
        };
        Ok(out)
    }

    /// The link counters as a dict.
    fn counters<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let c = self.decoder.counters();
        let d = PyDict::new(py);
        for (k, v) in [
            ("bytes", c.bytes),
            ("skipped_bytes", c.skipped_bytes),
            ("frames_ok", c.frames_ok),
            ("crc_errors", c.crc_errors),
            ("framing_errors", c.framing_errors),
            ("oversize", c.oversize),
            ("malformed", c.malformed),
            ("version_mismatches", c.version_mismatches),
            ("lost", c.lost),
            ("duplicates", c.duplicates),
            ("out_of_order", c.out_of_order),
            ("errors", c.errors()),
            ("partial_bytes", self.partial),
        ] {
            d.set_item(k, v)?;
        }
        Ok(d)
    }

    /// True once a Status has been decoded (commands can then take the
    /// settings they do not give from it).
    #[getter]
    fn has_status(&self) -> bool {
        self.status.is_some()
    }

    /// `encode_command` with the settings not given taken from this
    /// decoder's last Status.
    fn encode_command<'py>(
        &self,
        py: Python<'py>,
        line: &str,
        seq: u32,
    ) -> PyResult<Bound<'py, PyBytes>> {
        encode(py, line, seq, self.status.as_ref())
    }
}

fn encode<'py>(
    py: Python<'py>,
    line: &str,
    seq: u32,
    status: Option<&Status>,
) -> PyResult<Bound<'py, PyBytes>> {
    let args =
        grammar::parse_line(line).map_err(|e| PyValueError::new_err(format!("command: {e}")))?;
    let command = args
        .build(status)
        .map_err(|e| PyValueError::new_err(format!("command: {e}")))?;
    let mut buf = [0u8; beam_protocol::MAX_ENCODED_LEN];
    let n = beam_protocol::frame::encode(&command, seq, &mut buf)
        .map_err(|e| PyValueError::new_err(format!("command: {e}")))?;
    let mut bytes = Vec::with_capacity(n + 1);
    bytes.push(beam_protocol::DELIMITER);
    bytes.extend_from_slice(&buf[..n]);
    Ok(PyBytes::new(py, &bytes))
}

/// The bytes of one host → device command frame (a leading delimiter,
/// then the frame), from a `beamctl send` command line.
#[pyfunction]
#[pyo3(signature = (line, seq=0))]
fn encode_command<'py>(py: Python<'py>, line: &str, seq: u32) -> PyResult<Bound<'py, PyBytes>> {
    encode(py, line, seq, None)
}

pub(crate) fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<DecoderCore>()?;
    m.add_function(wrap_pyfunction!(encode_command, m)?)?;
    Ok(())
}
