"""(v, t) maps: ridge of maximum area, peristaltic wave speed, knee fit.

Functions of ``(n_v, n_t)`` arrays (rows along the tube from the inlet, columns
one periodic cycle), so a kymograph from anywhere can be fed in.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass
from statistics import median

import numpy as np
from scipy.ndimage import gaussian_filter1d

from .cycle import periodic_peak
from ..errors import InputError

FLAT_REL = 1e-3  # rows whose relative temporal range is below this have no ridge
# Gaussian sigma (ms) of the smoothing in time before each row's maximum is found: on the
# phantoms (195 frames of 1.85 ms, each meshed independently) it takes the ridge's error
# from 1.2 to 0.2 ms RMS and the worst local speed from 317 % to 5 % off; the cost is a
# shift of the ridge by ~1.7 ms where the area's peak is asymmetric (the same shift in every
# row whose peak has the same shape, so speeds keep it out). See docs/accuracy.md.
RIDGE_SMOOTHING_MS = 5.0
# ridge smoothing "auto": the smallest sigma (ms) of this ladder at which the local speeds'
# noise spread is at most AUTO_SPREAD_TARGET of them (median over the rows). On the 6 + 6
# phantoms it picked 5 ms without noise and 14-20 ms with 5 um of roughness, where the
# local speeds came out 4-10 % off instead of 15-31 % (docs/accuracy.md)
RIDGE_SMOOTHING_LADDER_MS = (5.0, 7.0, 10.0, 14.0, 20.0)
AUTO_SPREAD_TARGET = 0.10
# copies of a map, each with its own frame-to-frame noise drawn again, from which the
# spread of the wave speeds is measured (:func:`speed_spread`); their seed
SPREAD_DRAWS = 100
SPREAD_SEED = 0
# a spread is given only when this share of the draws gives a finite value
SPREAD_FINITE_SHARE = 0.9
# a speed is resolved when the spread of its inverse (the ridge's slope) over the draws is
# under this share of it: within one SD the wave neither stands still nor turns back
RESOLVED_SLOPE_SHARE = 0.5
# a row's local speed enters the speed statistics (Table 1's min, max, mean, std and the
# median) when its noise spread is finite and under this share of it: at a band's neck,
# where the ridge is not resolved, a row gave -29508 mm/s and the mean -584 mm/s
RESOLVED_ROW_SHARE = 0.5
# a row whose area swings over the cycle by under this share of the median row's swing
# (relative to its mean) barely moves: its time of maximum area is not the wave's
# (a band's neck: up to 15 ms off on the banded phantoms, error the noise spread cannot
# see); the speeds bridge it with the ridge's line between the nearest moving rows
STILL_ROW_SHARE = 0.7
# a ridge whose least-squares slope t(s) along the tube is within this many of its noise
# SDs of 0, or crosses the whole tube in under SYNCHRONOUS_FRAMES of a frame interval, is a
# synchronous contraction: no wave, no speeds (a chamber that contracts at once gave
# -338 +- 190 mm/s before this check)
SYNCHRONOUS_SDS = 2.0
SYNCHRONOUS_FRAMES = 0.25
# a map whose median row swings over the cycle by under this share of its largest area
# holds no wave to time: a helical wave on the wall moves the ring's parts in turn and
# leaves each section's area all but constant (0.6 % on a helical phantom, whose ridge
# gave -8.7 mm/s and a 58 % expansion share); the wave on the wall is timed instead
AREA_WAVE_MIN_SWING = 0.02


def _check_map(area: np.ndarray, s_mm: np.ndarray | None = None) -> np.ndarray:
    area = np.asarray(area, dtype=float)
    if area.ndim != 2 or area.shape[1] < 3:
        raise InputError(f"a (v, t) map must be 2-D with at least 3 frames, found {area.shape}")
    if s_mm is not None and np.shape(s_mm) != (area.shape[0],):
        raise InputError(
            f"s_mm must have one value per row ({area.shape[0]}), found shape {np.shape(s_mm)}"
        )
    return area


def flat_rows(area: np.ndarray) -> np.ndarray:
    """Rows that do not change over time (or hold NaN): no ridge there."""
    area = _check_map(area)
    scale = np.nanmax(np.abs(area), axis=1)
    rng = np.nanmax(area, axis=1) - np.nanmin(area, axis=1)
    return ~np.isfinite(rng) | (rng <= FLAT_REL * np.where(scale > 0, scale, 1.0))


def smooth_in_time(area: np.ndarray, period_ms: float, sigma_ms: float) -> np.ndarray:
    """Each row of a ``(n_v, n_t)`` map over one periodic cycle smoothed by a Gaussian
    of ``sigma_ms`` (ms), wrapping around the cycle. NaN cells stay NaN and do not
    count in their neighbours' means."""
    area = _check_map(area)
    if not np.isfinite(sigma_ms) or sigma_ms < 0:
        raise InputError(f"the smoothing sigma must be a number >= 0 ms, found {sigma_ms}")
    sigma = sigma_ms * area.shape[1] / period_ms  # frames
    if sigma == 0:
        return area
    ok = np.isfinite(area)
    if ok.all():  # the weights below would be 1 (to 1e-16): half the work
        return gaussian_filter1d(area, sigma, axis=1, mode="wrap")
    total = gaussian_filter1d(np.where(ok, area, 0.0), sigma, axis=1, mode="wrap")
    weight = gaussian_filter1d(ok.astype(float), sigma, axis=1, mode="wrap")
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(ok, total / weight, np.nan)


def _harmonic_power(area: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Power of each row's harmonics over the cycle, ``(n_v, n_t // 2 + 1)``, and the
    harmonic numbers ``(n_t // 2 + 1,)``."""
    power = np.abs(np.fft.rfft(area, axis=1)) ** 2
    return power, np.arange(power.shape[1])


def map_noise_sd(area: np.ndarray) -> np.ndarray:
    """Standard deviation of each row's frame-to-frame noise, in the map's units: ``(n_v,)``.

    ``area (n_v, n_t)`` over one periodic cycle. White noise spreads its power
    evenly over the harmonics of the cycle; a beat's power is in its first few.
    So the noise variance is the mean power of the harmonics above n_t / 4
    (and at least the 5th), what is left of frames segmented and meshed one by
    one (the phantoms' true areas have no power there: all of it is error).
    Noise correlated from frame to frame (a segmentation smoothed in time) is
    underestimated; error that does not change from frame to frame is not in it.
    NaN for a row with NaN, and for maps of under 10 frames (no such harmonics).
    """
    area = _check_map(area)
    n_t = area.shape[1]
    power, k = _harmonic_power(area)
    high = (k > n_t / 4) & (k >= 5)
    if not high.any():
        return np.full(area.shape[0], np.nan)
    both_sides = np.where(2 * k == n_t, 1.0, 2.0)[high]  # Nyquist counted once
    mean_power = (both_sides * power[:, high]).sum(axis=1) / both_sides.sum()
    return np.sqrt(mean_power / n_t)


def noise_colour(area: np.ndarray) -> float:
    """How much more power a map has in the lower half of its high harmonics (n_t / 4
    to 3 n_t / 8) than in the upper half (to n_t / 2), all rows together.

    About 1 for white noise, as :func:`map_noise_sd` assumes; above 1 when the
    noise is correlated from frame to frame (a segmentation smoothed in time), so
    that the noise near the beat's own frequencies, which moves the ridge, is more
    than :func:`map_noise_sd` measures: 30 for noise smoothed over one frame, but
    only 1.4 for AR(1) noise with 0.5 from frame to frame, whose spreads come out
    2.5-4 times too small (docs/accuracy.md). NaN for under 16 frames or NaN cells.
    """
    area = _check_map(area)
    n_t = area.shape[1]
    power, k = _harmonic_power(area)
    lower = (k > n_t / 4) & (k <= 3 * n_t / 8)
    upper = (k > 3 * n_t / 8) & (2 * k < n_t)  # Nyquist left out
    if n_t < 16 or not lower.any() or not upper.any():
        return float("nan")
    return float(power[:, lower].mean() / power[:, upper].mean())


def ridge_times(
    area: np.ndarray, period_ms: float, *, smoothing_ms: float = RIDGE_SMOOTHING_MS
) -> np.ndarray:
    """Time (ms) of each row's maximum, sub-frame, unwrapped along v: ``(n_v,)``.

    Each row is first smoothed in time (:func:`smooth_in_time`, Gaussian sigma
    ``smoothing_ms``; 0 for none), as its maximum is flat over several frames and
    each frame's area carries its own segmentation and meshing error. Then
    parabolic interpolation of the periodic peak; unwrapping keeps each row
    within half a period of the median of the five rows before it, so that
    one or two rows whose maximum is ill-defined (a neck that barely moves) cannot
    shift the whole rest of the ridge by a period. NaN (with a warning) for
    rows that do not change over time.
    """
    area = _check_map(area)
    n_t = area.shape[1]
    flat = flat_rows(area)
    smooth = smooth_in_time(area, period_ms, smoothing_ms)
    t = np.full(area.shape[0], np.nan)
    if not flat.all():
        t[~flat] = periodic_peak(smooth[~flat], find="max") * period_ms / n_t
    if flat.any():
        warnings.warn(
            f"{int(flat.sum())} of {len(flat)} rows of the map do not change over "
            "time: no ridge there (left blank)",
            RuntimeWarning,
            stacklevel=2,
        )
    ok = np.isfinite(t)
    if ok.sum() > 1:
        t[ok] = unwrap_robust(t[ok], period_ms)
        # start the unwrapped ridge in [0, period)
        t[ok] -= period_ms * np.floor(t[ok][0] / period_ms)
    return t


def still_rows(area: np.ndarray) -> np.ndarray:
    """Rows ``(n_v,)`` bool of ``area (n_v, n_t)`` that barely move: their swing over
    the cycle, relative to their mean, under :data:`STILL_ROW_SHARE` of the median
    row's."""
    area = _check_map(area)
    with np.errstate(divide="ignore", invalid="ignore"):
        swing = np.ptp(area, axis=1) / np.abs(np.mean(area, axis=1))
    ok = np.isfinite(swing)
    if not ok.any():
        return np.zeros(area.shape[0], bool)
    return ok & (swing < STILL_ROW_SHARE * np.median(swing[ok]))


def bridged_ridge(ridge_t_ms: np.ndarray, s_mm: np.ndarray, still: np.ndarray) -> np.ndarray:
    """The ridge ``(n_v,)`` ms with its ``still`` rows (and rows without a ridge)
    between moving rows replaced by the straight line between the nearest moving rows
    on either side (the wave taken to cross a neck at its neighbours' pace); still
    rows at an end of the tube, with no moving row beyond them, NaN."""
    t = np.asarray(ridge_t_ms, float).copy()
    s = np.asarray(s_mm, float)
    moving = np.isfinite(t) & ~np.asarray(still, bool)
    if moving.sum() < 2:
        return np.where(moving, t, np.nan)
    first, last = np.flatnonzero(moving)[[0, -1]]
    inside = np.zeros(len(t), bool)
    inside[first : last + 1] = True
    gap = ~moving & inside
    t[gap] = np.interp(s[gap], s[moving], t[moving])
    t[~moving & ~inside] = np.nan
    return t


def unwrap_robust(t: np.ndarray, period: float, *, memory: int = 5) -> np.ndarray:
    """Unwrap periodic times ``t (n,)`` (finite): each within half a period of the
    median of the ``memory`` values before it (``np.unwrap`` uses only the one before)."""
    out = np.array(t, dtype=float).tolist()  # Python floats: a median of 5 is 1 us
    for k in range(1, len(out)):
        ref = median(out[max(0, k - memory) : k])
        out[k] += period * round((ref - out[k]) / period)
    return np.array(out)


def local_speed(s_mm: np.ndarray, ridge_t_ms: np.ndarray, *, half_window: int = 3) -> np.ndarray:
    """Local wave speed ds/dt (mm/s) along the ridge, ``(n_v,)``.

    Least-squares slope of t(s) over ``2 half_window + 1`` rows (fewer at the
    ends), so a single noisy pixel cannot make a wild value. Negative where
    the wave runs backwards; NaN where the ridge is undefined.
    """
    s = np.asarray(s_mm, float)
    t = np.asarray(ridge_t_ms, float)
    ok = np.isfinite(t)
    if not ok.any():
        return np.full(len(s), np.nan)
    # window sums of 1, s, t, s^2, s t over the rows with a ridge, from cumulative sums
    # (centred first: the slope's sums then lose no digits)
    ds = np.where(ok, s - s[ok].mean(), 0.0)
    dt = np.where(ok, t - t[ok].mean(), 0.0)
    j = np.arange(len(s))
    lo, hi = np.maximum(0, j - half_window), np.minimum(len(s), j + half_window + 1)

    def window_sum(x):
        c = np.concatenate([[0.0], np.cumsum(x)])
        return c[hi] - c[lo]

    n, s1, t1 = window_sum(ok.astype(float)), window_sum(ds), window_sum(dt)
    with np.errstate(divide="ignore", invalid="ignore"):
        sxx = window_sum(ds * ds) - s1 * s1 / n
        slope = (window_sum(ds * dt) - s1 * t1 / n) / sxx  # ms per mm
        speed = np.where(slope != 0, 1e3 / slope, np.inf)
    fitted = (n >= 3) & (sxx > 1e-12 * window_sum(ds * ds))
    return np.where(fitted, speed, np.nan)


def cycle_speed(s_mm: np.ndarray, ridge_t_ms: np.ndarray, *, end_rows: int = 2) -> float:
    """End-to-end wave speed (mm/s): first to last row of the ridge.

    Each end's time is the mean of ``end_rows`` rows at that end.
    """
    s = np.asarray(s_mm, float)
    t = np.asarray(ridge_t_ms, float)
    ok = np.isfinite(t)
    if ok.sum() < 2 * end_rows:
        return float("nan")
    s, t = s[ok], t[ok]
    dt = t[-end_rows:].mean() - t[:end_rows].mean()
    ds = s[-end_rows:].mean() - s[:end_rows].mean()
    return float(1e3 * ds / dt) if dt != 0 else float("inf")


@dataclass(frozen=True)
class KneeFit:
    """Continuous two-segment line t(s): slopes as speeds and the knee (mm, and the
    line's time there, ms)."""

    knee_mm: float
    knee_t_ms: float
    speed_proximal_mm_s: float
    speed_distal_mm_s: float
    rms_ms: float


def two_segment_fit(
    s_mm: np.ndarray, ridge_t_ms: np.ndarray, *, min_rows: int = 3, refine: int = 10
) -> KneeFit:
    """Fit ``t = a + b s + c max(0, s - s_k)`` by least squares over the knee s_k.

    The knee is searched on a grid ``refine`` times finer than the rows, with
    at least ``min_rows`` rows on each side.
    """
    s = np.asarray(s_mm, float)
    t = np.asarray(ridge_t_ms, float)
    ok = np.isfinite(t)
    s, t = s[ok], t[ok]
    if len(s) < 2 * min_rows + 1:
        return KneeFit(np.nan, np.nan, np.nan, np.nan, np.nan)
    knees = np.linspace(s[min_rows - 1], s[-min_rows], refine * (len(s) - 2 * min_rows) + 1)
    # every knee's design matrix (n_knee, n_row, 3), solved at once by the normal equations
    ramp = np.maximum(0.0, s[None, :] - knees[:, None])
    A = np.stack(np.broadcast_arrays(1.0, s[None, :], ramp), axis=-1)
    At = np.swapaxes(A, 1, 2)
    coefs = np.linalg.solve(At @ A, (At @ t)[..., None])[..., 0]
    sses = (((A @ coefs[..., None])[..., 0] - t) ** 2).sum(axis=1)
    best = int(np.argmin(sses))
    sse, k, (a, b, c) = float(sses[best]), float(knees[best]), coefs[best]

    def to_speed(slope):
        return float(1e3 / slope) if slope != 0 else np.inf

    return KneeFit(
        knee_mm=float(k),
        knee_t_ms=float(a + b * k),
        speed_proximal_mm_s=to_speed(b),
        speed_distal_mm_s=to_speed(b + c),
        rms_ms=float(np.sqrt(sse / len(s))),
    )


def wave_speed_summary(
    speed_mm_s: np.ndarray, cycle_mm_s: float, *, rows: np.ndarray | None = None
) -> dict:
    """``min, max, mean, std`` (the paper's Table 1) and ``median`` of the local
    speeds ``(n_v,)`` mm/s over ``rows`` (a boolean mask ``(n_v,)``, default every
    finite one: :func:`resolved_rows` keeps those the map's noise resolves),
    ``rows_used`` (how many), and ``cycle`` (mm/s)."""
    v = np.asarray(speed_mm_s, float)
    keep = np.isfinite(v) if rows is None else np.asarray(rows, bool) & np.isfinite(v)
    v = v[keep]
    if len(v) == 0:
        return {
            "min": np.nan,
            "max": np.nan,
            "mean": np.nan,
            "std": np.nan,
            "median": np.nan,
            "rows_used": 0,
            "cycle": float(cycle_mm_s),
        }
    return {
        "min": float(v.min()),
        "max": float(v.max()),
        "mean": float(v.mean()),
        "std": float(v.std()),
        "median": float(np.median(v)),
        "rows_used": int(len(v)),
        "cycle": float(cycle_mm_s),
    }


def resolved_rows(local_mm_s: np.ndarray, local_sd_mm_s: np.ndarray) -> np.ndarray:
    """Rows ``(n_v,)`` bool whose local speed is resolved: its noise spread finite and
    under :data:`RESOLVED_ROW_SHARE` of it."""
    local, sd = np.asarray(local_mm_s, float), np.asarray(local_sd_mm_s, float)
    with np.errstate(invalid="ignore"):
        return np.isfinite(local) & np.isfinite(sd) & (sd < RESOLVED_ROW_SHARE * np.abs(local))


def wave_speeds(s_mm: np.ndarray, ridge_t_ms: np.ndarray) -> dict:
    """Every wave speed (mm/s) from one ridge: ``local (n_v,)``, the
    :func:`wave_speed_summary` of every row with a speed and the cycle, and the
    :func:`two_segment_fit`."""
    local = local_speed(s_mm, ridge_t_ms)
    return {
        "local": local,
        "summary": wave_speed_summary(local, cycle_speed(s_mm, ridge_t_ms)),
        "knee": two_segment_fit(s_mm, ridge_t_ms),
    }


def no_wave(n_v: int) -> dict:
    """:func:`wave_speeds` of a map without a wave: every speed NaN."""
    return {
        "local": np.full(n_v, np.nan),
        "summary": wave_speed_summary(np.full(n_v, np.nan), float("nan")),
        "knee": KneeFit(np.nan, np.nan, np.nan, np.nan, np.nan),
    }


def _speed_values(speeds: dict, rows: np.ndarray | None = None) -> dict:
    """The scalar speeds of :func:`wave_speeds`, by summary key, the statistics of the
    local speeds over ``rows`` (default: all)."""
    summary = wave_speed_summary(speeds["local"], speeds["summary"]["cycle"], rows=rows)
    out = {k: v for k, v in summary.items() if k not in ("std", "rows_used")}
    out["proximal"] = speeds["knee"].speed_proximal_mm_s
    out["distal"] = speeds["knee"].speed_distal_mm_s
    return out


def ridge_slope(s_mm: np.ndarray, ridge_t_ms: np.ndarray) -> float:
    """Least-squares slope (ms/mm) of the ridge's time along the tube over its finite
    rows; NaN for fewer than 3."""
    ok = np.isfinite(ridge_t_ms)
    if ok.sum() < 3:
        return float("nan")
    s = np.asarray(s_mm, float)[ok]
    t = np.asarray(ridge_t_ms, float)[ok]
    ds = s - s.mean()
    return float((ds * (t - t.mean())).sum() / (ds * ds).sum())


def area_swing(area: np.ndarray) -> float:
    """How much a ``(n_v, n_t)`` map's rows change over the cycle: the median row's
    (largest - smallest) / largest (0 for a map without finite rows)."""
    a = np.asarray(area, float)
    with np.errstate(invalid="ignore", divide="ignore"), warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # all-NaN rows
        swing = (np.nanmax(a, axis=1) - np.nanmin(a, axis=1)) / np.nanmax(a, axis=1)
    swing = swing[np.isfinite(swing)]
    return float(np.median(swing)) if swing.size else 0.0


def is_synchronous(slope: float, slope_sd: float, length_mm: float, frame_ms: float) -> bool:
    """Whether a ridge of ``slope`` (ms/mm) with noise ``slope_sd`` is consistent with
    no wave at all: within :data:`SYNCHRONOUS_SDS` SDs of 0, or the whole
    ``length_mm`` crossed in under :data:`SYNCHRONOUS_FRAMES` of ``frame_ms``."""
    if not np.isfinite(slope):
        return False
    return bool(
        abs(slope) * length_mm < SYNCHRONOUS_FRAMES * frame_ms
        or (np.isfinite(slope_sd) and abs(slope) < SYNCHRONOUS_SDS * slope_sd)
    )


def _spread(draws: np.ndarray) -> np.ndarray:
    """Half the 16th-84th percentile range over axis 0 (the SD of a normal
    distribution, robust to a few wild draws); NaN where under
    :data:`SPREAD_FINITE_SHARE` of the draws are finite."""
    finite = np.isfinite(draws)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # all-NaN columns: NaN
        lo, hi = np.nanpercentile(np.where(finite, draws, np.nan), [16, 84], axis=0)
    return np.where(finite.mean(axis=0) >= SPREAD_FINITE_SHARE, (hi - lo) / 2, np.nan)


def _resolved_spread(draws: np.ndarray, speed: np.ndarray) -> np.ndarray:
    """:func:`_spread` of speed ``draws (n_draws, ...)`` around the measured ``speed
    (...)``, NaN where the speed is not resolved: the spread of the inverse speeds
    (slopes; an infinite speed is a slope of 0) is over :data:`RESOLVED_SLOPE_SHARE`
    of the measured one's. A spike where the ridge is nearly flat along the tube
    (1000 mm/s, say) has a small spread in mm/s but not in slope."""
    with np.errstate(divide="ignore"):
        slope, slope_draws = 1.0 / np.asarray(speed, float), 1.0 / draws
    resolved = _spread(slope_draws) < RESOLVED_SLOPE_SHARE * np.abs(slope)
    return np.where(resolved, _spread(draws), np.nan)


def speed_spread(
    area: np.ndarray,
    s_mm: np.ndarray,
    period_ms: float,
    *,
    smoothing_ms: float = RIDGE_SMOOTHING_MS,
    draws: int = SPREAD_DRAWS,
    seed: int = SPREAD_SEED,
) -> dict:
    """How far the ridge and the wave speeds move with the map's own noise.

    ``draws`` copies of ``area (n_v, n_t)`` each get white Gaussian noise of
    each row's :func:`map_noise_sd` added; each copy's ridge
    (:func:`ridge_times`) and :func:`wave_speeds` are found as the map's own.
    Returns the map's own ``ridge`` and ``measured`` :func:`wave_speeds`, its
    ``noise_sd (n_v,)``, and the spread (:func:`_spread`: the SD of a normal
    distribution) over the draws of ``ridge_t_ms (n_v,)`` ms,
    ``local_speed_mm_s (n_v,)`` mm/s and ``speeds``, a dict of each scalar speed
    (min, max, mean, median, cycle, proximal, distal) mm/s. A speed that is
    not resolved (:func:`_resolved_spread`: the noise could stop or reverse the
    wave there) has a spread of NaN. Errors that do not change from frame to
    frame (a shape the grid follows badly) are not in the spread. ``synchronous``:
    the ridge's slope along the tube (``ridge_slope_ms_per_mm``, its spread
    ``ridge_slope_noise_sd_ms_per_mm``) is consistent with no wave
    (:func:`is_synchronous`); every measured speed is then NaN, as where the map's
    ``swing`` (:func:`area_swing`) is under :data:`AREA_WAVE_MIN_SWING` (``no_area_wave``:
    no wave of the areas to time). The speeds are
    measured on the ridge with its ``still_rows (n_v,)`` (:func:`still_rows`: a neck
    that barely moves) bridged (:func:`bridged_ridge`); ``ridge`` is the map's own.
    ``resolved_rows
    (n_v,)`` bool: the rows whose local speed the noise resolves
    (:func:`resolved_rows`; every row with a speed when the noise cannot be
    measured), over which the measured summary and every draw's are taken.
    """
    area = _check_map(area, s_mm)
    if int(draws) != draws or draws < 10:
        raise InputError(f"draws must be an integer >= 10, found {draws}")
    noise = map_noise_sd(area)
    ridge = ridge_times(area, period_ms, smoothing_ms=smoothing_ms)
    still = still_rows(area)
    rng = np.random.default_rng(seed)
    ridges, draws_speeds, slopes = [], [], []
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # the map's flat rows: said once
        for _ in range(int(draws)):
            noisy = area + rng.standard_normal(area.shape) * noise[:, None]
            r = ridge_times(noisy, period_ms, smoothing_ms=smoothing_ms)
            ridges.append(ridge + (r - ridge + period_ms / 2) % period_ms - period_ms / 2)
            draws_speeds.append(wave_speeds(s_mm, bridged_ridge(r, s_mm, still)))
            slopes.append(ridge_slope(s_mm, r))
    measured = wave_speeds(s_mm, bridged_ridge(ridge, s_mm, still))
    slope = ridge_slope(s_mm, ridge)
    slope_sd = float(_spread(np.array(slopes)[:, None])[0])
    s = np.asarray(s_mm, float)
    synchronous = is_synchronous(
        slope, slope_sd, float(s.max() - s.min()), period_ms / area.shape[1]
    )
    swing = area_swing(area)
    no_area_wave = swing < AREA_WAVE_MIN_SWING
    if synchronous or no_area_wave:
        measured = no_wave(len(s))
    local_sd = _resolved_spread(np.array([d["local"] for d in draws_speeds]), measured["local"])
    # the statistics over the rows the noise resolves (all with a speed when the noise
    # cannot be measured), in the measured map and in every draw alike
    rows = (
        resolved_rows(measured["local"], local_sd)
        if np.isfinite(noise).any()
        else np.isfinite(measured["local"])
    )
    measured["summary"] = wave_speed_summary(
        measured["local"], measured["summary"]["cycle"], rows=rows
    )
    scalars = _speed_values(measured, rows)
    values = np.array([list(_speed_values(d, rows).values()) for d in draws_speeds])
    return {
        "ridge": ridge,
        "measured": measured,
        "synchronous": synchronous,
        "swing": swing,
        "no_area_wave": no_area_wave,
        "ridge_slope_ms_per_mm": slope,
        "ridge_slope_noise_sd_ms_per_mm": slope_sd,
        "noise_sd": noise,
        "ridge_t_ms": _spread(np.array(ridges)),
        "local_speed_mm_s": local_sd,
        "resolved_rows": rows,
        "still_rows": still,
        "speeds": dict(
            zip(scalars, _resolved_spread(values, np.array(list(scalars.values()))).tolist())
        ),
    }


def auto_ridge_smoothing(
    area: np.ndarray,
    s_mm: np.ndarray,
    period_ms: float,
    *,
    ladder=RIDGE_SMOOTHING_LADDER_MS,
    target: float = AUTO_SPREAD_TARGET,
) -> tuple[float, dict]:
    """The ridge smoothing sigma (ms) a map needs, and :func:`speed_spread` with it.

    The smallest sigma of ``ladder`` at which the median over the rows of each
    local speed's noise spread over its size is at most ``target`` (a row not
    resolved counts as spread without bound); the largest when none is. The first
    when the map's noise cannot be measured. More smoothing moves the ridge later
    where the beat's peak is asymmetric (about 0.65 ms per ms of sigma when
    expansion takes 30 % of the cycle, 0.3 when 40 %), which speeds only see
    where that asymmetry changes along the tube.
    """
    for sigma in ladder:
        spread = speed_spread(area, s_mm, period_ms, smoothing_ms=sigma)
        if not np.isfinite(spread["noise_sd"]).any():
            return float(ladder[0]), spread
        if spread["synchronous"] or spread["no_area_wave"]:  # no wave: no speeds to resolve
            break
        with np.errstate(divide="ignore", invalid="ignore"):
            relative = spread["local_speed_mm_s"] / np.abs(spread["measured"]["local"])
        if np.median(np.where(np.isfinite(relative), relative, np.inf)) <= target:
            break
    return float(sigma), spread


def at_fixed_positions(area: np.ndarray, s_rows_mm: np.ndarray, s_mm: np.ndarray) -> np.ndarray:
    """A map resampled so that each row lies at one place along the tube in every frame.

    ``area (n_v, n_t)`` is measured at rows whose arc length from the inlet,
    ``s_rows_mm (n_v, n_t)``, drifts over the cycle (grid rows follow the
    surface's arc length, which changes with its shape). Row j of the result
    lies at the fraction ``s_mm[j] / s_mm[-1]`` of each frame's length (so at
    ``s_mm[j]`` when the length does not change), interpolated along the rows
    by a cubic spline (not-a-knot: 3e-5 relative error next to a neck where
    shape-preserving PCHIP gives 7e-3). NaN cells are left out; a frame with
    fewer than 2 values stays NaN. Returns ``(n_v, n_t)``.
    """
    from scipy.interpolate import CubicSpline

    area = _check_map(area, s_mm)
    s_rows_mm = np.asarray(s_rows_mm, dtype=float)
    if s_rows_mm.shape != area.shape:
        raise InputError(
            f"s_rows_mm must have the map's shape {area.shape}, found {s_rows_mm.shape}"
        )
    fraction = np.asarray(s_mm, float) / s_mm[-1]
    out = np.full(area.shape, np.nan)
    for k in range(area.shape[1]):
        s, a = s_rows_mm[:, k], area[:, k]
        ok = np.isfinite(a) & np.isfinite(s)
        ok[ok] = np.diff(np.concatenate([[-np.inf], s[ok]])) > 0  # drop repeats: s never falls
        if ok.sum() >= 2:
            target = np.clip(fraction * s_rows_mm[-1, k], s[ok][0], s[ok][-1])
            out[:, k] = CubicSpline(s[ok], a[ok])(target)
    return out
