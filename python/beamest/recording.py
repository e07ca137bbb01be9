"""``beamctl monitor --record FILE.csv`` recordings (docs/RECORDING.md)."""

from __future__ import annotations

import csv
import os
from dataclasses import dataclass
from typing import Dict, List, Optional

import numpy as np

__all__ = ["Recording", "read_recording"]


@dataclass
class Recording:
    """A monitor recording: every row of ``FILE.csv`` (``rows``, dicts of
    its columns, empty fields left out), the estimate rows as arrays
    (``estimates``) and the raw samples of ``FILE.raw.csv`` if it exists
    (``raw``: t, u, y)."""

    #: every row, in order: {"kind": ..., column: text}
    rows: List[Dict[str, str]]
    #: the estimate rows: host_s, sample_index, t_s, flags, omega (rows ×
    #: 3), zeta, bbar, lambda_rad_s (the λ of Θ̂), excitation_level
    #: (λmin(P)/tr(P)), theta (rows × 11); NaN where empty
    estimates: Dict[str, np.ndarray]
    #: FILE.raw.csv: {"t" or "sample_index", "u", "y"} or None
    raw: Optional[Dict[str, np.ndarray]]

    def kinds(self, kind: str) -> List[Dict[str, str]]:
        """The rows of one kind (estimate, raw, status, ack, command,
        timeout, error, end, command_echo)."""
        return [r for r in self.rows if r.get("kind") == kind]


def _num(text: Optional[str]) -> float:
    return float(text) if text not in (None, "") else np.nan


def read_recording(path: str) -> Recording:
    """Read ``FILE.csv`` written by ``beamctl monitor --record FILE.csv``
    (and ``FILE.raw.csv`` beside it, if present)."""
    path = os.fspath(path)
    with open(path, newline="", encoding="utf-8") as f:
        reader = csv.DictReader(f)
        if reader.fieldnames is None or "kind" not in reader.fieldnames:
            raise ValueError(f"{path}: not a beamctl monitor recording (no 'kind' column)")
        rows = [{k: v for k, v in r.items() if v not in (None, "")} for r in reader]
    est = [r for r in rows if r.get("kind") == "estimate"]
    estimates = {
        "host_s": np.array([_num(r.get("host_s")) for r in est]),
        "sample_index": np.array([int(r["sample_index"]) for r in est], dtype=np.int64),
        "t_s": np.array([_num(r.get("t_s")) for r in est]),
        "flags": np.array([int(r.get("flags", 0)) for r in est], dtype=np.int64),
        "lambda_rad_s": np.array([_num(r.get("lambda_rad_s")) for r in est]),
        "excitation_level": np.array([_num(r.get("excitation_level")) for r in est]),
    }
    for name, n in (("omega", 3), ("zeta", 3), ("bbar", 3), ("theta", 11)):
        estimates[name] = np.array(
            [[_num(r.get(f"{name}_{i}")) for i in range(1, n + 1)] for r in est]
        ).reshape(len(est), n)
    # As beamctl::link::raw_path_for: FILE.csv -> FILE.raw.csv.
    stem = path[:-4] if path.lower().endswith(".csv") else path
    raw_path = stem + ".raw.csv"
    raw = None
    if os.path.exists(raw_path):
        with open(raw_path, newline="", encoding="utf-8") as f:
            reader = csv.reader(f)
            header = next(reader)
            cols = list(zip(*reader))
        raw = {}
        for i, name in enumerate(header):
            values = cols[i] if cols else ()
            raw[name] = np.array([float(v) if v else np.nan for v in values])
    return Recording(rows=rows, estimates=estimates, raw=raw)
