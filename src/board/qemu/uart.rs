//! CMSDK APB UART0: interrupt-driven, ring-buffered serial link (QEMU maps
//! UART0 to the first `-serial` / `-chardev` backend).
//!
//! Registers (Cortex-M System Design Kit TRM, ARM DDI 0479C, "APB UART"):
//! DATA 0x00, STATE 0x04 (bit 0 TX buffer full, bit 1 RX buffer full,
//! bits 2–3 TX/RX overrun, write 1 to clear), CTRL 0x08 (bit 0 TX enable,
//! bit 1 RX enable, bit 2 TX interrupt enable, bit 3 RX interrupt enable),
//! INTSTATUS/INTCLEAR 0x0C (bit 0 TX, bit 1 RX, write 1 to clear), BAUDDIV
//! 0x10 (PCLK cycles per bit, at least 16). UART0 is at 0x4000_4000 with
//! RX on IRQ 0 and TX on IRQ 1 (QEMU `mps2.c`).
//!
//! # Design
//! Nothing here blocks. The sending context (thread mode) pushes bytes into
//! a single-producer single-consumer ring ([`UartTx`]) and pends the TX
//! interrupt; the TX interrupt ([`TxDrain::on_interrupt`]) moves bytes into
//! the one-byte transmit buffer while it is empty and returns; the CMSDK
//! UART raises TX again each time the buffer empties. Received bytes are
//! moved by the RX interrupt ([`RxFill::on_interrupt`]) into a second ring
//! that the command parser drains ([`UartRx`]). Bytes that do not fit are
//! dropped and counted, never waited for. Both interrupts run below the
//! sample interrupt, so the 10 kHz path never waits for the serial link.

use core::sync::atomic::{AtomicU32, Ordering};

use heapless::spsc::{Consumer, Producer, Queue};

use super::mmio::Reg;
use super::vectors::Interrupt;

/// UART0 base address (QEMU `mps2.c`: `uartbase[0]`).
const BASE: usize = 0x4000_4000;
// SAFETY (all five): CMSDK APB UART registers at their TRM offsets.
const DATA: Reg = unsafe { Reg::new(BASE, 0x00) };
const STATE: Reg = unsafe { Reg::new(BASE, 0x04) };
const CTRL: Reg = unsafe { Reg::new(BASE, 0x08) };
const INTCLEAR: Reg = unsafe { Reg::new(BASE, 0x0C) };
const BAUDDIV: Reg = unsafe { Reg::new(BASE, 0x10) };

const STATE_TX_FULL: u32 = 1 << 0;
const STATE_RX_FULL: u32 = 1 << 1;
const STATE_OVERRUNS: u32 = 0b1100;
const CTRL_TX_EN: u32 = 1 << 0;
const CTRL_RX_EN: u32 = 1 << 1;
const CTRL_TX_IRQ: u32 = 1 << 2;
const CTRL_RX_IRQ: u32 = 1 << 3;
const INT_TX: u32 = 1 << 0;
const INT_RX: u32 = 1 << 1;

/// Smallest BAUDDIV the TRM allows (QEMU ignores smaller values).
const BAUDDIV_MIN: u32 = 16;

/// TX ring size in bytes (holds `TX_RING - 1`): a full raw-sample frame
/// (542 bytes), a Status (≤ 142) and a dozen estimates (≤ 87 each), ≈ 22 ms
/// of the link at 921,600 baud (`docs/PROTOCOL.md` §7).
pub const TX_RING: usize = 2048;
/// RX ring size in bytes (holds `RX_RING - 1`): 22 ms of the link at
/// 921,600 baud, longer than thread mode's longest pass (an estimator
/// build, 2.75 million instructions: about 20 ms on a 168 MHz M4F with
/// the sample interrupt's share, docs/PROTOCOL.md §9.5), so input at the
/// full line rate is not dropped; 256 bytes (2.8 ms) dropped 21 % of a
/// hostile run's bytes in QEMU (`cargo xtask qemu --hostile`, before its
/// host paced them on the device's answers).
pub const RX_RING: usize = 2048;

/// Transmit ring storage (`static`, split once by [`Uart0::split`]).
pub type TxRing = Queue<u8, TX_RING>;
/// Receive ring storage (`static`, split once by [`Uart0::split`]).
pub type RxRing = Queue<u8, RX_RING>;

/// Bytes the sender offered while the TX ring was full (dropped).
static TX_DROPPED: AtomicU32 = AtomicU32::new(0);
/// Bytes received while the RX ring was full (dropped).
static RX_DROPPED: AtomicU32 = AtomicU32::new(0);
/// Receive overruns the UART flagged (a byte arrived before the previous
/// one was read: lost in the hardware).
static RX_OVERRUNS: AtomicU32 = AtomicU32::new(0);
const STATE_RX_OVERRUN: u32 = 1 << 3;

/// Owner of UART0's registers until split.
#[derive(Debug)]
pub struct Uart0 {
    _private: (),
}

impl Uart0 {
    /// Take UART0 (once, from [`super::Board::take`]); disabled.
    pub(super) fn new() -> Self {
        CTRL.write(0);
        Self { _private: () }
    }

    /// Configure 8N1 at `baud` (BAUDDIV = PCLK / baud, at least 16), enable
    /// TX, RX and their interrupts, and split into the four ends: the
    /// sender, the TX-interrupt drain, the RX-interrupt fill and the
    /// receiver. The caller unmasks [`Interrupt::UART0TX`] and
    /// [`Interrupt::UART0RX`] after moving the interrupt ends to them.
    pub fn split(
        self,
        pclk_hz: u32,
        baud: u32,
        tx_ring: &'static mut TxRing,
        rx_ring: &'static mut RxRing,
    ) -> (UartTx, TxDrain, RxFill, UartRx) {
        BAUDDIV.write((pclk_hz / baud.max(1)).max(BAUDDIV_MIN));
        STATE.write(STATE_OVERRUNS);
        INTCLEAR.write(INT_TX | INT_RX);
        CTRL.write(CTRL_TX_EN | CTRL_RX_EN | CTRL_TX_IRQ | CTRL_RX_IRQ);
        let (tx_p, tx_c) = tx_ring.split();
        let (rx_p, rx_c) = rx_ring.split();
        (
            UartTx { ring: tx_p },
            TxDrain { ring: tx_c },
            RxFill { ring: rx_p },
            UartRx { ring: rx_c },
        )
    }
}

/// The sending end (thread mode or a low-priority task).
pub struct UartTx {
    ring: Producer<'static, u8>,
}

impl UartTx {
    /// Queue as many of `bytes` as fit, start the transmitter, and return
    /// how many were queued (the rest are dropped and counted).
    pub fn write(&mut self, bytes: &[u8]) -> usize {
        let mut queued = 0;
        for &b in bytes {
            if self.ring.enqueue(b).is_err() {
                break;
            }
            queued += 1;
        }
        let dropped = bytes.len() - queued;
        if dropped > 0 {
            let d = u32::try_from(dropped).unwrap_or(u32::MAX);
            TX_DROPPED.fetch_add(d, Ordering::Relaxed);
        }
        if queued > 0 {
            // The TX interrupt moves bytes to the UART; pending it starts an
            // idle transmitter (a busy one re-raises TX by itself).
            cortex_m::peripheral::NVIC::pend(Interrupt::UART0TX);
        }
        queued
    }

    /// Free space in the TX ring, in bytes.
    pub fn space(&self) -> usize {
        self.ring.capacity() - self.ring.len()
    }

    /// True once every queued byte has been handed to the UART.
    pub fn is_drained(&self) -> bool {
        self.ring.is_empty()
    }
}

/// The serial link's frames go out through the ring: whole frames only
/// (the link checks [`TxSink::free`](crate::link::TxSink::free) first), then the TX interrupt is
/// pended.
impl crate::link::TxSink for UartTx {
    fn free(&self) -> usize {
        self.space()
    }

    fn push(&mut self, bytes: &[u8]) {
        self.write(bytes);
    }
}

/// The TX interrupt's end: owned by the `UART0TX` handler.
pub struct TxDrain {
    ring: Consumer<'static, u8>,
}

impl TxDrain {
    /// Body of the `UART0TX` handler: acknowledge, then fill the transmit
    /// buffer while it is empty and bytes are queued. Never waits.
    #[inline]
    pub fn on_interrupt(&mut self) {
        INTCLEAR.write(INT_TX);
        while STATE.read() & STATE_TX_FULL == 0 {
            match self.ring.dequeue() {
                Some(b) => DATA.write(u32::from(b)),
                None => break,
            }
        }
    }
}

/// The RX interrupt's end: owned by the `UART0RX` handler.
pub struct RxFill {
    ring: Producer<'static, u8>,
}

impl RxFill {
    /// Body of the `UART0RX` handler: acknowledge, then move every
    /// received byte into the RX ring (dropping and counting what does not
    /// fit).
    ///
    /// Acknowledge first: a byte that arrives after the last STATE read
    /// sets the interrupt again. Acknowledging after the loop cleared that
    /// byte's interrupt, and with nothing to raise it again (the receive
    /// buffer stays full, so no further byte arrives) reception stopped for
    /// good — seen under QEMU, whose character backend delivers bytes from
    /// another host thread while the guest runs: a command stalled after
    /// two bytes in 3 of 4 end-to-end runs.
    #[inline]
    pub fn on_interrupt(&mut self) {
        INTCLEAR.write(INT_RX);
        if STATE.read() & STATE_RX_OVERRUN != 0 {
            STATE.write(STATE_RX_OVERRUN);
            RX_OVERRUNS.fetch_add(1, Ordering::Relaxed);
        }
        while STATE.read() & STATE_RX_FULL != 0 {
            let b = (DATA.read() & 0xFF) as u8;
            if self.ring.enqueue(b).is_err() {
                RX_DROPPED.fetch_add(1, Ordering::Relaxed);
            }
        }
    }
}

/// The receiving end (thread mode or a low-priority task).
pub struct UartRx {
    ring: Consumer<'static, u8>,
}

impl UartRx {
    /// The next received byte, if any.
    pub fn read(&mut self) -> Option<u8> {
        self.ring.dequeue()
    }
}

/// Link counters since boot.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct LinkStats {
    /// Bytes dropped because the TX ring was full.
    pub tx_dropped: u32,
    /// Bytes dropped because the RX ring was full.
    pub rx_dropped: u32,
    /// Receive overruns the UART flagged (bytes lost before the interrupt
    /// read them; QEMU's model never loses one: it offers a byte only
    /// when the previous was read).
    pub rx_overruns: u32,
}

/// Current link counters.
pub fn link_stats() -> LinkStats {
    LinkStats {
        tx_dropped: TX_DROPPED.load(Ordering::Relaxed),
        rx_dropped: RX_DROPPED.load(Ordering::Relaxed),
        rx_overruns: RX_OVERRUNS.load(Ordering::Relaxed),
    }
}
