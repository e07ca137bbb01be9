//! Field-level helpers of the replay reader: the delimiter scan, number
//! parsing and error display.

/// Positions of ',' and '\n' in a block, found 8 bytes at a time with
/// SWAR bit tricks (no `unsafe`, no per-delimiter call): for each 8-byte
/// word, the bytes equal to a delimiter become set high bits of a mask,
/// whose set bits are then walked with `trailing_zeros`.
pub(super) struct Delimiters<'a> {
    bytes: &'a [u8],
    /// Start of the current 8-byte word.
    base: usize,
    /// Delimiter bits of the current word (bit 8k+7 ↔ byte k).
    mask: u64,
}

impl<'a> Delimiters<'a> {
    pub(super) fn new(bytes: &'a [u8]) -> Self {
        let mut d = Self {
            bytes,
            base: 0,
            mask: 0,
        };
        d.mask = d.word_mask(0);
        d
    }

    /// Mask of the delimiters in the 8 bytes from `at` (zero-padded).
    #[inline]
    fn word_mask(&self, at: usize) -> u64 {
        const LO: u64 = 0x0101_0101_0101_0101;
        const HI: u64 = 0x8080_8080_8080_8080;
        let x = match self.bytes.get(at..at + 8).map(<[u8; 8]>::try_from) {
            // Whole words: one load.
            Some(Ok(w)) => u64::from_le_bytes(w),
            _ => {
                let mut w = [0u8; 8];
                let end = (at + 8).min(self.bytes.len());
                if at < end {
                    w[..end - at].copy_from_slice(&self.bytes[at..end]);
                }
                u64::from_le_bytes(w)
            }
        };
        // A byte equal to c becomes 0 after XOR; mark zero bytes exactly
        // (no false positives: the carry-free form).
        let zero = |v: u64| !(((v & !HI) + !HI) | v | !HI);
        let m = zero(x ^ (LO * u64::from(b','))) | zero(x ^ (LO * u64::from(b'\n')));
        // Padding bytes are 0, never a delimiter.
        m
    }
}

impl Iterator for Delimiters<'_> {
    type Item = usize;

    #[inline]
    fn next(&mut self) -> Option<usize> {
        while self.mask == 0 {
            self.base += 8;
            if self.base >= self.bytes.len() {
                return None;
            }
            self.mask = self.word_mask(self.base);
        }
        let bit = self.mask.trailing_zeros() as usize;
        self.mask &= self.mask - 1;
        Some(self.base + bit / 8)
    }
}

/// Trim spaces, tabs and one pair of surrounding double quotes.
#[inline]
pub(super) fn clean(f: &[u8]) -> &[u8] {
    // Common case first: a bare number.
    if let (Some(a), Some(b)) = (f.first(), f.last()) {
        if (a.is_ascii_digit() || *a == b'-' || *a == b'.') && b.is_ascii_alphanumeric() {
            return f;
        }
    }
    let f = f.trim_ascii();
    match f {
        [b'"', inner @ .., b'"'] => inner.trim_ascii(),
        _ => f,
    }
}

/// Parse a numeric field: `Ok(NaN)` for empty/NaN/inf (a missing sample),
/// `Err` for anything that is not a number.
#[inline]
pub(super) fn number(f: &[u8]) -> Result<f64, ()> {
    let f = clean(f);
    if f.is_empty() {
        return Ok(f64::NAN);
    }
    match fast_float2::parse::<f64, _>(f) {
        Ok(v) if v.is_finite() => Ok(v),
        Ok(_) => Ok(f64::NAN),
        Err(_) => Err(()),
    }
}

/// 10^-k for k = 0..=18.
const INV_POW10: [f64; 19] = [
    1e0, 1e-1, 1e-2, 1e-3, 1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 1e-9, 1e-10, 1e-11, 1e-12, 1e-13, 1e-14,
    1e-15, 1e-16, 1e-17, 1e-18,
];

/// A plain decimal `[-]digits[.digits]` (at most 18 digits, no exponent) to
/// within a few ulps, by one multiplication instead of a correctly rounded
/// parse: enough to check the time base (1%), several times cheaper.
/// `None` for anything else (the caller then parses it properly).
#[inline]
pub(super) fn quick_decimal(f: &[u8]) -> Option<f64> {
    let (neg, digits) = match f {
        [b'-', rest @ ..] => (true, rest),
        _ => (false, f),
    };
    let (mut m, mut n, mut frac, mut dot) = (0u64, 0usize, 0usize, false);
    for &c in digits {
        if c.is_ascii_digit() {
            m = m * 10 + u64::from(c - b'0');
            n += 1;
            frac += usize::from(dot);
        } else if c == b'.' && !dot {
            dot = true;
        } else {
            return None;
        }
    }
    if n == 0 || n > 18 {
        return None;
    }
    let v = m as f64 * INV_POW10[frac];
    Some(if neg { -v } else { v })
}

/// Show a field in an error message (at most 40 characters).
pub(super) fn show(f: &[u8]) -> String {
    let s = String::from_utf8_lossy(clean(f));
    let mut out: String = s.chars().take(40).collect();
    if s.chars().count() > 40 {
        out.push('…');
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quick_decimal_agrees_with_the_parser() {
        for t in ["0", "12.3456", "-0.0001", "999999.999999", "3"] {
            let q = quick_decimal(t.as_bytes()).unwrap();
            let p: f64 = t.parse().unwrap();
            assert!((q - p).abs() <= 4.0 * f64::EPSILON * p.abs(), "{t}");
        }
        for t in ["1e-3", "", "-", "1.2.3", " 1", "1234567890123456789"] {
            assert_eq!(quick_decimal(t.as_bytes()), None, "{t}");
        }
    }

    #[test]
    fn delimiters_match_a_plain_scan() {
        let text = b"t,u,y\n0,0.1,-3.2e-6\r\n,,\n1234567,\"a,b\"\nlast";
        for len in 0..=text.len() {
            let bytes = &text[..len];
            let want: Vec<usize> = bytes
                .iter()
                .enumerate()
                .filter(|(_, &b)| b == b',' || b == b'\n')
                .map(|(i, _)| i)
                .collect();
            assert_eq!(
                Delimiters::new(bytes).collect::<Vec<_>>(),
                want,
                "len {len}"
            );
        }
        // Every byte value: only ',' and '\n' are delimiters.
        let all: Vec<u8> = (0..=255).collect();
        let found: Vec<usize> = Delimiters::new(&all).collect();
        assert_eq!(found, vec![usize::from(b'\n'), usize::from(b',')]);
    }
}
