use super::*;

const FS: f64 = 1e4;

fn window(lo: f64, hi: f64) -> SafeWindow<f64> {
    SafeWindow {
        min_v: lo,
        max_v: hi,
    }
}

/// |DFT| at integer bin `k` of `x` (Goertzel), normalised to the sine
/// amplitude (a sine of amplitude A on bin k gives A).
fn goertzel(x: &[f64], k: usize) -> f64 {
    let n = x.len() as f64;
    let w = 2.0 * core::f64::consts::PI * k as f64 / n;
    let c = 2.0 * w.cos();
    let (mut s1, mut s2) = (0.0, 0.0);
    for &v in x {
        let s = v + c * s1 - s2;
        s2 = s1;
        s1 = s;
    }
    let re = s1 - s2 * w.cos();
    let im = s2 * w.sin();
    2.0 * (re * re + im * im).sqrt() / n
}

fn take(e: &mut Excitation<f64>, n: usize) -> Vec<f64> {
    (0..n).map(|_| e.next_sample()).collect()
}

#[test]
fn square_is_bitwise_the_papers_square_wave() {
    let mut e = Excitation::new(
        &Waveform::Square { freq_hz: 7.0 },
        0.1,
        0.0,
        window(-10.0, 10.0),
        FS,
    )
    .unwrap();
    let mut s = SquareWave::<f64>::paper();
    for _ in 0..100_000 {
        assert_eq!(e.next_sample().to_bits(), s.next_sample().to_bits());
    }
    let mut e32 = Excitation::<f32>::new(
        &Waveform::Square { freq_hz: 7.0 },
        0.1,
        0.0,
        SafeWindow {
            min_v: -10.0,
            max_v: 10.0,
        },
        FS,
    )
    .unwrap();
    let mut s32 = SquareWave::<f32>::paper();
    for _ in 0..20_000 {
        assert_eq!(e32.next_sample().to_bits(), s32.next_sample().to_bits());
    }
}

#[test]
fn multisine_has_its_lines_and_nothing_else() {
    let spec = MultisineSpec {
        f_min_hz: 3.0,
        f_max_hz: 60.0,
        tones: 6,
        period_log2: 13,
        phases: Phases::Schroeder,
    };
    let gen = Generator::multisine(Multisine::new(&spec, FS).unwrap(), FS).unwrap();
    let mut e = Excitation::with_generator(gen, 2.0, 1.0, window(-5.0, 5.0)).unwrap();
    let n = 1 << 13;
    let x = take(&mut e, n);
    let State::Multisine(m) = e.generator().state else {
        unreachable!()
    };
    let peak = x.iter().map(|v| (v - 1.0).abs()).fold(0.0, f64::max);
    assert!((peak - 2.0).abs() < 1e-12, "peak {peak}");
    // Equal lines at the harmonics, nothing elsewhere (exact period: no leakage).
    let tone = 2.0 / f64::from(m.peak()) * f64::from(1 << 26);
    let lines: Vec<usize> = (0..6).map(|i| m.harmonic(i).unwrap() as usize).collect();
    for k in 1..200 {
        let a = goertzel(&x, k);
        if lines.contains(&k) {
            assert!((a / tone - 1.0).abs() < 1e-4, "bin {k}: {a} vs {tone}");
        } else {
            assert!(a < 1e-4 * tone, "bin {k}: {a}");
        }
    }
    // DC = offset.
    let mean = x.iter().sum::<f64>() / n as f64;
    assert!((mean - 1.0).abs() < 1e-6);
    assert_eq!(e.generator().spectral_lines(), 6);
    assert!(e.generator().excites(3));
    assert!(!e.generator().excites(4));
}

#[test]
fn square_and_prbs_spectra() {
    // Square at fs/64: odd harmonics with amplitude 4/(πk) (to aliasing).
    let mut e = Excitation::new(
        &Waveform::Square {
            freq_hz: (FS / 64.0) as f32,
        },
        1.0,
        0.0,
        window(-1.0, 1.0),
        FS,
    )
    .unwrap();
    let x = take(&mut e, 64 * 16);
    let a1 = goertzel(&x, 16);
    assert!(
        (a1 / (4.0 / core::f64::consts::PI) - 1.0).abs() < 2e-3,
        "{a1}"
    );
    assert!(goertzel(&x, 32) < 1e-12);
    assert!(goertzel(&x, 48) > 0.4);
    assert_eq!(e.generator().spectral_lines(), 16);
    // PRBS order 7, one bit per sample: one period = 127 samples, flat
    // lines |X_k| = 2·√(128)/127 for every k ≠ 0, mean 1/127.
    let gen = Generator::prbs(Prbs::new(7, 1, 1).unwrap(), FS).unwrap();
    let mut p = Excitation::with_generator(gen, 1.0, 0.0, window(-1.0, 1.0)).unwrap();
    let x = take(&mut p, 127);
    let flat = 2.0 * 128f64.sqrt() / 127.0;
    for k in 1..63 {
        assert!((goertzel(&x, k) / flat - 1.0).abs() < 1e-9, "bin {k}");
    }
    assert!((x.iter().sum::<f64>() - 1.0).abs() < 1e-12);
    assert_eq!(p.generator().spectral_lines(), 63);
}

#[test]
fn chirp_energy_stays_in_its_band() {
    let spec = ChirpSpec {
        f0_hz: 100.0,
        f1_hz: 300.0,
        period_s: 0.4096,
        sweep: Sweep::Linear,
    };
    let gen = Generator::chirp(Chirp::new(&spec, FS).unwrap(), FS).unwrap();
    let mut e = Excitation::with_generator(gen, 1.0, 0.0, window(-1.0, 1.0)).unwrap();
    let x = take(&mut e, 4096);
    // Bin spacing fs/4096 = 2.44 Hz: band = bins 41..123.
    let inband: f64 = (45..120).map(|k| goertzel(&x, k).powi(2)).sum();
    let outband: f64 = (1..25)
        .chain(145..400)
        .map(|k| goertzel(&x, k).powi(2))
        .sum();
    assert!(outband < 0.02 * inband, "{outband} vs {inband}");
    assert_eq!(e.generator().spectral_lines(), 82);
}

#[test]
fn level_changes_are_checked_against_the_window() {
    let sq = Waveform::Square { freq_hz: 10.0 };
    let w = window(-20.0, 100.0);
    assert_eq!(
        Excitation::new(&sq, 30.0, 0.0, w, FS).unwrap_err(),
        ExcitationError::OutsideWindow
    );
    let mut e = Excitation::new(&sq, 20.0, 0.0, w, FS).unwrap();
    let before = e;
    assert_eq!(e.set_amplitude(21.0), Err(ExcitationError::OutsideWindow));
    assert_eq!(e.set_amplitude(-1.0), Err(ExcitationError::Amplitude));
    assert_eq!(e.set_amplitude(f64::NAN), Err(ExcitationError::Amplitude));
    assert_eq!(e.set_offset(f64::INFINITY), Err(ExcitationError::Offset));
    assert_eq!(e.set_offset(-1.0), Err(ExcitationError::OutsideWindow));
    assert_eq!(
        e.set_window(window(-10.0, 10.0)),
        Err(ExcitationError::OutsideWindow)
    );
    assert_eq!(
        e.set_window(window(1.0, -1.0)),
        Err(ExcitationError::Window)
    );
    assert_eq!(e.set_frequency(6000.0), Err(ExcitationError::Frequency));
    assert_eq!(e.set_band(1.0, 2.0), Err(ExcitationError::Unsupported));
    assert_eq!(e, before, "rejected requests change nothing");
    // Both together pass where neither alone does.
    e.set_level(50.0, 50.0).unwrap();
    let x = take(&mut e, 2000);
    assert!(x.iter().all(|&v| v == 0.0 || v == 100.0));
    assert_eq!(e.clamped_samples(), 0);
    // Off holds the offset.
    e.set_generator(Generator::new(&Waveform::Off, FS).unwrap())
        .unwrap();
    assert!(take(&mut e, 10).iter().all(|&v| v == 50.0));
    assert_eq!(
        e.set_generator(Generator::new(&Waveform::Off, 2.0 * FS).unwrap()),
        Err(ExcitationError::SampleRate)
    );
}

#[test]
fn amplitude_and_frequency_changes_keep_the_phase() {
    let mut e = Excitation::new(
        &Waveform::Square { freq_hz: 5.0 },
        1.0,
        0.0,
        window(-2.0, 2.0),
        FS,
    )
    .unwrap();
    // 0.15 periods in: still high; halve the amplitude, double the frequency.
    let x = take(&mut e, 300);
    assert!(x.iter().all(|&v| v == 1.0));
    e.set_amplitude(0.5).unwrap();
    e.set_frequency(10.0).unwrap();
    // Phase 0.15 cycle → flips at 0.5 cycle: (0.5 − 0.15)/10 Hz = 350 samples.
    let y = take(&mut e, 400);
    let flip = y.iter().position(|&v| v < 0.0).unwrap();
    assert!((349..=351).contains(&flip), "{flip}");
    assert!(y[..flip].iter().all(|&v| v == 0.5));
    // PRBS bit rate changes keep the register.
    let gen = Generator::prbs(Prbs::new(9, 10, 3).unwrap(), FS).unwrap();
    let mut p = Excitation::with_generator(gen, 1.0, 0.0, window(-1.0, 1.0)).unwrap();
    take(&mut p, 25);
    p.set_frequency(5000.0).unwrap();
    let State::Prbs(reg) = p.generator().state else {
        unreachable!()
    };
    assert_eq!(reg.divider(), 2);
    assert_eq!(
        Excitation::new(&Waveform::Off, 0.0, 0.0, window(-1.0, 1.0), FS)
            .unwrap()
            .set_frequency(1.0),
        Err(ExcitationError::Unsupported)
    );
}

#[test]
fn multisine_level_never_leaves_a_tight_window() {
    // Window exactly offset ± amplitude: the gain rounding must keep every
    // sample inside without the clamp (f32 rounds the most).
    let spec = MultisineSpec {
        f_min_hz: 1.0,
        f_max_hz: 400.0,
        tones: 16,
        period_log2: 14,
        phases: Phases::Random(99),
    };
    let gen = Generator::multisine(Multisine::new(&spec, FS).unwrap(), FS).unwrap();
    let mut e = Excitation::<f32>::with_generator(
        gen,
        3.3,
        1.7,
        SafeWindow {
            min_v: 1.7 - 3.3,
            max_v: 1.7 + 3.3,
        },
    )
    .unwrap();
    let mut dev = 0.0f32;
    for _ in 0..(1 << 15) {
        let v = e.next_sample();
        assert!((1.7 - 3.3..=1.7 + 3.3).contains(&v));
        dev = dev.max((v - 1.7).abs());
    }
    assert_eq!(e.clamped_samples(), 0);
    assert!(dev > 3.3 - 1e-5, "peak reached: {dev}");
}

#[test]
fn errors_display() {
    use core::fmt::Write;
    let mut s = String::new();
    write!(s, "{}", ExcitationError::OutsideWindow).unwrap();
    assert!(s.contains("window"));
}

#[test]
fn the_wire_waveforms_build_the_documented_generators() {
    // Generator::new's rule: Schroeder phases over 2^period_log2_for,
    // the PRBS from the all-ones register, a linear chirp.
    let ms = Waveform::Multisine {
        f_min_hz: 2.0,
        f_max_hz: 80.0,
        tones: 8,
    };
    let spec = MultisineSpec {
        f_min_hz: 2.0,
        f_max_hz: 80.0,
        tones: 8,
        period_log2: multisine::period_log2_for(2.0, FS),
        phases: Phases::Schroeder,
    };
    let prbs = Waveform::Prbs {
        bit_rate_hz: 500.0,
        register_bits: 10,
    };
    let chirp = Waveform::Chirp {
        f_start_hz: 1.0,
        f_end_hz: 80.0,
        sweep_s: 4.0,
    };
    let sweep = ChirpSpec {
        f0_hz: 1.0,
        f1_hz: 80.0,
        period_s: 4.0,
        sweep: Sweep::Linear,
    };
    for (w, own) in [
        (
            ms,
            Generator::multisine(Multisine::new(&spec, FS).unwrap(), FS),
        ),
        (prbs, Generator::prbs(Prbs::new(10, 20, 0).unwrap(), FS)),
        (chirp, Generator::chirp(Chirp::new(&sweep, FS).unwrap(), FS)),
    ] {
        let mut a = Generator::new(&w, FS).unwrap();
        let mut b = own.unwrap();
        assert_eq!(a, b);
        assert_eq!(a.kind(), w.kind());
        for _ in 0..70_000 {
            assert_eq!(a.next_raw(), b.next_raw());
        }
    }
    assert_eq!(
        Generator::multisine(Multisine::new(&spec, FS).unwrap(), f64::NAN),
        Err(ExcitationError::SampleRate)
    );
}

#[test]
fn an_excitation_is_an_endless_drive() {
    let mut e = Excitation::new(
        &Waveform::Square { freq_hz: 7.0 },
        0.1,
        0.0,
        window(-10.0, 10.0),
        FS,
    )
    .unwrap();
    let mut same = e;
    assert!(e
        .by_ref()
        .take(3000)
        .eq((0..3000).map(|_| same.next_sample())));
    assert_eq!(e.next(), Some(same.next_sample()));
    // Off ignores the amplitude on the wire: only the offset is the level.
    let off = protocol::Excitation {
        waveform: Waveform::Off,
        amplitude_v: 50.0,
        offset_v: 2.0,
    };
    assert_eq!(level::<f64>(&off), (0.0, 2.0));
    let sq = protocol::Excitation::default();
    assert_eq!(level::<f32>(&sq), (0.1, 0.0));
}
