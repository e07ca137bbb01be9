//! Whether a report's estimate can be trusted, from what the record itself
//! shows (no truth): `verdict: {trusted, reasons}` of every replay and
//! simulate report.
//!
//! # The checks (each failing one is a reason; trusted = none fails)
//! * **`no_estimate`**: the law produced no modal estimate.
//! * **`not_physical`**: the estimate fails the physical-validity test
//!   (ω > 0, 0 < ζ < 1, distinct modes; [`beamest::modal::Validity`]).
//! * **`no_fit`**: the model-output fit could not be computed (an unstable
//!   model, or no record to compute it on).
//! * **`residual_structured`**: the fit's residual ε = y − ŷ holds
//!   structure the model does not explain: its own past predicts more than
//!   1 − 1/[`RESIDUAL_GAIN_LIMIT`] of its power (an AR model of ε;
//!   [`crate::judge::fit::Fit::residual_prediction_gain`]) **and** that
//!   predictable part is more than [`RESIDUAL_STRUCTURE_LIMIT`] of y's RMS.
//!   Unmodelled dynamics (a mode above the band, an acceleration output's
//!   direct term), an offset or drift, a mains line or coloured noise all
//!   read so; a white residual (the model is right and the noise is white)
//!   reads a gain of 1 whatever the noise level, and a structured residual
//!   far below y's level (a noise-free record's round-off, a tiny model
//!   error) does not count.
//! * **`drifting`**: the estimate moved by more than [`DRIFT_LIMIT`] over
//!   the last 10% of the record (the report's `drift_last_10pct`).
//! * **`mode_not_excited`**: neither the input nor the record's initial
//!   motion reveals a reported mode: u has less than [`COVERAGE_LIMIT`] of
//!   its power (Welch spectrum) within an octave either side of it,
//!   [ω/2, 2ω], **and** the mode's fitted free response (a record that
//!   starts with the beam moving) holds less than [`FREE_RESPONSE_SHARE`]
//!   of y's energy about its mean. Such a mode is
//!   reported as not identifiable (`identifiable[i]` false) rather than as
//!   estimated, however well the model fits. (On a record that holds
//!   exactly the model's modes the response far from a mode still carries
//!   information on it; on a real structure that part of the response
//!   belongs to modes the model does not have.)

//! * **`line_near_mode`**: a narrow line that u does not drive stands out
//!   of the residual's spectrum within a reported mode's band,
//!   ω(1 ± max(2ζ, 2Δf/f)) (Δf the spectrum's bin spacing): a mode under it
//!   cannot be told from it. A line is a residual bin at [`LINE_RATIO`]
//!   times its neighbourhood's median ([`PowerSpectrum::lines`]), with an
//!   RMS of at least [`LINE_LEVEL`] of y's, where u has no line of its own
//!   (a line of u by the same test with at least [`COVERAGE_LIMIT`] of its
//!   power within two bins: a residual line at one of u's lines is model
//!   error, which `residual_structured` judges; a broadband u such as a
//!   chirp through 50 Hz has no line there), and that stands out of the
//!   spectrum of each half of the record as well (a disturbance is there
//!   throughout; a peak of one half only is a transient, e.g. a model that
//!   is wrong near a mode while a sweep passes it). Every
//!   line found is listed (`lines`: frequency, RMS, the mode it lies on),
//!   near a mode or not.

use crate::judge::fit::{self, Fit, Model};
use crate::judge::frf::PowerSpectrum;
use serde::Serialize;

/// `residual_structured` when the residual's prediction gain exceeds this
/// (its past predicts more than 20% of its power)...
pub const RESIDUAL_GAIN_LIMIT: f64 = 1.25;
/// ...and the predictable part's RMS exceeds this share of y's RMS.
pub const RESIDUAL_STRUCTURE_LIMIT: f64 = 1e-2;
/// `drifting` above this `drift_last_10pct`.
pub const DRIFT_LIMIT: f64 = 1e-2;
/// A residual spectrum's bin at this many times its neighbourhood's median
/// is a line (20 dB; the Welch average of white noise over 2 or more
/// segments gets there with a probability below 1e-6 per bin).
pub const LINE_RATIO: f64 = 100.0;

/// The strongest lines listed in a verdict (a record with many, e.g. one
/// cut and pasted, lists these and one reason per mode).
pub const MAX_LINES: usize = 16;

/// A residual line counts from this RMS ÷ y's RMS.
pub const LINE_LEVEL: f64 = 1e-3;

/// `mode_not_excited` below this share of u's power in [ω/2, 2ω]...
pub const COVERAGE_LIMIT: f64 = 1e-6;
/// ...unless the mode's fitted free response holds this share of
/// Σ (y − ȳ)².
pub const FREE_RESPONSE_SHARE: f64 = 1e-2;

/// One failed check.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Reason {
    /// `no_estimate`, `not_physical`, `no_fit`, `residual_structured`,
    /// `drifting` or `mode_not_excited` (module docs).
    pub code: &'static str,
    /// The evidence, in words and numbers.
    pub detail: String,
}

/// A narrow line found in the residual.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct LineFound {
    /// Frequency (Hz) of its spectrum's peak bin.
    pub freq_hz: f64,
    /// Its RMS (units of y).
    pub rms: f64,
    /// The reported mode (1-based) whose band it lies in, if any.
    pub near_mode: Option<usize>,
}

/// The verdict on one estimator's report.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Verdict {
    /// No check failed.
    pub trusted: bool,
    /// The failed checks, in the order of the module docs.
    pub reasons: Vec<Reason>,
    /// Per reported mode: the input has power near it (see
    /// `mode_not_excited`); empty without an estimate or an input spectrum.
    pub identifiable: Vec<bool>,
    /// Per reported mode: the share of u's power in [ω/2, 2ω].
    pub input_power_near_mode: Vec<f64>,
    /// Per reported mode: the energy of its fitted free response ÷
    /// Σ (y − ȳ)² (0 without a fit).
    pub free_response_share: Vec<f64>,
    /// [`Fit::residual_prediction_gain`], if there is a fit.
    pub residual_prediction_gain: Option<f64>,
    /// RMS of the residual's predictable part ÷ RMS of y about its mean,
    /// if there is a fit.
    pub residual_structure: Option<f64>,
    /// The narrow lines in the residual, strongest first (at most
    /// [`MAX_LINES`]).
    pub lines: Vec<LineFound>,
}

/// What the verdict is formed from.
#[derive(Debug, Clone, Copy)]
pub struct Evidence<'a> {
    /// The final estimate's ω_i (rad/s), `None` without an estimate.
    pub omega: Option<&'a [f64]>,
    /// Its ζ_i.
    pub zeta: &'a [f64],
    /// Its physical-validity flags (empty: valid).
    pub validity: &'a [&'static str],
    /// The model-output fit over the record.
    pub fit: Option<&'a Fit>,
    /// The report's `drift_last_10pct`.
    pub drift: Option<f64>,
    /// The record's input spectrum.
    pub input: Option<&'a PowerSpectrum>,
    /// The fit's residual spectra ([`residual_spectrum`]).
    pub residual: Option<&'a ResidualSpectrum>,
}

/// What a record tells about an estimate: its model-output fit, the
/// input's spectrum and the fit residual's spectrum.
#[derive(Debug, Clone, Copy, Default)]
pub struct RecordEvidence<'a> {
    /// The model-output fit.
    pub fit: Option<&'a Fit>,
    /// The input's spectrum.
    pub input: Option<&'a PowerSpectrum>,
    /// The fit residual's spectra ([`residual_spectrum`]).
    pub residual: Option<&'a ResidualSpectrum>,
}

/// The spectrum of a fit's residual over the record, and over each half
/// of it (a line counts only where both halves show it: see
/// `line_near_mode` in the module docs).
#[derive(Debug, Clone)]
pub struct ResidualSpectrum {
    /// Over the whole record.
    pub whole: PowerSpectrum,
    /// Over its first and its second half (`None` for a record too short
    /// to split).
    pub halves: Option<[PowerSpectrum; 2]>,
}

impl ResidualSpectrum {
    /// Whether a narrow line at `freq_hz` stands out of both halves (true
    /// when there are no halves).
    fn steady(&self, freq_hz: f64) -> bool {
        self.halves
            .as_ref()
            .is_none_or(|h| h.iter().all(|s| s.has_line_at(freq_hz, LINE_RATIO)))
    }
}

/// The spectra of the residual of `fit` (of `model`) over the `n` samples
/// `samples` yields.
pub fn residual_spectrum<I: IntoIterator<Item = (f64, f64)>>(
    model: &Model,
    fit: &Fit,
    samples: I,
    n: usize,
    ts_s: f64,
) -> Option<ResidualSpectrum> {
    let r: Vec<f64> = fit::residuals(model, fit, samples).take(n).collect();
    let whole = PowerSpectrum::of(r.iter().copied(), r.len(), ts_s)?;
    let half = r.len() / 2;
    let halves = match (
        PowerSpectrum::of(r[..half].iter().copied(), half, ts_s),
        PowerSpectrum::of(r[half..].iter().copied(), r.len() - half, ts_s),
    ) {
        (Some(a), Some(b)) => Some([a, b]),
        _ => None,
    };
    Some(ResidualSpectrum { whole, halves })
}

impl Verdict {
    /// Run every check of the module docs on `e`.
    pub fn of(e: &Evidence<'_>) -> Self {
        let mut reasons = Vec::new();
        let has_estimate = e.omega.is_some();
        if !has_estimate {
            reasons.push(Reason {
                code: "no_estimate",
                detail: "the law produced no modal estimate".into(),
            });
        } else if !e.validity.is_empty() {
            reasons.push(Reason {
                code: "not_physical",
                detail: format!(
                    "the estimate is not a physical beam ({})",
                    e.validity.join(", ")
                ),
            });
        }
        let (gain, structure) = match e.fit {
            Some(f) => {
                let gain = f.residual_prediction_gain;
                let residual_share = (1.0 - f.percent / 100.0).max(0.0);
                let structure = residual_share * (1.0 - 1.0 / gain.max(1.0)).sqrt();
                (Some(gain), Some(structure))
            }
            None => (None, None),
        };
        match (gain, structure) {
            (Some(g), Some(s)) if g > RESIDUAL_GAIN_LIMIT && s > RESIDUAL_STRUCTURE_LIMIT => {
                reasons.push(Reason {
                    code: "residual_structured",
                    detail: format!(
                        "the residual y − ŷ is not white: its own past predicts {:.0}% of its power, \
                         {:.2e} of y's RMS (unmodelled dynamics, an offset or drift, a line, or coloured noise)",
                        100.0 * (1.0 - 1.0 / g),
                        s
                    ),
                });
            }
            (None, _) if has_estimate => reasons.push(Reason {
                code: "no_fit",
                detail: "no model-output fit (an unstable model, or no record)".into(),
            }),
            _ => {}
        }
        if let Some(d) = e.drift.filter(|d| *d > DRIFT_LIMIT) {
            reasons.push(Reason {
                code: "drifting",
                detail: format!(
                    "the estimate moved by {:.2e} over the last 10% of the record",
                    d
                ),
            });
        }
        let mut identifiable = Vec::new();
        let mut near = Vec::new();
        let mut free = Vec::new();
        if let (Some(omega), Some(input)) = (e.omega, e.input) {
            for (i, &w) in omega.iter().enumerate() {
                let f_hz = w / (2.0 * std::f64::consts::PI);
                let share = input.share(f_hz / 2.0, 2.0 * f_hz).unwrap_or(0.0);
                let free_share = e.fit.map_or(0.0, |f| free_response_share(f, w));
                let revealed = share >= COVERAGE_LIMIT || free_share >= FREE_RESPONSE_SHARE;
                near.push(share);
                free.push(free_share);
                identifiable.push(revealed);
                if !revealed {
                    reasons.push(Reason {
                        code: "mode_not_excited",
                        detail: format!(
                            "mode {} ({:.4} Hz): the input has {:.1e} of its power within an octave of it \
                             and the initial motion does not reveal it (free response {:.1e} of y's energy); \
                             not identifiable from this record",
                            i + 1,
                            f_hz,
                            share,
                            free_share
                        ),
                    });
                }
            }
        }
        let mut lines = Vec::new();
        if let (Some(spectra), Some(f)) = (e.residual, e.fit) {
            let spectrum = &spectra.whole;
            let df = spectrum.bin_hz();
            let y_rms = f.residual_rms / (1.0 - f.percent / 100.0).max(f64::MIN_POSITIVE);
            for (freq_hz, share) in spectrum.lines(LINE_RATIO) {
                let rms = share.sqrt() * f.residual_rms;
                let driven = e.input.is_some_and(|u| {
                    u.share(freq_hz - 2.0 * df, freq_hz + 2.0 * df)
                        .is_some_and(|s| s >= COVERAGE_LIMIT)
                        && u.has_line_at(freq_hz, LINE_RATIO)
                });
                if driven || rms < LINE_LEVEL * y_rms || !spectra.steady(freq_hz) {
                    continue;
                }
                let near_mode = e.omega.and_then(|omega| {
                    omega.iter().zip(e.zeta).position(|(&w, &z)| {
                        let f_mode = w / std::f64::consts::TAU;
                        let half = f_mode * (2.0 * z.abs()).max(2.0 * df / f_mode);
                        (freq_hz - f_mode).abs() <= half
                    })
                });
                if lines.len() == MAX_LINES {
                    break;
                }
                let first_on_mode = near_mode
                    .is_some_and(|i| !lines.iter().any(|l: &LineFound| l.near_mode == Some(i + 1)));
                if let (Some(i), true) = (near_mode, first_on_mode) {
                    reasons.push(Reason {
                        code: "line_near_mode",
                        detail: format!(
                            "a narrow line at {freq_hz:.4} Hz in the residual, where u has none, lies in mode {}'s band \
                             (a disturbance such as the mains, or a mode the model gets wrong)",
                            i + 1
                        ),
                    });
                }
                lines.push(LineFound {
                    freq_hz,
                    rms,
                    near_mode: near_mode.map(|i| i + 1),
                });
            }
        }
        Self {
            trusted: reasons.is_empty(),
            reasons,
            identifiable,
            input_power_near_mode: near,
            free_response_share: free,
            lines,
            residual_prediction_gain: gain,
            residual_structure: structure,
        }
    }

    /// "yes" or "no: code, code" (each code once).
    pub fn summary(&self) -> String {
        if self.trusted {
            return "yes".into();
        }
        let mut codes: Vec<&str> = self.reasons.iter().map(|r| r.code).collect();
        codes.dedup();
        format!("no: {}", codes.join(", "))
    }
}

/// Energy of the fitted free response of the model's mode nearest `omega`
/// (in log ω) ÷ Σ (y − ȳ)².
fn free_response_share(f: &Fit, omega: f64) -> f64 {
    let nearest = f.free_response.iter().min_by(|a, b| {
        let d = |w: f64| (w / omega).ln().abs();
        d(a.0).total_cmp(&d(b.0))
    });
    match nearest {
        Some(&(_, energy)) => energy / f.output_energy.max(f64::MIN_POSITIVE),
        None => 0.0,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn fit(percent: f64, gain: f64) -> Fit {
        Fit {
            percent,
            initial: Vec::new(),
            residual_rms: 1.0,
            residual_prediction_gain: gain,
            free_response: Vec::new(),
            output_energy: 1.0,
        }
    }

    /// A multisine's lines at 400–800 Hz and a PRBS-like flat input.
    fn spectra() -> (PowerSpectrum, PowerSpectrum) {
        let ts = 1e-4;
        let n = 100_000;
        let lines = (0..n).map(|k| {
            let t = k as f64 * ts;
            (1..=5)
                .map(|j| (2.0 * std::f64::consts::PI * (300.0 + 100.0 * j as f64) * t).sin())
                .sum::<f64>()
        });
        let mut state = 0x2545_f491_4f6c_dd1du64;
        let flat = (0..n).map(move |_| {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            if state & 1 == 0 {
                1.0
            } else {
                -1.0
            }
        });
        (
            PowerSpectrum::of(lines, n, ts).unwrap(),
            PowerSpectrum::of(flat, n, ts).unwrap(),
        )
    }

    #[test]
    fn a_good_estimate_on_a_covering_input_is_trusted() {
        let (_, flat) = spectra();
        let est = [50.0, 280.0];
        let v = Verdict::of(&Evidence {
            omega: Some(&est),
            validity: &[],
            fit: Some(&fit(99.0, 1.001)),
            drift: Some(1e-4),
            input: Some(&flat),
            zeta: &[0.02, 0.02],
            residual: None,
        });
        assert!(v.trusted, "{v:?}");
        assert_eq!(v.identifiable, vec![true, true]);
        assert_eq!(v.summary(), "yes");
    }

    #[test]
    fn modes_the_input_does_not_reach_are_not_identifiable() {
        let (lines, _) = spectra();
        // 8 and 45 Hz, lines only at 400–800 Hz; mode 3 at 600 Hz is reached.
        let est = [50.0, 282.0, 3770.0];
        let v = Verdict::of(&Evidence {
            omega: Some(&est),
            validity: &[],
            fit: Some(&fit(99.9, 1.0)),
            drift: Some(0.0),
            input: Some(&lines),
            zeta: &[0.02; 3],
            residual: None,
        });
        assert!(!v.trusted);
        assert_eq!(v.identifiable, vec![false, false, true]);
        let codes: Vec<_> = v.reasons.iter().map(|r| r.code).collect();
        assert_eq!(codes, ["mode_not_excited", "mode_not_excited"]);
        assert!(v.input_power_near_mode[0] < 1e-9 && v.input_power_near_mode[2] > 0.1);
        // A record that starts with mode 1 ringing reveals it.
        let moving = Fit {
            free_response: vec![(50.0, 0.5), (282.0, 1e-3)],
            ..fit(99.9, 1.0)
        };
        let v = Verdict::of(&Evidence {
            omega: Some(&est),
            validity: &[],
            fit: Some(&moving),
            drift: Some(0.0),
            input: Some(&lines),
            zeta: &[0.02; 3],
            residual: None,
        });
        assert_eq!(v.identifiable, vec![true, false, true]);
    }

    #[test]
    fn structure_counts_only_when_it_is_a_visible_part_of_y() {
        let est = [50.0];
        let with = |f: Fit| {
            Verdict::of(&Evidence {
                omega: Some(&est),
                validity: &[],
                fit: Some(&f),
                drift: None,
                input: None,
                zeta: &[0.02],
                residual: None,
            })
        };
        // A white residual at a low SNR: trusted.
        assert!(with(fit(10.0, 1.01)).trusted);
        // A structured residual of 1e-4 of y (noise-free round-off): trusted.
        assert!(with(fit(99.99, 1e4)).trusted);
        // A structured residual of 30% of y: not.
        let v = with(fit(70.0, 50.0));
        assert_eq!(v.summary(), "no: residual_structured");
        assert!((v.residual_structure.unwrap() - 0.3 * (1.0f64 - 1.0 / 50.0).sqrt()).abs() < 1e-12);
    }

    /// White noise of σ 1 with a 50 Hz line of RMS 0.3: found
    /// at 50 Hz with its RMS; the noise alone has none.
    #[test]
    fn a_line_in_the_residual_is_found_and_white_noise_has_none() {
        let ts = 1e-4;
        let n = 200_000;
        let white = || {
            let mut g = beamest::rig::GaussianNoise::<f64>::new(1.0, 5).unwrap();
            (0..n).map(move |_| g.sample())
        };
        let plain = PowerSpectrum::of(white(), n, ts).unwrap();
        assert!(
            plain.lines(LINE_RATIO).is_empty(),
            "{:?}",
            plain.lines(LINE_RATIO)
        );
        let amp = 0.3 * std::f64::consts::SQRT_2;
        let hum = white()
            .enumerate()
            .map(|(k, w)| w + amp * (std::f64::consts::TAU * 50.0 * k as f64 * ts).sin());
        let hum: Vec<f64> = hum.collect();
        let halves = |x: &[f64]| {
            let h = x.len() / 2;
            Some([
                PowerSpectrum::of(x[..h].iter().copied(), h, ts).unwrap(),
                PowerSpectrum::of(x[h..].iter().copied(), x.len() - h, ts).unwrap(),
            ])
        };
        let s = PowerSpectrum::of(hum.iter().copied(), n, ts).unwrap();
        let spectra = ResidualSpectrum {
            whole: s.clone(),
            halves: halves(&hum),
        };
        let lines = s.lines(LINE_RATIO);
        assert_eq!(lines.len(), 1, "{lines:?}");
        assert!((lines[0].0 - 50.0).abs() <= s.bin_hz(), "{lines:?}");
        // RMS 0.3 of a total RMS √(1 + 0.09): share 0.09/1.09, less the
        // noise's part of the three bins.
        assert!((lines[0].1 / (0.09 / 1.09) - 1.0).abs() < 0.05, "{lines:?}");
        // A mode at 50 Hz under it is named; one at 80 Hz is not.
        let fit = Fit {
            percent: 0.0,
            ..fit(0.0, 1.0)
        };
        let v = |w: f64| {
            Verdict::of(&Evidence {
                omega: Some(&[w]),
                zeta: &[0.02],
                validity: &[],
                fit: Some(&fit),
                drift: None,
                input: None,
                residual: Some(&spectra),
            })
        };
        let near = v(std::f64::consts::TAU * 50.0);
        assert_eq!(near.lines[0].near_mode, Some(1));
        assert!(near.reasons.iter().any(|r| r.code == "line_near_mode"));
        // The same line in the first half only (a transient: a mode the
        // model gets wrong while a sweep passes it) is not a line.
        let transient: Vec<f64> = white()
            .enumerate()
            .map(|(k, w)| {
                let t = k as f64 * ts;
                w + if k < n / 2 {
                    2.0 * amp * (std::f64::consts::TAU * 50.0 * t).sin()
                } else {
                    0.0
                }
            })
            .collect();
        let passing = ResidualSpectrum {
            whole: PowerSpectrum::of(transient.iter().copied(), n, ts).unwrap(),
            halves: halves(&transient),
        };
        assert!(!passing.whole.lines(LINE_RATIO).is_empty());
        let once = Verdict::of(&Evidence {
            omega: Some(&[std::f64::consts::TAU * 50.0]),
            zeta: &[0.02],
            validity: &[],
            fit: Some(&fit),
            drift: None,
            input: None,
            residual: Some(&passing),
        });
        assert!(once.lines.is_empty() && once.trusted, "{once:?}");
        let far = v(std::f64::consts::TAU * 80.0);
        assert_eq!(far.lines[0].near_mode, None);
        assert!(
            (far.lines[0].rms / 0.3 - 1.0).abs() < 0.05,
            "{:?}",
            far.lines
        );
    }

    #[test]
    fn no_estimate_invalid_and_drifting_are_reasons() {
        let est = [50.0];
        let v = Verdict::of(&Evidence {
            omega: Some(&est),
            validity: &["zeta_out_of_range"],
            fit: None,
            drift: Some(0.05),
            input: None,
            zeta: &[0.02],
            residual: None,
        });
        assert_eq!(v.summary(), "no: not_physical, no_fit, drifting");
        let v = Verdict::of(&Evidence {
            omega: None,
            validity: &["not_recovered"],
            fit: None,
            drift: None,
            input: None,
            zeta: &[0.02],
            residual: None,
        });
        assert_eq!(v.summary(), "no: no_estimate");
    }
}
