"""Probability maps in (issue 60): ``probabilities/<layer>/`` meshed at 0.5 as label
volumes are, the phantom's own maps through `oftimg run`, and bad maps refused in
one line."""

import json
import shutil

import numpy as np
import pytest
import tifffile

from oftimg.cli import main
from oftimg.io.label_dataset import load_label_dataset, read_frame
from oftimg.mesh.labels import wall_occupancy
from oftimg.synthetic.labels import LabelGrid, label_params, partial_volumes, write_label_phantom
from oftimg.synthetic.phantom import Phantom, sample_params

from helpers import label_phantom_area_errors

pytestmark = pytest.mark.usefixtures("png_figures_only")

COARSE_UM = (8.0, 8.0, 16.0)


@pytest.fixture(scope="module")
def maps(tmp_path_factory):
    path = tmp_path_factory.mktemp("probabilities") / "pm"
    write_label_phantom(path, sample_params("normal", 0, n_frames=8), COARSE_UM, probabilities=True)
    return path


def test_the_phantoms_maps_are_its_partial_volumes(maps):
    """Each layer's map is its share of each voxel, with noise: in [0, 1], the layers
    adding up to one at most (the background takes the rest, noise and all); without
    the noise and blur, the outer wall's occupancy summed over the voxels is its volume
    (within 1 %)."""
    lds = load_label_dataset(maps)
    assert lds.kind == "probabilities" and lds.folder == maps / "probabilities"
    assert [layer for layer, _ in lds.sources[0].layers] == ["myocardium", "jelly", "lumen"]
    assert str(lds.sources[3]) == str(maps / "probabilities" / "*" / "f3.tif")
    frame = read_frame(lds.sources[0])
    assert all(p.dtype == np.float32 and 0 <= p.min() and p.max() <= 1 for p in frame.values())
    assert sum(frame.values()).max() <= 1.0 + 2 / 255  # rounded to uint8
    far = frame["myocardium"][:, :3, :3]  # background only: the bend's centre
    assert far.max() < 0.01
    ph = Phantom(label_params(sample_params("normal", 0, n_frames=8)))
    grids = [
        LabelGrid(ph, COARSE_UM, (ox, oy, oz))
        for ox in (-0.25, 0.25)
        for oy in (-0.25, 0.25)
        for oz in (-0.25, 0.25)
    ]
    t = float(ph.frame_times_ms()[0])
    occupancy = wall_occupancy(partial_volumes(grids, t))["outer"]
    volume_mm3 = occupancy.sum() * np.prod(COARSE_UM) * 1e-9
    assert abs(volume_mm3 / ph.volume_mm3("outer", np.array([t]))[0] - 1) < 0.01, volume_mm3


def test_probability_maps_through_run(maps, tmp_path, capsys):
    assert main(["validate", str(maps)]) == 0
    assert "probability maps (z, y, x)" in capsys.readouterr().out
    out = tmp_path / "res"
    with pytest.warns(Warning) as caught:
        assert main(["run", str(maps), "--out", str(out), "--quiet", "--jobs", "2"]) == 0
    said = " ".join(str(w.message) for w in caught)  # its own kind, not labels'
    assert "curvature fields from probability maps" in said and "label volumes" not in said
    summary = json.loads((out / "pm" / "summary.json").read_text())
    meshing = summary["provenance"]["meshing"]
    assert meshing["kind"] == "probabilities" and meshing["label_repairs"] == []
    files = {f["file"] for f in summary["provenance"]["inputs"]["probabilities"]}
    assert len(files) == 3 * 8 and all("/probabilities/" in f for f in files)
    for wall, error in label_phantom_area_errors(out / "pm", maps, 8).items():
        assert np.median(error) < 0.05, wall


def damaged(maps, dst, problem):
    shutil.copytree(maps, dst)
    layer = dst / "probabilities" / "lumen"
    first = tifffile.imread(layer / "f2.tif")
    if problem == "beyond_one":
        tifffile.imwrite(layer / "f2.tif", first.astype(np.float32) / 100)  # up to 2.55
        return layer / "f2.tif", "probabilities from 0 to 2.55; a probability map holds values"
    if problem == "int32":
        tifffile.imwrite(layer / "f2.tif", first.astype(np.int32))
        return layer / "f2.tif", "int32 voxels; a probability map is float"
    if problem == "fewer_frames":
        (layer / "f7.tif").unlink()
        return (
            dst / "probabilities",
            "different numbers of frames (myocardium/ 8, jelly/ 8, lumen/ 7)",
        )
    if problem == "both":
        (dst / "labels").mkdir()
        return dst, "holds both labels/ and probabilities/"
    if problem == "no_myocardium":
        shutil.rmtree(dst / "probabilities" / "myocardium")
        return dst / "probabilities", "no myocardium/ folder"
    raw = json.loads((dst / "meta.json").read_text())
    (dst / "meta.json").write_text(json.dumps({**raw, "labels": {"myocardium": 1}}))
    return dst / "meta.json", "a probabilities dataset names its layers by its folders"


@pytest.mark.parametrize(
    "problem", ["beyond_one", "int32", "fewer_frames", "both", "no_myocardium", "labels_in_meta"]
)
def test_bad_maps_are_one_line_naming_the_file(maps, tmp_path, capsys, problem):
    where, what = damaged(maps, tmp_path / "bad", problem)
    out = tmp_path / "out"
    assert main(["run", str(tmp_path / "bad"), "--out", str(out), "--quiet", "--jobs", "1"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith(f"oftimg: error: {where}"), err
    assert what in err[0], err[0]
    assert not out.exists()


AXISTAGS = {
    key: {"key": key, "typeFlags": flag, "resolution": 0, "description": ""}
    for key, flag in (("t", 8), ("z", 2), ("y", 2), ("x", 2), ("c", 1))
}


def ilastik_export(maps, dst, *, series: bool) -> None:
    """``maps`` as ilastik's Pixel Classification exports them (h5py, dataset
    ``exported_data``, float32, its ``axistags`` as vigra writes them, channel 0 the
    background), the classes in another order than oftimg's layers (lumen 1,
    myocardium 2, jelly 3): one 4-D ``probabilities.h5`` (t, z, y, x, c) or one file per
    frame (z, y, x, c)."""
    import h5py

    lds = load_label_dataset(maps)
    frames = [read_frame(s) for s in lds.sources]
    stacks = [
        np.stack([1 - sum(f.values()), f["lumen"], f["myocardium"], f["jelly"]], axis=-1)
        for f in frames
    ]
    (dst / "probabilities").mkdir(parents=True)
    raw = json.loads((maps / "meta.json").read_text())
    raw["classes"] = {"myocardium": 2, "jelly": 3, "lumen": 1}
    (dst / "meta.json").write_text(json.dumps(raw))

    def write(path, data, axes):
        with h5py.File(path, "w") as f:
            ds = f.create_dataset(
                "exported_data", data=data.astype(np.float32), chunks=True, compression="gzip"
            )
            ds.attrs["axistags"] = json.dumps({"axes": [AXISTAGS[a] for a in axes]})

    if series:
        write(dst / "probabilities" / "probabilities.h5", np.stack(stacks), "tzyxc")
    else:
        for t, stack in enumerate(stacks):
            write(dst / "probabilities" / f"frame_{t}.h5", stack, "zyxc")


@pytest.mark.parametrize("series", [True, False], ids=["one_4d_file", "a_file_per_frame"])
def test_an_ilastik_export_reads_as_the_tiff_maps(maps, tmp_path, series):
    """ilastik's HDF5 export, its channels named in meta.json's "classes", gives every
    layer's map of every frame as the TIFF folders do, voxel for voxel."""
    ilastik_export(maps, tmp_path / "pm", series=series)
    tiffs, h5 = load_label_dataset(maps), load_label_dataset(tmp_path / "pm")
    assert h5.kind == "probabilities" and h5.n_frames == tiffs.n_frames == 8
    assert h5.shape == tiffs.shape and h5.voxel_size == tiffs.voxel_size
    assert [layer for layer, _ in h5.sources[0].layers] == ["myocardium", "jelly", "lumen"]
    for a, b in zip(tiffs.sources[::3], h5.sources[::3]):
        fa, fb = read_frame(a), read_frame(b)
        for layer in fa:
            np.testing.assert_allclose(fb[layer], fa[layer], atol=1e-6, err_msg=layer)


def test_an_ilastik_export_gives_the_tiff_maps_numbers(maps, tmp_path):
    """The same maps as an ilastik export and as TIFF folders: the same results."""
    ilastik_export(maps, tmp_path / "pm", series=True)
    for source, out in ((maps, tmp_path / "tiff"), (tmp_path / "pm", tmp_path / "h5")):
        assert (
            main(
                ["run", str(source), "--out", str(out), "--quiet", "--jobs", "1", "--numbers-only"]
            )
            == 0
        )
    a, b = (np.load(out / "pm" / "arrays.npz") for out in (tmp_path / "tiff", tmp_path / "h5"))
    for key in (
        "area_outer_mm2",
        "area_lumen_mm2",
        "wall_thickness_mm",
        "radial_curvature_outer_per_mm",
    ):
        np.testing.assert_allclose(b[key], a[key], rtol=1e-4, atol=1e-9, err_msg=key)


@pytest.mark.parametrize("problem", ["no_classes", "channel_out_of_range", "bad_axistags"])
def test_a_bad_ilastik_export_is_one_line(maps, tmp_path, capsys, problem):
    import h5py

    ilastik_export(maps, tmp_path / "pm", series=True)
    meta = tmp_path / "pm" / "meta.json"
    raw = json.loads(meta.read_text())
    file = tmp_path / "pm" / "probabilities" / "probabilities.h5"
    if problem == "no_classes":
        del raw["classes"]
        with h5py.File(file, "a") as f:  # 5 channels: no default numbering
            data = f["exported_data"][...]
            del f["exported_data"]
            f["exported_data"] = np.concatenate([data, data[..., :1]], axis=-1)
            f["exported_data"].attrs["axistags"] = json.dumps(
                {"axes": [AXISTAGS[a] for a in "tzyxc"]}
            )
        expected = '5 channels; meta.json\'s "classes" says which is which'
    elif problem == "channel_out_of_range":
        raw["classes"]["lumen"] = 4
        expected = "gives lumen channel 4; the file has channels 0-3"
    else:
        with h5py.File(file, "a") as f:
            f["exported_data"].attrs["axistags"] = "not json"
        expected = "its axistags cannot be read"
    meta.write_text(json.dumps(raw))
    out = tmp_path / "out"
    assert main(["run", str(tmp_path / "pm"), "--out", str(out), "--quiet", "--jobs", "1"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and expected in err[0], err
    assert not out.exists()


def test_validate_says_each_inputs_format_axes_and_voxel_size(maps, tmp_path, capsys):
    """Per input, the format, the axes and where they and the voxel size came from."""
    ilastik_export(maps, tmp_path / "pm", series=True)
    assert main(["validate", str(tmp_path / "pm")]) == 0
    out = capsys.readouterr().out
    assert (
        "HDF5 (exported_data), one file holding every frame; axes tzyxc (its axistags); "
        "voxel size from meta.json"
    ) in out
    assert main(["validate", str(maps)]) == 0
    assert "TIFF, one file per frame; axes zyx" in capsys.readouterr().out


def test_an_ilastik_export_with_its_classes_first_and_no_axistags(maps, tmp_path, capsys):
    """A file per frame of (c, z, y, x) with no axistags (issue 83, point 6: read in
    ilastik's order, (z, y, x, c), as 133 classes and blamed on layer folders that do not
    exist): one line that names the axis that looks like the classes and the "axes" to
    write; with it, the maps read as the TIFF folders give them."""
    import h5py

    ilastik_export(maps, tmp_path / "pm", series=False)
    for path in sorted((tmp_path / "pm" / "probabilities").iterdir()):
        with h5py.File(path, "a") as f:
            data = np.moveaxis(f["exported_data"][...], -1, 0)  # classes first
            del f["exported_data"]
            f["exported_data"] = data  # no axistags
    meta = tmp_path / "pm" / "meta.json"
    raw = {k: v for k, v in json.loads(meta.read_text()).items() if k != "axes"}
    meta.write_text(json.dumps(raw))
    out = tmp_path / "out"
    assert main(["run", str(tmp_path / "pm"), "--out", str(out), "--quiet", "--jobs", "1"]) == 2
    err = capsys.readouterr().err.strip()
    assert "frame_0.h5: read in ilastik order, no axistags (axes zyxc)" in err
    assert 'looks like them: if so, write "axes": "czyx"' in err and "folder" not in err
    meta.write_text(json.dumps({**raw, "axes": "czyx"}))
    tiffs, h5 = load_label_dataset(maps), load_label_dataset(tmp_path / "pm")
    fa, fb = read_frame(tiffs.sources[2]), read_frame(h5.sources[2])
    for layer in fa:
        np.testing.assert_allclose(fb[layer], fa[layer], atol=1e-6, err_msg=layer)
