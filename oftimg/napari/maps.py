"""A result's maps and fields as napari Image layers beside its walls, on the same
time slider, so that napari's own tools (contrast, histogram, line profiles, other
plugins) work on them.

napari lines up a layer's axes with the viewer's last ones, so an image of (v, u)
cannot share the time axis unless it has the walls' four: each (u, v, t) field is an
image ``(t, 1, v, u)``, the wall unrolled (v up, the outlet at the top, as in the
figures; u across from the seam) and laid flat beside the tube, its single plane
spanning the walls' z range so that it shows at every z in 2-D views too; rows are
spaced by the tube's length over the rows (mm), columns by the outer wall's median
circumference over the columns (mm). The (v, t) maps lie beside it, time across, with
a cursor at the slider's frame. What each pixel is, and each frame's time in ms,
is in the layer's metadata (``oftimg``).
"""

from __future__ import annotations

import numpy as np

from ..output.style import CYCLIC, colour_scale
from .surfaces import AXIS_LABELS, WALL_NAMES, WALLS, field_values, wall_fields, words_with_unit

GAP = 0.15  # between the tube, the unrolled fields and the maps: of the tube's length
# the (v, t) maps shown: areas, expansion, the cushions (the lumen's closure, ellipticity
# and the jelly at and between them)
MAP_PREFIXES = (
    "area_",
    "expanded_mask_75_",
    "lumen_closed",
    "lumen_aspect_ratio",
    "jelly_at_cushions",
    "jelly_between_cushions",
)


def placement(results) -> dict:
    """Where the unrolled images lie (pixel centres, as napari places them): ``z``
    (the walls' lowest z and z range, mm; each image's one plane spans it),
    ``y0`` (the walls' lowest y), ``x_fields`` and ``x_maps`` (each image's left
    edge), ``dv`` (mm a row: the tube's length over the rows), ``du`` (mm a column:
    the outer wall's median circumference over the columns)."""
    zyx = np.concatenate([results[w][..., ::-1].reshape(-1, 3) for w in WALLS if w in results])
    low, high = np.nanmin(zyx, axis=0), np.nanmax(zyx, axis=0)
    s_mm = results["s_mm"]
    length = float(s_mm[-1] - s_mm[0])
    wall = next(w for w in WALLS if w in results)
    rings = results[wall]  # (u, v, t, 3)
    perimeter = np.linalg.norm(np.roll(rings, -1, axis=0) - rings, axis=-1).sum(axis=0)
    circumference = float(np.nanmedian(perimeter))
    gap = GAP * length
    return {
        "z": (float(low[0]), max(float(high[0] - low[0]), length / len(s_mm))),
        "y0": float(low[1]),
        "x_fields": float(high[2]) + gap,
        "x_maps": float(high[2]) + 2 * gap + circumference,
        "dv": length / (len(s_mm) - 1),
        "du": circumference / rings.shape[0],
        "length": length,
    }


def _layer_kwargs(results, name: str, meta: dict, visible: bool) -> dict:
    return {
        "name": f"{results.name}: {name}",
        "axis_labels": AXIS_LABELS,
        "visible": visible,
        "metadata": {"oftimg": {"results": str(results.folder), **meta}},
    }


def field_image(results, field: str, wall: str, at: dict, *, visible: bool = False) -> tuple:
    """``field`` ``(n_u, n_v, n_t)`` on ``wall`` as an Image layer-data tuple: the
    unrolled wall ``(n_t, 1, n_v, n_u)`` (v up, outlet at the top), in the house's
    colours, beside the tube (``at``: :func:`placement`)."""
    values = field_values(results, field)
    image = np.ascontiguousarray(
        np.transpose(values, (2, 1, 0))[:, None, ::-1, :], dtype=np.float32
    )
    scale = (
        colour_scale(values)
        if results.info(field).get("unit") != "rad"
        else {"cmap": CYCLIC, "vmin": -np.pi, "vmax": np.pi}
    )
    z0, z_span = at["z"]
    words = words_with_unit(results, field, wall=wall)
    kwargs = _layer_kwargs(
        results,
        f"{WALL_NAMES[wall]} {words}, unrolled",
        {
            "array": field,
            "wall": wall,
            "dims": ["u", "v", "t"],
            "rows": "v from the outlet (top) to the inlet (bottom)",
            "columns": "u around from the seam",
            "t_ms": results["t_ms"].tolist(),
        },
        visible,
    )
    kwargs.update(
        scale=(1.0, z_span, at["dv"], at["du"]),
        translate=(0.0, z0 + z_span / 2, at["y0"], at["x_fields"]),
        colormap=scale["cmap"],
        contrast_limits=(scale.get("vmin", 0.0), scale.get("vmax", 1.0)),
    )
    return image, kwargs, "image"


def map_image(results, name: str, at: dict, *, visible: bool = False) -> tuple:
    """A (v, t) map as an Image layer-data tuple ``(1, n_v, n_t)`` (no time axis: it
    holds every time; v up, time across, as long as the tube is), beside the unrolled
    fields."""
    values = np.asarray(results[name])
    image = values[::-1].astype(np.float32 if values.dtype != bool else np.uint8)[None]
    z0, z_span = at["z"]
    scale = colour_scale(values) if values.dtype != bool else {"cmap": "gray", "vmin": 0, "vmax": 1}
    wall = next((w for w in WALLS if name.endswith(f"_{w}") or f"_{w}_" in name), None)
    words = words_with_unit(results, name, wall=wall).replace(" (bool)", "")
    title = f"{WALL_NAMES[wall]} {words}" if wall else words
    kwargs = _layer_kwargs(
        results,
        f"{title}, (v, t) map",
        {
            "array": name,
            "dims": ["v", "t"],
            "rows": "v from the outlet (top) to the inlet (bottom)",
            "columns": "t, the frames of the cycle",
            "t_ms": results["t_ms"].tolist(),
        },
        visible,
    )
    kwargs.update(
        scale=(z_span, at["dv"], at["length"] / values.shape[1]),
        translate=(z0 + z_span / 2, at["y0"], at["x_maps"]),
        colormap=scale["cmap"],
        contrast_limits=(scale.get("vmin", 0.0), scale.get("vmax", 1.0)),
    )
    kwargs["axis_labels"] = AXIS_LABELS[1:]
    return image, kwargs, "image"


def time_cursor(results, at: dict, *, visible: bool = False) -> tuple:
    """A white column over the (v, t) maps at the slider's frame: an image ``(n_t, 1,
    1, n_t)`` whose frame ``t`` lights column ``t``, added over the maps."""
    n_t = len(results["t_ms"])
    z0, z_span = at["z"]
    kwargs = _layer_kwargs(results, "time on the (v, t) maps", {}, visible)
    kwargs.update(
        scale=(1.0, z_span, at["length"] + at["dv"], at["length"] / n_t),
        translate=(0.0, z0 + z_span / 2, at["y0"] + at["length"] / 2, at["x_maps"]),
        colormap="gray",
        contrast_limits=(0, 1),
        blending="additive",
    )
    return np.eye(n_t, dtype=np.uint8)[:, None, None, :], kwargs, "image"


def map_layers(results, shown: str | None = None) -> list[tuple]:
    """Every wall's (u, v, t) fields and activation times unrolled (:func:`field_image`), the section-area
    and expansion (v, t) maps (:func:`map_image`) and their time cursor, as layer-data
    tuples; hidden, but for the field ``shown`` on the first wall that has it."""
    at = placement(results)
    layers = []
    for wall in (w for w in WALLS if w in results):
        for field in wall_fields(results, wall):
            if results.info(field)["dims"] != ["u", "v", "t"] and not field.startswith(
                "activation_time_"
            ):
                continue  # the phase maps: wall colours only
            if field == "wall_thickness_mm" and wall != "outer" and "outer" in results:
                continue  # one image of the two walls'
            visible = field == shown
            shown = None if visible else shown
            layers.append(field_image(results, field, wall, at, visible=visible))
    maps = [
        n
        for n, d in results.described.items()
        if d["dims"] == ["v", "t"] and n.startswith(MAP_PREFIXES)
    ]
    layers += [map_image(results, n, at) for n in maps]
    return layers + [time_cursor(results, at)]
