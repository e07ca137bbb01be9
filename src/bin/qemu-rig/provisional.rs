//! Provisional per-sample path of the emulated rig, until the real
//! pipeline (ADS131M02/AD5761R drivers against their chip models) replaces
//! it: one call to [`RigPipeline::step`] per timer interrupt.
//!
//! Each sample: advance the simulated beam (the paper's plant, Section
//! IV.A, eq. 46 numerator, simulated exactly in `f64`) over the past period
//! with the held drive u; sample y; next excitation value (0.1·square(7 Hz))
//! becomes the held u; step the `f32` estimator (λ = 100 rad/s, U0 = 0.1,
//! the excitation amplitude); every [`RECORD_EVERY`] samples push Θ into
//! the telemetry queue for the low-priority context.
//!
//! # Start-up
//! Y0 (the output scale of the filter bank) is the RMS of y over the first
//! [`STARTUP_SAMPLES`] samples (0.1 s), measured here with the excitation
//! running; thread mode then builds the estimator and hands it over
//! ([`Handoff`]). The beam is moving by then, so the estimator's filters
//! start out of step with it: the law is held (its input quarantine, see
//! `beamest::estimator`) for 40 filter time constants (0.4 s at
//! λ = 100 rad/s) while they settle. Measured on the host: without that
//! hold the estimate is 71% off on ω2 after 5 s, with it 9e-8.

#![deny(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::panic,
    clippy::indexing_slicing
)]

use beamest::board::qemu::cycles::{self, SpanSum};
use beamest::board::qemu::Handoff;
use beamest::estimator::{Adaptive2, Estimator, StepStatus};
use beamest::excitation::SquareWave;
use beamest::model::{PAPER_B, PAPER_OMEGA, PAPER_ZETA};
use beamest::plant::{ModalPlant, PlantError};
use heapless::spsc::Producer;

/// Samples of the start-up window that measures Y0 (0.1 s at 10 kHz).
pub const STARTUP_SAMPLES: u32 = 1_000;
/// A telemetry record every this many samples (100 Hz).
pub const RECORD_EVERY: u32 = 100;
/// Telemetry queue size (holds `TELEMETRY_QUEUE - 1` records: 150 ms).
pub const TELEMETRY_QUEUE: usize = 16;
/// Sample period of the rig, s (the paper's Ts).
pub const TS_S: f64 = 1e-4;

/// Number of estimated parameters Θ for two modes (eq. 29: 4n − 1).
pub const NP: usize = 7;

/// What the sample path sends to the low-priority context.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Record {
    /// The start-up window ended: build the estimator with this Y0.
    Startup {
        /// RMS of y over the window (units of y).
        y_rms: f32,
    },
    /// Θ (eq. 29, physical units) after `sample` samples.
    Estimate {
        /// Samples since boot.
        sample: u32,
        /// Θ.
        theta: [f32; NP],
        /// Estimator steps that did not update the law so far (frozen,
        /// rejected or skipped).
        not_updated: u32,
    },
}

/// Instruction spans of the sample path, summed over its samples.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Spans {
    /// `Estimator::step` alone.
    pub estimator: SpanSum,
    /// The simulated beam (`ModalPlant<f64>::advance` + `output`): the
    /// rig, standing in for the ADC and DAC transfers.
    pub plant: SpanSum,
}

/// The provisional sample path: simulated rig + excitation + estimator.
pub struct RigPipeline {
    plant: ModalPlant<f64>,
    excitation: SquareWave<f32>,
    u_held: f32,
    estimator: Option<&'static mut Adaptive2<f32>>,
    estimator_slot: &'static Handoff<&'static mut Adaptive2<f32>>,
    telemetry: Producer<'static, Record>,
    sample: u32,
    y_square_sum: f32,
    not_updated: u32,
    dropped: u32,
    spans: Spans,
}

impl RigPipeline {
    /// The paper's plant at rest, the paper's excitation, no estimator yet.
    pub fn new(
        estimator_slot: &'static Handoff<&'static mut Adaptive2<f32>>,
        telemetry: Producer<'static, Record>,
    ) -> Result<Self, PlantError> {
        Ok(Self {
            plant: ModalPlant::with_numerator(&PAPER_OMEGA, &PAPER_ZETA, &PAPER_B, TS_S)?,
            excitation: SquareWave::paper(),
            u_held: 0.0,
            estimator: None,
            estimator_slot,
            telemetry,
            sample: 0,
            y_square_sum: 0.0,
            not_updated: 0,
            dropped: 0,
            spans: Spans::default(),
        })
    }

    /// One sample period. Never allocates, formats, blocks or panics.
    #[inline(never)]
    pub fn step(&mut self) {
        let t0 = cycles::now();
        self.plant.advance(f64::from(self.u_held));
        let y = self.plant.output() as f32;
        self.spans.plant.add(t0, cycles::now());

        let u = self.excitation.next_sample();
        self.u_held = u;

        if self.estimator.is_none() {
            self.estimator = self.estimator_slot.take();
        }
        match self.estimator.as_mut() {
            Some(est) => {
                let t1 = cycles::now();
                let status = est_step(est, u, y);
                self.spans.estimator.add(t1, cycles::now());
                if status != StepStatus::Updated {
                    self.not_updated = self.not_updated.saturating_add(1);
                }
            }
            None if self.sample < STARTUP_SAMPLES => {
                self.y_square_sum += y * y;
                if self.sample + 1 == STARTUP_SAMPLES {
                    let mean = self.y_square_sum / STARTUP_SAMPLES as f32;
                    self.push(Record::Startup {
                        y_rms: libm::sqrtf(mean),
                    });
                }
            }
            None => {}
        }

        self.sample = self.sample.wrapping_add(1);
        if self.sample % RECORD_EVERY == 0 {
            if let Some(est) = self.estimator.as_ref() {
                let record = Record::Estimate {
                    sample: self.sample,
                    theta: est.theta(),
                    not_updated: self.not_updated,
                };
                self.push(record);
            }
        }
    }

    fn push(&mut self, record: Record) {
        if self.telemetry.enqueue(record).is_err() {
            self.dropped = self.dropped.saturating_add(1);
        }
    }

    /// Samples processed.
    pub fn samples(&self) -> u32 {
        self.sample
    }

    /// Records dropped because the telemetry queue was full.
    pub fn dropped(&self) -> u32 {
        self.dropped
    }

    /// Instruction spans so far.
    pub fn spans(&self) -> Spans {
        self.spans
    }

    /// Θ now, if the estimator runs.
    pub fn theta(&self) -> Option<[f32; NP]> {
        self.estimator.as_ref().map(|e| e.theta())
    }
}

/// The estimator step, kept out of line so its instructions can be found
/// in the disassembly (soft-float check).
#[inline(never)]
fn est_step(est: &mut Adaptive2<f32>, u: f32, y: f32) -> StepStatus {
    est.step(u, y)
}
