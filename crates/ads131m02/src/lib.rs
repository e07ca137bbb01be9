//! Platform-agnostic driver for the TI ADS131M02: 24-bit, 2-channel,
//! simultaneous-sampling ΔΣ ADC, on `embedded-hal` 1.0 alone (`no_std`, no
//! allocation). The README has the wiring and a usage example.
//!
//! Sources: ADS131M02 data sheet SBAS853A (TI, Jan 2020, rev. Apr 2021).
//! Where the M02's own page could not be read, the identical section of a
//! sibling ADS131M0x data sheet was read and is named in the module that
//! uses it; every constant cites its table.
//!
//! # Protocol, as modelled here
//! * SPI mode 1 (CPOL 0, CPHA 1), MSB first ([`SPI_MODE`]); one frame per
//!   CS-low period, so one [`SpiDevice::transaction`] per frame.
//! * The first DOUT word of a frame answers the command of the **previous**
//!   frame (Table 8-11). The driver remembers the command it sent last
//!   ([`Ads131m02::pending`]) and checks every frame's first word against
//!   it ([`Command::decode_response`]); a word that does not answer it is
//!   [`Error::UnexpectedResponse`], a RESET not answered by FF22h is
//!   [`Error::ResetReply`].
//! * Every frame's output CRC is checked ([`Error::Crc`]); every STATUS
//!   word is checked against the format the driver frames with and for the
//!   CRC_ERR / F_RESYNC / RESET flags. With [`Config::rx_crc`] the driver
//!   also appends the input CRC to every command, so a corrupted command is
//!   refused by the device (and reported by STATUS.CRC_ERR, except WREG,
//!   which the device executes regardless, §8.3.12 — the read-back in
//!   [`Ads131m02::configure`] catches that case).
//! * A register operation is two frames: the command, then NULL to collect
//!   its answer (the pattern of TI's reference code). [`Ads131m02::configure`]
//!   pipelines its three writes, each frame checking the previous answer.
//! * MODE changes (word length, CRC type, input CRC) are assumed to apply
//!   from the frame after the WREG that writes them; the data-sheet text
//!   that states this could not be read, so the behaviour is the driver's
//!   assumption — confirm it on hardware.
//!
//! # Pins
//! The driver owns only the SPI device ([`Ads131m02::new`] takes it,
//! [`Ads131m02::destroy`] gives it back). DRDY is the application's sample
//! interrupt, so it stays with the application, which calls
//! [`Ads131m02::read_frame`] from that interrupt, and hands its level to
//! [`Ads131m02::drain`] after any pause in reading. The SYNC/RESET pin must
//! be held high; the software RESET command does what a pin reset does and
//! is the only reset that is acknowledged (FF22h), so the driver uses it.
//! If the MCU restarts while the ADC runs with a non-default word length,
//! the RESET frame is mis-framed: pulse SYNC/RESET (application code) or
//! power-cycle before [`Ads131m02::reset`].
//!
//! # Sample path
//! [`Ads131m02::read_frame`] is one 12-byte (24-bit words) transfer, one
//! table-driven CRC and a few comparisons: no allocation, no formatting, no
//! panic, no fallible indexing (the crate denies `unwrap`, `expect`,
//! `panic!` and indexing).
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

mod command;
mod conversion;
mod error;
mod frame;
mod registers;

use embedded_hal::delay::DelayNs;
use embedded_hal::spi::SpiDevice;

pub use command::{Command, Response, MAX_READ_REGISTERS, RESET_REPLY};
pub use conversion::{lsb_volts, Conversion, Saturated, CODE_MAX, CODE_MIN, VREF_VOLTS};
pub use error::Error;
pub use frame::{crc16, FrameFormat, FRAME_WORDS, MAX_FRAME_BYTES, MAX_WORD_BYTES};
pub use registers::{
    Clock, CrcType, DrdyFormat, DrdySelect, Gain, Mode, Osr, PgaGain, PowerMode, Register, Status,
    WordLength,
};

/// The README's usage example, compiled as a doctest.
#[cfg(doctest)]
#[doc = include_str!("../README.md")]
struct ReadmeDoctest;

/// SPI mode of the ADS131M02: CPOL 0, CPHA 1, MSB first (SBAS853A §8.5.1
/// Interface; TI application note SBAA858 states mode 1 for the ADS131M0x
/// family).
pub const SPI_MODE: embedded_hal::spi::Mode = embedded_hal::spi::MODE_1;

/// t_REGACQ, register default acquisition time after a reset before the
/// next frame, in µs (§6.7 Switching Characteristics: 5 µs).
pub const T_REGACQ_US: u32 = 5;

/// Most frames [`Ads131m02::drain`] clocks: the two conversions the output
/// FIFO holds after a pause, one more completing during the drain, and one
/// spare. A frame at 10 MHz SCLK takes about 10 µs of the 100 µs period, so
/// a working device is drained in two or three.
pub const DRAIN_MAX_FRAMES: u8 = 4;

/// What [`Ads131m02::drain`] did.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Drained {
    /// NULL frames clocked (their data discarded).
    pub frames: u8,
    /// DRDY was high at the end: nothing left unread. `false` after
    /// [`DRAIN_MAX_FRAMES`] frames with DRDY still low (frames not reaching
    /// the device, or DRDY miswired).
    pub drdy_high: bool,
}

/// Which end of the ADC's range a code sits at (Table 8-10: the output
/// clips at 7FFFFFh and 800000h).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Rail {
    /// Negative full scale, 800000h.
    Low,
    /// Positive full scale, 7FFFFFh (7FFFh in 16-bit words).
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

/// Bytes of the longest frame the driver clocks: the answer to an RREG of
/// [`MAX_READ_REGISTERS`] registers (ack + registers + CRC) in 32-bit words.
const LONG_FRAME_BYTES: usize = (MAX_READ_REGISTERS + 2) * MAX_WORD_BYTES;

/// Writable bits of MODE, CLOCK and GAIN1 (Table 8-12), compared after
/// configuration.
const MODE_MASK: u16 = 0x3F1F;
const CLOCK_MASK: u16 = 0x033F;
const GAIN_MASK: u16 = 0x0077;

/// Everything [`Ads131m02::configure`] sets.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Config {
    /// CLOCK.CHn_EN: channel ADC enabled (a disabled channel reads 0).
    pub channel_enable: [bool; 2],
    /// GAIN1.PGAGAINn: full-scale range ±1.2 V/gain.
    pub gains: [PgaGain; 2],
    /// CLOCK.OSR: f_DATA = f_CLKIN/(2·OSR).
    pub osr: Osr,
    /// CLOCK.PWR.
    pub power_mode: PowerMode,
    /// MODE.WLENGTH.
    pub word_length: WordLength,
    /// MODE.CRC_TYPE (both directions).
    pub crc_type: CrcType,
    /// MODE.RX_CRC_EN: the device checks a CRC on every command.
    pub rx_crc: bool,
    /// MODE.DRDY_SEL.
    pub drdy_select: DrdySelect,
    /// MODE.DRDY_FMT.
    pub drdy_format: DrdyFormat,
    /// MODE.DRDY_HiZ.
    pub drdy_hiz: bool,
    /// MODE.TIMEOUT: SPI timeout (32768 t_CLKIN, §6.7) resets a stalled frame.
    pub spi_timeout: bool,
    /// Driver-side check, not a register: report [`Error::StuckData`] once
    /// both channel codes repeat bit for bit in this many consecutive
    /// frames (0 or 1: off). Off by default: a noise-free input (simulation,
    /// a beam at rest) legitimately repeats.
    pub stuck_limit: u16,
}

impl Default for Config {
    /// The rig's settings: both channels at gain 1, OSR 256 (10 kSPS from a
    /// 5.12 MHz CLKIN), high-resolution, 24-bit words, CCITT CRC checked in
    /// both directions, DRDY on the most lagging channel as a logic level.
    fn default() -> Config {
        Config {
            channel_enable: [true, true],
            gains: [PgaGain::G1; 2],
            osr: Osr::Osr256,
            power_mode: PowerMode::HighResolution,
            word_length: WordLength::Bits24,
            crc_type: CrcType::Ccitt,
            rx_crc: true,
            drdy_select: DrdySelect::MostLagging,
            drdy_format: DrdyFormat::LogicLow,
            drdy_hiz: false,
            spi_timeout: true,
            stuck_limit: 0,
        }
    }
}

impl Config {
    /// The MODE register value (RESET bit cleared).
    pub const fn mode(&self) -> Mode {
        Mode {
            reg_crc_enable: false,
            rx_crc_enable: self.rx_crc,
            crc_type: self.crc_type,
            reset: false,
            word_length: self.word_length,
            timeout: self.spi_timeout,
            drdy_select: self.drdy_select,
            drdy_hiz: self.drdy_hiz,
            drdy_format: self.drdy_format,
        }
    }

    /// The CLOCK register value.
    pub const fn clock(&self) -> Clock {
        Clock {
            channel_enable: self.channel_enable,
            turbo: false,
            osr: self.osr,
            power_mode: self.power_mode,
        }
    }

    /// The GAIN1 register value.
    pub const fn gain(&self) -> Gain {
        Gain { pga: self.gains }
    }

    /// The frame format in force once MODE is written.
    pub const fn format(&self) -> FrameFormat {
        FrameFormat {
            word_length: self.word_length,
            crc_type: self.crc_type,
            rx_crc: self.rx_crc,
        }
    }
}

impl Config {
    /// MODE, CLOCK and GAIN1 as [`Ads131m02::configure`] writes them,
    /// masked to their writable bits: what [`ReadBack::registers`] must
    /// give.
    pub const fn expected_registers(&self) -> [u16; 3] {
        [
            self.mode().to_bits() & MODE_MASK,
            self.clock().to_bits() & CLOCK_MASK,
            self.gain().to_bits() & GAIN_MASK,
        ]
    }
}

/// The ID and the configuration registers as [`Ads131m02::read_back`]
/// found them.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ReadBack {
    /// ID (22xxh for the two-channel part).
    pub id: u16,
    /// MODE as read.
    pub mode: u16,
    /// CLOCK as read.
    pub clock: u16,
    /// GAIN1 as read.
    pub gain: u16,
}

impl ReadBack {
    /// The ID names a two-channel ADS131M0x (22xxh, Table 8-12).
    pub const fn id_ok(&self) -> bool {
        self.id >> 8 == registers::ID_HIGH_BYTE as u16
    }

    /// MODE, CLOCK and GAIN1 masked to their writable bits (compare with
    /// [`Config::expected_registers`]).
    pub const fn registers(&self) -> [u16; 3] {
        [
            self.mode & MODE_MASK,
            self.clock & CLOCK_MASK,
            self.gain & GAIN_MASK,
        ]
    }

    /// The configuration registers hold `config` (under the masks).
    pub fn matches(&self, config: &Config) -> bool {
        self.registers() == config.expected_registers()
    }
}

/// One data frame: the STATUS word that answered NULL and both channels.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Frame {
    /// The STATUS word (checked).
    pub status: Status,
    /// Channel 0 and channel 1 conversions.
    pub channels: [Conversion; 2],
}

/// The ADS131M02 on an SPI device.
#[derive(Debug)]
pub struct Ads131m02<SPI> {
    spi: SPI,
    format: FrameFormat,
    /// The NULL command's frame in `format` (command word, its input CRC
    /// if enabled, zeros): every data read sends it, so it is encoded
    /// when the format changes ([`Ads131m02::set_format`]), not per frame.
    null_frame: [u8; MAX_FRAME_BYTES],
    /// The command the device latched at the end of the last frame: the
    /// next frame's first word answers it.
    pending: Command,
    gains: [PgaGain; 2],
    enabled: [bool; 2],
    /// MODE.RESET has been cleared by [`Ads131m02::configure`]: a STATUS
    /// with RESET set now means the device reset on its own.
    configured: bool,
    locked: bool,
    stuck_limit: u16,
    last_codes: [i32; 2],
    repeats: u16,
    /// A data frame may have been missed (it failed on the bus, or the
    /// application said so): the next [`Ads131m02::read_frame`] catches up.
    behind: bool,
}

impl<SPI: SpiDevice> Ads131m02<SPI> {
    /// Take the SPI device (mode [`SPI_MODE`]). No bus traffic; assumes the
    /// device is in its power-on state (24-bit words, CCITT, no input CRC,
    /// idle). Call [`Ads131m02::reset`] next.
    pub fn new(spi: SPI) -> Self {
        Ads131m02 {
            spi,
            format: FrameFormat::RESET,
            null_frame: null_frame(FrameFormat::RESET),
            pending: Command::Null,
            gains: [PgaGain::G1; 2],
            enabled: [true; 2],
            configured: false,
            locked: false,
            stuck_limit: 0,
            last_codes: [0; 2],
            repeats: 0,
            behind: false,
        }
    }

    /// Give the SPI device back.
    pub fn destroy(self) -> SPI {
        self.spi
    }

    /// The frame format the driver currently uses.
    pub const fn format(&self) -> FrameFormat {
        self.format
    }

    /// The command whose answer the next frame carries.
    pub const fn pending(&self) -> Command {
        self.pending
    }

    /// Software reset: RESET, wait t_REGACQ, check the FF22h reply, then
    /// read the ID register and check it is a two-channel part (22xxh).
    /// Returns the ID. The answer to whatever preceded the RESET frame, and
    /// that frame's CRC, are not checked: the device state is unknown.
    pub fn reset(&mut self, delay: &mut impl DelayNs) -> Result<u16, Error<SPI::Error>> {
        // The RESET frame must be complete to be latched: as long as the
        // answer to a multi-register read still owed, if there is one.
        let words = FRAME_WORDS.max(self.pending.response_register_words() + 2);
        let mut buf = [0u8; LONG_FRAME_BYTES];
        let tx = buf
            .get_mut(..words * self.format.word_bytes())
            .ok_or(Error::InvalidArgument)?;
        self.load_command(tx, Command::Reset, &[]);
        self.spi.transfer_in_place(tx)?;
        self.pending = Command::Reset;
        // RESET restores every register (Table 8-12), so the framing too.
        self.set_format(FrameFormat::RESET);
        self.gains = [PgaGain::G1; 2];
        self.enabled = [true; 2];
        self.configured = false;
        self.locked = false;
        self.repeats = 0;
        self.behind = false;
        delay.delay_us(T_REGACQ_US);
        self.command(Command::Null, &[])?;
        let id = self.read_register(Register::Id)?;
        if id >> 8 != u16::from(registers::ID_HIGH_BYTE) {
            return Err(Error::IdMismatch(id));
        }
        Ok(id)
    }

    /// Write CLOCK, GAIN1 and MODE (clearing MODE.RESET) in three pipelined
    /// frames, then read the three back and compare. From the frame after
    /// the MODE write on, the driver frames with the new word length, CRC
    /// type and input CRC.
    pub fn configure(&mut self, config: &Config) -> Result<(), Error<SPI::Error>> {
        let clock = config.clock().to_bits();
        let gain = config.gain().to_bits();
        let mode = config.mode().to_bits();
        self.command(Command::write(Register::Clock), &[clock])?;
        self.command(Command::write(Register::Gain), &[gain])?;
        self.command(Command::write(Register::Mode), &[mode])?;
        self.set_format(config.format());
        self.configured = true;
        self.command(Command::Null, &[])?;
        for (register, wrote, mask) in [
            (Register::Clock, clock, CLOCK_MASK),
            (Register::Gain, gain, GAIN_MASK),
            (Register::Mode, mode, MODE_MASK),
        ] {
            let read = self.read_register(register)?;
            if read & mask != wrote & mask {
                return Err(Error::ConfigMismatch {
                    register,
                    wrote: wrote & mask,
                    read: read & mask,
                });
            }
        }
        self.gains = config.gains;
        self.enabled = config.channel_enable;
        self.stuck_limit = config.stuck_limit;
        self.repeats = 0;
        Ok(())
    }

    /// The sample path: one NULL frame. Returns both conversions, or an
    /// error if the CRC, the STATUS word, the DRDY bits (no new data) or
    /// the optional stuck-data check fail. Saturation is not an error here:
    /// it is carried by each [`Conversion`]. If an earlier register
    /// operation failed after its command was latched, this frame carries
    /// that command's (checked) answer instead of STATUS and no sample:
    /// [`Error::OwedResponse`]; the next frame is normal again.
    /// After [`Error::UnexpectedReset`] or a failed [`Ads131m02::configure`],
    /// call [`Ads131m02::reset`] and [`Ads131m02::configure`] again.
    ///
    /// Catching up: the device queues unread conversions two deep and a
    /// frame outputs the oldest ([`Ads131m02::drain`]). After a data frame
    /// failed on the bus ([`Error::Spi`]: its conversion may still be
    /// queued) or [`Ads131m02::note_pause`], the next call reads one more
    /// frame and returns the newer conversion if that frame has one
    /// (STATUS.DRDY set), the first otherwise, so one lost frame does not
    /// leave every later read one conversion behind. That costs one extra
    /// frame, once.
    #[inline]
    pub fn read_frame(&mut self) -> Result<Frame, Error<SPI::Error>> {
        if self.behind {
            return self.catch_up();
        }
        self.read_one()
    }

    /// [`Ads131m02::read_frame`] when a frame may have been missed.
    #[cold]
    #[inline(never)]
    fn catch_up(&mut self) -> Result<Frame, Error<SPI::Error>> {
        match self.read_one() {
            // Still nothing through: still behind.
            Err(e @ Error::Spi(_)) => Err(e),
            Err(e) => {
                self.behind = false;
                Err(e)
            }
            Ok(frame) => {
                self.behind = false;
                match self.read_one() {
                    Ok(newer) => Ok(newer),
                    // Nothing was queued behind it (or the extra frame
                    // failed: it is not this sample's): the first stands.
                    Err(_) => Ok(frame),
                }
            }
        }
    }

    /// The application missed at least one DRDY (e.g. its sample interrupt
    /// came two periods late): the next [`Ads131m02::read_frame`] catches
    /// up (see there).
    pub fn note_pause(&mut self) {
        self.behind = true;
    }

    /// One data frame, checked.
    #[inline(always)]
    fn read_one(&mut self) -> Result<Frame, Error<SPI::Error>> {
        let answered = self.pending;
        let (response, codes) = match self.command(Command::Null, &[]) {
            Ok(r) => r,
            Err(e) => {
                if matches!(e, Error::Spi(_)) {
                    self.behind = true;
                }
                return Err(e);
            }
        };
        let Response::Status(status) = response else {
            return Err(Error::OwedResponse { command: answered });
        };
        let fresh = self
            .enabled
            .iter()
            .zip(status.drdy.iter())
            .all(|(&en, &ready)| !en || ready);
        if !fresh {
            return Err(Error::NoNewData(status));
        }
        if codes == self.last_codes {
            self.repeats = self.repeats.saturating_add(1);
        } else {
            self.repeats = 0;
            self.last_codes = codes;
        }
        let frames = self.repeats.saturating_add(1);
        if self.stuck_limit > 1 && frames >= self.stuck_limit {
            return Err(Error::StuckData { frames });
        }
        let wl = self.format.word_length;
        let [g0, g1] = self.gains;
        let [c0, c1] = codes;
        Ok(Frame {
            status,
            channels: [Conversion::new(c0, g0, wl), Conversion::new(c1, g1, wl)],
        })
    }

    /// Empty the output FIFO after a pause in reading: clock NULL frames
    /// (data discarded) while `drdy_low()` — the application's DRDY pin —
    /// says a conversion is unread, at most [`DRAIN_MAX_FRAMES`].
    ///
    /// The device queues conversions it was not asked for in a two-deep
    /// FIFO and a frame outputs the oldest (the section "Collecting Data
    /// for the First Time or After a Pause in Data Collection" of the
    /// ADS131M0x data sheets, whose text could not be read for this crate:
    /// the behaviour is as that section is summarised by drivers that cite
    /// it; confirm on hardware). After any pause of two or more conversion periods (reset
    /// and configuration, start-up work with the sample interrupt off, a
    /// re-initialisation) a host that reads one frame per DRDY falling edge
    /// would therefore stay one conversion behind for good. Call this after
    /// every pause, then arm the DRDY interrupt: from the next falling edge
    /// on, each frame carries the conversion that edge announced.
    ///
    /// Frame errors (CRC, STATUS) are returned: the frame was clocked, but
    /// the device or the bus needs attention; [`Error::NoNewData`] cannot
    /// occur (the data are not checked here).
    pub fn drain(
        &mut self,
        mut drdy_low: impl FnMut() -> bool,
    ) -> Result<Drained, Error<SPI::Error>> {
        let mut frames = 0u8;
        while drdy_low() {
            if frames >= DRAIN_MAX_FRAMES {
                return Ok(Drained {
                    frames,
                    drdy_high: false,
                });
            }
            self.command(Command::Null, &[])?;
            frames += 1;
        }
        self.repeats = 0;
        self.behind = false;
        Ok(Drained {
            frames,
            drdy_high: true,
        })
    }

    /// Read ID, STATUS, MODE, CLOCK and GAIN1 with one multi-register RREG
    /// ([`Ads131m02::read_registers`]): two frames, the first a normal data
    /// frame, the second the answer, which carries no ADC data. For a
    /// check while converting (the self-test): between two samples, right
    /// after a data frame was read, so that no conversion completes in
    /// between (one that did would be output by the RREG frame and missed
    /// by the next read).
    pub fn read_back(&mut self) -> Result<ReadBack, Error<SPI::Error>> {
        let mut r = [0u16; 5];
        self.read_registers(Register::Id, &mut r)?;
        let [id, _status, mode, clock, gain] = r;
        Ok(ReadBack {
            id,
            mode,
            clock,
            gain,
        })
    }

    /// Read one register (RREG, then NULL for the answer).
    pub fn read_register(&mut self, register: Register) -> Result<u16, Error<SPI::Error>> {
        self.command(Command::read(register), &[])?;
        match self.command(Command::Null, &[])? {
            (Response::Register(v), _) => Ok(v),
            (other, _) => Err(Error::UnexpectedResponse {
                command: Command::read(register),
                response: other.word(),
            }),
        }
    }

    /// Read `out.len()` consecutive registers from `start` with one RREG
    /// (1..=[`MAX_READ_REGISTERS`]); the answer frame carries no ADC data.
    pub fn read_registers(
        &mut self,
        start: Register,
        out: &mut [u16],
    ) -> Result<(), Error<SPI::Error>> {
        let count = u8::try_from(out.len()).map_err(|_| Error::InvalidArgument)?;
        if count == 0 || out.len() > MAX_READ_REGISTERS {
            return Err(Error::InvalidArgument);
        }
        if count == 1 {
            let v = self.read_register(start)?;
            out.iter_mut().for_each(|o| *o = v);
            return Ok(());
        }
        let cmd = Command::ReadRegisters {
            start: start.addr(),
            count,
        };
        self.command(cmd, &[])?;
        let mut buf = [0u8; LONG_FRAME_BYTES];
        let n = (out.len() + 2) * self.format.word_bytes();
        let rx = buf.get_mut(..n).ok_or(Error::InvalidArgument)?;
        self.transact(rx, Command::Null, &[])?;
        for (i, o) in out.iter_mut().enumerate() {
            *o = self.format.word16(rx, 1 + i);
        }
        Ok(())
    }

    /// Write one register (WREG, then NULL for the acknowledgement). Keeps
    /// the driver's view of MODE/CLOCK/GAIN1 in step; ID, STATUS and
    /// REGMAP_CRC are read-only ([`Error::InvalidArgument`]).
    pub fn write_register(
        &mut self,
        register: Register,
        value: u16,
    ) -> Result<(), Error<SPI::Error>> {
        if !register.is_writable() {
            return Err(Error::InvalidArgument);
        }
        self.command(Command::write(register), &[value])?;
        match register {
            Register::Mode => {
                let m = Mode::from_bits(value);
                self.set_format(FrameFormat {
                    word_length: m.word_length,
                    crc_type: m.crc_type,
                    rx_crc: m.rx_crc_enable,
                });
                self.configured = !m.reset;
            }
            Register::Clock => self.enabled = Clock::from_bits(value).channel_enable,
            Register::Gain => self.gains = Gain::from_bits(value).pga,
            _ => {}
        }
        self.command(Command::Null, &[])?;
        Ok(())
    }

    /// Read and check the STATUS register.
    pub fn status(&mut self) -> Result<Status, Error<SPI::Error>> {
        let v = self.read_register(Register::Status)?;
        Status::from_bits(v).ok_or(Error::UnexpectedResponse {
            command: Command::read(Register::Status),
            response: v,
        })
    }

    /// STANDBY: stop conversions (acknowledged by 0022h).
    pub fn standby(&mut self) -> Result<(), Error<SPI::Error>> {
        self.acknowledged(Command::Standby)
    }

    /// WAKEUP: resume conversions (acknowledged by 0033h).
    pub fn wakeup(&mut self) -> Result<(), Error<SPI::Error>> {
        self.acknowledged(Command::Wakeup)
    }

    /// LOCK the interface: only NULL, UNLOCK and RREG stay valid.
    pub fn lock(&mut self) -> Result<(), Error<SPI::Error>> {
        self.command(Command::Lock, &[])?;
        self.locked = true;
        self.command(Command::Null, &[])?;
        Ok(())
    }

    /// UNLOCK the interface.
    pub fn unlock(&mut self) -> Result<(), Error<SPI::Error>> {
        self.command(Command::Unlock, &[])?;
        self.locked = false;
        self.command(Command::Null, &[])?;
        Ok(())
    }

    fn acknowledged(&mut self, cmd: Command) -> Result<(), Error<SPI::Error>> {
        self.command(cmd, &[])?;
        self.command(Command::Null, &[])?;
        Ok(())
    }

    /// One frame sending `cmd` (+ WREG `data`); returns the checked answer
    /// to the previous command and the two channel codes (zeros if the
    /// answer was a multi-register read, which carries no ADC data).
    fn command(
        &mut self,
        cmd: Command,
        data: &[u16],
    ) -> Result<(Response, [i32; 2]), Error<SPI::Error>> {
        let registers = self.pending.response_register_words();
        if registers > 0 {
            // The previous command was a multi-register RREG whose answer
            // was never collected: clock the long frame and drop the data.
            let mut buf = [0u8; LONG_FRAME_BYTES];
            let n = (registers + 2) * self.format.word_bytes();
            let rx = buf.get_mut(..n).ok_or(Error::InvalidArgument)?;
            return Ok((self.transact(rx, cmd, data)?, [0; 2]));
        }
        let n = self.format.frame_bytes();
        // A data read (NULL) sends the frame encoded in advance.
        let null = cmd == Command::Null && data.is_empty();
        let mut buf = if null {
            self.null_frame
        } else {
            [0u8; MAX_FRAME_BYTES]
        };
        let rx = buf.get_mut(..n).ok_or(Error::InvalidArgument)?;
        let response = if null {
            self.exchange(rx, cmd)?
        } else {
            self.transact(rx, cmd, data)?
        };
        Ok((response, [self.format.data(rx, 1), self.format.data(rx, 2)]))
    }

    /// The framing from now on (and the NULL frame encoded in it).
    fn set_format(&mut self, format: FrameFormat) {
        self.format = format;
        self.null_frame = null_frame(format);
    }

    /// Put `cmd`, its data words and (if enabled) the input CRC in `tx`.
    fn load_command(&self, tx: &mut [u8], cmd: Command, data: &[u16]) {
        load_command(self.format, tx, cmd, data);
    }

    /// Clock one frame in `buf` (its length is the frame length), check
    /// the output CRC and type the first word by the pending command.
    fn transact(
        &mut self,
        buf: &mut [u8],
        cmd: Command,
        data: &[u16],
    ) -> Result<Response, Error<SPI::Error>> {
        self.load_command(buf, cmd, data);
        self.exchange(buf, cmd)
    }

    /// [`Ads131m02::transact`] with `cmd` already in `buf`.
    fn exchange(&mut self, buf: &mut [u8], cmd: Command) -> Result<Response, Error<SPI::Error>> {
        self.spi.transfer_in_place(buf)?;
        // The frame completed, so the device latched `cmd`.
        let answered = core::mem::replace(&mut self.pending, cmd);
        let f = self.format;
        let crc_index = (buf.len() / f.word_bytes()).saturating_sub(1);
        let computed = f.crc(buf.get(..crc_index * f.word_bytes()).unwrap_or(&[]));
        let received = f.word16(buf, crc_index);
        if computed != received {
            return Err(Error::Crc { received, computed });
        }
        let word = f.word16(buf, 0);
        let response = answered.decode_response(word).map_err(|w| match answered {
            Command::Reset => Error::ResetReply(w),
            command => Error::UnexpectedResponse {
                command,
                response: w,
            },
        })?;
        if let Response::Status(s) = response {
            self.check_status(s)?;
        }
        Ok(response)
    }

    fn check_status(&self, s: Status) -> Result<(), Error<SPI::Error>> {
        if s.crc_error {
            Err(Error::InputCrc(s))
        } else if s.reset && self.configured {
            Err(Error::UnexpectedReset(s))
        } else if s.word_length != self.format.word_length
            || s.crc_type != self.format.crc_type
            || s.lock != self.locked
        {
            Err(Error::StatusMismatch(s))
        } else if s.resync_fault {
            Err(Error::ResyncFault(s))
        } else {
            Ok(())
        }
    }
}

/// Put `cmd`, its data words and (if enabled) the input CRC in `tx`, in
/// `format`.
fn load_command(format: FrameFormat, tx: &mut [u8], cmd: Command, data: &[u16]) {
    tx.fill(0);
    format.put_word16(tx, 0, cmd.word());
    for (i, &d) in data.iter().enumerate() {
        format.put_word16(tx, 1 + i, d);
    }
    if format.rx_crc {
        let covered = (1 + data.len()) * format.word_bytes();
        let crc = format.crc(tx.get(..covered).unwrap_or(&[]));
        format.put_word16(tx, 1 + data.len(), crc);
    }
}

/// The NULL command's frame in `format` (the bytes of a data read).
fn null_frame(format: FrameFormat) -> [u8; MAX_FRAME_BYTES] {
    let mut frame = [0u8; MAX_FRAME_BYTES];
    if let Some(tx) = frame.get_mut(..format.frame_bytes()) {
        load_command(format, tx, Command::Null, &[]);
    }
    frame
}
