#!/usr/bin/env python3
"""Offline reference for the pyFRF impact record (independent of this
project: numpy/scipy, ../frf_fit.py).

    python3 reference.py SOURCE      # SOURCE as in source.py

1. H1 = Σ conj(F)·X / Σ|F|² over the five hits (rectangular window, 1 s,
   Δf = 1 Hz; the responses have decayed to ~1% of their peak by the end
   of each record), with the coherence.
2. Local rational-fraction least-squares fits of the accelerance (model in
   ../frf_fit.py: real residues, upper and lower residual) in bands chosen
   around the isolated peaks, on H1 and on each hit alone (X_k/F_k).
3. A second, time-domain method as a cross-check: each hit's response
   band-passed zero-phase (4th-order Butterworth, scipy sosfiltfilt, the
   same band) and its free decay from 10 ms to 0.9 s fitted by a sum of
   damped sinusoids (scipy least_squares); the mean over the hits.
4. Reference value = the fit on H1; uncertainty σ = sqrt(σ_hits² + Δ²),
   σ_hits the sample standard deviation of the five single-hit FRF fits
   (each hit is an independent measurement, so this is the uncertainty of
   a value from ONE hit, which is what a replay of record.csv.gz — hit 1 —
   yields) and Δ the difference between the two methods (their systematic
   disagreement). The H1 fit's own 1σ is stored beside it. Tolerance for a
   replay: ω within max(3σ, 1e-4) relative, ζ within 3σ relative.
"""

import json
import sys
from pathlib import Path

import numpy as np
from scipy.ndimage import uniform_filter1d
from scipy.optimize import least_squares
from scipy.signal import butter, sosfiltfilt

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
sys.path.insert(0, str(HERE.parent))
from frf_fit import fit, h1  # noqa: E402
from source import COMMIT, FS, REPO, load  # noqa: E402

# (band Hz, initial peak picks Hz, scored?)
GROUPS = [
    ((650.0, 1100.0), [810.0, 900.0], True),
    ((2450.0, 2850.0), [2640.0], True),
    ((3550.0, 3800.0), [3669.0, 3690.0], False),
]


def free_decay(hits, band, f0s, z0s):
    """Mean (f_hz, zeta) per mode of damped-sinusoid fits to each hit's
    band-passed free decay (10 ms … 0.9 s after the record start)."""
    sos = butter(4, band, btype="band", fs=FS, output="sos")
    res = []
    for h in hits:
        t = h[0]
        y = sosfiltfilt(sos, h[2])
        sel = (t > 0.01) & (t < 0.9)
        tt, yy = t[sel] - 0.01, y[sel]

        def mdl(p):
            out = np.zeros_like(tt)
            for i in range(len(f0s)):
                f, z, a, b = p[4 * i : 4 * i + 4]
                w = 2 * np.pi * f
                wd = w * np.sqrt(1 - z * z)
                out += np.exp(-z * w * tt) * (a * np.cos(wd * tt) + b * np.sin(wd * tt))
            return out

        p0 = []
        for f, z in zip(f0s, z0s):
            p0 += [f, z, yy.std(), yy.std()]
        p = least_squares(lambda q: mdl(q) - yy, p0, x_scale="jac").x
        res.append([(p[4 * i], p[4 * i + 1]) for i in range(len(f0s))])
    res = np.array(res)  # hits × modes × 2
    return res.mean(0)


def main():
    hits = load(sys.argv[1])
    n = hits[0].shape[1]
    freq = np.fft.rfftfreq(n, 1 / FS)
    H, coh, F, X = h1([h[1] for h in hits], [h[2] for h in hits])
    fmag = np.abs(F).mean(0)
    fmax = fmag[1:200].mean()  # the force spectrum's low-frequency level
    smooth = uniform_filter1d(20 * np.log10(fmag / fmax), 51)
    rolloff = {thr: int(freq[1 + int(np.argmax(smooth[1:] < thr))]) for thr in (-3, -10, -20)}
    modes = []
    for band, picks, scored in GROUPS:
        ref, _, fitpct = fit(freq, H, band, picks)
        per = [fit(freq, X[k] / F[k], band, picks)[0] for k in range(len(hits))]
        fd = free_decay(hits, band, [q["omega"] / (2 * np.pi) for q in ref], [q["zeta"] for q in ref])
        for i, m in enumerate(ref):
            om = np.array([p[i]["omega"] for p in per])
            ze = np.array([p[i]["zeta"] for p in per])
            # a single-hit fit that jumped to the neighbour of a doublet
            # shows as a spread far above the others; keep it (honest) but
            # such groups are not scored.
            k = int(round(m["omega"] / (2 * np.pi)))
            sd_om = float(np.std(om, ddof=1))
            sd_ze = float(np.std(ze, ddof=1))
            d_om = abs(2 * np.pi * fd[i][0] - m["omega"])
            d_ze = abs(fd[i][1] - m["zeta"])
            modes.append({
                "f_hz": m["omega"] / (2 * np.pi),
                "omega_rad_s": m["omega"],
                "zeta": m["zeta"],
                "residue_r": m["r"],
                "sigma_omega_rel": float(np.hypot(sd_om, d_om) / m["omega"]),
                "sigma_zeta_rel": float(np.hypot(sd_ze, d_ze) / m["zeta"]),
                "sigma_omega_rel_hits": sd_om / m["omega"],
                "sigma_zeta_rel_hits": sd_ze / m["zeta"],
                "free_decay_f_hz": float(fd[i][0]),
                "free_decay_zeta": float(fd[i][1]),
                "sigma_omega_rel_fit": m["sd_omega"] / m["omega"],
                "sigma_zeta_rel_fit": m["sd_zeta"] / m["zeta"],
                "per_hit_omega_rad_s": om.tolist(),
                "per_hit_zeta": ze.tolist(),
                "band_hz": list(band),
                "band_fit_percent": fitpct,
                "coherence_at_peak": float(coh[k]),
                "force_level_db": float(20 * np.log10(fmag[k] / fmax)),
                "scored": scored,
            })
    scored = [m for m in modes if m["scored"]]
    # b̄ in the project's convention for the two model hypotheses a user
    # would try: the 2 or 3 lowest modes (c = −2, 2, −2 in that order).
    c = [-2.0, 2.0, -2.0]
    ref = {
        "record": "real_pyfrf_impact",
        "kind": "real",
        "source": {
            "repository": REPO,
            "commit": COMMIT,
            "files": [f"data/measurements_{i}.npy" for i in range(1, 6)],
            "record_is": "data/measurements_1.npy (hit 1)",
            "authors": "measurements prepared by Matej Razpotnik (University of Ljubljana, "
            "Laboratory for Dynamics of Machines and Structures); repository by Janko Slavič",
            "date": "2016-09-15 (commit)",
            "licence": "MIT",
            "url": "https://github.com/ladisk/pyFRF",
        },
        "sensor_output": "acceleration",
        "sensor_output_evidence": "below the first mode |H1| is flat (≈1.2 source units) with phase "
        "≈180°: the mass line of a free-free structure's accelerance (a receptance would rise "
        "as 1/ω²); pyFRF's default response type is 'a'",
        "output_relative_degree": 0,
        "excitation": "impact",
        "excitation_detail": "one hammer impact per record at t ≈ 0.86 ms (22 samples of pre-trigger), "
        "pulse ≈ 0.3 ms wide (7–8 samples above 10% of its peak, by hit); the force spectrum (mean |F| of the "
        "hits, 51-bin moving average) falls below its 1–199 Hz level by 3 dB at "
        f"{rolloff[-3]} Hz, 10 dB at {rolloff[-10]} Hz, 20 dB at {rolloff[-20]} Hz "
        "(force_level_db per mode)",
        "structure": "not described by the source; the accelerance has a rigid-body mass line "
        "(free-free support) and lightly damped modes from 810 Hz up (doublets near 3.67 and 4.1 kHz)",
        "sample_rate_hz": FS,
        "ts_s": 1 / FS,
        "samples": n,
        "duration_s": n / FS,
        "units": "source units, not stated by the source (u: force channel; y: response channel)",
        "published_modal_values": None,
        "reference_method": "H1 over 5 hits + local rational-fraction least-squares fits "
        "(host-tests/data/records/frf_fit.py, reference.py), cross-checked by damped-sinusoid fits "
        "of the band-passed free decays; σ = spread of the 5 single-hit fits ⊕ the methods' difference",
        "modes": modes,
        "modes_in_band": len(scored),
        "bbar_project_convention": {
            "two_lowest": [scored[i]["residue_r"] / c[i] for i in range(2)],
            "three_lowest": [scored[i]["residue_r"] / c[i] for i in range(3)],
            "note": "acceleration output: y = s²·Σ c_i·b̄_i/q_i(s)·u, c = (−2, 2, −2) over the "
            "modelled modes in ascending order; b̄_i = r_i/c_i",
        },
        "acceptance": {
            "rule": "real_reference",
            "omega_rel_tol": [max(3 * m["sigma_omega_rel"], 1e-4) for m in scored],
            "zeta_rel_tol": [3 * m["sigma_zeta_rel"] for m in scored],
            "scored_f_hz": [m["f_hz"] for m in scored],
            "text": "each reported mode is matched to the nearest scored reference mode; "
            "ω within max(3σ, 1e-4) relative, ζ within 3σ relative (σ: spread of single-hit fits "
            "combined with the FRF-fit vs free-decay-fit difference). "
            "Modes not scored (doublets whose single-hit fits swap) are listed for information",
        },
        "notes": "Replay caveats: (1) acceleration output (biproper), outside the project's "
        "strictly proper model today; (2) rigid-body mass line below the modes (no ω = 0 mode in "
        "the model); (3) many modes above the scored ones (2.64, 3.67, 4.1, 4.4, 5.0, 6.0 kHz …); "
        "(4) u sampled, not held: Ts/2 lag under the replay's reading (convert.py).",
    }
    (HERE / "reference.json").write_text(json.dumps(ref, indent=2, ensure_ascii=False) + "\n")
    for m in modes:
        print(f"{m['f_hz']:9.3f} Hz  ζ {m['zeta']:.5f}  σω/ω {m['sigma_omega_rel_hits']:.1e}  "
              f"σζ/ζ {m['sigma_zeta_rel_hits']:.2f}  decay {m['free_decay_f_hz']:.3f} {m['free_decay_zeta']:.5f}  "
              f"σ {m['sigma_omega_rel']:.1e} {m['sigma_zeta_rel']:.2f}  fit {m['band_fit_percent']:.1f}%  "
              f"coh {m['coherence_at_peak']:.4f}  F {m['force_level_db']:.1f} dB  scored {m['scored']}")


if __name__ == "__main__":
    main()
