//! Tests of [`super::TimedPlant`]: against [`ModalPlant`] when ideal, and
//! against a brute-force simulation (fine sub-steps, the sinc³ average by
//! Simpson's rule) with the board's timing.

use super::*;
use crate::model::{PAPER_B, PAPER_OMEGA, PAPER_ZETA};

const TS: f64 = 1e-4;

fn paper(ts: f64) -> ModalPlant<f64> {
    ModalPlant::with_numerator(&PAPER_OMEGA, &PAPER_ZETA, &PAPER_B, ts).unwrap()
}

/// A drive that steps often and by uneven amounts.
fn drive(k: usize) -> f64 {
    let square = if (k / 37) % 2 == 0 { 1.0 } else { -0.7 };
    square + 0.2 * libm::sin(0.31 * k as f64)
}

#[test]
fn ideal_timing_is_the_modal_plant() {
    let mut reference = paper(TS);
    let mut timed = TimedPlant::new(&reference, ConverterTiming::IDEAL).unwrap();
    for k in 0..5000 {
        let u = drive(k);
        reference.advance(u);
        timed.advance(u);
        // Bit for bit: the same matrix exponential, the same sums.
        assert_eq!(timed.output(), reference.output(), "{k}");
        assert_eq!(timed.measured(), timed.output());
        assert_eq!(timed.measured_drive(), u);
    }
}

/// Sub-steps per sample of the brute-force simulation (even, for Simpson;
/// the DAC switch at 0.15·Ts falls on an even node).
const FINE: usize = 600;

/// ∫₀¹ w(s)·v(s) ds by Simpson's rule over the FINE + 1 nodes of `v`.
fn simpson(v: &[f64], w: impl Fn(f64) -> f64) -> f64 {
    let h = 1.0 / FINE as f64;
    let mut acc = 0.0;
    for (n, vn) in v.iter().enumerate() {
        let c = if n == 0 || n == FINE {
            1.0
        } else if n % 2 == 1 {
            4.0
        } else {
            2.0
        };
        acc += c * w(n as f64 * h) * vn;
    }
    acc * h / 3.0
}

/// The sinc³ weights of the period 0 (newest), 1, 2 before the tick.
fn weight(i: usize, s: f64) -> f64 {
    match i {
        0 => 0.5 * (1.0 - s) * (1.0 - s),
        1 => 0.5 + s - s * s,
        _ => 0.5 * s * s,
    }
}

#[test]
fn sinc3_and_dac_latency_match_a_brute_force_simulation() {
    let latency = 15e-6;
    let switch = (latency / TS * FINE as f64).round() as usize;
    assert_eq!(switch, 90);
    let timing = ConverterTiming {
        sinc3: true,
        dac_latency_s: latency,
    };
    let mut timed = TimedPlant::new(&paper(TS), timing).unwrap();
    let mut fine = paper(TS / FINE as f64);
    // Node values of y and of the drive over the last three periods.
    let mut y_periods: Vec<Vec<f64>> = Vec::new();
    let mut u_periods: Vec<Vec<f64>> = Vec::new();
    let (mut u_old, mut worst, mut worst_u, mut peak) = (0.0, 0.0f64, 0.0f64, 0.0f64);
    for k in 0..3000 {
        let u = drive(k);
        timed.advance(u);
        let mut ys = vec![fine.output()];
        let mut us = vec![u_old];
        for n in 0..FINE {
            let held = if n < switch { u_old } else { u };
            fine.advance(held);
            ys.push(fine.output());
            // The staircase's value at node n + 1 (the right limit at the
            // switch node: Simpson then sees the jump on a panel boundary).
            us.push(if n + 1 < switch { u_old } else { u });
        }
        u_old = u;
        y_periods.insert(0, ys);
        u_periods.insert(0, us);
        y_periods.truncate(3);
        u_periods.truncate(3);
        // Point output: the fine simulation at the tick.
        let y_tick = *y_periods[0].last().unwrap();
        assert!((timed.output() - y_tick).abs() <= 1e-11 * (1.0 + y_tick.abs()));
        if k >= 2 {
            let bf: f64 = (0..3)
                .map(|i| simpson(&y_periods[i], |s| weight(i, s)))
                .sum();
            worst = worst.max((timed.measured() - bf).abs());
            peak = peak.max(bf.abs());
            // The drive jumps at the switch: split its panels there.
            let bu: f64 = (0..3)
                .map(|i| {
                    let (old, new) = (u_periods[i][0], u_periods[i][FINE]);
                    let a = switch as f64 / FINE as f64;
                    let int = |lo: f64, hi: f64| {
                        // ∫ w over [lo, hi] by Simpson on one panel (w is quadratic: exact).
                        (hi - lo) / 6.0
                            * (weight(i, lo) + 4.0 * weight(i, 0.5 * (lo + hi)) + weight(i, hi))
                    };
                    old * int(0.0, a) + new * int(a, 1.0)
                })
                .sum();
            worst_u = worst_u.max((timed.measured_drive() - bu).abs());
        }
    }
    println!(
        "sinc3 y: worst |model − brute force| {worst:.2e} of peak {peak:.3e}; drive {worst_u:.2e}"
    );
    assert!(peak > 1e-3, "{peak}");
    assert!(worst <= 1e-9 * peak, "{worst:e} vs peak {peak:e}");
    assert!(worst_u <= 1e-13, "{worst_u:e}");
}

#[test]
fn sinc3_settles_in_three_conversions() {
    // The monitor's view of a unit step written at tick 0 with no DAC
    // latency: 1/6, 5/6, then 1 (the M₃ weights' masses: the data sheet's
    // three-conversion settling).
    let timing = ConverterTiming {
        sinc3: true,
        dac_latency_s: 0.0,
    };
    let mut p = TimedPlant::new(&paper(TS), timing).unwrap();
    let mut seen = [0.0; 4];
    for s in seen.iter_mut() {
        p.advance(1.0);
        *s = p.measured_drive();
    }
    let expect = [1.0 / 6.0, 5.0 / 6.0, 1.0, 1.0];
    for (s, e) in seen.iter().zip(expect) {
        assert!((s - e).abs() < 1e-15, "{seen:?}");
    }
    // DC: the sinc³ of the beam's settled step response is its DC gain.
    for _ in 0..400_000 {
        p.advance(1.0);
    }
    assert!((p.measured() - p.output()).abs() < 1e-12 * p.output().abs());
}

#[test]
fn rejects_bad_timing() {
    let plant = paper(TS);
    for dac_latency_s in [-1e-6, TS, f64::NAN, f64::INFINITY] {
        let t = ConverterTiming {
            sinc3: true,
            dac_latency_s,
        };
        assert_eq!(TimedPlant::new(&plant, t).err(), Some(PlantError::Value));
    }
    let t = ConverterTiming {
        sinc3: false,
        dac_latency_s: 0.99 * TS,
    };
    assert_eq!(TimedPlant::new(&plant, t).unwrap().timing(), t);
}
