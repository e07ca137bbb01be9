//! ADS131M02 driver, every transaction checked byte for byte against the
//! data sheet's framing (SBAS853A Table 8-11 commands, Table 8-12
//! registers, §8.3.12 CRC) with embedded-hal-mock.

mod common;

use ads131m02::{
    crc16, Ads131m02, Command, Config, CrcType, Error, PgaGain, Rail, Register, Response, Status,
    WordLength,
};
use common::{crc16_bitwise, frame, status, FailOnce, FailingSpi, Fmt, ANSI, CCITT, RESET_FMT};
use embedded_hal::spi::ErrorKind;
use embedded_hal_mock::eh1::delay::{CheckedDelay, Transaction as DelayTx};
use embedded_hal_mock::eh1::spi::{Mock, Transaction};

type Driver = Ads131m02<Mock<u8>>;

fn driver(expectations: &[Transaction<u8>]) -> Driver {
    Ads131m02::new(Mock::new(expectations))
}

fn done(d: Driver) {
    d.destroy().done();
}

/// STATUS after RESET: RESET flag, 24-bit words, CCITT, both DRDY set.
const STATUS_AFTER_RESET: u16 = 0x0503;
/// STATUS once configured (RESET cleared), 24-bit words.
const STATUS_RUNNING: u16 = 0x0103;

#[test]
fn reference_crc_matches_the_catalogue_and_the_driver() {
    // Check values of CRC-16/IBM-3740 (CCITT-FALSE) and CRC-16/CMS.
    assert_eq!(crc16_bitwise(CCITT, b"123456789"), 0x29B1);
    assert_eq!(crc16_bitwise(ANSI, b"123456789"), 0xAEE7);
    let mut x: u32 = 12345;
    for len in 0..40 {
        let data: Vec<u8> = (0..len)
            .map(|_| {
                x = x.wrapping_mul(1_103_515_245).wrapping_add(12_345);
                (x >> 16) as u8
            })
            .collect();
        assert_eq!(crc16(CrcType::Ccitt, &data), crc16_bitwise(CCITT, &data));
        assert_eq!(crc16(CrcType::Ansi, &data), crc16_bitwise(ANSI, &data));
    }
}

#[test]
fn reset_checks_the_ff22_reply_and_the_id() {
    let mut ex = Vec::new();
    // RESET 0011h: its frame's DOUT (answer to an unknown earlier command,
    // bad CRC here) is not checked.
    ex.extend(frame(
        vec![0x00, 0x11, 0x00, 0, 0, 0, 0, 0, 0, 0, 0, 0],
        vec![
            0x05, 0x00, 0x00, 0x12, 0x34, 0x56, 0, 0, 0, 0xDE, 0xAD, 0x00,
        ],
    ));
    // NULL; DOUT = FF22h, channels 0, CRC 6081h over the 9 bytes before it.
    assert_eq!(
        crc16_bitwise(CCITT, &[0xFF, 0x22, 0, 0, 0, 0, 0, 0, 0]),
        0x6081
    );
    ex.extend(frame(
        vec![0; 12],
        vec![0xFF, 0x22, 0x00, 0, 0, 0, 0, 0, 0, 0x60, 0x81, 0x00],
    ));
    // RREG ID: 1010 0000 0000 0000.
    assert_eq!(
        crc16_bitwise(CCITT, &[0x05, 0x03, 0, 0x12, 0x34, 0x56, 0xFF, 0xFF, 0xFE]),
        0x2308
    );
    ex.extend(frame(
        vec![0xA0, 0x00, 0x00, 0, 0, 0, 0, 0, 0, 0, 0, 0],
        vec![
            0x05, 0x03, 0x00, 0x12, 0x34, 0x56, 0xFF, 0xFF, 0xFE, 0x23, 0x08, 0x00,
        ],
    ));
    // NULL; DOUT = ID 2200h, CRC 79E9h.
    ex.extend(frame(
        vec![0; 12],
        vec![0x22, 0x00, 0x00, 0, 0, 0, 0, 0, 0, 0x79, 0xE9, 0x00],
    ));
    let mut d = driver(&ex);
    let mut delay = CheckedDelay::new(&[DelayTx::delay_us(5)]);
    assert_eq!(d.reset(&mut delay), Ok(0x2200));
    assert_eq!(d.pending(), Command::Null);
    delay.done();
    done(d);
}

fn reset_head(reply: u16) -> Vec<Transaction<u8>> {
    let mut ex = Vec::new();
    ex.extend(frame(RESET_FMT.din(0x0011, &[]), vec![0; 12]));
    ex.extend(frame(RESET_FMT.din(0, &[]), RESET_FMT.dout(reply, 0, 0)));
    ex
}

#[test]
fn a_wrong_reset_reply_is_an_error() {
    // FF24h is the four-channel part's reply.
    let ex = reset_head(0xFF24);
    let mut d = driver(&ex);
    let mut delay = CheckedDelay::new(&[DelayTx::delay_us(5)]);
    assert_eq!(d.reset(&mut delay), Err(Error::ResetReply(0xFF24)));
    delay.done();
    done(d);
    // A device that never got the frame answers like NULL (a STATUS word).
    let ex = reset_head(STATUS_AFTER_RESET);
    let mut d = driver(&ex);
    let mut delay = CheckedDelay::new(&[DelayTx::delay_us(5)]);
    assert_eq!(d.reset(&mut delay), Err(Error::ResetReply(0x0503)));
    delay.done();
    done(d);
}

#[test]
fn an_id_of_another_part_is_an_error() {
    let mut ex = reset_head(0xFF22);
    ex.extend(frame(
        RESET_FMT.din(0xA000, &[]),
        RESET_FMT.dout(STATUS_AFTER_RESET, 0, 0),
    ));
    ex.extend(frame(RESET_FMT.din(0, &[]), RESET_FMT.dout(0x2400, 0, 0)));
    let mut d = driver(&ex);
    let mut delay = CheckedDelay::new(&[DelayTx::delay_us(5)]);
    assert_eq!(d.reset(&mut delay), Err(Error::IdMismatch(0x2400)));
    delay.done();
    done(d);
}

/// The frames of `configure(config)` from the reset state, each answer
/// what the device would send.
fn configure_frames(config: &Config) -> Vec<Transaction<u8>> {
    let clock = config.clock().to_bits();
    let gain = config.gain().to_bits();
    let mode = config.mode().to_bits();
    let old = RESET_FMT;
    let new = Fmt {
        word_bytes: config.word_length.bytes(),
        sign_extend: config.word_length == WordLength::Bits32SignExtend,
        poly: if config.crc_type == CrcType::Ansi {
            ANSI
        } else {
            CCITT
        },
        rx_crc: config.rx_crc,
    };
    let running = status(
        false,
        config.word_length.to_bits(),
        config.crc_type == CrcType::Ansi,
    );
    let mut ex = Vec::new();
    // WREG CLOCK 011 00001 1 0000000 = 6180h, answers the last NULL.
    ex.extend(frame(
        old.din(0x6180, &[clock]),
        old.dout(STATUS_AFTER_RESET, 0, 0),
    ));
    // WREG GAIN1 6200h, answers WREG CLOCK with 010 00001 1 0000000 = 4180h.
    ex.extend(frame(old.din(0x6200, &[gain]), old.dout(0x4180, 0, 0)));
    // WREG MODE 6100h, answers WREG GAIN1 with 4200h.
    ex.extend(frame(old.din(0x6100, &[mode]), old.dout(0x4200, 0, 0)));
    // From here on the new format: NULL collects the MODE ack 4100h.
    ex.extend(frame(new.din(0, &[]), new.dout(0x4100, 0, 0)));
    for (rreg, value) in [(0xA180, clock), (0xA200, gain), (0xA100, mode)] {
        ex.extend(frame(new.din(rreg, &[]), new.dout(running, 0, 0)));
        ex.extend(frame(new.din(0, &[]), new.dout(value, 0, 0)));
    }
    ex
}

#[test]
fn configure_pipelines_three_writes_and_reads_them_back() {
    let config = Config::default();
    // Register values of the rig configuration (Table 8-12 bit positions).
    assert_eq!(config.clock().to_bits(), 0x0306); // CH1_EN|CH0_EN, OSR 256, HR
    assert_eq!(config.gain().to_bits(), 0x0000);
    assert_eq!(config.mode().to_bits(), 0x1110); // RX_CRC_EN, 24-bit, TIMEOUT
    let ex = configure_frames(&config);
    // The first frame with input CRC, byte for byte: NULL 000000h, then
    // its CRC CC9Ch, then two zero words.
    assert_eq!(crc16_bitwise(CCITT, &[0, 0, 0]), 0xCC9C);
    let crc_fmt = Fmt {
        rx_crc: true,
        ..RESET_FMT
    };
    assert_eq!(
        crc_fmt.din(0, &[]),
        [0, 0, 0, 0xCC, 0x9C, 0, 0, 0, 0, 0, 0, 0]
    );
    // WREG CLOCK 0306h in the reset format: 61 80 00 | 03 06 00 | 0 | 0.
    assert_eq!(
        RESET_FMT.din(0x6180, &[0x0306]),
        [0x61, 0x80, 0, 0x03, 0x06, 0, 0, 0, 0, 0, 0, 0]
    );
    let mut d = driver(&ex);
    assert_eq!(d.configure(&config), Ok(()));
    assert_eq!(d.format(), config.format());
    done(d);
}

#[test]
fn a_configuration_that_does_not_read_back_is_an_error() {
    let config = Config::default();
    let mut ex = configure_frames(&config);
    // Corrupt the CLOCK read-back (second-to-last frames of the CLOCK pair).
    let new = Fmt {
        rx_crc: true,
        ..RESET_FMT
    };
    let idx = ex.len() - 3 * 3 * 2 + 3; // the NULL answering RREG CLOCK
    ex[idx + 1] = Transaction::transfer_in_place(new.din(0, &[]), new.dout(0x0302, 0, 0));
    ex.truncate(idx + 3);
    let mut d = driver(&ex);
    assert_eq!(
        d.configure(&config),
        Err(Error::ConfigMismatch {
            register: Register::Clock,
            wrote: 0x0306,
            read: 0x0302
        })
    );
    done(d);
}

#[test]
fn read_frame_decodes_both_channels() {
    let rx = vec![
        0x05, 0x03, 0x00, 0x12, 0x34, 0x56, 0xFF, 0xFF, 0xFE, 0x23, 0x08, 0x00,
    ];
    let mut d = driver(&frame(vec![0; 12], rx));
    let f = d.read_frame().unwrap();
    let s = f.status;
    assert!(s.reset && s.drdy == [true, true]);
    assert_eq!(s.word_length, WordLength::Bits24);
    assert_eq!(f.channels[0].code(), 0x123456);
    assert_eq!(f.channels[1].code(), -2);
    assert_eq!(
        f.channels[0].volts_f64(),
        Ok(0x123456 as f64 * 1.2 / 8_388_608.0)
    );
    assert_eq!(f.channels[1].volts_f32(), Ok(-2.0 * 1.2 / 8_388_608.0));
    done(d);
}

#[test]
fn a_bad_output_crc_is_an_error_never_a_sample() {
    let mut rx = vec![
        0x05, 0x03, 0x00, 0x12, 0x34, 0x56, 0xFF, 0xFF, 0xFE, 0x23, 0x08, 0x00,
    ];
    rx[5] ^= 0x01; // one data bit flipped on the wire
    let computed = crc16_bitwise(CCITT, &rx[..9]);
    let mut d = driver(&frame(vec![0; 12], rx));
    assert_eq!(
        d.read_frame(),
        Err(Error::Crc {
            received: 0x2308,
            computed
        })
    );
    done(d);
}

#[test]
fn status_flags_and_format_mismatches_are_errors() {
    let f = RESET_FMT;
    let cases: [u16; 5] = [
        0x1503, // CRC_ERR: the device refused our last command
        0x4503, // F_RESYNC
        0x0703, // WLENGTH says 32-bit: our 24-bit framing is wrong
        0x8503, // LOCK set although the driver never locked
        0x0501, // DRDY1 clear: a repeat of the last conversion
    ];
    for (i, word) in cases.iter().enumerate() {
        let mut d = driver(&frame(f.din(0, &[]), f.dout(*word, 1, 2)));
        let e = d.read_frame().unwrap_err();
        let ok = match (i, e) {
            (0, Error::InputCrc(s)) => s.to_bits() == *word,
            (1, Error::ResyncFault(s)) => s.to_bits() == *word,
            (2, Error::StatusMismatch(s)) => s.to_bits() == *word,
            (3, Error::StatusMismatch(s)) => s.to_bits() == *word,
            (4, Error::NoNewData(s)) => s.to_bits() == *word,
            _ => false,
        };
        assert!(ok, "case {i}: {e:?}");
        done(d);
    }
    // A word with reserved STATUS bits set is no STATUS word.
    let mut d = driver(&frame(f.din(0, &[]), f.dout(0x0507, 1, 2)));
    assert_eq!(
        d.read_frame(),
        Err(Error::UnexpectedResponse {
            command: Command::Null,
            response: 0x0507
        })
    );
    done(d);
}

#[test]
fn a_device_reset_after_configuration_is_an_error() {
    let f = RESET_FMT;
    let mut ex = Vec::new();
    // write_register(MODE, 0x0110): RESET cleared, 24-bit.
    ex.extend(frame(
        f.din(0x6100, &[0x0110]),
        f.dout(STATUS_AFTER_RESET, 0, 0),
    ));
    ex.extend(frame(f.din(0, &[]), f.dout(0x4100, 0, 0)));
    // Later the device browns out: STATUS.RESET is back.
    ex.extend(frame(f.din(0, &[]), f.dout(STATUS_AFTER_RESET, 7, 8)));
    let mut d = driver(&ex);
    d.write_register(Register::Mode, 0x0110).unwrap();
    match d.read_frame() {
        Err(Error::UnexpectedReset(s)) => assert!(s.reset),
        other => panic!("{other:?}"),
    }
    done(d);
}

#[test]
fn a_response_that_does_not_answer_the_previous_command_is_an_error() {
    let f = RESET_FMT;
    let mut ex = Vec::new();
    ex.extend(frame(
        f.din(0x6200, &[0x0011]),
        f.dout(STATUS_RUNNING, 0, 0),
    ));
    // The ack should be 4200h (GAIN1); 4180h acknowledges CLOCK.
    ex.extend(frame(f.din(0, &[]), f.dout(0x4180, 0, 0)));
    let mut d = driver(&ex);
    assert_eq!(
        d.write_register(Register::Gain, 0x0011),
        Err(Error::UnexpectedResponse {
            command: Command::write(Register::Gain),
            response: 0x4180
        })
    );
    // The driver knows the device has latched that NULL.
    assert_eq!(d.pending(), Command::Null);
    done(d);
}

#[test]
fn spi_errors_are_reported() {
    let mut d = Ads131m02::new(FailingSpi(ErrorKind::ModeFault));
    assert_eq!(d.read_frame(), Err(Error::Spi(ErrorKind::ModeFault)));
    assert_eq!(
        d.read_register(Register::Id),
        Err(Error::Spi(ErrorKind::ModeFault))
    );
    let e = d.read_frame().unwrap_err();
    assert!(format!("{e}").contains("SPI error"));
    let _: &dyn core::error::Error = &e;
}

#[test]
fn an_answer_owed_by_a_failed_operation_is_no_sample() {
    let read_clock = Command::read(Register::Clock);
    let mut ex = Vec::new();
    // RREG CLOCK (A180h) completes: the device latches it.
    ex.extend(frame(
        RESET_FMT.din(0xA180, &[]),
        RESET_FMT.dout(STATUS_AFTER_RESET, 0, 0),
    ));
    // (The NULL that should collect the answer fails on the bus.)
    // The next frame carries the register, not STATUS: no sample.
    ex.extend(frame(RESET_FMT.din(0, &[]), RESET_FMT.dout(0x030E, 7, 7)));
    // And the frame after it is a normal one again.
    ex.extend(frame(
        RESET_FMT.din(0, &[]),
        RESET_FMT.dout(STATUS_AFTER_RESET, 5, -5),
    ));
    let spi = FailOnce {
        mock: Mock::new(&ex),
        fail_at: 2,
        seen: 0,
    };
    let mut d = Ads131m02::new(spi);
    assert_eq!(
        d.read_register(Register::Clock),
        Err(Error::Spi(ErrorKind::Other))
    );
    assert_eq!(d.pending(), read_clock);
    assert_eq!(
        d.read_frame(),
        Err(Error::OwedResponse {
            command: read_clock
        })
    );
    let f = d.read_frame().unwrap();
    assert_eq!([f.channels[0].code(), f.channels[1].code()], [5, -5]);
    d.destroy().mock.done();
}

#[test]
fn error_messages_name_the_chip_and_are_distinct() {
    let s = Status::from_bits(STATUS_AFTER_RESET).unwrap();
    let errors: [Error<ErrorKind>; 14] = [
        Error::Spi(ErrorKind::Other),
        Error::Crc {
            received: 1,
            computed: 2,
        },
        Error::UnexpectedResponse {
            command: Command::Null,
            response: 0xFFFF,
        },
        Error::OwedResponse {
            command: Command::Lock,
        },
        Error::ResetReply(0x0011),
        Error::IdMismatch(0x2400),
        Error::InputCrc(s),
        Error::ResyncFault(s),
        Error::UnexpectedReset(s),
        Error::StatusMismatch(s),
        Error::NoNewData(s),
        Error::StuckData { frames: 3 },
        Error::ConfigMismatch {
            register: Register::Mode,
            wrote: 1,
            read: 0,
        },
        Error::InvalidArgument,
    ];
    let messages: Vec<String> = errors.iter().map(|e| e.to_string()).collect();
    for (i, m) in messages.iter().enumerate() {
        assert!(m.starts_with("ADS131M02: "), "{m}");
        assert!(!m.contains('\n'), "{m}");
        for other in &messages[i + 1..] {
            assert_ne!(m, other);
        }
    }
}

#[test]
fn sixteen_bit_words_with_ansi_crc() {
    let old = RESET_FMT;
    // MODE: CRC_TYPE ANSI (bit 11), WLENGTH 00 (16-bit), TIMEOUT.
    let mode = 0x0810;
    let new = Fmt {
        word_bytes: 2,
        sign_extend: false,
        poly: ANSI,
        rx_crc: false,
    };
    let mut ex = Vec::new();
    ex.extend(frame(
        old.din(0x6100, &[mode]),
        old.dout(STATUS_AFTER_RESET, 0, 0),
    ));
    ex.extend(frame(new.din(0, &[]), new.dout(0x4100, 0, 0)));
    // 8-byte frames: STATUS 0803h, channel codes truncated to 16 bits.
    let rx = new.dout(0x0803, 0x7FFF00, -0x123400);
    assert_eq!(rx.len(), 8);
    assert_eq!(&rx[..6], &[0x08, 0x03, 0x7F, 0xFF, 0xED, 0xCC]);
    ex.extend(frame(vec![0; 8], rx));
    let mut d = driver(&ex);
    d.write_register(Register::Mode, mode).unwrap();
    let f = d.read_frame().unwrap();
    assert_eq!(f.channels[0].code(), 0x7FFF00);
    assert_eq!(f.channels[0].saturation(), Some(Rail::High));
    assert_eq!(f.channels[1].code(), -0x123400);
    assert!(f.channels[1].saturation().is_none());
    done(d);
}

#[test]
fn thirty_two_bit_sign_extended_words_with_input_crc() {
    let old = RESET_FMT;
    // MODE: RX_CRC_EN, WLENGTH 11 (32-bit sign-extended), TIMEOUT.
    let mode = 0x1310;
    let new = Fmt {
        word_bytes: 4,
        sign_extend: true,
        poly: CCITT,
        rx_crc: true,
    };
    let mut ex = Vec::new();
    ex.extend(frame(
        old.din(0x6100, &[mode]),
        old.dout(STATUS_AFTER_RESET, 0, 0),
    ));
    // NULL with input CRC over 00000000h: 16 bytes on DIN.
    let din = new.din(0, &[]);
    assert_eq!(&din[4..8], &[0x84, 0xC0, 0, 0]);
    ex.extend(frame(din.clone(), new.dout(0x4100, 0, 0)));
    let rx = new.dout(0x0303, -0x800000, 5);
    assert_eq!(
        &rx[4..12],
        &[0xFF, 0x80, 0x00, 0x00, 0x00, 0x00, 0x00, 0x05]
    );
    ex.extend(frame(din, rx));
    let mut d = driver(&ex);
    d.write_register(Register::Mode, mode).unwrap();
    let f = d.read_frame().unwrap();
    assert_eq!(f.channels[0].code(), -0x800000);
    assert_eq!(f.channels[0].volts_f32().unwrap_err().rail, Rail::Low);
    assert_eq!(f.channels[1].code(), 5);
    done(d);
}

#[test]
fn a_multi_register_read_has_a_long_answer_frame() {
    let f = RESET_FMT;
    let mut ex = Vec::new();
    // RREG 3 registers from MODE: 101 00000 1 0000010 = A102h.
    ex.extend(frame(f.din(0xA102, &[]), f.dout(STATUS_AFTER_RESET, 0, 0)));
    // Answer: 111 00000 1 0000010 = E102h, MODE, CLOCK, GAIN1, CRC: 5 words.
    let rx = f.dout_registers(0xE102, &[0x0510, 0x030E, 0x0000]);
    assert_eq!(rx.len(), 15);
    ex.extend(frame(f.din_words(0, &[], 5), rx));
    let mut d = driver(&ex);
    let mut regs = [0u16; 3];
    d.read_registers(Register::Mode, &mut regs).unwrap();
    assert_eq!(regs, [0x0510, 0x030E, 0x0000]);
    assert_eq!(
        d.read_registers(Register::Mode, &mut [0u16; 0]),
        Err(Error::InvalidArgument)
    );
    assert_eq!(
        d.read_registers(Register::Id, &mut [0u16; 21]),
        Err(Error::InvalidArgument)
    );
    assert_eq!(
        d.write_register(Register::Id, 0),
        Err(Error::InvalidArgument)
    );
    done(d);
}

/// The self-test's read-back: ID, STATUS, MODE, CLOCK, GAIN1 in one RREG
/// (101 00000 0 0000100 = A004h), answered by E004h and five registers;
/// the ID and the configuration checked under the writable masks.
#[test]
fn read_back_reads_the_id_and_the_configuration_in_one_rreg() {
    let f = RESET_FMT;
    let mut ex = Vec::new();
    ex.extend(frame(f.din(0xA004, &[]), f.dout(STATUS_AFTER_RESET, 0, 0)));
    let rx = f.dout_registers(0xE004, &[0x2201, 0x0503, 0x0510, 0x030E, 0x0000]);
    ex.extend(frame(f.din_words(0, &[], 7), rx));
    let mut d = driver(&ex);
    let r = d.read_back().unwrap();
    assert_eq!(
        (r.id, r.mode, r.clock, r.gain),
        (0x2201, 0x0510, 0x030E, 0x0000)
    );
    assert!(r.id_ok());
    // The reset values are not the default configuration's.
    let config = Config::default();
    assert!(!r.matches(&config));
    let [mode, clock, gain] = config.expected_registers();
    let configured = ads131m02::ReadBack {
        // Bit 5 of MODE is reserved: ignored by the comparison.
        mode: mode | 0x0020,
        clock,
        gain,
        ..r
    };
    assert!(configured.matches(&config));
    let m04 = ads131m02::ReadBack { id: 0x2400, ..r };
    assert!(!m04.id_ok());
    done(d);
}

#[test]
fn standby_wakeup_lock_unlock_are_acknowledged() {
    let f = RESET_FMT;
    let mut ex = Vec::new();
    for (cmd, status_before) in [
        (0x0022u16, STATUS_AFTER_RESET),
        (0x0033, STATUS_AFTER_RESET),
        (0x0555, STATUS_AFTER_RESET),
        (0x0655, STATUS_AFTER_RESET | 0x8000),
    ] {
        ex.extend(frame(f.din(cmd, &[]), f.dout(status_before, 0, 0)));
        ex.extend(frame(f.din(0, &[]), f.dout(cmd, 0, 0)));
    }
    // A wrong echo: UNLOCK answered by the LOCK echo.
    ex.extend(frame(f.din(0x0655, &[]), f.dout(STATUS_AFTER_RESET, 0, 0)));
    ex.extend(frame(f.din(0, &[]), f.dout(0x0555, 0, 0)));
    let mut d = driver(&ex);
    d.standby().unwrap();
    d.wakeup().unwrap();
    d.lock().unwrap();
    d.unlock().unwrap();
    assert_eq!(
        d.unlock(),
        Err(Error::UnexpectedResponse {
            command: Command::Unlock,
            response: 0x0555
        })
    );
    done(d);
}

#[test]
fn status_register_read_and_stuck_data_check() {
    let f = RESET_FMT;
    let config = Config {
        rx_crc: false,
        stuck_limit: 3,
        gains: [PgaGain::G4, PgaGain::G1],
        ..Config::default()
    };
    let mut ex = configure_frames(&config);
    // Two identical frames pass, the third is reported as stuck.
    for _ in 0..3 {
        ex.extend(frame(f.din(0, &[]), f.dout(STATUS_RUNNING, 100, -100)));
    }
    // A changed code clears the count.
    ex.extend(frame(f.din(0, &[]), f.dout(STATUS_RUNNING, 101, -100)));
    // STATUS via RREG 0x01: A080h.
    ex.extend(frame(f.din(0xA080, &[]), f.dout(STATUS_RUNNING, 0, 0)));
    ex.extend(frame(f.din(0, &[]), f.dout(0x0101, 0, 0)));
    let mut d = driver(&ex);
    d.configure(&config).unwrap();
    let first = d.read_frame().unwrap();
    assert_eq!(first.channels[0].gain(), PgaGain::G4);
    let v = first.channels[0].volts_f64().unwrap();
    assert!((v - 100.0 * 0.3 / 8_388_608.0).abs() < 1e-18);
    d.read_frame().unwrap();
    assert_eq!(d.read_frame(), Err(Error::StuckData { frames: 3 }));
    assert!(d.read_frame().is_ok());
    let s = d.status().unwrap();
    assert_eq!(s.drdy, [true, false]);
    done(d);
}

#[test]
fn responses_are_typed_by_the_command_they_answer() {
    let f = RESET_FMT;
    let mut ex = Vec::new();
    ex.extend(frame(f.din(0xA000, &[]), f.dout(STATUS_AFTER_RESET, 0, 0)));
    ex.extend(frame(f.din(0, &[]), f.dout(0x2201, 0, 0)));
    let mut d = driver(&ex);
    assert_eq!(d.read_register(Register::Id), Ok(0x2201));
    done(d);
    assert_eq!(
        Command::read(Register::Id).decode_response(0x2201),
        Ok(Response::Register(0x2201))
    );
}
