//! One of two estimators, chosen at run time: a firmware that switches
//! laws by command ([`beam_protocol::EstimatorKind`]) steps an
//! `Either<A, B>` and its sample path stays free of dynamic dispatch (one
//! branch per call).

use crate::estimator::{Estimator, Health, StepStatus};
use crate::model::TransferFunction;
use crate::scalar::Real;
use crate::supervise::Supervision;

/// Either estimator `L` or estimator `R`.
#[derive(Debug, Clone)]
pub enum Either<L, R> {
    /// The first kind (e.g. the paper's adaptive law).
    Left(L),
    /// The second kind (e.g. the robust estimator).
    Right(R),
}

impl<L, R> Either<L, R> {
    /// The second kind, if this is it.
    pub fn right(&self) -> Option<&R> {
        match self {
            Self::Left(_) => None,
            Self::Right(r) => Some(r),
        }
    }

    /// The second kind, mutably, if this is it.
    pub fn right_mut(&mut self) -> Option<&mut R> {
        match self {
            Self::Left(_) => None,
            Self::Right(r) => Some(r),
        }
    }
}

/// Forward `$call` to whichever estimator this is.
macro_rules! either {
    ($self:expr, $e:ident => $call:expr) => {
        match $self {
            Either::Left($e) => $call,
            Either::Right($e) => $call,
        }
    };
}

impl<T: Real, L: Estimator<T, NP>, R: Estimator<T, NP>, const NP: usize> Estimator<T, NP>
    for Either<L, R>
{
    #[inline]
    fn step(&mut self, u: T, y: T) -> StepStatus {
        either!(self, e => e.step(u, y))
    }
    fn theta(&self) -> [T; NP] {
        either!(self, e => e.theta())
    }
    fn transfer_function(&self) -> TransferFunction<T> {
        either!(self, e => e.transfer_function())
    }
    fn reset(&mut self) {
        either!(self, e => e.reset())
    }
    fn excitation_level(&self) -> Option<T> {
        either!(self, e => e.excitation_level())
    }
    fn health(&self) -> Health {
        either!(self, e => e.health())
    }
    fn information(&self) -> Option<[[T; NP]; NP]> {
        either!(self, e => e.information())
    }
    fn hold(&mut self, samples: u32) {
        either!(self, e => e.hold(samples))
    }
    fn settling_samples(&self) -> u32 {
        either!(self, e => e.settling_samples())
    }
    fn supervision(&self) -> Option<Supervision<T>> {
        either!(self, e => e.supervision())
    }
    fn residual(&self) -> Option<super::feedthrough::Residual<T>> {
        either!(self, e => e.residual())
    }
    fn hold_for_settling(&mut self) {
        either!(self, e => e.hold_for_settling())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::estimator::robust::{Robust2, RobustConfig};
    use crate::estimator::{Adaptive2, AdaptiveConfig};
    use crate::filter_bank::{FilterConfig, SignalScales};

    #[test]
    fn forwards_every_call_to_the_chosen_estimator() {
        let f = FilterConfig {
            scales: SignalScales {
                u_scale: 0.1,
                y_scale: 4e-3,
            },
            ..FilterConfig::default()
        };
        let a = Adaptive2::<f64>::new(&f, &AdaptiveConfig::default()).unwrap();
        let r = Robust2::<f64>::new(&f, &RobustConfig::default()).unwrap();
        let mut plain = (a.clone(), r.clone());
        let mut left: Either<_, Robust2<f64>> = Either::Left(a);
        let mut right: Either<Adaptive2<f64>, _> = Either::Right(r);
        assert!(left.right().is_none() && right.right_mut().is_some());
        for k in 0..3_000 {
            let (u, y) = (
                if k % 700 < 350 { 0.1 } else { -0.1 },
                1e-3 * (k as f64).sin(),
            );
            assert_eq!(left.step(u, y), plain.0.step(u, y));
            assert_eq!(right.step(u, y), plain.1.step(u, y));
        }
        assert_eq!(left.theta(), plain.0.theta());
        assert_eq!(right.theta(), plain.1.theta());
        assert_eq!(right.information(), Some(plain.1.information()));
        assert_eq!(left.health(), plain.0.health());
        assert_eq!(right.settling_samples(), plain.1.settling_samples());
        right.hold(5);
        assert_eq!(right.step(0.1, 0.0), StepStatus::Frozen);
        right.reset();
        assert_eq!(right.health().samples, 0);
    }
}
