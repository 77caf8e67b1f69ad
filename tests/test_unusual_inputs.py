"""Every valid dataset runs to the end (issue 71, point 4), the inputs' side: µm
meshes, a band, label volumes with every wall, labels with intensity, probability
maps; each through `oftimg run` with every figure, video and page and every export,
ending with exit 0 and complete outputs (tests/test_unusual_meshes.py: the shapes)."""

import pytest

from helpers import UNUSUAL_DATASETS, run_to_the_end

pytestmark = [pytest.mark.long, pytest.mark.slow, pytest.mark.usefixtures("png_figures_only")]


@pytest.mark.parametrize("case", ["um", "banded", "labels", "labels_intensity", "probabilities"])
def test_an_unusual_input_runs_to_the_end(case, tmp_path):
    summary = run_to_the_end(UNUSUAL_DATASETS[case](tmp_path / case), tmp_path)
    if case == "um":
        assert summary["provenance"]["length_unit"] == "um"
    if case in ("labels", "labels_intensity", "probabilities"):
        assert summary["provenance"]["voxel_size"] is not None
        kind = "probabilities" if case == "probabilities" else "labels"
        assert set(summary["provenance"]["inputs"]) == (
            {kind, "intensity"} if case == "labels_intensity" else {kind}
        )
