//! ADC codes → physical signals: the bridge channel to strain (and to the
//! paper's deflection by eq. 17), the monitor channel to actuator volts.
//!
//! # The chain, with units
//! 1. **Code → volts at the ADC input.** V_adc = code·V_ref/(G_PGA·2²³)
//!    (ADS131M02 datasheet, "Data Format": FSR = ±1.2 V/Gain with the
//!    internal reference, LSB = 2·FSR/2²⁴).
//! 2. **→ bridge ratio.** V_r = s·(V_adc/G_amp − V_null)/V_exc: G_amp the
//!    gain of any amplifier between bridge and ADC (1 when the bridge feeds
//!    the ADC's PGA directly), V_null the bridge output at zero strain
//!    (the paper's "bridge offset nulling"), V_exc the bridge excitation,
//!    s = −1 if the bridge is wired with the opposite polarity.
//! 3. **→ strain.** Quarter bridge, active gauge R(1 + GF·ε) against three
//!    equal resistors R: V_r = GF·ε/(4 + 2·GF·ε), hence exactly
//!    ε = 4·V_r/(GF·(1 − 2·V_r)) ([`Linearisation::Exact`]). The usual
//!    small-strain form ε ≈ 4·V_r/GF ([`Linearisation::Linear`]) is
//!    off by the relative amount 2V_r ≈ GF·ε/2 (1e-3 at 1000 µε with
//!    GF = 2): a static scale error, but on a vibrating beam a second
//!    harmonic the linear model of eq. 22 cannot explain.
//! 4. **→ output y.** Either the strain itself, or eq. 17's deflection
//!    w = 2L³ε/(3L₁h) (Wang, Costa-Castelló, Na et al., *Modelling and
//!    Adaptive Parameter Estimation for a Piezoelectric Cantilever Beam*,
//!    Section II.C; L beam length, L₁ gauge-to-load distance, h thickness),
//!    as the paper did for its experiments.
//!
//! The monitor channel: u_mon = V_adc/k_mon with k_mon the ADC volts per
//! actuator volt of the amplifier's monitor output (and any divider).
//!
//! Every factor is folded at construction (in `f64`, rounded once to the
//! working type), so the sample path costs one multiply-subtract (linear)
//! or that plus one division (exact).

use crate::scalar::Real;

/// The ADS131M02's internal reference (V): FSR = ±1.2 V/Gain (datasheet,
/// "Data Format").
pub const ADS131M02_VREF_V: f64 = 1.2;
/// 2²³: codes per (V_ref/Gain) of a 24-bit two's-complement converter.
const CODES_PER_FS: f64 = 8_388_608.0;

/// Invalid conversion settings (each names the bad parameter).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ConversionError {
    /// Reference voltage not positive and finite.
    Reference,
    /// PGA gain not one of 1, 2, 4, …, 128 (ADS131M02 "PGA" settings).
    PgaGain,
    /// Bridge excitation not positive and finite.
    Excitation,
    /// Gauge factor not positive and finite.
    GaugeFactor,
    /// Bridge amplifier gain not positive and finite.
    Amplifier,
    /// Null offset not finite.
    Offset,
    /// Eq. 17 geometry (L, L₁, h) not positive and finite.
    Geometry,
    /// Monitor scale not non-zero and finite.
    Monitor,
}

impl core::fmt::Display for ConversionError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(match self {
            Self::Reference => "ADC reference voltage not positive and finite",
            Self::PgaGain => "PGA gain not a power of two in 1..=128",
            Self::Excitation => "bridge excitation not positive and finite",
            Self::GaugeFactor => "gauge factor not positive and finite",
            Self::Amplifier => "bridge amplifier gain not positive and finite",
            Self::Offset => "bridge null offset not finite",
            Self::Geometry => "eq. 17 geometry (L, L1, h) not positive and finite",
            Self::Monitor => "monitor scale zero or not finite",
        })
    }
}

impl core::error::Error for ConversionError {}

/// One ADC channel's scale.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AdcScale {
    /// Reference voltage (V).
    pub vref_v: f64,
    /// PGA gain (1, 2, 4, …, 128).
    pub pga_gain: u8,
}

impl AdcScale {
    /// Volts at the ADC input per code.
    pub fn volts_per_code(&self) -> Result<f64, ConversionError> {
        if !(self.vref_v > 0.0 && self.vref_v.is_finite()) {
            return Err(ConversionError::Reference);
        }
        if !(self.pga_gain.is_power_of_two() && self.pga_gain <= 128) {
            return Err(ConversionError::PgaGain);
        }
        Ok(self.vref_v / (f64::from(self.pga_gain) * CODES_PER_FS))
    }
}

/// Strain from the bridge ratio: exact or small-strain.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Linearisation {
    /// ε = 4V_r/GF.
    Linear,
    /// ε = 4V_r/(GF(1 − 2V_r)) (quarter bridge, exact).
    #[default]
    Exact,
}

/// The quarter bridge and its front end.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BridgeConfig {
    /// Bridge excitation V_exc (V).
    pub excitation_v: f64,
    /// Gauge factor GF (the paper's WFLA-6-11: ≈ 2.1).
    pub gauge_factor: f64,
    /// Gain between bridge output and ADC input (V/V).
    pub amplifier_gain: f64,
    /// Bridge output at zero strain V_null (V, before the amplifier).
    pub null_offset_v: f64,
    /// Exact or linearised strain.
    pub linearisation: Linearisation,
    /// The bridge is wired with the opposite polarity (s = −1).
    pub invert: bool,
}

/// The paper's eq. 17 geometry.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Eq17 {
    /// Beam length L (m).
    pub length_m: f64,
    /// Gauge-to-load distance L₁ (m).
    pub gauge_lever_arm_m: f64,
    /// Beam thickness h (m).
    pub thickness_m: f64,
}

impl Eq17 {
    /// w/ε = 2L³/(3L₁h) (m per unit strain).
    pub(crate) fn factor_m(&self) -> Result<f64, ConversionError> {
        let (l, l1, h) = (self.length_m, self.gauge_lever_arm_m, self.thickness_m);
        if [l, l1, h].iter().all(|v| *v > 0.0 && v.is_finite()) {
            Ok(2.0 * l * l * l / (3.0 * l1 * h))
        } else {
            Err(ConversionError::Geometry)
        }
    }
}

/// What the estimator's y is.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum OutputQuantity {
    /// Strain ε (dimensionless).
    Strain,
    /// Eq. 17 deflection (m).
    Deflection(Eq17),
}

/// Everything that maps codes to signals.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ConversionConfig {
    /// Channel 0 (bridge) scale.
    pub bridge_adc: AdcScale,
    /// The bridge.
    pub bridge: BridgeConfig,
    /// y = strain or eq. 17 deflection.
    pub output: OutputQuantity,
    /// Channel 1 (monitor) scale.
    pub monitor_adc: AdcScale,
    /// ADC volts per actuator volt on the monitor channel (V/V, sign
    /// included).
    pub monitor_v_per_v: f64,
}

impl ConversionConfig {
    /// Validate and fold into the per-sample form.
    pub fn compile<T: Real>(&self) -> Result<Conversion<T>, ConversionError> {
        let f = self.factors()?;
        Ok(Conversion {
            code_to_ratio: T::from_f64(f.code_to_ratio),
            null_ratio: T::from_f64(f.null_ratio),
            ratio_to_y: T::from_f64(f.ratio_to_y),
            exact: self.bridge.linearisation == Linearisation::Exact,
            code_to_u: T::from_f64(f.code_to_u),
        })
    }

    fn factors(&self) -> Result<Factors, ConversionError> {
        let b = &self.bridge;
        let pos = |v: f64| v > 0.0 && v.is_finite();
        if !pos(b.excitation_v) {
            return Err(ConversionError::Excitation);
        }
        if !pos(b.gauge_factor) {
            return Err(ConversionError::GaugeFactor);
        }
        if !pos(b.amplifier_gain) {
            return Err(ConversionError::Amplifier);
        }
        if !b.null_offset_v.is_finite() {
            return Err(ConversionError::Offset);
        }
        let m = self.monitor_v_per_v;
        if !(m != 0.0 && m.is_finite()) {
            return Err(ConversionError::Monitor);
        }
        let s = if b.invert { -1.0 } else { 1.0 };
        let out = match self.output {
            OutputQuantity::Strain => 1.0,
            OutputQuantity::Deflection(g) => g.factor_m()?,
        };
        Ok(Factors {
            code_to_ratio: s * self.bridge_adc.volts_per_code()?
                / (b.amplifier_gain * b.excitation_v),
            null_ratio: s * b.null_offset_v / b.excitation_v,
            ratio_to_y: 4.0 / b.gauge_factor * out,
            code_to_u: self.monitor_adc.volts_per_code()? / m,
        })
    }

    /// The bridge code an ideal converter gives for output `y` (inverse of
    /// the chain, in `f64`, rounded to nearest and clipped to 24 bits): for
    /// simulated converters and tests. `None` if the settings are invalid
    /// or y is beyond the bridge's range.
    pub fn bridge_code_for(&self, y: f64) -> Option<i32> {
        let f = self.factors().ok()?;
        let eps_term = y / f.ratio_to_y; // = V_r (linear) or V_r/(1 − 2V_r)
        let vr = match self.bridge.linearisation {
            Linearisation::Linear => eps_term,
            Linearisation::Exact => eps_term / (1.0 + 2.0 * eps_term),
        };
        let code = (vr + f.null_ratio) / f.code_to_ratio;
        quantise(code)
    }

    /// The monitor code an ideal converter gives for actuator voltage `u`.
    pub fn monitor_code_for(&self, u_v: f64) -> Option<i32> {
        let f = self.factors().ok()?;
        quantise(u_v / f.code_to_u)
    }

    /// The chain run backwards to the ADC's analog inputs (validates the
    /// settings): what a simulated front end feeds a converter model.
    pub fn analog_front_end(&self) -> Result<AnalogFrontEnd, ConversionError> {
        let f = self.factors()?;
        let b = &self.bridge;
        let s = if b.invert { -1.0 } else { 1.0 };
        Ok(AnalogFrontEnd {
            ratio_to_y: f.ratio_to_y,
            null_ratio: f.null_ratio,
            adc_v_per_ratio: s * b.amplifier_gain * b.excitation_v,
            exact: b.linearisation == Linearisation::Exact,
            monitor_v_per_v: self.monitor_v_per_v,
        })
    }
}

/// The simulated analog side of [`ConversionConfig`], in `f64`: output y →
/// bridge → amplifier → volts at the ADC's channel 0, and actuator volts →
/// monitor → volts at channel 1, before any quantisation (the converter
/// model quantises). Steps 2–4 of the module docs inverted:
/// V_r = ε·GF/4 (linear) or e/(1 + 2e) with e = ε·GF/4 (exact quarter
/// bridge), V_adc = G_amp·(s·V_r·V_exc + V_null).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AnalogFrontEnd {
    ratio_to_y: f64,
    null_ratio: f64,
    /// s·G_amp·V_exc: ADC volts per unit of (V_r + s·V_null/V_exc).
    adc_v_per_ratio: f64,
    exact: bool,
    monitor_v_per_v: f64,
}

impl AnalogFrontEnd {
    /// Volts at the ADC's bridge input for output `y` (strain or m). Beyond
    /// the quarter bridge's range (V_r → ±∞) the result is ±∞ or NaN, which
    /// a converter model clips or rejects.
    #[inline]
    pub fn bridge_volts(&self, y: f64) -> f64 {
        let e = y / self.ratio_to_y;
        let vr = if self.exact { e / (1.0 + 2.0 * e) } else { e };
        (vr + self.null_ratio) * self.adc_v_per_ratio
    }

    /// Volts at the ADC's monitor input for actuator voltage `u_v`.
    #[inline]
    pub(crate) fn monitor_volts(&self, u_v: f64) -> f64 {
        u_v * self.monitor_v_per_v
    }
}

fn quantise(code: f64) -> Option<i32> {
    if !code.is_finite() {
        return None;
    }
    let c = libm::round(code).clamp(
        f64::from(super::converters::ADC_CODE_MIN),
        f64::from(super::converters::ADC_CODE_MAX),
    );
    Some(c as i32)
}

struct Factors {
    code_to_ratio: f64,
    null_ratio: f64,
    ratio_to_y: f64,
    code_to_u: f64,
}

/// The folded conversion, in working precision.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Conversion<T> {
    code_to_ratio: T,
    null_ratio: T,
    ratio_to_y: T,
    exact: bool,
    code_to_u: T,
}

impl<T: Real> Conversion<T> {
    /// y (strain or m) from a bridge code.
    #[inline]
    pub fn y_from_code(&self, code: i32) -> T {
        let vr = T::from_i32(code) * self.code_to_ratio - self.null_ratio;
        if self.exact {
            self.ratio_to_y * vr / (T::ONE - (vr + vr))
        } else {
            self.ratio_to_y * vr
        }
    }

    /// Actuator volts from a monitor code.
    #[inline]
    pub fn u_from_monitor(&self, code: i32) -> T {
        T::from_i32(code) * self.code_to_u
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used, clippy::indexing_slicing)]
mod tests {
    use super::*;

    pub(crate) fn rig() -> ConversionConfig {
        ConversionConfig {
            bridge_adc: AdcScale {
                vref_v: ADS131M02_VREF_V,
                pga_gain: 128,
            },
            bridge: BridgeConfig {
                excitation_v: 5.0,
                gauge_factor: 2.1,
                amplifier_gain: 1.0,
                null_offset_v: 1e-5,
                linearisation: Linearisation::Exact,
                invert: false,
            },
            output: OutputQuantity::Deflection(Eq17 {
                length_m: 0.36,
                gauge_lever_arm_m: 0.34,
                thickness_m: 1e-3,
            }),
            monitor_adc: AdcScale {
                vref_v: ADS131M02_VREF_V,
                pga_gain: 1,
            },
            monitor_v_per_v: 0.01,
        }
    }

    #[test]
    fn chain_matches_the_formulas() {
        let cfg = rig();
        let conv = cfg.compile::<f64>().unwrap();
        let code = 1_234_567;
        // Independent evaluation of steps 1–4.
        let v_adc = code as f64 * 1.2 / (128.0 * 8_388_608.0);
        let vr = (v_adc / 1.0 - 1e-5) / 5.0;
        let eps = 4.0 * vr / (2.1 * (1.0 - 2.0 * vr));
        let w = 2.0 * 0.36f64.powi(3) * eps / (3.0 * 0.34 * 1e-3);
        assert!((conv.y_from_code(code) / w - 1.0).abs() < 1e-14);
        // Eq. 17 as the beam module implements it.
        let w_beam = crate::beam::deflection_from_strain(eps, 0.36, 0.34, 1e-3).unwrap();
        assert!((w / w_beam - 1.0).abs() < 1e-15);
        // Linear form differs by 2V_r relative.
        let mut lin = cfg;
        lin.bridge.linearisation = Linearisation::Linear;
        let wl = lin.compile::<f64>().unwrap().y_from_code(code);
        assert!(((w - wl) / w - 2.0 * vr).abs() < 1e-9);
        // Monitor: code·1.2/2²³/0.01.
        let u = conv.u_from_monitor(-700_000);
        assert!((u - (-700_000.0 * 1.2 / 8_388_608.0 / 0.01)).abs() < 1e-12);
        // Inversion flips the strain sign around the null.
        let mut inv = cfg;
        inv.bridge.invert = true;
        inv.bridge.null_offset_v = 0.0;
        let mut plain = cfg;
        plain.bridge.null_offset_v = 0.0;
        let a = plain.compile::<f64>().unwrap().y_from_code(5000);
        let b = inv.compile::<f64>().unwrap().y_from_code(-5000);
        assert_eq!(a, b);
    }

    #[test]
    fn inverse_round_trips_within_half_a_code() {
        let cfg = rig();
        let conv = cfg.compile::<f64>().unwrap();
        for y in [-2e-3, -1e-6, 0.0, 3e-7, 1.5e-3] {
            let code = cfg.bridge_code_for(y).unwrap();
            let back = conv.y_from_code(code);
            let lsb = conv.y_from_code(code + 1) - back;
            assert!((back - y).abs() <= 0.5 * lsb.abs() * 1.0001, "{y}: {back}");
        }
        // Clipping at full scale, codes for the monitor.
        assert_eq!(cfg.bridge_code_for(1.0), Some(0x7F_FFFF));
        assert_eq!(cfg.bridge_code_for(-1.0), Some(-0x80_0000));
        assert_eq!(cfg.bridge_code_for(f64::NAN), None);
        let m = cfg.monitor_code_for(50.0).unwrap();
        // Half an LSB: 1.2 V/2²⁴ at the ADC, ÷ 0.01 V/V.
        assert!((conv.u_from_monitor(m) - 50.0).abs() <= 0.6 * 1.2 / 8_388_608.0 / 0.01);
    }

    #[test]
    fn analog_front_end_inverts_the_chain() {
        for invert in [false, true] {
            for lin in [Linearisation::Exact, Linearisation::Linear] {
                let mut cfg = rig();
                cfg.bridge.invert = invert;
                cfg.bridge.linearisation = lin;
                cfg.bridge.amplifier_gain = 3.0;
                let fe = cfg.analog_front_end().unwrap();
                let vpc = cfg.bridge_adc.volts_per_code().unwrap();
                for y in [-2e-3, -1e-6, 0.0, 3e-7, 1.5e-3] {
                    // Volts → code (unrounded) → y is the identity.
                    let code = fe.bridge_volts(y) / vpc;
                    let vr = code * 1.2 / (128.0 * 8_388_608.0) / 3.0;
                    let s = if invert { -1.0 } else { 1.0 };
                    let ratio = s * (vr - 1e-5) / 5.0;
                    let eps = match lin {
                        Linearisation::Exact => 4.0 * ratio / (2.1 * (1.0 - 2.0 * ratio)),
                        Linearisation::Linear => 4.0 * ratio / 2.1,
                    };
                    let w = 2.0 * 0.36f64.powi(3) * eps / (3.0 * 0.34 * 1e-3);
                    assert!((w - y).abs() <= 1e-12 * y.abs().max(1e-9), "{y}: {w}");
                    // and the rounded code is the one bridge_code_for gives.
                    let c = cfg.bridge_code_for(y).unwrap();
                    assert!((code.round() - f64::from(c)).abs() <= 1.0, "{y}");
                }
                assert_eq!(fe.monitor_volts(50.0), 0.5);
            }
        }
        assert_eq!(
            {
                let mut c = rig();
                c.bridge.gauge_factor = 0.0;
                c.analog_front_end()
            },
            Err(ConversionError::GaugeFactor)
        );
    }

    #[test]
    fn rejects_bad_settings() {
        let bad = |f: fn(&mut ConversionConfig)| {
            let mut c = rig();
            f(&mut c);
            c.compile::<f32>().unwrap_err()
        };
        assert_eq!(bad(|c| c.bridge_adc.pga_gain = 3), ConversionError::PgaGain);
        assert_eq!(
            bad(|c| c.bridge_adc.vref_v = 0.0),
            ConversionError::Reference
        );
        assert_eq!(
            bad(|c| c.bridge.excitation_v = -5.0),
            ConversionError::Excitation
        );
        assert_eq!(
            bad(|c| c.bridge.gauge_factor = f64::NAN),
            ConversionError::GaugeFactor
        );
        assert_eq!(
            bad(|c| c.bridge.amplifier_gain = 0.0),
            ConversionError::Amplifier
        );
        assert_eq!(
            bad(|c| c.bridge.null_offset_v = f64::INFINITY),
            ConversionError::Offset
        );
        assert_eq!(bad(|c| c.monitor_v_per_v = 0.0), ConversionError::Monitor);
        assert_eq!(
            bad(|c| c.output = OutputQuantity::Deflection(Eq17 {
                length_m: 0.36,
                gauge_lever_arm_m: 0.0,
                thickness_m: 1e-3
            })),
            ConversionError::Geometry
        );
    }
}
