//! The real converter drivers behind the pipeline's converter traits: the
//! ADS131M02 driver is a [`StrainAdc`], the AD5761R driver a [`PiezoDac`],
//! and their errors say which [`FaultKind`] they are. Plus the start-up of
//! both converters ([`bring_up`]) and the ADC scales the pipeline's
//! conversion must use for a given ADC configuration ([`adc_scales`]).
//!
//! # How driver results become readings
//! [`Ads131m02::read_frame`] either returns a frame whose CRC, STATUS word
//! and DRDY bits were checked, or an error with no sample in it. The frame's
//! channel 0 is the bridge, channel 1 the amplifier monitor (codes on the
//! 24-bit scale); a code at full scale is flagged saturated (the driver's
//! [`Conversion::saturation`], SBAS853A Table 8-10). Two driver errors are
//! not transport faults but verdicts about the data, and become flags on a
//! reading whose codes carry nothing: no new conversion
//! ([`ads131m02::Error::NoNewData`], STATUS.DRDY clear) is *stale*, and the
//! driver's own stuck-data check ([`ads131m02::Error::StuckData`]) is
//! *stuck*. Everything else is an error, classified:
//!
//! | ADS131M02 error | kind |
//! |---|---|
//! | `Spi` | [`FaultKind::Bus`] |
//! | `Crc` (output CRC mismatch, §8.3.12) | [`FaultKind::Crc`] |
//! | `UnexpectedResponse`, `OwedResponse`, `ResetReply`, `InputCrc`, `ResyncFault`, `UnexpectedReset`, `StatusMismatch` | [`FaultKind::Status`] |
//! | `IdMismatch`, `ConfigMismatch`, `InvalidArgument` (and, if ever returned as errors, `NoNewData`, `StuckData`) | [`FaultKind::Other`] |
//!
//! | AD5761R error | kind |
//! |---|---|
//! | `Spi` | [`FaultKind::Bus`] |
//! | `UnexpectedReadback` | [`FaultKind::Status`] |
//! | `NotConfigured`, `NotFinite`, `InvalidConfig`, `ConfigMismatch` | [`FaultKind::Other`] |
//!
//! A DAC write reports the voltage the written code holds (the driver's
//! transfer function of that code: the request quantised to 16 bits and
//! limited to the range) and whether the request was beyond a rail.
//!
//! [`Conversion::saturation`]: ads131m02::Conversion::saturation

use core::fmt;

use embedded_hal::delay::DelayNs;
use embedded_hal::spi::SpiDevice;

use super::convert::{AdcScale, ADS131M02_VREF_V};
use super::converters::{AdcFlags, AdcReading, DacOutcome, Fault, FaultKind, PiezoDac, StrainAdc};
use ad5761r::{Ad5761r, ControlReadback};
use ads131m02::Ads131m02;

impl<E> Fault for ads131m02::Error<E> {
    fn kind(&self) -> FaultKind {
        use ads131m02::Error as E;
        match self {
            E::Spi(_) => FaultKind::Bus,
            E::Crc { .. } => FaultKind::Crc,
            E::UnexpectedResponse { .. }
            | E::OwedResponse { .. }
            | E::ResetReply(_)
            | E::InputCrc(_)
            | E::ResyncFault(_)
            | E::UnexpectedReset(_)
            | E::StatusMismatch(_) => FaultKind::Status,
            E::NoNewData(_)
            | E::StuckData { .. }
            | E::IdMismatch(_)
            | E::ConfigMismatch { .. }
            | E::InvalidArgument => FaultKind::Other,
        }
    }
}

impl<E> Fault for ad5761r::Error<E> {
    fn kind(&self) -> FaultKind {
        use ad5761r::Error as E;
        match self {
            E::Spi(_) => FaultKind::Bus,
            E::UnexpectedReadback { .. } => FaultKind::Status,
            E::NotConfigured | E::NotFinite | E::InvalidConfig(_) | E::ConfigMismatch { .. } => {
                FaultKind::Other
            }
        }
    }
}

/// True for the ADS131M02 errors after which the device has lost its
/// settings (an unexpected reset, a reset reply where a response was due, a
/// STATUS word that disagrees with the configured framing, an ID or
/// configuration read-back that does not match): the board must reset and
/// configure it again, between samples, before its data can be trusted.
pub fn lost_configuration<E>(e: &ads131m02::Error<E>) -> bool {
    use ads131m02::Error as E;
    matches!(
        e,
        E::UnexpectedReset(_)
            | E::StatusMismatch(_)
            | E::ResetReply(_)
            | E::IdMismatch(_)
            | E::ConfigMismatch { .. }
    )
}

/// A reading whose codes carry nothing, with one flag set.
fn flagged(stale: bool, stuck: bool) -> AdcReading {
    AdcReading {
        bridge: 0,
        monitor: 0,
        flags: AdcFlags {
            stale,
            stuck,
            ..AdcFlags::default()
        },
    }
}

impl<SPI: SpiDevice> StrainAdc for Ads131m02<SPI> {
    type Error = ads131m02::Error<SPI::Error>;

    /// One NULL frame ([`Ads131m02::read_frame`]); see the module docs.
    #[inline]
    fn read(&mut self) -> Result<AdcReading, Self::Error> {
        match self.read_frame() {
            Ok(frame) => {
                let [bridge, monitor] = frame.channels;
                Ok(AdcReading {
                    bridge: bridge.code(),
                    monitor: monitor.code(),
                    flags: AdcFlags {
                        bridge_saturated: bridge.saturation().is_some(),
                        monitor_saturated: monitor.saturation().is_some(),
                        stale: false,
                        stuck: false,
                    },
                })
            }
            Err(ads131m02::Error::NoNewData(_)) => Ok(flagged(true, false)),
            Err(ads131m02::Error::StuckData { .. }) => Ok(flagged(false, true)),
            Err(e) => Err(e),
        }
    }

    /// [`Ads131m02::read_back`]: one multi-register read (two frames).
    fn read_back(&mut self) -> Result<ads131m02::ReadBack, FaultKind> {
        Ads131m02::read_back(self).map_err(|e| e.kind())
    }
}

/// The AD5761R as the pipeline's DAC, in `f32` (the driver's own
/// precision) and `f64` (converted exactly on the way back; the request is
/// rounded to `f32`, far finer than the DAC's 16 bits).
macro_rules! piezo_dac {
    ($t:ty, $to_f32:expr, $from_f32:expr) => {
        impl<SPI: SpiDevice> PiezoDac<$t> for Ad5761r<SPI> {
            type Error = ad5761r::Error<SPI::Error>;

            /// Write-and-update ([`Ad5761r::write_volts`]): one 3-byte
            /// frame; the held voltage is the transfer function of the
            /// code written.
            #[inline]
            fn write_volts(&mut self, volts: $t) -> Result<DacOutcome<$t>, Self::Error> {
                let w = Ad5761r::<SPI>::write_volts(self, $to_f32(volts))?;
                let held = self
                    .transfer()
                    .ok_or(ad5761r::Error::NotConfigured)?
                    .volts(w.code);
                Ok(DacOutcome {
                    held_v: $from_f32(held),
                    saturated: w.clamped.is_some(),
                })
            }
        }
    };
}

piezo_dac!(f32, |v: f32| v, |v: f32| v);
piezo_dac!(f64, |v: f64| v as f32, f64::from);

/// The ADC scales of channel 0 (bridge) and channel 1 (monitor) for an
/// ADS131M02 configuration: internal 1.2 V reference (SBAS853A §8.3.4) and
/// the configured PGA gains. Build the pipeline's
/// [`super::ConversionConfig`] with these so codes are converted at the
/// gain they were taken at.
pub(crate) fn adc_scales(config: &ads131m02::Config) -> [AdcScale; 2] {
    config.gains.map(|g| AdcScale {
        vref_v: ADS131M02_VREF_V,
        pga_gain: u8::try_from(g.factor()).unwrap_or(u8::MAX),
    })
}

/// What [`bring_up`] found.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct BringUp {
    /// The ADS131M02's ID register (22xxh, checked).
    pub adc_id: u16,
    /// The AD5761R's control register as read back (checked against what
    /// was written).
    pub dac_control: ControlReadback,
}

/// Which converter failed to start, and why.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum BringUpError<EA, ED> {
    /// The ADS131M02: reset, ID check, configuration or its read-back.
    Adc(ads131m02::Error<EA>),
    /// The AD5761R: reset, control write or its read-back.
    Dac(ad5761r::Error<ED>),
}

impl<EA: fmt::Debug, ED: fmt::Debug> fmt::Display for BringUpError<EA, ED> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Adc(e) => write!(f, "converter bring-up: {e}"),
            Self::Dac(e) => write!(f, "converter bring-up: {e}"),
        }
    }
}

impl<EA: fmt::Debug, ED: fmt::Debug> core::error::Error for BringUpError<EA, ED> {
    fn source(&self) -> Option<&(dyn core::error::Error + 'static)> {
        // The driver errors are generic over the bus error, which need not
        // be 'static; the message carries them.
        None
    }
}

/// Start both converters before the sample interrupt runs: the DAC first
/// (software full reset, control register written and read back: its
/// output goes to the configured power-up level, 0 V at mid-scale on
/// ±10 V, before anything else happens), then the ADC (software reset with
/// the FF22h reply and the ID check, configuration written and read back).
pub fn bring_up<A: SpiDevice, D: SpiDevice>(
    adc: &mut Ads131m02<A>,
    dac: &mut Ad5761r<D>,
    adc_config: &ads131m02::Config,
    dac_config: ad5761r::Config,
    delay: &mut impl DelayNs,
) -> Result<BringUp, BringUpError<A::Error, D::Error>> {
    let dac_control = dac.init(dac_config).map_err(BringUpError::Dac)?;
    let adc_id = adc.reset(delay).map_err(BringUpError::Adc)?;
    adc.configure(adc_config).map_err(BringUpError::Adc)?;
    Ok(BringUp {
        adc_id,
        dac_control,
    })
}

#[cfg(test)]
#[allow(clippy::unwrap_used, clippy::indexing_slicing, clippy::panic)]
mod tests {
    use super::*;
    use crate::rig::chips::ads131m02::quantize;
    use crate::rig::chips::{Ad5761rModel, Ads131m02Model, ModelBusError, Shared};
    use ad5761r::{ConfigError, OutputRange};
    use ads131m02::{Command, PgaGain, Rail, Register, Status};
    use core::cell::RefCell;

    struct NoDelay;

    impl DelayNs for NoDelay {
        fn delay_ns(&mut self, _ns: u32) {}
    }

    #[test]
    fn every_driver_error_has_its_kind() {
        use ads131m02::Error as A;
        let s = Status::from_bits(0x0500).unwrap();
        let adc: [(A<ModelBusError>, FaultKind); 14] = [
            (A::Spi(ModelBusError), FaultKind::Bus),
            (
                A::Crc {
                    received: 1,
                    computed: 2,
                },
                FaultKind::Crc,
            ),
            (
                A::UnexpectedResponse {
                    command: Command::Null,
                    response: 0,
                },
                FaultKind::Status,
            ),
            (
                A::OwedResponse {
                    command: Command::Null,
                },
                FaultKind::Status,
            ),
            (A::ResetReply(0), FaultKind::Status),
            (A::InputCrc(s), FaultKind::Status),
            (A::ResyncFault(s), FaultKind::Status),
            (A::UnexpectedReset(s), FaultKind::Status),
            (A::StatusMismatch(s), FaultKind::Status),
            (A::NoNewData(s), FaultKind::Other),
            (A::StuckData { frames: 9 }, FaultKind::Other),
            (A::IdMismatch(0), FaultKind::Other),
            (
                A::ConfigMismatch {
                    register: Register::Mode,
                    wrote: 0,
                    read: 1,
                },
                FaultKind::Other,
            ),
            (A::InvalidArgument, FaultKind::Other),
        ];
        for (e, k) in adc {
            assert_eq!(e.kind(), k, "{e:?}");
        }
        use ad5761r::Error as D;
        let dac: [(D<ModelBusError>, FaultKind); 6] = [
            (D::Spi(ModelBusError), FaultKind::Bus),
            (
                D::UnexpectedReadback {
                    command: 0xB,
                    word: 0,
                },
                FaultKind::Status,
            ),
            (D::NotConfigured, FaultKind::Other),
            (D::NotFinite, FaultKind::Other),
            (
                D::InvalidConfig(ConfigError::ReferenceVoltage),
                FaultKind::Other,
            ),
            (D::ConfigMismatch { wrote: 0, read: 1 }, FaultKind::Other),
        ];
        for (e, k) in dac {
            assert_eq!(e.kind(), k, "{e:?}");
        }
    }

    type Adc<'a> = Ads131m02<Shared<'a, Ads131m02Model>>;
    type Dac<'a> = Ad5761r<Shared<'a, Ad5761rModel>>;

    fn started<'a>(
        adc_model: &'a RefCell<Ads131m02Model>,
        dac_model: &'a RefCell<Ad5761rModel>,
        adc_config: &ads131m02::Config,
    ) -> (Adc<'a>, Dac<'a>) {
        let mut adc = Ads131m02::new(Shared(adc_model));
        let mut dac = Ad5761r::new(Shared(dac_model));
        let b = bring_up(
            &mut adc,
            &mut dac,
            adc_config,
            ad5761r::Config::default(),
            &mut NoDelay,
        )
        .unwrap();
        assert_eq!(b.adc_id, 0x2200);
        assert_eq!(b.dac_control.control.range, OutputRange::Bipolar10V);
        (adc, dac)
    }

    /// One DRDY period of the model, then the adapter's read.
    fn convert_and_read(
        adc: &mut Adc<'_>,
        model: &RefCell<Ads131m02Model>,
        volts: [f64; 2],
    ) -> Result<AdcReading, ads131m02::Error<ModelBusError>> {
        {
            let mut m = model.borrow_mut();
            m.set_inputs(volts);
            m.convert();
        }
        StrainAdc::read(adc)
    }

    #[test]
    fn adc_readings_flags_and_faults_through_the_chip_model() {
        let model = RefCell::new(Ads131m02Model::new());
        let dac_model = RefCell::new(Ad5761rModel::new());
        let config = ads131m02::Config {
            gains: [PgaGain::G128, PgaGain::G1],
            stuck_limit: 4,
            ..ads131m02::Config::default()
        };
        let (mut adc, _dac) = started(&model, &dac_model, &config);
        let [s0, s1] = adc_scales(&config);
        assert_eq!((s0.pga_gain, s1.pga_gain), (128, 1));
        assert_eq!(s0.vref_v, 1.2);
        // A normal frame: the codes of the model's ideal conversion.
        let v = [3.1e-3, -0.42];
        let r = convert_and_read(&mut adc, &model, v).unwrap();
        assert_eq!(r.bridge, quantize(v[0], 128));
        assert_eq!(r.monitor, quantize(v[1], 1));
        assert_eq!(r.flags, AdcFlags::default());
        // Saturation of either channel is flagged (and the code clipped).
        let r = convert_and_read(&mut adc, &model, [1.0, 0.1]).unwrap();
        assert_eq!(r.bridge, ads131m02::CODE_MAX);
        assert!(r.flags.bridge_saturated && !r.flags.monitor_saturated);
        let r = convert_and_read(&mut adc, &model, [0.0, -2.0]).unwrap();
        assert!(!r.flags.bridge_saturated && r.flags.monitor_saturated);
        model.borrow_mut().set_saturation(Some(Rail::Low));
        let r = convert_and_read(&mut adc, &model, v).unwrap();
        assert!(r.flags.bridge_saturated && r.flags.monitor_saturated);
        model.borrow_mut().set_saturation(None);
        // A corrupted frame: a CRC error, never a reading.
        model.borrow_mut().inject_bad_crc(1);
        let e = convert_and_read(&mut adc, &model, v).unwrap_err();
        assert_eq!(e.kind(), FaultKind::Crc);
        // A dropped conversion: DRDY clear → stale.
        model.borrow_mut().drop_conversions(1);
        let r = convert_and_read(&mut adc, &model, v).unwrap();
        assert_eq!(r.flags, flagged(true, false).flags);
        // A bus fault.
        model.borrow_mut().inject_bus_errors(1);
        let e = convert_and_read(&mut adc, &model, v).unwrap_err();
        assert_eq!(e.kind(), FaultKind::Bus);
        // The failed frame did not clock the data out: the conversion is
        // still queued. The next read catches up (the driver reads the
        // newer one too), so nothing is left queued after it.
        assert!(model.borrow().drdy_low());
        let w = [2e-3, 0.2];
        let r = convert_and_read(&mut adc, &model, w).unwrap();
        assert_eq!(r.bridge, quantize(w[0], 128));
        assert!(!model.borrow().drdy_low());
        // Stuck data (the driver's check, limit 4 frames): flagged stuck
        // from the 4th identical frame (the stuck conversions repeat the
        // last good frame's codes, `w`'s, so that frame is the run's first
        // and the third stuck frame its 4th).
        model.borrow_mut().set_stuck(true);
        let flags: [bool; 5] =
            core::array::from_fn(|_| convert_and_read(&mut adc, &model, v).unwrap().flags.stuck);
        assert_eq!(flags, [false, false, true, true, true]);
        model.borrow_mut().set_stuck(false);
        assert!(
            !convert_and_read(&mut adc, &model, [1e-3, 0.0])
                .unwrap()
                .flags
                .stuck
        );
        // A brown-out: the device lost its settings → a status fault.
        model.borrow_mut().brown_out();
        let e = convert_and_read(&mut adc, &model, v).unwrap_err();
        assert_eq!(e.kind(), FaultKind::Status);
    }

    #[test]
    fn dac_writes_report_the_held_voltage_and_saturation() {
        let adc_model = RefCell::new(Ads131m02Model::new());
        let model = RefCell::new(Ad5761rModel::new());
        let (_adc, mut dac) = started(&adc_model, &model, &ads131m02::Config::default());
        // After bring-up the output is at mid-scale: 0 V.
        assert_eq!(model.borrow().output_volts(), 0.0);
        let lsb = 20.0 / 65_536.0;
        for v in [0.01f64, -0.01, 3.3, -9.99, 0.0] {
            let out = PiezoDac::<f64>::write_volts(&mut dac, v).unwrap();
            assert!(!out.saturated);
            assert_eq!(out.held_v, model.borrow().output_volts(), "{v}");
            assert!((out.held_v - v).abs() <= 0.5 * lsb, "{v}");
            let out32 = PiezoDac::<f32>::write_volts(&mut dac, v as f32).unwrap();
            assert_eq!(f64::from(out32.held_v), out.held_v);
        }
        let hi = PiezoDac::<f32>::write_volts(&mut dac, 12.0).unwrap();
        assert!(hi.saturated);
        assert_eq!(f64::from(hi.held_v), model.borrow().output_volts());
        assert!((hi.held_v - (10.0 - lsb as f32)).abs() < 1e-6);
        let lo = PiezoDac::<f64>::write_volts(&mut dac, -10.5).unwrap();
        assert!(lo.saturated);
        assert_eq!(lo.held_v, -10.0);
        let e = PiezoDac::<f32>::write_volts(&mut dac, f32::NAN).unwrap_err();
        assert_eq!(e.kind(), FaultKind::Other);
        model.borrow_mut().inject_bus_errors(1);
        let e = PiezoDac::<f64>::write_volts(&mut dac, 1.0).unwrap_err();
        assert_eq!(e.kind(), FaultKind::Bus);
        // Not configured: a driver that was never brought up.
        let other = RefCell::new(Ad5761rModel::new());
        let mut raw = Ad5761r::new(Shared(&other));
        let e = PiezoDac::<f32>::write_volts(&mut raw, 1.0).unwrap_err();
        assert_eq!(e, ad5761r::Error::NotConfigured);
    }

    #[test]
    fn bring_up_reports_which_converter_failed() {
        let adc_model = RefCell::new(Ads131m02Model::new());
        let dac_model = RefCell::new(Ad5761rModel::new());
        adc_model.borrow_mut().set_id(0x2400);
        let mut adc = Ads131m02::new(Shared(&adc_model));
        let mut dac = Ad5761r::new(Shared(&dac_model));
        let e = bring_up(
            &mut adc,
            &mut dac,
            &ads131m02::Config::default(),
            ad5761r::Config::default(),
            &mut NoDelay,
        )
        .unwrap_err();
        assert_eq!(e, BringUpError::Adc(ads131m02::Error::IdMismatch(0x2400)));
        let msg = std::format!("{e}");
        assert!(msg.contains("2400"), "{msg}");
        dac_model.borrow_mut().inject_bus_errors(1);
        let e = bring_up(
            &mut adc,
            &mut dac,
            &ads131m02::Config::default(),
            ad5761r::Config::default(),
            &mut NoDelay,
        )
        .unwrap_err();
        assert_eq!(e, BringUpError::Dac(ad5761r::Error::Spi(ModelBusError)));
    }
}
