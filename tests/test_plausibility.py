"""Results checked for sense before they are written (issue 71, point 2): walls that
coincide or cross, a wall thinner than a micrometre, a volume that jumps between
frames, a tube no living thing has (a length unit off by 1000) stop the run with exit
2 and one line naming the likely cause; exit 0 is never given to results that cannot
be right."""

import json
import shutil

import numpy as np
import pytest

from oftimg.analysis.plausibility import implausible
from oftimg.cli import main
from oftimg.io.meshfile import read_mesh_file, write_ply
from oftimg.synthetic.phantom import sample_params, write_phantom


def test_nested_walls_of_a_beating_tube_are_plausible():
    r = 0.2 * (1 + 0.3 * np.sin(np.linspace(0, 2 * np.pi, 6)))
    volumes = {
        "outer": np.pi * r**2,
        "inner": np.pi * (0.7 * r) ** 2,
        "lumen": np.pi * (0.5 * r) ** 2,
    }
    wall = np.broadcast_to(0.3 * r, (16, 5, 6)).copy()
    wall[0, 0, :3] = -0.001  # a slip: 3 nodes a little outside
    assert implausible(volumes, {"inner": wall, "lumen": 0.5 * wall}) == []


def test_a_layer_thinner_than_its_voxels_is_no_swap():
    """The zoo's coarse draws: a myocardium eroded to a voxel leaves the walls touching,
    16 % of the nodes a fraction of a voxel outside; it ran, it is valid."""
    rng = np.random.default_rng(0)
    wall = np.abs(rng.normal(0.03, 0.01, (16, 5, 6)))
    touching = rng.random(wall.shape) < 0.3
    wall[touching] = rng.normal(0.0, 0.003, touching.sum())  # about 16 % below 0
    assert 0.1 < (wall < 0).mean() < 0.2
    r = np.full(6, 0.2)
    assert implausible({"outer": r, "inner": 0.8 * r}, {"inner": wall}) == []


def test_what_no_tube_can_give_is_named_with_its_likely_cause():
    r = np.full(6, 0.2)
    volumes = {"outer": np.pi * r**2, "inner": np.pi * r**2}
    swapped = np.full((16, 5, 6), -0.05)
    said = implausible(volumes, {"inner": swapped})
    assert any(
        "inner wall lies outside the outer one at 100% of the grid nodes, by half the "
        "myocardium's median thickness or more" in p
        for p in said
    )
    assert any("encloses as much as the outer one or more in 6 of 6 frames" in p for p in said)
    same = np.full((16, 5, 6), 2e-7)  # one surface given twice: 0.2 nm
    same[::2] *= -1
    said = implausible(volumes, {"inner": same})
    assert any("lie 0.2 nm apart" in p and "no myocardium is thinner than 1 µm" in p for p in said)
    assert any("lies outside the outer one at 50% of the grid nodes" in p for p in said)
    jump = np.array([0.12, 0.13, 0.14, 140.0, 0.13, 0.12])
    said = implausible({"outer": jump}, {}, frame_names=[f"f{t}.ply" for t in range(6)])
    assert said == [
        "the outer wall's volume in f3.ply is 1.08e+03 times the frames' median "
        "(a beat changes it by far less): is that frame in other units, or of "
        "another embryo?"
    ]


@pytest.fixture(scope="module")
def small(tmp_path_factory):
    path = tmp_path_factory.mktemp("sense") / "small"
    return write_phantom(
        path, sample_params("normal", 2, n_frames=6, vertices_min=900, vertices_max=1200)
    )


def refused(capsys, folder, tmp_path, command="run") -> str:
    out = tmp_path / "out"
    args = [command, str(folder)] + (
        ["--out", str(out), "--quiet", "--jobs", "1"] if command == "run" else []
    )
    assert main(args) == 2
    err = [
        line for line in capsys.readouterr().err.splitlines() if line.startswith("oftimg: error:")
    ]
    assert len(err) == 1 and not out.exists()
    return err[0]


def test_swapped_walls_are_refused(small, tmp_path, capsys):
    bad = shutil.copytree(small, tmp_path / "swapped")
    (bad / "outer").rename(bad / "x")
    (bad / "lumen").rename(bad / "outer")
    (bad / "x").rename(bad / "lumen")
    line = refused(capsys, bad, tmp_path)
    assert f"{bad}: results that cannot be right, so none are written" in line
    assert "the inner wall lies outside the outer one" in line


def test_one_surface_given_twice_is_refused(small, tmp_path, capsys):
    bad = shutil.copytree(small, tmp_path / "twice")
    shutil.rmtree(bad / "inner")
    shutil.copytree(bad / "outer", bad / "inner")
    line = refused(capsys, bad, tmp_path)
    assert "the outer and inner walls lie" in line and "one surface given as both" in line


def test_a_frame_in_other_units_is_refused(small, tmp_path, capsys):
    bad = shutil.copytree(small, tmp_path / "jump")
    for wall in ("outer", "inner", "lumen"):
        path = sorted((bad / wall).iterdir())[3]
        V, F = read_mesh_file(path)
        write_ply(path, V * 1000, F)
    line = refused(capsys, bad, tmp_path, "validate")  # before any work
    assert line.startswith(f"oftimg: error: {bad / 'outer' / 'f3.ply'}: its inlet's area is ")
    assert "e+06 times the frames' median" in line and "is this frame in other units" in line


@pytest.mark.parametrize("unit, says", [("um", "0.3"), ("mm", "3")])
def test_a_length_unit_off_by_1000_is_refused_by_validate(small, tmp_path, capsys, unit, says):
    bad = shutil.copytree(small, tmp_path / unit)
    meta = json.loads((bad / "meta.json").read_text())
    if unit == "mm":  # µm coordinates said to be mm
        for path in sorted(bad.glob("*/*.ply")):
            V, F = read_mesh_file(path)
            write_ply(path, V * 1000, F)
        meta["inlet"] = [1000 * x for x in meta["inlet"]]
    meta["length_unit"] = unit
    (bad / "meta.json").write_text(json.dumps(meta))
    line = refused(capsys, bad, tmp_path, "validate")
    assert line.startswith(f"oftimg: error: {bad / 'outer'}: a tube {says}")
    other = "mm" if unit == "um" else "um"
    assert f'set "length_unit": "{other}" in meta.json' in line
