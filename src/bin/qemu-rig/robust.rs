//! The robust estimator's model updates in thread mode: the core's
//! scheduler ([`beamest::link::RobustUpdates`], shared with the NUCLEO
//! image) with this board's chunk sizes ([`CHUNK`], [`APPLY_MAX`]), one
//! poll per pass of the thread-mode loop, lock spans on SysTick; and the
//! report at the end of the run. Every one of these locks is also counted
//! in the device's lock statistics.

#![deny(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::panic,
    clippy::indexing_slicing
)]

use beamest::board::qemu::cycles::SpanSum;
use beamest::estimator::robust::Phase;
use beamest::link::{Device, RobustAccess};
use cortex_m_semihosting::hprintln;

use crate::device::QemuDevice;

/// Units (a replayed or fitted sample, or a refinement step; ≈ 2,000–4,000
/// instructions each on the Cortex-M4F in `f32`) per catch-up lock: ≲ 60,000
/// instructions, under the 100,000 of a sample period minus the sample
/// interrupt's ~20,000.
pub const CHUNK: usize = 16;
/// Most units left to do inside the installing lock.
pub const APPLY_MAX: usize = 16;

/// The updates of this image's robust estimator, lock spans in SysTick
/// ticks.
pub type RobustUpdates = beamest::link::RobustUpdates<f32, SpanSum>;

/// The scheduler with this image's chunk sizes.
pub fn updates() -> RobustUpdates {
    RobustUpdates::new(CHUNK, APPLY_MAX)
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
