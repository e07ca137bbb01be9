//! Reference values for the chip-model tests, written from the data sheets
//! independently of the drivers: a bitwise CRC (no table, no `crc` crate)
//! and the AD5761R's output spans.

/// CCITT polynomial x¹⁶+x¹²+x⁵+1 (ADS131M02 §8.3.12 Table 8-7).
pub const CCITT: u16 = 0x1021;

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
