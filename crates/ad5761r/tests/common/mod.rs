//! Frame builders for the driver tests, written from the data sheet
//! independently of the crate's own encodings: explicit byte layouts.

use embedded_hal::spi::{ErrorKind, ErrorType, Operation, SpiDevice};
use embedded_hal_mock::eh1::spi::Transaction;

/// One SpiDevice transaction: CS low, full-duplex `tx`/`rx`, CS high.
pub fn frame(tx: Vec<u8>, rx: Vec<u8>) -> [Transaction<u8>; 3] {
    assert_eq!(tx.len(), rx.len());
    [
        Transaction::transaction_start(),
        Transaction::transfer_in_place(tx, rx),
        Transaction::transaction_end(),
    ]
}

/// One write-only SpiDevice transaction.
pub fn write(tx: Vec<u8>) -> [Transaction<u8>; 3] {
    [
        Transaction::transaction_start(),
        Transaction::write_vec(tx),
        Transaction::transaction_end(),
    ]
}

/// (low, high) volts of each AD5761R range, in RA order (data sheet
/// front page: 8 software-programmable output ranges).
pub const DAC_SPANS: [(f64, f64); 8] = [
    (-10.0, 10.0),
    (0.0, 10.0),
    (-5.0, 5.0),
    (0.0, 5.0),
    (-2.5, 7.5),
    (-3.0, 3.0),
    (0.0, 16.0),
    (0.0, 20.0),
];

/// An SPI device whose every transaction fails with the given kind.
pub struct FailingSpi(pub ErrorKind);

impl ErrorType for FailingSpi {
    type Error = ErrorKind;
}

impl SpiDevice for FailingSpi {
    fn transaction(&mut self, _: &mut [Operation<'_, u8>]) -> Result<(), ErrorKind> {
        Err(self.0)
    }
}
