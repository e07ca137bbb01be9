#!/usr/bin/env python3
"""Offline reference for the USC Dataset-4 Test 1 record (independent of
this project: numpy/scipy).

    python3 reference.py SOURCE      # SOURCE as in source.py

The drive holds three sines only (100, 120, 150 Hz), so no method can
identify a mode from this record: the reference is the verdict "not
identifiable", supported by the input's spectrum (Welch, Hann, 2^13-sample
segments, 0.39 Hz resolution): its level at each published natural
frequency relative to its strongest line. The published natural
frequencies (the dataset's modal_analysis/README.md, from the FFT of an
impulse test of the same beam: 6.62, 41.4 and 117.5 Hz; no damping is
published) are stored for information. H1 = S_uy/S_uu at the three lines
(accelerance per volt of drive) is stored too: the only FRF values the
record determines.
"""

import json
import sys
from pathlib import Path

import numpy as np
from scipy.signal import csd, welch

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
from source import COMMIT, FILE, FS, REPO, load  # noqa: E402

PUBLISHED_HZ = [6.62, 41.4, 117.5]
LINES_HZ = [100.0, 120.0, 150.0]


def main():
    t, v, f, a = load(sys.argv[1])
    nper = 2**13
    fr, puu = welch(v - v.mean(), fs=FS, nperseg=nper)
    _, pff = welch(f - f.mean(), fs=FS, nperseg=nper)
    _, puy = csd(v - v.mean(), a - a.mean(), fs=FS, nperseg=nper)
    top = puu.max()

    def level(p, hz):
        k = np.argmin(abs(fr - hz))
        return float(10 * np.log10(p[max(k - 1, 0) : k + 2].max() / p.max()))

    # fraction of the drive's power within ±10% of each published mode
    def share(hz):
        m = (fr > 0.9 * hz) & (fr < 1.1 * hz)
        return float(puu[m].sum() / puu.sum())

    modes = [
        {
            "f_hz_published": hz,
            "omega_rad_s_published": 2 * np.pi * hz,
            "zeta_published": None,
            "drive_level_db_re_strongest_line": level(puu, hz),
            "force_level_db_re_strongest_line": level(pff, hz),
            "drive_power_share_within_10pct": share(hz),
            "excited": "no" if share(hz) < 1e-6 else
            "one drive line near it only (a single line cannot fix ω and ζ)",
        }
        for hz in PUBLISHED_HZ
    ]
    lines = []
    for hz in LINES_HZ:
        k = np.argmin(abs(fr - hz))
        k = k - 1 + int(np.argmax(puu[k - 1 : k + 2]))
        h = puy[k] / puu[k]
        lines.append({"f_hz": float(fr[k]), "drive_level_db": float(10 * np.log10(puu[k] / top)),
                      "h1_re": float(h.real), "h1_im": float(h.imag)})
    ref = {
        "record": "real_arts_beam_sines",
        "kind": "real",
        "source": {
            "repository": REPO,
            "commit": COMMIT,
            "files": [FILE],
            "authors": "Puja Chowdhury, Austin Downey, Jason D. Bakos, Philip Conrad "
            "(University of South Carolina)",
            "date": "recorded 2020-08-06; dataset Apr. 2021",
            "licence": "CC-BY-SA-4.0",
            "url": "https://github.com/" + REPO,
        },
        "sensor_output": "acceleration",
        "output_relative_degree": 0,
        "excitation": "three sines (100, 120, 150 Hz) of the shaker drive, steady state",
        "structure": "steel cantilever beam 759 × 50.66 × 5.14 mm on an electromagnetic shaker "
        "through a load cell; accelerometer near the free end",
        "sample_rate_hz": FS,
        "ts_s": 1 / FS,
        "samples": len(t),
        "duration_s": len(t) / FS,
        "units": "t s; u V (drive); y m/s² (from g); force_n N (from pounds; preload offset ≈ "
        f"{f.mean():.1f} N)",
        "published_modal_values": {
            "f_hz": PUBLISHED_HZ,
            "where": "modal_analysis/README.md of the same repository (FFT of an impulse test)",
        },
        "reference_method": "input spectrum (Welch) at each published mode; no modal fit is "
        "possible from a three-line excitation",
        "modes": modes,
        "drive_lines": lines,
        "modes_in_band": 0,
        "acceptance": {
            "rule": "unidentifiable",
            "expected_trusted": False,
            "text": "the drive has no power at the beam's modes (≤ −95 dB re its lines at 6.6 and "
            "41.4 Hz; near 117.5 Hz only the single 120 Hz line): the report must say trusted: false (not identifiable), and no estimate "
            "may be presented as trusted",
        },
        "notes": "Published issue 15 symptom: `beamctl replay` reports an estimate (flagged only by "
        "a negative ζ). The force channel has a static preload and extra lines (≈20, 80, 300 Hz) "
        "the drive does not have: it is the load cell's reading of the beam's reaction, not a "
        "broadband input either.",
    }
    (HERE / "reference.json").write_text(json.dumps(ref, indent=2, ensure_ascii=False) + "\n")
    for m in modes:
        print(m)
    for ln in lines:
        print(ln)


if __name__ == "__main__":
    main()
