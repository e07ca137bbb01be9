//! Behavioural model of the ADI AD5761R on its SPI interface.
//!
//! # What it does
//! * Decodes each 24-bit word latched at SYNC rising (the last 24 bits
//!   clocked; fewer than 24 bits abort the write, the "SYNC interrupt"
//!   behaviour of ADI's serial DACs): DB19:16 command, DB15:0 data; a word
//!   with DB20 set is ignored (DB20 must be 0, Table 14).
//! * Commands (see the `ad5761r` crate's [`Command`] for sources):
//!   write input register, update DAC from input, write and update, write
//!   control (SC/BO cleared), software data reset, daisy-chain enable,
//!   readback of input/DAC/control, software full reset.
//! * SDO: during each frame the device shifts out the previous frame's
//!   input word (daisy chain), or, after a readback command, the readback
//!   word `[cmd, data]` (Table 15). With daisy chain disabled SDO reads 0.
//! * [`Ad5761rModel::output_volts`]: 0 V while the output is clamped (from
//!   power-on or a full reset until the control register is written), then
//!   V_REF·(M·D/2¹⁶ − C) of the DAC register (two's complement converted),
//!   with the 5 % overrange scaling of the driver's [`Transfer`].
//!
//! # Assumptions (not verified against the data sheet here)
//! The output is clamped at 0 V until the first control write (the design
//! notes' reading of the data sheet). At that write a DAC register never
//! written since reset takes the power-up level PV; a software data reset
//! loads PV too. IRO = 0 uses [`Ad5761rModel::set_external_reference`]
//! (0 V by default: no reference, no output).
//!
//! # Not modelled
//! Settling time and slew, glitches, noise, INL/DNL, the LDAC, CLEAR and
//! RESET pins (so CV has no effect), short-circuit and brown-out detection
//! (SC/BO read 0), thermal shutdown.
//!
//! [`Command`]: ad5761r::Command
//! [`Transfer`]: ad5761r::Transfer

use embedded_hal::spi::{ErrorType, Operation, SpiDevice};

use ad5761r::{
    Command, OutputRange, ScaleLevel, CONTROL_MASK, INTERNAL_VREF_VOLTS, OVERRANGE_FACTOR,
};

use super::{clock_operations, ModelBusError};

/// The AD5761R model. See the module docs.
#[derive(Clone, Debug)]
pub struct Ad5761rModel {
    /// Control register bits 10:0; `None` while the output is clamped.
    control: Option<u16>,
    input: u16,
    dac: u16,
    dac_written: bool,
    daisy_chain: bool,
    /// Word shifted out of SDO during the next frame.
    sdo: [u8; 3],
    external_vref_volts: f64,
    bus_errors: u32,
    words: u64,
}

impl Default for Ad5761rModel {
    fn default() -> Self {
        Self::new()
    }
}

impl Ad5761rModel {
    /// A device just powered on: output clamped at 0 V.
    pub fn new() -> Self {
        Ad5761rModel {
            control: None,
            input: 0,
            dac: 0,
            dac_written: false,
            daisy_chain: true,
            sdo: [0; 3],
            external_vref_volts: 0.0,
            bus_errors: 0,
            words: 0,
        }
    }

    /// Voltage on an external REFIN (used when IRO = 0), volts.
    pub fn set_external_reference(&mut self, volts: f64) {
        self.external_vref_volts = volts;
    }

    /// Fault: the next `n` transactions fail with [`ModelBusError`] and
    /// have no effect.
    pub fn inject_bus_errors(&mut self, n: u32) {
        self.bus_errors = n;
    }

    /// Control register bits 10:0, `None` while clamped.
    pub fn control(&self) -> Option<u16> {
        self.control
    }

    /// The DAC register (in the configured coding).
    pub fn dac_code(&self) -> u16 {
        self.dac
    }

    /// Whether the output is still clamped (no control write since reset).
    pub fn is_clamped(&self) -> bool {
        self.control.is_none()
    }

    /// 24-bit words latched so far.
    pub fn words(&self) -> u64 {
        self.words
    }

    /// The held output voltage, volts: what the plant sees.
    pub fn output_volts(&self) -> f64 {
        let Some(ctrl) = self.control else {
            return 0.0;
        };
        let range = OutputRange::from_bits(ctrl);
        let (m, c) = range.m_c_tenths();
        let ovr = if ctrl & (1 << 8) != 0 {
            f64::from(OVERRANGE_FACTOR)
        } else {
            1.0
        };
        let m = f64::from(m) / 10.0 * ovr;
        let c = f64::from(c) / 10.0 * ovr;
        let vref = if ctrl & (1 << 5) != 0 {
            f64::from(INTERNAL_VREF_VOLTS)
        } else {
            self.external_vref_volts
        };
        let d = f64::from(self.straight(self.dac));
        vref * (m * d / 65_536.0 - c)
    }

    /// XOR turning a register code into straight binary (and back).
    fn coding_xor(&self) -> u16 {
        match self.control {
            Some(ctrl) if ctrl & (1 << 7) != 0 && OutputRange::from_bits(ctrl).is_bipolar() => {
                0x8000
            }
            _ => 0,
        }
    }

    fn straight(&self, code: u16) -> u16 {
        code ^ self.coding_xor()
    }

    fn power_up_code(&self) -> u16 {
        let pv = self
            .control
            .and_then(|c| ScaleLevel::from_bits(c >> 3))
            .unwrap_or(ScaleLevel::Zero);
        pv.code() ^ self.coding_xor()
    }

    fn latch(&mut self, word: [u8; 3]) {
        let [hi, d1, d0] = word;
        let data = u16::from_be_bytes([d1, d0]);
        // By default the next frame shifts this word out again.
        self.sdo = if self.daisy_chain { word } else { [0; 3] };
        if hi & 0x10 != 0 {
            return;
        }
        self.words += 1;
        let readback = |cmd: Command, v: u16| {
            let [a, b] = v.to_be_bytes();
            [cmd as u8, a, b]
        };
        match Command::from_nibble(hi) {
            Some(Command::WriteInput) => self.input = data,
            Some(Command::UpdateDac) => {
                self.dac = self.input;
                self.dac_written = true;
            }
            Some(Command::WriteUpdateDac) => {
                self.input = data;
                self.dac = data;
                self.dac_written = true;
            }
            Some(Command::WriteControl) => {
                self.control = Some(data & CONTROL_MASK);
                if !self.dac_written {
                    self.dac = self.power_up_code();
                    self.input = self.dac;
                }
            }
            Some(Command::DataReset) => {
                self.dac = self.power_up_code();
                self.input = self.dac;
            }
            Some(Command::DisableDaisyChain) => self.daisy_chain = data & 1 == 0,
            Some(cmd @ Command::ReadInput) if self.daisy_chain => {
                self.sdo = readback(cmd, self.input)
            }
            Some(cmd @ Command::ReadDac) if self.daisy_chain => self.sdo = readback(cmd, self.dac),
            Some(cmd @ Command::ReadControl) if self.daisy_chain => {
                self.sdo = readback(cmd, self.control.unwrap_or(0))
            }
            Some(Command::FullReset) => {
                *self = Ad5761rModel {
                    external_vref_volts: self.external_vref_volts,
                    bus_errors: self.bus_errors,
                    words: self.words,
                    ..Ad5761rModel::new()
                }
            }
            _ => {}
        }
    }
}

impl ErrorType for Ad5761rModel {
    type Error = ModelBusError;
}

impl SpiDevice for Ad5761rModel {
    fn transaction(&mut self, operations: &mut [Operation<'_, u8>]) -> Result<(), ModelBusError> {
        if self.bus_errors > 0 {
            self.bus_errors -= 1;
            return Err(ModelBusError);
        }
        let out = self.sdo;
        // The shift register: the last three bytes clocked in.
        let mut shift = [0u8; 3];
        // Bytes clocked in, kept to replay on SDO after the first 24 bits
        // (daisy chain).
        let mut history = [0u8; 64];
        let mut n = 0usize;
        let daisy = self.daisy_chain;
        clock_operations(operations, |mosi| {
            let miso = match out.get(n) {
                Some(&b) => b,
                None if daisy => history.get(n - 3).copied().unwrap_or(0),
                None => 0,
            };
            if let Some(h) = history.get_mut(n) {
                *h = mosi;
            }
            let [_, a, b] = shift;
            shift = [a, b, mosi];
            n += 1;
            miso
        });
        if n >= 3 {
            self.latch(shift);
        }
        Ok(())
    }
}

#[cfg(test)]
#[allow(clippy::indexing_slicing, clippy::unwrap_used)]
mod tests {
    use super::*;

    #[test]
    fn clamped_until_the_control_register_is_written() {
        let mut m = Ad5761rModel::new();
        m.latch([0x03, 0xFF, 0xFF]);
        assert!(m.is_clamped());
        assert_eq!(m.output_volts(), 0.0);
        // ±10 V, PV mid, IRO: the written code now shows.
        m.latch([0x04, 0x00, 0x28]);
        assert!((m.output_volts() - (10.0 - 20.0 / 65_536.0)).abs() < 1e-12);
        m.latch([0x0F, 0x00, 0x00]);
        assert_eq!(m.output_volts(), 0.0);
        // PV mid on a fresh device: 0 V at the first control write.
        m.latch([0x04, 0x00, 0x28]);
        assert_eq!(m.dac_code(), 0x8000);
        assert_eq!(m.output_volts(), 0.0);
        // DB20 set: ignored.
        m.latch([0x13, 0x00, 0x00]);
        assert_eq!(m.dac_code(), 0x8000);
    }
}
