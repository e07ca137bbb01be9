//! Behavioural model of the TI ADS131M02 on its SPI interface.
//!
//! # What it does, as the chip does (SBAS853A)
//! * Frames: the first DOUT word answers the command of the previous frame
//!   (Table 8-11): STATUS for NULL and for anything invalid, FF22h after
//!   RESET, the echo of STANDBY/WAKEUP/LOCK/UNLOCK, the register for a
//!   single RREG, `111a aaaa annn nnnn` + the registers (no ADC data) for a
//!   multi-register RREG, `010a aaaa annn nnnn` for WREG. Then one word per
//!   channel and the output CRC (§8.3.12, never disabled).
//! * Register file with the Table 8-12 reset values; ID 22xxh (revision
//!   byte settable); STATUS built from MODE and the live flags; read-only
//!   registers ignore writes. MODE's word length, CRC type and input CRC
//!   apply from the frame after the WREG that sets them.
//! * Input CRC (MODE.RX_CRC_EN): a command with a wrong CRC is not executed
//!   except WREG, which always executes; CRC_ERR is set and the next answer
//!   is STATUS; CRC_ERR clears when STATUS is output (§8.3.12).
//! * A frame shorter than the command needs is not latched; an incomplete
//!   RESET is answered by 0011h (the RESET command section).
//! * LOCK leaves only NULL, UNLOCK and RREG valid. STANDBY stops
//!   conversions until WAKEUP.
//! * [`Ads131m02Model::convert`] is one DRDY period: each enabled channel's
//!   input voltage is quantised ideally (Table 8-10): code =
//!   round(V·gain/1.2 V·2²³), clipped to 800000h…7FFFFFh.
//! * Output buffer: conversions queue in a two-deep FIFO (`FIFO_DEPTH`;
//!   the ADS131M0x data sheets' "Collecting Data for the First Time or
//!   After a Pause in Data Collection"). A data frame outputs the **oldest**
//!   queued conversion and removes it; a conversion that finds the FIFO
//!   full discards the oldest entry. STATUS.DRDYn and the DRDY pin
//!   ([`Ads131m02Model::drdy_low`]) show whether anything is queued. So a
//!   host that lets two conversions pile up (a pause) and then reads one
//!   frame per DRDY stays one conversion behind until it drains the FIFO
//!   (reads until DRDY is high). Which entry a full FIFO discards could not
//!   be read in the data sheet; either choice leaves the one-frame-per-DRDY
//!   reader one conversion behind. With the FIFO empty a frame repeats the
//!   last data with the DRDY bits clear. Sources: the data sheets point to
//!   that section for reading "after a pause from when the ADCs were last
//!   enabled" and say a low DRDY means the latest data are unread (the
//!   ADS131M0x/ADS131B0x DRDY sections); the section's own text could not
//!   be read here, so the depth and the oldest-first output are from the
//!   pre-flash review that asked for this model and from third-party
//!   drivers that read two frames after a pause citing it — check on the
//!   chip.
//!
//! # What it does not model
//! The digital filter itself: it converts the voltages it is given. The
//! filter's averaging of a moving input (sinc³ over the last three
//! periods: group delay and droop) is simulated by the rig on the analog
//! side ([`crate::rig::timing`], on in [`crate::bench`]), which hands this
//! model the filtered voltages. Not modelled at all: the filter's settling
//! after a reset, a channel enable or a gain change, phase calibration,
//! offset/gain calibration registers (stored, not applied), global chop,
//! current detection, the register-map CRC, noise and offset, the DRDY pin's edges and pulses (its level is
//! [`Ads131m02Model::drdy_low`]), a frame cut short (it still removes the
//! conversion it started to output), the SPI timeout
//! and SYNC/RESET pin timing, turbo mode. The framing helpers (word packing,
//! CRC) are the driver's own [`FrameFormat`] methods, which the driver tests
//! check byte for byte against the data sheet; the behaviour above is
//! independent of the driver's state machine.

use embedded_hal::spi::{ErrorType, Operation, SpiDevice};

use ads131m02::{
    Command, FrameFormat, Gain, Mode, Rail, Register, Status, CODE_MAX, CODE_MIN, MAX_WORD_BYTES,
    RESET_REPLY, VREF_VOLTS,
};

use super::{clock_operations, ModelBusError};

/// Registers the model answers one RREG with: the 6-bit address space. An
/// RREG of more (the count field allows 128) gets a frame cut at this
/// length (not modelled further).
const MAX_REGISTERS: usize = 64;
/// Bytes of the longest frame the model answers (ack, 64 registers, CRC).
const BUF_BYTES: usize = (MAX_REGISTERS + 2) * MAX_WORD_BYTES;
/// Depth of the conversion-data FIFO (see the module docs).
pub const FIFO_DEPTH: usize = 2;
/// Writable bits of MODE, CLOCK, GAIN1 (Table 8-12).
const MODE_MASK: u16 = 0x3F1F;
const CLOCK_MASK: u16 = 0x033F;
const GAIN_MASK: u16 = 0x0077;

/// What the next frame's first word(s) will be.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Answer {
    Status,
    Word(u16),
    Registers { start: u8, count: u8 },
}

/// Counters for tests and the simulated rig.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ModelStats {
    /// Frames clocked (transactions without an injected bus fault).
    pub frames: u64,
    /// Conversions completed.
    pub conversions: u64,
    /// Commands refused for a bad input CRC.
    pub input_crc_errors: u64,
}

/// The ADS131M02 model. See the module docs.
#[derive(Clone, Debug)]
pub struct Ads131m02Model {
    /// The ID register (kept across resets).
    id: u16,
    regs: [u16; 64],
    inputs_volts: [f64; 2],
    /// The latest conversion's codes.
    codes: [i32; 2],
    /// Queued conversions, oldest first: codes and the channels that
    /// were enabled (their DRDYn bits).
    fifo: [([i32; 2], [bool; 2]); FIFO_DEPTH],
    queued: usize,
    /// The data the last data frame output (repeated while the FIFO is
    /// empty).
    output: [i32; 2],
    answer: Answer,
    crc_error: bool,
    standby: bool,
    locked: bool,
    // Faults.
    bad_crc_frames: u32,
    bad_crc_period: u32,
    stuck: bool,
    saturate: Option<Rail>,
    dropped_conversions: u32,
    /// Conversions per [`Ads131m02Model::convert`] call: numerator,
    /// denominator (≤ 1), and the phase accumulator.
    data_rate: (u32, u32),
    rate_phase: u32,
    /// A register whose read-back has bits flipped: address, XOR mask.
    register_fault: Option<(u8, u16)>,
    bus_errors: u32,
    stats: ModelStats,
}

impl Default for Ads131m02Model {
    fn default() -> Self {
        Self::new()
    }
}

/// Ideal conversion of `volts` at PGA `gain` (Table 8-10): round to the
/// nearest code, clip at full scale. NaN converts as 0 V.
pub fn quantize(volts: f64, gain: u32) -> i32 {
    let x = libm::round(volts * f64::from(gain) / VREF_VOLTS * 8_388_608.0);
    // `as` saturates (±∞) and maps NaN to 0.
    (x as i64).clamp(i64::from(CODE_MIN), i64::from(CODE_MAX)) as i32
}

impl Ads131m02Model {
    /// A device just powered on: registers at reset values, inputs 0 V, no
    /// conversion yet, the first frame answers with STATUS.
    pub fn new() -> Self {
        let mut m = Ads131m02Model {
            id: Register::Id.reset_value(),
            regs: [0; 64],
            inputs_volts: [0.0; 2],
            codes: [0; 2],
            fifo: [([0; 2], [false; 2]); FIFO_DEPTH],
            queued: 0,
            output: [0; 2],
            answer: Answer::Status,
            crc_error: false,
            standby: false,
            locked: false,
            bad_crc_frames: 0,
            bad_crc_period: 0,
            stuck: false,
            saturate: None,
            dropped_conversions: 0,
            data_rate: (1, 1),
            rate_phase: 0,
            register_fault: None,
            bus_errors: 0,
            stats: ModelStats::default(),
        };
        m.reset_registers();
        m
    }

    fn reset_registers(&mut self) {
        self.regs = [0; 64];
        for r in Register::ALL {
            if let Some(slot) = self.regs.get_mut(usize::from(r.addr())) {
                *slot = r.reset_value();
            }
        }
        self.codes = [0; 2];
        self.queued = 0;
        self.output = [0; 2];
        self.crc_error = false;
        self.standby = false;
        self.locked = false;
    }

    /// Set the ID register's revision byte (low byte of 22xxh).
    #[cfg(test)]
    pub(crate) fn set_revision(&mut self, revision: u8) {
        self.id = (self.id & 0xFF00) | u16::from(revision);
    }

    /// Replace the whole ID register (to model another part).
    pub fn set_id(&mut self, id: u16) {
        self.id = id;
    }

    /// Analog input voltages (AINnP − AINnN) of channels 0 and 1, volts.
    pub fn set_inputs(&mut self, volts: [f64; 2]) {
        self.inputs_volts = volts;
    }

    /// The input voltages last set.
    pub fn inputs(&self) -> [f64; 2] {
        self.inputs_volts
    }

    /// One DRDY period: quantise the inputs and queue the conversion in the
    /// output FIFO (discarding the oldest entry if it is full). Nothing
    /// happens in standby or while a dropped conversion is injected.
    pub fn convert(&mut self) {
        if self.standby {
            return;
        }
        if self.dropped_conversions > 0 {
            self.dropped_conversions -= 1;
            return;
        }
        let (num, den) = self.data_rate;
        if num < den {
            self.rate_phase = self.rate_phase.saturating_add(num);
            if self.rate_phase < den {
                return;
            }
            self.rate_phase -= den;
        }
        let clock = self.reg(Register::Clock);
        let gains = Gain::from_bits(self.reg(Register::Gain)).pga;
        let mut ready = [false; 2];
        for (ch, gain) in gains.into_iter().enumerate() {
            let enabled = clock & (1 << (8 + ch)) != 0;
            let g = gain.factor();
            let volts = self.inputs_volts.get(ch).copied().unwrap_or(0.0);
            let code = match (enabled, self.stuck, self.saturate) {
                (false, _, _) => 0,
                (true, true, _) => self.codes.get(ch).copied().unwrap_or(0),
                (true, false, Some(Rail::High)) => CODE_MAX,
                (true, false, Some(Rail::Low)) => CODE_MIN,
                (true, false, None) => quantize(volts, g),
            };
            if let Some(c) = self.codes.get_mut(ch) {
                *c = code;
            }
            if let Some(d) = ready.get_mut(ch) {
                *d = enabled;
            }
        }
        if self.queued == FIFO_DEPTH {
            self.fifo.rotate_left(1);
            self.queued -= 1;
        }
        if let Some(slot) = self.fifo.get_mut(self.queued) {
            *slot = (self.codes, ready);
            self.queued += 1;
        }
        self.stats.conversions += 1;
    }

    /// The DRDY pin is low (DRDY_FMT = 0, a logic level): at least one
    /// conversion is queued and unread.
    pub fn drdy_low(&self) -> bool {
        self.queued > 0
    }

    /// Conversions queued in the output FIFO (0, 1 or 2).
    pub fn queued(&self) -> usize {
        self.queued
    }

    /// STATUS.DRDYn: the oldest queued conversion's channels.
    fn drdy(&self) -> [bool; 2] {
        match self.fifo.first() {
            Some((_, ready)) if self.queued > 0 => *ready,
            _ => [false; 2],
        }
    }

    /// Output the oldest queued conversion (removing it), or repeat the
    /// last output if none is queued.
    fn pop(&mut self) -> [i32; 2] {
        if self.queued > 0 {
            if let Some((codes, _)) = self.fifo.first() {
                self.output = *codes;
            }
            self.fifo.rotate_left(1);
            self.queued -= 1;
        }
        self.output
    }

    /// The codes of the latest conversion (24-bit scale), queued or read.
    pub fn codes(&self) -> [i32; 2] {
        self.codes
    }

    /// The register at `reg` (STATUS as it would be output now).
    pub fn register(&self, reg: Register) -> u16 {
        self.read_addr(reg.addr())
    }

    /// The frame format MODE currently sets.
    pub fn format(&self) -> FrameFormat {
        let mode = Mode::from_bits(self.reg(Register::Mode));
        FrameFormat {
            word_length: mode.word_length,
            crc_type: mode.crc_type,
            rx_crc: mode.rx_crc_enable,
        }
    }

    /// Whether STANDBY is in force.
    pub fn is_standby(&self) -> bool {
        self.standby
    }

    /// Counters.
    pub fn stats(&self) -> ModelStats {
        self.stats
    }

    /// Fault: corrupt one bit of the next `frames` frames after their CRC
    /// was computed (a transmission error).
    pub fn inject_bad_crc(&mut self, frames: u32) {
        self.bad_crc_frames = frames;
    }

    /// Fault: corrupt every `period`-th frame (0: off).
    pub fn set_bad_crc_period(&mut self, period: u32) {
        self.bad_crc_period = period;
    }

    /// Fault: conversions repeat the last code (a stuck front end; DRDY
    /// still toggles).
    pub fn set_stuck(&mut self, stuck: bool) {
        self.stuck = stuck;
    }

    /// Fault: conversions at the full-scale code of `rail`.
    pub fn set_saturation(&mut self, rail: Option<Rail>) {
        self.saturate = rail;
    }

    /// Fault: the next `n` conversions do not happen (dropped DRDY).
    pub fn drop_conversions(&mut self, n: u32) {
        self.dropped_conversions = n;
    }

    /// Fault: the converter runs at `numerator/denominator` of the rate it
    /// is clocked for (a slow or wrong CLKIN, a wrong OSR): of every
    /// `denominator` calls of [`Ads131m02Model::convert`] only `numerator`
    /// convert, evenly spread; the others leave DRDY as it was. 0: no
    /// conversions at all (DRDY missing); a ratio of 1 or more (or a zero
    /// denominator): the normal rate.
    pub(crate) fn set_data_rate(&mut self, numerator: u32, denominator: u32) {
        self.data_rate = if denominator == 0 || numerator >= denominator {
            (1, 1)
        } else {
            (numerator, denominator)
        };
        self.rate_phase = 0;
    }

    /// Fault: register `register` reads back with the bits of `xor`
    /// flipped (a register that does not hold what was written, or a
    /// corrupted read); writes and the conversions are unaffected. `None`:
    /// off.
    pub(crate) fn set_register_fault(&mut self, fault: Option<(Register, u16)>) {
        self.register_fault = fault.map(|(r, x)| (r.addr(), x));
    }

    /// Fault: the next `n` transactions fail with [`ModelBusError`] and
    /// have no effect.
    pub fn inject_bus_errors(&mut self, n: u32) {
        self.bus_errors = n;
    }

    /// Fault: a brown-out — the device resets without a command (registers
    /// to defaults, STATUS.RESET set, next answer STATUS).
    pub fn brown_out(&mut self) {
        self.reset_registers();
        self.answer = Answer::Status;
    }

    fn reg(&self, reg: Register) -> u16 {
        self.regs.get(usize::from(reg.addr())).copied().unwrap_or(0)
    }

    fn status(&self) -> Status {
        let f = self.format();
        Status {
            lock: self.locked,
            resync_fault: false,
            reg_map_changed: false,
            crc_error: self.crc_error,
            crc_type: f.crc_type,
            reset: self.reg(Register::Mode) & (1 << 10) != 0,
            word_length: f.word_length,
            drdy: self.drdy(),
        }
    }

    fn read_addr(&self, addr: u8) -> u16 {
        let value = if addr == Register::Status.addr() {
            self.status().to_bits()
        } else if addr == Register::Id.addr() {
            self.id
        } else {
            self.regs.get(usize::from(addr)).copied().unwrap_or(0)
        };
        match self.register_fault {
            Some((a, xor)) if a == addr => value ^ xor,
            _ => value,
        }
    }

    fn write_addr(&mut self, addr: u8, value: u16) {
        let Some(reg) = Register::from_addr(addr) else {
            return;
        };
        let value = match reg {
            _ if !reg.is_writable() => return,
            Register::Mode => value & MODE_MASK,
            Register::Clock => value & CLOCK_MASK,
            Register::Gain => value & GAIN_MASK,
            _ => value,
        };
        if let Some(slot) = self.regs.get_mut(usize::from(addr)) {
            *slot = value;
        }
    }

    /// Build DOUT for a frame starting now; returns its length in bytes.
    fn begin_frame(&mut self, f: FrameFormat, out: &mut [u8]) -> usize {
        let wb = f.word_bytes();
        out.fill(0);
        let words = match self.answer {
            Answer::Registers { start, count } => {
                let n = usize::from(count).min(MAX_REGISTERS);
                let ack = 0xE000 | (u16::from(start & 0x3F) << 7) | u16::from(count - 1);
                f.put_word16(out, 0, ack);
                for i in 0..n {
                    let v = self.read_addr(start.wrapping_add(i as u8));
                    f.put_word16(out, 1 + i, v);
                }
                n + 2
            }
            answer => {
                let first = match answer {
                    Answer::Word(w) => w,
                    _ => {
                        let s = self.status().to_bits();
                        // CRC_ERR clears once STATUS is output.
                        self.crc_error = false;
                        s
                    }
                };
                f.put_word16(out, 0, first);
                // The data are read: the oldest queued conversion leaves
                // the FIFO.
                let [c0, c1] = self.pop();
                f.put_data(out, 1, c0);
                f.put_data(out, 2, c1);
                4
            }
        };
        let len = words * wb;
        let crc_at = (words - 1) * wb;
        let crc = f.crc(out.get(..crc_at).unwrap_or(&[]));
        f.put_word16(out, words - 1, crc);
        let periodic = self.bad_crc_period > 0
            && (self.stats.frames + 1) % u64::from(self.bad_crc_period) == 0;
        if self.bad_crc_frames > 0 || periodic {
            self.bad_crc_frames = self.bad_crc_frames.saturating_sub(1);
            if let Some(b) = out.get_mut(crc_at - 1) {
                *b ^= 0x01;
            }
        }
        len
    }

    /// Latch the command of a frame whose DIN was `din` (clocked length).
    fn end_frame(&mut self, f: FrameFormat, din: &[u8], out_words: usize) {
        let wb = f.word_bytes();
        let word = f.word16(din, 0);
        let cmd = Command::from_word(word);
        let data_words = cmd.map_or(0, Command::data_words);
        let in_words = 1 + data_words + usize::from(f.rx_crc);
        if din.len() < out_words.max(in_words) * wb {
            self.answer = if cmd == Some(Command::Reset) {
                Answer::Word(Command::Reset.word())
            } else {
                Answer::Status
            };
            return;
        }
        if f.rx_crc {
            let covered = (1 + data_words) * wb;
            let sent = f.word16(din, 1 + data_words);
            if f.crc(din.get(..covered).unwrap_or(&[])) != sent {
                self.crc_error = true;
                self.stats.input_crc_errors += 1;
                if !matches!(cmd, Some(Command::WriteRegisters { .. })) {
                    self.answer = Answer::Status;
                    return;
                }
            }
        }
        self.answer = match cmd {
            Some(Command::Null) | None => Answer::Status,
            Some(Command::Unlock) => {
                self.locked = false;
                Answer::Word(word)
            }
            Some(Command::ReadRegisters { start, count }) => {
                if count == 1 {
                    Answer::Word(self.read_addr(start))
                } else {
                    Answer::Registers { start, count }
                }
            }
            Some(_) if self.locked => Answer::Status,
            Some(Command::Reset) => {
                self.reset_registers();
                Answer::Word(RESET_REPLY)
            }
            Some(Command::Standby) => {
                self.standby = true;
                Answer::Word(word)
            }
            Some(Command::Wakeup) => {
                self.standby = false;
                Answer::Word(word)
            }
            Some(Command::Lock) => {
                self.locked = true;
                Answer::Word(word)
            }
            Some(Command::WriteRegisters { start, count }) => {
                for i in 0..usize::from(count) {
                    let v = f.word16(din, 1 + i);
                    self.write_addr(start.wrapping_add(i as u8), v);
                }
                Answer::Word(0x4000 | (word & 0x1FFF))
            }
        };
    }
}

impl ErrorType for Ads131m02Model {
    type Error = ModelBusError;
}

impl SpiDevice for Ads131m02Model {
    fn transaction(&mut self, operations: &mut [Operation<'_, u8>]) -> Result<(), ModelBusError> {
        if self.bus_errors > 0 {
            self.bus_errors -= 1;
            return Err(ModelBusError);
        }
        // The format is the one in force when CS falls.
        let f = self.format();
        let mut out = [0u8; BUF_BYTES];
        let out_len = self.begin_frame(f, &mut out);
        let mut din = [0u8; BUF_BYTES];
        let mut n = 0usize;
        clock_operations(operations, |mosi| {
            if let Some(slot) = din.get_mut(n) {
                *slot = mosi;
            }
            let miso = if n < out_len {
                out.get(n).copied().unwrap_or(0)
            } else {
                0
            };
            n += 1;
            miso
        });
        self.stats.frames += 1;
        let clocked = din.get(..n.min(BUF_BYTES)).unwrap_or(&[]);
        self.end_frame(f, clocked, out_len / f.word_bytes());
        Ok(())
    }
}

#[cfg(test)]
#[allow(clippy::indexing_slicing, clippy::unwrap_used, clippy::panic)]
mod tests {
    use super::*;

    #[test]
    fn quantisation_follows_table_8_10() {
        let lsb = 1.2 / 8_388_608.0;
        assert_eq!(quantize(0.0, 1), 0);
        assert_eq!(quantize(lsb, 1), 1);
        assert_eq!(quantize(-lsb, 1), -1);
        assert_eq!(quantize(0.49 * lsb, 1), 0);
        assert_eq!(quantize(1.2 * (8_388_607.0 / 8_388_608.0), 1), CODE_MAX);
        assert_eq!(quantize(5.0, 1), CODE_MAX);
        assert_eq!(quantize(-1.2, 1), CODE_MIN);
        assert_eq!(quantize(-7.0, 128), CODE_MIN);
        assert_eq!(quantize(0.15, 4), 1 << 22);
        assert_eq!(quantize(f64::NAN, 1), 0);
        assert_eq!(quantize(f64::INFINITY, 1), CODE_MAX);
    }

    #[test]
    fn registers_start_at_reset_values() {
        let mut m = Ads131m02Model::new();
        assert_eq!(m.register(Register::Id), 0x2200);
        assert_eq!(m.register(Register::Mode), 0x0510);
        assert_eq!(m.register(Register::Clock), 0x030E);
        assert_eq!(m.register(Register::Status), 0x0500);
        m.set_revision(0x03);
        m.brown_out();
        assert_eq!(m.register(Register::Id), 0x2203);
        m.write_addr(Register::Id.addr(), 0);
        assert_eq!(m.register(Register::Id), 0x2203);
        m.write_addr(Register::Gain.addr(), 0xFFFF);
        assert_eq!(m.register(Register::Gain), 0x0077);
    }

    #[test]
    fn conversions_queue_two_deep_and_frames_output_the_oldest() {
        let mut m = Ads131m02Model::new();
        assert!(!m.drdy_low());
        for k in 1..=3 {
            m.set_inputs([f64::from(k) * 0.1, 0.0]);
            m.convert();
        }
        // Three conversions, two kept: the second and the third.
        assert_eq!(m.queued(), FIFO_DEPTH);
        assert!(m.drdy_low());
        assert_eq!(m.register(Register::Status) & 0b11, 0b11);
        let f = m.format();
        let mut out = [0u8; BUF_BYTES];
        m.begin_frame(f, &mut out);
        assert_eq!(f.data(&out, 1), quantize(0.2, 1));
        assert!(m.drdy_low());
        m.begin_frame(f, &mut out);
        assert_eq!(f.data(&out, 1), quantize(0.3, 1));
        assert!(!m.drdy_low());
        assert_eq!(m.register(Register::Status) & 0b11, 0);
        // Empty: the last data again, DRDY bits clear.
        m.begin_frame(f, &mut out);
        assert_eq!(f.data(&out, 1), quantize(0.3, 1));
        assert_eq!(f.word16(&out, 0) & 0b11, 0);
        m.convert();
        m.brown_out();
        assert_eq!(m.queued(), 0);
    }

    /// The self-test's faults: a slower data rate converts on `n` of every
    /// `d` periods, evenly; 0 converts never; a register fault flips the
    /// bits of its read-back only.
    #[test]
    fn data_rate_and_register_faults() {
        let mut m = Ads131m02Model::new();
        m.set_data_rate(19, 20);
        for _ in 0..200 {
            m.convert();
        }
        assert_eq!(m.stats.conversions, 190);
        m.set_data_rate(0, 1);
        for _ in 0..50 {
            m.convert();
        }
        assert_eq!(m.stats.conversions, 190);
        m.set_data_rate(5, 5);
        m.convert();
        assert_eq!(m.stats.conversions, 191);
        let gain = m.register(Register::Gain);
        m.set_register_fault(Some((Register::Gain, 0x0001)));
        assert_eq!(m.register(Register::Gain), gain ^ 1);
        assert_eq!(m.reg(Register::Gain), gain, "the register itself holds");
        m.set_register_fault(None);
        assert_eq!(m.register(Register::Gain), gain);
    }

    /// The driver, reset and configured with its defaults, on `model`.
    fn configured(
        model: &core::cell::RefCell<Ads131m02Model>,
    ) -> ads131m02::Ads131m02<super::super::Shared<'_, Ads131m02Model>> {
        struct NoDelay;
        impl embedded_hal::delay::DelayNs for NoDelay {
            fn delay_ns(&mut self, _ns: u32) {}
        }
        let mut adc = ads131m02::Ads131m02::new(super::super::Shared(model));
        adc.reset(&mut NoDelay).unwrap();
        adc.configure(&ads131m02::Config::default()).unwrap();
        adc
    }

    /// The pause the reference board has between configuring the ADC and
    /// arming the DRDY interrupt, with the driver: reading one frame per
    /// conversion afterwards lags one conversion for as long as it goes
    /// on; after [`ads131m02::Ads131m02::drain`] it does not lag.
    #[test]
    fn after_a_pause_one_frame_per_drdy_lags_until_drained() {
        let volts = |k: u32| 1e-3 * f64::from(k);
        let model = core::cell::RefCell::new(Ads131m02Model::new());
        let convert = |k: u32| {
            let mut m = model.borrow_mut();
            m.set_inputs([volts(k), -volts(k)]);
            m.convert();
        };
        let mut adc = configured(&model);
        // The pause: conversions nobody reads.
        let mut k = 0;
        for _ in 0..5 {
            convert(k);
            k += 1;
        }
        // One frame per conversion, as the sample interrupt does: the
        // frame carries the conversion before the one just announced.
        for _ in 0..20 {
            convert(k);
            let frame = adc.read_frame().unwrap();
            assert_eq!(frame.channels[0].code(), quantize(volts(k - 1), 1));
            assert_eq!(frame.channels[1].code(), quantize(-volts(k - 1), 1));
            assert!(model.borrow().drdy_low());
            k += 1;
        }
        // Drain to DRDY high: the conversion each read left queued goes.
        let drained = adc.drain(|| model.borrow().drdy_low()).unwrap();
        assert_eq!(drained.frames, 1);
        assert!(drained.drdy_high);
        // From the next conversion on, no lag.
        for _ in 0..20 {
            convert(k);
            let frame = adc.read_frame().unwrap();
            assert_eq!(frame.channels[0].code(), quantize(volts(k), 1));
            assert!(!model.borrow().drdy_low());
            k += 1;
        }
        // A drain with nothing queued clocks nothing; right after a pause
        // it clocks the FIFO's two.
        let drained = adc.drain(|| model.borrow().drdy_low()).unwrap();
        assert_eq!(drained.frames, 0);
        for _ in 0..3 {
            convert(k);
            k += 1;
        }
        let drained = adc.drain(|| model.borrow().drdy_low()).unwrap();
        assert_eq!(drained.frames, 2);
        // DRDY that never goes high stops after DRAIN_MAX_FRAMES.
        let drained = adc.drain(|| true).unwrap();
        assert_eq!(drained.frames, ads131m02::DRAIN_MAX_FRAMES);
        assert!(!drained.drdy_high);
    }

    /// A data frame lost on the bus leaves its conversion queued; the
    /// driver's next read catches up (one extra frame) instead of staying
    /// one conversion behind.
    #[test]
    fn a_frame_lost_on_the_bus_does_not_leave_the_reads_behind() {
        use ads131m02::Error;
        let volts = |k: u32| 1e-3 * f64::from(k);
        let model = core::cell::RefCell::new(Ads131m02Model::new());
        let convert = |k: u32| {
            let mut m = model.borrow_mut();
            m.set_inputs([volts(k), 0.0]);
            m.convert();
        };
        let mut adc = configured(&model);
        for k in 0..10 {
            convert(k);
            if k == 3 || k == 6 {
                model
                    .borrow_mut()
                    .inject_bus_errors(if k == 3 { 1 } else { 2 });
            }
            match adc.read_frame() {
                Ok(frame) => {
                    assert_eq!(frame.channels[0].code(), quantize(volts(k), 1), "{k}");
                }
                // Two failures from k = 6: the reads at 6 and 7.
                Err(Error::Spi(_)) => assert!(matches!(k, 3 | 6 | 7), "{k}"),
                Err(e) => panic!("{k}: {e:?}"),
            }
        }
        // After two lost in a row (FIFO full: 7 and 8 queued), k = 8 read
        // its own conversion and nothing is left queued.
        assert!(!model.borrow().drdy_low());
        // A pause the application reports (a late tick): caught up too.
        convert(10);
        convert(11);
        adc.note_pause();
        let frame = adc.read_frame().unwrap();
        assert_eq!(frame.channels[0].code(), quantize(volts(11), 1));
        assert!(!model.borrow().drdy_low());
    }
}
