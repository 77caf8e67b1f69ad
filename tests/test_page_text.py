"""What a reader of the report sees (issue 87): figures and videos captioned by what
they show, tables headed in words with their units, the provenance in one line."""

from helpers import FIGURES, VIDEOS

from oftimg.output import html, report


def test_every_figure_and_video_a_run_writes_has_a_caption():
    stems = set().union(*FIGURES.values(), *VIDEOS.values())
    stems |= {"activation_outer", "activation_inner", "activation_lumen", "phase_outer_3d"}
    stems |= {
        f"group_{k}"
        for k in (
            "area_maps",
            "wall_thickness_maps",
            "max_area",
            "ridge_time",
            "volume",
            "pca_expansion",
        )
    }
    missing = sorted(stems - set(html.CAPTIONS))
    assert not missing, missing
    text = html.caption("radial_curvature_outer", "tracked grid")
    assert text.startswith("Outer wall: radial curvature") and "on the tracked grid" in text
    assert "(radial_curvature_outer)" in text  # the file, for finding it


def test_table_headers_are_words_with_their_units():
    columns = report.MEASUREMENT_COLUMNS + report.QC_COLUMNS
    headers = {c.name: report.column_header(c) for c in columns}
    assert headers["wall_thickness_median_mm"] == "wall thickness median (mm)"
    assert headers["max_expansion_rate_mm2_ms"] == "max expansion rate (mm²/ms)"
    assert headers["jelly_volume_change_percent"] == "jelly volume change (%)"
    assert all("_" not in h for h in headers.values())


def test_the_provenance_is_one_line_with_the_files_counted():
    summary = {
        "provenance": {
            "dataset": {"path": "/data/e1"},
            "oftimg_version": "0.1.0",
            "inputs": {"meshes": {"outer": [{}] * 24, "inner": [{}] * 24}, "intensity": [{}] * 24},
        }
    }
    assert html.provenance_line(summary) == (
        "from /data/e1; input files: 24 outer meshes, 24 inner meshes, 24 intensity; oftimg 0.1.0"
    )
