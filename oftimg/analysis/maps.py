"""The (v, t) area-map analyses of one dataset, wired together (paper section 5)."""

from __future__ import annotations

import warnings

import numpy as np

from ..image.band import detect_band, neck_depth
from ..image.gradient import area_rates
from ..image.kymograph import (
    AREA_WAVE_MIN_SWING,
    RESOLVED_ROW_SHARE,
    STILL_ROW_SHARE,
    auto_ridge_smoothing,
    noise_colour,
    speed_spread,
)
from ..image.masks import expanded_75, expanded_sigma
from .uncertainty import speed_band_95


def fill_gaps(area: np.ndarray) -> tuple[np.ndarray, int]:
    """NaN cells of a ``(n_v, n_t)`` map filled by periodic interpolation in time,
    rows without any value by interpolation along v. Returns ``(filled, count)``."""
    a = np.array(area, dtype=float)
    bad = ~np.isfinite(a)
    if not bad.any():
        return a, 0
    n_v, n_t = a.shape
    t = np.arange(n_t)
    for j in range(n_v):
        ok = ~bad[j]
        if ok.any() and not ok.all():
            a[j, ~ok] = np.interp(t[~ok], t[ok], a[j, ok], period=n_t)
    rows_ok = np.isfinite(a).all(axis=1)
    if rows_ok.any() and not rows_ok.all():
        v = np.arange(n_v)
        for k in range(n_t):
            a[~rows_ok, k] = np.interp(v[~rows_ok], v[rows_ok], a[rows_ok, k])
    return a, int(bad.sum())


# a wave speed whose spread is more than this share of it is said to be poorly resolved
SPREAD_NOTE_SHARE = 0.2
# noise_colour above this: the map's noise looks correlated in time (white: 1; noise
# smoothed over 0.5 / 1 frame: 1.5 / 30; AR(1) with 0.5, not caught: 1.4; the phantoms,
# white: 0.6-1.4; the animated midgut: 0.7)
COLOURED_NOISE = 2.0


# a wave that crosses the tube in fewer frames than this: its speed is at the frame
# rate's limit (the zoo's 50 mesh draws, by the crossing each run measured: 1.5 and 2.6
# frames, the cycle speed 35 and 20 % slow with noise spreads of 0.2-0.5 %; from 3.2
# frames on every one within 6 %; draw 10, crossing in 0.95 frame, 40 % slow)
FRAME_LIMITED_CROSSING = 3.0


def frame_limited(length_mm: float, speed_mm_s: float, frame_ms: float) -> str | None:
    """A note when a wave of ``speed_mm_s`` crosses a tube of ``length_mm`` in fewer
    than :data:`FRAME_LIMITED_CROSSING` frames of ``frame_ms``, else None."""
    if not (np.isfinite(speed_mm_s) and speed_mm_s > 0):
        return None
    crossing_ms = 1000.0 * length_mm / speed_mm_s
    if crossing_ms >= FRAME_LIMITED_CROSSING * frame_ms:
        return None
    return (
        f"the wave crosses the tube in {crossing_ms:.3g} ms at its cycle speed, "
        f"{crossing_ms / frame_ms:.2g} frames of {frame_ms:.3g} ms: its speeds are at the "
        "limit of the frame rate and likely too slow, by more than their noise spread "
        "says (a zoo phantom crossed in 0.95 frame came out 40 % slow); more frames per "
        "cycle resolve it (wave_crossing_frames)"
    )


def analyse_area_maps(
    area: dict[str, np.ndarray],
    s_mm: np.ndarray,
    period_ms: float,
    *,
    ridge_smoothing_ms: float | str = "auto",
) -> tuple[dict, dict]:
    """Ridge, wave speeds, knee, expansion fractions and masks, rates, band.

    ``area[wall] (n_v, n_t)`` mm^2 over one aligned cycle, ``s_mm (n_v,)``;
    cells without a contour (NaN) are interpolated first (and counted).
    Speeds and the band come from the outer wall; expansion fractions from
    every wall; the ridge from the outer map smoothed in time by a Gaussian of
    ``ridge_smoothing_ms`` (:func:`~oftimg.image.kymograph.ridge_times`; "auto":
    as much as the map's noise needs, :func:`~oftimg.image.kymograph.auto_ridge_smoothing`,
    the sigma used in ``summary["ridge_smoothing_ms"]``); the speeds' spread
    from the outer map's own frame-to-frame noise
    (:func:`~oftimg.image.kymograph.speed_spread`). Returns ``(arrays, summary)``.
    """
    n_t = area["outer"].shape[1]
    arrays, summary = {}, {}
    filled = {}
    area = dict(area)
    for wall in list(area):
        area[wall], filled[wall] = fill_gaps(area[wall])
    summary["area_cells_interpolated"] = filled
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        if ridge_smoothing_ms == "auto":
            smoothing, spread = auto_ridge_smoothing(area["outer"], s_mm, period_ms)
        else:
            smoothing = float(ridge_smoothing_ms)
            spread = speed_spread(area["outer"], s_mm, period_ms, smoothing_ms=smoothing)
        ridge, speeds = spread["ridge"], spread["measured"]
        for wall, a in area.items():
            share75, up, down, mask75 = expanded_75(a)
            share_sig, sigma, r2, mask_sig = expanded_sigma(a)
            arrays[f"max_area_{wall}_mm2"] = np.nanmax(a, axis=1)
            arrays[f"expanded_fraction_75_{wall}"] = share75
            arrays[f"expanded_fraction_sigma_{wall}"] = share_sig
            arrays[f"expanded_mask_75_{wall}"] = mask75
            arrays[f"expanded_mask_sigma_{wall}"] = mask_sig
            arrays[f"crossing_75_{wall}_ms"] = np.stack([up, down]) * period_ms / n_t
            arrays[f"gaussian_sigma_{wall}_ms"] = sigma * period_ms / n_t
            arrays[f"gaussian_fit_r2_{wall}"] = r2
    notes = sorted({str(w.message) for w in caught})
    notes += [
        f"{k} {w} area cells without a contour were interpolated for the map analyses"
        for w, k in filled.items()
        if k
    ]
    expand_rate, contract_rate = area_rates(area["outer"], period_ms / n_t)
    knee, sd = speeds["knee"], spread["speeds"]
    if spread["no_area_wave"]:
        notes.append(
            f"the sections' areas change by {100 * spread['swing']:.2g} % over the "
            f"beat (median row), under {100 * AREA_WAVE_MIN_SWING:g} %: the area map "
            "holds no wave to time, so no wave speed and no expansion share are "
            "given from it (a helical wave leaves each section's area all but "
            "constant); the wave on the wall is in wave_fronts"
        )
    elif spread["synchronous"]:
        notes.append(
            f"the ridge's slope along the tube, {spread['ridge_slope_ms_per_mm']:.3g} "
            f"± {spread['ridge_slope_noise_sd_ms_per_mm']:.2g} ms/mm, is consistent "
            "with none within the map's noise: the tube contracts at once "
            "(synchronous within noise), so no wave speed is given"
        )
    elif np.isfinite(spread["noise_sd"]).any():
        notes += _unresolved_speeds(
            speeds["summary"]
            | {"proximal": knee.speed_proximal_mm_s, "distal": knee.speed_distal_mm_s},
            sd,
        )
    else:
        notes.append(
            f"the area map's noise cannot be measured on {n_t} frames (10 or more): "
            "the wave speeds are given without their spread"
        )
    still = int(np.count_nonzero(spread["still_rows"]))
    summary["ridge_rows_bridged"] = still
    if still and not spread["no_area_wave"]:
        notes.append(
            f"{still} rows of the outer map barely move (area swing under "
            f"{STILL_ROW_SHARE:.0%} of the median row's, as at a band's neck): their "
            "time of maximum area is not the wave's, so the wave speeds bridge them "
            "with the ridge's line between the nearest moving rows"
        )
    with_speed = int(np.count_nonzero(np.isfinite(speeds["local"])))
    used = speeds["summary"]["rows_used"]
    if used < with_speed:
        notes.append(
            f"the local wave speeds' min, max, mean and SD are over the {used} of "
            f"{with_speed} rows whose speed the map's noise resolves (spread under "
            f"{RESOLVED_ROW_SHARE:.0%} of it); the others, where the ridge is nearly "
            "flat or turns within the noise, are left out (local_speed_noise_sd_mm_s)"
        )
    colour = noise_colour(area["outer"])
    summary["area_noise_colour"] = colour
    if colour > COLOURED_NOISE:
        notes.append(
            f"the outer area map has {colour:.3g} times more power at a quarter of "
            "the frame rate than near half of it: if that is segmentation noise "
            "correlated from frame to frame, the speeds' noise spreads and the auto "
            "ridge smoothing are too small (see oftimg's docs/accuracy.md)"
        )
    summary["ridge_smoothing_ms"] = smoothing
    arrays["ridge_t_ms"] = ridge
    arrays["ridge_t_noise_sd_ms"] = spread["ridge_t_ms"]
    arrays["local_speed_mm_s"] = speeds["local"]
    arrays["local_speed_noise_sd_mm_s"] = spread["local_speed_mm_s"]
    arrays["ridge_bridged"] = spread["still_rows"].astype(np.uint8)
    arrays["area_noise_sd_outer_mm2"] = spread["noise_sd"]
    summary["wave_synchronous_within_noise"] = spread["synchronous"]
    summary["area_wave"] = not spread["no_area_wave"]
    summary["area_swing"] = spread["swing"]
    summary["ridge_slope_ms_per_mm"] = spread["ridge_slope_ms_per_mm"]
    summary["ridge_slope_noise_sd_ms_per_mm"] = spread["ridge_slope_noise_sd_ms_per_mm"]
    summary["wave_speed_mm_s"] = speeds["summary"]
    cycle, length = speeds["summary"]["cycle"], float(s_mm[-1] - s_mm[0])
    frame_ms = period_ms / n_t
    summary["wave_crossing_frames"] = (
        float(1000.0 * length / cycle / frame_ms)
        if cycle is not None and np.isfinite(cycle) and cycle > 0
        else None
    )
    limited = frame_limited(length, cycle if cycle is not None else np.nan, frame_ms)
    if limited:
        notes.append(limited)
    summary["wave_speed_noise_sd_mm_s"] = {
        k: sd[k] for k in ("min", "max", "mean", "median", "cycle")
    }
    summary["wave_speed_band_95_mm_s"] = {"cycle": speed_band_95(cycle, sd["cycle"])}
    summary["wave_two_segment"] = {
        "speed_proximal_mm_s": knee.speed_proximal_mm_s,
        "speed_distal_mm_s": knee.speed_distal_mm_s,
        "speed_proximal_noise_sd_mm_s": sd["proximal"],
        "speed_distal_noise_sd_mm_s": sd["distal"],
        "knee_mm": knee.knee_mm,
        "knee_t_ms": knee.knee_t_ms,
        "rms_ms": knee.rms_ms,
    }
    summary["max_expansion_rate_mm2_ms"] = expand_rate
    summary["max_contraction_rate_mm2_ms"] = contract_rate
    summary["band_position_mm"] = detect_band(area["outer"], s_mm)
    summary["max_area_neck_depth"] = neck_depth(area["outer"])
    fractions = arrays["expanded_fraction_75_outer"]
    fractions = fractions[np.isfinite(fractions)]  # none: a tube that never moves
    summary["expanded_fraction_75_mean"] = float(fractions.mean()) if fractions.size else np.nan
    summary["image_analysis_notes"] = notes
    return arrays, summary


def _unresolved_speeds(speeds_mm_s: dict, spread: dict) -> list[str]:
    """One note naming the wave speeds whose spread is over :data:`SPREAD_NOTE_SHARE` of
    their value or undefined (none when every speed is resolved; a speed that was not
    measured at all is no part of it: the notes on the ridge say why)."""
    poor = []
    for k, sd_mm_s in spread.items():
        if not np.isfinite(speeds_mm_s[k]):
            continue
        if not np.isfinite(sd_mm_s):
            poor.append(f"{k} {speeds_mm_s[k]:.3g} mm/s (not resolved)")
        elif sd_mm_s > SPREAD_NOTE_SHARE * abs(speeds_mm_s[k]):
            poor.append(f"{k} {speeds_mm_s[k]:.3g} ± {sd_mm_s:.2g} mm/s")
    if not poor:
        return []
    return [
        f"wave speeds whose spread from the area map's frame-to-frame noise alone is over "
        f"{SPREAD_NOTE_SHARE:.0%} of them (see wave_speed_noise_sd_mm_s): " + ", ".join(poor)
    ]
