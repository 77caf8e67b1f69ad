"""Every valid mesh dataset runs to the end (issue 71, point 4): unusual but valid
datasets through `oftimg run` with every figure, video and page, and every export
(`paraview`, `tiff`, the napari reader), ending with exit 0 and complete outputs."""

import pytest

from helpers import UNUSUAL_DATASETS, run_to_the_end

pytestmark = [pytest.mark.long, pytest.mark.slow, pytest.mark.usefixtures("png_figures_only")]


@pytest.mark.parametrize(
    "case",
    [
        "rigid",
        "breathing",
        "outer_alone",
        "outer_and_lumen",
        "five_frames",
        "short_tube",
        "long_tube",
    ],
)
def test_an_unusual_mesh_dataset_runs_to_the_end(case, tmp_path):
    summary = run_to_the_end(UNUSUAL_DATASETS[case](tmp_path / case), tmp_path)
    if case in ("rigid", "breathing"):  # no wave: said, not measured
        speeds = summary["wave_speed_mm_s"]
        assert speeds["rows_used"] == 0 and speeds["cycle"] is None  # null in JSON
        for wall, found in summary["wave_fronts"].items():  # nor on the walls
            if isinstance(found, dict):
                assert found["propagates"] is False and found["speed_mm_s"] is None, wall


def test_400_frames_run_to_the_end(tmp_path):
    summary = run_to_the_end(UNUSUAL_DATASETS["400_frames"](tmp_path / "long"), tmp_path)
    assert summary["n_frames"] == 400


def test_a_figure_or_video_that_cannot_be_drawn_never_stops_the_run(tmp_path, monkeypatch):
    """A drawing that fails (matplotlib's overflow warning once ended whole runs: issue
    87, point 1) is left out, named in one warning, in summary.json and on the page;
    every number and every other figure and video is written (exit 0)."""
    import json

    from oftimg.cli import main
    from oftimg.output import figures, video

    def broken(*args, **kwargs):
        raise RuntimeWarning("overflow encountered in dot")

    real = video.render_videos

    def one_broken(kind, inputs, fps=None):
        if kind == "lumen_3d":
            raise FloatingPointError("a video that cannot be rendered")
        return real(kind, inputs, fps)

    monkeypatch.setattr(figures, "volume_over_cycle", broken)
    monkeypatch.setattr(video, "render_videos", one_broken)
    data = UNUSUAL_DATASETS["five_frames"](tmp_path / "five")
    with pytest.warns(Warning, match="could not be drawn and are left out"):
        assert (
            main(["run", str(data), "--out", str(tmp_path / "out"), "--quiet", "--jobs", "1"]) == 0
        )
    folder = tmp_path / "out" / "five"
    summary = json.loads((folder / "summary.json").read_text())
    failed = summary["drawings_failed"]
    assert {
        "figure": "volume_over_cycle.png",
        "error": "RuntimeWarning: overflow encountered in dot",
    } in failed
    assert {
        "video": "lumen_3d",
        "error": "FloatingPointError: a video that cannot be rendered",
    } in failed
    assert (folder / "arrays.npz").is_file() and (
        folder / "figures" / "area_map_outer.png"
    ).is_file()
    assert not (folder / "figures" / "volume_over_cycle.png").exists()
    assert len(list((folder / "videos").glob("*.mp4"))) > 3
    assert "could not be drawn" in (folder / "index.html").read_text()
