//! The robust estimator's model updates in thread mode, on any board
//! (`crate::estimator::robust`, `update_every = 0` on a device): while its
//! start-up record lasts, every [`UPDATE_EVERY`] recorded samples an
//! update is seeded (a short copy inside the lock), its model built outside
//! the lock ([`UpdateSeed::start`](crate::estimator::robust::UpdateSeed::start):
//! roots, matrix exponential), then the O(record) work — initial-state fit,
//! replay, refinement, the samples recorded meanwhile — done in chunks of
//! [`RobustUpdates::chunk`] units, each under its own short lock, one
//! chunk per [`RobustUpdates::poll`], while the sample interrupt keeps
//! stepping the current model and recording; the update is installed
//! (`apply_bounded`) once at most [`RobustUpdates::apply_max`] units are
//! left. Every one of these locks is timed by the board's clock
//! ([`LockSpans`]).

use crate::estimator::robust::{
    Pending, Phase, RecordStore, RobustEstimator, Samples, UpdateError,
};
use crate::scalar::Real;

/// Recorded samples between two updates (the host default,
/// `RobustConfig::update_every`).
pub const UPDATE_EVERY: usize = 1_000;

/// Polls between two looks for a due update (each look is a lock): a
/// thread-mode loop runs every few thousand instructions, so a due update
/// waits a fraction of a sample period at most.
const LOOK_EVERY: u32 = 16;

/// A board's access to the running two-mode robust estimator (record of
/// `B` samples kept in `S`) inside the sample interrupt's lock.
pub trait RobustAccess<T: Real, const B: usize, S: RecordStore<T> = Samples<T, B>> {
    /// Run `f` on the running robust estimator with the sample interrupt
    /// masked; `None` if the pipeline runs another kind.
    fn with_robust<R>(
        &mut self,
        f: impl FnOnce(&mut RobustEstimator<T, 4, 7, 28, B, S>) -> R,
    ) -> Option<R>;
}

/// Lock-span statistics on a board's clock.
pub trait LockSpans: Default {
    /// A reading of the board's clock.
    type Instant: Copy;
    /// The clock now.
    fn now() -> Self::Instant;
    /// Add the span from `start` to `end`.
    fn add(&mut self, start: Self::Instant, end: Self::Instant);
}

/// The update in progress and the statistics.
#[derive(Debug, Clone)]
pub struct RobustUpdates<T, S> {
    pending: Option<Pending<T, 4, 7, 28>>,
    chunk: usize,
    apply_max: usize,
    /// Record length at the last seed.
    seeded_at: usize,
    /// Updates seeded.
    pub seeded: u32,
    /// Installed.
    pub applied: u32,
    /// Start-up candidate still moving (stored for the next check).
    pub not_converged: u32,
    /// Refused: stale (the estimator moved on), unstable, or the record
    /// filled first.
    pub refused: u32,
    /// Catch-up chunks run.
    pub chunks: u32,
    /// Lock spans of these updates (seed, chunks, installation).
    pub locks: S,
    /// Seed to installation, in samples recorded meanwhile: the longest.
    pub longest_lag: usize,
    started_at: usize,
    /// Polls since the last look for a due update.
    idle: u32,
}

impl<T: Real, S: LockSpans> RobustUpdates<T, S> {
    /// `chunk` units (a replayed or fitted sample, or a refinement step)
    /// per catch-up lock, at most `apply_max` left to do inside the
    /// installing lock: each bounds how long one lock delays a sample.
    pub fn new(chunk: usize, apply_max: usize) -> Self {
        Self {
            pending: None,
            chunk,
            apply_max,
            seeded_at: 0,
            seeded: 0,
            applied: 0,
            not_converged: 0,
            refused: 0,
            chunks: 0,
            locks: S::default(),
            longest_lag: 0,
            started_at: 0,
            idle: 0,
        }
    }

    /// Units per catch-up lock.
    pub fn chunk(&self) -> usize {
        self.chunk
    }

    /// Most units left to do inside the installing lock.
    pub fn apply_max(&self) -> usize {
        self.apply_max
    }

    /// One step of work, if the pipeline runs the robust estimator.
    pub fn poll<const B: usize, R: RecordStore<T>>(
        &mut self,
        dev: &mut impl RobustAccess<T, B, R>,
    ) {
        let t0 = S::now();
        match self.pending.take() {
            None => self.seed(dev),
            Some(mut p) => {
                let (chunk, apply_max) = (self.chunk, self.apply_max);
                // None: a chunk done, more to do.
                let r = dev.with_robust(|r| match r.behind(&p) {
                    Ok(left) if left <= apply_max => Some(r.apply_bounded(&mut p, apply_max)),
                    Ok(_) => r.catch_up(&mut p, chunk).err().map(Err),
                    Err(e) => Some(Err(e)),
                });
                self.locks.add(t0, S::now());
                match r {
                    // Not robust any more: drop the update.
                    None => {}
                    Some(None) => {
                        self.chunks = self.chunks.saturating_add(1);
                        self.pending = Some(p);
                    }
                    Some(Some(Ok(()))) => {
                        self.applied = self.applied.saturating_add(1);
                        self.longest_lag = self
                            .longest_lag
                            .max(p.replayed().saturating_sub(self.started_at));
                    }
                    Some(Some(Err(UpdateError::NotConverged))) => {
                        self.not_converged = self.not_converged.saturating_add(1);
                    }
                    Some(Some(Err(_))) => self.refused = self.refused.saturating_add(1),
                }
            }
        }
    }

    /// Seed an update when one is due, and build its model outside the lock.
    fn seed<const B: usize, R: RecordStore<T>>(&mut self, dev: &mut impl RobustAccess<T, B, R>) {
        self.idle += 1;
        if self.idle < LOOK_EVERY {
            return;
        }
        self.idle = 0;
        let t0 = S::now();
        let seeded_at = self.seeded_at;
        let seed = dev.with_robust(|r| {
            let n = r.recorded();
            // A new record (a new estimator, a reset, a detected change).
            let due = n < seeded_at || n >= seeded_at + UPDATE_EVERY;
            (r.phase() != Phase::Steady && due).then(|| (n, r.update_seed()))
        });
        let Some(Some((n, seed))) = seed else {
            if seed.is_some() {
                self.locks.add(t0, S::now());
            }
            return;
        };
        self.locks.add(t0, S::now());
        self.seeded_at = n;
        self.started_at = n;
        self.seeded = self.seeded.saturating_add(1);
        match seed.and_then(|s| s.start()) {
            Ok(p) => self.pending = Some(p),
            Err(_) => self.refused = self.refused.saturating_add(1),
        }
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used, clippy::indexing_slicing)]
mod tests {
    use super::*;
    use crate::estimator::robust::ExternalUpdates;
    use crate::estimator::Estimator;
    use crate::excitation::SquareWave;
    use crate::filter_bank::{FilterConfig, SignalScales};
    use crate::link::rebuild_robust;
    use crate::modal::modal_from_tf;
    use crate::model::{PAPER_B, PAPER_OMEGA, PAPER_ZETA};
    use crate::rig::ModalPlant;
    use beam_protocol::{EstimatorKind, EstimatorSettings};

    /// A 0.6 s record keeps the test quick.
    const B: usize = 6_000;
    type Slot = RobustEstimator<f64, 4, 7, 28, B>;

    /// The device side of a board, without a lock: the estimator the
    /// "sample interrupt" steps.
    struct Board {
        est: ExternalUpdates<&'static mut Slot>,
    }

    impl RobustAccess<f64, B> for Board {
        fn with_robust<R>(&mut self, f: impl FnOnce(&mut Slot) -> R) -> Option<R> {
            Some(f(self.est.inner_mut()))
        }
    }

    /// Lock spans counted, not timed.
    #[derive(Default)]
    struct Count(u32);

    impl LockSpans for Count {
        type Instant = ();
        fn now() {}
        fn add(&mut self, _: (), _: ()) {
            self.0 += 1;
        }
    }

    /// The firmware's arrangement on the host: the estimator rebuilt in
    /// place for the link's settings, stepped without in-step updates, its
    /// model updates run by the scheduler between samples in small chunks
    /// (as the NUCLEO image does, 4 units per lock): the updates are
    /// installed, the record fills, and the estimate is the beam's.
    #[test]
    fn updates_between_samples_converge() {
        let filter = FilterConfig {
            lambda_rad_s: 100.0,
            scales: SignalScales {
                u_scale: 0.1,
                y_scale: 4e-3,
            },
            ..FilterConfig::default()
        };
        let settings = EstimatorSettings {
            kind: EstimatorKind::Robust,
            ..EstimatorSettings::default()
        };
        let (f0, law) = crate::link::robust_configs::<7>(&settings, 100.0, &filter);
        assert_eq!(law.update_every, 0);
        let mut board = Board {
            est: ExternalUpdates(Box::leak(Box::new(Slot::new(&f0, &law).unwrap()))),
        };
        // A second build into the same slot, as a new command would.
        rebuild_robust(board.est.inner_mut(), &settings, &filter, &[], 0.0).unwrap();
        let mut updates = RobustUpdates::<f64, Count>::new(4, 4);
        let mut plant =
            ModalPlant::with_numerator(&PAPER_OMEGA, &PAPER_ZETA, &PAPER_B, 1e-4).unwrap();
        let mut sq = SquareWave::<f64>::paper();
        for _ in 0..30_000 {
            let u = sq.next_sample();
            board.est.step(u, plant.sample(u));
            for _ in 0..8 {
                updates.poll(&mut board);
            }
        }
        let est = board.est.inner_mut();
        assert_eq!(est.phase(), Phase::Steady);
        assert!(updates.applied >= 2 && est.updates() == updates.applied);
        assert!(updates.chunks > 0 && updates.locks.0 > updates.chunks);
        let m = modal_from_tf(&est.transfer_function(), &[-2.0, 2.0]).unwrap();
        for i in 0..2 {
            assert!((m.omega_rad_s[i] / PAPER_OMEGA[i] - 1.0).abs() < 1e-6);
            assert!((m.zeta[i] / PAPER_ZETA[i] - 1.0).abs() < 1e-5);
        }
    }
}
