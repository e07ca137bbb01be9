//! The converters' timing and its compensation (docs/RIG.md, "The
//! ADS131M02's filter delay"; BENCHMARKS.md):
//!
//! ```sh
//! cargo run --release -p host-tests --example adc_delay
//! ```
//!
//! On the board each conversion is the ADS131M02's sinc3 average of the
//! last three sample periods (group delay 1.5 samples, droop
//! ≈ 1 − (ωTs)²/8) and the DAC takes each value ≈ 15 µs after DRDY, while
//! the estimator assumes y(t_k) at the tick and u_k from the tick on. This
//! example runs the paper's plant (Wang, Costa-Castelló, Na et al.,
//! *Modelling and Adaptive Parameter Estimation for a Piezoelectric
//! Cantilever Beam*, Section IV.A, eq. 46; λ = 100 rad/s) and a fast-mode
//! plant (155/1520 rad/s, plant 3 of BENCHMARKS.md's random plants;
//! λ = 300 rad/s) behind the exact simulated converters
//! (`beamest::rig::TimedPlant`), with the estimator's output timing
//! (`FilterConfig::timing`) off, a pure delay, or the sinc³ kernel, in
//! f64 and f32: the relative errors of ω and ζ after 20 s, noise-free,
//! 0.1·square(7 Hz), the firmware's start-up (Y0 = RMS of y over 0.1 s,
//! then the law held while the filters settle).
//!
//! A last part checks the continuous sinc³ model of the simulated rig
//! against the chip's discrete filter: the beam at the modulator rate
//! (2.56 MHz, OSR 256), the 3·256 − 2 sinc3 taps over point samples.

use beamest::estimator::{Adaptive2, AdaptiveConfig, Estimator};
use beamest::excitation::SquareWave;
use beamest::filter_bank::{FilterConfig, OutputAverage, OutputTiming, SignalScales};
use beamest::modal::modal_from_tf;
use beamest::model::{ModalParams, PAPER_B, PAPER_OMEGA, PAPER_ZETA};
use beamest::rig::ModalPlant;
use beamest::rig::{ConverterTiming, TimedPlant};
use beamest::Real;
use host_tests::scenario::random_two_mode_plants;

/// Sample period (s).
const TS: f64 = 1e-4;
/// Run length after the start-up window, samples (20 s).
const SAMPLES: usize = 200_000;
/// Start-up window for Y0, samples (0.1 s).
const STARTUP: usize = 1_000;
/// The board's DAC latency after DRDY (s): docs/RIG.md, "Timing".
const DAC_S: f64 = 15e-6;
/// The ADS131M02's OSR (modulator samples per conversion).
const OSR: usize = 256;

/// One beam: its simulation, truth, C̄ and λ.
struct Beam {
    name: &'static str,
    plant: ModalPlant<f64>,
    truth: [f64; 4],
    c: [f64; 2],
    lambda: f64,
}

fn beams() -> [Beam; 2] {
    let paper = ModalPlant::with_numerator(&PAPER_OMEGA, &PAPER_ZETA, &PAPER_B, TS)
        .expect("the paper's plant");
    let m: ModalParams<f64> = random_two_mode_plants(5, 2026)[3];
    let fast = ModalPlant::from_modal(&m, TS).expect("plant 3");
    [
        Beam {
            name: "paper plant (39/245 rad/s), lambda = 100",
            plant: paper,
            truth: [PAPER_OMEGA[0], PAPER_OMEGA[1], PAPER_ZETA[0], PAPER_ZETA[1]],
            c: [-2.0, 2.0],
            lambda: 100.0,
        },
        Beam {
            name: "fast plant (155/1520 rad/s), lambda = 300",
            plant: fast,
            truth: [m.omega_rad_s[0], m.omega_rad_s[1], m.zeta[0], m.zeta[1]],
            c: [m.output_weight[0], m.output_weight[1]],
            lambda: 300.0,
        },
    ]
}

/// The conversions y_k at each tick and the drive u_k decided there.
trait Converters {
    /// y_k as converted at this tick.
    fn measured(&self) -> f64;
    /// Advance to the next tick with the DAC value written at this one.
    fn advance(&mut self, u: f64);
}

impl Converters for TimedPlant {
    fn measured(&self) -> f64 {
        TimedPlant::measured(self)
    }
    fn advance(&mut self, u: f64) {
        TimedPlant::advance(self, u);
    }
}

/// The firmware's procedure over `rig`; returns the relative errors of
/// ω₁, ω₂, ζ₁, ζ₂.
fn run<T: Real>(beam: &Beam, rig: &mut impl Converters, timing: OutputTiming) -> [f64; 4] {
    let mut square = SquareWave::<f64>::paper();
    let mut sum_sq = 0.0;
    for _ in 0..STARTUP {
        let y = rig.measured();
        sum_sq += y * y;
        rig.advance(square.next_sample());
    }
    let filter = FilterConfig {
        ts_s: TS,
        lambda_rad_s: beam.lambda,
        scales: SignalScales {
            u_scale: 0.1,
            y_scale: (sum_sq / STARTUP as f64).sqrt(),
        },
        timing,
        ..FilterConfig::default()
    };
    let mut est = Adaptive2::<T>::new(&filter, &AdaptiveConfig::default()).expect("settings");
    est.hold(est.settling_samples());
    for _ in 0..SAMPLES {
        let y = rig.measured();
        let u = square.next_sample();
        est.step(T::from_f64(u), T::from_f64(y));
        rig.advance(u);
    }
    let c = beam.c.map(T::from_f64);
    let m = modal_from_tf(&est.transfer_function(), &c).expect("modes");
    let got = [
        m.omega_rad_s[0].to_f64(),
        m.omega_rad_s[1].to_f64(),
        m.zeta[0].to_f64(),
        m.zeta[1].to_f64(),
    ];
    core::array::from_fn(|i| got[i] / beam.truth[i] - 1.0)
}

fn row(label: &str, e: [f64; 4]) {
    println!(
        "| {label} | {:+.1e} | {:+.1e} | {:+.1e} | {:+.1e} |",
        e[0], e[1], e[2], e[3]
    );
}

/// The chip's filter: the beam at the modulator rate and the sinc3's
/// 3·OSR − 2 weights over its point samples (index 0 = the sample at
/// DRDY), the DAC switched `dac_steps` modulator periods after it.
struct DiscreteSinc3 {
    plant: ModalPlant<f64>,
    weights: Vec<f64>,
    hist: Vec<f64>,
    pos: usize,
    dac_steps: usize,
    u_old: f64,
}

impl DiscreteSinc3 {
    fn new(beam: &Beam, dac_steps: usize) -> Self {
        let fine = match beam.name.starts_with("paper") {
            true => {
                ModalPlant::with_numerator(&PAPER_OMEGA, &PAPER_ZETA, &PAPER_B, TS / OSR as f64)
            }
            false => ModalPlant::from_modal(&random_two_mode_plants(5, 2026)[3], TS / OSR as f64),
        }
        .expect("plant");
        let boxcar = vec![1.0; OSR];
        let conv = |a: &[f64], b: &[f64]| {
            let mut c = vec![0.0; a.len() + b.len() - 1];
            for (i, x) in a.iter().enumerate() {
                for (j, y) in b.iter().enumerate() {
                    c[i + j] += x * y;
                }
            }
            c
        };
        let w = conv(&conv(&boxcar, &boxcar), &boxcar);
        let sum: f64 = w.iter().sum();
        let weights: Vec<f64> = w.iter().map(|v| v / sum).collect();
        let hist = vec![0.0; weights.len()];
        Self {
            plant: fine,
            weights,
            hist,
            pos: 0,
            dac_steps,
            u_old: 0.0,
        }
    }

    fn group_delay_samples(&self) -> f64 {
        let m: f64 = self
            .weights
            .iter()
            .enumerate()
            .map(|(i, w)| i as f64 * w)
            .sum();
        m / OSR as f64
    }
}

impl Converters for DiscreteSinc3 {
    fn measured(&self) -> f64 {
        let n = self.hist.len();
        self.weights
            .iter()
            .enumerate()
            .map(|(age, w)| w * self.hist[(self.pos + n - 1 - age) % n])
            .sum()
    }
    fn advance(&mut self, u: f64) {
        let n = self.hist.len();
        for j in 0..OSR {
            let held = if j < self.dac_steps { self.u_old } else { u };
            self.plant.advance(held);
            self.hist[self.pos] = self.plant.output();
            self.pos = (self.pos + 1) % n;
        }
        self.u_old = u;
    }
}

fn main() {
    let board = ConverterTiming {
        sinc3: true,
        dac_latency_s: DAC_S,
    };
    // What a user knows: the sinc3's group delay (1.5 samples) and the
    // board's DAC latency; never the simulated beam.
    let sinc3 = OutputTiming::sinc3_adc(DAC_S, TS);
    let delay = OutputTiming {
        average: OutputAverage::Point,
        ..sinc3
    };
    println!(
        "compensation: delay {:.2} samples (sinc3 group delay 1.5 + DAC {:.0} us)\n",
        sinc3.delay_samples,
        DAC_S * 1e6
    );
    let cases = [
        ("point", ConverterTiming::IDEAL, "off", OutputTiming::IDEAL),
        ("sinc3 + DAC 15 us", board, "off", OutputTiming::IDEAL),
        ("sinc3 + DAC 15 us", board, "delay 1.65", delay),
        ("sinc3 + DAC 15 us", board, "sinc3 kernel 1.65", sinc3),
        ("point", ConverterTiming::IDEAL, "sinc3 kernel 1.65", sinc3),
    ];
    for beam in beams() {
        println!("### {}, 20 s, noise-free\n", beam.name);
        println!("| rig | compensation | precision | ω₁ | ω₂ | ζ₁ | ζ₂ |");
        println!("|---|---|---|---|---|---|---|");
        for (rig_name, rig, comp_name, comp) in cases {
            for precision in ["f64", "f32"] {
                let mut r = TimedPlant::new(&beam.plant, rig).expect("timing");
                let e = match precision {
                    "f64" => run::<f64>(&beam, &mut r, comp),
                    _ => run::<f32>(&beam, &mut r, comp),
                };
                row(&format!("{rig_name} | {comp_name} | {precision}"), e);
            }
        }
        println!();
    }

    println!("### The continuous sinc³ against the chip's discrete sinc3 (f64)\n");
    let dac_steps = (DAC_S / TS * OSR as f64).round() as usize;
    let latency = dac_steps as f64 / OSR as f64 * TS;
    for beam in beams() {
        let mut chip = DiscreteSinc3::new(&beam, dac_steps);
        let gd = chip.group_delay_samples();
        let timing = ConverterTiming {
            sinc3: true,
            dac_latency_s: latency,
        };
        let mut cont = TimedPlant::new(&beam.plant, timing).expect("timing");
        // The difference over 1 s, and the time shift that explains it
        // (least squares on the continuous model's slope).
        let mut square = SquareWave::<f64>::paper();
        let (mut prev, mut sdd, mut sds, mut peak, mut worst) = (0.0, 0.0, 0.0, 0.0f64, 0.0f64);
        let mut pending: Option<(f64, f64)> = None;
        for _ in 0..10_000 {
            let (yc, yd) = (cont.measured(), chip.measured());
            if let Some((yc0, yd0)) = pending {
                // Central slope at the previous tick (per sample).
                let slope = 0.5 * (yc - prev);
                sdd += slope * (yd0 - yc0);
                sds += slope * slope;
                prev = yc0;
            }
            pending = Some((yc, yd));
            peak = peak.max(yc.abs());
            worst = worst.max((yd - yc).abs());
            let u = square.next_sample();
            cont.advance(u);
            chip.advance(u);
        }
        println!(
            "{}: discrete group delay {gd:.5} samples; max |discrete − continuous| = \
             {:.1e} of the peak; as a time shift {:+.5} samples",
            beam.name,
            worst / peak,
            sdd / sds
        );
        let d_cont = OutputTiming::sinc3_adc(latency, TS);
        let d_disc = OutputTiming {
            delay_samples: gd + latency / TS,
            ..d_cont
        };
        for (label, t) in [
            ("told 1.5 + DAC", d_cont),
            ("told the discrete delay + DAC", d_disc),
        ] {
            let mut chip = DiscreteSinc3::new(&beam, dac_steps);
            row(
                &format!("discrete sinc3 rig | {label}"),
                run::<f64>(&beam, &mut chip, t),
            );
        }
        println!();
    }
}
