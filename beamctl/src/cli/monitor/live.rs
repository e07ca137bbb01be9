//! The verdict on a live stream: the checks of [`crate::judge::verdict`]
//! (the same rules, limits and reason codes as a replay's report) applied
//! to the last estimate over a window of the stream's recent past.
//!
//! What a window holds:
//! * the raw sample pairs (u, y) of the last [`LiveVerdict::window_s`]
//!   seconds, as the estimator received them, when the device sends every
//!   sample (raw decimation 1) without a gap: a model-output fit needs every
//!   sample. A gap in the sample index, or decimated pairs, restart the
//!   window;
//! * every estimate's ω̂, ζ̂ over the same span, for the drift indicator
//!   ([`crate::judge::drift`]): the last tenth of the window.
//!
//! The estimate's model is its own Θ̂ and λ (PROTOCOL.md §4.0): the
//! verdict needs nothing the stream does not carry. Without raw pairs at
//! full rate the fit, the residual and the input's spectrum are missing:
//! the verdict then reads `no_fit` with the reason, and the coverage and
//! line checks are not made.

use crate::judge::drift::History;
use crate::judge::fit::{self, Model};
use crate::judge::frf::PowerSpectrum;
use crate::judge::verdict::{residual_spectrum, Evidence, Verdict};
use beam_protocol::{Estimate, RawSamples, StatusFlags};
use beamest::model::TransferFunction;
use std::collections::VecDeque;

/// The window's default length (s of device time).
pub const DEFAULT_WINDOW_S: f64 = 10.0;

/// A verdict is formed at most once per this much device time (s): a fit
/// over the window costs O(window) per verdict.
pub const VERDICT_EVERY_S: f64 = 1.0;

/// The name of the validity check the device's flag stands for: the device
/// sends whether its estimate is physically valid, not which test failed.
const DEVICE_SAYS_NOT_PHYSICAL: &str = "device_flag_not_physically_valid";

/// The stream's recent past and the verdict on the last estimate.
#[derive(Debug)]
pub struct LiveVerdict {
    window_s: f64,
    /// Consecutive full-rate pairs, oldest first.
    pairs: VecDeque<(f64, f64)>,
    /// The sample index of the pair that would come next.
    next_index: Option<u64>,
    /// The last raw block was decimated (no fit can be made).
    decimated: bool,
    /// The window restarted because of a gap in the sample index.
    gaps: u64,
    history: History,
    /// The last verdict and the sample index of its estimate.
    last: Option<(u64, Verdict)>,
}

impl LiveVerdict {
    /// A window of `window_s` seconds (> 0) of device time.
    pub fn new(window_s: f64) -> Self {
        Self {
            window_s,
            pairs: VecDeque::new(),
            next_index: None,
            decimated: false,
            gaps: 0,
            history: History::default(),
            last: None,
        }
    }

    /// The window's length (s).
    pub fn window_s(&self) -> f64 {
        self.window_s
    }

    /// Full-rate pairs held.
    pub fn pairs(&self) -> usize {
        self.pairs.len()
    }

    /// Times the window restarted at a gap in the raw samples' index.
    pub fn gaps(&self) -> u64 {
        self.gaps
    }

    /// The last verdict formed, with its estimate's sample index.
    pub fn last(&self) -> Option<&(u64, Verdict)> {
        self.last.as_ref()
    }

    /// Take in a raw block (`fs`: the sample rate, if known).
    pub fn raw(&mut self, r: &RawSamples, fs: Option<f64>) {
        if r.decimation != 1 {
            self.decimated = true;
            self.pairs.clear();
            self.next_index = None;
            return;
        }
        self.decimated = false;
        if self.next_index.is_some_and(|n| n != r.first_sample_index) {
            self.gaps += 1;
            self.pairs.clear();
        }
        self.pairs
            .extend(r.samples.iter().map(|s| (f64::from(s.u_v), f64::from(s.y))));
        self.next_index = Some(r.first_sample_index + r.samples.len() as u64);
        if let Some(fs) = fs.filter(|f| *f > 0.0) {
            let keep = (self.window_s * fs).ceil() as usize;
            let excess = self.pairs.len().saturating_sub(keep);
            self.pairs.drain(..excess);
        }
    }

    /// Take in an estimate; when at least [`VERDICT_EVERY_S`] of device
    /// time has passed since the last verdict (or there is none), form the
    /// verdict on it and return it. `fs`: the sample rate (without it no
    /// verdict is formed).
    pub fn estimate(&mut self, e: &Estimate, fs: Option<f64>) -> Option<&Verdict> {
        let fs = fs.filter(|f| *f > 0.0)?;
        let t = e.sample_index as f64 / fs;
        let values = (!e.modes.is_empty()).then(|| {
            e.modes
                .iter()
                .map(|m| f64::from(m.omega_rad_s))
                .chain(e.modes.iter().map(|m| f64::from(m.zeta)))
                .collect()
        });
        self.history.push_values(t, values);
        self.history.forget_before(t - self.window_s);
        let due = self.last.as_ref().is_none_or(|(k, _)| {
            (e.sample_index.saturating_sub(*k)) as f64 >= VERDICT_EVERY_S * fs
        });
        if !due {
            return None;
        }
        let v = self.judge(e, fs, t);
        self.last = Some((e.sample_index, v));
        self.last.as_ref().map(|(_, v)| v)
    }

    /// The verdict on `e` at device time `t` (s).
    fn judge(&self, e: &Estimate, fs: f64, t: f64) -> Verdict {
        let ts = 1.0 / fs;
        let omega: Vec<f64> = e.modes.iter().map(|m| f64::from(m.omega_rad_s)).collect();
        let zeta: Vec<f64> = e.modes.iter().map(|m| f64::from(m.zeta)).collect();
        let validity: Vec<&'static str> =
            if e.modes.is_empty() || e.flags.contains(StatusFlags::PHYSICALLY_VALID) {
                Vec::new()
            } else {
                vec![DEVICE_SAYS_NOT_PHYSICAL]
            };
        let theta: Vec<f64> = e.theta.iter().map(|&v| f64::from(v)).collect();
        let model = TransferFunction::from_theta(&theta, f64::from(e.lambda_rad_s))
            .and_then(|tf| Model::new(&tf, ts));
        let n = self.pairs.len();
        let record = || self.pairs.iter().copied();
        let fit = match (&model, e.modes.is_empty()) {
            (Some(m), false) if n > 1 => fit::fit(m, record),
            _ => None,
        };
        let input = PowerSpectrum::of(record().map(|(u, _)| u), n, ts);
        let residual = model
            .as_ref()
            .zip(fit.as_ref())
            .and_then(|(m, f)| residual_spectrum(m, f, record(), n, ts));
        let span_s = n as f64 * ts;
        let start = if span_s > 0.0 {
            t - span_s
        } else {
            t - self.window_s
        };
        let mut v = Verdict::of(&Evidence {
            omega: (!e.modes.is_empty()).then_some(&omega[..]),
            zeta: &zeta,
            validity: &validity,
            fit: fit.as_ref(),
            drift: self.history.drift(start, t),
            input: input.as_ref(),
            residual: residual.as_ref(),
        });
        // Say why the stream gave no fit, where it is the stream's doing.
        if let Some(r) = v.reasons.iter_mut().find(|r| r.code == "no_fit") {
            if self.decimated {
                r.detail = "no model-output fit: the raw samples are decimated (a fit needs every sample: \
                            `telemetry --raw-decimation 1`)"
                    .into();
            } else if n < 2 {
                r.detail = "no model-output fit: no raw samples (turn them on: \
                            `telemetry --raw-decimation 1`)"
                    .into();
            }
        }
        v
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use beam_protocol::{EstimatorKind, ModeEstimate, UySample, MAX_RAW_SAMPLES};
    use beamest::model::ModalParams;
    use beamest::rig::ModalPlant;

    const FS: f64 = 10_000.0;

    /// A one-mode plant's Θ̂ (λ = 100) and its modes.
    fn estimate(sample_index: u64, omega: f64, zeta: f64, valid: bool) -> Estimate {
        let m = ModalParams::new(&[omega], &[zeta], &[1.0], None).unwrap();
        let tf = m.transfer_function();
        let mut theta = [0.0f64; 3];
        tf.to_theta(100.0, &mut theta).unwrap();
        let mut flags = StatusFlags::default();
        flags.set(StatusFlags::PHYSICALLY_VALID, valid);
        Estimate {
            sample_index,
            estimator: EstimatorKind::Adaptive,
            flags,
            modes: [ModeEstimate {
                omega_rad_s: omega as f32,
                zeta: zeta as f32,
                b_bar: 1.0,
            }]
            .into_iter()
            .collect(),
            lambda_rad_s: 100.0,
            theta: theta.iter().map(|&v| v as f32).collect(),
            excitation_level: Some(1e-3),
        }
    }

    /// `seconds` of a one-mode beam (ζ 0.02) driven by a random ±1
    /// sequence held for 16 samples, in raw blocks from sample `first`.
    fn stream(first: u64, seconds: f64, omega: f64) -> Vec<RawSamples> {
        let m = ModalParams::new(&[omega], &[0.02], &[1.0], None).unwrap();
        let mut plant = ModalPlant::<f64>::from_modal(&m, 1.0 / FS).unwrap();
        let mut state = 0x1234_5678u32;
        let n = (seconds * FS) as usize;
        let pairs: Vec<UySample> = (0..n)
            .map(|k| {
                if k % 16 == 0 {
                    state ^= state << 13;
                    state ^= state >> 17;
                    state ^= state << 5;
                }
                let u = if state & 1 == 1 { 1.0 } else { -1.0 };
                let y = plant.sample(u);
                UySample {
                    u_v: u as f32,
                    y: y as f32,
                }
            })
            .collect();
        pairs
            .chunks(MAX_RAW_SAMPLES)
            .enumerate()
            .map(|(i, c)| RawSamples {
                first_sample_index: first + (i * MAX_RAW_SAMPLES) as u64,
                decimation: 1,
                samples: c.iter().copied().collect(),
            })
            .collect()
    }

    #[test]
    fn the_right_model_over_the_window_is_trusted() {
        let mut live = LiveVerdict::new(2.0);
        for b in stream(0, 3.0, 300.0) {
            live.raw(&b, Some(FS));
        }
        assert_eq!(live.pairs(), 20_000, "the window keeps its last 2 s");
        let v = live
            .estimate(&estimate(29_999, 300.0, 0.02, true), Some(FS))
            .unwrap();
        assert!(v.trusted, "{:?}", v.reasons);
        assert_eq!(v.identifiable, vec![true]);
    }

    #[test]
    fn a_wrong_model_is_not_trusted_and_the_window_follows_the_stream() {
        let mut live = LiveVerdict::new(2.0);
        for b in stream(0, 3.0, 300.0) {
            live.raw(&b, Some(FS));
        }
        // 5% off in ω: the residual holds the mode.
        let v = live
            .estimate(&estimate(29_999, 315.0, 0.02, true), Some(FS))
            .unwrap();
        assert!(!v.trusted);
        assert!(
            v.reasons.iter().any(|r| r.code == "residual_structured"),
            "{:?}",
            v.reasons
        );
        // Within a second of device time no new verdict is formed.
        assert!(live
            .estimate(&estimate(30_999, 300.0, 0.02, true), Some(FS))
            .is_none());
        assert!(live
            .estimate(&estimate(40_000, 300.0, 0.02, true), Some(FS))
            .is_some());
    }

    #[test]
    fn without_full_rate_samples_the_verdict_says_why() {
        let mut live = LiveVerdict::new(2.0);
        let e = estimate(100, 300.0, 0.02, true);
        let v = live.estimate(&e, Some(FS)).unwrap();
        let r = v.reasons.iter().find(|r| r.code == "no_fit").unwrap();
        assert!(r.detail.contains("no raw samples"), "{}", r.detail);
        let mut blocks = stream(0, 0.1, 300.0);
        for b in &mut blocks {
            b.decimation = 10;
            live.raw(b, Some(FS));
        }
        assert_eq!(live.pairs(), 0);
        let v = live
            .estimate(&estimate(20_000, 300.0, 0.02, true), Some(FS))
            .unwrap();
        let r = v.reasons.iter().find(|r| r.code == "no_fit").unwrap();
        assert!(r.detail.contains("decimated"), "{}", r.detail);
    }

    #[test]
    fn a_gap_restarts_the_window_and_the_device_flag_counts() {
        let mut live = LiveVerdict::new(2.0);
        let mut blocks = stream(0, 0.5, 300.0);
        let later = stream(10_000, 0.5, 300.0);
        blocks.extend(later);
        for b in &blocks {
            live.raw(b, Some(FS));
        }
        assert_eq!(live.gaps(), 1);
        assert_eq!(live.pairs(), 5_000);
        let v = live
            .estimate(&estimate(14_999, 300.0, 0.02, false), Some(FS))
            .unwrap();
        assert!(
            v.reasons.iter().any(|r| r.code == "not_physical"),
            "{:?}",
            v.reasons
        );
        // No modes: no estimate.
        let mut none = estimate(30_000, 300.0, 0.02, false);
        none.modes.clear();
        let v = live.estimate(&none, Some(FS)).unwrap();
        assert_eq!(v.reasons[0].code, "no_estimate");
    }
}
