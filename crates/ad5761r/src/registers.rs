//! AD5761R input shift register, commands and control register.
//!
//! Sources: AD5761R/AD5721R data sheet Rev. C (ADI, 2014–2018). Verified in
//! its text: the 24-bit input shift register, DB23:21 don't care, DB20 = 0,
//! DB19:16 register address (command), DB15:0 data, MSB first (Table 14);
//! the readback word shifted out of SDO during the *next* command, echoing
//! the address in DB19:16 (Table 15); the control register layout SC (12),
//! BO (11), `CV[1:0]` (10:9), OVR (8), B2C (7), ETS (6), IRO (5), `PV[1:0]`
//! (4:3), `RA[2:0]` (2:0) (Table 15), SC and BO reset at every control write
//! (Table 16); bipolar codes, straight binary 8000h = 0 V and two's
//! complement 0000h = 0 V (Table 13). The command nibbles other than 1100
//! (readback control), the RA and PV/CV encodings and the IRO polarity
//! (1 = internal reference on) are from ADI's no-OS driver `ad5761r.h` and
//! agree with the Linux `ad5761` driver; the data-sheet tables that define
//! them (Tables 9–12) were not available to the search tools here.

/// Input shift register commands, DB19:16.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[repr(u8)]
pub enum Command {
    /// 0000: no operation (also 0101, 0110, 1101, 1110).
    Nop = 0x0,
    /// 0001: write the input register.
    WriteInput = 0x1,
    /// 0010: update the DAC register from the input register.
    UpdateDac = 0x2,
    /// 0011: write the input register and update the DAC register.
    WriteUpdateDac = 0x3,
    /// 0100: write the control register.
    WriteControl = 0x4,
    /// 0111: software data reset (input and DAC registers).
    DataReset = 0x7,
    /// 1001: disable daisy chain (DB0 = 1 disables SDO; readback needs it).
    DisableDaisyChain = 0x9,
    /// 1010: read back the input register.
    ReadInput = 0xA,
    /// 1011: read back the DAC register.
    ReadDac = 0xB,
    /// 1100: read back the control register.
    ReadControl = 0xC,
    /// 1111: software full reset (all registers to power-on state).
    FullReset = 0xF,
}

impl Command {
    /// Decode DB19:16; `None` for the no-op and reserved nibbles other than
    /// 0000 (0101, 0110, 1000, 1101, 1110).
    pub const fn from_nibble(n: u8) -> Option<Command> {
        match n & 0x0F {
            0x0 => Some(Command::Nop),
            0x1 => Some(Command::WriteInput),
            0x2 => Some(Command::UpdateDac),
            0x3 => Some(Command::WriteUpdateDac),
            0x4 => Some(Command::WriteControl),
            0x7 => Some(Command::DataReset),
            0x9 => Some(Command::DisableDaisyChain),
            0xA => Some(Command::ReadInput),
            0xB => Some(Command::ReadDac),
            0xC => Some(Command::ReadControl),
            0xF => Some(Command::FullReset),
            _ => None,
        }
    }

    /// The 24-bit input word, MSB first: DB23:20 = 0, DB19:16 = command,
    /// DB15:0 = `data`.
    pub const fn frame(self, data: u16) -> [u8; 3] {
        [self as u8, (data >> 8) as u8, data as u8]
    }
}

/// Output range, control register `RA[2:0]`, with the transfer-function
/// constants M and C: V_OUT = V_REF·(M·D/2¹⁶ − C), D straight binary.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum OutputRange {
    /// 000: −10 V to +10 V (M = 8, C = 4).
    Bipolar10V = 0,
    /// 001: 0 V to +10 V (M = 4, C = 0).
    Unipolar10V = 1,
    /// 010: −5 V to +5 V (M = 4, C = 2).
    Bipolar5V = 2,
    /// 011: 0 V to +5 V (M = 2, C = 0).
    Unipolar5V = 3,
    /// 100: −2.5 V to +7.5 V (M = 4, C = 1).
    Minus2V5To7V5 = 4,
    /// 101: −3 V to +3 V (M = 2.4, C = 1.2).
    Bipolar3V = 5,
    /// 110: 0 V to +16 V (M = 6.4, C = 0).
    Unipolar16V = 6,
    /// 111: 0 V to +20 V (M = 8, C = 0).
    Unipolar20V = 7,
}

impl OutputRange {
    /// Every range, in RA order.
    pub const ALL: [OutputRange; 8] = [
        OutputRange::Bipolar10V,
        OutputRange::Unipolar10V,
        OutputRange::Bipolar5V,
        OutputRange::Unipolar5V,
        OutputRange::Minus2V5To7V5,
        OutputRange::Bipolar3V,
        OutputRange::Unipolar16V,
        OutputRange::Unipolar20V,
    ];

    /// `RA[2:0]`.
    pub const fn to_bits(self) -> u16 {
        self as u16
    }

    /// Decode `RA[2:0]` (all eight codes are ranges).
    pub const fn from_bits(bits: u16) -> OutputRange {
        match bits & 0b111 {
            0 => OutputRange::Bipolar10V,
            1 => OutputRange::Unipolar10V,
            2 => OutputRange::Bipolar5V,
            3 => OutputRange::Unipolar5V,
            4 => OutputRange::Minus2V5To7V5,
            5 => OutputRange::Bipolar3V,
            6 => OutputRange::Unipolar16V,
            _ => OutputRange::Unipolar20V,
        }
    }

    /// (M, C) of the transfer function, in tenths (exact integers; the
    /// Linux driver's table uses the same scaling).
    pub const fn m_c_tenths(self) -> (u32, u32) {
        match self {
            OutputRange::Bipolar10V => (80, 40),
            OutputRange::Unipolar10V => (40, 0),
            OutputRange::Bipolar5V => (40, 20),
            OutputRange::Unipolar5V => (20, 0),
            OutputRange::Minus2V5To7V5 => (40, 10),
            OutputRange::Bipolar3V => (24, 12),
            OutputRange::Unipolar16V => (64, 0),
            OutputRange::Unipolar20V => (80, 0),
        }
    }

    /// Whether the range spans 0 V from below (C > 0): B2C coding applies.
    pub const fn is_bipolar(self) -> bool {
        self.m_c_tenths().1 > 0
    }
}

/// Bipolar-range coding, control register B2C (bit 7), Table 13.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum BipolarCoding {
    /// 0: straight (offset) binary, 8000h is mid-scale.
    StraightBinary = 0,
    /// 1: two's complement, 0000h is mid-scale.
    TwosComplement = 1,
}

/// Power-up (`PV[1:0]`) or clear (`CV[1:0]`) output level.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum ScaleLevel {
    /// 00: zero scale (the bottom of the range: −10 V on ±10 V!).
    Zero = 0,
    /// 01: mid-scale (0 V on the symmetric bipolar ranges).
    Mid = 1,
    /// 10: full scale.
    Full = 2,
}

impl ScaleLevel {
    /// Decode a 2-bit field; `None` for 11 (meaning not verified).
    pub const fn from_bits(bits: u16) -> Option<ScaleLevel> {
        match bits & 0b11 {
            0 => Some(ScaleLevel::Zero),
            1 => Some(ScaleLevel::Mid),
            2 => Some(ScaleLevel::Full),
            _ => None,
        }
    }

    /// The straight-binary DAC code of this level.
    pub const fn code(self) -> u16 {
        match self {
            ScaleLevel::Zero => 0x0000,
            ScaleLevel::Mid => 0x8000,
            ScaleLevel::Full => 0xFFFF,
        }
    }
}

/// Control register contents (the writable bits 10:0).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ControlRegister {
    /// `RA[2:0]`: output range.
    pub range: OutputRange,
    /// B2C: coding of the bipolar ranges (unipolar ranges are always
    /// straight binary).
    pub coding: BipolarCoding,
    /// OVR: 5 % overrange.
    pub overrange: bool,
    /// `CV[1:0]`: output level while CLEAR is asserted.
    pub clear: ScaleLevel,
    /// `PV[1:0]`: power-up output level.
    pub power_up: ScaleLevel,
    /// ETS: thermal shutdown when the die overheats.
    pub thermal_shutdown: bool,
    /// IRO: internal 2.5 V reference on.
    pub internal_reference: bool,
}

/// Mask of the control register's writable bits (CV..RA, bits 10:0).
pub const CONTROL_MASK: u16 = 0x07FF;

const fn flag(b: bool, n: u32) -> u16 {
    (b as u16) << n
}

impl ControlRegister {
    /// Encode bits 10:0.
    pub const fn to_bits(self) -> u16 {
        ((self.clear as u16) << 9)
            | flag(self.overrange, 8)
            | ((self.coding as u16) << 7)
            | flag(self.thermal_shutdown, 6)
            | flag(self.internal_reference, 5)
            | ((self.power_up as u16) << 3)
            | self.range.to_bits()
    }

    /// Decode bits 10:0; `None` if CV or PV is 11.
    pub const fn from_bits(v: u16) -> Option<ControlRegister> {
        let (Some(clear), Some(power_up)) =
            (ScaleLevel::from_bits(v >> 9), ScaleLevel::from_bits(v >> 3))
        else {
            return None;
        };
        Some(ControlRegister {
            range: OutputRange::from_bits(v),
            coding: if v & (1 << 7) != 0 {
                BipolarCoding::TwosComplement
            } else {
                BipolarCoding::StraightBinary
            },
            overrange: v & (1 << 8) != 0,
            clear,
            power_up,
            thermal_shutdown: v & (1 << 6) != 0,
            internal_reference: v & (1 << 5) != 0,
        })
    }
}

/// A control-register readback: the settings plus the status flags.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ControlReadback {
    /// Bits 10:0.
    pub control: ControlRegister,
    /// SC (bit 12): short-circuit condition detected since the last
    /// control write.
    pub short_circuit: bool,
    /// BO (bit 11): brown-out condition detected since the last control
    /// write.
    pub brownout: bool,
}

#[cfg(test)]
#[allow(clippy::indexing_slicing, clippy::unwrap_used)]
mod tests {
    use super::*;

    #[test]
    fn frames_put_the_command_in_db19_16() {
        assert_eq!(Command::FullReset.frame(0), [0x0F, 0x00, 0x00]);
        assert_eq!(Command::WriteUpdateDac.frame(0xBEEF), [0x03, 0xBE, 0xEF]);
        assert_eq!(Command::ReadControl.frame(0), [0x0C, 0x00, 0x00]);
        for n in 0..16u8 {
            if let Some(c) = Command::from_nibble(n) {
                assert_eq!(c as u8, n);
            }
        }
    }

    #[test]
    fn control_register_round_trips() {
        let levels = [ScaleLevel::Zero, ScaleLevel::Mid, ScaleLevel::Full];
        let codings = [BipolarCoding::StraightBinary, BipolarCoding::TwosComplement];
        for range in OutputRange::ALL {
            for &clear in &levels {
                for &power_up in &levels {
                    for &coding in &codings {
                        for f in 0..8u8 {
                            let c = ControlRegister {
                                range,
                                coding,
                                overrange: f & 1 != 0,
                                clear,
                                power_up,
                                thermal_shutdown: f & 2 != 0,
                                internal_reference: f & 4 != 0,
                            };
                            assert_eq!(c.to_bits() & !CONTROL_MASK, 0);
                            assert_eq!(ControlRegister::from_bits(c.to_bits()), Some(c));
                        }
                    }
                }
            }
        }
        // Table 15 bit positions.
        let c = ControlRegister::from_bits(0b100_0110_1011).unwrap();
        assert_eq!(c.clear, ScaleLevel::Full);
        assert!(!c.overrange);
        assert_eq!(c.coding, BipolarCoding::StraightBinary);
        assert!(c.thermal_shutdown && c.internal_reference);
        assert_eq!(c.power_up, ScaleLevel::Mid);
        assert_eq!(c.range, OutputRange::Unipolar5V);
        assert_eq!(ControlRegister::from_bits(0b11 << 9), None);
    }

    #[test]
    fn range_constants_span_the_named_voltages() {
        let spans = [
            (-10.0, 10.0),
            (0.0, 10.0),
            (-5.0, 5.0),
            (0.0, 5.0),
            (-2.5, 7.5),
            (-3.0, 3.0),
            (0.0, 16.0),
            (0.0, 20.0),
        ];
        for (r, (lo, hi)) in OutputRange::ALL.iter().zip(spans) {
            let (m, c) = r.m_c_tenths();
            let (m, c) = (m as f64 / 10.0, c as f64 / 10.0);
            assert!((2.5 * -c - lo).abs() < 1e-12, "{r:?}");
            assert!((2.5 * (m - c) - hi).abs() < 1e-12, "{r:?}");
            assert_eq!(r.is_bipolar(), lo < 0.0);
        }
    }
}
