//! The self-test's measurements on synthetic signals with known answers
//! (the chip models and the bench: host test `selftest`).

use super::*;
use crate::pipeline::TickReading;
use crate::rig::GaussianNoise;
use core::f64::consts::PI;

fn tone(k: u64, delay: f64) -> f64 {
    libm::sin(2.0 * PI * f64::from(TONE_HARMONIC) * (k as f64 - delay) / TONE_SAMPLES as f64 + 0.3)
}

/// White noise of σ under a large ringing mode (10 mm at 245 rad/s, the
/// paper beam's second) and a slow one: the fourth differences see the
/// noise, not the modes.
#[test]
fn noise_floor_sees_white_noise_not_a_ringing_beam() {
    let sigma = 1e-6;
    let mut noise = GaussianNoise::<f64>::new(sigma, 3).unwrap();
    let mut f = NoiseFloor::default();
    let n = 20_000u64;
    for k in 0..n {
        let t = k as f64 * 1e-4;
        let beam = 1e-2 * libm::sin(245.37 * t) * libm::exp(-0.13 * 245.37 * t)
            + 1e-2 * libm::sin(39.15 * t);
        f.push(k, Some(beam + noise.sample()));
    }
    let sd = f.sd().unwrap();
    println!(
        "σ = {sigma:e}, estimated {sd:e} from {} differences",
        f.count()
    );
    assert_eq!(f.count(), n - 4);
    assert!((sd / sigma - 1.0).abs() < 0.03, "{sd}");
    // Without noise the modes alone leave (ωTs)⁴ of their amplitude.
    let mut quiet = NoiseFloor::default();
    for k in 0..n {
        let t = k as f64 * 1e-4;
        quiet.push(k, Some(1e-2 * libm::sin(245.37 * t)));
    }
    assert!(quiet.sd().unwrap() < 1e-3 * sigma);
}

/// A gap (a missing conversion or a skipped index) restarts the run of
/// five: no difference spans it.
#[test]
fn noise_floor_differences_never_span_a_gap() {
    let mut f = NoiseFloor::default();
    for k in 0..10 {
        f.push(k, Some(0.0));
    }
    assert_eq!(f.count(), 6);
    f.push(10, None);
    for k in 11..15 {
        f.push(k, Some(1.0));
    }
    assert_eq!(f.count(), 6, "four after the gap: none yet");
    f.push(15, Some(1.0));
    f.push(17, Some(5.0));
    assert_eq!(f.count(), 7, "the index jump restarts the run");
    assert_eq!(f.sd(), Some(0.0));
}

/// Gain, offset and a fractional delay are read back exactly from a
/// monitor that is the drive scaled, delayed and offset; missing samples
/// only lose information.
#[test]
fn tone_fit_reads_gain_offset_and_delay() {
    for (gain, offset, delay) in [(1.0, 0.0, 2.15), (0.97, 0.01, 2.15), (0.5, -0.2, 0.7)] {
        let mut fit = ToneFit::default();
        for k in 0..TONE_SAMPLES {
            let u = 1.5 * tone(k, 0.0);
            let m = if k % 17 == 3 {
                f64::NAN
            } else {
                offset + gain * 1.5 * tone(k, delay)
            };
            fit.push(k, m, u);
        }
        let l = fit.loopback().unwrap();
        assert!((l.gain - gain).abs() < 1e-12, "{l:?}");
        assert!((l.offset - offset).abs() < 1e-12, "{l:?}");
        assert!((l.delay_samples.unwrap() - delay).abs() < 1e-9, "{l:?}");
    }
    // No tone on the monitor: gain 0, no delay.
    let mut fit = ToneFit::default();
    for k in 0..TONE_SAMPLES {
        fit.push(k, 0.0, tone(k, 0.0));
    }
    let l = fit.loopback().unwrap();
    assert_eq!((l.gain, l.delay_samples), (0.0, None));
    assert!(ToneFit::default().loopback().is_none());
}

fn tick(index: u64, fresh: bool, held_v: f32, monitor_v: f32, y: f32) -> Tick<f32> {
    Tick {
        sample_index: index,
        commanded_v: held_v,
        fed: None,
        step: None,
        held_v,
        reading: TickReading {
            fresh,
            y,
            monitor_v,
        },
    }
}

/// The collector times the intervals between new conversions: a stale
/// tick lengthens one interval; the first conversion starts the clock.
#[test]
fn collector_times_the_intervals_between_conversions() {
    let mut c = Collector::<f32>::new();
    let mut blocks = Vec::new();
    for k in 0..64u64 {
        // Tick 0 is stale, so is every 10th after it.
        let fresh = k % 10 != 0;
        c.push(&tick(100 + k, fresh, k as f32, 0.0, 0.0), 2_500, |b| {
            blocks.push(b);
            true
        });
    }
    assert_eq!(blocks.len(), 2);
    let (intervals, ticks): (u32, u64) = blocks
        .iter()
        .fold((0, 0), |(n, t), b| (n + b.intervals, t + b.interval_ticks));
    // Fresh ticks 1..=63 but 10, 20, …, 60: 57; intervals between them 56,
    // spanning ticks 1 to 63.
    assert_eq!(intervals, 56);
    assert_eq!(ticks, 62 * 2_500);
    assert_eq!(blocks[0].first_index, 100);
    assert_eq!(blocks[1].first_index, 132);
    assert_eq!(blocks[0].fresh & 1, 0);
    assert_eq!(blocks[0].held_v[5], 5.0);
    // Refused blocks are counted; stop forgets the partial block.
    c.push(&tick(164, true, 0.0, 0.0, 0.0), 2_500, |_| false);
    c.stop();
    for k in 0..32 {
        c.push(&tick(200 + k, true, 0.0, 0.0, 0.0), 2_500, |b| {
            blocks.push(b);
            false
        });
    }
    assert_eq!(c.dropped(), 1);
    assert_eq!(blocks.last().unwrap().first_index, 200);
    assert_eq!(
        blocks.last().unwrap().intervals,
        31,
        "the clock starts afresh"
    );
}

/// A whole run on synthetic ticks (a perfect bench): the phases' windows,
/// the transitions and a report where every check passes; then each
/// failure on its own.
#[test]
fn a_run_goes_through_its_phases_and_judges_each_check() {
    let config = crate::bench::self_test_config();
    let adc = config.adc;
    let read_back = ads131m02::ReadBack {
        id: 0x2203,
        mode: adc.mode().to_bits(),
        clock: adc.clock().to_bits(),
        gain: adc.gain().to_bits(),
    };
    // (monitor gain, monitor delay, noise σ, clock ticks per sample, ID)
    let run = |gain: f64, delay: f64, sigma: f64, period: u32, id: u16| {
        let mut r = SelfTestRun::new(
            &config,
            false,
            1_000,
            Ok(ads131m02::ReadBack { id, ..read_back }),
        );
        let mut noise = GaussianNoise::<f64>::new(sigma.max(1e-30), 5).unwrap();
        let mut c = Collector::<f32>::new();
        let mut blocks = Vec::new();
        let mut phase_start = 1_000;
        let mut index = 1_000u64;
        let mut transitions = Vec::new();
        loop {
            let k = index - phase_start;
            let (u, m, y) = match r.phase() {
                Phase::Quiet => (0.0, 0.0, 1e-3 * libm::sin(k as f64 * 0.0245)),
                Phase::Tone => (tone(k, 0.0), gain * tone(k, delay), 0.0),
                Phase::Signal => (0.1, 0.1, 4e-3 * libm::sin(k as f64 * 4e-3)),
            };
            let y = y + noise.sample();
            c.push(
                &tick(index, true, u as f32, m as f32, y as f32),
                period,
                |b| {
                    blocks.push(b);
                    true
                },
            );
            index += 1;
            for b in blocks.drain(..) {
                match r.push(&b) {
                    Some(Next::Begin(p)) => {
                        transitions.push((p, index));
                        // The lock lands between two samples.
                        phase_start = index;
                        r.begin(p, index);
                    }
                    Some(Next::Finish) => return (r.report(index - 1), transitions),
                    None => {}
                }
            }
            assert!(index < 20_000, "the run never ended");
        }
    };
    let (ok, transitions) = run(1.0, config.expected_delay_samples, 1e-8, 2_500, 0x2203);
    println!("{ok:?}");
    assert!(ok.passed(), "{ok:?}");
    assert_eq!(transitions.len(), 2);
    assert_eq!(transitions[0].0, Phase::Tone);
    // Quiet ends after its settle and window, rounded up to a block.
    assert!(transitions[0].1 >= 1_000 + QUIET_SETTLE + QUIET_SAMPLES);
    assert!(ok.last_sample - ok.first_sample >= TOTAL_SAMPLES - 1);
    assert!((ok.drdy.rate_hz - 1e4).abs() < 1e-3);
    assert!((ok.loopback.gain - 1.0).abs() < 1e-6);
    assert!((f64::from(ok.loopback.delay_samples) - config.expected_delay_samples).abs() < 1e-5);
    assert!(ok.noise.snr_db > 100.0);
    use SelfTestChecks as C;
    let fails = |r: &SelfTestReport| (r.failed, r.not_measured);
    assert_eq!(
        fails(&run(1.0, config.expected_delay_samples, 1e-8, 2_500, 0x2400).0),
        (C::ADC_ID, C::default())
    );
    assert_eq!(
        fails(&run(1.0, config.expected_delay_samples, 1e-8, 2_501, 0x2203).0),
        (C::DRDY_RATE, C::default()),
        "4e-4 slow"
    );
    assert_eq!(
        fails(
            &run(
                1.0,
                config.expected_delay_samples + 0.05,
                1e-8,
                2_500,
                0x2203
            )
            .0
        ),
        (C::LOOPBACK, C::default())
    );
    assert_eq!(
        fails(&run(0.9, config.expected_delay_samples, 1e-8, 2_500, 0x2203).0),
        (C::LOOPBACK, C::default())
    );
    assert_eq!(
        fails(&run(1.0, config.expected_delay_samples, 1e-5, 2_500, 0x2203).0),
        (C::NOISE, C::default())
    );
}
