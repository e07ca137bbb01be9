//! The truth-free tuning rule on the device ([`crate::tuning::AutoTune`],
//! docs/SETTINGS.md), split across the firmware's two priority levels.
//!
//! * **Start-up window.** The sample interrupt only copies the (u, y) pairs
//!   it feeds (valid or NaN) into fixed blocks of [`RAW_BLOCK_LEN`] pairs
//!   and pushes them into a bounded queue while [`Tuner::collecting`]; the
//!   low-priority task hands each block to [`Tuner::startup_block`], which
//!   runs [`AutoTune::startup_sample`] (its sums are in `f64`: software on
//!   a single-precision FPU, so not in the interrupt). A dropped block (a
//!   gap in the pairs' numbering) breaks the statistics' difference chains
//!   as a rejected sample does, so no difference spans the gap.
//! * **First build.** When the window closes the rule gives U0, Y0 and λ0;
//!   the build (its matrix exponentials) is left [`Pending`] for the
//!   low-priority task, which builds it outside the lock and swaps it in
//!   between two samples (`DeviceLink::poll`).
//! * **Reviews.** The steps between two telemetry records are counted
//!   ([`AutoTune::advance`]) from the sample at which the current estimator
//!   was swapped in; when a review is due, the record's Θ̂ (at the record's
//!   λ) is reviewed. A re-centring is left [`Pending`] with
//!   θ(0) = [`carry_over`] of that estimate and swapped in the same way.
//!
//! The sample interrupt never builds, reviews or computes in `f64`.

use crate::filter_bank::FilterConfig;
use crate::model::TransferFunction;
use crate::pipeline::{RawBlock, RAW_BLOCK_LEN};
use crate::scalar::Real;
use crate::tuning::{carry_over, AutoTune, Phase, TuningConfig, TuningError};
use beam_protocol::{OutputKind, MAX_THETA};

/// Why an estimator is to be built.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BuildKind {
    /// The first estimator, after the start-up window.
    First,
    /// λ re-centred on the estimated band, the estimate carried over.
    Recentre,
}

/// An estimator the rule asked for, to be built outside the lock.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Pending {
    /// Why.
    pub kind: BuildKind,
    /// Its filter bank (Ts, λ, U0, Y0, hold, timing).
    pub filter: FilterConfig,
    /// θ(0) in its scaled coordinates (`theta0_len` entries; none = zero).
    pub theta0: [f64; MAX_THETA],
    /// Valid entries of `theta0`.
    pub theta0_len: usize,
}

impl Pending {
    /// θ(0) (empty: zero).
    pub fn theta0(&self) -> &[f64] {
        self.theta0.get(..self.theta0_len).unwrap_or(&[])
    }
}

/// The device's side of the rule (see the module doc).
#[derive(Debug, Clone)]
pub struct Tuner {
    rule: AutoTune,
    /// Number of the next start-up pair expected (gap detection).
    next_pair: u64,
    /// Pairs lost in dropped blocks.
    lost_pairs: u64,
    /// First sample of the current estimator: records from here on are
    /// its own.
    review_from: Option<u64>,
    /// Steps counted up to (excluding) this sample.
    counted_to: u64,
    pending: Option<Pending>,
    /// A rebuild failed: the rule stops (the running estimator stays).
    stopped: bool,
}

impl Tuner {
    /// The rule with `cfg` (its λ source is the automatic one: `Data` or a
    /// `Band` the board knows).
    pub fn new(cfg: &TuningConfig) -> Result<Self, TuningError> {
        Ok(Self {
            rule: AutoTune::new(cfg)?,
            next_pair: 0,
            lost_pairs: 0,
            review_from: None,
            counted_to: 0,
            pending: None,
            stopped: false,
        })
    }

    /// The sample interrupt should still collect start-up pairs.
    pub(crate) fn collecting(&self) -> bool {
        self.rule.phase() == Phase::Startup
    }

    /// One block of start-up pairs (numbered from 0 by `first_index`, one
    /// per fed sample). Returns true when this block closed the window
    /// (the first build is then [`Tuner::pending`]).
    pub fn startup_block<T: Real>(&mut self, block: &RawBlock<T>) -> bool {
        if !self.collecting() {
            return false;
        }
        if block.first_index != self.next_pair {
            // Pairs were dropped: no difference may span the gap.
            self.lost_pairs = self
                .lost_pairs
                .saturating_add(block.first_index.abs_diff(self.next_pair));
            let _ = self.rule.startup_sample(T::from_f64(f64::NAN), T::ZERO);
        }
        let n = usize::from(block.len).min(RAW_BLOCK_LEN);
        self.next_pair = block.first_index.saturating_add(n as u64);
        for (&u, &y) in block.u_v.iter().zip(block.y.iter()).take(n) {
            if let Some(filter) = self.rule.startup_sample(u, y) {
                self.pending = Some(Pending {
                    kind: BuildKind::First,
                    filter,
                    theta0: [0.0; MAX_THETA],
                    theta0_len: 0,
                });
                return true;
            }
        }
        false
    }

    /// The estimator asked for, if any (taken by the build).
    pub(crate) fn take_pending(&mut self) -> Option<Pending> {
        self.pending.take()
    }

    /// The estimator asked for, if any.
    pub fn pending(&self) -> Option<&Pending> {
        self.pending.as_ref()
    }

    /// Forget a pending re-centring (a command replaced the estimator).
    pub(crate) fn cancel_pending(&mut self) {
        if self
            .pending
            .as_ref()
            .is_some_and(|p| p.kind == BuildKind::Recentre)
        {
            self.pending = None;
        }
    }

    /// The estimator built from `filter` runs from sample `at`: its steps
    /// are counted from there.
    pub(crate) fn swapped_in(&mut self, at: u64) {
        self.review_from = Some(at);
        self.counted_to = at;
    }

    /// A command rebuilt the estimator at `filter` with the automatic λ,
    /// running from `at`: review it again from its settling on.
    pub(crate) fn rebuilt(&mut self, filter: FilterConfig, at: u64) {
        self.cancel_pending();
        self.rule.rebuilt(filter);
        self.swapped_in(at);
    }

    /// The estimator's settings name another sensor output kind: the
    /// rule's filters carry it from now on, a pending first build too, and
    /// a pending re-centring (its θ(0) in the old kind's coordinates) is
    /// dropped.
    pub(crate) fn set_output(&mut self, output: OutputKind) {
        if self.rule.config().output == output {
            return;
        }
        self.cancel_pending();
        if let Some(p) = self.pending.as_mut() {
            p.filter.output = output;
        }
        self.rule.set_output(output);
    }

    /// Samples up to `index` are not counted (adaptation frozen by command,
    /// or λ fixed): the rule's clock resumes after them.
    pub(crate) fn skip_to(&mut self, index: u64) {
        if self.review_from.is_some() {
            self.counted_to = self.counted_to.max(index.saturating_add(1));
        }
    }

    /// A rebuild failed: stop the rule, the running estimator stays.
    pub fn stop(&mut self) {
        self.stopped = true;
        self.pending = None;
    }

    /// One telemetry record of the running estimator (its last sample
    /// `index`, its Θ̂ at `lambda_rad_s`): counts its steps and reviews the
    /// estimate when due. Returns true when a re-centring is now
    /// [`Tuner::pending`]. Records older than the current estimator, or
    /// made at another λ, are not its own and are skipped.
    pub fn on_record<T: Real, const NP: usize>(
        &mut self,
        index: u64,
        theta: &[T; NP],
        lambda_rad_s: f64,
    ) -> bool {
        let Some(from) = self.review_from else {
            return false;
        };
        let own = self
            .rule
            .filter()
            .is_some_and(|f| f.lambda_rad_s == lambda_rad_s);
        if self.stopped || self.pending.is_some() || index < from || !own {
            return false;
        }
        let steps = index.saturating_add(1).saturating_sub(self.counted_to);
        self.counted_to = self.counted_to.max(index.saturating_add(1));
        if !self.rule.advance(steps) {
            return false;
        }
        let Some(tf) = TransferFunction::from_theta(theta, lambda_rad_s) else {
            return false;
        };
        let Some(filter) = self.rule.review(&tf) else {
            return false;
        };
        let mut theta0 = [0.0; MAX_THETA];
        // Without a finite carry-over the new estimator starts from zero.
        let len = match carry_over::<T, NP>(&tf, &filter) {
            Some(t) if NP <= MAX_THETA => {
                for (d, s) in theta0.iter_mut().zip(t.iter()) {
                    *d = *s;
                }
                NP
            }
            _ => 0,
        };
        self.pending = Some(Pending {
            kind: BuildKind::Recentre,
            filter,
            theta0,
            theta0_len: len,
        });
        true
    }

    /// Where the rule is.
    pub fn phase(&self) -> Phase {
        self.rule.phase()
    }

    /// Re-centrings done.
    pub fn recentres(&self) -> u8 {
        self.rule.recentres()
    }

    /// The rule (its start-up statistics, settings).
    pub fn rule(&self) -> &AutoTune {
        &self.rule
    }

    /// Start-up pairs lost in dropped blocks.
    pub fn lost_pairs(&self) -> u64 {
        self.lost_pairs
    }
}

/// The sample interrupt's half: copies fed pairs into blocks numbered by
/// pair, hands each full block to `push` (a bounded queue's `enqueue`;
/// a refused block is counted and shows as a gap). A handful of
/// instructions per sample, no floating point but the copies.
#[derive(Debug, Clone, Copy)]
pub struct StartupCollector<T> {
    block: RawBlock<T>,
    next_pair: u64,
    dropped: u32,
}

impl<T: Real> Default for StartupCollector<T> {
    fn default() -> Self {
        Self::new()
    }
}

impl<T: Real> StartupCollector<T> {
    /// Empty.
    pub const fn new() -> Self {
        Self {
            block: RawBlock {
                first_index: 0,
                decimation: 1,
                len: 0,
                u_v: [T::ZERO; RAW_BLOCK_LEN],
                y: [T::ZERO; RAW_BLOCK_LEN],
            },
            next_pair: 0,
            dropped: 0,
        }
    }

    /// Take one fed pair (NaN if the sample was rejected); a full block
    /// goes to `push`, which returns whether it was taken.
    #[inline]
    pub fn push(&mut self, u: T, y: T, push: impl FnOnce(RawBlock<T>) -> bool) {
        let i = usize::from(self.block.len);
        if let (Some(du), Some(dy)) = (self.block.u_v.get_mut(i), self.block.y.get_mut(i)) {
            *du = u;
            *dy = y;
            self.block.len += 1;
        }
        self.next_pair = self.next_pair.wrapping_add(1);
        if usize::from(self.block.len) >= RAW_BLOCK_LEN {
            if !push(self.block) {
                self.dropped = self.dropped.saturating_add(1);
            }
            self.block.len = 0;
            self.block.first_index = self.next_pair;
        }
    }

    /// Blocks the queue refused.
    pub fn dropped(&self) -> u32 {
        self.dropped
    }
}
