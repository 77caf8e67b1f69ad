"""Band detection (beyond the paper): a neck in the maximum-area profile where the
wall nearly stops moving."""

from __future__ import annotations

import numpy as np
from scipy.signal import find_peaks


def detect_band(
    area: np.ndarray,
    s_mm: np.ndarray,
    *,
    min_prominence: float = 0.05,
    max_motion_ratio: float = 0.7,
) -> float | None:
    """Position (mm) of a band, or ``None``.

    A band is a local minimum of the maximum-area profile ``max_t A(v, t)``
    whose prominence is at least ``min_prominence`` of the profile's median,
    where the relative motion ``(max - min) / max`` is below
    ``max_motion_ratio`` times the median motion of the map (a horizontal
    band of near-zero temporal derivative). The position is refined with a
    parabola through the minimum and its neighbours.
    """
    area = np.asarray(area, float)
    s = np.asarray(s_mm, float)
    amax = np.nanmax(area, axis=1)
    motion = (amax - np.nanmin(area, axis=1)) / amax
    peaks, props = find_peaks(-amax, prominence=min_prominence * np.nanmedian(amax))
    best = None
    for j, prom in zip(peaks, props["prominences"]):
        if motion[j] > max_motion_ratio * np.nanmedian(motion):
            continue
        if best is None or prom > best[1]:
            best = (j, prom)
    if best is None:
        return None
    j = best[0]
    y0, y1, y2 = amax[j - 1], amax[j], amax[j + 1]
    denom = y0 - 2 * y1 + y2
    off = 0.5 * (y0 - y2) / denom if denom > 0 else 0.0
    return float(np.interp(j + np.clip(off, -0.5, 0.5), np.arange(len(s)), s))


def neck_depth(area: np.ndarray) -> float:
    """Deepest interior neck of the maximum-area profile, relative to its median.

    The largest prominence of a local minimum of ``max_t A(v, t)`` divided by
    the profile's median; 0 for a profile without interior minima (a plain
    taper). Defined for every embryo, so groups can be compared on it.
    """
    amax = np.nanmax(np.asarray(area, float), axis=1)
    _, props = find_peaks(-amax, prominence=0)
    if len(props["prominences"]) == 0:
        return 0.0
    return float(props["prominences"].max() / np.nanmedian(amax))
