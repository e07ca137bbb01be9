//! Volatile access to the CMSDK peripheral registers: the only raw pointer
//! use of the QEMU board.
//!
//! A [`Reg`] can only be made by [`Reg::new`], which is `unsafe` and called
//! solely in the `const` register tables of [`super::timer`] and
//! [`super::uart`], each entry a documented register of the Cortex-M System
//! Design Kit TRM (ARM DDI 0479C) at the base address QEMU's `mps2.c` maps it
//! to. Reading and writing such a register is then safe.

use core::ptr;

/// A 32-bit memory-mapped device register.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Reg(usize);

impl Reg {
    /// A register at `base + offset`.
    ///
    /// # Safety
    /// The address must be a 4-byte aligned, always-mapped device register
    /// whose reads and writes have no effect on memory the program owns.
    pub(crate) const unsafe fn new(base: usize, offset: usize) -> Self {
        Self(base + offset)
    }

    /// Volatile read.
    #[inline(always)]
    pub(crate) fn read(self) -> u32 {
        // SAFETY: `Reg::new`'s contract: an aligned, mapped device register.
        unsafe { ptr::read_volatile(self.0 as *const u32) }
    }

    /// Volatile write.
    #[inline(always)]
    pub(crate) fn write(self, value: u32) {
        // SAFETY: `Reg::new`'s contract: an aligned, mapped device register.
        unsafe { ptr::write_volatile(self.0 as *mut u32, value) }
    }
}
