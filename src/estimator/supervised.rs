//! The supervised learning step of an [`Identifier`]: the supervisor
//! ([`crate::supervise`]) decides per sample whether the law learns
//! (input present), and every [`SUPERVISE_EVERY`] samples runs the change
//! test and Lemma 1's bookkeeping.

use super::screen::InputScreen;
use super::{Identifier, StepStatus, UpdateLaw};
use crate::filter_bank::Regressor;
use crate::scalar::Real;
use crate::supervise::Supervisor;

/// The supervisor's change test and Lemma 1 bookkeeping run every this
/// many learning samples ([`crate::supervise`]; its time constants are in
/// seconds, so only the cost changes: ~1/10 of the per-sample work).
pub const SUPERVISE_EVERY: u32 = 10;

/// What the supervised learning step reads and writes besides the law:
/// the fields an [`Identifier`] and a
/// [`Feedthrough`](super::feedthrough::Feedthrough) share.
pub(super) struct LearnState<'a, T> {
    pub screen: &'a mut InputScreen<T>,
    pub supervisor: &'a mut Supervisor<T>,
    pub supervised: bool,
    pub inv_u_scale: T,
    pub pending_discount: &'a mut bool,
    pub supervise_phase: &'a mut u32,
    pub skipped: &'a mut u32,
    pub samples: u64,
}

/// One good sample's regressor `reg` (input `u`) into `law`, unless the
/// supervisor holds it.
#[inline]
pub(super) fn learn<T: Real, L: UpdateLaw<T, NP>, const NP: usize>(
    law: &mut L,
    reg: &Regressor<T, NP>,
    u: T,
    st: LearnState<'_, T>,
) -> StepStatus {
    if st.supervised {
        if !st.supervisor.admit(u * st.inv_u_scale) {
            return StepStatus::Frozen;
        }
        if *st.pending_discount {
            // The transition after a detected change is over: forget
            // everything before it (see `supervise::change`).
            *st.pending_discount = false;
            law.discount(T::from_f64(crate::supervise::DISCOUNT));
        }
        // The change test and Lemma 1's bookkeeping every
        // SUPERVISE_EVERY samples (the θ step's cadence by default:
        // the residual of neighbouring samples at 10 kHz carries
        // little new information, and Lemma 1 changes only at θ steps).
        *st.supervise_phase += 1;
        if *st.supervise_phase >= SUPERVISE_EVERY {
            *st.supervise_phase = 0;
            let e = law.prediction_error(reg);
            if st.supervisor.residual(e, st.samples).is_some() {
                // Hold while the filters carry the old beam's history,
                // then discount.
                st.screen.hold(st.screen.quarantine_len());
                *st.pending_discount = true;
                return StepStatus::Frozen;
            }
            let forgetting = st.supervisor.lemma1(law.lemma1());
            law.set_forgetting(forgetting);
        }
    }
    match law.update(reg) {
        Ok(()) => StepStatus::Updated,
        Err(_) => {
            *st.skipped = st.skipped.saturating_add(1);
            StepStatus::Skipped
        }
    }
}

impl<T: Real, L: UpdateLaw<T, NP>, const D: usize, const NP: usize> Identifier<T, L, D, NP> {
    /// One good sample through the bank and, unless the supervisor holds
    /// it, the law.
    #[inline]
    pub(super) fn learn(&mut self, u: T, y: T) -> StepStatus {
        let reg = self.bank.push(u, y);
        learn(
            &mut self.law,
            &reg,
            u,
            LearnState {
                screen: &mut self.screen,
                supervisor: &mut self.supervisor,
                supervised: self.supervised,
                inv_u_scale: self.inv_u_scale,
                pending_discount: &mut self.pending_discount,
                supervise_phase: &mut self.supervise_phase,
                skipped: &mut self.skipped,
                samples: self.samples,
            },
        )
    }
}
