//! The ADS131M02 as the reference board's [`StrainAdc`], with the one thing
//! the board adds to the shared adapter ([`crate::pipeline::adapters`]):
//! it remembers when the converter has lost its settings, so thread mode
//! can reset and configure it again between samples ([`Adc::reinit`]).
//! The AD5761R needs nothing extra: the board uses the shared
//! [`crate::pipeline::PiezoDac`] impl of the driver directly.

use embedded_hal::delay::DelayNs;
use embedded_hal::spi::SpiDevice;

use crate::pipeline::{lost_configuration, AdcReading, FaultKind, StrainAdc};
use ads131m02::Ads131m02;

use super::drdy::Drdy;

/// Drain-and-check rounds [`resync`] tries before giving up (a conversion
/// completing between a drain and the DRDY check costs one more round).
const RESYNC_ROUNDS: u8 = 3;

/// Why [`resync`] failed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum ResyncError<E> {
    /// A drain frame failed.
    Adc(ads131m02::Error<E>),
    /// DRDY stayed low through every drain: frames do not reach the ADC,
    /// or DRDY (PF3) is miswired.
    DrdyStuckLow,
}

/// Bring the ADS131M02 and the DRDY interrupt back into step after any
/// pause in reading (configuration, start-up work, a re-initialisation):
/// drain the output FIFO to DRDY high ([`Ads131m02::drain`]), then clear
/// the DRDY edges seen so far ([`super::discard_sample_edge`]); repeat if
/// a conversion came in between. Afterwards every DRDY falling edge
/// announces exactly the conversion the next frame carries. Returns the
/// frames drained. Call with the sample interrupt masked (before it is
/// enabled, or inside the sample task's lock).
pub fn resync<SPI: SpiDevice>(
    adc: &mut Ads131m02<SPI>,
    drdy: &Drdy,
) -> Result<u8, ResyncError<SPI::Error>> {
    let mut frames = 0u8;
    for _ in 0..RESYNC_ROUNDS {
        let d = adc.drain(|| drdy.is_low()).map_err(ResyncError::Adc)?;
        frames = frames.saturating_add(d.frames);
        if !d.drdy_high {
            return Err(ResyncError::DrdyStuckLow);
        }
        super::discard_sample_edge();
        if !drdy.is_low() {
            return Ok(frames);
        }
    }
    Err(ResyncError::DrdyStuckLow)
}

/// The ADS131M02 as the pipeline's [`StrainAdc`], tracking lost settings.
pub struct Adc<SPI> {
    adc: Ads131m02<SPI>,
    config: ads131m02::Config,
    needs_reinit: bool,
}

impl<SPI: SpiDevice> Adc<SPI> {
    /// Reset (with the ID check) and configure the converter.
    pub fn new(
        spi: SPI,
        config: ads131m02::Config,
        delay: &mut impl DelayNs,
    ) -> Result<Self, ads131m02::Error<SPI::Error>> {
        let mut adc = Self {
            adc: Ads131m02::new(spi),
            config,
            needs_reinit: true,
        };
        adc.reinit(delay)?;
        Ok(adc)
    }

    /// Software reset (FF22h reply and ID checked) and the full
    /// configuration with read-back; clears [`Adc::needs_reinit`] on
    /// success. Between samples only: takes about ten frames, a pause in
    /// reading, so call [`resync`] after it.
    pub fn reinit(
        &mut self,
        delay: &mut impl DelayNs,
    ) -> Result<u16, ads131m02::Error<SPI::Error>> {
        let id = self.adc.reset(delay)?;
        self.adc.configure(&self.config)?;
        self.needs_reinit = false;
        Ok(id)
    }

    /// The device lost its settings; call [`Adc::reinit`].
    pub fn needs_reinit(&self) -> bool {
        self.needs_reinit
    }

    /// The driver, for reads outside the sample path (e.g. start-up).
    pub fn driver(&mut self) -> &mut Ads131m02<SPI> {
        &mut self.adc
    }
}

impl<SPI: SpiDevice> StrainAdc for Adc<SPI> {
    type Error = ads131m02::Error<SPI::Error>;

    #[inline]
    fn read(&mut self) -> Result<AdcReading, Self::Error> {
        let reading = self.adc.read();
        if let Err(e) = &reading {
            self.needs_reinit |= lost_configuration(e);
        }
        reading
    }

    fn read_back(&mut self) -> Result<ads131m02::ReadBack, FaultKind> {
        StrainAdc::read_back(&mut self.adc)
    }
}
