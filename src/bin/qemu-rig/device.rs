//! What the serial link needs from this board ([`beamest::link::Device`]):
//! the pipeline inside the sample task's lock, and the estimators' static
//! storage.
//!
//! Two `Adaptive2<f32>` slots exist (both placed at boot): the one the
//! pipeline steps and a spare. A new estimator is built into the spare in
//! thread mode, with the sample interrupt running (its matrix
//! exponentials take ~10⁵ instructions), swapped in inside the lock, and
//! the replaced one's slot becomes the spare. The robust estimator
//! (`EstimatorKind::Robust`, [`Robust2Compact`]`<f32>`: its 2 s start-up
//! record in the compact form, 53,720 B) has one slot and a head workspace
//! (2,848 B): while the slot is free a new robust estimator is built into
//! it in thread mode and swapped in like the adaptive law; while it runs,
//! a new one (another `SetEstimator` Robust, the tuning rule's
//! re-centring) is built into the head workspace in thread mode and
//! installed into the running slot inside the lock
//! ([`QemuDevice::swap_estimator`], a copy of the head: the record starts
//! afresh). Every lock span is timed (SysTick): the longest is how long a
//! command, a swap or a robust model update's chunk ever delayed a
//! sample.

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
use beamest::estimator::robust::{CompactRecord, Head, Robust2Compact, DEFAULT_RECORD};
use beamest::estimator::{Adaptive2, Either};
use beamest::filter_bank::FilterConfig;
use beamest::link::{estimator_configs, with_theta0, Device, RobustAccess};
use beamest::link::{rebuild_robust, reject_config, robust_head};

use crate::sample::{Est, RigPipeline, RobustSlot, SampleTask, NP};

/// The board's side of the link.
pub struct QemuDevice {
    task: &'static Shared<IsrOwned<&'static mut SampleTask>>,
    spare: Option<&'static mut Adaptive2<f32>>,
    /// The robust estimator's slot while the pipeline does not run it.
    robust: Option<&'static mut Robust2Compact<f32>>,
    /// The head workspace while no head waits for installation.
    head: Option<&'static mut Head<f32, 4, NP, 28>>,
    locks: SpanSum,
}

impl QemuDevice {
    /// The device around the shared sample task, with the spare estimator
    /// slot, the robust estimator's slot and its head workspace.
    pub fn new(
        task: &'static Shared<IsrOwned<&'static mut SampleTask>>,
        spare: &'static mut Adaptive2<f32>,
        robust: &'static mut Robust2Compact<f32>,
        head: &'static mut Head<f32, 4, NP, 28>,
    ) -> Self {
        Self {
            task,
            spare: Some(spare),
            robust: Some(robust),
            head: Some(head),
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
impl RobustAccess<f32, DEFAULT_RECORD, CompactRecord<f32>> for QemuDevice {
    fn with_robust<R>(&mut self, f: impl FnOnce(&mut Robust2Compact<f32>) -> R) -> Option<R> {
        self.with_pipeline(|p| match p.estimator_mut().inner_mut().right_mut() {
            Some(RobustSlot::Slot(r)) => Some(f(r)),
            _ => None,
        })
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
            EstimatorKind::Robust => self.build_robust(settings, filter, theta0),
            EstimatorKind::Gradient | EstimatorKind::LeastSquares => {
                Err(RejectReason::EstimatorUnavailable)
            }
        }
    }

    fn recycle_estimator(&mut self, old: Est) {
        match old.into_inner() {
            Either::Left(a) => self.spare = Some(a),
            Either::Right(RobustSlot::Slot(r)) => self.robust = Some(r),
            Either::Right(RobustSlot::Head(h)) => self.head = Some(h),
        }
    }

    /// A head ([`RobustSlot::Head`]: a new robust estimator while the slot
    /// runs) is installed into the running slot inside the lock
    /// ([`Robust2Compact::install`], then the pipeline starts it as a
    /// swapped-in estimator: `Pipeline::rebuild_estimator`) and comes back
    /// to be recycled; anything else is swapped in.
    fn swap_estimator(
        &mut self,
        estimator: Est,
        lambda_rad_s: f64,
        resume: bool,
    ) -> (Result<Est, Est>, u64) {
        if !matches!(estimator.inner(), Either::Right(RobustSlot::Head(_))) {
            return self.with_pipeline(|pl| {
                let swap = pl.replace_estimator(estimator, lambda_rad_s);
                if swap.is_ok() && resume {
                    pl.resume();
                }
                (swap, pl.next_sample_index())
            });
        }
        self.with_pipeline(|pl| {
            let runs_slot = matches!(pl.estimator().inner().right(), Some(RobustSlot::Slot(_)));
            let installed = match estimator.inner() {
                Either::Right(RobustSlot::Head(h)) if runs_slot => {
                    pl.rebuild_estimator(lambda_rad_s, |e| {
                        if let Some(RobustSlot::Slot(slot)) = e.inner_mut().right_mut() {
                            slot.install(h);
                        }
                    })
                }
                _ => false,
            };
            if installed && resume {
                pl.resume();
            }
            let at = pl.next_sample_index();
            (
                if installed {
                    Ok(estimator)
                } else {
                    Err(estimator)
                },
                at,
            )
        })
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

    /// The robust estimator: into its slot, rebuilt in place, while the
    /// pipeline does not run it; else into the head workspace, for
    /// [`QemuDevice::swap_estimator`] to install into the running slot
    /// (`theta0`: its start-up law's θ(0)). Model updates are then prepared
    /// in thread mode ([`crate::robust::RobustUpdates`]).
    fn build_robust(
        &mut self,
        settings: &EstimatorSettings,
        filter: &FilterConfig,
        theta0: &[f64],
    ) -> Result<Est, RejectReason> {
        let step = beamest::bench::input_step_v();
        if let Some(slot) = self.robust.take() {
            return match rebuild_robust(slot, settings, filter, theta0, step) {
                Ok(()) => Ok(TimedEstimator::new(Either::Right(RobustSlot::Slot(slot)))),
                Err(e) => {
                    self.robust = Some(slot);
                    Err(e)
                }
            };
        }
        // The slot runs: the pipeline holds a robust estimator, or a head
        // is already out (refused).
        let Some(head) = self.head.take() else {
            return Err(RejectReason::EstimatorUnavailable);
        };
        match robust_head::<f32>(settings, filter, theta0, step) {
            Ok(h) => {
                *head = h;
                Ok(TimedEstimator::new(Either::Right(RobustSlot::Head(head))))
            }
            Err(e) => {
                self.head = Some(head);
                Err(e)
            }
        }
    }
}
