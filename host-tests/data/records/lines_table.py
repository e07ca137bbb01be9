#!/usr/bin/env python3
"""Error ÷ Cramér–Rao σ on the white-noise and mains records, per estimator,
precision and line pass (BENCHMARKS.md, "Lines in y"). Replays each record
with `target/release/beamctl replay FILE --estimator E --precision P
[--lines off]` and prints, per flag set, the largest |ω̂_i − ω_i|/ω_i ÷
σ_CRB(ω_i) and the same for ζ over the modes (σ_CRB from reference.json:
on the mains records the bound treats the lines' amplitudes and phases as
unknown). Only this scoring reads reference.json.

    cargo build --release -p beamctl
    python3 host-tests/data/records/lines_table.py
"""

import json
import subprocess
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
ROOT = HERE.parents[2]
RECORDS = ["lab_noise40_prbs", "lab_hum50_chirp", "lab_hum60_prbs", "lab_hum50_harmonics_prbs"]


def ratios(name, flags, beamctl):
    ref = json.loads((HERE / name / "reference.json").read_text())
    p = subprocess.run([beamctl, "replay", str(HERE / name / "record.csv.gz"), "--json", *flags],
                       capture_output=True, text=True)
    r = json.loads(p.stdout)
    r = r[0] if isinstance(r, list) else r
    est, tru, crb = r["estimate"], ref["truth"], ref["crb"]
    if not est or not est.get("omega") or len(est["omega"]) < len(tru["omega_rad_s"]):
        return None, None, r["verdict"]["trusted"]
    ew = max(abs(est["omega"][i] / w - 1) / s for i, (w, s) in
             enumerate(zip(tru["omega_rad_s"], crb["omega_rel"])))
    ez = max(abs(est["zeta"][i] / z - 1) / s for i, (z, s) in
             enumerate(zip(tru["zeta"], crb["zeta_rel"])))
    return ew, ez, r["verdict"]["trusted"]


def main():
    beamctl = sys.argv[1] if len(sys.argv) > 1 else str(ROOT / "target/release/beamctl")
    sets = [(e, p, lines) for e in ("adaptive", "robust", "auto") for p in ("f64", "f32")
            for lines in ("auto", "off")]
    print("| record | " + " | ".join(f"{e} {p}{'' if l == 'auto' else ', lines off'}"
                                     for e, p, l in sets) + " |")
    print("|---|" + "---|" * len(sets))
    for name in RECORDS:
        cells = []
        for e, p, lines in sets:
            flags = ["--estimator", e, "--precision", p] + (["--lines", "off"] if lines == "off" else [])
            ew, ez, trusted = ratios(name, flags, beamctl)
            if ew is None:
                cells.append("no estimate")
            else:
                cells.append(f"{ew:.2g} / {ez:.2g}{'' if trusted else ' (nt)'}")
        print(f"| {name} | " + " | ".join(cells) + " |")


if __name__ == "__main__":
    main()
