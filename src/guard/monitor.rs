//! Sensor-fault tests on the model's equation error ε
//! ([`super::residual`]): an offset step and the onset of a drift are seen
//! on ε, where the beam's own vibration is gone, instead of on the raw y.
//!
//! * **Offset step** — a matched test like the raw one (module `step`), on
//!   [`EPS_STEP_BEFORE`] + [`EPS_STEP_AFTER`] samples of ε, against a line
//!   (1, t), with the shape a step δ of y leaves in ε: δ·g(t), g the step
//!   response of Â(s)/Λ(s) (1 at once, ≈ 0.41 after 4 ms, →
//!   Â(0)/Λ(0) ≈ 0.91 on the paper's plant). The shape is computed from Θ̂
//!   whenever the model is set ([`ResidualMonitor::set_theta`]). Threshold
//!   [`EPS_STEP_FACTOR`] × d̂'s running RMS, never below
//!   [`EPS_STEP_FLOOR`] (a fraction of Y0).
//! * **Drift onset** — the same kind of test for a ramp starting in the
//!   window ([`RAMP_BEFORE`] + [`RAMP_AFTER`] samples; the shape is ε's
//!   response to a ramp of y, the running sum of g), threshold
//!   [`RAMP_FACTOR`] × its running RMS, never below [`RAMP_FLOOR_Y0_PER_S`]
//!   — and it must *fit*: the window's residual after the line and the
//!   ramp's shape must be below [`RAMP_FIT_MAX`] of the ramp's part.
//!   A plant change (the beam's ω or ζ moves) also bends ε at once, but as
//!   Δθᵀφ, the filtered signals, not as a ramp: measured noise-free on the
//!   paper's plant, a 10% step of ω1 or a 50% step of ζ1 crossed the
//!   ramp's threshold within 1 ms (330–2,200× over it) with a fit ratio of
//!   0.37–0.51, a drift of 0.002–0.02·Y0/s with 1e-4 (`f64`) to 4.5e-2
//!   (`f32`). That is how the two are told apart before the estimator's
//!   own change test fires (12–19 ms later); after it fires, the caller
//!   drops the model ([`model_for_monitor`]) until the estimate has
//!   settled on the new beam.
//!
//! Measurements: `cargo run --release -p host-tests --example
//! residual_detect`, docs/ROBUSTNESS.md §1 "On the model's residual".

use super::residual::{ResidualFilter, RESIDUAL_LAG};
use super::STEP_PEAK_WAIT;
use crate::estimator::Estimator;
use crate::filter_bank::{FilterBank, FilterConfig, FilterConfigError, Scaling};
use crate::scalar::Real;

/// ε samples before the tested step position.
pub const EPS_STEP_BEFORE: usize = 36;
/// ε samples from the tested step position on (the look-ahead).
pub const EPS_STEP_AFTER: usize = 12;
const NS: usize = EPS_STEP_BEFORE + EPS_STEP_AFTER;
/// Samples from an offset step to its detection on ε, at most: the peak
/// is followed over the look-ahead as in the raw test, and ε lags y by
/// [`RESIDUAL_LAG`]. The guard's delay line is lengthened to hold them.
pub(crate) const MONITOR_STEP_LATENCY: usize = 2 * (EPS_STEP_AFTER - 1) + RESIDUAL_LAG;
/// Offset-step threshold on ε, in d̂'s running RMS: measured on the
/// paper's plant, 5 seeds × 60 s of clean data at 40 and 20 dB never came
/// above 0.89 of it (d̂ is Gaussian there: 6σ is exceeded with probability
/// 2e-9 per sample).
pub const EPS_STEP_FACTOR: f64 = 6.0;
/// The offset-step threshold is never below this (units of Y0): noise-free
/// ε sits at 2e-10 (`f64`) / 1.3e-7 (`f32`) of Y0 and a plant change bends
/// it (by < 0.7 of this floor in 12 ms, measured for 10% of ω1 and 50% of
/// ζ1).
pub const EPS_STEP_FLOOR: f64 = 1e-3;
/// ε samples before the tested ramp onset.
pub const RAMP_BEFORE: usize = 50;
/// ε samples from the tested onset on (5 ms at 10 kHz: the flag comes
/// ≈ 5 ms after the onset).
pub const RAMP_AFTER: usize = 50;
const NR: usize = RAMP_BEFORE + RAMP_AFTER;
/// Ramp threshold in its estimate's running RMS.
pub const RAMP_FACTOR: f64 = 8.0;
/// The ramp threshold is never below this rate (Y0 per second).
pub const RAMP_FLOOR_Y0_PER_S: f64 = 1e-3;
/// A ramp is flagged only if the window's residual after the fit is below
/// this fraction of the ramp's part (see the module docs).
pub const RAMP_FIT_MAX: f64 = 0.15;
/// Time constant of both tests' running mean squares, and their learning
/// time after the model is set (s).
pub(crate) const MONITOR_REFERENCE_S: f64 = 0.1;
/// After a gap the bank's states mix both sides of it: no test for this
/// many filter time constants 1/λ (as the estimator's quarantine).
pub(crate) const MONITOR_SETTLE_TIME_CONSTANTS: f64 = 40.0;
/// After an offset step is corrected, ε carries what the bank saw of the
/// uncorrected samples (a pulse of the step's size, ≤ 2.6 ms long): a kink
/// that decays with the bank, as e^{−λt}; no test for this many 1/λ.
/// Measured: without it a 0.05·Y0 step was found again 6 ms after its
/// correction.
pub(crate) const MONITOR_CORRECTION_TIME_CONSTANTS: f64 = 10.0;
/// [`model_for_monitor`]: no model within this long of a detected plant
/// change (s); a caller that holds the estimator after a change (the
/// guard's change hold) gives the monitor no model until this long after
/// the hold ends either (the law tracks the new plant only from then on).
pub const CHANGE_QUIET_S: f64 = 1.0;
/// See [`CHANGE_QUIET_S`] (s).
pub const MODEL_AFTER_S: f64 = 3.0;

/// What the monitor found.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum MonitorEvent<T> {
    /// An offset step of y from sample `index` on, of `size` (units of y).
    Step {
        /// First sample of the step.
        index: u64,
        /// Its size (units of y).
        size: T,
    },
    /// A drift started at about sample `index`.
    Drift {
        /// The onset's sample.
        index: u64,
    },
}

/// The model the estimator `est` offers the monitor now: its Θ̂ when it is
/// excited, has run `MODEL_AFTER_S` and has not detected a plant change
/// within `CHANGE_QUIET_S`; `None` otherwise (the monitor then rests).
/// `ts_s` is the sample period.
pub fn model_for_monitor<T: Real, const NP: usize, E: Estimator<T, NP> + ?Sized>(
    est: &E,
    ts_s: f64,
) -> Option<[T; NP]> {
    let sup = est.supervision()?;
    let n = est.health().samples;
    let quiet = (CHANGE_QUIET_S / ts_s) as u64;
    let recent = sup
        .last_change_sample
        .is_some_and(|c| n.saturating_sub(c) < quiet);
    (sup.excited() && !recent && n as f64 * ts_s >= MODEL_AFTER_S).then(|| est.theta())
}

/// A matched test on a window of N values, NA of them from the tested
/// position on.
#[derive(Debug, Clone, Copy)]
struct Matched<T, const N: usize, const NA: usize> {
    w: [T; N],
    ring: [T; N],
    head: usize,
    len: usize,
    ms: T,
    learn: u32,
    learn_len: u32,
    alpha: T,
    factor2: T,
    floor2: T,
    pending: Option<(u64, T, T, u64)>,
}

impl<T: Real, const N: usize, const NA: usize> Matched<T, N, NA> {
    fn new(alpha: T, learn_len: u32, factor: f64, floor: f64) -> Self {
        Self {
            w: [T::ZERO; N],
            ring: [T::ZERO; N],
            head: 0,
            len: 0,
            ms: T::ZERO,
            learn: learn_len,
            learn_len,
            alpha,
            factor2: T::from_f64(factor * factor),
            floor2: T::from_f64(floor * floor),
            pending: None,
        }
    }

    fn interrupt(&mut self) {
        self.len = 0;
        self.pending = None;
    }

    fn relearn(&mut self) {
        self.interrupt();
        self.ms = T::ZERO;
        self.learn = self.learn_len;
    }

    /// The window oldest first as two slices.
    fn window(&self) -> (&[T], &[T]) {
        let (a, b) = self.ring.split_at(self.head.min(N));
        (b, a)
    }

    /// Σ v_i·x_i over the window (oldest first).
    fn dot(&self, v: &[T; N]) -> T {
        let (old, new) = self.window();
        let (v1, v2) = v.split_at(old.len());
        let d1 = v1.iter().zip(old).fold(T::ZERO, |a, (w, y)| a + *w * *y);
        v2.iter().zip(new).fold(d1, |a, (w, y)| a + *w * *y)
    }

    /// Take one value; `Some(d̂)` when the window is full and tested.
    fn fill(&mut self, x: T) -> bool {
        if let Some(s) = self.ring.get_mut(self.head) {
            *s = x;
        }
        self.head = (self.head + 1) % N;
        if self.len < N {
            self.len += 1;
        }
        self.len == N
    }

    /// The threshold's square now.
    fn limit(&self) -> T {
        (self.factor2 * self.ms).max(self.floor2)
    }

    /// Learn or update the reference with d̂ (clipped at the threshold);
    /// true while learning.
    fn reference(&mut self, e2: T) -> bool {
        if self.learn > 0 {
            self.learn -= 1;
            self.ms += self.alpha * (e2 - self.ms);
            return true;
        }
        let limit = self.limit();
        self.ms += self.alpha * (e2.min(limit) - self.ms);
        false
    }
}

/// The tests on ε (see the module docs) for a 2-mode model.
#[derive(Debug, Clone)]
pub struct ResidualMonitor<T> {
    filter: ResidualFilter<T, 4, 7>,
    /// The bank's regressor after a unit (scaled) step of y from rest,
    /// at each of the first [`RAMP_AFTER`] samples from the step.
    step_phi: [[f64; 7]; RAMP_AFTER],
    to_scaled: [f64; 7],
    y_scale: T,
    step: Matched<T, NS, EPS_STEP_AFTER>,
    ramp: Matched<T, NR, RAMP_AFTER>,
    /// The ramp's shape made orthogonal to 1 and t, unit norm (for the fit).
    ramp_unit: [T; NR],
    armed: bool,
    settle: u32,
    settle_len: u32,
    correction_len: u32,
    /// Samples until the ramp test may flag again.
    ramp_quiet: u32,
}

impl<T: Real> ResidualMonitor<T> {
    /// For an estimator with filter settings `cfg` (its λ, U0, Y0, Ts,
    /// hold and timing; the Θ̂ given later must be for this λ).
    ///
    /// # Errors
    /// The bank's [`FilterConfigError`].
    pub fn new(cfg: &FilterConfig) -> Result<Self, FilterConfigError> {
        let filter = ResidualFilter::new(cfg)?;
        let mut bank = FilterBank::<f64, 4, 7>::new(cfg)?;
        let mut step_phi = [[0.0; 7]; RAMP_AFTER];
        for k in 0..RAMP_AFTER + RESIDUAL_LAG {
            let r = bank.push(0.0, cfg.scales.y_scale);
            if let Some(p) = k
                .checked_sub(RESIDUAL_LAG)
                .and_then(|j| step_phi.get_mut(j))
            {
                for (d, (a, b)) in p.iter_mut().zip(r.phi.iter().zip(&r.phi_lo)) {
                    *d = a + b;
                }
            }
        }
        let s = Scaling::<7>::new(cfg);
        let to_scaled = s.e.map(|e| 1.0 / (s.y_scale * e));
        let ts = cfg.ts_s;
        let alpha = T::from_f64(-libm::expm1(-ts / MONITOR_REFERENCE_S));
        let learn = libm::ceil(MONITOR_REFERENCE_S / ts) as u32;
        Ok(Self {
            filter,
            step_phi,
            to_scaled,
            y_scale: T::from_f64(cfg.scales.y_scale),
            step: Matched::new(alpha, learn, EPS_STEP_FACTOR, EPS_STEP_FLOOR),
            ramp: Matched::new(alpha, learn, RAMP_FACTOR, RAMP_FLOOR_Y0_PER_S * ts),
            ramp_unit: [T::ZERO; NR],
            armed: false,
            settle: 0,
            settle_len: libm::ceil(MONITOR_SETTLE_TIME_CONSTANTS / (cfg.lambda_rad_s * ts))
                .min(u32::MAX as f64) as u32,
            correction_len: libm::ceil(MONITOR_CORRECTION_TIME_CONSTANTS / (cfg.lambda_rad_s * ts))
                .min(u32::MAX as f64) as u32,
            ramp_quiet: 0,
        })
    }

    /// Evaluate ε with the physical Θ̂ `theta` (eq. 29; `None` or a
    /// non-finite entry: rest, no test). Recomputes both tests' shapes
    /// (≈ 2,000 flops in `f64`: call it at the telemetry rate, not per
    /// sample). The tests learn their level afresh when the monitor is
    /// armed after resting.
    pub fn set_theta(&mut self, theta: Option<&[T; 7]>) {
        let ok = theta.is_some_and(|t| self.filter.set_theta(t));
        if !ok {
            self.filter.clear_theta();
            self.armed = false;
            self.step.interrupt();
            self.ramp.interrupt();
            return;
        }
        let Some(t) = theta else { return };
        let mut th = [0.0f64; 7];
        for ((s, v), k) in th.iter_mut().zip(t).zip(&self.to_scaled) {
            *s = v.to_f64() * k;
        }
        // g_j: ε after a unit step of y/Y0, j samples on.
        let g: [f64; RAMP_AFTER] = core::array::from_fn(|j| {
            let p = self.step_phi.get(j).copied().unwrap_or([0.0; 7]);
            1.0 - th.iter().zip(&p).map(|(a, b)| a * b).sum::<f64>()
        });
        let step_h: [f64; NS] = core::array::from_fn(|i| {
            i.checked_sub(EPS_STEP_BEFORE)
                .and_then(|j| g.get(j))
                .copied()
                .unwrap_or(0.0)
        });
        let mut acc = 0.0;
        let sums: [f64; RAMP_AFTER] = core::array::from_fn(|j| {
            acc += g.get(j).copied().unwrap_or(0.0);
            acc
        });
        let ramp_h: [f64; NR] = core::array::from_fn(|i| {
            i.checked_sub(RAMP_BEFORE)
                .and_then(|j| sums.get(j))
                .copied()
                .unwrap_or(0.0)
        });
        let (w, _) = matched(&step_h);
        self.step.w = w.map(T::from_f64);
        let (w, unit) = matched(&ramp_h);
        self.ramp.w = w.map(T::from_f64);
        self.ramp_unit = unit.map(T::from_f64);
        if !self.armed {
            self.armed = true;
            self.step.relearn();
            self.ramp.relearn();
        }
    }

    /// Whether a model is set.
    #[cfg(test)]
    pub(crate) fn armed(&self) -> bool {
        self.armed
    }

    /// A faulty sample: not pushed; the tests rest until the bank has
    /// settled ([`MONITOR_SETTLE_TIME_CONSTANTS`]).
    pub(crate) fn interrupt(&mut self) {
        self.settle = self.settle_len;
        self.step.interrupt();
        self.ramp.interrupt();
    }

    /// The guard corrected an offset step: the windows restart (they hold
    /// ε of the uncorrected samples) after
    /// [`MONITOR_CORRECTION_TIME_CONSTANTS`].
    pub(crate) fn corrected(&mut self) {
        self.settle = self.settle.max(self.correction_len);
        self.step.interrupt();
        self.ramp.interrupt();
    }

    /// Push one good raw pair (y with the removed offsets subtracted) of
    /// sample `index`; `test` false skips the tests (a repeated reading).
    #[inline]
    pub(crate) fn push(&mut self, u: T, y: T, index: u64, test: bool) -> Option<MonitorEvent<T>> {
        let e = self.filter.push(u, y);
        if !self.armed || !e.is_finite() {
            return None;
        }
        if self.settle > 0 {
            self.settle -= 1;
            return None;
        }
        let newest = index.wrapping_sub(RESIDUAL_LAG as u64);
        let step_full = self.step.fill(e);
        let ramp_full = self.ramp.fill(e);
        self.ramp_quiet = self.ramp_quiet.saturating_sub(1);
        if !test {
            return None;
        }
        if step_full {
            if let Some(s) = self.test_step(newest) {
                return Some(s);
            }
        }
        if ramp_full {
            return self.test_ramp(newest);
        }
        None
    }

    fn test_step(&mut self, newest: u64) -> Option<MonitorEvent<T>> {
        let t = &mut self.step;
        let d = t.dot(&t.w);
        let e2 = d * d;
        let at = newest.wrapping_sub(EPS_STEP_AFTER as u64 - 1);
        if let Some((first, peak2, peak, pat)) = t.pending.as_mut() {
            if e2 > *peak2 {
                (*peak2, *peak, *pat) = (e2, d, at);
            }
            let seen_all = at.wrapping_sub(*first) >= EPS_STEP_AFTER as u64 - 1;
            if !(seen_all && at.wrapping_sub(*pat) >= STEP_PEAK_WAIT) {
                return None;
            }
            let ev = MonitorEvent::Step {
                index: *pat,
                size: *peak * self.y_scale,
            };
            t.pending = None;
            return Some(ev);
        }
        if t.learn == 0 && e2 > t.limit() {
            t.pending = Some((at, e2, d, at));
            return None;
        }
        t.reference(e2);
        None
    }

    fn test_ramp(&mut self, newest: u64) -> Option<MonitorEvent<T>> {
        let t = &mut self.ramp;
        let d = t.dot(&t.w);
        let e2 = d * d;
        if t.learn > 0 || e2 <= t.limit() {
            t.reference(e2);
            return None;
        }
        if self.ramp_quiet > 0 {
            return None;
        }
        // The fit: the window minus its line and the ramp's part.
        let c = t.dot(&self.ramp_unit);
        let (old, new) = t.window();
        let n = T::from_f64(NR as f64);
        let mid = T::from_f64((NR as f64 - 1.0) / 2.0);
        let (mut s0, mut s1, mut s2) = (T::ZERO, T::ZERO, T::ZERO);
        for (i, x) in old.iter().chain(new).enumerate() {
            let tt = T::from_f64(i as f64) - mid;
            s0 += *x;
            s1 += tt * *x;
            s2 += tt * tt;
        }
        let (b0, b1) = (s0 / n, s1 / s2);
        let mut r2 = T::ZERO;
        for (i, (x, h)) in old.iter().chain(new).zip(&self.ramp_unit).enumerate() {
            let tt = T::from_f64(i as f64) - mid;
            let r = *x - b0 - b1 * tt - c * *h;
            r2 += r * r;
        }
        let fit = T::from_f64(RAMP_FIT_MAX);
        if r2 < fit * fit * c * c {
            self.ramp_quiet = NR as u32;
            return Some(MonitorEvent::Drift {
                index: newest.wrapping_sub(RAMP_AFTER as u64 - 1),
            });
        }
        None
    }
}

/// Matched weights for the shape `h` against a line (1, t): w = h⊥/(h·h⊥)
/// (so that w·h = 1 and w ⟂ 1, t), and h⊥/‖h⊥‖.
fn matched<const N: usize>(h: &[f64; N]) -> ([f64; N], [f64; N]) {
    let n = N as f64;
    let mid = (n - 1.0) / 2.0;
    let s2: f64 = (0..N).map(|i| (i as f64 - mid) * (i as f64 - mid)).sum();
    let mean = h.iter().sum::<f64>() / n;
    let slope = h
        .iter()
        .enumerate()
        .map(|(i, v)| (i as f64 - mid) * v)
        .sum::<f64>()
        / s2;
    let p: [f64; N] = core::array::from_fn(|i| {
        h.get(i).copied().unwrap_or(0.0) - mean - slope * (i as f64 - mid)
    });
    let hp: f64 = p.iter().zip(h).map(|(a, b)| a * b).sum();
    let norm = libm::sqrt(p.iter().map(|a| a * a).sum::<f64>());
    if !(hp > 0.0 && norm > 0.0) {
        return ([0.0; N], [0.0; N]);
    }
    (p.map(|a| a / hp), p.map(|a| a / norm))
}

#[cfg(test)]
#[allow(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::indexing_slicing,
    clippy::panic
)]
mod tests {
    use super::*;
    use crate::excitation::SquareWave;
    use crate::filter_bank::SignalScales;
    use crate::guard::{GuardConfig, LevelEvent, SensorGuard};
    use crate::model::{lambda_poly, paper_plant_tf, PAPER_B, PAPER_OMEGA, PAPER_ZETA};
    use crate::rig::ModalPlant;
    use crate::rig::Rig;

    const TS: f64 = 1e-4;

    fn setup() -> (FilterConfig, [f64; 7], Rig<f64>) {
        let cfg = FilterConfig {
            ts_s: TS,
            lambda_rad_s: 100.0,
            scales: SignalScales {
                u_scale: 0.1,
                y_scale: 1e-3,
            },
            ..FilterConfig::default()
        };
        let tf = paper_plant_tf();
        let k = lambda_poly(4, 100.0);
        let theta = core::array::from_fn(|j| {
            if j < 3 {
                tf.b[j]
            } else {
                k[j - 3] - tf.a[j - 3]
            }
        });
        let plant = ModalPlant::with_numerator(&PAPER_OMEGA, &PAPER_ZETA, &PAPER_B, TS).unwrap();
        (cfg, theta, Rig::new(plant, SquareWave::paper()))
    }

    #[test]
    fn the_true_model_leaves_no_residual_and_a_step_is_found_with_its_size() {
        // ε's floor in units of Y0 (the interpolation's in f64, rounding
        // in f32), the step's size to this fraction of itself.
        step_found::<f64>(1e-7, 1e-3);
        step_found::<f32>(2e-6, 2e-3);
    }

    /// A step of 0.02·Y0 at 2.5 s, in `T`.
    fn step_found<T: Real>(floor: f64, tol: f64) {
        let ty = T::NAME;
        let (cfg, theta, mut rig) = setup();
        let theta = theta.map(T::from_f64);
        let mut f = ResidualFilter::<T, 4, 7>::new(&cfg).unwrap();
        assert!(f.set_theta(&theta));
        let mut m = ResidualMonitor::<T>::new(&cfg).unwrap();
        m.set_theta(Some(&theta));
        assert!(m.armed());
        let size = 2e-5; // 0.02 of the 1e-3 scale
        let mut found = None;
        for k in 0..30_000u64 {
            let s = rig.tick();
            let e = f.push(T::from_f64(s.u), T::from_f64(s.y)).to_f64();
            if (10_000..25_000).contains(&k) {
                assert!(e.abs() < floor, "{ty} {k}: ε = {e:e}");
            }
            // As the guard does: a found step is subtracted from then on.
            let removed = if found.is_some() { size } else { 0.0 };
            let y = s.y + if k >= 25_000 { size } else { 0.0 } - removed;
            if let Some(ev) = m.push(T::from_f64(s.u), T::from_f64(y), k, true) {
                assert!(found.is_none(), "{ty}: {ev:?} after {found:?}");
                found = Some((k, ev));
                m.corrected();
            }
        }
        let (k, ev) = found.expect("found");
        let MonitorEvent::Step { index, size: d } = ev else {
            panic!("{ty}: {ev:?}");
        };
        assert_eq!(index, 25_000, "{ty}");
        assert!(k - index <= MONITOR_STEP_LATENCY as u64, "{ty}: {k}");
        let d = d.to_f64();
        assert!((d - size).abs() < tol * size, "{ty}: {d:e}");
        // Dropping the model stops the tests.
        m.set_theta(None);
        assert!(!m.armed());
    }

    #[test]
    fn the_guard_flags_a_drift_within_ten_ms_of_its_onset() {
        drift_flagged::<f64>();
        drift_flagged::<f32>();
    }

    /// The guard and its monitor in `T`: a drift of 0.02·Y0/s from 3 s.
    fn drift_flagged<T: Real>() {
        let (cfg, theta, mut rig) = setup();
        let theta = theta.map(T::from_f64);
        let mut g = SensorGuard::<T>::new(&GuardConfig::new(TS)).unwrap();
        let mut m = ResidualMonitor::<T>::new(&cfg).unwrap();
        let rate = 0.02 * 1e-3; // 0.02·Y0/s
        let mut flags = Vec::new();
        for k in 0..40_000u64 {
            if k == 10_000 {
                m.set_theta(Some(&theta));
            }
            let s = rig.tick();
            let t = (k as f64 - 30_000.0).max(0.0) * TS;
            let (u, y) = (T::from_f64(s.u), T::from_f64(s.y + rate * t));
            g.push_monitored(u, y, true, k, Some(&mut m));
            if let Some(l) = g.last_screening().level {
                flags.push((k, l));
            }
        }
        let ty = T::NAME;
        assert_eq!(flags.len(), 1, "{ty}: {flags:?}");
        let (k, l) = flags[0];
        assert_eq!(l, LevelEvent::Drift, "{ty}");
        assert!((30_000..=30_100).contains(&k), "{ty}: {k}");
        assert_eq!(g.counts().drift, 1, "{ty}");
        assert_eq!(g.counts().offset, 0, "{ty}");
    }
}
