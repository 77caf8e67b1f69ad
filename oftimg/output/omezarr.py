"""A dataset's fields and pullbacks as OME-Zarr images (NGFF 0.4, zarr format 2), the
format napari, Fiji (BigDataViewer, MoBIE), QuPath and web viewers open with their
axes: time in ms as the time axis, the grid's v (rows) and u (columns) as the space
axes, the principal stretches as channels, and what the values are in the image's
``oftimg`` attributes.

Written with zarr alone (no OME library at run time): one resolution level, the
arrays are small (80 x 50 nodes). Version 0.4 rather than 0.5 because more of the
tools labs use read it today; :mod:`oftimg.io.labelfile` reads both. Each image lies
as :mod:`oftimg.output.image_order` draws it (v rows from the outlet at the top); the
space axes count grid nodes (no unit: a node's size in mm changes along the tube and
over the cycle; each row's distance from the inlet is in ``oftimg.s_mm``).
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from .image_order import in_image_order

NGFF_VERSION = "0.4"
OME_DIMS = (["u", "v"], ["u", "v", "t"], ["u", "v", "t", "l1,l2"])
FRAMES_PER_CHUNK = 64
CHANNEL_COLOURS = ("FF00FF", "00FF00")  # the stretches' channels as viewers show them


def ome_zarr_names(described: dict) -> list[str]:
    """The arrays of ``arrays.json`` that are OME-Zarr images: the (u, v, t) fields,
    the principal stretches and the (u, v) phase maps (a (v, t) map has one space
    axis, which an OME-Zarr image cannot have: ``oftimg tiff`` writes those)."""
    return [
        name
        for name, d in described.items()
        if d.get("file", "arrays.npz") == "arrays.npz" and d["dims"] in OME_DIMS
    ]


def ome_image(
    values: np.ndarray, info: dict, t_ms: np.ndarray, s_mm: np.ndarray
) -> tuple[np.ndarray, dict]:
    """One array on its named axes (``info``: its arrays.json entry) as ``(image,
    group attributes)``: the image ``([t], [c], v, u)`` in image order, float32 with
    NaN kept (a mask uint8 0 / 1), and its OME ``multiscales`` (axes with types and
    units, the frame interval as the time scale), ``omero`` channel names, and
    ``oftimg``: the array's name, description, unit, dims and each frame's time and
    each row's distance from the inlet."""
    image, axes = in_image_order(values, info["dims"])
    image = image.astype(np.uint8) if image.dtype == bool else image.astype(np.float32)
    named = {
        "T": {"name": "t", "type": "time", "unit": "millisecond"},
        "C": {"name": "c", "type": "channel"},
        "Y": {"name": "v", "type": "space"},
        "X": {"name": "u", "type": "space"},
    }
    scale = [float(np.median(np.diff(t_ms))) if a == "T" else 1.0 for a in axes]
    attrs = {
        "multiscales": [
            {
                "version": NGFF_VERSION,
                "name": info.get("name", ""),
                "axes": [named[a] for a in axes],
                "datasets": [
                    {"path": "0", "coordinateTransformations": [{"type": "scale", "scale": scale}]}
                ],
            }
        ],
        "oftimg": {
            "description": info["description"],
            "unit": info.get("unit", ""),
            "dims": info["dims"],
            "rows": "v, from the outlet (row 0) to the inlet",
            "columns": "u, around the tube from the seam (u = 0)",
            "s_mm": [float(s) for s in s_mm[::-1]],
            **({"t_ms": [float(t) for t in t_ms]} if "T" in axes else {}),
        },
    }
    if "C" in axes:
        attrs["omero"] = {
            "channels": [
                {"label": label, "active": True, "color": color, "window": _window(image[:, k])}
                for k, (label, color) in enumerate(
                    zip(info["dims"][-1].split(","), CHANNEL_COLOURS)
                )
            ]
        }
    return image, attrs


def _window(values: np.ndarray) -> dict:
    """A channel's display window (OMERO's): its finite range."""
    finite = values[np.isfinite(values)]
    low, high = (float(finite.min()), float(finite.max())) if finite.size else (0.0, 1.0)
    return {"min": low, "max": high, "start": low, "end": high}


def write_ome_zarr(path: Path, image: np.ndarray, attrs: dict) -> Path:
    """``image`` and its group attributes as the OME-Zarr image ``path`` (a new
    folder): level ``0`` chunked by frames, NaN the fill value of a float image."""
    import zarr

    group = zarr.open_group(str(path), mode="w-", zarr_format=2)
    group.attrs.update(json.loads(json.dumps(attrs)))  # plain JSON types only
    chunks = (
        (min(FRAMES_PER_CHUNK, image.shape[0]), *image.shape[1:]) if image.ndim > 2 else image.shape
    )
    fill = np.nan if image.dtype.kind == "f" else 0
    array = group.create_array(
        "0",
        shape=image.shape,
        dtype=image.dtype,
        chunks=chunks,
        fill_value=fill,
        chunk_key_encoding={"name": "v2", "separator": "/"},
    )
    array[...] = image
    return path


def write_ome_zarr_images(results: Path, out: Path) -> list[Path]:
    """Every OME-Zarr image of one dataset's results folder (:func:`ome_zarr_names`,
    and each pullback of ``pullbacks.npz``) as ``out/<array name>.ome.zarr``. Returns
    the images written."""
    described = json.loads((results / "arrays.json").read_text())
    out.mkdir(parents=True)
    written = []
    with np.load(results / "arrays.npz") as npz:
        t_ms, s_mm = npz["t_ms"], npz["s_mm"]
        for name in ome_zarr_names(described):
            image, attrs = ome_image(npz[name], described[name] | {"name": name}, t_ms, s_mm)
            written.append(write_ome_zarr(out / f"{name}.ome.zarr", image, attrs))
    if (results / "pullbacks.npz").is_file():
        with np.load(results / "pullbacks.npz") as npz:
            for name in npz.files:
                info = described[name] | {"name": name, "dims": ["u", "v", "t"]}
                image, attrs = ome_image(npz[name], info, t_ms, s_mm)
                attrs["oftimg"].update(
                    rows="v_fine, from the outlet (row 0) to the inlet",
                    columns="u_fine, around the tube from the seam",
                    not_imaged="NaN",
                )
                del attrs["oftimg"]["s_mm"]  # rows finer than the grid's
                written.append(write_ome_zarr(out / f"{name}.ome.zarr", image, attrs))
    return written
