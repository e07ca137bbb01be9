//! Integer sine for the direct digital synthesis (DDS) generators: a 32-bit
//! phase (2³² = one cycle) → sin(2π·phase/2³²) in Q30 (±2³⁰ = ±1).
//!
//! # Design
//! A quarter-wave table of `QUARTER` + 1 entries (1 KiB of flash) with
//! linear interpolation on the next 16 phase bits: 1,024 segments per
//! cycle, so the interpolation error is at most (2π/1024)²/8 = 4.7e-6 of
//! full scale (−107 dB; the unit test's worst case lies between 3e-6 and
//! 4.8e-6). Per call: two table reads, one 32×32→64 multiply, a few shifts
//! and a sign flip — no floating point, so the f32 and f64 builds produce
//! identical waveforms. `libm::sinf` evaluates its kernel in `f64`, which
//! is software on a single-precision FPU such as the Cortex-M4F's (x86
//! instruction counts of both in `BENCHMARKS.md`).
//!
//! The table is computed at compile time by a `const fn` Taylor series in
//! `f64` (error < 1e-16 on [0, π/2]), so no literal table is checked in.

/// Table entries per quarter cycle.
pub(crate) const QUARTER: usize = 256;
/// Q30 unity: sin = 1 is `ONE_Q30`.
pub(crate) const ONE_Q30: i32 = 1 << 30;
/// log2 of [`QUARTER`].
const QUARTER_BITS: u32 = 8;
/// Phase bits below the table index, within a quarter (30 − 8).
const FRAC_BITS: u32 = 30 - QUARTER_BITS;
/// Fraction bits actually used for the interpolation.
const INTERP_BITS: u32 = 16;

/// sin(x) for 0 ≤ x ≤ π/2 by its Taylor series (const-evaluable).
const fn taylor_sin(x: f64) -> f64 {
    let x2 = x * x;
    let mut term = x;
    let mut sum = x;
    let mut k = 1;
    while k < 15 {
        term = -term * x2 / ((2 * k) as f64 * (2 * k + 1) as f64);
        sum += term;
        k += 1;
    }
    sum
}

// Evaluated at compile time only: an out-of-range index would be a
// compile error, never a run-time panic.
#[allow(clippy::indexing_slicing)]
const fn build_table() -> [i32; QUARTER + 1] {
    let mut t = [0i32; QUARTER + 1];
    let mut i = 0;
    while i <= QUARTER {
        let x = core::f64::consts::FRAC_PI_2 * i as f64 / QUARTER as f64;
        let v = taylor_sin(x) * ONE_Q30 as f64;
        // Round half away from zero (v ≥ 0 here).
        t[i] = (v + 0.5) as i32;
        i += 1;
    }
    t
}

/// sin at the quarter-wave nodes, Q30.
static TABLE: [i32; QUARTER + 1] = build_table();

/// sin(2π·phase/2³²) in Q30, |result| ≤ 2³⁰. Never panics.
#[inline]
pub(crate) fn sin_q30(phase: u32) -> i32 {
    let quadrant = phase >> 30;
    let within = phase & (ONE_Q30 as u32 - 1);
    // Quadrants 1 and 3 run the table backwards: sin(π/2 + x) = sin(π/2 − x).
    let p = if quadrant & 1 == 0 {
        within
    } else {
        (ONE_Q30 as u32) - within
    };
    let idx = (p >> FRAC_BITS) as usize;
    let frac = (p >> (FRAC_BITS - INTERP_BITS)) & ((1 << INTERP_BITS) - 1);
    let a = TABLE.get(idx).copied().unwrap_or(ONE_Q30);
    let b = TABLE.get(idx + 1).copied().unwrap_or(ONE_Q30);
    let v = a + ((i64::from(b - a) * i64::from(frac)) >> INTERP_BITS) as i32;
    if quadrant >= 2 {
        -v
    } else {
        v
    }
}

/// cos(2π·phase/2³²) in Q30.
#[inline]
#[cfg(test)]
pub(crate) fn cos_q30(phase: u32) -> i32 {
    sin_q30(phase.wrapping_add(1 << 30))
}

#[cfg(test)]
#[allow(clippy::unwrap_used, clippy::indexing_slicing)]
mod tests {
    use super::*;

    #[test]
    fn table_matches_libm() {
        for (i, &t) in TABLE.iter().enumerate() {
            let x = core::f64::consts::FRAC_PI_2 * i as f64 / QUARTER as f64;
            let exact = libm::sin(x) * ONE_Q30 as f64;
            assert!((t as f64 - exact).abs() <= 0.5 + 1e-6, "i={i}");
        }
        assert_eq!(TABLE[0], 0);
        assert_eq!(TABLE[QUARTER], ONE_Q30);
    }

    #[test]
    fn interpolated_sine_error_below_5e_6() {
        let mut worst = 0.0f64;
        // Every 4099th phase (odd stride: visits all quadrants and fractions).
        let mut p: u32 = 0;
        for _ in 0..1_100_000 {
            let got = sin_q30(p) as f64 / ONE_Q30 as f64;
            let exact = libm::sin(2.0 * core::f64::consts::PI * p as f64 / 4_294_967_296.0);
            worst = worst.max((got - exact).abs());
            p = p.wrapping_add(3_904_819);
        }
        assert!(worst < 4.8e-6, "{worst}");
        assert!(
            worst > 3.0e-6,
            "{worst}: the bound should be nearly reached"
        );
        // Exact at the quadrant points, odd symmetry, cos = shifted sin.
        assert_eq!(sin_q30(0), 0);
        assert_eq!(sin_q30(1 << 30), ONE_Q30);
        assert_eq!(sin_q30(2 << 30), 0);
        assert_eq!(sin_q30(3 << 30), -ONE_Q30);
        assert_eq!(cos_q30(0), ONE_Q30);
        for p in [1u32, 12345, 0x1234_5678, 0x7fff_ffff] {
            assert_eq!(sin_q30(p.wrapping_neg()), -sin_q30(p), "{p}");
        }
    }
}
