//! ADS131M02 register map and typed register contents.
//!
//! Addresses, reset values and bit positions are from the register map,
//! SBAS853A Table 8-12 (read in the text of the ADS131M02-Q1 data sheet
//! SBASAE7, whose Table 8-12 is the same map; field meanings from the TI
//! ADS131M0x example header). Every struct has `to_bits`/`from_bits`;
//! `from_bits(to_bits(x)) == x` is unit-tested for every field value.

/// Register addresses (Table 8-12). Addresses not listed are reserved.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[repr(u8)]
pub enum Register {
    /// 00h ID (read-only), reset 22xxh: CHANCNT = 2 in bits 11:8.
    Id = 0x00,
    /// 01h STATUS (read-only), reset 0500h.
    Status = 0x01,
    /// 02h MODE, reset 0510h.
    Mode = 0x02,
    /// 03h CLOCK, reset 030Eh.
    Clock = 0x03,
    /// 04h GAIN1, reset 0000h (PGAGAIN1 bits 6:4, PGAGAIN0 bits 2:0).
    Gain = 0x04,
    /// 06h CFG (global chop, current detect), reset 0600h.
    Cfg = 0x06,
    /// 07h THRSHLD_MSB, reset 0000h.
    ThresholdMsb = 0x07,
    /// 08h THRSHLD_LSB (and `DCBLOCK[3:0]`), reset 0000h.
    ThresholdLsb = 0x08,
    /// 09h CH0_CFG (PHASE0, MUX0), reset 0000h.
    Ch0Cfg = 0x09,
    /// 0Ah CH0_OCAL_MSB, reset 0000h.
    Ch0OcalMsb = 0x0A,
    /// 0Bh CH0_OCAL_LSB, reset 0000h.
    Ch0OcalLsb = 0x0B,
    /// 0Ch CH0_GCAL_MSB, reset 8000h (gain 1.0).
    Ch0GcalMsb = 0x0C,
    /// 0Dh CH0_GCAL_LSB, reset 0000h.
    Ch0GcalLsb = 0x0D,
    /// 0Eh CH1_CFG, reset 0000h.
    Ch1Cfg = 0x0E,
    /// 0Fh CH1_OCAL_MSB, reset 0000h.
    Ch1OcalMsb = 0x0F,
    /// 10h CH1_OCAL_LSB, reset 0000h.
    Ch1OcalLsb = 0x10,
    /// 11h CH1_GCAL_MSB, reset 8000h.
    Ch1GcalMsb = 0x11,
    /// 12h CH1_GCAL_LSB, reset 0000h.
    Ch1GcalLsb = 0x12,
    /// 3Eh REGMAP_CRC (read-only), register-map CRC.
    RegmapCrc = 0x3E,
}

impl Register {
    /// All registers of the map, in address order.
    pub const ALL: [Register; 19] = [
        Register::Id,
        Register::Status,
        Register::Mode,
        Register::Clock,
        Register::Gain,
        Register::Cfg,
        Register::ThresholdMsb,
        Register::ThresholdLsb,
        Register::Ch0Cfg,
        Register::Ch0OcalMsb,
        Register::Ch0OcalLsb,
        Register::Ch0GcalMsb,
        Register::Ch0GcalLsb,
        Register::Ch1Cfg,
        Register::Ch1OcalMsb,
        Register::Ch1OcalLsb,
        Register::Ch1GcalMsb,
        Register::Ch1GcalLsb,
        Register::RegmapCrc,
    ];

    /// The 6-bit register address.
    pub const fn addr(self) -> u8 {
        self as u8
    }

    /// The register at `addr`, if the map has one there.
    pub fn from_addr(addr: u8) -> Option<Register> {
        Register::ALL.iter().copied().find(|r| r.addr() == addr)
    }

    /// Value after power-on or RESET (Table 8-12). For ID the revision byte
    /// is device-specific ("22xxh"); this returns it as 00h.
    pub const fn reset_value(self) -> u16 {
        match self {
            Register::Id => 0x2200,
            Register::Status => 0x0500,
            Register::Mode => 0x0510,
            Register::Clock => 0x030E,
            Register::Cfg => 0x0600,
            Register::Ch0GcalMsb | Register::Ch1GcalMsb => 0x8000,
            _ => 0x0000,
        }
    }

    /// Whether WREG can change the register (ID, STATUS and REGMAP_CRC are
    /// read-only, Table 8-12).
    pub const fn is_writable(self) -> bool {
        !matches!(self, Register::Id | Register::Status | Register::RegmapCrc)
    }
}

/// Expected high byte of the ID register: reserved nibble 2h and
/// `CHANCNT[3:0]` = 2 (Table 8-12, "22xxh").
pub(crate) const ID_HIGH_BYTE: u8 = 0x22;

macro_rules! bit_enum {
    ($(#[$m:meta])* $name:ident : $mask:literal { $($(#[$vm:meta])* $var:ident = $val:literal),+ $(,)? }) => {
        $(#[$m])*
        #[derive(Clone, Copy, Debug, PartialEq, Eq)]
        #[cfg_attr(feature = "defmt", derive(defmt::Format))]
        pub enum $name { $($(#[$vm])* $var = $val),+ }

        impl $name {
            /// Every value, in encoding order.
            pub const ALL: &'static [$name] = &[$($name::$var),+];

            /// The field's encoding (unshifted).
            pub const fn to_bits(self) -> u16 {
                self as u16
            }

            /// Decode the (unshifted) field; `None` for an encoding the
            /// enum does not name.
            pub fn from_bits(bits: u16) -> Option<$name> {
                match bits & $mask {
                    $($val => Some($name::$var),)+
                    _ => None,
                }
            }
        }
    };
}

bit_enum! {
    /// Word length, MODE/STATUS `WLENGTH[1:0]` (bits 9:8).
    WordLength: 0b11 {
        /// 16-bit words; conversion data truncated to the 16 MSBs.
        Bits16 = 0,
        /// 24-bit words (reset default).
        Bits24 = 1,
        /// 32-bit words, data LSB zero-padded.
        Bits32ZeroPad = 2,
        /// 32-bit words, data MSB sign-extended.
        Bits32SignExtend = 3,
    }
}

impl WordLength {
    /// Bytes per SPI word.
    pub const fn bytes(self) -> usize {
        match self {
            WordLength::Bits16 => 2,
            WordLength::Bits24 => 3,
            WordLength::Bits32ZeroPad | WordLength::Bits32SignExtend => 4,
        }
    }
}

bit_enum! {
    /// CRC polynomial, MODE/STATUS CRC_TYPE (bit 11), §8.3.12 Table 8-7.
    CrcType: 0b1 {
        /// CCITT x¹⁶+x¹²+x⁵+1 (0x1021), seed FFFFh (reset default).
        Ccitt = 0,
        /// ANSI x¹⁶+x¹⁵+x²+1 (0x8005), seed FFFFh.
        Ansi = 1,
    }
}

bit_enum! {
    /// MODE `DRDY_SEL[1:0]` (bits 3:2): which channel's conversion drives DRDY.
    DrdySelect: 0b11 {
        /// The most lagging enabled channel (reset default).
        MostLagging = 0,
        /// Logic OR of all enabled channels.
        LogicOr = 1,
        /// The most leading enabled channel.
        MostLeading = 2,
        /// Alternative encoding of "most leading".
        MostLeadingAlt = 3,
    }
}

bit_enum! {
    /// MODE DRDY_FMT (bit 0).
    DrdyFormat: 0b1 {
        /// DRDY is a logic level, low while new data are available (default).
        LogicLow = 0,
        /// DRDY is a fixed-width negative pulse.
        NegativePulse = 1,
    }
}

bit_enum! {
    /// CLOCK `OSR[2:0]` (bits 4:2). Output data rate f_DATA = f_CLKIN/(2·OSR)
    /// (f_MOD = f_CLKIN/2, §8.3.5/§8.3.7).
    Osr: 0b111 {
        /// OSR 128.
        Osr128 = 0,
        /// OSR 256.
        Osr256 = 1,
        /// OSR 512.
        Osr512 = 2,
        /// OSR 1024 (reset default).
        Osr1024 = 3,
        /// OSR 2048.
        Osr2048 = 4,
        /// OSR 4096.
        Osr4096 = 5,
        /// OSR 8192.
        Osr8192 = 6,
        /// OSR 16384.
        Osr16384 = 7,
    }
}

impl Osr {
    /// The oversampling ratio.
    pub const fn ratio(self) -> u32 {
        128 << (self as u32)
    }

    /// Output data rate in Hz for a CLKIN of `f_clkin_hz`: f_CLKIN/(2·OSR).
    pub fn data_rate_hz(self, f_clkin_hz: f64) -> f64 {
        f_clkin_hz / (2.0 * self.ratio() as f64)
    }
}

bit_enum! {
    /// CLOCK `PWR[1:0]` (bits 1:0), §8.3.5.
    PowerMode: 0b11 {
        /// Very-low-power mode.
        VeryLowPower = 0,
        /// Low-power mode.
        LowPower = 1,
        /// High-resolution mode (reset default).
        HighResolution = 2,
        /// Alternative encoding of high-resolution.
        HighResolutionAlt = 3,
    }
}

bit_enum! {
    /// GAIN1 `PGAGAINn[2:0]`: PGA gain 2ⁿ, §8.3.3. Full-scale range is
    /// ±1.2 V / gain (Table 8-10).
    PgaGain: 0b111 {
        /// Gain 1 (reset default).
        G1 = 0,
        /// Gain 2.
        G2 = 1,
        /// Gain 4.
        G4 = 2,
        /// Gain 8.
        G8 = 3,
        /// Gain 16.
        G16 = 4,
        /// Gain 32.
        G32 = 5,
        /// Gain 64.
        G64 = 6,
        /// Gain 128.
        G128 = 7,
    }
}

impl PgaGain {
    /// The gain factor.
    pub const fn factor(self) -> u32 {
        1 << (self as u32)
    }
}

const fn bit(v: u16, n: u32) -> bool {
    v & (1 << n) != 0
}

const fn flag(b: bool, n: u32) -> u16 {
    (b as u16) << n
}

/// STATUS register (01h), also the response to NULL (Table 8-11).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Status {
    /// LOCK (bit 15): the interface is locked.
    pub lock: bool,
    /// F_RESYNC (bit 14): a resynchronisation fault occurred.
    pub resync_fault: bool,
    /// REG_MAP (bit 13): the register-map CRC changed.
    pub reg_map_changed: bool,
    /// CRC_ERR (bit 12): an input CRC error occurred; the command of that
    /// frame was not executed (WREG excepted), §8.3.12.
    pub crc_error: bool,
    /// CRC_TYPE (bit 11).
    pub crc_type: CrcType,
    /// RESET (bit 10): a reset occurred since MODE.RESET was last cleared.
    pub reset: bool,
    /// `WLENGTH[1:0]` (bits 9:8).
    pub word_length: WordLength,
    /// DRDY1, DRDY0 (bits 1, 0): new data available on channel 1, 0.
    pub drdy: [bool; 2],
}

/// STATUS bits 7:2 are reserved on the two-channel part (Table 8-12).
const STATUS_RESERVED_MASK: u16 = 0x00FC;

impl Status {
    /// Encode to the 16-bit register value.
    pub const fn to_bits(self) -> u16 {
        flag(self.lock, 15)
            | flag(self.resync_fault, 14)
            | flag(self.reg_map_changed, 13)
            | flag(self.crc_error, 12)
            | (self.crc_type.to_bits() << 11)
            | flag(self.reset, 10)
            | (self.word_length.to_bits() << 8)
            | flag(self.drdy[1], 1)
            | flag(self.drdy[0], 0)
    }

    /// Decode; `None` if a reserved bit (7:2) is set, i.e. the word is not
    /// a STATUS word of this part.
    pub fn from_bits(v: u16) -> Option<Status> {
        if v & STATUS_RESERVED_MASK != 0 {
            return None;
        }
        Some(Status {
            lock: bit(v, 15),
            resync_fault: bit(v, 14),
            reg_map_changed: bit(v, 13),
            crc_error: bit(v, 12),
            crc_type: CrcType::from_bits(v >> 11)?,
            reset: bit(v, 10),
            word_length: WordLength::from_bits(v >> 8)?,
            drdy: [bit(v, 0), bit(v, 1)],
        })
    }
}

/// MODE register (02h), reset 0510h.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Mode {
    /// REGCRC_EN (bit 13): register-map CRC enabled.
    pub reg_crc_enable: bool,
    /// RX_CRC_EN (bit 12): input (command) CRC checked by the device.
    pub rx_crc_enable: bool,
    /// CRC_TYPE (bit 11).
    pub crc_type: CrcType,
    /// RESET (bit 10): write 0 to clear the reset flag.
    pub reset: bool,
    /// `WLENGTH[1:0]` (bits 9:8).
    pub word_length: WordLength,
    /// TIMEOUT (bit 4): SPI timeout enabled (default 1).
    pub timeout: bool,
    /// `DRDY_SEL[1:0]` (bits 3:2).
    pub drdy_select: DrdySelect,
    /// DRDY_HiZ (bit 1): DRDY high-impedance (instead of driven high) when
    /// no data are ready.
    pub drdy_hiz: bool,
    /// DRDY_FMT (bit 0).
    pub drdy_format: DrdyFormat,
}

impl Mode {
    /// Encode to the 16-bit register value (reserved bits 0).
    pub const fn to_bits(self) -> u16 {
        flag(self.reg_crc_enable, 13)
            | flag(self.rx_crc_enable, 12)
            | (self.crc_type.to_bits() << 11)
            | flag(self.reset, 10)
            | (self.word_length.to_bits() << 8)
            | flag(self.timeout, 4)
            | (self.drdy_select.to_bits() << 2)
            | flag(self.drdy_hiz, 1)
            | self.drdy_format.to_bits()
    }

    /// Decode (reserved bits ignored).
    pub fn from_bits(v: u16) -> Mode {
        Mode {
            reg_crc_enable: bit(v, 13),
            rx_crc_enable: bit(v, 12),
            crc_type: if bit(v, 11) {
                CrcType::Ansi
            } else {
                CrcType::Ccitt
            },
            reset: bit(v, 10),
            word_length: word_length_of(v >> 8),
            timeout: bit(v, 4),
            drdy_select: match (v >> 2) & 0b11 {
                0 => DrdySelect::MostLagging,
                1 => DrdySelect::LogicOr,
                2 => DrdySelect::MostLeading,
                _ => DrdySelect::MostLeadingAlt,
            },
            drdy_hiz: bit(v, 1),
            drdy_format: if bit(v, 0) {
                DrdyFormat::NegativePulse
            } else {
                DrdyFormat::LogicLow
            },
        }
    }
}

/// Infallible decode of a 2-bit WLENGTH field (all four codes are named).
const fn word_length_of(bits: u16) -> WordLength {
    match bits & 0b11 {
        0 => WordLength::Bits16,
        1 => WordLength::Bits24,
        2 => WordLength::Bits32ZeroPad,
        _ => WordLength::Bits32SignExtend,
    }
}

/// CLOCK register (03h), reset 030Eh.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Clock {
    /// CH1_EN (bit 9), CH0_EN (bit 8): channel ADC enabled.
    pub channel_enable: [bool; 2],
    /// TBM (bit 5), turbo mode. The data sheet text for this bit was not
    /// available when this driver was written; the driver always writes 0
    /// and keeps what it reads.
    pub turbo: bool,
    /// `OSR[2:0]` (bits 4:2).
    pub osr: Osr,
    /// `PWR[1:0]` (bits 1:0).
    pub power_mode: PowerMode,
}

impl Clock {
    /// Encode to the 16-bit register value.
    pub const fn to_bits(self) -> u16 {
        flag(self.channel_enable[1], 9)
            | flag(self.channel_enable[0], 8)
            | flag(self.turbo, 5)
            | (self.osr.to_bits() << 2)
            | self.power_mode.to_bits()
    }

    /// Decode (reserved bits ignored).
    pub fn from_bits(v: u16) -> Clock {
        Clock {
            channel_enable: [bit(v, 8), bit(v, 9)],
            turbo: bit(v, 5),
            osr: osr_of(v >> 2),
            power_mode: match v & 0b11 {
                0 => PowerMode::VeryLowPower,
                1 => PowerMode::LowPower,
                2 => PowerMode::HighResolution,
                _ => PowerMode::HighResolutionAlt,
            },
        }
    }
}

const fn osr_of(bits: u16) -> Osr {
    match bits & 0b111 {
        0 => Osr::Osr128,
        1 => Osr::Osr256,
        2 => Osr::Osr512,
        3 => Osr::Osr1024,
        4 => Osr::Osr2048,
        5 => Osr::Osr4096,
        6 => Osr::Osr8192,
        _ => Osr::Osr16384,
    }
}

/// Infallible decode of a 3-bit PGAGAIN field (all eight codes are named).
const fn pga_gain_of(bits: u16) -> PgaGain {
    match bits & 0b111 {
        0 => PgaGain::G1,
        1 => PgaGain::G2,
        2 => PgaGain::G4,
        3 => PgaGain::G8,
        4 => PgaGain::G16,
        5 => PgaGain::G32,
        6 => PgaGain::G64,
        _ => PgaGain::G128,
    }
}

/// GAIN1 register (04h), reset 0000h.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Gain {
    /// PGAGAIN0 (bits 2:0) and PGAGAIN1 (bits 6:4).
    pub pga: [PgaGain; 2],
}

impl Gain {
    /// Encode to the 16-bit register value.
    pub const fn to_bits(self) -> u16 {
        (self.pga[1].to_bits() << 4) | self.pga[0].to_bits()
    }

    /// Decode (reserved bits ignored).
    pub fn from_bits(v: u16) -> Gain {
        Gain {
            pga: [pga_gain_of(v), pga_gain_of(v >> 4)],
        }
    }
}

#[cfg(test)]
#[allow(clippy::indexing_slicing, clippy::unwrap_used)]
mod tests {
    use super::*;

    #[test]
    fn reset_values_decode_to_the_documented_defaults() {
        let mode = Mode::from_bits(Register::Mode.reset_value());
        assert_eq!(mode.word_length, WordLength::Bits24);
        assert_eq!(mode.crc_type, CrcType::Ccitt);
        assert!(mode.reset && mode.timeout && !mode.rx_crc_enable);
        assert_eq!(mode.to_bits(), 0x0510);
        let clock = Clock::from_bits(Register::Clock.reset_value());
        assert_eq!(clock.osr, Osr::Osr1024);
        assert_eq!(clock.power_mode, PowerMode::HighResolution);
        assert_eq!(clock.channel_enable, [true, true]);
        assert_eq!(clock.to_bits(), 0x030E);
        let status = Status::from_bits(Register::Status.reset_value()).unwrap();
        assert!(status.reset);
        assert_eq!(status.word_length, WordLength::Bits24);
        assert_eq!(status.to_bits(), 0x0500);
    }

    #[test]
    fn every_field_value_round_trips() {
        for &wl in WordLength::ALL {
            for &ct in CrcType::ALL {
                for &ds in DrdySelect::ALL {
                    for &df in DrdyFormat::ALL {
                        for flags in 0..16u8 {
                            let m = Mode {
                                reg_crc_enable: flags & 1 != 0,
                                rx_crc_enable: flags & 2 != 0,
                                crc_type: ct,
                                reset: flags & 4 != 0,
                                word_length: wl,
                                timeout: flags & 8 != 0,
                                drdy_select: ds,
                                drdy_hiz: flags & 1 == 0,
                                drdy_format: df,
                            };
                            assert_eq!(Mode::from_bits(m.to_bits()), m);
                        }
                    }
                }
            }
        }
        for &osr in Osr::ALL {
            for &pm in PowerMode::ALL {
                for en in 0..8u8 {
                    let c = Clock {
                        channel_enable: [en & 1 != 0, en & 2 != 0],
                        turbo: en & 4 != 0,
                        osr,
                        power_mode: pm,
                    };
                    assert_eq!(Clock::from_bits(c.to_bits()), c);
                }
            }
        }
        for &g0 in PgaGain::ALL {
            for &g1 in PgaGain::ALL {
                let g = Gain { pga: [g0, g1] };
                assert_eq!(Gain::from_bits(g.to_bits()), g);
            }
        }
        for v in 0..=u16::MAX {
            match Status::from_bits(v) {
                Some(s) => assert_eq!(s.to_bits(), v),
                None => assert_ne!(v & STATUS_RESERVED_MASK, 0),
            }
        }
    }

    #[test]
    fn osr_ratios_and_data_rate() {
        let ratios: [u32; 8] = [128, 256, 512, 1024, 2048, 4096, 8192, 16384];
        for (&osr, &r) in Osr::ALL.iter().zip(ratios.iter()) {
            assert_eq!(osr.ratio(), r);
        }
        // The rig (docs/RIG.md): 5.12 MHz CLKIN with OSR 256 gives exactly 10 kSPS.
        assert_eq!(Osr::Osr256.data_rate_hz(5.12e6), 10_000.0);
        // Data sheet default: 8.192 MHz, OSR 1024 → 4 kSPS.
        assert_eq!(Osr::Osr1024.data_rate_hz(8.192e6), 4_000.0);
        for (i, &g) in PgaGain::ALL.iter().enumerate() {
            assert_eq!(g.factor(), 1 << i);
        }
    }

    #[test]
    fn register_addresses_are_unique_and_found() {
        for r in Register::ALL {
            assert_eq!(Register::from_addr(r.addr()), Some(r));
        }
        assert_eq!(Register::from_addr(0x05), None);
        assert_eq!(Register::Ch1GcalLsb.addr(), 0x12);
        assert_eq!(Register::RegmapCrc.addr(), 0x3E);
    }
}
