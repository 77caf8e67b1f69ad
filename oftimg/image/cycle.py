"""The cardiac cycle: time alignment at minimum volume, expansion timing, warps.

Pure functions on ``(..., n_t)`` arrays whose time axis is periodic.
"""

from __future__ import annotations

import numpy as np

from ..errors import InputError


def periodic_peak(y: np.ndarray, *, find: str = "max"):
    """Sub-frame index (in [0, n)) of the maximum or minimum of a periodic signal
    along the last axis of ``y (..., n)``: a float for one signal, ``(...)`` for many.

    Parabolic interpolation through the extreme sample and its two neighbours.
    """
    y = np.asarray(y, dtype=float)
    if find not in ("max", "min"):
        raise InputError(f"find must be 'max' or 'min', found {find!r}")
    if find == "min":
        y = -y
    n = y.shape[-1]
    k = np.nanargmax(y, axis=-1)

    def at(i):
        return np.take_along_axis(y, (i % n)[..., None], axis=-1)[..., 0]

    ym, y0, yp = at(k - 1), at(k), at(k + 1)
    denom = ym - 2 * y0 + yp
    with np.errstate(divide="ignore", invalid="ignore"):
        offset = np.where(denom < 0, 0.5 * (ym - yp) / denom, 0.0)
    peak = (k + np.clip(offset, -0.5, 0.5)) % n
    return float(peak) if peak.ndim == 0 else peak


def cycle_timing(volume: np.ndarray, period_ms: float) -> dict:
    """Expansion (minimum to maximum volume) and contraction of a cycle.

    ``volume (n_t,)`` mm^3 in input frame order. Returns the paper's Table 1
    quantities and ``t0_frame``, the input index of the minimum volume.
    """
    n = len(volume)
    t_min = periodic_peak(volume, find="min")
    t_max = periodic_peak(volume, find="max")
    expand = ((t_max - t_min) % n) / n
    return {
        "t0_frame": int(np.argmin(volume)),
        "t_min_frame": t_min,
        "t_max_frame": t_max,
        "expand_fraction": expand,
        "contract_fraction": 1.0 - expand,
        "expand_contract_ratio": expand / (1.0 - expand) if expand < 1 else np.inf,
        "expand_ms": expand * period_ms,
        "contract_ms": (1.0 - expand) * period_ms,
    }


def volume_change(volume_mm3: np.ndarray) -> float:
    """How much a volume changes over the cycle: (largest - smallest) / smallest of
    ``volume_mm3 (n_t,)``; NaN where the smallest is not positive (a layer between two
    walls that cross: its inside wall is larger than its outside one)."""
    volume_mm3 = np.asarray(volume_mm3, dtype=float)
    smallest = volume_mm3.min()
    return float((volume_mm3.max() - smallest) / smallest) if smallest > 0 else float("nan")


def wrap_step_ratio(volume: np.ndarray) -> float:
    """The step from the last frame back to the first over the largest step between
    consecutive frames, ``volume (n_t,)``. At most 1 when the frames sample one
    cycle (the wrap is one of its steps); most often well above 1 when they do
    not (part of a cycle, or more than one, unless its ends happen to meet) or
    an end frame is out of place."""
    v = np.asarray(volume, dtype=float)
    largest = np.abs(np.diff(v)).max()
    wrap = abs(v[0] - v[-1])
    return float(wrap / largest) if largest > 0 else (0.0 if wrap == 0 else np.inf)


def standout_frames(
    values: np.ndarray, *, periodic: bool = True, factor: float = 6.0
) -> np.ndarray:
    """Frames whose value stands out of the series ``values (n_t,)``, as one frame
    segmented wrongly does: it differs from the mean of its two neighbours by more
    than ``factor`` times the robust spread (1.4826 MAD) of that difference over
    all frames, and by more than its neighbours do. On a smooth cycle the largest
    difference is 1.4-1.5 spreads (the phantoms). Without ``periodic`` the end
    frames are not judged. Returns their indices."""
    v = np.asarray(values, dtype=float)
    r = v - 0.5 * (np.roll(v, 1) + np.roll(v, -1))
    judged = np.ones(len(v), dtype=bool)
    if not periodic:
        judged[[0, -1]] = False
    d = r[judged]
    spread = 1.4826 * np.median(np.abs(d - np.median(d))) if len(d) >= 3 else 0.0
    if spread == 0:
        return np.zeros(0, dtype=int)
    a = np.abs(r)
    peak = (a > np.roll(a, 1)) & (a > np.roll(a, -1))
    return np.nonzero(judged & peak & (a > factor * spread))[0]


def two_segment_warp(n_t: int, t_max: float) -> np.ndarray:
    """Input frame positions (after alignment) sampled so maximum expansion is at 0.5.

    Returns ``(n_t,)`` fractional frame indices: the first half of the output
    cycle samples [0, t_max), the second half [t_max, n_t). Use with
    :func:`resample_time`.
    """
    out = np.arange(n_t) / n_t
    return np.where(out < 0.5, out / 0.5 * t_max, t_max + (out - 0.5) / 0.5 * (n_t - t_max))


def resample_time(a: np.ndarray, positions: np.ndarray, *, axis: int = -1) -> np.ndarray:
    """Linear periodic interpolation of ``a`` along ``axis`` at fractional frames."""
    a = np.moveaxis(np.asarray(a), axis, -1)
    n = a.shape[-1]
    k = np.floor(positions).astype(int) % n
    f = positions - np.floor(positions)
    out = a[..., k] * (1 - f) + a[..., (k + 1) % n] * f
    return np.moveaxis(out, -1, axis)
