//! The H743's RAMs beyond DTCM that the image uses: the AXI SRAM (D1,
//! 512 KiB at 0x2400_0000) and SRAM1–3 (D2, 288 KiB at 0x3000_0000), each
//! one NOLOAD output section of `src/board/nucleo/memory.x` (`.axisram`,
//! `.sram123`) that holds one robust-estimator slot.
//!
//! cortex-m-rt initialises RAM (DTCM) only, so [`init`] does for these
//! sections what it does for `.bss`: it zeroes them, after enabling the
//! clocks they need. Every static placed there is a
//! `cortex_m::singleton!` (a `MaybeUninit` and a `taken` flag, both valid
//! when zero) written once before it is read.
//!
//! What the reference manual (RM0433) says, as found in public copies and
//! discussions of it (not checked on the board here):
//! * SRAM1, SRAM2 and SRAM3 belong to the D2 domain; "if the CPU wants to
//!   use memories located into D2 domain (SRAM1, SRAM2 and SRAM3), it has
//!   to enable them": RCC_AHB2ENR SRAM1EN/SRAM2EN/SRAM3EN (bits 29–31),
//!   0 after reset. ST's `SystemInit` sets them only under
//!   `DATA_IN_D2_SRAM`; on an H743 the D2 SRAMs were reported to work
//!   without them, on an H7B0 an unclocked AHB SRAM took a bus fault at the
//!   first access. They are set here before the first access, either way.
//! * The AXI SRAM is in the CPU's own D1 domain and is clocked after reset
//!   (it is the default RAM of ST's own H743 start-up code and of the HAL
//!   crates' H743 memory maps). This PAC version names an AXISRAMEN bit
//!   (RCC_AHB3ENR bit 31) for RM0433 parts; it is set too, which is
//!   harmless if the silicon ignores it.

use embassy_stm32::pac;

extern "C" {
    static mut __saxisram: u32;
    static mut __eaxisram: u32;
    static mut __ssram123: u32;
    static mut __esram123: u32;
}

/// Enable the clocks of the AXI and D2 SRAMs and zero the `.axisram` and
/// `.sram123` sections. Call once, first thing at boot (before any static
/// placed there is touched): [`crate::board::nucleo::Board::init`] does.
pub(super) fn init() {
    pac::RCC.ahb3enr().modify(|w| w.set_axisramen(true));
    pac::RCC.ahb2enr().modify(|w| {
        w.set_sram1en(true);
        w.set_sram2en(true);
        w.set_sram3en(true);
    });
    // The enables take effect before the first access (RM0433: a
    // read-back of the RCC register, then a barrier).
    let _ = pac::RCC.ahb2enr().read();
    cortex_m::asm::dsb();
    // SAFETY: the linker script defines each start/end pair around one
    // NOLOAD output section (word-aligned at both ends) that nothing has
    // accessed yet: no reference into it exists, so writing words through
    // raw pointers is the only access, like cortex-m-rt's zeroing of .bss.
    unsafe {
        zero(
            core::ptr::addr_of_mut!(__saxisram),
            core::ptr::addr_of_mut!(__eaxisram),
        );
        zero(
            core::ptr::addr_of_mut!(__ssram123),
            core::ptr::addr_of_mut!(__esram123),
        );
    }
}

/// Zero the words in `[start, end)`.
///
/// # Safety
/// `start..end` is word-aligned memory that no reference points into.
unsafe fn zero(start: *mut u32, end: *mut u32) {
    let mut p = start;
    while p < end {
        // SAFETY: inside `[start, end)` (the caller's contract).
        unsafe { p.write_volatile(0) };
        // SAFETY: at most one past `end`'s word.
        p = unsafe { p.add(1) };
    }
}
