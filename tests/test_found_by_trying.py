"""What trying oftimg as a lab would found (issue 71): each one a clear line or a
correct result now. A 4-D labels.tif that is a folder, a lone surrogate in meta.json,
a PLY header of over 64 KB, provenance that survives a move, the frames counted once."""

import json
import os
import re
import shutil

import numpy as np
import pytest

from oftimg.cli import main
from oftimg.io.meshfile import read_mesh_file
from oftimg.synthetic.labels import write_label_phantom
from oftimg.synthetic.phantom import sample_params, write_phantom

SMALL = dict(n_frames=5, vertices_min=600, vertices_max=800)
pytestmark = pytest.mark.usefixtures("png_figures_only")


@pytest.fixture(scope="module")
def meshes(tmp_path_factory):
    return write_phantom(
        tmp_path_factory.mktemp("found") / "emb", sample_params("normal", 3, **SMALL)
    )


def one_line(capsys, args) -> str:
    assert main(args) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("oftimg: error: ")
    return err[0]


def test_a_4d_labels_tif_that_is_a_folder_is_named(tmp_path, capsys):
    """It gave "[Errno 21] Is a directory" and exit 1."""
    path = write_label_phantom(
        tmp_path / "lp", sample_params("normal", 0, n_frames=5), (40.0, 40.0, 40.0), noise=0.0
    )
    for frame in (path / "labels").iterdir():
        frame.unlink()
    (path / "labels" / "labels.tif").mkdir()
    line = one_line(capsys, ["validate", str(path)])
    assert line == f"oftimg: error: {path / 'labels' / 'labels.tif'}: is a folder, not a file"


def test_a_lone_surrogate_in_meta_json_is_named(meshes, tmp_path, capsys):
    """JSON lets "\\udc80" through; the run ended in "internal error: UnicodeEncodeError"."""
    bad = shutil.copytree(meshes, tmp_path / "bad")
    meta = json.loads((bad / "meta.json").read_text())
    (bad / "meta.json").write_text(json.dumps({**meta, "name": "emb\udc80A"}))
    line = one_line(capsys, ["validate", str(bad)])
    assert "'name' holds '\\udc80', half of a UTF-16 pair (a lone surrogate)" in line


def test_a_ply_header_of_any_length_is_read(meshes, tmp_path, capsys):
    """A valid PLY with 70 KB of comments was refused: "no end_header line in its first
    64 KB". The validator then gives the inlet to the µm, not as [0.298879, ..., 1.5e-05]."""
    good = shutil.copytree(meshes, tmp_path / "long")
    path = sorted((good / "outer").iterdir())[0]
    data = path.read_bytes()
    comments = b"".join(b"comment a tool's history, step %d\n" % k for k in range(2500))
    path.write_bytes(data.replace(b"\n", b"\n" + comments, 1))
    assert path.stat().st_size > len(data) + 65536
    V, F = read_mesh_file(path)
    V0, F0 = read_mesh_file(meshes / "outer" / path.name)
    np.testing.assert_array_equal(V, V0)
    np.testing.assert_array_equal(F, F0)
    capsys.readouterr()
    assert main(["validate", str(good)]) == 0
    inlet = re.search(r"inlet at (\S.*?) mm \(", capsys.readouterr().out).group(1)
    assert re.fullmatch(r"\(-?\d+\.\d{3}, -?\d+\.\d{3}, -?\d+\.\d{3}\)", inlet), inlet  # to the µm


@pytest.mark.slow
def test_a_result_moved_with_its_dataset_finds_it_from_any_folder(tmp_path, monkeypatch, capsys):
    """The dataset path was stored relative to where the run was started: a result
    opened from another folder (napari) lost its volumes without a word."""
    import oftimg
    from oftimg.napari.reader import results_layers
    from oftimg.napari.volumes import dataset_of

    project = tmp_path / "project"
    write_label_phantom(
        project / "data" / "lp",
        sample_params("normal", 1, n_frames=5),
        (16.0, 16.0, 32.0),
        noise=0.0,
    )
    monkeypatch.chdir(project)  # paths given relative, as a lab would
    assert main(["run", "data/lp", "--out", "results", "--quiet", "--jobs", "1"]) == 0
    summary = json.loads((project / "results" / "lp" / "summary.json").read_text())
    provenance = summary["provenance"]
    assert provenance["dataset"] == {
        "path": str(project / "data" / "lp"),
        "from_results": os.path.join("..", "..", "data", "lp"),
    }
    assert set(provenance["inputs"]) == {"labels"}
    assert all(os.path.isabs(f["file"]) for f in provenance["inputs"]["labels"])
    assert provenance["voxel_size"] == [16.0, 16.0, 32.0]
    monkeypatch.chdir(tmp_path)
    moved = shutil.move(str(project), str(tmp_path / "elsewhere"))
    res = oftimg.load_results(f"{moved}/results/lp")
    assert dataset_of(res) == tmp_path / "elsewhere" / "data" / "lp"
    assert [layer[2] for layer in results_layers(f"{moved}/results")][:1] == ["labels"]
    shutil.rmtree(tmp_path / "elsewhere" / "data")
    with pytest.warns(
        UserWarning,
        match=f"the dataset these results were made from is not at {project / 'data' / 'lp'} nor ",
    ):
        layers = results_layers(f"{moved}/results")
    kinds = [layer[2] for layer in layers]
    assert kinds[:3] == ["surface"] * 3 and "labels" not in kinds  # no volumes, said
