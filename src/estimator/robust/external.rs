//! The robust estimator as firmware steps it: its model updates run
//! elsewhere (thread mode, in bounded chunks: [`crate::link::RobustUpdates`]),
//! never inside the sample path's step.

use super::{RecordStore, RobustEstimator};
use crate::estimator::{Estimator, Health, StepStatus};
use crate::model::TransferFunction;
use crate::scalar::Real;
use crate::supervise::Supervision;

/// A robust estimator (by value or borrowed: `E` is a
/// [`RobustEstimator`] or a `&mut` one) whose [`Estimator::step`] records
/// and runs the law only: the model updates that `step` runs itself when
/// `update_every > 0` (the replays, matrix exponentials and root finding of
/// [`RobustEstimator::prepare_update`]) are not called from it at all, so
/// the sample interrupt's call graph holds none of that work (the NUCLEO
/// image's check: no panic, no software floating point). With
/// `update_every = 0`, as on the devices (`crate::link::robust_configs`),
/// it steps exactly like the estimator itself.
#[derive(Debug)]
pub struct ExternalUpdates<E>(pub E);

impl<E> ExternalUpdates<E> {
    /// The estimator.
    pub fn inner_mut(&mut self) -> &mut E {
        &mut self.0
    }

    /// The estimator, unwrapped.
    pub fn into_inner(self) -> E {
        self.0
    }
}

impl<
        T: Real,
        const D: usize,
        const NP: usize,
        const NS: usize,
        const B: usize,
        R: RecordStore<T>,
    > Estimator<T, NP> for ExternalUpdates<&mut RobustEstimator<T, D, NP, NS, B, R>>
{
    #[inline]
    fn step(&mut self, u: T, y: T) -> StepStatus {
        self.0.step_recording(u, y)
    }
    fn theta(&self) -> [T; NP] {
        self.0.theta()
    }
    fn transfer_function(&self) -> TransferFunction<T> {
        self.0.transfer_function()
    }
    fn reset(&mut self) {
        Estimator::reset(&mut *self.0)
    }
    fn excitation_level(&self) -> Option<T> {
        self.0.excitation_level()
    }
    fn health(&self) -> Health {
        self.0.health()
    }
    fn information(&self) -> Option<[[T; NP]; NP]> {
        Estimator::information(&*self.0)
    }
    fn hold(&mut self, samples: u32) {
        self.0.hold(samples)
    }
    fn settling_samples(&self) -> u32 {
        self.0.settling_samples()
    }
    fn supervision(&self) -> Option<Supervision<T>> {
        self.0.supervision()
    }
    fn residual(&self) -> Option<crate::estimator::feedthrough::Residual<T>> {
        self.0.residual()
    }
}

#[cfg(test)]
mod tests {
    use super::super::tests::{filter, Rig, Small};
    use super::super::RobustConfig;
    use super::*;

    /// With `update_every = 0` it steps exactly like the estimator itself;
    /// with `update_every > 0` it never updates the model.
    #[test]
    fn steps_like_the_estimator_without_updates() {
        let external = RobustConfig {
            update_every: 0,
            ..RobustConfig::default()
        };
        let mut a = Small::<f64>::new(&filter(), &external).unwrap();
        let mut b = Small::<f64>::new(&filter(), &external).unwrap();
        let mut wrapped = ExternalUpdates(&mut b);
        let mut rig = Rig::new();
        for _ in 0..4_000 {
            let (u, y) = rig.sample();
            assert_eq!(a.step(u, y), wrapped.step(u, y));
        }
        assert_eq!(a.theta(), wrapped.theta());
        assert_eq!(Estimator::information(&a), wrapped.information());

        let mut c = Small::<f64>::new(&filter(), &RobustConfig::default()).unwrap();
        let mut wrapped = ExternalUpdates(&mut c);
        let mut rig = Rig::new();
        for _ in 0..6_000 {
            let (u, y) = rig.sample();
            wrapped.step(u, y);
        }
        assert_eq!(c.updates(), 0);
        assert_eq!(c.recorded(), 3_000);
    }
}
