"""The napari dock widget (issue 63): opening a result, the field list, the views
linked to the slider, clicks on the (u, v) image and on a wall. Qt offscreen with a
headless napari ViewerModel (the window itself: tests/test_napari_window.py)."""

import numpy as np
import pytest

pytest.importorskip("napari")
pytest.importorskip("qtpy.QtWidgets")
pytest.importorskip("pytestqt")


@pytest.fixture
def widget(qtbot, run_out):
    from napari.components import ViewerModel

    from oftimg.napari.widget import OftimgWidget

    viewer = ViewerModel(ndisplay=3)
    widget = OftimgWidget(viewer)
    qtbot.addWidget(widget)
    widget.open(run_out / "normal")
    return widget


def test_the_widget_opens_a_result_with_its_fields_and_follows_the_slider(widget, run_out):
    import oftimg

    res = oftimg.load_results(run_out / "normal")
    items = [
        (widget.fields.itemText(k), widget.fields.itemData(k)) for k in range(widget.fields.count())
    ]
    headings = [text for text, data in items if data is None]
    assert headings == ["outer wall", "inner wall", "lumen"]  # every wall, by its name
    choices = {data: text.strip() for text, data in items if data is not None}
    assert choices[("outer", "radial_curvature_outer_per_mm")] == "radial curvature (1/mm)"
    assert choices[("outer", "strain_energy_outer")] == "strain energy (dimensionless)"
    assert choices[("inner", "jelly_thickness_mm")] == "jelly thickness (mm)"
    assert choices[("lumen", "mean_curvature_lumen_per_mm")] == "mean curvature (1/mm)"
    assert ("inner", "wall_thickness_mm") in choices and ("outer", "wall_thickness_mm") in choices
    assert widget.fields.currentData() == ("outer", "radial_curvature_outer_per_mm")
    assert {layer.name for layer in widget.viewer.layers} >= {"normal: outer wall", "normal: lumen"}
    widget.viewer.dims.set_current_step(0, 6)
    assert widget.views.cursor.get_xdata()[0] == res["t_ms"][6]
    widget.fields.setCurrentIndex(widget.fields.findText("   strain energy (dimensionless)"))
    assert widget.walls.layers["outer"].colormap.name == "viridis"  # as a user chose it
    np.testing.assert_array_equal(
        widget.views.image.get_array(), res["strain_energy_outer"][:, :, 6].T
    )
    assert "normal" in widget.status.text()
    widget.select("mean_curvature_lumen_per_mm")  # the lumen's own field
    lumen = widget.walls.layers["lumen"]
    assert lumen.metadata["oftimg"]["field"] == "mean_curvature_lumen_per_mm"
    np.testing.assert_array_equal(
        lumen.data[2], res["mean_curvature_lumen_per_mm"][:, :, 6].reshape(-1)
    )
    np.testing.assert_array_equal(widget.views.map_image.get_array(), res["area_lumen_mm2"])
    assert widget.walls.layers["outer"].metadata["oftimg"]["field"] == "strain_energy_outer"
    widget.select("wall_thickness_mm", "inner")  # one wall, not both
    assert widget.walls.layers["inner"].metadata["oftimg"]["field"] == "wall_thickness_mm"
    assert widget.walls.layers["outer"].metadata["oftimg"]["field"] == "strain_energy_outer"


def test_a_click_on_the_image_or_on_a_wall_picks_a_node(widget):
    from matplotlib.backend_bases import MouseEvent

    views = widget.views
    n_u, n_v = views.field.shape[:2]
    x, y = views.ax_field.transData.transform((10 / n_u, 25 / (n_v - 1)))
    widget.canvas.draw()
    MouseEvent("button_press_event", widget.canvas, x, y, button=1)._process()
    assert views.node == (10, 25)
    layer = widget.walls.layers["outer"]  # a wall in the 3-D view
    vertices = layer.data[0]
    k = 17 * n_v + 30
    outward = vertices[k] - vertices.mean(axis=0)
    outward /= np.linalg.norm(outward)
    position = np.r_[widget.walls.frame, vertices[k] + 0.3 * outward]

    class Click:
        view_direction, dims_displayed = np.r_[0, -outward], [1, 2, 3]

    Click.position = position
    widget._clicked_wall(layer, Click)
    i_u, i_v = views.node
    assert abs(i_u - 17) <= 1 and abs(i_v - 30) <= 1  # the vertex clicked, or one beside it


def test_opening_another_result_replaces_the_first(widget, run_out):
    layers_before = len(widget.viewer.layers)
    widget.open(run_out / "normal")
    assert len(widget.viewer.layers) == layers_before


def test_the_field_and_its_area_map_as_image_layers_follow_the_choice(widget, run_out):
    """The dock's check box puts the chosen field (unrolled, on the time slider), its
    wall's (v, t) area map and the time cursor in the viewer as Image layers; another
    field replaces them; unchecked, they go."""
    import oftimg

    res = oftimg.load_results(run_out / "normal")
    before = len(widget.viewer.layers)
    widget.images_box.setChecked(True)
    names = [layer.name for layer in widget.images]
    assert names == [
        "normal: outer wall radial curvature (1/mm), unrolled",
        "normal: outer wall area (mm²), (v, t) map",
        "normal: time on the (v, t) maps",
    ]
    assert len(widget.viewer.layers) == before + 3
    # in view, not half off-screen beside the tube (issue 83, point 6): the camera
    # centred on every visible layer, the images beside the tube among them
    shown = [layer.extent.world[:, -3:] for layer in widget.viewer.layers if layer.visible]
    low, high = np.min([e[0] for e in shown], axis=0), np.max([e[1] for e in shown], axis=0)
    scene = getattr(widget.viewer, "scene", None)  # napari 0.9: scene.camera
    camera = scene.camera if scene is not None else widget.viewer.camera
    off = np.abs(np.asarray(camera.center) - (low + high) / 2)
    assert np.all(off <= 0.1 * (high - low) + 1e-6), (off, low, high)
    widget.select("mean_curvature_lumen_per_mm")
    field, area, _ = widget.images
    assert field.name == "normal: lumen mean curvature (1/mm), unrolled"
    np.testing.assert_array_equal(
        field.data[:, 0, ::-1].transpose(2, 1, 0),
        res["mean_curvature_lumen_per_mm"].astype(np.float32),
    )
    np.testing.assert_array_equal(area.data[0, ::-1], res["area_lumen_mm2"].astype(np.float32))
    widget.images_box.setChecked(False)
    assert len(widget.viewer.layers) == before and widget.images == []


def test_volumes_show_the_slider_s_frame_coarse_while_it_moves_and_full_at_rest(qtbot, tmp_path):
    """VolumesOverTime: each volume layer holds the slider's frame (input frame
    order[t]); in a Qt application a step shows every 4th voxel at 4 times the scale
    (the same mm), and the full frame once the slider has rested; the frames ahead
    are read in a thread."""
    from napari.components import ViewerModel

    from oftimg.io.label_dataset import load_label_dataset, read_frame
    from oftimg.io.labelfile import read_volume
    from oftimg.napari.volumes import (
        PROXY_STEP,
        REST_MS,
        VolumesOverTime,
        cycle_order,
        volume_series,
    )
    from oftimg.synthetic.labels import write_label_phantom
    from oftimg.synthetic.phantom import sample_params

    path = tmp_path / "tex"
    write_label_phantom(
        path, sample_params("normal", 0, n_frames=5), (8.0, 8.0, 16.0), intensity=True
    )
    lds = load_label_dataset(path)
    order = cycle_order(5, 2)
    viewer = ViewerModel(ndisplay=3)
    viewer.add_points(np.array([[0, 0, 0, 0], [4, 0, 0, 0]]), size=0)  # the time axis
    volumes = VolumesOverTime(viewer, volume_series(path, order))
    labels, intensity = volumes.layers
    labels.visible = True
    np.testing.assert_array_equal(labels.data, read_frame(lds.sources[2]))
    assert intensity.data.dtype == np.uint8  # as stored, not float
    full_scale = np.asarray(labels.scale)
    volumes.show(3)  # the slider moved
    np.testing.assert_array_equal(
        labels.data, read_frame(lds.sources[0])[::PROXY_STEP, ::PROXY_STEP, ::PROXY_STEP]
    )
    np.testing.assert_allclose(labels.scale, full_scale * PROXY_STEP)
    qtbot.wait(REST_MS + 200)  # it rests
    np.testing.assert_array_equal(labels.data, read_frame(lds.sources[0]))
    np.testing.assert_allclose(labels.scale, full_scale)
    np.testing.assert_array_equal(intensity.data, read_volume(lds.intensity.sources[0]))
    volumes.reader.shutdown(wait=True)
    assert volumes.series[0].read.cache_info().currsize >= 3  # frames 3, 4, 0 read
    volumes.close()


def test_the_wave_s_phase_and_activation_colour_the_walls(widget, run_out):
    """The phase of each node's motion colours a wall in a cyclic map from -pi to pi
    (its ends one colour, as the cycle's), the activation time (a (u, v) map) the same
    at every frame; both as images beside the tube too."""
    import oftimg
    from oftimg.napari.reader import results_layers

    res = oftimg.load_results(run_out / "normal")
    widget.select("phase_outer", "outer")
    outer = widget.walls.layers["outer"]
    assert outer.colormap.name == "twilight"
    assert tuple(outer.contrast_limits) == pytest.approx((-np.pi, np.pi))
    widget.viewer.dims.set_current_step(0, 4)
    np.testing.assert_array_equal(outer.data[2], res["phase_outer"][:, :, 4].reshape(-1))
    widget.select("activation_time_outer_ms", "outer")
    for t in (1, 7):
        widget.viewer.dims.set_current_step(0, t)
        np.testing.assert_array_equal(outer.data[2], res["activation_time_outer_ms"].reshape(-1))
    names = [layer[1]["name"] for layer in results_layers(run_out / "normal")]
    assert "normal: outer wall activation time (ms), unrolled" in names
