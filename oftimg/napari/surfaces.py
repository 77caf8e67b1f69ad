"""A result's walls as napari Surfaces: each wall's grid over time (vertices ``(t, z,
y, x)`` mm, one set per frame, so that napari's time slider moves the wall), coloured
by a (u, v, t) field in the house colour maps (viridis for a one-signed field, RdBu
centred on 0 for a signed one), and the names every layer shares (the world's axes,
the walls' names, the fields in words). Pure functions of the stored arrays; napari is
needed only to show them.
"""

from __future__ import annotations

import numpy as np

from ..mesh.strain import grid_triangles
from ..output.export import WALLS
from ..output.paraview import node_field_names
from ..output.results import Results
from ..output.numbers import label_unit
from ..output.style import CYCLIC, colour_scale

WALL_NAMES = {"outer": "outer wall", "inner": "inner wall", "lumen": "lumen"}
# the world's axes: every layer names them (napari labels its sliders from its layers)
AXIS_LABELS = ("frame", "z (mm)", "y (mm)", "x (mm)")
# the field each wall is coloured by when none is asked for (the first it has)
DEFAULT_FIELDS = {
    "outer": ("radial_curvature_outer_per_mm", "strain_energy_outer"),
    "inner": ("radial_curvature_inner_per_mm", "strain_energy_inner"),
    "lumen": ("mean_curvature_lumen_per_mm",),
}


UNIT_SUFFIXES = ("_per_mm", "_mm2", "_mm", "_ms", "_um")


def readable(name: str) -> str:
    """An array's name as words, its unit suffix left to the unit:
    ``radial_curvature_outer_per_mm`` -> ``radial curvature outer``,
    ``phase_max_strain_energy_outer_ms`` -> ``time of maximum strain energy outer``,
    ``radial_curvature_outer_band95_per_mm`` -> ``95 % band of radial curvature outer``."""
    for which in ("max", "min"):
        prefix = f"phase_{which}_"
        if name.startswith(prefix) and name.endswith("_ms"):
            return f"time of {which}imum {readable(name[len(prefix) : -len('_ms')])}"
    if "_band95" in name:
        return "95 % band of " + readable(name.replace("_band95", ""))
    if name.startswith("activation_sd_"):
        return "activation time SD " + readable(name[len("activation_sd_") :])
    if name.startswith("phase_") and name.count("_") == 1:
        return f"phase of the motion {name[len('phase_') :]}"
    for suffix in UNIT_SUFFIXES:
        if name.endswith(suffix):
            name = name[: -len(suffix)]
            break
    return name.replace("_", " ")


def words_with_unit(results, name: str, wall: str | None = None) -> str:
    """An array's name as words with its unit, ``radial curvature (1/mm)``; under a
    wall's heading (``wall``) without that wall's name."""
    words = readable(name)
    if wall is not None:
        words = " ".join(w for w in words.split() if w != wall)
    unit = label_unit(results.info(name).get("unit", ""))
    return f"{words} ({unit})" if unit else words


def surface_over_time(grid: np.ndarray, values: np.ndarray | None = None) -> tuple[np.ndarray, ...]:
    """napari Surface data of a grid ``(n_u, n_v, n_t, 3)`` mm (x, y, z) over time:
    vertices ``(n_t n_u n_v, 4)`` as (frame, z, y, x), faces ``(n_t F, 3)`` (each
    frame's grid triangles, periodic in u), and with ``values (n_u, n_v, n_t)`` the
    value of each vertex ``(n_t n_u n_v,)`` (NaN where the field has none)."""
    n_u, n_v, n_t, _ = grid.shape
    per_frame = np.moveaxis(grid, 2, 0).reshape(n_t, n_u * n_v, 3)[..., ::-1]  # z, y, x
    frame = np.repeat(np.arange(n_t, dtype=float), n_u * n_v)[:, None]
    vertices = np.concatenate([frame, per_frame.reshape(-1, 3)], axis=1)
    triangles = grid_triangles(n_u, n_v)
    faces = (triangles[None] + (n_u * n_v * np.arange(n_t))[:, None, None]).reshape(-1, 3)
    if values is None:
        return vertices, faces
    return vertices, faces, np.moveaxis(values, 2, 0).reshape(-1).astype(float)


def wall_fields(results: Results, wall: str) -> list[str]:
    """The fields on ``wall``'s grid nodes that a Surface can be coloured by: its
    (u, v, t) fields, then its (u, v) maps (activation times, phase maps), the same at
    every frame."""
    names = node_field_names(results.described, wall)
    return [n for n in names if results.info(n)["dims"] == ["u", "v", "t"]] + [
        n for n in names if results.info(n)["dims"] == ["u", "v"]
    ]


def field_values(results: Results, name: str) -> np.ndarray:
    """A field ``(n_u, n_v, n_t)``: a (u, v, t) field as stored, a (u, v) map the same
    at every frame (a view, not a copy)."""
    values = results[name]
    if values.ndim == 2:
        values = np.broadcast_to(values[:, :, None], (*values.shape, len(results["t_ms"])))
    return values


def field_choices(results: Results) -> list[tuple[str, str, list[tuple[str, str]]]]:
    """Every wall's fields as a person chooses them: ``[(wall, its name, [(field in
    words with its unit, array name), ...]), ...]`` in the walls' order (outer, inner,
    lumen); a field two walls carry (the wall thickness) under both."""
    return [
        (
            w,
            WALL_NAMES.get(w, w),
            [(words_with_unit(results, f, wall=w), f) for f in wall_fields(results, w)],
        )
        for w in WALLS
        if w in results and wall_fields(results, w)
    ]


def field_label(results: Results, name: str) -> str:
    """A field's name with its unit, as a colour bar or a list names it."""
    unit = label_unit(results.info(name).get("unit", ""))
    return f"{name} ({unit})" if unit else name


def wall_style(
    results: Results, wall: str, field: str | None = None
) -> tuple[np.ndarray | None, dict]:
    """What colours one wall: the field's values ``(n_u, n_v, n_t)`` (``field``, or
    :data:`DEFAULT_FIELDS`'s first the wall has; None: one colour) and the Surface
    layer's keywords (name, colour map and limits, wireframe hidden, metadata)."""
    fields = wall_fields(results, wall)
    if field is None or field not in fields:
        field = next((f for f in DEFAULT_FIELDS.get(wall, ()) if f in fields), None)
    kwargs = {
        "name": f"{results.name}: {WALL_NAMES.get(wall, wall)}",
        "shading": "smooth",
        "wireframe": {"visible": False, "color": "black", "width": 0.5},
        "metadata": {
            "oftimg": {
                "results": str(results.folder),
                "wall": wall,
                "field": field,
                "fields": fields,
                "t_ms": results["t_ms"].tolist(),
            }
        },
    }
    if field is None:
        return None, kwargs
    values = field_values(results, field)
    kwargs.update(field_colours(values, results.info(field).get("unit", "")))
    kwargs["metadata"]["oftimg"]["label"] = field_label(results, field)
    return values, kwargs


def field_colours(values: np.ndarray, unit: str = "") -> dict:
    """A Surface's colour map and contrast limits for ``values``: the house's
    (:func:`~oftimg.output.style.colour_scale`); a phase (``unit`` rad) in a cyclic map
    from -pi to pi, its ends the same colour as the cycle's."""
    if unit == "rad":
        return {"colormap": CYCLIC, "contrast_limits": (-np.pi, np.pi)}
    scale = colour_scale(values)
    return {
        "colormap": scale["cmap"],
        "contrast_limits": (scale.get("vmin", 0.0), scale.get("vmax", 1.0)),
    }


def wall_layer(results: Results, wall: str, field: str | None = None) -> tuple:
    """One wall as a napari layer-data tuple ``(data, kwargs, "surface")`` over all
    frames (:func:`surface_over_time`), coloured as :func:`wall_style` says."""
    values, kwargs = wall_style(results, wall, field)
    return (
        surface_over_time(results[wall], values),
        kwargs | {"axis_labels": AXIS_LABELS},
        "surface",
    )
