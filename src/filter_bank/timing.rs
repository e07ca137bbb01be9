//! The converters' timing, modelled on the filter bank's u channel.
//!
//! The estimator's regression (eq. 29) holds when the filtered u and the
//! filtered y are related by the plant alone. On a real rig the measured
//! y_k is not y(t_k): a ΔΣ ADC's decimation filter averages the output
//! over the last conversion periods, and the DAC's new value takes effect
//! some time after the tick. Both are linear and time-invariant, so they
//! commute with the plant: if the u channel is driven by the same timing
//! applied to the held input, y_k and the u channel agree again and the
//! regression is exact.
//!
//! # The kernel
//! Everything the timing does to the held staircase u(t) = u_k on
//! [t_k, t_{k+1}) is one kernel K (age s in samples): the u channel is
//! driven by u_eff(t) = Σ_k u_k·K((t − t_k)/Ts).
//! * [`OutputAverage::Point`]: y_k is a point sample taken `d` samples
//!   late, i.e. u is delayed by d: K = the unit box on [d, d + 1).
//! * [`OutputAverage::Sinc3`]: y_k is the sinc³ average of the output over
//!   the last three sample periods, H(s) = ((1 − e^{−sTs})/(sTs))³ (the
//!   ADS131M02's sinc3 decimator at its data rate, SBAS853A §8.3.7; its
//!   group delay is 1.5 samples), and u takes effect `d − 1.5` samples
//!   late: K = M₄(s − (d − 1.5)), M₄ the cubic B-spline on [0, 4) (the
//!   hold's box convolved with the three boxes of the sinc³).
//!
//! `d` ([`OutputTiming::delay_samples`]) is the total delay of y behind u
//! in both shapes: the ADC filter's group delay plus the DAC's latency.
//!
//! # Exact under the hold
//! Over one sample interval τ ∈ [0, 1) the kernel's pieces are
//! polynomials (degree 0 or 3) with one break at frac(a), a the kernel's
//! shift. The interval is integrated in (at most) two pieces with the bank's
//! polynomial-input responses G_m(h) (response over h samples to τ^m/m!,
//! from one matrix exponential of the augmented system per piece) and the
//! first piece carried through Φ(1 − f): one gain vector per u sample in
//! reach, computed once in `f64`. A point delay needs two taps (one when
//! d is an integer), the sinc³ five (four).

use crate::linalg::{expm, Block, EXPM_MAX};

/// Largest total delay [`OutputTiming::delay_samples`] accepted (samples):
/// the u history the bank keeps covers it.
pub(crate) const MAX_OUTPUT_DELAY_SAMPLES: f64 = 3.0;
/// Gain vectors on u at most (the sinc³ kernel at a fractional shift).
pub(crate) const U_TAPS: usize = 5;
/// Length of the u history u_n … u_{n−U_HIST+1} the bank keeps: the
/// look-ahead's three and the kernel's reach at the largest delay (the
/// sinc³ at d = 3: u_{n−3−5}).
pub(crate) const U_HIST: usize = 9;
/// The bank integrates [t_{n−3}, t_{n−2}] at push n (its look-ahead):
/// u_{n−3−i} is history entry `LAG + i`.
const LAG: i32 = 3;

/// How the measured y_k weights the plant's output over time.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum OutputAverage {
    /// A point sample (of the output `delay_samples` before the tick).
    #[default]
    Point,
    /// The sinc³ average over the last three sample periods (a ΔΣ ADC's
    /// sinc3 decimation filter running at the sample rate).
    Sinc3,
}

/// When and how the measured output y_k sees the plant, relative to the
/// held input u_k fed with it (see the module docs).
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct OutputTiming {
    /// Total delay of y behind u in samples (see [`Self::is_valid`] for
    /// the range): the ADC filter's group delay (1.5 for a sinc3 at the
    /// data rate) plus the DAC's update latency / Ts.
    pub delay_samples: f64,
    /// The shape of the ADC's averaging.
    pub average: OutputAverage,
}

impl Default for OutputTiming {
    fn default() -> Self {
        Self::IDEAL
    }
}

impl OutputTiming {
    /// The paper's assumption: y_k = y(t_k), u_k held from t_k on.
    pub const IDEAL: Self = Self {
        delay_samples: 0.0,
        average: OutputAverage::Point,
    };

    /// Group delay of a sinc3 decimator at its data rate (samples): half its
    /// three-period window.
    pub(crate) const SINC3_GROUP_DELAY_SAMPLES: f64 = 1.5;

    /// A sinc3 ADC whose samples are paired with a DAC value that takes
    /// effect `dac_latency_s` after the tick, at sample period `ts_s`:
    /// delay = 1.5 + latency/Ts.
    pub fn sinc3_adc(dac_latency_s: f64, ts_s: f64) -> Self {
        Self {
            delay_samples: Self::SINC3_GROUP_DELAY_SAMPLES + dac_latency_s / ts_s,
            average: OutputAverage::Sinc3,
        }
    }

    /// Whether the numbers are usable: 0 ≤ d ≤ `MAX_OUTPUT_DELAY_SAMPLES`,
    /// and d ≥ 1 for [`OutputAverage::Sinc3`] (its window's group delay is
    /// 1.5 samples; a chip's decimator may come out a few modulator periods
    /// shorter, e.g. 1.494 for 3·256 − 2 taps over point samples, but not
    /// half a sample).
    pub fn is_valid(&self) -> bool {
        let d = self.delay_samples;
        let min = match self.average {
            OutputAverage::Point => 0.0,
            OutputAverage::Sinc3 => 1.0,
        };
        d.is_finite() && (min..=MAX_OUTPUT_DELAY_SAMPLES).contains(&d)
    }

    /// Whether this is [`Self::IDEAL`] in effect (the u channel is a plain
    /// zero-order hold).
    pub(crate) fn is_ideal(&self) -> bool {
        self.delay_samples == 0.0 && self.average == OutputAverage::Point
    }

    /// Weights w_j of the u history (`u_hist[j]` = u_{n−j}) that give the
    /// timing's input u_eff(t) = Σ_k u_k·K((t − t_k)/Ts) just before
    /// t_{n−2}, the instant of the bank's regressor: what a direct term of
    /// the model (an accelerometer's, `FilterConfig::output`) adds to
    /// y_{n−2}. The left limit, because y is read before the input of its
    /// own sample takes effect: [`Self::IDEAL`] gives u_{n−3} (w_3 = 1).
    pub(crate) fn direct_weights(&self) -> [f64; U_HIST] {
        let (pieces, a) = self.kernel();
        core::array::from_fn(|j| {
            // Age of u_{n−j} at t_{n−2} in samples, as the kernel's argument.
            let x = j as f64 - 2.0 - a;
            // The piece holding x from the left: x ∈ (p, p + 1].
            let p = libm::ceil(x) - 1.0;
            if p < 0.0 || p >= pieces.len() as f64 {
                return 0.0;
            }
            derivatives(&pieces[p as usize], x)[0]
        })
    }

    /// The kernel's polynomial pieces on [p, p + 1) (coefficients of x^0..x^3)
    /// and its shift a (K(s) = P(s − a)).
    fn kernel(&self) -> (&'static [[f64; 4]], f64) {
        const BOX: [[f64; 4]; 1] = [[1.0, 0.0, 0.0, 0.0]];
        // The cardinal cubic B-spline M₄ on [0, 4).
        const M4: [[f64; 4]; 4] = [
            [0.0, 0.0, 0.0, 1.0 / 6.0],
            [4.0 / 6.0, -2.0, 2.0, -0.5],
            [-44.0 / 6.0, 10.0, -4.0, 0.5],
            [64.0 / 6.0, -8.0, 2.0, -1.0 / 6.0],
        ];
        match self.average {
            OutputAverage::Point => (&BOX, self.delay_samples),
            OutputAverage::Sinc3 => (&M4, self.delay_samples - Self::SINC3_GROUP_DELAY_SAMPLES),
        }
    }
}

/// Derivatives 0..3 of the polynomial `c` (ascending) at x.
fn derivatives(c: &[f64; 4], x: f64) -> [f64; 4] {
    [
        c[0] + x * (c[1] + x * (c[2] + x * c[3])),
        c[1] + x * (2.0 * c[2] + x * 3.0 * c[3]),
        2.0 * c[2] + 6.0 * c[3] * x,
        6.0 * c[3],
    ]
}

/// The u channel's gain vectors for one sample interval: u_{n−3−i} for
/// i = `first_lag` … `first_lag + count − 1`, in that order.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct InputTaps<const D: usize> {
    pub gains: [[f64; D]; U_TAPS],
    /// History index of the first tap's u (u_n is index 0).
    pub first: usize,
    pub count: usize,
}

impl<const D: usize> InputTaps<D> {
    /// Taps for `timing` on the normalized filter whose augmented system
    /// (in τ = t/Ts: x' = ρTs(A_n x + e_{D−1} q0), q_m' = q_{m+1}, size
    /// `n` ≥ D + 4) is `aug`. The caller validates `timing`.
    pub(crate) fn new(aug: &Block, n: usize, timing: &OutputTiming) -> Self {
        let (pieces, a) = timing.kernel();
        let len = pieces.len() as f64;
        let fl = libm::floor(a);
        let f = a - fl;
        // Sub-intervals of [0, 1) in which every kernel piece is one
        // polynomial: [0, f) and [f, 1) (one when f = 0).
        let splits: [(f64, f64); 2] = [(0.0, f), (f, 1.0)];
        let scaled = |h: f64| {
            let mut m: Block = [[0.0; EXPM_MAX]; EXPM_MAX];
            for (mr, ar) in m.iter_mut().zip(aug.iter()).take(n) {
                for (mv, av) in mr.iter_mut().zip(ar.iter()).take(n) {
                    *mv = av * h;
                }
            }
            expm(&m, n)
        };
        let e_tail = scaled(1.0 - f);
        let e_head = scaled(f);
        // Candidate lags: the kernel reaches u_{j−i} for a − 1 < i < a + len.
        // i32, not i64: the FPU converts 32-bit integers (an i64 ↔ f64
        // conversion is a library call, which the firmware's call-graph
        // check refuses on the sample path); a kernel spans a few samples.
        let i0 = fl as i32 - 1;
        let mut all = [[0.0f64; D]; U_TAPS + 2];
        for (k, g) in all.iter_mut().enumerate() {
            let i = f64::from(i0 + k as i32);
            for (piece, &(ts, te)) in splits.iter().enumerate() {
                let h = te - ts;
                if h <= 0.0 {
                    continue;
                }
                // Kernel argument at the piece's start, and which piece.
                let x0 = ts + i - a;
                let p = libm::floor(x0 + 0.5 * h);
                if p < 0.0 || p >= len {
                    continue;
                }
                let der = derivatives(&pieces[p as usize], x0);
                let e = if piece == 0 { &e_head } else { &e_tail };
                // Response over the piece: Σ_m G_m(h)·p^{(m)}(start).
                let mut v = [0.0f64; D];
                for (r, vr) in v.iter_mut().enumerate() {
                    for (m, dm) in der.iter().enumerate() {
                        *vr += e[r][D + m] * dm;
                    }
                }
                if piece == 0 {
                    // Carried through the rest of the interval: Φ(1 − f)·v.
                    for (r, gr) in g.iter_mut().enumerate() {
                        for (c, vc) in v.iter().enumerate() {
                            *gr += e_tail[r][c] * vc;
                        }
                    }
                } else {
                    for (gr, vr) in g.iter_mut().zip(v.iter()) {
                        *gr += vr;
                    }
                }
            }
        }
        let nonzero = |g: &[f64; D]| g.iter().any(|v| *v != 0.0);
        let start = all.iter().position(nonzero).unwrap_or(0);
        let end = all.iter().rposition(nonzero).map_or(start, |e| e + 1);
        let count = (end - start).min(U_TAPS);
        let mut gains = [[0.0f64; D]; U_TAPS];
        for (dst, src) in gains.iter_mut().zip(all.iter().skip(start)).take(count) {
            *dst = *src;
        }
        let first = (LAG + i0 + start as i32).clamp(0, (U_HIST - count) as i32) as usize;
        Self {
            gains,
            first,
            count,
        }
    }
}

#[cfg(test)]
#[path = "timing_tests.rs"]
mod tests;
