//! ADS131M02 conversion results: codes, volts and saturation.
//!
//! Data are 24-bit two's complement (SBAS853A "Data Format", Table 8-10):
//! 1 LSB = FSR/2²³ with FSR = V_REF/gain = 1.2 V/gain (internal reference,
//! §8.3.4). A positive full-scale input (≥ FSR·(2²³−1)/2²³) gives 7FFFFFh,
//! a negative one (≤ −FSR) 800000h, and "the output clips at these codes
//! for signals that exceed full-scale". A code at either end therefore does
//! not say what the input was, only that it was at least that large: such a
//! conversion is reported as saturated, never as a value.

use super::registers::{PgaGain, WordLength};
use crate::Rail;

/// Internal reference voltage V_REF in volts (§8.3.4).
pub const VREF_VOLTS: f64 = 1.2;

/// Largest 24-bit code, 7FFFFFh.
pub const CODE_MAX: i32 = (1 << 23) - 1;
/// Smallest 24-bit code, 800000h.
pub const CODE_MIN: i32 = -(1 << 23);

/// Volts per 24-bit code at `gain`: 1.2 V / (gain · 2²³).
pub fn lsb_volts(gain: PgaGain) -> f64 {
    VREF_VOLTS / (gain.factor() as f64 * (1u32 << 23) as f64)
}

/// The largest code a word of `word_length` can carry (16-bit words drop
/// the 8 LSBs, so their full scale is 7FFF00h on the 24-bit scale).
const fn positive_full_scale(word_length: WordLength) -> i32 {
    match word_length {
        WordLength::Bits16 => CODE_MAX & !0xFF,
        _ => CODE_MAX,
    }
}

/// The value a saturated conversion would have been reported as.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Saturated {
    /// Which end of the range the code sits at.
    pub rail: Rail,
}

impl core::fmt::Display for Saturated {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        write!(f, "ADC input at the {} (code clipped)", self.rail)
    }
}

impl core::error::Error for Saturated {}

/// One channel's conversion result, with the gain it was taken at.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Conversion {
    code: i32,
    gain: PgaGain,
    saturation: Option<Rail>,
}

impl Conversion {
    /// A conversion of `code` (24-bit scale) received in `word_length`
    /// words at PGA `gain`.
    pub const fn new(code: i32, gain: PgaGain, word_length: WordLength) -> Conversion {
        let saturation = if code >= positive_full_scale(word_length) {
            Some(Rail::High)
        } else if code <= CODE_MIN {
            Some(Rail::Low)
        } else {
            None
        };
        Conversion {
            code,
            gain,
            saturation,
        }
    }

    /// The code on the 24-bit scale, sign-extended.
    pub const fn code(self) -> i32 {
        self.code
    }

    /// The PGA gain the conversion was taken at.
    pub const fn gain(self) -> PgaGain {
        self.gain
    }

    /// `Some(rail)` if the code is at full scale.
    pub const fn saturation(self) -> Option<Rail> {
        self.saturation
    }

    /// Input voltage in volts (single precision, for the sample path of an
    /// FPU without doubles); an error if the code is at full scale.
    pub fn volts_f32(self) -> Result<f32, Saturated> {
        match self.saturation {
            Some(rail) => Err(Saturated { rail }),
            // 1.2/2²³ is exact in binary up to the factor 1.2; dividing by a
            // power-of-two gain is exact.
            None => Ok(
                self.code as f32 * (VREF_VOLTS as f32 / 8_388_608.0) / self.gain.factor() as f32
            ),
        }
    }

    /// Input voltage in volts (double precision); an error if the code is
    /// at full scale.
    pub fn volts_f64(self) -> Result<f64, Saturated> {
        match self.saturation {
            Some(rail) => Err(Saturated { rail }),
            None => Ok(self.code as f64 * lsb_volts(self.gain)),
        }
    }
}

#[cfg(test)]
#[allow(clippy::indexing_slicing, clippy::unwrap_used)]
mod tests {
    use super::*;

    #[test]
    fn full_scale_codes_are_saturated() {
        let c = Conversion::new(CODE_MAX, PgaGain::G1, WordLength::Bits24);
        assert_eq!(c.volts_f64(), Err(Saturated { rail: Rail::High }));
        let c = Conversion::new(CODE_MIN, PgaGain::G1, WordLength::Bits24);
        assert_eq!(c.volts_f32(), Err(Saturated { rail: Rail::Low }));
        let c = Conversion::new(CODE_MAX - 1, PgaGain::G1, WordLength::Bits24);
        assert!(c.saturation().is_none());
        // 16-bit words: 7FFFh is full scale.
        let c = Conversion::new(0x7FFF00, PgaGain::G1, WordLength::Bits16);
        assert_eq!(c.saturation(), Some(Rail::High));
        let c = Conversion::new(0x7FFE00, PgaGain::G1, WordLength::Bits16);
        assert!(c.saturation().is_none());
    }

    #[test]
    fn volts_follow_table_8_10() {
        // FSR/2²³ per code: code 1 at gain 1 is 1.2/2²³ V.
        let one = Conversion::new(1, PgaGain::G1, WordLength::Bits24);
        assert_eq!(one.volts_f64().unwrap(), 1.2 / 8_388_608.0);
        // Half scale at gain 4: 0.15 V.
        let half = Conversion::new(1 << 22, PgaGain::G4, WordLength::Bits24);
        assert_eq!(half.volts_f64().unwrap(), 0.15);
        assert_eq!(half.volts_f32().unwrap(), 0.15);
        let neg = Conversion::new(-(1 << 22), PgaGain::G128, WordLength::Bits24);
        assert!((neg.volts_f64().unwrap() + 0.6 / 128.0).abs() < 1e-15);
        assert_eq!(lsb_volts(PgaGain::G2), 0.6 / 8_388_608.0);
    }
}
