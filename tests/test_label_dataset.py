"""Label datasets (issue 53): the formats read back, the label phantom through
`oftimg run` and `oftimg mesh`, anisotropic voxels, ends planes, and bad input."""

import json
import shutil

import numpy as np
import pytest

from oftimg.cli import main
from oftimg.errors import DatasetError, OftimgWarning
from oftimg.io.dataset import load_dataset, validate_dataset
from oftimg.io.label_dataset import load_label_dataset, mesh_frame
from oftimg.io.labelfile import read_volume
from oftimg.mesh.labels import MeshOptions, mesh_wall, mesh_walls
from oftimg.mesh.topology import boundary_loops, capped_signed_volume, check_tube, face_areas
from oftimg.synthetic.labels import LABEL_VALUES, LabelGrid, label_params, write_label_phantom
from oftimg.synthetic.phantom import Phantom, sample_params

from helpers import label_phantom_area_errors

pytestmark = pytest.mark.usefixtures("png_figures_only")

COARSE_UM = (8.0, 8.0, 16.0)  # fast: about half a million voxels a frame


@pytest.fixture(scope="module")
def label_phantom(tmp_path_factory):
    """A small label phantom: 8 frames of 8 x 8 x 16 um voxels, with segmentation noise."""
    path = tmp_path_factory.mktemp("labels") / "lp"
    write_label_phantom(path, sample_params("normal", 0, n_frames=8), COARSE_UM, noise=0.05)
    return path


def copy_with(src, dst, meta=None, frames=None):
    """A copy of a label dataset with meta.json entries replaced and frames (index ->
    volume, written as .tif) replaced."""
    import tifffile

    shutil.copytree(src, dst)
    if meta is not None:
        raw = json.loads((dst / "meta.json").read_text())
        raw.update(meta)
        (dst / "meta.json").write_text(json.dumps(raw))
    files = sorted((dst / "labels").iterdir())
    for t, volume in (frames or {}).items():
        tifffile.imwrite(files[t], volume)
    return dst


def run_fails(capsys, args, out):
    """Run the CLI expecting exit 2: the one error line, and no ``out`` left."""
    assert main(args) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert not out.exists()
    return err[0]


def test_formats_read_back(label_phantom, tmp_path):
    """The same frames as per-frame TIFF, one 4-D ImageJ TIFF with its spacing,
    per-frame NIfTI (spacing in its header, axes (x, y, z)), .npy, zarr, and OME-TIFF
    (4-D t-major and z-major, and per frame, as tifffile's OME writer makes them):
    each read back voxel for voxel, with its voxel size."""
    import nibabel
    import tifffile
    import zarr

    lds = load_label_dataset(label_phantom)
    volumes = [read_volume(s) for s in lds.sources[:3]]
    assert lds.voxel_size == COARSE_UM and volumes[0].shape == lds.shape
    assert lds.label_ids == LABEL_VALUES
    meta = {
        k: v
        for k, v in json.loads((label_phantom / "meta.json").read_text()).items()
        if k != "voxel_size"
    }

    def dataset(name):
        folder = tmp_path / name
        (folder / "labels").mkdir(parents=True)
        (folder / "meta.json").write_text(json.dumps(meta))
        return folder

    dx, dy, dz = COARSE_UM
    stack = dataset("imagej")
    tifffile.imwrite(
        stack / "labels" / "labels.tif",
        np.stack(volumes),
        imagej=True,
        resolution=(1 / dx, 1 / dy),
        metadata={"spacing": dz, "unit": "um", "axes": "TZYX"},
    )
    nifti = dataset("nifti")
    for t, v in enumerate(volumes):
        img = nibabel.Nifti1Image(v.transpose(2, 1, 0), np.diag([dx, dy, dz, 1.0]))
        img.header.set_xyzt_units("micron")
        nibabel.save(img, nifti / "labels" / f"t{t}.nii.gz")
    npy = dataset("npy")
    for t, v in enumerate(volumes):
        np.save(npy / "labels" / f"t{t}.npy", v)
    (npy / "meta.json").write_text(json.dumps({**meta, "voxel_size": list(COARSE_UM)}))
    store = dataset("zarr")
    zarr.save_array(str(store / "labels" / "labels.zarr"), np.stack(volumes))
    (store / "meta.json").write_text(json.dumps({**meta, "voxel_size": list(COARSE_UM)}))
    # OME-TIFF as Bio-Formats and Fiji write it: the voxel size in its OME-XML (each
    # axis in its unit), the planes in the order its DimensionOrder gives
    physical = {f"PhysicalSize{a}": d for a, d in zip("XYZ", COARSE_UM)}
    ome = dataset("ome")
    tifffile.imwrite(
        ome / "labels" / "labels.ome.tif",
        np.stack(volumes),
        ome=True,
        metadata={"axes": "TZYX", **physical, **{f"PhysicalSize{a}Unit": "µm" for a in "XYZ"}},
    )
    z_major = dataset("ome_z_major")
    tifffile.imwrite(
        z_major / "labels" / "labels.ome.tif",
        np.stack(volumes).transpose(1, 0, 2, 3),
        ome=True,
        metadata={"axes": "ZTYX", **physical},
    )  # µm: OME's default
    per_frame = dataset("ome_per_frame")
    for t, v in enumerate(volumes):
        tifffile.imwrite(
            per_frame / "labels" / f"t{t}.ome.tif",
            v,
            ome=True,
            metadata={
                "axes": "ZYX",
                **{k: d / 1000 for k, d in physical.items()},
                **{f"PhysicalSize{a}Unit": "mm" for a in "XYZ"},
            },
        )
    for folder in (stack, nifti, npy, store, ome, z_major, per_frame):
        read = load_label_dataset(folder)
        assert read.n_frames == 3 and read.shape == lds.shape, folder.name
        assert read.voxel_size == pytest.approx(COARSE_UM), folder.name
        for source, volume in zip(read.sources, volumes):
            assert np.array_equal(read_volume(source), volume), folder.name


def test_the_label_phantom_through_run(label_phantom, tmp_path):
    """`oftimg run` meshes each frame in its workers; the results record the label
    files and the meshing; the section areas follow the truth (coarse voxels here:
    within 6 %; the accuracy run at 4 x 4 x 8 um is in docs/accuracy.md)."""
    out = tmp_path / "res"
    with pytest.warns(OftimgWarning, match="curvature fields from label volumes are less exact"):
        assert main(["run", str(label_phantom), "--out", str(out), "--quiet", "--jobs", "2"]) == 0
    summary = json.loads((out / "lp" / "summary.json").read_text())
    prov = summary["provenance"]
    assert [f["file"] for f in prov["inputs"]["labels"]] == [
        str(p) for p in sorted((label_phantom / "labels").iterdir())
    ]
    meshing = prov["meshing"]
    assert meshing["voxel_size"] == list(COARSE_UM) and meshing["labels"] == LABEL_VALUES
    assert set(meshing["vertices"]) == {"outer", "inner", "lumen"}
    assert all(len(v) == 8 and min(v) > 1000 for v in meshing["vertices"].values())
    assert prov["options"]["meshing"] == MeshOptions().as_dict()
    for wall, error in label_phantom_area_errors(out / "lp", label_phantom, 8).items():
        assert np.median(error) < 0.06, wall
    assert not list(tmp_path.rglob("*.meshes"))  # the meshes went with the run


def test_mesh_command_writes_a_mesh_dataset(label_phantom, tmp_path):
    out = tmp_path / "meshed"
    assert (
        main(
            [
                "mesh",
                str(label_phantom),
                str(out),
                "--quiet",
                "--jobs",
                "1",
                "--mesh-vertices",
                "3000",
            ]
        )
        == 0
    )
    for wall in ("outer", "inner", "lumen"):
        assert len(list((out / wall).glob("*.ply"))) == 8
    meta = json.loads((out / "meta.json").read_text())
    source = json.loads((label_phantom / "meta.json").read_text())
    assert meta == {k: source[k] for k in ("name", "group", "period_ms", "length_unit", "inlet")}
    record = json.loads((out / "meshing.json").read_text())
    assert all(2000 < n < 4000 for n in record["meshing"]["vertices"]["outer"])
    report = validate_dataset(load_dataset(out))
    assert set(report["surfaces"]) == {"outer", "inner", "lumen"}


def test_a_dask_cluster_meshes_the_frames_as_this_process_does(label_phantom, tmp_path):
    """--scheduler: each worker reads its own frame's volume and writes its meshes."""
    distributed = pytest.importorskip("distributed")
    from oftimg.io.label_dataset import mesh_label_dataset
    from oftimg.io.meshfile import read_mesh_file
    from oftimg.workers import make_executor

    lds = load_label_dataset(label_phantom)
    options = MeshOptions(target_vertices=3000)
    serial = mesh_label_dataset(lds, tmp_path / "serial", options)
    with distributed.LocalCluster(
        n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None
    ) as cluster:
        executor = make_executor(None, scheduler=cluster.scheduler_address)
        try:
            remote = mesh_label_dataset(lds, tmp_path / "dask", options, executor=executor)
        finally:
            executor.shutdown()
            executor._client.close()
    assert remote["meshing"]["vertices"] == serial["meshing"]["vertices"]
    for wall in ("outer", "inner", "lumen"):
        frames = sorted((tmp_path / "serial" / wall).iterdir())
        remote_frames = sorted((tmp_path / "dask" / wall).iterdir())
        assert [f.name for f in frames] == [f.name for f in remote_frames]
        for frame in frames:
            (V, F), (V_remote, F_remote) = (
                read_mesh_file(frame),
                read_mesh_file(tmp_path / "dask" / wall / frame.name),
            )
            assert np.array_equal(V, V_remote) and np.array_equal(F, F_remote), frame


def test_validate_meshes_a_label_dataset_as_a_run_would(label_phantom, capsys):
    assert main(["validate", str(label_phantom)]) == 0
    out = capsys.readouterr().out
    assert "label volumes (z, y, x) (36, 133, 133), voxel 8 x 8 x 16 um" in out
    assert all(f"  {wall} " in out for wall in ("outer", "inner", "lumen"))
    assert "problems: none" in out


def test_anisotropic_voxels_agree_and_the_order_matters():
    """One frame of the phantom at 4 x 4 x 4 and 4 x 4 x 12 um: each wall's volume
    and area within 2 %, the volume within 3 % of the model's; the voxel size given
    in the wrong order is another tube."""
    ph = Phantom(label_params(sample_params("banded", 1, n_frames=4)))

    def measured(voxel, given=None):
        """Each wall's capped volume (mm^3) and surface area (mm^2)."""
        walls = mesh_walls(LabelGrid(ph, voxel).labels(100.0), LABEL_VALUES, given or voxel)
        return {
            w: (
                capped_signed_volume(m.V, m.F, boundary_loops(m.F)) * 1e-9,
                face_areas(m.V, m.F).sum() * 1e-6,
            )
            for w, m in walls.items()
        }

    fine, coarse = measured((4.0, 4.0, 4.0)), measured((4.0, 4.0, 12.0))
    for wall, (volume, area) in fine.items():
        assert coarse[wall][0] == pytest.approx(volume, rel=0.02), wall
        assert coarse[wall][1] == pytest.approx(area, rel=0.02), wall
        assert volume == pytest.approx(ph.volume_mm3(wall, 100.0)[0], rel=0.03), wall
    # x and z swapped keep dx dy dz, so the volume; the tube's shape changes
    wrong = measured((4.0, 4.0, 12.0), given=(12.0, 4.0, 4.0))
    assert abs(wrong["outer"][1] / fine["outer"][1] - 1) > 0.2


def closed_cylinder(shape=(60, 40, 40), radius=12, ends=(10, 50)):
    """A solid cylinder along z that ends inside the volume at both ``ends``
    (voxel planes): (z, y, x) labels 1."""
    z, y, x = np.indices(shape)
    inside = (
        (np.hypot(x - shape[2] / 2, y - shape[1] / 2) <= radius) & (z >= ends[0]) & (z < ends[1])
    )
    return inside.astype(np.uint8)


def test_ends_planes_cut_a_tube_inside_the_volume():
    """A tube that ends inside the volume is cut at the two ``ends`` planes: two
    boundary loops, each lying in its plane; without them it is refused."""
    labels = closed_cylinder()
    ends = (((0, 0, 80.0), (0, 0, 1.0)), ((0, 0, 320.0), (0, 0, -1.0)))
    wall = mesh_wall(labels.astype(bool), (8.0, 8.0, 8.0), ends=ends)
    loops = boundary_loops(wall.F)
    check_tube(wall.V, wall.F)
    assert sorted(float(wall.V[lp, 2].mean()) for lp in loops) == pytest.approx([80.0, 320.0])
    assert all(np.ptp(wall.V[lp, 2]) < 1e-6 for lp in loops)
    volume = capped_signed_volume(wall.V, wall.F, loops)
    assert volume == pytest.approx(np.pi * (12 * 8.0) ** 2 * 240.0, rel=0.03)
    from oftimg.mesh.topology import MeshError

    with pytest.raises(MeshError, match="closed surface"):
        mesh_wall(labels.astype(bool), (8.0, 8.0, 8.0))
    beside = (((0, 0, 400.0), (0, 0, 1.0)), ((0, 0, 470.0), (0, 0, -1.0)))  # past its end
    with pytest.raises(
        MeshError, match="lies wholly outside the part between the ends planes"
    ):  # an IndexError (found by the fuzzer)
        mesh_wall(labels.astype(bool), (8.0, 8.0, 8.0), ends=beside)


def test_ends_in_meta_json_cut_a_tube_that_ends_inside_the_volume(label_phantom, tmp_path):
    """The phantom's outlet end moved inside the volume (the voxels beyond x = 200 um
    cleared in every frame): with meta.json "ends" (the inlet face, and a plane at
    x = 240 um), every wall of every frame is an open tube whose outlet loop lies in
    that plane."""
    lds = load_label_dataset(label_phantom)
    cleared = {}
    for t, source in enumerate(lds.sources):
        volume = read_volume(source)
        volume[:, :, : int(200 / COARSE_UM[0])] = 0
        cleared[t] = volume
    ends = [
        {"point": [0, 0, 0], "normal": [0, 1, 0]},
        {"point": [240.0, 0, 0], "normal": [1, 0, 0]},
    ]
    data = copy_with(label_phantom, tmp_path / "inside", meta={"ends": ends}, frames=cleared)
    out = tmp_path / "meshed"
    assert main(["mesh", str(data), str(out), "--quiet", "--jobs", "1"]) == 0
    ds = load_dataset(out)
    for wall in ds.surfaces:
        for tube in ds.iter_tubes(wall):
            outlet_x = tube.V[tube.outlet, 0] * 1e3  # mm -> um
            assert np.allclose(outlet_x, 240.0, atol=1e-6), wall
            assert np.allclose(tube.V[tube.inlet, 1], 0.0, atol=1e-9), wall


def test_a_wall_that_cannot_be_meshed_is_left_out_with_its_reason(tmp_path):
    """The worker returns why a wall cannot be meshed (the dataset then fills it from
    the frames around, or names every such frame) and writes nothing for it; a
    file that is no label volume comes back as the error naming it."""
    import tifffile

    from oftimg.io.labelfile import LabelSource

    path = tmp_path / "f0.tif"
    tifffile.imwrite(path, closed_cylinder(ends=(0, 30)))  # leaves through z = 0 only
    record = mesh_frame(
        LabelSource(str(path)),
        str(tmp_path / "out"),
        "f0.ply",
        {"myocardium": 1},
        (8.0, 8.0, 8.0),
        MeshOptions(),
    )
    assert record["left_out"]["outer"].startswith(
        "the outer wall leaves the volume at one end only"
    )
    assert record["vertices"] == {} and not (tmp_path / "out").exists()
    tifffile.imwrite(path, closed_cylinder().astype(np.float32))
    error = mesh_frame(
        LabelSource(str(path)),
        str(tmp_path / "out"),
        "f0.ply",
        {"myocardium": 1},
        (8.0, 8.0, 8.0),
        MeshOptions(),
    )
    assert str(error).startswith(f"{path}: labels are float32, not integers")


@pytest.mark.parametrize("problem", ["shape", "float", "absent", "zero", "one_face", "nifti"])
def test_bad_label_input_one_line_exit_2_nothing_written(label_phantom, tmp_path, capsys, problem):
    lds = load_label_dataset(label_phantom)
    first = read_volume(lds.sources[0])
    bad = tmp_path / "bad"
    if problem == "shape":
        copy_with(label_phantom, bad, frames={3: first[:, :-1]})
        expect = ["f3.tif", "shape", str(first.shape)]
    elif problem == "float":
        copy_with(label_phantom, bad, frames={2: first.astype(np.float32)})
        expect = ["f2.tif", "float32 labels"]
    elif problem == "absent":
        copy_with(label_phantom, bad, frames={4: np.where(first == 3, 2, first).astype(np.uint8)})
        expect = ["f4.tif", "no voxel labelled lumen (3)"]
    elif problem == "zero":
        copy_with(label_phantom, bad, frames={5: np.zeros_like(first)})
        expect = ["f5.tif", "no labelled voxel (all zero)"]
    elif problem == "one_face":
        cut = first.copy()
        cut[:, :, : cut.shape[2] // 3] = 0  # the outlet end now inside the box
        copy_with(label_phantom, bad, frames={1: cut})
        expect = ["f1.tif", "one end only", '"ends"']
    else:
        import nibabel

        copy_with(label_phantom, bad)
        shutil.rmtree(bad / "labels")
        (bad / "labels").mkdir()
        for t in range(6):
            img = nibabel.Nifti1Image(first.transpose(2, 1, 0), np.diag([8.0, 8.0, 8.0, 1.0]))
            img.header.set_xyzt_units("micron")
            nibabel.save(img, bad / "labels" / f"t{t}.nii")
        expect = [
            "t0.nii",
            "voxel size [8, 8, 8] um disagrees with meta.json's voxel_size [8, 8, 16]",
        ]
    out = tmp_path / "out"
    line = run_fails(capsys, ["run", str(bad), "--out", str(out), "--quiet", "--jobs", "1"], out)
    assert line.startswith("oftimg: error: ") and all(e in line for e in expect), line
    assert not list(tmp_path.glob("*.meshes")) and not list(tmp_path.glob(".out*"))


LABEL_HEADER_PROBLEMS = {  # meta.json entry -> what the one line says (all found by a fuzzer)
    "label_beyond_dtype": (
        {"labels": {"myocardium": 1, "jelly": 2, "lumen": 300}},
        "label 300 cannot occur in",
    ),
    "label_10_400": (
        '{"labels": {"myocardium": 1' + "0" * 400 + "}}",
        "a whole number of 401 digits",
    ),
    "ends_one_point": (
        {
            "ends": [
                {"point": [100, 100, 100], "normal": [1, 0, 0]},
                {"point": [100, 100, 100], "normal": [-1, 0, 0]},
            ]
        },
        "the ends planes keep nothing of the volume between them",
    ),
    "ends_far": (
        {
            "ends": [
                {"point": [0, 0, 0], "normal": [1, 0, 0]},
                {"point": [1e9, 0, 0], "normal": [-1, 0, 0]},
            ]
        },
        "ends point [1000000000.0, 0.0, 0.0] lies outside the volume",
    ),
    "ends_no_normal": (
        {
            "ends": [
                {"point": [0, 0, 0], "normal": [0, 0, 0]},
                {"point": [200, 0, 0], "normal": [-1, 0, 0]},
            ]
        },
        "an ends normal has no direction",
    ),
    "tiny_voxel": ({"voxel_size": [10, 1e-12, 20]}, "each side must lie between 1e-05 and 10 mm"),
}


@pytest.mark.parametrize("problem", sorted(LABEL_HEADER_PROBLEMS))
def test_absurd_label_headers_are_refused_before_any_meshing(
    label_phantom, tmp_path, capsys, problem
):
    """Each gave an exception's text (ValueError, TypeError, MemoryError for 128 TiB)."""
    bad = copy_with(label_phantom, tmp_path / "bad")
    entry, expect = LABEL_HEADER_PROBLEMS[problem]
    if isinstance(entry, str):
        (bad / "meta.json").write_text(entry)
    else:
        raw = json.loads((bad / "meta.json").read_text())
        (bad / "meta.json").write_text(json.dumps({**raw, **entry}))
    assert main(["validate", str(bad)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith(f"oftimg: error: {bad / 'meta.json'}: ")
    assert expect in err[0], err[0]


@pytest.mark.parametrize("problem", ["random_labels", "four_frames", "folder", "fifo"])
def test_odd_label_frames_are_named_in_one_line(
    label_phantom, tmp_path, capsys, monkeypatch, problem
):
    """Random labels gave marching cubes' "Surface level must be within volume data range";
    4 frames passed validate and failed the run; a folder or FIFO named as a frame gave
    "[Errno 21]" or blocked."""
    import os

    from oftimg.progress import EVERY_S_VARIABLE

    monkeypatch.setenv(
        EVERY_S_VARIABLE, "3600"
    )  # a slow machine's progress line is not an error line

    lds = load_label_dataset(label_phantom)
    shape = read_volume(lds.sources[0]).shape
    rng = np.random.default_rng(0)
    bad = copy_with(
        label_phantom,
        tmp_path / "bad",
        frames={2: rng.integers(1, 4, shape).astype(np.uint8)}
        if problem == "random_labels"
        else None,
    )
    frames = sorted((bad / "labels").iterdir())
    if problem == "four_frames":
        for f in frames[4:]:
            f.unlink()
    elif problem in ("folder", "fifo"):
        frames[3].unlink()
        frames[3].mkdir() if problem == "folder" else os.mkfifo(frames[3])
    expect = {
        "random_labels": (bad / "labels", "f2.tif: the outer wall fills the whole volume"),
        "four_frames": (bad / "labels", "4 frames; an analysis needs at least 5"),
        "folder": (frames[3], "is a folder, not a file"),
        "fifo": (frames[3], "is a named pipe (FIFO), not a file"),
    }[problem]
    assert main(["validate", str(bad)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith(f"oftimg: error: {expect[0]}"), err
    assert expect[1] in err[0], err[0]


def test_a_zarr_store_without_zarr_installed_says_how_to_get_it(tmp_path, capsys, monkeypatch):
    """An empty labels.zarr without zarr installed gave ModuleNotFoundError's text."""
    import sys

    data = tmp_path / "emb"
    (data / "labels" / "labels.zarr").mkdir(parents=True)
    (data / "meta.json").write_text(
        json.dumps({"period_ms": 300, "voxel_size": [8, 8, 16], "length_unit": "um"})
    )
    monkeypatch.setitem(sys.modules, "zarr", None)  # import zarr: ImportError
    assert main(["validate", str(data)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err == [
        f"oftimg: error: {data / 'labels' / 'labels.zarr'}: reading a zarr store "
        "needs zarr: pip install 'oftimg[zarr]'"
    ]


def test_a_bridge_across_the_lumen_in_one_frame_is_mended_and_said(label_phantom, tmp_path, capsys):
    """A strand of jelly across the lumen in one frame (Euler characteristic -2 on the
    mesh) refused the whole dataset; now that frame's lumen mask is closed by a ball of
    one voxel, the frame meshes as an open tube, and the repair is named in a warning
    and recorded at its frame and wall."""
    lds = load_label_dataset(label_phantom)
    volume = read_volume(lds.sources[2]).copy()
    lumen = volume == LABEL_VALUES["lumen"]
    k = int(np.median(np.nonzero(lumen)[0]))
    j = int(np.median(np.nonzero(lumen[k])[0]))
    across = np.nonzero(lumen[k, j])[0]
    strand = (slice(k, k + 2), slice(j, j + 2), slice(across.min() - 1, across.max() + 2))
    volume[strand] = np.where(
        volume[strand] == LABEL_VALUES["lumen"], LABEL_VALUES["jelly"], volume[strand]
    )
    data = copy_with(label_phantom, tmp_path / "bridged", frames={2: volume})
    out = tmp_path / "meshed"
    with pytest.warns(
        OftimgWarning,
        match=r"mended the topology of 1 wall mask .*: "
        r"f2\.tif lumen \(closing",
    ):
        assert main(["mesh", str(data), str(out), "--quiet", "--jobs", "1"]) == 0
    meshing = json.loads((out / "meshing.json").read_text())
    repairs = meshing["meshing"]["label_repairs"]
    assert [(r["frame"], r["wall"]) for r in repairs] == [(2, "lumen")]
    assert repairs[0]["what"].startswith("closing, radius ") and repairs[0]["voxels"] > 0
    for tube in load_dataset(out).iter_tubes("lumen"):  # every frame an open tube
        assert len(tube.inlet) and len(tube.outlet)
    results = tmp_path / "results"  # a run says it on the pages too
    assert main(["run", str(data), "--out", str(results), "--quiet", "--jobs", "1"]) == 0
    page = next(results.glob("*/summary.json")).parent  # named as in its meta.json
    summary = json.loads((page / "summary.json").read_text())
    assert [(r["frame"], r["wall"]) for r in summary["provenance"]["meshing"]["label_repairs"]] == [
        (2, "lumen")
    ]
    assert "mended the topology of 1 wall mask" in (page / "index.html").read_text()


def test_an_ome_tiff_with_channels_or_an_odd_unit_is_named(tmp_path):
    """An OME-TIFF of three channels is no label series unless meta.json says which
    channel holds what, and a voxel size in a unit that is no length is not taken: one
    line each, naming the file."""
    import tifffile

    from oftimg.io.labelfile import LabelSource, read_header

    two = tmp_path / "two.ome.tif"
    tifffile.imwrite(two, np.zeros((2, 3, 2, 8, 8), np.uint8), ome=True, metadata={"axes": "TCZYX"})
    with pytest.raises(
        DatasetError,
        match=r"two.ome.tif: has 3 channels \(axes TCZYX\); "
        r"meta.json's \"channels\" says which holds what",
    ):
        read_header(LabelSource(str(two), 0))
    odd = tmp_path / "odd.ome.tif"
    tifffile.imwrite(
        odd,
        np.zeros((3, 8, 8), np.uint8),
        ome=True,
        metadata={
            "axes": "ZYX",
            "PhysicalSizeX": 1.0,
            "PhysicalSizeXUnit": "s",
            "PhysicalSizeY": 1.0,
            "PhysicalSizeZ": 1.0,
        },
    )
    with pytest.raises(
        DatasetError, match="odd.ome.tif: OME PhysicalSizeXUnit 's' is not a length"
    ):
        read_header(LabelSource(str(odd)))


def test_a_tiff_header_is_read_from_its_description_only_when_its_pages_agree(tmp_path):
    """tifffile's "shaped" description gives a per-frame TIFF's shape without parsing
    its pages (a dataset's headers are read for every frame); a description whose
    shape the pages do not bear out is not believed."""
    import tifffile

    from oftimg.io.labelfile import LabelSource, _shaped_shape, read_header

    good = tmp_path / "good.tif"
    tifffile.imwrite(good, np.zeros((5, 7, 9), np.uint16))
    lying = tmp_path / "lying.tif"
    tifffile.imwrite(
        lying, np.zeros((5, 7, 9), np.uint8), description='{"shape": [4, 7, 9]}', metadata=None
    )
    with tifffile.TiffFile(good) as tif:
        assert _shaped_shape(tif) == (5, 7, 9)
    with tifffile.TiffFile(lying) as tif:
        assert _shaped_shape(tif) is None
    assert read_header(LabelSource(str(good))).shape == (5, 7, 9)
    assert read_header(LabelSource(str(good))).dtype == np.uint16
    assert read_header(LabelSource(str(lying))).shape == (5, 7, 9)  # from its pages


@pytest.mark.parametrize("kind", ["labels", "probabilities"])
def test_um_voxels_given_as_mm_are_named_as_such(tmp_path, capsys, kind):
    """Voxel sizes in µm with meta.json's length_unit "mm" (its "labels" given, as the
    docs say: a label dataset's own keys): a tube 395 mm across is refused in one line
    that names the volumes and the length unit to write, not "unknown key 'labels'"
    (the tube-size check read meta.json with a mesh dataset's keys; issue 83, point 3)."""
    import tifffile

    data = tmp_path / "embryo"
    tube = closed_cylinder((30, 48, 48), radius=22, ends=(0, 30)).astype(np.uint8)
    if kind == "labels":
        (data / "labels").mkdir(parents=True)
        for t in range(6):
            tifffile.imwrite(data / "labels" / f"f{t}.tif", tube)
        meta = {"labels": {"myocardium": 1}}
    else:
        (data / "probabilities" / "myocardium").mkdir(parents=True)
        for t in range(6):
            tifffile.imwrite(data / "probabilities" / "myocardium" / f"f{t}.tif", tube * 255)
        meta = {}
    (data / "meta.json").write_text(
        json.dumps({**meta, "length_unit": "mm", "voxel_size": [9.0, 9.0, 9.0], "period_ms": 300})
    )
    line = run_fails(
        capsys,
        ["run", str(data), "--out", str(tmp_path / "out"), "--quiet", "--jobs", "1"],
        tmp_path / "out",
    )
    assert "unknown key" not in line
    assert line.startswith(f"oftimg: error: {data / kind}: a tube 39")
    assert "meta.json's length_unit right? The voxel sizes look like um" in line
    assert '"length_unit": "um"' in line


def transposed_copy(src, dst, meta, *, kind="tif"):
    """The label dataset ``src`` with every frame saved (x, y, z), as ``kind`` (plain
    TIFF or npy), and meta.json's entries ``meta`` (None: the key removed)."""
    import tifffile

    shutil.copytree(src, dst)
    for path in sorted((dst / "labels").iterdir()):
        volume = tifffile.imread(path).transpose(2, 1, 0)
        path.unlink()
        if kind == "tif":
            tifffile.imwrite(path, volume)
        else:
            np.save(path.with_suffix(".npy"), volume)
    raw = json.loads((dst / "meta.json").read_text())
    for key, value in meta.items():
        raw.pop(key, None) if value is None else raw.update({key: value})
    (dst / "meta.json").write_text(json.dumps(raw))
    return dst


@pytest.mark.parametrize("kind", ["tif", "npy"])
def test_volumes_that_name_no_axis_order_need_it_where_voxels_are_not_cubes(
    label_phantom, tmp_path, capsys, kind
):
    """Frames saved (x, y, z) in files that name no order of their axes, with voxels of
    8 x 8 x 16 um (issue 83, point 2: read as (z, y, x), a tube twice as long and a
    speed 85 % high, exit 0): without meta.json's "axes" the run stops in one line that
    names the file and what to write; with "axes": "xyz" the frames are read as they
    are meant, the same volumes and areas as the phantom's own files give."""
    bare = transposed_copy(label_phantom, tmp_path / "bare", {"axes": None}, kind=kind)
    line = run_fails(
        capsys, ["run", str(bare), "--out", str(tmp_path / "o"), "--quiet"], tmp_path / "o"
    )
    assert line.startswith(f"oftimg: error: {bare / 'labels'}/") and "not cubes" in line
    assert '"axes": "zyx"' in line and "stretched 4 times" in line
    said = transposed_copy(label_phantom, tmp_path / "said", {"axes": "xyz"}, kind=kind)
    assert main(["validate", str(said)]) == 0
    out = capsys.readouterr().out
    assert "label volumes (z, y, x) (36, 133, 133), voxel 8 x 8 x 16 um" in out
    assert "xyz (meta.json" in out
    assert main(["validate", str(label_phantom)]) == 0
    own = capsys.readouterr().out
    rows = [
        [line for line in text.splitlines() if line.startswith("  outer ")] for text in (out, own)
    ]
    assert rows[0] == rows[1]


def test_cubic_voxels_or_files_that_name_their_axes_need_no_axis_order(label_phantom, tmp_path):
    """Voxels that are cubes: a volume read in another order is the same tube mirrored
    (every number the same); an ImageJ TIFF names its axes. Neither needs "axes"; an
    "axes" that contradicts the file's own names is refused."""
    import tifffile

    from oftimg.io.label_dataset import load_label_dataset

    cubes = transposed_copy(
        label_phantom, tmp_path / "cubes", {"axes": None, "voxel_size": [8.0, 8.0, 8.0]}
    )
    assert load_label_dataset(cubes).voxel_size == (8.0, 8.0, 8.0)
    named = transposed_copy(label_phantom, tmp_path / "named", {"axes": None})
    for path in sorted((named / "labels").iterdir()):
        volume = tifffile.imread(path).transpose(2, 1, 0)  # back to (z, y, x)
        tifffile.imwrite(
            path,
            volume,
            imagej=True,
            resolution=(1 / 8.0, 1 / 8.0),
            metadata={"spacing": 16.0, "unit": "um", "axes": "ZYX"},
        )
    assert load_label_dataset(named).voxel_size == (8.0, 8.0, 16.0)
    raw = json.loads((named / "meta.json").read_text())
    (named / "meta.json").write_text(json.dumps({**raw, "axes": "xyz"}))
    with pytest.raises(DatasetError, match="names its own axes .* contradicts"):
        load_label_dataset(named)


def test_a_series_whose_file_names_its_axes_wrongly_is_refused_by_its_shape(
    label_phantom, tmp_path, capsys
):
    """A (t, x, y, z) array written as an OME-TIFF with the axes TZYX (issue 83, point 2:
    exit 0, a tube twice as long): read so, the tube's sections are 2-3 times longer
    one way than the other, round read as (x, y, z); the run stops in one line that
    says so. The same frames written in their true order pass."""
    import tifffile

    frames = np.stack([tifffile.imread(p) for p in sorted((label_phantom / "labels").iterdir())])
    voxel = {
        "PhysicalSizeX": 8.0,
        "PhysicalSizeY": 8.0,
        "PhysicalSizeZ": 16.0,
        **{f"PhysicalSize{a}Unit": "µm" for a in "XYZ"},
    }
    for name, array in (("wrong", frames.transpose(0, 3, 2, 1)), ("right", frames)):
        data = tmp_path / name
        (data / "labels").mkdir(parents=True)
        tifffile.imwrite(
            data / "labels" / "labels.ome.tif", array, ome=True, metadata={"axes": "TZYX", **voxel}
        )
        raw = json.loads((label_phantom / "meta.json").read_text())
        (data / "meta.json").write_text(
            json.dumps({k: v for k, v in raw.items() if k not in ("axes", "voxel_size")})
        )
    line = run_fails(
        capsys,
        ["run", str(tmp_path / "wrong"), "--out", str(tmp_path / "o"), "--quiet", "--jobs", "1"],
        tmp_path / "o",
    )
    assert line.startswith(f"oftimg: error: {tmp_path / 'wrong' / 'labels' / 'labels.ome.tif'}")
    assert "read as (x, y, z)" in line and "save it with its axes in their true order" in line
    assert main(["validate", str(tmp_path / "right")]) == 0


def test_a_series_file_is_parsed_once_per_process(label_phantom, tmp_path, monkeypatch):
    """A 4-D OME-TIFF's frames are checked and read without opening and parsing the
    file again for each (issue 83, point 5: 195 frames of 54 planes took 48 s to check,
    quadratic in the frames; scripts/bench_series.py times it against files per frame):
    every header and every frame of the series from one parse."""
    import tifffile

    from oftimg.io import labelfile
    from oftimg.io.label_dataset import load_label_dataset

    frames = np.stack([tifffile.imread(p) for p in sorted((label_phantom / "labels").iterdir())])
    data = tmp_path / "series"
    (data / "labels").mkdir(parents=True)
    tifffile.imwrite(
        data / "labels" / "labels.ome.tif",
        frames,
        ome=True,
        metadata={
            "axes": "TZYX",
            "PhysicalSizeX": 8.0,
            "PhysicalSizeY": 8.0,
            "PhysicalSizeZ": 16.0,
        },
    )
    raw = json.loads((label_phantom / "meta.json").read_text())
    (data / "meta.json").write_text(
        json.dumps({k: v for k, v in raw.items() if k not in ("axes", "voxel_size")})
    )
    opened = []
    original = tifffile.TiffFile.__init__

    def counted(self, *args, **kwargs):
        opened.append(args[0] if args else kwargs.get("file"))
        original(self, *args, **kwargs)

    monkeypatch.setattr(tifffile.TiffFile, "__init__", counted)
    labelfile.close_series_files()
    lds = load_label_dataset(data)
    volumes = [read_volume(source) for source in lds.sources]
    assert np.array_equal(np.stack(volumes), frames)
    assert len(opened) == 1
    assert (
        labelfile.describe_format(lds.sources[0])["format"]
        == "OME-TIFF, one file holding every frame"
    )
