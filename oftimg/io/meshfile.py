"""Mesh files read and written: PLY, OBJ, STL, OFF, VTK and VTP in, binary PLY out.

A file is read as it is, ``V (n_vert, 3) float64`` in the file's units and
``F (n_face, 3) int64``; a file that is missing, not a regular file, empty, cut
short, lying in its header or not made of triangles raises
:class:`~oftimg.errors.DatasetError` naming it. Every format but .vtp is parsed by
oftimg's own NumPy readers (:mod:`oftimg.io.meshformats`): open3d's crash the
process on damaged PLY files, so no untrusted byte reaches it.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..errors import DatasetError
from .meshformats import PARSERS, MeshFormatError, not_triangles, ply_vertex_property
from .safefile import read_file_start, read_regular_file

MESH_SUFFIXES = (".ply", ".obj", ".stl", ".off", ".vtk", ".vtp")
MAX_MESH_BYTES = 2**31  # 2 GiB: some 50 million triangles
HEADER_PEEK_BYTES = 65536  # a PLY header is read from this much of a file


def read_mesh_file(path: str | Path) -> tuple[np.ndarray, np.ndarray]:
    """Read a triangle mesh file as ``(V float64, F int64)``, untouched.

    Raises :class:`DatasetError` naming the file when it is missing, not a regular
    file, empty, unreadable, inconsistent with its own header or not made of
    triangles.
    """
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix not in MESH_SUFFIXES:
        raise DatasetError(
            f"{path}: unsupported mesh format {suffix!r}; use one of {', '.join(MESH_SUFFIXES)}"
        )
    if suffix == ".vtp":
        read_regular_file(path, max_bytes=0)  # checks the kind of file only
        V, F = _read_vtp(path)
    else:
        data = read_regular_file(path, max_bytes=MAX_MESH_BYTES)
        try:
            V, F = PARSERS[suffix](data)
        except MeshFormatError as exc:
            raise DatasetError(f"{path}: {exc}") from None
    if len(F) == 0:
        raise DatasetError(f"{path}: no triangles could be read (broken or not a triangle mesh)")
    if V.shape[1:] != (3,) or F.shape[1:] != (3,):
        raise DatasetError(
            f"{path}: expected 3-D vertices and triangles, "
            f"found vertices {V.shape} and faces {F.shape}"
        )
    if F.min() < 0 or F.max() >= len(V):
        raise DatasetError(f"{path}: face indices out of range 0..{len(V) - 1}")
    return V, F


def _read_vtp(path: Path) -> tuple[np.ndarray, np.ndarray]:
    """VTK XML PolyData through the vtk package (meshio does not read .vtp)."""
    try:
        from vtkmodules.util.numpy_support import vtk_to_numpy
        from vtkmodules.vtkFiltersCore import vtkTriangleFilter
        from vtkmodules.vtkIOXML import vtkXMLPolyDataReader
    except ImportError:
        raise DatasetError(
            f"{path}: reading .vtp needs the vtk package (pip install 'oftimg[vtk]')"
        ) from None
    reader = vtkXMLPolyDataReader()
    if not reader.CanReadFile(str(path)):
        raise DatasetError(f"{path}: cannot be read as VTK XML PolyData")
    reader.SetFileName(str(path))
    reader.Update()
    polys = reader.GetOutput().GetPolys()
    others = int(
        np.count_nonzero(np.diff(vtk_to_numpy(polys.GetOffsetsArray())) != 3)
        if polys is not None and polys.GetNumberOfCells()
        else 0
    )
    if others:
        raise DatasetError(f"{path}: {not_triangles(others)}")
    tri = vtkTriangleFilter()  # triangle strips, if any, to triangles
    tri.SetInputConnection(reader.GetOutputPort())
    tri.Update()
    poly = tri.GetOutput()
    if poly.GetNumberOfPoints() == 0 or poly.GetNumberOfPolys() == 0:
        return np.zeros((0, 3)), np.zeros((0, 3), np.int64)
    V = vtk_to_numpy(poly.GetPoints().GetData()).astype(np.float64)
    conn = vtk_to_numpy(poly.GetPolys().GetConnectivityArray()).astype(np.int64)
    return V, conn.reshape(-1, 3)


def write_ply(
    path: str | Path,
    V: np.ndarray,
    F: np.ndarray,
    vertex_values: dict[str, np.ndarray] | None = None,
) -> None:
    """Write a binary little-endian PLY (float32 vertices, int32 faces), with
    ``vertex_values`` (name -> ``(n_vert,)``) as float vertex properties after x, y, z
    (ParaView shows them; :func:`read_vertex_values` reads one back)."""
    names = list(vertex_values or {})
    rec_v = np.empty(len(V), dtype=[(c, "<f4") for c in ["x", "y", "z"] + names])
    for k, c in enumerate("xyz"):
        rec_v[c] = V[:, k]
    for name in names:
        rec_v[name] = vertex_values[name]
    rec = np.empty(len(F), dtype=[("n", "u1"), ("idx", "<i4", (3,))])
    rec["n"] = 3
    rec["idx"] = F
    header = (
        "ply\nformat binary_little_endian 1.0\n"
        f"element vertex {len(V)}\n"
        + "".join(f"property float {c}\n" for c in ["x", "y", "z"] + names)
        + f"element face {len(F)}\nproperty list uchar int vertex_indices\nend_header\n"
    )
    with open(path, "wb") as fh:
        fh.write(header.encode("ascii"))
        fh.write(rec_v.tobytes())
        fh.write(rec.tobytes())


def read_vertex_values(path: str | Path, name: str) -> np.ndarray | None:
    """The vertex property ``name`` of a .ply mesh file (one per vertex, in the file's
    order), or None for another format or a PLY without it."""
    path = Path(path)
    if path.suffix.lower() != ".ply":
        return None
    head = read_file_start(path, HEADER_PEEK_BYTES)  # most files have none: no reading
    end = head.find(b"end_header")
    if end >= 0 and name.encode() not in head[:end]:
        return None
    try:
        return ply_vertex_property(read_regular_file(path, max_bytes=MAX_MESH_BYTES), name)
    except MeshFormatError as exc:
        raise DatasetError(f"{path}: {exc}") from None
