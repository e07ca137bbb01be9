//! The device end of the serial link (`beamest::link`) on the QEMU image's
//! data path (the simulated bench behind the real drivers, the `f32`
//! pipeline), with the core's `Decoder` as the host:
//!
//! * commands are validated, applied between samples and acknowledged; a
//!   refused one changes nothing (settings, generator, estimator); the
//!   estimates converge to the beam's truth before and after a new
//!   estimator, a freeze, a reset;
//! * a full TX ring drops whole frames, each one exactly one lost sequence
//!   number at the host, flagged and counted; a stalled low-priority task
//!   makes the sample path drop records (counted), never wait;
//! * the EXCITED flag follows the excitation (the threshold's evidence);
//! * arbitrary bytes on the RX side never panic, and arbitrary commands
//!   are either applied or refused without a change;
//! * the self-test (`selftest`): passes on the healthy bench, each bench
//!   fault fails exactly its check, a commanded one leaves the estimator
//!   as it was.

mod bench;
mod selftest;
#[path = "../protocol/strategies.rs"]
#[allow(dead_code)]
mod strategies;

use beam_protocol::{
    AckResult, Command, Estimate, EstimatorSettings, Excitation, Message, RejectReason, Status,
    StatusFlags, TelemetryRates, Waveform,
};
use beamest::estimator::Estimator;
use beamest::link::{TxSink, ANSWER_RESERVE_BYTES};
use beamest::model::{PAPER_OMEGA, PAPER_ZETA};
use proptest::collection::vec;
use proptest::prelude::*;

use bench::{with_bench, Bench, Host, Ring};

/// Samples per second.
const FS: u64 = 10_000;

fn acks(msgs: &[Message]) -> Vec<(u32, AckResult)> {
    msgs.iter()
        .filter_map(|m| match m {
            Message::Ack(a) => Some((a.command_seq, a.result)),
            _ => None,
        })
        .collect()
}

fn statuses<'a>(msgs: impl IntoIterator<Item = &'a Message>) -> Vec<Status> {
    msgs.into_iter()
        .filter_map(|m| match m {
            Message::Status(s) => Some(s.clone()),
            _ => None,
        })
        .collect()
}

fn estimates<'a>(msgs: impl IntoIterator<Item = &'a Message>) -> Vec<Estimate> {
    msgs.into_iter()
        .filter_map(|m| match m {
            Message::Estimate(e) => Some(e.clone()),
            _ => None,
        })
        .collect()
}

/// Largest relative error of ω1, ω2, ζ1, ζ2 of an estimate.
fn error(e: &Estimate) -> f64 {
    assert_eq!(e.modes.len(), 2, "{e:?}");
    e.modes
        .iter()
        .enumerate()
        .flat_map(|(i, m)| {
            [
                (f64::from(m.omega_rad_s) / PAPER_OMEGA[i] - 1.0).abs(),
                (f64::from(m.zeta) / PAPER_ZETA[i] - 1.0).abs(),
            ]
        })
        .fold(0.0, f64::max)
}

fn square(amplitude_v: f32) -> Excitation {
    Excitation {
        waveform: Waveform::Square { freq_hz: 7.0 },
        amplitude_v,
        offset_v: 0.0,
    }
}

/// Send `c` and return its answer (drains the ring).
fn ask(
    b: &mut Bench<'_>,
    host: &mut Host,
    c: &Command,
    tx: &mut Ring,
) -> (AckResult, Vec<Message>) {
    b.command(host, c, tx);
    let msgs = host.drain(tx);
    let a = acks(&msgs);
    assert_eq!(a.len(), 1, "one Ack per command: {msgs:?}");
    assert_eq!(a[0].0, host.seq - 1);
    (a[0].1, msgs)
}

#[test]
fn commands_estimates_and_raw_samples_end_to_end() {
    with_bench(None, |b| {
        let mut tx = Ring::new(2048);
        let mut host = Host::new();
        let none = |_: &mut Bench<'_>, _: &[Message], _: &mut Ring, _: &mut Host| {};
        b.run_until(FS / 2, &mut tx, &mut host, 10, none);
        let start = b.started_at.expect("started after the 0.2 s window");
        assert!((2_000..2_200).contains(&start), "{start}");
        assert!(estimates(host.messages())
            .iter()
            .all(|e| e.sample_index >= start));
        let first = statuses(host.messages())[0].clone();
        assert_eq!(first.excitation, square(0.1));
        // The automatic rule: no λ until the window closes.
        assert_eq!(first.estimator.lambda_rad_s, None);
        let lambda0 = b.link.lambda_rad_s().unwrap();
        assert!((50.0..200.0).contains(&lambda0), "{lambda0}");

        // Raw samples on at 1 kHz.
        let rates = TelemetryRates {
            raw_decimation: 10,
            ..TelemetryRates::default()
        };
        let (r, _) = ask(b, &mut host, &Command::SetTelemetry(rates), &mut tx);
        assert_eq!(r, AckResult::Accepted);
        b.run_until(FS, &mut tx, &mut host, 10, none);

        // A 20 V excitation leaves the ±10 V window: refused, nothing changes.
        let gen = *b.device.pipeline.excitation();
        let theta = b.device.pipeline.estimator().theta();
        let before = b.link.status(0, &b.device.pipeline.counters());
        let (r, _) = ask(b, &mut host, &Command::SetExcitation(square(20.0)), &mut tx);
        assert_eq!(r, AckResult::Rejected(RejectReason::SafeWindow));
        assert_eq!(*b.device.pipeline.excitation(), gen);
        assert_eq!(b.device.pipeline.estimator().theta(), theta);
        let (_, msgs) = ask(b, &mut host, &Command::RequestStatus, &mut tx);
        let after = &statuses(&msgs)[0];
        assert_eq!(
            (after.excitation, after.estimator, after.telemetry),
            (before.excitation, before.estimator, before.telemetry)
        );
        assert_eq!(after.counters.commands_rejected, 1);
        let newest_before = b.samples;
        b.run_until(FS * 3 / 2, &mut tx, &mut host, 10, none);

        // 0.2 V: accepted, in force from the next sample.
        let (r, msgs) = ask(b, &mut host, &Command::SetExcitation(square(0.2)), &mut tx);
        assert_eq!(r, AckResult::Accepted);
        assert!(statuses(&msgs).is_empty());
        let switched = b.samples;
        assert_eq!(b.device.pipeline.excitation().amplitude(), 0.2);
        b.run_until(2 * FS, &mut tx, &mut host, 10, none);
        let mut raw = Vec::new();
        for m in host.messages() {
            if let Message::RawSamples(r) = m {
                assert!(r.samples.len() <= 64 && r.decimation == 10);
                for (i, s) in r.samples.iter().enumerate() {
                    raw.push((r.first_sample_index + 10 * i as u64, s.u_v));
                }
            }
        }
        let level = |lo: u64, hi: u64, a: f32| {
            let v: Vec<f32> = raw
                .iter()
                .filter(|r| r.0 >= lo && r.0 < hi && r.1.is_finite())
                .map(|r| r.1)
                .collect();
            assert!(v.len() > 100, "{} pairs in [{lo}, {hi})", v.len());
            for u in v {
                assert!((u.abs() / a - 1.0).abs() < 0.02, "|u| = {u} vs {a}");
            }
        };
        level(0, newest_before, 0.1);
        level(switched, 2 * FS, 0.2);
        let e = estimates(host.messages());
        assert!(error(e.last().unwrap()) < 1e-3);

        // A new estimator (λ = 120 rad/s): built outside, swapped in, held
        // for its settling time, converged again 1 s later.
        let s = EstimatorSettings {
            lambda_rad_s: Some(120.0),
            ..EstimatorSettings::default()
        };
        let (r, _) = ask(b, &mut host, &Command::SetEstimator(s), &mut tx);
        assert_eq!(r, AckResult::Accepted);
        let swapped = b.samples;
        assert_eq!(b.link.lambda_rad_s(), Some(120.0));
        b.run_until(3 * FS, &mut tx, &mut host, 10, none);
        let e = estimates(host.messages());
        let after: Vec<&Estimate> = e.iter().filter(|e| e.sample_index >= swapped).collect();
        assert!(
            after[0].flags.contains(StatusFlags::FROZEN_AUTO),
            "held after the swap"
        );
        assert!(error(after.last().unwrap()) < 1e-3);
        let (_, msgs) = ask(b, &mut host, &Command::RequestStatus, &mut tx);
        assert_eq!(statuses(&msgs)[0].estimator.lambda_rad_s, Some(120.0));

        // Freeze: Θ̂ held, flagged; Resume; Reset: converged again.
        let (r, _) = ask(b, &mut host, &Command::Freeze, &mut tx);
        assert_eq!(r, AckResult::Accepted);
        let frozen_at = b.samples;
        b.run_until(3 * FS + 3_000, &mut tx, &mut host, 10, none);
        let e = estimates(host.messages());
        let frozen: Vec<&Estimate> = e.iter().filter(|e| e.sample_index >= frozen_at).collect();
        assert!(frozen.len() >= 29);
        assert!(frozen.iter().all(
            |e| e.flags.contains(StatusFlags::FROZEN_BY_COMMAND) && e.theta == frozen[0].theta
        ));
        for c in [Command::Resume, Command::Reset] {
            assert_eq!(ask(b, &mut host, &c, &mut tx).0, AckResult::Accepted);
        }
        let reset_at = b.samples;
        b.run_until(9 * FS / 2, &mut tx, &mut host, 10, none);
        let e = estimates(host.messages());
        let last = e.last().unwrap();
        assert!(last.sample_index > reset_at + 10_000);
        assert!(!last.flags.contains(StatusFlags::FROZEN_BY_COMMAND));
        assert!(error(last) < 1e-3, "{}", error(last));
        assert!(last.flags.contains(
            StatusFlags::EXCITED
                .with(StatusFlags::PHYSICALLY_VALID)
                .with(StatusFlags::CONVERGED)
        ));

        // The link: every frame delivered, in order; every command answered.
        let c = host.dec.counters();
        assert_eq!(
            (c.lost, c.errors(), c.duplicates, c.out_of_order),
            (0, 0, 0, 0)
        );
        assert_eq!(b.link.commands(), (8, 1));
        assert_eq!(b.device.pipeline.counters().dropped_records, 0);
        assert_eq!(b.device.pipeline.counters().dropped_raw_blocks, 0);
    });
}

#[test]
fn full_tx_ring_drops_whole_frames_counted_exactly_and_never_blocks() {
    with_bench(None, |b| {
        let mut tx = Ring::new(1024);
        let mut host = Host::new();
        let none = |_: &mut Bench<'_>, _: &[Message], _: &mut Ring, _: &mut Host| {};
        b.run_until(FS / 2, &mut tx, &mut host, 10, none);
        assert_eq!(b.link.tx_stats().frames_dropped, 0);
        // The host stops reading for 0.3 s: the ring fills, frames drop;
        // every sample still runs (checked in `step`).
        b.run_until(FS / 2 + 3_000, &mut tx, &mut host, 0, none);
        let dropped = b.link.tx_stats().frames_dropped;
        assert!(dropped > 10, "{dropped}");
        assert!(
            tx.free() >= ANSWER_RESERVE_BYTES,
            "the answers' reserve stays free"
        );
        b.run_until(FS, &mut tx, &mut host, 10, none);
        // Exactly one lost sequence number per dropped frame.
        let c = host.dec.counters();
        assert_eq!(c.lost, u64::from(dropped));
        assert_eq!(c.errors(), 0);
        // One gap (the drops were consecutive); the first estimate after it
        // says so, the next does not; the Status counts them.
        let gaps: Vec<usize> = (1..host.frames.len())
            .filter(|&i| host.frames[i].seq != host.frames[i - 1].seq + 1)
            .collect();
        assert_eq!(gaps.len(), 1);
        assert_eq!(
            u64::from(host.frames[gaps[0]].seq - host.frames[gaps[0] - 1].seq - 1),
            c.lost
        );
        let after = estimates(host.frames[gaps[0]..].iter().map(|f| &f.message));
        assert!(after[0].flags.contains(StatusFlags::TELEMETRY_DROPPED));
        assert!(!after[1].flags.contains(StatusFlags::TELEMETRY_DROPPED));
        let (_, msgs) = ask(b, &mut host, &Command::RequestStatus, &mut tx);
        assert_eq!(statuses(&msgs)[0].counters.telemetry_dropped, dropped);
        assert_eq!(b.device.pipeline.counters().dropped_records, 0);
    });
}

#[test]
fn stalled_low_priority_task_drops_records_counted_sample_path_runs() {
    with_bench(None, |b| {
        let mut tx = Ring::new(2048);
        let mut host = Host::new();
        let none = |_: &mut Bench<'_>, _: &[Message], _: &mut Ring, _: &mut Host| {};
        b.run_until(FS / 2, &mut tx, &mut host, 10, none);
        // Thread mode stalls for 0.3 s: the 15-record queue holds 150 ms.
        b.stalled = true;
        b.run_until(FS / 2 + 3_000, &mut tx, &mut host, 10, none);
        b.stalled = false;
        let dropped = b.device.pipeline.counters().dropped_records;
        assert_eq!(dropped, 30 - 15, "30 records made, 15 queued");
        let seen = host.frames.len();
        b.run_until(FS, &mut tx, &mut host, 10, none);
        let after = estimates(host.frames[seen..].iter().map(|f| &f.message));
        // The queued 15 come first (their flags predate the drops), then the
        // first record made after the drops carries them.
        let flagged: Vec<u64> = after
            .iter()
            .filter(|e| e.flags.contains(StatusFlags::TELEMETRY_DROPPED))
            .map(|e| e.sample_index)
            .collect();
        assert_eq!(flagged.len(), 1, "{flagged:?}");
        let (_, msgs) = ask(b, &mut host, &Command::RequestStatus, &mut tx);
        assert_eq!(statuses(&msgs)[0].counters.telemetry_dropped, dropped);
        assert_eq!(
            host.dec.counters().lost,
            0,
            "records lost are not frames lost"
        );
    });
}

/// λmin(P)/tr(P) of the records every 0.5 s from 1 s to 30 s (time in s,
/// ratio), and the EXCITED flag of every estimate (sample index, flag).
type Levels = (Vec<(f64, f32)>, Vec<(u64, bool)>);

/// [`Levels`] of a 30 s run under excitation `x`.
fn excitation_levels(x: Option<Excitation>) -> Levels {
    with_bench(x, |b| {
        let mut tx = Ring::new(4096);
        let mut host = Host::new();
        let mut ratios = Vec::new();
        let mut next = FS;
        // Thread mode by hand, to see P next to the estimates.
        b.stalled = true;
        while b.samples < 30 * FS {
            b.step(&mut tx);
            b.tune();
            while let Some(r) = b.records.dequeue() {
                let rec = b.link.on_record(&r, &[-2.0f32, 2.0], &mut tx);
                if let (Some(rec), true) = (rec, r.sample_index >= next) {
                    next += FS / 2;
                    let p: [[f32; 7]; 7] = beamest::pipeline::unpack_symmetric(&r.information);
                    let tr: f32 = (0..7).map(|i| p[i][i]).sum();
                    let lmin = rec.excitation_min_eig.unwrap();
                    ratios.push((r.sample_index as f64 / FS as f64, lmin / tr));
                }
            }
            host.drain(&mut tx);
        }
        let all = estimates(host.messages());
        // EXCITED is checkable from each frame (PROTOCOL.md §4.1, §9.3):
        // excitation_level ≥ 1e-7 and INPUT_GONE clear; the level is never
        // negative.
        let rho = beamest::link::FlagRules::default().excitation_rel_threshold;
        for e in &all {
            let level = e.excitation_level.expect("the adaptive law has P");
            assert!((0.0..=1.0).contains(&level), "{level}");
            assert_eq!(
                e.flags.contains(StatusFlags::EXCITED),
                level >= rho && !e.flags.contains(StatusFlags::INPUT_GONE),
                "sample {}: level {level}, flags {:#x}",
                e.sample_index,
                e.flags.0
            );
        }
        let flags = all
            .iter()
            .map(|e| (e.sample_index, e.flags.contains(StatusFlags::EXCITED)))
            .collect();
        (ratios, flags)
    })
}

#[test]
fn excited_flag_follows_the_excitation() {
    let tones = |n: u8, f_max_hz: f32| Excitation {
        waveform: Waveform::Multisine {
            f_min_hz: 7.0,
            f_max_hz,
            tones: n,
        },
        amplitude_v: 0.1,
        offset_v: 0.0,
    };
    let runs = [
        ("square 7 Hz", None),
        ("one tone 7 Hz", Some(tones(1, 7.0))),
        ("two tones 7, 30 Hz", Some(tones(2, 30.0))),
    ];
    let rho = beamest::link::FlagRules::default().excitation_rel_threshold;
    for (i, (name, x)) in runs.into_iter().enumerate() {
        let (ratios, flags) = excitation_levels(x);
        let lo = ratios.iter().map(|r| r.1).fold(f32::INFINITY, f32::min);
        let hi = ratios.iter().map(|r| r.1.abs()).fold(0.0, f32::max);
        println!(
            "{name:>18}: lambda_min(P)/tr(P) from 1 s to 30 s: min {lo:.2e}, max |.| {hi:.2e}; \
             EXCITED in {} of {} estimates",
            flags.iter().filter(|f| f.1).count(),
            flags.len()
        );
        if i == 0 {
            // Exciting: at least 3× the threshold from 1 s on (measured
            // 3.5× on the timed bench under the automatic rule), flagged.
            assert!(lo >= 3.0 * rho, "{lo}");
            assert!(flags.iter().filter(|f| f.0 >= FS).all(|f| f.1));
        } else {
            // Not exciting for 2 modes (Lemma 1): rounding noise, at
            // least 3× below the threshold (measured 4.2× with one tone,
            // 5.0× with two, at the automatic rule's λ; 8.5× at λ = 100).
            assert!(hi <= rho / 3.0, "{hi}");
            assert!(flags.iter().all(|f| !f.1));
        }
    }
}

/// A bench whose estimator has started (0.22 s in), the host attached.
fn started(b: &mut Bench<'_>, tx: &mut Ring, host: &mut Host) {
    let none = |_: &mut Bench<'_>, _: &[Message], _: &mut Ring, _: &mut Host| {};
    b.run_until(2_200, tx, host, 10, none);
    assert!(b.started_at.is_some());
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 48, .. ProptestConfig::default() })]

    /// Arbitrary bytes, with intact command frames mixed in (each after a
    /// delimiter): no panic, exactly those commands answered, the rest
    /// counted, and the sample path runs on.
    #[test]
    fn arbitrary_rx_bytes_never_panic(
        chunks in vec((vec(any::<u8>(), 0..80), proptest::option::of(strategies::command())), 1..8)
    ) {
        with_bench(None, |b| {
            let mut tx = Ring::new(8192);
            let mut host = Host::new();
            started(b, &mut tx, &mut host);
            let mut bytes = Vec::new();
            let mut sent = 0;
            for (noise, cmd) in &chunks {
                bytes.extend(noise);
                if let Some(c) = cmd {
                    bytes.push(0);
                    bytes.extend(host.command(c));
                    sent += 1;
                }
            }
            b.link.receive(bytes, &mut b.device, &mut tx);
            let got = acks(&host.drain(&mut tx));
            // Noise could only add an Ack by forging a CRC-32 (2^-32).
            prop_assert_eq!(got.len(), sent);
            for _ in 0..100 {
                b.step(&mut tx);
            }
            Ok(())
        })?;
    }

    /// Any command (arbitrary values, NaN, out of range): applied as the
    /// Status then states, or refused with nothing changed.
    #[test]
    fn any_command_is_applied_or_refused_without_change(c in strategies::command()) {
        with_bench(None, |b| {
            let mut tx = Ring::new(8192);
            let mut host = Host::new();
            started(b, &mut tx, &mut host);
            let gen = *b.device.pipeline.excitation();
            let theta = b.device.pipeline.estimator().theta();
            let frozen = b.device.pipeline.is_frozen();
            let before = b.link.status(0, &b.device.pipeline.counters());
            let (r, _) = ask(b, &mut host, &c, &mut tx);
            let (_, msgs) = ask(b, &mut host, &Command::RequestStatus, &mut tx);
            let after = statuses(&msgs)[0].clone();
            match r {
                AckResult::Rejected(_) => {
                    prop_assert_eq!(*b.device.pipeline.excitation(), gen);
                    prop_assert_eq!(b.device.pipeline.estimator().theta(), theta);
                    prop_assert_eq!(b.device.pipeline.is_frozen(), frozen);
                    prop_assert_eq!(after.excitation, before.excitation);
                    prop_assert_eq!(after.estimator, before.estimator);
                    prop_assert_eq!(after.telemetry, before.telemetry);
                }
                AckResult::Accepted => match c {
                    Command::SetExcitation(x) => prop_assert_eq!(after.excitation, x),
                    Command::SetTelemetry(t) => prop_assert_eq!(after.telemetry, t),
                    Command::SetEstimator(s) => prop_assert_eq!(
                        after.estimator,
                        EstimatorSettings { lambda_rad_s: s.lambda_rad_s.or(before.estimator.lambda_rad_s), ..s }
                    ),
                    Command::Freeze => prop_assert!(after.adaptation_frozen && b.device.pipeline.is_frozen()),
                    _ => {}
                },
            }
            // The sample path runs on whatever was accepted.
            for _ in 0..200 {
                b.step(&mut tx);
            }
            Ok(())
        })?;
    }
}
