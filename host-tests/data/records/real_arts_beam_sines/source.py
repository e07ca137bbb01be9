"""Where this record comes from, and how to read it (shared by convert.py
and reference.py).

Source: GitHub repository
High-Rate-SHM-Working-Group/Dataset-4-Univariate-signal-with-non-stationarity,
commit 577933e013047c13147778849f20be701c5590a3 (2025-05-26), file
data/data_I/test_1/data_set_1_downsampled_by_16.lvm (last changed in commit
184c77631ef2554317044f4ef6402d67f6060901, 2022-02-04). Authors: Puja
Chowdhury, Austin Downey, Jason D. Bakos, Philip Conrad (University of South
Carolina), "Dataset-4-univariate-signal-with-nonstationarity", Apr. 2021;
recorded 2020-08-06 (the file's header). Licence CC BY-SA 4.0 (NOTICE in
this folder).

The rig (the dataset's README): a steel cantilever beam 759 × 50.66 ×
5.14 mm driven by an electromagnetic shaker (LDS V203R, amplifier LDS
PA25E-CE) through a 45 N load cell (Transducer Techniques MLP-10, NI-9237),
an IEPE accelerometer (PCB J352C33, 100 mV/g, NI-9234) near the free end.
Test 1: "one sine wave signal built from 100, 120, and 150 Hz frequencies
with no nonstationary"; original sampling 51.2 kHz, this file decimated by
16 by the dataset's authors (3.2 kHz; their method is not stated).

The .lvm file is a LabVIEW text file: two header blocks ending in
***End_of_Header***, a column-name line (X_Value, Voltage, Force,
Acceleration), then tab-separated rows: time (s, rounded to 1 µs),
voltage (V), force (pounds), acceleration (g).

    python3 convert.py SOURCE     # writes record.csv.gz
    python3 reference.py SOURCE   # writes reference.json

SOURCE is the .lvm file itself or the git directory of a clone of the
repository (read at the commit above with `git show`).
"""

import subprocess
from pathlib import Path

import numpy as np

REPO = "High-Rate-SHM-Working-Group/Dataset-4-Univariate-signal-with-non-stationarity"
COMMIT = "577933e013047c13147778849f20be701c5590a3"
FILE = "data/data_I/test_1/data_set_1_downsampled_by_16.lvm"
FS = 51200.0 / 16  # 3200 Hz
LBF_TO_N = 4.4482216152605
G_TO_MS2 = 9.80665


def load(src):
    """(t, voltage V, force N, acceleration m/s²) of the whole file."""
    src = Path(src)
    if src.is_file():
        text = src.read_text()
    else:
        text = subprocess.run(
            ["git", f"--git-dir={src}", "show", f"{COMMIT}:{FILE}"],
            check=True, capture_output=True, text=True,
        ).stdout
    lines = text.splitlines()
    ends = [i for i, ln in enumerate(lines) if ln.startswith("***End_of_Header***")]
    start = ends[1] + 1
    assert lines[start].startswith("X_Value"), lines[start]
    rows = [ln.split("\t") for ln in lines[start + 1 :] if ln.strip()]
    d = np.array([[float(x) for x in r[:4]] for r in rows])
    t, v, f, a = d.T
    # the time column is k/3200 s rounded to 1 µs: check, then use k/3200
    k = np.arange(len(t))
    assert np.max(np.abs(t - k / FS)) <= 0.6e-6, np.max(np.abs(t - k / FS))
    return k / FS, v, f * LBF_TO_N, a * G_TO_MS2
