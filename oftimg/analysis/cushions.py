"""The lumen's shape the endocardial cushions make: each section's ellipticity and its
major axis's direction, and where and when the lumen closes (issue 85).

The cushions make the lumen elliptical and, as the myocardium contracts, bulge until
they appose and close it: a primitive valve. These are (v, t) maps read from the
lumen's section contours and areas, pure functions on arrays.
"""

from __future__ import annotations

import warnings

import numpy as np


# a section whose minor axis is this share of its major or more is round: it has no major
# axis to speak of (its direction would turn with any rounding)
ROUND_ASPECT = 0.95


def section_ellipse(contour: np.ndarray, normal: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Aspect ratio and major-axis direction of each section, from its area's second
    moments (the ellipse with the same moments: exact for an ellipse, for any other
    section its equivalent ellipse).

    ``contour (n_u, ..., 3)`` mm: closed planar polygons, points in order round the
    section turning positively about ``normal (..., 3)`` (as u does), point 0 on the
    seam (u = 0). Returns ``aspect (...)``, minor over major axis in (0, 1], and
    ``major_deg (...)``, the major axis's direction in [0, 180) degrees from the seam's
    direction (section centroid to point 0), positive turning as u does. Both NaN
    where the polygon has no area (a closed lumen) or is not finite; the direction NaN
    too where the section is round (aspect over :data:`ROUND_ASPECT`).
    """
    C = np.asarray(contour, float)
    n = np.asarray(normal, float)
    n = n / np.linalg.norm(n, axis=-1, keepdims=True)
    rel = C - C.mean(axis=0)
    rel = rel - np.einsum("u...k,...k->u...", rel, n)[..., None] * n  # into the plane
    e1 = rel[0] / np.linalg.norm(rel[0], axis=-1, keepdims=True)
    e2 = np.cross(n, e1)
    x = np.einsum("u...k,...k->u...", rel, e1)
    y = np.einsum("u...k,...k->u...", rel, e2)
    x1, y1 = np.roll(x, -1, axis=0), np.roll(y, -1, axis=0)
    c = x * y1 - x1 * y  # Green's theorem, edge by edge
    with np.errstate(invalid="ignore", divide="ignore"):
        area = c.sum(axis=0) / 2
        mx = ((x + x1) * c).sum(axis=0) / (6 * area)
        my = ((y + y1) * c).sum(axis=0) / (6 * area)
        ixx = ((x * x + x * x1 + x1 * x1) * c).sum(axis=0) / (12 * area) - mx * mx
        iyy = ((y * y + y * y1 + y1 * y1) * c).sum(axis=0) / (12 * area) - my * my
        ixy = ((x * y1 + 2 * x * y + 2 * x1 * y1 + x1 * y) * c).sum(axis=0) / (24 * area) - mx * my
        half_diff = np.hypot((ixx - iyy) / 2, ixy)
        mid = (ixx + iyy) / 2
        aspect = np.sqrt(np.clip((mid - half_diff) / (mid + half_diff), 0, 1))
        major_deg = np.degrees(0.5 * np.arctan2(2 * ixy, ixx - iyy)) % 180.0
    bad = ~(np.isfinite(area) & (np.abs(area) > 0) & np.isfinite(aspect))
    round_ = bad | ~(aspect <= ROUND_ASPECT)
    return np.where(bad, np.nan, aspect), np.where(round_, np.nan, major_deg)


# a lumen section is closed when its area is at most this share of its row's largest over
# the cycle: the cushions apposed to within what a segmentation can hold open
LUMEN_CLOSED_SHARE = 0.02


def closed_map(area: np.ndarray, share: float = LUMEN_CLOSED_SHARE) -> np.ndarray:
    """``(n_v, n_t)`` bool: where the lumen's section ``area (n_v, n_t)`` mm^2 is at most
    ``share`` of its row's largest (or is NaN, no lumen found: a closure; telling a
    closure from a segmentation's gap is the caller's)."""
    a = np.asarray(area, float)
    with np.errstate(invalid="ignore"):
        largest = np.nanmax(np.where(np.isfinite(a), a, -np.inf), axis=1, keepdims=True)
        return ~(a > share * np.maximum(largest, 0.0))


def closure_times(
    area: np.ndarray, period_ms: float, share: float = LUMEN_CLOSED_SHARE
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per row, when the lumen closes and opens again, and for how much of the cycle.

    ``area (n_v, n_t)`` mm^2 over one cycle of frames (periodic). A row closes where its
    area falls through ``share`` of its largest and opens where it rises through it again,
    each time sub-frame by linear interpolation of the area between the two frames.
    A section closed to nothing has area 0 however long before the frame it closed: there
    the time is where the line through the open side's two frames reaches area 0 (the
    area of a slit closing falls to 0 at a steady pace): the apposition's own time.
    Returns ``close_ms (n_v,)`` and ``open_ms (n_v,)`` in [0, period) (of the longest
    closure when a row closes more than once; NaN in rows that never close or never
    open) and ``closed_share (n_v,)``, the share of the cycle closed (interpolated the
    same way; 1 for a row closed throughout).
    """
    a = np.asarray(area, float)
    n_v, n_t = a.shape
    largest = np.nanmax(np.where(np.isfinite(a), a, -np.inf), axis=1)
    level = share * np.maximum(largest, 0.0)
    x = np.where(np.isfinite(a), a, 0.0) - level[:, None]  # <= 0: closed
    frame_ms = period_ms / n_t
    close = np.full(n_v, np.nan)
    reopen = np.full(n_v, np.nan)
    closed_share = np.zeros(n_v)
    for j in range(n_v):
        shut = x[j] <= 0
        if shut.all():
            closed_share[j] = 1.0
            continue
        if not shut.any():
            continue
        downs = np.flatnonzero(~shut & np.roll(shut, -1))  # open at k, shut at k+1
        ups = np.flatnonzero(shut & ~np.roll(shut, -1))  # shut at k, open at k+1
        t_down = (downs + _crossing(x[j], level[j], downs, +1)) * frame_ms
        t_up = (ups + 1 - _crossing(x[j], level[j], (ups + 1) % n_t, -1)) * frame_ms
        # pair each closing with the next opening, keep the longest closure
        gaps = (t_up[None, :] - t_down[:, None]) % period_ms
        nxt = np.argmin(gaps, axis=1)
        lengths = gaps[np.arange(len(downs)), nxt]
        k = int(np.argmax(lengths))
        close[j], reopen[j] = t_down[k] % period_ms, t_up[nxt[k]] % period_ms
        closed_share[j] = lengths.sum() / period_ms
    return close, reopen, closed_share


# a slit under a voxel or two across is lost to the voxels before it closes: the closing
# is extrapolated this many frames at most past the last frame that shows it open
MAX_EXTRAPOLATED_FRAMES = 3


def _crossing(x: np.ndarray, level: float, k: np.ndarray, step: int) -> np.ndarray:
    """How far (frames, >= 0) from open frames ``k`` towards ``k + step`` the periodic
    series ``x (n_t,)`` (area less ``level``; > 0 open) closes: where it crosses 0, linear
    between the two frames (at most 1); or, where the closed frame sits at the floor (a
    section closed to nothing), where the line through ``k - step`` and ``k`` reaches
    area 0 (the apposition itself, not the level), up to :data:`MAX_EXTRAPOLATED_FRAMES`
    frames on while the frames there stay closed."""
    n_t = len(x)
    here, there, before = x[k], x[(k + step) % n_t], x[(k - step) % n_t]
    floor = x.min()
    # how many frames on from k stay at the floor: the extrapolation stays within them
    reach = np.ones(len(k))
    for i, kk in enumerate(np.atleast_1d(k)):
        n = 1
        while n < min(MAX_EXTRAPOLATED_FRAMES, n_t - 2) and x[(kk + (n + 1) * step) % n_t] <= floor:
            n += 1
        reach[i] = n
    with np.errstate(invalid="ignore", divide="ignore"):
        between = here / (here - there)
        extrapolated = np.minimum((here + level) / (before - here), reach)
    use = (there <= floor) & (before > here)
    return np.clip(np.where(use, extrapolated, np.clip(between, 0.0, 1.0)), 0.0, None)


# nodes within this angle (degrees) of the lumen's minor axis are at the cushions, within it
# of the major axis between them (an eighth of the way round each side)
CUSHION_SECTOR_DEG = 22.5


def node_angles(
    points: np.ndarray, centre: np.ndarray, normal: np.ndarray, toward: np.ndarray
) -> np.ndarray:
    """Angle (degrees in [0, 360)) of each of ``points (n_u, ..., 3)`` mm round
    ``centre (..., 3)`` in the plane of ``normal (..., 3)``, from the direction of
    ``toward (..., 3)`` (a point), turning positively about the normal."""
    n = normal / np.linalg.norm(normal, axis=-1, keepdims=True)
    ref = toward - centre
    e1 = ref - np.einsum("...k,...k->...", ref, n)[..., None] * n
    e1 = e1 / np.linalg.norm(e1, axis=-1, keepdims=True)
    e2 = np.cross(n, e1)
    rel = points - centre
    x = np.einsum("u...k,...k->u...", rel, e1)
    y = np.einsum("u...k,...k->u...", rel, e2)
    return np.degrees(np.arctan2(y, x)) % 360.0


def sector_means(
    values: np.ndarray,
    angle_deg: np.ndarray,
    axis_deg: np.ndarray,
    half_width_deg: float = CUSHION_SECTOR_DEG,
) -> np.ndarray:
    """Mean of ``values (n_u, ...)`` over the nodes whose ``angle_deg (n_u, ...)`` is within
    ``half_width_deg`` of the line at ``axis_deg (...)`` (either direction along it);
    NaN where none is or the axis is NaN."""
    off = np.abs((angle_deg - axis_deg + 90.0) % 180.0 - 90.0)
    inside = off <= half_width_deg
    total = np.where(inside, values, 0.0).sum(axis=0)
    count = inside.sum(axis=0)
    return np.where(count > 0, total / np.maximum(count, 1), np.nan)


def cushion_measures(
    area: np.ndarray,
    contour: np.ndarray,
    normal: np.ndarray,
    centroid: np.ndarray,
    s_mm: np.ndarray,
    period_ms: float,
    *,
    jelly: np.ndarray | None = None,
    inner_grid: np.ndarray | None = None,
) -> tuple[dict, dict]:
    """The lumen's closure and ellipticity over the cycle, as arrays and summary numbers.

    ``area (n_v, n_t)`` mm^2, ``contour (n_u, n_v, n_t, 3)`` mm, ``normal`` and ``centroid
    (n_v, n_t, 3)``: the lumen's sections (contour point 0 on the seam) and their planes;
    ``s_mm (n_v,)`` the rows' positions; with ``jelly (n_u, n_v, n_t)`` mm on ``inner_grid
    (n_u, n_v, n_t, 3)`` mm, also the cardiac jelly's thickness at the cushions (about
    the lumen's minor axis) and between them (about its major axis), ``(n_v, n_t)`` mm.

    Arrays: ``lumen_closed`` (:func:`closed_map`), ``lumen_aspect_ratio`` and
    ``lumen_major_axis_deg`` (:func:`section_ellipse`; NaN where closed),
    ``lumen_close_ms``, ``lumen_open_ms``, ``lumen_closed_share`` (:func:`closure_times`).
    Summary: the rows that close and their largest closed share, the closure's speed along
    the tube (the Theil-Sen slope of their close times, robust to the closed stretch's end
    rows, which close briefly and late; NaN unless 3 rows close), the
    median row's aspect ratio at its narrowest and widest (each row's 10th and 90th
    percentile over the cycle), and the median of the jelly at over between the cushions.
    """
    from ..image.kymograph import unwrap_robust

    closed = closed_map(area)
    aspect, major = section_ellipse(contour, normal)
    aspect, major = np.where(closed, np.nan, aspect), np.where(closed, np.nan, major)
    close_ms, open_ms, closed_share = closure_times(area, period_ms)
    arrays = {
        "lumen_closed": closed,
        "lumen_aspect_ratio": aspect.astype(np.float32),
        "lumen_major_axis_deg": major.astype(np.float32),
        "lumen_close_ms": close_ms,
        "lumen_open_ms": open_ms,
        "lumen_closed_share": closed_share,
    }
    closing = np.isfinite(close_ms)
    speed = np.nan
    if closing.sum() >= 3:  # Theil-Sen: the stretch's end rows close briefly
        from scipy.stats import theilslopes

        ridge = unwrap_robust(close_ms[closing], period_ms)
        slope = theilslopes(ridge, np.asarray(s_mm, float)[closing]).slope  # ms/mm
        speed = 1e3 / slope if slope != 0 else np.inf
    with warnings.catch_warnings():  # rows closed throughout: all NaN
        warnings.simplefilter("ignore", RuntimeWarning)
        narrow = np.nanpercentile(aspect, 10, axis=1)
        wide = np.nanpercentile(aspect, 90, axis=1)
    summary = {
        "closed_rows": int((closed_share > 0).sum()),
        "closed_share_max": float(closed_share.max()) if len(closed_share) else 0.0,
        "closure_speed_mm_s": float(speed),
        "aspect_ratio_narrowest": _nanmedian(narrow),
        "aspect_ratio_widest": _nanmedian(wide),
    }
    if jelly is not None and inner_grid is not None:
        angle = node_angles(inner_grid, centroid, normal, contour[0])
        minor = (major + 90.0) % 180.0
        at = sector_means(jelly, angle, minor)
        between = sector_means(jelly, angle, major)
        arrays["jelly_at_cushions_mm"] = at.astype(np.float32)
        arrays["jelly_between_cushions_mm"] = between.astype(np.float32)
        with np.errstate(invalid="ignore", divide="ignore"):
            summary["jelly_at_over_between_cushions"] = _nanmedian(at / between)
    return arrays, summary


def _nanmedian(x: np.ndarray) -> float:
    """The median of the finite values, NaN if there is none."""
    x = np.asarray(x, float)
    x = x[np.isfinite(x)]
    return float(np.median(x)) if len(x) else float("nan")
