//! The QEMU image's `--robust` sequence on the host (`cargo xtask qemu
//! --robust`, `xtask/src/e2e_robust.rs`): the firmware's pipeline (drivers
//! over the chip models, the bench's converter timing, the sensor guard)
//! with `Robust2<f32>` swapped in by `link::robust_configs` at the device's
//! own settings, and its model updates staged like
//! `src/bin/qemu-rig/robust.rs` (a seed every 1,000 recorded samples,
//! catch-up in chunks of 16 units, three chunks every four samples as on
//! the QEMU image, installation with ≤ 16 left).
//!
//! Checked: the robust estimator, modelling the converters' timing as the
//! adaptive law does, converges ([`TOLERANCE`]) started over a beam at rest
//! after the excitation was off (the QEMU sequence: 20 s, and 8 s with the
//! beam still ringing) and started on the moving beam 1 s into the
//! excitation; a beam at rest without drive is not flagged stuck. `--nocapture` prints the figures
//! BENCHMARKS.md quotes.
//!
//! Before this test's commit the QEMU sequence (rest 20 s) ended here with
//! an estimate that was no longer two modes (on the QEMU image 41–48% off):
//! the start-up took two candidates of its start-up law, held by the
//! pipeline at the swap, as settled; and the guard flagged the resting
//! beam's repeated ADC code as a stuck sensor (82,180 samples).

use ad5761r::Ad5761r;
use ads131m02::Ads131m02;
use beam_protocol::{EstimatorKind, EstimatorSettings};
use beamest::bench::{self, ConverterModels};
use beamest::estimator::robust::Robust2;
use beamest::estimator::robust::{Pending, Phase, UpdateError};
use beamest::estimator::{Adaptive2, AdaptiveConfig, Either, Estimator};
use beamest::filter_bank::{FilterConfig, SignalScales};
use beamest::link::robust_configs;
use beamest::modal::modal_from_tf;
use beamest::model::{PAPER_OMEGA, PAPER_ZETA};
use beamest::pipeline::{bring_up, NoSink, Pipeline};
use heapless::spsc::Queue;

struct NoDelay;
impl embedded_hal::delay::DelayNs for NoDelay {
    fn delay_ns(&mut self, _ns: u32) {}
}

type Est = Either<&'static mut Adaptive2<f32>, &'static mut Robust2<f32>>;

fn err(tf: &beamest::model::TransferFunction<f32>) -> (f64, f64) {
    match modal_from_tf(tf, &[-2.0f32, 2.0]) {
        Ok(m) => {
            let (mut ew, mut ez) = (0.0f64, 0.0f64);
            for i in 0..2 {
                ew = ew.max((f64::from(m.omega_rad_s[i]) / PAPER_OMEGA[i] - 1.0).abs());
                ez = ez.max((f64::from(m.zeta[i]) / PAPER_ZETA[i] - 1.0).abs());
            }
            (ew, ez)
        }
        Err(_) => (f64::INFINITY, f64::INFINITY),
    }
}

#[derive(Default)]
struct Updates {
    pending: Option<Pending<f32, 4, 7, 28>>,
    seeded_at: usize,
    applied: u32,
    not_converged: u32,
    refused: u32,
}

impl Updates {
    fn poll(&mut self, r: &mut Robust2<f32>) {
        match self.pending.take() {
            None => {
                let n = r.recorded();
                let due = n < self.seeded_at || n >= self.seeded_at + 1_000;
                if r.phase() == Phase::Steady || !due {
                    return;
                }
                self.seeded_at = n;
                match r.update_seed().and_then(|s| s.start()) {
                    Ok(p) => self.pending = Some(p),
                    Err(_) => self.refused += 1,
                }
            }
            Some(mut p) => {
                let res = match r.behind(&p) {
                    Ok(left) if left <= 16 => Some(r.apply_bounded(&mut p, 16)),
                    Ok(_) => r.catch_up(&mut p, 16).err().map(Err),
                    Err(e) => Some(Err(e)),
                };
                match res {
                    None => self.pending = Some(p),
                    Some(Ok(())) => self.applied += 1,
                    Some(Err(UpdateError::NotConverged)) => self.not_converged += 1,
                    Some(Err(_)) => self.refused += 1,
                }
            }
        }
    }
}

/// Bound on ω's and ζ's relative error (the QEMU image's:
/// `src/bin/qemu-rig/robust.rs`, and the default run's for the adaptive
/// law). Measured here: ≤ 8.3e-7 on ω and ≤ 1.0e-5 on ζ started at rest,
/// 2.3e-6 and 2.5e-5 started on the moving beam.
pub const TOLERANCE: f64 = 1e-3;

/// What a run did.
struct Outcome {
    omega: f64,
    zeta: f64,
    phase: Phase,
    applied: u32,
    /// Pipeline stuck / rejected counters when the robust estimator was
    /// swapped in.
    stuck_at_switch: u32,
    rejected_at_switch: u32,
    moving: Option<bool>,
}

/// Excitation off at 0.5 s for `rest_s` (0: never off, the switch at 1 s
/// on the moving beam), the switch to the robust estimator, the excitation
/// on again `on_delay` samples later (the host's round trip), `after_s`
/// more.
fn run(rest_s: f64, on_delay: u64, after_s: f64) -> Outcome {
    let models: &'static ConverterModels = Box::leak(Box::new(ConverterModels::new()));
    let mut adc = Ads131m02::new(models.adc_spi());
    let mut dac = Ad5761r::new(models.dac_spi());
    bring_up(
        &mut adc,
        &mut dac,
        &bench::adc_config(),
        bench::dac_config(),
        &mut NoDelay,
    )
    .unwrap();
    let mut rig = bench::converter_rig(models).unwrap();
    // The device's own settings in the QEMU run (its log: λ from the
    // automatic rule, U0 and Y0 measured at start-up), not the truth.
    let (lambda, u0, y0) = (94.15, 0.1007, 2.3195e-3);
    let filter = FilterConfig {
        lambda_rad_s: lambda,
        scales: SignalScales {
            u_scale: u0,
            y_scale: y0,
        },
        ..bench::filter_config(y0)
    };
    let adaptive: &'static mut Adaptive2<f32> = Box::leak(Box::new(
        Adaptive2::new(&filter, &AdaptiveConfig::default()).unwrap(),
    ));
    let q: &'static mut Queue<beamest::pipeline::TelemetryRecord<f32, 7, 28>, 4> =
        Box::leak(Box::new(Queue::new()));
    let (prod, mut cons) = q.split();
    let mut p = Pipeline::new(
        &bench::pipeline_config(),
        Est::Left(adaptive),
        bench::excitation::<f32>().unwrap(),
        adc,
        dac,
        prod,
        NoSink,
    )
    .unwrap();
    let off_at = 5_000u64;
    let switch_at = if rest_s > 0.0 {
        off_at + (rest_s * 1e4) as u64
    } else {
        10_000
    };
    let on_at = switch_at + on_delay;
    let end = switch_at + (after_s * 1e4) as u64;
    let mut upd = Updates::default();
    let settings = EstimatorSettings {
        kind: EstimatorKind::Robust,
        forgetting_p: 0.01,
        forgetting_h: 0.01,
        lambda_rad_s: Some(lambda as f32),
        ..EstimatorSettings::default()
    };
    let (mut stuck_at_switch, mut rejected_at_switch) = (0, 0);
    for k in 0..end {
        rig.tick().unwrap();
        let _ = p.tick();
        while cons.dequeue().is_some() {}
        if k + 1 == off_at && rest_s > 0.0 {
            p.excitation_mut().set_amplitude(0.0).unwrap();
        }
        if k + 1 == switch_at {
            let (f, law) = robust_configs::<7>(&settings, lambda, &filter);
            let r: &'static mut Robust2<f32> = Box::leak(Box::new(Robust2::new(&f, &law).unwrap()));
            assert!(p.replace_estimator(Est::Right(r), lambda).is_ok());
            stuck_at_switch = p.counters().stuck;
            rejected_at_switch = p.counters().rejected;
        }
        if k + 1 == on_at {
            p.excitation_mut().set_amplitude(0.1).unwrap();
        }
        // Three polls of the thread-mode loop every four samples.
        if k + 1 >= switch_at && k % 4 < 3 {
            upd.poll(p.estimator_mut().right_mut().unwrap());
        }
    }
    let r = p.estimator().right().unwrap();
    let (omega, zeta) = err(&r.transfer_function());
    Outcome {
        omega,
        zeta,
        phase: r.phase(),
        applied: upd.applied,
        stuck_at_switch,
        rejected_at_switch,
        moving: r.initial_state_significance().map(|(_, m)| m),
    }
}

#[test]
fn robust_estimator_converges_on_the_firmware_path() {
    // (rest s, excitation on after the switch, samples): the QEMU
    // sequence, a shorter rest with the beam still ringing, and no rest.
    for (rest, delay) in [(20.0, 300), (20.0, 0), (8.0, 300), (0.0, 0)] {
        let o = run(rest, delay, 6.5);
        println!(
            "rest {rest} s, excitation on {delay} samples after the switch: omega within \
             {:.1e}, zeta within {:.1e}; phase {:?}, {} updates installed; start test: moving \
             {:?}; at the switch: stuck {}, rejected {}",
            o.omega, o.zeta, o.phase, o.applied, o.moving, o.stuck_at_switch, o.rejected_at_switch
        );
        assert!(
            o.omega <= TOLERANCE && o.zeta <= TOLERANCE,
            "rest {rest}: omega {:.1e} zeta {:.1e}",
            o.omega,
            o.zeta
        );
        assert_eq!(o.phase, Phase::Steady);
        assert!(o.applied >= 1);
        // The beam at rest without drive reads one code: no stuck sensor.
        assert_eq!((o.stuck_at_switch, o.rejected_at_switch), (0, 0));
    }
}
