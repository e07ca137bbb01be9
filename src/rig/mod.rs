//! The simulated rig: one plant, one excitation and one noise model in the
//! `no_std` core, so `beamctl simulate`, the host tests and the emulated
//! firmware all run the same rig.
//!
//! * [`plant`] — an exact discrete simulator of the modal model (eq. 22–23)
//!   under a held input: what the beam does between two samples;
//! * [`noise`] — seeded, deterministic Gaussian measurement noise;
//! * [`sim`] — [`Rig`], which joins them per 10 kHz tick exactly as the
//!   firmware's sample path sees the beam: the input u held over the coming
//!   period and the output y sampled now (plus noise);
//! * [`scenario`] — [`ScenarioRig`]: a [`Rig`] going through the events of
//!   a [`Scenario`] (a plant change with the state continuous, excitation
//!   off, sensor faults on the measured y) and with modes beyond the
//!   estimator's model.
//!
//! * [`chips`] — behavioural models of the converters (ADS131M02 ADC,
//!   AD5761R DAC) behind `SpiDevice`, so the real drivers run against the
//!   simulated beam;
//! * [`converter`] — [`ConverterRig`]: the plant between those two models
//!   with the analog front end (amplifier, bridge, monitor), one DRDY
//!   period per tick — the rig the QEMU image and the firmware host tests
//!   run behind the real drivers;
//! * [`timing`] — [`TimedPlant`]: the beam as the converters see it, the
//!   ADS131M02's sinc³ averaging and the DAC's update latency simulated
//!   exactly ([`ConverterTiming`]);
//! * [`bench`](mod@bench) — the settings of that simulated bench (the paper's beam,
//!   the converters' configuration and timing, the front end, the
//!   excitation).
//!
//! The rig runs in the emulated board's sample interrupt, so the whole
//! module keeps the sample path's panic-free lints.
#![deny(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::panic,
    clippy::indexing_slicing
)]

pub mod bench;
pub mod chips;
pub mod converter;
pub mod noise;
pub mod plant;
pub mod scenario;
pub mod sim;
pub mod timing;

pub use converter::{ConverterModels, ConverterRig, RigError, RigTick};
pub use noise::{noise_sd_for_snr, GaussianNoise, NoiseError, Xoshiro256PlusPlus};
pub use plant::{ModalPlant, PlantError};
pub use scenario::{
    beam_modes, ExcitationOff, FaultKind, PlantStep, Scenario, ScenarioError, ScenarioRig,
    SensorFault, Window,
};
pub use sim::{Rig, Sample};
pub use timing::{ConverterTiming, TimedPlant};
