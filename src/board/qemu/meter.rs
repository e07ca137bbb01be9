//! Instruction meters that separate the product's instructions from the
//! simulated rig's inside one sample interrupt (SysTick spans, see
//! [`super::cycles`]):
//!
//! * [`TimedEstimator`] wraps the estimator the pipeline steps and times
//!   each [`Estimator::step`] — the estimator's own cost;
//! * [`MeteredSpi`] wraps a chip model's SPI handle and sums the ticks
//!   spent inside its transactions into an [`SpiMeter`] — the model's cost,
//!   which on the real board is SPI bus time, not instructions. The driver's
//!   own framing, CRC and checks stay outside the meter: they are product.
//!
//! The meters' own reads of SysTick (a load and a few adds each) land in the
//! spans around them.

use core::sync::atomic::{AtomicU32, Ordering};

use embedded_hal::spi::{ErrorType, Operation, SpiDevice};

use super::cycles::{self, SpanSum};
use crate::estimator::{Estimator, Health, StepStatus};
use crate::model::TransferFunction;
use crate::scalar::Real;

/// An estimator whose `step` is timed.
#[derive(Debug)]
pub struct TimedEstimator<E> {
    inner: E,
    last_ticks: u32,
    steps: SpanSum,
}

impl<E> TimedEstimator<E> {
    /// Wrap `inner`.
    pub fn new(inner: E) -> Self {
        Self {
            inner,
            last_ticks: 0,
            steps: SpanSum::default(),
        }
    }

    /// Ticks of the most recent `step`.
    pub fn last_ticks(&self) -> u32 {
        self.last_ticks
    }

    /// All steps so far.
    pub fn steps(&self) -> SpanSum {
        self.steps
    }

    /// The wrapped estimator.
    pub fn inner(&self) -> &E {
        &self.inner
    }

    /// The wrapped estimator, mutably.
    pub fn inner_mut(&mut self) -> &mut E {
        &mut self.inner
    }

    /// Unwrap (e.g. to reuse a replaced estimator's storage).
    pub fn into_inner(self) -> E {
        self.inner
    }
}

impl<T: Real, E: Estimator<T, NP>, const NP: usize> Estimator<T, NP> for TimedEstimator<E> {
    /// Kept out of line so the step can be found in the disassembly.
    #[inline(never)]
    fn step(&mut self, u: T, y: T) -> StepStatus {
        let t0 = cycles::now();
        let s = self.inner.step(u, y);
        let t1 = cycles::now();
        self.steps.add(t0, t1);
        self.last_ticks = cycles::ticks_between(t0, t1);
        s
    }
    fn theta(&self) -> [T; NP] {
        self.inner.theta()
    }
    fn transfer_function(&self) -> TransferFunction<T> {
        self.inner.transfer_function()
    }
    fn reset(&mut self) {
        self.inner.reset()
    }
    fn excitation_level(&self) -> Option<T> {
        self.inner.excitation_level()
    }
    fn health(&self) -> Health {
        self.inner.health()
    }
    fn information(&self) -> Option<[[T; NP]; NP]> {
        self.inner.information()
    }
    fn hold(&mut self, samples: u32) {
        self.inner.hold(samples)
    }
    fn settling_samples(&self) -> u32 {
        self.inner.settling_samples()
    }
}

/// Ticks spent inside metered SPI transactions (wrapping).
#[derive(Debug, Default)]
pub struct SpiMeter(AtomicU32);

impl SpiMeter {
    /// A meter at zero.
    pub const fn new() -> Self {
        Self(AtomicU32::new(0))
    }

    /// The running total, ticks (take differences with `wrapping_sub`).
    #[inline(always)]
    pub fn ticks(&self) -> u32 {
        self.0.load(Ordering::Relaxed)
    }
}

/// An SPI device whose transactions are timed into a [`SpiMeter`].
#[derive(Debug)]
pub struct MeteredSpi<S> {
    inner: S,
    meter: &'static SpiMeter,
}

impl<S> MeteredSpi<S> {
    /// Wrap `inner`, counting into `meter`.
    pub fn new(inner: S, meter: &'static SpiMeter) -> Self {
        Self { inner, meter }
    }
}

impl<S: ErrorType> ErrorType for MeteredSpi<S> {
    type Error = S::Error;
}

impl<S: SpiDevice> SpiDevice for MeteredSpi<S> {
    #[inline]
    fn transaction(&mut self, operations: &mut [Operation<'_, u8>]) -> Result<(), S::Error> {
        let t0 = cycles::now();
        let r = self.inner.transaction(operations);
        let t = cycles::ticks_between(t0, cycles::now());
        // Only the sample interrupt and the boot code (before it runs)
        // transact: a plain load/store pair cannot be torn.
        self.meter.0.store(
            self.meter.0.load(Ordering::Relaxed).wrapping_add(t),
            Ordering::Relaxed,
        );
        r
    }
}
