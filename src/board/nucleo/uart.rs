//! USART3 — the ST-LINK virtual COM port (PD8 TX, PD9 RX; UM2407 "USART
//! virtual communication") — at 921,600 Bd, 8N1, interrupt-driven through
//! two rings. Nothing here blocks.
//!
//! embassy-stm32 sets the peripheral up (clock, pins in AF7, BRR = 25 from
//! the 23.04 MHz kernel clock of [`super::clocks`], FIFO mode); from then
//! on this module drives the registers itself (RM0433, "USART" with FIFO
//! mode: ISR.TXFNF is bit 7, `txe` in the PAC; ISR.RXFNE is bit 5,
//! `rxne`):
//!
//! * **TX.** The sender ([`UartTx`], thread mode) pushes bytes into a
//!   single-producer single-consumer ring and enables the "TX FIFO not
//!   full" interrupt (CR1.TXFNFIE). The `USART3` handler
//!   ([`TxDrain::on_interrupt`]) fills the hardware FIFO from the ring
//!   until it is full; if bytes remain it waits for the FIFO to drain to
//!   half (CR3.TXFTIE, TXFTCFG = 1/2) instead of taking one interrupt per
//!   byte, and when the ring is empty it disables both.
//! * **RX.** Every received byte raises CR1.RXFNEIE; the handler
//!   ([`RxFill::on_interrupt`]) moves the FIFO's bytes into a second ring
//!   for the command parser ([`UartRx`]). Overrun, framing and noise
//!   errors are cleared and counted.
//!
//! Bytes that do not fit a ring are dropped and counted
//! ([`link_stats`]), never waited for. The `USART3` interrupt runs below
//! the sample interrupt, so the 10 kHz path never waits for the link.

use core::sync::atomic::{AtomicU32, Ordering};

use embassy_stm32::mode::Blocking;
use embassy_stm32::pac;
use embassy_stm32::usart::Uart;
use heapless::spsc::{Consumer, Producer, Queue};

/// TX ring size in bytes (holds `TX_RING - 1`): 44 ms of the link.
pub const TX_RING: usize = 4096;
/// RX ring size in bytes (holds `RX_RING - 1`): several command frames.
pub const RX_RING: usize = 512;

/// Transmit ring storage (`static`, split once by [`Usart3::split`]).
pub type TxRing = Queue<u8, TX_RING>;
/// Receive ring storage (`static`, split once by [`Usart3::split`]).
pub type RxRing = Queue<u8, RX_RING>;

/// USART_CR3.TXFTCFG = 010: the TX FIFO threshold flag rises at half depth.
const TXFTCFG_HALF: u8 = 0b010;

static TX_DROPPED: AtomicU32 = AtomicU32::new(0);
static RX_DROPPED: AtomicU32 = AtomicU32::new(0);
static RX_ERRORS: AtomicU32 = AtomicU32::new(0);

/// What the link has lost so far (bytes, since start-up, saturating).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct LinkStats {
    /// Bytes the sender offered while the TX ring was full.
    pub tx_dropped: u32,
    /// Bytes received while the RX ring was full.
    pub rx_dropped: u32,
    /// Receive errors (overrun, framing, noise, parity).
    pub rx_errors: u32,
}

/// The counters now.
pub fn link_stats() -> LinkStats {
    LinkStats {
        tx_dropped: TX_DROPPED.load(Ordering::Relaxed),
        rx_dropped: RX_DROPPED.load(Ordering::Relaxed),
        rx_errors: RX_ERRORS.load(Ordering::Relaxed),
    }
}

fn bump(counter: &AtomicU32, by: u32) {
    // Saturating: a load/store pair is enough, each counter has one writer.
    let v = counter.load(Ordering::Relaxed);
    counter.store(v.saturating_add(by), Ordering::Relaxed);
}

/// USART3 configured by the HAL, not yet split.
pub struct Usart3 {
    _private: (),
}

impl Usart3 {
    /// Take over a configured HAL UART. The HAL object is forgotten, not
    /// dropped: dropping it would switch the peripheral's clock off. The
    /// NVIC line stays as the caller sets it.
    pub(super) fn from_hal(uart: Uart<'static, Blocking>) -> Self {
        core::mem::forget(uart);
        let r = pac::USART3;
        r.cr1().modify(|w| {
            w.set_txeie(false);
            w.set_rxneie(false);
        });
        r.cr3().modify(|w| {
            w.set_txftie(false);
            w.set_txftcfg(TXFTCFG_HALF);
        });
        Self { _private: () }
    }

    /// Split into the sender, the interrupt's two ends and the receiver,
    /// and enable the receive interrupt. Call before unmasking `USART3`.
    pub fn split(
        self,
        tx_ring: &'static mut TxRing,
        rx_ring: &'static mut RxRing,
    ) -> (UartTx, TxDrain, RxFill, UartRx) {
        let (tx_p, tx_c) = tx_ring.split();
        let (rx_p, rx_c) = rx_ring.split();
        pac::USART3.cr1().modify(|w| w.set_rxneie(true));
        (
            UartTx { ring: tx_p },
            TxDrain { ring: tx_c },
            RxFill { ring: rx_p },
            UartRx { ring: rx_c },
        )
    }
}

/// The sending end (thread mode).
pub struct UartTx {
    ring: Producer<'static, u8>,
}

impl UartTx {
    /// Queue as many of `bytes` as fit and start the transmitter; returns
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
            bump(&TX_DROPPED, u32::try_from(dropped).unwrap_or(u32::MAX));
        }
        if queued > 0 {
            // The handler clears TXFNFIE from its own context; this
            // read-modify-write must not interleave with it.
            critical_section::with(|_| pac::USART3.cr1().modify(|w| w.set_txeie(true)));
        }
        queued
    }

    /// Queue all of `bytes` or nothing (whole frames only); `false` if the
    /// ring lacks the room (the frame is dropped and counted).
    pub fn write_all_or_nothing(&mut self, bytes: &[u8]) -> bool {
        if bytes.len() > self.space() {
            bump(&TX_DROPPED, u32::try_from(bytes.len()).unwrap_or(u32::MAX));
            return false;
        }
        self.write(bytes) == bytes.len()
    }

    /// Free space in the TX ring, bytes.
    pub fn space(&self) -> usize {
        self.ring.capacity() - self.ring.len()
    }

    /// Every queued byte has been handed to the USART.
    pub fn is_drained(&self) -> bool {
        self.ring.is_empty()
    }
}

/// The serial link's frames go out through the ring: whole frames only
/// (the link checks [`TxSink::free`](crate::link::TxSink::free) first),
/// then the transmit interrupt is enabled.
impl crate::link::TxSink for UartTx {
    fn free(&self) -> usize {
        self.space()
    }

    fn push(&mut self, bytes: &[u8]) {
        self.write(bytes);
    }
}

/// The interrupt's transmit end.
pub struct TxDrain {
    ring: Consumer<'static, u8>,
}

impl TxDrain {
    /// Transmit part of the `USART3` handler: fill the TX FIFO from the
    /// ring; then wait for half-empty (more queued) or stop (ring empty).
    #[inline]
    pub fn on_interrupt(&mut self) {
        let r = pac::USART3;
        let cr1 = r.cr1().read();
        let cr3 = r.cr3().read();
        if !(cr1.txeie() || cr3.txftie()) {
            return;
        }
        while r.isr().read().txe() {
            match self.ring.dequeue() {
                Some(b) => r.tdr().write(|w| w.set_dr(u16::from(b))),
                None => break,
            }
        }
        let more = !self.ring.is_empty();
        // FIFO full with bytes left: wake at half-empty; else stop.
        r.cr1().modify(|w| w.set_txeie(false));
        r.cr3().modify(|w| w.set_txftie(more));
    }
}

/// The interrupt's receive end.
pub struct RxFill {
    ring: Producer<'static, u8>,
}

impl RxFill {
    /// Receive part of the `USART3` handler: clear and count errors, move
    /// every byte in the RX FIFO into the ring.
    #[inline]
    pub fn on_interrupt(&mut self) {
        let r = pac::USART3;
        let isr = r.isr().read();
        if isr.ore() || isr.fe() || isr.ne() || isr.pe() {
            bump(&RX_ERRORS, 1);
            r.icr().write(|w| {
                w.set_ore(true);
                w.set_fe(true);
                w.set_ne(true);
                w.set_pe(true);
            });
        }
        while r.isr().read().rxne() {
            let b = (r.rdr().read().dr() & 0xFF) as u8;
            if self.ring.enqueue(b).is_err() {
                bump(&RX_DROPPED, 1);
            }
        }
    }
}

/// The receiving end (thread mode, e.g. the command parser).
pub struct UartRx {
    ring: Consumer<'static, u8>,
}

impl UartRx {
    /// The next received byte, if any.
    pub fn read(&mut self) -> Option<u8> {
        self.ring.dequeue()
    }
}
