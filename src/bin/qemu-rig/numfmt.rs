//! Decimal output of floats by integer arithmetic, for the firmware's log
//! and telemetry lines: `core::fmt`'s float formatting (Grisu/Dragon with
//! their tables, in f32 and f64) costs ~25 KiB of flash, a third of the
//! QEMU image's budget. Thread mode only.

use core::fmt;

/// `value` with `decimals` digits after the point (≤ 9), rounded half away
/// from zero; `nan`/`inf` as such; magnitudes beyond 1.8e10 print `big`.
#[derive(Debug, Clone, Copy)]
pub struct Fixed(pub f64, pub u32);

/// `value` as `d.ddde±x` with `decimals` mantissa digits after the point.
#[derive(Debug, Clone, Copy)]
pub struct Sci(pub f64, pub u32);

const POW10: [u64; 10] = [
    1,
    10,
    100,
    1_000,
    10_000,
    100_000,
    1_000_000,
    10_000_000,
    100_000_000,
    1_000_000_000,
];

fn pow10(decimals: u32) -> u64 {
    POW10
        .get(decimals as usize)
        .copied()
        .unwrap_or(1_000_000_000)
}

/// Sign and finiteness; `None` once written.
fn special(f: &mut fmt::Formatter<'_>, x: f64) -> Result<Option<f64>, fmt::Error> {
    if x.is_nan() {
        f.write_str("nan")?;
        return Ok(None);
    }
    if x < 0.0 {
        f.write_str("-")?;
    }
    let a = x.abs();
    if a.is_infinite() {
        f.write_str("inf")?;
        return Ok(None);
    }
    Ok(Some(a))
}

fn write_fixed(f: &mut fmt::Formatter<'_>, a: f64, decimals: u32) -> fmt::Result {
    let d = decimals.min(9);
    let scale = pow10(d);
    let scaled = libm::round(a * scale as f64);
    if scaled >= 1.8e19 {
        return f.write_str("big");
    }
    let v = scaled as u64;
    if d == 0 {
        write!(f, "{}", v)
    } else {
        write!(f, "{}.{:0w$}", v / scale, v % scale, w = d as usize)
    }
}

impl fmt::Display for Fixed {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match special(f, self.0)? {
            Some(a) => write_fixed(f, a, self.1),
            None => Ok(()),
        }
    }
}

impl fmt::Display for Sci {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let Some(a) = special(f, self.0)? else {
            return Ok(());
        };
        if a == 0.0 {
            return write!(f, "{}e0", Fixed(0.0, self.1));
        }
        // Normalise to 1 ≤ m < 10 (bounded: |exponent| ≤ 324 for f64).
        let (mut m, mut e) = (a, 0i32);
        while m >= 10.0 && e < 400 {
            m /= 10.0;
            e += 1;
        }
        while m < 1.0 && e > -400 {
            m *= 10.0;
            e -= 1;
        }
        // Rounding can carry into the next decade (9.9996 → 10.000).
        let scale = pow10(self.1.min(9)) as f64;
        if libm::round(m * scale) >= 10.0 * scale {
            m /= 10.0;
            e += 1;
        }
        write_fixed(f, m, self.1)?;
        write!(f, "e{}", e)
    }
}
