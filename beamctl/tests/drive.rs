//! `beamctl simulate --wave`: the firmware's generators drive the paper's
//! 2-mode plant, and the estimate converges on the simulated truth.

mod common;

use common::*;

/// Measured at 5 s (f64, noise-free, automatic λ): the largest relative
/// error of ω, ζ and b̄ is 9.5e-10 (multisine), 1.4e-9 (PRBS), 8.8e-10
/// (chirp), each within 0.1% from 0.54–0.88 s on.
const TOLERANCE: f64 = 1e-7;

#[test]
fn every_firmware_waveform_identifies_the_papers_plant() {
    for wave in [
        &["--wave", "multisine", "--band", "2:80", "--tones", "8"][..],
        &["--wave", "prbs", "--bit-rate", "500", "--bits", "10"],
        &["--wave", "chirp", "--band", "1:80", "--sweep", "4"],
    ] {
        let mut a = vec!["simulate", "--json", "--duration", "5"];
        a.extend_from_slice(wave);
        let r = json(&beamctl(&a));
        for k in ["omega", "zeta", "bbar"] {
            for (e, t) in r["estimate"][k]
                .as_array()
                .unwrap()
                .iter()
                .zip(r["truth"][k].as_array().unwrap())
            {
                let rel = ((num(e) - num(t)) / num(t)).abs();
                assert!(rel < TOLERANCE, "{wave:?}: {k} {e} vs truth {t}");
            }
        }
        assert!(num(&r["time_to_0p1pct_s"]) < 1.5, "{wave:?}");
        assert_eq!(r["excitation"]["amplitude_v"], 0.1, "{wave:?}");
    }
}

#[test]
fn without_wave_the_report_names_the_square_wave_and_no_excitation() {
    let o = beamctl(&["simulate", "--duration", "1"]);
    assert!(stdout(&o).contains("u = 0.1·square(7 Hz)"));
    let r = json(&beamctl(&["simulate", "--duration", "1", "--json"]));
    assert!(r.get("excitation").is_none());
    let o = beamctl(&["simulate", "--duration", "1", "--wave", "sine"]);
    assert_eq!(o.status.code(), Some(2));
}
