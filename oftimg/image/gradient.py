"""Derivative image of a (v, t) map: Sobel gradient, angle to hue, magnitude to value."""

from __future__ import annotations

import numpy as np
from matplotlib.colors import hsv_to_rgb
from scipy import ndimage


def sobel_gradient(image: np.ndarray, *, periodic_t: bool = True):
    """Per-pixel derivatives ``(d/dv, d/dt)`` of a ``(n_v, n_t)`` image.

    Sobel along each axis, wrapping along t when it is periodic (one cycle),
    nearest-value padding along v. In units of the image per pixel.
    """
    image = np.asarray(image, float)
    mode_t = "wrap" if periodic_t else "nearest"
    # The two separable 1-D parts of each Sobel kernel, each with its own
    # boundary: wrap along periodic t, nearest along v.
    diff, smooth = np.array([-1.0, 0.0, 1.0]) / 2.0, np.array([1.0, 2.0, 1.0]) / 4.0
    d_v = ndimage.correlate1d(image, diff, axis=0, mode="nearest")
    d_v = ndimage.correlate1d(d_v, smooth, axis=1, mode=mode_t)
    d_t = ndimage.correlate1d(image, diff, axis=1, mode=mode_t)
    d_t = ndimage.correlate1d(d_t, smooth, axis=0, mode="nearest")
    return d_v, d_t


def gradient_hsv(
    image: np.ndarray, *, periodic_t: bool = True, magnitude_percentile: float = 99.0
) -> np.ndarray:
    """RGB image ``(n_v, n_t, 3)`` in [0, 1]: gradient angle as hue, magnitude as value.

    Hue = (atan2(d/dv, d/dt) + pi) / 2 pi, so a pure increase in time is cyan
    (hue 0.5) and a pure decrease red (hue 0); value is the magnitude scaled
    by its ``magnitude_percentile``-th percentile (clipped to 1).
    """
    d_v, d_t = sobel_gradient(image, periodic_t=periodic_t)
    d_v, d_t = np.nan_to_num(d_v), np.nan_to_num(d_t)  # cells without data: black
    angle = np.arctan2(d_v, d_t)
    mag = np.hypot(d_v, d_t)
    top = np.percentile(mag, magnitude_percentile)
    value = np.clip(mag / top, 0, 1) if top > 0 else np.zeros_like(mag)
    hsv = np.stack([(angle + np.pi) / (2 * np.pi) % 1.0, np.ones_like(mag), value], axis=-1)
    return np.clip(hsv_to_rgb(hsv), 0.0, 1.0)


def colour_wheel(size: int = 101) -> np.ndarray:
    """The legend of :func:`gradient_hsv`: RGBA ``(size, size, 4)``, d/dt to the right,
    d/dv up."""
    y, x = np.mgrid[1 : -1 : size * 1j, -1 : 1 : size * 1j]
    r = np.hypot(x, y)
    hsv = np.stack(
        [(np.arctan2(y, x) + np.pi) / (2 * np.pi) % 1.0, np.ones_like(r), np.clip(r, 0, 1)], axis=-1
    )
    rgba = np.concatenate([hsv_to_rgb(hsv), (r <= 1)[..., None].astype(float)], axis=-1)
    return rgba


def area_rates(area_mm2: np.ndarray, frame_ms: float) -> tuple[float, float]:
    """Maximum expansion and contraction rates (mm^2/ms) from the Sobel d/dt."""
    _, d_t = sobel_gradient(area_mm2)
    rate = d_t / frame_ms
    return float(rate.max()), float(-rate.min())
