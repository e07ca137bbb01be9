#!/usr/bin/env python3
"""Error ÷ Cramér–Rao σ on the white-noise, mains and coloured-noise
records, per estimator, precision and with or without the replay's
disturbance passes (BENCHMARKS.md, "Mains lines and coloured noise").
Replays each record with `target/release/beamctl replay FILE --estimator E
--precision P [--lines off --prewhiten off]` and prints, per flag set, the
largest |ω̂_i − ω_i|/ω_i ÷ σ_CRB(ω_i) over the modes and the same for ζ
(σ_CRB from reference.json: on the mains records the bound treats the
lines' amplitudes and phases as unknown; on the coloured-noise records it
is the bound for that noise spectrum). The five seeds of
lab_colour45_multisine are one row: per parameter the RMS over the seeds
of the error ÷ σ_CRB, then the largest over the modes. Only this scoring
reads reference.json.

    cargo build --release -p beamctl
    python3 host-tests/data/records/lines_table.py
"""

import json
import math
import subprocess
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
ROOT = HERE.parents[2]
RECORDS = [
    ("lab_noise40_prbs", ["lab_noise40_prbs"]),
    ("lab_hum50_chirp", ["lab_hum50_chirp"]),
    ("lab_hum60_prbs", ["lab_hum60_prbs"]),
    ("lab_hum50_harmonics_prbs", ["lab_hum50_harmonics_prbs"]),
    ("lab_colour45_multisine (RMS of 5 seeds)",
     [f"lab_colour45_multisine_s{k}" for k in range(1, 6)]),
    ("lab_colour40_prbs", ["lab_colour40_prbs"]),
    ("lab_colour60_multisine", ["lab_colour60_multisine"]),
]


def errors(name, flags, beamctl):
    """Per mode (e_ω, e_ζ) ÷ σ_CRB, and whether the verdict trusts it;
    None without an estimate, "N modes" when another model order was
    chosen."""
    ref = json.loads((HERE / name / "reference.json").read_text())
    p = subprocess.run([beamctl, "replay", str(HERE / name / "record.csv.gz"), "--json", *flags],
                       capture_output=True, text=True)
    r = json.loads(p.stdout)
    r = r[0] if isinstance(r, list) else r
    est, tru, crb = r["estimate"], ref["truth"], ref["crb"]
    n = len(tru["omega_rad_s"])
    if est and est.get("omega") and len(est["omega"]) != n:
        return f"{len(est['omega'])} modes", r["verdict"]["trusted"]
    if not est or not est.get("omega") or None in est["omega"]:
        return None, r["verdict"]["trusted"]
    ew = [(est["omega"][i] / tru["omega_rad_s"][i] - 1) / crb["omega_rel"][i] for i in range(n)]
    ez = [(est["zeta"][i] / tru["zeta"][i] - 1) / crb["zeta_rel"][i] for i in range(n)]
    return ew + ez, r["verdict"]["trusted"]


def main():
    beamctl = sys.argv[1] if len(sys.argv) > 1 else str(ROOT / "target/release/beamctl")
    sets = [(e, p, passes) for e in ("adaptive", "robust", "auto") for p in ("f64", "f32")
            for passes in ("on", "off")]
    print("| record | " + " | ".join(f"{e} {p}{'' if s == 'on' else ', passes off'}"
                                     for e, p, s in sets) + " |")
    print("|---|" + "---|" * len(sets))
    for label, names in RECORDS:
        cells = []
        for e, p, passes in sets:
            flags = ["--estimator", e, "--precision", p]
            if passes == "off":
                flags += ["--lines", "off", "--prewhiten", "off"]
            runs = [errors(n, flags, beamctl) for n in names]
            if any(r[0] is None for r in runs):
                cells.append("no estimate")
                continue
            wrong = [r[0] for r in runs if isinstance(r[0], str)]
            if wrong:
                cells.append(f"{wrong[0]} chosen" + ("" if len(runs) == 1 else f" ({len(wrong)} of {len(runs)})"))
                continue
            m = len(runs[0][0]) // 2
            rms = [math.sqrt(sum(r[0][j] ** 2 for r in runs) / len(runs)) for j in range(2 * m)]
            trusted = sum(r[1] for r in runs)
            note = "" if trusted == len(runs) else (
                " (nt)" if len(runs) == 1 else f" ({len(runs) - trusted} nt)")
            cells.append(f"{max(rms[:m]):.2g} / {max(rms[m:]):.2g}{note}")
        print(f"| {label} | " + " | ".join(cells) + " |")


if __name__ == "__main__":
    main()
