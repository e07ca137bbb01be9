//! A progress bar on stderr for long simulations.
//!
//! The bar counts simulated samples. It stays hidden for the first
//! [`SHOW_AFTER`] of wall time, so short runs print nothing, and it is never
//! shown when disabled (stderr not a terminal, or `--json`).

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use std::time::{Duration, Instant};

/// Wall time after which a still-running simulation shows its bar.
pub const SHOW_AFTER: Duration = Duration::from_secs(1);

/// Progress over a known number of samples.
pub struct Progress {
    bar: Option<ProgressBar>,
    started: Instant,
    shown: bool,
}

impl Progress {
    /// A bar over `total` samples; `enabled = false` makes every call a no-op.
    pub fn new(total: u64, enabled: bool) -> Self {
        let bar = enabled.then(|| {
            let bar = ProgressBar::with_draw_target(Some(total), ProgressDrawTarget::hidden());
            let style = ProgressStyle::with_template(
                "{msg:>9} [{wide_bar:.cyan/blue}] {percent:>3}% ETA {eta:>3}",
            )
            .unwrap_or_else(|_| ProgressStyle::default_bar())
            .progress_chars("=> ");
            bar.set_style(style);
            bar
        });
        Self {
            bar,
            started: Instant::now(),
            shown: false,
        }
    }

    /// Label the bar (e.g. with the estimator running).
    pub fn set_message(&self, msg: &str) {
        if let Some(bar) = &self.bar {
            bar.set_message(msg.to_string());
        }
    }

    /// Samples done so far (absolute).
    pub fn set_position(&mut self, samples: u64) {
        if let Some(bar) = &self.bar {
            if !self.shown && self.started.elapsed() >= SHOW_AFTER {
                bar.set_draw_target(ProgressDrawTarget::stderr());
                self.shown = true;
            }
            bar.set_position(samples);
        }
    }

    /// Remove the bar from the terminal.
    pub fn finish(&self) {
        if let Some(bar) = &self.bar {
            bar.finish_and_clear();
        }
    }
}
