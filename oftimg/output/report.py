"""Cohort tables: one row per dataset (the paper's Table 1 and more)."""
from __future__ import annotations

import csv
from pathlib import Path

import numpy as np

from ..analysis.stats import holm, permutation_test

# (column header with unit, summary key path)
COHORT_COLUMNS = [
    ("name", ("name",)),
    ("group", ("group",)),
    ("n_frames", ("n_frames",)),
    ("period_ms", ("period_ms",)),
    ("expand_fraction", ("expand_fraction",)),
    ("contract_fraction", ("contract_fraction",)),
    ("expand_contract_ratio", ("expand_contract_ratio",)),
    ("expand_ms", ("expand_ms",)),
    ("contract_ms", ("contract_ms",)),
    ("speed_min_mm_s", ("wave_speed_mm_s", "min")),
    ("speed_max_mm_s", ("wave_speed_mm_s", "max")),
    ("speed_avg_mm_s", ("wave_speed_mm_s", "mean")),
    ("speed_std_mm_s", ("wave_speed_mm_s", "std")),
    ("speed_median_mm_s", ("wave_speed_mm_s", "median")),   # not in the paper: robust
    ("speed_cycle_mm_s", ("wave_speed_mm_s", "cycle")),
    ("speed_proximal_mm_s", ("wave_two_segment", "speed_proximal_mm_s")),
    ("speed_distal_mm_s", ("wave_two_segment", "speed_distal_mm_s")),
    ("knee_mm", ("wave_two_segment", "knee_mm")),
    ("ridge_smoothing_ms", ("ridge_smoothing_ms",)),       # the sigma used (auto: per dataset)
    # not in the paper: the speeds' spread from the area map's own frame-to-frame noise
    ("speed_min_noise_sd_mm_s", ("wave_speed_noise_sd_mm_s", "min")),
    ("speed_max_noise_sd_mm_s", ("wave_speed_noise_sd_mm_s", "max")),
    ("speed_avg_noise_sd_mm_s", ("wave_speed_noise_sd_mm_s", "mean")),
    ("speed_median_noise_sd_mm_s", ("wave_speed_noise_sd_mm_s", "median")),
    ("speed_cycle_noise_sd_mm_s", ("wave_speed_noise_sd_mm_s", "cycle")),
    ("speed_proximal_noise_sd_mm_s", ("wave_two_segment", "speed_proximal_noise_sd_mm_s")),
    ("speed_distal_noise_sd_mm_s", ("wave_two_segment", "speed_distal_noise_sd_mm_s")),
    ("max_expansion_rate_mm2_ms", ("max_expansion_rate_mm2_ms",)),
    ("max_contraction_rate_mm2_ms", ("max_contraction_rate_mm2_ms",)),
    ("band_position_mm", ("band_position_mm",)),
    ("max_area_neck_depth", ("max_area_neck_depth",)),
    ("corner_count", ("corner_count",)),
    ("tube_length_mm", ("tube_length_mm",)),
    ("myocardial_volume_change", ("myocardial_volume_change",)),
    ("jelly_volume_change", ("jelly_volume_change",)),   # inner - lumen (not in the paper)
    ("wall_thickness_median_mm", ("wall_thickness_median_mm",)),
    ("wall_thickening", ("wall_thickening",)),   # rows' mean thickness, max / min - 1
    ("jelly_thickness_median_mm", ("jelly_thickness_median_mm",)),   # inner wall to lumen
    ("jelly_thickening", ("jelly_thickening",)),
    # quality checks: 0, 0 and about 0 on good data
    ("flipped_triangles_outer", ("flipped_triangles", "outer")),
    ("sections_from_ring_outer", ("sections_from_ring", "outer")),
    ("section_volume_error_outer", ("section_volume_error", "outer")),
    ("standout_frames", ("frame_series_checks", "standout_frame_count")),
    ("wrap_step_ratio", ("frame_series_checks", "wrap_step_ratio")),     # <= 1: one cycle
    # share of a shape field's change over the cycle that is noise (well under 0.25)
    ("radial_curvature_outer_noise_share",
     ("field_noise", "radial_curvature_outer_per_mm", "noise_share")),
    ("mean_curvature_lumen_noise_share",
     ("field_noise", "mean_curvature_lumen_per_mm", "noise_share")),
    ("wall_thickness_noise_share", ("field_noise", "wall_thickness_mm", "noise_share")),
    ("jelly_thickness_noise_share", ("field_noise", "jelly_thickness_mm", "noise_share")),
    # the sigma (ms) each was smoothed by in time (auto: as much as its noise asks)
    ("radial_curvature_outer_smoothing_ms",
     ("field_noise", "radial_curvature_outer_per_mm", "smoothing_ms")),
    ("mean_curvature_lumen_smoothing_ms",
     ("field_noise", "mean_curvature_lumen_per_mm", "smoothing_ms")),
    ("wall_thickness_smoothing_ms", ("field_noise", "wall_thickness_mm", "smoothing_ms")),
    ("jelly_thickness_smoothing_ms", ("field_noise", "jelly_thickness_mm", "smoothing_ms")),
    # share of each strain energy field's size by which its grid's node noise moves it
    ("strain_energy_outer_error_share", ("strain_noise", "strain_energy_outer", "error_share")),
    ("strain_energy_inner_error_share", ("strain_noise", "strain_energy_inner", "error_share")),
    # the sigma its grid nodes were smoothed by ("auto": as much as that noise asks)
    ("strain_energy_outer_smoothing_ms", ("strain_noise", "strain_energy_outer", "smoothing_ms")),
    ("strain_energy_inner_smoothing_ms", ("strain_noise", "strain_energy_inner", "smoothing_ms")),
]


def _get(d: dict, path: tuple):
    """The value at ``path``; "" when there is none, or it is NaN or infinite (as
    summary.json, which stores those as null, gives it back to ``oftimg cohort``)."""
    for key in path:
        if not isinstance(d, dict) or key not in d:
            return ""
        d = d[key]
    if isinstance(d, float) and not np.isfinite(d):
        return ""
    return d


def cohort_rows(summaries: list[dict]) -> list[dict]:
    return [{col: _get(s, path) for col, path in COHORT_COLUMNS} for s in summaries]


def write_cohort_table(folder: Path, summaries: list[dict]) -> Path:
    """``cohort.csv`` in ``folder``: one row per dataset, units in the headers."""
    path = Path(folder) / "cohort.csv"
    with open(path, "w", newline="") as fh:
        writer = csv.DictWriter(fh, fieldnames=[c for c, _ in COHORT_COLUMNS])
        writer.writeheader()
        writer.writerows(cohort_rows(summaries))
    return path


def write_cohort_markdown(folder: Path, summaries: list[dict]) -> Path:
    """``cohort.md``: the cohort table as Markdown (3 significant digits)."""
    rows = cohort_rows(summaries)
    cols = [c for c, _ in COHORT_COLUMNS]

    def fmt(x):
        if isinstance(x, float):
            return f"{x:.3g}"
        return "" if x is None else str(x).replace("|", r"\|")   # a name's "|": no new cell

    lines = ["| " + " | ".join(cols) + " |", "|" + "---|" * len(cols)]
    lines += ["| " + " | ".join(fmt(r[c]) for c in cols) + " |" for r in rows]
    path = Path(folder) / "cohort.md"
    path.write_text("\n".join(lines) + "\n")
    return path


def group_comparison(summaries: list[dict]) -> list[dict]:
    """Per numeric cohort metric and pair of groups (in name order): each group's n,
    mean and sd, the two-sided permutation p-value of the pair, and that p-value
    Holm-adjusted over the metric's pairs (``p_holm``; the same with two groups).
    With one group: its n, mean and sd, no p-values."""
    from itertools import combinations

    rows = cohort_rows(summaries)
    groups = sorted({r["group"] for r in rows})
    out = []
    for col, _ in COHORT_COLUMNS:
        if col in ("name", "group", "n_frames"):
            continue
        values = {}
        for g in groups:
            vals = [r[col] for r in rows if r["group"] == g]
            vals = [float(v) if isinstance(v, (int, float)) and v is not None else float("nan")
                    for v in vals]
            values[g] = np.asarray(vals, float)
        if all(np.isnan(v).all() for v in values.values()):
            continue
        stats = {"metric": col}
        for g in groups:
            v = values[g][np.isfinite(values[g])]
            stats[f"{g}_n"] = len(v)
            stats[f"{g}_mean"] = float(v.mean()) if len(v) else float("nan")
            stats[f"{g}_sd"] = float(v.std(ddof=1)) if len(v) > 1 else float("nan")
        pairs = list(combinations(groups, 2))
        if not pairs:                                    # one group: its statistics alone
            out.append({**stats, "p_value": float("nan"), "p_holm": float("nan"),
                        "groups": groups[0]})
        p = [permutation_test(values[a], values[b]) for a, b in pairs]
        for (a, b), p_pair, p_adj in zip(pairs, p, holm(p)):
            out.append({**stats, "p_value": p_pair, "p_holm": p_adj, "groups": f"{a} vs {b}"})
    return out


def _sigmas_by_group(summaries: list[dict], sigma_of) -> tuple[str, float] | None:
    """The range of ``sigma_of(summary)`` in each group, as text ("a: 5 ms; b: 7-20
    ms"), and the largest sigma; None when there is one group or one sigma."""
    by_group: dict[str, list[float]] = {}
    for s in summaries:
        sigma = sigma_of(s)
        if isinstance(sigma, (int, float)) and np.isfinite(sigma):
            by_group.setdefault(s["group"], []).append(float(sigma))
    if len(by_group) < 2 or len({x for v in by_group.values() for x in v}) < 2:
        return None
    ranges = "; ".join(f"{g}: {min(v):g}" + (f"-{max(v):g}" if max(v) > min(v) else "") + " ms"
                       for g, v in sorted(by_group.items()))
    return ranges, max(x for v in by_group.values() for x in v)


def smoothing_caveat(summaries: list[dict]) -> str | None:
    """What to know before comparing groups whose embryos' ridges were smoothed in time
    by different sigmas (``ridge_smoothing_ms``: "auto" takes as much as each map's
    noise needs); None when there is one group or one sigma."""
    found = _sigmas_by_group(summaries, lambda s: s.get("ridge_smoothing_ms"))
    if found is None:
        return None
    ranges, largest = found
    return (f"the embryos' ridges were smoothed in time by different sigmas ({ranges}), as "
            "their maps' noise asked: more smoothing puts the ridge later where the beat's "
            "peak is asymmetric, so group differences in ridge times, and in wave speeds where "
            "the expansion share changes along the tube, may come from it "
            "(oftimg's docs/accuracy.md); to compare the groups, analyse them all with "
            f"--ridge-smoothing-ms {largest:g}")


# the fields whose sigma "auto" chooses per dataset: summary key -> (what, run option)
FIELD_SIGMAS = {"field_smoothing_ms": ("shape fields", "--field-smoothing-ms"),
                "strain_smoothing_ms": ("strain fields (their grid nodes)",
                                        "--strain-smoothing-ms")}


def field_smoothing_caveat(summaries: list[dict], key: str = "field_smoothing_ms"
                           ) -> str | None:
    """The same for the curvature and thickness fields (``field_smoothing_ms``,
    per field: "auto" takes as much as each field's noise needs), or the strain
    fields (``key="strain_smoothing_ms"``); None when each field's sigma is the
    same in every group."""
    what, option = FIELD_SIGMAS[key]
    names = sorted({n for s in summaries if isinstance(s.get(key), dict) for n in s[key]})
    differing, largest = [], 0.0
    for name in names:
        found = _sigmas_by_group(
            summaries, lambda s: s[key].get(name) if isinstance(s.get(key), dict) else None)
        if found is not None:
            differing.append(f"{name} ({found[0]})")
            largest = max(largest, found[1])
    if not differing:
        return None
    return (f"the embryos' {what} were smoothed in time by different sigmas, as "
            f"their noise asked: {', '.join(differing)}; more smoothing lowers and widens "
            "each pixel's peaks over the cycle, so group differences in those fields' size "
            "and phase maps may come from it (oftimg's docs/accuracy.md); to compare the groups, "
            f"analyse them all with {option} {largest:g}")


def map_comparison_rows(maps: dict, alpha: float = 0.05) -> list[dict]:
    """Per comparison of groups and tested map of ``maps``
    (:func:`oftimg.output.export.cohort_maps`): the least p pixel by pixel and by cluster,
    and the share of the map (of its pixels with a value) in clusters with p below
    ``alpha``."""
    from .export import TESTED_MAPS

    rows = []
    for k, name in enumerate(maps["comparisons"]):
        for key in TESTED_MAPS:
            p_fwer, p_cluster = maps[f"{key}_p_fwer"][k], maps[f"{key}_p_cluster"][k]
            tested_pixels = np.isfinite(p_cluster)
            rows.append({
                "comparison": str(name), "map": key,
                "least_p_pixel": float(np.nanmin(p_fwer)) if tested_pixels.any() else None,
                "least_p_cluster": float(np.nanmin(p_cluster)) if tested_pixels.any() else None,
                f"share_in_clusters_p<{alpha:g}": (float(np.mean(p_cluster[tested_pixels] < alpha))
                                                   if tested_pixels.any() else None)})
    return rows


def write_groups_table(folder: Path, summaries: list[dict],
                       comparison: list[dict] | None = None) -> Path | None:
    """``groups.csv``: group means, sds and permutation p-values (two groups or more);
    ``comparison``: :func:`group_comparison` of ``summaries`` if already made."""
    rows = group_comparison(summaries) if comparison is None else comparison
    if not rows or len({s["group"] for s in summaries}) < 2:
        return None
    path = Path(folder) / "groups.csv"
    fields = list(rows[0])
    with open(path, "w", newline="") as fh:
        writer = csv.DictWriter(fh, fieldnames=fields)
        writer.writeheader()
        writer.writerows(rows)
    return path


def mean_curve(curves: list[tuple], x: np.ndarray, *, period: float | None = None,
               min_share: float = 0.5) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Mean, SD (ddof 1) and count of a group's curves ``[(x_k, y_k), ...]`` on the
    common ``x``.

    Each curve is interpolated linearly onto ``x``: NaN outside its own range
    (a shorter tube has no value there), or periodically with ``period`` (a
    cycle). Where fewer than ``min_share`` of the curves (and fewer than 2)
    have a value, mean and SD are NaN. Returns three ``(len(x),)`` arrays.
    """
    Y = np.array([np.interp(x, xk, yk, period=period) if period is not None
                  else np.interp(x, xk, yk, left=np.nan, right=np.nan)
                  for xk, yk in curves])
    count = np.isfinite(Y).sum(axis=0)
    enough = count >= max(2, min_share * len(curves))
    mean = np.full(len(x), np.nan)
    sd = np.full(len(x), np.nan)
    if enough.any():
        mean[enough] = np.nanmean(Y[:, enough], axis=0)
        sd[enough] = np.nanstd(Y[:, enough], axis=0, ddof=1)
    return mean, sd, count
