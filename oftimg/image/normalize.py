"""Per-pixel views of (u, v, t) fields: normalisation over the cycle and phase maps."""

from __future__ import annotations

import numpy as np

from .cycle import periodic_peak
from .kymograph import RIDGE_SMOOTHING_LADDER_MS, RIDGE_SMOOTHING_MS, map_noise_sd, smooth_in_time

# field smoothing "auto": the smallest sigma (ms) of the ridge's ladder after which at most
# FIELD_NOISE_TARGET of each pixel's variance over the cycle is noise (median pixel), the
# largest when none. On the phantoms (accuracy.py) it keeps 5 ms without noise; with 2 um of
# roughness 20 ms took the radial curvature from 10 to 6 % off (against the model at the
# contour points' positions averaged alike), for 0.5 points more without noise
FIELD_NOISE_TARGET = 0.10
# strain smoothing "auto" (:func:`oftimg.analysis.fields.smoothed_strain`): the ladder is
# climbed until the grid nodes' noise moves the strain energy by at most this share of its
# median size (summary.json: strain_noise, error_share), or stops before a sigma whose
# flattening of the energy would leave more error than the noise it removes
STRAIN_NOISE_TARGET = 0.07


def per_pixel_normalize(field: np.ndarray) -> np.ndarray:
    """Each (u, v) pixel scaled to [0, 1] by its own min and max over t (last axis).

    Pixels that do not change are 0.5; pixels without any value stay NaN.
    """
    has = np.isfinite(field).any(axis=-1, keepdims=True)
    safe = np.where(has, field, 0.0)
    with np.errstate(invalid="ignore"):
        lo = np.where(
            has,
            np.nanmin(np.where(np.isfinite(safe), safe, np.inf), axis=-1, keepdims=True),
            np.nan,
        )
        hi = np.where(
            has,
            np.nanmax(np.where(np.isfinite(safe), safe, -np.inf), axis=-1, keepdims=True),
            np.nan,
        )
    span = hi - lo
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(span > 0, (field - lo) / np.where(span > 0, span, 1), 0.5)


def phase_maps(
    field: np.ndarray, period_ms: float, *, smoothing_ms: float = RIDGE_SMOOTHING_MS
) -> tuple[np.ndarray, np.ndarray]:
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
    return (
        np.reshape(periodic_peak(filled, find="max") * to_ms, field.shape[:-1]),
        np.reshape(periodic_peak(filled, find="min") * to_ms, field.shape[:-1]),
    )


def smooth_field_in_time(field: np.ndarray, period_ms: float, sigma_ms: float) -> np.ndarray:
    """Each pixel of ``field (..., n_t)`` over one periodic cycle smoothed in time by a
    Gaussian of ``sigma_ms`` (ms; 0: unchanged), as :func:`~oftimg.image.kymograph.smooth_in_time`
    does a map's rows; same shape, NaN cells stay NaN."""
    n_t = field.shape[-1]
    return smooth_in_time(np.reshape(field, (-1, n_t)), period_ms, sigma_ms).reshape(field.shape)


def time_flattening(field: np.ndarray, period_ms: float, sigma_ms: float) -> np.ndarray:
    """What smoothing in time by a Gaussian of ``sigma_ms`` takes off each pixel of a
    (smoothed) ``field (..., n_t)`` over one periodic cycle, as estimated from it:
    sigma^2 / 2 times the size of its second derivative in time (a peak of the beat
    flattened; the field's unit, same shape; NaN stays NaN)."""
    n_t = field.shape[-1]
    step_ms = period_ms / n_t
    second = np.roll(field, -1, axis=-1) - 2 * field + np.roll(field, 1, axis=-1)
    return 0.5 * (sigma_ms / step_ms) ** 2 * np.abs(second)


def smoothing_kernel(n_t: int, period_ms: float, sigma_ms: float) -> np.ndarray:
    """The weights ``(n_t,)`` that :func:`smooth_field_in_time` gives frames 0, 1, ...
    (wrapping around) in frame 0's smoothed value: white noise of SD s comes out
    with SD ``s * sqrt(sum(weights ** 2))``."""
    impulse = np.zeros((1, n_t))
    impulse[0, 0] = 1.0
    return smooth_in_time(impulse, period_ms, sigma_ms)[0]


def field_noise(field: np.ndarray, smoothed: np.ndarray, period_ms: float, sigma_ms: float) -> dict:
    """How much of a field's change over the cycle is frame-to-frame noise.

    ``field (..., n_t)``, unsmoothed, over one periodic cycle, and ``smoothed``, the
    same in time by ``sigma_ms`` (:func:`smooth_field_in_time`). Each pixel's noise
    is measured as an area map row's is (:func:`~oftimg.image.kymograph.map_noise_sd`:
    the power of its harmonics above a quarter of the frame rate), then carried
    through the smoothing. Returns, over the pixels with a
    value in every frame (median), in the field's units: ``noise_sd`` (one frame),
    ``noise_sd_smoothed`` (after the smoothing), ``temporal_sd`` (each smoothed
    pixel's standard deviation over the cycle) and ``noise_share``, the share of
    that variance that is noise (0 to 1, flat pixels left out; above 0.25 the
    noise is over half the change the per-pixel views show). NaN for under 10 frames.
    """
    return _noise_after(*pixel_noise(field), smoothed, period_ms, sigma_ms)


def pixel_noise(field: np.ndarray) -> tuple[np.ndarray, np.ndarray | None]:
    """Which pixels of ``field (..., n_t)`` have a value in every frame (flat mask),
    and their frame-to-frame noise SD (None for under 10 frames)."""
    n_t = field.shape[-1]
    pixels = np.reshape(field, (-1, n_t)).astype(float)
    whole = np.isfinite(pixels).all(axis=1)
    if not whole.any() or n_t < 10:
        return whole, None
    return whole, map_noise_sd(pixels[whole])


def _noise_after(
    whole: np.ndarray,
    noise: np.ndarray | None,
    smoothed: np.ndarray,
    period_ms: float,
    sigma_ms: float,
) -> dict:
    """:func:`field_noise` from :func:`pixel_noise`'s pixels and noise."""
    keys = ("noise_sd", "noise_sd_smoothed", "temporal_sd", "noise_share")
    if noise is None:
        return dict.fromkeys(keys, float("nan"))
    n_t = smoothed.shape[-1]
    gain = float(np.sqrt((smoothing_kernel(n_t, period_ms, sigma_ms) ** 2).sum()))
    noise = gain * noise
    variance = np.reshape(smoothed, (-1, n_t))[whole].astype(float).var(axis=1)
    with np.errstate(invalid="ignore", divide="ignore"):
        share = np.clip(noise**2 / np.where(variance > 0, variance, np.nan), 0.0, 1.0)
    return {
        "noise_sd": float(np.median(noise) / gain),
        "noise_sd_smoothed": float(np.median(noise)),
        "temporal_sd": float(np.sqrt(np.median(variance))),
        "noise_share": float(np.nanmedian(share)) if np.isfinite(share).any() else float("nan"),
    }


def smooth_field(
    field: np.ndarray, period_ms: float, sigma_ms: float | str
) -> tuple[np.ndarray, dict]:
    """A field ``(..., n_t)`` over one periodic cycle smoothed in time, and its
    :func:`field_noise` with the sigma used (``smoothing_ms``).

    ``sigma_ms``: a Gaussian sigma in ms (0: none), or "auto": the smallest of
    ``RIDGE_SMOOTHING_LADDER_MS`` whose noise share is at most
    ``FIELD_NOISE_TARGET`` (the largest when none is; the first when the noise
    cannot be measured, as on under 10 frames).
    """
    ladder = RIDGE_SMOOTHING_LADDER_MS if sigma_ms == "auto" else (float(sigma_ms),)
    pixels = pixel_noise(field)  # measured once for every sigma
    for sigma in ladder:
        smoothed = smooth_field_in_time(field, period_ms, sigma)
        noise = _noise_after(*pixels, smoothed, period_ms, sigma)
        if not noise["noise_share"] > FIELD_NOISE_TARGET:  # NaN: not measurable
            break
    return smoothed, {**noise, "smoothing_ms": float(sigma)}
