#!/usr/bin/env python3
"""Converts Test 1 of the USC Dataset-4 (source.py) to the replay CSV
(docs/REPLAY.md): t,u,y plus a force column.

    python3 convert.py SOURCE

- t = k/3200 s (the source's time column is that, rounded to 1 µs; checked
  in source.load);
- u = the "Voltage" channel in V (the shaker drive signal as logged: the
  known input a controller would apply);
- y = the "Acceleration" channel converted from g to m/s² (×9.80665);
- force_n = the load-cell "Force" channel converted from pounds to N
  (×4.4482216152605): an alternative input (`--columns t,force_n,y`). It
  carries a static preload offset of about −23 N.
The whole file (63,041 rows, 19.7 s), no further filtering or decimation.
Both channels were sampled at the same instants; the replay reads u_k as
held over [t_k, t_k + Ts) (a Ts/2 = 156 µs lag under that reading).
Values with 9 significant digits (the source has 6 decimals: 1e-6 V, 1e-6 lb, 1e-6 g).
"""

import gzip
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from source import load  # noqa: E402


def main():
    t, v, f, a = load(sys.argv[1])
    lines = ["t,u,y,force_n"]
    for k in range(len(t)):
        lines.append(f"{t[k]:.7f},{v[k]:.9g},{a[k]:.9g},{f[k]:.9g}")
    out = Path(__file__).resolve().parent / "record.csv.gz"
    with gzip.GzipFile(out, "wb", mtime=0) as fh:
        fh.write(("\n".join(lines) + "\n").encode())
    print(f"{out}: {len(t)} rows, {out.stat().st_size} bytes")


if __name__ == "__main__":
    main()
