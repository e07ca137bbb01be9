//! The simulated rig: one plant, one excitation and one noise model in the
//! `no_std` core, so `beamctl simulate`, the host tests and the emulated
//! firmware all run the same rig.
//!
//! * `plant` — an exact discrete simulator of the modal model (eq. 22–23)
//!   under a held input: what the beam does between two samples;
//! * `noise` — seeded, deterministic Gaussian measurement noise;
//! * `sim` — [`Rig`], which joins them per 10 kHz tick exactly as the
//!   firmware's sample path sees the beam: the input u held over the coming
//!   period and the output y sampled now (plus noise);
//! * `scenario` — [`ScenarioRig`]: a [`Rig`] going through the events of
//!   a [`Scenario`] (a plant change with the state continuous, excitation
//!   off, sensor faults on the measured y) and with modes beyond the
//!   estimator's model.
//!
//! * [`chips`] — behavioural models of the converters (ADS131M02 ADC,
//!   AD5761R DAC) behind `SpiDevice`, so the real drivers run against the
//!   simulated beam;
//! * `timing` — [`TimedPlant`]: the beam as the converters see it, the
//!   ADS131M02's sinc³ averaging and the DAC's update latency simulated
//!   exactly ([`ConverterTiming`]).
//!
//! The rig depends on the foundations (model, numerics), the converter
//! drivers' encodings and the excitation only: the assembly of a bench
//! around it, with the sample task's front end, pipeline and link, is
//! [`crate::bench`].
//!
//! The rig runs in the emulated board's sample interrupt, so the whole
//! module keeps the sample path's panic-free lints.
#![deny(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::panic,
    clippy::indexing_slicing
)]

pub mod chips;
pub(crate) mod noise;
pub(crate) mod plant;
pub(crate) mod scenario;
pub(crate) mod sim;
pub(crate) mod timing;

pub use noise::{noise_sd_for_snr, GaussianNoise, NoiseError};
pub use plant::{ModalPlant, PlantError};
pub use scenario::{
    beam_modes, ExcitationOff, FaultKind, PlantStep, Scenario, ScenarioError, ScenarioRig,
    SensorFault, Window,
};
pub use sim::{Rig, Sample};
pub use timing::{ConverterTiming, TimedPlant};
