//! AD5761R volts ↔ code, with saturation at the rails reported, never
//! wrapped.
//!
//! Transfer function V_OUT = V_REF·(M·D/2¹⁶ − C) with D the straight-binary
//! code and (M, C) per range ([`crate::OutputRange::m_c_tenths`]); in two's
//! complement coding the code written is D XOR 8000h (Table 13). The 5 %
//! overrange (OVR) is modelled as M and C both scaled by 1.05 (a span 5 %
//! wider on each side of the range's own zero); that scaling is this
//! driver's reading of "5 % overrange", not checked against the data
//! sheet's overrange table, which was not available here.

use super::registers::{BipolarCoding, ControlRegister};
use crate::Rail;

/// Internal reference voltage, volts (data sheet front page: "2.5 V
/// reference").
pub const INTERNAL_VREF_VOLTS: f32 = 2.5;

/// Overrange factor applied to M and C when OVR is set: the span 5 % wider
/// on each side of the range's own zero. This is the driver's reading of
/// "5 % overrange", not checked against the data sheet's overrange table.
pub const OVERRANGE_FACTOR: f32 = 1.05;

/// A code to write, and whether the requested voltage was beyond a rail.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct DacWrite {
    /// The code, in the configured coding.
    pub code: u16,
    /// `Some(rail)` if the request was outside the range and the code was
    /// clamped to that rail (0000h / FFFFh straight binary).
    pub clamped: Option<Rail>,
}

/// The requested voltage was NaN or infinite: nothing is written.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct NotFinite;

/// Precomputed conversion for one configuration: the sample path costs one
/// multiply-add, two compares and a cast.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Transfer {
    /// Codes per volt: 2¹⁶/(M·V_REF).
    codes_per_volt: f32,
    /// Straight-binary code at 0 V: 2¹⁶·C/M.
    zero_code: f32,
    /// XOR applied to straight binary: 8000h for two's complement on a
    /// bipolar range, else 0.
    coding_xor: u16,
    /// V_REF·M/2¹⁶ and −V_REF·C for the inverse.
    volts_per_code: f32,
    offset_volts: f32,
}

impl Transfer {
    /// The transfer function of `control` with reference `vref_volts`.
    pub fn new(control: &ControlRegister, vref_volts: f32) -> Transfer {
        let (m, c) = control.range.m_c_tenths();
        let ovr = if control.overrange {
            OVERRANGE_FACTOR
        } else {
            1.0
        };
        let m = m as f32 / 10.0 * ovr;
        let c = c as f32 / 10.0 * ovr;
        let full = 65_536.0_f32;
        let coding_xor = match (control.range.is_bipolar(), control.coding) {
            (true, BipolarCoding::TwosComplement) => 0x8000,
            _ => 0,
        };
        Transfer {
            codes_per_volt: full / (m * vref_volts),
            zero_code: full * c / m,
            coding_xor,
            volts_per_code: vref_volts * m / full,
            offset_volts: -vref_volts * c,
        }
    }

    /// The code for `volts`, rounded to nearest; beyond a rail (by more
    /// than half an LSB) the code is that rail's and `clamped` says so.
    pub fn code(&self, volts: f32) -> Result<DacWrite, NotFinite> {
        if !volts.is_finite() {
            return Err(NotFinite);
        }
        let x = volts * self.codes_per_volt + self.zero_code;
        let (straight, clamped) = if x >= 65_535.5 {
            (0xFFFF, Some(Rail::High))
        } else if x < -0.5 {
            (0x0000, Some(Rail::Low))
        } else {
            // x + 0.5 ∈ [0, 65536): the cast floors, i.e. rounds x.
            ((x + 0.5) as u16, None)
        };
        Ok(DacWrite {
            code: straight ^ self.coding_xor,
            clamped,
        })
    }

    /// The ideal output voltage of `code` (in the configured coding).
    pub fn volts(&self, code: u16) -> f32 {
        f32::from(code ^ self.coding_xor) * self.volts_per_code + self.offset_volts
    }

    /// Volts per code (1 LSB).
    pub fn lsb_volts(&self) -> f32 {
        self.volts_per_code
    }
}

#[cfg(test)]
#[allow(clippy::indexing_slicing, clippy::unwrap_used)]
mod tests {
    use super::super::registers::{OutputRange, ScaleLevel};
    use super::*;

    fn control(range: OutputRange, coding: BipolarCoding) -> ControlRegister {
        ControlRegister {
            range,
            coding,
            overrange: false,
            clear: ScaleLevel::Mid,
            power_up: ScaleLevel::Mid,
            thermal_shutdown: true,
            internal_reference: true,
        }
    }

    #[test]
    fn bipolar_10v_codes() {
        let sb = Transfer::new(
            &control(OutputRange::Bipolar10V, BipolarCoding::StraightBinary),
            2.5,
        );
        assert_eq!(sb.code(0.0).unwrap().code, 0x8000);
        assert_eq!(
            sb.code(-10.0).unwrap(),
            DacWrite {
                code: 0,
                clamped: None
            }
        );
        // +10 V is one LSB above the top code: clamped high.
        let top = sb.code(10.0).unwrap();
        assert_eq!(
            top,
            DacWrite {
                code: 0xFFFF,
                clamped: Some(Rail::High)
            }
        );
        assert_eq!(sb.code(-10.1).unwrap().clamped, Some(Rail::Low));
        assert_eq!(sb.code(5.0).unwrap().code, 0xC000);
        let tc = Transfer::new(
            &control(OutputRange::Bipolar10V, BipolarCoding::TwosComplement),
            2.5,
        );
        assert_eq!(tc.code(0.0).unwrap().code, 0x0000);
        assert_eq!(tc.code(-10.0).unwrap().code, 0x8000);
        assert_eq!(
            tc.code(1e9).unwrap(),
            DacWrite {
                code: 0x7FFF,
                clamped: Some(Rail::High)
            }
        );
        assert_eq!(tc.volts(0xC000), -5.0);
        assert_eq!(tc.code(f32::NAN), Err(NotFinite));
        assert_eq!(tc.code(f32::INFINITY), Err(NotFinite));
    }

    #[test]
    fn unipolar_ranges_ignore_b2c() {
        let t = Transfer::new(
            &control(OutputRange::Unipolar10V, BipolarCoding::TwosComplement),
            2.5,
        );
        assert_eq!(t.code(0.0).unwrap().code, 0);
        assert_eq!(t.code(5.0).unwrap().code, 0x8000);
        assert_eq!(t.code(-0.1).unwrap().clamped, Some(Rail::Low));
    }

    #[test]
    fn codes_round_trip_within_half_an_lsb() {
        for range in OutputRange::ALL {
            for coding in [BipolarCoding::StraightBinary, BipolarCoding::TwosComplement] {
                let t = Transfer::new(&control(range, coding), 2.5);
                for code in (0..=0xFFFFu16).step_by(97) {
                    let v = t.volts(code);
                    let back = t.code(v).unwrap();
                    assert_eq!(back.code, code, "{range:?} {coding:?} {code:04X}");
                    assert_eq!(back.clamped, None);
                }
            }
        }
    }
}
