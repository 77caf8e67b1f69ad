"""The walls of one results folder in a napari viewer one frame at a time, for
scrubbing: each wall's Surface holds only the current frame (its vertices and values
swapped when the time slider moves, a few milliseconds), and a hidden Points layer
spanning the frames gives napari its time axis. :func:`~oftimg.napari.reader.results_layers`
gives the same walls as layers with every frame in them (napari slices them itself:
simpler to pass around, slower to scrub).
"""

from __future__ import annotations

import numpy as np

from ..mesh.strain import grid_triangles
from ..output.results import Results, load_results
from .surfaces import (
    AXIS_LABELS,
    WALLS,
    field_colours,
    field_label,
    field_values,
    wall_fields,
    wall_style,
)
from .volumes import VolumesOverTime, result_volumes


TILT_DEG = 30.0  # the first view: from beside the tube's bend, this far from the outlet


def oblique_view(grid_zyx: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """A first camera for one frame's grid ``(n_u, n_v, 3)`` (z, y, x): the view
    direction and the up direction (napari's ``camera.set_view_direction``). Up runs
    from the inlet to the outlet, as v does in the (u, v) image; the view looks at the
    plane the centreline bends in, from :data:`TILT_DEG` towards the outlet, so the
    tube's curve and its outlet opening both show."""
    centres = grid_zyx.mean(axis=0)  # (n_v, 3) ring centres
    up = centres[-1] - centres[0]
    up /= np.linalg.norm(up)
    _, _, axes = np.linalg.svd(centres - centres.mean(axis=0))
    normal = np.cross(axes[0], axes[1])  # of the bend's plane
    normal -= (normal @ up) * up
    normal /= np.linalg.norm(normal)
    tilt = np.radians(TILT_DEG)
    return np.cos(tilt) * normal - np.sin(tilt) * up, up


class WallsOverTime:
    """One results folder's walls in ``viewer`` (a napari ``Viewer`` or
    ``ViewerModel``), coloured by ``field`` where a wall has it (default: each wall's
    own, :data:`~oftimg.napari.surfaces.DEFAULT_FIELDS`); time is the viewer's first
    axis, in frames of the aligned cycle (``t_ms``)."""

    def __init__(self, viewer, folder, field: str | None = None, volumes: bool = True):
        self.viewer = viewer  # folder: a results folder, or its Results already read
        self.results = folder if isinstance(folder, Results) else load_results(folder)
        self.t_ms = self.results["t_ms"]
        self.walls = [w for w in WALLS if w in self.results]
        self.grids = {w: self.results[w][..., ::-1] for w in self.walls}  # (u, v, t, zyx)
        n_u, n_v = self.grids[self.walls[0]].shape[:2]
        self.faces = grid_triangles(n_u, n_v)
        ends = np.zeros((2, 4))
        ends[1, 0] = len(self.t_ms) - 1
        self.clock = viewer.add_points(
            ends,
            name=f"{self.results.name}: frames",
            visible=False,
            size=0,
            axis_labels=AXIS_LABELS,
        )
        # the dataset's volumes under the walls, if it is still where it was read
        self.volume_frames = VolumesOverTime(
            viewer, result_volumes(self.results) if volumes else []
        )
        self.volumes = self.volume_frames.layers
        self.values, self.layers = {}, {}
        for w in self.walls:
            values, kwargs = wall_style(self.results, w, field)
            self.values[w] = values
            self.layers[w] = viewer.add_surface(self._frame_data(w, 0), **kwargs)
            self.layers[w].metadata["oftimg"]["frame"] = 0
            self.layers[w].events.visible.connect(self.show_current)
        if len(viewer.layers) == len(self.walls) + len(self.volumes) + 1:
            # only ours: fit the view to them
            viewer.dims.axis_labels = AXIS_LABELS
            viewer.reset_view()
            if viewer.dims.ndisplay == 3:
                view, up = oblique_view(self.grids[self.walls[0]][:, :, 0])
                # napari 0.9 moved the camera to viewer.scene
                camera = viewer.scene.camera if hasattr(viewer, "scene") else viewer.camera
                camera.set_view_direction(tuple(view), tuple(up))
        viewer.dims.events.current_step.connect(self.show_current)
        self.show_current()

    @property
    def frame(self) -> int:
        """The frame the viewer's time slider is at."""
        return int(np.clip(self.viewer.dims.current_step[0], 0, len(self.t_ms) - 1))

    def _frame_data(self, wall: str, t: int) -> tuple:
        vertices = self.grids[wall][:, :, t].reshape(-1, 3)
        values = self.values[wall]
        if values is None:
            return vertices, self.faces
        return vertices, self.faces, values[:, :, t].reshape(-1).astype(float)

    def show_current(self, event=None) -> None:
        """Put the current frame's vertices and values into each shown wall's layer (a
        hidden wall gets its frame when it is shown: each wall's new frame costs vispy
        a shader rebuild, vispy/vispy#2568)."""
        t = self.frame
        self.volume_frames.show(t)
        for w, layer in self.layers.items():
            if layer.visible and layer.metadata["oftimg"].get("frame") != t:
                layer.data = self._frame_data(w, t)
                layer.metadata["oftimg"]["frame"] = t

    def colour_by(self, field: str, wall: str | None = None) -> list[str]:
        """Colour ``wall`` (default: every wall that has ``field``) by ``field`` (the
        others keep theirs); returns the walls recoloured."""
        recoloured = []
        for w, layer in self.layers.items():
            if field not in wall_fields(self.results, w) or wall not in (None, w):
                continue
            self.values[w] = field_values(self.results, field)
            layer.data = self._frame_data(w, self.frame)
            layer.metadata["oftimg"]["frame"] = self.frame
            colours = field_colours(self.values[w], self.results.info(field).get("unit", ""))
            layer.colormap, layer.contrast_limits = colours["colormap"], colours["contrast_limits"]
            layer.metadata["oftimg"].update(field=field, label=field_label(self.results, field))
            recoloured.append(w)
        return recoloured

    def close(self) -> None:
        """Stop following the time slider."""
        self.viewer.dims.events.current_step.disconnect(self.show_current)
        self.volume_frames.close()
        for layer in self.layers.values():
            layer.events.visible.disconnect(self.show_current)
