//! The emulated board: QEMU `mps2-an386` (ARM MPS2 with the AN386 FPGA
//! image, Cortex-M4F with a single-precision FPU, 25 MHz SYSCLK).
//!
//! * [`vectors`] — the device interrupt vector (no PAC exists for MPS2);
//! * [`timer`] — CMSDK APB timer 0 at exactly 10 kHz, standing in for DRDY;
//! * [`uart`] — CMSDK UART0, interrupt-driven rings, never blocking;
//! * [`cycles`] — SysTick instruction counting under `-icount shift=0`;
//! * [`meter`] — meters that tell the estimator's and the simulated chips'
//!   instructions apart inside the sample interrupt;
//! * [`Handoff`] — move a value from thread mode into an interrupt handler;
//! * [`Shared`] — state the sample interrupt and thread mode both change,
//!   each inside a critical section;
//! * [`command_line`] — the semihosting command line (run options).
//!
//! Priorities ([`priority`]): the sample interrupt (timer 0) is the highest;
//! the UART interrupts run below it; thread mode (telemetry, modal recovery,
//! semihosting logs) below everything. Semihosting is for thread mode only:
//! a semihosting call stops the emulated CPU for a host round trip.
//!
//! Memory map: `src/board/qemu/memory.x` (selected by `build.rs`).

#![allow(unsafe_code)]
// The timer, SysTick and meter code run in the sample interrupt.
#![deny(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::panic,
    clippy::indexing_slicing
)]

pub mod cycles;
pub mod meter;
mod mmio;
pub mod timer;
pub mod uart;
pub mod vectors;

use core::cell::{Cell, RefCell};

use cortex_m::peripheral::NVIC;
use critical_section::Mutex;

/// `#[interrupt]` handler attribute (cortex-m-rt); the handler name must be
/// a variant of [`Interrupt`], which is also exported as `interrupt` in the
/// type namespace for that check, as peripheral access crates do.
pub use cortex_m_rt::interrupt;
pub use vectors::{interrupt, Interrupt};

/// NVIC priorities (upper bits of the 8-bit field; lower = more urgent; the
/// AN386 Cortex-M4 implements 3 priority bits, so these are levels 0 and 2).
pub mod priority {
    /// The sample interrupt: preempts everything else.
    pub const SAMPLE: u8 = 0x00;
    /// UART TX/RX interrupts.
    pub const SERIAL: u8 = 0x40;
}

/// Sample rate of the rig, Hz (the paper's Ts = 0.1 ms).
pub const SAMPLE_RATE_HZ: u32 = 10_000;

/// Timer reload for [`SAMPLE_RATE_HZ`]: 25 MHz / 10 kHz = 2,500 cycles per
/// period, RELOAD = 2,499 (see [`timer`]).
pub const SAMPLE_RELOAD: u32 = match timer::reload_for(SAMPLE_RATE_HZ) {
    Some(r) => r,
    None => panic!("the sample rate must divide the 25 MHz timer clock"),
};

/// UART0 line rate (bits/s): the reference board's link rate
/// (`docs/PROTOCOL.md` §7, 92,160 B/s at 8N1), so the link budget the
/// firmware enforces is the board's. QEMU's CMSDK UART does not pace bytes
/// by the divisor: a byte leaves as soon as the character backend takes
/// it, so in emulation the budget is enforced but never felt.
pub const UART_BAUD: u32 = 921_600;

/// The board's peripherals, taken once at boot.
pub struct Board {
    /// Timer 0, the sample tick.
    pub timer: timer::SampleTimer,
    /// UART0 (split it into the four ring ends).
    pub uart0: uart::Uart0,
    /// The interrupt controller.
    pub nvic: NVIC,
}

impl Board {
    /// Take the core and device peripherals, start SysTick as the
    /// instruction counter, set the interrupt priorities. Interrupts stay
    /// masked in the NVIC until [`Board::unmask`]. `None` if called twice.
    pub fn take() -> Option<Self> {
        let cp = cortex_m::Peripherals::take()?;
        cycles::start_systick(cp.SYST);
        let mut nvic = cp.NVIC;
        // SAFETY: set before any of these interrupts is unmasked, so no
        // priority-based critical section can be running.
        unsafe {
            nvic.set_priority(Interrupt::TIMER0, priority::SAMPLE);
            nvic.set_priority(Interrupt::UART0TX, priority::SERIAL);
            nvic.set_priority(Interrupt::UART0RX, priority::SERIAL);
        }
        Some(Self {
            timer: timer::SampleTimer::new(),
            uart0: uart::Uart0::new(),
            nvic,
        })
    }

    /// Unmask the sample and UART interrupts in the NVIC. Call after their
    /// handlers' state has been placed in its [`Handoff`]s.
    pub fn unmask() {
        // SAFETY: the firmware uses no mask-based critical sections that
        // these interrupts could break (critical sections use PRIMASK).
        unsafe {
            NVIC::unmask(Interrupt::UART0TX);
            NVIC::unmask(Interrupt::UART0RX);
            NVIC::unmask(Interrupt::TIMER0);
        }
    }
}

/// Move a value from thread mode into an interrupt handler once: thread
/// mode [`put`](Handoff::put)s it, the handler [`take`](Handoff::take)s it
/// into its own `static mut` state on its next run. Only that hand-off is
/// a critical section; the handler then owns the value. A `Cell`, not a
/// `RefCell`: moving in and out has no borrow flag and no panic path.
pub struct Handoff<T>(Mutex<Cell<Option<T>>>);

impl<T> Handoff<T> {
    /// An empty slot.
    pub const fn new() -> Self {
        Self(Mutex::new(Cell::new(None)))
    }

    /// Place `value` (replacing one not yet taken).
    pub fn put(&self, value: T) {
        critical_section::with(|cs| self.0.borrow(cs).set(Some(value)));
    }

    /// Take the value, if one was placed.
    pub fn take(&self) -> Option<T> {
        critical_section::with(|cs| self.0.borrow(cs).take())
    }
}

/// State that the sample interrupt and thread mode share: each runs on it
/// inside a critical section (PRIMASK: every interrupt masked), so thread
/// mode's changes land between two samples and the sample interrupt never
/// sees one half made. The sample interrupt is the highest priority, so
/// its own critical section costs it only the few instructions of the
/// mask; a thread-mode section delays the next sample by its length (keep
/// it to setters and swaps). A `RefCell` borrowed with `try_borrow_mut`:
/// no panic path.
pub struct Shared<T>(Mutex<RefCell<Option<T>>>);

impl<T> Shared<T> {
    /// An empty slot.
    pub const fn new() -> Self {
        Self(Mutex::new(RefCell::new(None)))
    }

    /// Place the value.
    pub fn put(&self, value: T) {
        critical_section::with(|cs| {
            if let Ok(mut slot) = self.0.borrow(cs).try_borrow_mut() {
                *slot = Some(value);
            }
        });
    }

    /// Run `f` on the value inside a critical section; `None` if no value
    /// has been placed (or, impossibly, it is borrowed already).
    #[inline]
    pub fn lock<R>(&self, f: impl FnOnce(&mut T) -> R) -> Option<R> {
        critical_section::with(|cs| {
            let mut slot = self.0.borrow(cs).try_borrow_mut().ok()?;
            slot.as_mut().map(f)
        })
    }
}

impl<T> Default for Shared<T> {
    fn default() -> Self {
        Self::new()
    }
}

/// A value the sample interrupt owns once thread mode has built it,
/// although it is not `Send`: on this board the simulated rig and the
/// drivers inside the sample task share the chip models through `&RefCell`
/// handles ([`crate::rig::chips::Shared`]), and `RefCell` is not `Sync`.
/// Moving the whole bundle — the models' only users — into the interrupt
/// is sound as long as nothing outside it can still reach the models;
/// [`IsrOwned::new`] is `unsafe` so the caller states that.
pub struct IsrOwned<T>(T);

// SAFETY: the value is used from one context at a time (thread mode until
// it is put into a `Handoff` or a `Shared`; then the interrupt, or either
// side inside the `Shared`'s critical section, which excludes the other),
// and by the contract of `new` nothing outside it refers to what it
// borrows, so no `RefCell` it shares is ever touched from two contexts at
// once.
unsafe impl<T> Send for IsrOwned<T> {}

impl<T> IsrOwned<T> {
    /// Wrap `value` for the hand-off to the interrupt.
    ///
    /// # Safety
    /// From this call on, nothing outside `value` may access what `value`
    /// borrows (e.g. the `RefCell`s its parts share).
    pub unsafe fn new(value: T) -> Self {
        Self(value)
    }

    /// The value (in the context that owns it).
    pub fn get_mut(&mut self) -> &mut T {
        &mut self.0
    }
}

impl<T> Default for Handoff<T> {
    fn default() -> Self {
        Self::new()
    }
}

/// Thread-mode idle step: burn ~2,000 instructions (20 µs at the 1 ns per
/// instruction of `-icount shift=0`) in straight-line blocks, cheap for
/// QEMU to emulate.
///
/// Never `wfi` on this board: with `-icount shift=0,sleep=off`, QEMU 7.2
/// advances virtual time to the next timer deadline while the CPU sleeps
/// and can do so again before the timer's interrupt wakes it, so most
/// sample interrupts arrived 200 µs apart (measured with SysTick over 1,000
/// periods: 4,972.5 ticks per period instead of 2,500); with this idle the
/// same measurement reads 2,500.000.
#[inline]
pub fn idle() {
    cycles::idle_block(8);
}

/// The semihosting command line (QEMU: the `-semihosting-config arg=…`
/// words joined by spaces), read into `buf`; `None` if the host has none
/// or it is not UTF-8. Thread mode only.
pub fn command_line(buf: &mut [u8]) -> Option<&str> {
    // SYS_GET_CMDLINE (0x15): r1 points to {buffer address, buffer
    // length}; the host writes the line (NUL-terminated) and its length.
    let mut block: [usize; 2] = [buf.as_mut_ptr() as usize, buf.len().saturating_sub(1)];
    // SAFETY: the block and the buffer it points to are valid and writable
    // for the call's duration; the host writes at most block[1] + 1 bytes.
    // The `bkpt` asm clobbers memory, so the block is re-read after it.
    let r = unsafe {
        cortex_m_semihosting::syscall1(
            cortex_m_semihosting::nr::GET_CMDLINE,
            block.as_mut_ptr() as usize,
        )
    };
    if r != 0 {
        return None;
    }
    let n = block[1].min(buf.len());
    core::str::from_utf8(buf.get(..n)?).ok()
}

/// End the emulation through semihosting: QEMU exits with status 0 for
/// `success`, 1 otherwise. Thread mode only.
pub fn exit(success: bool) -> ! {
    use cortex_m_semihosting::debug;
    debug::exit(if success {
        debug::EXIT_SUCCESS
    } else {
        debug::EXIT_FAILURE
    });
    // Not reached under QEMU; on a debugger without semihosting exit, park.
    loop {
        cortex_m::asm::wfi();
    }
}
