//! The converters' timing on the simulated bench: the ADS131M02's sinc3
//! decimation filter and the DAC's update latency, simulated exactly.
//!
//! * **ADC.** Each conversion is the sinc³ average of the analog input over
//!   the last three conversion periods (ADS131M02 data sheet SBAS853A,
//!   §8.3.7 "Digital Filter": a linear-phase sinc3 FIR at OSR 256 whose
//!   output settles three conversions after a step): the input filtered by
//!   H(s) = ((1 − e^{−sT})/(sT))³, T = 1/f_DATA, sampled at DRDY. Its
//!   impulse response is M₃(t/T)/T, M₃ the quadratic B-spline on [0, 3):
//!   weights (1 − s)²/2, 1/2 + s − s², s²/2 (s ∈ [0, 1) the position
//!   inside each of the three periods, newest first). Its group delay is
//!   1.5 samples, its droop |H(jω)| = sinc(ωT/2)³ ≈ 1 − (ωT)²/8.
//! * **DAC.** The value written at tick k takes effect δ after t_k (the
//!   board writes it after reading the ADC frame); before that the previous
//!   value holds.
//!
//! # Exact discretization
//! Each mode is augmented with three integrators of its output
//! contribution, restarted every period: I₁' = y, I₂' = I₁, I₃' = I₂ in
//! τ = t/T, so at the period's end I₁ = ∫y, I₂ = ∫(1 − s)y,
//! I₃ = ∫(1 − s)²/2·y. The three weights above are combinations of these
//! (I₃; I₁/2 + I₂ − 2I₃; (I₁ − 2I₂ + 2I₃)/2), so one period contributes to
//! three conversions through three linear forms in (x_k, u_old, u_new).
//! The period is split at δ: two matrix exponentials of the augmented
//! system ([[A·T, B·T], [C, shift]]), as [`super::plant`] does for the
//! held input. Equivalent to Δ³I₃(t_k)/T³ with global integrators, but
//! those grow like t³ and lose every digit to cancellation within seconds;
//! the restarted ones stay O(y).
//!
//! The monitor channel gets the same sinc³ of the actuator voltage (a
//! staircase switched at δ), in closed form.
//!
//! # Not modelled
//! The decimator is modelled by its continuous limit (three boxcars of
//! width T). The chip's filter sums 3·256 − 2 modulator samples: for point
//! samples at the modulator rate it is the continuous cascade advanced by
//! 3/(2·256) = 0.0059 sample (group delay 1.494 instead of 1.5): each
//! boxcar of 256 point samples is sin(ωT/2)/(256·sin(ωT/512)) against
//! sin(ωT/2)/(ωT/2), a relative magnitude difference of (ωT/512)²/6 per
//! boxcar, 1.1e-9 for the three at ω₂ = 245 rad/s, 4.4e-8 at 1520 rad/s
//! (`host-tests/examples/adc_delay.rs` measures the shift: +0.00586
//! sample). Where the modulator samples sit relative to DRDY is not in the
//! data sheet. The bridge is averaged in y, before the front end's
//! nonlinearity, not in volts (the quarter bridge's relative nonlinearity
//! is GF·ε/2 ≈ 1e-4 here, so the difference is second order in the
//! signal's change over 0.3 ms); the ADC's memory starts from rest (the
//! chip instead delivers its first two conversions after a reset from a
//! fast-settling sinc1 path, §8.3.7.1.1: start-up only).

use super::plant::{ModalPlant, ModeSpec, PlantError};
use crate::linalg::{expm, Block, EXPM_MAX};
use crate::model::MAX_MODES;

/// How the simulated converters sample the beam.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ConverterTiming {
    /// Each conversion is the sinc³ average over the last three periods
    /// (else a point sample at the tick).
    pub sinc3: bool,
    /// The DAC's new value takes effect this long after the tick (s),
    /// 0 ≤ δ < Ts.
    pub dac_latency_s: f64,
}

impl ConverterTiming {
    /// Point samples at the tick, the DAC updated at the tick: what the
    /// estimator's model assumes (and `Rig` simulates).
    pub const IDEAL: Self = Self {
        sinc3: false,
        dac_latency_s: 0.0,
    };

    /// Whether the numbers make sense for sample period `ts_s`.
    pub fn is_valid(&self, ts_s: f64) -> bool {
        let d = self.dac_latency_s;
        d.is_finite() && d >= 0.0 && d < ts_s
    }
}

impl Default for ConverterTiming {
    fn default() -> Self {
        Self::IDEAL
    }
}

/// One mode's split-period discretization and its sinc³ forms.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
struct TimedMode {
    phi: [[f64; 2]; 2],
    /// Gains of the old input (over [0, δ)) and the new one (over [δ, T)).
    gamma_old: [f64; 2],
    gamma_new: [f64; 2],
    out: [f64; 2],
    /// Contribution of the period to the conversion 1, 2, 3 periods
    /// later: w·x + w_old·u_old + w_new·u_new.
    w: [[f64; 2]; 3],
    w_old: [f64; 3],
    w_new: [f64; 3],
    x: [f64; 2],
}

/// The sinc³ weights of one period from its moments I₁, I₂, I₃.
fn sinc3_forms(i: [f64; 3]) -> [f64; 3] {
    let [i1, i2, i3] = i;
    [
        i3,
        0.5 * i1 + i2 - 2.0 * i3,
        0.5 * (i1 - 2.0 * i2 + 2.0 * i3),
    ]
}

impl TimedMode {
    /// Discretize `s` over one period `ts` split at `frac` = δ/Ts.
    fn new(s: &ModeSpec, ts: f64, frac: f64) -> Self {
        // z = [η, η', I₁, I₂, I₃, u] in τ = t/Ts.
        const N: usize = 6;
        let mut m: Block = [[0.0; EXPM_MAX]; EXPM_MAX];
        m[0][1] = ts;
        m[1][0] = -s.omega * s.omega * ts;
        m[1][1] = -2.0 * s.zeta * s.omega * ts;
        m[1][5] = s.gain * ts;
        m[2][0] = s.pos;
        m[2][1] = s.vel;
        m[3][2] = 1.0;
        m[4][3] = 1.0;
        let over = |h: f64| {
            let mut mh = m;
            for row in mh.iter_mut().take(N) {
                for v in row.iter_mut().take(N) {
                    *v *= h;
                }
            }
            expm(&mh, N)
        };
        // The state's own transition from the 3×3 system [η, η', u] (the
        // integrators do not feed back), exactly as `ModalPlant` computes
        // it: with δ = 0 the two agree bit for bit.
        let mut m3: Block = [[0.0; EXPM_MAX]; EXPM_MAX];
        for (r3, r) in m3.iter_mut().zip(m.iter()).take(2) {
            r3[0] = r[0];
            r3[1] = r[1];
            r3[2] = r[5];
        }
        let over3 = |h: f64| {
            let mut mh = m3;
            for row in mh.iter_mut().take(3) {
                for v in row.iter_mut().take(3) {
                    *v *= h;
                }
            }
            expm(&mh, 3)
        };
        let (head, tail) = (over(frac), over(1.0 - frac));
        let (head3, tail3) = (over3(frac), over3(1.0 - frac));
        fn apply<const K: usize>(e: &Block, z: &[f64; K]) -> [f64; K] {
            let mut out = [0.0; K];
            for (o, row) in out.iter_mut().zip(e.iter()) {
                *o = row.iter().zip(z.iter()).map(|(a, b)| a * b).sum();
            }
            out
        }
        // The period from state x with inputs (old, new): the moments, and
        // the state at its end.
        let run = |x: [f64; 2], old: f64, new: f64| {
            let mut z = apply(&head, &[x[0], x[1], 0.0, 0.0, 0.0, old]);
            z[5] = new;
            let z = apply(&tail, &z);
            let mut z3 = apply(&head3, &[x[0], x[1], old]);
            z3[2] = new;
            let z3 = apply(&tail3, &z3);
            ([z[2], z[3], z[4]], [z3[0], z3[1]])
        };
        let (i0, col0) = run([1.0, 0.0], 0.0, 0.0);
        let (i1, col1) = run([0.0, 1.0], 0.0, 0.0);
        let (i_old, old) = run([0.0, 0.0], 1.0, 0.0);
        let (i_new, new) = run([0.0, 0.0], 0.0, 1.0);
        let (w0, w1) = (sinc3_forms(i0), sinc3_forms(i1));
        Self {
            phi: [[col0[0], col1[0]], [col0[1], col1[1]]],
            gamma_old: old,
            gamma_new: new,
            out: [s.pos, s.vel],
            w: [[w0[0], w1[0]], [w0[1], w1[1]], [w0[2], w1[2]]],
            w_old: sinc3_forms(i_old),
            w_new: sinc3_forms(i_new),
            x: [0.0; 2],
        }
    }
}

/// Sinc³ forms of a staircase input: `old` over [0, frac), `new` after.
fn staircase_forms(frac: f64) -> [[f64; 2]; 3] {
    let r = 1.0 - frac;
    let i_new = [r, 0.5 * r * r, r * r * r / 6.0];
    let i_old = [frac, 0.5 - i_new[1], 1.0 / 6.0 - i_new[2]];
    let (o, n) = (sinc3_forms(i_old), sinc3_forms(i_new));
    [[o[0], n[0]], [o[1], n[1]], [o[2], n[2]]]
}

/// The beam with the converters' timing (see the module docs): point
/// output y(t_k), the ADC's view of it, and of the actuator voltage.
#[derive(Debug, Clone, PartialEq)]
pub struct TimedPlant {
    modes: usize,
    m: [TimedMode; MAX_MODES],
    specs: [ModeSpec; MAX_MODES],
    ts_s: f64,
    timing: ConverterTiming,
    /// The drive before the latest DAC update (held over [t_k, t_k + δ)).
    u_old: f64,
    /// Sinc³ contributions already made to the next two conversions.
    y_pending: [f64; 2],
    y_adc: f64,
    u_forms: [[f64; 2]; 3],
    u_pending: [f64; 2],
    u_adc: f64,
}

impl TimedPlant {
    /// `plant`'s modes (and state) with the converters' `timing`. The
    /// sinc³'s memory starts at zero (a just-reset ADC: its first three
    /// conversions are not settled, as on the chip).
    ///
    /// # Errors
    /// [`PlantError::Value`] for a plant read by a velocity or
    /// acceleration sensor ([`ModalPlant::with_output`]): the converters'
    /// timing is modelled for a strain (or displacement) output only.
    pub fn new(plant: &ModalPlant<f64>, timing: ConverterTiming) -> Result<Self, PlantError> {
        if plant.output_kind() != beam_protocol::OutputKind::Strain {
            return Err(PlantError::Value);
        }
        let mut specs = [ModeSpec::default(); MAX_MODES];
        let mut states = [[0.0; 2]; MAX_MODES];
        for ((sp, st), (ps, px)) in specs
            .iter_mut()
            .zip(states.iter_mut())
            .zip(plant.specs().iter().zip(plant.states()))
        {
            *sp = *ps;
            *st = px;
        }
        Self::build(plant.modes(), specs, &states, plant.ts_s(), timing)
    }

    /// The same beam, in its current state, with another `timing` (the
    /// sinc³'s memory restarts at zero).
    pub(crate) fn with_timing(&self, timing: ConverterTiming) -> Result<Self, PlantError> {
        let mut states = [[0.0; 2]; MAX_MODES];
        for (st, md) in states.iter_mut().zip(self.m.iter()) {
            *st = md.x;
        }
        Self::build(self.modes, self.specs, &states, self.ts_s, timing)
    }

    fn build(
        modes: usize,
        specs: [ModeSpec; MAX_MODES],
        states: &[[f64; 2]; MAX_MODES],
        ts: f64,
        timing: ConverterTiming,
    ) -> Result<Self, PlantError> {
        if !timing.is_valid(ts) {
            return Err(PlantError::Value);
        }
        let frac = timing.dac_latency_s / ts;
        let mut m = [TimedMode::default(); MAX_MODES];
        for ((tm, spec), x) in m.iter_mut().zip(specs.iter()).zip(states).take(modes) {
            *tm = TimedMode::new(spec, ts, frac);
            tm.x = *x;
        }
        Ok(Self {
            modes,
            m,
            specs,
            ts_s: ts,
            timing,
            u_old: 0.0,
            y_pending: [0.0; 2],
            y_adc: 0.0,
            u_forms: staircase_forms(frac),
            u_pending: [0.0; 2],
            u_adc: 0.0,
        })
    }

    /// The converters' timing.
    pub fn timing(&self) -> ConverterTiming {
        self.timing
    }

    /// Advance one period to the next tick: the drive was the previous
    /// value until δ after the last tick, then `u` (the DAC's value now).
    #[inline]
    pub fn advance(&mut self, u: f64) {
        let old = self.u_old;
        let mut c = [0.0f64; 3];
        for md in self.m.iter_mut().take(self.modes) {
            let x = md.x;
            for (ci, ((w, wo), wn)) in c
                .iter_mut()
                .zip(md.w.iter().zip(md.w_old.iter()).zip(md.w_new.iter()))
            {
                *ci += w[0] * x[0] + w[1] * x[1] + wo * old + wn * u;
            }
            let x0 = md.phi[0][0] * x[0]
                + md.phi[0][1] * x[1]
                + md.gamma_old[0] * old
                + md.gamma_new[0] * u;
            let x1 = md.phi[1][0] * x[0]
                + md.phi[1][1] * x[1]
                + md.gamma_old[1] * old
                + md.gamma_new[1] * u;
            md.x = [x0, x1];
        }
        let [f0, f1, f2] = self.u_forms;
        let cu = [
            f0[0] * old + f0[1] * u,
            f1[0] * old + f1[1] * u,
            f2[0] * old + f2[1] * u,
        ];
        self.y_adc = self.y_pending[0] + c[0];
        self.y_pending = [self.y_pending[1] + c[1], c[2]];
        self.u_adc = self.u_pending[0] + cu[0];
        self.u_pending = [self.u_pending[1] + cu[1], cu[2]];
        self.u_old = u;
    }

    /// Output y(t_k) at the tick (a point sample).
    pub fn output(&self) -> f64 {
        self.m
            .iter()
            .take(self.modes)
            .map(|md| md.out[0] * md.x[0] + md.out[1] * md.x[1])
            .sum()
    }

    /// What the ADC converts at this tick: the sinc³ average of y if
    /// [`ConverterTiming::sinc3`], else y(t_k).
    pub fn measured(&self) -> f64 {
        if self.timing.sinc3 {
            self.y_adc
        } else {
            self.output()
        }
    }

    /// What the ADC converts of the drive at this tick: its sinc³ average,
    /// or (point sample) the value held just before the tick.
    pub(crate) fn measured_drive(&self) -> f64 {
        if self.timing.sinc3 {
            self.u_adc
        } else {
            self.u_old
        }
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used, clippy::indexing_slicing)]
#[path = "timing_tests.rs"]
mod tests;
