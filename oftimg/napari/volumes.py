"""A dataset folder in napari: its label volumes (a Labels layer), its intensity
volumes (an Image layer) and, for a mesh dataset, its surfaces, each over time on
napari's time slider, in mm (the walls' coordinates: voxel ``(k, j, i)`` at ``origin +
(i dx, j dy, k dz)``). Volumes are read a frame at a time as the slider reaches it
(dask), never whole. Under a result's walls the frames are put in the aligned cycle's
order (result frame ``t`` is input frame ``(t + t0_frame) mod n``).
"""

from __future__ import annotations

import functools
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..io.dataset import is_dataset, load_dataset
from ..io.label_dataset import is_label_dataset, load_label_dataset, read_frame
from ..io.labelfile import read_header, read_volume
from ..io.meshfile import read_mesh_file
from ..io.units import UNIT_TO_MM
from .surfaces import AXIS_LABELS

SURFACE_COLOURS = {"outer": "#E69F00", "inner": "#56B4E9", "lumen": "#CC79A7"}


def lazy_frames(read, n_frames: int, shape: tuple, dtype):
    """A dask array ``(t, z, y, x)`` whose frame ``t`` is ``read(t)``, read when napari
    asks for it."""
    import dask
    import dask.array as da

    frames = [
        da.from_delayed(dask.delayed(read)(t), shape=tuple(shape), dtype=dtype)
        for t in range(n_frames)
    ]
    return da.stack(frames)


def cycle_order(n_frames: int, t0_frame: int) -> np.ndarray:
    """The input frame of each frame of the aligned cycle: ``(t + t0_frame) mod n``."""
    return (np.arange(n_frames) + int(t0_frame)) % n_frames


def dataset_of(results) -> Path | None:
    """The dataset folder a result was made from, if it is still there
    (:meth:`~oftimg.output.results.Results.dataset_candidates`: where the run found
    it, or as far from the results as it was)."""
    for folder in results.dataset_candidates():
        if folder.is_dir() and (is_dataset(folder) or is_label_dataset(folder)):
            return folder
    return None


def result_volumes(results) -> list[VolumeSeries]:
    """The volume series of the dataset ``results`` were made from (:func:`dataset_of`),
    frames in the aligned cycle's order, named as the results: none when the dataset is
    gone, or the cycle was time-warped (its frames are not the input's)."""
    folder = dataset_of(results)
    summary = results.summary
    if folder is None:
        import warnings

        from ..errors import OftimgWarning

        places = " nor ".join(str(p) for p in results.dataset_candidates()) or "unknown"
        warnings.warn(
            f"{results.folder}: the dataset these results were made from is "
            f"not at {places}: its walls are shown without its volumes",
            OftimgWarning,
            stacklevel=2,
        )  # napari shows it as a notification
        return []
    if summary.get("time_warp"):
        return []
    order = cycle_order(int(summary["n_frames"]), int(summary["t0_frame"]))
    return volume_series(folder, order, name=results.name)


@dataclass(frozen=True)
class VolumeSeries:
    """One of a dataset's volume series as napari shows it: ``read(t)`` frame ``t``'s
    voxels ``(z, y, x)`` as stored (input frame ``order[t]``, the last
    :data:`CACHED_FRAMES` kept), the layer's ``kind`` (labels or image) and keywords
    (4-D scale and translate in mm, first axis the frame)."""

    read: object
    n_frames: int
    shape: tuple
    dtype: np.dtype
    kind: str
    kwargs: dict

    def layer_data(self) -> tuple:
        """The napari layer-data tuple with every frame, read as the slider reaches it."""
        return lazy_frames(self.read, self.n_frames, self.shape, self.dtype), self.kwargs, self.kind


CACHED_FRAMES = 8  # of each series: the frames about the slider, read once


def _cached(read, order) -> object:
    """``read(order[t])`` for frame ``t``, its last :data:`CACHED_FRAMES` kept."""
    order = np.asarray(order)
    return functools.lru_cache(maxsize=CACHED_FRAMES)(lambda t: read(int(order[t])))


def volume_series(path, order=None, name: str | None = None) -> list[VolumeSeries]:
    """The label and intensity volumes of the dataset at ``path`` (none it does not
    have): labels hidden at first (they hide the walls), intensity as a grey
    maximum-intensity projection, both in their stored type (a uint8 volume is a
    quarter of a float32 texture to draw); ``order``: the input frame of each frame
    shown (:func:`cycle_order` under a result)."""
    path = Path(path)
    name = name or path.name
    series = []
    if is_label_dataset(path):
        lds = load_label_dataset(path)
        n = lds.n_frames
        order = np.arange(n) if order is None else order
        dx, dy, dz = (d * UNIT_TO_MM[lds.meta.length_unit] for d in lds.voxel_size)
        if lds.kind == "labels":
            header = read_header(lds.sources[0])
            series.append(
                VolumeSeries(
                    _cached(lambda t: read_frame(lds.sources[t]), order),
                    n,
                    header.shape,
                    header.dtype,
                    "labels",
                    {
                        "name": f"{name}: labels",
                        "scale": (1.0, dz, dy, dx),
                        "opacity": 0.5,
                        "axis_labels": AXIS_LABELS,
                        "visible": False,
                    },
                )
            )
        intensity = lds.intensity
    else:
        intensity = load_dataset(path).intensity
    if intensity is not None:
        n = intensity.n_frames
        order = np.arange(n) if order is None else order
        read = _cached(lambda t: np.asarray(read_volume(intensity.sources[t])), order)
        first = read(0)
        low, high = np.percentile(first, [1, 99.8])
        dx, dy, dz = intensity.voxel_size_mm
        ox, oy, oz = intensity.origin_mm
        series.append(
            VolumeSeries(
                read,
                n,
                intensity.shape,
                first.dtype,
                "image",
                {
                    "name": f"{name}: intensity",
                    "scale": (1.0, dz, dy, dx),
                    "axis_labels": AXIS_LABELS,
                    "translate": (0.0, oz, oy, ox),
                    "colormap": "gray",
                    "contrast_limits": (float(low), float(high) if high > low else float(low) + 1),
                    "rendering": "mip",
                    "opacity": 0.6,
                    "blending": "additive",
                },
            )
        )
    return series


PROXY_STEP = 4  # while the slider moves: every 4th voxel along each axis
REST_MS = 250  # the slider still this long: the full frames
PREFETCH = 2  # frames read ahead, the way the slider goes


class VolumesOverTime:
    """Volume series (:class:`VolumeSeries`) in a napari viewer one frame a layer, as
    :class:`~oftimg.napari.walls.WallsOverTime` shows the walls: :meth:`show` puts
    frame ``t`` into each shown layer. The frames the slider goes towards are read
    ahead in a thread and kept (:data:`CACHED_FRAMES`); in napari's window, while the
    slider moves each layer shows a coarse copy (every :data:`PROXY_STEP`-th voxel:
    1/64 of the texture to send, a quarter to half of Mesa's drawing), and the full
    frame once the slider has rested :data:`REST_MS`."""

    def __init__(self, viewer, series: list[VolumeSeries]):
        from concurrent.futures import ThreadPoolExecutor

        self.viewer, self.series, self.frame, self.step = viewer, series, 0, 1
        self.layers, self.scales = [], []
        for v in series:
            kwargs = dict(v.kwargs)
            scale = np.asarray(kwargs.pop("scale")[1:], float)
            kwargs["translate"] = kwargs.get("translate", (0.0,) * 4)[1:]
            kwargs["axis_labels"] = AXIS_LABELS[1:]
            layer = getattr(viewer, f"add_{v.kind}")(v.read(0), scale=scale, **kwargs)
            layer.metadata["oftimg"] = {"frame": 0, "coarse": False}
            layer.events.visible.connect(self._shown)
            self.layers.append(layer)
            self.scales.append(scale)
        self.reader = ThreadPoolExecutor(max_workers=1, thread_name_prefix="oftimg-volumes")
        self.timer = _rest_timer(self.settle)

    def show(self, t: int) -> None:
        """Frame ``t`` in each shown layer: coarse while the slider moves (in a window),
        the full frame when it rests; the next frames read ahead."""
        self.step = 1 if t >= self.frame else -1
        moving = self.timer is not None and t != self.frame
        self.frame = t
        for layer, v, scale in zip(self.layers, self.series, self.scales):
            if layer.visible:
                self._put(layer, v, scale, t, coarse=moving)
        if moving:
            self.timer.start()
        for v in self.series:  # the frames the slider goes towards
            for k in range(1, PREFETCH + 1):
                self.reader.submit(v.read, (t + k * self.step) % v.n_frames)

    def settle(self) -> None:
        """The full frames, once the slider has rested."""
        for layer, v, scale in zip(self.layers, self.series, self.scales):
            if layer.visible and layer.metadata["oftimg"]["coarse"]:
                self._put(layer, v, scale, self.frame, coarse=False)

    def _put(self, layer, v: VolumeSeries, scale, t: int, coarse: bool) -> None:
        meta = layer.metadata["oftimg"]
        if meta["frame"] == t and meta["coarse"] == coarse:
            return
        data = v.read(t)
        if coarse:
            data = data[::PROXY_STEP, ::PROXY_STEP, ::PROXY_STEP]
        if meta["coarse"] != coarse:
            layer.scale = scale * (PROXY_STEP if coarse else 1)
        layer.data = data
        meta.update(frame=t, coarse=coarse)

    def _shown(self, event=None) -> None:
        for layer, v, scale in zip(self.layers, self.series, self.scales):
            if layer.visible:
                self._put(layer, v, scale, self.frame, coarse=False)

    def close(self) -> None:
        """Stop reading ahead."""
        if self.timer is not None:
            self.timer.stop()
        self.reader.shutdown(wait=False, cancel_futures=True)


def _rest_timer(settle):
    """A Qt single-shot timer of :data:`REST_MS` calling ``settle`` (on the window's
    thread), or None without a running Qt application (a headless viewer: no coarse
    frames)."""
    try:
        from qtpy.QtCore import QTimer
        from qtpy.QtWidgets import QApplication
    except Exception:
        return None
    if QApplication.instance() is None:
        return None
    timer = QTimer()
    timer.setSingleShot(True)
    timer.setInterval(REST_MS)
    timer.timeout.connect(settle)
    return timer


def volume_layers(path, order=None, name: str | None = None) -> list[tuple]:
    """:func:`volume_series` as napari layer-data tuples, every frame in each (read as
    the slider reaches it)."""
    return [v.layer_data() for v in volume_series(path, order, name)]


def surfaces_over_time(path) -> list[tuple]:
    """A mesh dataset's surfaces (outer, inner, lumen) as napari Surfaces over time,
    in mm, as meshed (each frame its own vertices and triangles)."""
    ds = load_dataset(path)
    layers = []
    for surface, files in ds.frames.items():
        vertices, faces, start = [], [], 0
        for t, file in enumerate(files):
            V, F = read_mesh_file(file)
            V = np.asarray(V, float) * ds.unit_scale
            vertices.append(np.column_stack([np.full(len(V), float(t)), V[:, ::-1]]))
            faces.append(np.asarray(F) + start)
            start += len(V)
        layers.append(
            (
                (np.concatenate(vertices), np.concatenate(faces)),
                {
                    "name": f"{ds.meta.name}: {surface} (as meshed)",
                    "shading": "smooth",
                    "axis_labels": AXIS_LABELS,
                    "colormap": _one_colour(SURFACE_COLOURS[surface]),
                    "opacity": 0.7,
                },
                "surface",
            )
        )
    return layers


def _one_colour(colour: str):
    from napari.utils.colormaps import Colormap

    return Colormap([colour, colour], name=f"oftimg {colour}")


def dataset_layers(path) -> list[tuple]:
    """Everything napari shows of a dataset folder: its volumes
    (:func:`volume_layers`) and, for a mesh dataset, its surfaces
    (:func:`surfaces_over_time`); the labels shown where nothing else is (hidden, as
    under a result's walls, the canvas was black)."""
    path = Path(path)
    layers = volume_layers(path)
    if is_dataset(path) and not is_label_dataset(path):
        layers += surfaces_over_time(path)
    if layers and not any(kwargs.get("visible", True) for _, kwargs, _ in layers):
        layers[0][1]["visible"] = True  # alone, the labels are what there is to see
    return layers
