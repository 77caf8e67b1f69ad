"""Cohort tables, one row per dataset: Table 1 (the paper's quantities in the paper's
units and rounding), the other measurements, the quality checks, a data dictionary
of all their columns, and the group comparison."""

from __future__ import annotations

import csv
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..analysis.group_maps import TESTED_MAPS
from ..analysis.stats import holm, permutation_test
from .units import THICKENING, VOLUME_CHANGE
from . import numbers


@dataclass(frozen=True)
class Column:
    """One column of a cohort table: its header, where its value is in summary.json
    (keys), unit, what it is and how it is made; ``scale`` turns summary.json's
    value into the column's unit (100: a fraction as %); ``decimals`` or
    ``significant`` round it as the paper does (Table 1 only; None: as is)."""

    name: str
    path: tuple
    unit: str
    what: str
    scale: float = 1.0
    decimals: int | None = None
    significant: int | None = None


_SPEED = (
    "wave speed along the tube from the ridge of the outer area map (time of maximum "
    "area at each position): {} over the rows of its slope ds/dt that the map's noise "
    "resolves (qc.csv speed_rows_used); empty when none does"
)
_NOISE_SD = (
    "spread (SD) of {} from the area map's own frame-to-frame noise, by "
    "resampling that noise (not in the paper)"
)
_NOISE_SHARE = (
    "share of {} field's change over the cycle that is frame-to-frame noise, "
    "median pixel (well under 0.25 on good data)"
)
_SIGMA = (
    "sigma (ms) of the Gaussian in time that smoothed the {} field ('auto': as its noise asked)"
)

ID_COLUMNS = [
    Column("name", ("name",), "", "the dataset (meta.json: name, else its folder's name)"),
    Column("group", ("group",), "", "its group (meta.json: group)"),
]

# the paper's Table 1, in its units and rounding, and the myocardium's volumes
TABLE1_COLUMNS = ID_COLUMNS + [
    Column(
        "expand_percent",
        ("expand_fraction",),
        "%",
        "share of the cycle during which the "
        "outer wall's capped volume grows (from its minimum at t = 0 to its maximum)",
        scale=100.0,
        decimals=2,
    ),
    Column(
        "contract_percent",
        ("contract_fraction",),
        "%",
        "share of the cycle during which it shrinks: 100 - expand_percent",
        scale=100.0,
        decimals=2,
    ),
    Column(
        "expand_contract_ratio",
        ("expand_contract_ratio",),
        "1",
        "expansion time over contraction time",
        decimals=2,
    ),
    Column("period_ms", ("period_ms",), "ms", "the cardiac cycle's length (meta.json)", decimals=0),
    Column(
        "expand_ms",
        ("expand_ms",),
        "ms",
        "time of expansion: expand_percent of the period",
        decimals=0,
    ),
    Column("contract_ms", ("contract_ms",), "ms", "time of contraction", decimals=0),
    Column(
        "speed_min_mm_s",
        ("wave_speed_mm_s", "min"),
        "mm/s",
        _SPEED.format("minimum"),
        significant=5,
    ),
    Column(
        "speed_max_mm_s",
        ("wave_speed_mm_s", "max"),
        "mm/s",
        _SPEED.format("maximum"),
        significant=5,
    ),
    Column(
        "speed_avg_mm_s", ("wave_speed_mm_s", "mean"), "mm/s", _SPEED.format("mean"), significant=5
    ),
    Column(
        "speed_std_mm_s", ("wave_speed_mm_s", "std"), "mm/s", _SPEED.format("SD"), significant=5
    ),
    Column(
        "speed_cycle_mm_s",
        ("wave_speed_mm_s", "cycle"),
        "mm/s",
        "the ridge's tube length "
        "over the time it takes from the inlet to the outlet (the paper's 'cycle')",
        significant=5,
    ),
    Column(
        "myocardial_volume_change_percent",
        ("myocardial_volume_change",),
        "%",
        "the myocardium's (outer minus inner capped) volume change over the cycle, "
        "(largest - smallest) / smallest",
        scale=100.0,
        decimals=1,
    ),
    Column(
        "clipped_myocardial_volume_mm3",
        ("clipped_myocardial_volume_mm3",),
        "mm^3",
        "the constant myocardial volume the Lagrangian clipping plane keeps in every frame",
        significant=4,
    ),
]

# Table 1's headers as the paper words them (with the unit in brackets)
TABLE1_LABELS = {
    "expand_percent": "Expand",
    "contract_percent": "Contract",
    "expand_contract_ratio": "Ratio",
    "period_ms": "Period",
    "expand_ms": "Expand",
    "contract_ms": "Contract",
    "speed_min_mm_s": "Speed min",
    "speed_max_mm_s": "Speed max",
    "speed_avg_mm_s": "Speed avg",
    "speed_std_mm_s": "Speed std",
    "speed_cycle_mm_s": "Speed cycle",
    "myocardial_volume_change_percent": "Myocardial volume change",
    "clipped_myocardial_volume_mm3": "Clipped myocardial volume",
}

# every other measurement, in summary.json's units at full precision
MEASUREMENT_COLUMNS = ID_COLUMNS + [
    Column("n_frames", ("n_frames",), "1", "frames in the dataset"),
    Column(
        "speed_median_mm_s",
        ("wave_speed_mm_s", "median"),
        "mm/s",
        _SPEED.format("median") + " (not in the paper: robust to a flat ridge)",
    ),
    Column(
        "speed_proximal_mm_s",
        ("wave_two_segment", "speed_proximal_mm_s"),
        "mm/s",
        "wave speed of the ridge's first straight segment (two-segment fit, not in the paper)",
    ),
    Column(
        "speed_distal_mm_s",
        ("wave_two_segment", "speed_distal_mm_s"),
        "mm/s",
        "wave speed of its second segment",
    ),
    Column(
        "knee_mm",
        ("wave_two_segment", "knee_mm"),
        "mm",
        "where along the tube the two segments meet",
    ),
    Column(
        "max_expansion_rate_mm2_ms",
        ("max_expansion_rate_mm2_ms",),
        "mm^2/ms",
        "largest growth rate of a section's area (the area map's time derivative)",
    ),
    Column(
        "max_contraction_rate_mm2_ms",
        ("max_contraction_rate_mm2_ms",),
        "mm^2/ms",
        "largest shrink rate of a section's area",
    ),
    Column(
        "band_position_mm",
        ("band_position_mm",),
        "mm",
        "position of the narrowest section of the maximum-area profile (a band); empty: none",
    ),
    Column(
        "max_area_neck_depth",
        ("max_area_neck_depth",),
        "1",
        "depth of that narrowing relative to its neighbours' areas",
    ),
    Column(
        "corner_count",
        ("corner_count",),
        "1",
        "corners of the outer section contour at maximum expansion (curvature peaks)",
    ),
    Column(
        "tube_length_mm",
        ("tube_length_mm",),
        "mm",
        "length of the outer contours' centroid line, time average",
    ),
    Column(
        "jelly_volume_change_percent",
        ("jelly_volume_change",),
        VOLUME_CHANGE.unit,
        "the cardiac jelly's (inner minus lumen) volume change, (largest - smallest) / smallest",
        scale=VOLUME_CHANGE.scale,
    ),
    Column(
        "wall_thickness_median_mm",
        ("wall_thickness_median_mm",),
        "mm",
        "myocardial wall thickness (outer to inner wall), median over pixels and cycle",
    ),
    Column(
        "wall_thickening_percent",
        ("wall_thickening",),
        THICKENING.unit,
        "rows' mean wall thickness, largest over smallest in the cycle, minus 1; median row",
        scale=THICKENING.scale,
    ),
    Column(
        "jelly_thickness_median_mm",
        ("jelly_thickness_median_mm",),
        "mm",
        "cardiac jelly thickness (inner wall to lumen), median",
    ),
    Column(
        "jelly_thickening_percent",
        ("jelly_thickening",),
        THICKENING.unit,
        "its thickening, as wall_thickening_percent",
        scale=THICKENING.scale,
    ),
    Column(
        "lumen_aspect_ratio_narrowest",
        ("cushions", "aspect_ratio_narrowest"),
        "1",
        "the lumen's minor over major axis at its narrowest (each row's 10th percentile "
        "over the cycle, open sections; median row): the cushions' ellipse",
    ),
    Column(
        "lumen_aspect_ratio_widest",
        ("cushions", "aspect_ratio_widest"),
        "1",
        "the same at its widest (90th percentile)",
    ),
    Column(
        "lumen_closed_rows",
        ("cushions", "closed_rows"),
        "1",
        "rows where the lumen closes at some time in the cycle (the cushions appose)",
    ),
    Column(
        "lumen_closed_share_max",
        ("cushions", "closed_share_max"),
        "1",
        "the largest share of the cycle a row's lumen is closed",
    ),
    Column(
        "lumen_closure_speed_mm_s",
        ("cushions", "closure_speed_mm_s"),
        "mm/s",
        "how fast the closure travels along the tube: the slope of the rows' closing "
        "times (empty: under 3 rows close)",
    ),
    Column(
        "jelly_at_over_between_cushions",
        ("cushions", "jelly_at_over_between_cushions"),
        "1",
        "the cardiac jelly's thickness about the lumen's minor axis (the cushions) "
        "over that about its major axis, median row and frame",
    ),
    Column(
        "front_speed_mm_s",
        ("wave_fronts", "outer", "speed_mm_s"),
        "mm/s",
        "the wave's speed on the outer wall, median node: 1 / |gradient of the activation "
        "times on the wall| (not in the paper; empty: no propagation)",
    ),
    Column(
        "front_axial_speed_mm_s",
        ("wave_fronts", "outer", "axial_speed_mm_s"),
        "mm/s",
        "its speed along the tube: 1 / median dt/ds of the activation times (beside the "
        "ridge's speeds: they agree where the fronts are cross-sections)",
    ),
    Column(
        "front_helix_angle_deg",
        ("wave_fronts", "outer", "helix_angle_deg"),
        "deg",
        "angle of the wave's mean direction on the outer wall to the tube's axis (the "
        "mean slowness vector's; 0: along it, 90: around it; the sign: towards "
        "increasing u)",
    ),
    Column(
        "front_helix_angle_iqr_deg",
        ("wave_fronts", "outer", "helix_angle_iqr_deg"),
        "deg",
        "the interquartile range of the wall's nodes' angles about it",
    ),
    Column(
        "front_earliest_s_mm",
        ("wave_fronts", "outer", "earliest_s_mm"),
        "mm",
        "where along the tube the outer wall activates first",
    ),
    Column(
        "front_slowest_s_mm",
        ("wave_fronts", "outer", "slowest_s_mm"),
        "mm",
        "the row where the wave runs slowest on the outer wall (median node of the row)",
    ),
]

# quality checks and noise spreads: 0, 0 and about 0 on good data
QC_COLUMNS = ID_COLUMNS + [
    Column(
        "flipped_triangles_outer",
        ("flipped_triangles", "outer"),
        "1",
        "triangles of the outer wall's (u, v) maps that flipped, over all frames (0)",
    ),
    Column(
        "sections_from_ring_outer",
        ("sections_from_ring", "outer"),
        "1",
        "outer sections measured on the grid ring for want of a clean contour (0)",
    ),
    Column(
        "section_volume_error_outer",
        ("section_volume_error", "outer"),
        "1",
        "median |volume from sections / capped volume - 1| of the outer wall (about 0)",
    ),
    Column(
        "standout_frames",
        ("frame_series_checks", "standout_frame_count"),
        "1",
        "frames whose volume stands out from their neighbours' (0)",
    ),
    Column(
        "wrap_step_ratio",
        ("frame_series_checks", "wrap_step_ratio"),
        "1",
        "last-to-first frame's volume step over the largest step between frames "
        "(at most 1 when the frames are one cycle)",
    ),
    Column(
        "ridge_smoothing_ms",
        ("ridge_smoothing_ms",),
        "ms",
        "sigma of the ridge's smoothing in time ('auto': per dataset, as its noise asked)",
    ),
    Column(
        "speed_rows_used",
        ("wave_speed_mm_s", "rows_used"),
        "1",
        "rows of the outer map whose local wave speed is resolved (noise spread finite and "
        "under half of it), over which Table 1's speed min, max, avg and std are taken",
    ),
    Column(
        "ridge_rows_bridged",
        ("ridge_rows_bridged",),
        "1",
        "rows of the outer map that barely move (a neck: area swing under 0.7 of the "
        "median row's), bridged by the ridge's line for the wave speeds (0 without a band)",
    ),
    Column(
        "speed_min_noise_sd_mm_s",
        ("wave_speed_noise_sd_mm_s", "min"),
        "mm/s",
        _NOISE_SD.format("speed_min_mm_s"),
    ),
    Column(
        "speed_max_noise_sd_mm_s",
        ("wave_speed_noise_sd_mm_s", "max"),
        "mm/s",
        _NOISE_SD.format("speed_max_mm_s"),
    ),
    Column(
        "speed_avg_noise_sd_mm_s",
        ("wave_speed_noise_sd_mm_s", "mean"),
        "mm/s",
        _NOISE_SD.format("speed_avg_mm_s"),
    ),
    Column(
        "speed_median_noise_sd_mm_s",
        ("wave_speed_noise_sd_mm_s", "median"),
        "mm/s",
        _NOISE_SD.format("speed_median_mm_s"),
    ),
    Column(
        "speed_cycle_noise_sd_mm_s",
        ("wave_speed_noise_sd_mm_s", "cycle"),
        "mm/s",
        _NOISE_SD.format("speed_cycle_mm_s"),
    ),
    Column(
        "speed_cycle_band_95_mm_s",
        ("wave_speed_band_95_mm_s", "cycle"),
        "mm/s",
        "half the 95 % band of speed_cycle_mm_s (Table 1's ±): 1.96 x its noise SD and "
        "the share of it the accuracy zoo found beyond the noise, in quadrature",
    ),
    Column(
        "speed_proximal_noise_sd_mm_s",
        ("wave_two_segment", "speed_proximal_noise_sd_mm_s"),
        "mm/s",
        _NOISE_SD.format("speed_proximal_mm_s"),
    ),
    Column(
        "speed_distal_noise_sd_mm_s",
        ("wave_two_segment", "speed_distal_noise_sd_mm_s"),
        "mm/s",
        _NOISE_SD.format("speed_distal_mm_s"),
    ),
    Column(
        "radial_curvature_outer_noise_share",
        ("field_noise", "radial_curvature_outer_per_mm", "noise_share"),
        "1",
        _NOISE_SHARE.format("the outer radial curvature"),
    ),
    Column(
        "mean_curvature_lumen_noise_share",
        ("field_noise", "mean_curvature_lumen_per_mm", "noise_share"),
        "1",
        _NOISE_SHARE.format("the lumen's mean curvature"),
    ),
    Column(
        "wall_thickness_noise_share",
        ("field_noise", "wall_thickness_mm", "noise_share"),
        "1",
        _NOISE_SHARE.format("the wall thickness"),
    ),
    Column(
        "jelly_thickness_noise_share",
        ("field_noise", "jelly_thickness_mm", "noise_share"),
        "1",
        _NOISE_SHARE.format("the jelly thickness"),
    ),
    Column(
        "radial_curvature_outer_smoothing_ms",
        ("field_noise", "radial_curvature_outer_per_mm", "smoothing_ms"),
        "ms",
        _SIGMA.format("outer radial curvature"),
    ),
    Column(
        "mean_curvature_lumen_smoothing_ms",
        ("field_noise", "mean_curvature_lumen_per_mm", "smoothing_ms"),
        "ms",
        _SIGMA.format("lumen mean curvature"),
    ),
    Column(
        "wall_thickness_smoothing_ms",
        ("field_noise", "wall_thickness_mm", "smoothing_ms"),
        "ms",
        _SIGMA.format("wall thickness"),
    ),
    Column(
        "jelly_thickness_smoothing_ms",
        ("field_noise", "jelly_thickness_mm", "smoothing_ms"),
        "ms",
        _SIGMA.format("jelly thickness"),
    ),
    *[
        Column(
            f"{field}_band_95",
            ("field_noise", f"{field}_{unit}", "band_95"),
            unit.replace("per_mm", "1/mm"),
            f"half the 95 % band of the {what} at each node: its noise widened by the "
            "accuracy zoo's calibration for the input kind (docs/accuracy.md)",
        )
        for field, unit, what in (
            ("radial_curvature_outer", "per_mm", "outer radial curvature"),
            ("radial_curvature_inner", "per_mm", "inner radial curvature"),
            ("mean_curvature_lumen", "per_mm", "lumen's mean curvature"),
            ("wall_thickness", "mm", "wall thickness"),
            ("jelly_thickness", "mm", "jelly thickness"),
        )
    ],
    Column(
        "strain_energy_outer_error_share",
        ("strain_noise", "strain_energy_outer", "error_share"),
        "1",
        "share of the outer strain energy's median size by which its grid nodes' noise "
        "moves it (well under 0.5)",
    ),
    Column(
        "strain_energy_inner_error_share",
        ("strain_noise", "strain_energy_inner", "error_share"),
        "1",
        "the same for the inner wall",
    ),
    Column(
        "strain_energy_outer_smoothing_ms",
        ("strain_noise", "strain_energy_outer", "smoothing_ms"),
        "ms",
        "sigma (ms) by which the outer grid's nodes were smoothed in time for the strain",
    ),
    Column(
        "strain_energy_inner_smoothing_ms",
        ("strain_noise", "strain_energy_inner", "smoothing_ms"),
        "ms",
        "the same for the inner grid",
    ),
]

# file name -> its columns (what a cohort run writes, and the data dictionary covers)
TABLES = {"table1.csv": TABLE1_COLUMNS, "cohort.csv": MEASUREMENT_COLUMNS, "qc.csv": QC_COLUMNS}
# an embryo's Table 1 cell without a value, and what it means
NO_VALUE = numbers.DASH
ROUNDING_NOTE = (
    "Rounded as the paper rounds, or to 3 digits where it gives more; a group's "
    "mean to the decimal of its SD, given to 2 digits, and no finer than its rows; "
    "p to 2 digits; table1.csv keeps the paper's rounding."
)
BAND_NOTE = (
    "An embryo's Speed cycle is followed by its 95 % band in brackets: the run's "
    "own noise and the share the accuracy zoo found beyond it (qc.csv "
    "speed_cycle_band_95_mm_s); ± is a group's SD."
)
POOR_MARK = " †"
POOR_NOTE = (
    "†: a wave speed whose spread from the map's frame-to-frame noise alone is over "
    "{share:.0%} of it (qc.csv *_noise_sd_mm_s; the embryo's notes give it)."
)
NO_VALUE_NOTE = (
    "–: no value: not resolved within the map's noise (a wave speed), or not "
    "measurable on this embryo (see its summary.json notes)."
)
# how the p-values of the Table 1 quantities are corrected (stated where they are shown)
CORRECTION = "Holm"


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


def rounded(x: float, column: Column) -> float:
    """``x`` (in summary.json's unit) in the column's unit, rounded as it says."""
    return round_as(float(x) * column.scale, column)


def round_as(x: float, column: Column) -> float:
    """``x`` (in the column's unit) rounded as the column says."""
    if not np.isfinite(x):
        return x
    if column.decimals is not None:
        return round(x, column.decimals) if column.decimals else float(round(x))
    if column.significant is not None and x != 0:
        return round(x, column.significant - 1 - math.floor(math.log10(abs(x))))
    return x


def table_rows(summaries: list[dict], columns: list[Column]) -> list[dict]:
    """One row per summary: column name -> its value in the column's unit and
    rounding ("" where there is none)."""
    rows = []
    for s in summaries:
        row = {}
        for c in columns:
            v = _get(s, c.path)
            numeric = isinstance(v, (int, float)) and not isinstance(v, bool)
            row[c.name] = (
                rounded(v, c)
                if numeric
                and (c.scale != 1.0 or c.decimals is not None or c.significant is not None)
                else v
            )
        rows.append(row)
    return rows


def cohort_rows(summaries: list[dict]) -> list[dict]:
    """Rows of ``cohort.csv`` (:data:`MEASUREMENT_COLUMNS`)."""
    return table_rows(summaries, MEASUREMENT_COLUMNS)


def _write_csv(path: Path, header: list[str], rows: list[dict]) -> Path:
    with open(path, "w", newline="") as fh:
        writer = csv.DictWriter(fh, fieldnames=header)
        writer.writeheader()
        writer.writerows(rows)
    return path


def write_cohort_tables(folder: Path, summaries: list[dict]) -> list[Path]:
    """``table1.csv``, ``cohort.csv`` and ``qc.csv`` (one row per dataset, see
    :data:`TABLES`) and ``columns.csv``, the data dictionary of all three: table,
    column, unit, rounding, what it is and how it is made, summary.json key."""
    written = [
        _write_csv(Path(folder) / file, [c.name for c in columns], table_rows(summaries, columns))
        for file, columns in TABLES.items()
    ]
    dictionary = []
    for file, columns in TABLES.items():
        for c in columns:
            rounding = (
                f"{c.decimals} decimals"
                if c.decimals is not None
                else f"{c.significant} significant digits"
                if c.significant is not None
                else "as computed"
            )
            dictionary.append(
                {
                    "table": file,
                    "column": c.name,
                    "unit": c.unit,
                    "rounding": rounding,
                    "description": c.what,
                    "summary_json": ".".join(c.path)
                    + (f" x {c.scale:g}" if c.scale != 1.0 else ""),
                }
            )
    written.append(_write_csv(Path(folder) / "columns.csv", list(dictionary[0]), dictionary))
    return written


def _group_values(summaries: list[dict], column: Column, groups: list[str]) -> dict:
    """Each group's finite values of a column, in the column's unit (unrounded)."""
    values = {}
    for g in groups:
        vals = [_get(s, column.path) for s in summaries if s["group"] == g]
        vals = [
            float(v) * column.scale
            for v in vals
            if isinstance(v, (int, float)) and not isinstance(v, bool)
        ]
        values[g] = np.asarray([v for v in vals if np.isfinite(v)], float)
    return values


# beyond Table 1, the measurements a group comparison tests: the wave's fronts, and the
# cushions' valve action (how elliptical the lumen at its narrowest, how long it closes)
TESTED_FRONTS = ("front_speed_mm_s", "front_helix_angle_deg")
TESTED_CUSHIONS = ("lumen_aspect_ratio_narrowest", "lumen_closed_share_max")


def group_comparison(summaries: list[dict]) -> list[dict]:
    """Per cohort metric and pair of groups (in name order): the table it is in, each
    group's n, mean and sd (in the column's unit), and for the Table 1 quantities
    alone the two-sided permutation p-value (``p_value``) and that p-value corrected
    by Holm's method over all Table 1 quantities and pairs of groups (``p_holm``),
    and so too the wave's speed and helix angle on the outer wall
    (:data:`TESTED_FRONTS`) and the lumen's narrowest aspect ratio and largest closed
    share (:data:`TESTED_CUSHIONS`), not in the paper, in the same Holm family; the other
    measurements and the quality checks are shown, not tested (NaN).
    With one group: its n, mean and sd, no p-values."""
    from itertools import combinations

    groups = sorted({s["group"] for s in summaries})
    pairs = list(combinations(groups, 2))
    out = []
    for file, columns in TABLES.items():
        for column in columns:
            if column in ID_COLUMNS or column.name == "n_frames":
                continue
            values = _group_values(summaries, column, groups)
            if not any(len(v) for v in values.values()):
                continue
            stats = {"metric": column.name, "table": file, "unit": column.unit}
            for g in groups:
                v = values[g]
                stats[f"{g}_n"] = len(v)
                stats[f"{g}_mean"] = float(v.mean()) if len(v) else float("nan")
                stats[f"{g}_sd"] = float(v.std(ddof=1)) if len(v) > 1 else float("nan")
            tested = file == "table1.csv" or column.name in TESTED_FRONTS + TESTED_CUSHIONS
            for a, b in pairs or [(groups[0], None)]:
                p = permutation_test(values[a], values[b]) if tested and b else float("nan")
                out.append(
                    {
                        **stats,
                        "groups": a if b is None else f"{a} vs {b}",
                        "p_value": p,
                        "p_holm": float("nan"),
                    }
                )
    tested_rows = [r for r in out if np.isfinite(r["p_value"])]
    for row, p_adjusted in zip(tested_rows, holm([r["p_value"] for r in tested_rows])):
        row["p_holm"] = p_adjusted
    return out


# a column name's unit suffix, longest first, as a header writes it in brackets
_UNIT_SUFFIXES = (
    "_mm2_ms",
    "_mm_s",
    "_per_mm",
    "_percent",
    "_mm3",
    "_mm2",
    "_deg",
    "_ms",
    "_mm",
    "_um",
)


def column_header(column: Column) -> str:
    """A column's header as a person reads it: its name in words without the unit
    suffix, the unit typeset in brackets ("wall thickness median (mm)" for
    ``wall_thickness_median_mm``); the CSV keeps the name."""
    name = column.name
    for suffix in _UNIT_SUFFIXES:
        if name.endswith(suffix):
            name = name[: -len(suffix)]
            break
    shown = numbers.unit(column.unit)
    return name.replace("_", " ") + (f" ({shown})" if shown else "")


def statistics_note(comparison: list[dict]) -> str:
    """What the p-values of ``comparison`` (:func:`group_comparison`'s rows) are, said
    from what was tested: the test, the smallest p it can give the groups' sizes, the
    quantities tested (Table 1's and those beyond it by name) and the correction over
    them and the pairs of groups; "" when nothing was tested."""
    from ..analysis.stats import smallest_permutation_p

    tested = [r for r in comparison if np.isfinite(r["p_value"])]
    if not tested:
        return ""
    metrics = list(dict.fromkeys(r["metric"] for r in tested))
    in_table1 = [
        m for m in metrics if any(r["table"] == "table1.csv" and r["metric"] == m for r in tested)
    ]
    beyond = [m for m in metrics if m not in in_table1]
    pairs = list(dict.fromkeys(r["groups"] for r in tested))
    floors = []
    for pair in pairs:
        a, b = pair.split(" vs ")
        rows = [r for r in tested if r["groups"] == pair]
        n, m = max(r[f"{a}_n"] for r in rows), max(r[f"{b}_n"] for r in rows)
        floors.append(f"{n} {a} against {m} {b}: {numbers.p_value(smallest_permutation_p(n, m))}")
    what = (
        f"the {len(in_table1)} Table 1 quantit{'y' if len(in_table1) == 1 else 'ies'}"
        if in_table1
        else ""
    ) + ((" and " if in_table1 else "") + ", ".join(beyond) + " (cohort.csv)" if beyond else "")
    return (
        f"p: two-sided permutation test of the difference of means (exact for up to 10 "
        f"embryos per group; the smallest p it can give, {'; '.join(floors)}), for "
        f"{what}; p ({CORRECTION}): corrected over these {len(metrics)} quantities"
        + (f" and the {len(pairs)} pairs of groups" if len(pairs) > 1 else "")
        + "."
    )


def _cell(x, column: Column | None = None) -> str:
    """A table cell's text as a reader sees it: a number rounded as its column is
    (:data:`~oftimg.output.numbers.SIGNIFICANT` digits where the paper gives more or
    no rounding), "" for none."""
    if isinstance(x, float):
        if not np.isfinite(x):
            return ""
        if column is not None and column.decimals is not None:
            return numbers.with_decimals(round_as(x, column), column.decimals)
        return numbers.number(
            x,
            min(column.significant or numbers.SIGNIFICANT, numbers.SIGNIFICANT)
            if column
            else numbers.SIGNIFICANT,
        )
    return "" if x is None else str(x)


def table1_layout(
    summaries: list[dict], comparison: list[dict] | None = None
) -> tuple[list[str], list[list[str]], str]:
    """Table 1 as the paper lays it out, as text: the header (quantity and unit), one
    row per embryo (the paper's rounding), each group's mean ± SD (n), each pair
    of groups' p-value and its correction; and the note that says how p was made ("" with
    one group)."""
    data_cols = TABLE1_COLUMNS[2:]
    header = ["Embryo", "Group"] + [
        TABLE1_LABELS[c.name] + (f" ({numbers.unit(c.unit)})" if numbers.unit(c.unit) else "")
        for c in data_cols
    ]
    body = [
        [_cell(row["name"]), _cell(row["group"])]
        + [_with_band(row[c.name], c, summary) or NO_VALUE for c in data_cols]
        for row, summary in zip(table_rows(summaries, TABLE1_COLUMNS), summaries)
    ]
    banded = any(
        (s.get("wave_speed_band_95_mm_s") or {}).get("cycle") is not None for s in summaries
    )
    blank = any(NO_VALUE in row for row in body)
    poor = any(cell.endswith(POOR_MARK) for row in body for cell in row)
    comparison = group_comparison(summaries) if comparison is None else comparison
    by_metric = {}
    for r in comparison:
        if r["table"] == "table1.csv":
            by_metric.setdefault(r["metric"], []).append(r)
    groups = sorted({s["group"] for s in summaries})
    for g in groups:
        cells, counts = [], []
        for c in data_cols:
            r = by_metric.get(c.name, [{}])[0]
            mean, sd, n = r.get(f"{g}_mean"), r.get(f"{g}_sd"), r.get(f"{g}_n", 0)
            decimals = (
                c.decimals
                if c.decimals is not None
                else numbers.decimals_of(
                    mean, min(c.significant or numbers.SIGNIFICANT, numbers.SIGNIFICANT)
                )
            )
            cells.append("" if not n else numbers.mean_sd(mean, sd, decimals))
            counts.append(n)
        shown = {n for n in counts if n}
        if len(shown) == 1:  # every column of the same embryos: n said once
            body.append(["mean ± SD", f"{_cell(g)} (n={shown.pop()})"] + cells)
        else:
            body.append(
                ["mean ± SD", _cell(g)]
                + [f"{cell} (n={n})" if n else cell for cell, n in zip(cells, counts)]
            )
    pairs = (
        []
        if len(groups) < 2
        else sorted({r["groups"] for r in comparison if " vs " in r["groups"]})
    )
    for pair in pairs:
        for key, label in (("p_value", "p"), ("p_holm", f"p ({CORRECTION})")):
            cells = []
            for c in data_cols:
                r = next((r for r in by_metric.get(c.name, []) if r["groups"] == pair), None)
                cells.append(
                    ""
                    if r is None or not np.isfinite(r[key])
                    else numbers.p_value(r[key])
                    + (" *" if key == "p_holm" and r[key] < 0.05 else "")
                )
            body.append([label, _cell(pair)] + cells)
    note = (
        statistics_note(comparison) + f" *: {CORRECTION}-corrected p < 0.05. Each "
        "column is described in columns.csv."
        if pairs
        else ""
    )
    if banded:
        note += (" " if note else "") + BAND_NOTE
    if poor:
        from ..analysis.maps import SPREAD_NOTE_SHARE

        note += (" " if note else "") + POOR_NOTE.format(share=SPREAD_NOTE_SHARE)
    if blank:
        note += (" " if note else "") + NO_VALUE_NOTE
    flat = [s["name"] for s in summaries if s.get("area_wave") is False]
    if flat:
        from ..image.kymograph import AREA_WAVE_MIN_SWING

        note += (
            f" {', '.join(map(str, flat))}: the sections' areas change by under "
            f"{100 * AREA_WAVE_MIN_SWING:g} % over the beat (a helical wave moves the "
            "ring's parts in turn), so the area map holds no wave to time and the speeds "
            "and expansion share are blank; the wave on the wall is in cohort.csv "
            "(front_speed_mm_s, front_helix_angle_deg) and on the embryo's page."
        )
    note += (" " if note else "") + ROUNDING_NOTE
    return header, body, note


def _with_band(value, column: Column, summary: dict) -> str:
    """A Table 1 cell of one embryo: its value, for the cycle speed with its 95 % band
    in brackets (:func:`~oftimg.analysis.uncertainty.speed_band_95`) when the run has one (no
    finer than the other rows), and :data:`POOR_MARK` after a speed whose noise spread
    is over :data:`~oftimg.analysis.maps.SPREAD_NOTE_SHARE` of it (the run's notes
    name it: the cell says so too)."""
    band = (summary.get("wave_speed_band_95_mm_s") or {}).get("cycle")
    if not numbers.is_finite_number(value):
        return _cell(value, column)
    if column.name == "speed_cycle_mm_s" and band is not None:
        text = numbers.with_interval(value, band, numbers.decimals_of(value))
    else:
        text = _cell(value, column)
    return text + (POOR_MARK if _poorly_resolved(value, column, summary) else "")


def _poorly_resolved(value: float, column: Column, summary: dict) -> bool:
    """Whether a wave speed's noise spread (summary.json wave_speed_noise_sd_mm_s) is
    over :data:`~oftimg.analysis.maps.SPREAD_NOTE_SHARE` of it, or undefined."""
    from ..analysis.maps import SPREAD_NOTE_SHARE

    noise = summary.get("wave_speed_noise_sd_mm_s") or {}
    if column.path[0] != "wave_speed_mm_s" or column.path[1] not in noise:
        return False  # no spread of its own (the speeds' SD)
    sd = noise[column.path[1]]
    return not numbers.is_finite_number(sd) or sd > SPREAD_NOTE_SHARE * abs(value)


def table1_markdown(summaries: list[dict], comparison: list[dict] | None = None) -> str:
    """:func:`table1_layout` as a Markdown table and its note."""
    header, body, note = table1_layout(summaries, comparison)
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    lines += ["| " + " | ".join(cell.replace("|", r"\|") for cell in row) + " |" for row in body]
    return "\n".join(lines) + "\n" + (f"\n{note}\n" if note else "")


def write_table1_markdown(
    folder: Path, summaries: list[dict], comparison: list[dict] | None = None
) -> Path:
    """``table1.md``: :func:`table1_markdown`."""
    path = Path(folder) / "table1.md"
    path.write_text(table1_markdown(summaries, comparison))
    return path


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
    ranges = "; ".join(
        f"{g}: {min(v):g}" + (f"-{max(v):g}" if max(v) > min(v) else "") + " ms"
        for g, v in sorted(by_group.items())
    )
    return ranges, max(x for v in by_group.values() for x in v)


def smoothing_caveat(summaries: list[dict]) -> str | None:
    """What to know before comparing groups whose embryos' ridges were smoothed in time
    by different sigmas (``ridge_smoothing_ms``: "auto" takes as much as each map's
    noise needs); None when there is one group or one sigma."""
    found = _sigmas_by_group(summaries, lambda s: s.get("ridge_smoothing_ms"))
    if found is None:
        return None
    ranges, largest = found
    return (
        f"the embryos' ridges were smoothed in time by different sigmas ({ranges}), as "
        "their maps' noise asked: more smoothing puts the ridge later where the beat's "
        "peak is asymmetric, so group differences in ridge times, and in wave speeds where "
        "the expansion share changes along the tube, may come from it "
        "(oftimg's docs/accuracy.md); to compare the groups, analyse them all with "
        f"--ridge-smoothing-ms {largest:g}"
    )


# the fields whose sigma "auto" chooses per dataset: summary key -> (what, run option)
FIELD_SIGMAS = {
    "field_smoothing_ms": ("shape fields", "--field-smoothing-ms"),
    "strain_smoothing_ms": ("strain fields (their grid nodes)", "--strain-smoothing-ms"),
}


def field_smoothing_caveat(summaries: list[dict], key: str = "field_smoothing_ms") -> str | None:
    """The same for the curvature and thickness fields (``field_smoothing_ms``,
    per field: "auto" takes as much as each field's noise needs), or the strain
    fields (``key="strain_smoothing_ms"``); None when each field's sigma is the
    same in every group."""
    what, option = FIELD_SIGMAS[key]
    names = sorted({n for s in summaries if isinstance(s.get(key), dict) for n in s[key]})
    differing, largest = [], 0.0
    for name in names:
        found = _sigmas_by_group(
            summaries, lambda s: s[key].get(name) if isinstance(s.get(key), dict) else None
        )
        if found is not None:
            differing.append(f"{name} ({found[0]})")
            largest = max(largest, found[1])
    if not differing:
        return None
    return (
        f"the embryos' {what} were smoothed in time by different sigmas, as "
        f"their noise asked: {', '.join(differing)}; more smoothing lowers and widens "
        "each pixel's peaks over the cycle, so group differences in those fields' size "
        "and phase maps may come from it (oftimg's docs/accuracy.md); to compare the groups, "
        f"analyse them all with {option} {largest:g}"
    )


def map_comparison_rows(maps: dict, alpha: float = 0.05) -> list[dict]:
    """Per comparison of groups and tested map of ``maps``
    (:func:`oftimg.output.export.cohort_maps`, its maps :data:`~oftimg.analysis.group_maps.TESTED_MAPS`): the least p pixel by pixel and by cluster,
    and the share of the map (of its pixels with a value) in clusters with p below
    ``alpha``."""
    rows = []
    for k, name in enumerate(maps["comparisons"]):
        for key in TESTED_MAPS:
            p_fwer, p_cluster = maps[f"{key}_p_fwer"][k], maps[f"{key}_p_cluster"][k]
            tested_pixels = np.isfinite(p_cluster)
            rows.append(
                {
                    "comparison": str(name),
                    "map": key,
                    "least_p_pixel": float(np.nanmin(p_fwer)) if tested_pixels.any() else None,
                    "least_p_cluster": float(np.nanmin(p_cluster)) if tested_pixels.any() else None,
                    f"share_in_clusters_p<{alpha:g}": (
                        float(np.mean(p_cluster[tested_pixels] < alpha))
                        if tested_pixels.any()
                        else None
                    ),
                }
            )
    return rows


def write_groups_table(
    folder: Path, summaries: list[dict], comparison: list[dict] | None = None
) -> Path | None:
    """``groups.csv``: :func:`group_comparison`'s rows (two groups or more), an empty
    cell where there is no value (no p: not tested; no SD: one embryo);
    ``comparison``: :func:`group_comparison` of ``summaries`` if already made."""
    rows = group_comparison(summaries) if comparison is None else comparison
    if not rows or len({s["group"] for s in summaries}) < 2:
        return None
    blank = [
        {
            k: "" if isinstance(v, float) and not np.isfinite(v) else v  # not "nan"
            for k, v in row.items()
        }
        for row in rows
    ]
    return _write_csv(Path(folder) / "groups.csv", list(rows[0]), blank)


def mean_curve(
    curves: list[tuple], x: np.ndarray, *, period: float | None = None, min_share: float = 0.5
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Mean, SD (ddof 1) and count of a group's curves ``[(x_k, y_k), ...]`` on the
    common ``x``.

    Each curve is interpolated linearly onto ``x``: NaN outside its own range
    (a shorter tube has no value there), or periodically with ``period`` (a
    cycle). Where fewer than ``min_share`` of the curves (and fewer than 2)
    have a value, mean and SD are NaN. Returns three ``(len(x),)`` arrays.
    """
    Y = np.array(
        [
            np.interp(x, xk, yk, period=period)
            if period is not None
            else np.interp(x, xk, yk, left=np.nan, right=np.nan)
            for xk, yk in curves
        ]
    )
    count = np.isfinite(Y).sum(axis=0)
    enough = count >= max(2, min_share * len(curves))
    mean = np.full(len(x), np.nan)
    sd = np.full(len(x), np.nan)
    if enough.any():
        mean[enough] = np.nanmean(Y[:, enough], axis=0)
        sd[enough] = np.nanstd(Y[:, enough], axis=0, ddof=1)
    return mean, sd, count
