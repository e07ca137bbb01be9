//! The 1/Λ(s) filter bank that turns the held input u and the sampled output
//! y into the regressor Ψ of eq. 29, in scaled coordinates.
//!
//! For `D = 2n` (n modes) and Λ(s) = (s+λ)^D, eq. 28–29 need
//! s^k/Λ(s)·u for k = 0..D−2 and s^k/Λ(s)·y for k = 0..D−1. Each channel is
//! one D-state filter whose states are those signals.
//!
//! # Design
//! * **Normalized states.** State k is z_k = λ^{D−k}·s^k/Λ(s)·(v), so every
//!   state has an O(1) gain (the DC gain of z_0 is exactly 1). In these
//!   states A = λ·(shift; last row −C(D, j)) and B = λ·e_{D−1}: everything
//!   depends on λ·Ts only. Signals enter divided by their scales U0, Y0
//!   ([`SignalScales`]), so Ψ has O(1) entries in any units. The parameters
//!   seen by the update laws are therefore scaled too; [`Scaling`] maps them
//!   back to the paper's Θ (eq. 29).
//! * **Exact zero-order hold on u.** The DAC holds u between samples, so
//!   x⁺ = Φx + G₀u is exact.
//! * **The converters' timing on u** ([`FilterConfig::timing`],
//!   [`OutputTiming`]). A real ADC's y_k is a sinc³ average of the last
//!   three periods and the DAC takes u_k late; both are LTI, so the bank
//!   drives its u channel with the same timing (the sinc³ of a held
//!   staircase, delayed, is a cubic B-spline of the samples): exact under
//!   the hold, up to five gain vectors on u. Chosen over a pure fractional
//!   delay (two gain vectors) by measurement against the exact sinc3 rig,
//!   20 s, noise-free (`cargo run --release -p host-tests --example
//!   adc_delay`): the sinc³ kernel leaves the smallest residual bias of ω,
//!   ζ, on the paper's plant and on a 155/1520 rad/s one, where the delay
//!   exceeds the 1e-3 acceptance (BENCHMARKS.md, "Converter timing:
//!   simulated sinc3 on/off × compensation on/off"; its cost on the
//!   Cortex-M4F step and its state: "Firmware on the emulated board",
//!   "Memory: estimator state"). Default off: results unchanged bit for
//!   bit.
//! * **Interpolating hold on y.** y is *sampled*, not held. Over
//!   [t_k, t_{k+1}] the filter is driven by the polynomial p through nearby
//!   samples, integrated exactly: x⁺ = Φx + Σ_m G_m·p^{(m)}(0), with G_m the
//!   response to τ^m/m!. The taps are folded into one gain vector per
//!   window sample at start-up. The hold order sets the floor on ζ2 of the
//!   paper's plant after 20 s (BENCHMARKS.md, "y-hold order", for the
//!   zero-order, first-order, cubic (y_{k−1}..y_{k+2}) and quintic holds); the unit test
//!   `hold_order_sets_accuracy` pins the ordering. The cubic's error grows as (ωTs)⁴ and
//!   reaches 1.2e-3 on a 1520 rad/s mode, so the default is the quintic
//!   through y_{k−2}..y_{k+3} ([`OutputHold::Quintic`], (ωTs)⁶). The
//!   look-ahead costs two samples of lag; the u channel is delayed to match,
//!   so Ψ and y stay aligned in time.
//! * Φ and the G_m come from one matrix exponential of an augmented system
//!   (`linalg::expm`, computed in f64 at construction, never Euler).
//!
//! # Sensor output kinds
//! A strain gauge or a displacement sensor reads the modes' response
//! B(s)/A(s) (relative degree 2, eq. 25); a velocity sensor reads its
//! derivative s·B/A, an accelerometer s²·B/A (numerator and denominator of
//! the same degree: a direct term). With r = 2 − relative degree
//! ([`FilterConfig::output`]) eq. 28 becomes
//! s^D/Λ·y = −Σ a_k·s^k/Λ·y + Σ b_k·s^{k+r}/Λ·u, so the regressor's u entries
//! are the states z_{D−2+r} … z_r: the same number of parameters (B and A
//! keep their meaning, and so do ω, ζ and b̄ of eqs. 30–32), only the u
//! states shift. z_{D−1} is the filter's top state; z_D = σ^D/Λ̃(σ)·u =
//! u − Σ_k C(D, k)·z_k (σ = s/λ, Λ̃ = (σ + 1)^D) is the input itself less
//! the states: the input as the direct term sees it when y_{n−2} is read —
//! held from the sample before (y is read before the new input is
//! applied), or through the converters' timing kernel
//! (`OutputTiming::direct_weights`).
//!
//! An accelerometer's y jumps where the held u does (by the direct term's
//! share of the jump), while the interpolating hold on y assumes a smooth
//! signal: the equation-error laws then carry a discretisation error that
//! grows with the input's jumps (a square wave or a PRBS more than a
//! multisine). The robust estimator's output error compares samples with
//! samples and has none (`estimator::robust`).

use crate::linalg::{dot, expm, solve_dense, Block, EXPM_MAX};
use crate::model::binomial;
use crate::scalar::compensated::CompensatedArray;
use crate::scalar::Real;
use beam_protocol::OutputKind;

mod timing;

pub(crate) use timing::{InputTaps, U_HIST, U_TAPS};

pub use timing::{OutputAverage, OutputTiming};

/// How the sampled output y is interpolated between samples for the filter.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum OutputHold {
    /// y held constant over the sample interval (biased: ~1.2% on ζ2).
    ZeroOrder,
    /// Straight line from y_k to y_{k+1} (~2e-4 on ζ2).
    FirstOrder,
    /// Cubic through y_{k−1}, y_k, y_{k+1}, y_{k+2} (~2e-8 on ζ2 for the
    /// paper's plant; error grows as (ωTs)⁴).
    Cubic,
    /// Quintic through y_{k−2} … y_{k+3} (error grows as (ωTs)⁶: needed
    /// when a mode sits above ~1000 rad/s at Ts = 0.1 ms).
    #[default]
    Quintic,
}

impl OutputHold {
    /// Interpolation nodes τ (in samples, relative to t_k) of this hold.
    fn nodes(self) -> &'static [f64] {
        match self {
            Self::ZeroOrder => &[0.0],
            Self::FirstOrder => &[0.0, 1.0],
            Self::Cubic => &[-1.0, 0.0, 1.0, 2.0],
            Self::Quintic => &[-2.0, -1.0, 0.0, 1.0, 2.0, 3.0],
        }
    }

    /// Matrix M with p^{(m)}(0) = Σ_i M[m][i]·y(τ_i) for the interpolating
    /// polynomial p through the nodes, expressed on the window
    /// y_{k−2} … y_{k+3} (columns) — unused window entries get zero weight.
    fn derivative_weights(self) -> [[f64; WINDOW]; WINDOW] {
        let nodes = self.nodes();
        let q = nodes.len();
        // Vandermonde V[i][m] = τ_i^m; coefficients c = V⁻¹y; p^{(m)}(0) = m!·c_m.
        let mut v = [[0.0f64; EXPM_MAX]; EXPM_MAX];
        for (i, &t) in nodes.iter().enumerate() {
            // τ^m by repeated multiplication: exact for these small
            // integers (as libm's `pow` was), without linking `pow`.
            let mut p = 1.0;
            for m in 0..q {
                v[i][m] = p;
                p *= t;
            }
        }
        let mut out = [[0.0f64; WINDOW]; WINDOW];
        for (i, &t) in nodes.iter().enumerate() {
            // Column i of V⁻¹: solve V·c = e_i.
            let mut e = [0.0f64; EXPM_MAX];
            e[i] = 1.0;
            // Nodes are distinct, so V is invertible.
            let c = solve_dense(&v, &e, q).unwrap_or([0.0; EXPM_MAX]);
            let col = (t + 2.0) as usize;
            let mut fact = 1.0;
            for m in 0..q {
                if m > 0 {
                    fact *= m as f64;
                }
                out[m][col] = fact * c[m];
            }
        }
        out
    }
}

/// Length of the y window (y_{k−2} … y_{k+3}).
pub(crate) const WINDOW: usize = 6;

/// Signal scales: u and y enter the filters as u/U0 and y/Y0.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct SignalScales {
    /// U0, in the units of u (e.g. volts): typically the excitation amplitude.
    pub u_scale: f64,
    /// Y0, in the units of y: typically the expected output amplitude.
    pub y_scale: f64,
}

impl Default for SignalScales {
    fn default() -> Self {
        Self {
            u_scale: 1.0,
            y_scale: 1.0,
        }
    }
}

/// Errors in a filter-bank configuration.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum FilterConfigError {
    /// Ts must be positive and finite.
    SamplePeriod,
    /// λ must be positive and finite.
    Lambda,
    /// Signal scales must be positive and finite.
    Scale,
    /// `NP` must equal 2·D − 1 and D must be even, 2..=6.
    Dimensions,
    /// The output timing's delay is not finite or outside its range
    /// ([`OutputTiming::is_valid`]).
    Timing,
}

impl core::fmt::Display for FilterConfigError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(match self {
            Self::SamplePeriod => "invalid sample period ts_s: must be positive and finite",
            Self::Lambda => "invalid filter pole lambda_rad_s: must be positive and finite",
            Self::Scale => "invalid signal scale u_scale or y_scale: must be positive and finite",
            Self::Dimensions => "invalid filter sizes: need NP = 2*D - 1 with D even, 2..=6",
            Self::Timing => {
                "invalid output timing: delay_samples must be finite, 0..=3 (1..=3 with Sinc3)"
            }
        })
    }
}

impl core::error::Error for FilterConfigError {}

/// Configuration shared by the filter bank and the scaling of Θ.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct FilterConfig {
    /// Sample period Ts in seconds.
    pub ts_s: f64,
    /// Filter pole λ in rad/s (Λ(s) = (s+λ)^D).
    pub lambda_rad_s: f64,
    /// Input/output scales.
    pub scales: SignalScales,
    /// Interpolation of y.
    pub hold: OutputHold,
    /// How the measured y lags the input (the converters' timing), modelled
    /// on the u channel; [`OutputTiming::IDEAL`] by default.
    pub timing: OutputTiming,
    /// What the sensor measures ([`OutputKind`]): the regressor's u
    /// entries are s^{k+r}/Λ·u for the numerator s^r·B(s) of the model
    /// G = s^r·B/A (r = 2 − relative degree; see *Sensor output kinds* in
    /// the module docs). [`OutputKind::Strain`] (r = 0, eq. 29) by default.
    pub output: OutputKind,
}

impl Default for FilterConfig {
    /// The paper's simulation (Section IV.A): Ts = 0.1 ms, λ = 100 rad/s.
    fn default() -> Self {
        Self {
            ts_s: 1e-4,
            lambda_rad_s: 100.0,
            scales: SignalScales::default(),
            hold: OutputHold::Quintic,
            timing: OutputTiming::IDEAL,
            output: OutputKind::Strain,
        }
    }
}

impl FilterConfig {
    /// Check the numbers and the dimensions `D`, `NP`.
    pub fn validate(&self, d: usize, np: usize) -> Result<(), FilterConfigError> {
        if !(self.ts_s > 0.0 && self.ts_s.is_finite()) {
            return Err(FilterConfigError::SamplePeriod);
        }
        if !(self.lambda_rad_s > 0.0 && self.lambda_rad_s.is_finite()) {
            return Err(FilterConfigError::Lambda);
        }
        let s = self.scales;
        if !(s.u_scale > 0.0 && s.u_scale.is_finite() && s.y_scale > 0.0 && s.y_scale.is_finite()) {
            return Err(FilterConfigError::Scale);
        }
        if d % 2 != 0 || d < 2 || d + WINDOW > EXPM_MAX || np != 2 * d - 1 {
            return Err(FilterConfigError::Dimensions);
        }
        if !self.timing.is_valid() {
            return Err(FilterConfigError::Timing);
        }
        Ok(())
    }
}

/// Map between the scaled parameters θ_s used internally and the paper's Θ.
///
/// With φ_j = E_j·Ψ_j (E_j = λ^{D−k−r}/U0 for the u entry of b_k, which
/// multiplies s^{k+r}/Λ·u for the output kind's r, [`FilterConfig::output`];
/// λ^{D−k}/Y0 for the y entry of power k) and y/Y0 = θ_sᵀφ, we have
/// Θ_j = Y0·E_j·θ_s,j.
/// The same E maps the gains: H_s = E⁻¹HE⁻¹ (so H_s⁻¹ = E·H⁻¹·E),
/// P_s = E·P·E, and a gradient gain Γ1,s = E⁻¹Γ1E⁻¹.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Scaling<const NP: usize> {
    /// E_j of the doc above.
    pub e: [f64; NP],
    /// Y0.
    pub y_scale: f64,
}

impl<const NP: usize> Scaling<NP> {
    /// Build from a configuration (D = (NP+1)/2).
    pub fn new(cfg: &FilterConfig) -> Self {
        let d = NP.div_ceil(2);
        let mut e = [0.0; NP];
        let lam = cfg.lambda_rad_s;
        let r = cfg.output.numerator_shift();
        // u entries: b_{D−2} … b_0, on the states of powers D−2+r … r.
        for (j, ej) in e.iter_mut().enumerate().take(d - 1) {
            let k = d - 2 - j;
            *ej = libm::pow(lam, d.saturating_sub(k + r) as f64) / cfg.scales.u_scale;
        }
        // y entries: powers D−1 … 0.
        for j in 0..d {
            let k = d - 1 - j;
            e[d - 1 + j] = libm::pow(lam, (d - k) as f64) / cfg.scales.y_scale;
        }
        Self {
            e,
            y_scale: cfg.scales.y_scale,
        }
    }

    /// θ_s → Θ (physical units, eq. 29).
    pub(crate) fn to_physical<T: Real>(self, theta_s: &[T; NP]) -> [T; NP] {
        let mut out = [T::ZERO; NP];
        for j in 0..NP {
            out[j] = theta_s[j] * T::from_f64(self.y_scale * self.e[j]);
        }
        out
    }

    /// A diagonal gain given in physical units (H, Γ1, Γ2 of eqs. 37, 47,
    /// 48) in scaled coordinates: G_s = E⁻¹·G·E⁻¹, i.e. g_j/E_j².
    pub(crate) fn gain_to_scaled(&self, gain_physical: &[f64; NP]) -> [f64; NP] {
        let mut g = [0.0; NP];
        for j in 0..NP {
            g[j] = gain_physical[j] / (self.e[j] * self.e[j]);
        }
        g
    }

    /// Θ → θ_s.
    pub fn to_scaled<T: Real>(&self, theta: &[T; NP]) -> [T; NP] {
        let mut out = [T::ZERO; NP];
        for j in 0..NP {
            out[j] = theta[j] / T::from_f64(self.y_scale * self.e[j]);
        }
        out
    }
}

/// Σ x_i·y_i summed from the first product (not from zero, which costs an
/// instruction per dot product and changes nothing but the sign of an
/// exact zero). Used on the `f32` path; the `f64` path keeps
/// `linalg::dot` so its results stay bit-identical.
#[inline(always)]
fn dot_from_first<T: Real, const N: usize>(x: &[T; N], y: &[T; N]) -> T {
    let mut terms = x.iter().zip(y.iter()).map(|(a, b)| *a * *b);
    let first = terms.next().unwrap_or(T::ZERO);
    terms.fold(first, |s, t| s + t)
}

/// One regressor sample: φ (scaled Ψ) and the matching scaled output y/Y0.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Regressor<T, const NP: usize> {
    /// φ = E·Ψ (see [`Scaling`]), rounded to working precision.
    pub phi: [T; NP],
    /// Rounding error of `phi` (φ ≈ phi + phi_lo to about twice the working
    /// precision) when `T::COMPENSATED`; zero otherwise.
    pub phi_lo: [T; NP],
    /// y/Y0 at the same instant.
    pub y: T,
}

/// Exact discretization (in `f64`) of the normalized filter bank for a
/// general monic denominator: the states z_k = ρ^{D−k}·s^k/Â(s)·v with
/// Â(s) = s^D + Σ_k â_k s^k given by its normalized coefficients
/// c_k = â_k/ρ^{D−k} (k = 0..D−1). For Λ(s) = (s+λ)^D and ρ = λ, c_k is the
/// binomial C(D, k) ([`FilterBank`]); the re-centred banks of
/// `estimator::robust` pass the current estimate's denominator.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct FilterMatrices<const D: usize> {
    /// Φ − I, Φ = e^{A·Ts}.
    pub phi_minus_i: [[f64; D]; D],
    /// Zero-order-hold input gain (held u).
    pub gain_u: [f64; D],
    /// Gains on y_{k−2} … y_{k+3} for the interpolating hold on a sampled
    /// signal.
    pub taps_y: [[f64; D]; WINDOW],
}

impl<const D: usize> FilterMatrices<D> {
    /// Discretize for normalized coefficients `c` and ρ·Ts = `rho_ts`.
    /// The caller validates D (D + [`WINDOW`] ≤ `EXPM_MAX`).
    pub(crate) fn new(c: &[f64; D], rho_ts: f64, hold: OutputHold) -> Self {
        let (m, n) = Self::augmented(c, rho_ts);
        let e = expm(&m, n);
        let mut g = [[0.0f64; D]; WINDOW];
        let mut phi_minus_i = [[0.0f64; D]; D];
        for i in 0..D {
            for j in 0..D {
                let identity = if i == j { 1.0 } else { 0.0 };
                phi_minus_i[i][j] = e[i][j] - identity;
            }
            for (mm, gm) in g.iter_mut().enumerate() {
                gm[i] = e[i][D + mm];
            }
        }
        // x⁺ = Φx + Σ_m G_m p^{(m)}(0), p^{(m)}(0) = Σ_tap M[m][tap]·y_tap.
        let deriv = hold.derivative_weights();
        let mut taps_y = [[0.0f64; D]; WINDOW];
        for (tap, t) in taps_y.iter_mut().enumerate() {
            for i in 0..D {
                let mut s = 0.0;
                for mm in 0..WINDOW {
                    s += deriv[mm][tap] * g[mm][i];
                }
                t[i] = s;
            }
        }
        Self {
            phi_minus_i,
            gain_u: g[0],
            taps_y,
        }
    }

    /// The augmented system in τ = t/Ts and its size: [x; q0..q5],
    /// x' = ρTs(A_n x + e_{D−1} q0), q_m' = q_{m+1}; starting from
    /// q_m(0) = 1 drives x with τ^m/m!.
    pub(crate) fn augmented(c: &[f64; D], rho_ts: f64) -> (Block, usize) {
        let lt = rho_ts;
        let n = D + WINDOW;
        let mut m = [[0.0f64; EXPM_MAX]; EXPM_MAX];
        for i in 0..D - 1 {
            m[i][i + 1] = lt;
        }
        for j in 0..D {
            m[D - 1][j] = -lt * c[j];
        }
        m[D - 1][D] = lt;
        for q in 0..WINDOW - 1 {
            m[D + q][D + q + 1] = 1.0;
        }
        (m, n)
    }
}

/// The two D-state filters (u and y) with their delay lines.
///
/// `D` is the filter order 2n; `NP = 2D − 1` is the length of Ψ.
#[derive(Debug, Clone)]
pub struct FilterBank<T, const D: usize, const NP: usize> {
    /// Φ − I (Φ = e^{A·Ts} is within λTs ≈ 0.01 of I: storing the
    /// difference keeps its full precision in `f32`).
    phi_minus_i: [[T; D]; D],
    /// Gains on u_{n−3−i} over the interval integrated at push n: one (the
    /// zero-order hold) for [`OutputTiming::IDEAL`], up to [`U_TAPS`]
    /// for a delayed or averaged output (`timing`).
    taps_u: [[T; D]; U_TAPS],
    /// Where the taps read `u_hist` (tap k: `u_hist[taps_u_first + k]`),
    /// and the number of nonzero taps (1: only `taps_u[0]` is read).
    taps_u_first: u8,
    taps_u_count: u8,
    /// Gains on y_{k−2} … y_{k+3}.
    taps_y: [[T; D]; WINDOW],
    inv_u_scale: T,
    inv_y_scale: T,
    /// Filter states (double-word when `T::COMPENSATED`: the per-sample
    /// increment is only ~λTs of the state, so the addition, not the
    /// increment, carries the rounding error).
    x_u: CompensatedArray<T, D>,
    x_y: CompensatedArray<T, D>,
    /// y window y_{k−2} … y_{k+3} (scaled).
    y_win: [T; WINDOW],
    /// u history u_n, u_{n−1}, … (scaled; newest first).
    u_hist: [T; U_HIST],
    /// r of the output kind: the u entries are the states z_{D−2+r} … z_r
    /// (module docs, *Sensor output kinds*).
    shift: u8,
    /// For r = 2 (z_D, the direct term): the weights of the u history
    /// that give the input at t_{n−2} as y_{n−2} sees it, and C(D, k).
    direct_u: [T; U_HIST],
    binomial: [T; D],
}

impl<T: Real, const D: usize, const NP: usize> FilterBank<T, D, NP> {
    /// Discretize Λ(s) for the given configuration.
    pub fn new(cfg: &FilterConfig) -> Result<Self, FilterConfigError> {
        cfg.validate(D, NP)?;
        let mut c = [0.0f64; D];
        for (j, cj) in c.iter_mut().enumerate() {
            *cj = binomial(D, j);
        }
        let rho_ts = cfg.lambda_rad_s * cfg.ts_s;
        let m = FilterMatrices::<D>::new(&c, rho_ts, cfg.hold);
        let (aug, n) = FilterMatrices::<D>::augmented(&c, rho_ts);
        let taps = InputTaps::<D>::new(&aug, n, &cfg.timing);
        // One tap: at its own history index. More: a window of U_TAPS
        // history entries from `start` (unused taps zero), so that the loop
        // has a fixed length.
        let start = if taps.count == 1 {
            taps.first
        } else {
            taps.first.min(U_HIST - U_TAPS)
        };
        let mut gains = [[0.0f64; D]; U_TAPS];
        for (g, t) in gains
            .iter_mut()
            .skip(taps.first - start)
            .zip(taps.gains.iter().take(taps.count))
        {
            *g = *t;
        }
        Ok(Self {
            phi_minus_i: m.phi_minus_i.map(|row| row.map(T::from_f64)),
            taps_u: gains.map(|row| row.map(T::from_f64)),
            // Both < U_HIST ≤ 255.
            taps_u_first: start as u8,
            taps_u_count: taps.count as u8,
            taps_y: m.taps_y.map(|row| row.map(T::from_f64)),
            inv_u_scale: T::from_f64(1.0 / cfg.scales.u_scale),
            inv_y_scale: T::from_f64(1.0 / cfg.scales.y_scale),
            x_u: CompensatedArray::default(),
            x_y: CompensatedArray::default(),
            y_win: [T::ZERO; WINDOW],
            u_hist: [T::ZERO; U_HIST],
            // 0, 1 or 2.
            shift: cfg.output.numerator_shift() as u8,
            direct_u: cfg.timing.direct_weights().map(T::from_f64),
            binomial: c.map(T::from_f64),
        })
    }

    /// Zero all states (the plant is assumed at rest before the first sample).
    pub fn reset(&mut self) {
        self.x_u = CompensatedArray::default();
        self.x_y = CompensatedArray::default();
        self.y_win = [T::ZERO; WINDOW];
        self.u_hist = [T::ZERO; U_HIST];
    }

    /// Push sample n: `u` is the input held over [t_n, t_{n+1}), `y` the
    /// output sampled at t_n (both in physical units). Returns the regressor
    /// at t_{n−2}: the quintic hold looks three samples ahead of the interval
    /// it integrates, [t_{n−3}, t_{n−2}].
    ///
    /// The caller must pass finite values (see `estimator::Identifier`, which
    /// screens inputs); with finite inputs this never panics.
    #[inline]
    pub fn push(&mut self, u: T, y: T) -> Regressor<T, NP> {
        // Shift the new sample (scaled) into the windows (by value: a
        // `copy_within` here costs a `memmove` call per sample).
        let w = self.y_win;
        self.y_win = core::array::from_fn(|k| match w.get(k + 1) {
            Some(&v) => v,
            None => y * self.inv_y_scale,
        });
        let h = self.u_hist;
        self.u_hist = core::array::from_fn(|k| match k.checked_sub(1) {
            Some(i) => h.get(i).copied().unwrap_or(T::ZERO),
            None => u * self.inv_u_scale,
        });
        // Advance both filters over [t_{n−3}, t_{n−2}]:
        // x ← x + ((Φ − I)x + Σ taps·y), the small increment summed last
        // (with the low word's share when compensated). One channel at a
        // time, so that few values are live at once (on a 32-register FPU
        // the interleaved form spilled).
        let mut dy = self.free_response(&self.x_y);
        for (i, d) in dy.iter_mut().enumerate() {
            for (tap, yv) in self.taps_y.iter().zip(self.y_win.iter()) {
                *d += tap[i] * *yv;
            }
        }
        for (i, d) in dy.iter().enumerate() {
            self.x_y.add(i, *d);
        }
        let mut du = self.free_response(&self.x_u);
        let start = usize::from(self.taps_u_first);
        if self.taps_u_count == 1 {
            // The zero-order hold (and integer point delays): one gain.
            let uv = self.u_hist.get(start).copied().unwrap_or(T::ZERO);
            for (d, gi) in du.iter_mut().zip(self.taps_u[0].iter()) {
                *d += *gi * uv;
            }
        } else if let Some(Ok(win)) = self
            .u_hist
            .get(start..start + U_TAPS)
            .map(<&[T; U_TAPS]>::try_from)
        {
            for (g, uv) in self.taps_u.iter().zip(win.iter()) {
                for (d, gi) in du.iter_mut().zip(g.iter()) {
                    *d += *gi * *uv;
                }
            }
        }
        for (i, d) in du.iter().enumerate() {
            self.x_u.add(i, *d);
        }
        self.regressor()
    }

    /// (Φ − I)·x for a double-word state x (its low word's share added
    /// when `T::COMPENSATED`).
    #[inline(always)]
    fn free_response(&self, x: &CompensatedArray<T, D>) -> [T; D] {
        let mut d = [T::ZERO; D];
        for (di, row) in d.iter_mut().zip(self.phi_minus_i.iter()) {
            if T::COMPENSATED {
                *di = dot_from_first(row, &x.hi) + dot_from_first(row, &x.lo);
            } else {
                *di = dot(row, &x.hi);
            }
        }
        d
    }

    /// All D states of the input filter at t_{n−2} (z_0 … z_{D−1} of u/U0,
    /// lowest power first; the regressor holds z_0 … z_{D−2}), e.g. for a
    /// model with a numerator of full degree (`estimator::feedthrough`).
    pub fn input_states(&self) -> [T; D] {
        self.x_u.hi
    }

    /// The input's states z_0 … z_D at t_{n−2} (high and low words), z_D
    /// being the direct term σ^D/Λ̃·u (module docs, *Sensor output
    /// kinds*).
    #[inline(always)]
    fn input_state(&self, k: usize) -> (T, T) {
        match (self.x_u.hi.get(k), self.x_u.lo.get(k)) {
            (Some(&hi), Some(&lo)) => (hi, lo),
            _ => {
                // u at t_{n−2} less Σ C(D, j)·z_j; the states' low words
                // go to the low word.
                let mut hi = T::ZERO;
                for (w, u) in self.direct_u.iter().zip(self.u_hist.iter()) {
                    hi += *w * *u;
                }
                let mut lo = T::ZERO;
                for ((c, h), l) in self
                    .binomial
                    .iter()
                    .zip(self.x_u.hi.iter())
                    .zip(self.x_u.lo.iter())
                {
                    hi -= *c * *h;
                    lo -= *c * *l;
                }
                (hi, lo)
            }
        }
    }

    /// The current regressor (φ at t_{n−2} and y_{n−2}/Y0).
    pub(crate) fn regressor(&self) -> Regressor<T, NP> {
        let mut phi = [T::ZERO; NP];
        let mut phi_lo = [T::ZERO; NP];
        // u entries: z_{D−2+r} … z_r; y entries: z_{D−1} … z_0 (eq. 29
        // order).
        let r = usize::from(self.shift);
        if r == 0 {
            for j in 0..D - 1 {
                phi[j] = self.x_u.hi[D - 2 - j];
                phi_lo[j] = self.x_u.lo[D - 2 - j];
            }
        } else {
            for j in 0..D - 1 {
                (phi[j], phi_lo[j]) = self.input_state(D - 2 - j + r);
            }
        }
        for j in 0..D {
            phi[D - 1 + j] = self.x_y.hi[D - 1 - j];
            phi_lo[D - 1 + j] = self.x_y.lo[D - 1 - j];
        }
        Regressor {
            phi,
            phi_lo,
            y: self.y_win[3],
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dc_gain_of_lowest_state_is_one() {
        let cfg = FilterConfig::default();
        let mut fb = FilterBank::<f64, 4, 7>::new(&cfg).unwrap();
        let mut r = fb.push(0.0, 0.0);
        for _ in 0..100_000 {
            r = fb.push(1.0, 1.0);
        }
        // Lowest-order normalized states → 1, derivatives → 0.
        assert!((r.phi[2] - 1.0).abs() < 1e-9, "{:?}", r.phi);
        assert!((r.phi[6] - 1.0).abs() < 1e-9);
        assert!(r.phi[3].abs() < 1e-9 && r.phi[0].abs() < 1e-9);
    }

    #[test]
    fn sine_response_matches_analytic_filter_to_cubic_hold_accuracy() {
        // Drive y with sin(ωt); compare the steady-state z_k with
        // λ^{D−k}(jω)^k/(jω+λ)^D.
        let cfg = FilterConfig::default();
        let mut fb = FilterBank::<f64, 4, 7>::new(&cfg).unwrap();
        let w = 245.0f64;
        let ts = cfg.ts_s;
        let steps = 40_000;
        let mut r = fb.push(0.0, 0.0);
        for k in 1..=steps {
            r = fb.push(0.0, libm::sin(w * ts * k as f64));
        }
        // Regressor time is t_{steps−2}.
        let t = ts * (steps - 2) as f64;
        let lam = cfg.lambda_rad_s;
        for k in 0..4 {
            // H(jω) = λ^{4−k}(jω)^k/(jω+λ)^4.
            let mag = libm::pow(lam, (4 - k) as f64) * libm::pow(w, k as f64)
                / libm::pow(w * w + lam * lam, 2.0);
            let phase = k as f64 * core::f64::consts::FRAC_PI_2 - 4.0 * libm::atan2(w, lam);
            let expect = mag * libm::sin(w * t + phase);
            let got = r.phi[3 + (3 - k)];
            assert!(
                (got - expect).abs() < 1e-9,
                "k={k} got {got} expect {expect}"
            );
        }
    }

    #[test]
    fn hold_order_sets_accuracy() {
        // First-order hold is measurably worse than cubic on the same sine.
        let w = 245.0f64;
        let err = |hold| {
            let cfg = FilterConfig {
                hold,
                ..FilterConfig::default()
            };
            let mut fb = FilterBank::<f64, 4, 7>::new(&cfg).unwrap();
            let mut r = fb.push(0.0, 0.0);
            let steps = 40_000;
            for k in 1..=steps {
                r = fb.push(0.0, libm::sin(w * 1e-4 * k as f64));
            }
            let t = 1e-4 * (steps - 2) as f64;
            let mag = 1e8 / libm::pow(w * w + 1e4, 2.0);
            let expect = mag * libm::sin(w * t - 4.0 * libm::atan2(w, 100.0));
            (r.phi[6] - expect).abs()
        };
        let quintic = err(OutputHold::Quintic);
        let cubic = err(OutputHold::Cubic);
        assert!(quintic * 10.0 < cubic, "quintic {quintic} cubic {cubic}");
        let linear = err(OutputHold::FirstOrder);
        let zoh = err(OutputHold::ZeroOrder);
        assert!(cubic * 100.0 < linear, "cubic {cubic} linear {linear}");
        assert!(linear * 10.0 < zoh, "linear {linear} zoh {zoh}");
    }

    #[test]
    fn scaling_round_trip_and_bad_config() {
        let cfg = FilterConfig {
            scales: SignalScales {
                u_scale: 0.1,
                y_scale: 1e-3,
            },
            ..FilterConfig::default()
        };
        let s = Scaling::<7>::new(&cfg);
        let th = [13.02, -1180.0, -1.11e6, 334.0, 0.0, 3.8e6, 7.7e6];
        let back = s.to_physical(&s.to_scaled(&th));
        for i in 0..7 {
            assert!((back[i] - th[i]).abs() <= 1e-12 * th[i].abs());
        }
        let bad = FilterConfig {
            lambda_rad_s: -1.0,
            ..cfg
        };
        assert_eq!(
            FilterBank::<f64, 4, 7>::new(&bad).err(),
            Some(FilterConfigError::Lambda)
        );
        assert_eq!(
            FilterBank::<f64, 4, 6>::new(&cfg).err(),
            Some(FilterConfigError::Dimensions)
        );
    }
}

#[cfg(test)]
mod output_kind_tests {
    use super::*;
    use crate::excitation::SquareWave;
    use crate::model::ModalParams;
    use crate::rig::ModalPlant;

    /// Largest |y/Y0 − θᵀφ| of the true Θ over 2 s for a sensor of kind
    /// `output`, under a square wave or a sum of sines.
    fn equation_error(output: OutputKind, square: bool) -> f64 {
        let mp = ModalParams::new(&[50.0, 280.0], &[0.02, 0.015], &[12.0, 30.0], None).unwrap();
        let mut tf = mp.transfer_function();
        tf.output = output;
        let cfg = FilterConfig {
            lambda_rad_s: 120.0,
            output,
            ..FilterConfig::default()
        };
        let mut th = [0.0; 7];
        tf.to_theta(cfg.lambda_rad_s, &mut th).unwrap();
        let theta_s = Scaling::<7>::new(&cfg).to_scaled(&th);
        let mut plant = ModalPlant::<f64>::from_modal(&mp, cfg.ts_s)
            .unwrap()
            .with_output(output)
            .unwrap();
        let mut bank = FilterBank::<f64, 4, 7>::new(&cfg).unwrap();
        let mut sq = SquareWave::<f64>::paper();
        let mut worst = 0.0f64;
        let mut size = 0.0f64;
        for k in 0..20_000 {
            let t = k as f64 * cfg.ts_s;
            let u = if square {
                sq.next_sample()
            } else {
                (2.0 * 9.0 * t).sin() + 0.7 * (2.0 * 47.0 * t).sin() + 0.5 * (2.0 * 170.0 * t).sin()
            };
            let y = plant.sample(u);
            let r = bank.push(u, y);
            if k > 100 {
                let e = r.y - theta_s.iter().zip(&r.phi).map(|(a, b)| a * b).sum::<f64>();
                worst = worst.max(e.abs());
                size = size.max(r.y.abs());
            }
        }
        worst / size
    }

    /// The true Θ satisfies the regression for every kind of sensor, up to
    /// the interpolating hold's error on y (module docs, *Sensor output
    /// kinds*): a strain output is smooth to its second derivative, a
    /// velocity output has kinks and an acceleration output jumps where the
    /// held u steps, so the error grows by orders of magnitude (measured:
    /// 8e-11, 7e-6, 2.5e-3 of max |y/Y0| under three sines; 6e-9, 8e-6,
    /// 7.7e-3 under a square wave).
    #[test]
    fn the_regression_holds_for_each_output_kind() {
        let bound = |o| match o {
            OutputKind::Strain => 1e-7,
            OutputKind::Velocity => 2e-5,
            OutputKind::Acceleration => 2e-2,
        };
        for output in OutputKind::ALL {
            for square in [false, true] {
                let e = equation_error(output, square);
                assert!(e < bound(output), "{output} square {square}: {e:e}");
            }
        }
        // The acceleration output's error is the interpolation of its
        // jumps, not a wrong direct term: smooth drive, 300× the velocity's.
        assert!(equation_error(OutputKind::Acceleration, false) > 1e-4);
    }
}
