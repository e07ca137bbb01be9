//! What the monitor knows and shows: the link (through [`Host`]), the last
//! estimate, the history of ω̂ and ζ̂ for the chart and the plot, and the
//! log of commands and their answers. The terminal view and the plain
//! output are both drawn from a [`State`].

use crate::cli::monitor::live::LiveVerdict;
use crate::judge::verdict::Verdict;
use crate::link::{text, Host};
use beam_protocol::{Estimate, Frame, Message, MAX_MODES};
use std::collections::VecDeque;
use std::time::Instant;

/// Lines kept in the command log.
pub const LOG_LINES: usize = 200;

/// One estimate in the history.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Point {
    /// The estimate's sample index.
    pub sample_index: u64,
    /// Number of modes in the estimate (0: recovery failed).
    pub modes: usize,
    /// ω̂_i (rad/s).
    pub omega: [f64; MAX_MODES],
    /// ζ̂_i.
    pub zeta: [f64; MAX_MODES],
}

/// Frames delivered, by kind.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct KindCounts {
    /// Estimates.
    pub estimates: u64,
    /// Raw-sample blocks.
    pub raw: u64,
    /// Status frames.
    pub status: u64,
    /// Acknowledgements.
    pub acks: u64,
    /// Self-test reports.
    pub self_tests: u64,
    /// Frames of a host → device kind (a loop-back, or a wrong wire).
    pub other: u64,
}

/// The monitor's state.
#[derive(Debug)]
pub struct State {
    /// What the bytes come from (for titles and messages).
    pub source: String,
    /// The link.
    pub host: Host,
    /// The last estimate and when it arrived.
    pub last: Option<(Estimate, Instant)>,
    /// Every estimate's ω̂, ζ̂, in arrival order.
    pub history: Vec<Point>,
    /// Commands sent and their answers, newest last.
    pub log: VecDeque<String>,
    /// The command line being typed in the terminal view, if open.
    pub input: Option<String>,
    /// When the monitor started.
    pub start: Instant,
    /// Frames by kind.
    pub kinds: KindCounts,
    /// Commands can be sent (a live device, not --listen-only).
    pub writable: bool,
    /// The verdict on the last estimate over the stream's recent past.
    pub live: LiveVerdict,
}

impl State {
    /// A state for `source`; its verdict judges the last `window_s` seconds
    /// of the stream.
    pub fn new(source: String, host: Host, writable: bool, window_s: f64) -> Self {
        Self {
            source,
            host,
            last: None,
            history: Vec::new(),
            log: VecDeque::new(),
            input: None,
            start: Instant::now(),
            kinds: KindCounts::default(),
            writable,
            live: LiveVerdict::new(window_s),
        }
    }

    /// Seconds since the start (host clock).
    pub fn host_s(&self, now: Instant) -> f64 {
        now.duration_since(self.start).as_secs_f64()
    }

    /// Add a line to the command log.
    pub fn log(&mut self, line: String) {
        if self.log.len() == LOG_LINES {
            self.log.pop_front();
        }
        self.log.push_back(line);
    }

    /// Take note of a delivered frame (counts, last estimate, history, the
    /// verdict's window).
    pub fn frame(&mut self, f: &Frame, now: Instant) {
        let fs = self.host.sample_rate_hz();
        match &f.message {
            Message::Estimate(e) => {
                self.live.estimate(e, fs);
                self.kinds.estimates += 1;
                let mut p = Point {
                    sample_index: e.sample_index,
                    modes: e.modes.len(),
                    omega: [f64::NAN; MAX_MODES],
                    zeta: [f64::NAN; MAX_MODES],
                };
                for (i, m) in e.modes.iter().enumerate().take(MAX_MODES) {
                    p.omega[i] = f64::from(m.omega_rad_s);
                    p.zeta[i] = f64::from(m.zeta);
                }
                self.history.push(p);
                self.last = Some((e.clone(), now));
            }
            Message::RawSamples(r) => {
                self.kinds.raw += 1;
                self.live.raw(r, fs);
            }
            Message::Status(_) => self.kinds.status += 1,
            Message::Ack(_) => self.kinds.acks += 1,
            Message::SelfTestReport(_) => self.kinds.self_tests += 1,
            Message::Command(_) => self.kinds.other += 1,
        }
    }

    /// The most modes seen in an estimate (for charts and plots).
    pub fn modes(&self) -> usize {
        let seen = self.history.iter().map(|p| p.modes).max().unwrap_or(0);
        let status = self
            .host
            .status()
            .map_or(0, |s| usize::from(s.modes).min(MAX_MODES));
        seen.max(status)
    }
}

/// One line per estimate (plain output): sample index, device time,
/// sequence number, law, ω̂, ζ̂, b̂̄ per mode, the λ of its Θ̂, the
/// excitation level λmin(P)/tr(P) and the flags.
/// Values are the f32 the device sent, printed exactly (shortest form);
/// `-` where there is none, `?` for a time before the sample rate is known.
pub fn estimate_line(e: &Estimate, seq: u32, host: &Host) -> String {
    let t = host
        .time_s(e.sample_index)
        .map_or_else(|| "?".to_string(), |t| t.to_string());
    let list = |f: &dyn Fn(&beam_protocol::ModeEstimate) -> f32| {
        if e.modes.is_empty() {
            "-".to_string()
        } else {
            e.modes
                .iter()
                .map(|m| f(m).to_string())
                .collect::<Vec<_>>()
                .join(",")
        }
    };
    let level = e
        .excitation_level
        .map_or_else(|| "-".to_string(), |l| l.to_string());
    format!(
        "sample={} t_s={t} seq={seq} law={} omega_rad_s={} zeta={} bbar={} lambda_rad_s={} excitation_level={level} flags={}",
        e.sample_index,
        e.estimator.name(),
        list(&|m| m.omega_rad_s),
        list(&|m| m.zeta),
        list(&|m| m.b_bar),
        e.lambda_rad_s,
        text::flags_text(e.flags, "|"),
    )
}

/// The plain output's verdict line (printed after an estimate line when
/// the verdict changes): the judged estimate's sample index and device
/// time, `trusted=yes|no` and the reasons' codes.
pub fn verdict_line(sample_index: u64, v: &Verdict, host: &Host) -> String {
    let t = host
        .time_s(sample_index)
        .map_or_else(|| "?".to_string(), |t| t.to_string());
    let mut codes: Vec<&str> = v.reasons.iter().map(|r| r.code).collect();
    codes.dedup();
    format!(
        "verdict sample={sample_index} t_s={t} trusted={} reasons={}",
        if v.trusted { "yes" } else { "no" },
        if codes.is_empty() {
            "-".to_string()
        } else {
            codes.join(",")
        }
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use beam_protocol::{EstimatorKind, ModeEstimate, StatusFlags};

    fn estimate(modes: &[(f32, f32, f32)], flags: StatusFlags, level: Option<f32>) -> Estimate {
        Estimate {
            sample_index: 2_099,
            estimator: EstimatorKind::Adaptive,
            flags,
            modes: modes
                .iter()
                .map(|&(omega_rad_s, zeta, b_bar)| ModeEstimate {
                    omega_rad_s,
                    zeta,
                    b_bar,
                })
                .collect(),
            lambda_rad_s: 92.5,
            theta: [0.0; 7].into_iter().collect(),
            excitation_level: level,
        }
    }

    /// An estimate before the law's first update (no modes, no validity:
    /// PROTOCOL.md §4.1) shows `-` for ω, ζ, b̄ and no PHYSICALLY_VALID;
    /// λ and the level are shown as sent.
    #[test]
    fn estimate_lines_show_missing_modes_lambda_and_level() {
        let host = Host::new(false);
        let e = estimate(&[], StatusFlags::FROZEN_AUTO, Some(0.0));
        assert_eq!(
            estimate_line(&e, 43, &host),
            "sample=2099 t_s=? seq=43 law=adaptive omega_rad_s=- zeta=- bbar=- \
             lambda_rad_s=92.5 excitation_level=0 flags=FROZEN_AUTO"
        );
        let e = estimate(
            &[(39.15, 0.0207, 9.63), (245.4, 0.13, 16.15)],
            StatusFlags::EXCITED.with(StatusFlags::PHYSICALLY_VALID),
            Some(3.5e-7),
        );
        assert_eq!(
            estimate_line(&e, 44, &host),
            "sample=2099 t_s=? seq=44 law=adaptive omega_rad_s=39.15,245.4 zeta=0.0207,0.13 \
             bbar=9.63,16.15 lambda_rad_s=92.5 excitation_level=0.00000035 flags=EXCITED|PHYSICALLY_VALID"
        );
        let e = estimate(&[], StatusFlags::default(), None);
        assert!(estimate_line(&e, 45, &host).contains("excitation_level=- flags=-"));
    }
}
