//! Maximum-length pseudo-random binary sequence (PRBS): ±full scale from a
//! k-bit Fibonacci linear-feedback shift register, one bit every
//! `divider` samples.
//!
//! # Design
//! * The feedback polynomials are primitive (maximal length 2^k − 1), taken
//!   from the standard table (Xilinx XAPP052, *Efficient Shift Registers,
//!   LFSR Counters, and Long Pseudo-Random Sequence Generators*); the unit
//!   test checks the period of every order offered.
//! * One period holds 2^(k−1) ones and 2^(k−1) − 1 zeros: the mean is
//!   1/(2^k − 1) of the amplitude.
//! * Spectrum: lines every f_bit/(2^k − 1) (f_bit = fs/divider), with the
//!   power envelope sinc²(f/f_bit): usable up to about 0.4·f_bit. Lemma 1
//!   needs 2n lines for n modes (4n − 1 parameters): any k ≥ 3 with the
//!   band placed over the modes gives many more.
//! * Cost: one compare per sample, a parity of k bits once per bit.

use super::ExcitationError;

/// Shortest register.
pub const MIN_ORDER: u8 = 2;
/// Longest register (period 16,777,215 bits).
pub const MAX_ORDER: u8 = 24;

/// Tap sets (exponents of the feedback polynomial besides x^0), by order.
const TAPS: [&[u8]; 25] = [
    &[],
    &[],
    &[2, 1],
    &[3, 2],
    &[4, 3],
    &[5, 3],
    &[6, 5],
    &[7, 6],
    &[8, 6, 5, 4],
    &[9, 5],
    &[10, 7],
    &[11, 9],
    &[12, 6, 4, 1],
    &[13, 4, 3, 1],
    &[14, 5, 3, 1],
    &[15, 14],
    &[16, 15, 13, 4],
    &[17, 14],
    &[18, 11],
    &[19, 6, 2, 1],
    &[20, 17],
    &[21, 19],
    &[22, 21],
    &[23, 18],
    &[24, 23, 22, 17],
];

/// A running PRBS generator.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Prbs {
    state: u32,
    seed: u32,
    mask: u32,
    order: u8,
    divider: u32,
    count: u32,
}

impl Prbs {
    /// Order `order` (MIN_ORDER..=MAX_ORDER), a new bit every `divider` ≥ 1
    /// samples, register started at `seed` (its low k bits; 0 → all ones).
    pub fn new(order: u8, divider: u32, seed: u32) -> Result<Self, ExcitationError> {
        let taps = TAPS
            .get(usize::from(order))
            .filter(|_| order >= MIN_ORDER)
            .ok_or(ExcitationError::PrbsOrder)?;
        if divider == 0 {
            return Err(ExcitationError::Frequency);
        }
        let k = u32::from(order);
        let width = (1u32 << k) - 1;
        let mask = taps.iter().fold(0u32, |m, &t| m | 1 << (k - u32::from(t)));
        let seed = if seed & width == 0 {
            width
        } else {
            seed & width
        };
        Ok(Self {
            state: seed,
            seed,
            mask,
            order,
            divider,
            count: 0,
        })
    }

    /// +1 (`true`) or −1 (`false`) for this sample, then advance one sample.
    #[inline]
    pub(crate) fn next_bit(&mut self) -> bool {
        let bit = self.state & 1 == 1;
        self.count += 1;
        if self.count >= self.divider {
            self.count = 0;
            let fb = (self.state & self.mask).count_ones() & 1;
            self.state = (self.state >> 1) | (fb << (u32::from(self.order) - 1));
        }
        bit
    }

    /// Register length k.
    pub fn order(&self) -> u8 {
        self.order
    }

    /// Samples per bit.
    pub fn divider(&self) -> u32 {
        self.divider
    }

    /// Change the bit period, keeping the register and the position within
    /// the current bit (clamped to the new period).
    pub(crate) fn set_divider(&mut self, divider: u32) -> Result<(), ExcitationError> {
        if divider == 0 {
            return Err(ExcitationError::Frequency);
        }
        self.divider = divider;
        self.count = self.count.min(divider - 1);
        Ok(())
    }

    /// Period of the sequence in bits, 2^k − 1.
    #[cfg(test)]
    pub(crate) fn period_bits(&self) -> u32 {
        (1u32 << self.order) - 1
    }

    /// Back to the seed.
    pub fn reset(&mut self) {
        self.state = self.seed;
        self.count = 0;
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used, clippy::indexing_slicing)]
mod tests {
    use super::*;

    #[test]
    fn every_order_has_maximal_period_and_balance() {
        for k in MIN_ORDER..=MAX_ORDER {
            let mut p = Prbs::new(k, 1, 1).unwrap();
            let start = p.state;
            let mut ones = 0u64;
            let mut n = 0u64;
            loop {
                ones += u64::from(p.next_bit());
                n += 1;
                if p.state == start || n > 1 << 25 {
                    break;
                }
            }
            assert_eq!(n, (1u64 << k) - 1, "order {k}");
            assert_eq!(ones, 1u64 << (k - 1), "order {k}");
        }
    }

    #[test]
    fn divider_holds_each_bit() {
        let mut p = Prbs::new(7, 5, 0x55).unwrap();
        let bits: Vec<bool> = (0..127 * 5).map(|_| p.next_bit()).collect();
        for c in bits.chunks(5) {
            assert!(c.iter().all(|&b| b == c[0]));
        }
        // Period 127 bits = 635 samples.
        let again: Vec<bool> = (0..127 * 5).map(|_| p.next_bit()).collect();
        assert_eq!(bits, again);
        p.reset();
        assert_eq!(p.next_bit(), bits[0]);
        assert!(Prbs::new(1, 1, 1).is_err());
        assert!(Prbs::new(25, 1, 1).is_err());
        assert!(Prbs::new(7, 0, 1).is_err());
        assert!(p.set_divider(0).is_err());
    }
}
