//! Output sensitivities ∂y_k/∂p of the modal beam model, simulated exactly
//! under a held input, sample by sample.
//!
//! The model is the one of eq. 22–23 written per mode with a unit input gain
//! and general output weights:
//!
//! η_i'' + 2ζ_iω_iη_i' + ω_i²η_i = u,  y = Σ_i (α_i·η_i + β_i·η_i').
//!
//! The paper's model (23) is α_i = c_i·b̄_i (c = C̄ of eq. 24), β_i = 0; any
//! strictly proper numerator of degree ≤ 2n − 2 (e.g. the paper's eq. 46) is
//! α_i, β_i with Σ_i β_i = 0 (the s^{2n−1} coefficient of the numerator).
//!
//! # Design
//! The sensitivities of η_i to ω_i and ζ_i obey the same mode equation driven
//! by the derivative of the mode matrix: with x = (η, η'),
//! (∂x/∂ω)' = A·∂x/∂ω + (∂A/∂ω)·x, and likewise for ζ. Each mode is one
//! 6-state linear system [x, ∂x/∂ω, ∂x/∂ζ] with a held input, discretized
//! once by the matrix exponential of its 7×7 augmented matrix
//! (`linalg::expm`), so the sensitivities are exact at any Ts, like the
//! simulated plant (`plant`). Nothing is differenced numerically.
//!
//! A velocity or acceleration sensor ([`ModalOutputModel::output`]) reads
//! the r-th derivative of y (r = 1, 2); its sensitivities are the same
//! combinations of the states' r-th derivatives, x^{(r)} = A^{r−1}(A·x +
//! b·u) with the input held before the sample (the sample is read before
//! the new input is applied, as `plant::ModalPlant` reads it).

use crate::linalg::{expm, EXPM_MAX};
use crate::model::MAX_MODES;
use beam_protocol::OutputKind;

/// States per mode: η, η', ∂η/∂ω, ∂η'/∂ω, ∂η/∂ζ, ∂η'/∂ζ.
const MODE_STATES: usize = 6;

/// Why a modal model is not usable for sensitivities.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SensitivityError {
    /// Number of modes outside 1..=[`MAX_MODES`] or slice lengths disagree.
    Dimensions,
    /// ω ≤ 0, ζ < 0, Ts ≤ 0 or a non-finite number.
    Value,
}

impl core::fmt::Display for SensitivityError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Self::Dimensions => f.write_str("mode count outside 1..=3 or slice lengths disagree"),
            Self::Value => f.write_str("ω ≤ 0, ζ < 0, Ts ≤ 0 or a non-finite value"),
        }
    }
}

impl core::error::Error for SensitivityError {}

/// A modal model y = Σ (α_i·η_i + β_i·η_i'), η_i'' + 2ζ_iω_iη_i' + ω_i²η_i = u.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ModalOutputModel {
    /// Number of modes n.
    pub modes: usize,
    /// ω_i (rad/s).
    pub omega_rad_s: [f64; MAX_MODES],
    /// ζ_i.
    pub zeta: [f64; MAX_MODES],
    /// Position weights α_i (c_i·b̄_i in the paper's model).
    pub alpha: [f64; MAX_MODES],
    /// Velocity weights β_i (zero in the paper's model (23)).
    pub beta: [f64; MAX_MODES],
    /// What the sensor reads: y, its first or its second derivative.
    pub output: OutputKind,
}

impl ModalOutputModel {
    /// Build from slices of length n.
    ///
    /// # Errors
    /// [`SensitivityError::Dimensions`] or [`SensitivityError::Value`].
    pub fn new(
        omega_rad_s: &[f64],
        zeta: &[f64],
        alpha: &[f64],
        beta: &[f64],
    ) -> Result<Self, SensitivityError> {
        let n = omega_rad_s.len();
        if n == 0 || n > MAX_MODES || zeta.len() != n || alpha.len() != n || beta.len() != n {
            return Err(SensitivityError::Dimensions);
        }
        let mut m = Self {
            modes: n,
            omega_rad_s: [0.0; MAX_MODES],
            zeta: [0.0; MAX_MODES],
            alpha: [0.0; MAX_MODES],
            beta: [0.0; MAX_MODES],
            output: OutputKind::Strain,
        };
        m.omega_rad_s[..n].copy_from_slice(omega_rad_s);
        m.zeta[..n].copy_from_slice(zeta);
        m.alpha[..n].copy_from_slice(alpha);
        m.beta[..n].copy_from_slice(beta);
        m.validate()?;
        Ok(m)
    }

    /// The same model read by a sensor of kind `output` (module docs).
    pub fn with_output(mut self, output: OutputKind) -> Self {
        self.output = output;
        self
    }

    fn validate(&self) -> Result<(), SensitivityError> {
        let n = self.modes;
        if n == 0 || n > MAX_MODES {
            return Err(SensitivityError::Dimensions);
        }
        for i in 0..n {
            let v = [
                self.omega_rad_s[i],
                self.zeta[i],
                self.alpha[i],
                self.beta[i],
            ];
            if !v.iter().all(|x| x.is_finite())
                || !(self.omega_rad_s[i] > 0.0)
                || self.zeta[i] < 0.0
            {
                return Err(SensitivityError::Value);
            }
        }
        Ok(())
    }
}

/// One sample of the model output and its raw sensitivities.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SensitivitySample {
    /// y(t_k) of the noise-free model.
    pub y: f64,
    /// η_i(t_k) (= ∂y/∂α_i).
    pub eta: [f64; MAX_MODES],
    /// η_i'(t_k) (= ∂y/∂β_i).
    pub eta_dot: [f64; MAX_MODES],
    /// ∂y/∂ω_i.
    pub d_omega: [f64; MAX_MODES],
    /// ∂y/∂ζ_i.
    pub d_zeta: [f64; MAX_MODES],
}

#[derive(Debug, Clone, Copy, PartialEq)]
struct ModeSim {
    phi: [[f64; MODE_STATES]; MODE_STATES],
    gamma: [f64; MODE_STATES],
    /// The continuous system x' = A·x + b·u (for a derivative output).
    a: [[f64; MODE_STATES]; MODE_STATES],
    b: [f64; MODE_STATES],
    x: [f64; MODE_STATES],
}

impl ModeSim {
    /// The states' `r`-th time derivative just before the sample, under
    /// the input `held` since the sample before (module docs).
    fn derivative(&self, r: usize, held: f64) -> [f64; MODE_STATES] {
        let mut x = self.x;
        for k in 0..r {
            let input = if k == 0 { held } else { 0.0 };
            x = core::array::from_fn(|i| {
                (0..MODE_STATES).fold(self.b[i] * input, |s, j| s + self.a[i][j] * x[j])
            });
        }
        x
    }
}

/// Exact per-sample simulator of y and ∂y/∂(ω, ζ, α, β) for a held input.
#[derive(Debug, Clone, PartialEq)]
pub struct OutputSensitivity {
    model: ModalOutputModel,
    modes: [ModeSim; MAX_MODES],
    /// The input held since the last sample.
    held: f64,
}

impl OutputSensitivity {
    /// Discretize `model` at sample period `ts_s`.
    ///
    /// # Errors
    /// [`SensitivityError::Value`] for a bad model or Ts.
    pub fn new(model: &ModalOutputModel, ts_s: f64) -> Result<Self, SensitivityError> {
        model.validate()?;
        if !(ts_s > 0.0 && ts_s.is_finite()) {
            return Err(SensitivityError::Value);
        }
        let zero = ModeSim {
            phi: [[0.0; MODE_STATES]; MODE_STATES],
            gamma: [0.0; MODE_STATES],
            a: [[0.0; MODE_STATES]; MODE_STATES],
            b: [0.0; MODE_STATES],
            x: [0.0; MODE_STATES],
        };
        let mut modes = [zero; MAX_MODES];
        for (i, sim) in modes.iter_mut().enumerate().take(model.modes) {
            let (w, z) = (model.omega_rad_s[i], model.zeta[i]);
            // Continuous 6-state system times Ts, input column last.
            let mut a = [[0.0f64; EXPM_MAX]; EXPM_MAX];
            for blk in 0..3 {
                let o = 2 * blk;
                a[o][o + 1] = ts_s;
                a[o + 1][o] = -w * w * ts_s;
                a[o + 1][o + 1] = -2.0 * z * w * ts_s;
            }
            // ∂A/∂ω = [[0, 0], [−2ω, −2ζ]] acting on (η, η').
            a[3][0] = -2.0 * w * ts_s;
            a[3][1] = -2.0 * z * ts_s;
            // ∂A/∂ζ = [[0, 0], [0, −2ω]].
            a[5][1] = -2.0 * w * ts_s;
            a[1][MODE_STATES] = ts_s;
            let e = expm(&a, MODE_STATES + 1);
            for r in 0..MODE_STATES {
                for c in 0..MODE_STATES {
                    sim.phi[r][c] = e[r][c];
                    sim.a[r][c] = a[r][c] / ts_s;
                }
                sim.gamma[r] = e[r][MODE_STATES];
                sim.b[r] = a[r][MODE_STATES] / ts_s;
            }
        }
        Ok(Self {
            model: *model,
            modes,
            held: 0.0,
        })
    }

    /// The model being simulated.
    pub fn model(&self) -> &ModalOutputModel {
        &self.model
    }

    /// The output and sensitivities at the current sample t_k; then hold `u`
    /// over [t_k, t_{k+1}) and advance (the convention of
    /// `plant::ModalPlant::sample`).
    pub fn push(&mut self, u: f64) -> SensitivitySample {
        let mut s = SensitivitySample {
            y: 0.0,
            eta: [0.0; MAX_MODES],
            eta_dot: [0.0; MAX_MODES],
            d_omega: [0.0; MAX_MODES],
            d_zeta: [0.0; MAX_MODES],
        };
        let m = &self.model;
        let r = m.output.numerator_shift();
        for (i, sim) in self.modes.iter_mut().enumerate().take(m.modes) {
            let x = sim.derivative(r, self.held);
            let (al, be) = (m.alpha[i], m.beta[i]);
            s.eta[i] = x[0];
            s.eta_dot[i] = x[1];
            s.y += al * x[0] + be * x[1];
            s.d_omega[i] = al * x[2] + be * x[3];
            s.d_zeta[i] = al * x[4] + be * x[5];
            let x = sim.x;
            let mut next = [0.0; MODE_STATES];
            for (r, nr) in next.iter_mut().enumerate() {
                let mut acc = sim.gamma[r] * u;
                for c in 0..MODE_STATES {
                    acc += sim.phi[r][c] * x[c];
                }
                *nr = acc;
            }
            sim.x = next;
        }
        self.held = u;
        s
    }

    /// Back to rest.
    pub fn reset(&mut self) {
        for sim in self.modes.iter_mut() {
            sim.x = [0.0; MODE_STATES];
        }
        self.held = 0.0;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The last sample of a model run for `n` samples of a square input.
    fn run(m: &ModalOutputModel, n: usize) -> SensitivitySample {
        let mut s = OutputSensitivity::new(m, 1e-3).unwrap();
        let mut last = s.push(1.0);
        for k in 0..n {
            let u = if (k / 150) % 2 == 0 { 1.0 } else { -0.5 };
            last = s.push(u);
        }
        last
    }

    #[test]
    fn sensitivities_match_central_differences() {
        for output in OutputKind::ALL {
            sensitivities_match_central_differences_for(output);
        }
    }

    fn sensitivities_match_central_differences_for(output: OutputKind) {
        let m = ModalOutputModel::new(&[30.0, 140.0], &[0.03, 0.1], &[-2.0, 5.0], &[0.01, -0.01])
            .unwrap()
            .with_output(output);
        let s = run(&m, 2000);
        for i in 0..2 {
            for which in 0..4 {
                let h = match which {
                    0 => 1e-6 * m.omega_rad_s[i],
                    1 => 1e-6 * m.zeta[i],
                    2 => 1e-6,
                    _ => 1e-8,
                };
                let bump = |d: f64| {
                    let mut p = m;
                    match which {
                        0 => p.omega_rad_s[i] += d,
                        1 => p.zeta[i] += d,
                        2 => p.alpha[i] += d,
                        _ => p.beta[i] += d,
                    }
                    run(&p, 2000).y
                };
                let fd = (bump(h) - bump(-h)) / (2.0 * h);
                let exact = [s.d_omega[i], s.d_zeta[i], s.eta[i], s.eta_dot[i]][which];
                assert!(
                    (fd - exact).abs() <= 1e-6 * exact.abs().max(1e-6),
                    "{output}: mode {i} param {which}: fd {fd} exact {exact}"
                );
            }
        }
    }

    #[test]
    fn output_matches_the_plant_simulator() {
        use crate::model::ModalParams;
        use crate::rig::ModalPlant;
        let mp = ModalParams::new(&[30.0, 140.0], &[0.03, 0.1], &[1.5, -4.0], None).unwrap();
        let m = ModalOutputModel::new(
            &[30.0, 140.0],
            &[0.03, 0.1],
            &[-2.0 * 1.5, 2.0 * -4.0],
            &[0.0, 0.0],
        )
        .unwrap();
        for output in OutputKind::ALL {
            let mut plant = ModalPlant::<f64>::from_modal(&mp, 1e-3)
                .unwrap()
                .with_output(output)
                .unwrap();
            let mut sens = OutputSensitivity::new(&m.with_output(output), 1e-3).unwrap();
            let scale = [1.0, 100.0, 1e4][output.numerator_shift()];
            for k in 0..3000 {
                let u = if (k / 97) % 2 == 0 { 0.3 } else { -0.3 };
                let (a, b) = (plant.sample(u), sens.push(u).y);
                assert!((a - b).abs() <= 1e-12 * (scale + a.abs()), "{output} k={k}");
            }
        }
    }

    #[test]
    fn rejects_bad_models() {
        assert_eq!(
            ModalOutputModel::new(&[1.0], &[0.1], &[1.0], &[]).err(),
            Some(SensitivityError::Dimensions)
        );
        assert_eq!(
            ModalOutputModel::new(&[-1.0], &[0.1], &[1.0], &[0.0]).err(),
            Some(SensitivityError::Value)
        );
        let m = ModalOutputModel::new(&[1.0], &[0.1], &[1.0], &[0.0]).unwrap();
        assert_eq!(
            OutputSensitivity::new(&m, f64::NAN).err(),
            Some(SensitivityError::Value)
        );
    }
}
