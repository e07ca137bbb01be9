"""The frequency-response picture: the measured FRF of a record (H1 with
Welch averaging, and the coherence) with the identified model's response
over it, as ``beamctl replay|simulate --plot`` draws it.

H1 = G_yu / G_uu is computed by beamctl's own code (``judge::frf``; its
module documentation is the method): Hann-windowed segments of
``segment_s`` seconds overlapping by half, mean removed, spectra averaged;
the coherence γ² = |G_yu|² / (G_uu·G_yy) says at each frequency how much
of y is linearly explained by u. Only frequencies where u has power are
kept (a square wave or a multisine excites a comb of lines; the bins the
Hann window leaks each line into are dropped too). The model's response
drawn over it is that of the sampled model the record follows: H(s) =
B(s)/A(s) of eqs. 25–26 under an exact zero-order hold, at
z = exp(j2πf·Ts) (the continuous H(j2πf) differs from it by about the
hold's phase lag π·f·Ts: 1.8° at 50 Hz for Ts = 0.1 ms).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Optional

import numpy as np

from . import _beamest

__all__ = ["H1", "h1", "plot"]


@dataclass(frozen=True)
class H1:
    """An H1 estimate on the frequencies where u has power."""

    #: frequency (Hz)
    f_hz: np.ndarray
    #: H1 = G_yu/G_uu (units of y per unit of u)
    h: np.ndarray
    #: coherence γ², 0..1
    coherence: np.ndarray
    #: segments averaged
    segments: int
    #: segment length (s)
    segment_s: float


def h1(u, y, ts: float, segment_s: Optional[float] = None) -> H1:
    """H1 and the coherence of the record ``u``, ``y`` at sample interval
    ``ts`` (beamctl's ``judge::frf::h1``). ``segment_s``: Welch segment
    length [default: an eighth of the record, at least 1 s when the record
    allows]. Raises ValueError when u has power at no frequency or the
    record is shorter than 16 samples."""
    from . import _array

    d = _beamest.frf_h1(_array("u", u), _array("y", y), float(ts),
                        None if segment_s is None else float(segment_s))
    if d is None:
        raise ValueError("u: no frequency with power in the record (or fewer than 16 samples)")
    return H1(f_hz=d["f_hz"], h=d["re"] + 1j * d["im"], coherence=d["coherence"],
              segments=d["segments"], segment_s=d["segment_s"])


def plot(result, path: Optional[str] = None, segment_s: Optional[float] = None, fig=None):
    """Draw the FRF picture of a :class:`beamest.ReplayResult` (see the
    module's text); save it to ``path`` when given; return the figure."""
    try:
        import matplotlib

        if fig is None and path is not None:
            matplotlib.use("Agg", force=False)
        import matplotlib.pyplot as plt
    except ImportError as e:  # pragma: no cover
        raise ImportError("plot_frf needs matplotlib: pip install matplotlib") from e
    m = result.frf(segment_s=segment_s)
    if fig is None:
        fig = plt.figure(figsize=(10, 7.5))
    ax_mag, ax_ph, ax_coh = fig.subplots(3, 1, sharex=True,
                                         gridspec_kw={"height_ratios": [3, 2, 1]})
    if len(m.f_hz) == 0:
        raise ValueError("u: no frequency with power in the record")
    lo = m.f_hz.min() / 1.5
    hi = min(m.f_hz.max() * 1.5, 0.5 / result.ts)
    omega = result.omega
    valid = result.ok and bool(np.all(np.isfinite(omega)))
    if valid:
        # From a third of the lowest mode to ten times the highest.
        f_modes = omega / (2 * math.pi)
        lo = min(lo, f_modes.min() / 3)
        hi = min(0.5 / result.ts, max(f_modes.max() * 10, lo * 10))
    fgrid = np.logspace(math.log10(lo), math.log10(hi), 800)
    shown = m.f_hz <= hi
    f_meas, h_meas, coh = m.f_hz[shown], m.h[shown], m.coherence[shown]
    ph_meas = np.degrees(np.angle(h_meas))
    label_meas = f"measured H1 ({m.segments} Hann segments of {m.segment_s:.3g} s, 50 % overlap)"
    if valid:
        hm = result.response(fgrid)
        ph_model = np.degrees(np.unwrap(np.angle(hm)))
        # The measured phase on the model's branch (both are mod 360°).
        near = np.interp(f_meas, fgrid, ph_model)
        ph_meas = ph_meas + 360.0 * np.round((near - ph_meas) / 360.0)
    ax_mag.loglog(f_meas, np.abs(h_meas), "o", ms=3.5, color="tab:blue", label=label_meas, zorder=3)
    ax_ph.semilogx(f_meas, ph_meas, "o", ms=3.5, color="tab:blue", zorder=3)
    ax_coh.semilogx(f_meas, coh, "o", ms=3.5, color="tab:blue")
    if valid:
        fit = result.fit_percent
        label = f"identified model, exact ZOH ({result.estimator}"
        label += f", fit {fit:.2f} %)" if fit is not None else ")"
        ax_mag.loglog(fgrid, np.abs(hm), "-", color="tab:red", lw=1.6, label=label)
        ax_ph.semilogx(fgrid, ph_model, "-", color="tab:red", lw=1.6)
        for i, (w, z) in enumerate(zip(result.omega, result.zeta), 1):
            fn = w / (2 * math.pi)
            for ax in (ax_mag, ax_ph, ax_coh):
                ax.axvline(fn, color="0.4", ls="--", lw=0.9)
            ax_mag.annotate(f"mode {i}: {fn:.4g} Hz\nω = {w:.4g} rad/s\nζ = {z:.4g}",
                            xy=(fn, 0.97 - 0.2 * (i - 1)), xycoords=("data", "axes fraction"),
                            xytext=(5, 0), textcoords="offset points", va="top", fontsize=9,
                            bbox=dict(boxstyle="round,pad=0.25", fc="white", ec="0.7", alpha=0.9))
        lo_ph = math.floor(min(ph_model.min(), ph_meas.min() if len(ph_meas) else 0) / 90) * 90
        hi_ph = math.ceil(max(ph_model.max(), ph_meas.max() if len(ph_meas) else 0) / 90) * 90
        ax_ph.set_ylim(lo_ph - 20, hi_ph + 20)
        ax_ph.set_yticks(np.arange(lo_ph, hi_ph + 1, 90))
    else:
        ax_ph.set_ylim(-200, 200)
        ax_ph.set_yticks([-180, -90, 0, 90, 180])
    ax_mag.set_ylabel("|H| (y-units per u-unit)")
    ax_ph.set_ylabel("phase (°)")
    ax_coh.set_ylabel("coherence γ²")
    ax_coh.set_ylim(0, 1.05)
    ax_coh.set_xlabel("frequency (Hz)")
    ax_coh.set_xlim(lo, hi)
    for ax in (ax_mag, ax_ph, ax_coh):
        ax.grid(True, which="both", alpha=0.3)
    ax_mag.legend(loc="lower left", fontsize=9)
    ax_mag.set_title(f"{result.file}: frequency response (Ts = {result.ts} s, "
                     f"{result.samples} samples)", fontsize=11)
    fig.tight_layout()
    if path is not None:
        fig.savefig(path, dpi=110)
    return fig
