//! ADS131M02 SPI frame format: words, padding, conversion data and CRC.
//!
//! A frame is the bytes clocked while CS is low (SPI mode 1, MSB first).
//! It is made of words of 16, 24 or 32 bits (MODE.WLENGTH). Commands,
//! responses, register data and CRC carry 16 bits, MSB-aligned, the LSBs
//! zero-padded; conversion data are 24 bits, truncated to the 16 MSBs in
//! 16-bit mode, zero-padded or sign-extended in 32-bit mode (SBAS853A "SPI
//! Communication Words" and "ADC Conversion Data" sections, §8.5.1).
//!
//! On DIN the host sends the command, the register words of a WREG, the
//! input CRC if MODE.RX_CRC_EN is set (else that word is zeros) and zeros
//! to the end; on DOUT the device sends the response to the previous
//! frame's command, one word per channel and the output CRC: 4 words for
//! the M02 (§8.5.1 "SPI Communication Frames").
//!
//! CRC (§8.3.12, Table 8-7): 16 bits, seed FFFFh, CCITT x¹⁶+x¹²+x⁵+1 or
//! ANSI x¹⁶+x¹⁵+x²+1, MSB first, no reflection, no final XOR — the `crc`
//! crate's `CRC_16_IBM_3740` (CCITT-FALSE) and `CRC_16_CMS`. "Coverage
//! includes all words in the SPI frame where the CRC is enabled, including
//! padded bits in a 32-bit word size": every byte of the words before the
//! CRC word. The output CRC cannot be disabled.

use super::registers::{CrcType, WordLength};

/// Words in a normal M02 frame: response/command, 2 channels, CRC.
pub const FRAME_WORDS: usize = 4;
/// Bytes of the longest word (32-bit mode).
pub const MAX_WORD_BYTES: usize = 4;
/// Bytes of the longest normal frame.
pub const MAX_FRAME_BYTES: usize = FRAME_WORDS * MAX_WORD_BYTES;

static CRC_CCITT: crc::Crc<u16> = crc::Crc::<u16>::new(&crc::CRC_16_IBM_3740);
static CRC_ANSI: crc::Crc<u16> = crc::Crc::<u16>::new(&crc::CRC_16_CMS);

/// CRC-16 of `bytes` as the ADS131M02 computes it (§8.3.12).
pub fn crc16(crc_type: CrcType, bytes: &[u8]) -> u16 {
    match crc_type {
        CrcType::Ccitt => CRC_CCITT.checksum(bytes),
        CrcType::Ansi => CRC_ANSI.checksum(bytes),
    }
}

/// Everything that shapes a frame: word length, CRC polynomial, and whether
/// the device expects an input CRC.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct FrameFormat {
    /// MODE.WLENGTH.
    pub word_length: WordLength,
    /// MODE.CRC_TYPE.
    pub crc_type: CrcType,
    /// MODE.RX_CRC_EN.
    pub rx_crc: bool,
}

impl FrameFormat {
    /// Power-on / post-RESET format: 24-bit words, CCITT, no input CRC
    /// (MODE reset value 0510h).
    pub const RESET: FrameFormat = FrameFormat {
        word_length: WordLength::Bits24,
        crc_type: CrcType::Ccitt,
        rx_crc: false,
    };

    /// Bytes per word.
    pub const fn word_bytes(self) -> usize {
        self.word_length.bytes()
    }

    /// Bytes of a normal 4-word frame.
    pub const fn frame_bytes(self) -> usize {
        FRAME_WORDS * self.word_bytes()
    }

    /// CRC of `bytes` with this format's polynomial.
    pub fn crc(self, bytes: &[u8]) -> u16 {
        crc16(self.crc_type, bytes)
    }

    /// Write the 16-bit `value` MSB-aligned, zero-padded, as word `index`.
    pub fn put_word16(self, buf: &mut [u8], index: usize, value: u16) {
        let wb = self.word_bytes();
        if let Some(word) = buf.get_mut(index * wb..(index + 1) * wb) {
            word.fill(0);
            for (dst, src) in word.iter_mut().zip(value.to_be_bytes()) {
                *dst = src;
            }
        }
    }

    /// The 16 MSBs of word `index` (0 if the buffer is shorter).
    pub fn word16(self, buf: &[u8], index: usize) -> u16 {
        let wb = self.word_bytes();
        let hi = buf.get(index * wb).copied().unwrap_or(0);
        let lo = buf.get(index * wb + 1).copied().unwrap_or(0);
        u16::from_be_bytes([hi, lo])
    }

    /// Write a 24-bit two's-complement conversion `code` as word `index`
    /// in this word length's data format.
    pub fn put_data(self, buf: &mut [u8], index: usize, code: i32) {
        let wb = self.word_bytes();
        let bytes = encode_data(self.word_length, code);
        if let Some(word) = buf.get_mut(index * wb..(index + 1) * wb) {
            for (dst, src) in word.iter_mut().zip(bytes) {
                *dst = src;
            }
        }
    }

    /// Decode word `index` as conversion data, to the 24-bit code scale
    /// (16-bit words are shifted left by 8, so 1 LSB of a 16-bit word is
    /// 256 codes).
    pub fn data(self, buf: &[u8], index: usize) -> i32 {
        let at = index * self.word_bytes();
        let b = |k: usize| buf.get(at + k).copied().unwrap_or(0);
        // The word's bytes at known offsets for each length (no loop).
        let w = match self.word_length {
            WordLength::Bits16 => [b(0), b(1), 0, 0],
            WordLength::Bits24 => [b(0), b(1), b(2), 0],
            WordLength::Bits32ZeroPad | WordLength::Bits32SignExtend => [b(0), b(1), b(2), b(3)],
        };
        decode_data(self.word_length, w)
    }
}

/// Encode a 24-bit code (sign-extended in an `i32`) as the first
/// `word_length.bytes()` bytes of the returned array.
fn encode_data(word_length: WordLength, code: i32) -> [u8; MAX_WORD_BYTES] {
    let c = (code & 0x00FF_FFFF) as u32;
    match word_length {
        // Truncated to the 16 MSBs.
        WordLength::Bits16 => [(c >> 16) as u8, (c >> 8) as u8, 0, 0],
        WordLength::Bits24 => [(c >> 16) as u8, (c >> 8) as u8, c as u8, 0],
        WordLength::Bits32ZeroPad => [(c >> 16) as u8, (c >> 8) as u8, c as u8, 0],
        WordLength::Bits32SignExtend => (code.clamp(-(1 << 23), (1 << 23) - 1)).to_be_bytes(),
    }
}

/// Decode a data word (the first `word_length.bytes()` bytes of `w`) to
/// the 24-bit code scale, sign-extended.
fn decode_data(word_length: WordLength, w: [u8; MAX_WORD_BYTES]) -> i32 {
    let [a, b, c, d] = w;
    match word_length {
        WordLength::Bits16 => i32::from_be_bytes([a, b, 0, 0]) >> 8,
        WordLength::Bits24 | WordLength::Bits32ZeroPad => i32::from_be_bytes([a, b, c, 0]) >> 8,
        // Sign-extended in the MSB: the 24-bit value is the low 3 bytes;
        // re-extend from bit 23 so a malformed extension byte cannot yield
        // a value outside the 24-bit range.
        WordLength::Bits32SignExtend => i32::from_be_bytes([b, c, d, 0]) >> 8,
    }
}

#[cfg(test)]
#[allow(clippy::indexing_slicing, clippy::unwrap_used)]
mod tests {
    use super::*;

    #[test]
    fn crc_catalogue_check_values() {
        // CRC-16/IBM-3740 (CCITT-FALSE) and CRC-16/CMS check values.
        assert_eq!(crc16(CrcType::Ccitt, b"123456789"), 0x29B1);
        assert_eq!(crc16(CrcType::Ansi, b"123456789"), 0xAEE7);
        // Seed FFFFh: the CRC of nothing is the seed.
        assert_eq!(crc16(CrcType::Ccitt, &[]), 0xFFFF);
    }

    #[test]
    fn data_words_round_trip_in_every_word_length() {
        let codes = [0, 1, -1, 0x7FFFFF, -0x800000, 0x123456, -0x123456];
        for &wl in WordLength::ALL {
            for &c in &codes {
                let w = encode_data(wl, c);
                let back = decode_data(wl, w);
                let expect = if wl == WordLength::Bits16 {
                    (c >> 8) << 8
                } else {
                    c
                };
                assert_eq!(back, expect, "{wl:?} {c:#x}");
            }
        }
        assert_eq!(encode_data(WordLength::Bits24, -1), [0xFF, 0xFF, 0xFF, 0]);
        assert_eq!(
            encode_data(WordLength::Bits32ZeroPad, -2),
            [0xFF, 0xFF, 0xFE, 0]
        );
        assert_eq!(
            encode_data(WordLength::Bits32SignExtend, -2),
            [0xFF, 0xFF, 0xFF, 0xFE]
        );
        assert_eq!(encode_data(WordLength::Bits32SignExtend, 5), [0, 0, 0, 5]);
        assert_eq!(
            encode_data(WordLength::Bits16, 0x123456),
            [0x12, 0x34, 0, 0]
        );
    }

    #[test]
    fn words_are_msb_aligned_and_zero_padded() {
        for &wl in WordLength::ALL {
            let f = FrameFormat {
                word_length: wl,
                ..FrameFormat::RESET
            };
            let mut buf = [0xAAu8; MAX_FRAME_BYTES];
            f.put_word16(&mut buf, 1, 0xBEEF);
            let wb = f.word_bytes();
            assert_eq!(buf[wb], 0xBE);
            assert_eq!(buf[wb + 1], 0xEF);
            assert!(buf[wb + 2..2 * wb].iter().all(|&b| b == 0));
            assert_eq!(f.word16(&buf, 1), 0xBEEF);
            // Out of range reads give 0, writes are ignored.
            assert_eq!(f.word16(&buf, 99), 0);
            f.put_word16(&mut buf, 99, 1);
        }
    }
}
