//! What a lab's sensor adds to y besides white noise, for `beamctl
//! simulate --hum` and `--noise-colour`: narrowband lines that u does not
//! drive (the mains and its harmonics) and coloured measurement noise.
//!
//! * **Lines.** Each is a sine A·sin(2πf·t + φ) added to the measured y,
//!   its RMS a given share of the noise-free y's RMS over the run
//!   (A = √2·share·RMS), its phase drawn from the run's seed.
//! * **Coloured noise.** The white Gaussian noise of σ (from `--snr-db` or
//!   `--noise-sd`) passed through a first-order low-pass at the corner f_c
//!   with unit power gain: n_k = a·n_{k−1} + √(1 − a²)·w_k, a =
//!   e^{−2πf_c·Ts} — an AR(1) process whose σ is the white noise's, so the
//!   SNR keeps its meaning and only the spectrum changes (flat below f_c,
//!   falling 20 dB per decade above).

use crate::run::drive::Drive;
use beamest::rig::{GaussianNoise, Sample, ScenarioRig};

/// One line in y: frequency (Hz) and RMS as a share of the noise-free y's
/// RMS.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct HumLine {
    /// Frequency (Hz, > 0).
    pub freq_hz: f64,
    /// RMS ÷ the noise-free y's RMS (≥ 0).
    pub level: f64,
}

/// The spectrum of the measurement noise (JSON: `"white"` or
/// `{"low_pass": {"corner_hz": …}}`).
#[derive(Debug, Clone, Copy, PartialEq, Default, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum NoiseColour {
    /// Flat.
    #[default]
    White,
    /// A first-order low-pass at this corner (Hz, > 0), unit power gain.
    LowPass {
        /// Corner frequency (Hz).
        corner_hz: f64,
    },
}

/// A simulated rig with the lines and coloured noise of [`crate::run::RunConfig`]
/// on its y.
#[derive(Debug, Clone)]
pub struct DisturbedRig {
    rig: ScenarioRig<f64, Drive>,
    /// Per line: amplitude (units of y), phase advance per sample (rad),
    /// phase now (rad).
    lines: Vec<(f64, f64, f64)>,
    /// Coloured noise: the white source, the pole a and the state.
    colour: Option<(GaussianNoise<f64>, f64, f64)>,
}

impl DisturbedRig {
    /// `rig` with `lines` (RMS of the noise-free y `rms_y`) and, for
    /// `colour` other than white, noise of σ `sd` coloured by it (the rig
    /// must then carry no noise of its own).
    pub fn new(
        rig: ScenarioRig<f64, Drive>,
        lines: &[HumLine],
        rms_y: f64,
        colour: NoiseColour,
        sd: Option<f64>,
        ts_s: f64,
        seed: u64,
    ) -> Result<Self, String> {
        // Phases from the seed, on a stream of their own.
        let mut phases = GaussianNoise::<f64>::new(1.0, seed ^ 0x6875_6d5f_7068_6173)
            .map_err(|_| "noise seed".to_string())?;
        let lines = lines
            .iter()
            .map(|l| {
                let phase = phases.sample().rem_euclid(std::f64::consts::TAU);
                (
                    std::f64::consts::SQRT_2 * l.level * rms_y,
                    std::f64::consts::TAU * l.freq_hz * ts_s,
                    phase,
                )
            })
            .collect();
        let colour = match (colour, sd) {
            (NoiseColour::LowPass { corner_hz }, Some(sd)) => {
                let white = GaussianNoise::new(sd, seed)
                    .map_err(|_| format!("invalid noise level (σ = {sd})"))?;
                let a = (-std::f64::consts::TAU * corner_hz * ts_s).exp();
                Some((white, a, 0.0))
            }
            _ => None,
        };
        Ok(Self { rig, lines, colour })
    }

    /// The rig's scenario.
    pub fn scenario(&self) -> &beamest::rig::Scenario {
        self.rig.scenario()
    }

    /// Advance one sample period ([`ScenarioRig::tick`]), y with the lines
    /// and the coloured noise added.
    pub fn tick(&mut self) -> Sample<f64> {
        let mut s = self.rig.tick();
        for (amp, step, phase) in &mut self.lines {
            s.y += *amp * phase.sin();
            *phase = (*phase + *step) % std::f64::consts::TAU;
        }
        if let Some((white, a, state)) = &mut self.colour {
            *state = *a * *state + (1.0 - *a * *a).sqrt() * white.sample();
            s.y += *state;
        }
        s
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::run::{clean_rig, RunConfig};

    fn rig() -> ScenarioRig<f64, Drive> {
        let cfg = RunConfig::default();
        ScenarioRig::new(clean_rig(&cfg).unwrap(), Default::default()).unwrap()
    }

    #[test]
    fn a_line_adds_its_rms_at_its_frequency() {
        let mut clean = rig();
        let mut hum = DisturbedRig::new(
            rig(),
            &[HumLine {
                freq_hz: 50.0,
                level: 0.03,
            }],
            2.0,
            NoiseColour::White,
            None,
            1e-4,
            7,
        )
        .unwrap();
        let n = 200_000; // 1,000 periods of 50 Hz
        let (mut ss, mut c, mut q) = (0.0, 0.0, 0.0);
        for k in 0..n {
            let d = hum.tick().y - clean.tick().y;
            ss += d * d;
            let t = k as f64 * 1e-4;
            c += d * (std::f64::consts::TAU * 50.0 * t).cos();
            q += d * (std::f64::consts::TAU * 50.0 * t).sin();
        }
        let rms = (ss / n as f64).sqrt();
        assert!((rms / 0.06 - 1.0).abs() < 1e-6, "{rms}");
        // All of it at 50 Hz: amplitude from the quadrature sums.
        let amp = 2.0 * (c * c + q * q).sqrt() / n as f64;
        assert!(
            (amp / (0.06 * std::f64::consts::SQRT_2) - 1.0).abs() < 1e-6,
            "{amp}"
        );
    }

    #[test]
    fn coloured_noise_keeps_its_sigma_and_loses_its_whiteness() {
        let mut clean = rig();
        let mut noisy = DisturbedRig::new(
            rig(),
            &[],
            1.0,
            NoiseColour::LowPass { corner_hz: 50.0 },
            Some(1e-3),
            1e-4,
            3,
        )
        .unwrap();
        let n = 400_000;
        let (mut s0, mut s1, mut last) = (0.0, 0.0, 0.0);
        for _ in 0..n {
            let d = noisy.tick().y - clean.tick().y;
            s0 += d * d;
            s1 += d * last;
            last = d;
        }
        let sd = (s0 / n as f64).sqrt();
        assert!((sd / 1e-3 - 1.0).abs() < 0.05, "{sd}");
        let rho = s1 / s0;
        let a = (-std::f64::consts::TAU * 50.0 * 1e-4f64).exp();
        assert!((rho - a).abs() < 0.01, "lag-1 correlation {rho} vs {a}");
    }
}
