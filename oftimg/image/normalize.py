"""Per-pixel views of (u, v, t) fields: normalisation over the cycle and phase maps."""
from __future__ import annotations

import numpy as np


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


def phase_maps(field: np.ndarray, period_ms: float) -> tuple[np.ndarray, np.ndarray]:
    """Time (ms since t = 0) of each pixel's maximum and minimum over the cycle."""
    n_t = field.shape[-1]
    filled = np.where(np.isfinite(field), field, np.nanmean(field))
    return (np.argmax(filled, axis=-1) * period_ms / n_t,
            np.argmin(filled, axis=-1) * period_ms / n_t)
