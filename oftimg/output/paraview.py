"""A dataset's results as ParaView time series: each grid (a quad surface closed
around the seam) with every field that lives on its nodes, and each wall's section
contours (closed polylines), one VTK XML file (.vtu, meshio) per frame and one
.pvd collection per series whose time steps are ``t_ms``."""

from __future__ import annotations

import json
from pathlib import Path
from xml.sax.saxutils import quoteattr

import numpy as np

from .results import load_results

WALLS = ("outer", "inner", "lumen")
MYOCARDIUM = ("outer", "inner")  # the walls the wall thickness belongs to
JELLY = "inner"  # the wall the jelly thickness is measured from


def quad_cells(n_u: int, n_v: int) -> np.ndarray:
    """Quads ``(n_u (n_v - 1), 4)`` of a grid whose nodes are numbered ``i n_v + j``
    (``G[i, j]`` flattened), closed around u. Corners in the order (i, j), (i+1, j),
    (i+1, j+1), (i, j+1): the normal d/du x d/dv points out of the tube (u runs
    clockwise looking from the inlet towards the outlet)."""
    i, j = np.meshgrid(np.arange(n_u), np.arange(n_v - 1), indexing="ij")
    nxt = (i + 1) % n_u
    return (
        np.stack([i * n_v + j, nxt * n_v + j, nxt * n_v + j + 1, i * n_v + j + 1], axis=-1)
        .reshape(-1, 4)
        .astype(np.int32)
    )


def ring_segments(n_u: int, n_v: int) -> np.ndarray:
    """Line segments ``(n_u n_v, 2)`` closing each of the ``n_v`` rings of ``n_u``
    points (numbered ``i n_v + j``, as :func:`quad_cells`)."""
    i, j = np.meshgrid(np.arange(n_u), np.arange(n_v), indexing="ij")
    return np.stack([i * n_v + j, (i + 1) % n_u * n_v + j], axis=-1).reshape(-1, 2).astype(np.int32)


def node_field_names(described: dict, wall: str) -> list[str]:
    """The arrays of ``arrays.json`` (``described``: name -> {"dims", ...}) that
    live on ``wall``'s grid nodes: its ``(u, v, t[, k])`` fields and ``(u, v)`` phase
    maps, for the myocardial walls the wall thickness's, and for the inner wall the
    cardiac jelly's thickness's (measured from its nodes)."""

    def belongs(name):
        return (
            f"_{wall}" in name
            or (wall in MYOCARDIUM and "wall_thickness" in name)
            or (wall == JELLY and "jelly_thickness" in name)
        )

    return [
        name
        for name, d in described.items()
        if d.get("file", "arrays.npz") == "arrays.npz"
        and d["dims"][:2] == ["u", "v"]
        and d["dims"][-1] != "xyz"
        and belongs(name)
    ]


def row_area_name(described: dict, wall: str) -> str:
    """The area map whose rows are ``wall``'s grid rows (``area_rows_*`` when the
    run's maps were resampled to fixed positions)."""
    rows = f"area_rows_{wall}_mm2"
    return rows if rows in described else f"area_{wall}_mm2"


def _point_values(a: np.ndarray) -> np.ndarray:
    """A field on the grid's ``(n_u, n_v[, k])`` nodes as VTK point data ``(n_u n_v[, k])``
    (bool as uint8: VTK has no bool)."""
    a = np.asarray(a)
    a = a.astype(np.uint8) if a.dtype == bool else a.astype(np.float32)
    return a.reshape(a.shape[0] * a.shape[1], *a.shape[2:])


def uv_data(n_u: int, n_v: int) -> dict:
    """The grid parameters u (around, from the seam) and v (along, from the inlet)
    of every node, as VTK point data."""
    u, v = np.meshgrid(np.arange(n_u) / n_u, np.linspace(0.0, 1.0, n_v), indexing="ij")
    return {"u": _point_values(u), "v": _point_values(v)}


def grid_frame_data(arrays, described: dict, wall: str, t: int, n_u: int, n_v: int) -> dict:
    """Point data of ``wall``'s ``(n_u, n_v)`` grid at time index ``t``: u and v, the
    node fields (:func:`node_field_names`), the area of each node's row and the
    row's position along the tube ``s_rows_mm``."""
    data = uv_data(n_u, n_v)
    for name in node_field_names(described, wall):
        a = arrays[name]
        data[name] = _point_values(a[:, :, t] if described[name]["dims"][2:3] == ["t"] else a)
    for name in (row_area_name(described, wall), "s_rows_mm"):
        data[name] = _point_values(np.broadcast_to(arrays[name][:, t], (n_u, n_v)))
    return data


def write_pvd(path: Path, steps: list[tuple[float, str]]) -> None:
    """A ParaView collection: ``steps`` of (time, file relative to ``path``'s folder)."""
    rows = "".join(
        f'    <DataSet timestep="{t!r}" group="" part="0" file={quoteattr(f)}/>\n' for t, f in steps
    )
    path.write_text(
        '<?xml version="1.0"?>\n'
        '<VTKFile type="Collection" version="0.1" byte_order="LittleEndian">\n'
        f"  <Collection>\n{rows}  </Collection>\n</VTKFile>\n"
    )


def series_names(results: Path) -> list[str]:
    """The series :func:`write_series` can make of a results folder: every grid of
    ``grids.npz``, then ``sections_<wall>`` for each wall with section contours."""
    described = json.loads((results / "arrays.json").read_text())
    return [n for n, d in described.items() if d.get("file") == "grids.npz"] + [
        f"sections_{w}" for w in WALLS if f"contour_{w}_mm" in described
    ]


def _series_frames(results: Path, name: str):
    """The ``(points (n_u, n_v, 3), (cell type, cells), point data)`` of each frame of
    series ``name``, and the times (ms); reads only the arrays the series needs."""
    described = json.loads((results / "arrays.json").read_text())
    with np.load(results / "arrays.npz") as npz:
        t_ms = npz["t_ms"]
        if name.startswith("sections_"):
            wall = name.removeprefix("sections_")
            contour, area_name = npz[f"contour_{wall}_mm"], row_area_name(described, wall)
            area = npz[area_name]
            n_u, n_v = contour.shape[:2]
            u = uv_data(n_u, n_v)["u"]
            cells = ("line", ring_segments(n_u, n_v))
            return t_ms, (
                (
                    contour[:, :, t],
                    cells,
                    {"u": u, area_name: _point_values(np.broadcast_to(area[:, t], (n_u, n_v)))},
                )
                for t in range(len(t_ms))
            )
        G = load_results(results)[name]  # a clipped grid is made on load
        n_u, n_v = G.shape[:2]
        wall = name.removesuffix("_clipped")
        cells = ("quad", quad_cells(n_u, n_v))
        if name != wall:  # clipped: other nodes than the fields'
            return t_ms, ((G[:, :, t], cells, uv_data(n_u, n_v)) for t in range(len(t_ms)))
        needed = node_field_names(described, wall) + [row_area_name(described, wall), "s_rows_mm"]
        arrays = {k: npz[k] for k in needed}
    return t_ms, (
        (G[:, :, t], cells, grid_frame_data(arrays, described, wall, t, n_u, n_v))
        for t in range(len(t_ms))
    )


def write_series(results: Path, name: str, out: Path) -> Path:
    """Series ``name`` (:func:`series_names`) of one dataset's results folder
    (``grids.npz``, ``arrays.npz``, ``arrays.json``) into ``out``: ``<name>.pvd`` and
    its frames ``<name>/<name>_<t>.vtu``. The walls' grids carry their node fields
    (:func:`grid_frame_data`); the clipped grids u and v only; the sections each
    ring's area. Returns the .pvd file."""
    import meshio

    t_ms, frames = _series_frames(results, name)
    (out / name).mkdir(parents=True)
    steps = []
    for t, (points, cells, data) in enumerate(frames):
        file = f"{name}/{name}_{t:04d}.vtu"
        meshio.write(
            out / file, meshio.Mesh(points.reshape(-1, 3), [cells], point_data=data), binary=True
        )
        steps.append((float(t_ms[t]), file))
    write_pvd(out / f"{name}.pvd", steps)
    return out / f"{name}.pvd"
