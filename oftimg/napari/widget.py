"""The dock widget in napari's window: open a results folder (or run a dataset,
:class:`~oftimg.napari.run.RunPanel`), choose the field, and see the linked views
(:class:`~oftimg.napari.linked.LinkedViews`) move with the time slider; a click on the
(u, v) image, or on a wall in the 3-D view, picks the node whose time course is
plotted; a click on the area map moves the time slider there. Needs napari's Qt
(``pip install "oftimg[napari]"``).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from matplotlib.backends.backend_qtagg import FigureCanvasQTAgg
from qtpy.QtWidgets import (
    QCheckBox,
    QComboBox,
    QFileDialog,
    QLabel,
    QPushButton,
    QScrollArea,
    QVBoxLayout,
    QWidget,
)

from ..errors import InputError
from ..output.results import load_results, result_folders
from .linked import LinkedViews
from .maps import field_image, map_image, placement, time_cursor
from .surfaces import field_choices, wall_fields
from .run import RunPanel
from .walls import WallsOverTime


# the linked views' least size on the screen (px): below it their labels overlap and the
# (u, v) image becomes a strip, so a smaller dock scrolls instead
VIEWS_MIN_PX = (300, 700)


class OftimgWidget(QWidget):
    """oftimg's dock widget for ``napari_viewer``: :meth:`open` a results folder (or
    the Open button), a field list (named with units) that recolours the walls and
    the views, the linked views below."""

    def __init__(self, napari_viewer):
        super().__init__()
        self.viewer, self.walls, self.views, self.canvas = napari_viewer, None, None, None
        self.setLayout(QVBoxLayout())
        self.open_button = QPushButton("Open results folder…")
        self.open_button.clicked.connect(self._choose_folder)
        self.fields = QComboBox()  # every wall's fields, under its name
        self.fields.currentIndexChanged.connect(self._chosen)
        self.images_box = QCheckBox("the field and the area map as image layers")
        self.images_box.setToolTip(
            "beside the tube, on the time slider: napari's own tools "
            "(contrast, histogram, line profiles) work on them"
        )
        self.images_box.toggled.connect(self._show_images)
        self.images = []
        self.status = QLabel("no results open")
        self.status.setWordWrap(True)
        self.run_panel = RunPanel(done=self.open)
        for w in (self.open_button, self.run_panel, self.fields, self.images_box, self.status):
            self.layout().addWidget(w)

    def _choose_folder(self) -> None:
        folder = QFileDialog.getExistingDirectory(self, "An oftimg results folder (OUT/<name>)")
        if folder:
            try:
                self.open(folder)
            except InputError as exc:  # the command line's one line
                self.status.setText(f"error: {exc}")

    def open(self, folder) -> None:
        """Show the results in ``folder`` (one dataset's, ``OUT/<name>``, or a run's
        ``OUT``: its first dataset's): the walls over time in the viewer, the linked
        views here."""
        folder = result_folders(folder)[0]
        self.close_results()
        results = load_results(folder)
        self.walls = WallsOverTime(self.viewer, results)  # the arrays read once
        wall = self.walls.walls[0]
        first = self.walls.layers[wall].metadata["oftimg"]["field"] or wall_fields(results, wall)[0]
        self.views = LinkedViews(results, first, wall)
        self.canvas = FigureCanvasQTAgg(self.views.figure)
        self.canvas.mpl_connect("button_press_event", self._clicked_image)
        self.canvas.setMinimumSize(*VIEWS_MIN_PX)  # never squashed: the dock scrolls
        self.scroll = QScrollArea()
        self.scroll.setWidgetResizable(True)
        self.scroll.setWidget(self.canvas)
        self.layout().addWidget(self.scroll, stretch=1)
        self.views.follow(self.walls)
        for layer in self.walls.layers.values():
            layer.mouse_drag_callbacks.append(self._clicked_wall)
        self._list_fields(results)
        self.select(first, wall)
        folder = Path(folder)  # the full path: the tooltip
        self.status.setText(
            f"{results.name}: {len(results['t_ms'])} frames, from "
            f"{folder.parent.name}/{folder.name}"
        )
        self.status.setToolTip(str(folder.resolve()))

    def _list_fields(self, results) -> None:
        """The field list: each wall's name (not a choice), its fields below it in
        words with their units, each item's data ``(wall, array name)``."""
        self.fields.blockSignals(True)
        self.fields.clear()
        for wall, heading, entries in field_choices(results):
            self.fields.addItem(heading)
            item = self.fields.model().item(self.fields.count() - 1)
            item.setEnabled(False)
            font = item.font()
            font.setBold(True)
            item.setFont(font)
            for words, field in entries:
                self.fields.addItem(f"   {words}", (wall, field))
        self.fields.blockSignals(False)

    def select(self, field: str, wall: str | None = None) -> None:
        """Choose ``field`` on ``wall`` (default: the first wall that has it) in the
        field list, as a user would."""
        for k in range(self.fields.count()):
            data = self.fields.itemData(k)
            if data is not None and data[1] == field and wall in (None, data[0]):
                self.fields.setCurrentIndex(k)
                self._chosen(k)
                return
        raise KeyError(f"no field {field!r}" + (f" on the {wall}" if wall else ""))

    def _chosen(self, index: int) -> None:
        data = self.fields.itemData(index)
        if data is not None:
            self.set_field(data[1], data[0])

    def set_field(self, field: str, wall: str | None = None) -> None:
        """Colour ``wall`` (default: every wall that has ``field``) and the (u, v) view
        by ``field``; the area map shows that wall's areas."""
        if self.views is None or not field:
            return
        self.walls.colour_by(field, wall)
        self.views.set_field(field, wall)
        self.canvas.draw_idle()
        self.shown = (
            field,
            wall
            or next(w for w in self.walls.walls if field in wall_fields(self.walls.results, w)),
        )
        if self.images_box.isChecked():
            self._show_images(True)

    def _show_images(self, on: bool) -> None:
        """The chosen field unrolled, its wall's (v, t) area map and the time cursor
        as napari Image layers beside the tube (:mod:`oftimg.napari.maps`); none when
        ``on`` is False."""
        for layer in self.images:
            if layer in self.viewer.layers:
                self.viewer.layers.remove(layer)
        self.images = []
        if not on or self.walls is None:
            return
        results = self.walls.results
        field, wall = self.shown
        at = placement(results)
        area = f"area_{wall}_mm2" if f"area_{wall}_mm2" in results else "area_outer_mm2"
        for data, kwargs, _ in (
            field_image(results, field, wall, at, visible=True),
            map_image(results, area, at, visible=True),
            time_cursor(results, at, visible=True),
        ):
            self.images.append(self.viewer.add_image(data, **kwargs))
        self.viewer.reset_view()  # the tube and the images beside it, all in view

    def _clicked_image(self, event) -> None:
        """A click on the (u, v) image picks its node; on the area map, moves the time
        slider to the frame clicked."""
        if event.xdata is None:
            return
        if event.inaxes is self.views.ax_field:
            self.views.pick(*self.views.node_at(event.xdata, event.ydata))
            self.canvas.draw_idle()
        elif event.inaxes is self.views.ax_map:
            self.viewer.dims.set_current_step(0, self.views.frame_at(event.xdata))

    def _clicked_wall(self, layer, event) -> None:
        """A click on a wall in the 3-D view: of the triangle hit, the vertex nearest
        the line of sight."""
        vertex = vertex_hit(layer, event.position, event.view_direction, event.dims_displayed)
        if vertex is not None:
            self.views.pick_vertex(vertex)
            self.canvas.draw_idle()

    def close_results(self) -> None:
        """Take the open results' layers and views away."""
        if self.walls is None:
            return
        self.views.unfollow()
        self.walls.close()
        self._show_images(False)
        for layer in [*self.walls.layers.values(), self.walls.clock, *self.walls.volumes]:
            if layer in self.viewer.layers:
                self.viewer.layers.remove(layer)
        self.layout().removeWidget(self.scroll)
        self.scroll.deleteLater()
        self.walls = self.views = self.canvas = self.scroll = None


def vertex_hit(layer, position, view_direction, dims_displayed) -> int | None:
    """The vertex of a one-frame Surface ``layer`` that a click at ``position`` looking
    along ``view_direction`` (world coordinates, all dims) meets: of the first triangle
    on that line, its vertex nearest the line; None if the line misses the wall."""
    hit = layer.get_value(
        position, view_direction=view_direction, dims_displayed=dims_displayed, world=True
    )
    if hit is None or hit[1] is None:
        return None
    corners = layer.data[1][int(hit[1])]
    points = layer.data[0][corners]  # (3, 3) in the displayed dims
    origin = np.asarray(position, float)[list(dims_displayed)]
    direction = np.asarray(view_direction, float)[list(dims_displayed)]
    direction = direction / np.linalg.norm(direction)
    offsets = points - origin
    off_line = offsets - np.outer(offsets @ direction, direction)
    return int(corners[np.argmin(np.linalg.norm(off_line, axis=1))])
