//! The real drivers against the behavioural chip models: the simulated
//! rig's converters agree with the drivers, and faults surface as driver
//! errors, never as samples.

mod common;

use std::cell::{Cell, RefCell};

use ad5761r::{Ad5761r, BipolarCoding, OutputRange, Reference, ScaleLevel};
use ads131m02::{Ads131m02, Command, Config, CrcType, Error, PgaGain, Rail, Register, WordLength};
use beamest::rig::chips::quantize;
use beamest::rig::chips::{Ad5761rModel, Ads131m02Model, ModelBusError, Shared};
use common::{crc16_bitwise, CCITT, DAC_SPANS};
use embedded_hal::spi::{ErrorType, Operation, SpiDevice};

struct NoDelay;

impl embedded_hal::delay::DelayNs for NoDelay {
    fn delay_ns(&mut self, _ns: u32) {}
}

type Adc<'a> = Ads131m02<Shared<'a, Ads131m02Model>>;

fn adc<'a>(model: &'a RefCell<Ads131m02Model>, config: &Config) -> Adc<'a> {
    let mut d = Ads131m02::new(Shared(model));
    assert_eq!(d.reset(&mut NoDelay), Ok(0x2200));
    d.configure(config).unwrap();
    d
}

/// One DRDY period of the simulated rig: set the inputs, convert, read.
fn sample<S: SpiDevice<Error = ModelBusError>>(
    d: &mut Ads131m02<S>,
    model: &RefCell<Ads131m02Model>,
    volts: [f64; 2],
) -> Result<ads131m02::Frame, Error<ModelBusError>> {
    {
        let mut m = model.borrow_mut();
        m.set_inputs(volts);
        m.convert();
    }
    d.read_frame()
}

fn fsr(gain: PgaGain) -> f64 {
    1.2 / f64::from(gain.factor())
}

#[test]
fn a_thousand_frames_of_a_known_signal_come_back_within_one_lsb() {
    let configs = [
        Config::default(),
        Config {
            word_length: WordLength::Bits16,
            crc_type: CrcType::Ansi,
            gains: [PgaGain::G8, PgaGain::G1],
            ..Config::default()
        },
        Config {
            word_length: WordLength::Bits32SignExtend,
            gains: [PgaGain::G2, PgaGain::G128],
            rx_crc: false,
            ..Config::default()
        },
        Config {
            word_length: WordLength::Bits32ZeroPad,
            crc_type: CrcType::Ansi,
            gains: [PgaGain::G32, PgaGain::G4],
            ..Config::default()
        },
    ];
    for config in configs {
        let model = RefCell::new(Ads131m02Model::new());
        let mut d = adc(&model, &config);
        let lsb_codes = if config.word_length == WordLength::Bits16 {
            256.0
        } else {
            1.0
        };
        for k in 0..1000 {
            let t = k as f64 * 1e-4;
            let v0 = 0.93 * fsr(config.gains[0]) * (2.0 * std::f64::consts::PI * 7.3 * t).sin();
            let v1 = -0.6 * fsr(config.gains[1]) * (2.0 * std::f64::consts::PI * 41.0 * t).cos();
            let f = sample(&mut d, &model, [v0, v1]).unwrap();
            for (ch, v) in [v0, v1].into_iter().enumerate() {
                let c = f.channels[ch];
                let lsb = fsr(config.gains[ch]) / 8_388_608.0 * lsb_codes;
                let got = c.volts_f64().unwrap();
                assert!((got - v).abs() <= lsb, "{config:?} k={k} ch={ch} {got} {v}");
                if config.word_length != WordLength::Bits16 {
                    assert_eq!(c.code(), quantize(v, config.gains[ch].factor()));
                }
            }
        }
        let stats = model.borrow().stats();
        // The driver's input CRC (when enabled) was right on every command.
        assert_eq!(stats.input_crc_errors, 0, "{config:?}");
        assert_eq!(stats.conversions, 1000);
    }
}

#[test]
fn register_reads_and_writes_agree_with_the_model() {
    let model = RefCell::new(Ads131m02Model::new());
    let mut d = adc(&model, &Config::default());
    let mut regs = [0u16; 3];
    d.read_registers(Register::Mode, &mut regs).unwrap();
    let m = model.borrow().register(Register::Mode);
    assert_eq!(regs, [m, 0x0306, 0x0000]);
    d.write_register(Register::Ch0OcalMsb, 0x1234).unwrap();
    assert_eq!(model.borrow().register(Register::Ch0OcalMsb), 0x1234);
    assert_eq!(d.read_register(Register::Ch0GcalMsb), Ok(0x8000));
    let s = d.status().unwrap();
    assert!(!s.reset && !s.crc_error);
    // Standby stops conversions: the next frame has no new data.
    d.standby().unwrap();
    assert!(model.borrow().is_standby());
    assert!(matches!(
        sample(&mut d, &model, [0.1, 0.1]),
        Err(Error::NoNewData(_))
    ));
    d.wakeup().unwrap();
    assert!(sample(&mut d, &model, [0.1, 0.1]).is_ok());
    // While locked the device ignores WREG and answers STATUS instead.
    d.lock().unwrap();
    assert!(matches!(
        d.write_register(Register::Gain, 0x0011),
        Err(Error::UnexpectedResponse { .. })
    ));
    assert_eq!(model.borrow().register(Register::Gain), 0x0000);
    d.unlock().unwrap();
    d.write_register(Register::Gain, 0x0011).unwrap();
    assert_eq!(model.borrow().register(Register::Gain), 0x0011);
}

#[test]
fn injected_faults_are_driver_errors() {
    let model = RefCell::new(Ads131m02Model::new());
    let config = Config {
        stuck_limit: 5,
        ..Config::default()
    };
    let mut d = adc(&model, &config);
    let x = [0.3, -0.2];
    assert!(sample(&mut d, &model, x).is_ok());

    // A corrupted frame: CRC error, then normal again.
    model.borrow_mut().inject_bad_crc(1);
    assert!(matches!(sample(&mut d, &model, x), Err(Error::Crc { .. })));
    assert!(sample(&mut d, &model, [0.31, -0.2]).is_ok());

    // Every 10th frame corrupted: exactly 10 errors in 100 frames.
    model.borrow_mut().set_bad_crc_period(10);
    let errors = (0..100)
        .filter(|&k| sample(&mut d, &model, [0.001 * k as f64, 0.0]).is_err())
        .count();
    assert_eq!(errors, 10);
    model.borrow_mut().set_bad_crc_period(0);

    // Stuck data: the front end repeats the last good code, so the fourth
    // stuck frame is the fifth identical one and is reported.
    assert!(sample(&mut d, &model, [0.123, 0.0]).is_ok());
    model.borrow_mut().set_stuck(true);
    let results: Vec<_> = (0..4)
        .map(|k| sample(&mut d, &model, [0.01 * k as f64, 0.0]))
        .collect();
    assert!(results[..3].iter().all(Result::is_ok));
    assert_eq!(results[3], Err(Error::StuckData { frames: 5 }));
    model.borrow_mut().set_stuck(false);
    assert!(sample(&mut d, &model, [0.2, 0.1]).is_ok());

    // Saturation: a valid frame whose conversions refuse to be volts.
    for rail in [Rail::High, Rail::Low] {
        model.borrow_mut().set_saturation(Some(rail));
        let f = sample(&mut d, &model, x).unwrap();
        for c in f.channels {
            assert_eq!(c.saturation(), Some(rail));
            assert_eq!(c.volts_f32().unwrap_err().rail, rail);
        }
    }
    model.borrow_mut().set_saturation(None);
    // An input beyond full scale saturates too.
    let f = sample(&mut d, &model, [1.5, -1.3]).unwrap();
    assert_eq!(f.channels[0].saturation(), Some(Rail::High));
    assert_eq!(f.channels[1].saturation(), Some(Rail::Low));

    // A dropped conversion: no new data, not a repeated sample.
    model.borrow_mut().drop_conversions(1);
    assert!(matches!(
        sample(&mut d, &model, x),
        Err(Error::NoNewData(_))
    ));
    assert!(sample(&mut d, &model, [0.05, 0.0]).is_ok());

    // A bus fault: reported, and the device state is untouched.
    model.borrow_mut().inject_bus_errors(1);
    assert_eq!(sample(&mut d, &model, x), Err(Error::Spi(ModelBusError)));
    assert!(sample(&mut d, &model, [0.06, 0.0]).is_ok());

    // A command garbled on DIN (bad input CRC) from elsewhere: the device
    // flags CRC_ERR and the driver reports it.
    let mut glitch = [0u8; 12];
    glitch[3] = 0xAB; // wrong input CRC word after NULL
    model
        .borrow_mut()
        .transaction(&mut [Operation::TransferInPlace(&mut glitch)])
        .unwrap();
    assert!(matches!(sample(&mut d, &model, x), Err(Error::InputCrc(_))));
    assert_eq!(model.borrow().stats().input_crc_errors, 1);

    // A brown-out: the device lost its settings.
    model.borrow_mut().brown_out();
    assert!(matches!(
        sample(&mut d, &model, x),
        Err(Error::UnexpectedReset(_))
    ));
    // Recovery: reset and configure again.
    assert_eq!(d.reset(&mut NoDelay), Ok(0x2200));
    d.configure(&config).unwrap();
    assert!(sample(&mut d, &model, [0.07, 0.0]).is_ok());
}

/// The model behind a link that drops the transaction `fail_in` counts
/// down to (1 = the next one); 0 = never.
struct FlakyLink<'a> {
    model: Shared<'a, Ads131m02Model>,
    fail_in: &'a Cell<u32>,
}

impl ErrorType for FlakyLink<'_> {
    type Error = ModelBusError;
}

impl SpiDevice for FlakyLink<'_> {
    fn transaction(&mut self, ops: &mut [Operation<'_, u8>]) -> Result<(), ModelBusError> {
        let n = self.fail_in.get();
        self.fail_in.set(n.saturating_sub(1));
        if n == 1 {
            return Err(ModelBusError);
        }
        self.model.transaction(ops)
    }
}

#[test]
fn an_answer_owed_after_a_failed_operation_is_not_a_sample() {
    let model = RefCell::new(Ads131m02Model::new());
    let fail_in = Cell::new(0);
    let link = FlakyLink {
        model: Shared(&model),
        fail_in: &fail_in,
    };
    let mut d = Ads131m02::new(link);
    d.reset(&mut NoDelay).unwrap();
    d.configure(&Config::default()).unwrap();
    // The RREG frame goes through, the frame collecting its answer is lost.
    fail_in.set(2);
    let mut regs = [0u16; 4];
    assert_eq!(
        d.read_registers(Register::Mode, &mut regs),
        Err(Error::Spi(ModelBusError))
    );
    let owed = Command::ReadRegisters { start: 2, count: 4 };
    assert_eq!(d.pending(), owed);
    model.borrow_mut().set_inputs([0.2, 0.1]);
    model.borrow_mut().convert();
    // The next frame is the long answer (no ADC data): an error, no sample.
    assert_eq!(d.read_frame(), Err(Error::OwedResponse { command: owed }));
    // Then back to normal.
    let f = sample(&mut d, &model, [0.2, 0.1]).unwrap();
    assert_eq!(f.channels[0].code(), quantize(0.2, 1));
}

#[test]
fn another_part_fails_the_id_check() {
    let model = RefCell::new(Ads131m02Model::new());
    model.borrow_mut().set_id(0x2400);
    let mut d = Ads131m02::new(Shared(&model));
    assert_eq!(d.reset(&mut NoDelay), Err(Error::IdMismatch(0x2400)));
    model.borrow_mut().set_id(0x2205);
    assert_eq!(d.reset(&mut NoDelay), Ok(0x2205));
}

#[test]
fn the_model_answers_raw_frames_like_the_data_sheet() {
    let mut m = Ads131m02Model::new();
    let mut frame = [0u8; 12];
    // RESET, then a NULL frame whose DOUT is FF22h + zeros + CRC 6081h.
    frame[..3].copy_from_slice(&[0x00, 0x11, 0x00]);
    m.transaction(&mut [Operation::TransferInPlace(&mut frame)])
        .unwrap();
    let mut frame = [0u8; 12];
    m.transaction(&mut [Operation::TransferInPlace(&mut frame)])
        .unwrap();
    assert_eq!(frame, [0xFF, 0x22, 0, 0, 0, 0, 0, 0, 0, 0x60, 0x81, 0]);
    assert_eq!(crc16_bitwise(CCITT, &frame[..9]), 0x6081);
    // An incomplete RESET frame is not latched and answers 0011h.
    let mut short = [0x00, 0x11, 0x00, 0, 0, 0];
    m.transaction(&mut [Operation::TransferInPlace(&mut short)])
        .unwrap();
    let mut frame = [0u8; 12];
    m.transaction(&mut [Operation::TransferInPlace(&mut frame)])
        .unwrap();
    assert_eq!(&frame[..3], &[0x00, 0x11, 0x00]);
    // One frame split over Write and Read operations: WREG CLOCK whose
    // data word is clocked as zeros by the Read.
    let mut rx = [0u8; 9];
    m.transaction(&mut [
        Operation::Write(&[0x61, 0x80, 0x00]),
        Operation::Read(&mut rx),
    ])
    .unwrap();
    assert_eq!(m.register(Register::Clock), 0x0000);
    // Enable the input CRC: WREG MODE 1110h (RX_CRC_EN, 24-bit, TIMEOUT).
    let mut f = [0u8; 12];
    f[..6].copy_from_slice(&[0x61, 0x00, 0x00, 0x11, 0x10, 0x00]);
    m.transaction(&mut [Operation::TransferInPlace(&mut f)])
        .unwrap();
    assert!(m.format().rx_crc);
    // With input CRC on, WREG executes even with a bad CRC (§8.3.12).
    let mut f = [0u8; 12];
    f[..9].copy_from_slice(&[0x62, 0x00, 0x00, 0x00, 0x33, 0x00, 0xDE, 0xAD, 0x00]);
    m.transaction(&mut [Operation::TransferInPlace(&mut f)])
        .unwrap();
    assert_eq!(m.register(Register::Gain), 0x0033);
    assert_eq!(m.stats().input_crc_errors, 1);
    assert!(m.register(Register::Status) & (1 << 12) != 0);
    assert_eq!(
        Command::from_word(0x6200),
        Some(Command::write(Register::Gain))
    );
}

fn dac<'a>(
    model: &'a RefCell<Ad5761rModel>,
    config: ad5761r::Config,
) -> Ad5761r<Shared<'a, Ad5761rModel>> {
    let mut d = Ad5761r::new(Shared(model));
    d.init(config).unwrap();
    d
}

#[test]
fn dac_codes_round_trip_to_the_model_voltage_within_one_lsb() {
    for (range, (lo, hi)) in OutputRange::ALL.into_iter().zip(DAC_SPANS) {
        for coding in [BipolarCoding::StraightBinary, BipolarCoding::TwosComplement] {
            let model = RefCell::new(Ad5761rModel::new());
            assert!(model.borrow().is_clamped());
            assert_eq!(model.borrow().output_volts(), 0.0);
            let config = ad5761r::Config {
                range,
                coding,
                ..ad5761r::Config::default()
            };
            let mut d = dac(&model, config);
            // Power-up level: mid-scale.
            let mid = (lo + hi) / 2.0;
            assert!(
                (model.borrow().output_volts() - mid).abs() < 1e-9,
                "{range:?}"
            );
            let lsb = (hi - lo) / 65536.0;
            for k in 0..=200 {
                let v = lo + (hi - lo - lsb) * f64::from(k) / 200.0;
                let w = d.write_volts(v as f32).unwrap();
                assert_eq!(w.clamped, None);
                let out = model.borrow().output_volts();
                assert!((out - v).abs() <= lsb, "{range:?} {coding:?} {v} -> {out}");
                assert_eq!(d.read_dac(), Ok(model.borrow().dac_code()));
            }
            // Saturation at both rails: reported, output at the rail.
            let w = d.write_volts((hi + 1.0) as f32).unwrap();
            assert_eq!(w.clamped, Some(ad5761r::Rail::High));
            assert!((model.borrow().output_volts() - (hi - lsb)).abs() < 1e-9);
            let w = d.write_volts((lo - 1.0) as f32).unwrap();
            assert_eq!(w.clamped, Some(ad5761r::Rail::Low));
            assert!((model.borrow().output_volts() - lo).abs() < 1e-9);
        }
    }
}

#[test]
fn dac_resets_reference_and_faults() {
    let model = RefCell::new(Ad5761rModel::new());
    let mut d = dac(&model, ad5761r::Config::default());
    d.write_volts(3.0).unwrap();
    assert!((model.borrow().output_volts() - 3.0).abs() < 2e-4);
    // Software data reset: back to the power-up level (0 V).
    d.software_data_reset().unwrap();
    assert_eq!(model.borrow().output_volts(), 0.0);
    // Full reset: clamped again, the driver forgets its configuration.
    d.write_volts(3.0).unwrap();
    d.software_full_reset().unwrap();
    assert!(model.borrow().is_clamped());
    assert_eq!(model.borrow().output_volts(), 0.0);
    assert_eq!(d.write_volts(1.0), Err(ad5761r::Error::NotConfigured));
    // Zero-scale power-up on ±10 V is the negative rail: the hazard the
    // driver docs warn about.
    let zero = ad5761r::Config {
        power_up: ScaleLevel::Zero,
        ..ad5761r::Config::default()
    };
    d.init(zero).unwrap();
    assert_eq!(model.borrow().output_volts(), -10.0);
    // External reference: no REFIN, no output; 2.048 V scales the range.
    let ext = ad5761r::Config {
        reference: Reference::External { volts: 2.048 },
        ..ad5761r::Config::default()
    };
    d.init(ext).unwrap();
    d.write_volts(4.0).unwrap();
    assert_eq!(model.borrow().output_volts(), 0.0);
    model.borrow_mut().set_external_reference(2.048);
    assert!((model.borrow().output_volts() - 4.0).abs() < 2e-4);
    // A bus fault is the driver's SPI error.
    model.borrow_mut().inject_bus_errors(1);
    assert_eq!(d.write_volts(1.0), Err(ad5761r::Error::Spi(ModelBusError)));
    assert!((model.borrow().output_volts() - 4.0).abs() < 2e-4);
}
