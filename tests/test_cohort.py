"""`oftimg cohort`: datasets analysed separately (one cluster job each) gathered into
one cohort equal to a run over all of them, without writing to the sources."""

import json
import shutil
from pathlib import Path

import numpy as np
import pytest

from oftimg import api
from oftimg.cli import main
from oftimg.analysis.group_maps import AROUND_TUBE_MAPS, TESTED_MAPS
from oftimg.errors import DatasetError
from oftimg.synthetic.phantom import sample_params, write_phantom

pytestmark = [pytest.mark.long, pytest.mark.slow, pytest.mark.usefixtures("png_figures_only")]


@pytest.fixture(scope="module")
def runs(tmp_path_factory, png_figures_only):
    """A joint run of n0, n1 (normal) and b0 (banded); n0 alone; n1 and b0 together."""
    root = tmp_path_factory.mktemp("cohort")
    for name, group, seed in (("n0", "normal", 0), ("n1", "normal", 1), ("b0", "banded", 2)):
        write_phantom(
            root / "all" / name,
            sample_params(group, seed, n_frames=5, vertices_min=1500, vertices_max=1800),
            name=name,
        )
    (root / "rest").mkdir()
    for name in ("n1", "b0"):
        (root / "rest" / name).symlink_to(root / "all" / name, target_is_directory=True)
    for source, out in (("all", "joint"), ("all/n0", "alone"), ("rest", "together")):
        assert (
            main(["run", str(root / source), "--out", str(root / out), "--quiet", "--jobs", "1"])
            == 0
        )
    return root


def test_separate_runs_gathered_equal_one_run(runs, tmp_path):
    source_page = runs / "alone" / "n0" / "index.html"
    before = source_page.read_bytes()
    out = tmp_path / "cohort"
    assert (
        main(
            [
                "cohort",
                str(runs / "alone" / "n0"),
                str(runs / "together"),
                "--out",
                str(out),
                "--cluster-alpha",
                "0.1",
            ]
        )
        == 0
    )
    assert np.load(out / "cohort_maps.npz")["cluster_alpha"] == 0.1
    assert np.load(runs / "joint" / "cohort_maps.npz")["cluster_alpha"] == 0.05
    for table in ("table1.csv", "table1.md", "cohort.csv", "qc.csv", "columns.csv", "groups.csv"):
        assert (out / table).read_text() == (runs / "joint" / table).read_text(), table
    for name in ("b0", "n0", "n1"):
        a, b = np.load(out / name / "arrays.npz"), np.load(runs / "joint" / name / "arrays.npz")
        assert all(np.array_equal(a[k], b[k], equal_nan=True) for k in a.files), name
        assert (out / name / "index.html").is_file()
    assert sorted(p.name for p in (out / "figures").iterdir()) == sorted(
        p.name for p in (runs / "joint" / "figures").iterdir()
    )
    assert "n0/index.html" in (out / "index.html").read_text()
    run_info = json.loads((out / "run.json").read_text())
    assert run_info["cluster_alpha"] == 0.1
    assert run_info["inputs"] == [
        str(runs / "together" / "b0"),
        str(runs / "alone" / "n0"),
        str(runs / "together" / "n1"),
    ]
    # run.json's seconds are the gathering's; the datasets' own runs are summed apart
    own = [json.loads((Path(p) / "summary.json").read_text()) for p in run_info["inputs"]]
    assert all(s["timings_s"]["total_s"] > s["timings_s"]["frames_s"] > 0 for s in own)
    assert run_info["datasets_seconds"] == pytest.approx(
        sum(s["validation"]["seconds"] + s["timings_s"]["total_s"] for s in own), abs=0.01
    )
    assert "the datasets' own runs took" in (out / "index.html").read_text()
    del own[0]["timings_s"]["total_s"]  # a summary of an older oftimg
    assert api._datasets_seconds(own) is None
    # the sources are untouched: the page is a new file, the rest hard links
    assert source_page.read_bytes() == before
    assert (out / "n0" / "index.html").stat().st_ino != source_page.stat().st_ino
    assert (out / "n0" / "arrays.npz").stat().st_ino == (
        runs / "alone" / "n0" / "arrays.npz"
    ).stat().st_ino


def test_cohort_maps_hold_every_embryos_area_map_on_one_grid(runs):
    """In the cohort table's order; at the tube's ends and at frame times on the grid
    (5 frames: every 20th of 100 phases) each embryo's own areas and wall thickness
    around the tube; a figure of the groups' means."""
    out = runs / "joint"
    maps = np.load(out / "cohort_maps.npz")
    described = json.loads((out / "cohort_maps.json").read_text())
    assert set(described) == set(maps.files)
    names = [row.split(",")[0] for row in (out / "cohort.csv").read_text().splitlines()[1:]]
    assert maps["names"].tolist() == names == ["b0", "n0", "n1"]
    assert maps["groups"].tolist() == ["banded", "normal", "normal"]
    assert (
        maps["area_outer_mm2"].shape
        == (3, 50, 100)
        == tuple(described["area_outer_normalized"]["shape"])
    )
    for k, name in enumerate(names):
        own = np.load(out / name / "arrays.npz")["area_outer_mm2"]
        assert maps["area_outer_mm2"][k][[0, -1]][:, ::20] == pytest.approx(own[[0, -1]], rel=1e-12)
        rows = maps["area_outer_normalized"][k]
        assert rows[[0, -1]][:, ::20] == pytest.approx(
            own[[0, -1]] / own[[0, -1]].max(axis=1, keepdims=True), rel=1e-12
        )
        for key in AROUND_TUBE_MAPS:  # wall and jelly thickness, strain energy
            around = np.load(out / name / "arrays.npz")[key][:, [0, -1]].mean(axis=0)
            assert maps[key][k][[0, -1]][:, ::20] == pytest.approx(around, rel=1e-12, abs=1e-15)
    # one banded embryo against two normals: the difference, but too few to test
    assert maps["comparisons"].tolist() == ["banded - normal"]
    assert set(TESTED_MAPS) == {
        "area_outer_normalized",
        "wall_thickness_mm",
        "jelly_thickness_mm",
        "strain_energy_outer",
    }
    for key in TESTED_MAPS:
        assert maps[f"{key}_difference"][0] == pytest.approx(
            maps[key][0] - maps[key][1:].mean(axis=0), rel=1e-12
        )
        assert np.isnan(maps[f"{key}_p_fwer"]).all() and np.isnan(maps[f"{key}_p_cluster"]).all()
    assert {
        "group_area_maps.png",
        "group_wall_thickness_maps.png",
        "group_jelly_thickness_maps.png",
        "group_strain_energy_maps.png",
    } <= {p.name for p in (out / "figures").iterdir()}


def test_cohort_maps_open_in_fiji_one_slice_per_comparison(runs, tmp_path):
    import tifffile

    import oftimg

    out = oftimg.tiff(runs / "joint", tmp_path / "tiff", quiet=True)
    maps = np.load(runs / "joint" / "cohort_maps.npz")
    with tifffile.TiffFile(out / "cohort_maps" / "strain_energy_outer_difference.tif") as tif:
        image, meta = tif.asarray(), tif.imagej_metadata
    assert np.array_equal(
        image.reshape(1, 50, 100),
        maps["strain_energy_outer_difference"][:, ::-1].astype(np.float32),
    )
    assert "slices: comparisons: banded - normal" in meta["Info"]
    with tifffile.TiffFile(out / "cohort_maps" / "wall_thickness_mm.tif") as tif:
        assert tif.imagej_metadata["Labels"] == ["b0 (banded)", "n0 (normal)", "n1 (normal)"]
    assert sorted(p.name for p in out.iterdir()) == ["b0", "cohort_maps", "n0", "n1"]


def test_cohort_refuses_what_cannot_be_compared(runs, tmp_path):
    other = tmp_path / "other"
    shutil.copytree(runs / "alone" / "n0", other / "n0")
    summary = json.loads((other / "n0" / "summary.json").read_text())
    summary["provenance"]["options"]["grid"]["n_u"] = 60
    (other / "n0" / "summary.json").write_text(json.dumps(summary))
    with pytest.raises(ValueError, match=r"different options \(grid.n_u 80 and 60\)") as err:
        api.cohort([runs / "together", other / "n0"], tmp_path / "out")
    assert str(other / "n0") in str(err.value) and str(runs / "together" / "b0") in str(err.value)
    with pytest.raises(ValueError, match="same dataset name 'n0'"):
        api.cohort([runs / "alone", runs / "joint"], tmp_path / "out")
    (other / "n0" / "arrays.npz").unlink()
    with pytest.raises(DatasetError, match="has no arrays.npz"):
        api.cohort([other], tmp_path / "out")
    (other / "n0" / "summary.json").write_text("{")
    with pytest.raises(DatasetError, match="cannot be read as JSON"):
        api.cohort([other], tmp_path / "out")
    with pytest.raises(DatasetError, match="neither one dataset's results"):
        api.cohort([tmp_path], tmp_path / "out")
    with pytest.raises(
        DatasetError,
        match=r"cohort\.csv: .*one of the cohort files of the "
        rf"run {runs / 'together'}: give that folder itself",
    ):
        api.cohort(sorted((runs / "together").iterdir()), tmp_path / "out")  # together/*
    with pytest.raises(ValueError, match="inside the input"):
        api.cohort([runs / "together"], runs / "together" / "b0" / "merged")
    assert main(["cohort", str(tmp_path / "nothing"), "--out", str(tmp_path / "out")]) == 2
    assert not (tmp_path / "out").exists()


def test_cohort_warns_of_runs_that_did_not_finish_beside_it(runs, tmp_path, capsys):
    """A job array where one job was killed: `oftimg cohort results/*` gathers the
    others and says which run is missing."""
    from oftimg.errors import OftimgWarning

    results = tmp_path / "results"
    shutil.copytree(runs / "alone" / "n0", results / "n0")
    (results / ".n7.finished").mkdir()
    (results / ".n7.finished" / ".lock").touch()
    with pytest.warns(OftimgWarning, match=r"1 run\(s\) into n7 did not finish"):
        assert main(["cohort", str(results / "n0"), "--out", str(tmp_path / "out")]) == 0
    assert f"cohort: {tmp_path / 'out'} (1 dataset)" in capsys.readouterr().out


def test_cohort_of_several_oftimg_versions_warns(runs, tmp_path):
    from oftimg.errors import OftimgWarning

    old = tmp_path / "old"
    shutil.copytree(runs / "together", old)
    summary = json.loads((old / "b0" / "summary.json").read_text())
    summary["provenance"]["oftimg_version"] = "0.0.9"
    (old / "b0" / "summary.json").write_text(json.dumps(summary))
    with pytest.warns(OftimgWarning, match=r"different oftimg versions \(0.0.9, "):
        api.cohort([old, runs / "alone"], tmp_path / "out")
    assert (tmp_path / "out" / "groups.csv").is_file()


def test_groups_smoothed_differently_are_said_to_be(runs, tmp_path):
    """auto smoothing took another sigma for one embryo: the gathered cohort says so
    (warning, run.json, the cohort page) and names the sigma that compares like with
    like; the same sigmas say nothing."""
    from oftimg.errors import OftimgWarning

    mixed = tmp_path / "mixed"
    shutil.copytree(runs / "together", mixed)
    summary = json.loads((mixed / "b0" / "summary.json").read_text())
    summary["ridge_smoothing_ms"] = 14.0
    (mixed / "b0" / "summary.json").write_text(json.dumps(summary))
    with pytest.warns(
        OftimgWarning,
        match=r"banded: 14 ms; normal: 5 ms.*"
        r"--ridge-smoothing-ms 14",
    ):
        api.cohort([mixed, runs / "alone"], tmp_path / "out")
    notes = json.loads((tmp_path / "out" / "run.json").read_text())["notes"]
    assert len(notes) == 1 and "different sigmas" in notes[0]
    assert "different sigmas" in (tmp_path / "out" / "index.html").read_text()
    api.cohort([runs / "together", runs / "alone"], tmp_path / "same")
    assert "notes" not in json.loads((tmp_path / "same" / "run.json").read_text())
