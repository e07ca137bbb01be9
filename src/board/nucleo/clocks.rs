//! The clock tree of the reference board: a 400 MHz core, and an ADC clock
//! (CLKIN) of exactly 5.12 MHz, so that the ADS131M02 converts at exactly
//! f_DATA = f_CLKIN/(2·OSR) = 5.12 MHz/(2·256) = 10,000 samples/s, locked
//! to the MCU's clock.
//!
//! # Source
//! HSE = 8 MHz in bypass mode: the NUCLEO-H743ZI2 feeds PH0-OSC_IN from the
//! ST-LINK's MCO (8 MHz, the board's default configuration; UM2407
//! "HSE clock (high-speed external clock)"). All three PLLs run from it
//! (RM0433, RCC_PLLCKSELR.PLLSRC: one source for all three PLLs).
//!
//! # Plan (every number is checked at compile time below)
//! ```text
//! PLL1: 8 MHz /M1=1 = 8 MHz ref (PLL1RGE 8–16 MHz) ×N1=100 = 800 MHz VCO (wide)
//!       /P1=2 = 400 MHz sys_ck → CPU 400 MHz (D1CPRE /1)
//!                                 AHB 200 MHz (HPRE /2), APB1..4 100 MHz (/2)
//!       /Q1=5 = 160 MHz pll1_q → SPI1 kernel clock (SPI123SEL reset value)
//! PLL2: 8 MHz /M2=2 = 4 MHz ref (PLL2RGE 4–8 MHz)  ×N2=128 = 512 MHz VCO (wide)
//!       /P2=10 = 51.2 MHz pll2_p → MCO2 /10 = 5.12 MHz on PC9 → ADS131M02 CLKIN
//! PLL3: 8 MHz /M3=1 = 8 MHz ref (PLL3RGE 8–16 MHz) ×N3=72 = 576 MHz VCO (wide)
//!       /Q3=25 = 23.04 MHz pll3_q → USART3 kernel clock: BRR = 25 → 921,600 Bd exactly
//! SPI4 (DAC): kernel = APB2 = 100 MHz (SPI45SEL reset value)
//! ```
//! Limits (RM0433 registers RCC_PLLCKSELR, RCC_PLLCFGR, RCC_PLLxDIVR,
//! RCC_CFGR; STM32H743 data sheet DS12110, table "PLL characteristics (wide
//! VCO frequency range)"): reference 1–16 MHz, 2–16 MHz for the wide VCO;
//! wide VCO 192–836 MHz (the 960 MHz of revision V needs VOS0, not used
//! here); DIVM 1–63, DIVN 4–512, DIVP/Q/R 1–128 with DIVP1 even; MCO2PRE
//! 1–15. Voltage scale 1: CPU ≤ 400 MHz, AHB ≤ 200 MHz, APB ≤ 100 MHz
//! (DS12110, "General operating conditions"; embassy-stm32 asserts the same
//! limits when it applies the configuration).
//!
//! # Exactness
//! No fractional-N anywhere (FRACEN = 0), so every output is an exact
//! rational multiple of the HSE: CLKIN = 8 MHz·128/(2·10·10) = 5.12 MHz,
//! f_DATA = CLKIN/512 = 10 kHz, baud = 8 MHz·72/(25·25·16) = 921,600 Bd.
//! Their absolute accuracy is that of the ST-LINK's crystal (not specified
//! here: measure CLKIN with a counter at bring-up, docs/RIG.md).

use embassy_stm32::rcc::mux::{Saisel, Spi45sel, Usart234578sel};
use embassy_stm32::rcc::{
    AHBPrescaler, APBPrescaler, Hse, HseMode, Mco2Source, McoPrescaler, Pll, PllDiv, PllMul,
    PllPreDiv, PllSource, Sysclk, VoltageScale,
};
use embassy_stm32::time::Hertz;

/// HSE from the ST-LINK MCO (Hz).
pub const HSE_HZ: u32 = 8_000_000;

/// A PLL's integer settings (DIVx = 0: output disabled).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct PllPlan {
    /// DIVM, pre-divider.
    pub m: u32,
    /// DIVN, multiplier.
    pub n: u32,
    /// DIVP (0 = off).
    pub p: u32,
    /// DIVQ (0 = off).
    pub q: u32,
}

impl PllPlan {
    /// Reference frequency at the phase detector (Hz).
    pub const fn ref_hz(&self) -> u32 {
        HSE_HZ / self.m
    }

    /// VCO frequency (Hz).
    pub const fn vco_hz(&self) -> u32 {
        self.ref_hz() * self.n
    }

    /// P output (Hz).
    pub const fn p_hz(&self) -> u32 {
        self.vco_hz() / self.p
    }

    /// Q output (Hz).
    pub const fn q_hz(&self) -> u32 {
        self.vco_hz() / self.q
    }

    /// Every RM0433 / DS12110 limit listed in the module doc, and exact
    /// division wherever an output is used.
    const fn is_valid(&self) -> bool {
        let reference_ok = HSE_HZ % self.m == 0 && self.ref_hz() >= 2_000_000;
        let ranges_ok = self.m >= 1
            && self.m <= 63
            && self.n >= 4
            && self.n <= 512
            && self.p <= 128
            && self.q <= 128
            && self.ref_hz() <= 16_000_000;
        let vco_ok = self.vco_hz() >= 192_000_000 && self.vco_hz() <= 836_000_000;
        let exact = (self.p == 0 || self.vco_hz() % self.p == 0)
            && (self.q == 0 || self.vco_hz() % self.q == 0);
        reference_ok && ranges_ok && vco_ok && exact
    }
}

/// PLL1: system clock and the SPI1 kernel clock.
pub const PLL1: PllPlan = PllPlan {
    m: 1,
    n: 100,
    p: 2,
    q: 5,
};
/// PLL2: the ADC clock through MCO2.
pub const PLL2: PllPlan = PllPlan {
    m: 2,
    n: 128,
    p: 10,
    q: 0,
};
/// PLL3: the USART3 kernel clock.
pub const PLL3: PllPlan = PllPlan {
    m: 1,
    n: 72,
    p: 0,
    q: 25,
};

/// CPU clock (Hz): sys_ck = PLL1 P, D1CPRE /1.
pub const CPU_HZ: u32 = PLL1.p_hz();
/// AHB clock (Hz): HPRE /2.
pub const AHB_HZ: u32 = CPU_HZ / 2;
/// APB1..APB4 clocks (Hz): each /2 from the AHB.
pub const APB_HZ: u32 = AHB_HZ / 2;

/// MCO2 prescaler (MCO2PRE).
pub const MCO2_DIV: u32 = 10;
/// The ADS131M02 CLKIN on PC9 (Hz).
pub const CLKIN_HZ: u32 = PLL2.p_hz() / MCO2_DIV;
/// ADS131M02 oversampling ratio (CLOCK.OSR = 256, the driver's default).
pub const ADC_OSR: u32 = 256;
/// The ADC's output data rate (Hz): f_CLKIN/(2·OSR) (ADS131M02 data sheet
/// §8.3.5: f_MOD = f_CLKIN/2; §8.3.7: f_DATA = f_MOD/OSR).
pub const SAMPLE_RATE_HZ: u32 = CLKIN_HZ / (2 * ADC_OSR);
/// CPU cycles per sample period: the sample interrupt's budget.
pub const CYCLES_PER_SAMPLE: u32 = CPU_HZ / SAMPLE_RATE_HZ;

/// SPI1 kernel clock (Hz): pll1_q.
pub const SPI1_KERNEL_HZ: u32 = PLL1.q_hz();
/// SPI4 kernel clock (Hz): APB2.
pub const SPI4_KERNEL_HZ: u32 = APB_HZ;
/// ADC SCLK (Hz): SPI1 kernel /16. The ADS131M02 allows up to 25 MHz
/// (t_c(SC) ≥ 40 ns, data sheet §6.6); 10 MHz leaves margin for jumper
/// wires and clocks a 12-byte frame in 9.6 µs.
pub const ADC_SCLK_HZ: u32 = SPI1_KERNEL_HZ / 16;
/// DAC SCLK (Hz) for writes (the sample path): SPI4 kernel /8 (the
/// AD5761R's write clock is specified well above this; 3 bytes take 1.9 µs).
pub const DAC_SCLK_HZ: u32 = SPI4_KERNEL_HZ / 8;
/// DAC SCLK (Hz) during `Ad5761r::init` (software reset, control write
/// and its read-back: five 24-bit frames, 77 µs at boot): SPI4 kernel /64
/// = 1.5625 MHz, 320 ns per half period. In SPI mode 1 the AD5761R changes
/// SDO on one SCLK edge and the STM32 samples MISO on the next, half a
/// period later; at 12.5 MHz that is 40 ns, which must cover the DAC's
/// SDO-valid delay, the wires and the STM32H743's MISO set-up. The AD5761R
/// data sheet's read-back timing (its SCLK limit with SDO in use and the
/// SDO-valid delay) could not be read here, and ADI's serial DACs commonly
/// let SDO lag SCLK by 25–40 ns (e.g. the AD5686R data sheet, Table 5:
/// t10 ≤ 25 ns and SCLK cycle ≥ 40 ns for daisy-chain and read-back), so
/// 12.5 MHz is not shown to be safe for read-back; 320 ns is eight times
/// the 40 ns. The sample path's writes run at [`DAC_SCLK_HZ`]
/// (`board::nucleo::dac_write_clock`, called after the read-back). Not
/// verified on hardware.
pub const DAC_READBACK_SCLK_HZ: u32 = SPI4_KERNEL_HZ / 64;

/// USART3 kernel clock (Hz): pll3_q.
pub const USART3_KERNEL_HZ: u32 = PLL3.q_hz();
/// The serial link's rate (Bd).
pub const BAUD: u32 = 921_600;
/// USART3 BRR with 16× oversampling (RM0433, USART_BRR: baud = f_ck/USARTDIV).
pub const USART3_BRR: u32 = USART3_KERNEL_HZ / BAUD;

// ---- Compile-time checks of the plan ----
const _: () = assert!(PLL1.is_valid() && PLL2.is_valid() && PLL3.is_valid());
// DIVP1 must be even (RM0433, RCC_PLL1DIVR.DIVP1: odd values not allowed).
const _: () = assert!(PLL1.p % 2 == 0);
const _: () = assert!(CPU_HZ == 400_000_000 && AHB_HZ <= 200_000_000 && APB_HZ <= 100_000_000);
const _: () = assert!(MCO2_DIV >= 1 && MCO2_DIV <= 15 && PLL2.p_hz() % MCO2_DIV == 0);
// Exactly 10 kHz from exactly 5.12 MHz (ADS131M02 HR mode: CLKIN 0.3–8.4 MHz,
// data sheet §6.3).
const _: () = assert!(CLKIN_HZ == 5_120_000 && CLKIN_HZ % (2 * ADC_OSR) == 0);
const _: () = assert!(SAMPLE_RATE_HZ == 10_000 && CPU_HZ % SAMPLE_RATE_HZ == 0);
const _: () = assert!(CLKIN_HZ >= 300_000 && CLKIN_HZ <= 8_400_000);
// SPI prescalers are powers of two, 2..=256 (RM0433, SPI_CFG1.MBR).
const _: () = assert!(ADC_SCLK_HZ == 10_000_000 && SPI1_KERNEL_HZ % ADC_SCLK_HZ == 0);
const _: () = assert!(ADC_SCLK_HZ <= 25_000_000);
const _: () = assert!(DAC_SCLK_HZ == 12_500_000 && SPI4_KERNEL_HZ % DAC_SCLK_HZ == 0);
const _: () =
    assert!(DAC_READBACK_SCLK_HZ == 1_562_500 && SPI4_KERNEL_HZ % DAC_READBACK_SCLK_HZ == 0);
// 921,600 Bd with no rounding: BRR ≥ 16 with 16× oversampling (RM0433,
// USART_BRR) and exact.
const _: () = assert!(USART3_KERNEL_HZ % BAUD == 0 && USART3_BRR >= 16);

fn pll(plan: PllPlan) -> Pll {
    let div = |d: u32| {
        if d == 0 {
            None
        } else {
            Some(PllDiv::from_bits((d - 1) as u8))
        }
    };
    Pll {
        source: PllSource::HSE,
        prediv: PllPreDiv::from_bits(plan.m as u8),
        mul: PllMul::from_bits((plan.n - 1) as u16),
        fracn: None,
        divp: div(plan.p),
        divq: div(plan.q),
        divr: None,
    }
}

/// The embassy-stm32 configuration for this plan.
pub fn hal_config() -> embassy_stm32::Config {
    let mut config = embassy_stm32::Config::default();
    let rcc = &mut config.rcc;
    rcc.hsi = None;
    rcc.csi = false;
    rcc.hsi48 = None;
    rcc.hse = Some(Hse {
        freq: Hertz(HSE_HZ),
        mode: HseMode::Bypass,
    });
    rcc.pll1 = Some(pll(PLL1));
    rcc.pll2 = Some(pll(PLL2));
    rcc.pll3 = Some(pll(PLL3));
    rcc.sys = Sysclk::PLL1_P;
    rcc.d1c_pre = AHBPrescaler::DIV1;
    rcc.ahb_pre = AHBPrescaler::DIV2;
    rcc.apb1_pre = APBPrescaler::DIV2;
    rcc.apb2_pre = APBPrescaler::DIV2;
    rcc.apb3_pre = APBPrescaler::DIV2;
    rcc.apb4_pre = APBPrescaler::DIV2;
    rcc.voltage_scale = VoltageScale::Scale1;
    rcc.mux.spi123sel = Saisel::PLL1_Q;
    rcc.mux.spi45sel = Spi45sel::PCLK2;
    rcc.mux.usart234578sel = Usart234578sel::PLL3_Q;
    config
}

/// MCO2 source and prescaler for CLKIN.
pub const MCO2_SOURCE: Mco2Source = Mco2Source::PLL2_P;
/// MCO2PRE for [`MCO2_DIV`].
pub const MCO2_PRESCALER: McoPrescaler = McoPrescaler::from_bits(MCO2_DIV as u8);
