//! Platform-agnostic driver for the ADI AD5761R: 16-bit, bipolar/unipolar
//! voltage-output DAC with a 2.5 V internal reference, on `embedded-hal`
//! 1.0 alone (`no_std`, no allocation). The README has the wiring and a
//! usage example.
//!
//! Source: AD5761R/AD5721R data sheet Rev. C; the `registers` module says
//! which facts were read in it and which come from ADI's own drivers.
//!
//! # Protocol
//! * One 24-bit word per SYNC-low period (one [`SpiDevice`] transaction):
//!   DB19:16 command, DB15:0 data, MSB first (Table 14). The device latches
//!   SDI on SCLK falling edges; [`SPI_MODE`] is mode 1, which a working
//!   third-party driver uses. The data-sheet timing diagram could not be
//!   read: check CPOL on hardware with a scope.
//! * A readback command (1010/1011/1100) makes the device shift the register
//!   out of SDO during the **next** frame, echoing the command in DB19:16
//!   (Table 15). The driver sends the readback, then a NOP whose SDO word it
//!   checks against the readback it asked for. Readback needs SDO, i.e.
//!   daisy-chain mode enabled, which [`Ad5761r::init`] sets explicitly.
//! * Writes ([`Ad5761r::write_volts`], [`Ad5761r::write_code`]) are
//!   write-only transactions (command 0011, write and update DAC register):
//!   no SDO is read on the sample path.
//! * Volts ↔ code: [`Transfer`], V_OUT = V_REF·(M·D/2¹⁶ − C) per range
//!   (Table 13 for the bipolar codings); a request beyond a rail writes
//!   that rail and says so ([`DacWrite::clamped`]), it never wraps.
//!
//! # Power-up and safety
//! The data sheet's description, as summarised in the design notes this
//! driver was written from, has the output clamped until the control
//! register is written; the exact power-on output was not verified. [`Ad5761r::init`]
//! does a software full reset, so the output starts from the power-on state
//! whatever ran before, then writes the control register with the
//! configured power-up level. Pick [`ScaleLevel::Mid`] for the symmetric
//! bipolar ranges: zero scale there is the *negative* rail (−10 V on ±10 V).
//!
//! # Pins
//! The driver owns only the SPI device ([`Ad5761r::new`] takes it,
//! [`Ad5761r::destroy`] gives it back). LDAC, CLEAR and RESET are not used:
//! command 0011 updates the output without LDAC, and the software resets
//! replace the RESET pin; tie LDAC low, CLEAR and RESET high (or drive
//! them from the application).
//!
//! # Sample path
//! [`Ad5761r::write_volts`] is one multiply-add, two compares, a cast and
//! one 3-byte write: no allocation, no formatting, no panic, no fallible
//! indexing (the crate denies `unwrap`, `expect`, `panic!` and indexing).
//!
//! # Features
//! * `defmt`: derive `defmt::Format` on every public type.
#![cfg_attr(not(test), no_std)]
#![forbid(unsafe_code)]
#![deny(missing_docs)]
#![deny(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::panic,
    clippy::indexing_slicing
)]

mod error;
mod registers;
mod transfer;

use embedded_hal::spi::SpiDevice;

pub use error::{ConfigError, Error};
pub use registers::{
    BipolarCoding, Command, ControlReadback, ControlRegister, OutputRange, ScaleLevel, CONTROL_MASK,
};
pub use transfer::{DacWrite, NotFinite, Transfer, INTERNAL_VREF_VOLTS, OVERRANGE_FACTOR};

/// The README's usage example, compiled as a doctest.
#[cfg(doctest)]
#[doc = include_str!("../README.md")]
struct ReadmeDoctest;

/// Which end of the DAC's range a request went beyond.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Rail {
    /// The lowest output voltage (straight-binary code 0000h).
    Low,
    /// The highest output voltage (straight-binary code FFFFh).
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

/// SPI mode used for the AD5761R (see the module docs).
pub const SPI_MODE: embedded_hal::spi::Mode = embedded_hal::spi::MODE_1;

/// The reference the DAC runs on.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Reference {
    /// The internal 2.5 V reference (IRO = 1).
    Internal,
    /// An external reference of this many volts (IRO = 0).
    External {
        /// Reference voltage in volts.
        volts: f32,
    },
}

/// Everything [`Ad5761r::init`] sets. The control register has no
/// short-circuit setting: SC (bit 12) only reports a detected short since
/// the last control write, see [`ControlReadback`].
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Config {
    /// RA: output range.
    pub range: OutputRange,
    /// B2C: bipolar-range coding.
    pub coding: BipolarCoding,
    /// OVR: 5 % overrange.
    pub overrange: bool,
    /// PV: output level at power-up.
    pub power_up: ScaleLevel,
    /// CV: output level while CLEAR is asserted.
    pub clear: ScaleLevel,
    /// ETS: thermal shutdown.
    pub thermal_shutdown: bool,
    /// IRO and the reference voltage.
    pub reference: Reference,
}

impl Default for Config {
    /// The rig: ±10 V straight binary, no overrange, power-up and clear at
    /// mid-scale (0 V), thermal shutdown on, internal reference.
    fn default() -> Config {
        Config {
            range: OutputRange::Bipolar10V,
            coding: BipolarCoding::StraightBinary,
            overrange: false,
            power_up: ScaleLevel::Mid,
            clear: ScaleLevel::Mid,
            thermal_shutdown: true,
            reference: Reference::Internal,
        }
    }
}

impl Config {
    /// The control register value.
    pub const fn control(&self) -> ControlRegister {
        ControlRegister {
            range: self.range,
            coding: self.coding,
            overrange: self.overrange,
            clear: self.clear,
            power_up: self.power_up,
            thermal_shutdown: self.thermal_shutdown,
            internal_reference: matches!(self.reference, Reference::Internal),
        }
    }

    /// The reference voltage in volts.
    pub const fn vref_volts(&self) -> f32 {
        match self.reference {
            Reference::Internal => INTERNAL_VREF_VOLTS,
            Reference::External { volts } => volts,
        }
    }

    /// The transfer function of this configuration.
    pub fn transfer(&self) -> Transfer {
        Transfer::new(&self.control(), self.vref_volts())
    }
}

/// The AD5761R on an SPI device.
#[derive(Debug)]
pub struct Ad5761r<SPI> {
    spi: SPI,
    config: Option<(Config, Transfer)>,
}

impl<SPI: SpiDevice> Ad5761r<SPI> {
    /// Take the SPI device. No bus traffic.
    pub fn new(spi: SPI) -> Self {
        Ad5761r { spi, config: None }
    }

    /// Give the SPI device back.
    pub fn destroy(self) -> SPI {
        self.spi
    }

    /// The SPI device, borrowed: e.g. to change the bus clock once
    /// [`Ad5761r::init`] has read the control register back (a read-back
    /// may need a slower SCLK than writes), keeping the configuration.
    pub fn spi_mut(&mut self) -> &mut SPI {
        &mut self.spi
    }

    /// The configuration written by [`Ad5761r::init`], if any.
    pub fn config(&self) -> Option<&Config> {
        self.config.as_ref().map(|(c, _)| c)
    }

    /// The transfer function in force, if configured.
    pub fn transfer(&self) -> Option<&Transfer> {
        self.config.as_ref().map(|(_, t)| t)
    }

    /// Software full reset, enable SDO (daisy chain), write the control
    /// register, read it back and compare bits 10:0. Returns the readback
    /// (with the short-circuit and brown-out flags, just reset by the
    /// write).
    pub fn init(&mut self, config: Config) -> Result<ControlReadback, Error<SPI::Error>> {
        if let Reference::External { volts } = config.reference {
            if !(volts.is_finite() && volts > 0.0) {
                return Err(Error::InvalidConfig(ConfigError::ReferenceVoltage));
            }
        }
        self.software_full_reset()?;
        self.send(Command::DisableDaisyChain, 0)?;
        let wrote = config.control().to_bits();
        self.send(Command::WriteControl, wrote)?;
        let readback = self.read_control()?;
        let read = readback.control.to_bits();
        if read != wrote {
            return Err(Error::ConfigMismatch { wrote, read });
        }
        self.config = Some((config, config.transfer()));
        Ok(readback)
    }

    /// The sample path: convert `volts` and write-and-update the DAC
    /// register (one 3-byte write). A request beyond a rail writes that
    /// rail and says so in [`DacWrite::clamped`]; NaN/∞ write nothing.
    pub fn write_volts(&mut self, volts: f32) -> Result<DacWrite, Error<SPI::Error>> {
        let (_, transfer) = self.config.as_ref().ok_or(Error::NotConfigured)?;
        let w = transfer.code(volts).map_err(|_| Error::NotFinite)?;
        self.send(Command::WriteUpdateDac, w.code)?;
        Ok(w)
    }

    /// Write-and-update the DAC register with a raw code (configured coding).
    pub fn write_code(&mut self, code: u16) -> Result<(), Error<SPI::Error>> {
        self.send(Command::WriteUpdateDac, code)
    }

    /// Read back the control register (readback, then NOP for the answer).
    pub fn read_control(&mut self) -> Result<ControlReadback, Error<SPI::Error>> {
        let v = self.readback(Command::ReadControl)?;
        let control = ControlRegister::from_bits(v).ok_or(Error::UnexpectedReadback {
            command: Command::ReadControl as u8,
            word: (u32::from(Command::ReadControl as u8) << 16) | u32::from(v),
        })?;
        Ok(ControlReadback {
            control,
            short_circuit: v & (1 << 12) != 0,
            brownout: v & (1 << 11) != 0,
        })
    }

    /// Read back the DAC register.
    pub fn read_dac(&mut self) -> Result<u16, Error<SPI::Error>> {
        self.readback(Command::ReadDac)
    }

    /// Read back the input register.
    pub fn read_input(&mut self) -> Result<u16, Error<SPI::Error>> {
        self.readback(Command::ReadInput)
    }

    /// Software data reset: input and DAC registers to their reset code.
    pub fn software_data_reset(&mut self) -> Result<(), Error<SPI::Error>> {
        self.send(Command::DataReset, 0)
    }

    /// Software full reset: every register to its power-on value; the
    /// driver forgets its configuration.
    pub fn software_full_reset(&mut self) -> Result<(), Error<SPI::Error>> {
        self.config = None;
        self.send(Command::FullReset, 0)
    }

    fn send(&mut self, cmd: Command, data: u16) -> Result<(), Error<SPI::Error>> {
        self.spi.write(&cmd.frame(data))?;
        Ok(())
    }

    /// Send readback `cmd`, then a NOP; check the NOP frame's SDO word
    /// echoes `cmd` and return its data.
    fn readback(&mut self, cmd: Command) -> Result<u16, Error<SPI::Error>> {
        self.send(cmd, 0)?;
        let mut buf = Command::Nop.frame(0);
        self.spi.transfer_in_place(&mut buf)?;
        let [hi, mid, lo] = buf;
        // DB23:21 are don't care; DB20 must be 0 and DB19:16 the command.
        if hi & 0x1F != cmd as u8 {
            return Err(Error::UnexpectedReadback {
                command: cmd as u8,
                word: u32::from_be_bytes([0, hi, mid, lo]),
            });
        }
        Ok(u16::from_be_bytes([mid, lo]))
    }
}
