"""Cohort tables: one row per dataset (the paper's Table 1 and more)."""
from __future__ import annotations

import csv
from pathlib import Path

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
    ("speed_cycle_mm_s", ("wave_speed_mm_s", "cycle")),
    ("speed_proximal_mm_s", ("wave_two_segment", "speed_proximal_mm_s")),
    ("speed_distal_mm_s", ("wave_two_segment", "speed_distal_mm_s")),
    ("knee_mm", ("wave_two_segment", "knee_mm")),
    ("max_expansion_rate_mm2_ms", ("max_expansion_rate_mm2_ms",)),
    ("max_contraction_rate_mm2_ms", ("max_contraction_rate_mm2_ms",)),
    ("band_position_mm", ("band_position_mm",)),
    ("corner_count", ("corner_count",)),
    ("tube_length_mm", ("tube_length_mm",)),
    ("myocardial_volume_change", ("myocardial_volume_change",)),
    ("flipped_triangles_outer", ("flipped_triangles", "outer")),
]


def _get(d: dict, path: tuple):
    for key in path:
        if not isinstance(d, dict) or key not in d:
            return ""
        d = d[key]
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
