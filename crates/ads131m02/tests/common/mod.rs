//! Frame builders for the driver tests, written from the data sheet
//! independently of the crate's own framing code: a bitwise CRC (no table,
//! no `crc` crate) and explicit byte layouts.

use embedded_hal::spi::{ErrorKind, ErrorType, Operation, SpiDevice};
use embedded_hal_mock::eh1::spi::Transaction;

/// CCITT polynomial x¹⁶+x¹²+x⁵+1 (ADS131M02 §8.3.12 Table 8-7).
pub const CCITT: u16 = 0x1021;
/// ANSI polynomial x¹⁶+x¹⁵+x²+1.
pub const ANSI: u16 = 0x8005;

/// MSB-first bitwise CRC-16 with seed FFFFh, no reflection, no final XOR
/// (the procedure of TI's ADS131M0x example code).
pub fn crc16_bitwise(poly: u16, data: &[u8]) -> u16 {
    let mut crc: u16 = 0xFFFF;
    for &byte in data {
        crc ^= u16::from(byte) << 8;
        for _ in 0..8 {
            crc = if crc & 0x8000 != 0 {
                (crc << 1) ^ poly
            } else {
                crc << 1
            };
        }
    }
    crc
}

/// An ADS131M02 frame format as the tests see it.
#[derive(Clone, Copy, Debug)]
pub struct Fmt {
    /// Bytes per word: 2, 3 or 4.
    pub word_bytes: usize,
    /// 32-bit words with MSB sign extension (WLENGTH = 11b).
    pub sign_extend: bool,
    /// CRC polynomial.
    pub poly: u16,
    /// Input CRC appended to commands.
    pub rx_crc: bool,
}

/// Power-on format: 24-bit, CCITT, no input CRC.
pub const RESET_FMT: Fmt = Fmt {
    word_bytes: 3,
    sign_extend: false,
    poly: CCITT,
    rx_crc: false,
};

impl Fmt {
    /// A 16-bit value MSB-aligned, zero-padded to a word.
    pub fn word(&self, v: u16) -> Vec<u8> {
        let mut w = vec![(v >> 8) as u8, v as u8];
        w.resize(self.word_bytes, 0);
        w
    }

    /// A 24-bit conversion code as a data word.
    pub fn data(&self, code: i32) -> Vec<u8> {
        let b = [(code >> 16) as u8, (code >> 8) as u8, code as u8];
        match (self.word_bytes, self.sign_extend) {
            (2, _) => vec![b[0], b[1]],
            (3, _) => b.to_vec(),
            (4, false) => vec![b[0], b[1], b[2], 0],
            (4, true) => {
                let ext = if code < 0 { 0xFF } else { 0x00 };
                vec![ext, b[0], b[1], b[2]]
            }
            _ => unreachable!(),
        }
    }

    /// DOUT of a normal frame: response, two channels, CRC over the rest.
    pub fn dout(&self, response: u16, ch0: i32, ch1: i32) -> Vec<u8> {
        let mut f = self.word(response);
        f.extend(self.data(ch0));
        f.extend(self.data(ch1));
        let crc = crc16_bitwise(self.poly, &f);
        f.extend(self.word(crc));
        f
    }

    /// DOUT answering a multi-register RREG: ack, registers, CRC.
    pub fn dout_registers(&self, ack: u16, regs: &[u16]) -> Vec<u8> {
        let mut f = self.word(ack);
        for &r in regs {
            f.extend(self.word(r));
        }
        let crc = crc16_bitwise(self.poly, &f);
        f.extend(self.word(crc));
        f
    }

    /// DIN: command, WREG data, input CRC if enabled, zeros to `words`.
    pub fn din_words(&self, cmd: u16, data: &[u16], words: usize) -> Vec<u8> {
        let mut f = self.word(cmd);
        for &d in data {
            f.extend(self.word(d));
        }
        if self.rx_crc {
            let crc = crc16_bitwise(self.poly, &f);
            f.extend(self.word(crc));
        }
        f.resize(words * self.word_bytes, 0);
        f
    }

    /// DIN of a normal 4-word frame.
    pub fn din(&self, cmd: u16, data: &[u16]) -> Vec<u8> {
        self.din_words(cmd, data, 4)
    }
}

/// One SpiDevice transaction: CS low, full-duplex `tx`/`rx`, CS high.
pub fn frame(tx: Vec<u8>, rx: Vec<u8>) -> [Transaction<u8>; 3] {
    assert_eq!(tx.len(), rx.len());
    [
        Transaction::transaction_start(),
        Transaction::transfer_in_place(tx, rx),
        Transaction::transaction_end(),
    ]
}

/// A STATUS word: RESET flag, word-length code, CRC type, both DRDY set.
pub fn status(reset: bool, wlength: u16, ansi: bool) -> u16 {
    (u16::from(reset) << 10) | (wlength << 8) | (u16::from(ansi) << 11) | 0b11
}

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

/// A mock SPI device whose `fail_at`-th transaction (counting from 1)
/// fails with [`ErrorKind::Other`] without reaching the mock; every other
/// transaction is checked against the mock's expectations.
pub struct FailOnce {
    /// The checked device.
    pub mock: embedded_hal_mock::eh1::spi::Mock<u8>,
    /// Which transaction fails.
    pub fail_at: usize,
    /// Transactions seen so far.
    pub seen: usize,
}

impl ErrorType for FailOnce {
    type Error = ErrorKind;
}

impl SpiDevice for FailOnce {
    fn transaction(&mut self, operations: &mut [Operation<'_, u8>]) -> Result<(), ErrorKind> {
        self.seen += 1;
        if self.seen == self.fail_at {
            return Err(ErrorKind::Other);
        }
        self.mock.transaction(operations)
    }
}
