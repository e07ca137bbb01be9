//! The QEMU image's `--robust` sequence on the host: the firmware's pipeline
//! (drivers over the chip models, the bench's converter timing, the guard)
//! with the robust estimator swapped in over a resting beam and its model
//! updates staged like `src/bin/qemu-rig/robust.rs`.
//!
//! `cargo run --release -p host-tests --example robust_fwpath -- [rest_s] [on_delay_samples] [stuck_after] [chunks_per_4_samples] [after_s]`

use beamest::drivers::ad5761r::Ad5761r;
use beamest::drivers::ads131m02::Ads131m02;
use beamest::estimator::robust::{Pending, Phase, UpdateError};
use beamest::estimator::{Adaptive2, AdaptiveConfig, Either, Estimator, Robust2};
use beamest::filter_bank::{FilterConfig, SignalScales};
use beamest::link::robust_configs;
use beamest::modal::modal_from_tf;
use beamest::model::{PAPER_OMEGA, PAPER_ZETA};
use beamest::pipeline::{bring_up, NoSink, Pipeline, PipelineConfig};
use beamest::protocol::{EstimatorKind, EstimatorSettings};
use beamest::rig::{bench, ConverterModels};
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

fn main() {
    let a: Vec<String> = std::env::args().collect();
    let arg = |i: usize, d: f64| a.get(i).and_then(|s| s.parse().ok()).unwrap_or(d);
    let rest_s = arg(1, 20.0);
    let on_delay = arg(2, 300.0) as u64;
    let stuck_after = arg(3, f64::from(bench::STUCK_AFTER)) as u16;
    let chunks4 = arg(4, 3.0) as u32;
    let after_s = arg(5, 6.5);

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
    // The device's own settings in the QEMU run (its log): λ, U0, Y0.
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
    let cfg = PipelineConfig {
        stuck_after,
        ..bench::pipeline_config()
    };
    let mut p = Pipeline::new(
        &cfg,
        Est::Left(adaptive),
        bench::excitation::<f32>().unwrap(),
        adc,
        dac,
        prod,
        NoSink,
    )
    .unwrap();
    let off_at = 5_000u64;
    let switch_at = off_at + (rest_s * 1e4) as u64;
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
    let mut rejected_at_switch = 0;
    for k in 0..end {
        rig.tick().unwrap();
        let _ = p.tick();
        while cons.dequeue().is_some() {}
        if k + 1 == off_at {
            p.excitation_mut().set_amplitude(0.0).unwrap();
        }
        if k + 1 == switch_at {
            let (f, law) = robust_configs::<7>(&settings, lambda, &filter);
            let r: &'static mut Robust2<f32> = Box::leak(Box::new(Robust2::new(&f, &law).unwrap()));
            let _ = p.replace_estimator(Est::Right(r), lambda);
            rejected_at_switch = p.counters().rejected;
            println!(
                "switch at {}: rejected so far {rejected_at_switch}, stuck {}",
                k + 1,
                p.counters().stuck
            );
        }
        if k + 1 == on_at {
            p.excitation_mut().set_amplitude(0.1).unwrap();
        }
        if k + 1 >= switch_at {
            let r = p.estimator_mut().right_mut().unwrap();
            // `chunks4` polls every 4 samples.
            if (k % 4) < u64::from(chunks4) {
                upd.poll(r);
            }
            let n = k + 1 - switch_at;
            if n % 2_000 == 0 || n == 40 {
                let r = p.estimator().right().unwrap();
                let (ew, ez) = err(&r.transfer_function());
                let c = p.counters();
                println!(
                    "t {:6.2} (+{:5.2}) {:?} upd {} nc {} ref {} init {:?} rej {} stuck {} h {:?} ω {:.2e} ζ {:.2e}",
                    (k + 1) as f64 * 1e-4,
                    n as f64 * 1e-4,
                    r.phase(),
                    upd.applied,
                    upd.not_converged,
                    upd.refused,
                    r.initial_state_significance(),
                    c.rejected - rejected_at_switch,
                    c.stuck,
                    r.health().rejected,
                    ew,
                    ez
                );
            }
        }
    }
}
