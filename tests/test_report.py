"""Cohort tables and the group comparison (issue 10)."""

import numpy as np
import pytest

from oftimg.output import numbers
from oftimg.output.report import (
    cohort_rows,
    group_comparison,
    map_comparison_rows,
    mean_curve,
    table1_layout,
    table1_markdown,
    write_cohort_tables,
    write_table1_markdown,
)
from oftimg.analysis.stats import holm, permutation_test


def test_exact_permutation_test():
    a, b = [1.0, 2.0, 3.0, 4.0], [11.0, 12.0, 13.0, 14.0]
    # complete separation of 4 vs 4: the two extreme relabellings out of 70
    assert permutation_test(a, b) == pytest.approx(2 / 70)
    assert permutation_test([1, 2, 3, 4], [1, 2, 3, 4]) == pytest.approx(1.0)
    assert np.isnan(permutation_test([1.0], [2.0, 3.0]))


def test_exact_permutation_test_of_10_against_10():
    a, b = np.arange(10.0), np.arange(10.0) + 100
    assert permutation_test(a, b) == pytest.approx(2 / 184756)  # of C(20, 10) relabellings


def test_random_permutation_test_agrees_with_every_relabelling():
    from itertools import combinations

    rng = np.random.default_rng(1)
    a, b = rng.normal(0, 1, 11), rng.normal(1.0, 1, 3)  # 11 > 10: random relabellings
    pooled = np.concatenate([a, b])
    observed = abs(a.mean() - b.mean())
    exact = np.mean(
        [
            abs(np.delete(pooled, list(i)).mean() - pooled[list(i)].mean()) >= observed
            for i in combinations(range(14), 3)
        ]
    )
    assert 0.02 < exact < 0.5
    assert permutation_test(a, b) == pytest.approx(exact, abs=0.01)  # 4 standard errors


def test_random_permutation_test_for_large_groups():
    rng = np.random.default_rng(1)
    a, b = rng.normal(0, 1, 15), rng.normal(0, 1, 15) + 3
    assert permutation_test(a, b, n_random=2000) < 0.01
    same = permutation_test(rng.normal(0, 1, 15), rng.normal(0, 1, 15), n_random=2000)
    assert same > 0.01


def test_group_comparison_rows():
    """Table 1 quantities are tested, Holm-corrected over all of them; the other
    measurements and the quality checks are shown (n, mean, sd), not tested."""
    summaries = [
        {
            "name": f"n{k}",
            "group": "normal",
            "period_ms": 350.0 + k,
            "expand_fraction": 0.40 + 0.01 * k,
            "max_area_neck_depth": 0.0,
            "flipped_triangles": {"outer": 0},
        }
        for k in range(4)
    ]
    summaries += [
        {
            "name": f"b{k}",
            "group": "banded",
            "period_ms": 351.0 + k,
            "expand_fraction": 0.30 + 0.01 * k,
            "max_area_neck_depth": 0.3 + 0.01 * k,
            "flipped_triangles": {"outer": 1},
        }
        for k in range(4)
    ]
    rows = {r["metric"]: r for r in group_comparison(summaries)}
    assert rows["expand_percent"]["p_value"] == pytest.approx(2 / 70)
    assert rows["expand_percent"]["normal_mean"] == pytest.approx(41.5)  # in %, as Table 1
    assert rows["period_ms"]["p_value"] > 0.3
    assert rows["period_ms"]["normal_mean"] == pytest.approx(351.5)
    assert len(cohort_rows(summaries)) == 8
    # corrected over the two Table 1 quantities present: the smaller p twice
    assert rows["expand_percent"]["p_holm"] == pytest.approx(4 / 70)
    assert rows["period_ms"]["groups"] == "banded vs normal"
    for untested in ("max_area_neck_depth", "flipped_triangles_outer"):
        assert np.isnan(rows[untested]["p_value"]) and np.isnan(rows[untested]["p_holm"])
    assert rows["max_area_neck_depth"]["banded_mean"] == pytest.approx(0.315)
    assert rows["flipped_triangles_outer"]["table"] == "qc.csv"


def test_table1_in_the_papers_units_and_rounding(tmp_path):
    """The paper's Table 1: % with 2 decimals, ms whole, speeds to 5 significant digits;
    a group row mean ± SD (n) and a corrected p row; columns.csv describes every
    column of every table."""
    import csv

    summary = {
        "name": "Normal A",
        "group": "normal",
        "expand_fraction": 0.382712,
        "contract_fraction": 0.617288,
        "expand_contract_ratio": 0.61998,
        "period_ms": 372.2,
        "expand_ms": 142.46,
        "contract_ms": 229.74,
        "wave_speed_mm_s": {
            "min": 3.360123,
            "max": 18.49876,
            "mean": 8.961934,
            "std": 3.424517,
            "cycle": 6.814912,
        },
        "myocardial_volume_change": 0.16750693,
        "clipped_myocardial_volume_mm3": 0.0241060,
    }
    summaries = [
        summary,
        {**summary, "name": "Normal B", "expand_fraction": 0.3418},
        {**summary, "name": "Banded A", "group": "banded", "expand_fraction": 0.3622},
        {**summary, "name": "Banded B", "group": "banded", "expand_fraction": 0.4439},
    ]
    write_cohort_tables(tmp_path, summaries)
    row = next(csv.DictReader(open(tmp_path / "table1.csv")))
    assert row["expand_percent"] == "38.27" and row["contract_percent"] == "61.73"
    assert row["expand_contract_ratio"] == "0.62" and row["period_ms"] == "372.0"
    assert row["speed_min_mm_s"] == "3.3601" and row["speed_max_mm_s"] == "18.499"
    assert row["myocardial_volume_change_percent"] == "16.8"
    assert row["clipped_myocardial_volume_mm3"] == "0.02411"
    dictionary = list(csv.DictReader(open(tmp_path / "columns.csv")))
    for table in ("table1.csv", "cohort.csv", "qc.csv"):
        header = next(csv.reader(open(tmp_path / table)))
        described = [d["column"] for d in dictionary if d["table"] == table]
        assert header == described
    assert all(d["description"] and d["summary_json"] for d in dictionary)
    text = table1_markdown(summaries)
    assert "| Normal A | normal | 38.27 | 61.73 | 0.62 | 372 | 142 | 230 | 3.36 | 18.5 |" in text
    assert "| mean ± SD | banded (n=2) | 40.3 ± 5.8 |" in text  # to the SD's 2 digits
    assert "| p | banded vs normal | 0.67 |" in text  # 2 vs 2: 4 of 6 relabellings as far
    assert "| p (Holm) | banded vs normal | 1.0 | 1.0 |" in text  # 13 tests, 2 digits
    assert "p (Holm): corrected over these 13 quantities." in text
    assert "the smallest p it can give, 2 banded against 2 normal: 0.33" in text
    assert "the 13 Table 1 quantities;" in text
    assert "†" not in text  # no speed's noise given: none marked


def test_table1_marks_a_speed_lost_in_the_noise_and_rounds_means_as_rows():
    """A speed whose noise spread is over a fifth of it carries a mark and the note says
    why; a group's mean is given no finer than its embryos' rows (13.8, not 13.83)."""
    from oftimg.analysis.maps import SPREAD_NOTE_SHARE

    def embryo(name, group, cycle, max_sd):
        return {
            "name": name,
            "group": group,
            "period_ms": 300.0,
            "wave_speed_mm_s": {"min": 5.0, "max": 24.6, "mean": 12.0, "std": 4.0, "cycle": cycle},
            "wave_speed_noise_sd_mm_s": {"min": 0.1, "max": max_sd, "mean": 0.2, "cycle": 0.05},
        }

    poor = 24.6 * SPREAD_NOTE_SHARE * 1.1
    summaries = [
        embryo("A", "normal", 13.83, poor),
        embryo("B", "normal", 13.81, 0.3),
        embryo("C", "banded", 9.0, 0.3),
        embryo("D", "banded", 9.4, 0.3),
    ]
    header, body, note = table1_layout(summaries)
    column = {name: k for k, name in enumerate(header)}
    rows = {row[0] if row[0] != "mean ± SD" else row[1].split()[0]: row for row in body}
    assert rows["A"][column["Speed max (mm/s)"]] == "24.6 †"
    assert rows["B"][column["Speed max (mm/s)"]] == "24.6"
    assert rows["A"][column["Speed min (mm/s)"]] == "5.00"
    assert f"over {SPREAD_NOTE_SHARE:.0%} of it" in note
    assert rows["normal"][column["Speed cycle (mm/s)"]] == "13.8 ± 0.0"  # as its rows
    assert rows["normal"][1] == "normal (n=2)"  # the same embryos in every column


def test_p_values_read_alike_in_every_table():
    """Table 1 and the report's tables: 0.10, not 0.1 in one and 0.100 in another."""
    from oftimg.output import html

    assert numbers.p_value(0.1) == "0.10" and numbers.p_value(0.0321) == "0.032"
    table = html._table(
        [
            {
                "metric": "x",
                "p_value": 0.1,
                "p_holm": 1.0,
                "least_p_cluster": 0.25,
                "banded_mean": 0.1,
            }
        ],
        ["metric", "p_value", "p_holm", "least_p_cluster", "banded_mean"],
    )
    assert "<td>0.10</td><td>1.0</td><td>0.25</td><td>0.100</td>" in table


def test_holm_adjusted_p_values():
    assert holm([0.01, 0.04, 0.03]) == pytest.approx([0.03, 0.06, 0.06])
    assert holm([0.6, 0.7]) == [1.0, 1.0]
    adjusted = holm([float("nan"), 0.02])  # NaN is not a test
    assert np.isnan(adjusted[0]) and adjusted[1] == pytest.approx(0.02)


def test_every_pair_of_three_groups_is_compared():
    summaries = [
        {"name": f"{g}{k}", "group": g, "period_ms": 350.0 + k + (30 if g == "c" else 0)}
        for g in "abc"
        for k in range(4)
    ]
    rows = {r["groups"]: r for r in group_comparison(summaries) if r["metric"] == "period_ms"}
    assert sorted(rows) == ["a vs b", "a vs c", "b vs c"]
    assert rows["a vs b"]["p_value"] == pytest.approx(1.0)
    assert rows["a vs c"]["p_value"] == pytest.approx(2 / 70)  # complete separation, 4 vs 4
    assert rows["a vs c"]["p_holm"] == pytest.approx(6 / 70)  # the smallest of 3, x 3
    assert rows["a vs c"]["c_mean"] == pytest.approx(381.5)


def test_mean_curve_of_a_group_on_a_common_axis():
    x = np.array([0.0, 0.5, 1.0, 1.5, 2.0])
    long, short = (
        (np.array([0.0, 1.0, 2.0]), np.array([0.0, 1.0, 2.0])),
        (np.array([0.0, 1.0]), np.array([2.0, 3.0])),
    )  # y = x, y = x + 2 up to 1
    mean, sd, count = mean_curve([long, short], x)
    assert count.tolist() == [2, 2, 2, 1, 1]
    assert np.allclose(mean[:3], x[:3] + 1) and np.isnan(mean[3:]).all()  # one curve: none
    assert np.allclose(sd[:3], np.sqrt(2))  # SD with ddof 1
    mean, _, _ = mean_curve([long, short, long], x)  # 2 of 3 reach 1.5 and 2
    assert np.allclose(mean, [2 / 3, 7 / 6, 5 / 3, 1.5, 2.0], equal_nan=True)
    cycle, _, _ = mean_curve(
        [(np.array([0.0, 0.5]), np.array([0.0, 1.0]))] * 2, np.array([0.25, 0.75]), period=1.0
    )
    assert np.allclose(cycle, [0.5, 0.5])  # 0.75 lies between 0.5 and 1 = 0


def test_markdown_table_keeps_a_name_with_a_bar_in_its_cell(tmp_path):
    summaries = [
        {"name": "WT|3", "group": "a|b", "period_ms": 350.0},
        {"name": "KO", "group": "c", "period_ms": 351.0},
    ]
    lines = write_table1_markdown(tmp_path, summaries).read_text().splitlines()
    cells = lambda line: len(line.replace(r"\|", "").split("|"))  # noqa: E731
    assert cells(lines[2]) == cells(lines[0]) == cells(lines[3])
    assert lines[2].startswith(r"| WT\|3 | a\|b | ")


def test_smoothing_caveat_only_where_groups_were_smoothed_differently():
    from oftimg.output.report import smoothing_caveat

    def cohort(sigmas):
        return [
            {"name": f"e{k}", "group": g, "ridge_smoothing_ms": s}
            for k, (g, s) in enumerate(sigmas)
        ]

    assert smoothing_caveat(cohort([("a", 5.0), ("a", 5.0), ("b", 5.0)])) is None
    assert smoothing_caveat(cohort([("a", 5.0), ("a", 14.0)])) is None  # one group
    assert smoothing_caveat(cohort([("a", 5.0), ("b", float("nan"))])) is None
    text = smoothing_caveat(cohort([("a", 5.0), ("a", 7.0), ("b", 20.0)]))
    assert "a: 5-7 ms; b: 20 ms" in text and text.endswith("--ridge-smoothing-ms 20")


def test_field_smoothing_caveat_names_the_fields_smoothed_differently():
    from oftimg.output.report import field_smoothing_caveat

    def cohort(sigmas):
        return [
            {"name": f"e{k}", "group": g, "field_smoothing_ms": {"radial": radial, "lumen": 20.0}}
            for k, (g, radial) in enumerate(sigmas)
        ]

    assert field_smoothing_caveat(cohort([("a", 5.0), ("b", 5.0)])) is None  # lumen: 20 in all
    assert field_smoothing_caveat(cohort([("a", 5.0), ("a", 14.0)])) is None  # one group
    assert (
        field_smoothing_caveat([{"name": "e", "group": "a"}, {"name": "f", "group": "b"}]) is None
    )
    text = field_smoothing_caveat(cohort([("a", 5.0), ("a", 7.0), ("b", 14.0)]))
    assert "radial (a: 5-7 ms; b: 14 ms)" in text and "lumen" not in text
    assert text.endswith("--field-smoothing-ms 14")
    strained = [
        {"name": f"e{k}", "group": g, "strain_smoothing_ms": {"strain_energy_inner": x}}
        for k, (g, x) in enumerate([("a", 5.0), ("b", 10.0)])
    ]
    assert field_smoothing_caveat(strained) is None  # no curvature sigmas
    text = field_smoothing_caveat(
        strained
        + [
            {
                "name": "old",
                "group": "b",  # an older summary
                "strain_smoothing_ms": 5.0,
            }
        ],
        "strain_smoothing_ms",
    )
    assert "strain fields" in text and "strain_energy_inner (a: 5 ms; b: 10 ms)" in text
    assert text.endswith("--strain-smoothing-ms 10")


def test_map_comparison_rows_sum_up_where_the_groups_differ():
    from oftimg.analysis.group_maps import group_differences

    rng = np.random.default_rng(0)
    groups = np.array(["normal", "banded"] * 4)
    maps = {"groups": groups}
    area = 0.6 + 0.02 * rng.standard_normal((8, 50, 100))
    area[groups == "banded", 20:30, 40:60] += 0.3  # 4 % of the map
    thickness = 0.03 + 0.002 * rng.standard_normal((8, 50, 100))
    thickness[groups == "normal"] = np.nan  # no inner walls
    jelly = 0.05 + 0.002 * rng.standard_normal((8, 50, 100))  # no difference
    strain = 0.05 + 0.002 * rng.standard_normal((8, 50, 100))
    strain[groups == "banded", 5:15, 10:30] -= 0.03  # 4 % elsewhere
    for key, values in (
        ("area_outer_normalized", area),
        ("wall_thickness_mm", thickness),
        ("jelly_thickness_mm", jelly),
        ("strain_energy_outer", strain),
    ):
        compared = group_differences(values, groups)
        maps["comparisons"] = compared.pop("names")
        maps.update({f"{key}_{what}": v for what, v in compared.items()})
    area_row, thickness_row, jelly_row, strain_row = map_comparison_rows(maps)
    assert (
        area_row["comparison"] == "banded - normal" and area_row["map"] == "area_outer_normalized"
    )
    assert area_row["least_p_pixel"] == area_row["least_p_cluster"] == pytest.approx(2 / 70)
    assert 0.04 <= area_row["share_in_clusters_p<0.05"] < 0.06  # the block and its fringe
    assert thickness_row["least_p_cluster"] is None
    assert jelly_row["map"] == "jelly_thickness_mm" and jelly_row["least_p_cluster"] > 0.05
    assert strain_row["map"] == "strain_energy_outer"
    assert 0.04 <= strain_row["share_in_clusters_p<0.05"] < 0.06


@pytest.mark.parametrize(
    "size, wide",
    [
        ((2126, 1300), True),  # the page's width (180 mm)
        ((1200, 500), True),  # over twice as wide as high
        ((1004, 768), False),
    ],
)  # a column's figure
def test_a_page_wide_figure_spans_the_report(tmp_path, size, wide):
    """Drawn the page's width, a figure takes the grid's whole width: in one cell its
    7-9 pt text (the shape modes') was shown at under half its size."""
    from PIL import Image

    from oftimg.output.html import figure_html

    path = tmp_path / "figure.png"
    Image.new("RGB", size, "white").save(path)
    assert ('class="wide"' in figure_html(path, "figure.png", "a figure")) == wide


def test_the_wave_s_helix_angle_and_speed_are_tested_between_groups():
    """Beyond Table 1, the wave's helix angle and speed on the outer wall are tested
    (permutation, in the same Holm family); a dataset whose wall does not propagate
    has no value there, not a zero."""

    def fronts(angle, speed):
        return {
            "outer": {
                "propagates": speed is not None,
                "speed_mm_s": speed,
                "helix_angle_deg": angle,
                "earliest_s_mm": 0.1,
            }
        }

    summaries = [
        {
            "name": f"n{k}",
            "group": "normal",
            "period_ms": 350.0,
            "wave_fronts": fronts(1.0 + k, 15.0 + k),
        }
        for k in range(4)
    ]
    summaries += [
        {
            "name": f"h{k}",
            "group": "helical",
            "period_ms": 350.0,
            "wave_fronts": fronts(40.0 + k, 3.0 + k),
        }
        for k in range(4)
    ]
    summaries.append(
        {"name": "still", "group": "helical", "period_ms": 350.0, "wave_fronts": fronts(None, None)}
    )
    rows = {r["metric"]: r for r in group_comparison(summaries)}
    assert rows["front_helix_angle_deg"]["p_value"] == pytest.approx(2 / 70)
    assert rows["front_speed_mm_s"]["p_value"] == pytest.approx(2 / 70)
    assert rows["front_helix_angle_deg"]["helical_n"] == 4
    assert rows["front_helix_angle_deg"]["p_holm"] >= rows["front_helix_angle_deg"]["p_value"]
    assert np.isnan(rows["front_earliest_s_mm"]["p_value"])  # shown, not tested


def test_table1_says_why_an_embryo_without_an_area_wave_has_no_speed():
    """An embryo whose sections' areas barely change (a helical wave) has its speeds and
    expansion share blank in Table 1, and the note names it, says why and where its wave
    is measured (issue 83, point 4)."""

    def embryo(name, moves):
        speed = 12.0 if moves else None
        return {
            "name": name,
            "group": "normal",
            "period_ms": 300.0,
            "area_wave": moves,
            "expand_fraction": 0.4 if moves else None,
            "wave_speed_mm_s": {
                "min": speed,
                "max": speed,
                "mean": speed,
                "std": speed,
                "cycle": speed,
            },
        }

    header, body, note = table1_layout([embryo("A", True), embryo("H", False)])
    column = {name: k for k, name in enumerate(header)}
    rows = {row[0]: row for row in body}
    assert rows["H"][column["Speed cycle (mm/s)"]] == rows["H"][column["Expand (%)"]] == "–"
    assert rows["A"][column["Speed cycle (mm/s)"]] != "–"
    assert "H: the sections' areas change by under 2 % over the beat" in note
    assert "A:" not in note and "front_speed_mm_s" in note


def test_the_cushions_valve_action_is_tested_and_the_note_says_what_was(tmp_path):
    """Issue 85/87: the lumen's narrowest aspect ratio and largest closed share are tested
    with Table 1 (one Holm family), the note names what was tested and the smallest p
    3 against 3 can give (0.10); groups.csv leaves a cell empty where there is no value."""
    from oftimg.output.report import statistics_note, write_groups_table

    def embryo(name, group, aspect, shut, period):
        return {
            "name": name,
            "group": group,
            "period_ms": period,
            "cushions": {
                "aspect_ratio_narrowest": aspect,
                "closed_share_max": shut,
                "closure_speed_mm_s": None,
            },
        }

    summaries = [
        embryo(f"n{k}", "normal", 0.5 + 0.01 * k, 0.3 + 0.01 * k, 350.0 + k) for k in range(3)
    ]
    summaries += [
        embryo(f"b{k}", "banded", 0.2 + 0.01 * k, 0.6 + 0.01 * k, 400.0 + k) for k in range(3)
    ]
    comparison = group_comparison(summaries)
    rows = {r["metric"]: r for r in comparison}
    for tested in ("lumen_aspect_ratio_narrowest", "lumen_closed_share_max", "period_ms"):
        assert rows[tested]["p_value"] == pytest.approx(0.1), tested  # 2 of 20
        assert rows[tested]["p_holm"] == pytest.approx(0.3), tested
    assert "lumen_closure_speed_mm_s" not in rows  # no embryo has one
    note = statistics_note(comparison)
    assert (
        "the smallest p it can give, 3 banded against 3 normal: 0.10), for the 1 Table 1 "
        "quantity and lumen_aspect_ratio_narrowest, lumen_closed_share_max (cohort.csv)" in note
    ), note
    assert "corrected over these 3 quantities." in note
    text = write_groups_table(tmp_path, summaries, comparison).read_text()
    assert "nan" not in text.lower()
