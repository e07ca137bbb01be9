//! The reference board: NUCLEO-H743ZI2 (STM32H743ZI, Cortex-M7 with a
//! double-precision FPU, here at 400 MHz) with an ADS131M02 strain-gauge
//! ADC and an AD5761R piezo DAC. Wiring, clocks and bring-up: docs/RIG.md.
//!
//! * [`clocks`] — the clock plan: 400 MHz core; CLKIN = 5.12 MHz on MCO2
//!   so the ADC converts at exactly 10 kSPS; 921,600 Bd exactly;
//! * [`drdy`] — DRDY on PF3 → EXTI line 3: the sample interrupt;
//! * [`uart`] — USART3 (ST-LINK virtual COM port), interrupt-driven rings;
//! * [`cycles`] — the DWT cycle counter and a busy-wait `DelayNs`;
//! * [`converters`] — the drivers as the pipeline's converter traits;
//! * [`shared`] — state shared by the sample interrupt and thread mode;
//! * `extra_ram` — the AXI and D2 SRAMs (the robust estimator's record)
//!   clocked and zeroed at boot.
//!
//! HAL: embassy-stm32 used in blocking mode only (clock tree, GPIO,
//! embedded-hal 1.0 SPI, USART set-up); no executor, no time driver, no
//! `exti` feature (this board owns `EXTI3`), no `memory-x` feature (the map
//! is `src/board/nucleo/memory.x`).
//!
//! Priorities ([`priority`]): DRDY (`EXTI3`) highest; `USART3` below it;
//! SysTick ([`WAKE_HZ`], an empty handler that only wakes thread mode from
//! `wfi`) lowest of the exceptions; thread mode (telemetry, modal
//! recovery, start-up, logging) below everything.
//!
//! # Pins (NUCLEO-H743ZI2 ST Zio / Arduino labels; docs/RIG.md has the table)
//! | Signal | Pin | Label | Function |
//! |---|---|---|---|
//! | ADC SCLK | PA5 | D13 | SPI1_SCK (AF5) |
//! | ADC DOUT → MCU | PA6 | D12 | SPI1_MISO (AF5) |
//! | ADC DIN ← MCU | PB5 | D11 | SPI1_MOSI (AF5) |
//! | ADC CS | PD14 | D10 | GPIO out |
//! | ADC DRDY | PF3 | D8 | EXTI3, falling edge |
//! | ADC SYNC/RESET | PG12 | D7 | GPIO out, high = run |
//! | ADC CLKIN | PC9 | D44 (Zio CN8 only) | MCO2 (AF0), 5.12 MHz |
//! | DAC SCLK | PE2 | D56 | SPI4_SCK (AF5), [`dac_write_clock`] |
//! | DAC SDO → MCU | PE5 | D58 | SPI4_MISO (AF5) |
//! | DAC SDI ← MCU | PE6 | D59 | SPI4_MOSI (AF5) |
//! | DAC SYNC (CS) | PE4 | D57 | GPIO out |
//! | DAC RESET | PG14 | D2 | GPIO out, high = run |
//! | DAC CLEAR | PE13 | D3 | GPIO out, high = run, low = 0 V |
//! | link TX / RX | PD8 / PD9 | ST-LINK VCP | USART3 (AF7) |
//! | heartbeat / fault | PB0 / PB14 | LD1 / LD3 | GPIO out |
//!
//! The pin-to-function pairs are checked by the compiler (embassy's
//! `SckPin<SPI1>` etc. traits come from ST's pin data); the connector
//! positions follow the board's Arduino/Zio labelling (STM32duino's and
//! Zephyr's NUCLEO-H743ZI2 pin tables): check them against the user manual
//! UM2407 before wiring (docs/RIG.md, bring-up step 0).

#![allow(unsafe_code)]
#![deny(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::panic,
    clippy::indexing_slicing
)]

pub mod clocks;
pub mod converters;
pub mod cycles;
pub mod drdy;
mod extra_ram;
pub mod shared;
pub mod uart;

use cortex_m::peripheral::scb::SystemHandler;
use cortex_m::peripheral::syst::SystClkSource;
use embassy_stm32::gpio::{Level, Output, Speed};
use embassy_stm32::interrupt::{self, InterruptExt};
use embassy_stm32::mode::Blocking;
use embassy_stm32::rcc::{Mco, McoConfig};
use embassy_stm32::spi::{self, Spi};
use embassy_stm32::time::Hertz;
use embassy_stm32::usart::{self, Uart};
use embassy_stm32::{pac, peripherals};
use embedded_hal::delay::DelayNs;
use embedded_hal_bus::spi::ExclusiveDevice;

use cycles::CycleDelay;

/// NVIC priorities (STM32H7: 4 priority bits; lower = more urgent).
pub mod priority {
    use embassy_stm32::interrupt::Priority;
    /// DRDY, the sample interrupt: preempts everything else.
    pub const SAMPLE: Priority = Priority::P0;
    /// USART3 TX/RX.
    pub const SERIAL: Priority = Priority::P4;
    /// SysTick, the thread-mode wake-up (raw 8-bit value: the lowest).
    pub const WAKE: u8 = 0xF0;
}

/// SysTick rate (Hz): thread mode wakes at least this often.
pub const WAKE_HZ: u32 = 100;

/// A blocking SPI bus with its chip select: an embedded-hal 1.0
/// `SpiDevice` for the drivers.
pub type SpiDev =
    ExclusiveDevice<Spi<'static, Blocking, spi::mode::Master>, Output<'static>, CycleDelay>;

/// Everything the firmware uses, initialised.
pub struct Board {
    /// SPI1 + CS (PD14): the ADS131M02.
    pub adc_spi: SpiDev,
    /// SPI4 + CS (PE4): the AD5761R, at [`clocks::DAC_READBACK_SCLK_HZ`]
    /// for `Ad5761r::init` (its read-back); [`dac_write_clock`] switches it
    /// to [`clocks::DAC_SCLK_HZ`] for the sample path.
    pub dac_spi: SpiDev,
    /// The sample tick (DRDY on PF3, EXTI3).
    pub drdy: drdy::Drdy,
    /// USART3, configured, not yet split.
    pub uart: uart::Usart3,
    /// ADS131M02 SYNC/RESET (PG12), high.
    pub adc_sync_reset: Output<'static>,
    /// AD5761R RESET (PG14), high after [`Board::init`]'s reset pulse.
    pub dac_reset: Output<'static>,
    /// AD5761R CLEAR (PE13), high (not clearing).
    pub dac_clear: Output<'static>,
    /// LD1 (green): thread-mode heartbeat.
    pub led_heartbeat: Output<'static>,
    /// LD3 (red): a fault was seen.
    pub led_fault: Output<'static>,
    /// Busy-wait delay on the 400 MHz core clock.
    pub delay: CycleDelay,
    _clkin: Mco<'static, peripherals::MCO2>,
}

/// What can stop [`Board::init`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum BoardError {
    /// The core peripherals were already taken.
    CorePeripheralsTaken,
    /// The HAL refused the USART settings.
    Usart,
    /// A chip-select pin could not be driven.
    ChipSelect,
    /// The HAL refused an SPI clock change.
    SpiClock,
}

impl core::fmt::Display for BoardError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(match self {
            Self::CorePeripheralsTaken => "core peripherals already taken",
            Self::Usart => "USART3 configuration refused",
            Self::ChipSelect => "chip-select pin error",
            Self::SpiClock => "SPI clock change refused",
        })
    }
}

impl core::error::Error for BoardError {}

/// Hold time of the ADS131M02's SYNC/RESET low for a reset: at least 2048
/// CLKIN periods (400 µs at 5.12 MHz, data sheet §8.4.1.2); 1 ms here.
const ADC_RESET_LOW_US: u32 = 1_000;
/// AD5761R RESET pulse and the wait after it (µs): generous against the
/// data sheet's timing table (not checked here, docs/RIG.md).
const DAC_RESET_US: u32 = 100;

fn spi_config(mode: embedded_hal::spi::Mode, sclk_hz: u32) -> spi::Config {
    let mut c = spi::Config::default();
    c.mode = spi::Mode {
        polarity: match mode.polarity {
            embedded_hal::spi::Polarity::IdleLow => spi::Polarity::IdleLow,
            embedded_hal::spi::Polarity::IdleHigh => spi::Polarity::IdleHigh,
        },
        phase: match mode.phase {
            embedded_hal::spi::Phase::CaptureOnFirstTransition => {
                spi::Phase::CaptureOnFirstTransition
            }
            embedded_hal::spi::Phase::CaptureOnSecondTransition => {
                spi::Phase::CaptureOnSecondTransition
            }
        },
    };
    c.frequency = Hertz(sclk_hz);
    c.gpio_speed = Speed::High;
    c
}

impl Board {
    /// Clocks, caches, cycle counter, pins, both SPI buses, CLKIN, DRDY
    /// (EXTI configured, NVIC line off), USART3 (NVIC line off), and the
    /// interrupt priorities. The converters are reset here by their pins
    /// (ADS131M02 SYNC/RESET low 1 ms with CLKIN running; AD5761R RESET
    /// pulse); their drivers do the rest.
    pub fn init() -> Result<Self, BoardError> {
        let mut cp = cortex_m::Peripherals::take().ok_or(BoardError::CorePeripheralsTaken)?;
        // The AXI and D2 SRAMs (the robust estimator's slots): clocked and
        // zeroed before anything touches their statics.
        extra_ram::init();
        // Code and constants come from flash through the AXI bus: cache
        // them. Data live in DTCM (memory.x), which is never cached, so the
        // debugger's RTT reads see what the core wrote; the robust
        // estimator's record in the AXI/D2 SRAMs is cached, and only the
        // core accesses it.
        cp.SCB.enable_icache();
        cp.SCB.enable_dcache(&mut cp.CPUID);
        cycles::start(&mut cp.DCB, &mut cp.DWT);
        // SysTick wakes thread mode from `wfi` even when no DRDY comes, so
        // it can notice that (the binary defines the empty handler).
        let mut syst = cp.SYST;
        syst.set_clock_source(SystClkSource::Core);
        syst.set_reload(clocks::CPU_HZ / WAKE_HZ - 1);
        syst.clear_current();
        syst.enable_interrupt();
        syst.enable_counter();
        // SAFETY: set before the interrupts that could be running are
        // enabled; the lowest priority never delays the sample interrupt.
        unsafe { cp.SCB.set_priority(SystemHandler::SysTick, priority::WAKE) };

        let p = embassy_stm32::init(clocks::hal_config());
        let mut delay = CycleDelay::new(clocks::CPU_HZ);

        // Both converters held in reset (the DAC's output at its power-on
        // level, not cleared) until their chip selects are driven high and
        // their buses configured, so neither sees a frame start or stray
        // clocks when it leaves reset.
        let mut dac_reset = Output::new(p.PG14, Level::Low, Speed::Low);
        let dac_clear = Output::new(p.PE13, Level::High, Speed::Low);
        let mut adc_sync_reset = Output::new(p.PG12, Level::Low, Speed::Low);
        let adc_cs = Output::new(p.PD14, Level::High, Speed::High);
        let dac_cs = Output::new(p.PE4, Level::High, Speed::High);

        let adc_bus = Spi::new_blocking(
            p.SPI1,
            p.PA5,
            p.PB5,
            p.PA6,
            spi_config(ads131m02::SPI_MODE, clocks::ADC_SCLK_HZ),
        );
        let adc_spi =
            ExclusiveDevice::new(adc_bus, adc_cs, delay).map_err(|_| BoardError::ChipSelect)?;

        let dac_bus = Spi::new_blocking(
            p.SPI4,
            p.PE2,
            p.PE6,
            p.PE5,
            spi_config(ad5761r::SPI_MODE, clocks::DAC_READBACK_SCLK_HZ),
        );
        let dac_spi =
            ExclusiveDevice::new(dac_bus, dac_cs, delay).map_err(|_| BoardError::ChipSelect)?;

        // CLKIN must run before the ADC leaves reset.
        let mut mco = McoConfig::default();
        mco.prescaler = clocks::MCO2_PRESCALER;
        mco.speed = Speed::Medium;
        let clkin = Mco::new(p.MCO2, p.PC9, clocks::MCO2_SOURCE, mco);
        delay.delay_us(ADC_RESET_LOW_US);
        adc_sync_reset.set_high();
        delay.delay_us(ads131m02::T_REGACQ_US);
        delay.delay_us(DAC_RESET_US);
        dac_reset.set_high();
        delay.delay_us(DAC_RESET_US);

        let drdy = drdy::Drdy::new(p.PF3);

        let mut uart_config = usart::Config::default();
        uart_config.baudrate = clocks::BAUD;
        let uart = Uart::new_blocking(p.USART3, p.PD9, p.PD8, uart_config)
            .map_err(|_| BoardError::Usart)?;
        let uart = uart::Usart3::from_hal(uart);

        interrupt::EXTI3.disable();
        interrupt::USART3.disable();
        interrupt::EXTI3.set_priority(priority::SAMPLE);
        interrupt::USART3.set_priority(priority::SERIAL);

        Ok(Self {
            adc_spi,
            dac_spi,
            drdy,
            uart,
            adc_sync_reset,
            dac_reset,
            dac_clear,
            led_heartbeat: Output::new(p.PB0, Level::Low, Speed::Low),
            led_fault: Output::new(p.PB14, Level::Low, Speed::Low),
            delay,
            _clkin: clkin,
        })
    }
}

/// Switch the AD5761R's bus from the read-back clock
/// ([`clocks::DAC_READBACK_SCLK_HZ`], set by [`Board::init`]) to the write
/// clock of the sample path ([`clocks::DAC_SCLK_HZ`]): call once
/// `Ad5761r::init` has read the control register back. Frames that read
/// SDO after this would run at the write clock: none do (the sample path
/// only writes).
pub fn dac_write_clock(dac_spi: &mut SpiDev) -> Result<(), BoardError> {
    dac_spi
        .bus_mut()
        .set_config(&spi_config(ad5761r::SPI_MODE, clocks::DAC_SCLK_HZ))
        .map_err(|()| BoardError::SpiClock)
}

/// Unmask the USART3 interrupt (after its handler's state is in place).
pub fn enable_serial_interrupt() {
    interrupt::USART3.unpend();
    // SAFETY: the handler's state is placed before this call; no
    // mask-based critical section is in use (critical sections use PRIMASK).
    unsafe { interrupt::USART3.enable() };
}

/// Unmask the sample interrupt (after the pipeline is in place and
/// [`converters::resync`] has drained the ADC and cleared older DRDY
/// edges). An edge pending now announces a conversion that came after the
/// drain, so it is kept: the first tick reads that conversion.
pub fn enable_sample_interrupt() {
    // SAFETY: as for `enable_serial_interrupt`.
    unsafe { interrupt::EXTI3.enable() };
}

/// Clear a DRDY edge the sample interrupt must not see (its conversion
/// was read, or drained, in thread mode): the EXTI flag and the NVIC's.
pub fn discard_sample_edge() {
    drdy::clear_pending();
    interrupt::EXTI3.unpend();
}

/// Mask the sample interrupt (before stopping the converters).
pub fn disable_sample_interrupt() {
    interrupt::EXTI3.disable();
}

/// Drive the piezo to 0 V from any context, even a fault handler: assert
/// the AD5761R's CLEAR (PE13 low; the DAC output goes to its clear code,
/// mid-scale = 0 V with the firmware's configuration) and light LD3. One
/// atomic write to each port's bit set/reset register (RM0433,
/// GPIOx_BSRR), so it needs no ownership of the pins.
pub fn safe_state() {
    pac::GPIOE.bsrr().write(|w| w.set_br(13, true));
    pac::GPIOB.bsrr().write(|w| w.set_bs(14, true));
}
