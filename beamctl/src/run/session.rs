//! Several estimators fed the same samples, evaluated at the telemetry
//! rate: the part of a run that `beamctl simulate` (samples from the
//! simulated rig) and `beamctl replay` (samples from a file) share. Knows
//! nothing of the truth; the simulation scores the evaluations it is
//! handed. Every sample passes one sensor guard ([`beamest::guard`]) on its
//! way to the estimators (they share it: they see the same samples); the
//! outcome carries its counters, the supervisor's state and the final
//! estimate's physical validity.

use crate::judge::drift::History;
use crate::judge::fit::Model;
use crate::judge::verdict::{Evidence, RecordEvidence, Verdict};
use crate::run::error::RunError;
use crate::run::estimator::{EstimatorKind, Gains};
use crate::run::feed::Feed;
use crate::run::tuned::{Build, RobustStatus, Totals, Tuned};
use beam_protocol::OutputKind;
use beamest::filter_bank::{FilterConfig, OutputHold, SignalScales};
use beamest::guard::{
    model_for_monitor, GuardConfig, GuardCounts, GuardError, LevelEvent, ResidualMonitor,
    SampleFault, Screening,
};
use beamest::modal::modal_from_tf;
use beamest::modal::Validity;
use beamest::model::{ModalParams, TransferFunction};
use beamest::tuning::TuningConfig;
use beamest::Real;
use serde::Serialize;

/// Modal parameters and polynomial of an estimate or of the truth.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ModalSummary {
    /// ω_i (rad/s).
    pub omega: Vec<f64>,
    /// ζ_i.
    pub zeta: Vec<f64>,
    /// b̄_i.
    pub bbar: Vec<f64>,
    /// [a_{2n−1}, …, a_0].
    pub a: Vec<f64>,
    /// [b_{2n−2}, …, b_0].
    pub b: Vec<f64>,
    /// What the sensor measures: the model is s^r·B(s)/A(s) (`strain`:
    /// r = 0, `velocity`: 1, `acceleration`: 2).
    #[serde(serialize_with = "output_name")]
    pub output: OutputKind,
}

/// An output kind as its name (`strain`, `velocity`, `acceleration`).
pub fn output_name<S: serde::Serializer>(k: &OutputKind, s: S) -> Result<S::Ok, S::Error> {
    s.serialize_str(k.name())
}

impl ModalSummary {
    /// From a recovery result (NaN where it failed) and the polynomial.
    pub fn new(m: Option<&ModalParams<f64>>, tf: &TransferFunction<f64>) -> Self {
        let n = tf.modes;
        let (omega, zeta, bbar) = match m {
            Some(m) => (
                m.omega_rad_s[..n].to_vec(),
                m.zeta[..n].to_vec(),
                m.bbar[..n].to_vec(),
            ),
            None => (vec![f64::NAN; n], vec![f64::NAN; n], vec![f64::NAN; n]),
        };
        Self {
            omega,
            zeta,
            bbar,
            a: tf.a[..2 * n].to_vec(),
            b: tf.b[..2 * n - 1].to_vec(),
            output: tf.output,
        }
    }

    /// No estimate at all for an `n`-mode model (all NaN) of a sensor of
    /// kind `output`.
    pub fn empty(n: usize, output: OutputKind) -> Self {
        Self {
            omega: vec![f64::NAN; n],
            zeta: vec![f64::NAN; n],
            bbar: vec![f64::NAN; n],
            a: vec![f64::NAN; 2 * n],
            b: vec![f64::NAN; 2 * n - 1],
            output,
        }
    }

    /// True if ω and ζ of every mode are finite.
    pub fn is_valid(&self) -> bool {
        self.omega.iter().chain(&self.zeta).all(|v| v.is_finite())
    }
}

/// An f64 copy of a transfer function.
pub fn to_f64_tf<T: Real>(tf: &TransferFunction<T>) -> TransferFunction<f64> {
    TransferFunction {
        modes: tf.modes,
        a: tf.a.map(|v| v.to_f64()),
        b: tf.b.map(|v| v.to_f64()),
        output: tf.output,
    }
}

/// An f64 copy of modal parameters.
pub fn to_f64_modal<T: Real>(m: &ModalParams<T>) -> ModalParams<f64> {
    ModalParams {
        modes: m.modes,
        omega_rad_s: m.omega_rad_s.map(|v| v.to_f64()),
        zeta: m.zeta.map(|v| v.to_f64()),
        bbar: m.bbar.map(|v| v.to_f64()),
        output_weight: m.output_weight.map(|v| v.to_f64()),
    }
}

/// One estimator's estimate at an evaluation instant.
#[derive(Debug, Clone)]
pub struct Eval<const NP: usize> {
    /// Θ̂ (physical units, eq. 29); NaN before the first build.
    pub theta: [f64; NP],
    /// ω̂, ζ̂, b̄ if an estimator runs and recovery succeeded.
    pub modal: Option<ModalParams<f64>>,
    /// The estimator's λ (rad/s), once built.
    pub lambda_rad_s: Option<f64>,
    /// Physical-validity flags of the estimate (0 = valid;
    /// [`Validity`] bits, `not_recovered` without an estimate).
    pub validity: u8,
}

/// The part of a report that needs no truth.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Outcome {
    /// Final estimate (NaN where there is none): the modes the record
    /// reveals (its a, b: the whole model's).
    pub estimate: ModalSummary,
    /// The model's modes above every mode the record reveals that the
    /// record does not reveal itself (no input power within an octave, no
    /// free response): they stand for the structure's modes above the
    /// excited band (their quasi-static response in it) and are reported
    /// apart, not as estimates ([`above_band`]); empty otherwise.
    pub residual_modes: Vec<ResidualMode>,
    /// λmin of the scaled P at the end (Lemma 1), None for the baselines.
    pub excitation_min_eig: Option<f64>,
    /// The feedthrough D of a model with a residual term
    /// (`--estimator feedthrough`), units of y per unit of u; absent for
    /// the other estimators.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub feedthrough: Option<f64>,
    /// The s³ coefficient of the numerator of that model (B = N − D·A,
    /// which its two modes cannot hold; units of y·s³ per unit of u);
    /// absent for the other estimators. With `feedthrough` and `estimate`'s
    /// a, b it is the whole fitted model (the model output fit uses it).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub numerator_s3: Option<f64>,
    /// Samples rejected as non-finite or out of range (start-up window
    /// included).
    pub rejected_samples: u64,
    /// Law updates skipped (singular step).
    pub skipped_updates: u64,
    /// Law updates applied (0: the law never ran, no estimate).
    pub law_updates: u64,
    /// The estimator's state integrity check at the end of the run.
    pub state_ok: bool,
    /// The final filter pole λ (rad/s); None if no estimator was built.
    pub lambda_rad_s: Option<f64>,
    /// How the tuning rule ended: `startup` (never built), `reviewing`,
    /// `fixed`, `converged`, `max_recentres`, `timeout`.
    pub tuning: &'static str,
    /// Every estimator the rule built, in order (sample index, λ, U0, Y0).
    pub builds: Vec<Build>,
    /// Model output vs measured output: 100·(1 − ‖y − ŷ‖/‖y − ȳ‖) of the
    /// final model driven by the recorded u (None without an estimate or
    /// for an unstable model).
    pub fit_percent: Option<f64>,
    /// How much the estimate moved over the last 10% of the record: over
    /// the evaluations in it, split into an earlier and a later half, the
    /// largest |median(later) − median(earlier)| / |median(later)| of ω̂_i,
    /// ζ̂_i (None if recovery failed in it or it holds fewer than two). A
    /// steady trend reads about half its span over the window; a transient
    /// excursion of fewer than half of either half's evaluations does not
    /// move a median, so a converged estimate with one outlying evaluation
    /// reads as converged.
    pub drift_last_10pct: Option<f64>,
    /// The robust estimator's phase, a-posteriori noise RMS and model
    /// updates (None for the paper's laws).
    pub robust: Option<RobustStatus>,
    /// The supervisor's state at the end (excitation flag and reason,
    /// anti-windup, detected changes); None for an unsupervised law or
    /// without an estimator.
    pub supervision: Option<SupervisionReport>,
    /// Why the final estimate is not a physical beam
    /// ([`beamest::modal::Validity`] names; empty: valid):
    /// `not_recovered`, `mode_count`, `non_finite`, `omega_not_positive`,
    /// `zeta_out_of_range`, `not_distinct`.
    pub validity: Vec<&'static str>,
    /// What the sensor guard flagged over the record (shared by every
    /// estimator of the run: they see the same samples).
    pub guard: GuardReport,
    /// Whether the estimate can be trusted, and why not
    /// ([`crate::judge::verdict`]).
    pub verdict: Verdict,
}

/// A mode of the model that the record does not reveal and that lies
/// above every mode it does (`Outcome::residual_modes`).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ResidualMode {
    /// ω (rad/s).
    pub omega: f64,
    /// ζ.
    pub zeta: f64,
    /// b̄.
    pub bbar: f64,
    /// Why it is reported apart: `above_band`.
    pub reason: &'static str,
}

/// The modes to keep as estimated when the model's highest modes are
/// ones the record does not reveal (the verdict's `identifiable` false:
/// no input power within an octave of them, no free response) and every
/// mode it does reveal lies below them: the indices of the revealed ones.
/// `None` when every mode is revealed, none is, or an unrevealed mode lies
/// below a revealed one (a mode the input misses inside the band is no
/// residual: the verdict says it is not identifiable).
pub fn above_band(verdict: &Verdict, estimate: &ModalSummary) -> Option<Vec<usize>> {
    let id = &verdict.identifiable;
    if id.len() != estimate.omega.len() || id.iter().all(|&b| b) || !id.iter().any(|&b| b) {
        return None;
    }
    let top = id
        .iter()
        .zip(&estimate.omega)
        .filter(|(b, _)| **b)
        .map(|(_, w)| *w)
        .fold(f64::NEG_INFINITY, f64::max);
    let above = id
        .iter()
        .zip(&estimate.omega)
        .filter(|(b, _)| !**b)
        .all(|(_, &w)| w > top);
    above.then(|| (0..id.len()).filter(|&i| id[i]).collect())
}

/// `estimate` with only the modes `keep` (its a, b, the model's, kept
/// whole), and the others as residual modes.
fn split_modes(estimate: &ModalSummary, keep: &[usize]) -> (ModalSummary, Vec<ResidualMode>) {
    let pick = |v: &[f64]| keep.iter().map(|&i| v[i]).collect::<Vec<_>>();
    let kept = ModalSummary {
        omega: pick(&estimate.omega),
        zeta: pick(&estimate.zeta),
        bbar: pick(&estimate.bbar),
        ..estimate.clone()
    };
    let residual = (0..estimate.omega.len())
        .filter(|i| !keep.contains(i))
        .map(|i| ResidualMode {
            omega: estimate.omega[i],
            zeta: estimate.zeta[i],
            bbar: estimate.bbar[i],
            reason: "above_band",
        })
        .collect();
    (kept, residual)
}

/// The supervisor's state ([`beamest::supervise::Supervision`]) as
/// reported.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct SupervisionReport {
    /// Excited by both tests (input present, Lemma 1).
    pub excited: bool,
    /// `excited`, `input_gone`, `not_persistent` or `starting`.
    pub excitation_reason: &'static str,
    /// Adaptation frozen by the anti-windup now (input gone).
    pub frozen: bool,
    /// Forgetting active (false while suspended for lack of excitation).
    pub forgetting: bool,
    /// λmin(P)/tr(P) of Lemma 1, if measured.
    pub lemma1_ratio: Option<f64>,
    /// Changes of the plant detected since the estimator started.
    pub changes_detected: u32,
    /// Time of the last detected change (s from the first sample of the
    /// record), if any.
    pub last_change_s: Option<f64>,
}

impl SupervisionReport {
    /// From the estimator's supervision, the sample period and the index
    /// of the record's sample the estimator took first (its sample count
    /// starts there).
    pub fn new<T: Real>(s: &beamest::supervise::Supervision<T>, ts_s: f64, first: u64) -> Self {
        Self {
            excited: s.excited(),
            excitation_reason: s.reason.as_str(),
            frozen: s.frozen,
            forgetting: s.forgetting,
            lemma1_ratio: s.lemma1_ratio.map(|r| r.to_f64()),
            changes_detected: s.changes,
            // The count includes the sample of the detection.
            last_change_s: s
                .last_change_sample
                .map(|k| (first + k.saturating_sub(1)) as f64 * ts_s),
        }
    }
}

/// The sensor guard's counters ([`beamest::guard::GuardCounts`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize)]
pub struct GuardReport {
    /// Samples kept from the estimators, all kinds.
    pub rejected: u32,
    /// … of which u or y NaN or ±∞.
    pub non_finite: u32,
    /// … y at a rail of `--range` (overload).
    pub saturated: u32,
    /// … y repeating exactly (stuck sensor).
    pub stuck: u32,
    /// … y jumped to a rail and stays (open gauge).
    pub open: u32,
    /// Offset steps of y detected (removed with `--level-correction`).
    pub offset_steps: u32,
    /// Slow drifts of y's level flagged.
    pub drift_flags: u32,
}

impl From<GuardCounts> for GuardReport {
    fn from(c: GuardCounts) -> Self {
        Self {
            rejected: c.rejected(),
            non_finite: c.non_finite,
            saturated: c.saturated,
            stuck: c.stuck,
            open: c.open,
            offset_steps: c.offset,
            drift_flags: c.drift,
        }
    }
}

/// The name of a guard fault (`non_finite`, `saturated`, `stuck`, `open`,
/// `upstream`).
pub fn fault_name(f: SampleFault) -> &'static str {
    match f {
        SampleFault::NonFinite => "non_finite",
        SampleFault::Saturated => "saturated",
        SampleFault::Stuck => "stuck",
        SampleFault::Open => "open",
        SampleFault::Upstream => "upstream",
    }
}

/// The name of a guard level event (`offset`, `drift`).
pub fn level_name(l: LevelEvent) -> &'static str {
    match l {
        LevelEvent::Offset => "offset",
        LevelEvent::Drift => "drift",
    }
}

/// The guard settings of `beamctl simulate` and `replay`: the converter's
/// rails in units of y (`--range`; without them saturation and open
/// bridges show as stuck readings), the default stuck run, and the level
/// corrections (DC-removing high-pass and offset-step removal) only with
/// `--level-correction` (as the firmware pipeline: off by default).
pub fn guard_config(ts_s: f64, range: Option<[f64; 2]>, level_correction: bool) -> GuardConfig {
    GuardConfig {
        range,
        highpass_rad_s: if level_correction {
            Some(beamest::guard::DEFAULT_HIGHPASS_RAD_S)
        } else {
            None
        },
        offset_steps: level_correction,
        ..GuardConfig::new(ts_s)
    }
}

/// The residual monitor's model is refreshed at this period (s; the
/// telemetry rate; [`Session::with_monitor`]).
pub const MONITOR_MODEL_PERIOD_S: f64 = 0.01;

/// Samples between the evaluations kept for the drift (0.1 s of record).
pub fn drift_every(ts_s: f64) -> u64 {
    (0.1 / ts_s).round().max(1.0) as u64
}

/// Estimators of one model size and precision run side by side.
pub struct Session<T: Real, const D: usize, const NP: usize, const NS: usize> {
    kinds: Vec<EstimatorKind>,
    runs: Vec<Tuned<T, D, NP, NS>>,
    history: Vec<History>,
    weights: Vec<T>,
    /// The sensor guard and the hold policy ([`super::feed`]).
    feed: Feed,
    ts_s: f64,
    /// The guard's residual monitor (`--residual-monitor`), if on.
    monitor: Option<Monitor>,
    hold: OutputHold,
    /// [`MONITOR_MODEL_PERIOD_S`] in samples.
    model_every: u64,
    /// Each estimator's detected plant changes when last looked at (for
    /// the guard's change hold, [`SensorGuard::change_hold`]).
    changes_held: Vec<u32>,
    /// What the sensor measures (the estimators' model).
    output: OutputKind,
}

/// The residual monitor of a session and the build of the first estimator
/// it was made for (λ, U0, Y0: its filter bank must be that estimator's).
struct Monitor {
    mon: Option<ResidualMonitor<f64>>,
    build: Option<(f64, f64, f64)>,
}

impl<T: Real, const D: usize, const NP: usize, const NS: usize> Session<T, D, NP, NS> {
    /// One estimator per kind under the tuning rule; modal recovery with
    /// output weights `weights` (one per mode); the samples pass the sensor
    /// guard of [`guard_config`] without a range or level corrections
    /// ([`Session::with_guard`] sets others).
    pub fn new(
        kinds: &[EstimatorKind],
        gains: Gains,
        tuning: &TuningConfig,
        weights: &[f64],
    ) -> Result<Self, RunError> {
        let feed = Feed::new(&guard_config(tuning.ts_s, None, false))
            .map_err(|e: GuardError| RunError::Setup(e.to_string()))?;
        let runs = kinds
            .iter()
            .map(|&k| Tuned::new(k, gains, tuning))
            .collect::<Result<Vec<_>, _>>()?;
        Ok(Self {
            kinds: kinds.to_vec(),
            history: vec![History::default(); runs.len()],
            runs,
            weights: weights.iter().map(|&w| T::from_f64(w)).collect(),
            feed,
            ts_s: tuning.ts_s,
            monitor: None,
            hold: tuning.hold,
            model_every: (MONITOR_MODEL_PERIOD_S / tuning.ts_s).round().max(1.0) as u64,
            changes_held: vec![0; kinds.len()],
            output: tuning.output,
        })
    }

    /// The same session with the guard's residual monitor on
    /// ([`beamest::guard::ResidualMonitor`]): offset steps and drift onsets
    /// seen on the first estimator's equation error, its Θ̂ taken every 10
    /// ms once it is excited and settled
    /// ([`beamest::guard::model_for_monitor`]). Off: unchanged.
    ///
    /// # Errors
    /// On with a model of other than two modes (the monitor's bank is the
    /// 2-mode one).
    pub fn with_monitor(mut self, on: bool) -> Result<Self, RunError> {
        if on && NP != 7 {
            return Err(RunError::Setup(
                "the residual monitor needs the 2-mode model".into(),
            ));
        }
        self.monitor = on.then_some(Monitor {
            mon: None,
            build: None,
        });
        Ok(self)
    }

    /// Refresh the monitor's bank (after a rebuild of the first estimator)
    /// and its model.
    fn follow(&mut self) {
        let Some(m) = self.monitor.as_mut() else {
            return;
        };
        let Some(run) = self.runs.first() else {
            return;
        };
        let build = run
            .builds()
            .last()
            .map(|b| (b.lambda_rad_s, b.u_scale, b.y_scale));
        if build != m.build {
            m.build = build;
            m.mon = build.and_then(|(lambda_rad_s, u_scale, y_scale)| {
                ResidualMonitor::new(&FilterConfig {
                    ts_s: self.ts_s,
                    lambda_rad_s,
                    scales: SignalScales { u_scale, y_scale },
                    hold: self.hold,
                    ..FilterConfig::default()
                })
                .ok()
            });
        }
        let theta = run
            .estimate()
            .filter(|_| self.feed.model_allowed())
            .and_then(|e| model_for_monitor(e, self.ts_s))
            .and_then(|t| <[f64; 7]>::try_from(t.map(|v| v.to_f64()).as_slice()).ok());
        if let Some(mon) = m.mon.as_mut() {
            mon.set_theta(theta.as_ref());
        }
    }

    /// The same session with another sensor guard (see [`guard_config`]).
    ///
    /// # Errors
    /// Invalid guard settings.
    pub fn with_guard(mut self, cfg: &GuardConfig) -> Result<Self, RunError> {
        self.feed = Feed::new(cfg).map_err(|e| RunError::Setup(e.to_string()))?;
        Ok(self)
    }

    /// The same session with `lines` cancelled after the guard
    /// ([`Feed::with_lines`]; set after [`Session::with_guard`]).
    ///
    /// # Errors
    /// A line the canceller cannot hold.
    pub fn with_lines(
        mut self,
        lines: &[beamest::guard::lines::LineSpec],
    ) -> Result<Self, RunError> {
        self.feed = self
            .feed
            .with_lines(lines)
            .map_err(|e| RunError::Setup(e.to_string()))?;
        Ok(self)
    }

    /// The same session with the whitening filter `coeffs` ([1, c_1, …])
    /// on u and y after the line canceller ([`Feed::with_whitener`]; set
    /// after [`Session::with_guard`]); `None`: none.
    pub fn with_whitener(mut self, coeffs: Option<&[f64]>) -> Self {
        self.feed = self.feed.with_whitener(coeffs);
        self
    }

    /// Feed one raw sample: it passes the sensor guard
    /// ([`beamest::guard`]), and the pair leaving the guard's delay line
    /// (faulty ones as NaN, which the estimators reject) goes to every
    /// estimator, with the holds the guard asks for ([`super::feed`]).
    /// Returns what the guard saw in this sample at once.
    #[inline]
    pub fn step(&mut self, u: f64, y: f64) -> Screening {
        if self.monitor.is_some() && self.feed.index().is_multiple_of(self.model_every) {
            self.follow();
        }
        let monitor = self.monitor.as_mut().and_then(|m| m.mon.as_mut());
        let screened = self.feed.push(u, y, monitor);
        for (r, held) in self.runs.iter_mut().zip(&mut self.changes_held) {
            self.feed.deliver(&screened, r, held);
        }
        screened.screening
    }

    /// The guard's counters so far.
    pub fn guard_counts(&self) -> GuardCounts {
        self.feed.guard().counts()
    }

    /// The supervisor's state of estimator `i` now, if it is supervised.
    pub fn supervision(&self, i: usize) -> Option<SupervisionReport> {
        let run = &self.runs[i];
        let est = run.estimator()?;
        // A robust estimator's count starts at its replayed record's first
        // sample, the paper's laws' at their build.
        let first = run
            .builds()
            .last()
            .map_or(0, |b| b.sample.saturating_sub(b.replayed_samples));
        est.supervision()
            .map(|s| SupervisionReport::new(&s, self.ts_s, first))
    }

    /// Number of estimators.
    pub fn len(&self) -> usize {
        self.runs.len()
    }

    /// True without estimators.
    pub fn is_empty(&self) -> bool {
        self.runs.is_empty()
    }

    /// The law of estimator `i`.
    pub fn kind(&self, i: usize) -> EstimatorKind {
        self.kinds[i]
    }

    /// Evaluate estimator `i` at time `t_s` (recovery in the estimator's
    /// own precision, as the firmware does); `record` keeps it for the
    /// drift (callers record on the [`drift_every`] grid and the last
    /// sample, so the drift does not depend on the evaluation rate).
    pub fn evaluate(&mut self, i: usize, t_s: f64, record: bool) -> Eval<NP> {
        let run = &self.runs[i];
        let (theta, modal, validity) = match run.estimate() {
            Some(est) => {
                let th = est.theta().map(|v| v.to_f64());
                let r = modal_from_tf(&est.transfer_function(), &self.weights);
                let v = Validity::of_result(&r, self.weights.len());
                (th, r.ok().map(|m| to_f64_modal(&m)), v)
            }
            None => ([f64::NAN; NP], None, Validity::NOT_RECOVERED),
        };
        if record {
            self.history[i].push(t_s, modal.as_ref());
        }
        Eval {
            theta,
            modal,
            lambda_rad_s: run.lambda_rad_s(),
            validity: validity.0,
        }
    }

    /// The final transfer function of estimator `i` (f64), if any.
    pub fn transfer_function(&self, i: usize) -> Option<TransferFunction<f64>> {
        self.runs[i]
            .estimate()
            .map(|e| to_f64_tf(&e.transfer_function()))
    }

    /// The identified model of estimator `i` for [`crate::judge::fit::fit`],
    /// if any: its transfer function, with the residual terms of a model
    /// that has them.
    pub fn model(&self, i: usize, ts_s: f64) -> Option<Model> {
        let tf = self.transfer_function(i)?;
        match self.runs[i].estimate().and_then(|e| e.residual()) {
            Some(r) => Model::with_residual(&tf, ts_s, r.b3.to_f64(), r.feedthrough.to_f64()),
            None => Model::new(&tf, ts_s),
        }
    }

    /// Counters of estimator `i` over the record.
    pub fn totals(&self, i: usize) -> Totals {
        self.runs[i].totals()
    }

    /// The truth-free part of estimator `i`'s report. `end_s` is the time
    /// of the last sample, `record` what the record tells about the
    /// estimate (the model-output fit, [`crate::judge::fit::fit`], and the
    /// spectra of the verdict).
    pub fn outcome(&self, i: usize, end_s: f64, record: &RecordEvidence<'_>) -> Outcome {
        let fit = record.fit;
        let run = &self.runs[i];
        let n = self.weights.len();
        let (estimate, exc, ok, validity, residual) = match run.estimate() {
            Some(est) => {
                let tf = est.transfer_function();
                let recovered = modal_from_tf(&tf, &self.weights);
                let validity = Validity::of_result(&recovered, n);
                let modal = recovered.ok().map(|m| to_f64_modal(&m));
                (
                    ModalSummary::new(modal.as_ref(), &to_f64_tf(&tf)),
                    est.excitation_level().map(|v| v.to_f64()),
                    est.health().state_ok,
                    validity,
                    est.residual()
                        .map(|r| (r.feedthrough.to_f64(), r.b3.to_f64())),
                )
            }
            None => (
                ModalSummary::empty(n, self.output),
                None,
                true,
                Validity::NOT_RECOVERED,
                None,
            ),
        };
        let totals = run.totals();
        let validity: Vec<&'static str> = validity.names().collect();
        let judge = |estimate: &ModalSummary, drift: Option<f64>| {
            Verdict::of(&Evidence {
                omega: estimate.is_valid().then_some(&estimate.omega[..]),
                zeta: &estimate.zeta,
                validity: &validity,
                fit,
                drift,
                input: record.input,
                residual: record.residual,
            })
        };
        let mut drift = self.history[i].drift(0.0, end_s);
        let mut verdict = judge(&estimate, drift);
        let mut estimate = estimate;
        let mut residual_modes = Vec::new();
        if let Some(keep) = above_band(&verdict, &estimate) {
            (estimate, residual_modes) = split_modes(&estimate, &keep);
            drift = self.history[i].drift_of_modes(0.0, end_s, &keep);
            verdict = judge(&estimate, drift);
        }
        Outcome {
            estimate,
            residual_modes,
            excitation_min_eig: exc,
            feedthrough: residual.map(|r| r.0),
            numerator_s3: residual.map(|r| r.1),
            rejected_samples: totals.rejected,
            skipped_updates: totals.skipped,
            law_updates: totals.updates,
            state_ok: ok,
            lambda_rad_s: run.lambda_rad_s(),
            tuning: run.phase_label(),
            builds: run.builds().to_vec(),
            fit_percent: fit.map(|f| f.percent),
            drift_last_10pct: drift,
            robust: run.robust_status(),
            supervision: self.supervision(i),
            validity,
            guard: self.feed.guard().counts().into(),
            verdict,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Modes the record does not reveal are reported apart only when they
    /// lie above every revealed one.
    #[test]
    fn only_unrevealed_modes_above_the_band_are_residual() {
        let est = ModalSummary {
            omega: vec![50.0, 280.0, 1500.0],
            zeta: vec![0.02, 0.015, 0.01],
            bbar: vec![12.0, 30.0, 1500.0],
            a: vec![0.0; 6],
            b: vec![0.0; 5],
            output: OutputKind::Strain,
        };
        let verdict = |id: [bool; 3]| Verdict {
            trusted: false,
            reasons: Vec::new(),
            identifiable: id.to_vec(),
            input_power_near_mode: Vec::new(),
            free_response_share: Vec::new(),
            residual_prediction_gain: None,
            residual_structure: None,
            lines: Vec::new(),
        };
        let keep = above_band(&verdict([true, true, false]), &est).unwrap();
        assert_eq!(keep, vec![0, 1]);
        let (kept, residual) = split_modes(&est, &keep);
        assert_eq!(kept.omega, vec![50.0, 280.0]);
        assert_eq!(kept.a.len(), 6, "the model's coefficients stay whole");
        assert_eq!(residual.len(), 1);
        assert_eq!(
            (residual[0].omega, residual[0].reason),
            (1500.0, "above_band")
        );
        // A mode the input misses below a revealed one, all or none revealed.
        assert_eq!(above_band(&verdict([false, true, true]), &est), None);
        assert_eq!(above_band(&verdict([true, false, true]), &est), None);
        assert_eq!(above_band(&verdict([true; 3]), &est), None);
        assert_eq!(above_band(&verdict([false; 3]), &est), None);
    }
}
