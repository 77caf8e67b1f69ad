"""Per-pixel views of (u, v, t) fields: normalisation over the cycle and phase maps."""
from __future__ import annotations

import numpy as np

from ..cycle import periodic_peak
from .kymograph import RIDGE_SMOOTHING_MS, smooth_in_time


def per_pixel_normalize(field: np.ndarray) -> np.ndarray:
    """Each (u, v) pixel scaled to [0, 1] by its own min and max over t (last axis).

    Pixels that do not change are 0.5; pixels without any value stay NaN.
    """
    has = np.isfinite(field).any(axis=-1, keepdims=True)
    safe = np.where(has, field, 0.0)
    with np.errstate(invalid="ignore"):
        lo = np.where(has, np.nanmin(np.where(np.isfinite(safe), safe, np.inf), axis=-1,
                                     keepdims=True), np.nan)
        hi = np.where(has, np.nanmax(np.where(np.isfinite(safe), safe, -np.inf), axis=-1,
                                     keepdims=True), np.nan)
    span = hi - lo
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(span > 0, (field - lo) / np.where(span > 0, span, 1), 0.5)


def phase_maps(field: np.ndarray, period_ms: float, *,
               smoothing_ms: float = RIDGE_SMOOTHING_MS) -> tuple[np.ndarray, np.ndarray]:
    """Time (ms since t = 0) of each pixel's maximum and minimum over the cycle.

    ``field (..., n_t)``: each pixel is smoothed in time first (periodic Gaussian
    of ``smoothing_ms``, as the ridge is: each frame's field carries its own
    error), then its peak is placed between frames by a parabola. Returns two
    ``(...)`` arrays; a pixel without any value gives 0.
    """
    n_t = field.shape[-1]
    rows = smooth_in_time(np.reshape(field, (-1, n_t)), period_ms, smoothing_ms)
    filled = np.where(np.isfinite(rows), rows, np.nanmean(field))
    to_ms = period_ms / n_t
    return (np.reshape(periodic_peak(filled, find="max") * to_ms, field.shape[:-1]),
            np.reshape(periodic_peak(filled, find="min") * to_ms, field.shape[:-1]))
