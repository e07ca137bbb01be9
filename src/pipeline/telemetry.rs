//! What the sample task hands to the low-priority task, and what the
//! low-priority task makes of it.
//!
//! * [`TelemetryRecord`] — every K samples: Θ̂ (physical units, eq. 29), a
//!   packed copy of the scaled information matrix P (eq. 33), the last
//!   sample, the wire's status flags as far as the sample task knows them
//!   ([`StatusFlags`]) and a snapshot of every counter. Copying costs a
//!   few hundred instructions per record; the expensive parts — the roots of
//!   the estimated denominator (eq. 30), b̄ (eq. 31–32) and λmin(P)
//!   (Lemma 1) — are left to [`recover`], in the low-priority task.
//! * [`RawBlock`] — optional blocks of the (u, y) pairs fed to the
//!   estimator, decimated, for recording and replay; a rejected sample is
//!   recorded as NaN so a replay rejects it the same way.
//! * [`Sink`] — where records go: a `heapless::spsc::Producer` (never
//!   blocks: a full queue returns the record, which is counted as dropped).

use crate::estimator::{Estimator, StepStatus};
use crate::modal::{modal_from_tf, ModalError};
use crate::model::{ModalParams, TransferFunction};
use crate::scalar::Real;
use crate::supervise::excitation_min_eig;
use beam_protocol::StatusFlags;

/// Samples per [`RawBlock`].
pub const RAW_BLOCK_LEN: usize = 32;

/// A bounded, non-blocking destination for messages from the sample task.
pub trait Sink<M> {
    /// Hand over `message`, or give it back if there is no room.
    fn try_push(&mut self, message: M) -> Result<(), M>;
}

impl<M> Sink<M> for heapless::spsc::Producer<'_, M> {
    #[inline]
    fn try_push(&mut self, message: M) -> Result<(), M> {
        self.enqueue(message)
    }
}

/// A sink that accepts nothing (raw recording not wired up): every push is
/// refused, so enabling raw blocks without a queue shows up as drops.
#[derive(Debug, Clone, Copy, Default)]
pub struct NoSink;

impl<M> Sink<M> for NoSink {
    fn try_push(&mut self, message: M) -> Result<(), M> {
        Err(message)
    }
}

/// Saturating event counters of the sample path (all since the last
/// [`super::Pipeline::reset_counters`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Counters {
    /// Late interrupts reported by the board ([`super::Pipeline::note_overrun`]).
    pub overruns: u32,
    /// Sample ticks lost in those overruns.
    pub missed_ticks: u32,
    /// ADC frames with a CRC mismatch.
    pub adc_crc: u32,
    /// ADC frames with a bad status word or response.
    pub adc_status: u32,
    /// ADC bus errors.
    pub adc_bus: u32,
    /// Other ADC errors, and conversions the ADC marked stale.
    pub adc_other: u32,
    /// Bridge conversions at a full-scale code (or flagged over range).
    pub bridge_saturated: u32,
    /// Monitor conversions at a full-scale code (or flagged over range).
    pub monitor_saturated: u32,
    /// Bridge conversions rejected as stuck (identical code for too long,
    /// or flagged stuck by the converter's driver).
    pub stuck: u32,
    /// DAC writes that failed.
    pub dac_errors: u32,
    /// DAC writes limited at a rail.
    pub dac_saturated: u32,
    /// Excitation samples the safe-window clamp limited.
    pub excitation_clamped: u32,
    /// Samples found invalid and given to the estimator as NaN (it
    /// substitutes them and freezes its law, see [`crate::estimator`]); a
    /// deliberate hold (after an overrun, a resume, a new estimator) rejects
    /// nothing and is not counted.
    pub rejected: u32,
    /// Telemetry records dropped on a full queue.
    pub dropped_records: u32,
    /// Raw blocks dropped on a full queue.
    pub dropped_raw_blocks: u32,
    /// Bridge conversions of an open gauge: a jump to a rail, held
    /// ([`crate::guard::SampleFault::Open`]).
    pub open: u32,
    /// Offset steps of y removed ([`crate::guard::LevelEvent::Offset`]).
    pub offset_steps: u32,
    /// Drifts of y flagged ([`crate::guard::LevelEvent::Drift`]).
    pub drift: u32,
}

/// How the estimator's steps went since the previous record.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct StepCounts {
    /// [`StepStatus::Updated`].
    pub updated: u16,
    /// [`StepStatus::Frozen`] (quarantine or deliberate hold).
    pub frozen: u16,
    /// [`StepStatus::Rejected`].
    pub rejected: u16,
    /// [`StepStatus::Skipped`].
    pub skipped: u16,
}

impl StepCounts {
    pub(crate) fn count(&mut self, s: StepStatus) {
        let c = match s {
            StepStatus::Updated => &mut self.updated,
            StepStatus::Frozen => &mut self.frozen,
            StepStatus::Rejected => &mut self.rejected,
            StepStatus::Skipped => &mut self.skipped,
        };
        *c = c.saturating_add(1);
    }
}

/// One telemetry record (`NP` = 4n − 1 parameters, `NS` = NP(NP+1)/2).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TelemetryRecord<T, const NP: usize, const NS: usize> {
    /// Index of the newest sample (ticks since start, missed ticks
    /// included: time = index·Ts).
    pub sample_index: u64,
    /// Θ̂ of eq. 29 in physical units.
    pub theta: [T; NP],
    /// The scaled information matrix P (eq. 33), upper triangle packed
    /// row by row (P₀₀, P₀₁, …, P₀,NP−1, P₁₁, …); all zero when
    /// `has_information` is false (a law that keeps no P).
    pub information: [T; NS],
    /// Whether `information` holds P.
    pub has_information: bool,
    /// λ of the estimator's filter Λ(s) = (s + λ)^{2n} (rad/s), to map Θ̂
    /// to the transfer function (eq. 28–29).
    pub lambda_rad_s: f64,
    /// u fed to the estimator at the newest sample (V).
    pub u_v: T,
    /// y fed to the estimator at the newest sample (strain or m).
    pub y: T,
    /// The bits of the estimate's flags the sample task decides
    /// (`docs/PROTOCOL.md` §4.1), about the samples since the previous
    /// record that got through unless noted: FROZEN_BY_COMMAND (state),
    /// FROZEN_AUTO (the law was held: quarantine after a rejected sample,
    /// a deliberate hold, or the input gone), STATE_DEGRADED (state),
    /// EXCITED, INPUT_GONE (state, a supervised estimator's own decision),
    /// CHANGE_DETECTED, SENSOR_LEVEL, TELEMETRY_DROPPED (records dropped).
    /// The link adds the rest ([`crate::link::estimate`]).
    pub flags: StatusFlags,
    /// The estimator is supervised ([`crate::supervise`]): EXCITED is its
    /// own decision. Otherwise the link decides EXCITED from P (Lemma 1).
    pub supervised: bool,
    /// The supervisor's in-loop λmin(P)/tr(P) (Lemma 1, the ratio its
    /// EXCITED decision is tested against), if it has measured one; `None`
    /// without supervision or before its first measurement.
    pub lemma1_ratio: Option<T>,
    /// Estimator steps since the previous record.
    pub steps: StepCounts,
    /// Counters at the newest sample.
    pub counters: Counters,
}

impl<T: Real, const NP: usize, const NS: usize> TelemetryRecord<T, NP, NS> {
    /// The estimator's part of a record — Θ̂ (eq. 29) and the packed P
    /// (eq. 33) — with the sample task's part empty, for the sample task
    /// to fill in. A value the estimator knows joins the record here, beside
    /// its field (docs/ARCHITECTURE.md, "Where to change what").
    pub(crate) fn from_estimator<E: Estimator<T, NP> + ?Sized>(estimator: &E) -> Self {
        let mut information = [T::ZERO; NS];
        let p = estimator.information();
        if let Some(p) = &p {
            pack_symmetric(p, &mut information);
        }
        Self {
            sample_index: 0,
            theta: estimator.theta(),
            information,
            has_information: p.is_some(),
            lambda_rad_s: 0.0,
            u_v: T::ZERO,
            y: T::ZERO,
            flags: StatusFlags::default(),
            supervised: false,
            lemma1_ratio: None,
            steps: StepCounts::default(),
            counters: Counters::default(),
        }
    }
}

/// Up to [`RAW_BLOCK_LEN`] decimated (u, y) pairs as fed to the estimator
/// (before the prefilter); NaN marks a rejected sample.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RawBlock<T> {
    /// Sample index of `u[0]`, `y[0]`.
    pub first_index: u64,
    /// One pair every `decimation` samples.
    pub decimation: u16,
    /// Valid entries (the last block before a setting change may be short).
    pub len: u16,
    /// Actuator volts.
    pub u_v: [T; RAW_BLOCK_LEN],
    /// Strain or m.
    pub y: [T; RAW_BLOCK_LEN],
}

/// A record turned into modal terms by the low-priority task.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Recovered<T> {
    /// From the record.
    pub sample_index: u64,
    /// ω̂, ζ̂, b̄̂ (eq. 30–32), or why they could not be recovered.
    pub modal: Result<ModalParams<T>, ModalError>,
    /// λmin of the scaled P (Lemma 1); `None` if the law keeps no P. NaN if
    /// P held a non-finite entry.
    pub excitation_min_eig: Option<T>,
    /// From the record.
    pub flags: StatusFlags,
    /// From the record.
    pub counters: Counters,
}

/// Unpack a packed upper triangle into a full symmetric matrix.
pub fn unpack_symmetric<T: Real, const NP: usize, const NS: usize>(
    packed: &[T; NS],
) -> [[T; NP]; NP] {
    let mut p = [[T::ZERO; NP]; NP];
    let mut it = packed.iter();
    for i in 0..NP {
        for j in i..NP {
            let v = it.next().copied().unwrap_or(T::ZERO);
            if let Some(row) = p.get_mut(i) {
                if let Some(e) = row.get_mut(j) {
                    *e = v;
                }
            }
            if let Some(row) = p.get_mut(j) {
                if let Some(e) = row.get_mut(i) {
                    *e = v;
                }
            }
        }
    }
    p
}

/// Pack the upper triangle of `p` row by row (the record's layout).
pub(crate) fn pack_symmetric<T: Real, const NP: usize, const NS: usize>(
    p: &[[T; NP]; NP],
    out: &mut [T; NS],
) {
    let mut it = out.iter_mut();
    for (i, row) in p.iter().enumerate() {
        for v in row.iter().skip(i) {
            if let Some(o) = it.next() {
                *o = *v;
            }
        }
    }
}

/// The low-priority task's work on one record: Θ̂ → A(s), B(s) (eq. 28–29)
/// → ω̂, ζ̂, b̄̂ (eq. 30–32, `output_weight` = C̄ of eq. 24 for the modes in
/// ascending ω), and λmin(P). Pure; never panics.
pub fn recover<T: Real, const NP: usize, const NS: usize>(
    record: &TelemetryRecord<T, NP, NS>,
    output_weight: &[T],
) -> Recovered<T> {
    let modal = TransferFunction::from_theta(&record.theta, record.lambda_rad_s)
        .ok_or(ModalError::LengthMismatch)
        .and_then(|tf| modal_from_tf(&tf, output_weight));
    let excitation_min_eig = if record.has_information {
        let p: [[T; NP]; NP] = unpack_symmetric(&record.information);
        Some(excitation_min_eig(&p))
    } else {
        None
    };
    Recovered {
        sample_index: record.sample_index,
        modal,
        excitation_min_eig,
        flags: record.flags,
        counters: record.counters,
    }
}
