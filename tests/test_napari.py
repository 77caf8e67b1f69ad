"""The napari plugin (issue 63, first part): a results folder opens as the walls'
surfaces over time on napari's time slider, coloured by a field in the house colour
maps; found by napari through the entry point; oftimg itself never imports napari.
Headless: napari's ViewerModel, no Qt."""

import subprocess
import sys

import numpy as np
import pytest

napari = pytest.importorskip("napari")

from oftimg.napari.reader import napari_get_reader, results_layers  # noqa: E402
from oftimg.napari.surfaces import surface_over_time, wall_layer  # noqa: E402

pytestmark = pytest.mark.long  # make test-long (accuracy, rendering, whole runs)


def _cylinder(n_u=8, n_v=5, n_t=3):
    u = np.linspace(0, 2 * np.pi, n_u, endpoint=False)[:, None, None]
    v = np.linspace(0, 1, n_v)[None, :, None]
    r = (0.2 + 0.05 * np.arange(n_t))[None, None, :]
    x, y, z = np.broadcast_arrays(r * np.cos(u), r * np.sin(u), v + 0 * r)
    return np.stack([x, y, z], axis=-1)  # (u, v, t, xyz)


def test_a_grid_over_time_is_one_vertex_set_a_frame_in_napari_axis_order():
    grid = _cylinder()
    field = np.arange(8 * 5 * 3, dtype=float).reshape(8, 5, 3)
    vertices, faces, values = surface_over_time(grid, field)
    assert vertices.shape == (3 * 40, 4) and faces.shape == (3 * 2 * 8 * 4, 3)
    frame = vertices[:, 0].astype(int)
    assert np.array_equal(np.bincount(frame), [40, 40, 40])
    for t in range(3):  # (z, y, x) of frame t's nodes, u-major
        np.testing.assert_array_equal(
            vertices[frame == t, 1:], grid[:, :, t].reshape(-1, 3)[:, ::-1]
        )
        np.testing.assert_array_equal(values[frame == t], field[:, :, t].ravel())
    assert np.all(frame[faces] == frame[faces][:, :1])  # no face joins two frames


@pytest.fixture(scope="module")
def viewer_with_results(run_out):
    from napari.components import ViewerModel
    from napari.plugins import _initialize_plugins

    _initialize_plugins()  # headless: napari finds plugins itself
    viewer = ViewerModel(ndisplay=3)
    layers = viewer.open(run_out / "normal", plugin="oftimg")
    return viewer, layers


def test_a_results_folder_opens_as_three_walls_on_the_time_slider(viewer_with_results, run_out):
    import oftimg

    viewer, layers = viewer_with_results
    res = oftimg.load_results(run_out / "normal")
    walls = [layer for layer in layers if layer._type_string == "surface"]
    assert [layer.name for layer in walls] == [
        "normal: outer wall",
        "normal: inner wall",
        "normal: lumen",
    ]
    assert layers[:3] == walls
    n_t = res["t_ms"].size
    assert viewer.dims.nsteps[0] == n_t  # time first
    assert viewer.dims.axis_labels == ("frame", "z (mm)", "y (mm)", "x (mm)")  # as the dock's
    outer = res["outer"]
    for t in (0, n_t // 2):
        viewer.dims.set_current_step(0, t)
        shown = layers[0]._view_vertices  # (z, y, x) of frame t
        np.testing.assert_allclose(
            np.sort(shown, axis=0), np.sort(outer[:, :, t].reshape(-1, 3)[:, ::-1], axis=0)
        )
        assert len(layers[0]._view_faces) == 2 * outer.shape[0] * (outer.shape[1] - 1)


def test_each_wall_is_coloured_by_a_field_in_the_house_colour_maps(viewer_with_results, run_out):
    import oftimg

    _, layers = viewer_with_results
    res = oftimg.load_results(run_out / "normal")
    meta = layers[0].metadata["oftimg"]
    assert meta["field"] == "radial_curvature_outer_per_mm"  # signed: RdBu, about 0
    assert meta["label"] == "radial_curvature_outer_per_mm (1/mm)"
    assert layers[0].colormap.name == "RdBu_r"
    low, high = layers[0].contrast_limits
    assert low == pytest.approx(-high)
    assert "strain_energy_outer" in meta["fields"] and "wall_thickness_mm" in meta["fields"]
    # each node's error bar, a field of its own (issue 84)
    assert "radial_curvature_outer_band95_per_mm" in meta["fields"]
    from oftimg.napari.surfaces import readable

    assert readable("radial_curvature_outer_band95_per_mm") == "95 % band of radial curvature outer"
    data, kwargs, kind = wall_layer(res, "outer", "strain_energy_outer")  # one-signed
    assert kind == "surface" and kwargs["colormap"] == "viridis"
    assert kwargs["contrast_limits"][0] >= 0
    assert kwargs["metadata"]["oftimg"]["field"] == "strain_energy_outer"
    assert layers[2].metadata["oftimg"]["field"] == "mean_curvature_lumen_per_mm"


def test_the_reader_takes_results_and_leaves_other_folders(run_out, tmp_path):
    assert napari_get_reader(str(run_out / "normal")) is results_layers
    assert napari_get_reader(str(run_out)) is results_layers  # a run's --out
    assert napari_get_reader(str(tmp_path)) is None
    assert napari_get_reader(str(run_out / "normal" / "arrays.npz")) is None
    assert [kind for _, _, kind in results_layers(run_out)][:3] == ["surface"] * 3


def test_oftimg_runs_without_napari():
    """Importing oftimg and its command line never imports napari."""
    code = (
        "import sys, oftimg, oftimg.api, oftimg.cli, oftimg.output.results; "
        "assert 'napari' not in sys.modules, 'napari imported'"
    )
    subprocess.run([sys.executable, "-c", code], check=True)


def test_walls_over_time_show_the_slider_s_frame_and_change_field(run_out):
    """For scrubbing: each wall's layer holds the current frame only, swapped when the
    time slider moves; the slider spans the frames; a field can be chosen for all."""
    import oftimg
    from napari.components import ViewerModel

    from oftimg.napari.walls import WallsOverTime

    res = oftimg.load_results(run_out / "normal")
    viewer = ViewerModel(ndisplay=3)
    walls = WallsOverTime(viewer, run_out / "normal")
    n_t = res["t_ms"].size
    assert viewer.dims.nsteps[0] == n_t
    for t in (0, 7, n_t - 1):
        viewer.dims.set_current_step(0, t)
        assert walls.frame == t
        for w in ("outer", "lumen"):
            vertices, faces, values = walls.layers[w].data
            np.testing.assert_array_equal(vertices, res[w][:, :, t].reshape(-1, 3)[:, ::-1])
        field = res["radial_curvature_outer_per_mm"][:, :, t].reshape(-1)
        np.testing.assert_array_equal(walls.layers["outer"].data[2], field)
    assert walls.colour_by("strain_energy_outer") == ["outer"]
    assert walls.layers["outer"].colormap.name == "viridis"
    np.testing.assert_array_equal(
        walls.layers["outer"].data[2], res["strain_energy_outer"][:, :, n_t - 1].reshape(-1)
    )
    assert walls.layers["inner"].metadata["oftimg"]["field"] == "radial_curvature_inner_per_mm"
    walls.close()
    viewer.dims.set_current_step(0, 0)  # no longer followed
    np.testing.assert_array_equal(
        walls.layers["outer"].data[0], res["outer"][:, :, n_t - 1].reshape(-1, 3)[:, ::-1]
    )


def test_the_linked_views_move_with_the_slider_and_follow_a_picked_node(run_out):
    """The (u, v) view shows the current frame, the area map's cursor sits at its time,
    a picked node (in the image, or as a vertex of the 3-D wall) gets its time course
    and its row's area, and a new field recolours the views."""
    import oftimg
    from napari.components import ViewerModel

    from oftimg.napari.linked import LinkedViews
    from oftimg.napari.walls import WallsOverTime

    res = oftimg.load_results(run_out / "normal")
    viewer = ViewerModel(ndisplay=3)
    walls = WallsOverTime(viewer, run_out / "normal")
    views = LinkedViews(res, "radial_curvature_outer_per_mm")
    import matplotlib.pyplot as plt  # not one of pyplot's, kept open for ever

    assert all(plt.figure(n) is not views.figure for n in plt.get_fignums())
    redrawn = []
    views.follow(walls, redraw=lambda: redrawn.append(walls.frame))
    field, t_ms = res["radial_curvature_outer_per_mm"], res["t_ms"]
    viewer.dims.set_current_step(0, 9)
    assert redrawn[-1] == 9
    np.testing.assert_array_equal(views.image.get_array(), field[:, :, 9].T)
    assert views.cursor.get_xdata()[0] == t_ms[9]
    n_u, n_v = field.shape[:2]
    assert views.node_at(20 / n_u, 30 / (n_v - 1)) == (20, 30)
    views.pick(20, 30)
    assert views.marker.get_xydata().tolist() == [[20 / n_u, 30 / (n_v - 1)]]
    (curve,) = views.ax_node.get_lines()[:1]
    np.testing.assert_array_equal(curve.get_ydata(), field[20, 30])
    np.testing.assert_array_equal(views._twin.get_lines()[0].get_ydata(), res["area_outer_mm2"][30])
    assert views.now.get_xdata()[0] == t_ms[9]
    viewer.dims.set_current_step(0, 4)
    assert views.now.get_xdata()[0] == t_ms[4]
    assert views.pick_vertex(7 * n_v + 11) == (7, 11)  # a vertex of the 3-D wall
    views.set_field("strain_energy_outer")
    assert views.image.get_cmap().name == "viridis"
    np.testing.assert_array_equal(views.image.get_array(), res["strain_energy_outer"][:, :, 4].T)
    np.testing.assert_array_equal(
        views.ax_node.get_lines()[0].get_ydata(), res["strain_energy_outer"][7, 11]
    )
    from test_figure_style import layout_problems

    assert layout_problems(views.figure) == []  # the house's type, nothing overlaps
    views.unfollow()
    viewer.dims.set_current_step(0, 2)
    assert views.frame == 4


def test_a_mesh_dataset_opens_as_its_surfaces_over_time(phantom_normal):
    """A dataset folder (drag and drop): each surface as meshed, frame by frame, in mm."""
    from oftimg.io.meshfile import read_mesh_file
    from oftimg.napari.volumes import dataset_layers

    reader = napari_get_reader(str(phantom_normal))
    assert reader is not None
    layers = reader(str(phantom_normal))
    assert [kwargs["name"] for _, kwargs, _ in layers] == [
        "normal: outer (as meshed)",
        "normal: inner (as meshed)",
        "normal: lumen (as meshed)",
    ]
    (vertices, faces), _, kind = layers[2]
    assert kind == "surface"
    V, F = read_mesh_file(sorted((phantom_normal / "lumen").iterdir())[7])
    frame = vertices[:, 0].astype(int)
    np.testing.assert_allclose(vertices[frame == 7, 1:], V[:, ::-1])  # mm (z, y, x)
    assert np.all(frame[faces] == 7 * np.ones((1, 3), int), axis=1).sum() == len(F)
    assert dataset_layers is not None


def test_a_label_dataset_alone_opens_with_its_labels_shown(tmp_path):
    """A label dataset folder without intensity volumes (drag and drop): its one layer,
    the labels, shown (hidden, as under a result's walls, the canvas was black: issue
    83, point 6); with intensity volumes, those shown and the labels hidden."""
    from oftimg.synthetic.labels import write_label_phantom
    from oftimg.synthetic.phantom import sample_params

    for intensity in (False, True):
        path = tmp_path / f"labels_{intensity}"
        write_label_phantom(
            path, sample_params("normal", 0, n_frames=3), (12.0, 12.0, 12.0), intensity=intensity
        )
        layers = napari_get_reader(str(path))(str(path))
        shown = {kind: kwargs.get("visible", True) for _, kwargs, kind in layers}
        assert shown == ({"labels": False, "image": True} if intensity else {"labels": True})


def test_a_result_finds_its_dataset_and_its_volumes_come_in_the_cycle_s_order(
    run_out, phantom_normal, tmp_path
):
    """The volumes under a result's walls: input frame (t + t0_frame) mod n at result
    frame t; labels and intensity on the labels' voxels, in mm."""
    import oftimg
    from oftimg.napari.volumes import cycle_order, dataset_of, result_volumes, volume_layers
    from oftimg.synthetic.labels import write_label_phantom
    from oftimg.synthetic.phantom import sample_params

    res = oftimg.load_results(run_out / "normal")
    assert dataset_of(res) == phantom_normal
    assert result_volumes(res) == []  # meshes only: no volumes
    assert cycle_order(5, 3).tolist() == [3, 4, 0, 1, 2]
    path = tmp_path / "tex"
    write_label_phantom(
        path, sample_params("normal", 0, n_frames=4), (4.0, 4.0, 8.0), intensity=True
    )
    from oftimg.io.label_dataset import load_label_dataset, read_frame

    lds = load_label_dataset(path)
    order = cycle_order(4, 1)
    (labels, lkw, lkind), (image, ikw, ikind) = volume_layers(path, order)
    assert (lkind, ikind) == ("labels", "image")
    assert labels.shape == (4, *lds.shape) and image.shape == (4, *lds.shape)
    np.testing.assert_allclose(lkw["scale"], (1, 0.008, 0.004, 0.004))  # mm, (t, z, y, x)
    np.testing.assert_allclose(ikw["scale"], lkw["scale"])
    np.testing.assert_array_equal(np.asarray(labels[0]), read_frame(lds.sources[1]))
    np.testing.assert_array_equal(np.asarray(image[3]), lds.intensity.volume(0))
    assert lkw["visible"] is False and ikw["rendering"] == "mip"
    low, high = ikw["contrast_limits"]
    assert 0 <= low < high


def test_a_hidden_wall_gets_its_frame_when_it_is_shown(run_out):
    """Each wall's new frame costs vispy a shader rebuild: a hidden wall is not
    updated while hidden, and shows the slider's frame as soon as it is shown."""
    import oftimg
    from napari.components import ViewerModel

    from oftimg.napari.walls import AXIS_LABELS, WallsOverTime

    res = oftimg.load_results(run_out / "normal")
    viewer = ViewerModel(ndisplay=3)
    walls = WallsOverTime(viewer, run_out / "normal")
    assert tuple(viewer.dims.axis_labels) == AXIS_LABELS
    inner, before = walls.layers["inner"], walls.frame  # napari starts mid-slider
    inner.visible = False
    viewer.dims.set_current_step(0, 5)
    np.testing.assert_array_equal(inner.data[0], res["inner"][:, :, before].reshape(-1, 3)[:, ::-1])
    inner.visible = True
    np.testing.assert_array_equal(inner.data[0], res["inner"][:, :, 5].reshape(-1, 3)[:, ::-1])


def test_the_first_view_has_the_outlet_up_and_looks_at_the_bend():
    """A tube bent in the (z, x) plane, inlet at z = 0: up is from inlet to outlet,
    the view is perpendicular to the bend's plane, tilted 30 degrees from above."""
    from oftimg.napari.walls import TILT_DEG, oblique_view

    s = np.linspace(0, np.pi / 2, 50)  # a quarter circle
    u = np.linspace(0, 2 * np.pi, 80, endpoint=False)[:, None]
    centre = np.stack([np.sin(s), 0 * s, 1 - np.cos(s)], axis=-1)  # (z, y, x)
    grid = centre[None] + 0.1 * np.stack(
        [0 * u + 0 * s, np.cos(u) + 0 * s, np.sin(u) + 0 * s], axis=-1
    )
    view, up = oblique_view(grid)
    chord = centre[-1] - centre[0]
    np.testing.assert_allclose(up, chord / np.linalg.norm(chord), atol=0.02)
    assert np.degrees(np.arcsin(-view @ up)) == pytest.approx(TILT_DEG, abs=0.5)
    side = view + np.sin(np.radians(TILT_DEG)) * up  # its part off the axis
    assert abs(side[1]) == pytest.approx(np.cos(np.radians(TILT_DEG)), abs=0.02)  # along y


def test_every_field_and_map_is_an_image_on_the_walls_time_slider(viewer_with_results, run_out):
    """Each wall's (u, v, t) fields as Image layers (t, 1, v, u): unrolled beside the
    tube (v up, the outlet at the top), frame t of the slider showing the field's
    frame t, named in words with units; the (v, t) area maps beside them with a
    cursor column at the slider's frame; hidden until asked for, in the house's
    colours, napari's own tools on them."""
    import oftimg

    viewer, layers = viewer_with_results
    res = oftimg.load_results(run_out / "normal")
    images = {layer.name: layer for layer in layers if layer._type_string == "image"}
    field = images["normal: outer wall radial curvature (1/mm), unrolled"]
    assert "normal: lumen mean curvature (1/mm), unrolled" in images
    assert "normal: inner wall jelly thickness (mm), unrolled" in images
    assert not any(layer.visible for layer in images.values())
    n_u, n_v, n_t = res["radial_curvature_outer_per_mm"].shape
    assert field.data.shape == (n_t, 1, n_v, n_u)
    np.testing.assert_array_equal(
        field.data[5, 0, ::-1].T, res["radial_curvature_outer_per_mm"][:, :, 5].astype(np.float32)
    )  # v up: the outlet row first
    assert field.colormap.name == "RdBu_r"
    walls_x = max(layer.extent.world[1][3] for layer in layers[:3])
    assert field.extent.world[0][3] > walls_x  # beside the tube, not in it
    field.visible = True
    viewer.dims.set_current_step(0, 5)
    shown = np.asarray(field._slice.image.view)  # what napari draws now
    np.testing.assert_array_equal(np.squeeze(shown), field.data[5, 0])
    area = images["normal: outer wall area (mm²), (v, t) map"]
    np.testing.assert_array_equal(area.data[0], res["area_outer_mm2"][::-1].astype(np.float32))
    assert area.extent.world[0][2] > field.extent.world[1][3]  # beside the fields (z, y, x)
    cursor = images["normal: time on the (v, t) maps"]
    assert cursor.data[5, 0, 0].tolist() == [int(k == 5) for k in range(n_t)]
    np.testing.assert_allclose(cursor.scale[3], area.scale[2])  # columns on the map's
    np.testing.assert_allclose(cursor.translate[3], area.translate[2])
    field.visible = False


def test_the_napari_check_says_in_one_line_what_is_missing(monkeypatch, capsys):
    """``python -m oftimg.napari --check``: ready under Xvfb (the suite's screen);
    a library Qt's xcb plugin lacks named with its Debian package; no screen said
    with the way round it."""
    from oftimg.napari import check
    from oftimg.napari.__main__ import main

    ldd = (
        "\tlinux-vdso.so.1 (0x00007ffd)\n"
        "\tlibxcb-icccm.so.4 => not found\n"
        "\tlibxcb-keysyms.so.1 => not found\n"
        "\tlibxcb.so.1 => /lib/x86_64-linux-gnu/libxcb.so.1 (0x00007f)\n"
        "\tlibxcb-icccm.so.4 => not found\n"
    )
    assert check.not_found(ldd) == ["libxcb-icccm.so.4", "libxcb-keysyms.so.1"]
    assert [
        check.package_of(s)
        for s in (
            "libxcb-icccm.so.4",
            "libxcb-keysyms.so.1",
            "libxkbcommon-x11.so.0",
            "libdbus-1.so.3",
            "libEGL.so.1",
            "libxcb-render-util.so.0",
        )
    ] == [
        "libxcb-icccm4",
        "libxcb-keysyms1",
        "libxkbcommon-x11-0",
        "libdbus-1-3",
        "libegl1",
        "libxcb-render-util0",
    ]
    monkeypatch.setattr(
        check,
        "missing_libraries",
        lambda: (["libxcb-icccm.so.4", "libxcb-keysyms.so.1"], "PySide6 6.12"),
    )
    assert main(["--check"]) == 1
    out = capsys.readouterr().out.strip().splitlines()
    assert len(out) == 1 and out[0].endswith(
        "lacks the system libraries libxcb-icccm.so.4, libxcb-keysyms.so.1: sudo apt-get "
        "install libxcb-icccm4 libxcb-keysyms1 (Debian / Ubuntu; or `make napari`)"
    ), out
    assert main(["--packages"]) == 0
    assert capsys.readouterr().out.strip() == "libxcb-icccm4 libxcb-keysyms1"
    monkeypatch.undo()
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    assert main(["--check"]) == 1
    assert (
        "no screen here (no DISPLAY): run napari under `xvfb-run -a napari`"
        in capsys.readouterr().out
    )


def test_one_qt_binding_is_installed():
    """The napari extra and the test extra bring one binding (PySide6): two bindings
    in one environment leave qtpy to choose between them."""
    from oftimg.napari.check import installed_bindings

    assert installed_bindings() == ["PySide6"]
