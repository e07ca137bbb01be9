//! Excitation signals for the piezo drive, generated sample by sample: the
//! paper's square wave, a multisine, a PRBS and a chirp, with amplitude,
//! offset and frequency settable at run time inside a safe voltage window.
//!
//! * [`SquareWave`] — the paper's 0.1·square(7 Hz) (Section IV.A), kept as
//!   the reference generator of the host tests;
//! * [`Excitation`] — the run-time generator of the firmware: one
//!   [`Waveform`] (normalised, integer) times an amplitude plus an offset,
//!   in the actuator's volts, never outside a [`SafeWindow`].
//!
//! # Lemma 1 (persistent excitation)
//! Θ of eq. 29 has 4n − 1 entries for n modes. Each sinusoid in u gives two
//! spectral lines, so u must contain at least 2n distinct frequencies in
//! the plant's band (DC adds one line). Per kind ([`Waveform::spectral_lines`]
//! counts them for the current settings):
//!
//! | kind | sinusoids in one period | n modes need |
//! |---|---|---|
//! | square, frequency f | odd harmonics below fs/2: ⌈(fs/(2f) − 1)/2⌉, amplitude ∝ 1/k | f below the first mode |
//! | multisine, M tones | M | M ≥ 2n, band over the modes |
//! | PRBS, order k, bit rate f_b | (2^k − 1)·fs/(2f_b) − nulls, usable below ≈ 0.4 f_b | f_b ≳ 2.5× the top mode |
//! | chirp f0→f1, period T | ≈ \|f1 − f0\|·T | band over the modes |
//! | off | 0 | never exciting |
//!
//! # Safe window
//! Every level request is checked: `offset ± amplitude` must stay inside
//! the window, otherwise the request is **rejected** (an error, nothing
//! changes) — a piezo command that is silently reduced would mislead the
//! user, and the serial protocol answers a rejected command with a reason.
//! Each waveform's samples are bounded by its full scale by construction,
//! so accepted settings can never leave the window; the per-sample clamp
//! is a second line of defence whose activations are counted
//! ([`Excitation::clamped_samples`], expected to stay 0).
//!
//! # Design
//! Every waveform is integer: a 32-bit phase accumulator (direct digital
//! synthesis) and a Q30 sine table ([`sine`]), so nothing drifts and the
//! f32 and f64 builds produce the same normalised sequence. One conversion
//! and one multiply-add per sample turn it into volts.

#![deny(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::panic,
    clippy::indexing_slicing
)]

pub mod chirp;
pub mod multisine;
pub mod prbs;
pub mod sine;
mod square;

pub use chirp::{Chirp, ChirpSpec, Sweep};
pub use multisine::{Multisine, MultisineSpec, Phases};
pub use prbs::Prbs;
pub use square::SquareWave;

use crate::scalar::Real;
use sine::ONE_Q30;

/// 2³² as f64: phase units per cycle.
const CYCLE: f64 = 4_294_967_296.0;

/// Invalid excitation settings.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum ExcitationError {
    /// A frequency (or bit rate) is not positive, not finite or not below
    /// half the sample rate, or a band is empty.
    Frequency,
    /// Amplitude must be finite and non-negative.
    Amplitude,
    /// Offset must be finite.
    Offset,
    /// The window must be finite with min ≤ max.
    Window,
    /// offset ± amplitude would leave the safe window.
    OutsideWindow,
    /// Number of multisine tones outside 1..=[`multisine::MAX_TONES`].
    Tones,
    /// Period out of range (multisine 2^8..2^16 samples, chirp ≥ 2 samples).
    Period,
    /// PRBS order outside [`prbs::MIN_ORDER`]..=[`prbs::MAX_ORDER`].
    PrbsOrder,
    /// The sample rate is not positive and finite, or a waveform was built
    /// for another sample rate.
    SampleRate,
    /// The setting does not apply to the current waveform (e.g. a single
    /// frequency for a multisine).
    Unsupported,
}

impl core::fmt::Display for ExcitationError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(match self {
            Self::Frequency => "frequency not positive or not below half the sample rate",
            Self::Amplitude => "amplitude not finite and non-negative",
            Self::Offset => "offset not finite",
            Self::Window => "safe window not finite or min > max",
            Self::OutsideWindow => "offset ± amplitude outside the safe window",
            Self::Tones => "number of multisine tones out of range",
            Self::Period => "period out of range",
            Self::PrbsOrder => "PRBS order out of range",
            Self::SampleRate => "sample rate invalid or mismatched",
            Self::Unsupported => "setting does not apply to this waveform",
        })
    }
}

impl core::error::Error for ExcitationError {}

/// Which waveform.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ExcitationKind {
    /// Output held at the offset.
    Off,
    /// Square wave.
    Square,
    /// Multisine.
    Multisine,
    /// Maximum-length PRBS.
    Prbs,
    /// Repeating chirp.
    Chirp,
}

/// What to generate (settings; [`Waveform::new`] builds the generator).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Shape {
    /// No excitation: the output is the offset.
    Off,
    /// ±1 square wave at this frequency (Hz).
    Square {
        /// Frequency (Hz), 0 < f < fs/2.
        frequency_hz: f64,
    },
    /// Periodic multisine.
    Multisine(MultisineSpec),
    /// ±1 PRBS.
    Prbs {
        /// Register length k (period 2^k − 1 bits).
        order: u8,
        /// Bits per second; the bit period is round(fs/bit_rate) ≥ 1 samples.
        bit_rate_hz: f64,
        /// Initial register (0 → all ones).
        seed: u32,
    },
    /// Repeating sweep.
    Chirp(ChirpSpec),
}

/// A running, normalised generator: integer samples in
/// [−[`Waveform::full_scale`], +full scale].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Waveform {
    gen: Generator,
    sample_rate_hz: f64,
}

#[derive(Debug, Clone, Copy, PartialEq)]
enum Generator {
    Off,
    Square { phase: u32, step: u32 },
    Multisine(Multisine),
    Prbs(Prbs),
    Chirp(Chirp),
}

fn dds_step(freq_hz: f64, sample_rate_hz: f64) -> Result<u32, ExcitationError> {
    if !(freq_hz > 0.0 && freq_hz < 0.5 * sample_rate_hz) {
        return Err(ExcitationError::Frequency);
    }
    Ok(libm::round(freq_hz / sample_rate_hz * CYCLE) as u32)
}

fn prbs_divider(bit_rate_hz: f64, sample_rate_hz: f64) -> Result<u32, ExcitationError> {
    if !(bit_rate_hz > 0.0 && bit_rate_hz <= sample_rate_hz) {
        return Err(ExcitationError::Frequency);
    }
    let d = libm::round(sample_rate_hz / bit_rate_hz);
    if d > f64::from(u32::MAX) {
        return Err(ExcitationError::Frequency);
    }
    Ok((d as u32).max(1))
}

impl Waveform {
    /// Build the generator for `shape` at `sample_rate_hz`. A multisine
    /// scans one period here (see [`multisine`]): call this outside the
    /// sample interrupt.
    pub fn new(shape: &Shape, sample_rate_hz: f64) -> Result<Self, ExcitationError> {
        if !(sample_rate_hz > 0.0 && sample_rate_hz.is_finite()) {
            return Err(ExcitationError::SampleRate);
        }
        let gen = match *shape {
            Shape::Off => Generator::Off,
            Shape::Square { frequency_hz } => Generator::Square {
                phase: 0,
                step: dds_step(frequency_hz, sample_rate_hz)?,
            },
            Shape::Multisine(spec) => Generator::Multisine(Multisine::new(&spec, sample_rate_hz)?),
            Shape::Prbs {
                order,
                bit_rate_hz,
                seed,
            } => Generator::Prbs(Prbs::new(
                order,
                prbs_divider(bit_rate_hz, sample_rate_hz)?,
                seed,
            )?),
            Shape::Chirp(spec) => Generator::Chirp(Chirp::new(&spec, sample_rate_hz)?),
        };
        Ok(Self {
            gen,
            sample_rate_hz,
        })
    }

    /// This sample (|v| ≤ full scale), then advance one sample.
    #[inline]
    pub fn next_raw(&mut self) -> i32 {
        match &mut self.gen {
            Generator::Off => 0,
            Generator::Square { phase, step } => {
                let v = if *phase < 0x8000_0000 {
                    ONE_Q30
                } else {
                    -ONE_Q30
                };
                *phase = phase.wrapping_add(*step);
                v
            }
            Generator::Multisine(m) => m.next_raw(),
            Generator::Prbs(p) => {
                if p.next_bit() {
                    ONE_Q30
                } else {
                    -ONE_Q30
                }
            }
            Generator::Chirp(c) => c.next_raw(),
        }
    }

    /// The largest |sample|: 2³⁰, or a multisine's scanned peak.
    pub fn full_scale(&self) -> i32 {
        match &self.gen {
            Generator::Multisine(m) => m.peak(),
            _ => ONE_Q30,
        }
    }

    /// Which waveform.
    pub fn kind(&self) -> ExcitationKind {
        match self.gen {
            Generator::Off => ExcitationKind::Off,
            Generator::Square { .. } => ExcitationKind::Square,
            Generator::Multisine(_) => ExcitationKind::Multisine,
            Generator::Prbs(_) => ExcitationKind::Prbs,
            Generator::Chirp(_) => ExcitationKind::Chirp,
        }
    }

    /// The sample rate it was built for (Hz).
    pub fn sample_rate_hz(&self) -> f64 {
        self.sample_rate_hz
    }

    /// Distinct sinusoids below fs/2 in one period (the module table),
    /// saturating; compare with 2n for n modes (Lemma 1).
    pub fn spectral_lines(&self) -> u32 {
        let fs = self.sample_rate_hz;
        let lines = match &self.gen {
            Generator::Off => 0.0,
            Generator::Square { step, .. } => {
                let harmonics = CYCLE / (2.0 * f64::from((*step).max(1)));
                libm::ceil((harmonics - 1.0) / 2.0).max(1.0)
            }
            Generator::Multisine(m) => m.tones() as f64,
            Generator::Prbs(p) => {
                let period = f64::from(p.period_bits()) * f64::from(p.divider());
                let below_nyquist = libm::floor(period / 2.0);
                // Lines at multiples of the bit rate are nulls (sinc² zeros).
                below_nyquist - libm::floor(below_nyquist / f64::from(p.period_bits()))
            }
            Generator::Chirp(c) => {
                let s = c.spec();
                libm::round((s.f1_hz - s.f0_hz).abs() * f64::from(c.period_samples()) / fs).max(1.0)
            }
        };
        if lines >= f64::from(u32::MAX) {
            u32::MAX
        } else {
            lines as u32
        }
    }

    /// Whether the waveform has the 2n sinusoids that n modes need (Lemma 1).
    pub fn excites(&self, modes: usize) -> bool {
        (self.spectral_lines() as usize) >= 2 * modes
    }

    /// Back to the start of the waveform (phase 0, PRBS seed).
    pub fn reset(&mut self) {
        match &mut self.gen {
            Generator::Off => {}
            Generator::Square { phase, .. } => *phase = 0,
            Generator::Multisine(m) => m.reset(),
            Generator::Prbs(p) => p.reset(),
            Generator::Chirp(c) => c.reset(),
        }
    }
}

/// The voltage range the actuator may see (V, inclusive), e.g. the piezo's
/// rated range (the paper's PI P-876.A12 DuraAct: −100 V … +250 V).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SafeWindow<T> {
    /// Lowest allowed voltage (V).
    pub min_v: T,
    /// Highest allowed voltage (V).
    pub max_v: T,
}

impl<T: Real> SafeWindow<T> {
    fn validate(&self) -> Result<(), ExcitationError> {
        if self.min_v.is_finite() && self.max_v.is_finite() && self.min_v <= self.max_v {
            Ok(())
        } else {
            Err(ExcitationError::Window)
        }
    }
}

/// The run-time excitation: `offset + amplitude·w(k)/full_scale` volts,
/// w a [`Waveform`], always inside the [`SafeWindow`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Excitation<T> {
    wave: Waveform,
    amplitude_v: T,
    offset_v: T,
    window: SafeWindow<T>,
    /// amplitude/full_scale, rounded so that gain·full_scale ≤ amplitude.
    gain: T,
    clamped: u32,
}

impl<T: Real> Excitation<T> {
    /// Generator for `shape` at `sample_rate_hz`, level `offset_v ±
    /// amplitude_v` (V) inside `window`.
    pub fn new(
        shape: &Shape,
        amplitude_v: T,
        offset_v: T,
        window: SafeWindow<T>,
        sample_rate_hz: f64,
    ) -> Result<Self, ExcitationError> {
        window.validate()?;
        let wave = Waveform::new(shape, sample_rate_hz)?;
        check_level(amplitude_v, offset_v, &window)?;
        Ok(Self {
            wave,
            amplitude_v,
            offset_v,
            window,
            gain: gain_for(amplitude_v, wave.full_scale()),
            clamped: 0,
        })
    }

    /// Voltage for this sample (V, inside the window), then advance.
    #[inline]
    pub fn next_sample(&mut self) -> T {
        let v = self.offset_v + self.gain * T::from_i32(self.wave.next_raw());
        if v > self.window.max_v {
            self.clamped = self.clamped.saturating_add(1);
            self.window.max_v
        } else if v < self.window.min_v {
            self.clamped = self.clamped.saturating_add(1);
            self.window.min_v
        } else {
            v
        }
    }

    /// New amplitude (V, ≥ 0); rejected if offset ± amplitude leaves the
    /// window. The waveform's phase is kept.
    pub fn set_amplitude(&mut self, amplitude_v: T) -> Result<(), ExcitationError> {
        self.set_level(amplitude_v, self.offset_v)
    }

    /// New offset (V); rejected if offset ± amplitude leaves the window.
    pub fn set_offset(&mut self, offset_v: T) -> Result<(), ExcitationError> {
        self.set_level(self.amplitude_v, offset_v)
    }

    /// Amplitude and offset together (one check: moving both can pass
    /// through an invalid intermediate state).
    pub fn set_level(&mut self, amplitude_v: T, offset_v: T) -> Result<(), ExcitationError> {
        check_level(amplitude_v, offset_v, &self.window)?;
        self.amplitude_v = amplitude_v;
        self.offset_v = offset_v;
        self.gain = gain_for(amplitude_v, self.wave.full_scale());
        Ok(())
    }

    /// New safe window; rejected if the current level does not fit in it.
    pub fn set_window(&mut self, window: SafeWindow<T>) -> Result<(), ExcitationError> {
        window.validate()?;
        check_level(self.amplitude_v, self.offset_v, &window)?;
        self.window = window;
        Ok(())
    }

    /// Square: the frequency (Hz); PRBS: the bit rate (Hz). The phase (the
    /// PRBS register) is kept, so the output stays continuous.
    /// [`ExcitationError::Unsupported`] for the other kinds (use
    /// [`Excitation::set_band`] or [`Excitation::set_waveform`]).
    pub fn set_frequency(&mut self, freq_hz: f64) -> Result<(), ExcitationError> {
        let fs = self.wave.sample_rate_hz;
        match &mut self.wave.gen {
            Generator::Square { step, .. } => *step = dds_step(freq_hz, fs)?,
            Generator::Prbs(p) => p.set_divider(prbs_divider(freq_hz, fs)?)?,
            _ => return Err(ExcitationError::Unsupported),
        }
        Ok(())
    }

    /// Chirp: new start/end frequencies, keeping the sweep period, the
    /// phase and the relative position in the sweep. Other kinds:
    /// [`ExcitationError::Unsupported`] (a multisine's band is rebuilt with
    /// [`Waveform::new`] outside the interrupt, then [`Excitation::set_waveform`]).
    pub fn set_band(&mut self, f0_hz: f64, f1_hz: f64) -> Result<(), ExcitationError> {
        let fs = self.wave.sample_rate_hz;
        match &mut self.wave.gen {
            Generator::Chirp(c) => {
                let spec = ChirpSpec {
                    f0_hz,
                    f1_hz,
                    ..*c.spec()
                };
                c.retune(&spec, fs)
            }
            _ => Err(ExcitationError::Unsupported),
        }
    }

    /// Replace the waveform (built beforehand with [`Waveform::new`] at the
    /// same sample rate); the level and window stay. It starts at its own
    /// phase 0.
    pub fn set_waveform(&mut self, wave: Waveform) -> Result<(), ExcitationError> {
        if wave.sample_rate_hz != self.wave.sample_rate_hz {
            return Err(ExcitationError::SampleRate);
        }
        self.gain = gain_for(self.amplitude_v, wave.full_scale());
        self.wave = wave;
        Ok(())
    }

    /// Amplitude (V).
    pub fn amplitude(&self) -> T {
        self.amplitude_v
    }

    /// Offset (V).
    pub fn offset(&self) -> T {
        self.offset_v
    }

    /// The safe window.
    pub fn window(&self) -> SafeWindow<T> {
        self.window
    }

    /// The waveform.
    pub fn waveform(&self) -> &Waveform {
        &self.wave
    }

    /// Which waveform.
    pub fn kind(&self) -> ExcitationKind {
        self.wave.kind()
    }

    /// Samples the final clamp had to limit (saturating; 0 unless a bug).
    pub fn clamped_samples(&self) -> u32 {
        self.clamped
    }

    /// Restart the waveform (phase 0); level, window and counter stay.
    pub fn reset(&mut self) {
        self.wave.reset();
    }
}

fn check_level<T: Real>(a: T, o: T, w: &SafeWindow<T>) -> Result<(), ExcitationError> {
    if !(a.is_finite() && a >= T::ZERO) {
        return Err(ExcitationError::Amplitude);
    }
    if !o.is_finite() {
        return Err(ExcitationError::Offset);
    }
    // Same arithmetic as the sample path (o + gain·q with |gain·q| ≤ a).
    if o - a >= w.min_v && o + a <= w.max_v {
        Ok(())
    } else {
        Err(ExcitationError::OutsideWindow)
    }
}

/// amplitude/full_scale, nudged down so that gain·full_scale ≤ amplitude
/// (then |gain·q| ≤ amplitude for every |q| ≤ full scale, by monotonic
/// rounding). Exact for the power-of-two full scale 2³⁰.
fn gain_for<T: Real>(amplitude: T, full_scale: i32) -> T {
    let fs = T::from_i32(full_scale.max(1));
    let g = amplitude / fs;
    if g * fs > amplitude {
        g * (T::ONE - T::EPSILON)
    } else {
        g
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used, clippy::indexing_slicing, clippy::panic)]
mod tests;
