//! Counting instructions on the emulated board with SysTick.
//!
//! QEMU models no DWT cycle counter. Under `-icount shift=0,sleep=off` each
//! executed instruction advances virtual time by exactly 1 ns, and SysTick,
//! clocked by the 25 MHz core clock (`CLKSOURCE` = processor clock), counts
//! down once per 40 ns: one tick = 40 instructions. [`calibrate`] checks
//! that ratio on the running machine with a loop of known length.
//!
//! # Design
//! SysTick runs free (reload 2²⁴ − 1, no interrupt); a span is the
//! difference of two reads, modulo 2²⁴ (spans must stay below 0.67 s).
//!
//! A 40-instruction tick is coarse, and the sample interrupt starts at the
//! same point of the tick grid every time (the timer period, 2,500 ticks, is
//! a whole number of ticks), so a plain average of tick counts would carry a
//! bias of up to one tick. [`dither`] therefore executes 0–39 extra
//! instructions before the first read, a different amount for each of 40
//! consecutive samples, which spreads the start over the whole tick, so the
//! average of the tick counts resolves a fraction of a tick. [`calibrate`]
//! checks it: a known 1,002-instruction difference reads 1,007 through the
//! dither (about ±5 instructions, against ±40 without it).

use core::arch::asm;

use cortex_m::peripheral::syst::SystClkSource;
use cortex_m::peripheral::SYST;

/// Largest SysTick reload: the counter is 24 bits wide.
const SYST_MAX: u32 = 0x00FF_FFFF;

/// Instructions per SysTick tick expected under `-icount shift=0`:
/// 1 instruction = 1 ns and the 25 MHz core clock ticks every 40 ns.
pub const EXPECTED_INSTRUCTIONS_PER_TICK: u32 = 40;

/// Number of distinct dither offsets (one full tick of instructions).
pub const DITHER_STEPS: u32 = 40;

/// Start SysTick as a free-running 24-bit down counter on the core clock.
/// It takes `SYST` by value so nothing else can reconfigure it afterwards;
/// the counter is then read through [`now`].
pub fn start_systick(mut syst: SYST) {
    syst.disable_interrupt();
    syst.set_clock_source(SystClkSource::Core);
    syst.set_reload(SYST_MAX);
    syst.clear_current();
    syst.enable_counter();
}

/// Current SysTick value (counts down).
#[inline(always)]
pub fn now() -> u32 {
    SYST::get_current()
}

/// Ticks from `start` to `end` (two [`now`] readings), modulo 2²⁴.
#[inline(always)]
pub fn ticks_between(start: u32, end: u32) -> u32 {
    start.wrapping_sub(end) & SYST_MAX
}

/// Exactly `2·n` instructions (n ≥ 1): `subs` + `bne` per iteration.
#[inline(never)]
pub fn spin2(n: u32) {
    // SAFETY: a register-only countdown loop; no memory, no stack.
    unsafe {
        asm!(
            "2:",
            "subs {0}, #1",
            "bne 2b",
            inout(reg) n.max(1) => _,
            options(nomem, nostack),
        );
    }
}

/// Exactly `3·n` instructions (n ≥ 1): `nop` + `subs` + `bne` per iteration.
#[inline(never)]
pub fn spin3(n: u32) {
    // SAFETY: a register-only countdown loop; no memory, no stack.
    unsafe {
        asm!(
            "2:",
            "nop",
            "subs {0}, #1",
            "bne 2b",
            inout(reg) n.max(1) => _,
            options(nomem, nostack),
        );
    }
}

/// Execute `c + 2·(k mod 20) + 3·((k / 20) mod 2)` instructions for a
/// constant c: over any 40 consecutive `k` the offsets 2a + 3b (a < 20,
/// b < 2) take every value mod 40 exactly once.
#[inline(always)]
pub fn dither(k: u32) {
    let step = k % DITHER_STEPS;
    spin2(step % 20 + 1);
    spin3(step / 20 + 1);
}

/// What [`calibrate`] measured.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Calibration {
    /// Instructions in the reference span (a difference of two loops).
    pub instructions: u32,
    /// SysTick ticks the reference span took.
    pub ticks: u32,
    /// Instructions in the dither check's known difference.
    pub dither_instructions: u32,
    /// That difference as measured through [`dither`], in instructions
    /// (averaged over [`DITHER_STEPS`] × repeats).
    pub dither_measured: f32,
}

impl Calibration {
    /// Instructions per tick as measured.
    pub fn instructions_per_tick(&self) -> f32 {
        self.instructions as f32 / self.ticks.max(1) as f32
    }

    /// True if the measured ratio is 40 instructions per tick within 0.01%
    /// and the dithered average is within 1% of the known span (it reads
    /// 1,007 for 1,002 here: sub-tick resolution of about ±5 instructions).
    pub fn is_as_expected(&self) -> bool {
        let expected = (EXPECTED_INSTRUCTIONS_PER_TICK * self.ticks) as f32;
        let ratio_ok = (self.instructions as f32 - expected).abs() <= 1e-4 * expected;
        let known = self.dither_instructions as f32;
        let dither_ok = (self.dither_measured - known).abs() <= 1e-2 * known;
        ratio_ok && dither_ok
    }
}

/// Measure instructions per SysTick tick, and the dither's resolution.
///
/// Ratio: `spin2(N₂)` minus `spin2(N₁)` is exactly 2·(N₂ − N₁) = 4·10⁶
/// instructions (same call site, so call overhead cancels), timed with
/// interrupts masked; the tick count is exact to ±1 in 10⁵.
///
/// Dither: like the sample interrupt, each run starts at a fixed point of
/// the tick grid (right after a SysTick edge), then [`dither`]s and times
/// `spin2`; the difference of 501 iterations (1,002 instructions,
/// 25.05 ticks) is averaged over 25 × 40 runs. Without the dither every run
/// would read the same 25 or 26 ticks (1,000 or 1,040 instructions).
pub fn calibrate() -> Calibration {
    const N1: u32 = 100_000;
    const N2: u32 = N1 + 2_000_000;
    let time = |n: u32| {
        cortex_m::interrupt::free(|_| {
            let t0 = now();
            spin2(n);
            ticks_between(t0, now())
        })
    };
    let ticks = time(N2) - time(N1);

    const SHORT: u32 = 10;
    const LONG: u32 = SHORT + 501;
    const REPEATS: u32 = 25;
    // Coprime with 1,000: i ↦ i·SCRAMBLE mod 1,000 is a permutation.
    const SCRAMBLE: u32 = 617;
    let timed = |k: u32, n: u32| {
        cortex_m::interrupt::free(|_| {
            sync_to_tick();
            dither(k);
            let t0 = now();
            spin2(n);
            ticks_between(t0, now())
        })
    };
    let mut diff_ticks: i64 = 0;
    for i in 0..DITHER_STEPS * REPEATS {
        // Unlike the interrupt's, this loop's start phase depends on the
        // previous runs; a scrambled dither order keeps it independent of
        // the dither (each offset still used 25 times).
        let k = i.wrapping_mul(SCRAMBLE) % (DITHER_STEPS * REPEATS);
        diff_ticks += i64::from(timed(k, LONG)) - i64::from(timed(k, SHORT));
    }
    let runs = (DITHER_STEPS * REPEATS) as f32;
    Calibration {
        instructions: 2 * (N2 - N1),
        ticks,
        dither_instructions: 2 * (LONG - SHORT),
        dither_measured: diff_ticks as f32 * EXPECTED_INSTRUCTIONS_PER_TICK as f32 / runs,
    }
}

/// Return just after SysTick's next decrement (a fixed point of the tick
/// grid, to within one polling loop).
fn sync_to_tick() {
    let start = now();
    while now() == start {}
}

/// Sum of spans of one code section, in ticks.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct SpanSum {
    /// Total ticks.
    pub ticks: u64,
    /// Spans added.
    pub count: u32,
    /// Longest span, ticks.
    pub max_ticks: u32,
}

impl SpanSum {
    /// Add the span from `start` to `end` (two [`now`] readings).
    #[inline(always)]
    pub fn add(&mut self, start: u32, end: u32) {
        let t = ticks_between(start, end);
        self.ticks = self.ticks.wrapping_add(u64::from(t));
        self.count = self.count.saturating_add(1);
        self.max_ticks = self.max_ticks.max(t);
    }

    /// Add a span already measured, in ticks.
    #[inline(always)]
    pub fn add_ticks(&mut self, t: u32) {
        self.ticks = self.ticks.wrapping_add(u64::from(t));
        self.count = self.count.saturating_add(1);
        self.max_ticks = self.max_ticks.max(t);
    }

    /// Mean instructions per span at `instructions_per_tick`.
    pub fn mean_instructions(&self, instructions_per_tick: f32) -> f32 {
        if self.count == 0 {
            return 0.0;
        }
        self.ticks as f32 * instructions_per_tick / self.count as f32
    }
}

/// The robust estimator's update locks timed on SysTick
/// ([`beamest::link::RobustUpdates`](crate::link::RobustUpdates)).
impl crate::link::LockSpans for SpanSum {
    type Instant = u32;
    fn now() -> u32 {
        now()
    }
    fn add(&mut self, start: u32, end: u32) {
        SpanSum::add(self, start, end);
    }
}

/// Burn `256·n` instructions (n ≥ 1) in straight-line blocks: the cheapest
/// busy idle for QEMU to emulate (one translation block per 256
/// instructions instead of per loop iteration).
#[inline(never)]
pub fn idle_block(n: u32) {
    // SAFETY: a register-only countdown loop; no memory, no stack.
    unsafe {
        asm!(
            "2:",
            ".rept 254",
            "nop",
            ".endr",
            "subs {0}, #1",
            "bne 2b",
            inout(reg) n.max(1) => _,
            options(nomem, nostack),
        );
    }
}

/// A blocking delay for the converters' start-up (e.g. the ADS131M02's
/// t_REGACQ): under `-icount shift=0` one instruction is one nanosecond, so
/// `spin2(ns/2)` waits at least `ns` of virtual time.
#[derive(Debug, Clone, Copy, Default)]
pub struct SpinDelay;

impl embedded_hal::delay::DelayNs for SpinDelay {
    fn delay_ns(&mut self, ns: u32) {
        spin2(ns / 2 + 1);
    }
}
