//! Unit tests with scripted converters and a recording estimator.

use super::*;
use crate::estimator::{Health, StepStatus};
use crate::excitation::SafeWindow;
use crate::model::TransferFunction;
use beam_protocol::StatusFlags;
use beam_protocol::Waveform;
use heapless::spsc::Queue;
use std::collections::VecDeque;
use std::vec::Vec;

/// Records every step; Θ = [steps, 0, 0]; P = diag(1, 2, 3); holds the
/// law like the real estimators (a hold of [`SETTLING`] samples).
#[derive(Default)]
struct Recorder {
    fed: Vec<(f64, f64)>,
    resets: usize,
    held: u32,
    holds: Vec<u32>,
}

/// The recorder's settling time, samples.
const SETTLING: u32 = 3;

impl Estimator<f64, 3> for Recorder {
    fn step(&mut self, u: f64, y: f64) -> StepStatus {
        self.fed.push((u, y));
        if !(u.is_finite() && y.is_finite()) {
            StepStatus::Rejected
        } else if self.held > 0 {
            self.held -= 1;
            StepStatus::Frozen
        } else {
            StepStatus::Updated
        }
    }
    fn hold(&mut self, samples: u32) {
        self.holds.push(samples);
        self.held = self.held.max(samples);
    }
    fn settling_samples(&self) -> u32 {
        SETTLING
    }
    fn theta(&self) -> [f64; 3] {
        [self.fed.len() as f64, 0.0, 0.0]
    }
    fn transfer_function(&self) -> TransferFunction<f64> {
        TransferFunction {
            modes: 0,
            a: Default::default(),
            b: Default::default(),
            output: Default::default(),
        }
    }
    fn reset(&mut self) {
        self.resets += 1;
    }
    fn excitation_level(&self) -> Option<f64> {
        None
    }
    fn health(&self) -> Health {
        Health {
            samples: 0,
            rejected: 0,
            skipped: 0,
            state_ok: true,
        }
    }
    fn information(&self) -> Option<[[f64; 3]; 3]> {
        Some([[1.0, 0.5, 0.0], [0.5, 2.0, 0.0], [0.0, 0.0, 3.0]])
    }
}

/// Scripted ADC: pops a result per tick, else bridge = monitor = tick count.
#[derive(Default)]
struct Adc {
    script: VecDeque<Result<AdcReading, FaultKind>>,
    n: i32,
}

impl StrainAdc for Adc {
    type Error = FaultKind;
    fn read(&mut self) -> Result<AdcReading, FaultKind> {
        self.n += 1;
        self.script.pop_front().unwrap_or(Ok(AdcReading {
            bridge: self.n,
            monitor: self.n,
            flags: AdcFlags::default(),
        }))
    }
}

/// Records writes; saturates beyond ±10 V; fails when told.
#[derive(Default)]
struct Dac {
    writes: Vec<f64>,
    fail_next: bool,
}

impl PiezoDac<f64> for Dac {
    type Error = FaultKind;
    fn write_volts(&mut self, v: f64) -> Result<DacOutcome<f64>, FaultKind> {
        self.writes.push(v);
        if core::mem::take(&mut self.fail_next) {
            return Err(FaultKind::Bus);
        }
        Ok(DacOutcome {
            held_v: v.clamp(-10.0, 10.0),
            saturated: v.abs() > 10.0,
        })
    }
}

/// Conversion with y = code·1e-6 and u_mon = code·1e-3 (linear, exact in f64
/// up to rounding of the factors).
fn conversion() -> ConversionConfig {
    ConversionConfig {
        bridge_adc: AdcScale {
            vref_v: 8.388_608,
            pga_gain: 1,
        },
        bridge: BridgeConfig {
            excitation_v: 4.0,
            gauge_factor: 1.0,
            amplifier_gain: 1.0,
            null_offset_v: 0.0,
            linearisation: Linearisation::Linear,
            invert: false,
        },
        output: OutputQuantity::Strain,
        monitor_adc: AdcScale {
            vref_v: 8.388_608,
            pga_gain: 1,
        },
        monitor_v_per_v: 1e-3,
    }
}

fn config() -> PipelineConfig {
    PipelineConfig {
        conversion: conversion(),
        input: InputSource::Commanded,
        amplifier_gain: 1.0,
        dac_latch: DacLatch::Immediate,
        prefilter: None,
        telemetry_every: 4,
        raw_decimation: 0,
        stuck_after: 0,
        lambda_rad_s: 100.0,
    }
}

fn square(amplitude: f64) -> Excitation<f64> {
    Excitation::new(
        &Waveform::Square { freq_hz: 1000.0 },
        amplitude,
        0.0,
        SafeWindow {
            min_v: -50.0,
            max_v: 50.0,
        },
        1e4,
    )
    .unwrap()
}

type Rec = TelemetryRecord<f64, 3, 6>;
type P<'a> = Pipeline<
    f64,
    Recorder,
    Adc,
    Dac,
    heapless::spsc::Producer<'a, Rec>,
    heapless::spsc::Producer<'a, RawBlock<f64>>,
    3,
    6,
>;

fn build<'a>(
    cfg: &PipelineConfig,
    adc: Adc,
    tq: &'a mut Queue<Rec, 4>,
    rq: &'a mut Queue<RawBlock<f64>, 4>,
) -> (
    P<'a>,
    heapless::spsc::Consumer<'a, Rec>,
    heapless::spsc::Consumer<'a, RawBlock<f64>>,
) {
    let (tp, tc) = tq.split();
    let (rp, rc) = rq.split();
    let p = Pipeline::new(
        cfg,
        Recorder::default(),
        square(2.0),
        adc,
        Dac::default(),
        tp,
        rp,
    )
    .unwrap();
    (p, tc, rc)
}

fn close(a: f64, b: f64) -> bool {
    (a - b).abs() <= 1e-12 * b.abs().max(1e-300)
}

#[test]
fn immediate_latch_pairs_this_ticks_u_with_this_ticks_y() {
    let (mut tq, mut rq) = (Queue::new(), Queue::new());
    let (mut p, _, _) = build(&config(), Adc::default(), &mut tq, &mut rq);
    for _ in 0..8 {
        p.tick();
    }
    let (est, _, dac, _, _) = p.into_parts();
    for (k, &(u, y)) in est.fed.iter().enumerate() {
        assert_eq!(u, dac.writes[k]);
        assert!(close(y, (k + 1) as f64 * 1e-6), "{k}: {y}");
    }
}

#[test]
fn next_tick_latch_and_monitored_input_shift_by_one_sample() {
    let (mut tq, mut rq) = (Queue::new(), Queue::new());
    let cfg = PipelineConfig {
        dac_latch: DacLatch::NextTick,
        ..config()
    };
    let (mut p, _, _) = build(&cfg, Adc::default(), &mut tq, &mut rq);
    assert_eq!(p.tick().step, None, "nothing held yet at the first tick");
    for _ in 0..7 {
        p.tick();
    }
    let (est, _, dac, _, _) = p.into_parts();
    assert_eq!(est.fed.len(), 7);
    for (k, &(u, y)) in est.fed.iter().enumerate() {
        // Tick k+1: the value written at tick k, y of tick k+1.
        assert_eq!(u, dac.writes[k]);
        assert!(close(y, (k + 2) as f64 * 1e-6));
    }
    let (mut tq, mut rq) = (Queue::new(), Queue::new());
    let cfg = PipelineConfig {
        input: InputSource::Monitored,
        ..config()
    };
    let (mut p, _, _) = build(&cfg, Adc::default(), &mut tq, &mut rq);
    for _ in 0..8 {
        p.tick();
    }
    let est = p.into_parts().0;
    for (k, &(u, y)) in est.fed.iter().enumerate() {
        // Tick k+1: monitor (k+2)·1e-3 V measured what tick k held, y of tick k.
        assert!(close(u, (k + 2) as f64 * 1e-3));
        assert!(close(y, (k + 1) as f64 * 1e-6));
    }
}

#[test]
fn converter_faults_are_counted_and_never_fed_as_valid() {
    let ok = |b: i32| {
        Ok(AdcReading {
            bridge: b,
            monitor: 0,
            flags: AdcFlags::default(),
        })
    };
    let flagged = |flags| {
        Ok(AdcReading {
            bridge: 5,
            monitor: 0,
            flags,
        })
    };
    let adc = Adc {
        n: 0,
        script: VecDeque::from([
            ok(1),
            Err(FaultKind::Crc),
            Err(FaultKind::Status),
            Err(FaultKind::Bus),
            Err(FaultKind::Other),
            ok(ADC_CODE_MAX),
            ok(ADC_CODE_MIN),
            flagged(AdcFlags {
                bridge_saturated: true,
                ..AdcFlags::default()
            }),
            flagged(AdcFlags {
                stale: true,
                ..AdcFlags::default()
            }),
            flagged(AdcFlags {
                stuck: true,
                ..AdcFlags::default()
            }),
            // Stuck: 7 four times; stuck_after = 2 → recognised at the third.
            ok(7),
            ok(7),
            ok(7),
            ok(7),
            ok(8),
            ok(ADC_CODE_MAX - 1),
        ]),
    };
    let cfg = PipelineConfig {
        stuck_after: 2,
        ..config()
    };
    let (mut tq, mut rq) = (Queue::new(), Queue::new());
    let (mut p, _, _) = build(&cfg, adc, &mut tq, &mut rq);
    for _ in 0..16 {
        p.tick();
    }
    let c = p.counters();
    assert_eq!(
        (c.adc_crc, c.adc_status, c.adc_bus, c.adc_other),
        (1, 1, 1, 2)
    );
    // The flagged conversion; the first rail code jumps there from
    // mid-range: an open gauge; the second moves to the other rail, which
    // an open gauge never does: an overload (`guard`).
    assert_eq!((c.bridge_saturated, c.open), (2, 1));
    // One flagged stuck by the driver; the four 7s: recognised at the
    // third, the first two flipped in the delay line (3 samples: the last 3
    // ticks are not fed yet).
    assert_eq!(c.stuck, 5);
    assert_eq!(c.rejected, 12);
    let est = p.into_parts().0;
    let valid: Vec<bool> = est
        .fed
        .iter()
        .map(|(u, y)| u.is_finite() && y.is_finite())
        .collect();
    let expect = [
        true, false, false, false, false, false, false, false, false, false, false, false, false,
    ];
    assert_eq!(valid, expect);
}

#[test]
fn dac_faults_are_counted_and_a_failed_write_invalidates_u() {
    let (mut tq, mut rq) = (Queue::new(), Queue::new());
    let (mut p, _, _) = build(&config(), Adc::default(), &mut tq, &mut rq);
    p.excitation_mut()
        .set_window(SafeWindow {
            min_v: -50.0,
            max_v: 50.0,
        })
        .unwrap();
    p.excitation_mut().set_amplitude(20.0).unwrap();
    p.tick();
    p.converters_mut().1.fail_next = true;
    let t = p.tick();
    assert!(t.fed.unwrap().0.is_nan());
    let c = p.counters();
    assert_eq!((c.dac_saturated, c.dac_errors, c.rejected), (1, 1, 1));
    // The saturated sample was fed with the held (rail) value.
    let est = p.into_parts().0;
    assert_eq!(est.fed[0].0, 10.0);
}

#[test]
fn full_queue_drops_and_counts_and_never_blocks() {
    let (mut tq, mut rq) = (Queue::new(), Queue::new());
    let cfg = PipelineConfig {
        telemetry_every: 1,
        raw_decimation: 1,
        ..config()
    };
    let (mut p, mut tc, _rc) = build(&cfg, Adc::default(), &mut tq, &mut rq);
    // Capacity 3 (N − 1): 3 records fit, the next 97 are dropped. A hold
    // (a missed period) falls in the dropped ones.
    for k in 0..100 {
        if k == 50 {
            p.note_overrun(1);
        }
        p.tick();
    }
    let c = p.counters();
    assert_eq!(c.dropped_records, 97);
    // 100 pairs = 3 full blocks (fit) + a partial one not yet sent.
    assert_eq!(c.dropped_raw_blocks, 0);
    for _ in 0..100 {
        p.tick();
    }
    assert_eq!(p.counters().dropped_raw_blocks, 3);
    let first = tc.dequeue().unwrap();
    assert_eq!(first.sample_index, 0);
    assert!(!first.flags.contains(StatusFlags::TELEMETRY_DROPPED));
    assert!(!first.flags.contains(StatusFlags::FROZEN_AUTO));
    tc.dequeue();
    tc.dequeue();
    p.tick();
    let next = tc.dequeue().unwrap();
    assert!(next.flags.contains(StatusFlags::TELEMETRY_DROPPED));
    // The hold happened in a dropped record, long over by now: still told.
    assert!(next.flags.contains(StatusFlags::FROZEN_AUTO));
    assert_eq!(next.counters.dropped_records, 197);
}

#[test]
fn records_carry_theta_packed_information_and_counts() {
    let (mut tq, mut rq) = (Queue::new(), Queue::new());
    let (mut p, mut tc, _) = build(&config(), Adc::default(), &mut tq, &mut rq);
    for _ in 0..8 {
        p.tick();
    }
    let r1 = tc.dequeue().unwrap();
    let r2 = tc.dequeue().unwrap();
    assert!(tc.dequeue().is_none());
    assert_eq!((r1.sample_index, r2.sample_index), (3, 7));
    assert_eq!(r2.theta, [8.0, 0.0, 0.0]);
    assert_eq!(r2.information, [1.0, 0.5, 0.0, 2.0, 0.0, 3.0]);
    assert!(r2.has_information);
    assert_eq!(r2.steps.updated, 4);
    assert_eq!(r2.lambda_rad_s, 100.0);
    let back: [[f64; 3]; 3] = telemetry::unpack_symmetric(&r2.information);
    assert_eq!(Some(back), Recorder::default().information());
    // recover(): λmin of diag-ish P; Θ with modes = 0 cannot be recovered.
    let rec = recover(&r2, &[1.0]);
    let lmin = rec.excitation_min_eig.unwrap();
    assert!(
        (lmin - (1.5 - (0.25f64 + 0.25).sqrt())).abs() < 1e-12,
        "{lmin}"
    );
    assert_eq!(rec.sample_index, 7);
}

#[test]
fn settings_take_effect_at_the_next_tick() {
    let (mut tq, mut rq) = (Queue::new(), Queue::new());
    let (mut p, mut tc, mut rc) = build(&config(), Adc::default(), &mut tq, &mut rq);
    assert_eq!(p.tick().commanded_v, 2.0);
    p.excitation_mut().set_amplitude(3.0).unwrap();
    assert_eq!(p.tick().commanded_v, 3.0);
    assert_eq!(
        p.excitation_mut().set_amplitude(60.0),
        Err(crate::excitation::ExcitationError::OutsideWindow)
    );
    assert_eq!(p.tick().commanded_v, 3.0);
    // Telemetry every 4 → every 2: ticks 3 (index 2) and 4 were counted.
    p.set_telemetry_every(2).unwrap();
    assert_eq!(p.set_telemetry_every(0), Err(PipelineError::TelemetryRate));
    p.tick();
    assert_eq!(tc.dequeue().unwrap().sample_index, 3);
    // Raw blocks: every 2nd sample.
    p.set_raw_decimation(2);
    for _ in 0..64 {
        p.tick();
    }
    let b = rc.dequeue().unwrap();
    assert_eq!((b.first_index, b.decimation, b.len), (4, 2, 32));
    assert!(close(b.y[1], 7.0 * 1e-6));
    // Freeze: no steps; resume: the law held for the settling time on
    // real samples (never NaN, nothing rejected), then normal.
    let steps_before = p.estimator().fed.len();
    p.freeze();
    assert!(p.is_frozen());
    p.tick();
    assert_eq!(p.estimator().fed.len(), steps_before);
    assert!(p.estimator().holds.is_empty());
    p.resume();
    assert_eq!(p.estimator().holds, [SETTLING]);
    for _ in 0..SETTLING {
        let t = p.tick();
        assert_eq!(t.step, Some(StepStatus::Frozen));
        assert!(t.fed.unwrap().1.is_finite());
    }
    assert_eq!(p.tick().step, Some(StepStatus::Updated));
    p.resume();
    assert_eq!(
        p.estimator().holds.len(),
        1,
        "resume when not frozen: no hold"
    );
    // Overrun: counted, index skips, the law held; nothing rejected.
    let idx = p.next_sample_index();
    p.note_overrun(3);
    let t = p.tick();
    assert_eq!(t.sample_index, idx + 3);
    assert_eq!(t.step, Some(StepStatus::Frozen));
    assert!(t.fed.unwrap().1.is_finite());
    let c = p.counters();
    assert_eq!((c.overruns, c.missed_ticks, c.rejected), (1, 3, 0));
    // A late interrupt that lost no conversion is counted, not held.
    let holds = p.estimator().holds.len();
    p.note_overrun(0);
    assert_eq!(p.estimator().holds.len(), holds);
    assert_eq!(p.counters().overruns, 2);
    // Two more held steps, then the record shows the hold, not rejection.
    p.tick();
    p.tick();
    assert_eq!(p.tick().step, Some(StepStatus::Updated));
    while let Some(r) = tc.dequeue() {
        assert_eq!(r.steps.rejected, 0);
        assert_eq!(r.counters.rejected, 0);
    }
    p.reset_estimator();
    assert_eq!(p.estimator().resets, 1);
    assert_eq!(p.tick().step, Some(StepStatus::Frozen));
    let old = p.replace_estimator(Recorder::default(), 50.0);
    assert_eq!(old.map(|r| r.resets).ok(), Some(1));
    assert_eq!(p.estimator().holds, [SETTLING]);
    assert!(p.replace_estimator(Recorder::default(), 0.0).is_err());
    p.reset_counters();
    assert_eq!(p.counters(), Counters::default());
}

#[test]
fn rejects_bad_configs() {
    let mk = |cfg: PipelineConfig| {
        let (mut tq, mut rq) = (Queue::<Rec, 4>::new(), Queue::<RawBlock<f64>, 4>::new());
        let (tp, _) = tq.split();
        let (rp, _) = rq.split();
        P::new(
            &cfg,
            Recorder::default(),
            square(1.0),
            Adc::default(),
            Dac::default(),
            tp,
            rp,
        )
        .err()
    };
    assert_eq!(
        mk(PipelineConfig {
            amplifier_gain: 0.0,
            ..config()
        }),
        Some(PipelineError::AmplifierGain)
    );
    assert_eq!(
        mk(PipelineConfig {
            telemetry_every: 0,
            ..config()
        }),
        Some(PipelineError::TelemetryRate)
    );
    assert_eq!(
        mk(PipelineConfig {
            lambda_rad_s: f64::NAN,
            ..config()
        }),
        Some(PipelineError::Lambda)
    );
    let mut bad = config();
    bad.prefilter = Some(PrefilterConfig {
        order: 9,
        cutoff_hz: 100.0,
        sample_rate_hz: 1e4,
    });
    assert_eq!(
        mk(bad),
        Some(PipelineError::Prefilter(PrefilterError::Order))
    );
    let msg = std::format!("{}", PipelineError::Conversion(ConversionError::PgaGain));
    assert!(msg.contains("PGA"));
}
