//! Telemetry records → protocol messages: the [`Estimate`] of a recovered
//! record with its status flags, and the mapping of the pipeline's
//! counters onto the protocol's [`DeviceCounters`].
//!
//! # Flags (`docs/PROTOCOL.md` §4.1)
//! The sample task sets the bits it knows in the record's own
//! [`StatusFlags`] ([`TelemetryRecord::flags`]): FROZEN_BY_COMMAND,
//! FROZEN_AUTO, STATE_DEGRADED, INPUT_GONE, CHANGE_DETECTED, SENSOR_LEVEL,
//! TELEMETRY_DROPPED (records dropped). The estimate keeps them and adds
//! (EXCITED replaced: decided from the level that is sent):
//!
//! | protocol bit | set when |
//! |---|---|
//! | EXCITED | the excitation level sent (λmin(P)/tr(P): the supervisor's in-loop value, else the record's) ≥ [`FlagRules::excitation_rel_threshold`], and INPUT_GONE clear (Lemma 1) |
//! | CONVERGED | [`Convergence`]: every ω̂, ζ̂ within [`FlagRules::converged_rel_tol`] of its value at the start of a window of [`FlagRules::converged_window_samples`] |
//! | PHYSICALLY_VALID | modes recovered, as many as the model has, ω > 0, 0 < ζ < 1, ω strictly ascending, all finite |
//! | SENSOR_FAULT | since the previous estimate: ADC CRC, status, bus or other errors, stale or stuck conversions, an open bridge |
//! | ADC_SATURATED | since the previous estimate: a bridge or monitor conversion at full scale |
//! | DAC_SATURATED | since the previous estimate: a DAC write limited at a rail or failed, or an excitation sample clamped at the safe window |
//! | TELEMETRY_DROPPED | (also) since the previous estimate: a record or raw block dropped on a full queue, or a frame dropped on a full TX ring |
//!
//! "Since the previous estimate" is since the previous Estimate that was
//! queued for the wire (PROTOCOL.md §4.1): the counter bits come from the
//! differences of the cumulative counters each record carries against
//! those of that estimate's record, and the record's own event bits
//! (FROZEN_AUTO, CHANGE_DETECTED, SENSOR_LEVEL, TELEMETRY_DROPPED) of the
//! records in between (records that only carried a Status, or whose
//! estimate was dropped on a full TX ring) are carried into the next estimate ([`EstimateContext::earlier_events`]).
//! So they are exact when records in between were dropped, when Status
//! runs faster than the estimates, and when an estimate is lost.

use crate::model::ModalParams;
use crate::pipeline::{Counters, Recovered, TelemetryRecord};
use crate::scalar::Real;
use beam_protocol::{
    DeviceCounters, Estimate, EstimatorKind, ModeEstimate, StatusFlags, MAX_MODES,
};

/// The firmware's rules for the flags that need a threshold.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FlagRules {
    /// EXCITED when the excitation level sent, λmin(P)/tr(P) (scaled
    /// coordinates, Lemma 1), reaches this value and the input is present
    /// (relative to tr(P): P's size grows with time and with 1/l, and so
    /// does the rounding noise on λmin). Default: the core's
    /// `crate::supervise::EXCITATION_REL_THRESHOLD`, the supervisor's.
    pub excitation_rel_threshold: f32,
    /// CONVERGED tolerance: relative change of every ω̂ and ζ̂.
    pub converged_rel_tol: f32,
    /// CONVERGED window (samples).
    pub converged_window_samples: u64,
}

impl Default for FlagRules {
    /// λmin(P) > 1e-7·tr(P); ω̂, ζ̂ within 1e-4 for 0.5 s at 10 kHz.
    ///
    /// The threshold sits between the levels measured on the simulated
    /// bench in `f32` with the default gains (l = γ = 0.05 /s) over 30 s
    /// (host test `link::excited_flag_follows_the_excitation`, which prints
    /// them; the figures: BENCHMARKS.md, "Design measurements"): under the
    /// paper's square wave (hundreds of sinusoids; 2 modes need 2n = 4,
    /// Lemma 1) λmin/tr(P) stays above it; under one tone and under two
    /// tones (2 and 4 spectral lines: not exciting for 7 parameters) λmin
    /// is rounding noise of either sign, far below it relative to tr(P),
    /// while |λmin| itself grows with P — why an absolute threshold cannot work. P is in the
    /// coordinates scaled by U0 and Y0 (eq. 29's scaling), so the ratio
    /// does not depend on the plant's units. A plant whose P is worse
    /// conditioned than ≈ 10⁷ (tr(P) ≥ λmax) is never flagged, excited or
    /// not: in `f32` its λmin is below the rounding noise anyway.
    fn default() -> Self {
        Self {
            excitation_rel_threshold: crate::supervise::EXCITATION_REL_THRESHOLD as f32,
            converged_rel_tol: 1e-4,
            converged_window_samples: 5_000,
        }
    }
}

/// The CONVERGED test: an anchor (ω̂, ζ̂ at the start of a window) and the
/// sample index it was taken at. An estimate that leaves the tolerance
/// band around the anchor becomes the new anchor; CONVERGED holds once the
/// anchor has held for the window. Truth-free: it looks only at the
/// estimates.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Convergence {
    anchor: Option<(u64, [f32; MAX_MODES], [f32; MAX_MODES])>,
}

impl Convergence {
    /// Forget the history (new or reset estimator).
    pub fn reset(&mut self) {
        self.anchor = None;
    }

    /// Take the estimate at `sample_index` (`None`: no valid modes, which
    /// restarts the window); true if converged.
    pub fn observe(
        &mut self,
        sample_index: u64,
        modes: Option<&ModalParams<f32>>,
        rules: &FlagRules,
    ) -> bool {
        let Some(m) = modes else {
            self.anchor = None;
            return false;
        };
        if let Some((since, w0, z0)) = &self.anchor {
            let close = |a: &[f32; MAX_MODES], b: &[f32; MAX_MODES]| {
                a.iter()
                    .zip(b.iter())
                    .take(m.modes)
                    .all(|(&x, &x0)| (x - x0).abs() <= rules.converged_rel_tol * x0.abs())
            };
            if close(&m.omega_rad_s, w0) && close(&m.zeta, z0) {
                return sample_index.saturating_sub(*since) >= rules.converged_window_samples;
            }
        }
        self.anchor = Some((sample_index, m.omega_rad_s, m.zeta));
        false
    }
}

/// Modes that are physical: as many as the model has, every value finite,
/// ω > 0, 0 < ζ < 1, ω strictly ascending (distinct modes) — the core's
/// [`crate::modal::Validity`] test.
pub(crate) fn physically_valid(m: &ModalParams<f32>, model_modes: usize) -> bool {
    crate::modal::Validity::of(m, model_modes).is_valid()
}

fn sum(values: &[u32]) -> u32 {
    values.iter().fold(0u32, |a, &v| a.saturating_add(v))
}

/// Sensor faults (ADC errors of every kind, stale and stuck conversions,
/// an open bridge).
fn sensor_faults(c: &Counters) -> u32 {
    sum(&[
        c.adc_crc,
        c.adc_status,
        c.adc_bus,
        c.adc_other,
        c.stuck,
        c.open,
    ])
}

/// Saturated conversions, bridge and monitor.
fn adc_saturations(c: &Counters) -> u32 {
    sum(&[c.bridge_saturated, c.monitor_saturated])
}

/// Excitation not delivered as commanded: DAC rail, failed write, clamp.
fn dac_saturations(c: &Counters) -> u32 {
    sum(&[c.dac_saturated, c.dac_errors, c.excitation_clamped])
}

/// Telemetry dropped on the sample side: records and raw blocks.
fn queue_drops(c: &Counters) -> u32 {
    sum(&[c.dropped_records, c.dropped_raw_blocks])
}

/// The protocol's device counters from the pipeline's, the link's command
/// counts and receive errors, and the TX frames it dropped.
///
/// Mapping (`docs/PROTOCOL.md` §4.3): adc_status_errors = status + bus +
/// other ADC errors (other includes stale conversions); adc_saturations =
/// bridge + monitor; dac_saturations = rail + failed writes + clamped
/// excitation samples; telemetry_dropped = records + raw blocks dropped on
/// the sample side + frames dropped on the TX ring.
pub(crate) fn device_counters(
    c: &Counters,
    commands_accepted: u32,
    commands_rejected: u32,
    rx_frame_errors: u32,
    tx_frames_dropped: u32,
) -> DeviceCounters {
    DeviceCounters {
        overruns: c.overruns,
        adc_crc_errors: c.adc_crc,
        adc_status_errors: sum(&[c.adc_status, c.adc_bus, c.adc_other]),
        adc_stuck: c.stuck.saturating_add(c.open),
        adc_saturations: adc_saturations(c),
        dac_saturations: dac_saturations(c),
        rejected_samples: c.rejected,
        telemetry_dropped: queue_drops(c).saturating_add(tx_frames_dropped),
        commands_accepted,
        commands_rejected,
        rx_frame_errors,
    }
}

/// tr(P) from the record's packed upper triangle (row by row: the
/// diagonal entries are NP, NP − 1, … apart).
fn information_trace<T: Real, const NS: usize>(packed: &[T; NS]) -> T {
    let mut t = T::ZERO;
    let (mut k, mut row_len) = (0usize, 0usize);
    // NP from NS = NP(NP + 1)/2.
    while row_len * (row_len + 1) / 2 < NS {
        row_len += 1;
    }
    while let Some(&v) = packed.get(k) {
        t += v;
        k += row_len;
        row_len = row_len.saturating_sub(1);
        if row_len == 0 {
            break;
        }
    }
    t
}

/// Modal parameters rounded to `f32` (the wire's precision).
fn modal_f32<T: Real>(m: &ModalParams<T>) -> ModalParams<f32> {
    let f = |a: &[T; MAX_MODES]| a.map(|v| v.to_f64() as f32);
    ModalParams {
        modes: m.modes,
        omega_rad_s: f(&m.omega_rad_s),
        zeta: f(&m.zeta),
        bbar: f(&m.bbar),
        output_weight: f(&m.output_weight),
    }
}

/// The record bits that say something happened since the previous record
/// (the sample task clears them after each record), as opposed to a state
/// at the record: a record that makes no estimate passes them on to the
/// next estimate ([`EstimateContext::earlier_events`]).
pub(crate) const SINCE_PREVIOUS_RECORD: StatusFlags = StatusFlags::FROZEN_AUTO
    .with(StatusFlags::CHANGE_DETECTED)
    .with(StatusFlags::SENSOR_LEVEL)
    .with(StatusFlags::TELEMETRY_DROPPED);

/// Everything besides the record that an [`Estimate`] needs.
#[derive(Debug, Clone, Copy)]
pub struct EstimateContext<'a> {
    /// The law in use.
    pub estimator: EstimatorKind,
    /// The model's mode count n (Θ has 4n − 1 entries).
    pub model_modes: usize,
    /// Thresholds.
    pub rules: &'a FlagRules,
    /// Counters of the record of the previous estimate queued for the wire
    /// (zero before the first).
    pub previous: &'a Counters,
    /// The event bits (FROZEN_AUTO, CHANGE_DETECTED, SENSOR_LEVEL,
    /// TELEMETRY_DROPPED) of the records after the previous estimate's and
    /// before this one (empty when every record makes an estimate that gets
    /// through).
    pub earlier_events: StatusFlags,
    /// Telemetry dropped since the previous estimate outside the records'
    /// counters (frames dropped on the TX ring).
    pub dropped_elsewhere: bool,
    /// The law has not updated since the estimator (re)started: Θ̂ is its
    /// initial value, not an estimate. The modes are then left out (and
    /// PHYSICALLY_VALID clear): Θ̂ = 0 would read as λ's own poles
    /// (ω = λ, ζ = 1), which a monitor would plot as an estimate.
    pub no_update_yet: bool,
}

/// The [`Estimate`] of one record and its recovery, with the CONVERGED
/// test advanced by it.
pub fn estimate<T: Real, const NP: usize, const NS: usize>(
    record: &TelemetryRecord<T, NP, NS>,
    recovered: &Recovered<T>,
    ctx: &EstimateContext<'_>,
    convergence: &mut Convergence,
) -> Estimate {
    let rules = ctx.rules;
    // Θ̂ = 0 is the law's initial value, never an estimate (B = 0): its
    // "modes" would be λ's own poles (ω = λ, ζ = 1).
    let uninformed = ctx.no_update_yet || record.theta.iter().all(|v| *v == T::ZERO);
    let modal = recovered
        .modal
        .as_ref()
        .ok()
        .filter(|_| !uninformed)
        .map(modal_f32);
    let valid = modal
        .as_ref()
        .is_some_and(|m| physically_valid(m, ctx.model_modes));
    let level = excitation_level(record, recovered);
    let now = &record.counters;
    let prev = ctx.previous;
    let grew = |f: fn(&Counters) -> u32| f(now) != f(prev);

    // The sample task's bits as they are; the link adds those that need
    // the recovery, the thresholds or the counters' differences. EXCITED
    // is decided here, from the level that is sent, so that a receiver
    // can check it: level ≥ threshold and the input present.
    let mut flags = record
        .flags
        .with(StatusFlags(ctx.earlier_events.0 & SINCE_PREVIOUS_RECORD.0));
    let input_gone = flags.contains(StatusFlags::INPUT_GONE);
    let lemma1 = level.is_some_and(|l| l >= rules.excitation_rel_threshold);
    flags.set(StatusFlags::EXCITED, lemma1 && !input_gone);
    let converged =
        convergence.observe(record.sample_index, modal.as_ref().filter(|_| valid), rules);
    flags.set(StatusFlags::CONVERGED, converged);
    flags.set(StatusFlags::PHYSICALLY_VALID, valid);
    flags.set(StatusFlags::SENSOR_FAULT, grew(sensor_faults));
    flags.set(StatusFlags::ADC_SATURATED, grew(adc_saturations));
    flags.set(StatusFlags::DAC_SATURATED, grew(dac_saturations));
    if grew(queue_drops) || ctx.dropped_elsewhere {
        flags = flags.with(StatusFlags::TELEMETRY_DROPPED);
    }

    let mut modes = heapless::Vec::new();
    // Never a NaN on the wire: non-finite modes are left out.
    let sendable = |m: &&ModalParams<f32>| {
        m.modes == ctx.model_modes
            && !crate::modal::Validity::of(*m, ctx.model_modes)
                .contains(crate::modal::Validity::NON_FINITE)
    };
    if let Some(m) = modal.as_ref().filter(sendable) {
        for i in 0..m.modes.min(MAX_MODES) {
            if let (Some(&w), Some(&z), Some(&b)) =
                (m.omega_rad_s.get(i), m.zeta.get(i), m.bbar.get(i))
            {
                let _ = modes.push(ModeEstimate {
                    omega_rad_s: w,
                    zeta: z,
                    b_bar: b,
                });
            }
        }
    }
    let theta = record
        .theta
        .iter()
        .take(beam_protocol::MAX_THETA)
        .map(|v| v.to_f64() as f32)
        .collect();
    Estimate {
        sample_index: record.sample_index,
        estimator: ctx.estimator,
        flags,
        modes,
        lambda_rad_s: record.lambda_rad_s as f32,
        theta,
        excitation_level: level,
    }
}

/// The excitation level sent with an estimate: λmin(P)/tr(P) of the scaled
/// information matrix (Lemma 1) — the supervisor's in-loop value when it
/// has one (its own EXCITED test), else the record's (λmin by Jacobi
/// rotations, tr(P) from the diagonal) — rounded to `f32` and clamped to
/// [0, 1]. P is positive semi-definite by construction (a filtered sum of
/// φφᵀ), so λmin ≥ 0 and λmin ≤ tr(P); a negative value is the rounding of
/// the eigenvalue solver on a nearly singular P (|λmin| ~ ε·λmax), and is
/// sent as 0. P = 0 (no information yet) is level 0. `None` for a law
/// without P and for a non-finite P.
fn excitation_level<T: Real, const NP: usize, const NS: usize>(
    record: &TelemetryRecord<T, NP, NS>,
    recovered: &Recovered<T>,
) -> Option<f32> {
    let ratio = match record.lemma1_ratio {
        Some(r) => Some(r.to_f64()),
        None if record.has_information => {
            let trace = information_trace(&record.information).to_f64();
            recovered.excitation_min_eig.map(|l| {
                if trace == 0.0 {
                    0.0
                } else {
                    l.to_f64() / trace
                }
            })
        }
        None => None,
    };
    ratio
        .filter(|r| r.is_finite())
        .map(|r| (r as f32).clamp(0.0, 1.0))
}

#[cfg(test)]
#[allow(clippy::unwrap_used, clippy::indexing_slicing)]
mod tests {
    use super::*;
    use crate::modal::ModalError;
    use crate::pipeline::StepCounts;

    fn params(w: [f32; 2], z: [f32; 2]) -> ModalParams<f32> {
        ModalParams {
            modes: 2,
            omega_rad_s: [w[0], w[1], 0.0],
            zeta: [z[0], z[1], 0.0],
            bbar: [9.6, 16.1, 0.0],
            output_weight: [-2.0, 2.0, 0.0],
        }
    }

    /// P = I (tr 7) packed.
    fn identity() -> [f32; 28] {
        let mut p = [[0.0f32; 7]; 7];
        for (i, row) in p.iter_mut().enumerate() {
            row[i] = 1.0;
        }
        let mut out = [0.0; 28];
        crate::pipeline::telemetry::pack_symmetric(&p, &mut out);
        out
    }

    #[test]
    fn trace_of_the_packed_information() {
        assert_eq!(information_trace(&identity()), 7.0);
        let mut p = [[0.0f64; 3]; 3];
        for i in 0..3 {
            for j in 0..3 {
                p[i][j] = (1 + i * 3 + j) as f64;
            }
        }
        let mut packed = [0.0; 6];
        crate::pipeline::telemetry::pack_symmetric(&p, &mut packed);
        assert_eq!(information_trace(&packed), 1.0 + 5.0 + 9.0);
    }

    fn record(index: u64, flags: StatusFlags, counters: Counters) -> TelemetryRecord<f32, 7, 28> {
        TelemetryRecord {
            sample_index: index,
            theta: [1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0],
            information: identity(),
            has_information: true,
            lambda_rad_s: 100.0,
            u_v: 0.1,
            y: 1e-3,
            flags,
            supervised: false,
            lemma1_ratio: None,
            steps: StepCounts::default(),
            counters,
        }
    }

    fn recovered(modal: Result<ModalParams<f32>, ModalError>, lmin: f32) -> Recovered<f32> {
        Recovered {
            sample_index: 0,
            modal,
            excitation_min_eig: Some(lmin),
            flags: StatusFlags::default(),
            counters: Counters::default(),
        }
    }

    #[test]
    fn physical_validity() {
        assert!(physically_valid(&params([39.0, 245.0], [0.02, 0.13]), 2));
        assert!(!physically_valid(&params([39.0, 245.0], [0.02, 0.13]), 3));
        assert!(!physically_valid(&params([39.0, 39.0], [0.02, 0.13]), 2));
        assert!(!physically_valid(&params([245.0, 39.0], [0.02, 0.13]), 2));
        assert!(!physically_valid(&params([-1.0, 39.0], [0.02, 0.13]), 2));
        assert!(!physically_valid(&params([39.0, 245.0], [0.0, 0.13]), 2));
        assert!(!physically_valid(&params([39.0, 245.0], [0.02, 1.0]), 2));
        assert!(!physically_valid(
            &params([39.0, f32::NAN], [0.02, 0.13]),
            2
        ));
        let mut m = params([39.0, 245.0], [0.02, 0.13]);
        m.bbar[1] = f32::INFINITY;
        assert!(!physically_valid(&m, 2));
    }

    #[test]
    fn convergence_needs_a_quiet_window() {
        let rules = FlagRules {
            converged_window_samples: 300,
            ..FlagRules::default()
        };
        let mut c = Convergence::default();
        let p = params([39.0, 245.0], [0.02, 0.13]);
        assert!(!c.observe(0, Some(&p), &rules));
        assert!(!c.observe(100, Some(&p), &rules));
        assert!(!c.observe(200, Some(&p), &rules));
        assert!(c.observe(300, Some(&p), &rules));
        // A step beyond 1e-4 on ζ2 restarts the window.
        let q = params([39.0, 245.0], [0.02, 0.13 * (1.0 + 2e-4)]);
        assert!(!c.observe(400, Some(&q), &rules));
        // Within 1e-4 of the new anchor.
        let r = params([39.0, 245.0 * (1.0 + 5e-5)], [0.02, 0.13 * (1.0 + 2e-4)]);
        assert!(!c.observe(600, Some(&r), &rules));
        assert!(c.observe(700, Some(&r), &rules));
        assert!(!c.observe(800, None, &rules));
        assert!(!c.observe(1200, Some(&r), &rules));
        c.reset();
        assert!(!c.observe(1600, Some(&r), &rules));
    }

    #[test]
    fn flags_from_record_state_and_counter_differences() {
        let rules = FlagRules::default();
        let prev = Counters {
            adc_crc: 3,
            bridge_saturated: 1,
            ..Counters::default()
        };
        let mut conv = Convergence::default();
        let ctx = |previous| EstimateContext {
            estimator: EstimatorKind::Adaptive,
            model_modes: 2,
            rules: &rules,
            previous,
            dropped_elsewhere: false,
            earlier_events: StatusFlags::default(),
            no_update_yet: false,
        };
        // Same counters, good modes, excited: EXCITED | PHYSICALLY_VALID.
        let rec = record(1000, StatusFlags::default(), prev);
        let e = estimate(
            &rec,
            &recovered(Ok(params([39.0, 245.0], [0.02, 0.13])), 1e-6),
            &ctx(&prev),
            &mut conv,
        );
        assert_eq!(
            e.flags,
            StatusFlags::EXCITED.with(StatusFlags::PHYSICALLY_VALID)
        );
        assert_eq!(e.modes.len(), 2);
        assert_eq!(e.theta.len(), 7);
        assert_eq!(e.modes[1].zeta, 0.13);
        // The level is λmin/tr(P) = 1e-6/7; λ is the record's.
        assert_eq!(e.excitation_level, Some((f64::from(1e-6f32) / 7.0) as f32));
        assert_eq!(e.lambda_rad_s, 100.0);
        assert!(e.is_consistent());
        // Each counter group and state flag sets its own bit.
        let none = StatusFlags::default();
        let cases: [(Counters, StatusFlags, StatusFlags); 9] = [
            (
                Counters {
                    adc_crc: 4,
                    bridge_saturated: 1,
                    ..Counters::default()
                },
                none,
                StatusFlags::SENSOR_FAULT,
            ),
            (
                Counters { stuck: 1, ..prev },
                none,
                StatusFlags::SENSOR_FAULT,
            ),
            (
                Counters {
                    monitor_saturated: 2,
                    ..prev
                },
                none,
                StatusFlags::ADC_SATURATED,
            ),
            (
                Counters {
                    excitation_clamped: 1,
                    ..prev
                },
                none,
                StatusFlags::DAC_SATURATED,
            ),
            (
                Counters {
                    dropped_raw_blocks: 1,
                    ..prev
                },
                none,
                StatusFlags::TELEMETRY_DROPPED,
            ),
            // The sample task's bits pass through.
            (
                prev,
                StatusFlags::FROZEN_BY_COMMAND,
                StatusFlags::FROZEN_BY_COMMAND,
            ),
            (prev, StatusFlags::FROZEN_AUTO, StatusFlags::FROZEN_AUTO),
            (
                prev,
                StatusFlags::STATE_DEGRADED,
                StatusFlags::STATE_DEGRADED,
            ),
            (
                prev,
                StatusFlags::TELEMETRY_DROPPED,
                StatusFlags::TELEMETRY_DROPPED,
            ),
        ];
        for (counters, pflags, bit) in cases {
            let e = estimate(
                &record(2000, pflags, counters),
                &recovered(Ok(params([39.0, 245.0], [0.02, 0.13])), 0.0),
                &ctx(&prev),
                &mut Convergence::default(),
            );
            assert_eq!(e.flags, bit.with(StatusFlags::PHYSICALLY_VALID), "{bit:?}");
        }
        // A supervised estimator: the level is its in-loop ratio, whatever
        // the record's λmin (0 or far above the threshold), and EXCITED
        // follows that level and INPUT_GONE, not the record's EXCITED bit;
        // its other bits pass through.
        for lmin in [0.0, 1.0] {
            for (ratio, bits, excited) in [
                (2e-7, StatusFlags::default(), true),
                (2e-7, StatusFlags::EXCITED, true),
                (5e-8, StatusFlags::EXCITED, false),
                (-3e-9, StatusFlags::EXCITED, false),
                (
                    2e-7,
                    StatusFlags::INPUT_GONE.with(StatusFlags::FROZEN_AUTO),
                    false,
                ),
                (2e-7, StatusFlags::CHANGE_DETECTED, true),
                (2e-7, StatusFlags::SENSOR_LEVEL, true),
            ] {
                let rec = TelemetryRecord {
                    supervised: true,
                    lemma1_ratio: Some(ratio),
                    ..record(2000, bits, prev)
                };
                let e = estimate(
                    &rec,
                    &recovered(Ok(params([39.0, 245.0], [0.02, 0.13])), lmin),
                    &ctx(&prev),
                    &mut Convergence::default(),
                );
                let mut want = bits.with(StatusFlags::PHYSICALLY_VALID);
                want.set(StatusFlags::EXCITED, excited);
                assert_eq!(e.flags, want, "{bits:?} {ratio} {lmin}");
                assert_eq!(e.excitation_level, Some(ratio.max(0.0)), "{ratio}");
            }
        }
        // The record's own level is never negative either: a λmin below 0
        // (rounding) is sent as 0, and P = 0 is level 0.
        let e = estimate(
            &rec,
            &recovered(Ok(params([39.0, 245.0], [0.02, 0.13])), -1.9e-9),
            &ctx(&prev),
            &mut conv,
        );
        assert_eq!(e.excitation_level, Some(0.0));
        assert!(!e.flags.contains(StatusFlags::EXCITED));
        let empty = TelemetryRecord {
            information: [0.0; 28],
            ..record(1000, StatusFlags::default(), prev)
        };
        let e = estimate(
            &empty,
            &recovered(Ok(params([39.0, 245.0], [0.02, 0.13])), 0.0),
            &ctx(&prev),
            &mut conv,
        );
        assert_eq!(e.excitation_level, Some(0.0));
        // A law without P: no level, never EXCITED.
        let no_p = TelemetryRecord {
            has_information: false,
            ..record(1000, StatusFlags::EXCITED, prev)
        };
        let mut none = recovered(Ok(params([39.0, 245.0], [0.02, 0.13])), 0.0);
        none.excitation_min_eig = None;
        let e = estimate(&no_p, &none, &ctx(&prev), &mut conv);
        assert_eq!(e.excitation_level, None);
        assert!(!e.flags.contains(StatusFlags::EXCITED));
        // λmin just below the threshold, 1e-7·tr(P), is not excited.
        let e = estimate(
            &rec,
            &recovered(Ok(params([39.0, 245.0], [0.02, 0.13])), 6.9e-7),
            &ctx(&prev),
            &mut conv,
        );
        assert!(!e.flags.contains(StatusFlags::EXCITED));
        // Failed recovery: no modes, not valid, Θ still sent; NaN λmin is
        // not excited.
        let e = estimate(
            &rec,
            &recovered(Err(ModalError::LengthMismatch), f32::NAN),
            &ctx(&prev),
            &mut conv,
        );
        assert!(e.modes.is_empty());
        assert_eq!(e.flags, StatusFlags::default());
        assert!(e.is_consistent());
        // Before the law's first update the modes are left out.
        let fresh = EstimateContext {
            no_update_yet: true,
            ..ctx(&prev)
        };
        let e = estimate(
            &rec,
            &recovered(Ok(params([39.0, 245.0], [0.02, 0.13])), 1e-6),
            &fresh,
            &mut conv,
        );
        assert!(e.modes.is_empty() && e.theta.len() == 7 && e.is_consistent());
        assert_eq!(e.flags, StatusFlags::EXCITED);
        // Θ̂ = 0 (the initial value) after an update: still no modes, not
        // valid, although its "modes" (λ's poles) would pass the test.
        let zero = TelemetryRecord {
            theta: [0.0; 7],
            ..rec
        };
        let e = estimate(
            &zero,
            &recovered(Ok(params([100.0, 100.5], [0.999, 0.999])), 1e-6),
            &ctx(&prev),
            &mut conv,
        );
        assert!(e.modes.is_empty() && e.is_consistent());
        assert!(!e.flags.contains(StatusFlags::PHYSICALLY_VALID));
        assert_eq!(e.theta.to_vec(), [0.0; 7]);
        // Unphysical modes are sent, flagged invalid.
        let e = estimate(
            &rec,
            &recovered(Ok(params([39.0, 245.0], [0.02, 1.5])), 1.0),
            &ctx(&prev),
            &mut conv,
        );
        assert_eq!(e.modes.len(), 2);
        assert_eq!(e.flags, StatusFlags::EXCITED);
    }

    #[test]
    fn device_counter_mapping() {
        let c = Counters {
            overruns: 1,
            missed_ticks: 9,
            adc_crc: 2,
            adc_status: 3,
            adc_bus: 4,
            adc_other: 5,
            bridge_saturated: 6,
            monitor_saturated: 7,
            stuck: 8,
            dac_errors: 10,
            dac_saturated: 11,
            excitation_clamped: 12,
            rejected: 13,
            dropped_records: 14,
            dropped_raw_blocks: 15,
            open: 20,
            offset_steps: 21,
            drift: 22,
        };
        let d = device_counters(&c, 16, 17, 18, 19);
        assert_eq!(
            d,
            DeviceCounters {
                overruns: 1,
                adc_crc_errors: 2,
                adc_status_errors: 12,
                adc_stuck: 28,
                adc_saturations: 13,
                dac_saturations: 33,
                rejected_samples: 13,
                telemetry_dropped: 48,
                commands_accepted: 16,
                commands_rejected: 17,
                rx_frame_errors: 18,
            }
        );
        let big = Counters {
            adc_status: u32::MAX,
            adc_bus: 1,
            ..Counters::default()
        };
        assert_eq!(
            device_counters(&big, 0, 0, 0, 0).adc_status_errors,
            u32::MAX
        );
    }
}
