"""Embryos' (v, t) maps on one common grid, so that a cohort compares as images:
position as a fraction of each tube's length, time as a fraction of each one's
cycle (both embryos' own, as the paper compares them)."""

from __future__ import annotations

import warnings

import numpy as np

N_POSITIONS = 50  # rows of the common grid, inlet (0) to outlet (1)
N_PHASES = 100  # columns, from the minimum outer volume (0) round the cycle
# fields (n_u, n_v, n_t) of arrays.npz whose mean around the tube is a cohort map
AROUND_TUBE_MAPS = ("wall_thickness_mm", "jelly_thickness_mm", "strain_energy_outer")
TESTED_MAPS = ("area_outer_normalized", *AROUND_TUBE_MAPS)  # compared between groups


def common_grid(n_positions: int = N_POSITIONS, n_phases: int = N_PHASES):
    """Position fractions ``(n_positions,)`` from 0 to 1 and cycle fractions
    ``(n_phases,)`` from 0 in steps of ``1 / n_phases``."""
    return np.linspace(0.0, 1.0, n_positions), np.arange(n_phases) / n_phases


def on_common_grid(
    values: np.ndarray,
    s_mm: np.ndarray,
    t_ms: np.ndarray,
    period_ms: float,
    n_positions: int = N_POSITIONS,
    n_phases: int = N_PHASES,
) -> np.ndarray:
    """A ``(n_v, n_t)`` map at positions ``s_mm (n_v,)`` (increasing from the inlet)
    and times ``t_ms (n_t,)`` in one cycle of ``period_ms``, resampled linearly onto
    :func:`common_grid`: ``(n_positions, n_phases)``, periodic in time."""
    values, s_mm, t_ms = (np.asarray(a, dtype=float) for a in (values, s_mm, t_ms))
    if values.shape != (len(s_mm), len(t_ms)):
        raise ValueError(
            f"a map of shape {values.shape} for {len(s_mm)} positions and {len(t_ms)} times"
        )
    if np.any(np.diff(s_mm) <= 0):
        raise ValueError("positions must increase from the inlet")
    position, phase = common_grid(n_positions, n_phases)
    at_phase = np.array([np.interp(phase, t_ms / period_ms, row, period=1.0) for row in values])
    fraction = (s_mm - s_mm[0]) / (s_mm[-1] - s_mm[0])
    return np.array([np.interp(position, fraction, col) for col in at_phase.T]).T


def row_normalized(values: np.ndarray) -> np.ndarray:
    """Each row of a ``(n_v, n_t)`` map over its own maximum (NaN left out; a row
    without a value stays NaN)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        return values / np.nanmax(values, axis=1, keepdims=True)


def group_mean_maps(maps: np.ndarray, groups) -> dict[str, tuple[np.ndarray, np.ndarray, int]]:
    """Per group of ``groups (n,)``: mean and SD (ddof 1; NaN for one embryo) of its
    members' ``maps (n, rows, cols)``, and how many, in the order groups first appear."""
    groups = np.asarray(groups)
    out = {}
    for g in dict.fromkeys(groups.tolist()):
        members = maps[groups == g]
        sd = (
            np.std(members, axis=0, ddof=1)
            if len(members) > 1
            else np.full(members.shape[1:], np.nan)
        )
        out[g] = (members.mean(axis=0), sd, len(members))
    return out


def groups_in_order(groups) -> list[str]:
    """The distinct groups, normals first, then by name (as the paper sets them side
    by side)."""
    return sorted(dict.fromkeys(np.asarray(groups).tolist()), key=lambda g: (g != "normal", g))


def group_differences(
    maps: np.ndarray, groups, *, cluster_alpha: float = 0.05, **test_options
) -> dict:
    """Each other group against the first of :func:`groups_in_order`, on
    ``maps (n, positions, phases)``: ``names`` (``"banded - normal"``), and each
    ``(n_comparisons, positions, phases)``: ``difference`` of the group means,
    ``p_fwer`` each pixel's p corrected over the map
    (:func:`oftimg.analysis.stats.map_permutation_test`) and ``p_cluster`` the p of the
    cluster each pixel belongs to (:func:`oftimg.analysis.stats.map_cluster_test`, clusters
    of uncorrected p <= ``cluster_alpha`` joined across the cycle's ends; 1 outside
    clusters)."""
    from .stats import map_cluster_test, map_permutation_test

    groups = np.asarray(groups)
    order = groups_in_order(groups)
    out = {"names": [], "difference": [], "p_fwer": [], "p_cluster": []}
    for g in order[1:]:
        a, b = maps[groups == g], maps[groups == order[0]]
        difference, p = map_permutation_test(a, b, **test_options)
        out["names"].append(f"{g} - {order[0]}")
        out["difference"].append(difference)
        out["p_fwer"].append(p)
        out["p_cluster"].append(
            map_cluster_test(a, b, periodic_axis=1, cluster_alpha=cluster_alpha, **test_options)
        )
    for key in ("difference", "p_fwer", "p_cluster"):
        out[key] = np.array(out[key]).reshape((len(out["names"]),) + maps.shape[1:])
    return out
