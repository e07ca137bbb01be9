//! The robust estimator's model updates in thread mode
//! (`beamest::estimator::robust`, `update_every = 0` on the device): while
//! its start-up record lasts, every [`UPDATE_EVERY`] recorded samples an
//! update is seeded (a short copy inside the lock), its model built outside
//! the lock ([`UpdateSeed::start`](beamest::estimator::robust::UpdateSeed::start):
//! roots, matrix exponential), then the O(record) work — initial-state fit,
//! replay, refinement, the samples recorded meanwhile — done in chunks of
//! [`CHUNK`] units, each under its own short lock, one chunk per pass of
//! the thread-mode loop, while the sample interrupt keeps stepping the
//! current model and recording; the update is installed
//! (`apply_bounded`) once at most [`APPLY_MAX`] units are left. Every one of
//! these locks is also counted in the device's lock statistics.

#![deny(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::panic,
    clippy::indexing_slicing
)]

use beamest::board::qemu::cycles::{self, SpanSum};
use beamest::estimator::robust::{Pending, Phase, UpdateError};
use beamest::link::Device;
use cortex_m_semihosting::hprintln;

use crate::device::QemuDevice;

/// Recorded samples between two updates (the host default,
/// `RobustConfig::update_every`).
pub const UPDATE_EVERY: usize = 1_000;
/// Units (a replayed or fitted sample, or a refinement step; ≈ 2,000–4,000
/// instructions each on the Cortex-M4F in `f32`) per catch-up lock: ≲ 60,000
/// instructions, under the 100,000 of a sample period minus the sample
/// interrupt's ~20,000.
pub const CHUNK: usize = 16;
/// Most units left to do inside the installing lock.
pub const APPLY_MAX: usize = 16;

/// The update in progress and the statistics.
#[derive(Debug, Clone, Default)]
pub struct RobustUpdates {
    pending: Option<Pending<f32, 4, 7, 28>>,
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
    /// Lock spans of these updates (seed, chunks, installation), ticks.
    pub locks: SpanSum,
    /// Seed to installation, in samples recorded meanwhile: the longest.
    pub longest_lag: usize,
    started_at: usize,
    /// Polls since the last look for a due update.
    idle: u32,
}

/// Polls of the thread-mode loop between two looks for a due update (each
/// look is a lock): the loop runs every few thousand instructions, so a
/// due update waits a fraction of a sample period at most.
const LOOK_EVERY: u32 = 16;

impl RobustUpdates {
    /// One step of work, if the pipeline runs the robust estimator.
    pub fn poll(&mut self, dev: &mut QemuDevice) {
        let t0 = cycles::now();
        match self.pending.take() {
            None => self.seed(dev),
            Some(mut p) => {
                // None: a chunk done, more to do.
                let r = dev.with_robust(|r| match r.behind(&p) {
                    Ok(left) if left <= APPLY_MAX => Some(r.apply_bounded(&mut p, APPLY_MAX)),
                    Ok(_) => r.catch_up(&mut p, CHUNK).err().map(Err),
                    Err(e) => Some(Err(e)),
                });
                self.locks.add(t0, cycles::now());
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
    fn seed(&mut self, dev: &mut QemuDevice) {
        self.idle += 1;
        if self.idle < LOOK_EVERY {
            return;
        }
        self.idle = 0;
        let t0 = cycles::now();
        let seeded_at = self.seeded_at;
        let seed = dev.with_robust(|r| {
            let n = r.recorded();
            // A new record (a new estimator, a reset, a detected change).
            let due = n < seeded_at || n >= seeded_at + UPDATE_EVERY;
            (r.phase() != Phase::Steady && due).then(|| (n, r.update_seed()))
        });
        let Some(Some((n, seed))) = seed else {
            if seed.is_some() {
                self.locks.add(t0, cycles::now());
            }
            return;
        };
        self.locks.add(t0, cycles::now());
        self.seeded_at = n;
        self.started_at = n;
        self.seeded = self.seeded.saturating_add(1);
        match seed.and_then(|s| s.start()) {
            Ok(p) => self.pending = Some(p),
            Err(_) => self.refused = self.refused.saturating_add(1),
        }
    }
}

/// The robust estimator's figures at the end of the run (timer stopped),
/// and `rig: robust` with what `cargo xtask qemu --robust` judges: its
/// phase, the model updates installed and the longest lock they took
/// (instructions).
pub fn report(u: &RobustUpdates, dev: &mut QemuDevice, ipt: f32) {
    let state = dev.with_robust(|r| (r.phase(), r.updates(), r.recorded()));
    let steps = dev.with_pipeline(|p| p.estimator().steps());
    let max = |s: &SpanSum| (s.max_ticks as f32 * ipt) as u32;
    hprintln!(
        "robust estimator: step (every sample since it was built, {} steps) mean {} max {} \
         instructions",
        steps.count,
        libm::roundf(steps.mean_instructions(ipt)) as u32,
        max(&steps)
    );
    hprintln!(
        "robust model updates in thread mode: {} seeded, {} installed, {} start-up candidates \
         still moving, {} refused; {} catch-up chunks of {} units; longest seed-to-install {} \
         samples; their locks: {}, longest {} instructions (mean {})",
        u.seeded,
        u.applied,
        u.not_converged,
        u.refused,
        u.chunks,
        CHUNK,
        u.longest_lag,
        u.locks.count,
        max(&u.locks),
        libm::roundf(u.locks.mean_instructions(ipt)) as u32
    );
    hprintln!(
        "robust_lock_instructions: {}; robust_step_instructions: mean {} max {}",
        max(&u.locks),
        libm::roundf(steps.mean_instructions(ipt)) as u32,
        max(&steps)
    );
    match state {
        Some((phase, updates, recorded)) => {
            let phase = match phase {
                Phase::Startup => "startup",
                Phase::Refining => "refining",
                Phase::Steady => "steady",
            };
            hprintln!(
                "robust estimator: phase {}, {} model updates, {} samples recorded",
                phase,
                updates,
                recorded
            );
            hprintln!(
                "rig: robust running=true phase={} updates={} lock_max_instructions={}",
                phase,
                updates,
                max(&u.locks)
            );
        }
        None => {
            hprintln!("robust estimator: not running at the end");
            hprintln!("rig: robust running=false");
        }
    }
}
