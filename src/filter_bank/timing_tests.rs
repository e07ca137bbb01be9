//! The u-channel timing against the simulated converters: with the rig's
//! timing modelled, the paper's true Θ explains the regression (eq. 29)
//! to rounding; without it, it does not.

use super::*;
use crate::excitation::SquareWave;
use crate::filter_bank::{FilterBank, FilterConfig, FilterConfigError, Scaling, SignalScales};
use crate::model::{paper_plant_tf, PAPER_B, PAPER_OMEGA, PAPER_ZETA};
use crate::rig::ModalPlant;
use crate::rig::{ConverterTiming, TimedPlant};

const TS: f64 = 1e-4;
/// The board's DAC latency (s).
const DAC_S: f64 = 15e-6;

fn cfg(timing: OutputTiming) -> FilterConfig {
    FilterConfig {
        scales: SignalScales {
            u_scale: 0.1,
            y_scale: 1e-3,
        },
        timing,
        ..FilterConfig::default()
    }
}

/// Largest |y/Y0 − θᵀφ| with the paper's true θ over 3 s of the paper's
/// square wave, the beam behind converters with `rig` timing and the bank
/// modelling `bank`; and the largest |y/Y0|.
fn regression_residual(rig: ConverterTiming, bank: OutputTiming) -> (f64, f64) {
    let c = cfg(bank);
    let mut theta = [0.0; 7];
    paper_plant_tf()
        .to_theta(c.lambda_rad_s, &mut theta)
        .unwrap();
    let theta_s = Scaling::<7>::new(&c).to_scaled(&theta);
    let plant = ModalPlant::with_numerator(&PAPER_OMEGA, &PAPER_ZETA, &PAPER_B, TS).unwrap();
    let mut plant = TimedPlant::new(&plant, rig).unwrap();
    let mut fb = FilterBank::<f64, 4, 7>::new(&c).unwrap();
    let mut sq = SquareWave::<f64>::paper();
    let (mut worst, mut peak) = (0.0f64, 0.0f64);
    for _ in 0..30_000 {
        let y = plant.measured();
        let u = sq.next_sample();
        let r = fb.push(u, y);
        let fit: f64 = r.phi.iter().zip(theta_s.iter()).map(|(p, t)| p * t).sum();
        worst = worst.max((r.y - fit).abs());
        peak = peak.max(r.y.abs());
        plant.advance(u);
    }
    (worst, peak)
}

#[test]
fn modelled_timing_makes_the_regression_exact_again() {
    let board = ConverterTiming {
        sinc3: true,
        dac_latency_s: DAC_S,
    };
    let sinc3 = OutputTiming::sinc3_adc(DAC_S, TS);
    let delay = OutputTiming {
        average: OutputAverage::Point,
        ..sinc3
    };
    let (ideal, peak) = regression_residual(ConverterTiming::IDEAL, OutputTiming::IDEAL);
    let (ignored, _) = regression_residual(board, OutputTiming::IDEAL);
    let (as_delay, _) = regression_residual(board, delay);
    let (as_sinc3, _) = regression_residual(board, sinc3);
    std::println!(
        "|y/Y0 − θᵀφ| (peak |y/Y0| {peak:.2}): ideal rig {ideal:.1e}; board rig: \
         timing ignored {ignored:.1e}, as a delay {as_delay:.1e}, as sinc3 {as_sinc3:.1e}"
    );
    assert!(peak > 1.0);
    // The bank's own floor (the quintic hold on y across the square
    // wave's steps: 1.1e-8 measured).
    assert!(ideal < 1e-7, "{ideal:e}");
    // The board's timing breaks the regression (8.5e-3 measured)…
    assert!(ignored > 1e-4 * peak, "{ignored:e}");
    // …a pure delay leaves the sinc³'s droop (4.8e-6 measured), the exact
    // kernel nothing beyond the hold's floor (2.1e-9: the sinc³-smoothed y
    // interpolates better than the point samples).
    assert!(
        as_delay < 1e-2 * ignored && as_delay > 100.0 * ideal,
        "{as_delay:e}"
    );
    assert!(as_sinc3 <= ideal, "{as_sinc3:e}");
}

#[test]
fn integer_delay_is_the_input_fed_late() {
    let late = cfg(OutputTiming {
        delay_samples: 2.0,
        average: OutputAverage::Point,
    });
    let mut a = FilterBank::<f64, 4, 7>::new(&late).unwrap();
    let mut b = FilterBank::<f64, 4, 7>::new(&cfg(OutputTiming::IDEAL)).unwrap();
    let mut sq = SquareWave::<f64>::paper();
    let mut u_hist = [0.0; 3];
    for k in 0..5_000 {
        let u = sq.next_sample() * (1.0 + 0.01 * k as f64);
        let y = libm::sin(0.01 * k as f64);
        u_hist = [u, u_hist[0], u_hist[1]];
        let (ra, rb) = (a.push(u, y), b.push(u_hist[2], y));
        assert_eq!(ra, rb, "{k}");
    }
}

#[test]
fn tap_counts_and_bad_timing() {
    let taps = |t: OutputTiming| {
        let (aug, n) =
            crate::filter_bank::FilterMatrices::<4>::augmented(&[1.0, 4.0, 6.0, 4.0], 0.01);
        InputTaps::<4>::new(&aug, n, &t)
    };
    let point = |d| OutputTiming {
        delay_samples: d,
        average: OutputAverage::Point,
    };
    let sinc3 = |d| OutputTiming {
        delay_samples: d,
        average: OutputAverage::Sinc3,
    };
    // (count, history index of u_{n−3−i} for the first tap)
    let got = |t| {
        let x = taps(t);
        (x.count, x.first)
    };
    assert_eq!(got(OutputTiming::IDEAL), (1, 3));
    assert_eq!(got(point(1.0)), (1, 4));
    assert_eq!(got(point(1.65)), (2, 4));
    assert_eq!(got(point(3.0)), (1, 6));
    assert_eq!(got(sinc3(1.5)), (4, 3));
    assert_eq!(got(sinc3(1.0)), (5, 2));
    assert_eq!(got(sinc3(1.65)), (5, 3));
    assert_eq!(got(sinc3(3.0)), (5, 4));
    // The taps sum to the hold's gain: the kernels have unit mass.
    let ideal = taps(OutputTiming::IDEAL).gains[0];
    for t in [point(1.65), sinc3(1.65), sinc3(2.9)] {
        let x = taps(t);
        let mut sum = [0.0; 4];
        for g in x.gains.iter().take(x.count) {
            for (s, v) in sum.iter_mut().zip(g) {
                *s += v;
            }
        }
        // Equal at DC only up to the filter's phase: compare the lowest
        // state's gain, whose DC response is exactly the input's mass.
        assert!((sum[0] / ideal[0] - 1.0).abs() < 0.2, "{t:?}");
    }
    for bad in [
        point(-0.1),
        point(3.1),
        point(f64::NAN),
        sinc3(0.9),
        sinc3(3.1),
    ] {
        assert!(!bad.is_valid());
        assert_eq!(
            FilterBank::<f64, 4, 7>::new(&cfg(bad)).err(),
            Some(FilterConfigError::Timing)
        );
    }
}

/// The direct term's input (an accelerometer's, `FilterConfig::output`):
/// the kernel's left limit at the regressor's instant t_{n−2}.
#[test]
fn direct_weights_are_the_input_as_the_sample_sees_it() {
    // Ideal: u_{n−3}, the input held before y_{n−2} was read.
    let w = OutputTiming::IDEAL.direct_weights();
    assert_eq!(w[3], 1.0);
    assert_eq!(w.iter().sum::<f64>(), 1.0);
    // A point sample one period late: u_{n−4}.
    let late = OutputTiming {
        delay_samples: 1.0,
        average: OutputAverage::Point,
    };
    assert_eq!(late.direct_weights()[4], 1.0);
    // Half a period late: u_{n−3}, whose age 1 lies in the box [0.5, 1.5).
    let half = OutputTiming {
        delay_samples: 0.5,
        average: OutputAverage::Point,
    };
    assert_eq!(half.direct_weights()[3], 1.0);
    // The sinc³ at its group delay: the cubic B-spline's 1/6, 4/6, 1/6.
    let sinc3 = OutputTiming::sinc3_adc(0.0, 1e-4).direct_weights();
    for (j, want) in [(3, 1.0 / 6.0), (4, 4.0 / 6.0), (5, 1.0 / 6.0)] {
        assert!((sinc3[j] - want).abs() < 1e-15, "{j}: {}", sinc3[j]);
    }
    assert!((sinc3.iter().sum::<f64>() - 1.0).abs() < 1e-14);
}
