//! The start-up record the robust estimator replays ([`RecordStore`]): every
//! sample as it came ([`Samples`], the host's default), or the compact
//! form a Cortex-M4F-class part holds in a few tens of KiB ([`Compact`]:
//! u on a 16-bit grid, y as block means; the choice and its measurements:
//! the module docs of [`crate::estimator::robust`], "Record in 64 KiB").

use super::start::START_TEST_SAMPLES;
use crate::scalar::Real;

/// How the robust estimator stores its start-up record of scaled u, y.
/// `BLOCK` = 1: every sample as it came, replayed one by one; `BLOCK` > 1:
/// y kept as the mean of each block of `BLOCK` samples, the replays then
/// compare the model's ŷ averaged over the same samples with it.
pub trait RecordStore<T: Real>: Sized {
    /// Samples the record holds.
    const CAPACITY: usize;
    /// Samples per stored y value.
    const BLOCK: usize;
    /// The storage's own dimensions agree (see [`Compact::CONSISTENT`]).
    const CONSISTENT: bool = true;

    /// An empty record: zeros, written where the record lies when built
    /// into a static slot (a literal, no copy through the stack).
    fn empty() -> Self;

    /// Start afresh: nothing stored; u is kept on the grid `u_step`
    /// (scaled units) where the storage quantizes it.
    fn restart(&mut self, u_step: T);

    /// Store sample `n` (the samples stored so far, < `CAPACITY`): scaled
    /// u, and scaled y or NaN for a rejected reading. Returns u as stored
    /// (what the replays will see).
    fn store(&mut self, n: usize, u: T, y: T) -> T;

    /// u as it will be stored (without storing it).
    fn quantize(&self, u: T) -> T;

    /// The samples as they came (u, y with NaN for a rejected y), if the
    /// record keeps them (`BLOCK` = 1).
    fn samples(&self) -> Option<(&[T], &[T])>;

    /// u_n as stored.
    fn u(&self, n: usize) -> T;

    /// Whether y_n was a reading (not rejected).
    fn valid(&self, n: usize) -> bool;

    /// Block `j` (samples j·BLOCK … j·BLOCK + BLOCK − 1, all stored): the
    /// mean of its readings and their count (0: none, the mean is NaN).
    fn block(&self, j: usize) -> (T, u32);

    /// y_n as it came (NaN: rejected), for n among the samples of the
    /// last two blocks stored (older ones: another sample's value, or
    /// `None`).
    fn recent_y(&self, n: usize) -> Option<T>;

    /// The first `min(len, START_TEST_SAMPLES)` values of y as they came
    /// (the start test's).
    fn first_y(&self, len: usize) -> &[T];
}

/// Every sample as it came: 2·`B` values of `T` (2 s at 10 kHz: 160 KB in
/// `f32`, 320 KB in `f64`).
#[derive(Debug, Clone)]
pub struct Samples<T, const B: usize> {
    u: [T; B],
    y: [T; B],
}

impl<T: Real, const B: usize> RecordStore<T> for Samples<T, B> {
    const CAPACITY: usize = B;
    const BLOCK: usize = 1;

    #[inline(always)]
    fn empty() -> Self {
        Self {
            u: [T::ZERO; B],
            y: [T::ZERO; B],
        }
    }

    fn restart(&mut self, _: T) {}

    #[inline]
    fn store(&mut self, n: usize, u: T, y: T) -> T {
        // Without indexing: the sample path has no panic to reach (the
        // firmware's call-graph check).
        if let (Some(ru), Some(ry)) = (self.u.get_mut(n), self.y.get_mut(n)) {
            *ru = u;
            *ry = y;
        }
        u
    }

    #[inline(always)]
    fn quantize(&self, u: T) -> T {
        u
    }

    fn samples(&self) -> Option<(&[T], &[T])> {
        Some((&self.u, &self.y))
    }

    fn u(&self, n: usize) -> T {
        self.u.get(n).copied().unwrap_or(T::ZERO)
    }

    fn valid(&self, n: usize) -> bool {
        self.y.get(n).is_some_and(|v| v.is_finite())
    }

    fn block(&self, j: usize) -> (T, u32) {
        match self.y.get(j) {
            Some(&v) if v.is_finite() => (v, 1),
            _ => (T::from_f64(f64::NAN), 0),
        }
    }

    fn recent_y(&self, n: usize) -> Option<T> {
        self.y.get(n).copied()
    }

    fn first_y(&self, len: usize) -> &[T] {
        self.y
            .get(..len.min(START_TEST_SAMPLES).min(B))
            .unwrap_or(&[])
    }
}

/// Bits of validity per word of [`Compact`]'s mask.
const MASK_BITS: usize = 32;

/// The compact record: u as a signed 16-bit count of `u_step` (lossless
/// when u comes from a 16-bit DAC and `u_step` is its step), y as the
/// means of blocks of `B / NB` samples (over the block's readings), a
/// validity bit per sample, the first 32 values of y (the start test's
/// `START_TEST_SAMPLES`) and the last two blocks' y as they came (what a
/// hand-over replays one by one). `NB` = B divided by the block length,
/// `NW` = ⌈B/32⌉ (stable Rust cannot compute array lengths from `B`; the
/// estimator refuses a mismatch, [`Compact::CONSISTENT`]). 2 s at 10 kHz
/// in blocks of 10, `f32`: 50,900 B.
#[derive(Debug, Clone)]
pub struct Compact<T, const B: usize, const NB: usize, const NW: usize> {
    u: [i16; B],
    y_mean: [T; NB],
    valid: [u32; NW],
    first: [T; START_TEST_SAMPLES],
    /// y of the last two blocks as they came (index n mod 2·BLOCK).
    recent: [T; 2 * MAX_BLOCK],
    /// Sum and count of the readings of the block being filled.
    sum: T,
    n_valid: u8,
    u_step: T,
    inv_u_step: T,
}

/// Longest block [`Compact`] supports (its count is a byte, its recent
/// values a fixed array).
const MAX_BLOCK: usize = 32;

impl<T: Real, const B: usize, const NB: usize, const NW: usize> Compact<T, B, NB, NW> {
    /// The block length B/NB divides B, is at most 32 (its count is a
    /// byte, its recent values a fixed array), and the mask
    /// has one bit per sample.
    pub const CONSISTENT: bool = NB > 0
        && B % NB == 0
        && B / NB <= MAX_BLOCK
        && NW * MASK_BITS >= B
        && (NW - 1) * MASK_BITS < B;
    const M: usize = match B.checked_div(NB) {
        Some(m) if m > 0 => m,
        _ => 1,
    };
}

impl<T: Real, const B: usize, const NB: usize, const NW: usize> RecordStore<T>
    for Compact<T, B, NB, NW>
{
    const CAPACITY: usize = B;
    const BLOCK: usize = Self::M;
    const CONSISTENT: bool = Self::CONSISTENT;

    #[inline(always)]
    fn empty() -> Self {
        Self {
            u: [0; B],
            y_mean: [T::ZERO; NB],
            valid: [0; NW],
            first: [T::ZERO; START_TEST_SAMPLES],
            recent: [T::ZERO; 2 * MAX_BLOCK],
            sum: T::ZERO,
            n_valid: 0,
            u_step: T::ONE,
            inv_u_step: T::ONE,
        }
    }

    fn restart(&mut self, u_step: T) {
        // Only the running block's sums carry over between samples; every
        // stored value is written before it is read.
        self.sum = T::ZERO;
        self.n_valid = 0;
        self.u_step = u_step;
        self.inv_u_step = T::ONE / u_step;
    }

    #[inline]
    fn store(&mut self, n: usize, u: T, y: T) -> T {
        let (code, stored) = self.code(u);
        if let Some(c) = self.u.get_mut(n) {
            *c = code;
        }
        let ok = y.is_finite();
        if let Some(w) = self.valid.get_mut(n / MASK_BITS) {
            let bit = 1u32 << (n % MASK_BITS);
            *w = if ok { *w | bit } else { *w & !bit };
        }
        if let Some(f) = self.first.get_mut(n) {
            *f = y;
        }
        if let Some(r) = self.recent.get_mut(n % (2 * Self::M)) {
            *r = y;
        }
        if ok {
            self.sum += y;
            self.n_valid = self.n_valid.saturating_add(1);
        }
        if n % Self::M == Self::M - 1 {
            let j = n / Self::M;
            let mean = if self.n_valid > 0 {
                self.sum / T::from_usize(usize::from(self.n_valid))
            } else {
                T::from_f64(f64::NAN)
            };
            if let Some(m) = self.y_mean.get_mut(j) {
                *m = mean;
            }
            self.sum = T::ZERO;
            self.n_valid = 0;
        }
        stored
    }

    #[inline(always)]
    fn quantize(&self, u: T) -> T {
        self.code(u).1
    }

    fn samples(&self) -> Option<(&[T], &[T])> {
        None
    }

    fn u(&self, n: usize) -> T {
        T::from_i32(i32::from(self.u.get(n).copied().unwrap_or(0))) * self.u_step
    }

    fn valid(&self, n: usize) -> bool {
        self.valid
            .get(n / MASK_BITS)
            .is_some_and(|w| w & (1 << (n % MASK_BITS)) != 0)
    }

    fn block(&self, j: usize) -> (T, u32) {
        // The count of readings from the validity bits (no count stored).
        let count = (j * Self::M..(j + 1) * Self::M)
            .filter(|&n| self.valid(n))
            .count();
        match self.y_mean.get(j) {
            Some(&m) => (m, count as u32),
            None => (T::from_f64(f64::NAN), 0),
        }
    }

    fn recent_y(&self, n: usize) -> Option<T> {
        self.recent.get(n % (2 * Self::M)).copied()
    }

    fn first_y(&self, len: usize) -> &[T] {
        self.first.get(..len.min(START_TEST_SAMPLES)).unwrap_or(&[])
    }
}

impl<T: Real, const B: usize, const NB: usize, const NW: usize> Compact<T, B, NB, NW> {
    /// u's count of `u_step` (rounded to nearest, clamped to 16 bits) and
    /// the value it stands for.
    #[inline(always)]
    fn code(&self, u: T) -> (i16, T) {
        let k = (u * self.inv_u_step).round().to_i32();
        let k = k.clamp(i32::from(i16::MIN), i32::from(i16::MAX));
        let code = i16::try_from(k).unwrap_or(0);
        (code, T::from_i32(k) * self.u_step)
    }
}
