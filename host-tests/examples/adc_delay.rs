//! How much the reference board's converter timing biases the identified
//! modes, on the paper's simulated plant (Wang, Costa-Castelló, Na et al.,
//! *Modelling and Adaptive Parameter Estimation for a Piezoelectric
//! Cantilever Beam*, Section IV.A, eq. 46), `f64`, λ = 100 rad/s, u =
//! 0.1·square(7 Hz), 20 s (docs/RIG.md, "Filter delay"):
//!
//! ```sh
//! cargo run --release -p host-tests --example adc_delay
//! ```
//!
//! The estimator assumes y(t_k) is the output at the tick and u_k is held
//! from the tick on. On the board neither is exact:
//! * the ADS131M02's sinc3 filter (OSR 256) averages the modulator's
//!   samples over the last 3·256 modulator periods with triangular-squared
//!   weights: a linear-phase FIR whose group delay is (3·256 − 2)/2 = 383
//!   modulator periods = 1.496 output samples (ADS131M02 data sheet
//!   §8.3.7: sinc3, data at f_MOD/OSR);
//! * the DAC is written after the ADC frame is read: about 15 µs after
//!   DRDY at the board's SPI clocks (12-byte ADC frame at 10 MHz, then the
//!   3-byte DAC word at 12.5 MHz), so u_k starts 0.15 sample late.
//!
//! The plant is simulated at the modulator rate (2.56 MHz, 256 steps per
//! sample) with exact zero-order-hold discretisation; each variant feeds
//! the same estimator procedure as the firmware (Y0 = RMS of y over the
//! first 0.1 s, then one invalid sample to arm the input quarantine).
//! Printed: the final relative errors of ω and ζ against the truth, and the
//! change caused by the timing (against the ideal variant). A last variant
//! shows what an integer compensation would buy: the estimator fed u one
//! sample late, leaving 1.494 + 0.148 − 1 = 0.64 samples of delay.

use beamest::estimator::{Adaptive2, AdaptiveConfig, Estimator};
use beamest::excitation::SquareWave;
use beamest::filter_bank::{FilterConfig, SignalScales};
use beamest::modal::modal_from_tf;
use beamest::model::{PAPER_B, PAPER_OMEGA, PAPER_ZETA};
use beamest::plant::ModalPlant;

/// Sample period (s).
const TS: f64 = 1e-4;
/// Modulator periods per sample (the ADS131M02's OSR).
const OSR: usize = 256;
/// Run length, samples (20 s).
const SAMPLES: usize = 200_000;
/// Start-up window for Y0, samples (0.1 s).
const STARTUP: usize = 1_000;
/// DAC update delay after DRDY on the board (s), see the module doc.
const DAC_DELAY_S: f64 = 15e-6;

/// How the simulated converters sample.
#[derive(Clone, Copy)]
struct Timing {
    name: &'static str,
    /// y is the sinc3 average (else a point sample).
    sinc3: bool,
    /// Point sample this many modulator periods before the tick.
    point_delay: usize,
    /// u_k starts this many modulator periods after the tick.
    dac_delay: usize,
    /// The estimator is fed u from this many samples earlier (an integer
    /// compensation of the delay on y; 0 = none, as the pipeline does).
    u_lag: usize,
}

/// Sinc3 weights over 3·OSR − 2 taps (three OSR-long boxes convolved),
/// normalised to unit sum; index 0 is the newest modulator sample.
fn sinc3_weights() -> Vec<f64> {
    let box1 = vec![1.0; OSR];
    let conv = |a: &[f64], b: &[f64]| {
        let mut c = vec![0.0; a.len() + b.len() - 1];
        for (i, x) in a.iter().enumerate() {
            for (j, y) in b.iter().enumerate() {
                c[i + j] += x * y;
            }
        }
        c
    };
    let w = conv(&conv(&box1, &box1), &box1);
    let sum: f64 = w.iter().sum();
    w.iter().map(|v| v / sum).collect()
}

/// Run one timing variant; returns (ω₁, ω₂, ζ₁, ζ₂).
fn run(t: Timing, weights: &[f64]) -> [f64; 4] {
    let mut plant =
        ModalPlant::<f64>::with_numerator(&PAPER_OMEGA, &PAPER_ZETA, &PAPER_B, TS / OSR as f64)
            .expect("the paper's plant");
    let mut square = SquareWave::<f64>::paper();
    // Modulator-rate output history, a ring (enough for sinc3 and the
    // point delays); `pos` is the next slot to write.
    let keep = weights.len().max(t.point_delay + 1);
    let mut hist: Vec<f64> = vec![0.0; keep];
    let mut pos = 0usize;
    let back = |hist: &[f64], pos: usize, age: usize| hist[(pos + keep - 1 - age) % keep];
    let mut u_prev = 0.0;
    let mut u_hist = [0.0_f64; 4];
    let mut est: Option<Adaptive2<f64>> = None;
    let mut sum_sq = 0.0;

    for k in 0..SAMPLES {
        // The conversion completed at this tick.
        let y = if t.sinc3 {
            weights
                .iter()
                .enumerate()
                .map(|(age, w)| w * back(&hist, pos, age))
                .sum()
        } else {
            back(&hist, pos, t.point_delay)
        };
        // The next excitation value, applied after the DAC delay.
        let u = square.next().expect("endless");
        u_hist.rotate_right(1);
        u_hist[0] = u;
        match est.as_mut() {
            Some(e) => {
                e.step(u_hist[t.u_lag], y);
            }
            None => {
                sum_sq += y * y;
                if k + 1 == STARTUP {
                    let y_rms = (sum_sq / STARTUP as f64).sqrt();
                    let filter = FilterConfig {
                        ts_s: TS,
                        lambda_rad_s: 100.0,
                        scales: SignalScales {
                            u_scale: 0.1,
                            y_scale: y_rms,
                        },
                        ..FilterConfig::default()
                    };
                    let mut e = Adaptive2::<f64>::new(&filter, &AdaptiveConfig::default())
                        .expect("estimator settings");
                    e.step(f64::NAN, f64::NAN);
                    est = Some(e);
                }
            }
        }
        // The plant over the next sample period at the modulator rate: the
        // old u until the DAC updates, then the new one.
        for j in 0..OSR {
            let held = if j < t.dac_delay { u_prev } else { u };
            plant.advance(held);
            hist[pos] = plant.output();
            pos = (pos + 1) % keep;
        }
        u_prev = u;
    }
    let est = est.expect("started");
    let m = modal_from_tf(&est.transfer_function(), &[-2.0, 2.0]).expect("modes");
    [m.omega_rad_s[0], m.omega_rad_s[1], m.zeta[0], m.zeta[1]]
}

fn main() {
    let weights = sinc3_weights();
    let group_delay: f64 = weights
        .iter()
        .enumerate()
        .map(|(i, w)| i as f64 * w)
        .sum::<f64>()
        / OSR as f64;
    let dac = (DAC_DELAY_S / TS * OSR as f64).round() as usize;
    println!(
        "sinc3 (OSR {OSR}): {} taps, group delay {group_delay:.4} samples; DAC delay {dac} \
         modulator periods = {:.3} samples",
        weights.len(),
        dac as f64 / OSR as f64
    );
    let variants = [
        Timing {
            name: "ideal (y at the tick, u from the tick)",
            sinc3: false,
            point_delay: 0,
            dac_delay: 0,
            u_lag: 0,
        },
        Timing {
            name: "pure 1.5-sample delay on y",
            sinc3: false,
            point_delay: 3 * OSR / 2,
            dac_delay: 0,
            u_lag: 0,
        },
        Timing {
            name: "sinc3 filter on y",
            sinc3: true,
            point_delay: 0,
            dac_delay: 0,
            u_lag: 0,
        },
        Timing {
            name: "sinc3 on y + DAC 15 us late (the board)",
            sinc3: true,
            point_delay: 0,
            dac_delay: dac,
            u_lag: 0,
        },
        Timing {
            name: "the board, estimator fed u one sample late (not done by the pipeline)",
            sinc3: true,
            point_delay: 0,
            dac_delay: dac,
            u_lag: 1,
        },
    ];
    let truth = [PAPER_OMEGA[0], PAPER_OMEGA[1], PAPER_ZETA[0], PAPER_ZETA[1]];
    let names = ["omega1", "omega2", "zeta1", "zeta2"];
    let mut ideal = [0.0; 4];
    for (i, v) in variants.iter().enumerate() {
        let r = run(*v, &weights);
        if i == 0 {
            ideal = r;
        }
        println!("\n{}:", v.name);
        for j in 0..4 {
            println!(
                "  {:<7} {:>12.6}  rel. error vs truth {:>+10.3e}  change vs ideal {:>+10.3e}",
                names[j],
                r[j],
                r[j] / truth[j] - 1.0,
                r[j] / ideal[j] - 1.0
            );
        }
    }
}
