//! Converter drivers on `embedded-hal` 1.0 alone.
//!
//! * [`ads131m02`] — TI ADS131M02, the 24-bit two-channel simultaneous
//!   sampling ΔΣ ADC that digitises the strain-gauge bridge (channel 0) and
//!   the piezo-amplifier monitor (channel 1);
//! * [`ad5761r`] — ADI AD5761R, the 16-bit bipolar voltage-output DAC that
//!   drives the piezo amplifier.
//!
//! Both drivers own an [`embedded_hal::spi::SpiDevice`] (the bus plus its
//! chip select), are `no_std` and never allocate. Their sample-path calls
//! ([`ads131m02::Ads131m02::read_frame`], [`ad5761r::Ad5761r::write_volts`])
//! do not allocate, format, panic or index fallibly: the clippy lints below
//! enforce it for every driver module.
//!
//! # Why our own drivers
//! The registry has `ads131m08` (the 8-channel part: 10-word frames, and it
//! does not model that a frame's first word answers the *previous* frame's
//! command) and `ad57xx` (the AD57x4 quad DACs, a different register map and
//! frame). Neither covers the ADS131M02 or the AD5761R; both were read for
//! shape only, as was eldruin's `ads1x1x` (typed registers, `new`/`destroy`,
//! an `Error<E>` generic over the bus error).
#![deny(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::panic,
    clippy::indexing_slicing
)]

pub mod ad5761r;
pub mod ads131m02;

/// Which end of a converter's range a value hit.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Rail {
    /// The most negative code / lowest output voltage.
    Low,
    /// The most positive code / highest output voltage.
    High,
}

impl core::fmt::Display for Rail {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(match self {
            Rail::Low => "low rail",
            Rail::High => "high rail",
        })
    }
}
