//! Excitation signals for the piezo drive, generated sample by sample: the
//! paper's square wave, a multisine, a PRBS and a chirp, with amplitude,
//! offset and frequency settable at run time inside a safe voltage window.
//!
//! * [`SquareWave`] — the paper's 0.1·square(7 Hz) (Section IV.A), kept as
//!   the reference generator of the host tests;
//! * [`Excitation`] — the run-time generator of the firmware: one
//!   [`Generator`] (normalised, integer) times an amplitude plus an offset,
//!   in the actuator's volts, never outside a [`SafeWindow`]. It is built
//!   from the wire's [`Waveform`] ([`Generator::new`] states the settings
//!   the wire leaves to the device), and it is an endless
//!   `Iterator<Item = T>` of volts, the drive a simulated rig takes
//!   ([`crate::rig::Rig`]) as it takes a [`SquareWave`].
//!
//! # Lemma 1 (persistent excitation)
//! Θ of eq. 29 has 4n − 1 entries for n modes. Each sinusoid in u gives two
//! spectral lines, so u must contain at least 2n distinct frequencies in
//! the plant's band (DC adds one line). Per kind (`Generator::spectral_lines`
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
//! (`Excitation::clamped_samples`, expected to stay 0).
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

pub(crate) mod chirp;
pub(crate) mod multisine;
pub(crate) mod prbs;
pub mod sine;
mod square;

pub use chirp::{Chirp, ChirpSpec, Sweep};
pub use multisine::{Multisine, MultisineSpec, Phases, MAX_TONES as MULTISINE_MAX_TONES};
pub use prbs::{Prbs, MAX_ORDER as PRBS_MAX_ORDER, MIN_ORDER as PRBS_MIN_ORDER};
pub use square::SquareWave;

use crate::scalar::Real;
use beam_protocol::{self as protocol, Waveform, WaveformKind};
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
    /// Number of multisine tones outside 1..=`multisine::MAX_TONES`.
    Tones,
    /// Period out of range (multisine 2^8..2^16 samples, chirp ≥ 2 samples).
    Period,
    /// PRBS order outside `prbs::MIN_ORDER`..=`prbs::MAX_ORDER`.
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

/// A running, normalised generator: integer samples in
/// [−[`Generator::full_scale`], +full scale].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Generator {
    state: State,
    sample_rate_hz: f64,
}

#[derive(Debug, Clone, Copy, PartialEq)]
enum State {
    Off,
    Square { phase: u32, step: u32 },
    Multisine(Multisine),
    Prbs(Prbs),
    Chirp(Chirp),
}

fn check_sample_rate(sample_rate_hz: f64) -> Result<(), ExcitationError> {
    if sample_rate_hz > 0.0 && sample_rate_hz.is_finite() {
        Ok(())
    } else {
        Err(ExcitationError::SampleRate)
    }
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

impl Generator {
    /// The generator the device runs for the wire's `waveform` at
    /// `sample_rate_hz` (f32 settings widened to f64). The settings the wire
    /// does not carry are fixed here, and only here:
    ///
    /// * square: phase 0 at the first sample (high first);
    /// * multisine: Schroeder phases ([`Phases::Schroeder`]) over a period
    ///   of 2^k samples, k = `multisine::period_log2_for` the lowest tone;
    /// * PRBS: one bit every round(f_s/bit rate) samples, from the
    ///   all-ones register (seed 0);
    /// * chirp: linear sweep ([`Sweep::Linear`]).
    ///
    /// A multisine scans one period here (see `multisine`): call this
    /// outside the sample interrupt. Other phases, seeds or sweep laws:
    /// build the generator itself and wrap it ([`Generator::multisine`],
    /// [`Generator::prbs`], [`Generator::chirp`]).
    pub fn new(waveform: &Waveform, sample_rate_hz: f64) -> Result<Self, ExcitationError> {
        check_sample_rate(sample_rate_hz)?;
        let state = match *waveform {
            Waveform::Off => State::Off,
            Waveform::Square { freq_hz } => State::Square {
                phase: 0,
                step: dds_step(f64::from(freq_hz), sample_rate_hz)?,
            },
            Waveform::Multisine {
                f_min_hz,
                f_max_hz,
                tones,
            } => {
                let spec = MultisineSpec {
                    f_min_hz: f64::from(f_min_hz),
                    f_max_hz: f64::from(f_max_hz),
                    tones,
                    period_log2: multisine::period_log2_for(f64::from(f_min_hz), sample_rate_hz),
                    phases: Phases::Schroeder,
                };
                State::Multisine(Multisine::new(&spec, sample_rate_hz)?)
            }
            Waveform::Prbs {
                bit_rate_hz,
                register_bits,
            } => State::Prbs(Prbs::new(
                register_bits,
                prbs_divider(f64::from(bit_rate_hz), sample_rate_hz)?,
                0,
            )?),
            Waveform::Chirp {
                f_start_hz,
                f_end_hz,
                sweep_s,
            } => {
                let spec = ChirpSpec {
                    f0_hz: f64::from(f_start_hz),
                    f1_hz: f64::from(f_end_hz),
                    period_s: f64::from(sweep_s),
                    sweep: Sweep::Linear,
                };
                State::Chirp(Chirp::new(&spec, sample_rate_hz)?)
            }
        };
        Ok(Self {
            state,
            sample_rate_hz,
        })
    }

    /// A multisine built for `sample_rate_hz` with settings of its own
    /// (e.g. random phases, another period).
    pub fn multisine(m: Multisine, sample_rate_hz: f64) -> Result<Self, ExcitationError> {
        Self::with(State::Multisine(m), sample_rate_hz)
    }

    /// A PRBS with settings of its own (e.g. another seed); its divider
    /// counts samples of `sample_rate_hz`.
    pub fn prbs(p: Prbs, sample_rate_hz: f64) -> Result<Self, ExcitationError> {
        Self::with(State::Prbs(p), sample_rate_hz)
    }

    /// A chirp built for `sample_rate_hz` with settings of its own (e.g. a
    /// logarithmic sweep).
    pub fn chirp(c: Chirp, sample_rate_hz: f64) -> Result<Self, ExcitationError> {
        Self::with(State::Chirp(c), sample_rate_hz)
    }

    fn with(state: State, sample_rate_hz: f64) -> Result<Self, ExcitationError> {
        check_sample_rate(sample_rate_hz)?;
        Ok(Self {
            state,
            sample_rate_hz,
        })
    }

    /// This sample (|v| ≤ full scale), then advance one sample.
    #[inline]
    pub(crate) fn next_raw(&mut self) -> i32 {
        match &mut self.state {
            State::Off => 0,
            State::Square { phase, step } => {
                let v = if *phase < 0x8000_0000 {
                    ONE_Q30
                } else {
                    -ONE_Q30
                };
                *phase = phase.wrapping_add(*step);
                v
            }
            State::Multisine(m) => m.next_raw(),
            State::Prbs(p) => {
                if p.next_bit() {
                    ONE_Q30
                } else {
                    -ONE_Q30
                }
            }
            State::Chirp(c) => c.next_raw(),
        }
    }

    /// The largest |sample|: 2³⁰, or a multisine's scanned peak.
    pub fn full_scale(&self) -> i32 {
        match &self.state {
            State::Multisine(m) => m.peak(),
            _ => ONE_Q30,
        }
    }

    /// Which waveform.
    pub fn kind(&self) -> WaveformKind {
        match self.state {
            State::Off => WaveformKind::Off,
            State::Square { .. } => WaveformKind::Square,
            State::Multisine(_) => WaveformKind::Multisine,
            State::Prbs(_) => WaveformKind::Prbs,
            State::Chirp(_) => WaveformKind::Chirp,
        }
    }

    /// The sample rate it was built for (Hz).
    pub fn sample_rate_hz(&self) -> f64 {
        self.sample_rate_hz
    }

    /// Distinct sinusoids below fs/2 in one period (the module table),
    /// saturating; compare with 2n for n modes (Lemma 1).
    #[cfg(test)]
    pub(crate) fn spectral_lines(&self) -> u32 {
        let fs = self.sample_rate_hz;
        let lines = match &self.state {
            State::Off => 0.0,
            State::Square { step, .. } => {
                let harmonics = CYCLE / (2.0 * f64::from((*step).max(1)));
                libm::ceil((harmonics - 1.0) / 2.0).max(1.0)
            }
            State::Multisine(m) => m.tones() as f64,
            State::Prbs(p) => {
                let period = f64::from(p.period_bits()) * f64::from(p.divider());
                let below_nyquist = libm::floor(period / 2.0);
                // Lines at multiples of the bit rate are nulls (sinc² zeros).
                below_nyquist - libm::floor(below_nyquist / f64::from(p.period_bits()))
            }
            State::Chirp(c) => {
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
    #[cfg(test)]
    pub(crate) fn excites(&self, modes: usize) -> bool {
        (self.spectral_lines() as usize) >= 2 * modes
    }

    /// Back to the start of the waveform (phase 0, PRBS seed).
    pub fn reset(&mut self) {
        match &mut self.state {
            State::Off => {}
            State::Square { phase, .. } => *phase = 0,
            State::Multisine(m) => m.reset(),
            State::Prbs(p) => p.reset(),
            State::Chirp(c) => c.reset(),
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
/// w a [`Generator`], always inside the [`SafeWindow`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Excitation<T> {
    wave: Generator,
    amplitude_v: T,
    offset_v: T,
    window: SafeWindow<T>,
    /// amplitude/full_scale, rounded so that gain·full_scale ≤ amplitude.
    gain: T,
    clamped: u32,
}

impl<T: Real> Excitation<T> {
    /// The device's generator for `waveform` at `sample_rate_hz`
    /// ([`Generator::new`]), level `offset_v ± amplitude_v` (V) inside
    /// `window`.
    pub fn new(
        waveform: &Waveform,
        amplitude_v: T,
        offset_v: T,
        window: SafeWindow<T>,
        sample_rate_hz: f64,
    ) -> Result<Self, ExcitationError> {
        window.validate()?;
        Self::with_generator(
            Generator::new(waveform, sample_rate_hz)?,
            amplitude_v,
            offset_v,
            window,
        )
    }

    /// `wave` at level `offset_v ± amplitude_v` (V) inside `window`.
    pub fn with_generator(
        wave: Generator,
        amplitude_v: T,
        offset_v: T,
        window: SafeWindow<T>,
    ) -> Result<Self, ExcitationError> {
        window.validate()?;
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
    #[cfg(test)]
    pub(crate) fn set_offset(&mut self, offset_v: T) -> Result<(), ExcitationError> {
        self.set_level(self.amplitude_v, offset_v)
    }

    /// Amplitude and offset together (one check: moving both can pass
    /// through an invalid intermediate state).
    pub(crate) fn set_level(&mut self, amplitude_v: T, offset_v: T) -> Result<(), ExcitationError> {
        check_level(amplitude_v, offset_v, &self.window)?;
        self.amplitude_v = amplitude_v;
        self.offset_v = offset_v;
        self.gain = gain_for(amplitude_v, self.wave.full_scale());
        Ok(())
    }

    /// New safe window; rejected if the current level does not fit in it.
    #[cfg(test)]
    pub(crate) fn set_window(&mut self, window: SafeWindow<T>) -> Result<(), ExcitationError> {
        window.validate()?;
        check_level(self.amplitude_v, self.offset_v, &window)?;
        self.window = window;
        Ok(())
    }

    /// Square: the frequency (Hz); PRBS: the bit rate (Hz). The phase (the
    /// PRBS register) is kept, so the output stays continuous.
    /// [`ExcitationError::Unsupported`] for the other kinds (use
    /// [`Excitation::set_band`] or [`Excitation::set_generator`]).
    pub(crate) fn set_frequency(&mut self, freq_hz: f64) -> Result<(), ExcitationError> {
        let fs = self.wave.sample_rate_hz;
        match &mut self.wave.state {
            State::Square { step, .. } => *step = dds_step(freq_hz, fs)?,
            State::Prbs(p) => p.set_divider(prbs_divider(freq_hz, fs)?)?,
            _ => return Err(ExcitationError::Unsupported),
        }
        Ok(())
    }

    /// Chirp: new start/end frequencies, keeping the sweep period, the
    /// phase and the relative position in the sweep. Other kinds:
    /// [`ExcitationError::Unsupported`] (a multisine's band is rebuilt with
    /// [`Generator::new`] outside the interrupt, then [`Excitation::set_generator`]).
    #[cfg(test)]
    pub(crate) fn set_band(&mut self, f0_hz: f64, f1_hz: f64) -> Result<(), ExcitationError> {
        let fs = self.wave.sample_rate_hz;
        match &mut self.wave.state {
            State::Chirp(c) => {
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

    /// Replace the generator (built beforehand, e.g. with
    /// [`Generator::new`], at the same sample rate); the level and window
    /// stay. It starts at its own phase 0.
    pub(crate) fn set_generator(&mut self, wave: Generator) -> Result<(), ExcitationError> {
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

    /// The generator.
    pub(crate) fn generator(&self) -> &Generator {
        &self.wave
    }

    /// Which waveform.
    pub fn kind(&self) -> WaveformKind {
        self.wave.kind()
    }

    /// Samples the final clamp had to limit (saturating; 0 unless a bug).
    pub(crate) fn clamped_samples(&self) -> u32 {
        self.clamped
    }

    /// Restart the waveform (phase 0); level, window and counter stay.
    pub fn reset(&mut self) {
        self.wave.reset();
    }
}

/// An endless sequence of volts ([`Excitation::next_sample`]): the drive of
/// a simulated rig ([`crate::rig::Rig`]), as a [`SquareWave`] is.
impl<T: Real> Iterator for Excitation<T> {
    type Item = T;

    #[inline]
    fn next(&mut self) -> Option<T> {
        Some(self.next_sample())
    }
}

/// The level the device sets for the wire's excitation `e`: (amplitude,
/// offset) in V; `Off` ignores the amplitude (`docs/PROTOCOL.md` §5.1), so
/// only its offset must be inside the window.
pub fn level<T: Real>(e: &protocol::Excitation) -> (T, T) {
    let amplitude_v = match e.waveform {
        Waveform::Off => T::ZERO,
        _ => T::from_f64(f64::from(e.amplitude_v)),
    };
    (amplitude_v, T::from_f64(f64::from(e.offset_v)))
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
