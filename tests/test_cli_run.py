"""End to end through the command line on a small phantom: the output contract."""
import csv
import json

import numpy as np
import pytest

from oftimg.cli import main

pytestmark = pytest.mark.slow

SUMMARY_KEYS = {"name", "group", "n_frames", "period_ms", "t0_frame", "expand_fraction",
                "contract_fraction", "expand_contract_ratio", "expand_ms", "contract_ms",
                "tube_length_mm", "myocardial_volume_change", "provenance"}


@pytest.fixture(scope="module")
def run_out(phantom_normal, tmp_path_factory):
    out = tmp_path_factory.mktemp("run") / "results"
    assert main(["run", str(phantom_normal), "--out", str(out), "--quiet"]) == 0
    return out


def test_output_contract(run_out, phantom_normal):
    folder = run_out / "normal"
    summary = json.loads((folder / "summary.json").read_text())
    assert SUMMARY_KEYS <= set(summary)
    assert summary["provenance"]["oftimg_version"]
    assert len(summary["provenance"]["inputs"]["outer"]) == 36
    grids = np.load(folder / "grids.npz")
    for wall in ("outer", "inner", "lumen"):
        assert grids[wall].shape == (80, 50, 36, 3) and grids[wall].dtype == np.float32
    arrays = np.load(folder / "arrays.npz")
    described = json.loads((folder / "arrays.json").read_text())
    assert set(arrays.files) | set(grids.files) == set(described)
    for name in arrays.files:
        assert described[name]["shape"] == list(arrays[name].shape)
        assert described[name]["unit"] and described[name]["dims"]
        if "v" in described[name]["dims"] and "t" in described[name]["dims"]:
            dims = described[name]["dims"]
            assert arrays[name].shape[dims.index("v")] == 50
            assert arrays[name].shape[dims.index("t")] == 36
    for fig in ("volume_over_cycle.png", "trim_over_cycle.png", "frame_t0_contours.png"):
        assert (folder / "figures" / fig).stat().st_size > 10_000
    rows = list(csv.DictReader(open(run_out / "cohort.csv")))
    assert len(rows) == 1 and rows[0]["name"] == "normal"
    assert float(rows[0]["expand_fraction"]) == pytest.approx(summary["expand_fraction"])


def test_rerun_needs_overwrite_and_keeps_results(run_out, phantom_normal, capsys):
    before = (run_out / "normal" / "summary.json").read_text()
    assert main(["run", str(phantom_normal), "--out", str(run_out), "--quiet"]) == 2
    assert (run_out / "normal" / "summary.json").read_text() == before
    assert not [p for p in run_out.parent.iterdir() if ".partial-" in p.name]
