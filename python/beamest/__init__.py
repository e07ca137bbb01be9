"""beamest: online modal identification of a piezo-actuated cantilever beam,
from Python.

The estimator, the Cramér–Rao bound, the beam model and the serial-link
decoder of the ``beamctl`` command-line tool, called as a library: the
same Rust code runs behind ``beamctl replay`` and :func:`replay`, so a
record replayed here gives the CLI's estimate bit for bit (same
precision). Options are the CLI's flags as keyword arguments
(``band_hz=(5, 50)`` for ``--band-hz 5,50``; ``lambda_`` for
``--lambda``). See python/README.md.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from typing import Any, Dict, List, Optional, Sequence, Union

import numpy as np

from . import _beamest, _options
from . import link  # noqa: F401  (beamest.link)
from .recording import Recording, read_recording  # noqa: F401

__all__ = [
    "replay",
    "ReplayResult",
    "Series",
    "Estimator",
    "Estimates",
    "read_replay_csv",
    "sample_interval",
    "simulate",
    "crlb",
    "beam_model",
    "read_recording",
    "Recording",
    "link",
]

#: Flags of ``beamctl replay`` that do not apply to arrays (the file's own)
#: or that :func:`replay` always sets.
_REPLAY_EXCLUDED = ("columns", "ts", "json", "help")
#: ... and those a streaming :class:`Estimator` has no use for.
_STREAM_EXCLUDED = _REPLAY_EXCLUDED + ("csv", "plot", "crlb", "noise-sd", "model-set")


def _array(name: str, v: Any) -> np.ndarray:
    """``v`` as a 1-D contiguous float64 array: the same memory when it
    already is one, a converted copy otherwise."""
    try:
        a = np.asarray(v)
    except Exception as e:  # pragma: no cover - numpy's own message
        raise TypeError(f"{name}: not convertible to an array ({e})") from None
    if a.dtype.kind not in "biuf":
        raise TypeError(f"{name}: expected real numbers, got an array of dtype {a.dtype}")
    if a.ndim != 1:
        raise ValueError(f"{name}: expected a 1-D array, got {a.ndim} dimensions (shape {a.shape})")
    return np.ascontiguousarray(a, dtype=np.float64)


def _interval(ts: Any, t: Any) -> float:
    if (ts is None) == (t is None):
        raise TypeError("give exactly one of ts (the sample interval, s) and t (the sample times, s)")
    if t is not None:
        return sample_interval(t)
    if isinstance(ts, bool) or not isinstance(ts, (int, float, np.floating, np.integer)):
        raise TypeError(f"ts: expected a number of seconds, got {type(ts).__name__}")
    ts = float(ts)
    if not (math.isfinite(ts) and ts > 0):
        raise ValueError(f"ts: the sample interval must be a finite number > 0 s (got {ts})")
    return ts


def sample_interval(t: Any) -> float:
    """The sample interval of the sample times ``t`` (s) by ``beamctl
    replay``'s rules for a time column (docs/REPLAY.md): every t finite and
    increasing, Ts the mean spacing of the first 10,000 rounded to 9
    significant digits, every interval within 1 % of it.

    Raises ValueError naming the offending index (``t[k]: ...``)."""
    return _beamest.time_base(_array("t", t))


@dataclass(frozen=True)
class Series:
    """One estimator's estimate over time: one row per evaluation (NaN
    where there is no estimate)."""

    #: index of the evaluated sample
    sample: np.ndarray
    #: its time (s), ``sample * ts``
    t: np.ndarray
    #: ω̂_i (rad/s), shape (evaluations, modes)
    omega: np.ndarray
    #: ζ̂_i, shape (evaluations, modes)
    zeta: np.ndarray
    #: b̂̄_i, shape (evaluations, modes)
    b_bar: np.ndarray
    #: Θ̂ of eq. 29 (physical units), shape (evaluations, 4·modes − 1)
    theta: np.ndarray
    #: λ in use (rad/s), NaN before the estimator is built
    lambda_rad_s: np.ndarray
    #: validity bits (0 = valid, 1 = no estimate; beamest::modal::validity)
    validity: np.ndarray
    #: the supervisor's excitation flag
    excited: np.ndarray

    @staticmethod
    def _of(d: Dict[str, np.ndarray]) -> "Series":
        return Series(sample=d["sample"], t=d["t"], omega=d["omega"], zeta=d["zeta"],
                      b_bar=d["bbar"], theta=d["theta"], lambda_rad_s=d["lambda_rad_s"],
                      validity=d["validity"], excited=d["excited"])

    def __len__(self) -> int:
        return len(self.sample)


def _nan_array(values: Optional[Sequence[Optional[float]]]) -> np.ndarray:
    return np.array([math.nan if v is None else v for v in (values or [])], dtype=np.float64)


class ReplayResult:
    """One estimator's replay: the report of ``beamctl replay --json``
    (:meth:`to_dict`, and every key as an attribute), the estimate as
    arrays, the estimate over time (:attr:`series`) and the record it was
    run on (for :meth:`frf` and :meth:`plot_frf`)."""

    def __init__(self, report: Dict[str, Any], series: Series, verdict: Optional[str],
                 u: np.ndarray, y: np.ndarray):
        self._report = report
        self.series = series
        #: why there is no estimate (the message ``beamctl replay`` exits 1
        #: with), or None when the final estimate is a valid modal model
        self.no_estimate_reason = verdict
        self._u = u
        self._y = y

    def to_dict(self) -> Dict[str, Any]:
        """The report exactly as ``beamctl replay --json`` prints it
        (``json.loads`` of its output; NaN written as None)."""
        return json.loads(json.dumps(self._report))

    def __getattr__(self, name: str) -> Any:
        report = self.__dict__.get("_report")
        if report is not None and name in report:
            return report[name]
        raise AttributeError(name)

    def __dir__(self):
        return sorted(set(super().__dir__()) | set(self._report))

    @property
    def ok(self) -> bool:
        """True when there is a final estimate and it is a physical beam
        (``validity`` empty: ω > 0, 0 < ζ < 1, distinct modes)."""
        return self.no_estimate_reason is None and not self._report["validity"]

    @property
    def trusted(self) -> bool:
        """The report's verdict: no check failed (``verdict["reasons"]``
        says which did)."""
        return bool(self._report["verdict"]["trusted"])

    @property
    def ts(self) -> float:
        """Sample interval (s)."""
        return self._report["ts_s"]

    @property
    def omega(self) -> np.ndarray:
        """ω̂_i (rad/s); NaN where there is none."""
        return _nan_array(self._report["estimate"]["omega"])

    @property
    def zeta(self) -> np.ndarray:
        """ζ̂_i; NaN where there is none."""
        return _nan_array(self._report["estimate"]["zeta"])

    @property
    def b_bar(self) -> np.ndarray:
        """b̂̄_i (eq. 32); NaN where there is none."""
        return _nan_array(self._report["estimate"]["bbar"])

    @property
    def transfer_function(self):
        """(num, den): H(s) = num(s)/den(s), coefficients highest power
        first as numpy.polyval takes them (den monic: [1, a_{2n−1}, …,
        a_0]; num: [b_{2n−2}, …, b_0]; eqs. 25–26)."""
        e = self._report["estimate"]
        return _nan_array(e["b"]), np.concatenate([[1.0], _nan_array(e["a"])])

    def response(self, f_hz: Any, zoh: bool = True) -> np.ndarray:
        """The identified model's frequency response at ``f_hz`` (Hz).

        ``zoh=True``: the sampled model the record follows, u held over
        each sample (exact zero-order hold, as the fit uses), at
        z = exp(j2πf·Ts): what H1 of the record measures. ``zoh=False``:
        the continuous H(j2πf)."""
        num, den = self.transfer_function
        f = np.asarray(f_hz, dtype=np.float64)
        if not zoh:
            s = 2j * np.pi * f
            return np.polyval(num, s) / np.polyval(den, s)
        # G(s)/s = G(0)/s + Σ c_i/(s − p_i), c_i = residue of G at p_i / p_i;
        # its sampled step response gives G_d(z) = G(0) + Σ c_i (z − 1)/(z − e^{p_i Ts}).
        poles = np.roots(den)
        dden = np.polyder(den)
        z = np.exp(2j * np.pi * f * self.ts)
        g = np.full(z.shape, np.polyval(num, 0.0) / np.polyval(den, 0.0), dtype=np.complex128)
        for p in poles:
            c = np.polyval(num, p) / np.polyval(dden, p) / p
            g += c * (z - 1) / (z - np.exp(p * self.ts))
        return g if g.ndim else complex(g)

    def frf(self, segment_s: Optional[float] = None):
        """The measured FRF of the record (H1 = G_yu/G_uu, Welch-averaged,
        and the coherence): see :func:`beamest.frf.h1`."""
        from . import frf

        return frf.h1(self._u, self._y, self.ts, segment_s=segment_s)

    def plot_frf(self, path: Optional[str] = None, segment_s: Optional[float] = None, fig=None):
        """Magnitude and phase of the measured FRF (H1, with its coherence)
        and of the identified model, log frequency, each mode marked with
        ω̂ and ζ̂ (matplotlib, an optional dependency). Saves to ``path``
        when given; returns the figure."""
        from . import frf

        return frf.plot(self, path=path, segment_s=segment_s, fig=fig)

    def table(self) -> str:
        """A short text table of the result."""
        rows = [f"{self._report['estimator']} ({self._report['precision']}, "
                f"{self._report['samples']} samples at Ts = {self.ts} s)"]
        for i, (w, z, b) in enumerate(zip(self.omega, self.zeta, self.b_bar), 1):
            rows.append(f"  mode {i}: ω = {w:.6g} rad/s ({w / (2 * np.pi):.6g} Hz), "
                        f"ζ = {z:.6g}, b̄ = {b:.6g}")
        fit = self._report.get("fit_percent")
        drift = self._report.get("drift_last_10pct")
        rows.append(f"  fit: {'-' if fit is None else f'{fit:.3f} %'}, drift over the last 10 %: "
                    f"{'-' if drift is None else f'{drift:.3g}'}")
        rows.append(f"  validity: {', '.join(self._report['validity']) or 'valid'}")
        if self.no_estimate_reason:
            rows.append(f"  no estimate: {self.no_estimate_reason}")
        return "\n".join(rows)

    def __repr__(self) -> str:
        return (f"ReplayResult(estimator={self._report['estimator']!r}, omega={self.omega!r}, "
                f"zeta={self.zeta!r}, fit_percent={self._report.get('fit_percent')!r})")


def replay(u: Any, y: Any, ts: Optional[float] = None, t: Any = None, *,
           file: str = "<arrays>", series_hz: float = 10.0,
           **options: Any) -> Union[ReplayResult, List[ReplayResult]]:
    """``beamctl replay`` on samples in memory.

    ``u[k]`` is held over sample k, ``y[k]`` sampled at its start (the
    replay file's rows, docs/REPLAY.md). Give the sample interval ``ts``
    (s) or the sample times ``t`` (s; checked and reduced to Ts as a time
    column is). ``options`` are ``beamctl replay``'s flags: estimator,
    precision, modes, weights, lambda_, band_hz, beam, paper_gains,
    paper_exp_gains, range, level_correction, no_level_correction,
    residual_monitor, crlb,
    noise_sd, model_set, csv, plot, lines, mains, prewhiten. ``file`` is
    the report's ``file``.
    ``series_hz``: evaluations per second of record kept in
    :attr:`ReplayResult.series` (10 = the drift grid, 1000 = ``--csv``'s).

    Returns a :class:`ReplayResult`, or a list of them with
    ``estimator="all"`` (the CLI's JSON array). The interpreter's lock is
    released while it runs; Ctrl-C interrupts it (KeyboardInterrupt).

    Raises TypeError for an unknown keyword or a value of the wrong type,
    ValueError for a bad value (the message names the argument)."""
    if not isinstance(file, str):
        raise TypeError(f"file: expected a string, got {type(file).__name__}")
    if isinstance(series_hz, bool) or not isinstance(series_hz, (int, float)):
        raise TypeError(f"series_hz: expected a number, got {type(series_hz).__name__}")
    ua, ya = _array("u", u), _array("y", y)
    ts_s = _interval(ts, t)
    if len(ua) != len(ya):
        raise ValueError(f"y: u and y must have the same length (got {len(ua)} and {len(ya)})")
    if t is not None and len(np.asarray(t)) != len(ua):
        raise ValueError(f"t: must have one time per sample (got {len(np.asarray(t))} for {len(ua)} samples)")
    if len(ua) == 0:
        raise ValueError("u: no samples (empty arrays)")
    argv = _options.argv("replay", "replay", options, exclude=_REPLAY_EXCLUDED, positional=(file,))
    text, logs, verdicts = _beamest.replay_arrays(argv, ua, ya, ts_s, file, float(series_hz))
    reports = json.loads(text)
    results = [ReplayResult(r, Series._of(l), v, ua, ya) for r, l, v in zip(reports, logs, verdicts)]
    return results[0] if len(results) == 1 else results


def read_replay_csv(path: str, columns: Optional[Sequence[str]] = None,
                    ts: Optional[float] = None):
    """Read a ``beamctl replay`` file (CSV, plain or gzip) with the CLI's
    own reader: returns ``(u, y, ts)``. ``columns``: names T,U,Y (or U,Y
    with ``ts``), as ``--columns``. Raises FileNotFoundError, or
    ValueError with the CLI's message (``FILE: line N: ...``)."""
    if columns is not None:
        if isinstance(columns, str):
            columns = columns.split(",")
        columns = [str(c) for c in columns]
    return _beamest.read_replay_csv(str(path), columns, None if ts is None else float(ts))


@dataclass(frozen=True)
class Estimates:
    """The evaluations that fell in one :meth:`Estimator.step` call, per
    estimator (a :class:`Series` each, in the order of ``names``)."""

    names: List[str]
    series: List[Series]

    def __getitem__(self, name: str) -> Series:
        return self.series[self.names.index(name)]

    def __len__(self) -> int:
        return len(self.series[0]) if self.series else 0


class Estimator:
    """The estimator fed as samples arrive: ``beamctl replay``'s session
    (sensor guard, truth-free tuning rule, the chosen laws) stepped one
    sample at a time, however the samples are split into chunks.

    ``Estimator(ts, rate_hz=100, **options)``: ``options`` as
    :func:`replay`'s (not csv, plot, crlb); ``estimator="auto"`` (the
    default) is the adaptive law here, with ``modes`` or 2 modes: a
    stream cannot choose a model before it has the record. ``step(u, y)`` takes arrays
    of any length and returns the estimates evaluated in them, one every
    ``round(1/(rate_hz·ts))`` samples (the first at sample
    ``every − 1``)."""

    def __init__(self, ts: float, rate_hz: float = 100.0, *, name: str = "<stream>",
                 **options: Any):
        self.ts = _interval(ts, None)
        if isinstance(rate_hz, bool) or not isinstance(rate_hz, (int, float)):
            raise TypeError(f"rate_hz: expected a number, got {type(rate_hz).__name__}")
        if not (math.isfinite(rate_hz) and rate_hz > 0):
            raise ValueError(f"rate_hz: must be a finite number > 0 (got {rate_hz})")
        #: samples between two evaluations
        self.every = max(1, round((1.0 / rate_hz) / self.ts))
        self._name = name
        argv = _options.argv("replay", "Estimator", options, exclude=_STREAM_EXCLUDED,
                             positional=(name,))
        self._core = _beamest.StreamCore(argv, self.ts, self.every)
        self.names = [r["estimator"] for r in json.loads(self._core.reports(name))]

    def step(self, u: Any, y: Any) -> Estimates:
        """Step the samples ``u[k]``, ``y[k]`` in order (arrays of equal
        length, any length); the estimates evaluated in them. Releases the
        interpreter's lock; Ctrl-C interrupts (KeyboardInterrupt) after a
        whole sub-chunk of 65,536 samples, ``samples`` telling how many
        were stepped."""
        ua, ya = _array("u", u), _array("y", y)
        if len(ua) != len(ya):
            raise ValueError(f"y: u and y must have the same length (got {len(ua)} and {len(ya)})")
        logs = self._core.feed(ua, ya)
        return Estimates(self.names, [Series._of(l) for l in logs])

    @property
    def samples(self) -> int:
        """Samples stepped so far."""
        return self._core.samples

    def reports(self, u: Any = None, y: Any = None) -> List[Dict[str, Any]]:
        """Each estimator's report now, as ``beamctl replay --json``'s
        objects. The estimator keeps no samples, so the model-output fit
        (``fit_percent``) is computed over the ``u``, ``y`` given here (the
        record so far, or a recent window of it: the fit includes the free
        response of the window's initial state); without them it is
        None."""
        if u is None and y is None:
            return json.loads(self._core.reports(self._name))
        if u is None or y is None:
            missing = "u" if u is None else "y"
            raise ValueError(f"{missing}: required with {'y' if missing == 'u' else 'u'}")
        ua, ya = _array("u", u), _array("y", y)
        if len(ua) != len(ya):
            raise ValueError(f"y: u and y must have the same length (got {len(ua)} and {len(ya)})")
        return json.loads(self._core.reports(self._name, ua, ya))


def simulate(**options: Any) -> Union[Dict[str, Any], List[Dict[str, Any]]]:
    """``beamctl simulate --json``: the simulated beam, the estimators, the
    report (a dict, or a list with ``estimator="all"``). ``options`` are
    its flags (duration, ts, modes, omega, zeta, bbar, snr_db, seed,
    estimator, precision, wave, csv, plot, ...). A law that produced no
    estimate is in the report (its ``validity``), not an exception."""
    argv = _options.argv("simulate", "simulate", options, exclude=("json", "help"))
    return json.loads(_beamest.simulate_json(argv))


def crlb(**options: Any) -> Dict[str, Any]:
    """``beamctl crlb --json``: the Cramér–Rao bound of an experiment
    (snr_db or noise_sd required; duration, modes, omega, ..., model_set)."""
    argv = _options.argv("crlb", "crlb", options, exclude=("json", "help"))
    return json.loads(_beamest.crlb_json(argv))


def beam_model(**options: Any) -> Dict[str, Any]:
    """``beamctl model --json``: the physical beam's modal parameters and
    transfer function (modes, beam: a TOML file)."""
    argv = _options.argv("model", "beam_model", options, exclude=("json", "help"))
    return json.loads(_beamest.model_json(argv))
