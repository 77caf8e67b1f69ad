"""napari's own window with oftimg's dock widget (issue 63, point 6), on a screen:
``make test`` runs the suite under Xvfb (Mesa draws the 3-D canvas on the CPU). The
screenshots are checked for what they show: the walls drawn in the field's colours,
the area map's cursor at the slider's time, clicks that move the slider and pick a
node; they are the docs' pictures (``OFTIMG_SCREENSHOTS=docs/_static/napari``)."""

import os
import shutil

import numpy as np
import pytest

pytestmark = pytest.mark.long  # make test-long (accuracy, rendering, whole runs)

pytest.importorskip("napari")
pytest.importorskip("qtpy.QtWidgets")
if not os.environ.get("DISPLAY") or os.environ.get("QT_QPA_PLATFORM") == "offscreen":
    pytest.skip(
        "napari's window needs a screen (make test runs the suite under Xvfb)",
        allow_module_level=True,
    )

GIF_FRAMES = 12
GIF_SCALE = 0.6


def settle(n: int = 5) -> None:
    from qtpy.QtWidgets import QApplication

    for _ in range(n):
        QApplication.processEvents()


def grab(widget) -> np.ndarray:
    """A Qt widget as it is on the screen: ``(height, width, 3)`` uint8."""
    image = widget.grab().toImage()
    image = image.convertToFormat(image.Format.Format_RGB888)
    width, height, row = image.width(), image.height(), image.bytesPerLine()
    return (
        np.frombuffer(image.constBits(), np.uint8)
        .reshape(height, row)[:, : 3 * width]
        .reshape(height, width, 3)
        .copy()
    )


def write_gif(path, frames: list[np.ndarray], frame_ms: int) -> None:
    """An animated GIF of RGB frames with one 256-colour palette made from all of
    them (median cut): the colour maps keep their ramps in every frame."""
    from PIL import Image

    palette = Image.fromarray(np.concatenate(frames, axis=0)).quantize(
        256, method=Image.Quantize.MEDIANCUT
    )
    images = [
        Image.fromarray(f).quantize(palette=palette, dither=Image.Dither.NONE) for f in frames
    ]
    images[0].save(path, save_all=True, append_images=images[1:], duration=frame_ms, loop=0)


@pytest.fixture(scope="module")
def window(run_out):
    import napari

    from oftimg.napari.widget import OftimgWidget

    viewer = napari.Viewer(ndisplay=3, title="oftimg in napari")
    viewer.window._qt_window.resize(1500, 950)
    widget = OftimgWidget(viewer)
    viewer.window.add_dock_widget(widget, area="right", name="oftimg")
    widget.run_panel.setVisible(False)  # the views in the picture: the panel has its own
    widget.open(run_out / "normal")
    settle()
    yield viewer, widget
    widget.close_results()
    viewer.close()


def shown(viewer) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The 3-D canvas on the screen: where something is drawn (not the black
    background), where it is red (RdBu's high end), where green (viridis's middle)."""
    canvas = viewer.screenshot(canvas_only=True, flash=False)[..., :3].astype(int)
    r, g, b = canvas[..., 0], canvas[..., 1], canvas[..., 2]
    drawn = canvas.sum(axis=-1) > 30
    return drawn, (r > b + 60) & (r > g + 40) & drawn, (g > r + 30) & drawn


def test_the_window_draws_the_walls_in_the_chosen_field_s_colours(window):
    viewer, widget = window
    drawn, red, green = shown(viewer)
    assert drawn.mean() > 0.05
    assert red.mean() > 0.01 and green.mean() < 0.001  # curvature in RdBu
    widget.select("strain_energy_outer", "outer")
    settle()
    drawn, red, green = shown(viewer)
    assert green.mean() > 0.01 and red.mean() < 0.001  # strain energy in viridis
    widget.select("radial_curvature_outer_per_mm", "outer")
    for layer in widget.walls.layers.values():
        layer.visible = False
    settle()
    assert shown(viewer)[0].mean() < 0.01  # what was drawn was the walls
    for layer in widget.walls.layers.values():
        layer.visible = True
    settle()


def cursor_column(widget, t_ms: float) -> tuple[int, slice]:
    """The area map's pixel column at time ``t_ms`` and its rows, in the Qt canvas."""
    ax = widget.views.ax_map
    x, _ = ax.transData.transform((t_ms, 0))
    box = ax.get_window_extent()
    height = widget.canvas.height()
    ratio = widget.canvas.devicePixelRatioF()
    return int(round(x / ratio)), slice(
        int(height - box.y1 / ratio) + 3, int(height - box.y0 / ratio) - 3
    )


def whiteness(image: np.ndarray, column: int, rows: slice) -> float:
    """The share of the column's rows (a pixel either side) with a white pixel (an
    anti-aliased line of 1.7 px: 220 or so in every channel)."""
    strip = image[rows, column - 1 : column + 2].astype(int)
    return float((strip.min(axis=-1) > 190).any(axis=1).mean())


def test_the_cursor_is_drawn_at_the_slider_s_time_and_a_click_on_the_map_moves_it(window):
    from qtpy.QtCore import QPoint, Qt
    from qtpy.QtTest import QTest

    viewer, widget = window
    t_ms = widget.views.t_ms
    viewer.dims.set_current_step(0, 20)
    settle()
    image = grab(widget.canvas)
    at, rows = cursor_column(widget, t_ms[20])
    elsewhere, _ = cursor_column(widget, t_ms[5])
    assert whiteness(image, at, rows) > 0.9  # the white cursor, top to bottom
    assert whiteness(image, elsewhere, rows) < 0.2
    x, rows = cursor_column(widget, t_ms[8])  # a real click on the map
    QTest.mouseClick(widget.canvas, Qt.LeftButton, pos=QPoint(x, (rows.start + rows.stop) // 2))
    settle()
    assert viewer.dims.current_step[0] == 8
    assert whiteness(grab(widget.canvas), x, rows) > 0.9


def test_a_click_on_the_field_image_picks_a_node_and_plots_its_course(window):
    from qtpy.QtCore import QPoint, Qt
    from qtpy.QtTest import QTest

    viewer, widget = window
    views = widget.views
    n_u, n_v = views.field.shape[:2]
    x, y = views.ax_field.transData.transform((30 / n_u, 20 / (n_v - 1)))
    ratio = widget.canvas.devicePixelRatioF()
    QTest.mouseClick(
        widget.canvas,
        Qt.LeftButton,
        pos=QPoint(round(x / ratio), round(widget.canvas.height() - y / ratio)),
    )
    settle()
    assert views.node == (30, 20)
    np.testing.assert_array_equal(views.ax_node.get_lines()[0].get_ydata(), views.field[30, 20])
    node_box = views.ax_node.get_window_extent()
    image = grab(widget.canvas)
    top = int(widget.canvas.height() - node_box.y1 / ratio)
    bottom = int(widget.canvas.height() - node_box.y0 / ratio)
    panel = image[top:bottom, int(node_box.x0 / ratio) : int(node_box.x1 / ratio)].astype(int)
    assert ((panel.max(axis=-1) < 60).mean()) > 0.005  # its black curve is drawn


def test_screenshots_and_a_scrubbing_gif_for_the_docs(window, tmp_path):
    import cv2
    import imageio.v3 as iio

    viewer, widget = window
    widget.views.pick(30, 20)
    widget.canvas.draw()
    out = tmp_path / "napari"
    out.mkdir()
    n_t = len(widget.views.t_ms)
    frames = []
    for t in np.linspace(0, n_t - 1, GIF_FRAMES).round().astype(int):
        viewer.dims.set_current_step(0, int(t))
        settle()
        frames.append(viewer.screenshot(canvas_only=False, flash=False)[..., :3])
    iio.imwrite(out / "window.png", frames[2])
    viewer.dims.set_current_step(0, 0)
    settle()
    small = [
        cv2.resize(frame, None, fx=GIF_SCALE, fy=GIF_SCALE, interpolation=cv2.INTER_AREA)
        for frame in frames
    ]  # a page's width, text legible
    write_gif(out / "scrubbing.gif", small, frame_ms=250)
    read = iio.imread(out / "scrubbing.gif", index=None)[..., :3]
    assert read.shape[0] == GIF_FRAMES
    assert np.abs(read.astype(int) - np.stack(small)).mean() < 3  # colours kept
    widget.run_panel.setVisible(True)
    widget.run_panel.dataset.setText("/data/embryo_07")
    settle()
    panel = grab(widget.run_panel)
    widget.run_panel.setVisible(False)
    widget.run_panel.dataset.setText("")
    assert panel.shape[0] > 150 and panel.std() > 10  # the panel drawn, not blank
    iio.imwrite(out / "run_panel.png", panel)
    moved = [np.abs(a.astype(int) - b.astype(int)).mean() for a, b in zip(frames, frames[1:])]
    assert min(moved) > 0.05  # the wall and the cursor move
    target = os.environ.get("OFTIMG_SCREENSHOTS")
    if target:
        os.makedirs(target, exist_ok=True)
        for name in ("window.png", "scrubbing.gif", "run_panel.png"):
            shutil.copy(out / name, os.path.join(target, name))


def test_the_views_stay_readable_in_a_small_window(window):
    """At a laptop's window (1024 x 640) the dock scrolls rather than squash the linked
    views: they keep their least size, nothing in them overlaps or leaves the figure,
    and the screenshot shows the (u, v) image taller than a strip."""
    from test_figure_style import layout_problems

    from oftimg.napari.widget import VIEWS_MIN_PX

    viewer, widget = window
    qt_window = viewer.window._qt_window
    size = qt_window.size()
    qt_window.resize(1024, 640)
    settle(10)
    try:
        assert widget.canvas.width() >= VIEWS_MIN_PX[0] - 30  # the scroll bar's width
        assert widget.canvas.height() >= VIEWS_MIN_PX[1]
        assert widget.scroll.verticalScrollBar().maximum() > 0  # it scrolls instead
        widget.canvas.draw()
        assert layout_problems(widget.views.figure) == []
        image = grab(widget.canvas)
        box = widget.views.ax_field.get_window_extent()
        ratio = widget.canvas.devicePixelRatioF()
        assert box.height / ratio > 150 and box.width / ratio > 150
        coloured = np.abs(image.astype(int) - image.mean(axis=-1, keepdims=True)).max(-1) > 40
        assert coloured[: int(widget.canvas.height() / 2)].mean() > 0.1  # the field drawn
    finally:
        qt_window.resize(size)
        settle()


def test_a_field_as_an_image_layer_is_drawn_beside_the_tube(window):
    """The dock's check box: the chosen field unrolled beside the tube in napari's
    canvas (its reds right of the walls), gone when unchecked."""
    viewer, widget = window

    def red_bodies() -> tuple[int, np.ndarray]:
        """How many red bodies lie side by side in the canvas (columns apart), and the
        red mask."""
        canvas = viewer.screenshot(canvas_only=True, flash=False)[..., :3].astype(int)
        r, g, b = canvas[..., 0], canvas[..., 1], canvas[..., 2]
        red = (r > b + 60) & (r > g + 40)
        columns = np.nonzero(red.any(axis=0))[0]
        return 1 + int((np.diff(columns) > 10).sum()), red

    assert red_bodies()[0] == 1  # the tube alone
    widget.images_box.setChecked(True)
    viewer.reset_view()
    settle()
    try:
        bodies, red = red_bodies()
        assert bodies >= 2, "the field image is not drawn beside the tube"  # its stripes too
        assert red[:, red.shape[1] // 2 :].mean() > 0.02
    finally:
        widget.images_box.setChecked(False)
        viewer.reset_view()
        settle()
    assert red_bodies()[0] == 1


def test_a_label_result_opened_from_another_folder_shows_its_volumes(tmp_path, monkeypatch):
    """A result of labels + intensity, opened in the window from another working
    folder: the intensity's projection drawn under the walls (grey pixels where there
    were none), the labels when shown; the axes named as the dock names them."""
    import napari

    from oftimg.cli import main
    from oftimg.napari.widget import OftimgWidget
    from oftimg.synthetic.labels import write_label_phantom
    from oftimg.synthetic.phantom import sample_params

    project = tmp_path / "project"
    write_label_phantom(
        project / "tex", sample_params("normal", 0, n_frames=5), (16.0, 16.0, 32.0), intensity=True
    )
    monkeypatch.chdir(project)  # relative, as a lab runs
    assert main(["run", "tex", "--out", "res", "--quiet", "--jobs", "1", "--numbers-only"]) == 0
    monkeypatch.chdir(tmp_path)
    viewer = napari.Viewer(ndisplay=3)
    try:
        widget = OftimgWidget(viewer)
        viewer.window.add_dock_widget(widget, area="right")
        widget.open("project/res/tex")
        labels, intensity = widget.walls.volumes
        assert viewer.dims.axis_labels == ("frame", "z (mm)", "y (mm)", "x (mm)")
        for layer in widget.walls.layers.values():
            layer.visible = False
        settle()

        def grey() -> float:
            canvas = viewer.screenshot(canvas_only=True, flash=False)[..., :3].astype(int)
            spread = canvas.max(axis=-1) - canvas.min(axis=-1)
            return float(((canvas.mean(axis=-1) > 40) & (spread < 12)).mean())

        assert grey() > 0.02  # the intensity drawn
        intensity.visible = False
        settle()
        assert grey() < 0.002
        labels.visible = True
        settle()
        assert (
            viewer.screenshot(canvas_only=True, flash=False)[..., :3].sum(-1).astype(bool).mean()
            > 0.02
        )  # the labels drawn
    finally:
        viewer.close()
