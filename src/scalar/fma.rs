//! The fused multiply-add a·b ± c, rounded once: [`Real::mul_add`] and
//! [`Real::mul_sub`] for both scalar types, and the one route from the core
//! to the FPU's `VFMA` / `VFNMS`.
//!
//! # Why this module exists
//! The compensated arithmetic of the f32 estimator (`compensated.rs`) needs
//! the exact error of a product, a·b − fl(a·b). With a fused multiply-add
//! that error is one instruction, `fma(a, b, −p)`; without one it is
//! Dekker's product with Veltkamp splitting, 17 operations. The Cortex-M4F
//! (FPv4-SP) and the Cortex-M7 (FPv5-D16) have `VFMA.F32`, the M7 also
//! `VFMA.F64`. Stable Rust gives `no_std` code no route to them:
//! `f32::mul_add` is in `std` only (the `core` version is the unstable
//! `core_float_math`), `core::intrinsics::fmaf32` is unstable, LLVM turns
//! `a * b + c` into the unfused `VMLA` (two roundings, as written), the
//! global `-C llvm-args=-fp-contract=fast` would fuse wherever LLVM likes
//! (including inside the error-free transformations, which it would
//! break), and `libm::fmaf` is a software routine on `thumbv7em` (libm has
//! hardware paths for x86 and AArch64 only). Hence an `asm!` wrapper.
//!
//! # Routes (chosen by `build.rs`, since stable `cfg` sees no ARM FPU
//! features)
//! * `f32`, `cfg(beamest_fma_f32)` (`thumbv7em-*-eabihf`, whose target
//!   specification enables FPv4-SP): `VFMA.F32`.
//! * `f64`, `cfg(beamest_fma_f64)` (the same target with
//!   `-C target-cpu=cortex-m7`, FPv5-D16): `VFMA.F64`. Never on the M4F,
//!   which has no double-precision FPU (the assembler would refuse the
//!   instruction there, and the core would fault on it).
//! * Everywhere else: `libm::fmaf` / `libm::fma`, the correctly rounded
//!   software fused multiply-add (on x86-64 libm itself takes the `FMA`
//!   instruction when the CPU has it). The instruction and the software
//!   both round a·b + c once to nearest-even, so the host computes the
//!   estimator bit for bit as the firmware does (test
//!   `fma_matches_the_software_two_product` below; the QEMU image checks
//!   the instruction against fixed triples at boot).
//!
//! # `unsafe`
//! The four `asm!` blocks here are the only `unsafe` code of the core
//! outside the board layer (`src/lib.rs` forbids it everywhere else; in
//! builds with these routes it denies it, and this module alone opts back
//! in).
//!
//! [`Real::mul_add`]: crate::scalar::Real::mul_add
//! [`Real::mul_sub`]: crate::scalar::Real::mul_sub

/// a·b + c with a single rounding (IEEE 754 fusedMultiplyAdd, round to
/// nearest even).
#[inline(always)]
pub(crate) fn mul_add_f32(a: f32, b: f32, c: f32) -> f32 {
    #[cfg(beamest_fma_f32)]
    {
        vfma_f32(a, b, c)
    }
    #[cfg(not(beamest_fma_f32))]
    {
        libm::fmaf(a, b, c)
    }
}

/// a·b + c with a single rounding, in double precision.
#[inline(always)]
pub(crate) fn mul_add_f64(a: f64, b: f64, c: f64) -> f64 {
    #[cfg(beamest_fma_f64)]
    {
        vfma_f64(a, b, c)
    }
    #[cfg(not(beamest_fma_f64))]
    {
        libm::fma(a, b, c)
    }
}

/// a·b − c with a single rounding (the exact error of a product p = fl(a·b)
/// is `mul_sub_f32(a, b, p)`, one `VFNMS` instead of a negation and a
/// `VFMA`).
#[inline(always)]
pub(crate) fn mul_sub_f32(a: f32, b: f32, c: f32) -> f32 {
    #[cfg(beamest_fma_f32)]
    {
        vfnms_f32(a, b, c)
    }
    #[cfg(not(beamest_fma_f32))]
    {
        libm::fmaf(a, b, -c)
    }
}

/// a·b − c with a single rounding, in double precision.
#[inline(always)]
pub(crate) fn mul_sub_f64(a: f64, b: f64, c: f64) -> f64 {
    #[cfg(beamest_fma_f64)]
    {
        vfnms_f64(a, b, c)
    }
    #[cfg(not(beamest_fma_f64))]
    {
        libm::fma(a, b, -c)
    }
}

/// `VFMA.F32 Sd, Sn, Sm`: Sd ← Sd + Sn·Sm, rounded once.
#[cfg(beamest_fma_f32)]
#[allow(unsafe_code)]
#[inline(always)]
fn vfma_f32(a: f32, b: f32, c: f32) -> f32 {
    let mut acc = c;
    // SAFETY: `beamest_fma_f32` is set only for `thumbv7em-*-eabihf`, whose
    // target enables FPv4-SP (Cortex-M4F, M7), so the instruction exists and
    // the FPU is on (the hard-float ABI requires it before `main`). It reads
    // and writes only the three S registers named here: no memory, no
    // stack. It may raise the FPSCR's cumulative exception flags, exactly
    // as the compiler's own `VMUL`/`VADD` do (no `preserves_flags`); the
    // rounding mode is the default round-to-nearest that the compiler
    // assumes everywhere, and flush-to-zero is whatever it is for every
    // other float instruction of the image.
    unsafe {
        core::arch::asm!(
            "vfma.f32 {acc}, {a}, {b}",
            acc = inout(sreg) acc,
            a = in(sreg) a,
            b = in(sreg) b,
            options(pure, nomem, nostack),
        );
    }
    acc
}

/// `VFMA.F64 Dd, Dn, Dm`: Dd ← Dd + Dn·Dm, rounded once.
#[cfg(beamest_fma_f64)]
#[allow(unsafe_code)]
#[inline(always)]
fn vfma_f64(a: f64, b: f64, c: f64) -> f64 {
    let mut acc = c;
    // SAFETY: `beamest_fma_f64` is set only with `-C target-cpu=cortex-m7`
    // (FPv5-D16, double precision in hardware), so the instruction exists;
    // otherwise as in `vfma_f32`: registers only, no memory, no stack.
    unsafe {
        core::arch::asm!(
            "vfma.f64 {acc}, {a}, {b}",
            acc = inout(dreg_low16) acc,
            a = in(dreg_low16) a,
            b = in(dreg_low16) b,
            options(pure, nomem, nostack),
        );
    }
    acc
}

/// `VFNMS.F32 Sd, Sn, Sm`: Sd ← Sn·Sm − Sd, rounded once.
#[cfg(beamest_fma_f32)]
#[allow(unsafe_code)]
#[inline(always)]
fn vfnms_f32(a: f32, b: f32, c: f32) -> f32 {
    let mut acc = c;
    // SAFETY: as in `vfma_f32` (the same FPv4-SP instruction class).
    unsafe {
        core::arch::asm!(
            "vfnms.f32 {acc}, {a}, {b}",
            acc = inout(sreg) acc,
            a = in(sreg) a,
            b = in(sreg) b,
            options(pure, nomem, nostack),
        );
    }
    acc
}

/// `VFNMS.F64 Dd, Dn, Dm`: Dd ← Dn·Dm − Dd, rounded once.
#[cfg(beamest_fma_f64)]
#[allow(unsafe_code)]
#[inline(always)]
fn vfnms_f64(a: f64, b: f64, c: f64) -> f64 {
    let mut acc = c;
    // SAFETY: as in `vfma_f64` (FPv5-D16 only).
    unsafe {
        core::arch::asm!(
            "vfnms.f64 {acc}, {a}, {b}",
            acc = inout(dreg_low16) acc,
            a = in(dreg_low16) a,
            b = in(dreg_low16) b,
            options(pure, nomem, nostack),
        );
    }
    acc
}

#[cfg(test)]
mod tests {
    use super::*;

    /// xorshift64 (tests only).
    fn rng(seed: u64) -> impl FnMut() -> u64 {
        let mut s = seed;
        move || {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            s
        }
    }

    /// The exact a·b + c rounded once to `f32`, from the product's exact
    /// double-word form: p + e = a·b exactly (Dekker/Veltkamp in `f64`,
    /// where a 24-bit by 24-bit product is exact, so e = 0 and p = a·b),
    /// then the sum in `f64` and its rounding corrected for the double
    /// rounding `f64` → `f32` by Boldo and Melquiond's round-to-odd.
    fn fmaf_reference(a: f32, b: f32, c: f32) -> f32 {
        let p = f64::from(a) * f64::from(b); // exact: 48 ≤ 53 bits
        let c = f64::from(c);
        let s = p + c;
        // Round-to-odd of p + c: the two-sum's error tells whether s is
        // exact; when it is not, force its last bit to 1 toward the exact
        // value, which makes the rounding to f32 correct (53 ≥ 24 + 2).
        let bb = s - p;
        let err = (p - (s - bb)) + (c - bb);
        if err == 0.0 || !s.is_finite() {
            return s as f32;
        }
        let bits = s.to_bits();
        let odd = if bits & 1 == 1 {
            s
        } else if (err > 0.0) == (s > 0.0) {
            f64::from_bits(bits + 1)
        } else {
            f64::from_bits(bits - 1)
        };
        odd as f32
    }

    #[test]
    fn fma_matches_the_software_two_product() {
        // Random triples over a wide exponent range, with c often close to
        // −a·b (the cancellations the error-free transformations use), and
        // bit equality with libm's fmaf and with the independent reference.
        let mut next = rng(0x9e37_79b9_7f4a_7c15);
        let mut random_f32 = |span: u32| {
            let bits = next();
            let mant = (bits as u32) & 0x007f_ffff;
            let exp = 127 - span / 2 + ((bits >> 32) as u32 % span);
            let sign = ((bits >> 63) as u32) << 31;
            f32::from_bits(sign | (exp << 23) | mant)
        };
        let mut cancelled = 0u32;
        for i in 0..400_000 {
            let (a, b) = (random_f32(60), random_f32(60));
            let c = match i % 3 {
                0 => random_f32(120),
                // −fl(a·b): the product's exact error, Dekker's e.
                1 => -(a * b),
                // −fl(a·b) nudged by a few ulps.
                _ => -(a * b) * (1.0 + f32::EPSILON * ((i % 7) as f32 - 3.0)),
            };
            let got = mul_add_f32(a, b, c);
            assert_eq!(got.to_bits(), mul_sub_f32(a, b, -c).to_bits());
            assert_eq!(
                got.to_bits(),
                libm::fmaf(a, b, c).to_bits(),
                "fma({a:e}, {b:e}, {c:e})"
            );
            assert_eq!(
                got.to_bits(),
                fmaf_reference(a, b, c).to_bits(),
                "fma({a:e}, {b:e}, {c:e}) against the reference"
            );
            if i % 3 == 1 {
                // The error of the rounded product, exactly.
                let exact = f64::from(a) * f64::from(b) - f64::from(a * b);
                assert_eq!(f64::from(got), exact, "error of {a:e}·{b:e}");
                cancelled += u32::from(got != 0.0);
            }
        }
        // Most products are inexact, so their error is not zero.
        assert!(cancelled > 100_000, "{cancelled}");
        // One rounding, not two: 1 + 2⁻²³ squared minus 1 + 2⁻²² keeps 2⁻⁴⁶.
        let x = 1.0 + f32::EPSILON;
        assert_eq!(
            mul_add_f32(x, x, -(1.0 + 2.0 * f32::EPSILON)),
            2f32.powi(-46)
        );
        assert_eq!(x * x - (1.0 + 2.0 * f32::EPSILON), 0.0);
    }

    #[test]
    fn fma_f64_rounds_once() {
        let x = 1.0 + f64::EPSILON;
        assert_eq!(
            mul_add_f64(x, x, -(1.0 + 2.0 * f64::EPSILON)),
            2f64.powi(-104)
        );
        let mut next = rng(5);
        for _ in 0..10_000 {
            let a = (next() >> 11) as f64 / (1u64 << 53) as f64 + 0.5;
            let b = (next() >> 11) as f64 / (1u64 << 53) as f64 - 0.5;
            assert_eq!(mul_add_f64(a, b, -(a * b)), a.mul_add(b, -(a * b)));
            assert_eq!(mul_sub_f64(a, b, a * b), a.mul_add(b, -(a * b)));
        }
    }
}
