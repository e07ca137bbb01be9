//! Bounded hand-over of a prepared model update (firmware use).
//!
//! [`RobustEstimator::apply`] replays, inside the caller's lock, every
//! sample recorded since the update was prepared: on the Cortex-M4F that
//! was up to 551 samples and 1.2 M instructions (`cargo xtask
//! robust-bench`), ~12 ms with the sample interrupt masked. Here the
//! low-priority task catches the pending update up in chunks *outside* the
//! lock ([`RobustEstimator::catch_up`], which borrows the estimator
//! immutably, like [`RobustEstimator::prepare_update`], so it runs between
//! two samples or under a short lock per chunk), while the sample
//! interrupt keeps stepping the current model and recording, and installs
//! it with [`RobustEstimator::apply_bounded`] only when at most a few
//! samples ([`APPLY_REPLAY_MAX`]) remain: the work inside the lock is
//! bounded by that count, whatever the preparation took.
//!
//! The preparation itself can run the same way: [`RobustEstimator::update_seed`]
//! copies the little it needs of the estimator (θ̂, the law, the record's
//! length: a short lock), [`UpdateSeed::start`] builds the new model
//! without the estimator (roots, matrix exponential), and `catch_up` then
//! does the O(record) work — the initial-state fit when the beam was
//! moving, the replay up to the preparation's record length, the
//! refinement steps, then the samples recorded since — in chunks of
//! `max_samples` units (a sample of the fit or of the replay, or one
//! refinement step: each a few thousand instructions on the Cortex-M4F).
//!
//! The replayed samples, their order and the arithmetic are those of
//! [`RobustEstimator::prepare_update`] and [`RobustEstimator::apply`]
//! ([`RobustEstimator::prepare_update`] is built from these pieces): the
//! result is bit-identical however it is chunked (tests below).

use super::{
    reflected_candidate, stable_candidate, BlockSums, Filters, InitialFit, OeLaw, OeModel, Pending,
    Phase, RecordStore, RobustEstimator, UpdateError, REFINE_STEPS,
};
use crate::filter_bank::{OutputHold, OutputTiming};
use crate::scalar::compensated::CompensatedArray;
use crate::scalar::Real;
use beam_protocol::OutputKind;

/// What a model update needs of the estimator, copied out of it (~1 KB for
/// two modes in `f32`): [`RobustEstimator::update_seed`], then
/// [`UpdateSeed::start`] without the estimator.
#[derive(Debug, Clone)]
pub struct UpdateSeed<T, const D: usize, const NP: usize, const NS: usize> {
    epoch: u32,
    target: usize,
    theta: CompensatedArray<T, NP>,
    refining: bool,
    adapted: u32,
    fit: bool,
    law: OeLaw<T, NP, NS>,
    rho_ts: f64,
    hold: OutputHold,
    timing: OutputTiming,
    output: OutputKind,
}

impl<T: Real, const D: usize, const NP: usize, const NS: usize> UpdateSeed<T, D, NP, NS> {
    /// The new model (stability check, exact discretization of its 1/Â:
    /// roots and a matrix exponential, no O(record) work): a pending update
    /// that has replayed nothing yet; [`RobustEstimator::catch_up`] does
    /// the rest.
    ///
    /// # Errors
    /// [`UpdateError::Unstable`].
    pub fn start(self) -> Result<Pending<T, D, NP, NS>, UpdateError> {
        // The linearization point: θ̂ if it is a stable model, else (an
        // early replay on a short record can overshoot) the current one,
        // replayed again on the longer record.
        let (theta, c) = match stable_candidate::<T, D, NP>(&self.theta) {
            Some(c) => (self.theta, c),
            None if self.refining => {
                let m = *self.law.model();
                let c = stable_candidate::<T, D, NP>(&m).ok_or(UpdateError::Unstable)?;
                (m, c)
            }
            // The start-up law's estimate, its unstable roots reflected.
            None => reflected_candidate::<T, D, NP>(&self.theta).ok_or(UpdateError::Unstable)?,
        };
        // (The timing was accepted by `RobustEstimator::new`, for Λ; the
        // same kernel on another stable 1/Â fails only if it is not causal.)
        let f = Filters::new(&c, self.rho_ts, self.hold, &self.timing, self.output)
            .ok_or(UpdateError::Unstable)?;
        let oe = OeModel::new(f, &theta);
        let mut law = self.law;
        law.restart(&theta);
        Ok(Pending {
            epoch: self.epoch,
            replayed: 0,
            target: self.target,
            fit: self.fit.then(InitialFit::new),
            refine_left: REFINE_STEPS,
            candidate: c.map(T::from_f64),
            adapted: self.adapted,
            oe,
            law,
            block: BlockSums::EMPTY,
        })
    }
}

/// A bound for [`RobustEstimator::apply_bounded`]'s work inside the lock:
/// 32 replayed samples are 32 robust steps, under one 100 µs sample period
/// on the Cortex-M4F in `f32` at the QEMU image's one instruction per ns
/// (the step's cost: BENCHMARKS.md, "The robust estimator on the
/// Cortex-M4F"); the sample interrupt is then delayed, not lost. The QEMU
/// image uses 16 (`src/bin/qemu-rig/robust.rs`; its longest lock:
/// BENCHMARKS.md, "On the QEMU image, selected over the link").
#[cfg(test)]
pub(crate) const APPLY_REPLAY_MAX: usize = 32;

impl<T, const D: usize, const NP: usize, const NS: usize> Pending<T, D, NP, NS> {
    /// Samples of the record this update has replayed so far.
    pub fn replayed(&self) -> usize {
        self.replayed
    }
}

impl<
        T: Real,
        const D: usize,
        const NP: usize,
        const NS: usize,
        const B: usize,
        R: RecordStore<T>,
    > RobustEstimator<T, D, NP, NS, B, R>
{
    /// The start of a model update (a short copy, inside the lock): see
    /// [`UpdateSeed::start`].
    ///
    /// # Errors
    /// [`UpdateError::RecordFull`]: the record is full, the model final.
    pub fn update_seed(&self) -> Result<UpdateSeed<T, D, NP, NS>, UpdateError> {
        // The replay must be able to catch up with the present.
        if self.phase == Phase::Steady || self.rec_len >= B {
            return Err(UpdateError::RecordFull);
        }
        Ok(UpdateSeed {
            epoch: self.epoch,
            target: self.rec_len,
            theta: self.theta_abs(),
            refining: self.phase == Phase::Refining,
            adapted: self.adapted,
            fit: matches!(self.initial, Some((_, true))),
            law: self.law.clone(),
            rho_ts: self.filter.lambda_rad_s * self.filter.ts_s,
            hold: self.filter.hold,
            timing: self.filter.timing,
            output: self.filter.output,
        })
    }

    /// Samples recorded since the record was started (at most `B`).
    pub fn recorded(&self) -> usize {
        self.rec_len
    }

    /// The work `p` still has to do before it can be installed, in
    /// [`RobustEstimator::catch_up`]'s units: samples of the initial-state
    /// fit and of the replay, refinement steps, and the samples recorded
    /// since it was prepared.
    ///
    /// # Errors
    /// [`UpdateError::Stale`] if `p` can no longer be applied (the
    /// estimator was reset or updated since, or samples arrived after the
    /// record was full).
    pub fn behind(&self, p: &Pending<T, D, NP, NS>) -> Result<usize, UpdateError> {
        self.check_fresh(p)?;
        Ok(self.work_left(p))
    }

    fn work_left(&self, p: &Pending<T, D, NP, NS>) -> usize {
        let fit = p
            .fit
            .as_ref()
            .map_or(0, |f| Self::fit_end(p.target).saturating_sub(f.pos));
        fit + self.rec_len.saturating_sub(p.replayed) + p.refine_left as usize
    }

    /// The initial-state fit runs over the record up to here: the
    /// preparation's record length, whole blocks of a [`Compact`]
    /// record (what a later catch-up finds in the record is then what a
    /// one-shot preparation found).
    ///
    /// [`Compact`]: super::Compact
    fn fit_end(target: usize) -> usize {
        target / R::BLOCK * R::BLOCK
    }

    /// Up to `max` units of `p`'s remaining work, in the order of the
    /// one-shot preparation (fit, replay to the target, refinement, the
    /// samples since); returns the work left.
    pub(super) fn replay_into(&self, p: &mut Pending<T, D, NP, NS>, max: usize) -> usize {
        let mut budget = max;
        if let Some(fit) = p.fit.as_mut() {
            let end = Self::fit_end(p.target);
            let (from, to) = (fit.pos, fit.pos.saturating_add(budget).min(end));
            match self.rec.samples() {
                Some((u, y)) => {
                    if let (Some(u), Some(y)) = (u.get(from..to), y.get(from..to)) {
                        fit.push(&p.oe, u, y);
                    }
                }
                None => fit.push_blocks(&p.oe, &self.rec, to),
            }
            budget -= to - from;
            if fit.pos < end {
                return self.work_left(p);
            }
            if let Some(x0) = fit.solve() {
                p.oe.start_at(&x0);
            }
            p.fit = None;
        }
        budget -= self.replay_samples(p, p.target, budget);
        if p.replayed < p.target {
            return self.work_left(p);
        }
        while p.refine_left > 0 && budget > 0 {
            let k = p.refine_left.min(u32::try_from(budget).unwrap_or(u32::MAX));
            // A failed step ends the refinement (θ̂ unchanged by it).
            p.refine_left = if p.law.refine(k) {
                p.refine_left - k
            } else {
                0
            };
            budget -= k as usize;
        }
        if p.refine_left == 0 {
            self.replay_samples(p, self.rec_len, budget);
        }
        self.work_left(p)
    }

    /// Replay recorded samples into `p` up to index `to`, at most `max`;
    /// returns how many.
    fn replay_samples(&self, p: &mut Pending<T, D, NP, NS>, to: usize, max: usize) -> usize {
        let from = p.replayed;
        let to = from.saturating_add(max).min(to).max(from);
        let Some((u, y)) = self.rec.samples() else {
            self.replay_blocks(p, to);
            return to - from;
        };
        let (Some(u), Some(y)) = (u.get(from..to), y.get(from..to)) else {
            return 0;
        };
        for (&u, &y) in u.iter().zip(y) {
            let s = p.oe.push(u, y);
            // A rejected reading (recorded as NaN) is no measurement: the
            // simulation runs on with u, the law skips its residual. A
            // failed step leaves θ̂ unchanged; the replay goes on.
            if s.eps.is_finite() {
                let _ = p.law.update(&s.psi, s.eps);
            }
        }
        p.replayed = to;
        to - from
    }

    /// [`Self::replay_samples`] on a record of block means: the model runs
    /// sample by sample on u; its ψ and ŷ at each reading (two samples
    /// behind the input, as [`OeModel::push`] returns them) are summed per
    /// block, and a block whose last sample is reached enters the law as
    /// one update: the block's mean ψ against its mean y − ŷ, weighted by
    /// its readings, the decay of all its samples.
    fn replay_blocks(&self, p: &mut Pending<T, D, NP, NS>, to: usize) {
        let m_len = R::BLOCK;
        for n in p.replayed..to {
            // With y = 0 pushed, ε = −ŷ exactly (y is compared by block).
            let s = p.oe.push(self.rec.u(n), T::ZERO);
            let Some(m) = n.checked_sub(2) else {
                continue;
            };
            let b = &mut p.block;
            if self.rec.valid(m) {
                for (a, v) in b.psi.iter_mut().zip(s.psi.iter()) {
                    *a += *v;
                }
                b.yhat -= s.eps;
                b.count += 1;
            }
            b.span += 1;
            if m % m_len == m_len - 1 {
                let (mean, _) = self.rec.block(m / m_len);
                let b = core::mem::replace(&mut p.block, BlockSums::EMPTY);
                Self::block_update(&mut p.law, &b, mean);
            }
        }
        p.replayed = to;
    }

    /// One law update from block sums `b` against the mean `y_mean` of the
    /// same readings.
    fn block_update(law: &mut OeLaw<T, NP, NS>, b: &BlockSums<T, NP>, y_mean: T) {
        if b.count == 0 {
            let _ = law.update_block(&[T::ZERO; NP], T::ZERO, 0, b.span);
            return;
        }
        let c = T::from_usize(b.count as usize);
        let psi = b.psi.map(|v| v / c);
        let eps = y_mean - b.yhat / c;
        // A failed step leaves θ̂ unchanged; the replay goes on.
        if eps.is_finite() {
            let _ = law.update_block(&psi, eps, b.count, b.span);
        }
    }

    /// At a hand-over, the readings of a block the replay has begun but
    /// not finished (its last sample not yet reached, or not yet two
    /// samples behind): one update against their own mean, from the y
    /// the record still keeps as it came ([`RecordStore::recent_y`]); the
    /// running law then takes the samples after them one by one. Nothing
    /// for a record of samples.
    pub(super) fn flush_block(&self, p: &mut Pending<T, D, NP, NS>) {
        if R::BLOCK == 1 {
            return;
        }
        // The replay pushed y = 0: the model's last three measurements,
        // which the running model compares with its next outputs, are the
        // record's.
        let n = p.replayed;
        p.oe.set_measured(core::array::from_fn(|k| {
            (n + k)
                .checked_sub(3)
                .and_then(|i| self.rec.recent_y(i))
                .unwrap_or(T::ZERO)
        }));
        let b = core::mem::replace(&mut p.block, BlockSums::EMPTY);
        if b.span == 0 {
            return;
        }
        // The block's readings so far: the samples m = last − span + 1 …
        // last, last = replayed − 3.
        let last = p.replayed.saturating_sub(3);
        let first = (last + 1).saturating_sub(b.span as usize);
        let mut sum = T::ZERO;
        for m in first..=last {
            if self.rec.valid(m) {
                sum += self.rec.recent_y(m).unwrap_or(T::ZERO);
            }
        }
        let mean = if b.count > 0 {
            sum / T::from_usize(b.count as usize)
        } else {
            T::ZERO
        };
        Self::block_update(&mut p.law, &b, mean);
    }

    /// Replay into `p` at most `max_samples` of the samples recorded since
    /// it was prepared (or last caught up), in record order; returns how
    /// many are still left. Off the sample path: it borrows the estimator
    /// immutably, so the caller holds the lock for one chunk at a time (or
    /// reads the record between samples).
    ///
    /// # Errors
    /// [`UpdateError::Stale`] as for [`RobustEstimator::behind`].
    pub fn catch_up(
        &self,
        p: &mut Pending<T, D, NP, NS>,
        max_samples: usize,
    ) -> Result<usize, UpdateError> {
        self.check_fresh(p)?;
        Ok(self.replay_into(p, max_samples))
    }

    /// [`RobustEstimator::apply`] with at most `max_replay` samples left to
    /// replay (inside the lock): `p` is caught up, checked and installed
    /// (its model and law are copied in; `p` itself is spent). With more
    /// samples left, nothing changes and [`UpdateError::Behind`] says to
    /// [`RobustEstimator::catch_up`] first.
    ///
    /// # Errors
    /// [`UpdateError::Behind`]; and those of [`RobustEstimator::apply`]:
    /// [`UpdateError::Stale`], [`UpdateError::RecordFull`],
    /// [`UpdateError::NotConverged`].
    pub fn apply_bounded(
        &mut self,
        p: &mut Pending<T, D, NP, NS>,
        max_replay: usize,
    ) -> Result<(), UpdateError> {
        if self.behind(p)? > max_replay {
            return Err(UpdateError::Behind);
        }
        self.admit(p)?;
        self.replay_into(p, max_replay);
        self.flush_block(p);
        self.install_model(p.oe.clone(), p.law.clone());
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::super::tests::{filter, Rig, Small};
    use super::super::{Compact, InitialState, Phase, RecordStore, RobustConfig, UpdateError};
    use super::APPLY_REPLAY_MAX;
    use crate::estimator::Estimator;
    use crate::scalar::Real;

    /// Drive two estimators the firmware's way (`update_every = 0`, an
    /// update prepared every 1,000 samples, `lag` samples arriving before
    /// it is installed): `a` with the one-shot `apply`, `b` with the chunked
    /// catch-up (`chunk` samples at a time, between samples) and
    /// `apply_bounded`. Returns both estimators' θ̂ after `n` samples and the
    /// count of updates installed.
    fn both_ways<T: Real, R: RecordStore<T> + Clone + core::fmt::Debug>(
        n: usize,
        lag: usize,
        chunk: usize,
        initial_state: InitialState,
    ) -> ([T; 7], [T; 7], u32, u32) {
        type Est<T, R> = super::super::RobustEstimator<T, 4, 7, 28, 3_000, R>;
        let cfg = RobustConfig {
            update_every: 0,
            initial_state,
            ..RobustConfig::default()
        };
        // With the initial state fitted the start-up law is held for its
        // quarantine (`QUARANTINE_TIME_CONSTANTS`/λ) after the start test: a faster Λ lets it adapt
        // inside the 0.3 s record.
        let f = match initial_state {
            InitialState::Estimate => crate::filter_bank::FilterConfig {
                lambda_rad_s: 400.0,
                ..filter()
            },
            _ => filter(),
        };
        // (and updates more often, so two candidates fit after it)
        let every = if initial_state == InitialState::Estimate {
            250
        } else {
            1_000
        };
        let mut a = Est::<T, R>::new(&f, &cfg).unwrap();
        let mut b = Est::<T, R>::new(&f, &cfg).unwrap();
        let mut rig = Rig::new();
        let mut k = 0;
        let mut step = |k: &mut usize, a: &mut Est<T, R>, b: &mut Est<T, R>| {
            let (u, y) = rig.sample();
            let (u, y) = (T::from_f64(u), T::from_f64(y));
            a.step(u, y);
            b.step(u, y);
            *k += 1;
        };
        while k < n {
            step(&mut k, &mut a, &mut b);
            if k % every != 0 || a.phase() == Phase::Steady {
                continue;
            }
            // a: one-shot preparation; b: seed, then everything in chunks
            // while the samples keep coming.
            let (pa, seed) = (a.prepare_update(), b.update_seed());
            let (Ok(pa), Ok(seed)) = (pa, seed) else {
                continue;
            };
            // a's preparation succeeded: b's start (the same model) must.
            let mut pb = seed.start().unwrap();
            for _ in 0..lag {
                step(&mut k, &mut a, &mut b);
                if b.catch_up(&mut pb, chunk).is_err() {
                    break;
                }
            }
            loop {
                match b.apply_bounded(&mut pb, APPLY_REPLAY_MAX) {
                    Err(UpdateError::Behind) => {
                        b.catch_up(&mut pb, chunk).unwrap();
                    }
                    rb => {
                        assert_eq!(a.apply(pa), rb);
                        break;
                    }
                }
            }
        }
        (a.theta(), b.theta(), a.updates(), b.updates())
    }

    #[test]
    fn chunked_catch_up_is_bit_identical_to_one_shot_apply() {
        // 0.45 s: start-up, refinement with updates, the full record and
        // steady state (the 0.3 s record fills at 3,000 samples).
        // The fit of the initial state runs in chunks too (Estimate).
        let cases = [(0, 64), (150, 7), (551, 64), (40, 1)];
        type C<T> = Compact<T, 3_000, 300, 94>;
        for init in [InitialState::Auto, InitialState::Estimate] {
            for (lag, chunk) in cases {
                for (a, b, ua, ub) in [
                    both_ways::<f64, super::super::Samples<f64, 3_000>>(4_500, lag, chunk, init),
                    both_ways::<f64, C<f64>>(4_500, lag, chunk, init),
                ] {
                    assert_eq!(a, b, "f64 lag {lag} chunk {chunk} {init:?}");
                    assert_eq!(ua, ub);
                    assert!(ua >= 1, "f64 lag {lag} {init:?}: no update installed");
                }
                for (a, b, ua, ub) in [
                    both_ways::<f32, super::super::Samples<f32, 3_000>>(4_500, lag, chunk, init),
                    both_ways::<f32, C<f32>>(4_500, lag, chunk, init),
                ] {
                    assert_eq!(a, b, "f32 lag {lag} chunk {chunk} {init:?}");
                    assert_eq!(ua, ub);
                    assert!(ua >= 1, "f32 lag {lag} {init:?}: no update installed");
                }
            }
        }
    }

    #[test]
    fn apply_bounded_refuses_then_installs_once_caught_up() {
        let cfg = RobustConfig {
            update_every: 0,
            ..RobustConfig::default()
        };
        let mut est = Small::<f64>::new(&filter(), &cfg).unwrap();
        let mut rig = Rig::new();
        rig.run(&mut est, 0.1);
        let p = est.prepare_update().unwrap();
        assert_eq!(est.apply(p), Err(UpdateError::NotConverged));
        // The next candidate after the start-up law has adapted for
        // START_MIN_ADAPT_S.
        rig.run(&mut est, 0.05);
        let mut p = est.prepare_update().unwrap();
        rig.run(&mut est, 0.01); // 100 samples arrive
        assert_eq!(est.behind(&p), Ok(100));
        let before = est.theta();
        assert_eq!(est.apply_bounded(&mut p, 32), Err(UpdateError::Behind));
        assert_eq!((est.theta(), est.phase()), (before, Phase::Startup));
        assert_eq!(est.catch_up(&mut p, 80), Ok(20));
        assert_eq!(p.replayed(), 1_580);
        assert_eq!(est.apply_bounded(&mut p, 32), Ok(()));
        assert_eq!((est.phase(), est.updates()), (Phase::Refining, 1));
        // Spent: the estimator moved on.
        assert_eq!(est.apply_bounded(&mut p, 32), Err(UpdateError::Stale));
        assert_eq!(est.catch_up(&mut p, 1), Err(UpdateError::Stale));
        // Prepared before the record filled, applied after: the samples
        // past the record are not in it, so it would lag; refused.
        let mut est = Small::<f64>::new(&filter(), &cfg).unwrap();
        let mut rig = Rig::new();
        rig.run(&mut est, 0.1);
        let _ = est.apply(est.prepare_update().unwrap());
        rig.run(&mut est, 0.05);
        let p = est.prepare_update().unwrap();
        est.apply(p).unwrap();
        let mut p = est.prepare_update().unwrap();
        rig.run(&mut est, 0.25);
        assert_eq!(est.phase(), Phase::Steady);
        assert_eq!(est.behind(&p), Err(UpdateError::Stale));
        assert_eq!(est.apply(p.clone()), Err(UpdateError::Stale));
        assert_eq!(est.apply_bounded(&mut p, 32), Err(UpdateError::Stale));
        assert!(!UpdateError::Behind.to_string().is_empty());
    }
}
