//! The floating-point abstraction every module of the core is generic over.
//!
//! One small trait, implemented for `f32` and `f64` through [`libm`], so the
//! same code serves a Cortex-M7 (double-precision FPU), a Cortex-M4F
//! (single-precision only) and the host.
//!
//! # Design
//! Only the operations the core really uses are here. Conversions go through
//! `f64` ([`Real::from_f64`], [`Real::to_f64`]): constants and one-off
//! start-up computations (matrix exponentials, scale factors) are done in
//! `f64` and rounded once, the per-sample path never converts.

use core::fmt::Debug;
use core::ops::{Add, AddAssign, Div, DivAssign, Mul, MulAssign, Neg, Sub, SubAssign};

/// A real floating-point scalar (`f32` or `f64`).
pub trait Real:
    Copy
    + Debug
    + Default
    + PartialEq
    + PartialOrd
    + Add<Output = Self>
    + Sub<Output = Self>
    + Mul<Output = Self>
    + Div<Output = Self>
    + Neg<Output = Self>
    + AddAssign
    + SubAssign
    + MulAssign
    + DivAssign
    + 'static
{
    /// Additive identity.
    const ZERO: Self;
    /// Multiplicative identity.
    const ONE: Self;
    /// Machine epsilon.
    const EPSILON: Self;
    /// Largest finite value.
    const MAX: Self;
    /// Short name used in reports (`"f32"` / `"f64"`).
    const NAME: &'static str;
    /// Whether long sums and the W residual (eq. 35) use compensated
    /// (double-word) arithmetic, see `src/compensated.rs`. `true` for
    /// `f32`, whose 24-bit mantissa cannot hold P otherwise (cond(P) ≈ 9e5
    /// for the paper's plant, ~1e8 with a weak high mode);
    /// `false` for `f64`, where plain arithmetic already reaches ~1e-10.
    const COMPENSATED: bool;
    /// Veltkamp splitting constant 2^⌈p/2⌉ + 1 for Dekker's exact product.
    const SPLITTER: Self;

    /// Round an `f64` to this type.
    fn from_f64(x: f64) -> Self;
    /// Widen to `f64`.
    fn to_f64(self) -> f64;
    /// Exact for |n| ≤ 2^24 in `f32` (every 24-bit ADC code), always in
    /// `f64`; a single integer-to-float instruction on an FPU (no detour
    /// through `f64`, which is software on a single-precision FPU).
    fn from_i32(n: i32) -> Self;
    /// Convert a small count.
    fn from_usize(n: usize) -> Self {
        Self::from_f64(n as f64)
    }
    /// Square root.
    fn sqrt(self) -> Self;
    /// Absolute value.
    fn abs(self) -> Self;
    /// e^x.
    fn exp(self) -> Self;
    /// Natural logarithm.
    fn ln(self) -> Self;
    /// Sine.
    fn sin(self) -> Self;
    /// Cosine.
    fn cos(self) -> Self;
    /// Hyperbolic sine.
    fn sinh(self) -> Self;
    /// Hyperbolic cosine.
    fn cosh(self) -> Self;
    /// Four-quadrant arctangent.
    fn atan2(self, x: Self) -> Self;
    /// √(x² + y²) without undue overflow.
    fn hypot(self, other: Self) -> Self;
    /// x^n for a small integer exponent.
    fn powi(self, n: i32) -> Self {
        let mut acc = Self::ONE;
        let mut base = if n < 0 { Self::ONE / self } else { self };
        let mut e = n.unsigned_abs();
        while e > 0 {
            if e & 1 == 1 {
                acc *= base;
            }
            base *= base;
            e >>= 1;
        }
        acc
    }
    /// True when neither NaN nor infinite.
    fn is_finite(self) -> bool;
    /// True for NaN.
    fn is_nan(self) -> bool;
    /// The larger of two values (NaN-ignoring like `f64::max`).
    fn max(self, other: Self) -> Self {
        if self >= other || other.is_nan() {
            self
        } else {
            other
        }
    }
    /// The smaller of two values (NaN-ignoring like `f64::min`).
    fn min(self, other: Self) -> Self {
        if self <= other || other.is_nan() {
            self
        } else {
            other
        }
    }
}

macro_rules! impl_real {
    ($t:ty, $name:literal, $comp:literal, $split:literal, $sqrt:path, $exp:path, $ln:path, $sin:path, $cos:path,
     $sinh:path, $cosh:path, $atan2:path, $hypot:path) => {
        impl Real for $t {
            const ZERO: Self = 0.0;
            const ONE: Self = 1.0;
            const EPSILON: Self = <$t>::EPSILON;
            const MAX: Self = <$t>::MAX;
            const NAME: &'static str = $name;
            const COMPENSATED: bool = $comp;
            const SPLITTER: Self = $split;

            #[inline(always)]
            fn from_f64(x: f64) -> Self {
                x as $t
            }
            #[inline(always)]
            fn to_f64(self) -> f64 {
                self as f64
            }
            #[inline(always)]
            fn from_i32(n: i32) -> Self {
                n as $t
            }
            #[inline(always)]
            fn sqrt(self) -> Self {
                $sqrt(self)
            }
            #[inline(always)]
            fn abs(self) -> Self {
                if self < 0.0 {
                    -self
                } else {
                    self
                }
            }
            #[inline(always)]
            fn exp(self) -> Self {
                $exp(self)
            }
            #[inline(always)]
            fn ln(self) -> Self {
                $ln(self)
            }
            #[inline(always)]
            fn sin(self) -> Self {
                $sin(self)
            }
            #[inline(always)]
            fn cos(self) -> Self {
                $cos(self)
            }
            #[inline(always)]
            fn sinh(self) -> Self {
                $sinh(self)
            }
            #[inline(always)]
            fn cosh(self) -> Self {
                $cosh(self)
            }
            #[inline(always)]
            fn atan2(self, x: Self) -> Self {
                $atan2(self, x)
            }
            #[inline(always)]
            fn hypot(self, other: Self) -> Self {
                $hypot(self, other)
            }
            #[inline(always)]
            fn is_finite(self) -> bool {
                <$t>::is_finite(self)
            }
            #[inline(always)]
            fn is_nan(self) -> bool {
                <$t>::is_nan(self)
            }
        }
    };
}

impl_real!(
    f32,
    "f32",
    true,
    4097.0,
    libm::sqrtf,
    libm::expf,
    libm::logf,
    libm::sinf,
    libm::cosf,
    libm::sinhf,
    libm::coshf,
    libm::atan2f,
    libm::hypotf
);
impl_real!(
    f64,
    "f64",
    false,
    134217729.0,
    libm::sqrt,
    libm::exp,
    libm::log,
    libm::sin,
    libm::cos,
    libm::sinh,
    libm::cosh,
    libm::atan2,
    libm::hypot
);

/// Relative closeness check used by tests and validation:
/// `|a − b| ≤ atol + rtol·|b|`.
pub fn isclose<T: Real>(a: T, b: T, rtol: T, atol: T) -> bool {
    (a - b).abs() <= atol + rtol * b.abs()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn powi_matches_repeated_multiplication() {
        assert_eq!(2.0f64.powi(10), 1024.0);
        assert_eq!(Real::powi(2.0f32, -2), 0.25);
        assert_eq!(Real::powi(3.0f64, 0), 1.0);
    }

    #[test]
    fn libm_backed_functions_agree_with_std() {
        for &x in &[0.1f64, 1.0, 2.5, -3.0] {
            assert!(isclose(Real::exp(x), x.exp(), 1e-15, 0.0));
            assert!(isclose(Real::cosh(x), x.cosh(), 1e-15, 0.0));
            assert!(isclose(Real::atan2(x, 0.7), x.atan2(0.7), 1e-15, 0.0));
        }
        assert!(!Real::is_finite(f32::NAN));
        assert_eq!(Real::max(1.0f64, f64::NAN), 1.0);
    }
}
