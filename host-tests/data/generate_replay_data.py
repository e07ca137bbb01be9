#!/usr/bin/env python3
"""Recorded-looking test data for `beamctl replay`, simulated independently
of this project (numpy + scipy, not the Rust rig).

Each file is a two-mode beam model y = G(s)·u with

    G(s) = c1·b1·q2(s) + c2·b2·q1(s)) / (q1(s)·q2(s)),  q_i = s² + 2ζ_iω_i·s + ω_i²,
    c = (−2, 2)  (the output weights of Wang, Costa-Castelló, Na et al., eq. 24),

realised in controllable canonical form (scipy.signal.tf2ss) and discretised
by an exact zero-order hold (scipy.signal.cont2discrete): u_k is held over
[t_k, t_{k+1}), y_k = C·x(t_k) is sampled before u_k is applied. The plants
are drawn from a seeded generator the Rust tests never see; the truth goes to
replay_truth.json, which only the test that scores the replay reads.

    python3 host-tests/data/generate_replay_data.py

rewrites host-tests/data/replay_*.csv.gz and replay_truth.json
(deterministic: same numpy/scipy versions give the same bytes).
"""

import gzip
import json
from pathlib import Path

import numpy as np
from scipy.signal import cont2discrete, tf2ss

TS = 1e-4          # 10 kHz
DURATION_S = 3.0   # per file
OUT = Path(__file__).resolve().parent


def plant(rng):
    w1 = float(np.exp(rng.uniform(np.log(15.0), np.log(150.0))))
    w2 = w1 * float(rng.uniform(2.5, 8.0))
    z = [float(rng.uniform(0.01, 0.1)), float(rng.uniform(0.02, 0.15))]
    b = [float(rng.uniform(3.0, 20.0)) * rng.choice([-1.0, 1.0]) for _ in range(2)]
    return [w1, w2], z, b


def tf(w, z, b):
    q = [np.array([1.0, 2 * z[i] * w[i], w[i] ** 2]) for i in range(2)]
    c = [-2.0, 2.0]
    num = c[0] * b[0] * q[1] + c[1] * b[1] * q[0]
    den = np.polymul(q[0], q[1])
    return num, den


def excitation(kind, n, rng):
    t = np.arange(n) * TS
    if kind == "square":
        return 0.5 * np.where(np.sin(2 * np.pi * 5.0 * t) >= 0, 1.0, -1.0)
    if kind == "steps":
        # Random levels held 25 ms: a random telegraph-like drive.
        hold = int(round(0.025 / TS))
        levels = rng.uniform(-1.0, 1.0, n // hold + 1)
        return np.repeat(levels, hold)[:n]
    if kind == "square_offset":
        return 0.2 + 0.3 * np.where(np.sin(2 * np.pi * 11.0 * t) >= 0, 1.0, -1.0)
    raise ValueError(kind)


def simulate(num, den, u, pre):
    """y_k = C x_k, x_{k+1} = Ad x_k + Bd u_k from rest, `pre` samples of
    the same excitation before the record starts (the beam already moves)."""
    a, bm, c, d = tf2ss(num, den)
    ad, bd, cd, _, _ = cont2discrete((a, bm, c, d), TS, method="zoh")
    x = np.zeros(ad.shape[0])
    out = np.empty(len(u) - pre)
    for k in range(len(u)):
        if k >= pre:
            out[k - pre] = (cd @ x)[0]
        x = ad @ x + bd[:, 0] * u[k]
    return out


def main():
    rng = np.random.default_rng(20260801)
    n = int(round(DURATION_S / TS))
    truth = {}
    for name, kind, pre_s in [
        ("replay_a", "square", 0.0),
        ("replay_b", "steps", 0.0),
        ("replay_c", "square_offset", 1.3),
    ]:
        w, z, b = plant(rng)
        num, den = tf(w, z, b)
        pre = int(round(pre_s / TS))
        u = excitation(kind, n + pre, rng)
        y = simulate(num, den, u, pre)
        u = u[pre:]
        lines = ["t,u,y"]
        for k in range(n):
            lines.append(f"{k * TS:.4f},{u[k]:.12g},{y[k]:.12g}")
        data = ("\n".join(lines) + "\n").encode()
        with gzip.GzipFile(OUT / f"{name}.csv.gz", "wb", mtime=0) as f:
            f.write(data)
        truth[name] = {
            "omega_rad_s": w,
            "zeta": z,
            "bbar": b,
            "output_weights": [-2.0, 2.0],
            "excitation": kind,
            "starts_in_motion_after_s": pre_s,
        }
    (OUT / "replay_truth.json").write_text(json.dumps(truth, indent=2) + "\n")


if __name__ == "__main__":
    main()
