//! Behavioural models of the rig's converters, behind the real drivers.
//!
//! Each model implements [`embedded_hal::spi::SpiDevice`]: one transaction
//! is one CS-low frame, decoded and answered the way the chip does, so the
//! drivers' byte framing runs unchanged on the host and in QEMU.
//!
//! * [`Ads131m02Model`] — the ADC: register file, previous-command
//!   responses, CRC, and one quantised conversion per [`Ads131m02Model::convert`]
//!   of the voltages set with [`Ads131m02Model::set_inputs`], queued in a
//!   two-deep output FIFO like the chip's (DRDY level: [`Ads131m02Model::drdy_low`]); injectable
//!   faults (bad CRC, stuck data, saturation, dropped conversions, bus
//!   errors, a brown-out reset).
//! * [`Ad5761rModel`] — the DAC: decodes writes and readbacks and holds the
//!   output voltage ([`Ad5761rModel::output_volts`]) the simulated plant
//!   takes as its input.
//!
//! The simulated rig is plant + these two models; [`Shared`] lets the rig
//! keep a model while a driver owns the SPI handle to it. The models are `no_std`
//! and allocation-free like the rest of the core, and they sit on the
//! simulated sample path (QEMU), so the same panic-free lints as the
//! drivers apply.
#![deny(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::panic,
    clippy::indexing_slicing
)]

pub(crate) mod ad5761r;
pub(crate) mod ads131m02;

pub use ad5761r::Ad5761rModel;
pub use ads131m02::{quantize, Ads131m02Model};

use core::cell::RefCell;
use core::fmt;

use embedded_hal::spi::{ErrorType, Operation, SpiDevice};

/// The error a model returns when a bus fault is injected. The transaction
/// then has no effect on the model.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ModelBusError;

impl embedded_hal::spi::Error for ModelBusError {
    fn kind(&self) -> embedded_hal::spi::ErrorKind {
        embedded_hal::spi::ErrorKind::Other
    }
}

impl fmt::Display for ModelBusError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str("injected SPI bus fault")
    }
}

impl core::error::Error for ModelBusError {}

/// A model shared between the driver that talks to it and the simulated
/// rig that sets its inputs or reads its output between frames: the SPI
/// device the driver owns is this handle, the rig keeps the `RefCell`.
/// A transaction while the model is borrowed elsewhere fails with
/// [`ModelBusError`] instead of panicking.
#[derive(Debug)]
pub struct Shared<'a, M>(pub &'a RefCell<M>);

impl<M> ErrorType for Shared<'_, M> {
    type Error = ModelBusError;
}

impl<M: SpiDevice<Error = ModelBusError>> SpiDevice for Shared<'_, M> {
    fn transaction(&mut self, operations: &mut [Operation<'_, u8>]) -> Result<(), ModelBusError> {
        self.0
            .try_borrow_mut()
            .map_err(|_| ModelBusError)?
            .transaction(operations)
    }
}

/// Feed the bytes of one transaction's operations through `shift`, which
/// takes the MOSI byte and returns the MISO byte, in clock order.
fn clock_operations(operations: &mut [Operation<'_, u8>], mut shift: impl FnMut(u8) -> u8) {
    for op in operations.iter_mut() {
        match op {
            Operation::Read(buf) => buf.iter_mut().for_each(|b| *b = shift(0)),
            Operation::Write(buf) => buf.iter().for_each(|&b| {
                shift(b);
            }),
            Operation::Transfer(read, write) => {
                let n = read.len().max(write.len());
                for i in 0..n {
                    let miso = shift(write.get(i).copied().unwrap_or(0));
                    if let Some(r) = read.get_mut(i) {
                        *r = miso;
                    }
                }
            }
            Operation::TransferInPlace(buf) => buf.iter_mut().for_each(|b| *b = shift(*b)),
            Operation::DelayNs(_) => {}
        }
    }
}
