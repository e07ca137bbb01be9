//! The supervised learning step of an [`Identifier`]: the supervisor
//! ([`crate::supervise`]) decides per sample whether the law learns
//! (input present), and every [`SUPERVISE_EVERY`] samples runs the change
//! test and Lemma 1's bookkeeping.

use super::{Identifier, StepStatus, UpdateLaw};
use crate::scalar::Real;

/// The supervisor's change test and Lemma 1 bookkeeping run every this
/// many learning samples ([`crate::supervise`]; its time constants are in
/// seconds, so only the cost changes: ~1/10 of the per-sample work).
pub const SUPERVISE_EVERY: u32 = 10;

impl<T: Real, L: UpdateLaw<T, NP>, const D: usize, const NP: usize> Identifier<T, L, D, NP> {
    /// One good sample through the bank and, unless the supervisor holds
    /// it, the law.
    #[inline]
    pub(super) fn learn(&mut self, u: T, y: T) -> StepStatus {
        let reg = self.bank.push(u, y);
        if self.supervised {
            if !self.supervisor.admit(u * self.inv_u_scale) {
                return StepStatus::Frozen;
            }
            if self.pending_discount {
                // The transition after a detected change is over: forget
                // everything before it (see `supervise::change`).
                self.pending_discount = false;
                self.law.discount(T::from_f64(crate::supervise::DISCOUNT));
            }
            // The change test and Lemma 1's bookkeeping every
            // SUPERVISE_EVERY samples (the θ step's cadence by default:
            // the residual of neighbouring samples at 10 kHz carries
            // little new information, and Lemma 1 changes only at θ steps).
            self.supervise_phase += 1;
            if self.supervise_phase >= SUPERVISE_EVERY {
                self.supervise_phase = 0;
                let e = self.law.prediction_error(&reg);
                if self.supervisor.residual(e, self.samples).is_some() {
                    // Hold while the filters carry the old beam's history,
                    // then discount.
                    self.screen.hold(self.screen.quarantine_len());
                    self.pending_discount = true;
                    return StepStatus::Frozen;
                }
                let forgetting = self.supervisor.lemma1(self.law.lemma1());
                self.law.set_forgetting(forgetting);
            }
        }
        match self.law.update(&reg) {
            Ok(()) => StepStatus::Updated,
            Err(_) => {
                self.skipped = self.skipped.saturating_add(1);
                StepStatus::Skipped
            }
        }
    }
}
