//! The bring-up self-test on the QEMU image's data path (the simulated
//! bench behind the real drivers, the `f32` pipeline, the link), as the
//! firmware runs it: at start-up before the tuning rule's window, and on
//! the `SelfTest` command while the estimator runs.
//!
//! * every check passes on the healthy bench, with the values the bench's
//!   physics gives (sinc⁴ droop, 2.15-sample delay, the quantisation floor);
//! * each of the bench's faults ([`BenchFault`]) fails exactly its check;
//! * a commanded self-test leaves the estimator as it was: Θ̂ held while it
//!   runs (its estimates flagged SELF_TEST), the excitation restored, no
//!   sample rejected, other commands refused (Busy), and the estimate
//!   within 1e-3 of the truth again afterwards.

use beam_protocol::{
    AckResult, Command, Message, RejectReason, SelfTestChecks, SelfTestState, StatusFlags,
};
use beamest::bench::{self, BenchFault};
use beamest::model::{PAPER_OMEGA, PAPER_ZETA};
use beamest::selftest::TOTAL_SAMPLES;

use crate::bench::{with_bench_opts, Host, Ring};
use crate::{acks, estimates, statuses, FS};

/// The largest relative error of ω and ζ of the last valid estimate.
fn worst_error(h: &Host) -> f64 {
    let e = estimates(h.messages())
        .into_iter()
        .rev()
        .find(|e| e.flags.contains(StatusFlags::PHYSICALLY_VALID))
        .expect("a valid estimate");
    e.modes
        .iter()
        .enumerate()
        .map(|(i, m)| {
            let ew = (f64::from(m.omega_rad_s) / PAPER_OMEGA[i] - 1.0).abs();
            let ez = (f64::from(m.zeta) / PAPER_ZETA[i] - 1.0).abs();
            ew.max(ez)
        })
        .fold(0.0, f64::max)
}

#[test]
fn the_start_up_self_test_passes_on_the_healthy_bench_then_the_estimator_starts() {
    with_bench_opts(None, None, true, |b| {
        let mut tx = Ring::new(1 << 16);
        let mut h = Host::new();
        b.run_until(5 * FS, &mut tx, &mut h, 100, |_, _, _, _| {});
        let [r] = b.reports.as_slice() else {
            panic!("{} reports", b.reports.len())
        };
        println!("{r:#?}");
        assert!(r.passed() && r.at_boot, "{r:?}");
        assert_eq!(r.first_sample, 0);
        assert!(r.last_sample >= TOTAL_SAMPLES - 1);
        assert_eq!(r.adc.id >> 8, 0x22);
        assert_eq!(r.adc.registers, bench::adc_config().expected_registers());
        assert_eq!(r.drdy.rate_hz, 1e4);
        assert_eq!(r.drdy.conversions, r.drdy.ticks);
        // The hold and the sinc³: sinc⁴(f·Ts) at 48.83 Hz, 1 − 1.6e-4; the
        // delay the estimator's timing model assumes.
        let droop = {
            let x = std::f64::consts::PI * 48.828125e-4;
            (x.sin() / x).powi(4)
        };
        assert!((f64::from(r.loopback.gain) - droop).abs() < 2e-6, "{r:?}");
        assert!((r.loopback.delay_samples - 2.15).abs() < 1e-4, "{r:?}");
        assert!(r.loopback.offset_v.abs() < 1e-4);
        // The beam rests at start-up: y is one code, the floor rules.
        assert_eq!(r.noise.noise_sd, 0.0);
        assert!(r.noise.snr_db > 100.0, "{r:?}");
        // The report reached the host; the tuning rule's window came after.
        assert!(h
            .messages()
            .any(|m| matches!(m, Message::SelfTestReport(x) if x.passed())));
        let started = b.started_at.unwrap();
        assert!(started > r.last_sample + 2_000, "{started}");
        assert!(worst_error(&h) < 1e-3, "{}", worst_error(&h));
        let st = statuses(h.messages());
        assert_eq!(st[0].self_test, SelfTestState::Running);
        assert_eq!(
            st.last().unwrap().self_test,
            SelfTestState::Done {
                failed: SelfTestChecks::default(),
                not_measured: SelfTestChecks::default()
            }
        );
        // No sample of the test was rejected: none reached the estimator.
        assert_eq!(st.last().unwrap().counters.rejected_samples, 0);
    });
}

#[test]
fn each_bench_fault_fails_exactly_its_check() {
    for (fault, name) in BenchFault::ALL {
        with_bench_opts(None, Some(fault), true, |b| {
            let mut tx = Ring::new(1 << 16);
            let mut h = Host::new();
            b.run_until(TOTAL_SAMPLES + 200, &mut tx, &mut h, 100, |_, _, _, _| {});
            let [r] = b.reports.as_slice() else {
                panic!("{name}: {} reports", b.reports.len())
            };
            println!(
                "{name}: failed {:#06x} not measured {:#06x}: id {:04X}h, registers {:04X?}, \
                 DRDY {} Hz, gain {}, delay {}, σ {:e}, SNR {} dB",
                r.failed.0,
                r.not_measured.0,
                r.adc.id,
                r.adc.registers,
                r.drdy.rate_hz,
                r.loopback.gain,
                r.loopback.delay_samples,
                r.noise.noise_sd,
                r.noise.snr_db
            );
            assert_eq!((r.failed, r.not_measured), fault.expected(), "{name}");
        });
    }
}

#[test]
fn a_commanded_self_test_holds_the_estimate_and_restores_the_drive() {
    with_bench_opts(None, None, true, |b| {
        let mut tx = Ring::new(1 << 16);
        let mut h = Host::new();
        b.run_until(3 * FS, &mut tx, &mut h, 100, |_, _, _, _| {});
        let before = b.link.status(0, &Default::default());
        b.command(&mut h, &Command::SelfTest, &mut tx);
        let at = b.samples;
        // Busy while it runs, RequestStatus still answered.
        b.command(&mut h, &Command::Reset, &mut tx);
        b.command(&mut h, &Command::RequestStatus, &mut tx);
        let msgs = h.drain(&mut tx);
        assert_eq!(
            acks(&msgs),
            [
                (0, AckResult::Accepted),
                (1, AckResult::Rejected(RejectReason::Busy)),
                (2, AckResult::Accepted)
            ]
        );
        b.run_until(6 * FS, &mut tx, &mut h, 100, |_, _, _, _| {});
        let [boot, r] = b.reports.as_slice() else {
            panic!("{} reports", b.reports.len())
        };
        assert!(boot.at_boot && !r.at_boot);
        assert!(r.passed(), "{r:?}");
        assert_eq!(r.first_sample, at);
        // The beam rang from the excitation: the differences see the
        // quantisation, not the beam.
        assert!(
            r.noise.noise_sd > 0.0 && r.noise.noise_sd < 2.0 * r.noise.floor_sd,
            "{r:?}"
        );
        // Estimates made during the test: flagged, Θ̂ held (the law frozen
        // from the test's first sample).
        let during: Vec<_> = estimates(h.messages())
            .into_iter()
            .filter(|e| (r.first_sample..=r.last_sample).contains(&e.sample_index))
            .collect();
        assert!(during.len() >= 60, "{}", during.len());
        for e in &during {
            assert!(e.flags.contains(StatusFlags::SELF_TEST), "{e:?}");
            assert_eq!(e.theta, during[0].theta);
        }
        let after = b.link.status(0, &Default::default());
        assert_eq!(after.excitation, before.excitation);
        assert_eq!(after.estimator.kind, before.estimator.kind);
        assert!(!after.adaptation_frozen);
        assert_eq!(
            b.device.pipeline.excitation().kind(),
            beam_protocol::WaveformKind::Square
        );
        assert_eq!(b.device.pipeline.counters().rejected, 0);
        assert!(worst_error(&h) < 1e-3, "{}", worst_error(&h));
    });
}
