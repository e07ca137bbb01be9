//! Raw blocks → [`RawSamples`] frames of up to [`MAX_RAW_SAMPLES`] pairs.
//!
//! The pipeline hands over blocks of [`RAW_BLOCK_LEN`] (32) pairs; the link
//! joins consecutive blocks into frames of 64, the block size the link
//! budget assumes (`docs/PROTOCOL.md` §7: 8.47 wire bytes per pair in full
//! frames; 32-pair frames would cost 8.9). A frame is closed when it is
//! full, when the next block does not continue it (another decimation, or
//! a gap in the sample indices: a block dropped on the sample side), and
//! after a short block (the pipeline sends one when the decimation
//! changes), so the tail of a series is never held back.

use crate::pipeline::{RawBlock, RAW_BLOCK_LEN};
use crate::scalar::Real;
use beam_protocol::{RawSamples, UySample, MAX_RAW_SAMPLES};

/// The frame being filled.
#[derive(Debug, Clone, Default)]
pub(crate) struct RawAssembler {
    frame: Option<RawSamples>,
}

impl RawAssembler {
    /// Take one block; `emit` gets every frame that is complete (by value:
    /// it becomes a `Message` without a copy).
    pub fn push<T: Real>(&mut self, block: &RawBlock<T>, mut emit: impl FnMut(RawSamples)) {
        let d = block.decimation.max(1);
        let continues = self.frame.as_ref().is_some_and(|f| {
            f.decimation == d
                && f.first_sample_index
                    .wrapping_add(f.samples.len() as u64 * u64::from(d))
                    == block.first_index
        });
        if !continues {
            self.flush(&mut emit);
        }
        let n = usize::from(block.len).min(RAW_BLOCK_LEN);
        for (i, (u, y)) in block.u_v.iter().zip(block.y.iter()).take(n).enumerate() {
            let f = self.frame.get_or_insert_with(|| RawSamples {
                first_sample_index: block.first_index.wrapping_add(i as u64 * u64::from(d)),
                decimation: d,
                samples: heapless::Vec::new(),
            });
            let _ = f.samples.push(UySample {
                u_v: u.to_f64() as f32,
                y: y.to_f64() as f32,
            });
            if f.samples.len() >= MAX_RAW_SAMPLES {
                self.flush(&mut emit);
            }
        }
        if n < RAW_BLOCK_LEN {
            self.flush(&mut emit);
        }
    }

    /// Emit the partly filled frame, if any.
    pub fn flush(&mut self, mut emit: impl FnMut(RawSamples)) {
        if let Some(f) = self.frame.take() {
            if !f.samples.is_empty() {
                emit(f);
            }
        }
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used, clippy::indexing_slicing)]
mod tests {
    use super::*;

    fn block(first: u64, d: u16, len: u16) -> RawBlock<f32> {
        let mut b = RawBlock {
            first_index: first,
            decimation: d,
            len,
            u_v: [0.0; RAW_BLOCK_LEN],
            y: [0.0; RAW_BLOCK_LEN],
        };
        for i in 0..RAW_BLOCK_LEN {
            b.u_v[i] = (first + i as u64 * u64::from(d)) as f32;
            b.y[i] = -(i as f32);
        }
        b
    }

    fn run(blocks: &[RawBlock<f32>]) -> Vec<RawSamples> {
        let mut a = RawAssembler::default();
        let mut out = Vec::new();
        for b in blocks {
            a.push(b, |f| out.push(f));
        }
        out
    }

    #[test]
    fn two_blocks_make_a_frame() {
        let out = run(&[block(0, 2, 32), block(64, 2, 32), block(128, 2, 32)]);
        assert_eq!(out.len(), 1);
        let f = &out[0];
        assert_eq!(
            (f.first_sample_index, f.decimation, f.samples.len()),
            (0, 2, 64)
        );
        for (i, s) in f.samples.iter().enumerate() {
            assert_eq!(s.u_v, (2 * i) as f32, "pair {i} carries its own index");
        }
    }

    #[test]
    fn gaps_decimation_changes_and_short_blocks_close_frames() {
        // A gap (a block dropped), then a short block, then a new decimation.
        let out = run(&[
            block(0, 1, 32),
            block(64, 1, 32),
            block(96, 1, 5),
            block(200, 4, 32),
        ]);
        let shape: Vec<(u64, u16, usize)> = out
            .iter()
            .map(|f| (f.first_sample_index, f.decimation, f.samples.len()))
            .collect();
        assert_eq!(shape, [(0, 1, 32), (64, 1, 37)]);
    }
}
