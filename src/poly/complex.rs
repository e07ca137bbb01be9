//! A complex number with only the operations the root finder and modal
//! recovery need (no dependency on an external complex crate, generic over
//! [`Real`]).

use crate::scalar::Real;
use core::ops::{Add, Div, Mul, Neg, Sub};

/// A complex number, only as much as the root finder and modal recovery need.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Complex<T> {
    /// Real part.
    pub re: T,
    /// Imaginary part.
    pub im: T,
}

impl<T: Real> Complex<T> {
    /// `re + j·im`.
    pub const fn new(re: T, im: T) -> Self {
        Self { re, im }
    }

    /// A real number as a complex one.
    pub fn from_real(re: T) -> Self {
        Self { re, im: T::ZERO }
    }

    /// Complex conjugate.
    pub fn conj(self) -> Self {
        Self::new(self.re, -self.im)
    }

    /// Modulus |z| (overflow-safe, via `hypot`).
    pub fn norm(self) -> T {
        self.re.hypot(self.im)
    }

    /// Multiply by a real number.
    pub fn scale(self, k: T) -> Self {
        Self::new(self.re * k, self.im * k)
    }

    /// True if both parts are finite.
    pub fn is_finite(self) -> bool {
        self.re.is_finite() && self.im.is_finite()
    }
}

impl<T: Real> Add for Complex<T> {
    type Output = Self;
    fn add(self, o: Self) -> Self {
        Self::new(self.re + o.re, self.im + o.im)
    }
}

impl<T: Real> Sub for Complex<T> {
    type Output = Self;
    fn sub(self, o: Self) -> Self {
        Self::new(self.re - o.re, self.im - o.im)
    }
}

impl<T: Real> Mul for Complex<T> {
    type Output = Self;
    fn mul(self, o: Self) -> Self {
        Self::new(
            self.re * o.re - self.im * o.im,
            self.re * o.im + self.im * o.re,
        )
    }
}

impl<T: Real> Div for Complex<T> {
    type Output = Self;
    /// Smith's algorithm (no intermediate overflow for moderate operands).
    /// Division by zero gives non-finite parts, as for real floats.
    fn div(self, o: Self) -> Self {
        if o.re.abs() >= o.im.abs() {
            let r = o.im / o.re;
            let den = o.re + o.im * r;
            Self::new((self.re + self.im * r) / den, (self.im - self.re * r) / den)
        } else {
            let r = o.re / o.im;
            let den = o.re * r + o.im;
            Self::new((self.re * r + self.im) / den, (self.im * r - self.re) / den)
        }
    }
}

impl<T: Real> Neg for Complex<T> {
    type Output = Self;
    fn neg(self) -> Self {
        Self::new(-self.re, -self.im)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn complex_division_is_smith_stable() {
        let q = Complex::new(1e300f64, 1e300) / Complex::new(1e300, 1e300);
        assert_eq!(q, Complex::new(1.0, 0.0));
        let q = Complex::new(1.0f64, 2.0) / Complex::new(3.0, -4.0);
        assert!((q - Complex::new(-0.2, 0.4)).norm() < 1e-16);
    }
}
