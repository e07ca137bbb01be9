//! The learner: what every estimator keeps around its law — the input
//! screen (bad samples never reach the filters, see *Bad input* in the
//! module docs of [`crate::estimator`]), the supervisor
//! ([`crate::supervise`]) and the health counters — and, for an
//! [`Identifier`](super::Identifier), the supervised learning step: per
//! sample the supervisor decides whether the law learns (input present),
//! and every [`SUPERVISE_EVERY`] samples it runs the change test and takes
//! the law's in-loop Lemma 1.

use super::screen::{InputScreen, Screened};
use super::{Health, StepStatus, UpdateLaw};
use crate::filter_bank::{FilterConfig, Regressor};
use crate::scalar::Real;
use crate::supervise::{Supervision, Supervisor, SupervisorConfig};

/// The supervisor's change test and Lemma 1 bookkeeping run every this
/// many learning samples ([`crate::supervise`]; its time constants are in
/// seconds, so only the cost changes: ~1/10 of the per-sample work).
pub(crate) const SUPERVISE_EVERY: u32 = 10;
const _: () = assert!(SUPERVISE_EVERY <= u8::MAX as u32);

/// Screen, supervisor and counters of one estimator (module docs).
#[derive(Debug, Clone)]
pub(crate) struct Learner<T> {
    /// The input screen and its quarantine.
    pub screen: InputScreen<T>,
    /// The supervisor.
    pub supervisor: Supervisor<T>,
    /// Whether the supervisor acts and reports
    /// ([`super::Estimator::supervision`]).
    supervised: bool,
    /// 1/U0, for the supervisor's input monitor.
    inv_u_scale: T,
    /// A change was detected: discount the old data when the hold ends.
    pending_discount: bool,
    /// Samples since the change test last ran (< [`SUPERVISE_EVERY`]; a
    /// byte, which shares the padding of the two flags: the two-mode `f32`
    /// estimator's size is pinned, host test `precision`).
    supervise_phase: u8,
    /// Samples since the information monitor last took the regressor's
    /// power (< `INFORM_EVERY`).
    inform_phase: u8,
    /// Samples pushed.
    pub samples: u64,
    /// Law updates that failed (saturating).
    pub skipped: u32,
}

impl<T: Real> Learner<T> {
    /// For an [`Identifier`](super::Identifier) built with `filter` whose
    /// law has the supervisor settings `sup` and reports Lemma 1 in the
    /// loop if `lemma1` ([`UpdateLaw::MEASURES_LEMMA1`]); the change test
    /// runs every [`SUPERVISE_EVERY`] samples.
    pub fn new(filter: &FilterConfig, sup: &SupervisorConfig, lemma1: bool) -> Self {
        let supervisor = if lemma1 {
            Supervisor::new(sup, filter.ts_s).with_lemma1()
        } else {
            Supervisor::new(sup, filter.ts_s)
        }
        .with_residual_every(SUPERVISE_EVERY, filter.ts_s);
        Self::with_supervisor(filter, supervisor, *sup != SupervisorConfig::OFF)
    }

    /// With a supervisor built by the estimator (`supervised`: whether it
    /// acts and reports).
    pub(crate) fn with_supervisor(
        filter: &FilterConfig,
        supervisor: Supervisor<T>,
        supervised: bool,
    ) -> Self {
        Self {
            screen: InputScreen::new(filter),
            supervisor,
            supervised,
            inv_u_scale: T::from_f64(1.0 / filter.scales.u_scale),
            pending_discount: false,
            supervise_phase: 0,
            inform_phase: 0,
            samples: 0,
            skipped: 0,
        }
    }

    /// The regressor `phi` of a good sample (the law's, learnt from or
    /// not): its power to the supervisor's information monitor every
    /// `INFORM_EVERY` samples.
    #[inline]
    pub(crate) fn observe(&mut self, phi: &[T]) {
        if !self.supervised {
            return;
        }
        self.inform_phase += 1;
        if u32::from(self.inform_phase) >= crate::supervise::INFORM_EVERY {
            self.inform_phase = 0;
            let power = phi.iter().fold(T::ZERO, |s, v| s + *v * *v);
            self.supervisor.inform(power);
        }
    }

    /// The sample's input `u` (scaled by 1/U0) to the supervisor's input
    /// monitor; false if adaptation must be frozen for it (input gone).
    #[inline]
    pub(crate) fn admit(&mut self, u: T) -> bool {
        self.supervisor.admit(u * self.inv_u_scale)
    }

    /// One sample of an [`Identifier`](super::Identifier): screened, then
    /// through the filters (`push`, which returns the law's regressor) and,
    /// for a good sample the supervisor admits, into `law`.
    #[inline]
    pub fn step<L: UpdateLaw<T, NL>, const NL: usize>(
        &mut self,
        u: T,
        y: T,
        mut push: impl FnMut(T, T) -> Regressor<T, NL>,
        law: &mut L,
    ) -> StepStatus {
        self.samples = self.samples.wrapping_add(1);
        match self.screen.screen(u, y) {
            Screened::Good(u, y) => {
                let reg = push(u, y);
                self.learn(law, &reg, u)
            }
            Screened::Quarantined(u, y) => {
                push(u, y);
                if self.supervised {
                    self.admit(u);
                }
                StepStatus::Frozen
            }
            Screened::Rejected(u, y) => {
                push(u, y);
                StepStatus::Rejected
            }
        }
    }

    /// One good sample's regressor `reg` (input `u`) into `law`, unless the
    /// supervisor holds it.
    #[inline]
    fn learn<L: UpdateLaw<T, NL>, const NL: usize>(
        &mut self,
        law: &mut L,
        reg: &Regressor<T, NL>,
        u: T,
    ) -> StepStatus {
        if self.supervised {
            self.observe(&reg.phi);
            if !self.admit(u) {
                return StepStatus::Frozen;
            }
            if self.pending_discount {
                // The transition after a detected change is over: forget
                // everything before it (see `supervise::change`).
                self.pending_discount = false;
                law.discount(T::from_f64(crate::supervise::DISCOUNT));
            }
            // The change test and Lemma 1's bookkeeping every
            // SUPERVISE_EVERY samples (the θ step's cadence by default:
            // the residual of neighbouring samples at 10 kHz carries
            // little new information, and Lemma 1 changes only at θ steps).
            self.supervise_phase += 1;
            if u32::from(self.supervise_phase) >= SUPERVISE_EVERY {
                self.supervise_phase = 0;
                let e = law.prediction_error(reg);
                if self.supervisor.residual(e, self.samples).is_some() {
                    // Hold while the filters carry the old beam's history,
                    // then discount.
                    self.screen.hold(self.screen.quarantine_len());
                    self.pending_discount = true;
                    return StepStatus::Frozen;
                }
                let forgetting = self.supervisor.lemma1(law.lemma1());
                law.set_forgetting(forgetting);
            }
        }
        match law.update(reg) {
            Ok(()) => StepStatus::Updated,
            Err(_) => {
                self.skipped = self.skipped.saturating_add(1);
                StepStatus::Skipped
            }
        }
    }

    /// [`super::Estimator::hold`]: the screen holds the law; the change
    /// test learns the residual's level afresh
    /// ([`Supervisor::restart_change`]).
    pub fn hold(&mut self, samples: u32) {
        self.screen.hold(samples);
        self.supervisor.restart_change();
    }

    /// [`super::Estimator::settling_samples`]: the quarantine's length.
    pub fn settling_samples(&self) -> u32 {
        self.screen.quarantine_len()
    }

    /// [`super::Estimator::supervision`]: the supervisor's state if it acts.
    pub fn supervision(&self) -> Option<Supervision<T>> {
        self.supervised.then(|| self.supervisor.status())
    }

    /// [`super::Estimator::health`], with the law's `state_ok`.
    pub fn health(&self, state_ok: bool) -> Health {
        Health {
            samples: self.samples,
            rejected: self.screen.rejected,
            skipped: self.skipped,
            state_ok,
        }
    }

    /// Back to the start (screen, supervisor, counters).
    pub fn reset(&mut self) {
        self.screen.reset();
        self.supervisor.reset();
        self.pending_discount = false;
        self.supervise_phase = 0;
        self.inform_phase = 0;
        self.samples = 0;
        self.skipped = 0;
    }
}
