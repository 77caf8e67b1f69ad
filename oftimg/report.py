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
    ("max_area_neck_depth", ("max_area_neck_depth",)),
    ("corner_count", ("corner_count",)),
    ("tube_length_mm", ("tube_length_mm",)),
    ("myocardial_volume_change", ("myocardial_volume_change",)),
    # quality checks: 0, 0 and about 0 on good data
    ("flipped_triangles_outer", ("flipped_triangles", "outer")),
    ("sections_from_ring_outer", ("sections_from_ring", "outer")),
    ("section_volume_error_outer", ("section_volume_error", "outer")),
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


def write_cohort_markdown(folder: Path, summaries: list[dict]) -> Path:
    """``cohort.md``: the cohort table as Markdown (3 significant digits)."""
    rows = cohort_rows(summaries)
    cols = [c for c, _ in COHORT_COLUMNS]

    def fmt(x):
        if isinstance(x, float):
            return "nan" if x != x else f"{x:.3g}"
        return "" if x is None else str(x)

    lines = ["| " + " | ".join(cols) + " |", "|" + "---|" * len(cols)]
    lines += ["| " + " | ".join(fmt(r[c]) for c in cols) + " |" for r in rows]
    path = Path(folder) / "cohort.md"
    path.write_text("\n".join(lines) + "\n")
    return path


def permutation_test(a, b, *, n_random: int = 20000, seed: int = 0) -> float:
    """Two-sided permutation test of the difference of means; returns the p-value.

    Exact (every relabelling) when both groups have at most 10 members, else
    ``n_random`` random relabellings. NaN values are left out.
    """
    from itertools import combinations

    import numpy as np

    a = np.asarray([x for x in a if x == x], float)
    b = np.asarray([x for x in b if x == x], float)
    if len(a) < 2 or len(b) < 2:
        return float("nan")
    pooled = np.concatenate([a, b])
    observed = abs(a.mean() - b.mean())
    n = len(a)
    tol = 1e-12 * max(1.0, abs(observed))
    if len(a) <= 10 and len(b) <= 10:
        total = pooled.sum()
        diffs = []
        for idx in combinations(range(len(pooled)), n):
            s = pooled[list(idx)].sum()
            diffs.append(abs(s / n - (total - s) / len(b)))
        diffs = np.asarray(diffs)
        return float(np.mean(diffs >= observed - tol))
    rng = np.random.default_rng(seed)
    count = 0
    for _ in range(n_random):
        p = rng.permutation(pooled)
        count += abs(p[:n].mean() - p[n:].mean()) >= observed - tol
    return float((count + 1) / (n_random + 1))


def group_comparison(summaries: list[dict]) -> list[dict]:
    """Per numeric cohort metric: each group's n, mean, sd, and the permutation p-value
    (first two groups in name order)."""
    import numpy as np

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
        row = {"metric": col}
        for g in groups:
            v = values[g][np.isfinite(values[g])]
            row[f"{g}_n"] = len(v)
            row[f"{g}_mean"] = float(v.mean()) if len(v) else float("nan")
            row[f"{g}_sd"] = float(v.std(ddof=1)) if len(v) > 1 else float("nan")
        row["p_value"] = (permutation_test(values[groups[0]], values[groups[1]])
                          if len(groups) >= 2 else float("nan"))
        row["groups"] = " vs ".join(groups[:2])
        out.append(row)
    return out


def write_groups_table(folder: Path, summaries: list[dict]) -> Path | None:
    """``groups.csv``: group means, sds and permutation p-values (two groups or more)."""
    rows = group_comparison(summaries)
    if not rows or len({s["group"] for s in summaries}) < 2:
        return None
    path = Path(folder) / "groups.csv"
    fields = list(rows[0])
    with open(path, "w", newline="") as fh:
        writer = csv.DictWriter(fh, fieldnames=fields)
        writer.writeheader()
        writer.writerows(rows)
    return path
