"""Replay a committed record with beamest, print the result table and save
the frequency-response picture.

    python python/examples/replay_record.py [RECORD.csv.gz] [OUT.png]

Defaults: host-tests/data/replay_a.csv.gz (simulated outside this project
with numpy/scipy, docs/REPLAY.md), frf.png. Needs matplotlib for the
picture."""

import pathlib
import sys

import beamest

repo = pathlib.Path(__file__).resolve().parents[2]
record = pathlib.Path(sys.argv[1]) if len(sys.argv) > 1 else repo / "host-tests/data/replay_a.csv.gz"
out = sys.argv[2] if len(sys.argv) > 2 else "frf.png"

u, y, ts = beamest.read_replay_csv(record)
results = beamest.replay(u, y, ts=ts, file=record.name, estimator="all")
for r in results:
    print(r.table())
    print()
best = max((r for r in results if r.ok), key=lambda r: r.fit_percent or -1e300)
best.plot_frf(out)
print(f"wrote {out} (FRF of the {best.estimator} estimate, fit {best.fit_percent:.3f} %)")
