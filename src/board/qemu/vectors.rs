//! The device interrupt vector of QEMU `mps2-an386` (IRQ 0–31).
//!
//! No peripheral access crate exists for the MPS2 FPGA images, so this
//! module provides what an svd2rust PAC would for cortex-m-rt's `device`
//! feature: the `Interrupt` enum (also exported as `interrupt`, the name
//! cortex-m-rt's `#[interrupt]` attribute checks handler names against) and
//! the `__INTERRUPTS` table that `link.x` places after the exception
//! vectors. `device.x` gives every named handler a weak alias to
//! `DefaultHandler`.
//!
//! The IRQ numbers are those QEMU's `hw/arm/mps2.c` wires for AN385/AN386
//! (NVIC with 32 external interrupts); unwired lines are reserved (0).

/// Device interrupts of `mps2-an386` that QEMU models.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[allow(clippy::upper_case_acronyms)]
#[repr(u16)]
pub enum Interrupt {
    /// CMSDK UART0 receive (byte in RX buffer).
    UART0RX = 0,
    /// CMSDK UART0 transmit (TX buffer became empty).
    UART0TX = 1,
    /// CMSDK UART1 receive.
    UART1RX = 2,
    /// CMSDK UART1 transmit.
    UART1TX = 3,
    /// CMSDK UART2 receive.
    UART2RX = 4,
    /// CMSDK UART2 transmit.
    UART2TX = 5,
    /// CMSDK APB timer 0 (0x4000_0000): the 10 kHz sample tick here.
    TIMER0 = 8,
    /// CMSDK APB timer 1 (0x4000_1000).
    TIMER1 = 9,
    /// CMSDK APB dual timer (0x4000_2000).
    DUALTIMER = 10,
    /// PL022 SPI (APB and LCD controllers, ORed).
    SPI0 = 11,
    /// Overrun of UART0–2 (TX or RX, ORed).
    UARTOVF = 12,
    /// LAN9118 Ethernet controller.
    ETHERNET = 13,
    /// CMSDK UART3 receive.
    UART3RX = 18,
    /// CMSDK UART3 transmit.
    UART3TX = 19,
    /// CMSDK UART4 receive.
    UART4RX = 20,
    /// CMSDK UART4 transmit.
    UART4TX = 21,
    /// PL022 SPI to the external ADC.
    SPIADC = 22,
    /// PL022 SPI to the two shield headers (ORed).
    SPISHIELD = 24,
}

pub use Interrupt as interrupt;

// SAFETY: `number` returns the NVIC line of each variant as wired by QEMU's
// mps2.c, all below the 32 lines the NVIC implements on this machine.
unsafe impl cortex_m::interrupt::InterruptNumber for Interrupt {
    #[inline(always)]
    fn number(self) -> u16 {
        self as u16
    }
}

/// One entry of the device vector: a handler or a reserved (zero) word.
#[doc(hidden)]
pub union Vector {
    handler: unsafe extern "C" fn(),
    reserved: usize,
}

extern "C" {
    fn UART0RX();
    fn UART0TX();
    fn UART1RX();
    fn UART1TX();
    fn UART2RX();
    fn UART2TX();
    fn TIMER0();
    fn TIMER1();
    fn DUALTIMER();
    fn SPI0();
    fn UARTOVF();
    fn ETHERNET();
    fn UART3RX();
    fn UART3TX();
    fn UART4RX();
    fn UART4TX();
    fn SPIADC();
    fn SPISHIELD();
}

const fn h(handler: unsafe extern "C" fn()) -> Vector {
    Vector { handler }
}

const RESERVED: Vector = Vector { reserved: 0 };

/// The 32 device vectors, placed by cortex-m-rt's `link.x` right after the
/// 16 system exception vectors.
#[doc(hidden)]
#[link_section = ".vector_table.interrupts"]
#[no_mangle]
pub static __INTERRUPTS: [Vector; 32] = [
    h(UART0RX),   // 0
    h(UART0TX),   // 1
    h(UART1RX),   // 2
    h(UART1TX),   // 3
    h(UART2RX),   // 4
    h(UART2TX),   // 5
    RESERVED,     // 6: GPIO0 combined (not modelled)
    RESERVED,     // 7: GPIO1 combined (not modelled)
    h(TIMER0),    // 8
    h(TIMER1),    // 9
    h(DUALTIMER), // 10
    h(SPI0),      // 11
    h(UARTOVF),   // 12
    h(ETHERNET),  // 13
    RESERVED,     // 14
    RESERVED,     // 15
    RESERVED,     // 16
    RESERVED,     // 17
    h(UART3RX),   // 18
    h(UART3TX),   // 19
    h(UART4RX),   // 20
    h(UART4TX),   // 21
    h(SPIADC),    // 22
    RESERVED,     // 23
    h(SPISHIELD), // 24
    RESERVED,     // 25
    RESERVED,     // 26
    RESERVED,     // 27
    RESERVED,     // 28
    RESERVED,     // 29
    RESERVED,     // 30
    RESERVED,     // 31
];
