"""How long each section stays expanded: 75 %-of-maximum and Gaussian one-sigma.

Functions of a ``(n_v, n_t)`` area map over one periodic cycle.
"""
from __future__ import annotations

import warnings

import numpy as np
from scipy.optimize import curve_fit

from ..cycle import periodic_peak


def threshold_crossings(row: np.ndarray, level: float) -> tuple[float, float]:
    """Sub-frame times where a periodic row rises above and falls below ``level``
    around its maximum; ``(nan, nan)`` if it never drops below."""
    n = len(row)
    k = int(np.nanargmax(row))
    if np.nanmin(row) >= level:
        return np.nan, np.nan

    def walk(step):
        j = k
        for _ in range(n):
            nxt = j + step
            if row[nxt % n] < level:
                a, b = row[j % n], row[nxt % n]
                return j + step * (a - level) / (a - b)
            j = nxt
        return np.nan

    return walk(-1), walk(+1)


def expanded_75(area: np.ndarray, *, fraction: float = 0.75):
    """Rows' share of the cycle with area >= ``fraction`` x its maximum.

    Returns ``share (n_v,)``, crossing frames ``up, down (n_v,)`` (sub-frame,
    ``up`` may be negative: periodic) and the mask ``(n_v, n_t)``.
    """
    area = np.asarray(area, float)
    n_v, n_t = area.shape
    up = np.full(n_v, np.nan)
    down = np.full(n_v, np.nan)
    level = fraction * np.nanmax(area, axis=1)
    for j in range(n_v):
        up[j], down[j] = threshold_crossings(area[j], level[j])
    share = (down - up) / n_t
    mask = area >= level[:, None]
    return share, up, down, mask


def _gauss(t, base, amp, sigma):
    return base + amp * np.exp(-0.5 * (t / sigma) ** 2)


def expanded_sigma(area: np.ndarray, *, min_r2: float = 0.8):
    """Gaussian in time centred on each row's maximum; one sigma either side.

    Fits ``base + amp exp(-dt^2 / 2 sigma^2)`` (dt: periodic frames from the
    sub-frame peak). Returns ``share (n_v,)`` = 2 sigma / n_t, ``sigma``
    (frames), the fit's R^2, and the mask of cells within one sigma of the peak.
    Rows whose fit fails or has R^2 < ``min_r2`` are NaN (counted in a warning).
    """
    area = np.asarray(area, float)
    n_v, n_t = area.shape
    sigma = np.full(n_v, np.nan)
    r2 = np.full(n_v, np.nan)
    peak = np.full(n_v, np.nan)
    frames = np.arange(n_t)
    for j in range(n_v):
        y = area[j]
        if not np.all(np.isfinite(y)) or np.ptp(y) <= 0:
            continue
        peak[j] = periodic_peak(y, find="max")
        dt = (frames - peak[j] + n_t / 2) % n_t - n_t / 2
        p0 = (y.min(), np.ptp(y), n_t / 6)
        try:
            popt, _ = curve_fit(_gauss, dt, y, p0=p0, maxfev=2000,
                                bounds=([-np.inf, 0, 0.5], [np.inf, np.inf, n_t]))
        except (RuntimeError, ValueError):
            continue
        resid = y - _gauss(dt, *popt)
        r2[j] = 1 - (resid ** 2).sum() / ((y - y.mean()) ** 2).sum()
        if r2[j] >= min_r2:
            sigma[j] = popt[2]
    bad = int(np.isnan(sigma).sum())
    if bad:
        warnings.warn(f"Gaussian fit failed or fits poorly (R^2 < {min_r2}) in {bad} of {n_v} "
                      "rows (NaN)", RuntimeWarning, stacklevel=2)
    dt = np.abs((frames[None, :] - peak[:, None] + n_t / 2) % n_t - n_t / 2)
    mask = dt <= sigma[:, None]
    return 2 * sigma / n_t, sigma, r2, mask
