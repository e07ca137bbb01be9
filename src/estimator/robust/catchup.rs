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
//! The replayed samples, their order and the arithmetic are those of
//! [`RobustEstimator::apply`]: the result is bit-identical (tests below).

use super::{Pending, RobustEstimator, UpdateError};
use crate::scalar::Real;

/// The most samples [`RobustEstimator::apply_bounded`] replays inside the
/// lock when the firmware uses this bound: 32 samples are ~70,000
/// instructions on the Cortex-M4F in `f32` (2,200 per replayed sample,
/// `cargo xtask robust-bench`), 0.7 ms, i.e. at most 7 sample periods
/// delayed — not lost: the sample interrupt is pending meanwhile and the
/// converters' data are read late (see BENCHMARKS.md).
pub const APPLY_REPLAY_MAX: usize = 32;

impl<T, const D: usize, const NP: usize, const NS: usize> Pending<T, D, NP, NS> {
    /// Samples of the record this update has replayed so far.
    pub fn replayed(&self) -> usize {
        self.replayed
    }
}

impl<T: Real, const D: usize, const NP: usize, const NS: usize, const B: usize>
    RobustEstimator<T, D, NP, NS, B>
{
    /// Samples recorded since `p` was prepared (or last caught up) that it
    /// has not replayed yet.
    ///
    /// # Errors
    /// [`UpdateError::Stale`] if `p` can no longer be applied (the
    /// estimator was reset or updated since, or samples arrived after the
    /// record was full).
    pub fn behind(&self, p: &Pending<T, D, NP, NS>) -> Result<usize, UpdateError> {
        self.check_fresh(p)?;
        Ok(self.rec_len - p.replayed)
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
        self.install(p.oe.clone(), p.law.clone());
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::super::tests::{filter, Rig, Small};
    use super::super::{Phase, RobustConfig, UpdateError};
    use super::APPLY_REPLAY_MAX;
    use crate::estimator::Estimator;
    use crate::scalar::Real;

    /// Drive two estimators the firmware's way (`update_every = 0`, an
    /// update prepared every 1,000 samples, `lag` samples arriving before
    /// it is installed): `a` with the one-shot `apply`, `b` with the chunked
    /// catch-up (`chunk` samples at a time, between samples) and
    /// `apply_bounded`. Returns both estimators' θ̂ after `n` samples and the
    /// count of updates installed.
    fn both_ways<T: Real>(n: usize, lag: usize, chunk: usize) -> ([T; 7], [T; 7], u32, u32) {
        let cfg = RobustConfig {
            update_every: 0,
            ..RobustConfig::default()
        };
        let mut a = Small::<T>::new(&filter(), &cfg).unwrap();
        let mut b = Small::<T>::new(&filter(), &cfg).unwrap();
        let mut rig = Rig::new();
        let mut k = 0;
        let mut step = |k: &mut usize, a: &mut Small<T>, b: &mut Small<T>| {
            let (u, y) = rig.sample();
            let (u, y) = (T::from_f64(u), T::from_f64(y));
            a.step(u, y);
            b.step(u, y);
            *k += 1;
        };
        while k < n {
            step(&mut k, &mut a, &mut b);
            if k % 1_000 != 0 || a.phase() == Phase::Steady {
                continue;
            }
            let (Ok(pa), Ok(mut pb)) = (a.prepare_update(), b.prepare_update()) else {
                continue;
            };
            // Samples arrive while b catches up chunk by chunk.
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
        for (lag, chunk) in [(0, 64), (150, 7), (551, 64), (40, 1)] {
            let (a, b, ua, ub) = both_ways::<f64>(4_500, lag, chunk);
            assert_eq!(a, b, "f64 lag {lag} chunk {chunk}");
            assert_eq!(ua, ub);
            assert!(ua >= 1, "f64 lag {lag}: no update installed");
            let (a, b, ua, ub) = both_ways::<f32>(4_500, lag, chunk);
            assert_eq!(a, b, "f32 lag {lag} chunk {chunk}");
            assert_eq!(ua, ub);
            assert!(ua >= 1, "f32 lag {lag}: no update installed");
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
        let mut p = est.prepare_update().unwrap();
        rig.run(&mut est, 0.01); // 100 samples arrive
        assert_eq!(est.behind(&p), Ok(100));
        let before = est.theta();
        assert_eq!(est.apply_bounded(&mut p, 32), Err(UpdateError::Behind));
        assert_eq!((est.theta(), est.phase()), (before, Phase::Startup));
        assert_eq!(est.catch_up(&mut p, 80), Ok(20));
        assert_eq!(p.replayed(), 1_080);
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
