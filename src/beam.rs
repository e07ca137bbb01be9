//! Euler–Bernoulli physics of the piezo-actuated cantilever (Section II and
//! Appendix of the paper): from the material data of Tables I–II to the modal
//! model (ω_i, ζ_i, b̄_i, c_i) that the estimator identifies.
//!
//! The chain, with the paper's equation numbers:
//!
//! 1. The PDE (eq. 12) with Kelvin–Voigt damping (eq. 2–3) and the
//!    clamped-free boundary conditions (eq. 7).
//! 2. The roots β_iL of the frequency equation cos βL·cosh βL + 1 = 0
//!    (eq. 20), see [`frequency_root`].
//! 3. The mode shapes W_i(x) of eq. 19, see [`ModeShape`].
//! 4. The Galerkin projection (eq. 49–57): mass m_ij (54), damping c_ij (55),
//!    stiffness k_ij (56) and piezo input z_i (57), integrated numerically by
//!    composite Gauss–Legendre quadrature, see [`GalerkinMatrices`].
//! 5. The diagonal modal model M η̈ + C η̇ + K η = z u (eq. 21), its state
//!    space form (eq. 22) and transfer function (eq. 25–26), see
//!    [`BeamModal`].
//!
//! The physics runs in `f64`: it is computed once, at start-up or on the
//! host, and its results are rounded to the estimator's scalar type there.
//!
//! # Design
//!
//! **Mode shapes.** Eq. 19 is garbled in the available text. We use the
//! classical clamped-free shape with the *paper's sign*,
//!
//! W_i(x) = cos β_ix − cosh β_ix − σ_i (sin β_ix − sinh β_ix),
//! σ_i = (cosh β_iL + cos β_iL)/(sinh β_iL + sin β_iL),
//!
//! i.e. the negative of the textbook form cosh − cos − σ(sinh − sin). With
//! this sign the tip values are W_i(L) = 2·(−1)^i = −2, 2, −2, …, which is the
//! paper's output row C̄ = [−2, 2] of eq. 24 and
//! [`model::default_output_weight`](crate::model::default_output_weight).
//! Every modal product the plant depends on (c_i·b̄_i, m_ii, k_ii, c_ii) is
//! invariant under a per-mode sign flip, so the transfer function is the same
//! with either sign.
//!
//! **Normalization.** No rescaling is applied: with the σ_i above,
//! ∫₀ᴸ W_i² dx = L and |W_i(L)| = 2 (both checked by the tests). The modal
//! coordinate η_i therefore has the unit of a deflection (m) and W_i is
//! dimensionless.
//!
//! **Numerical stability.** cosh βx − σ sinh βx cancels catastrophically for
//! large βx because σ → 1. We evaluate it as
//! ½(1−σ)e^{βx} + ½(1+σ)e^{−βx} with 1 − σ written without cancellation
//! (see [`ModeShape`]); the growing term is then bounded by O(1) for every
//! mode, so high modes (βL in the hundreds) evaluate as accurately as low ones.
//!
//! **Sign of the input z_i.** Projecting eq. 12 onto W_j gives, for the
//! actuator term, ∫ W_j ∂²M_a/∂x² dx = r_a d31 E_p U_a [W_j'(x_b) − W_j'(x_a)]
//! (distributional derivative of the Heaviside window of eq. 9). Moving it to
//! the right-hand side gives exactly eq. 21, M η̈ + C η̇ + K η = z u, with the
//! *first line* of eq. 57: z_i = r_a d31 E_p [W_i'(x_a) − W_i'(x_b)]. We use
//! that convention, so b̄_i = z_i/m_ii enters B̄ of eq. 24 with a plus sign.
//! (Eq. 53 keeps the term on the left, "+ z_i u", which is consistent with
//! the *second* line of eq. 57, z_i = r_a d31 E_p ∫W_i ∂²/∂x²[H(x−x_a) −
//! H(x−x_b)] dx = r_a d31 E_p [W_i'(x_b) − W_i'(x_a)], the opposite sign of
//! its first line. Both pairs describe the same physics; mixing eq. 53 with
//! the first line of eq. 57 would flip every b̄_i.)
//!
//! **Units of z_i.** Eq. 8, M_a = r_a d31 E_p U_a, has the unit N, not N·m:
//! the moment of a patch of width b_p is r_a d31 E_p b_p U_a. We follow the
//! paper literally (no b_p), so z_i is in N/(V·m) and b̄_i in 1/(V·s²);
//! multiply both by the patch width (m) for the physical N/V and m/(V·s²).
//! Only the input gain is affected; ω_i, ζ_i and c_i are not.
//!
//! **Geometry not in the paper.** Table I gives A = b·h = 8·10⁻⁵ m² and
//! I = b·h³/12 = 6.67·10⁻¹² m⁴ but not h; we solve h = √(12 I/A) ≈ 1.0 mm
//! (b = A/h ≈ 80 mm). The actuator span x_a..x_b is not given either; see
//! [`BeamParams::paper`] for the assumed default.

use crate::model::{ModalParams, TransferFunction, MAX_MODES, MAX_ORDER};

/// π, for the root brackets of eq. 20.
const PI: f64 = core::f64::consts::PI;

/// Number of equal panels of the composite Gauss–Legendre rule over [0, L].
/// With 5 nodes per panel the rule is exact for polynomials of degree 9 per
/// panel; for the first three modes β·(L/64) < 0.13, so the quadrature error
/// of the Galerkin integrals is at the level of rounding.
pub const QUADRATURE_PANELS: usize = 64;

/// Nodes of the 5-point Gauss–Legendre rule on [−1, 1]: 0, ±√(5 − 2√(10/7))/3,
/// ±√(5 + 2√(10/7))/3.
const GL5_NODES: [f64; 5] = [
    -0.906_179_845_938_664,
    -0.538_469_310_105_683_1,
    0.0,
    0.538_469_310_105_683_1,
    0.906_179_845_938_664,
];

/// Weights of the 5-point Gauss–Legendre rule on [−1, 1]: 128/225 at the
/// centre, (322 ± 13√70)/900 at the inner/outer pairs.
const GL5_WEIGHTS: [f64; 5] = [
    0.236_926_885_056_189_1,
    0.478_628_670_499_366_5,
    0.568_888_888_888_888_9,
    0.478_628_670_499_366_5,
    0.236_926_885_056_189_1,
];

/// Iteration cap of the safeguarded Newton search for β_iL. Newton converges
/// quadratically from the bracket centre in ≤ 6 steps; bisection alone would
/// need ~52 steps to reach f64 resolution on a bracket of width π/2.
const ROOT_MAX_ITERATIONS: usize = 100;

/// Which physical quantity the beam model outputs (row C_w of eq. 22).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BeamOutput {
    /// Deflection w(x_s, t) in metres: c_i = W_i(x_s). With x_s = L this is
    /// the tip deflection and c_i = W_i(L) = [−2, 2, −2] (eq. 24).
    Deflection,
    /// Surface bending strain at the gauge, ε = (h/2)·∂²w/∂x²(x_s)
    /// (dimensionless): c_i = (h/2)·W_i''(x_s). Sign: the strain of the face
    /// on the −w side, positive (tension) when the curvature w'' is positive
    /// (centre of curvature on the +w side). This is the sign for which a
    /// static tip load gives ε > 0 together with w(L) > 0, i.e. the sign
    /// under which eq. 16–17 hold.
    Strain,
    /// The paper's experimental output y = 2L³ε/(3 L₁ h) (eq. 17 applied to
    /// the strain above, L₁ = L − x_s the gauge-to-tip distance), in metres:
    /// c_i = L³·W_i''(x_s)/(3 L₁). It equals the tip deflection for a static
    /// tip load, not for a vibrating beam. Requires x_s < L.
    StrainAsTipDeflection,
}

/// Names the parameter a [`BeamError`] is about.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BeamParam {
    /// [`BeamParams::density_kg_m3`].
    Density,
    /// [`BeamParams::area_m2`].
    Area,
    /// [`BeamParams::youngs_modulus_pa`].
    YoungsModulus,
    /// [`BeamParams::inertia_m4`].
    Inertia,
    /// [`BeamParams::damping_pa_s`].
    Damping,
    /// [`BeamParams::length_m`].
    Length,
    /// [`BeamParams::thickness_m`].
    Thickness,
    /// [`BeamParams::piezo_modulus_pa`].
    PiezoModulus,
    /// [`BeamParams::piezo_d31_m_v`].
    PiezoD31,
    /// [`BeamParams::moment_arm_m`].
    MomentArm,
    /// The gauge-to-force distance L₁ of eq. 16–17.
    GaugeLeverArm,
    /// A strain or deflection value passed to the eq. 17 conversions.
    Measurement,
}

/// Errors of the beam computations.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BeamError {
    /// The parameter is not finite or not strictly positive (for
    /// [`BeamParam::Damping`]: negative; for [`BeamParam::PiezoD31`]: zero).
    InvalidParameter(BeamParam),
    /// The actuator span is not 0 ≤ x_a < x_b ≤ L (or not finite).
    ActuatorSpan,
    /// The output position is not within [0, L] (or not finite), or equals L
    /// for [`BeamOutput::StrainAsTipDeflection`] (L₁ = 0).
    OutputPosition,
    /// The mode count is not in 1..=[`MAX_MODES`].
    ModeCount,
    /// Mode numbers are 1-based; 0 was given.
    ModeNumber,
    /// The root of eq. 20 was not bracketed or did not converge.
    RootNotConverged,
    /// A derived quantity came out NaN, infinite or with a zero modal mass
    /// (parameters too extreme for f64).
    NonFinite,
}

/// Material, geometry, actuator and sensor data of the beam (Tables I–II plus
/// the assumptions documented on [`BeamParams::paper`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BeamParams {
    /// Beam density ρ (kg/m³).
    pub density_kg_m3: f64,
    /// Cross-section area A = b·h (m²).
    pub area_m2: f64,
    /// Young's modulus E (Pa).
    pub youngs_modulus_pa: f64,
    /// Bending moment of inertia I = b·h³/12 (m⁴).
    pub inertia_m4: f64,
    /// Kelvin–Voigt damping factor C of eq. 3 (Pa·s: the stress per unit
    /// strain rate, so that C·I multiplies ∂⁵w/∂t∂x⁴ like E·I multiplies
    /// ∂⁴w/∂x⁴; Table I prints the unit as N/(m/s)). Zero means undamped.
    pub damping_pa_s: f64,
    /// Beam length L (m).
    pub length_m: f64,
    /// Beam thickness h (m), used by the strain outputs and eq. 17.
    pub thickness_m: f64,
    /// Young's modulus of the piezo patch E_p (Pa).
    pub piezo_modulus_pa: f64,
    /// Piezoelectric coefficient d31 (C/N = m/V); its sign sets the polarity.
    pub piezo_d31_m_v: f64,
    /// Effective moment arm r_a of eq. 8 (m).
    pub moment_arm_m: f64,
    /// Actuator start x_a, measured from the clamp (m).
    pub actuator_start_m: f64,
    /// Actuator end x_b, measured from the clamp (m).
    pub actuator_end_m: f64,
    /// Output (sensor) position x_s, measured from the clamp (m).
    pub output_position_m: f64,
    /// Output quantity at x_s.
    pub output: BeamOutput,
}

impl BeamParams {
    /// The paper's beam: Table I (steel beam) and Table II (piezo ceramic),
    /// with tip-deflection output (x_s = L, c_i = W_i(L), eq. 24).
    ///
    /// Values not in the paper, and therefore assumptions:
    /// * thickness h = √(12 I/A) ≈ 1.00025 mm (width b = A/h ≈ 79.98 mm), from
    ///   A = b·h and I = b·h³/12;
    /// * actuator span x_a = 5 mm, x_b = 55 mm: a PI P-876.A12 DuraAct patch
    ///   (the paper's actuator, active length 50 mm) bonded 5 mm from the
    ///   clamp. Only b̄_i depends on it (through W_i' at the patch ends).
    pub fn paper() -> Self {
        let area_m2 = 8.0e-5;
        let inertia_m4 = 6.67e-12;
        let length_m = 0.36;
        Self {
            density_kg_m3: 7723.13,
            area_m2,
            youngs_modulus_pa: 1.93e11,
            inertia_m4,
            damping_pa_s: 9.8e7,
            length_m,
            thickness_m: rectangular_thickness_m(area_m2, inertia_m4),
            piezo_modulus_pa: 7.06e10,
            piezo_d31_m_v: -1.8e-10,
            moment_arm_m: 0.001,
            actuator_start_m: 0.005,
            actuator_end_m: 0.055,
            output_position_m: length_m,
            output: BeamOutput::Deflection,
        }
    }

    /// Width b = A/h of the rectangular section (m).
    pub fn width_m(&self) -> f64 {
        self.area_m2 / self.thickness_m
    }

    /// Check every field: ρ, A, E, I, L, h, E_p, r_a finite and > 0; C finite
    /// and ≥ 0; d31 finite and ≠ 0; 0 ≤ x_a < x_b ≤ L; 0 ≤ x_s ≤ L (x_s < L
    /// for [`BeamOutput::StrainAsTipDeflection`]).
    pub fn validate(&self) -> Result<(), BeamError> {
        let positive = [
            (self.density_kg_m3, BeamParam::Density),
            (self.area_m2, BeamParam::Area),
            (self.youngs_modulus_pa, BeamParam::YoungsModulus),
            (self.inertia_m4, BeamParam::Inertia),
            (self.length_m, BeamParam::Length),
            (self.thickness_m, BeamParam::Thickness),
            (self.piezo_modulus_pa, BeamParam::PiezoModulus),
            (self.moment_arm_m, BeamParam::MomentArm),
        ];
        for (value, which) in positive {
            if !is_positive_finite(value) {
                return Err(BeamError::InvalidParameter(which));
            }
        }
        if !(self.damping_pa_s.is_finite() && self.damping_pa_s >= 0.0) {
            return Err(BeamError::InvalidParameter(BeamParam::Damping));
        }
        if !(self.piezo_d31_m_v.is_finite() && self.piezo_d31_m_v != 0.0) {
            return Err(BeamError::InvalidParameter(BeamParam::PiezoD31));
        }
        let l = self.length_m;
        let (xa, xb) = (self.actuator_start_m, self.actuator_end_m);
        // Written so that NaN fails every comparison and is rejected.
        if !(xa >= 0.0 && xa < xb && xb <= l) {
            return Err(BeamError::ActuatorSpan);
        }
        let xs = self.output_position_m;
        let xs_ok = match self.output {
            BeamOutput::StrainAsTipDeflection => xs >= 0.0 && xs < l,
            BeamOutput::Deflection | BeamOutput::Strain => xs >= 0.0 && xs <= l,
        };
        if !xs_ok {
            return Err(BeamError::OutputPosition);
        }
        Ok(())
    }

    /// Wave number scale √(EI/(ρA)) (m²/s): ω_i = β_i²·√(EI/(ρA)).
    pub fn wave_scale_m2_s(&self) -> f64 {
        libm::sqrt(self.youngs_modulus_pa * self.inertia_m4 / (self.density_kg_m3 * self.area_m2))
    }

    /// Closed-form undamped natural frequency of mode `mode_number` (1-based):
    /// ω_i = (β_iL)²/L²·√(EI/(ρA)) (rad/s).
    pub fn natural_frequency_rad_s(&self, mode_number: usize) -> Result<f64, BeamError> {
        self.validate()?;
        let bl = frequency_root(mode_number)?;
        let l = self.length_m;
        Ok(bl * bl / (l * l) * self.wave_scale_m2_s())
    }

    /// Mode shape `mode_number` (1-based) of this beam.
    pub fn mode_shape(&self, mode_number: usize) -> Result<ModeShape, BeamError> {
        self.validate()?;
        ModeShape::new(mode_number, self.length_m)
    }

    /// Galerkin matrices of eq. 54–57 for the first `modes` modes.
    pub fn galerkin(&self, modes: usize) -> Result<GalerkinMatrices, BeamError> {
        GalerkinMatrices::new(self, modes)
    }

    /// The diagonal modal model of eq. 21–24 for the first `modes` modes.
    pub fn modal(&self, modes: usize) -> Result<BeamModal, BeamError> {
        BeamModal::new(self, modes)
    }

    /// Output weight c_i of one mode for the configured output (see
    /// [`BeamOutput`]).
    fn output_weight(&self, shape: &ModeShape) -> f64 {
        let xs = self.output_position_m;
        match self.output {
            BeamOutput::Deflection => shape.value(xs),
            BeamOutput::Strain => 0.5 * self.thickness_m * shape.derivative(2, xs),
            BeamOutput::StrainAsTipDeflection => {
                let l = self.length_m;
                l * l * l * shape.derivative(2, xs) / (3.0 * (l - xs))
            }
        }
    }
}

/// Thickness of a solid rectangular section from its area and second moment:
/// A = b·h, I = b·h³/12 ⇒ h = √(12 I/A) (m).
pub fn rectangular_thickness_m(area_m2: f64, inertia_m4: f64) -> f64 {
    libm::sqrt(12.0 * inertia_m4 / area_m2)
}

/// Eq. 17: the deflection w = 2L³ε/(3 L₁ h) that a static tip force produces
/// together with the surface strain ε at a gauge L₁ before the force point
/// (L₁ = L − x_s for a tip force). Sign as in [`BeamOutput::Strain`].
pub fn deflection_from_strain(
    strain: f64,
    length_m: f64,
    gauge_lever_arm_m: f64,
    thickness_m: f64,
) -> Result<f64, BeamError> {
    check_eq17(strain, length_m, gauge_lever_arm_m, thickness_m)?;
    Ok(2.0 * length_m * length_m * length_m * strain / (3.0 * gauge_lever_arm_m * thickness_m))
}

/// Inverse of eq. 17: ε = 3 L₁ h w/(2L³), the gauge strain of a static tip
/// deflection w (eq. 15–16 with ε = σ/E, eq. 14).
pub fn strain_from_deflection(
    deflection_m: f64,
    length_m: f64,
    gauge_lever_arm_m: f64,
    thickness_m: f64,
) -> Result<f64, BeamError> {
    check_eq17(deflection_m, length_m, gauge_lever_arm_m, thickness_m)?;
    Ok(3.0 * gauge_lever_arm_m * thickness_m * deflection_m
        / (2.0 * length_m * length_m * length_m))
}

fn check_eq17(value: f64, length_m: f64, lever_m: f64, thickness_m: f64) -> Result<(), BeamError> {
    if !value.is_finite() {
        return Err(BeamError::InvalidParameter(BeamParam::Measurement));
    }
    if !is_positive_finite(length_m) {
        return Err(BeamError::InvalidParameter(BeamParam::Length));
    }
    if !is_positive_finite(lever_m) {
        return Err(BeamError::InvalidParameter(BeamParam::GaugeLeverArm));
    }
    if !is_positive_finite(thickness_m) {
        return Err(BeamError::InvalidParameter(BeamParam::Thickness));
    }
    Ok(())
}

fn is_positive_finite(x: f64) -> bool {
    x.is_finite() && x > 0.0
}

/// g(x) = cos x + 1/cosh x: eq. 20 divided by cosh x, same roots but O(1)
/// everywhere (cos x·cosh x + 1 grows like eˣ).
fn frequency_function(x: f64) -> f64 {
    libm::cos(x) + 1.0 / libm::cosh(x)
}

/// g'(x) = −sin x − tanh x / cosh x.
fn frequency_function_slope(x: f64) -> f64 {
    -libm::sin(x) - libm::tanh(x) / libm::cosh(x)
}

/// The `mode_number`-th (1-based) positive root β_iL of the clamped-free
/// frequency equation cos βL·cosh βL + 1 = 0 (eq. 20).
///
/// The i-th root lies within π/4 of (2i − 1)π/2 (for i ≥ 2 within about
/// 2e^{−βL} of it), where g(x) = cos x + 1/cosh x changes sign; it is found by Newton's
/// method safeguarded by bisection on that bracket, to f64 resolution.
/// Reference values: 1.875 104 068 7, 4.694 091 133 0, 7.854 757 438 2.
pub fn frequency_root(mode_number: usize) -> Result<f64, BeamError> {
    if mode_number == 0 {
        return Err(BeamError::ModeNumber);
    }
    let centre = (2.0 * mode_number as f64 - 1.0) * 0.5 * PI;
    let (mut lo, mut hi) = (centre - 0.25 * PI, centre + 0.25 * PI);
    let mut f_lo = frequency_function(lo);
    let mut f_hi = frequency_function(hi);
    // (Written so that a NaN also fails.)
    let bracketed = f_lo * f_hi < 0.0;
    if !bracketed {
        return Err(BeamError::RootNotConverged);
    }
    let tolerance = 4.0 * f64::EPSILON * centre;
    let mut x = centre;
    for _ in 0..ROOT_MAX_ITERATIONS {
        let f = frequency_function(x);
        if f == 0.0 {
            return Ok(x);
        }
        // Keep the sign change inside [lo, hi].
        if (f < 0.0) == (f_lo < 0.0) {
            lo = x;
            f_lo = f;
        } else {
            hi = x;
            f_hi = f;
        }
        let slope = frequency_function_slope(x);
        let newton = x - f / slope;
        // A Newton step that rounds onto the bracket end is still good (the
        // last step at f64 resolution does); otherwise bisect.
        let next = if slope != 0.0 && newton >= lo && newton <= hi {
            newton
        } else {
            0.5 * (lo + hi)
        };
        if libm::fabs(next - x) <= tolerance {
            return Ok(next);
        }
        if hi - lo <= tolerance {
            return Ok(if libm::fabs(f_lo) < libm::fabs(f_hi) {
                lo
            } else {
                hi
            });
        }
        x = next;
    }
    Err(BeamError::RootNotConverged)
}

/// One clamped-free mode shape W_i(x) (eq. 19, paper's sign; see the module
/// docs for the sign and normalization):
///
/// W(x) = cos βx − cosh βx − σ (sin βx − sinh βx),
/// σ = (cosh βL + cos βL)/(sinh βL + sin βL),
///
/// satisfying W(0) = W'(0) = 0 and W''(L) = W'''(L) = 0 (eq. 7),
/// W'''' = β⁴W, ∫₀ᴸ W² dx = L and W(L) = 2·(−1)^i.
///
/// Evaluated in the cancellation-free form
/// W(x) = −[½(1−σ)e^{βx} + ½(1+σ)e^{−βx} − cos βx + σ sin βx], with
/// ½(1−σ)e^{βx} = τ·e^{β(x−L)} and
/// τ = (sin βL − cos βL − e^{−βL}) / (1 − e^{−2βL} + 2 sin βL·e^{−βL}).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ModeShape {
    mode_number: usize,
    beta_l: f64,
    beta_per_m: f64,
    length_m: f64,
    sigma: f64,
    /// τ of the stable form: ½(1−σ)e^{βx} = τ·e^{β(x−L)}.
    tail: f64,
}

impl ModeShape {
    /// Mode `mode_number` (1-based) of a cantilever of length `length_m`.
    pub fn new(mode_number: usize, length_m: f64) -> Result<Self, BeamError> {
        if !is_positive_finite(length_m) {
            return Err(BeamError::InvalidParameter(BeamParam::Length));
        }
        let beta_l = frequency_root(mode_number)?;
        let e = libm::exp(-beta_l);
        let (s, c) = (libm::sin(beta_l), libm::cos(beta_l));
        let tail = (s - c - e) / (1.0 - e * e + 2.0 * s * e);
        // ½(1 − σ) = τ·e^{−βL}.
        let sigma = 1.0 - 2.0 * tail * e;
        Ok(Self {
            mode_number,
            beta_l,
            beta_per_m: beta_l / length_m,
            length_m,
            sigma,
            tail,
        })
    }

    /// Mode number i (1-based).
    pub fn mode_number(&self) -> usize {
        self.mode_number
    }

    /// Root β_iL of eq. 20 (dimensionless).
    pub fn beta_l(&self) -> f64 {
        self.beta_l
    }

    /// Wave number β_i = β_iL/L (1/m).
    pub fn beta_per_m(&self) -> f64 {
        self.beta_per_m
    }

    /// Beam length L (m).
    pub fn length_m(&self) -> f64 {
        self.length_m
    }

    /// σ_i = (cosh β_iL + cos β_iL)/(sinh β_iL + sin β_iL).
    pub fn sigma(&self) -> f64 {
        self.sigma
    }

    /// W(x) (dimensionless).
    pub fn value(&self, x_m: f64) -> f64 {
        self.derivative(0, x_m)
    }

    /// The `order`-th derivative dᵏW/dxᵏ at x (unit 1/mᵏ). Any order is
    /// supported; the exponential and trigonometric parts cycle with period
    /// 2 and 4 in k.
    pub fn derivative(&self, order: usize, x_m: f64) -> f64 {
        let beta = self.beta_per_m;
        let xi = beta * x_m;
        let grow = self.tail * libm::exp(xi - self.beta_l);
        let decay = 0.5 * (1.0 + self.sigma) * libm::exp(-xi);
        let (s, c) = (libm::sin(xi), libm::cos(xi));
        // k-th derivatives of cos ξ and sin ξ with respect to ξ.
        let (dcos, dsin) = match order % 4 {
            0 => (c, s),
            1 => (-s, c),
            2 => (-c, -s),
            _ => (s, -c),
        };
        let decay_sign = if order % 2 == 0 { 1.0 } else { -1.0 };
        let textbook = grow + decay_sign * decay - dcos + self.sigma * dsin;
        let mut scale = 1.0;
        for _ in 0..order {
            scale *= beta;
        }
        -scale * textbook
    }

    /// [W, W', W'', W''', W''''] at x.
    pub fn derivatives(&self, x_m: f64) -> [f64; 5] {
        let mut d = [0.0; 5];
        for (k, dk) in d.iter_mut().enumerate() {
            *dk = self.derivative(k, x_m);
        }
        d
    }
}

/// ∫₀ᴸ f(x) dx by the composite 5-point Gauss–Legendre rule on
/// [`QUADRATURE_PANELS`] equal panels.
pub fn integrate<F: FnMut(f64) -> f64>(length_m: f64, mut f: F) -> f64 {
    let panel = length_m / QUADRATURE_PANELS as f64;
    let half = 0.5 * panel;
    let mut total = 0.0;
    for p in 0..QUADRATURE_PANELS {
        let mid = (p as f64 + 0.5) * panel;
        let mut sum = 0.0;
        for (node, weight) in GL5_NODES.iter().zip(GL5_WEIGHTS.iter()) {
            sum += weight * f(mid + half * node);
        }
        total += half * sum;
    }
    total
}

/// The Galerkin matrices of eq. 54–57 for the first `modes` mode shapes,
/// full (not assumed diagonal), with entries beyond `modes` zero.
///
/// m_ij = ∫ρA W_iW_j dx (54), c_ij = ∫CI W_i''''W_j dx (55),
/// k_ij = ∫EI W_i''''W_j dx (56), by quadrature with W_i'''' evaluated from
/// its own closed form (not replaced by β⁴W), so the diagonality of eq. 52 is
/// a genuine numerical property; z_i = r_a d31 E_p [W_i'(x_a) − W_i'(x_b)]
/// (57, first line; see the module docs for the sign).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GalerkinMatrices {
    /// Number of modes n.
    pub modes: usize,
    /// Roots β_iL of eq. 20.
    pub beta_l: [f64; MAX_MODES],
    /// Mass matrix m_ij (kg), eq. 54.
    pub mass_kg: [[f64; MAX_MODES]; MAX_MODES],
    /// Damping matrix c_ij (N·s/m), eq. 55.
    pub damping_n_s_m: [[f64; MAX_MODES]; MAX_MODES],
    /// Stiffness matrix k_ij (N/m), eq. 56.
    pub stiffness_n_m: [[f64; MAX_MODES]; MAX_MODES],
    /// Input vector z_i of eq. 57 (N/(V·m) as the paper writes eq. 8, whose
    /// moment lacks the patch width; see the module docs).
    pub input_z: [f64; MAX_MODES],
}

impl GalerkinMatrices {
    /// Compute eq. 54–57 for the first `modes` (1..=[`MAX_MODES`]) modes.
    pub fn new(params: &BeamParams, modes: usize) -> Result<Self, BeamError> {
        params.validate()?;
        if modes == 0 || modes > MAX_MODES {
            return Err(BeamError::ModeCount);
        }
        let l = params.length_m;
        let mut shapes = [ModeShape::new(1, l)?; MAX_MODES];
        for (i, shape) in shapes.iter_mut().enumerate().take(modes).skip(1) {
            *shape = ModeShape::new(i + 1, l)?;
        }
        let shapes = &shapes[..modes];

        let rho_a = params.density_kg_m3 * params.area_m2;
        let ei = params.youngs_modulus_pa * params.inertia_m4;
        let ci = params.damping_pa_s * params.inertia_m4;
        let piezo = params.moment_arm_m * params.piezo_d31_m_v * params.piezo_modulus_pa;

        let mut g = Self {
            modes,
            beta_l: [0.0; MAX_MODES],
            mass_kg: [[0.0; MAX_MODES]; MAX_MODES],
            damping_n_s_m: [[0.0; MAX_MODES]; MAX_MODES],
            stiffness_n_m: [[0.0; MAX_MODES]; MAX_MODES],
            input_z: [0.0; MAX_MODES],
        };
        for (i, wi) in shapes.iter().enumerate() {
            g.beta_l[i] = wi.beta_l;
            for (j, wj) in shapes.iter().enumerate() {
                let overlap = integrate(l, |x| wi.value(x) * wj.value(x));
                let fourth = integrate(l, |x| wi.derivative(4, x) * wj.value(x));
                g.mass_kg[i][j] = rho_a * overlap;
                g.stiffness_n_m[i][j] = ei * fourth;
                g.damping_n_s_m[i][j] = ci * fourth;
            }
            g.input_z[i] = piezo
                * (wi.derivative(1, params.actuator_start_m)
                    - wi.derivative(1, params.actuator_end_m));
        }
        Ok(g)
    }
}

/// The diagonal modal model of the beam (eq. 21–24) for n modes: every
/// per-mode number from β_iL to the output weight.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BeamModal {
    /// Number of modes n (1..=[`MAX_MODES`]); entries beyond n are zero.
    pub modes: usize,
    /// Roots β_iL of eq. 20.
    pub beta_l: [f64; MAX_MODES],
    /// Wave numbers β_i (1/m).
    pub beta_per_m: [f64; MAX_MODES],
    /// Natural frequencies ω_i = √(k_ii/m_ii) (rad/s).
    pub omega_rad_s: [f64; MAX_MODES],
    /// Damping ratios ζ_i = c_ii/(2 m_ii ω_i); for Kelvin–Voigt damping
    /// ζ_i = (C/E)·ω_i/2.
    pub zeta: [f64; MAX_MODES],
    /// Modal masses m_ii (kg), eq. 54.
    pub mass_kg: [f64; MAX_MODES],
    /// Modal stiffnesses k_ii (N/m), eq. 56.
    pub stiffness_n_m: [f64; MAX_MODES],
    /// Modal damping c_ii (N·s/m), eq. 55.
    pub damping_n_s_m: [f64; MAX_MODES],
    /// Modal inputs z_i, eq. 57 (first line; N/(V·m), see the module docs).
    pub input_z: [f64; MAX_MODES],
    /// Modal input gains b̄_i = z_i/m_ii (eq. 24), in 1/(V·s²) as eq. 8 is
    /// written (m/(V·s²) once multiplied by the patch width; module docs).
    pub bbar: [f64; MAX_MODES],
    /// Output weights c_i (row C_w of eq. 22, C̄ of eq. 24).
    pub output_weight: [f64; MAX_MODES],
}

/// The state-space model of eq. 22 with X = [η_1..η_n, η̇_1..η̇_n]:
/// A = [0 I; −Ω² −2ζΩ], B = [0; B_w], C = [C_w 0]. Only the leading
/// 2n × 2n block (2n entries of B, C) is used; the rest is zero.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BeamStateSpace {
    /// Number of modes n; the state dimension is 2n.
    pub modes: usize,
    /// System matrix A (row-major).
    pub a: [[f64; MAX_ORDER]; MAX_ORDER],
    /// Input vector B.
    pub b: [f64; MAX_ORDER],
    /// Output row C.
    pub c: [f64; MAX_ORDER],
}

impl BeamStateSpace {
    /// State dimension 2n.
    pub fn order(&self) -> usize {
        2 * self.modes
    }
}

impl BeamModal {
    /// Modal model of the first `modes` (1..=[`MAX_MODES`]) modes of `params`.
    pub fn new(params: &BeamParams, modes: usize) -> Result<Self, BeamError> {
        let g = GalerkinMatrices::new(params, modes)?;
        let mut m = Self {
            modes,
            beta_l: [0.0; MAX_MODES],
            beta_per_m: [0.0; MAX_MODES],
            omega_rad_s: [0.0; MAX_MODES],
            zeta: [0.0; MAX_MODES],
            mass_kg: [0.0; MAX_MODES],
            stiffness_n_m: [0.0; MAX_MODES],
            damping_n_s_m: [0.0; MAX_MODES],
            input_z: [0.0; MAX_MODES],
            bbar: [0.0; MAX_MODES],
            output_weight: [0.0; MAX_MODES],
        };
        for i in 0..modes {
            let shape = ModeShape::new(i + 1, params.length_m)?;
            let (mass, stiffness, damping) = (
                g.mass_kg[i][i],
                g.stiffness_n_m[i][i],
                g.damping_n_s_m[i][i],
            );
            if !(is_positive_finite(mass) && is_positive_finite(stiffness)) {
                return Err(BeamError::NonFinite);
            }
            let omega = libm::sqrt(stiffness / mass);
            m.beta_l[i] = shape.beta_l;
            m.beta_per_m[i] = shape.beta_per_m;
            m.omega_rad_s[i] = omega;
            m.zeta[i] = damping / (2.0 * mass * omega);
            m.mass_kg[i] = mass;
            m.stiffness_n_m[i] = stiffness;
            m.damping_n_s_m[i] = damping;
            m.input_z[i] = g.input_z[i];
            m.bbar[i] = g.input_z[i] / mass;
            m.output_weight[i] = params.output_weight(&shape);
            let all = [omega, m.zeta[i], m.bbar[i], m.output_weight[i]];
            if !all.iter().all(|v| v.is_finite()) {
                return Err(BeamError::NonFinite);
            }
        }
        Ok(m)
    }

    /// The modal parameters (ω, ζ, b̄, c) of eq. 23–24 for the estimator side.
    pub fn modal_params(&self) -> ModalParams<f64> {
        let mut p = ModalParams {
            modes: self.modes,
            omega_rad_s: [0.0; MAX_MODES],
            zeta: [0.0; MAX_MODES],
            bbar: [0.0; MAX_MODES],
            output_weight: [0.0; MAX_MODES],
        };
        let n = self.modes;
        p.omega_rad_s[..n].copy_from_slice(&self.omega_rad_s[..n]);
        p.zeta[..n].copy_from_slice(&self.zeta[..n]);
        p.bbar[..n].copy_from_slice(&self.bbar[..n]);
        p.output_weight[..n].copy_from_slice(&self.output_weight[..n]);
        p
    }

    /// The state-space model of eq. 22.
    pub fn state_space(&self) -> BeamStateSpace {
        let n = self.modes;
        let mut ss = BeamStateSpace {
            modes: n,
            a: [[0.0; MAX_ORDER]; MAX_ORDER],
            b: [0.0; MAX_ORDER],
            c: [0.0; MAX_ORDER],
        };
        for i in 0..n {
            let w = self.omega_rad_s[i];
            ss.a[i][n + i] = 1.0;
            ss.a[n + i][i] = -w * w;
            ss.a[n + i][n + i] = -2.0 * self.zeta[i] * w;
            ss.b[n + i] = self.bbar[i];
            ss.c[i] = self.output_weight[i];
        }
        ss
    }

    /// Transfer function B(s)/A(s) of eq. 25–26 (generalised to n modes).
    pub fn transfer_function(&self) -> TransferFunction<f64> {
        self.modal_params().transfer_function()
    }
}

#[cfg(test)]
// The tests walk several per-mode arrays in step; an index reads best there.
#[allow(clippy::needless_range_loop)]
mod tests {
    use super::*;
    use crate::model::default_output_weight;
    use crate::scalar::isclose;

    const BETA_L_REF: [f64; 3] = [1.875_104_068_7, 4.694_091_133_0, 7.854_757_438_2];
    /// The same roots to 17 significant digits (mpmath, 40-digit arithmetic).
    const BETA_L_PRECISE: [f64; 3] = [
        1.875_104_068_711_961,
        4.694_091_132_974_175,
        7.854_757_438_237_613,
    ];

    fn shapes(n: usize) -> [ModeShape; MAX_MODES] {
        let l = BeamParams::paper().length_m;
        let mut s = [ModeShape::new(1, l).unwrap(); MAX_MODES];
        for (i, si) in s.iter_mut().enumerate().take(n) {
            *si = ModeShape::new(i + 1, l).unwrap();
        }
        s
    }

    #[test]
    fn frequency_roots_match_reference() {
        for (i, r) in BETA_L_REF.iter().enumerate() {
            let bl = frequency_root(i + 1).unwrap();
            assert!((bl - r).abs() < 1e-9, "mode {}: {bl}", i + 1);
            // 40-digit values (mpmath findroot) to near f64 resolution.
            assert!(
                isclose(bl, BETA_L_PRECISE[i], 4.0 * f64::EPSILON, 0.0),
                "mode {}",
                i + 1
            );
            // Eq. 20 itself, in its scaled form.
            assert!(frequency_function(bl).abs() < 4.0 * f64::EPSILON * bl);
        }
        // Higher roots: satisfy eq. 20 and approach (2i − 1)π/2.
        for i in 4..=30 {
            let bl = frequency_root(i).unwrap();
            let centre = (2 * i - 1) as f64 * PI / 2.0;
            // |g'| ≈ 1 near the root, so |g| is bounded by the spacing of f64 at βL.
            assert!(
                frequency_function(bl).abs() < 4.0 * f64::EPSILON * bl,
                "mode {i}"
            );
            assert!(
                (bl - centre).abs() < 2.01 * libm::exp(-centre) + 4.0 * f64::EPSILON * centre,
                "mode {i}"
            );
        }
        assert_eq!(frequency_root(0), Err(BeamError::ModeNumber));
    }

    #[test]
    fn paper_natural_frequencies() {
        let m = BeamParams::paper().modal(2).unwrap();
        assert!(
            isclose(m.omega_rad_s[0], 39.1603, 1e-5, 0.0),
            "{}",
            m.omega_rad_s[0]
        );
        assert!(
            isclose(m.omega_rad_s[1], 245.4132, 1e-5, 0.0),
            "{}",
            m.omega_rad_s[1]
        );
        // Table III's "true" values are 1.8e-4 lower (DESIGN.md §3).
        let table_iii = crate::model::PAPER_OMEGA;
        for i in 0..2 {
            let rel = m.omega_rad_s[i] / table_iii[i] - 1.0;
            assert!(rel > 1.5e-4 && rel < 2.0e-4, "mode {}: {rel}", i + 1);
        }
        // h from A and I.
        let p = BeamParams::paper();
        assert!(isclose(p.thickness_m, 1.000_25e-3, 1e-5, 0.0));
        assert!(isclose(p.width_m(), 0.079_98, 1e-4, 0.0));
    }

    #[test]
    fn mode_shapes_satisfy_boundary_conditions() {
        let l = 0.36;
        for i in 1..=8 {
            let w = ModeShape::new(i, l).unwrap();
            let b = w.beta_per_m;
            // Scale of the k-th derivative: 2·β^k.
            let at0 = w.derivatives(0.0);
            let at_l = w.derivatives(l);
            assert!(at0[0].abs() < 1e-12, "mode {i} W(0) = {}", at0[0]);
            assert!(at0[1].abs() < 1e-12 * 2.0 * b, "mode {i} W'(0)");
            assert!(at_l[2].abs() < 1e-12 * 2.0 * b * b, "mode {i} W''(L)");
            assert!(at_l[3].abs() < 1e-12 * 2.0 * b * b * b, "mode {i} W'''(L)");
            // Tip value 2·(−1)^i: the paper's C̄ = [−2, 2] (eq. 24).
            let tip = if i % 2 == 0 { 2.0 } else { -2.0 };
            assert!(
                isclose(at_l[0], tip, 1e-12, 0.0),
                "mode {i} W(L) = {}",
                at_l[0]
            );
            if i <= MAX_MODES {
                assert_eq!(tip, default_output_weight(i - 1));
            }
        }
        // The stable form keeps high modes finite and on their BCs.
        let w = ModeShape::new(200, l).unwrap();
        let b = w.beta_per_m;
        assert!(w.value(0.0).abs() < 1e-12);
        assert!(isclose(w.value(l), 2.0, 1e-12, 0.0));
        assert!(w.derivative(2, l).abs() < 1e-12 * 2.0 * b * b);
    }

    #[test]
    fn mode_shapes_solve_the_beam_equation_and_are_normalized() {
        let l = 0.36;
        for i in 1..=MAX_MODES {
            let w = ModeShape::new(i, l).unwrap();
            let b4 = libm::pow(w.beta_per_m, 4.0);
            for k in 0..=10 {
                let x = l * k as f64 / 10.0;
                // W'''' = β⁴W (eq. 6 separated); scale 2β⁴.
                assert!((w.derivative(4, x) - b4 * w.value(x)).abs() < 1e-12 * 2.0 * b4);
            }
            // Derivative formula against a central difference of the lower one.
            let (x, dx) = (0.21, 1e-6);
            for k in 0..4 {
                let fd = (w.derivative(k, x + dx) - w.derivative(k, x - dx)) / (2.0 * dx);
                let scale = 2.0 * libm::pow(w.beta_per_m, (k + 1) as f64);
                assert!(
                    (fd - w.derivative(k + 1, x)).abs() < 1e-7 * scale,
                    "mode {i} k {k}"
                );
            }
            // ∫W² = L, and σ from its defining expression.
            assert!(isclose(
                integrate(l, |x| w.value(x) * w.value(x)),
                l,
                1e-13,
                0.0
            ));
            let bl = w.beta_l;
            let sigma = (libm::cosh(bl) + libm::cos(bl)) / (libm::sinh(bl) + libm::sin(bl));
            assert!(isclose(w.sigma, sigma, 1e-14, 0.0));
            // The stable evaluation equals eq. 19 written out directly.
            for k in 0..=10 {
                let xi = w.beta_per_m * l * k as f64 / 10.0;
                let direct =
                    libm::cos(xi) - libm::cosh(xi) - sigma * (libm::sin(xi) - libm::sinh(xi));
                assert!(
                    (w.value(xi / w.beta_per_m) - direct).abs() < 1e-12,
                    "mode {i}"
                );
            }
        }
    }

    #[test]
    fn quadrature_rule_is_exact_to_degree_nine_per_panel() {
        let w: f64 = GL5_WEIGHTS.iter().sum();
        assert!(isclose(w, 2.0, 1e-15, 0.0));
        // Degree 9 is integrated exactly (up to rounding) on every panel.
        assert!(isclose(
            integrate(1.0, |x| libm::pow(x, 9.0)),
            0.1,
            1e-14,
            0.0
        ));
        assert!(isclose(integrate(PI, libm::sin), 2.0, 1e-14, 0.0));
    }

    #[test]
    fn galerkin_matrices_are_diagonal() {
        let g = BeamParams::paper().galerkin(MAX_MODES).unwrap();
        for i in 0..MAX_MODES {
            for j in 0..MAX_MODES {
                if i == j {
                    continue;
                }
                let m_scale = libm::sqrt(g.mass_kg[i][i] * g.mass_kg[j][j]);
                let k_scale = libm::sqrt(g.stiffness_n_m[i][i] * g.stiffness_n_m[j][j]);
                let c_scale = libm::sqrt(g.damping_n_s_m[i][i] * g.damping_n_s_m[j][j]);
                assert!(g.mass_kg[i][j].abs() < 1e-10 * m_scale, "m{i}{j}");
                assert!(g.stiffness_n_m[i][j].abs() < 1e-10 * k_scale, "k{i}{j}");
                assert!(g.damping_n_s_m[i][j].abs() < 1e-10 * c_scale, "c{i}{j}");
            }
        }
    }

    #[test]
    fn stiffness_equals_strain_energy_form() {
        // ∫EI W_i''''W_j = ∫EI W_i''W_j'' after two integrations by parts,
        // which is exact only with the boundary conditions of eq. 7.
        let p = BeamParams::paper();
        let g = p.galerkin(MAX_MODES).unwrap();
        let s = shapes(MAX_MODES);
        let ei = p.youngs_modulus_pa * p.inertia_m4;
        for i in 0..MAX_MODES {
            for j in 0..MAX_MODES {
                let energy = ei
                    * integrate(p.length_m, |x| {
                        s[i].derivative(2, x) * s[j].derivative(2, x)
                    });
                let scale = libm::sqrt(g.stiffness_n_m[i][i] * g.stiffness_n_m[j][j]);
                assert!(
                    (energy - g.stiffness_n_m[i][j]).abs() < 1e-10 * scale,
                    "{i}{j}"
                );
            }
        }
    }

    #[test]
    fn omega_from_galerkin_equals_closed_form() {
        let p = BeamParams::paper();
        let m = p.modal(MAX_MODES).unwrap();
        for i in 0..MAX_MODES {
            let closed = p.natural_frequency_rad_s(i + 1).unwrap();
            assert!(
                isclose(m.omega_rad_s[i], closed, 1e-12, 0.0),
                "mode {}",
                i + 1
            );
            let bl = BETA_L_REF[i];
            let textbook = bl * bl / (p.length_m * p.length_m) * p.wave_scale_m2_s();
            assert!(isclose(m.omega_rad_s[i], textbook, 1e-9, 0.0));
            // m_ii = ρAL with ∫W² = L.
            assert!(isclose(
                m.mass_kg[i],
                p.density_kg_m3 * p.area_m2 * p.length_m,
                1e-13,
                0.0
            ));
        }
    }

    #[test]
    fn kelvin_voigt_damping_ratio() {
        let p = BeamParams::paper();
        let m = p.modal(MAX_MODES).unwrap();
        let c_over_e = p.damping_pa_s / p.youngs_modulus_pa;
        for i in 0..MAX_MODES {
            assert!(isclose(
                m.zeta[i],
                0.5 * c_over_e * m.omega_rad_s[i],
                1e-12,
                0.0
            ));
        }
        // With Table I's C: ζ1 ≈ 0.00994, ζ2 ≈ 0.0623 (Table III: 0.0207, 0.13).
        assert!(isclose(m.zeta[0], 0.009_943, 1e-3, 0.0), "{}", m.zeta[0]);
        assert!(isclose(m.zeta[1], 0.062_31, 1e-3, 0.0), "{}", m.zeta[1]);
        let undamped = BeamParams {
            damping_pa_s: 0.0,
            ..p
        }
        .modal(2)
        .unwrap();
        assert_eq!(undamped.zeta[..2], [0.0, 0.0]);
    }

    #[test]
    fn input_z_matches_patch_curvature_integral() {
        // z_i = r_a d31 E_p [W'(x_a) − W'(x_b)] = −r_a d31 E_p ∫_{x_a}^{x_b} W''.
        let p = BeamParams::paper();
        let g = p.galerkin(MAX_MODES).unwrap();
        let s = shapes(MAX_MODES);
        let piezo = p.moment_arm_m * p.piezo_d31_m_v * p.piezo_modulus_pa;
        let span = p.actuator_end_m - p.actuator_start_m;
        for i in 0..MAX_MODES {
            let curvature = integrate(span, |x| s[i].derivative(2, p.actuator_start_m + x));
            assert!(
                isclose(g.input_z[i], -piezo * curvature, 1e-12, 0.0),
                "mode {}",
                i + 1
            );
        }
        // Near the clamp W_i'' < 0 (paper sign), d31 < 0: z_i < 0 for all modes.
        assert!(g.input_z.iter().all(|z| *z < 0.0));
    }

    /// C(jωI − A)⁻¹B by Gaussian elimination with partial pivoting on the
    /// complex 2n × 2n system (jωI − A)x = B.
    fn state_space_response(ss: &BeamStateSpace, omega: f64) -> (f64, f64) {
        let d = ss.order();
        let mut re = [[0.0; MAX_ORDER + 1]; MAX_ORDER];
        let mut im = [[0.0; MAX_ORDER + 1]; MAX_ORDER];
        for r in 0..d {
            for c in 0..d {
                re[r][c] = -ss.a[r][c];
            }
            im[r][r] = omega;
            re[r][d] = ss.b[r];
        }
        for col in 0..d {
            let piv = (col..d)
                .max_by(|&a, &b| {
                    libm::hypot(re[a][col], im[a][col])
                        .total_cmp(&libm::hypot(re[b][col], im[b][col]))
                })
                .unwrap();
            re.swap(col, piv);
            im.swap(col, piv);
            let (pr, pi) = (re[col][col], im[col][col]);
            let den = pr * pr + pi * pi;
            for r in 0..d {
                if r == col {
                    continue;
                }
                // factor = row[r][col] / pivot
                let (ar, ai) = (re[r][col], im[r][col]);
                let (fr, fi) = ((ar * pr + ai * pi) / den, (ai * pr - ar * pi) / den);
                for c in col..=d {
                    let (br, bi) = (re[col][c], im[col][c]);
                    re[r][c] -= fr * br - fi * bi;
                    im[r][c] -= fr * bi + fi * br;
                }
            }
        }
        let (mut yr, mut yi) = (0.0, 0.0);
        for r in 0..d {
            let (pr, pi) = (re[r][r], im[r][r]);
            let den = pr * pr + pi * pi;
            let (xr, xi) = (
                (re[r][d] * pr + im[r][d] * pi) / den,
                (im[r][d] * pr - re[r][d] * pi) / den,
            );
            yr += ss.c[r] * xr;
            yi += ss.c[r] * xi;
        }
        (yr, yi)
    }

    #[test]
    fn state_space_matches_transfer_function() {
        for output in [
            BeamOutput::Deflection,
            BeamOutput::Strain,
            BeamOutput::StrainAsTipDeflection,
        ] {
            let p = BeamParams {
                output,
                output_position_m: if output == BeamOutput::Deflection {
                    0.36
                } else {
                    0.02
                },
                ..BeamParams::paper()
            };
            for n in 1..=MAX_MODES {
                let m = p.modal(n).unwrap();
                let ss = m.state_space();
                let tf = m.transfer_function();
                for &w in &[0.0, 5.0, 39.0, 120.0, 245.0, 700.0, 3000.0] {
                    let (sr, si) = state_space_response(&ss, w);
                    let (tr, ti) = tf.freq_response(w);
                    let mag = libm::hypot(tr, ti);
                    assert!(
                        libm::hypot(sr - tr, si - ti) < 1e-10 * mag,
                        "{output:?} n={n} w={w}"
                    );
                }
            }
        }
    }

    #[test]
    fn modal_params_carry_the_modal_numbers() {
        let m = BeamParams::paper().modal(2).unwrap();
        let mp = m.modal_params();
        assert_eq!(mp.modes, 2);
        assert_eq!(mp.omega_rad_s, m.omega_rad_s);
        assert_eq!(mp.zeta, m.zeta);
        assert_eq!(mp.bbar, m.bbar);
        for i in 0..2 {
            assert!(isclose(
                mp.output_weight[i],
                default_output_weight(i),
                1e-9,
                0.0
            ));
            assert!(isclose(m.bbar[i], m.input_z[i] / m.mass_kg[i], 1e-15, 0.0));
        }
        assert_eq!(m.modes, 2);
        assert_eq!(m.omega_rad_s[2], 0.0);
    }

    #[test]
    fn strain_deflection_eq17() {
        let (l, h) = (0.36, 1.0e-3);
        let xs = 0.02;
        let l1 = l - xs;
        // Static tip force F: w(L) = FL³/(3EI) (eq. 15), ε(x_s) = F L1 h/(2EI) (eq. 16).
        let (f, ei) = (0.5, 1.93e11 * 6.67e-12);
        let tip = f * l * l * l / (3.0 * ei);
        let strain = f * l1 * h / (2.0 * ei);
        let w = deflection_from_strain(strain, l, l1, h).unwrap();
        assert!(isclose(w, tip, 1e-14, 0.0));
        let back = strain_from_deflection(w, l, l1, h).unwrap();
        assert!(isclose(back, strain, 1e-14, 0.0));
        assert!(isclose(
            strain_from_deflection(-1e-3, l, l1, h).unwrap(),
            -3.0 * l1 * h * 1e-3 / (2.0 * l * l * l),
            1e-14,
            0.0
        ));
        assert_eq!(
            deflection_from_strain(1e-6, l, 0.0, h),
            Err(BeamError::InvalidParameter(BeamParam::GaugeLeverArm))
        );
        assert_eq!(
            deflection_from_strain(f64::NAN, l, l1, h),
            Err(BeamError::InvalidParameter(BeamParam::Measurement))
        );
        assert_eq!(
            strain_from_deflection(1e-3, l, l1, -h),
            Err(BeamError::InvalidParameter(BeamParam::Thickness))
        );
    }

    #[test]
    fn strain_outputs_follow_eq17_scaling() {
        let xs = 0.02;
        let base = BeamParams {
            output_position_m: xs,
            ..BeamParams::paper()
        };
        let strain = BeamParams {
            output: BeamOutput::Strain,
            ..base
        }
        .modal(MAX_MODES)
        .unwrap();
        let eq17 = BeamParams {
            output: BeamOutput::StrainAsTipDeflection,
            ..base
        }
        .modal(MAX_MODES)
        .unwrap();
        let s = shapes(MAX_MODES);
        for i in 0..MAX_MODES {
            let expect = 0.5 * base.thickness_m * s[i].derivative(2, xs);
            assert!(isclose(strain.output_weight[i], expect, 1e-14, 0.0));
            let w = deflection_from_strain(
                strain.output_weight[i],
                base.length_m,
                base.length_m - xs,
                base.thickness_m,
            )
            .unwrap();
            assert!(isclose(eq17.output_weight[i], w, 1e-13, 0.0));
        }
        // Sign: with η_1 > 0 the paper-sign mode 1 deflects towards −w
        // (W_1 < 0, W_1'' < 0), compressing the −w face: c_1 < 0.
        assert!(strain.output_weight[0] < 0.0);
    }

    #[test]
    fn validate_rejects_bad_params() {
        let good = BeamParams::paper();
        assert_eq!(good.validate(), Ok(()));
        let cases: [(BeamParams, BeamError); 14] = [
            (
                BeamParams {
                    density_kg_m3: 0.0,
                    ..good
                },
                BeamError::InvalidParameter(BeamParam::Density),
            ),
            (
                BeamParams {
                    area_m2: -1.0,
                    ..good
                },
                BeamError::InvalidParameter(BeamParam::Area),
            ),
            (
                BeamParams {
                    youngs_modulus_pa: f64::NAN,
                    ..good
                },
                BeamError::InvalidParameter(BeamParam::YoungsModulus),
            ),
            (
                BeamParams {
                    inertia_m4: f64::INFINITY,
                    ..good
                },
                BeamError::InvalidParameter(BeamParam::Inertia),
            ),
            (
                BeamParams {
                    damping_pa_s: -1.0,
                    ..good
                },
                BeamError::InvalidParameter(BeamParam::Damping),
            ),
            (
                BeamParams {
                    length_m: 0.0,
                    ..good
                },
                BeamError::InvalidParameter(BeamParam::Length),
            ),
            (
                BeamParams {
                    thickness_m: 0.0,
                    ..good
                },
                BeamError::InvalidParameter(BeamParam::Thickness),
            ),
            (
                BeamParams {
                    piezo_d31_m_v: 0.0,
                    ..good
                },
                BeamError::InvalidParameter(BeamParam::PiezoD31),
            ),
            (
                BeamParams {
                    actuator_start_m: 0.06,
                    ..good
                },
                BeamError::ActuatorSpan,
            ),
            (
                BeamParams {
                    actuator_start_m: -0.001,
                    ..good
                },
                BeamError::ActuatorSpan,
            ),
            (
                BeamParams {
                    actuator_end_m: 0.4,
                    ..good
                },
                BeamError::ActuatorSpan,
            ),
            (
                BeamParams {
                    output_position_m: 0.37,
                    ..good
                },
                BeamError::OutputPosition,
            ),
            (
                BeamParams {
                    output_position_m: f64::NAN,
                    ..good
                },
                BeamError::OutputPosition,
            ),
            (
                BeamParams {
                    output: BeamOutput::StrainAsTipDeflection,
                    ..good
                },
                BeamError::OutputPosition,
            ),
        ];
        for (i, (p, e)) in cases.iter().enumerate() {
            assert_eq!(p.validate(), Err(*e), "case {i}");
            assert_eq!(p.modal(2).err(), Some(*e), "case {i}");
        }
        assert_eq!(good.modal(0).err(), Some(BeamError::ModeCount));
        assert_eq!(good.modal(MAX_MODES + 1).err(), Some(BeamError::ModeCount));
        assert_eq!(good.mode_shape(0).err(), Some(BeamError::ModeNumber));
    }
}
