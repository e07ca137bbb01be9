//! What the serial link needs from this board ([`beamest::link::Device`]):
//! the pipeline inside the sample task's lock, and the estimators' static
//! storage.
//!
//! Two `Adaptive2<f32>` slots exist (both placed at boot): the one the
//! pipeline steps and a spare. A new estimator is built into the spare in
//! thread mode, with the sample interrupt running (its matrix
//! exponentials take ~10⁵ instructions), swapped in inside the lock, and
//! the replaced one's slot becomes the spare. The robust estimator
//! (`EstimatorKind::Robust`, `Robust2<f32>`, its 2 s record in each) has two slots of
//! its own, used the same way (a robust estimator replaced by another one
//! needs both). Every lock span is timed (SysTick): the longest is how
//! long a command, a swap or a robust model update's chunk ever delayed
//! a sample.

#![deny(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::panic,
    clippy::indexing_slicing
)]

use beam_protocol::{EstimatorKind, EstimatorSettings, RejectReason};
use beamest::board::qemu::cycles::{self, SpanSum};
use beamest::board::qemu::meter::TimedEstimator;
use beamest::board::qemu::{IsrOwned, Shared};
use beamest::estimator::robust::{Robust2, DEFAULT_RECORD};
use beamest::estimator::{Adaptive2, Either};
use beamest::filter_bank::FilterConfig;
use beamest::link::reject_config;
use beamest::link::{estimator_configs, with_theta0, Device, RobustAccess};

use crate::sample::{Est, RigPipeline, SampleTask, NP};

/// The board's side of the link.
pub struct QemuDevice {
    task: &'static Shared<IsrOwned<&'static mut SampleTask>>,
    spare: Option<&'static mut Adaptive2<f32>>,
    robust: [Option<&'static mut Robust2<f32>>; 2],
    locks: SpanSum,
}

impl QemuDevice {
    /// The device around the shared sample task, with the spare estimator
    /// slot and the two robust estimators' slots.
    /// Without the `qemu-robust` feature there are no robust slots (`[None,
    /// None]`) and the kind is refused.
    pub fn new(
        task: &'static Shared<IsrOwned<&'static mut SampleTask>>,
        spare: &'static mut Adaptive2<f32>,
        robust: [Option<&'static mut Robust2<f32>>; 2],
    ) -> Self {
        Self {
            task,
            spare: Some(spare),
            robust,
            locks: SpanSum::default(),
        }
    }

    /// Thread-mode lock spans so far (SysTick ticks).
    pub fn locks(&self) -> SpanSum {
        self.locks
    }

    /// Run `f` on the simulated bench inside the lock (boot: a fault).
    pub fn with_rig<R>(
        &mut self,
        f: impl FnOnce(&mut beamest::bench::ConverterRig<'static>) -> R,
    ) -> R {
        match self.task.lock(|t| f(t.get_mut().rig_mut())) {
            Some(r) => r,
            None => crate::fail("sample task not placed"),
        }
    }
}

/// The running robust estimator inside the lock (timed like every lock).
impl RobustAccess<f32, DEFAULT_RECORD> for QemuDevice {
    fn with_robust<R>(&mut self, f: impl FnOnce(&mut Robust2<f32>) -> R) -> Option<R> {
        self.with_pipeline(|p| p.estimator_mut().inner_mut().right_mut().map(|r| f(r)))
    }
}

impl Device for QemuDevice {
    type Real = f32;
    type Estimator = Est;
    type Pipeline = RigPipeline;

    fn with_pipeline<R>(&mut self, f: impl FnOnce(&mut RigPipeline) -> R) -> R {
        let t0 = cycles::now();
        let r = self.task.lock(|t| f(t.get_mut().pipeline_mut()));
        self.locks.add(t0, cycles::now());
        match r {
            Some(r) => r,
            // The task is placed before the link runs.
            None => crate::fail("sample task not placed"),
        }
    }

    fn build_estimator(
        &mut self,
        settings: &EstimatorSettings,
        filter: &FilterConfig,
        theta0: &[f64],
    ) -> Result<Est, RejectReason> {
        match settings.kind {
            EstimatorKind::Adaptive => self.build_adaptive(settings, filter, theta0),
            #[cfg(feature = "qemu-robust")]
            EstimatorKind::Robust => self.build_robust(settings, filter, theta0),
            #[cfg(not(feature = "qemu-robust"))]
            EstimatorKind::Robust => Err(RejectReason::EstimatorUnavailable),
            EstimatorKind::Gradient | EstimatorKind::LeastSquares => {
                Err(RejectReason::EstimatorUnavailable)
            }
        }
    }

    fn recycle_estimator(&mut self, old: Est) {
        match old.into_inner() {
            Either::Left(a) => self.spare = Some(a),
            Either::Right(r) => {
                if let Some(free) = self.robust.iter_mut().find(|s| s.is_none()) {
                    *free = Some(r);
                }
            }
        }
    }
}

impl QemuDevice {
    /// The paper's adaptive law into the spare slot.
    fn build_adaptive(
        &mut self,
        settings: &EstimatorSettings,
        filter: &FilterConfig,
        theta0: &[f64],
    ) -> Result<Est, RejectReason> {
        let (filter, law) = estimator_configs::<NP>(settings, filter.lambda_rad_s, filter);
        let Some(law) = with_theta0(law, theta0) else {
            return Err(RejectReason::EstimatorUnavailable);
        };
        let Some(slot) = self.spare.take() else {
            return Err(RejectReason::EstimatorUnavailable);
        };
        match Adaptive2::<f32>::new(&filter, &law) {
            Ok(est) => {
                *slot = est;
                Ok(TimedEstimator::new(Either::Left(slot)))
            }
            Err(e) => {
                self.spare = Some(slot);
                Err(reject_config(e))
            }
        }
    }

    /// The robust estimator into a free robust slot, rebuilt in place
    /// (`theta0`: its start-up law's θ(0)); model updates are then
    /// prepared in thread mode ([`crate::robust::RobustUpdates`]).
    #[cfg(feature = "qemu-robust")]
    fn build_robust(
        &mut self,
        settings: &EstimatorSettings,
        filter: &FilterConfig,
        theta0: &[f64],
    ) -> Result<Est, RejectReason> {
        let Some(free) = self.robust.iter_mut().find(|s| s.is_some()) else {
            return Err(RejectReason::EstimatorUnavailable);
        };
        let Some(slot) = free.take() else {
            return Err(RejectReason::EstimatorUnavailable);
        };
        match beamest::link::rebuild_robust(slot, settings, filter, theta0) {
            Ok(()) => Ok(TimedEstimator::new(Either::Right(slot))),
            Err(e) => {
                *free = Some(slot);
                Err(e)
            }
        }
    }
}
