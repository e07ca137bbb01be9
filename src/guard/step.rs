//! The offset-step detector: a matched test for a step of y at a sample a
//! few samples back, on a window of [`STEP_BEFORE`] samples before and
//! [`STEP_AFTER`] from it, with the signal modelled as a quadratic in time
//! over the window (10 kHz sampling of modes ≲ 250 rad/s: the window spans
//! ≲ 0.6 rad of the fastest).
//!
//! The step's least-squares estimate under that model is a fixed linear
//! combination d̂ = Σ wᵢ·yᵢ of the window (w = h⊥/‖h⊥‖², h the step's
//! indicator, h⊥ its part orthogonal to 1, t, t²): it is the step averaged
//! over both sides, with the noise of white σ reduced to σ·‖w‖ (‖w‖ = 0.82
//! at 12 + 12 samples; the second difference of the previous detector had
//! √6·σ ≈ 2.45σ). d̂ is tested against [`STEP_FACTOR`] × its own running
//! RMS (which holds the noise and what the quadratic leaves of the signal).
//! A step entering the window shows side lobes first (−0.34 of it 8
//! positions early), so after the first position over the threshold all
//! positions the step can be at are seen, and the largest |d̂| (the step's
//! sample) must stay the largest for [`STEP_PEAK_WAIT`] positions, before
//! the step is removed — at most [`STEP_LATENCY`] samples after it. The
//! guard's delay line supplies the look-ahead: the samples from the step
//! on are still inside it when the step is found, and are corrected there.

use crate::scalar::Real;

/// Window samples before the step's sample.
pub(crate) const STEP_BEFORE: usize = 12;
/// Window samples from the step's sample on (the look-ahead).
pub(crate) const STEP_AFTER: usize = 12;
const N: usize = STEP_BEFORE + STEP_AFTER;
/// Positions the peak of |d̂| must stay the largest before the step is
/// declared (≤ [`STEP_AFTER`] − 1).
pub(crate) const STEP_PEAK_WAIT: u64 = 3;
/// Samples from a step to its removal, at most (the delay line must be
/// longer): a step enters the window [`STEP_AFTER`] − 1 positions before
/// its own, where d̂ may cross the threshold on a side lobe; the peak is
/// followed over all positions the step can be at.
pub(crate) const STEP_LATENCY: usize = 2 * (STEP_AFTER - 1);

/// The weights w (see the module docs), in f64.
fn weights() -> [f64; N] {
    let mut basis = [[0.0f64; N]; 3];
    for (j, b) in basis.iter_mut().enumerate() {
        for (i, v) in b.iter_mut().enumerate() {
            let t = (i as f64 - (N as f64 - 1.0) / 2.0) / N as f64;
            *v = libm::pow(t, j as f64);
        }
    }
    // Gram–Schmidt on 1, t, t².
    let dot = |a: &[f64; N], b: &[f64; N]| a.iter().zip(b).map(|(x, y)| x * y).sum::<f64>();
    let mut q: [[f64; N]; 3] = [[0.0; N]; 3];
    for j in 0..3 {
        let mut v = basis.get(j).copied().unwrap_or([0.0; N]);
        for qi in q.iter().take(j) {
            let c = dot(&v, qi);
            v.iter_mut().zip(qi).for_each(|(x, y)| *x -= c * y);
        }
        let n = libm::sqrt(dot(&v, &v));
        if let Some(qj) = q.get_mut(j) {
            v.iter_mut().for_each(|x| *x /= n);
            *qj = v;
        }
    }
    let mut h = [0.0f64; N];
    h.iter_mut().skip(STEP_BEFORE).for_each(|x| *x = 1.0);
    for qi in &q {
        let c = dot(&h, qi);
        h.iter_mut().zip(qi).for_each(|(x, y)| *x -= c * y);
    }
    let n2 = dot(&h, &h);
    h.iter_mut().for_each(|x| *x /= n2);
    h
}

/// A step found: its first sample's index and its size (units of y).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Step<T> {
    pub index: u64,
    pub size: T,
}

/// A run of positions over the threshold, followed to its peak.
#[derive(Debug, Clone, Copy)]
struct Pending<T> {
    /// The first position over the threshold.
    first: u64,
    /// d̂² and d̂ at the peak, and its position.
    peak2: T,
    peak: T,
    at: u64,
}

/// The detector's state.
#[derive(Debug, Clone, Copy)]
pub(crate) struct StepDetector<T> {
    w: [T; N],
    /// Recent offset-free good y: a ring of N written twice (at i and
    /// i + N), so the window, oldest first, is the slice from `head` on.
    ring: [T; 2 * N],
    head: usize,
    len: usize,
    ms: T,
    learn: u32,
    learn_len: u32,
    alpha: T,
    factor2: T,
    /// Over the threshold at the position `first`: the peak so far.
    pending: Option<Pending<T>>,
}

impl<T: Real> StepDetector<T> {
    /// Reference time constant `alpha` (per sample), learning for
    /// `learn_len` samples, threshold `factor` × RMS.
    pub(crate) fn new(alpha: T, learn_len: u32, factor: f64) -> Self {
        let wf = weights();
        let mut w = [T::ZERO; N];
        w.iter_mut().zip(wf).for_each(|(a, b)| *a = T::from_f64(b));
        Self {
            w,
            ring: [T::ZERO; 2 * N],
            head: 0,
            len: 0,
            ms: T::ZERO,
            learn: learn_len,
            learn_len,
            alpha,
            factor2: T::from_f64(factor * factor),
            pending: None,
        }
    }

    /// The window restarts (a gap or a stuck run); the reference is kept.
    pub(crate) fn interrupt(&mut self) {
        self.len = 0;
        self.pending = None;
    }

    /// The reference is learnt afresh.
    pub(crate) fn relearn(&mut self) {
        self.interrupt();
        self.ms = T::ZERO;
        self.learn = self.learn_len;
    }

    /// Take the offset-free y of good sample `index`; `test` false skips
    /// the test (a repeated reading). Returns a step to remove.
    #[inline]
    pub(crate) fn push(&mut self, y: T, index: u64, test: bool) -> Option<Step<T>> {
        for i in [self.head, self.head + N] {
            if let Some(slot) = self.ring.get_mut(i) {
                *slot = y;
            }
        }
        self.head = (self.head + 1) % N;
        if self.len < N {
            self.len += 1;
            if self.len < N {
                return None;
            }
        }
        if !test {
            return None;
        }
        // The oldest sample sits at `head`.
        let window = self.ring.get(self.head..self.head + N)?;
        let d = self
            .w
            .iter()
            .zip(window)
            .fold(T::ZERO, |a, (w, y)| a + *w * *y);
        let at = index.wrapping_sub(STEP_AFTER as u64 - 1);
        let e2 = d * d;
        if self.learn > 0 {
            self.learn -= 1;
            self.ms += self.alpha * (e2 - self.ms);
            return None;
        }
        let limit = self.factor2 * self.ms;
        if let Some(p) = self.pending.as_mut() {
            if e2 > p.peak2 {
                (p.peak2, p.peak, p.at) = (e2, d, at);
            }
            let seen_all = at.wrapping_sub(p.first) >= STEP_AFTER as u64 - 1;
            if !(seen_all && at.wrapping_sub(p.at) >= STEP_PEAK_WAIT) {
                return None;
            }
            let step = Step {
                index: p.at,
                size: p.peak,
            };
            self.pending = None;
            self.remove(index, step.index, step.size);
            return Some(step);
        }
        if e2 > limit && self.ms > T::ZERO {
            self.pending = Some(Pending {
                first: at,
                peak2: e2,
                peak: d,
                at,
            });
            return None;
        }
        // The reference takes values up to the threshold (a step does not
        // raise its own yardstick).
        self.ms += self.alpha * (e2.min(limit) - self.ms);
        None
    }

    /// Another test found a step of `size` at `from` (`newest` is the
    /// latest sample's index): remove it from the window as if found here.
    pub(crate) fn correct(&mut self, newest: u64, from: u64, size: T) {
        self.pending = None;
        if self.len == N {
            self.remove(newest, from, size);
        } else {
            self.interrupt();
        }
    }

    /// Subtract `size` from the window's samples from index `from` on
    /// (`newest` is the latest's index).
    fn remove(&mut self, newest: u64, from: u64, size: T) {
        let n = (newest.wrapping_sub(from) as usize)
            .saturating_add(1)
            .min(N);
        for back in 1..=n {
            let i = (self.head + N - back) % N;
            for j in [i, i + N] {
                if let Some(v) = self.ring.get_mut(j) {
                    *v -= size;
                }
            }
        }
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used, clippy::indexing_slicing)]
mod tests {
    use super::*;

    #[test]
    fn weights_estimate_a_step_and_ignore_a_quadratic() {
        let w = weights();
        let fit = |f: &dyn Fn(f64) -> f64| {
            w.iter()
                .enumerate()
                .map(|(i, w)| w * f(i as f64))
                .sum::<f64>()
        };
        assert!((fit(&|t| 3.0 - 0.1 * t + 0.02 * t * t)).abs() < 1e-12);
        let step = |t: f64| if t >= STEP_BEFORE as f64 { 1.0 } else { 0.0 };
        assert!((fit(&step) - 1.0).abs() < 1e-12);
        let norm = w.iter().map(|x| x * x).sum::<f64>().sqrt();
        assert!((norm - 0.8186).abs() < 1e-3, "{norm}");
        // The side lobes: a step 8 positions after the tested one gives
        // −0.34 of itself; one position off, 0.69.
        let lobe = |k: f64| {
            fit(&|t| {
                if t >= STEP_BEFORE as f64 + k {
                    1.0
                } else {
                    0.0
                }
            })
        };
        assert!((lobe(8.0) + 0.338).abs() < 1e-3, "{}", lobe(8.0));
        assert!((lobe(1.0) - 0.686).abs() < 1e-3, "{}", lobe(1.0));
    }
}
