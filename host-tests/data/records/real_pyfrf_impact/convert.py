#!/usr/bin/env python3
"""Converts hit 1 of the pyFRF impact measurements (source.py) to the
replay CSV (docs/REPLAY.md): t,u,y with u the impact force and y the
response (an accelerometer: see reference.json), in the source's units.

    python3 convert.py SOURCE

No filtering, decimation or cutting: the whole 1 s record at 25.6 kHz
(25,600 rows). t = k/25600 s (the source's time row, which is k/25600 to
1e-12 s, checked). Both channels were sampled at the same instants; the
replay reads u_k as held over [t_k, t_k + Ts) — for a sampled force that
places the input Ts/2 (19.5 µs) later than where it was measured, a phase
lag of ω·Ts/2 (0.1 rad at 810 Hz, 0.45 rad at 3.67 kHz) that the
reference (an H1 of simultaneously sampled channels) does not have.
Values are written as shortest round-trip decimals of the float64 data.
"""

import gzip
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from source import FS, load  # noqa: E402


def main():
    hits = load(sys.argv[1])
    _, force, resp = hits[0]
    n = len(force)
    lines = ["t,u,y"]
    for k in range(n):
        lines.append(f"{k / FS:.9f},{float(force[k])!r},{float(resp[k])!r}")
    out = Path(__file__).resolve().parent / "record.csv.gz"
    with gzip.GzipFile(out, "wb", mtime=0) as f:
        f.write(("\n".join(lines) + "\n").encode())
    print(f"{out}: {n} rows, {out.stat().st_size} bytes")


if __name__ == "__main__":
    main()
