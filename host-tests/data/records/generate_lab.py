#!/usr/bin/env python3
"""Lab-like replay records, simulated independently of this project
(numpy + scipy only; nothing here imports or calls the Rust code).

    python3 host-tests/data/records/generate_lab.py [NAME ...]

writes, for every record NAME below, host-tests/data/records/NAME/record.csv.gz
and host-tests/data/records/NAME/reference.json (schema: README.md beside
this file). Deterministic: fixed seeds, gzip mtime 0 (same numpy/scipy
versions give the same bytes; written with numpy 2.4.6, scipy 1.17.1).

Model (the project's convention, src/model.rs, docs/ARCHITECTURE.md):

    G(s) = Σ_i c_i·b̄_i / q_i(s),   q_i(s) = s² + 2ζ_iω_i·s + ω_i²,
    c_i = 2·(−1)^(i+1) for 0-based i, i.e. c = [−2, 2, −2],

for a strain or displacement output (relative degree 2). A velocity
output is s·G(s) (relative degree 1) and an acceleration output s²·G(s)
(relative degree 0: biproper); b̄_i keeps its meaning (the modal input gain),
so the same (ω, ζ, b̄) describe the three sensor kinds.

Discretisation: exact zero-order hold on u. Each mode is its own
continuous state-space section (scipy.signal.tf2ss) discretised by
scipy.signal.cont2discrete(method="zoh"); the output is the sum of the
sections (exact by linearity, and better conditioned than one 2n-order
polynomial at 20 kHz). Row k of a record is

    t_k = k·Ts,  u_k held over [t_k, t_k + Ts),
    y_k = y(t_k) read BEFORE u_k is applied:  y_k = C·x_k + D·u_{k−1}

(x_{k+1} = Ad·x_k + Bd·u_k, x_0 = 0: every record starts at rest; D ≠ 0 only
for an acceleration output, whose output jumps with the input, and the
value before the jump is the one read), which is docs/REPLAY.md's alignment.

Noise: white Gaussian, σ = RMS(y_clean)·10^(−SNR/20), RMS over the whole
record of the noise-free output (for the offset/drift record: of the
dynamic part, before offset and drift are added). numpy.random.default_rng
with a per-record seed.

Coloured noise (the lab_colour* records): y also carries a bridge
amplifier's noise, white Gaussian through a first-order low-pass at a
corner f_c with unit power gain (a stationary AR(1) process, pole
a = exp(−2π·f_c·Ts), started from its stationary distribution), of σ =
RMS(y_clean)·10^(−SNR/20); optionally a white floor of its own level
(an ADC's noise), and the 16-bit quantisation of an ADC whose full scale
is 1.25·max|y| (y_q = LSB·round(y/LSB)). Their Cramér–Rao bound is that
of Gaussian noise with the known covariance Σ (low-pass + white floor +
LSB²/12 for the quantisation): F = JᵀΣ⁻¹J, computed exactly by whitening
J with the noise's innovations (a scalar Kalman filter of the AR(1)
state observed in the white floor, started from the stationary variance;
`noise_whiten`): for Gaussian noise of known spectrum the Fisher
information is that of the prewhitened output error. Stored as `crb`,
with `crb_white_same_power` (white noise of the same total variance) for
comparison.

Cramér–Rao bound (white-noise records): θ = (ω_i, ζ_i, b̄_i) per mode,
J = ∂y/∂θ of the noise-free output by central differences (relative step
1e-6, the same simulator), F = JᵀJ/σ², σ_θ = sqrt(diag F⁻¹). The initial
state is known (zero) and u is known exactly, so this is the bound for an
output-error estimator of this exact model structure. It is stored as a
relative σ (σ_ω/ω, σ_ζ/ζ).
"""

import gzip
import json
from pathlib import Path

import warnings

import numpy as np
from scipy.signal import chirp, cont2discrete, lfilter, max_len_seq, ss2tf, tf2ss

warnings.filterwarnings("ignore", message="Badly conditioned filter coefficients")
OUT = Path(__file__).resolve().parent
C_DEFAULT = [-2.0, 2.0, -2.0]


# --------------------------------------------------------------------------
# plant simulation


def mode_sections(w, z, b, kind, ts):
    """Discrete (num, den) in powers of z^{-1} per mode, for lfilter, with
    the read-before-apply alignment: y_k = C·x_k + D·u_{k−1}, i.e.
    H(z) = C (zI − Ad)^{-1} Bd + D·z^{-1}."""
    secs = []
    for i in range(len(w)):
        g = C_DEFAULT[i] * b[i]
        den = [1.0, 2 * z[i] * w[i], w[i] ** 2]
        num = {"strain": [0.0, 0.0, g], "displacement": [0.0, 0.0, g],
               "velocity": [0.0, g, 0.0], "acceleration": [g, 0.0, 0.0]}[kind]
        a, bm, c, d = tf2ss(num, den)
        ad, bd, cd, dd, _ = cont2discrete((a, bm, c, d), ts, method="zoh")
        nz, dz = ss2tf(ad, bd, cd, dd)
        nz, dz = nz[0], dz
        d0 = dd[0, 0]
        strict = nz - d0 * dz  # C adj(zI − Ad) Bd: its z² coefficient is 0
        numer = np.concatenate([strict, [0.0]]) + d0 * np.concatenate([[0.0], dz])
        secs.append((numer, dz))
    return secs


def simulate(w, z, b, kind, ts, u):
    y = np.zeros(len(u))
    for num, den in mode_sections(w, z, b, kind, ts):
        y += lfilter(num, den, u)
    return y


def noise_whiten(cols, a, var_lp, var_white):
    """Σ^(−1/2)·cols for the noise v = s + e, s a stationary AR(1) process
    (pole a, variance var_lp), e white (variance var_white): the
    innovations of a scalar Kalman filter of s observed in e, started from
    the stationary variance, each divided by its standard deviation. Exact:
    Σ = L·Lᵀ with L the innovations' lower-triangular map (Cholesky), for
    every column at once."""
    n = cols.shape[0]
    out = np.empty_like(cols)
    s_hat = np.zeros(cols.shape[1])
    p = var_lp
    q = (1.0 - a * a) * var_lp
    for k in range(n):
        sv = p + var_white
        innov = cols[k] - s_hat
        out[k] = innov / np.sqrt(sv)
        gain = p / sv
        s_hat = a * (s_hat + gain * innov)
        p = a * a * (1.0 - gain) * p + q
    return out


def fisher_sigma(w, z, b, kind, ts, u, sigma, nuisance_hz=(), noise=None):
    """Relative CRB σ of ω_i and ζ_i (and b̄_i) for white noise σ; with
    lines in y at `nuisance_hz`, their amplitudes and phases are unknown
    too (two columns cos, sin per line in the Jacobian), so the bound pays
    for not knowing them."""
    theta = np.array(list(w) + list(z) + list(b), dtype=float)
    n = len(w)

    def sim(th):
        return simulate(th[:n], th[n : 2 * n], th[2 * n :], kind, ts, u)

    cols = []
    for j in range(len(theta)):
        h = 1e-6 * abs(theta[j])
        tp, tm = theta.copy(), theta.copy()
        tp[j] += h
        tm[j] -= h
        cols.append((sim(tp) - sim(tm)) / (2 * h))
    t = np.arange(len(u)) * ts
    for f in nuisance_hz:
        cols.append(np.cos(2 * np.pi * f * t))
        cols.append(np.sin(2 * np.pi * f * t))
    jac = np.stack(cols, axis=1)
    if noise is None:
        fim = jac.T @ jac / sigma**2
    else:
        jw = noise_whiten(jac, noise["a"], noise["var_lowpass"], noise["var_white"])
        fim = jw.T @ jw
    cov = np.linalg.inv(fim)
    sd = np.sqrt(np.diag(cov))
    rel = sd[: len(theta)] / np.abs(theta)
    return {
        "omega_rel": rel[:n].tolist(),
        "zeta_rel": rel[n : 2 * n].tolist(),
        "bbar_rel": rel[2 * n :].tolist(),
    }


# --------------------------------------------------------------------------
# excitations


def square(t, f0, amp=1.0):
    return amp * np.where(np.sin(2 * np.pi * f0 * t) >= 0, 1.0, -1.0)


def multisine(t, freqs, rng, amp=1.0):
    """Sum of sines with random phases, scaled to peak `amp`."""
    ph = rng.uniform(0, 2 * np.pi, len(freqs))
    u = sum(np.sin(2 * np.pi * f * t + p) for f, p in zip(freqs, ph))
    return amp * u / np.max(np.abs(u))


def prbs(n, hold, nbits, seed_state, amp=1.0):
    """Maximum-length sequence (scipy.signal.max_len_seq), ±amp, each bit
    held `hold` samples."""
    state = np.array([(seed_state >> i) & 1 for i in range(nbits)], dtype=np.int8)
    seq, _ = max_len_seq(nbits, state=state, length=n // hold + 1)
    return amp * np.repeat(2.0 * seq - 1.0, hold)[:n]


def log_grid(f_lo, f_hi, count, df):
    """`count` log-spaced frequencies rounded to the record's bin df (so the
    multisine is periodic in the record), distinct."""
    f = np.unique(np.round(np.geomspace(f_lo, f_hi, count) / df) * df)
    return f[f > 0]


# --------------------------------------------------------------------------
# records


def records():
    """(name, spec) for every lab record. Plant values are chosen by hand to
    look like lab beams (first mode 5–20 Hz, light damping)."""
    two = dict(w=[2 * np.pi * 8.0, 2 * np.pi * 45.0], z=[0.02, 0.015], b=[12.0, 30.0])
    return [
        (
            "lab_offset_drift_square",
            dict(
                two,
                kind="strain",
                fs=10_000,
                dur=10.0,
                exc="square",
                snr_db=60.0,
                seed=1501,
                offset_rms=0.5,
                drift_rms=0.5,
                notes="Strain gauge with a constant offset of 0.5·RMS(y) from the first "
                "sample and a thermal warm-up drift 0.5·RMS(y)·(1 − exp(−t/3 s)) "
                "on top of 60 dB white noise; square wave 2 Hz (odd harmonics cover both modes).",
            ),
        ),
        (
            "lab_offset_step_prbs",
            dict(two, kind="strain", fs=10_000, dur=10.0, exc="prbs", snr_db=60.0, seed=1512,
                 offset_rms=0.0, step_rms=0.5, step_at_s=4.0,
                 notes="Strain gauge whose zero jumps by +0.5·RMS(y) at t = 4 s (an offset step, "
                 "e.g. a bridge re-balance), on 60 dB white noise; PRBS 2 ms per bit."),
        ),
        (
            "lab_velocity_prbs",
            dict(two, kind="velocity", fs=10_000, dur=10.0, exc="prbs", snr_db=60.0, seed=1513,
                 notes="Velocity output (a laser vibrometer: y = s·G·u, relative degree 1), PRBS "
                 "2 ms per bit, 60 dB."),
        ),
        (
            "lab_noise60_multisine",
            dict(two, kind="strain", fs=10_000, dur=10.0, exc="multisine", snr_db=60.0, seed=1502,
                 notes="Multisine, 40 log-spaced lines 2–150 Hz (periodic in the record), random phases."),
        ),
        (
            "lab_noise40_prbs",
            dict(two, kind="strain", fs=10_000, dur=10.0, exc="prbs", snr_db=40.0, seed=1503,
                 notes="PRBS (maximum-length sequence, 12 bits) held 2 ms per bit (20 samples)."),
        ),
        (
            "lab_mode3_above_chirp",
            dict(
                w=[2 * np.pi * 8.0, 2 * np.pi * 45.0, 2 * np.pi * 260.0],
                z=[0.02, 0.015, 0.01],
                b=[12.0, 30.0, 1500.0],
                kind="strain",
                fs=10_000,
                dur=10.0,
                exc="chirp",
                snr_db=60.0,
                seed=1504,
                modes_in_band=2,
                notes="Beam with a strong third mode at 260 Hz above the two modelled modes (its static "
                "response c3·b̄3/ω3² is 1.5× mode 2's); logarithmic chirp "
                "3→120 Hz over the record (the third mode is driven only off resonance). "
                "Model mismatch for a 2-mode model.",
            ),
        ),
        (
            "lab_1mode_1khz",
            dict(w=[2 * np.pi * 15.0], z=[0.03], b=[40.0], kind="strain", fs=1_000, dur=30.0,
                 exc="prbs", snr_db=40.0, seed=1505, prbs_hold=4,
                 notes="One mode, 1 kHz, PRBS held 4 ms per bit, 40 dB."),
        ),
        (
            "lab_2mode_5khz",
            dict(two, kind="strain", fs=5_000, dur=20.0, exc="multisine", snr_db=40.0, seed=1506,
                 notes="Two modes, 5 kHz, multisine 2–150 Hz, 40 dB."),
        ),
        (
            "lab_3mode_20khz",
            dict(
                w=[2 * np.pi * 12.0, 2 * np.pi * 70.0, 2 * np.pi * 190.0],
                z=[0.02, 0.012, 0.01],
                b=[15.0, 60.0, 200.0],
                kind="strain",
                fs=20_000,
                dur=5.0,
                exc="multisine",
                snr_db=60.0,
                seed=1507,
                ms_band=(3.0, 400.0),
                notes="Three modes, 20 kHz, multisine 3–400 Hz, 60 dB.",
            ),
        ),
        (
            "lab_impact_accel",
            dict(
                w=[2 * np.pi * 30.0, 2 * np.pi * 160.0],
                z=[0.01, 0.008],
                b=[20.0, 60.0],
                kind="acceleration",
                fs=10_000,
                dur=5.0,
                exc="impact",
                snr_db=60.0,
                seed=1508,
                notes="One half-sine force pulse of 1 ms (peak 1) at t = 5 ms, then free decay "
                "(the modes decay to the noise floor in ~2 s); accelerometer output (y = s²·G·u).",
            ),
        ),
        (
            "lab_accel_multisine",
            dict(two, kind="acceleration", fs=10_000, dur=10.0, exc="multisine", snr_db=60.0, seed=1509,
                 notes="Accelerometer output (y = s²·G·u) under a multisine 2–150 Hz, 60 dB."),
        ),
        (
            "lab_hum50_chirp",
            dict(two, kind="strain", fs=10_000, dur=20.0, exc="chirp", chirp_band=(1.0, 80.0),
                 snr_db=40.0, seed=1521, hum=[(50.0, 0.03), (150.0, 0.01)],
                 notes="Mains hum on a strain gauge: lines at 50 Hz (3% of RMS(y)) and 150 Hz (1%), "
                 "random phases, that u does not drive, on 40 dB white noise; mode 2 (45 Hz) is 5 Hz "
                 "from the 50 Hz line; logarithmic chirp 1→80 Hz over the record."),
        ),
        (
            "lab_hum60_prbs",
            dict(w=[2 * np.pi * 12.0, 2 * np.pi * 55.6], z=[0.02, 0.012], b=[15.0, 40.0],
                 kind="strain", fs=10_000, dur=10.0, exc="prbs", snr_db=40.0, seed=1522,
                 hum=[(60.6, 0.03), (181.8, 0.01)],
                 notes="60 Hz mains running 1% fast: lines at 60.6 Hz (3% of RMS(y)) and 181.8 Hz (1%) "
                 "on 40 dB white noise; mode 2 (55.6 Hz) is 5 Hz below the line; PRBS 2 ms per bit."),
        ),
        (
            "lab_hum50_harmonics_prbs",
            dict(two, kind="strain", fs=10_000, dur=10.0, exc="prbs", snr_db=40.0, seed=1523,
                 hum=[(49.6, 0.05), (148.8, 0.01), (248.0, 0.01), (347.2, 0.005)],
                 notes="50 Hz mains running 0.8% slow and its odd harmonics to the 7th: lines at "
                 "49.6 Hz (5% of RMS(y)), 148.8 (1%), 248.0 (1%), 347.2 Hz (0.5%) on 40 dB white "
                 "noise; mode 2 (45 Hz) is 4.6 Hz below the first; PRBS 2 ms per bit."),
        ),
    ] + [
        (
            f"lab_colour45_multisine_s{k}",
            dict(two, kind="strain", fs=5_000, dur=10.0, exc="multisine", snr_db=45.0,
                 seed=1530 + k, lowpass_hz=20.0, adc_bits=16,
                 notes="Coloured noise (a bridge amplifier's): white Gaussian noise through a "
                 "first-order low-pass at 20 Hz (between the modes), 45 dB, then a 16-bit ADC "
                 "(full scale 1.25·max|y|); 2 modes at 5 kHz, random-phase multisine 2–150 Hz. "
                 f"Seed {k} of 5 of the same experiment (the RMS over the five is scored)."),
        )
        for k in range(1, 6)
    ] + [
        (
            "lab_colour40_prbs",
            dict(two, kind="strain", fs=10_000, dur=10.0, exc="prbs", snr_db=40.0, seed=1541,
                 lowpass_hz=50.0, white_floor_db=58.0, adc_bits=16,
                 notes="Coloured noise: a first-order low-pass at 50 Hz (40 dB) plus a white floor "
                 "of its own (an ADC's noise, 58 dB) and a 16-bit ADC; PRBS 2 ms per bit."),
        ),
        (
            "lab_colour60_multisine",
            dict(w=[2 * np.pi * 12.0, 2 * np.pi * 55.6], z=[0.02, 0.012], b=[15.0, 40.0],
                 kind="strain", fs=10_000, dur=10.0, exc="multisine", snr_db=60.0, seed=1542,
                 lowpass_hz=8.0, adc_bits=16,
                 notes="Coloured noise: a first-order low-pass at 8 Hz (below both modes), 60 dB, "
                 "and a 16-bit ADC (its quantisation within 10 dB of the low-pass noise at the "
                 "Nyquist frequency); random-phase multisine 2–150 Hz."),
        ),
    ] + [
        (
            "lab_above_modes_only",
            dict(two, kind="strain", fs=10_000, dur=10.0, exc="multisine_high", snr_db=60.0, seed=1510,
                 identifiable=False,
                 notes="Multisine with lines only in 400–800 Hz (periodic in the record: zero "
                 "input power at 8 and 45 Hz): neither mode is excited; the expected verdict is "
                 "'not identifiable' (the issue's coverage rule). NB: under the EXACT 2-mode model "
                 "the response's tail above the modes still determines ω and ζ (see crb_exact_model): "
                 "the verdict is about what the input covers, not a statistical impossibility; on a "
                 "real beam that tail is dominated by modes the model does not have "
                 "(lab_above_modes_beam)."),
        ),
        (
            "lab_above_modes_beam",
            dict(
                w=[2 * np.pi * 8.0, 2 * np.pi * 45.0, 2 * np.pi * 600.0],
                z=[0.02, 0.015, 0.01],
                b=[12.0, 30.0, 3000.0],
                kind="strain",
                fs=10_000,
                dur=10.0,
                exc="multisine_high",
                snr_db=60.0,
                seed=1511,
                identifiable=False,
                modes_in_band=2,
                notes="As lab_above_modes_only, on a beam with a third mode at 600 Hz inside the "
                "excitation's 400–800 Hz: modes 1 and 2 (8, 45 Hz) are not excited (expected: not "
                "identifiable); mode 3 is excited (information only: a model may report it)."),
        ),
    ]


def make_u(spec, t, rng):
    n = len(t)
    df = 1.0 / spec["dur"]
    exc = spec["exc"]
    if exc == "square":
        return square(t, 2.0)
    if exc == "multisine":
        lo, hi = spec.get("ms_band", (2.0, 150.0))
        return multisine(t, log_grid(lo, hi, 40, df), rng)
    if exc == "multisine_high":
        return multisine(t, log_grid(400.0, 800.0, 20, df), rng)
    if exc == "prbs":
        hold = spec.get("prbs_hold", int(round(0.002 * spec["fs"])))
        return prbs(n, hold, 12, int(rng.integers(1, 4095)))
    if exc == "chirp":
        f0, f1 = spec.get("chirp_band", (3.0, 120.0))
        return chirp(t, f0=f0, t1=t[-1], f1=f1, method="logarithmic", phi=-90.0)
    if exc == "impact":
        u = np.zeros(n)
        k0 = int(round(0.005 * spec["fs"]))
        m = int(round(0.001 * spec["fs"]))
        u[k0 : k0 + m] = np.sin(np.pi * (np.arange(m) + 0.5) / m)
        return u
    raise ValueError(exc)


def fmt_rows(t, u, y, fs):
    tdec = {1_000: 3, 5_000: 4, 10_000: 4, 20_000: 5}[fs]
    lines = ["t,u,y"]
    for k in range(len(t)):
        lines.append(f"{t[k]:.{tdec}f},{u[k]:.6g},{y[k]:.6g}")
    return ("\n".join(lines) + "\n").encode()


def main():
    import sys
    only = set(sys.argv[1:])  # record names to write (default: all)
    for name, spec in records():
        if only and name not in only:
            continue
        rng = np.random.default_rng(spec["seed"])
        fs = spec["fs"]
        ts = 1.0 / fs
        n = int(round(spec["dur"] * fs))
        t = np.arange(n) * ts
        u = make_u(spec, t, rng)
        w, z, b, kind = spec["w"], spec["z"], spec["b"], spec["kind"]
        y_clean = simulate(w, z, b, kind, ts, u)
        rms = float(np.sqrt(np.mean(y_clean**2)))
        sigma = rms * 10 ** (-spec["snr_db"] / 20)
        coloured = None
        if "lowpass_hz" in spec:
            a = float(np.exp(-2 * np.pi * spec["lowpass_hz"] * ts))
            g = rng.standard_normal(n)
            first = sigma * g[0]
            rest = lfilter([np.sqrt(1 - a * a) * sigma], [1.0, -a], g[1:], zi=[a * first])[0]
            noise = np.concatenate([[first], rest])
            sd_white = rms * 10 ** (-spec["white_floor_db"] / 20) if "white_floor_db" in spec else 0.0
            if sd_white > 0:
                noise = noise + sd_white * rng.standard_normal(n)
            coloured = {"a": a, "var_lowpass": sigma**2, "var_white": sd_white**2,
                        "sd_white": sd_white}
        else:
            noise = sigma * rng.standard_normal(n)
        y = y_clean + noise
        if "adc_bits" in spec:
            full_scale = 1.25 * float(np.max(np.abs(y)))
            lsb = 2 * full_scale / 2 ** spec["adc_bits"]
            y = lsb * np.round(y / lsb)
            coloured["var_white"] += lsb**2 / 12
            coloured["lsb"] = lsb
            coloured["full_scale"] = full_scale
        level = np.zeros(n)
        if "offset_rms" in spec:
            level += spec["offset_rms"] * rms
        if "drift_rms" in spec:
            level += spec["drift_rms"] * rms * (1 - np.exp(-t / 3.0))
        if "step_rms" in spec:
            level += spec["step_rms"] * rms * (t >= spec["step_at_s"])
        y = y + level
        hum = []
        for f_line, share in spec.get("hum", []):
            phase = float(rng.uniform(0.0, 2 * np.pi))
            y = y + share * rms * np.sqrt(2.0) * np.sin(2 * np.pi * f_line * t + phase)
            hum.append({"freq_hz": f_line, "rms": share * rms, "rms_share_of_y": share,
                        "phase_rad": phase})

        # The record as written (6 significant digits) is what is replayed:
        # the bound is computed for that u.
        data = fmt_rows(t, u, y, fs)
        u_written = np.array([float(r.split(b",")[1]) for r in data.splitlines()[1:]])

        modes_in_band = spec.get("modes_in_band", len(w))
        identifiable = spec.get("identifiable", True)
        ref = {
            "record": name,
            "kind": "simulated",
            "generator": "host-tests/data/records/generate_lab.py (numpy/scipy only)",
            "sensor_output": kind,
            "output_relative_degree": {"strain": 2, "displacement": 2, "velocity": 1, "acceleration": 0}[kind],
            "excitation": spec["exc"],
            "sample_rate_hz": fs,
            "ts_s": ts,
            "samples": n,
            "duration_s": spec["dur"],
            "modes_in_band": modes_in_band,
            "modes_total": len(w),
            "output_weights": C_DEFAULT[: len(w)],
            "units": "u: arbitrary (model input); y: arbitrary (model output of G, s·G or s²·G)",
            "noise": ({"kind": "white_gaussian", "snr_db": spec["snr_db"], "sigma": sigma,
                       "rms_clean_y": rms, "seed": spec["seed"]} if coloured is None else
                      {"kind": "lowpass_first_order" + ("_plus_white" if "white_floor_db" in spec else ""),
                       "snr_db": spec["snr_db"], "sigma": sigma, "corner_hz": spec["lowpass_hz"],
                       "pole": coloured["a"], "white_floor_db": spec.get("white_floor_db"),
                       "sigma_white_floor": coloured["sd_white"], "adc_bits": spec["adc_bits"],
                       "adc_full_scale": coloured["full_scale"], "adc_lsb": coloured["lsb"],
                       "rms_clean_y": rms, "seed": spec["seed"],
                       "form": "n_0 = σ·g_0, n_k = a·n_(k−1) + sqrt(1 − a²)·σ·g_k (+ σ_white·g'_k); "
                               "y = LSB·round((y_clean + n)/LSB)"}),
            "truth": {
                "omega_rad_s": [float(x) for x in w],
                "zeta": [float(x) for x in z],
                "bbar": [float(x) for x in b],
            },
            "notes": spec["notes"],
        }
        if hum:
            ref["hum"] = {"lines": hum, "form": "rms·√2·sin(2π·f·t + phase), t from the first row"}
        if "drift_rms" in spec:
            ref["level"] = {"offset": spec["offset_rms"] * rms,
                            "drift": f"{spec['drift_rms']}*rms*(1-exp(-t/3 s))",
                            "drift_amplitude": spec["drift_rms"] * rms}
        if "step_rms" in spec:
            ref["level"] = {"step": spec["step_rms"] * rms, "step_at_s": spec["step_at_s"]}
        if not identifiable:
            k = modes_in_band
            ref["crb_exact_model"] = dict(
                fisher_sigma(w, z, b, kind, ts, u_written, sigma),
                note="the bound for an estimator that knows the exact model structure (all "
                f"{len(w)} modes): information only; the acceptance rule is the coverage verdict")
            ref["unexcited_modes"] = {"omega_rad_s": [float(x) for x in w[:k]],
                                      "zeta": [float(x) for x in z[:k]]}
            ref["acceptance"] = {
                "rule": "unidentifiable",
                "expected_trusted": False,
                "text": "no mode in the input's band: the report must say trusted: false "
                "(not identifiable), with no estimate presented as trusted",
            }
            if k < len(w):
                ref["acceptance"]["text"] = (
                    f"modes 1–{k} (unexcited_modes) are outside the input's band: a report must not "
                    "present an estimate of them as trusted (trusted: false, not identifiable); "
                    + (f"modes {k + 1}–{len(w)}" if len(w) - k > 1 else f"mode {k + 1}") + " (excited) may be reported")
                ref["acceptance"]["excited_modes"] = {"omega_rad_s": [float(x) for x in w[k:]],
                                                      "zeta": [float(x) for x in z[k:]]}
        elif modes_in_band < len(w):
            ref["acceptance"] = {
                "rule": "model_mismatch",
                "modes_scored": modes_in_band,
                "omega_rel_tol": [0.01] * modes_in_band,
                "zeta_rel_tol": [0.05] * modes_in_band,
                "text": f"the {modes_in_band} in-band modes: |ω̂−ω|/ω ≤ 1%, |ζ̂−ζ|/ζ ≤ 5%",
            }
        else:
            wm, zm, bm = w, z, b
            lines_hz = [h["freq_hz"] for h in hum]
            crb = fisher_sigma(wm, zm, bm, kind, ts, u_written, sigma, lines_hz, coloured)
            method = ("F = JᵀJ/σ², J = ∂y/∂(ω,ζ,b̄) by central differences "
                      "(rel. step 1e-6) of the noise-free output; σ_rel = sqrt(diag F⁻¹)/|θ|")
            if coloured is not None:
                method = ("F = JᵀΣ⁻¹J for the Gaussian noise of known covariance Σ (the low-pass, "
                          "the white floor if any, and the ADC's LSB²/12), J = ∂y/∂(ω,ζ,b̄) by central "
                          "differences (rel. step 1e-6) of the noise-free output, whitened exactly by "
                          "the noise's innovations (noise_whiten); σ_rel = sqrt(diag F⁻¹)/|θ|")
                total = np.sqrt(coloured["var_lowpass"] + coloured["var_white"])
                ref["crb_white_same_power"] = dict(
                    fisher_sigma(wm, zm, bm, kind, ts, u_written, total),
                    note="white noise of the same total variance (information only)")
            if hum:
                method += ("; J also holds ∂y/∂a_ℓ, ∂y/∂b_ℓ = cos, sin(2π f_ℓ t) of each line (its "
                           "amplitude and phase unknown, its frequency known)")
            ref["crb"] = dict(crb, method=method)
            floor = 1e-3 if hum else 1e-4
            ref["acceptance"] = {
                "rule": "white_noise_crb" if coloured is None else "coloured_noise_crb",
                "modes_scored": len(w),
                "omega_rel_tol": [max(3 * s, floor) for s in crb["omega_rel"]],
                "zeta_rel_tol": [max(3 * s, floor) for s in crb["zeta_rel"]],
                "text": "each ω̂_i, ζ̂_i within max(3σ_CRB, " + ("1e-3" if hum else "1e-4") + ") relative of the truth"
                + ("" if coloured is None else " (σ_CRB for the noise's own spectrum)"),
            }
            if "level" in ref:
                ref["acceptance"]["text"] += (
                    " (σ_CRB from the white noise alone: the offset, drift or step is assumed "
                    "removed by a correction that leaves u → y unchanged)"
                )
        folder = OUT / name
        folder.mkdir(exist_ok=True)
        with gzip.GzipFile(folder / "record.csv.gz", "wb", mtime=0) as f:
            f.write(data)
        (folder / "reference.json").write_text(json.dumps(ref, indent=2, ensure_ascii=False) + "\n")
        size = (folder / "record.csv.gz").stat().st_size
        print(f"{name}: {n} rows, {size / 1e6:.2f} MB, rms {rms:.4g}, sigma {sigma:.3g}")


if __name__ == "__main__":
    main()
