"""Every valid mesh dataset runs to the end (issue 71, point 4): unusual but valid
datasets through `oftimg run` with every figure, video and page, and every export
(`paraview`, `tiff`, the napari reader), ending with exit 0 and complete outputs."""
import pytest

from helpers import UNUSUAL_DATASETS, run_to_the_end

pytestmark = [pytest.mark.slow, pytest.mark.usefixtures("png_figures_only")]


@pytest.mark.parametrize("case", ["rigid", "breathing", "outer_alone", "outer_and_lumen",
                                  "five_frames", "short_tube", "long_tube"])
def test_an_unusual_mesh_dataset_runs_to_the_end(case, tmp_path):
    summary = run_to_the_end(UNUSUAL_DATASETS[case](tmp_path / case), tmp_path)
    if case in ("rigid", "breathing"):              # no wave: said, not measured
        speeds = summary["wave_speed_mm_s"]
        assert speeds["rows_used"] == 0 and speeds["cycle"] is None     # null in JSON
        for wall, found in summary["wave_fronts"].items():            # nor on the walls
            if isinstance(found, dict):
                assert found["propagates"] is False and found["speed_mm_s"] is None, wall


def test_400_frames_run_to_the_end(tmp_path):
    summary = run_to_the_end(UNUSUAL_DATASETS["400_frames"](tmp_path / "long"), tmp_path)
    assert summary["n_frames"] == 400
