//! [`Rig`]: the simulated beam as the firmware's sample path sees it, one
//! tick (one sample period Ts) at a time.
//!
//! Each tick: the excitation gives u_k, the input the DAC holds over
//! [t_k, t_{k+1}); the plant gives y(t_k), sampled at the start of that
//! period ([`ModalPlant::sample`]), and then holds u_k; measurement noise, if
//! any, is added to y. (u_k, y_k) is exactly the pair the estimator's
//! `step(u, y)` takes: nothing else (plant states, an exact regressor) ever
//! leaves the rig.
//!
//! # Design
//! * The excitation is any `Iterator<Item = T>`: the paper's
//!   [`SquareWave`] or the firmware's run-time generator
//!   ([`Excitation`](crate::excitation::Excitation): square, multisine,
//!   PRBS, chirp), both endless, or a scenario wrapper (an excitation
//!   pause), without changing the rig. When it runs out, the drive is 0.
//! * [`Rig::tick_with`] drives the plant with an input from outside instead
//!   (a DAC model, a pipeline under test).
//! * Everything is fixed-size and `no_std`; the rig is `Clone`, so a
//!   noise-free probe copy can be run ahead (e.g. to measure the signal RMS
//!   for an SNR) without disturbing the real one.

use super::noise::GaussianNoise;
use super::plant::ModalPlant;
use crate::excitation::SquareWave;
use crate::scalar::Real;

/// One tick of the rig: what the firmware's sample path handles.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Sample<T> {
    /// Input u_k, held over [t_k, t_{k+1}) (input units, e.g. V).
    pub u: T,
    /// Output y(t_k) as measured, noise included (output units).
    pub y: T,
}

/// Plant + excitation + optional measurement noise.
#[derive(Debug, Clone)]
pub struct Rig<T, E = SquareWave<T>> {
    plant: ModalPlant<T>,
    excitation: E,
    noise: Option<GaussianNoise<T>>,
}

impl<T: Real, E: Iterator<Item = T>> Rig<T, E> {
    /// A noise-free rig.
    pub fn new(plant: ModalPlant<T>, excitation: E) -> Self {
        Self {
            plant,
            excitation,
            noise: None,
        }
    }

    /// The same rig with white measurement noise added to y.
    pub fn with_noise(self, noise: GaussianNoise<T>) -> Self {
        Self {
            noise: Some(noise),
            ..self
        }
    }

    /// Advance one sample period: u from the excitation (0 once it has run
    /// out), y sampled at the start of the period, then u held.
    #[inline]
    pub fn tick(&mut self) -> Sample<T> {
        let u = self.excitation.next().unwrap_or(T::ZERO);
        let y = self.tick_with(u);
        Sample { u, y }
    }

    /// Advance one sample period with the input `u` given from outside
    /// (the excitation is not advanced). Returns the measured y(t_k).
    #[inline]
    pub fn tick_with(&mut self, u: T) -> T {
        let mut y = self.plant.sample(u);
        if let Some(noise) = self.noise.as_mut() {
            y += noise.sample();
        }
        y
    }

    /// The plant.
    pub fn plant(&self) -> &ModalPlant<T> {
        &self.plant
    }

    /// The plant, mutably (e.g. to reset it or to swap it for a changed one).
    pub(crate) fn plant_mut(&mut self) -> &mut ModalPlant<T> {
        &mut self.plant
    }

    /// The excitation.
    pub fn excitation(&self) -> &E {
        &self.excitation
    }

    /// The excitation, mutably.
    pub fn excitation_mut(&mut self) -> &mut E {
        &mut self.excitation
    }

    /// The measurement noise, if any.
    pub fn noise(&self) -> Option<&GaussianNoise<T>> {
        self.noise.as_ref()
    }
}

impl<T: Real, E: Iterator<Item = T> + Clone> Rig<T, E> {
    /// A copy of this rig, in its current state, without measurement noise.
    pub fn noise_free(&self) -> Self {
        Self {
            plant: self.plant.clone(),
            excitation: self.excitation.clone(),
            noise: None,
        }
    }
}

#[cfg(test)]
#[allow(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::panic,
    clippy::indexing_slicing
)]
mod tests {
    use super::*;
    use crate::model::{PAPER_B, PAPER_OMEGA, PAPER_ZETA};

    fn paper_plant() -> ModalPlant<f64> {
        ModalPlant::with_numerator(&PAPER_OMEGA, &PAPER_ZETA, &PAPER_B, 1e-4).unwrap()
    }

    #[test]
    fn tick_is_excitation_then_sampled_plant_then_noise() {
        let mut rig = Rig::new(paper_plant(), SquareWave::<f64>::paper())
            .with_noise(GaussianNoise::new(1e-4, 3).unwrap());
        let mut plant = paper_plant();
        let mut square = SquareWave::<f64>::paper();
        let mut noise = GaussianNoise::<f64>::new(1e-4, 3).unwrap();
        for _ in 0..30_000 {
            let s = rig.tick();
            let u = square.next_sample();
            let y = plant.sample(u) + noise.sample();
            assert_eq!(s, Sample { u, y });
        }
        assert_eq!(rig.noise().map(|n| n.sd()), Some(1e-4));
    }

    #[test]
    fn noise_free_copy_continues_without_noise() {
        let mut rig = Rig::new(paper_plant(), SquareWave::<f64>::paper())
            .with_noise(GaussianNoise::new(1e-3, 1).unwrap());
        for _ in 0..1000 {
            rig.tick();
        }
        let mut probe = rig.noise_free();
        let mut plant = rig.plant().clone();
        let mut square = *rig.excitation();
        for _ in 0..1000 {
            let s = probe.tick();
            assert_eq!(s.u, square.next_sample());
            assert_eq!(s.y, plant.sample(s.u));
        }
        assert!(probe.noise().is_none());
    }

    #[test]
    fn the_firmware_generator_drives_the_rig_too() {
        use crate::excitation::{Excitation, SafeWindow};
        use beam_protocol::Waveform;
        let chirp = Waveform::Chirp {
            f_start_hz: 1.0,
            f_end_hz: 80.0,
            sweep_s: 2.0,
        };
        let window = SafeWindow {
            min_v: -1.0,
            max_v: 1.0,
        };
        let e = Excitation::<f64>::new(&chirp, 0.1, 0.0, window, 1e4).unwrap();
        let mut rig = Rig::new(paper_plant(), e);
        let (mut plant, mut drive) = (paper_plant(), e);
        for _ in 0..30_000 {
            let u = drive.next_sample();
            assert_eq!(
                rig.tick(),
                Sample {
                    u,
                    y: plant.sample(u)
                }
            );
        }
    }

    #[test]
    fn external_input_and_finite_excitation() {
        // Two samples of drive, then the excitation runs out: u = 0.
        let mut rig = Rig::new(paper_plant(), [1.0f64, -1.0].into_iter());
        let mut plant = paper_plant();
        assert_eq!(rig.tick().u, 1.0);
        assert_eq!(rig.tick().u, -1.0);
        let s = rig.tick();
        assert_eq!(s.u, 0.0);
        plant.sample(1.0);
        plant.sample(-1.0);
        assert_eq!(s.y, plant.sample(0.0));
        // tick_with drives the plant directly and leaves the excitation alone.
        let mut rig = Rig::new(paper_plant(), SquareWave::<f32>::paper().map(f64::from));
        let mut plant = paper_plant();
        for k in 0..100 {
            let u = if k % 7 == 0 { 0.3 } else { -0.1 };
            assert_eq!(rig.tick_with(u), plant.sample(u));
        }
        assert_eq!(rig.tick().u, 0.1f32 as f64);
        // The plant can be reset in place.
        rig.plant_mut().reset();
        assert_eq!(rig.plant().output(), 0.0);
    }
}
