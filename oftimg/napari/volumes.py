"""A dataset folder in napari: its label volumes (a Labels layer), its intensity
volumes (an Image layer) and, for a mesh dataset, its surfaces, each over time on
napari's time slider, in mm (the walls' coordinates: voxel ``(k, j, i)`` at ``origin +
(i dx, j dy, k dz)``). Volumes are read a frame at a time as the slider reaches it
(dask), never whole. Under a result's walls the frames are put in the aligned cycle's
order (result frame ``t`` is input frame ``(t + t0_frame) mod n``).
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ..io.dataset import is_dataset, load_dataset
from ..io.label_dataset import is_label_dataset, load_label_dataset, read_frame
from ..io.labelfile import read_header
from ..io.meshfile import read_mesh_file
from ..io.units import UNIT_TO_MM
from .reader import AXIS_LABELS

SURFACE_COLOURS = {"outer": "#E69F00", "inner": "#56B4E9", "lumen": "#CC79A7"}


def lazy_frames(read, n_frames: int, shape: tuple, dtype, order=None):
    """A dask array ``(t, z, y, x)`` whose frame ``t`` is ``read(order[t])``, read when
    napari asks for it; ``order`` (default ``range(n_frames)``) the input frame of each."""
    import dask
    import dask.array as da

    order = np.arange(n_frames) if order is None else np.asarray(order)
    frames = [da.from_delayed(dask.delayed(read)(int(t)), shape=tuple(shape), dtype=dtype)
              for t in order]
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


def result_volumes(results) -> list[tuple]:
    """The volumes of the dataset ``results`` were made from (:func:`dataset_of`),
    frames in the aligned cycle's order, named as the results: none when the dataset is
    gone, or the cycle was time-warped (its frames are not the input's)."""
    folder = dataset_of(results)
    summary = results.summary
    if folder is None:
        import warnings

        from ..errors import OftimgWarning

        places = " nor ".join(str(p) for p in results.dataset_candidates()) or "unknown"
        warnings.warn(f"{results.folder}: the dataset these results were made from is "
                      f"not at {places}: its walls are shown without its volumes",
                      OftimgWarning, stacklevel=2)   # napari shows it as a notification
        return []
    if summary.get("time_warp"):
        return []
    order = cycle_order(int(summary["n_frames"]), int(summary["t0_frame"]))
    return volume_layers(folder, order, name=results.name)


def volume_layers(path, order=None, name: str | None = None) -> list[tuple]:
    """The label and intensity volumes of the dataset at ``path`` as napari layer-data
    tuples (none it does not have): labels hidden at first (they hide the walls),
    intensity as a grey maximum-intensity projection; ``order``: the input frame of
    each frame shown (:func:`cycle_order` under a result)."""
    path = Path(path)
    name = name or path.name
    layers = []
    if is_label_dataset(path):
        lds = load_label_dataset(path)
        dx, dy, dz = (d * UNIT_TO_MM[lds.meta.length_unit] for d in lds.voxel_size)
        scale = (1.0, dz, dy, dx)
        if lds.kind == "labels":
            header = read_header(lds.sources[0])
            data = lazy_frames(lambda t: read_frame(lds.sources[t]), lds.n_frames,
                               header.shape, header.dtype, order)
            layers.append((data, {"name": f"{name}: labels", "scale": scale, "opacity": 0.5,
                                  "axis_labels": AXIS_LABELS,
                                  "visible": False}, "labels"))
        intensity = lds.intensity
    else:
        intensity = load_dataset(path).intensity
    if intensity is not None:
        data = lazy_frames(intensity.volume, intensity.n_frames, intensity.shape,
                           np.float32, order)
        first = intensity.volume(0 if order is None else int(order[0]))
        low, high = np.percentile(first, [1, 99.8])
        dx, dy, dz = intensity.voxel_size_mm
        ox, oy, oz = intensity.origin_mm
        layers.append((data, {"name": f"{name}: intensity", "scale": (1.0, dz, dy, dx),
                              "axis_labels": AXIS_LABELS,
                              "translate": (0.0, oz, oy, ox), "colormap": "gray",
                              "contrast_limits": (float(low), float(high)),
                              "rendering": "mip", "opacity": 0.6, "blending": "additive"},
                       "image"))
    return layers


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
        layers.append(((np.concatenate(vertices), np.concatenate(faces)),
                       {"name": f"{ds.meta.name}: {surface} (as meshed)", "shading": "smooth",
                        "axis_labels": AXIS_LABELS,
                        "colormap": _one_colour(SURFACE_COLOURS[surface]), "opacity": 0.7},
                       "surface"))
    return layers


def _one_colour(colour: str):
    from napari.utils.colormaps import Colormap

    return Colormap([colour, colour], name=f"oftimg {colour}")


def dataset_layers(path) -> list[tuple]:
    """Everything napari shows of a dataset folder: its volumes
    (:func:`volume_layers`) and, for a mesh dataset, its surfaces
    (:func:`surfaces_over_time`)."""
    path = Path(path)
    layers = volume_layers(path)
    if is_dataset(path) and not is_label_dataset(path):
        layers += surfaces_over_time(path)
    return layers
