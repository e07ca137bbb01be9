//! ADS131M02 commands and the typed responses that answer them.
//!
//! Command words and expected responses are SBAS853A Table 8-11 ("Command
//! Definitions"; the table text was read in the ADS131M03/M04/M06 data
//! sheets, whose tables differ only in the RESET reply FF2nh, n = channel
//! count). The response to a command appears in the first word of the
//! *following* frame; [`Command::decode_response`] checks a response word
//! against the command it answers.

use super::registers::{Register, Status};

/// The RESET reply of the two-channel part: FF22h (Table 8-11, `1111 1111
/// 0010 0010`; FF2nh with n = CHANCNT across the family).
pub const RESET_REPLY: u16 = 0xFF22;

/// Most registers one RREG may read (the map spans 00h–12h; 20 covers it).
pub const MAX_READ_REGISTERS: usize = 20;

/// A 16-bit command word (Table 8-11).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Command {
    /// NULL `0000h`: no operation; the response is the STATUS register.
    Null,
    /// RESET `0011h`: reset to register defaults; reply [`RESET_REPLY`].
    Reset,
    /// STANDBY `0022h`: stop conversions; reply `0022h`.
    Standby,
    /// WAKEUP `0033h`: resume conversions; reply `0033h`.
    Wakeup,
    /// LOCK `0555h`: only NULL, UNLOCK and RREG stay valid; reply `0555h`.
    Lock,
    /// UNLOCK `0655h`; reply `0655h`.
    Unlock,
    /// RREG `101a aaaa annn nnnn`: read `count` registers from `start`.
    ReadRegisters {
        /// First register address (6 bits).
        start: u8,
        /// Number of registers, 1..=128 (encoded minus one in 7 bits).
        count: u8,
    },
    /// WREG `011a aaaa annn nnnn`: write `count` registers from `start`;
    /// the data words follow the command word in the same frame.
    WriteRegisters {
        /// First register address (6 bits).
        start: u8,
        /// Number of registers, 1..=128.
        count: u8,
    },
}

const RREG_OPCODE: u16 = 0b101 << 13;
const WREG_OPCODE: u16 = 0b011 << 13;
/// Opcode of the multi-register RREG acknowledgement `111a aaaa annn nnnn`.
const RREG_ACK_OPCODE: u16 = 0b111 << 13;
/// Opcode of the WREG acknowledgement `010a aaaa ammm mmmm`.
const WREG_ACK_OPCODE: u16 = 0b010 << 13;

const fn addr_count(start: u8, count: u8) -> u16 {
    (((start & 0x3F) as u16) << 7) | ((count.wrapping_sub(1) & 0x7F) as u16)
}

impl Command {
    /// RREG of one register.
    pub const fn read(reg: Register) -> Command {
        Command::ReadRegisters {
            start: reg.addr(),
            count: 1,
        }
    }

    /// WREG of one register.
    pub const fn write(reg: Register) -> Command {
        Command::WriteRegisters {
            start: reg.addr(),
            count: 1,
        }
    }

    /// The command word.
    pub const fn word(self) -> u16 {
        match self {
            Command::Null => 0x0000,
            Command::Reset => 0x0011,
            Command::Standby => 0x0022,
            Command::Wakeup => 0x0033,
            Command::Lock => 0x0555,
            Command::Unlock => 0x0655,
            Command::ReadRegisters { start, count } => RREG_OPCODE | addr_count(start, count),
            Command::WriteRegisters { start, count } => WREG_OPCODE | addr_count(start, count),
        }
    }

    /// Decode a command word; `None` for words that are no command (the
    /// device answers those like NULL).
    pub const fn from_word(w: u16) -> Option<Command> {
        let start = ((w >> 7) & 0x3F) as u8;
        let count = ((w & 0x7F) as u8) + 1;
        match w {
            0x0000 => Some(Command::Null),
            0x0011 => Some(Command::Reset),
            0x0022 => Some(Command::Standby),
            0x0033 => Some(Command::Wakeup),
            0x0555 => Some(Command::Lock),
            0x0655 => Some(Command::Unlock),
            _ if w & 0xE000 == RREG_OPCODE => Some(Command::ReadRegisters { start, count }),
            _ if w & 0xE000 == WREG_OPCODE => Some(Command::WriteRegisters { start, count }),
            _ => None,
        }
    }

    /// Number of register data words this command carries on DIN (WREG) —
    /// they follow the command word in the same frame.
    pub const fn data_words(self) -> usize {
        match self {
            Command::WriteRegisters { count, .. } => count as usize,
            _ => 0,
        }
    }

    /// Words of register data in the *response* frame of this command
    /// (multi-register RREG only: ADC data are then not output).
    pub const fn response_register_words(self) -> usize {
        match self {
            Command::ReadRegisters { count, .. } if count > 1 => count as usize,
            _ => 0,
        }
    }

    /// Check `word`, the first word of the frame after this command was
    /// sent, against Table 8-11 and type it.
    pub fn decode_response(self, word: u16) -> Result<Response, u16> {
        let echo = |r: Response| {
            if word == self.word() {
                Ok(r)
            } else {
                Err(word)
            }
        };
        match self {
            Command::Null => Status::from_bits(word).map(Response::Status).ok_or(word),
            Command::Reset => {
                if word == RESET_REPLY {
                    Ok(Response::Reset)
                } else {
                    Err(word)
                }
            }
            Command::Standby | Command::Wakeup | Command::Lock | Command::Unlock => {
                echo(Response::Ack(self))
            }
            Command::ReadRegisters { count: 1, .. } => Ok(Response::Register(word)),
            Command::ReadRegisters { start, count } => {
                if word == RREG_ACK_OPCODE | addr_count(start, count) {
                    Ok(Response::RegistersFollow { start, count })
                } else {
                    Err(word)
                }
            }
            Command::WriteRegisters { start, count } => {
                if word == WREG_ACK_OPCODE | addr_count(start, count) {
                    Ok(Response::Written { start, count })
                } else {
                    Err(word)
                }
            }
        }
    }
}

/// A response word, typed by the command it answers (Table 8-11).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Response {
    /// Answer to NULL: the STATUS register.
    Status(Status),
    /// Answer to RESET: FF22h, the device was reset.
    Reset,
    /// Echo of STANDBY, WAKEUP, LOCK or UNLOCK.
    Ack(Command),
    /// Answer to a single-register RREG: the register contents.
    Register(u16),
    /// Answer to a multi-register RREG: `111a aaaa annn nnnn`; the register
    /// words follow in the same frame.
    RegistersFollow {
        /// First register address.
        start: u8,
        /// Number of registers that follow.
        count: u8,
    },
    /// Answer to WREG: `010a aaaa ammm mmmm`, `count` registers written.
    Written {
        /// First register address.
        start: u8,
        /// Number of registers written.
        count: u8,
    },
}

impl Response {
    /// The word this response was decoded from.
    pub const fn word(self) -> u16 {
        match self {
            Response::Status(s) => s.to_bits(),
            Response::Reset => RESET_REPLY,
            Response::Ack(c) => c.word(),
            Response::Register(v) => v,
            Response::RegistersFollow { start, count } => {
                RREG_ACK_OPCODE | addr_count(start, count)
            }
            Response::Written { start, count } => WREG_ACK_OPCODE | addr_count(start, count),
        }
    }

    /// The STATUS word, if this is the answer to NULL.
    pub const fn status(self) -> Option<Status> {
        match self {
            Response::Status(s) => Some(s),
            _ => None,
        }
    }
}

#[cfg(test)]
#[allow(clippy::indexing_slicing, clippy::unwrap_used)]
mod tests {
    use super::*;

    #[test]
    fn command_words_match_table_8_11() {
        assert_eq!(Command::Null.word(), 0x0000);
        assert_eq!(Command::Reset.word(), 0x0011);
        assert_eq!(Command::Standby.word(), 0x0022);
        assert_eq!(Command::Wakeup.word(), 0x0033);
        assert_eq!(Command::Lock.word(), 0x0555);
        assert_eq!(Command::Unlock.word(), 0x0655);
        // RREG ID: 101 00000 0 0000000.
        assert_eq!(Command::read(Register::Id).word(), 0xA000);
        // RREG MODE (02h): 101 00000 1 0000000 → A100h.
        assert_eq!(Command::read(Register::Mode).word(), 0xA100);
        // WREG CLOCK (03h): 011 00000 1 1000000 → 6180h.
        assert_eq!(Command::write(Register::Clock).word(), 0x6180);
        // RREG of 19 registers from 00h: nnn nnnn = 18.
        let all = Command::ReadRegisters {
            start: 0,
            count: 19,
        };
        assert_eq!(all.word(), 0xA012);
        // Highest address 3Fh.
        let top = Command::ReadRegisters {
            start: 0x3F,
            count: 1,
        };
        assert_eq!(top.word(), 0xBF80);
    }

    #[test]
    fn every_command_word_round_trips() {
        for w in 0..=u16::MAX {
            if let Some(c) = Command::from_word(w) {
                assert_eq!(c.word(), w, "{w:04X}");
            }
        }
    }

    #[test]
    fn responses_are_checked_against_the_command() {
        assert_eq!(Command::Reset.decode_response(0xFF22), Ok(Response::Reset));
        assert_eq!(Command::Reset.decode_response(0xFF24), Err(0xFF24));
        assert_eq!(Command::Reset.decode_response(0x0011), Err(0x0011));
        assert_eq!(
            Command::Lock.decode_response(0x0555),
            Ok(Response::Ack(Command::Lock))
        );
        assert!(Command::Unlock.decode_response(0x0555).is_err());
        let w = Command::write(Register::Gain);
        assert_eq!(
            w.decode_response(0x4200),
            Ok(Response::Written { start: 4, count: 1 })
        );
        assert!(w.decode_response(0x4180).is_err());
        let r = Command::ReadRegisters { start: 2, count: 3 };
        assert_eq!(
            r.decode_response(0xE102),
            Ok(Response::RegistersFollow { start: 2, count: 3 })
        );
        assert!(r.decode_response(0xE101).is_err());
        assert_eq!(
            Command::read(Register::Id).decode_response(0x2203),
            Ok(Response::Register(0x2203))
        );
        // NULL wants a STATUS word: reserved bits 7:2 must be clear.
        assert!(Command::Null.decode_response(0x0503).is_ok());
        for (cmd, word) in [
            (Command::Null, 0x0503),
            (Command::Reset, 0xFF22),
            (Command::Wakeup, 0x0033),
            (Command::read(Register::Clock), 0x1234),
            (r, 0xE102),
            (w, 0x4200),
        ] {
            assert_eq!(cmd.decode_response(word).unwrap().word(), word);
        }
        assert_eq!(Command::Null.decode_response(0xFF22), Err(0xFF22));
    }
}
