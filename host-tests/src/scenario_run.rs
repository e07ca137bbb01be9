//! Scenario runs for the robustness tests of issue 9: a
//! [`ScenarioRig`] on the paper's plant feeds an estimator sample by
//! sample, and the estimate is scored at the telemetry rate against the
//! truth *in force* (after a plant step, the new plant's).
//!
//! Settings are truth-free: λ = 100 rad/s (the paper's), U0, Y0 = RMS of
//! the measured u, y over the first 0.2 s of the same run (noise and
//! events included).

use beamctl::run::feed::{Direct, Feed, Screened};
use beamest::estimator::{Estimator, StepStatus};
use beamest::excitation::SquareWave;
use beamest::filter_bank::{FilterConfig, SignalScales};
use beamest::modal::modal_from_tf;
use beamest::model::{ModalParams, TransferFunction, PAPER_B, PAPER_OMEGA, PAPER_ZETA};
use beamest::model::{PAPER_OMEGA as OMEGA0, PAPER_ZETA as ZETA0};
use beamest::rig::ModalPlant;
use beamest::rig::{
    noise_sd_for_snr, ExcitationOff, FaultKind, GaussianNoise, PlantStep, Rig, Sample, Scenario,
    ScenarioRig, SensorFault, Window,
};
use beamest::supervise::Supervision;
use beamest::Real;

/// Sample period (the paper's 0.1 ms).
pub const TS_S: f64 = 1e-4;
/// The paper's output weights C̄ (eq. 24).
pub const WEIGHTS: [f64; 2] = [-2.0, 2.0];

/// The rig of these runs.
pub type PaperRig = ScenarioRig<f64, SquareWave<f64>>;

/// The paper's plant under 0.1·square(7 Hz) going through `scenario`, with
/// white noise at `snr_db` (relative to the noise-free y's RMS over the
/// first 2 s) and `extra` modes beyond the model.
pub fn paper_rig(
    scenario: Scenario,
    snr_db: Option<f64>,
    seed: u64,
    extra: Option<&ModalParams<f64>>,
) -> PaperRig {
    let plant = ModalPlant::with_numerator(&PAPER_OMEGA, &PAPER_ZETA, &PAPER_B, TS_S)
        .expect("the paper's plant");
    rig_for(plant, scenario, snr_db, seed, extra)
}

/// Any plant under 0.1·square(7 Hz) going through `scenario` (see
/// [`paper_rig`]).
pub fn rig_for(
    plant: ModalPlant<f64>,
    scenario: Scenario,
    snr_db: Option<f64>,
    seed: u64,
    extra: Option<&ModalParams<f64>>,
) -> PaperRig {
    let mut rig =
        ScenarioRig::new(Rig::new(plant, SquareWave::paper()), scenario).expect("a valid scenario");
    if let Some(m) = extra {
        let p = ModalPlant::from_modal(m, TS_S).expect("valid extra modes");
        rig = rig.with_extra_modes(p).expect("same Ts");
    }
    if let Some(snr) = snr_db {
        let mut probe = rig.noise_free();
        let n = (2.0 / TS_S) as usize;
        let rms = ((0..n).map(|_| probe.tick().y.powi(2)).sum::<f64>() / n as f64).sqrt();
        let noise = GaussianNoise::new(noise_sd_for_snr(rms, snr), seed).expect("finite SNR");
        rig = rig.with_noise(noise);
    }
    rig
}

/// λ = 100 rad/s and U0, Y0 = RMS of what this rig will deliver over its
/// first 0.2 s (measured on a copy; non-finite samples skipped).
pub fn startup_filter(rig: &PaperRig) -> FilterConfig {
    let mut probe = rig.clone();
    let (mut su, mut sy, mut n) = (0.0, 0.0, 0usize);
    for _ in 0..(0.2 / TS_S) as usize {
        let s = probe.tick();
        if s.u.is_finite() && s.y.is_finite() {
            su += s.u * s.u;
            sy += s.y * s.y;
            n += 1;
        }
    }
    let n = n.max(1) as f64;
    FilterConfig {
        ts_s: TS_S,
        lambda_rad_s: 100.0,
        scales: SignalScales {
            u_scale: (su / n).sqrt(),
            y_scale: (sy / n).sqrt(),
        },
        ..FilterConfig::default()
    }
}

/// ω1, ω2, ζ1, ζ2 of a two-mode transfer function (C̄ = [−2, 2]).
pub fn omega_zeta<T: Real>(tf: &TransferFunction<T>) -> Option<[f64; 4]> {
    let w = [T::from_f64(WEIGHTS[0]), T::from_f64(WEIGHTS[1])];
    let m = modal_from_tf(tf, &w).ok()?;
    let v = [m.omega_rad_s[0], m.omega_rad_s[1], m.zeta[0], m.zeta[1]].map(|x| x.to_f64());
    v.iter().all(|x| x.is_finite()).then_some(v)
}

/// Largest relative error of ω1, ω2, ζ1, ζ2 (∞ if not recoverable).
pub fn max_rel_error(est: &[f64; 4], truth: &[f64; 4]) -> f64 {
    est.iter()
        .zip(truth)
        .map(|(e, t)| ((e - t) / t).abs())
        .fold(0.0, f64::max)
}

/// What a run recorded at the telemetry rate.
#[derive(Debug, Clone, Default)]
pub struct RunTrace {
    /// Time of each evaluation (s).
    pub t: Vec<f64>,
    /// Largest relative ω/ζ error against the truth in force (∞: none).
    pub err: Vec<f64>,
    /// The estimate (NaN when not recoverable).
    pub est: Vec<[f64; 4]>,
    /// Supervisor states.
    pub sup: Vec<Option<Supervision<f64>>>,
    /// Steps: [updated, frozen, rejected, skipped].
    pub steps: [u64; 4],
    /// Samples the caller's input filter rejected (NaN handed over).
    pub largest_theta: f64,
}

impl RunTrace {
    /// Largest error over evaluations with t in [from, to).
    pub fn max_err(&self, from: f64, to: f64) -> f64 {
        self.t
            .iter()
            .zip(&self.err)
            .filter(|(t, _)| **t >= from && **t < to)
            .map(|(_, e)| *e)
            .fold(0.0, f64::max)
    }

    /// The first time ≥ `from` after which the error stays below `tol`
    /// until `to` (None if it never does).
    pub fn settled_after(&self, from: f64, to: f64, tol: f64) -> Option<f64> {
        let mut since = None;
        for (t, e) in self.t.iter().zip(&self.err) {
            if *t < from || *t >= to {
                continue;
            }
            if *e < tol {
                since.get_or_insert(*t);
            } else {
                since = None;
            }
        }
        since
    }

    /// The change statistic's largest value seen at the evaluations (the
    /// detector's own peak since it was armed, at the last evaluation).
    pub fn change_peak(&self) -> f64 {
        self.sup
            .iter()
            .filter_map(|s| s.map(|s| s.change_peak))
            .fold(0.0, f64::max)
    }

    /// Largest relative deviation of ω/ζ from `other`'s estimate at the
    /// same evaluation (the same run without a fault: what the fault alone
    /// changed), over t in [from, to); ∞ where either is not recoverable.
    pub fn max_dev_from(&self, other: &RunTrace, from: f64, to: f64) -> f64 {
        self.t
            .iter()
            .zip(&self.est)
            .zip(other.t.iter().zip(&other.est))
            .filter(|((t, _), _)| **t >= from && **t < to)
            .map(|((_, e), (_, r))| {
                let d = max_rel_error(e, r);
                if e.iter().chain(r).all(|v| v.is_finite()) && d.is_finite() {
                    d
                } else {
                    f64::INFINITY
                }
            })
            .fold(0.0, f64::max)
    }

    /// Changes detected by the end.
    pub fn changes(&self) -> u32 {
        self.sup
            .iter()
            .rev()
            .find_map(|s| s.map(|s| s.changes))
            .unwrap_or(0)
    }
}

/// Feed `samples` ticks of `rig` to `est` (through `filter` when given: it
/// maps each raw sample to what the estimator gets), evaluating every
/// `eval_every` samples against the truth in force.
pub fn run<T: Real, E: Estimator<T, 7> + ?Sized>(
    est: &mut E,
    rig: &mut PaperRig,
    samples: u64,
    eval_every: u64,
    filter: &mut dyn FnMut(u64, Sample<f64>) -> Sample<f64>,
) -> RunTrace {
    run_with(est, rig, samples, eval_every, &mut |_: &mut E, k, s| {
        filter(k, s)
    })
}

/// A per-sample hook: sees the estimator and sample `k` before it is
/// fed, and returns what the estimator gets.
pub type SampleHook<'a, E> = dyn FnMut(&mut E, u64, Sample<f64>) -> Sample<f64> + 'a;

/// [`run`] with a hook that sees the estimator before each sample is fed.
pub fn run_with<T: Real, E: Estimator<T, 7> + ?Sized>(
    est: &mut E,
    rig: &mut PaperRig,
    samples: u64,
    eval_every: u64,
    hook: &mut SampleHook<'_, E>,
) -> RunTrace {
    run_fed(est, rig, samples, eval_every, &mut |e: &mut E, k, raw| {
        let s = hook(e, k, raw);
        Some(e.step(T::from_f64(s.u), T::from_f64(s.y)))
    })
}

/// How a run gives raw sample `k` to the estimator: its step status, or
/// `None` if nothing was stepped.
pub type FeedStep<'a, E> = dyn FnMut(&mut E, u64, Sample<f64>) -> Option<StepStatus> + 'a;

/// The run loop: tick the rig, `feed` the sample, evaluate every
/// `eval_every` samples against the truth in force, from the first sample
/// the estimator was given on (while the guard's delay line fills it gets
/// none, and has no estimate to evaluate).
pub fn run_fed<T: Real, E: Estimator<T, 7> + ?Sized>(
    est: &mut E,
    rig: &mut PaperRig,
    samples: u64,
    eval_every: u64,
    feed: &mut FeedStep<'_, E>,
) -> RunTrace {
    let mut tr = RunTrace::default();
    let mut fed = false;
    for k in 0..samples {
        let raw = rig.tick();
        if let Some(st) = feed(est, k, raw) {
            fed = true;
            tr.steps[match st {
                StepStatus::Updated => 0,
                StepStatus::Frozen => 1,
                StepStatus::Rejected => 2,
                StepStatus::Skipped => 3,
            }] += 1;
        }
        if fed && (k + 1) % eval_every == 0 {
            let truth = omega_zeta(&rig.plant().transfer_function()).expect("valid truth");
            let e = omega_zeta(&est.transfer_function());
            tr.t.push(k as f64 * TS_S);
            tr.err
                .push(e.map_or(f64::INFINITY, |e| max_rel_error(&e, &truth)));
            tr.est.push(e.unwrap_or([f64::NAN; 4]));
            tr.sup.push(est.supervision().map(|s| Supervision {
                reason: s.reason,
                frozen: s.frozen,
                forgetting: s.forgetting,
                lemma1_ratio: s.lemma1_ratio.map(|r| r.to_f64()),
                input_level: s.input_level.to_f64(),
                changes: s.changes,
                change_statistic: s.change_statistic.to_f64(),
                change_peak: s.change_peak.to_f64(),
                last_change_sample: s.last_change_sample,
            }));
            let big = est
                .theta()
                .iter()
                .map(|v| v.to_f64().abs())
                .fold(0.0, f64::max);
            tr.largest_theta = tr.largest_theta.max(big);
        }
    }
    tr
}

/// [`run`] through a [`GuardedFeed`]: the estimator is held while its
/// filters settle, then each raw sample is screened and delivered with the
/// holds the guard asks for, by beamctl's policy ([`beamctl::run::feed`],
/// the one `beamctl simulate|replay` and the firmware's sample task apply).
pub fn run_guarded<T: Real, E: Estimator<T, 7> + ?Sized>(
    est: &mut E,
    rig: &mut PaperRig,
    samples: u64,
    eval_every: u64,
    feed: &mut GuardedFeed,
) -> RunTrace {
    run_guarded_with(est, rig, samples, eval_every, feed, &mut |_, _, _, _| {})
}

/// What sees each raw sample of a guarded run after the guard screened it
/// and before it is delivered: the estimator, the sample's index, the raw
/// sample and what the guard made of it.
pub type GuardObserver<'a, E> = dyn FnMut(&mut E, u64, Sample<f64>, &Screened) + 'a;

/// [`run_guarded`] with an observer of each screened sample.
pub fn run_guarded_with<T: Real, E: Estimator<T, 7> + ?Sized>(
    est: &mut E,
    rig: &mut PaperRig,
    samples: u64,
    eval_every: u64,
    feed: &mut GuardedFeed,
    observe: &mut GuardObserver<'_, E>,
) -> RunTrace {
    // A new estimator is held while its filters settle, as the firmware's
    // pipeline and beamctl's tuning rule hold every estimator they build.
    est.hold_for_settling();
    run_fed(est, rig, samples, eval_every, &mut |e: &mut E, k, raw| {
        feed.follow(&*e, k);
        let screened = feed.screen(k, raw);
        observe(e, k, raw, &screened);
        feed.deliver(e, &screened)
    })
}

/// No input filter.
pub fn direct(_k: u64, s: Sample<f64>) -> Sample<f64> {
    s
}

/// A [`SensorGuard`](beamest::guard::SensorGuard) between the rig and the
/// estimator with beamctl's hold policy ([`beamctl::run::feed`]): each raw
/// sample is screened, and the pair leaving the guard's delay line (NaN for
/// a faulty one; nothing while the line fills) is what the estimator gets,
/// with the holds the guard asks for. Records the first sample index at or
/// after `watch_from` at which the guard raised anything.
#[derive(Debug, Clone)]
pub struct GuardedFeed {
    /// The guard and the hold policy.
    pub feed: Feed,
    /// The estimator's detected plant changes when last looked at.
    held: u32,
    /// Watch for flags from this sample index on.
    pub watch_from: u64,
    /// First flagged sample index ≥ `watch_from` and what was seen there.
    pub first_flag: Option<(u64, beamest::guard::Screening)>,
    /// The tests on the model's residual, if on
    /// ([`GuardedFeed::with_monitor`]).
    pub monitor: Option<beamest::guard::ResidualMonitor<f64>>,
}

/// The monitor's model is refreshed from the estimator every this many
/// samples (10 ms: the telemetry rate).
pub const MODEL_EVERY: u64 = 100;

impl GuardedFeed {
    /// A guard with `cfg`, watching from sample `watch_from`.
    pub fn new(cfg: &beamest::guard::GuardConfig, watch_from: u64) -> Self {
        Self {
            feed: Feed::new(cfg).expect("valid guard settings"),
            held: 0,
            watch_from,
            first_flag: None,
            monitor: None,
        }
    }

    /// With the tests on the model's residual
    /// ([`beamest::guard::ResidualMonitor`]) for an estimator with filter
    /// settings `filter`.
    pub fn with_monitor(mut self, filter: &FilterConfig) -> Self {
        self.monitor = Some(beamest::guard::ResidualMonitor::new(filter).expect("valid settings"));
        self
    }

    /// Give the monitor (if any) the estimator's model every
    /// [`MODEL_EVERY`] samples ([`beamest::guard::model_for_monitor`]).
    pub fn follow<T: Real, E: Estimator<T, 7> + ?Sized>(&mut self, est: &E, k: u64) {
        if let Some(m) = self.monitor.as_mut() {
            if k.is_multiple_of(MODEL_EVERY) {
                // As `beamctl simulate|replay --residual-monitor`: no model
                // while a hold runs, nor soon after ([`Feed::model_allowed`]).
                let th = if self.feed.model_allowed() {
                    beamest::guard::model_for_monitor(est, TS_S).map(|t| t.map(|v| v.to_f64()))
                } else {
                    None
                };
                m.set_theta(th.as_ref());
            }
        }
    }

    /// Screen raw sample `k` (its index must be the feed's next).
    pub fn screen(&mut self, k: u64, s: Sample<f64>) -> Screened {
        debug_assert_eq!(k, self.feed.index(), "samples in order");
        let screened = self.feed.push(s.u, s.y, self.monitor.as_mut());
        let seen = screened.screening;
        if k >= self.watch_from
            && self.first_flag.is_none()
            && (seen.fault.is_some() || seen.level.is_some())
        {
            self.first_flag = Some((k, seen));
        }
        screened
    }

    /// Give a screened sample to `est` with its holds.
    pub fn deliver<T: Real, E: Estimator<T, 7> + ?Sized>(
        &mut self,
        est: &mut E,
        screened: &Screened,
    ) -> Option<StepStatus> {
        self.feed
            .deliver::<T, _>(screened, &mut Direct::<E, 7>(est), &mut self.held)
    }

    /// The guard (counters, offset removed, last screening).
    pub fn guard(&self) -> &beamest::guard::SensorGuard<f64> {
        self.feed.guard()
    }

    /// The guard, to change its settings before the run.
    pub fn guard_mut(&mut self) -> &mut beamest::guard::SensorGuard<f64> {
        self.feed.guard_mut()
    }
}

/// Largest relative error of the first `n` ω and ζ of a model against
/// `truth` (ω1..ωn then ζ1..ζn); `weights` are the model's output weights.
pub fn modal_errors<T: Real>(
    tf: &TransferFunction<T>,
    weights: &[f64],
    truth_omega: &[f64],
    truth_zeta: &[f64],
) -> Option<(Vec<f64>, Vec<f64>)> {
    let w: Vec<T> = weights.iter().map(|&v| T::from_f64(v)).collect();
    let m = modal_from_tf(tf, &w).ok()?;
    let ew = truth_omega
        .iter()
        .enumerate()
        .map(|(i, t)| (m.omega_rad_s[i].to_f64() - t).abs() / t)
        .collect();
    let ez = truth_zeta
        .iter()
        .enumerate()
        .map(|(i, t)| (m.zeta[i].to_f64() - t).abs() / t)
        .collect();
    Some((ew, ez))
}

/// The physical beam's modes 3.. (`truth_modes` − 2 of them, 1 or 2) as
/// extra modes of the paper's plant: ω, ζ, c from the Euler–Bernoulli
/// model of the paper's beam ([`beamest::rig::beam_modes`]), b̄ scaled by
/// the paper's b̄1 over the beam model's b̄1 (so that the extra modes stand
/// to mode 1 as they do on the modelled beam).
pub fn paper_extra_modes(truth_modes: usize) -> ModalParams<f64> {
    let beam = beamest::beam::BeamParams::paper();
    let paper =
        modal_from_tf(&beamest::model::paper_plant_tf(), &WEIGHTS).expect("the paper's modes");
    let own = beam.mode_model(1).expect("mode 1");
    beamest::rig::beam_modes(&beam, 3, truth_modes - 2, paper.bbar[0] / own.bbar)
        .expect("the beam's modes")
}

/// A step of mode 1 at 10 s.
pub fn step_scenario(omega_factor: f64, zeta_factor: f64) -> Scenario {
    Scenario {
        step: Some(PlantStep {
            at: 100_000,
            omega_rad_s: [OMEGA0[0] * omega_factor, OMEGA0[1], 0.0],
            zeta: [ZETA0[0] * zeta_factor, ZETA0[1], 0.0],
            bbar: None,
        }),
        ..Scenario::default()
    }
}

/// Excitation off over [10 s, 70 s).
pub fn off_scenario(level: f64) -> Scenario {
    Scenario {
        excitation_off: Some(ExcitationOff {
            window: Window::new(100_000, Some(700_000)),
            level,
        }),
        ..Scenario::default()
    }
}

/// The fault windows: from 5 s for 0.5 s.
pub const FAULT_AT: u64 = 50_000;
/// See [`FAULT_AT`].
pub const FAULT_UNTIL: u64 = 55_000;

/// The converter's full scale in these runs, in units of Y0 (the rig's
/// bridge signal uses ~3% of the ADS131M02's range; 10× Y0 is tighter).
pub const FULL_SCALE_Y0: f64 = 10.0;

/// The six faults for a run whose y has RMS `y0`.
pub fn faults(y0: f64) -> [(&'static str, FaultKind); 6] {
    [
        ("nan", FaultKind::Nan),
        (
            "saturate",
            FaultKind::Saturate {
                full_scale: FULL_SCALE_Y0 * y0,
            },
        ),
        ("stuck", FaultKind::Stuck),
        (
            "open",
            FaultKind::Open {
                reading: FULL_SCALE_Y0 * y0,
            },
        ),
        ("offset", FaultKind::Offset { step: 0.5 * y0 }),
        (
            "drift",
            FaultKind::Drift {
                per_s: DRIFT_Y0_PER_S * y0,
            },
        ),
    ]
}

/// The drift's rate in units of Y0 per second.
pub const DRIFT_Y0_PER_S: f64 = 0.02;

/// The fault's window: [5 s, 5.5 s), a drift [5 s, 15 s).
pub fn fault_window(kind: FaultKind) -> (u64, u64) {
    match kind {
        FaultKind::Drift { .. } => (FAULT_AT, FAULT_AT + 100_000),
        _ => (FAULT_AT, FAULT_UNTIL),
    }
}

/// A run of the paper's plant with `kind` on y over its
/// [`fault_window`].
pub fn fault_scenario(kind: FaultKind) -> Scenario {
    let (from, until) = fault_window(kind);
    Scenario {
        fault: Some(SensorFault {
            kind,
            window: Window::new(from, Some(until)),
        }),
        ..Scenario::default()
    }
}

/// The guard of the fault runs: defaults, the converter's range ±
/// [`FULL_SCALE_Y0`]·`y0`, watching from the fault's start.
pub fn fault_guard(y0: f64) -> GuardedFeed {
    let fs = FULL_SCALE_Y0 * y0;
    GuardedFeed::new(
        &beamest::guard::GuardConfig {
            range: Some([-fs, fs]),
            ..beamest::guard::GuardConfig::new(TS_S)
        },
        FAULT_AT,
    )
}
