//! CPU cycle counting with the DWT cycle counter (Cortex-M7, 400 MHz:
//! one count = 2.5 ns, wraps every 10.7 s).
//!
//! Unlike QEMU, the real core has CYCCNT; it counts core clock cycles,
//! stalls included (flash wait states, FPU latencies), so these are the
//! numbers that matter against the 40,000-cycle sample period.

use cortex_m::peripheral::{DCB, DWT};

/// Enable the trace block and start CYCCNT. On the Cortex-M7 the DWT is
/// behind a software lock (DWT_LAR), which `unlock` opens first.
pub fn start(dcb: &mut DCB, dwt: &mut DWT) {
    dcb.enable_trace();
    DWT::unlock();
    dwt.enable_cycle_counter();
}

/// The cycle counter now.
#[inline(always)]
pub fn now() -> u32 {
    DWT::cycle_count()
}

/// Cycles from `start` to `end` (two [`now`] readings, modulo 2³²).
#[inline(always)]
pub fn between(start: u32, end: u32) -> u32 {
    end.wrapping_sub(start)
}

/// Sum, count and maximum of cycle spans (saturating, never panics).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Spans {
    /// Sum of the spans, cycles.
    pub total: u64,
    /// Spans added.
    pub count: u32,
    /// Longest span, cycles.
    pub max: u32,
}

impl Spans {
    /// Add one span of `cycles`.
    #[inline(always)]
    pub fn add(&mut self, cycles: u32) {
        self.total = self.total.saturating_add(u64::from(cycles));
        self.count = self.count.saturating_add(1);
        self.max = self.max.max(cycles);
    }

    /// Mean span in cycles (0 if empty).
    pub fn mean(&self) -> u32 {
        match self.total.checked_div(u64::from(self.count)) {
            Some(m) => u32::try_from(m).unwrap_or(u32::MAX),
            None => 0,
        }
    }
}

/// Missed sample periods between two interrupt entries `gap` cycles apart
/// at `period` cycles per sample: round(gap/period) − 1, so a gap within
/// half a period of one period (interrupt latency jitter) counts as none.
pub fn missed_periods(gap: u32, period: u32) -> u32 {
    if period == 0 {
        return 0;
    }
    let rounded = gap.saturating_add(period / 2) / period;
    rounded.saturating_sub(1)
}

/// A busy-wait delay on the core clock (embedded-hal 1.0 `DelayNs`), for
/// the ADC's reset wait and the SPI devices' chip-select timing; never
/// panics, unlike `embedded_hal_bus::spi::NoDelay`.
#[derive(Debug, Clone, Copy)]
pub struct CycleDelay {
    cpu_hz: u32,
}

impl CycleDelay {
    /// A delay for a core clock of `cpu_hz`.
    pub const fn new(cpu_hz: u32) -> Self {
        Self { cpu_hz }
    }
}

impl embedded_hal::delay::DelayNs for CycleDelay {
    fn delay_ns(&mut self, ns: u32) {
        // cycles = ns·f/1e9, rounded up; u64 so 4.29 s at 400 MHz fits.
        let cycles = (u64::from(ns) * u64::from(self.cpu_hz)).div_ceil(1_000_000_000);
        let mut left = cycles;
        while left > 0 {
            let chunk = u32::try_from(left).unwrap_or(u32::MAX);
            cortex_m::asm::delay(chunk);
            left -= u64::from(chunk);
        }
    }
}

/// Lock spans of the robust estimator's model updates, in cycles
/// ([`crate::link::RobustUpdates`]).
impl crate::link::LockSpans for Spans {
    type Instant = u32;
    fn now() -> u32 {
        now()
    }
    fn add(&mut self, start: u32, end: u32) {
        Spans::add(self, between(start, end));
    }
}
