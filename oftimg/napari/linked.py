"""The views beside a napari viewer's walls, linked to its time slider: the chosen
field at the current frame as a (u, v) image (seam at u = 0 and 1, inlet at the
bottom), the (v, t) area map with a cursor at the current time, and the time course of
a picked grid node (the field there and its row's section area) with the current time
marked. Drawn with matplotlib in the house style, so that the same views are a Qt dock
widget in napari's window or a figure anywhere else. What moves with time (the frame's
image, its time, the cursors, the marker) is drawn over a stored background
(matplotlib's blitting): a slider step redraws in a few milliseconds, not the ~130 ms of
the whole figure.
"""

from __future__ import annotations

import numpy as np

from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from ..output.style import COLUMN_MM, MM, bar_label, colour_bar, colour_scale, house_style
from .surfaces import field_values, readable, words_with_unit


def small_ticks(*axes) -> None:
    """The house's 7 pt tick labels, kept when the figure is drawn later (by a Qt canvas,
    outside the house style: ticks are made when drawn)."""
    for ax in axes:
        ax.tick_params(labelsize=7, width=0.6)


class LinkedViews:
    """The linked views of one result (a :class:`~oftimg.output.results.Results`):
    :meth:`set_frame` moves their time, :meth:`set_field` changes the field,
    :meth:`pick` marks a grid node ``(i_u, i_v)`` and plots its time course;
    ``figure`` is the matplotlib figure holding them."""

    @house_style
    def __init__(self, results, field: str, wall: str = "outer"):
        self.results, self.wall = results, wall
        self.t_ms, self.s_mm = results["t_ms"], results["s_mm"]
        self.area = self._area(wall)  # (v, t)
        # a Figure of its own, not pyplot's (which keeps every figure it made open):
        # a column beside napari's canvas
        self.figure = Figure(figsize=(COLUMN_MM * MM, 190 * MM), layout="constrained")
        FigureCanvasAgg(self.figure)  # drawn off screen until a Qt canvas takes it
        axes = self.figure.subplots(nrows=3)
        self.ax_field, self.ax_map, self.ax_node = axes
        self.frame, self.node, self.now, self._background = 0, None, None, None
        self._map()
        self.set_field(field)
        self.ax_node.set_axis_off()  # until a node is picked: how to pick one
        self.ax_node.text(
            0.5,
            0.5,
            "click the (u, v) image or a wall\nto follow a node over the cycle",
            ha="center",
            va="center",
            fontsize=7,
            color="0.3",
            transform=self.ax_node.transAxes,
        )
        # the callbacks live on the figure: they hold for any canvas that later shows it
        self.figure.canvas.mpl_connect("draw_event", self._drawn)

    def moving(self) -> list:
        """The artists that change with the frame (animated: a full draw leaves them
        out, :meth:`redraw_frame` draws them over the background)."""
        return [
            a
            for a in (self.image, self.time_title, self.cursor, self.marker, self.now)
            if a is not None
        ]

    def _drawn(self, event) -> None:
        """After a full draw: keep it as the background, and draw what moves on it."""
        self._background = self.figure.canvas.copy_from_bbox(self.figure.bbox)
        for artist in self.moving():
            self.figure.draw_artist(artist)

    def redraw_frame(self) -> None:
        """Show the current frame on the figure's canvas: the moving artists over the
        background of the last full draw (a full draw if there is none yet)."""
        canvas = self.figure.canvas
        if self._background is None:
            canvas.draw_idle()
            return
        canvas.restore_region(self._background)
        for artist in self.moving():
            self.figure.draw_artist(artist)
        if hasattr(canvas, "update"):  # a Qt canvas: painted with the window's next paint
            canvas.update()  # (its blit repaints the whole window at once)
        else:
            canvas.blit(self.figure.bbox)

    def _area(self, wall: str) -> np.ndarray:
        """``wall``'s (v, t) section areas (the outer wall's where it has none)."""
        name = f"area_{wall}_mm2"
        return self.results[name] if name in self.results else self.results["area_outer_mm2"]

    def _map(self) -> None:
        ax = self.ax_map
        step = self.t_ms[1] - self.t_ms[0] if len(self.t_ms) > 1 else 1.0
        self.map_image = ax.imshow(
            self.area,
            origin="lower",
            aspect="auto",
            extent=[self.t_ms[0] - step / 2, self.t_ms[-1] + step / 2, self.s_mm[0], self.s_mm[-1]],
            **colour_scale(self.area),
        )
        self.map_bar = colour_bar(self.figure, self.map_image, ax, self._map_label())
        self.cursor = ax.axvline(self.t_ms[0], color="w", lw=1.2, animated=True)
        small_ticks(ax, self.figure.axes[-1])  # and its colour bar
        ax.set_xlabel("time since minimum volume (ms)")
        ax.set_ylabel("s, from the inlet (mm)")

    def _map_label(self) -> str:
        return f"{'lumen' if self.wall == 'lumen' else self.wall + ' wall'} section area (mm$^2$)"

    @house_style
    def set_wall(self, wall: str) -> None:
        """Show ``wall``'s section areas in the area map and beside a node's course."""
        if wall == self.wall:
            return
        self.wall, self.area = wall, self._area(wall)
        scale = colour_scale(self.area)
        self.map_image.set_data(self.area)
        self.map_image.set_cmap(scale["cmap"])
        self.map_image.set_clim(scale.get("vmin", 0.0), scale.get("vmax", 1.0))
        self.map_bar.set_label(bar_label(self.figure, self.ax_map, self._map_label()))

    @house_style
    def set_field(self, field: str, wall: str | None = None) -> None:
        """Show ``field`` ``(n_u, n_v, n_t)`` in the (u, v) view and the node's course;
        ``wall``: the wall it is on (its areas in the map)."""
        if wall is not None:
            self.set_wall(wall)
        self.field_name, self.field = field, field_values(self.results, field)
        scale = colour_scale(self.field)
        ax = self.ax_field
        if getattr(self, "image", None) is None:
            n_u, n_v = self.field.shape[:2]  # pixel centres on the nodes
            self.image = ax.imshow(
                self.field[:, :, self.frame].T,
                origin="lower",
                aspect="auto",
                **scale,
                extent=[-0.5 / n_u, 1 - 0.5 / n_u, -0.5 / (n_v - 1), 1 + 0.5 / (n_v - 1)],
                animated=True,
            )
            self.bar = colour_bar(self.figure, self.image, ax, words_with_unit(self.results, field))
            ax.set_xlabel("u around the tube (0 and 1: the seam)")
            ax.set_ylabel("v (0: inlet, 1: outlet)")
            (self.marker,) = ax.plot([], [], "k+", ms=9, mew=1.5, animated=True)
            self.time_title = ax.set_title(" ")  # the field and the time: moves
            self.time_title.set_animated(True)
            small_ticks(ax, self.bar.ax)
        else:
            self.image.set_cmap(scale["cmap"])
            self.image.set_clim(scale.get("vmin", 0.0), scale.get("vmax", 1.0))
            self.bar.set_label(bar_label(self.figure, ax, words_with_unit(self.results, field)))
        self.set_frame(self.frame)
        if self.node is not None:
            self.pick(*self.node)

    @house_style
    def set_frame(self, t: int) -> None:
        """Move every view to frame ``t``."""
        self.frame = int(np.clip(t, 0, len(self.t_ms) - 1))
        self.image.set_data(self.field[:, :, self.frame].T)
        self.time_title.set_text(
            f"{readable(self.field_name)} at t = {self.t_ms[self.frame]:.0f} ms"
        )
        self.cursor.set_xdata([self.t_ms[self.frame]] * 2)
        if self.node is not None:
            self.now.set_xdata([self.t_ms[self.frame]] * 2)

    def frame_at(self, t_ms: float) -> int:
        """The frame nearest time ``t_ms`` (ms) of the area map."""
        return int(np.argmin(np.abs(self.t_ms - t_ms)))

    def node_at(self, u: float, v: float) -> tuple[int, int]:
        """The grid node ``(i_u, i_v)`` nearest the (u, v) image's point ``(u, v)``."""
        n_u, n_v = self.field.shape[:2]
        return int(round(u * n_u)) % n_u, int(np.clip(round(v * (n_v - 1)), 0, n_v - 1))

    @house_style
    def pick(self, i_u: int, i_v: int) -> None:
        """Mark grid node ``(i_u, i_v)`` and plot its field and its row's section area
        over the cycle, the current time marked."""
        n_u, n_v = self.field.shape[:2]
        self.node = (int(i_u) % n_u, int(np.clip(i_v, 0, n_v - 1)))
        i_u, i_v = self.node
        self.marker.set_data([i_u / n_u], [i_v / (n_v - 1)])
        ax = self.ax_node
        ax.clear()
        ax.set_axis_on()
        ax.plot(self.t_ms, self.field[i_u, i_v], color="k", lw=1.2)
        ax.set_ylabel(words_with_unit(self.results, self.field_name))
        ax.set_xlabel("time since minimum volume (ms)")
        twin = getattr(self, "_twin", None) or ax.twinx()
        self._twin = twin
        twin.clear()  # which puts its axis back on the left
        twin.yaxis.tick_right()
        twin.yaxis.set_label_position("right")
        twin.tick_params(axis="x", bottom=False, labelbottom=False)  # ax's time axis shows
        twin.patch.set_visible(False)
        twin.plot(self.t_ms, self.area[i_v], color="#0072B2", lw=1.0, ls="--")
        twin.set_ylabel(f"its row's {self.wall} area (mm$^2$)", color="#0072B2")
        ax.set_title(f"node u = {i_u / n_u:.2f}, v = {i_v / (n_v - 1):.2f}")
        self.now = ax.axvline(self.t_ms[self.frame], color="0.5", lw=0.8, animated=True)
        small_ticks(ax, twin)

    def pick_vertex(self, index: int) -> tuple[int, int]:
        """:meth:`pick` the grid node that is vertex ``index`` of a wall's one-frame
        Surface (:class:`~oftimg.napari.walls.WallsOverTime`: u-major); returns it."""
        n_v = self.field.shape[1]
        self.pick(*divmod(int(index), n_v))
        return self.node

    def follow(self, walls, redraw=None) -> None:
        """Move with ``walls``' time slider (a :class:`~oftimg.napari.walls.WallsOverTime`),
        calling ``redraw()`` after each move (default :meth:`redraw_frame`)."""
        redraw = redraw or self.redraw_frame

        def moved(event=None):
            self.set_frame(walls.frame)
            redraw()

        walls.viewer.dims.events.current_step.connect(moved)
        self._moved = (walls, moved)
        moved()

    def unfollow(self) -> None:
        """Stop following the slider :meth:`follow` tied these views to."""
        walls, moved = getattr(self, "_moved", (None, None))
        if walls is not None:
            walls.viewer.dims.events.current_step.disconnect(moved)
            self._moved = (None, None)
