//! Exact discrete simulator of the modal beam model (eq. 22–23) under a
//! zero-order-held input: the simulated rig of the host tests and of the
//! emulated firmware.
//!
//! Each mode i is η_i'' + 2ζ_iω_iη_i' + ω_i²η_i = g_i·u, and the output is
//! y = Σ_i (α_i·η_i + β_i·η_i'). With g = b̄, α = C̄ (eq. 24), β = 0 this is
//! the paper's model; the velocity weights β let any strictly proper
//! numerator of degree ≤ 2n−1 be represented, e.g. the paper's simulation
//! plant, whose numerator (eq. 46) is not exactly of the form (26).
//!
//! # Design
//! Modes are simulated separately (block-diagonal, 2×2 each), each
//! discretized once by the matrix exponential of [[A·Ts, B·Ts], [0, 0]], so
//! the simulation is exact for a held input at any Ts and ω·Ts. The outputs
//! are the samples y(t_k) — what an ADC sees.
//!
//! A velocity or acceleration sensor ([`ModalPlant::with_output`]) reads
//! the first or second derivative of that output, s·G or s²·G: from the
//! state and the input held before the sample (the sample is read before
//! the new input is applied), y(t_k) = o·[η, η'] + o_u·u_{k−1} per mode,
//! with η'' = g·u − 2ζωη' − ω²η and, under the hold, η''' = −2ζωη'' − ω²η'.

use crate::linalg::{expm, solve_dense, EXPM_MAX};
use crate::model::{ModalParams, TransferFunction, MAX_MODES, MAX_ORDER};
use crate::scalar::Real;
use beam_protocol::OutputKind;

/// Invalid plant description.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum PlantError {
    /// Number of modes outside 1..=MAX_MODES or slice lengths disagree.
    Dimensions,
    /// ω ≤ 0, ζ < 0, Ts ≤ 0 or a non-finite number.
    Value,
    /// The numerator cannot be expressed on these modes (repeated modes).
    Numerator,
}

impl core::fmt::Display for PlantError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Self::Dimensions => write!(
                f,
                "invalid plant dimensions: mode count must be 1..={MAX_MODES} and the slice lengths must agree"
            ),
            Self::Value => f.write_str(
                "invalid plant value: need omega_rad_s > 0, zeta >= 0, ts_s > 0, all finite",
            ),
            Self::Numerator => {
                f.write_str("numerator cannot be expressed on these modes (repeated modes)")
            }
        }
    }
}

impl core::error::Error for PlantError {}

/// One mode's exact discretization and state.
#[derive(Debug, Clone, Copy, PartialEq)]
struct DiscreteMode<T> {
    phi: [[T; 2]; 2],
    gamma: [T; 2],
    /// Output weights on [η, η'] for the plant's output kind.
    out: [T; 2],
    /// Output weight on the held input (velocity, acceleration outputs).
    out_u: T,
    x: [T; 2],
}

/// One mode's continuous description: η'' + 2ζωη' + ω²η = g·u, its
/// output contribution `pos`·η + `vel`·η'.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub(crate) struct ModeSpec {
    pub omega: f64,
    pub zeta: f64,
    pub gain: f64,
    pub pos: f64,
    pub vel: f64,
}

/// An `n`-mode beam simulated exactly under a held input.
#[derive(Debug, Clone, PartialEq)]
pub struct ModalPlant<T> {
    modes: usize,
    m: [DiscreteMode<T>; MAX_MODES],
    /// The continuous modes and the sample period (for
    /// [`super::timing::TimedPlant`], which discretizes them its own way).
    spec: [ModeSpec; MAX_MODES],
    ts_s: f64,
    /// What the sensor reads: the output (strain), its first or its second
    /// derivative.
    output: OutputKind,
    /// The input held since the last sample (a velocity or acceleration
    /// output reads it).
    held: T,
}

impl<T: Real> ModalPlant<T> {
    /// The paper's model (23): input gains b̄_i, output weights C̄.
    pub fn from_modal(p: &ModalParams<f64>, ts_s: f64) -> Result<Self, PlantError> {
        let n = p.modes;
        Self::build(
            n,
            &p.omega_rad_s,
            &p.zeta,
            &p.bbar,
            &p.output_weight,
            &[0.0; MAX_MODES],
            ts_s,
        )
    }

    /// Modes ω_i, ζ_i with an arbitrary numerator `b = [b_{2n−2}, …, b_0]`
    /// (the transfer function B(s)/Π q_i(s)), e.g. the paper's eq. 46.
    pub fn with_numerator(
        omega_rad_s: &[f64],
        zeta: &[f64],
        b: &[f64],
        ts_s: f64,
    ) -> Result<Self, PlantError> {
        let n = omega_rad_s.len();
        if n == 0 || n > MAX_MODES || zeta.len() != n || b.len() != 2 * n - 1 {
            return Err(PlantError::Dimensions);
        }
        let d = 2 * n;
        let ones = [1.0; MAX_MODES];
        let ones_n = ones.get(..n).ok_or(PlantError::Dimensions)?;
        // Unknowns [α_1..α_n, β_1..β_n]; equations: coefficients of s^{d−1}..s^0.
        let mut a = [[0.0f64; EXPM_MAX]; EXPM_MAX];
        let mut rhs = [0.0f64; EXPM_MAX];
        let unit = ModalParams::new(omega_rad_s, zeta, ones_n, Some(ones_n))
            .ok_or(PlantError::Dimensions)?;
        for i in 0..n {
            // Π_{j≠i} q_j, 2n−1 coefficients, highest first.
            let mut p = [0.0f64; MAX_ORDER + 1];
            p[0] = 1.0;
            let mut len = 1;
            for j in 0..n {
                if j != i {
                    len = crate::model::poly_mul_quadratic(&mut p, len, &unit.mode_poly(j));
                }
            }
            for (k, pk) in p.iter().enumerate().take(len) {
                // α_i·p contributes to powers 2n−2−k → row 1 + k.
                if let Some(e) = a.get_mut(1 + k).and_then(|r| r.get_mut(i)) {
                    *e += pk;
                }
                // β_i·s·p contributes to powers 2n−1−k → row k.
                if let Some(e) = a.get_mut(k).and_then(|r| r.get_mut(n + i)) {
                    *e += pk;
                }
            }
        }
        for (r, bk) in rhs.iter_mut().skip(1).zip(b) {
            *r = *bk;
        }
        let x = solve_dense(&a, &rhs, d).ok_or(PlantError::Numerator)?;
        let mut pos = [0.0; MAX_MODES];
        let mut vel = [0.0; MAX_MODES];
        for (i, (p, v)) in pos.iter_mut().zip(vel.iter_mut()).enumerate().take(n) {
            *p = x.get(i).copied().unwrap_or(0.0);
            *v = x.get(n + i).copied().unwrap_or(0.0);
        }
        let mut w = [0.0; MAX_MODES];
        let mut z = [0.0; MAX_MODES];
        for ((wo, zo), (wi, zi)) in w
            .iter_mut()
            .zip(z.iter_mut())
            .zip(omega_rad_s.iter().zip(zeta))
        {
            *wo = *wi;
            *zo = *zi;
        }
        Self::build(n, &w, &z, &ones, &pos, &vel, ts_s)
    }

    /// The first `n` entries of each array describe the modes.
    fn build(
        n: usize,
        omega: &[f64; MAX_MODES],
        zeta: &[f64; MAX_MODES],
        gain: &[f64; MAX_MODES],
        pos: &[f64; MAX_MODES],
        vel: &[f64; MAX_MODES],
        ts: f64,
    ) -> Result<Self, PlantError> {
        if n == 0 || n > MAX_MODES {
            return Err(PlantError::Dimensions);
        }
        if !(ts > 0.0 && ts.is_finite()) {
            return Err(PlantError::Value);
        }
        let zero = DiscreteMode {
            phi: [[T::ZERO; 2]; 2],
            gamma: [T::ZERO; 2],
            out: [T::ZERO; 2],
            out_u: T::ZERO,
            x: [T::ZERO; 2],
        };
        let mut m = [zero; MAX_MODES];
        let mut spec = [ModeSpec::default(); MAX_MODES];
        let params = omega.iter().zip(zeta).zip(gain).zip(pos).zip(vel);
        for ((mode, sp), ((((&w, &z), &g), &c), &v)) in
            m.iter_mut().zip(spec.iter_mut()).zip(params).take(n)
        {
            *sp = ModeSpec {
                omega: w,
                zeta: z,
                gain: g,
                pos: c,
                vel: v,
            };
            *mode = discretize(sp, ts, OutputKind::Strain)?;
        }
        Ok(Self {
            modes: n,
            m,
            spec,
            ts_s: ts,
            output: OutputKind::Strain,
            held: T::ZERO,
        })
    }

    /// The same beam read by a sensor of another kind: the output's first
    /// (velocity) or second (acceleration) derivative, s·G or s²·G (module
    /// docs). The state is kept.
    ///
    /// # Errors
    /// As construction (it cannot fail for a plant that was built).
    pub fn with_output(mut self, output: OutputKind) -> Result<Self, PlantError> {
        for (md, sp) in self.m.iter_mut().zip(self.spec.iter()).take(self.modes) {
            let x = md.x;
            *md = discretize(sp, self.ts_s, output)?;
            md.x = x;
        }
        self.output = output;
        Ok(self)
    }

    /// What the sensor reads ([`ModalPlant::with_output`]).
    pub(crate) fn output_kind(&self) -> OutputKind {
        self.output
    }

    /// Change the modes' ω and ζ (and, if given, their input gains b̄) with
    /// the beam's state continuous: each mode's (η, η') is kept and only its
    /// dynamics change from the next [`ModalPlant::advance`] on — a beam
    /// whose stiffness or damping changes (e.g. immersed in a liquid). The
    /// output weights are kept, and so are the input gains unless `bbar` is
    /// given (for a plant built [`ModalPlant::with_numerator`] the gains are
    /// 1 and the numerator lives in the output weights: keeping them keeps
    /// its modal residues' shape). Slices have one entry per mode.
    ///
    /// # Errors
    /// [`PlantError::Dimensions`] if a slice length is not the mode count,
    /// [`PlantError::Value`] for ω ≤ 0, ζ < 0 or a non-finite number; the
    /// plant is unchanged then.
    pub fn retune(
        &mut self,
        omega_rad_s: &[f64],
        zeta: &[f64],
        bbar: Option<&[f64]>,
    ) -> Result<(), PlantError> {
        let n = self.modes;
        if omega_rad_s.len() != n || zeta.len() != n || bbar.is_some_and(|b| b.len() != n) {
            return Err(PlantError::Dimensions);
        }
        let mut spec = self.spec;
        let mut m = self.m;
        for (i, (sp, md)) in spec.iter_mut().zip(m.iter_mut()).enumerate().take(n) {
            sp.omega = omega_rad_s.get(i).copied().unwrap_or(f64::NAN);
            sp.zeta = zeta.get(i).copied().unwrap_or(f64::NAN);
            if let Some(b) = bbar {
                sp.gain = b.get(i).copied().unwrap_or(f64::NAN);
            }
            let x = md.x;
            *md = discretize(sp, self.ts_s, self.output)?;
            md.x = x;
        }
        self.spec = spec;
        self.m = m;
        Ok(())
    }

    /// The continuous transfer function s^r·B(s)/A(s) being simulated (eq.
    /// 25–26): B/A = Σ_i g_i·(α_i + β_i·s)/(s² + 2ζ_iω_i·s + ω_i²), r of the
    /// output kind — the truth a run is scored against (after a
    /// [`ModalPlant::retune`], the new plant's).
    pub fn transfer_function(&self) -> TransferFunction<f64> {
        let n = self.modes;
        let mut tf = TransferFunction {
            modes: n,
            a: [0.0; MAX_ORDER],
            b: [0.0; MAX_ORDER],
            output: self.output,
        };
        let q = |sp: &ModeSpec| [1.0, 2.0 * sp.zeta * sp.omega, sp.omega * sp.omega];
        let mut den = [0.0f64; MAX_ORDER + 1];
        den[0] = 1.0;
        let mut len = 1;
        for sp in self.spec.iter().take(n) {
            len = crate::model::poly_mul_quadratic(&mut den, len, &q(sp));
        }
        let d = 2 * n;
        for (i, sp) in self.spec.iter().enumerate().take(n) {
            let mut p = [0.0f64; MAX_ORDER + 1];
            p[0] = 1.0;
            let mut plen = 1;
            for (j, other) in self.spec.iter().enumerate().take(n) {
                if j != i {
                    plen = crate::model::poly_mul_quadratic(&mut p, plen, &q(other));
                }
            }
            // g·(β s + α)·p: p has plen = 2n − 1 coefficients, highest first;
            // b has 2n − 1 entries [b_{2n−2}, …, b_0].
            for (k, pk) in p.iter().enumerate().take(plen) {
                // α·p_k → power 2n−2−k (index k); β·p_k → one power higher.
                if let Some(b) = tf.b.get_mut(k) {
                    *b += sp.gain * sp.pos * pk;
                }
                if k >= 1 {
                    if let Some(b) = tf.b.get_mut(k - 1) {
                        *b += sp.gain * sp.vel * pk;
                    }
                }
            }
        }
        for (a, dk) in tf.a.iter_mut().zip(den.iter().skip(1)).take(d) {
            *a = *dk;
        }
        tf
    }

    /// ω (rad/s) and ζ of mode `i` (in the order given at construction).
    pub fn mode(&self, i: usize) -> Option<(f64, f64)> {
        self.spec
            .get(i)
            .filter(|_| i < self.modes)
            .map(|s| (s.omega, s.zeta))
    }

    /// Sample period Ts (s).
    pub fn ts_s(&self) -> f64 {
        self.ts_s
    }

    /// Number of modes.
    pub fn modes(&self) -> usize {
        self.modes
    }

    /// The continuous modes (the first [`Self::modes`] entries).
    pub(crate) fn specs(&self) -> &[ModeSpec] {
        self.spec.get(..self.modes).unwrap_or(&[])
    }

    /// Each mode's state [η, η'] (the first [`Self::modes`] entries).
    pub(crate) fn states(&self) -> impl Iterator<Item = [T; 2]> + '_ {
        self.m.iter().take(self.modes).map(|md| md.x)
    }

    /// Output y at the current sample instant (read before the next input
    /// is applied).
    pub fn output(&self) -> T {
        let mut y = T::ZERO;
        for md in self.m.iter().take(self.modes) {
            y += md.out[0] * md.x[0] + md.out[1] * md.x[1] + md.out_u * self.held;
        }
        y
    }

    /// Advance one sample period with `u` held.
    pub fn advance(&mut self, u: T) {
        for md in self.m.iter_mut().take(self.modes) {
            let x0 = md.phi[0][0] * md.x[0] + md.phi[0][1] * md.x[1] + md.gamma[0] * u;
            let x1 = md.phi[1][0] * md.x[0] + md.phi[1][1] * md.x[1] + md.gamma[1] * u;
            md.x = [x0, x1];
        }
        self.held = u;
    }

    /// Sample y(t_k), then hold `u` over [t_k, t_{k+1}). Returns y(t_k).
    pub fn sample(&mut self, u: T) -> T {
        let y = self.output();
        self.advance(u);
        y
    }

    /// Back to rest.
    pub fn reset(&mut self) {
        for md in self.m.iter_mut() {
            md.x = [T::ZERO; 2];
        }
        self.held = T::ZERO;
    }
}

/// Exact discretization of one mode (matrix exponential of
/// [[A·Ts, B·Ts], [0, 0]]), at rest, with its output weights for the
/// sensor `output` (module docs).
fn discretize<T: Real>(
    sp: &ModeSpec,
    ts: f64,
    output: OutputKind,
) -> Result<DiscreteMode<T>, PlantError> {
    let (w, z, g, c, v) = (sp.omega, sp.zeta, sp.gain, sp.pos, sp.vel);
    let finite = [w, z, g, c, v].iter().all(|v| v.is_finite());
    if !finite || !(w > 0.0) || z < 0.0 {
        return Err(PlantError::Value);
    }
    let mut aug = [[0.0f64; EXPM_MAX]; EXPM_MAX];
    aug[0][1] = ts;
    aug[1][0] = -w * w * ts;
    aug[1][1] = -2.0 * z * w * ts;
    aug[1][2] = g * ts;
    let e = expm(&aug, 3);
    // y = c·η + v·η' and its derivatives: η'' = g·u − 2ζωη' − ω²η, and
    // under the hold η''' = −2ζωη'' − ω²η'.
    let (k, d) = (w * w, 2.0 * z * w);
    let (o0, o1, ou) = match output {
        OutputKind::Strain => (c, v, 0.0),
        OutputKind::Velocity => (-v * k, c - v * d, v * g),
        OutputKind::Acceleration => (
            -c * k + v * d * k,
            -c * d + v * (d * d - k),
            (c - v * d) * g,
        ),
    };
    Ok(DiscreteMode {
        phi: [
            [T::from_f64(e[0][0]), T::from_f64(e[0][1])],
            [T::from_f64(e[1][0]), T::from_f64(e[1][1])],
        ],
        gamma: [T::from_f64(e[0][2]), T::from_f64(e[1][2])],
        out: [T::from_f64(o0), T::from_f64(o1)],
        out_u: T::from_f64(ou),
        x: [T::ZERO; 2],
    })
}

#[cfg(test)]
#[allow(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::panic,
    clippy::indexing_slicing
)]
mod tests {
    use super::*;
    use crate::model::{paper_plant_tf, PAPER_B, PAPER_OMEGA, PAPER_ZETA};

    #[test]
    fn step_response_settles_at_dc_gain() {
        let plant_tf = paper_plant_tf();
        let mut p =
            ModalPlant::<f64>::with_numerator(&PAPER_OMEGA, &PAPER_ZETA, &PAPER_B, 1e-4).unwrap();
        let mut y = 0.0;
        for _ in 0..400_000 {
            y = p.sample(1.0);
        }
        let dc = plant_tf.b[2] / plant_tf.a[3];
        assert!((y - dc).abs() < 1e-9 * dc.abs(), "{y} vs {dc}");
    }

    #[test]
    fn single_mode_matches_closed_form_step_response() {
        let (w, z, g) = (50.0f64, 0.05f64, 2.0f64);
        let mp = ModalParams::new(&[w], &[z], &[g], Some(&[1.0])).unwrap();
        let ts = 1e-3;
        let mut p = ModalPlant::<f64>::from_modal(&mp, ts).unwrap();
        let wd = w * (1.0 - z * z).sqrt();
        for k in 0..2000 {
            let y = p.sample(1.0);
            let t = k as f64 * ts;
            let expect = g / (w * w)
                * (1.0 - (-z * w * t).exp() * ((wd * t).cos() + z * w / wd * (wd * t).sin()));
            assert!((y - expect).abs() < 1e-12, "k={k}");
        }
    }

    #[test]
    fn numerator_form_reproduces_modal_form() {
        let mp = ModalParams::new(
            &[30.0, 200.0, 700.0],
            &[0.02, 0.05, 0.1],
            &[1.0, 3.0, -2.0],
            None,
        )
        .unwrap();
        let tf = mp.transfer_function();
        let mut a = ModalPlant::<f64>::from_modal(&mp, 1e-4).unwrap();
        let mut b = ModalPlant::<f64>::with_numerator(
            &[30.0, 200.0, 700.0],
            &[0.02, 0.05, 0.1],
            &tf.b[..5],
            1e-4,
        )
        .unwrap();
        for k in 0..5000 {
            let u = if (k / 300) % 2 == 0 { 1.0 } else { -1.0 };
            let (ya, yb) = (a.sample(u), b.sample(u));
            assert!((ya - yb).abs() < 1e-9 * (1.0 + ya.abs()), "k={k}");
        }
    }

    #[test]
    fn rejects_bad_descriptions() {
        assert_eq!(
            ModalPlant::<f64>::with_numerator(&[10.0], &[0.1], &[1.0, 2.0], 1e-4).err(),
            Some(PlantError::Dimensions)
        );
        assert_eq!(
            ModalPlant::<f64>::with_numerator(&[-10.0], &[0.1], &[1.0], 1e-4).err(),
            Some(PlantError::Value)
        );
        assert_eq!(
            ModalPlant::<f64>::with_numerator(&[10.0, 10.0], &[0.1, 0.1], &[1.0, 1.0, 1.0], 1e-4)
                .err(),
            Some(PlantError::Numerator)
        );
    }
}
