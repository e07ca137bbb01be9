//! The excitation generators whose per-sample cost the pipeline bench
//! (`benches/pipeline.rs`) and the cost example (`examples/pipeline_cost.rs`)
//! measure, at 10 kHz: the firmware's square wave, one- and eight-tone
//! multisines, a PRBS and linear and logarithmic chirps (names as
//! BENCHMARKS.md quotes them).

use beam_protocol::Waveform;
use beamest::excitation::{
    Chirp, ChirpSpec, Generator, Multisine, MultisineSpec, Phases, Prbs, Sweep,
};

/// Sample rate of the measured generators (Hz).
pub const SAMPLE_RATE_HZ: f64 = 1e4;

/// One multisine of `tones` tones over [f_min, f_max] Hz, Schroeder phases,
/// a 2^14-sample period.
fn multisine(f_min_hz: f64, f_max_hz: f64, tones: u8) -> Generator {
    let spec = MultisineSpec {
        f_min_hz,
        f_max_hz,
        tones,
        period_log2: 14,
        phases: Phases::Schroeder,
    };
    Generator::multisine(
        Multisine::new(&spec, SAMPLE_RATE_HZ).expect("multisine"),
        SAMPLE_RATE_HZ,
    )
    .expect("multisine")
}

/// A 2 → 80 Hz chirp over 10 s with the given sweep law.
fn chirp(sweep: Sweep) -> Generator {
    let spec = ChirpSpec {
        f0_hz: 2.0,
        f1_hz: 80.0,
        period_s: 10.0,
        sweep,
    };
    Generator::chirp(
        Chirp::new(&spec, SAMPLE_RATE_HZ).expect("chirp"),
        SAMPLE_RATE_HZ,
    )
    .expect("chirp")
}

/// The measured generators, each with its name.
pub fn generators() -> [(&'static str, Generator); 6] {
    [
        (
            "square",
            Generator::new(&Waveform::Square { freq_hz: 7.0 }, SAMPLE_RATE_HZ).expect("square"),
        ),
        ("multisine1", multisine(7.0, 7.0, 1)),
        ("multisine8", multisine(2.0, 80.0, 8)),
        (
            "prbs",
            // 500 bit/s at 10 kHz: a bit every 20 samples.
            Generator::prbs(Prbs::new(12, 20, 1).expect("prbs"), SAMPLE_RATE_HZ).expect("prbs"),
        ),
        ("chirp_lin", chirp(Sweep::Linear)),
        ("chirp_log", chirp(Sweep::Logarithmic)),
    ]
}
