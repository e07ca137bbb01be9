//! AD5761R driver, every transaction checked byte for byte against the
//! data sheet's 24-bit input shift register (DB19:16 command, DB15:0 data)
//! and readback format (Tables 14/15), with embedded-hal-mock.

mod common;

use ad5761r::{
    Ad5761r, BipolarCoding, Config, ConfigError, DacWrite, Error, OutputRange, Rail, Reference,
    ScaleLevel,
};
use common::{frame, write, FailingSpi, DAC_SPANS};
use embedded_hal::spi::ErrorKind;
use embedded_hal_mock::eh1::spi::{Mock, Transaction};

/// The bytes `init` sends for control bits `ctrl`, and the readback the
/// device answers with `readback` (24 bits).
fn init_frames(ctrl: u16, readback: [u8; 3]) -> Vec<Transaction<u8>> {
    let mut ex = Vec::new();
    ex.extend(write(vec![0x0F, 0x00, 0x00])); // software full reset
    ex.extend(write(vec![0x09, 0x00, 0x00])); // daisy chain (SDO) on
    ex.extend(write(vec![0x04, (ctrl >> 8) as u8, ctrl as u8])); // control
    ex.extend(write(vec![0x0C, 0x00, 0x00])); // readback control
    ex.extend(frame(vec![0x00, 0x00, 0x00], readback.to_vec())); // NOP
    ex
}

fn echo(ctrl: u16) -> [u8; 3] {
    [0x0C, (ctrl >> 8) as u8, ctrl as u8]
}

#[test]
fn init_resets_writes_and_verifies_the_control_register() {
    let config = Config::default();
    // CV=01 (bits 10:9), ETS (6), IRO (5), PV=01 (4:3), RA=000: 0268h.
    assert_eq!(config.control().to_bits(), 0x0268);
    // Readback with DB23:21 and DB15:13 set (don't care), SC and BO set.
    let ex = init_frames(0x0268, [0xEC, 0xFA, 0x68]);
    let mut d = Ad5761r::new(Mock::new(&ex));
    let rb = d.init(config).unwrap();
    assert_eq!(rb.control, config.control());
    assert!(rb.short_circuit && rb.brownout);
    assert_eq!(d.config(), Some(&config));
    d.destroy().done();
}

#[test]
fn init_errors() {
    // Control bits read back differently.
    let ex = init_frames(0x0268, echo(0x0260));
    let mut d = Ad5761r::new(Mock::new(&ex));
    assert_eq!(
        d.init(Config::default()),
        Err(Error::ConfigMismatch {
            wrote: 0x0268,
            read: 0x0260
        })
    );
    assert_eq!(d.write_volts(0.0), Err(Error::NotConfigured));
    d.destroy().done();
    // The NOP frame does not echo 1100 (it echoes 1011).
    let ex = init_frames(0x0268, [0x0B, 0x02, 0x68]);
    let mut d = Ad5761r::new(Mock::new(&ex));
    assert_eq!(
        d.init(Config::default()),
        Err(Error::UnexpectedReadback {
            command: 0x0C,
            word: 0x0B0268
        })
    );
    d.destroy().done();
    // DB20 must be 0.
    let ex = init_frames(0x0268, [0x1C, 0x02, 0x68]);
    let mut d = Ad5761r::new(Mock::new(&ex));
    assert!(matches!(
        d.init(Config::default()),
        Err(Error::UnexpectedReadback { .. })
    ));
    d.destroy().done();
    // PV = 11 is not a level this driver knows.
    let ex = init_frames(0x0268, echo(0x0278));
    let mut d = Ad5761r::new(Mock::new(&ex));
    assert!(matches!(
        d.init(Config::default()),
        Err(Error::UnexpectedReadback { command: 0x0C, .. })
    ));
    d.destroy().done();
    // A bad external reference is refused before any bus traffic.
    let mut d = Ad5761r::new(Mock::new(&[]));
    let bad = Config {
        reference: Reference::External { volts: f32::NAN },
        ..Config::default()
    };
    assert_eq!(
        d.init(bad),
        Err(Error::InvalidConfig(ConfigError::ReferenceVoltage))
    );
    d.destroy().done();
}

/// Independent volts → straight-binary code: the range's span is 2¹⁶ LSBs
/// from its low end.
fn expected_code(lo: f64, hi: f64, v: f64) -> u16 {
    let x = (v - lo) / (hi - lo) * 65536.0;
    x.round().clamp(0.0, 65535.0) as u16
}

#[test]
fn volts_to_code_for_every_range_and_coding_with_saturation() {
    for (ra, (range, (lo, hi))) in OutputRange::ALL.iter().zip(DAC_SPANS).enumerate() {
        for coding in [BipolarCoding::StraightBinary, BipolarCoding::TwosComplement] {
            let config = Config {
                range: *range,
                coding,
                ..Config::default()
            };
            let ctrl = config.control().to_bits();
            assert_eq!(ctrl & 0x7, ra as u16);
            assert_eq!(ctrl >> 7 & 1, coding as u16);
            let xor = if lo < 0.0 && coding == BipolarCoding::TwosComplement {
                0x8000
            } else {
                0
            };
            let lsb = (hi - lo) / 65536.0;
            let requests = [
                (lo, None),
                (lo + 12_345.3 * lsb, None),
                (lo + 40_000.7 * lsb, None),
                (hi - 1.2 * lsb, None),
                // Beyond the rails: clamped and reported, never wrapped.
                (hi, Some(Rail::High)),
                (hi + 3.0, Some(Rail::High)),
                (lo - 0.6 * lsb, Some(Rail::Low)),
                (lo - 3.0, Some(Rail::Low)),
            ];
            let mut ex = init_frames(ctrl, echo(ctrl));
            let mut expect = Vec::new();
            for &(v, rail) in &requests {
                let code = expected_code(lo, hi, v) ^ xor;
                ex.extend(write(vec![0x03, (code >> 8) as u8, code as u8]));
                expect.push(DacWrite {
                    code,
                    clamped: rail,
                });
            }
            let mut d = Ad5761r::new(Mock::new(&ex));
            d.init(config).unwrap();
            for (&(v, _), e) in requests.iter().zip(expect) {
                assert_eq!(d.write_volts(v as f32), Ok(e), "{range:?} {coding:?} {v}");
            }
            // NaN and ∞ write nothing.
            assert_eq!(d.write_volts(f32::NAN), Err(Error::NotFinite));
            assert_eq!(d.write_volts(f32::NEG_INFINITY), Err(Error::NotFinite));
            d.destroy().done();
        }
    }
}

#[test]
fn raw_codes_readbacks_and_resets() {
    let mut ex = Vec::new();
    ex.extend(write(vec![0x03, 0xBE, 0xEF])); // write and update DAC
    ex.extend(write(vec![0x0B, 0x00, 0x00])); // readback DAC register
    ex.extend(frame(vec![0; 3], vec![0x0B, 0xBE, 0xEF]));
    ex.extend(write(vec![0x0A, 0x00, 0x00])); // readback input register
    ex.extend(frame(vec![0; 3], vec![0xEA, 0x12, 0x34]));
    ex.extend(write(vec![0x07, 0x00, 0x00])); // software data reset
    ex.extend(write(vec![0x0F, 0x00, 0x00])); // software full reset
    let mut d = Ad5761r::new(Mock::new(&ex));
    d.write_code(0xBEEF).unwrap();
    assert_eq!(d.read_dac(), Ok(0xBEEF));
    assert_eq!(d.read_input(), Ok(0x1234));
    d.software_data_reset().unwrap();
    d.software_full_reset().unwrap();
    assert_eq!(d.config(), None);
    assert_eq!(d.write_volts(1.0), Err(Error::NotConfigured));
    d.destroy().done();
}

#[test]
fn external_reference_scales_the_transfer_function() {
    let config = Config {
        range: OutputRange::Unipolar10V,
        reference: Reference::External { volts: 2.048 },
        power_up: ScaleLevel::Zero,
        ..Config::default()
    };
    // IRO clear.
    let ctrl = config.control().to_bits();
    assert_eq!(ctrl & (1 << 5), 0);
    let mut ex = init_frames(ctrl, echo(ctrl));
    // 0–10 V range on a 2.048 V reference spans 0–8.192 V: 4.096 V is
    // mid-scale.
    ex.extend(write(vec![0x03, 0x80, 0x00]));
    let mut d = Ad5761r::new(Mock::new(&ex));
    d.init(config).unwrap();
    assert_eq!(d.write_volts(4.096).unwrap().code, 0x8000);
    d.destroy().done();
}

#[test]
fn spi_errors_are_reported() {
    let mut d = Ad5761r::new(FailingSpi(ErrorKind::Overrun));
    assert_eq!(
        d.init(Config::default()),
        Err(Error::Spi(ErrorKind::Overrun))
    );
    assert_eq!(d.write_code(0), Err(Error::Spi(ErrorKind::Overrun)));
    let e = d.read_dac().unwrap_err();
    assert!(e.to_string().contains("SPI error"));
    let _: &dyn core::error::Error = &e;
}

#[test]
fn error_messages_name_the_chip_and_are_distinct() {
    let errors: [Error<ErrorKind>; 6] = [
        Error::Spi(ErrorKind::Other),
        Error::NotConfigured,
        Error::NotFinite,
        Error::InvalidConfig(ConfigError::ReferenceVoltage),
        Error::ConfigMismatch {
            wrote: 0x268,
            read: 0x068,
        },
        Error::UnexpectedReadback {
            command: 0xC,
            word: 0x0B_0268,
        },
    ];
    let messages: Vec<String> = errors.iter().map(|e| e.to_string()).collect();
    for (i, m) in messages.iter().enumerate() {
        assert!(m.starts_with("AD5761R: "), "{m}");
        assert!(!m.contains('\n'), "{m}");
        for other in &messages[i + 1..] {
            assert_ne!(m, other);
        }
    }
    assert_eq!(Rail::Low.to_string(), "low rail");
    assert_eq!(Rail::High.to_string(), "high rail");
}
