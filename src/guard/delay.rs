//! A short delay line between screening and the estimator, so a fault that
//! is recognised only after several samples (a stuck sensor: the reading
//! must repeat `stuck_after` times) can still be kept out of the estimator:
//! the samples already screened are marked faulty before they leave the
//! line. The estimate lags by the delay (at most [`MAX_DELAY`] samples,
//! 3.1 ms at 10 kHz); the DAC and the excitation do not.

use super::SampleFault;

/// Longest delay (samples); the ring holds one more.
pub(crate) const MAX_DELAY: usize = 31;
const RING: usize = MAX_DELAY + 1;

/// One screened pair: (u, y, fault if any, sample index).
pub(crate) type Entry<T> = (T, T, Option<SampleFault>, u64);

/// The ring.
#[derive(Debug, Clone, Copy)]
pub(crate) struct DelayLine<T> {
    buf: [Entry<T>; RING],
    head: usize,
    filled: usize,
    delay: usize,
}

impl<T: Copy> DelayLine<T> {
    /// A line of `delay` ≤ [`MAX_DELAY`] samples (longer is clamped).
    pub(crate) fn new(delay: usize, zero: T) -> Self {
        Self {
            buf: [(zero, zero, None, 0); RING],
            head: 0,
            filled: 0,
            delay: delay.min(MAX_DELAY),
        }
    }

    /// Store `e`; return the entry stored `delay` pushes ago, once there is
    /// one.
    #[inline]
    pub(crate) fn push(&mut self, e: Entry<T>) -> Option<Entry<T>> {
        let out = if self.filled >= self.delay {
            self.buf
                .get((self.head + RING - self.delay) % RING)
                .copied()
        } else {
            self.filled += 1;
            None
        };
        if let Some(slot) = self.buf.get_mut(self.head) {
            *slot = e;
        }
        self.head = (self.head + 1) % RING;
        out
    }

    /// Mark the `n` most recent entries (still in the line) that are not
    /// faulty yet as `fault`; returns how many were marked.
    pub(crate) fn invalidate_recent(&mut self, n: usize, fault: SampleFault) -> u32 {
        let mut flipped = 0;
        for back in 1..=n.min(self.filled) {
            let i = (self.head + RING - back) % RING;
            if let Some(e) = self.buf.get_mut(i) {
                if e.2.is_none() {
                    e.2 = Some(fault);
                    flipped += 1;
                }
            }
        }
        flipped
    }

    /// Subtract `dy` from the y of the entries still inside whose index is
    /// `from` or later (an offset step found after it entered).
    pub(crate) fn shift_from(&mut self, from: u64, dy: T)
    where
        T: core::ops::SubAssign,
    {
        for back in 1..=self.filled.min(self.delay) {
            let i = (self.head + RING - back) % RING;
            if let Some(e) = self.buf.get_mut(i) {
                if e.3 >= from {
                    e.1 -= dy;
                }
            }
        }
    }

    /// Lengthen the delay to `delay` (≤ [`MAX_DELAY`]; never shortened):
    /// the next pushes return nothing until the oldest entry not yet
    /// returned is `delay` pushes old; no entry is lost.
    pub(crate) fn lengthen(&mut self, delay: usize) {
        let delay = delay.min(MAX_DELAY);
        if delay > self.delay {
            self.filled = self.filled.min(self.delay);
            self.delay = delay;
        }
    }

    /// The delay (samples).
    pub(crate) fn delay(&self) -> usize {
        self.delay
    }

    /// Empty the line.
    pub(crate) fn clear(&mut self) {
        self.filled = 0;
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;

    #[test]
    fn delays_and_invalidates_what_is_still_inside() {
        let mut d = DelayLine::new(3, 0.0f64);
        let out: Vec<_> = (0..6u64)
            .map(|k| d.push((k as f64, 0.0, None, k)).map(|e| e.3))
            .collect();
        assert_eq!(out, [None, None, None, Some(0), Some(1), Some(2)]);
        // Entries 3, 4, 5 are inside: mark the last two.
        assert_eq!(d.invalidate_recent(2, SampleFault::Stuck), 2);
        assert_eq!(d.invalidate_recent(2, SampleFault::Stuck), 0);
        let e = d.push((6.0, 0.0, None, 6)).unwrap();
        assert_eq!((e.3, e.2), (3, None));
        assert_eq!(
            d.push((7.0, 0.0, None, 7)).unwrap().2,
            Some(SampleFault::Stuck)
        );
        assert_eq!(
            d.push((8.0, 0.0, None, 8)).unwrap().2,
            Some(SampleFault::Stuck)
        );
        assert_eq!(d.push((9.0, 0.0, None, 9)).unwrap().2, None);
        // 7, 8, 9 are inside: shift from 8 on; lengthen to 5 (two pushes
        // without output, then 7 onwards, nothing lost).
        d.shift_from(8, 0.5);
        d.lengthen(5);
        assert_eq!(d.push((10.0, 0.0, None, 10)), None);
        assert_eq!(d.push((11.0, 0.0, None, 11)), None);
        let e: Vec<_> = (12..15u64)
            .map(|k| d.push((k as f64, 0.0, None, k)).unwrap())
            .map(|e| (e.3, e.1))
            .collect();
        assert_eq!(e, [(7, 0.0), (8, -0.5), (9, -0.5)]);
        d.lengthen(2);
        assert_eq!(d.delay(), 5);
        d.clear();
        assert_eq!(d.push((1.0, 0.0, None, 10)), None);
        assert_eq!(DelayLine::new(99, 0.0f32).delay, MAX_DELAY);
    }
}
