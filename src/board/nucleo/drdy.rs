//! The ADS131M02's DRDY on PF3 → EXTI line 3 → the `EXTI3` interrupt: the
//! 10 kHz sample tick, locked to the ADC's conversions.
//!
//! DRDY is a push-pull output (MODE.DRDY_HiZ = 0) that goes low when a
//! conversion is ready (MODE.DRDY_FMT = 0, logic level; ADS131M02 data
//! sheet §8.5.1.3 "DRDY"); the falling edge is the tick. EXTI line 3 has
//! its own NVIC vector (`EXTI3`), so the handler never has to find out
//! which line fired.
//!
//! Registers (RM0433, "Extended interrupt and event controller" and
//! "System configuration controller"): SYSCFG_EXTICR1.EXTI3 = 5 routes
//! port F to line 3; EXTI_FTSR1 bit 3 selects the falling edge (EXTI_RTSR1
//! bit 3 cleared); EXTI_CPUIMR1 bit 3 unmasks it for the CPU;
//! EXTI_CPUPR1 bit 3 is the pending flag, cleared by writing 1.
//!
//! embassy-stm32 is built without its `exti` feature, so it neither
//! configures EXTI nor defines the `EXTI*` handlers: this module and the
//! firmware's `#[interrupt] fn EXTI3` own them.

use embassy_stm32::gpio::{Input, Pull};
use embassy_stm32::pac;
use embassy_stm32::pac::exti::regs::Lines;
use embassy_stm32::peripherals::PF3;
use embassy_stm32::Peri;

/// EXTI line (= pin number of PF3).
const LINE: usize = 3;
/// SYSCFG_EXTICRx port code of GPIOF (A = 0, B = 1, …).
const PORT_F: u8 = 5;

/// The DRDY input, configured for falling-edge interrupts.
pub struct Drdy {
    pin: Input<'static>,
}

impl Drdy {
    /// PF3 as an input with pull-up (a missing ADC then gives no edges)
    /// routed to EXTI line 3, falling edge, unmasked in EXTI. The NVIC
    /// line (`EXTI3`) stays disabled until the caller enables it.
    pub(super) fn new(pf3: Peri<'static, PF3>) -> Self {
        let pin = Input::new(pf3, Pull::Up);
        critical_section::with(|_| {
            pac::SYSCFG
                .exticr(LINE / 4)
                .modify(|w| w.set_exti(LINE % 4, PORT_F));
            pac::EXTI.rtsr(0).modify(|w| w.set_line(LINE, false));
            pac::EXTI.ftsr(0).modify(|w| w.set_line(LINE, true));
            pac::EXTI.imr(0).modify(|w| w.set_line(LINE, true));
        });
        clear_pending();
        Self { pin }
    }

    /// DRDY is low: a conversion is waiting to be read.
    pub fn is_low(&self) -> bool {
        self.pin.is_low()
    }
}

/// Clear the EXTI pending flag of line 3 (first thing in the handler, so
/// an edge during the handler pends it again).
#[inline(always)]
pub fn clear_pending() {
    pac::EXTI.pr(0).write_value(Lines(1 << LINE));
}

/// A falling edge arrived since the last [`clear_pending`]: at the end of
/// the handler, the next conversion was ready before the work was done.
#[inline(always)]
pub fn is_pending() -> bool {
    pac::EXTI.pr(0).read().line(LINE)
}
