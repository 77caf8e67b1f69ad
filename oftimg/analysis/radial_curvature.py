"""Radial curvature read node by node: the scale each wall's sections are read at,
chosen from the noise the frames show (issue 84).

Each section's curvature is measured on its own polygon at several scales
(:func:`~oftimg.mesh.curvature.polygon_curvature`): a fine one keeps a corner or a notch,
a wide one averages a flat side's noise away. Which one a wall can afford is a question
of noise, and a single frame cannot tell its noise from its shape; the frames can: each
frame is meshed on its own, so each scale's frame-to-frame noise is measured row by row
(:func:`~oftimg.image.kymograph.map_noise_sd`) and carried through the smoothing in time.
Every scale is first averaged along the tube (:data:`ALONG_ROWS`: a corner runs along
the tube, its noise does not). The scale taken is the one of least estimated squared
error: its noise, plus its bias estimated from how far it lies from the finest scale
beyond what the two scales' noise explains. On the phantoms a choice node by node
(intersection of confidence intervals, or this estimate made locally) was no better
than this one per wall (docs/methods.md, "Radial curvature").
"""

from __future__ import annotations

import warnings

import numpy as np

from ..image.kymograph import RIDGE_SMOOTHING_LADDER_MS
from ..image.normalize import (
    FIELD_NOISE_TARGET,
    field_noise,
    pixel_noise,
    smooth_field_in_time,
    smoothing_kernel,
    time_flattening,
)
from ..mesh.curvature import CURVATURE_SCALES

# every scale's estimate is first averaged along the tube by a Gaussian of this many grid
# rows' SD: a corner or a notch runs along the tube, its noise does not, and the fine
# scales it needs are affordable only so
ALONG_ROWS = 2.0
# the scale taken where the noise cannot be measured (under 10 frames): an index into
# oftimg.mesh.curvature.CURVATURE_SCALES (2.8 vertex spacings: the usual choice)
UNMEASURED_SCALE = 2


def scale_chosen_curvature(
    K: np.ndarray,
    period_ms: float,
    smoothing_ms: float | str,
    vertex_spacing: np.ndarray,
    contour: np.ndarray,
) -> tuple[np.ndarray, dict, np.ndarray, np.ndarray]:
    """The radial curvature ``(n_u, n_v, n_t)`` float32 (1/mm) from its estimates at each
    scale ``K (n_scales, n_u, n_v, n_t)`` (finest first, each node the same tissue in
    every frame; ``vertex_spacing (n_v, n_t)`` mm each section polygon's, the scales'
    unit; ``contour (n_u, n_v, n_t, 3)`` mm its points): averaged along the tube,
    smoothed in time, at the scale of least
    estimated error (:func:`least_error_scale`); its noise
    (:func:`~oftimg.image.normalize.field_noise`'s entries, ``smoothing_ms`` and the
    ``scale`` index taken), each node's noise SD after the smoothing ``(n_u, n_v,
    n_t)`` (1/mm, its row's; NaN where not measurable) and what the scale may not
    resolve there ``(n_u, n_v, n_t)`` (1/mm: a Gaussian's flattening, s^2 / 2 times the
    curvature's second derivative along the contour, estimated from the field's second
    difference round the section, and the smoothing in time's likewise,
    :func:`~oftimg.image.normalize.time_flattening`; :func:`node_band_95`).

    ``smoothing_ms``: a Gaussian sigma in ms, or "auto": the smallest of
    ``RIDGE_SMOOTHING_LADDER_MS`` after which the field's noise share is at most
    ``FIELD_NOISE_TARGET`` (the largest when none is), as
    :func:`~oftimg.image.normalize.smooth_field` chooses.
    """
    n_t = K.shape[-1]
    K = along_tube(K, ALONG_ROWS)
    raw_sd = np.stack([_row_noise(k) for k in K])  # (n_scales, 1, n_v, 1)
    ladder = RIDGE_SMOOTHING_LADDER_MS if smoothing_ms == "auto" else (float(smoothing_ms),)
    for sigma in ladder:
        gain = float(np.sqrt((smoothing_kernel(n_t, period_ms, sigma) ** 2).sum()))
        smoothed = np.stack([smooth_field_in_time(k, period_ms, sigma) for k in K])
        sd = gain * raw_sd
        scale = least_error_scale(smoothed, sd)
        noise = field_noise(K[scale], smoothed[scale], period_ms, sigma)
        if not noise["noise_share"] > FIELD_NOISE_TARGET:  # NaN: not measurable
            break
    node_sd = np.broadcast_to(sd[scale], K.shape[1:])
    field = smoothed[scale]
    # what the scale may flatten: s^2 / 2 times the curvature's second derivative along
    # the contour, from the field's second difference round the section over the nodes'
    # spacing h (large at a corner or a notch, small on a flat side; a finer scale's
    # difference from it was mostly that scale's noise)
    node_step = np.linalg.norm(np.roll(contour, -1, axis=0) - contour, axis=-1).mean(axis=0)
    with np.errstate(invalid="ignore", divide="ignore"):
        ratio = (CURVATURE_SCALES[scale] * vertex_spacing / node_step) ** 2  # (n_v, n_t)
    second = np.abs(np.roll(field, -1, axis=0) - 2 * field + np.roll(field, 1, axis=0))
    # and what the smoothing in time flattens (a fold deepening fast at contraction)
    unresolved = np.hypot(0.5 * ratio[None] * second, time_flattening(field, period_ms, sigma))
    return (
        field.astype(np.float32),
        {**noise, "smoothing_ms": float(sigma), "scale": scale},
        node_sd.astype(np.float32),
        unresolved.astype(np.float32),
    )


def node_band_95(node_sd: np.ndarray, unresolved: np.ndarray, factor: float) -> np.ndarray:
    """Each node's 95 % band (half its width, the field's unit) ``1.96 factor sqrt(sd^2 +
    unresolved^2)``: the noise the frames show and what the scale may not resolve there
    (a corner flattened), widened by ``factor`` as calibrated on the zoo
    (:data:`~oftimg.analysis.uncertainty.NODE_BAND_FACTORS`)."""
    return (1.96 * factor * np.hypot(node_sd, unresolved)).astype(np.float32)


def least_error_scale(estimates: np.ndarray, sd: np.ndarray) -> int:
    """The index of the scale of least estimated mean squared error, of ``estimates
    (n_scales, ...)`` (finest first) with noise SDs ``sd`` (broadcasting): its noise
    variance plus its squared bias, the mean squared difference from the finest scale
    less both scales' noise variances (at least 0). :data:`UNMEASURED_SCALE` where the
    noise is not known."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # all-NaN rows
        noise = np.array([np.nanmean(np.broadcast_to(s, estimates.shape[1:]) ** 2) for s in sd])
        if not np.isfinite(noise).all():
            return min(UNMEASURED_SCALE, len(estimates) - 1)
        apart = np.array([np.nanmean((e - estimates[0]) ** 2) for e in estimates])
    bias = np.maximum(apart - noise - noise[0], 0.0)
    bias[0] = 0.0
    return int(np.argmin(bias + noise))


def along_tube(K: np.ndarray, rows: float) -> np.ndarray:
    """``K (..., n_v, n_t)`` averaged along the tube by a Gaussian of ``rows`` grid rows'
    SD (NaN cells left out of their neighbours' averages, and NaN still)."""
    from scipy.ndimage import gaussian_filter1d

    if rows <= 0:
        return K
    known = np.isfinite(K)
    if known.all():  # (the usual: one pass, in K's own precision)
        return gaussian_filter1d(K, rows, axis=-2, mode="nearest")
    total = gaussian_filter1d(np.where(known, K, 0.0), rows, axis=-2, mode="nearest")
    weight = gaussian_filter1d(known.astype(float), rows, axis=-2, mode="nearest")
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(known, total / weight, np.nan)


def _row_noise(k: np.ndarray) -> np.ndarray:
    """Each row's frame-to-frame noise SD of one scale's curvature ``k (n_u, n_v, n_t)``:
    the median over the row's nodes of each node's (one node's, from a few of its
    harmonics, is itself noisy); ``(1, n_v, 1)``, NaN under 10 frames."""
    n_u, n_v, n_t = k.shape
    whole, noise = pixel_noise(k)  # each node's, as field_noise measures it
    sd = np.full(n_u * n_v, np.nan)
    if noise is not None:
        sd[whole] = noise
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # a row without a value: NaN
        return np.nanmedian(sd.reshape(n_u, n_v), axis=0)[None, :, None]
