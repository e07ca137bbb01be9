"""Where this record comes from, and how to read it (shared by convert.py
and reference.py).

Source: GitHub repository ladisk/pyFRF, commit
55431fd3c328ddc719232cc34b891291c9982a2e (2016-09-15, "added real
measurements to showcase", Janko Slavič), files data/measurements_1.npy …
data/measurements_5.npy; the measurements were "Prepared by: Matej
Razpotnik" (the repository's Showcase notebook, commit 47c28b3). MIT
licence (LICENSE in this folder, the repository's notice).

Each file is a float64 array of shape (3, 25600): row 0 time (s, step
1/25600 s), row 1 the excitation (impact force), row 2 the response; one
impact per file, 1 s each.

    python3 convert.py SOURCE     # writes record.csv.gz (hit 1)
    python3 reference.py SOURCE   # writes reference.json (all 5 hits)

SOURCE is either a folder holding measurements_1.npy … measurements_5.npy
or the git directory of a clone of ladisk/pyFRF (read at the commit above
with `git show`).
"""

import io
import subprocess
from pathlib import Path

import numpy as np

REPO = "ladisk/pyFRF"
COMMIT = "55431fd3c328ddc719232cc34b891291c9982a2e"
FILES = [f"data/measurements_{i}.npy" for i in range(1, 6)]
FS = 25600.0


def load(src):
    """The five hits as (t, force, response) arrays."""
    src = Path(src)
    out = []
    for f in FILES:
        p = src / Path(f).name
        if p.exists():
            a = np.load(p)
        else:
            raw = subprocess.run(
                ["git", f"--git-dir={src}", "show", f"{COMMIT}:{f}"],
                check=True, capture_output=True,
            ).stdout
            a = np.load(io.BytesIO(raw))
        assert a.shape == (3, 25600), a.shape
        assert np.allclose(np.diff(a[0]), 1 / FS, rtol=1e-9, atol=1e-12)
        out.append(a)
    return out
