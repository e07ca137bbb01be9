//! Design study of the robust estimator (numbers quoted in
//! `src/estimator/robust/mod.rs`): variants × SNR on the paper's plant,
//! RMS error over seeds against the Cramér–Rao bound.
//!
//! `cargo run --release -p host-tests --example robust_design -- [seconds] [seeds] [variant prefix]`
//! (defaults 60 s, 5 seeds, all variants; the module documentation quotes
//! the 20-seed run: `-- 60 20`).

use beamest::crlb::{FisherAccumulator, ModelSet};
use beamest::estimator::robust::{Compact, InitialState, RecordStore as Storage, RobustEstimator};
use beamest::estimator::robust::{Robust2, Robust2Compact, RobustConfig};
use beamest::estimator::{Adaptive2, AdaptiveConfig};
use beamest::filter_bank::FilterConfig;
use beamest::model::paper_plant_tf;
use beamest::Real;
use host_tests::noise_study::{rms, run, study_filter, Errors, Record};

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let seconds: f64 = args.get(1).and_then(|s| s.parse().ok()).unwrap_or(60.0);
    let seeds: u64 = args.get(2).and_then(|s| s.parse().ok()).unwrap_or(5);
    let only: Option<String> = args.get(3).cloned();
    let rec = Record::paper(seconds);
    let mut crb = FisherAccumulator::from_tf(&paper_plant_tf(), &[-2.0, 2.0], 1e-4).unwrap();
    crb.push_all(rec.u.iter().copied());
    let base = RobustConfig::<7>::default();
    let variants: Vec<(&str, RobustConfig<7>)> = vec![
        ("robust, default (2 s record)", base),
        (
            "update every 0.05 s",
            RobustConfig {
                update_every: 500,
                ..base
            },
        ),
        (
            "start tolerance 0.05",
            RobustConfig {
                start_tolerance: 0.05,
                ..base
            },
        ),
        (
            "forgetting l = 0.05",
            RobustConfig {
                forgetting: 0.05,
                ..base
            },
        ),
        (
            "forgetting l = 0.002",
            RobustConfig {
                forgetting: 0.002,
                ..base
            },
        ),
    ];
    for snr in [40.0, 20.0] {
        let sigma = crb.sigma_for_snr_db(snr);
        let b = crb.bound(ModelSet::TransferFunction, sigma).unwrap();
        let bound = [b.omega_rel[0], b.omega_rel[1], b.zeta_rel[0], b.zeta_rel[1]];
        println!(
            "\n{seconds} s, {snr} dB, {seeds} seeds; CRB (TF set) ω {:.2e} {:.2e} ζ {:.2e} {:.2e}",
            bound[0], bound[1], bound[2], bound[3]
        );
        println!("| variant | ω1 | ω2 | ζ1 | ζ2 | RMS/CRB ω1 ω2 ζ1 ζ2 | mean/CRB ω1 ω2 ζ1 ζ2 |");
        let report = |name: &str, errs: &[Errors]| {
            let r = rms(errs);
            let mean: Vec<f64> = (0..4)
                .map(|i| errs.iter().map(|e| e[i]).sum::<f64>() / errs.len() as f64 / bound[i])
                .collect();
            println!(
                "| {name} | {:.2e} | {:.2e} | {:.2e} | {:.2e} | {:.1} {:.1} {:.1} {:.1} | {:+.1} {:+.1} {:+.1} {:+.1} |",
                r[0], r[1], r[2], r[3],
                r[0] / bound[0], r[1] / bound[1], r[2] / bound[2], r[3] / bound[3],
                mean[0], mean[1], mean[2], mean[3]
            );
        };
        let noisy: Vec<Vec<f64>> = (1..=seeds).map(|s| rec.noisy_y(Some(snr), s)).collect();
        if only.as_deref().is_none_or(|o| o.starts_with("adaptive")) {
            let errs: Vec<Errors> = noisy
                .iter()
                .map(|y| {
                    let f = study_filter(&rec.u, y);
                    let mut est = Adaptive2::<f64>::new(&f, &AdaptiveConfig::default()).unwrap();
                    run(&mut est, &rec.u, y, 0, &mut |_, _| {})
                })
                .collect();
            report("adaptive (paper's law)", &errs);
        }
        for (name, cfg) in &variants {
            if only.as_deref().is_some_and(|o| !name.starts_with(o)) {
                continue;
            }
            let errs: Vec<Errors> = noisy
                .iter()
                .map(|y| {
                    let f = study_filter(&rec.u, y);
                    let mut est = Robust2::<f64>::new(&f, cfg).unwrap();
                    run(&mut est, &rec.u, y, 0, &mut |_, _| {})
                })
                .collect();
            report(name, &errs);
        }
        if only.as_deref().is_none_or(|o| o == "f32") {
            // (f32 default record)
            let errs: Vec<Errors> = noisy
                .iter()
                .map(|y| f32_record::<20_000>(&study_filter(&rec.u, y), &rec.u, y))
                .collect();
            report("robust, default, f32", &errs);
        }
        for (name, start, initial) in [
            (
                "started 1 s after the excitation (Auto)",
                10_000,
                InitialState::Auto,
            ),
            (
                "started 1 s after the excitation (Rest)",
                10_000,
                InitialState::Rest,
            ),
            ("at rest, InitialState::Estimate", 0, InitialState::Estimate),
        ] {
            if only.as_deref().is_some_and(|o| !name.starts_with(o)) {
                continue;
            }
            report(name, &late(start, initial, snr, seeds));
        }
        // The record in 64 KiB (module docs, "Record in 64 KiB"): u in 16
        // bits, y in block means; and the plain record cut to 1.5 s.
        let compact: [(&str, Compactor); 5] = [
            ("compact, blocks of 10, f32 (the firmware's)", |f, u, y| {
                boxed(
                    Box::new(Robust2Compact::<f32>::new(f, &RobustConfig::default()).unwrap()),
                    u,
                    y,
                )
            }),
            ("compact, blocks of 10, f64", |f, u, y| {
                boxed(
                    Box::new(Robust2Compact::<f64>::new(f, &RobustConfig::default()).unwrap()),
                    u,
                    y,
                )
            }),
            ("compact, blocks of 20, f32", |f, u, y| {
                compact_f32::<20_000, Compact<f32, 20_000, 1_000, 625>>(f, u, y)
            }),
            ("compact, blocks of 5, f32", |f, u, y| {
                compact_f32::<20_000, Compact<f32, 20_000, 4_000, 625>>(f, u, y)
            }),
            ("record 1.5 s, f32", |f, u, y| {
                compact_f32::<15_000, beamest::estimator::robust::Samples<f32, 15_000>>(f, u, y)
            }),
        ];
        for (name, go) in compact {
            if only.as_deref().is_some_and(|o| !name.starts_with(o)) {
                continue;
            }
            let errs: Vec<Errors> = noisy
                .iter()
                .map(|y| go(&study_filter(&rec.u, y), &rec.u, y))
                .collect();
            report(name, &errs);
        }
        for (name, secs) in [
            ("record 0.5 s", 0.5),
            ("record 1 s", 1.0),
            ("record 5 s", 5.0),
        ] {
            if only.as_deref().is_some_and(|o| !name.starts_with(o)) {
                continue;
            }
            let errs: Vec<Errors> = noisy
                .iter()
                .map(|y| {
                    let f = study_filter(&rec.u, y);
                    match (secs * 10.0) as u32 {
                        5 => with_record::<5_000>(&f, &rec.u, y),
                        10 => with_record::<10_000>(&f, &rec.u, y),
                        _ => with_record::<50_000>(&f, &rec.u, y),
                    }
                })
                .collect();
            report(name, &errs);
        }
    }
}

/// The default estimator started `start` samples after the excitation (the
/// beam already moving), on the next 60 s.
fn late(start: usize, initial: InitialState, snr: f64, seeds: u64) -> Vec<Errors> {
    let rec = Record::paper(60.0 + start as f64 * 1e-4);
    (1..=seeds)
        .map(|seed| {
            let y = rec.noisy_y(Some(snr), seed);
            let (u, y) = (&rec.u[start..], &y[start..]);
            let cfg = RobustConfig {
                initial_state: initial,
                ..RobustConfig::default()
            };
            let mut est = Box::new(Robust2::<f64>::new(&study_filter(u, y), &cfg).unwrap());
            run(&mut *est, u, y, 0, &mut |_, _| {})
        })
        .collect()
}

fn f32_record<const B: usize>(f: &FilterConfig, u: &[f64], y: &[f64]) -> Errors {
    let mut est =
        Box::new(RobustEstimator::<f32, 4, 7, 28, B>::new(f, &RobustConfig::default()).unwrap());
    run(&mut *est, u, y, 0, &mut |_, _| {})
}

fn with_record<const B: usize>(f: &FilterConfig, u: &[f64], y: &[f64]) -> Errors {
    let mut est =
        Box::new(RobustEstimator::<f64, 4, 7, 28, B>::new(f, &RobustConfig::default()).unwrap());
    run(&mut *est, u, y, 0, &mut |_, _| {})
}

/// One estimator of the record study, on a record's u, y.
type Compactor = fn(&FilterConfig, &[f64], &[f64]) -> Errors;

fn boxed<T: Real>(
    mut est: Box<dyn beamest::estimator::Estimator<T, 7>>,
    u: &[f64],
    y: &[f64],
) -> Errors {
    run(&mut *est, u, y, 0, &mut |_, _| {})
}

fn compact_f32<const B: usize, R: Storage<f32> + 'static>(
    f: &FilterConfig,
    u: &[f64],
    y: &[f64],
) -> Errors {
    boxed(
        Box::new(RobustEstimator::<f32, 4, 7, 28, B, R>::new(f, &RobustConfig::default()).unwrap()),
        u,
        y,
    )
}
