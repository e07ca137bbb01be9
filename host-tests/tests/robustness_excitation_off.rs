//! Issue 9, loss of excitation: the drive stops for 60 s after
//! convergence (u = 0 from 10 s to 70 s) on the paper's plant. With the
//! supervisor at its defaults the 2-mode adaptive law (f64 and f32) sees
//! the input gone, learns from the beam's ring-down while it is informative
//! (`FreeResponse`: the regressor's power within 20 dB of its level under
//! the drive), then freezes adaptation (anti-windup) and resumes on its
//! own: no NaN, H⁻¹ (R), P and Θ̂ bounded — frozen, in fact — estimates
//! within 1% throughout and within 0.1% again ≤ 1 s after the drive
//! returns. Settings truth-free (`host_tests::scenario_run`).
//! Figures: `cargo run --release -p host-tests --example robustness_table off`.

use beamest::estimator::{Adaptive2, AdaptiveConfig, Estimator};
use beamest::supervise::{ExcitationReason, SupervisorConfig};
use beamest::Real;
use host_tests::scenario_run::*;

const OFF_FROM: f64 = 10.0;
const OFF_TO: f64 = 70.0;
/// The ring-down decays 20 dB in regressor power within this (s).
const FREEZE_WITHIN_S: f64 = 5.0;

/// Largest |entry| of a matrix.
fn largest(m: &[[f64; 7]; 7]) -> f64 {
    m.iter().flatten().fold(0.0, |a, v| a.max(v.abs()))
}

fn excitation_off<T: Real>(snr: Option<f64>) {
    let ty = T::NAME;
    let mut rig = paper_rig(off_scenario(0.0), snr, 1, None);
    let f = startup_filter(&rig);
    let mut est = Adaptive2::<T>::new(&f, &AdaptiveConfig::default()).expect("valid settings");
    // The law's P and R (= H⁻¹ in scaled coordinates), every 0.1 s.
    let mut snapshots: Vec<(f64, f64, f64, bool)> = Vec::new();
    let tr = run_with(
        &mut est,
        &mut rig,
        750_000,
        100,
        &mut |e: &mut Adaptive2<T>, k, s| {
            if k % 1000 == 0 {
                let law = e.law();
                let p = law.p().map(|r| r.map(|v| v.to_f64()));
                let h = law.h_inverse().map(|r| r.map(|v| v.to_f64()));
                let finite = p.iter().chain(h.iter()).flatten().all(|v| v.is_finite())
                    && e.theta().iter().all(|v| v.is_finite());
                snapshots.push((k as f64 * TS_S, largest(&p), largest(&h), finite));
            }
            s
        },
    );
    // No NaN anywhere: Θ̂, P, R finite throughout, and every evaluation
    // from convergence on recovered finite ω, ζ.
    assert!(snapshots.iter().all(|s| s.3), "{ty}: non-finite Θ̂, P or R");
    assert!(
        tr.t.iter()
            .zip(&tr.est)
            .filter(|(t, _)| **t >= 5.0)
            .all(|(_, e)| e.iter().all(|v| v.is_finite())),
        "{ty}: NaN"
    );
    // The reason: the ring-down is learnt from (free response) from
    // within 50 ms of the stop, then the input is gone (frozen) within
    // FREEZE_WITHIN_S, and excited again within 10 ms of the return.
    let reason_at = |t: f64| {
        tr.t.iter()
            .zip(&tr.sup)
            .find(|(x, _)| **x >= t)
            .and_then(|(_, s)| s.map(|s| s.reason))
            .expect("supervised")
    };
    assert_eq!(reason_at(OFF_FROM + 0.05), ExcitationReason::FreeResponse);
    let frozen_at = tr
        .t
        .iter()
        .zip(&tr.sup)
        .find(|(x, s)| **x > OFF_FROM && s.is_some_and(|s| s.reason == ExcitationReason::InputGone))
        .map(|(x, _)| *x)
        .expect("frozen while the drive is off");
    assert!(
        frozen_at - OFF_FROM <= FREEZE_WITHIN_S,
        "{ty}: frozen {} s after the stop",
        frozen_at - OFF_FROM
    );
    assert_eq!(reason_at(OFF_TO - 0.1), ExcitationReason::InputGone);
    assert_eq!(reason_at(OFF_TO + 0.01), ExcitationReason::Excited);
    // P, R bounded: nothing grows once frozen.
    let at = |t: f64| {
        snapshots
            .iter()
            .find(|s| s.0 >= t)
            .copied()
            .expect("snapshot")
    };
    let (p0, h0) = (at(frozen_at + 0.1).1, at(frozen_at + 0.1).2);
    for s in snapshots
        .iter()
        .filter(|s| s.0 > frozen_at + 0.1 && s.0 < OFF_TO)
    {
        assert!(s.1 <= p0 * (1.0 + 1e-9), "{ty}: P grows at {} s", s.0);
        assert!(s.2 <= h0 * (1.0 + 1e-9), "{ty}: R grows at {} s", s.0);
    }
    // Θ̂ bounded: its largest entry never exceeds the converged one's.
    let theta_before =
        tr.t.iter()
            .zip(&tr.est)
            .find(|(t, _)| **t >= OFF_FROM - 0.01)
            .map(|(_, e)| *e)
            .expect("estimate");
    let drift =
        tr.t.iter()
            .zip(&tr.est)
            .filter(|(t, _)| **t >= OFF_FROM && **t < OFF_TO)
            .map(|(_, e)| max_rel_error(e, &theta_before))
            .fold(0.0, f64::max);
    // At 40 dB the ring-down it learns from moves the paper's law within
    // its own noise bias (measured: 1.05e-2, against > 30% unsupervised).
    let tol_off = if snr.is_some() { 2e-2 } else { 1e-5 };
    assert!(
        drift <= tol_off,
        "{ty}: the estimate moved by {drift:e} while off"
    );
    if snr.is_none() {
        // Within 1% throughout, within 0.1% ≤ 1 s after the return.
        let off = tr.max_err(OFF_FROM, OFF_TO);
        assert!(off <= 1e-2, "{ty}: {off:e} while off");
        let back = tr.settled_after(OFF_TO, 1e9, 1e-3).expect("settles") - OFF_TO;
        assert!(back <= 1.0, "{ty}: within 0.1% {back} s after the return");
        let after = tr.max_err(OFF_TO + 1.0, 1e9);
        assert!(after <= 1e-3, "{ty}: {after:e} after the return");
    }
}

#[test]
fn sixty_seconds_without_excitation_f64() {
    excitation_off::<f64>(None);
}

#[test]
fn sixty_seconds_without_excitation_f32() {
    excitation_off::<f32>(None);
}

/// At 40 dB the published law without supervision fits the noise while
/// the drive is off (its estimate moves by > 30%); supervised, it learns
/// from the ring-down only and moves by about 1% (within the law's own 5%
/// noise bias at 40 dB, which is another matter: the robust estimator's).
#[test]
fn without_supervision_noise_winds_the_estimate_up() {
    excitation_off::<f64>(Some(40.0));
    let cfg = AdaptiveConfig {
        supervision: SupervisorConfig::OFF,
        ..AdaptiveConfig::default()
    };
    let mut rig = paper_rig(off_scenario(0.0), Some(40.0), 1, None);
    let f = startup_filter(&rig);
    let mut est = Adaptive2::<f64>::new(&f, &cfg).expect("valid settings");
    let tr = run(&mut est, &mut rig, 700_000, 100, &mut direct);
    let before = tr.est[tr
        .t
        .iter()
        .position(|&t| t >= OFF_FROM - 0.01)
        .expect("10 s")];
    let moved = max_rel_error(tr.est.last().expect("estimate"), &before);
    assert!(moved > 0.3, "{moved:e}");
    assert!(est.supervision().is_none());
}
