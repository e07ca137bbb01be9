//! CMSDK APB timer 0: the 10 kHz sample tick that stands in for the ADC's
//! DRDY on the emulated board.
//!
//! Registers (Cortex-M System Design Kit TRM, ARM DDI 0479C, "APB timer"):
//! CTRL 0x00 (bit 0 enable, bit 3 interrupt enable), VALUE 0x04, RELOAD
//! 0x08, INTSTATUS/INTCLEAR 0x0C (bit 0, write 1 to clear). Timer 0 sits at
//! 0x4000_0000 on IRQ 8 and counts PCLK = SYSCLK = 25 MHz (QEMU `mps2.c`:
//! `SYSCLK_FRQ 25000000`).
//!
//! # Period
//! The counter decrements once per PCLK cycle; the interrupt fires on the
//! 1 → 0 step, the counter holds 0 for one cycle and then reloads (QEMU's
//! model: `PTIMER_POLICY_WRAP_AFTER_ONE_PERIOD`). One period is therefore
//! RELOAD + 1 cycles, and RELOAD = 2,499 gives exactly 2,500 cycles =
//! 100 µs. The firmware measures it at run time against SysTick (same
//! clock) and reports it (`timer period:` line of `cargo xtask qemu`).

use super::mmio::Reg;

/// Timer 0 base address (QEMU `mps2.c`, `cmsdk_apb_timer` at 0x4000_0000).
const BASE: usize = 0x4000_0000;
// SAFETY (all four): CMSDK APB timer registers at their TRM offsets.
const CTRL: Reg = unsafe { Reg::new(BASE, 0x00) };
const VALUE: Reg = unsafe { Reg::new(BASE, 0x04) };
const RELOAD: Reg = unsafe { Reg::new(BASE, 0x08) };
const INTCLEAR: Reg = unsafe { Reg::new(BASE, 0x0C) };

const CTRL_ENABLE: u32 = 1 << 0;
const CTRL_IRQ_ENABLE: u32 = 1 << 3;

/// Timer input clock: PCLK = the MPS2 SYSCLK, 25 MHz.
pub const PCLK_HZ: u32 = 25_000_000;

/// PCLK cycles per period for `rate_hz`, and the RELOAD value that gives it
/// (period = RELOAD + 1 cycles); `None` unless the rate divides PCLK exactly
/// into at least 2 cycles.
pub const fn reload_for(rate_hz: u32) -> Option<u32> {
    if rate_hz == 0 || PCLK_HZ % rate_hz != 0 || PCLK_HZ / rate_hz < 2 {
        None
    } else {
        Some(PCLK_HZ / rate_hz - 1)
    }
}

/// Owner of CMSDK APB timer 0.
#[derive(Debug)]
pub struct SampleTimer {
    _private: (),
}

impl SampleTimer {
    /// Take the timer (once, from [`super::Board::take`]); stopped.
    pub(super) fn new() -> Self {
        CTRL.write(0);
        INTCLEAR.write(1);
        Self { _private: () }
    }

    /// Start periodic interrupts every `reload + 1` PCLK cycles.
    pub fn start(&mut self, reload: u32) {
        CTRL.write(0);
        // Writing RELOAD also loads VALUE, so the first period is full.
        RELOAD.write(reload);
        INTCLEAR.write(1);
        CTRL.write(CTRL_ENABLE | CTRL_IRQ_ENABLE);
    }

    /// Stop the timer (no further interrupts).
    pub fn stop(&mut self) {
        CTRL.write(0);
        INTCLEAR.write(1);
    }

    /// Current counter value (PCLK cycles left in this period).
    pub fn value(&self) -> u32 {
        VALUE.read()
    }
}

/// Acknowledge the timer interrupt (first thing in the sample ISR: the
/// interrupt line is level-sensitive and stays high until cleared).
#[inline(always)]
pub fn clear_interrupt() {
    INTCLEAR.write(1);
}

// 10 kHz: 2,500 cycles of the 25 MHz PCLK, RELOAD = 2,499.
const _: () = assert!(matches!(reload_for(10_000), Some(2_499)));
const _: () = assert!(reload_for(7).is_none() && reload_for(0).is_none());
