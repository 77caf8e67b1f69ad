"""One unit per quantity wherever a person or a table reads it (issue 87): the cohort
tables, the dataset page, the figures and the videos ask oftimg.output.units."""

import re

import pytest

from oftimg.output import figures, html, report, units, video
from oftimg.output.numbers import unit


def test_every_table_column_and_page_row_shows_a_kind_in_its_one_unit():
    columns = [c for cols in report.TABLES.values() for c in cols]
    seen = set()
    for c in columns:
        shown = units.shown(c.path[-1])
        if shown is None or c.path[0] == "field_noise":
            continue
        seen.add(units.kind_of(c.path[-1]))
        assert (c.unit, c.scale) == (shown.unit, shown.scale), c.name
        # the column's name carries its unit as the house names it
        suffix = {"%": "_percent", "mm": "_mm", "mm^2/ms": "_mm2_ms"}[shown.unit]
        assert c.name.endswith(suffix), c.name
    for key, what, shown_unit, scale in html.QUANTITIES:
        shown = units.shown(key)
        if shown is not None:
            seen.add(units.kind_of(key))
            assert (shown_unit, scale) == (shown.unit, shown.scale), key
    assert {"thickness", "thickening", "volume_change", "share_of_cycle", "area_rate"} <= seen


def test_figures_and_videos_label_a_kind_in_its_one_unit():
    labels = [label for _, label, _ in figures.GROUP_PROFILES]
    labels += [m[4] for m in figures.GROUP_MAPS]
    labels += [opts["label"] for _, _, _, opts in video.FIELD_VIDEOS if "label" in opts]
    for text in labels:
        kind = (
            "thickening" if "thickening" in text else "thickness" if "thickness" in text else None
        )
        if kind is None:
            continue
        assert text.endswith(f"({unit(units.KINDS[kind].unit)})"), text
    # no thickness is drawn in another unit anywhere in the output code
    from pathlib import Path

    root = Path(figures.__file__).parent
    examples = root.parents[1] / "docs" / "examples"  # the gallery's too
    for path in [*root.glob("*.py"), *examples.glob("*.py")]:
        for line in path.read_text().splitlines():
            assert not re.search(r"thickness.*\((µm|um)\)", line), f"{path.name}: {line}"


@pytest.mark.parametrize(
    "key, kind",
    [
        ("wall_thickness_median_mm", "thickness"),
        ("jelly_thickening", "thickening"),
        ("jelly_volume_change", "volume_change"),
        ("expand_fraction", "share_of_cycle"),
        ("max_expansion_rate_mm2_ms", "area_rate"),
        ("period_ms", None),
    ],
)
def test_a_key_names_its_kind(key, kind):
    assert units.kind_of(key) == kind
