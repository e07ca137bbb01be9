//! The serial link on the reference board: the core's device end
//! ([`beamest::link::DeviceLink`], docs/PROTOCOL.md) on USART3, the same
//! code the QEMU image runs, with this board's side of it ([`NucleoDevice`]:
//! the sample task's pipeline inside its critical section, the adaptive law
//! built by value, the robust estimator rebuilt in one of its two static
//! slots) and its fixed properties ([`link_config`], [`start_settings`],
//! [`tuning`]). Thread mode only: records, raw blocks and received bytes
//! are handed to the link there; commands are applied between two samples
//! (the lock masks the DRDY interrupt for a setter or a swap).

use beam_protocol::budget::uart_bytes_per_s;
use beam_protocol::{EstimatorKind, EstimatorSettings, Limits, RejectReason, TelemetryRates};
use beamest::estimator::robust::ExternalUpdates;
use beamest::estimator::{Adaptive2, Either};
use beamest::excitation::{MULTISINE_MAX_TONES, PRBS_MAX_ORDER, PRBS_MIN_ORDER};
use beamest::filter_bank::FilterConfig;
use beamest::link::reject_config;
use beamest::link::{
    estimator_configs, rebuild_robust, with_theta0, Device, FlagRules, LinkConfig, RobustAccess,
    Settings, FIRMWARE_VERSION,
};
use beamest::tuning::{LambdaSource, TuningConfig};

use beamest::board::nucleo::clocks;

use crate::rig;
use crate::{Est, RigPipeline, RobustSlot, ROBUST_RECORD, SAMPLE};

/// What the link checks commands against: the ADC's rate, the actuator's
/// safe window, every generator's range, the adaptive law and the robust
/// estimator (its record in the AXI and D2 SRAMs), two modes, and USART3's
/// line rate as the link budget.
pub fn link_config() -> LinkConfig {
    LinkConfig {
        limits: Limits {
            sample_rate_hz: rig::SAMPLE_RATE_HZ as f32,
            piezo_min_v: rig::SAFE_WINDOW.min_v as f32,
            piezo_max_v: rig::SAFE_WINDOW.max_v as f32,
            max_multisine_tones: MULTISINE_MAX_TONES as u8,
            prbs_bits_min: PRBS_MIN_ORDER,
            prbs_bits_max: PRBS_MAX_ORDER,
            estimators: EstimatorKind::Adaptive.bit() | EstimatorKind::Robust.bit(),
            modes: 2,
            link_bytes_per_s: uart_bytes_per_s(clocks::BAUD) as f32,
        },
        firmware: FIRMWARE_VERSION,
        rules: FlagRules::default(),
        self_test: rig::self_test_config(),
    }
}

/// The settings at power-up: the start-up excitation of [`rig::excitation`],
/// the core's default gains with λ chosen by the automatic rule
/// (`lambda_rad_s = None`), the protocol's default telemetry rates.
pub fn start_settings() -> Settings {
    Settings {
        excitation: rig::start_excitation(),
        estimator: EstimatorSettings::default(),
        telemetry: TelemetryRates::default(),
    }
}

/// The truth-free tuning rule of this board (docs/SETTINGS.md): its sample
/// period and converter timing, λ0 from the data, the core's defaults.
pub fn tuning() -> TuningConfig {
    TuningConfig {
        timing: rig::output_timing(),
        ..TuningConfig::new(rig::TS_S, LambdaSource::Data)
    }
}

/// The board's side of the link: the robust estimator's two static slots
/// (`crate::robust_slots`), one running and one to build the next into (a
/// λ re-centring or a new command while it runs), or both free.
pub struct NucleoDevice {
    robust: [Option<&'static mut RobustSlot>; 2],
}

impl NucleoDevice {
    /// The device with the robust estimator's two slots.
    pub fn new(robust: [Option<&'static mut RobustSlot>; 2]) -> Self {
        Self { robust }
    }

    /// The adaptive law, by value (a few KB on the stack).
    fn build_adaptive(
        settings: &EstimatorSettings,
        filter: &FilterConfig,
        theta0: &[f64],
    ) -> Result<Est, RejectReason> {
        let (filter, law) =
            estimator_configs::<{ crate::NP }>(settings, filter.lambda_rad_s, filter);
        let law = with_theta0(law, theta0).ok_or(RejectReason::EstimatorUnavailable)?;
        Adaptive2::<f64>::new(&filter, &law)
            .map(Either::Left)
            .map_err(reject_config)
    }

    /// The robust estimator, rebuilt in place in a free slot.
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
        // (Its record keeps every u as it came: no input grid.)
        match rebuild_robust(slot, settings, filter, theta0, 0.0) {
            Ok(()) => Ok(Either::Right(ExternalUpdates(slot))),
            Err(e) => {
                *free = Some(slot);
                Err(e)
            }
        }
    }
}

impl Device for NucleoDevice {
    type Real = f64;
    type Estimator = Est;
    type Pipeline = RigPipeline;

    fn with_pipeline<R>(&mut self, f: impl FnOnce(&mut RigPipeline) -> R) -> R {
        match SAMPLE.with(|t| f(&mut t.pipeline)) {
            Some(r) => r,
            // The task is placed before the link runs.
            None => crate::fatal("sample task", "not placed"),
        }
    }

    fn build_estimator(
        &mut self,
        settings: &EstimatorSettings,
        filter: &FilterConfig,
        theta0: &[f64],
    ) -> Result<Est, RejectReason> {
        match settings.kind {
            EstimatorKind::Adaptive => Self::build_adaptive(settings, filter, theta0),
            EstimatorKind::Robust => self.build_robust(settings, filter, theta0),
            EstimatorKind::Gradient | EstimatorKind::LeastSquares => {
                Err(RejectReason::EstimatorUnavailable)
            }
        }
    }

    fn recycle_estimator(&mut self, old: Est) {
        if let Either::Right(r) = old {
            if let Some(free) = self.robust.iter_mut().find(|s| s.is_none()) {
                *free = Some(r.into_inner());
            }
        }
    }

    /// The ADS131M02 converts on its own clock: wait for a tick to end.
    fn align_to_sample(&mut self) {
        crate::between_samples();
    }
}

/// The running robust estimator inside the sample task's lock.
impl RobustAccess<f64, ROBUST_RECORD> for NucleoDevice {
    fn with_robust<R>(&mut self, f: impl FnOnce(&mut RobustSlot) -> R) -> Option<R> {
        self.with_pipeline(|p| p.estimator_mut().right_mut().map(|r| f(r.inner_mut())))
    }
}
