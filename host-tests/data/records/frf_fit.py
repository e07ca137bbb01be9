"""Offline reference method for the real records (numpy/scipy only,
independent of this project): H1 FRF estimates and a local
rational-fraction least-squares fit of an accelerance.

Model fitted in a band [f_lo, f_hi] (s = jω):

    A(jω) = s²·( Σ_i r_i / (s² + 2ζ_iω_i·s + ω_i²) + S ) + R

r_i real (real, proportionally damped modes), S and R complex constants:
the upper residual (modes above the band: their receptance is ~constant in
the band, so their accelerance is s²·S) and the lower residual (modes
below the band, including a free-free structure's rigid-body mass line,
whose accelerance is constant). scipy.optimize.least_squares
(Levenberg–Marquardt) on the real and imaginary parts, unweighted, started
from peak picks. The fit's own 1σ (covariance (JᵀJ)⁻¹·s², s² the residual
variance) is returned with each value; the reference uncertainty of the
records is the spread across independent measurements (see each record's
reference.py).

In the project's convention (y = s²·Σ c_i·b̄_i/q_i(s)·u for an
acceleration output, src/model.rs), r_i = c_i·b̄_i.
"""

import numpy as np
from scipy.optimize import least_squares


def h1(excitations, responses):
    """H1 = Σ conj(F)·X / Σ |F|² over records (rectangular window: each
    record holds one whole transient), with the ordinary coherence."""
    F = np.array([np.fft.rfft(e) for e in excitations])
    X = np.array([np.fft.rfft(r) for r in responses])
    sfx = (np.conj(F) * X).sum(0)
    sff = (np.abs(F) ** 2).sum(0)
    sxx = (np.abs(X) ** 2).sum(0)
    return sfx / sff, np.abs(sfx) ** 2 / (sff * sxx), F, X


def model(p, w, n):
    s = 1j * w
    g = np.zeros_like(s)
    for i in range(n):
        wi, zi, ri = p[3 * i : 3 * i + 3]
        g = g + ri / (s**2 + 2 * zi * wi * s + wi**2)
    S = p[3 * n] + 1j * p[3 * n + 1]
    R = p[3 * n + 2] + 1j * p[3 * n + 3]
    return s**2 * (g + S) + R


def fit(freq, H, band, f0s, z0=0.005):
    """Fit len(f0s) modes in band (Hz) to the complex FRF H(freq).
    Returns (modes, params, fit_percent) with modes a list of dicts
    omega (rad/s), zeta, r and their fit 1σ."""
    m = (freq >= band[0]) & (freq <= band[1])
    w = 2 * np.pi * freq[m]
    h = H[m]
    n = len(f0s)
    p0 = []
    for f0 in f0s:
        k = np.argmin(abs(freq[m] - f0))
        p0 += [2 * np.pi * f0, z0, float(np.real(-2j * z0 * h[k]))]
    p0 += [0.0, 0.0, 0.0, 0.0]
    p0 = np.array(p0, float)
    hm = np.max(np.abs(h))
    scale = np.abs(p0)
    scale[scale == 0] = 1.0
    scale[3 * n :] = [hm / w.max() ** 2, hm / w.max() ** 2, hm, hm]

    def res(q):
        e = model(q * scale, w, n) - h
        return np.concatenate([e.real, e.imag])

    sol = least_squares(res, p0 / scale, method="lm", x_scale="jac", max_nfev=20000)
    p = sol.x * scale
    jac = sol.jac / scale[None, :]
    dof = 2 * len(h) - len(p)
    s2 = float(np.sum(sol.fun**2) / dof)
    with np.errstate(invalid="ignore"):
        sd = np.sqrt(np.diag(np.linalg.pinv(jac.T @ jac) * s2))
    modes = [
        dict(omega=p[3 * i], zeta=p[3 * i + 1], r=p[3 * i + 2],
             sd_omega=sd[3 * i], sd_zeta=sd[3 * i + 1], sd_r=sd[3 * i + 2])
        for i in range(n)
    ]
    fitpct = 100 * (1 - np.linalg.norm(model(p, w, n) - h) / np.linalg.norm(h - h.mean()))
    return modes, p, float(fitpct)
