"""The formats labs' tools write (issue 74): OME-Zarr images as ome-zarr-py writes them
(NGFF 0.4 and 0.5, one 4-D image or one per frame), stacks of intensity and labels as
channels (OME-TIFF, ImageJ hyperstack, OME-Zarr), voxel size and time step from the
files checked against meta.json, and oftimg's own fields written back as OME-Zarr
that the reference reader and validator take."""

import json
import shutil
import warnings

import numpy as np
import pytest

from oftimg.cli import main
from oftimg.io.label_dataset import load_label_dataset
from oftimg.io.labelfile import read_volume
from oftimg.synthetic.labels import write_label_phantom
from oftimg.synthetic.phantom import sample_params

pytestmark = pytest.mark.usefixtures("png_figures_only")

VOXEL_UM = (8.0, 8.0, 16.0)
N_FRAMES = 6
PERIOD_MS = 330.0
AXES_UM = [
    {"name": "t", "type": "time", "unit": "millisecond"},
    *({"name": a, "type": "space", "unit": "micrometer"} for a in "zyx"),
]


@pytest.fixture(scope="module")
def textured(tmp_path_factory):
    """A small label phantom with its intensity volumes, as per-frame TIFFs."""
    path = tmp_path_factory.mktemp("formats") / "tex"
    write_label_phantom(
        path, sample_params("normal", 0, n_frames=N_FRAMES), VOXEL_UM, intensity=True
    )
    meta = json.loads((path / "meta.json").read_text())
    meta["period_ms"] = PERIOD_MS
    (path / "meta.json").write_text(json.dumps(meta))
    return path


def frames_of(folder):
    import tifffile

    return np.stack([tifffile.imread(p) for p in sorted(folder.glob("*.tif"))])


def new_dataset(src, dst, *, meta_changes=None, drop=("voxel_size",)):
    """An empty label dataset at ``dst`` with ``src``'s meta.json less ``drop``."""
    meta = {k: v for k, v in json.loads((src / "meta.json").read_text()).items() if k not in drop}
    meta.update(meta_changes or {})
    (dst / "labels").mkdir(parents=True)
    (dst / "meta.json").write_text(json.dumps(meta))
    return dst


def ome_zarr_write(path, data, axes, scale, version):
    """``data`` as an OME-Zarr image by ome-zarr-py (the reference writer)."""
    import zarr
    from ome_zarr.format import FormatV04, FormatV05
    from ome_zarr.writer import write_image

    fmt = {"0.4": FormatV04(), "0.5": FormatV05()}[version]
    root = zarr.open_group(str(path), mode="w", zarr_format=2 if version == "0.4" else 3)
    with warnings.catch_warnings():  # "too small to downsample": none asked
        warnings.simplefilter("ignore")
        write_image(
            data,
            root,
            axes="".join(a["name"] for a in axes),
            fmt=fmt,
            scale=dict(zip((a["name"] for a in axes), scale)),
            axes_units={a["name"]: a["unit"] for a in axes if "unit" in a},
            scale_factors=(),
        )


@pytest.mark.parametrize("version", ["0.4", "0.5"])
def test_an_ome_zarr_series_reads_as_the_tiffs(textured, tmp_path, version):
    """labels.ome.zarr as ome-zarr-py writes it (t, z, y, x; voxel size in µm and the
    frame interval in its multiscales): every frame voxel for voxel, the voxel size
    and period from the file, meta.json giving neither."""
    labels = frames_of(textured / "labels")
    data = new_dataset(textured, tmp_path / "oz", drop=("voxel_size", "period_ms"))
    ome_zarr_write(
        data / "labels" / "labels.ome.zarr",
        labels,
        AXES_UM,
        [PERIOD_MS / N_FRAMES, VOXEL_UM[2], VOXEL_UM[1], VOXEL_UM[0]],
        version,
    )
    read = load_label_dataset(data)
    assert read.n_frames == N_FRAMES and read.voxel_size == pytest.approx(VOXEL_UM)
    assert read.meta.period_ms == pytest.approx(PERIOD_MS)
    assert "labels.ome.zarr's time step 55 ms x 6 frames" in read.meta.period_from
    for t in (0, 3, 5):
        assert np.array_equal(read_volume(read.sources[t]), labels[t])


def test_a_per_frame_ome_zarr_and_axes_in_another_order(textured, tmp_path):
    """One OME-Zarr image per frame (z, y, x in mm), and a series stored (z, t, y, x):
    its axes from the metadata, never guessed from the shape."""
    labels = frames_of(textured / "labels")
    per_frame = new_dataset(textured, tmp_path / "pf")
    mm = [{"name": a, "type": "space", "unit": "millimeter"} for a in "zyx"]
    for t, volume in enumerate(labels):
        ome_zarr_write(
            per_frame / "labels" / f"f{t:02d}.ome.zarr",
            volume,
            mm,
            [d / 1000 for d in VOXEL_UM[::-1]],
            "0.4",
        )
    z_first = new_dataset(textured, tmp_path / "zt")
    axes = [AXES_UM[1], AXES_UM[0], *AXES_UM[2:]]
    import zarr

    root = zarr.open_group(str(z_first / "labels" / "labels.ome.zarr"), mode="w", zarr_format=2)
    root.create_array("0", data=labels.transpose(1, 0, 2, 3))  # a writer's own order
    root.attrs["multiscales"] = [
        {
            "version": "0.4",
            "axes": axes,
            "datasets": [
                {
                    "path": "0",
                    "coordinateTransformations": [
                        {"type": "scale", "scale": [VOXEL_UM[2], 55.0, VOXEL_UM[1], VOXEL_UM[0]]}
                    ],
                }
            ],
        }
    ]
    for folder in (per_frame, z_first):
        read = load_label_dataset(folder)
        assert read.n_frames == N_FRAMES and read.voxel_size == pytest.approx(VOXEL_UM)
        for t in (1, 4):
            assert np.array_equal(read_volume(read.sources[t]), labels[t]), folder.name


def stack_dataset(textured, dst, kind, channels=(("intensity", 0), ("labels", 1))):
    """The phantom's intensity and labels as one two-channel stack in labels/."""
    import tifffile

    labels, intensity = frames_of(textured / "labels"), frames_of(textured / "intensity")
    order = dict(channels)
    both = np.zeros((N_FRAMES, 2, *labels.shape[1:]), np.uint16)
    both[:, order["labels"]], both[:, order["intensity"]] = labels, intensity
    data = new_dataset(textured, dst, meta_changes={"channels": order})
    folder = data / "labels"
    physical = {f"PhysicalSize{a}": d for a, d in zip("XYZ", VOXEL_UM)}
    if kind == "ome_tiff":  # Bio-Formats' XYZCT: z, then c, then t
        tifffile.imwrite(
            folder / "labels.ome.tif",
            both.transpose(0, 2, 1, 3, 4),
            ome=True,
            metadata={"axes": "TZCYX", **physical, "TimeIncrement": 0.055},
        )
    elif kind == "imagej":  # Fiji's hyperstack, TZCYX
        tifffile.imwrite(
            folder / "labels.tif",
            both.transpose(0, 2, 1, 3, 4),
            imagej=True,
            resolution=(1 / VOXEL_UM[0], 1 / VOXEL_UM[1]),
            metadata={"axes": "TZCYX", "spacing": VOXEL_UM[2], "unit": "um", "finterval": 0.055},
        )
    elif kind == "ome_zarr":
        axes = [AXES_UM[0], {"name": "c", "type": "channel"}, *AXES_UM[1:]]
        ome_zarr_write(
            folder / "labels.ome.zarr",
            both,
            axes,
            [55.0, 1.0, VOXEL_UM[2], VOXEL_UM[1], VOXEL_UM[0]],
            "0.4",
        )
    elif kind == "per_frame_ome_tiff":
        for t in range(N_FRAMES):
            tifffile.imwrite(
                folder / f"f{t}.ome.tif", both[t], ome=True, metadata={"axes": "CZYX", **physical}
            )
    return data


@pytest.mark.parametrize("kind", ["ome_tiff", "imagej", "ome_zarr", "per_frame_ome_tiff"])
def test_a_stack_of_intensity_and_labels_reads_each_channel(textured, tmp_path, kind):
    """meta.json's "channels" says which channel holds what: the labels and the
    intensity come out as the phantom's TIFF folders hold them, the voxel size from
    the stack's own metadata."""
    read = load_label_dataset(stack_dataset(textured, tmp_path / kind, kind))
    tiffs = load_label_dataset(textured)
    assert read.voxel_size == pytest.approx(VOXEL_UM) and read.intensity is not None
    assert read.label_ids == tiffs.label_ids and read.meta.period_ms == PERIOD_MS
    for t in (0, 5):
        assert np.array_equal(read_volume(read.sources[t]), read_volume(tiffs.sources[t]))
        assert np.array_equal(read.intensity.volume(t), tiffs.intensity.volume(t))


def test_a_stack_gives_the_tiff_folders_numbers(textured, tmp_path):
    """The phantom as a two-channel OME-Zarr stack and as TIFF folders: one run's
    numbers, areas, thickness and the intensity pulled back, the same."""
    stack = stack_dataset(textured, tmp_path / "tex", "ome_zarr")
    for source, out in ((textured, tmp_path / "tiff"), (stack, tmp_path / "zarr")):
        assert (
            main(
                ["run", str(source), "--out", str(out), "--quiet", "--jobs", "1", "--numbers-only"]
            )
            == 0
        )
    a, b = (np.load(tmp_path / out / "tex" / "arrays.npz") for out in ("tiff", "zarr"))
    for key in (
        "area_outer_mm2",
        "area_lumen_mm2",
        "wall_thickness_mm",
        "radial_curvature_outer_per_mm",
    ):
        np.testing.assert_allclose(b[key], a[key], rtol=1e-4, atol=1e-9, err_msg=key)
    pa, pb = (np.load(tmp_path / out / "tex" / "pullbacks.npz") for out in ("tiff", "zarr"))
    assert pa.files == pb.files and pa.files
    for key in pa.files:
        np.testing.assert_allclose(pb[key], pa[key], rtol=1e-4, err_msg=key)


@pytest.mark.parametrize(
    "problem",
    ["voxel_size", "period", "channel_missing", "no_channels", "intensity_twice", "not_ome"],
)
def test_a_file_disagreeing_with_meta_json_is_one_line_naming_both(
    textured, tmp_path, capsys, problem
):
    """A stack whose voxel size or time step is not meta.json's, a channel it lacks, a
    stack without "channels", intensity given twice, a zarr group that is no OME
    image: exit 2 and one line naming the file (and both values)."""
    import zarr

    data = stack_dataset(textured, tmp_path / "bad", "ome_zarr")
    meta_path = data / "meta.json"
    meta = json.loads(meta_path.read_text())
    store = data / "labels" / "labels.ome.zarr"
    expect = {
        "voxel_size": (
            store,
            "its voxel size [8, 8, 16] um disagrees with meta.json's "
            "voxel_size [8, 8, 12]; correct one of them",
        ),
        "period": (
            store,
            "its time step 55 ms x 6 frames = 330 ms disagrees with meta.json's "
            "period_ms 400 ms; correct one of them",
        ),
        "channel_missing": (store, "has channels 0-1 (axes tczyx); channel 2 is not there"),
        "no_channels": (
            store,
            'has 2 channels (axes tczyx); meta.json\'s "channels" says which holds what',
        ),
        "intensity_twice": (
            meta_path,
            "takes the intensity from the labels' stack, and the "
            "dataset has intensity/ too; keep one",
        ),
        "not_ome": (store, 'a zarr group without OME-Zarr "multiscales" metadata'),
    }[problem]
    if problem == "voxel_size":
        meta |= {"voxel_size": [8, 8, 12], "length_unit": "um"}
    elif problem == "period":
        meta["period_ms"] = 400
    elif problem == "channel_missing":
        meta["channels"] = {"intensity": 0, "labels": 2}
    elif problem == "no_channels":
        del meta["channels"]
    elif problem == "intensity_twice":
        shutil.copytree(textured / "intensity", data / "intensity")
    elif problem == "not_ome":
        group = zarr.open_group(str(store), mode="r+")
        group.attrs.clear()
    meta_path.write_text(json.dumps(meta))
    assert main(["validate", str(data)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith(f"oftimg: error: {expect[0]}"), err
    assert expect[1] in err[0], err[0]


def test_ome_zarr_probabilities_by_class_and_intensity_beside_them(textured, tmp_path, capsys):
    """probabilities/probabilities.ome.zarr with a channel per class (named in
    "classes", as an ilastik export's are) and intensity/intensity.ome.zarr with its
    frame interval: each layer's map and each frame's intensity as written, the period
    from the files, and validate naming both inputs' formats."""
    labels, intensity = frames_of(textured / "labels"), frames_of(textured / "intensity")
    one_hot = np.stack([labels == k for k in range(4)], axis=1).astype(np.float32)
    data = new_dataset(
        textured,
        tmp_path / "pm",
        drop=("voxel_size", "period_ms"),
        meta_changes={"classes": {"myocardium": 1, "jelly": 2, "lumen": 3}},
    )
    (data / "labels").rmdir()
    (data / "probabilities").mkdir()
    (data / "intensity").mkdir()
    scale = [55.0, VOXEL_UM[2], VOXEL_UM[1], VOXEL_UM[0]]
    ome_zarr_write(
        data / "probabilities" / "probabilities.ome.zarr",
        one_hot,
        [AXES_UM[0], {"name": "c", "type": "channel"}, *AXES_UM[1:]],
        [scale[0], 1.0, *scale[1:]],
        "0.5",
    )
    ome_zarr_write(data / "intensity" / "intensity.ome.zarr", intensity, AXES_UM, scale, "0.4")
    read = load_label_dataset(data)
    assert read.kind == "probabilities" and read.meta.period_ms == pytest.approx(PERIOD_MS)
    assert read.voxel_size == pytest.approx(VOXEL_UM)
    from oftimg.io.label_dataset import read_frame

    maps = read_frame(read.sources[2])
    for layer, k in (("myocardium", 1), ("jelly", 2), ("lumen", 3)):
        assert np.array_equal(maps[layer], one_hot[2, k]), layer
    assert np.array_equal(read.intensity.volume(4), intensity[4].astype(np.float32))
    assert main(["validate", str(data)]) == 0
    out = capsys.readouterr().out
    assert (
        "OME-Zarr 0.5, one file holding every frame; axes tczyx (its OME-Zarr 0.5 "
        "multiscales); voxel size from the files' headers"
    ) in out
    assert (
        "intensity: OME-Zarr 0.4, one file holding every frame; axes tzyx (its OME-Zarr 0.4 "
        "multiscales)"
    ) in out


def test_validate_says_where_the_voxel_size_period_and_channels_came_from(
    textured, tmp_path, capsys
):
    data = stack_dataset(textured, tmp_path / "st", "ome_tiff")
    meta = json.loads((data / "meta.json").read_text())
    del meta["period_ms"]
    (data / "meta.json").write_text(json.dumps(meta))
    assert main(["validate", str(data)]) == 0
    out = capsys.readouterr().out
    assert (
        "OME-TIFF, one file holding every frame; axes tzcyx (its OME-XML); voxel size from "
        "the files' headers"
    ) in out
    assert "channels: intensity 0, labels 1 (meta.json)" in out
    assert "period: 330 ms (labels.ome.tif's time step 55 ms x 6 frames)" in out


def test_the_fields_written_as_ome_zarr_are_valid_and_read_back(run_out, tmp_path, capsys):
    """`oftimg ome-zarr`: every (u, v, t) field, stretch and phase map an OME-Zarr 0.4
    image that ome-zarr-models validates and ome-zarr-py reads back: the array's
    values in image order (v from the outlet down), time in ms at the frame interval,
    the value's unit in its attributes; nothing written over."""
    import zarr
    from ome_zarr.io import parse_url
    from ome_zarr.reader import Reader
    from ome_zarr_models.v04.image import Image

    results = next(p for p in run_out.iterdir() if (p / "arrays.json").is_file())
    out = tmp_path / "oz"
    assert main(["ome-zarr", str(results), "--out", str(out), "--quiet"]) == 0
    page = out / results.name
    described = json.loads((results / "arrays.json").read_text())
    npz = np.load(results / "arrays.npz")
    names = sorted(p.name[: -len(".ome.zarr")] for p in page.iterdir())
    assert "wall_thickness_mm" in names and "principal_stretch_outer" in names
    assert all(described[n]["dims"][:2] == ["u", "v"] for n in names)
    frame_ms = float(np.median(np.diff(npz["t_ms"])))
    for name in ("wall_thickness_mm", "principal_stretch_outer", "phase_max_wall_thickness_mm_ms"):
        group = zarr.open_group(str(page / f"{name}.ome.zarr"), mode="r")
        image = Image.from_zarr(group)  # raises unless valid NGFF 0.4
        axes = [a.name for a in image.ome_attributes.multiscales[0].axes]
        node = next(iter(Reader(parse_url(str(page / f"{name}.ome.zarr")))()))
        values = np.asarray(node.data[0])
        dims = described[name]["dims"]
        expect = np.flip(
            np.transpose(npz[name], {2: (1, 0), 3: (2, 1, 0), 4: (2, 3, 1, 0)}[len(dims)]), axis=-2
        )
        np.testing.assert_array_equal(values, expect.astype(np.float32), err_msg=name)
        assert axes == {2: ["v", "u"], 3: ["t", "v", "u"], 4: ["t", "c", "v", "u"]}[len(dims)]
        if "t" in axes:
            scale = node.metadata["coordinateTransformations"][0][0]["scale"]
            assert scale[0] == pytest.approx(frame_ms)
        assert group.attrs["oftimg"]["unit"] == described[name]["unit"]
    before = sorted(p.name for p in page.iterdir())
    assert main(["ome-zarr", str(results), "--out", str(out), "--quiet"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith(f"oftimg: error: {out}"), err
    assert sorted(p.name for p in page.iterdir()) == before


def test_without_zarr_an_ome_zarr_says_which_extra(tmp_path, capsys, monkeypatch):
    """An OME-Zarr dataset, or writing one, without zarr installed: one line naming
    ``oftimg[ome]``."""
    import sys

    data = tmp_path / "emb"
    (data / "labels" / "labels.ome.zarr").mkdir(parents=True)
    (data / "meta.json").write_text(json.dumps({"period_ms": 300}))
    monkeypatch.setitem(sys.modules, "zarr", None)  # import zarr: ImportError
    assert main(["validate", str(data)]) == 2
    assert capsys.readouterr().err.strip().splitlines() == [
        f"oftimg: error: {data / 'labels' / 'labels.ome.zarr'}: reading a zarr store needs "
        "zarr: pip install 'oftimg[ome]'"
    ]
    assert main(["ome-zarr", str(data), "--out", str(tmp_path / "out")]) == 2
    assert capsys.readouterr().err.strip().splitlines() == [
        "oftimg: error: writing OME-Zarr needs zarr: pip install 'oftimg[ome]'"
    ]
