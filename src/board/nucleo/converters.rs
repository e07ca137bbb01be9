//! Minimal adapters from the converter drivers to the pipeline's converter
//! traits ([`StrainAdc`], [`PiezoDac`]), private to this board until the
//! shared adapters land in the core (then this file goes).
//!
//! * [`Adc`]: one [`Ads131m02::read_frame`] per tick; codes and the
//!   driver's saturation flags into an [`AdcReading`]; every driver error
//!   classified into a [`FaultKind`] (never a sample). Errors after which
//!   the device has lost its settings (an unexpected reset, a STATUS word
//!   that disagrees with the framing) set [`Adc::needs_reinit`], which
//!   thread mode acts on between samples ([`Adc::reinit`]).
//! * [`Dac`]: [`Ad5761r::write_volts`] (write and update, command 0011),
//!   the held voltage read back from the driver's transfer function.

use embedded_hal::delay::DelayNs;
use embedded_hal::spi::SpiDevice;

use crate::drivers::ad5761r::{self, Ad5761r};
use crate::drivers::ads131m02::{self, Ads131m02};
use crate::pipeline::{AdcFlags, AdcReading, DacOutcome, FaultKind, PiezoDac, StrainAdc};
use crate::scalar::Real;

/// The ADS131M02 as the pipeline's [`StrainAdc`].
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
    /// success. Between samples only: takes about ten frames.
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

/// The pipeline's counter class of an ADS131M02 driver error, and whether
/// the device must be reset and configured again.
fn classify_adc<B>(e: &ads131m02::Error<B>) -> (FaultKind, bool) {
    use ads131m02::Error as E;
    match e {
        E::Spi(_) => (FaultKind::Bus, false),
        E::Crc { .. } => (FaultKind::Crc, false),
        E::UnexpectedReset(_) | E::StatusMismatch(_) | E::ResetReply(_) => {
            (FaultKind::Status, true)
        }
        E::UnexpectedResponse { .. }
        | E::OwedResponse { .. }
        | E::InputCrc(_)
        | E::ResyncFault(_) => (FaultKind::Status, false),
        E::IdMismatch(_) | E::ConfigMismatch { .. } => (FaultKind::Other, true),
        E::NoNewData(_) | E::StuckData { .. } | E::InvalidArgument => (FaultKind::Other, false),
    }
}

impl<SPI: SpiDevice> StrainAdc for Adc<SPI> {
    type Error = FaultKind;

    #[inline]
    fn read(&mut self) -> Result<AdcReading, FaultKind> {
        match self.adc.read_frame() {
            Ok(frame) => {
                let [bridge, monitor] = frame.channels;
                Ok(AdcReading {
                    bridge: bridge.code(),
                    monitor: monitor.code(),
                    flags: AdcFlags {
                        bridge_saturated: bridge.saturation().is_some(),
                        monitor_saturated: monitor.saturation().is_some(),
                        stale: false,
                    },
                })
            }
            Err(e) => {
                let (kind, reinit) = classify_adc(&e);
                self.needs_reinit |= reinit;
                Err(kind)
            }
        }
    }
}

/// The AD5761R as the pipeline's [`PiezoDac`].
pub struct Dac<SPI> {
    dac: Ad5761r<SPI>,
}

impl<SPI: SpiDevice> Dac<SPI> {
    /// Software full reset, control register written and read back.
    pub fn new(
        spi: SPI,
        config: ad5761r::Config,
    ) -> Result<(Self, ad5761r::ControlReadback), ad5761r::Error<SPI::Error>> {
        let mut dac = Ad5761r::new(spi);
        let readback = dac.init(config)?;
        Ok((Self { dac }, readback))
    }
}

impl<T: Real, SPI: SpiDevice> PiezoDac<T> for Dac<SPI> {
    type Error = FaultKind;

    #[inline]
    fn write_volts(&mut self, volts: T) -> Result<DacOutcome<T>, FaultKind> {
        let written = self
            .dac
            .write_volts(volts.to_f64() as f32)
            .map_err(|e| match e {
                ad5761r::Error::Spi(_) => FaultKind::Bus,
                _ => FaultKind::Other,
            })?;
        let held_v = self
            .dac
            .transfer()
            .map(|t| t.volts(written.code))
            .ok_or(FaultKind::Other)?;
        Ok(DacOutcome {
            held_v: T::from_f64(f64::from(held_v)),
            saturated: written.clamped.is_some(),
        })
    }
}
