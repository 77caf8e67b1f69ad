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
    names = [widget.fields.itemText(k) for k in range(widget.fields.count())]
    assert "strain_energy_outer" in names and "wall_thickness_mm" in names
    assert widget.fields.currentText() == "radial_curvature_outer_per_mm"
    assert {layer.name for layer in widget.viewer.layers} >= {"normal: outer wall",
                                                            "normal: lumen"}
    widget.viewer.dims.set_current_step(0, 6)
    assert widget.views.cursor.get_xdata()[0] == res["t_ms"][6]
    widget.fields.setCurrentText("strain_energy_outer")          # as a user chooses it
    assert widget.walls.layers["outer"].colormap.name == "viridis"
    np.testing.assert_array_equal(widget.views.image.get_array(),
                                  res["strain_energy_outer"][:, :, 6].T)
    assert "normal" in widget.status.text()


def test_a_click_on_the_image_or_on_a_wall_picks_a_node(widget):
    from matplotlib.backend_bases import MouseEvent

    views = widget.views
    n_u, n_v = views.field.shape[:2]
    x, y = views.ax_field.transData.transform((10 / n_u, 25 / (n_v - 1)))
    widget.canvas.draw()
    MouseEvent("button_press_event", widget.canvas, x, y, button=1)._process()
    assert views.node == (10, 25)
    layer = widget.walls.layers["outer"]                          # a wall in the 3-D view
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
    assert abs(i_u - 17) <= 1 and abs(i_v - 30) <= 1             # the vertex clicked, or one beside it


def test_opening_another_result_replaces_the_first(widget, run_out):
    layers_before = len(widget.viewer.layers)
    widget.open(run_out / "normal")
    assert len(widget.viewer.layers) == layers_before
