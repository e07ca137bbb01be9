#!/usr/bin/env python3
"""Checks the lab records and their Cramér–Rao σ with an efficient offline
estimator (numpy/scipy only): an output-error least-squares fit of the
exact model (generate_lab.simulate, the records' own simulator) to each
white-noise record as written (6-digit CSV), started 0.2% off in ω and 5%
off in ζ (a record with mains lines: each line's amplitude and phase fitted
too, its frequency known, as its bound assumes). An efficient estimator lands within a few σ_CRB of the truth;
the residual RMS ÷ σ_noise should be ≈ 1.

    python3 host-tests/data/records/check_lab.py
"""

import gzip
import json
import sys
from pathlib import Path

import numpy as np
from scipy.optimize import least_squares

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
from generate_lab import simulate  # noqa: E402


def main():
    print("| record | (ω̂−ω)/ω ÷ σ_CRB per mode | (ζ̂−ζ)/ζ ÷ σ_CRB per mode | residual RMS ÷ σ |")
    print("|---|---|---|---|")
    for refp in sorted(HERE.glob("lab_*/reference.json")):
        ref = json.loads(refp.read_text())
        if ref["acceptance"]["rule"] != "white_noise_crb":
            continue
        d = np.loadtxt(gzip.open(refp.parent / "record.csv.gz"), delimiter=",", skiprows=1)
        _, u, y = d.T
        tr = ref["truth"]
        n = len(tr["omega_rad_s"])
        th0 = np.array(tr["omega_rad_s"] + tr["zeta"] + tr["bbar"])
        # the level records: fit the level too (a constant and the amplitude
        # of the warm-up or step, whose shape is known to the check)
        lev = "level" in ref
        t = np.arange(len(y)) * ref["ts_s"]

        if lev and "step" in ref["level"]:
            shape = (t >= ref["level"]["step_at_s"]).astype(float)
        else:
            shape = 1 - np.exp(-t / 3.0)

        lines = [h["freq_hz"] for h in ref.get("hum", {}).get("lines", [])]
        waves = [w for f in lines for w in (np.cos(2 * np.pi * f * t), np.sin(2 * np.pi * f * t))]
        extra = 2 if lev else 0

        def res(q):
            th = q[: 3 * n] * th0
            e = simulate(th[:n], th[n : 2 * n], th[2 * n :], ref["sensor_output"], ref["ts_s"], u) - y
            if lev:
                e = e + q[3 * n] + q[3 * n + 1] * shape
            for j, w in enumerate(waves):
                e = e + q[3 * n + extra + j] * w
            return e

        q0 = np.ones(3 * n)
        q0[:n] *= 1.002
        q0[n : 2 * n] *= 1.05
        if lev:
            q0 = np.concatenate([q0, [0.0, 0.0]])
        q0 = np.concatenate([q0, np.zeros(len(waves))])
        s = least_squares(res, q0, method="lm", x_scale="jac")
        err = s.x[: 3 * n] - 1
        c = ref["crb"]
        ew = err[:n] / np.array(c["omega_rel"])
        ez = err[n : 2 * n] / np.array(c["zeta_rel"])
        rr = np.std(s.fun) / ref["noise"]["sigma"]
        print(f"| {ref['record']} | {' '.join(f'{x:+.2f}' for x in ew)} | "
              f"{' '.join(f'{x:+.2f}' for x in ez)} | {rr:.3f} |")


if __name__ == "__main__":
    main()
