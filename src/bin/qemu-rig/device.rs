//! What the serial link needs from this board ([`beamest::link::Device`]):
//! the pipeline inside the sample task's lock, and the estimators' static
//! storage.
//!
//! Two `Adaptive2<f32>` slots exist (both placed at boot): the one the
//! pipeline steps and a spare. A new estimator is built into the spare in
//! thread mode, with the sample interrupt running (its matrix
//! exponentials take ~10⁵ instructions), swapped in inside the lock, and
//! the replaced one's slot becomes the spare. Every lock span is timed
//! (SysTick): the longest is how long a command ever delayed a sample.

#![deny(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::panic,
    clippy::indexing_slicing
)]

use beamest::board::qemu::cycles::{self, SpanSum};
use beamest::board::qemu::meter::TimedEstimator;
use beamest::board::qemu::{IsrOwned, Shared};
use beamest::estimator::Adaptive2;
use beamest::filter_bank::FilterConfig;
use beamest::link::control::reject_config;
use beamest::link::{estimator_configs, with_theta0, Device};
use beamest::protocol::{EstimatorSettings, RejectReason};

use crate::sample::{Est, RigPipeline, SampleTask, NP};

/// The board's side of the link.
pub struct QemuDevice {
    task: &'static Shared<IsrOwned<&'static mut SampleTask>>,
    spare: Option<&'static mut Adaptive2<f32>>,
    locks: SpanSum,
}

impl QemuDevice {
    /// The device around the shared sample task, with the spare estimator
    /// slot.
    pub fn new(
        task: &'static Shared<IsrOwned<&'static mut SampleTask>>,
        spare: &'static mut Adaptive2<f32>,
    ) -> Self {
        Self {
            task,
            spare: Some(spare),
            locks: SpanSum::default(),
        }
    }

    /// Thread-mode lock spans so far (SysTick ticks).
    pub fn locks(&self) -> SpanSum {
        self.locks
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
                Ok(TimedEstimator::new(slot))
            }
            Err(e) => {
                self.spare = Some(slot);
                Err(reject_config(e))
            }
        }
    }

    fn recycle_estimator(&mut self, old: Est) {
        self.spare = Some(old.into_inner());
    }
}
