"""Mesh files read and written: PLY, OBJ, STL, OFF, VTK and VTP in, binary PLY out.

A file is read as it is, ``V (n_vert, 3) float64`` in the file's units and
``F (n_face, 3) int64``; a file that is missing, empty, cut short or not made
of triangles raises :class:`~oftimg.errors.DatasetError` naming it. The few
formats oftimg writes itself are read by a reader of its own, several times
faster than open3d's; everything else goes through open3d.
"""
from __future__ import annotations

import functools
import re
from pathlib import Path

import numpy as np

from ..errors import DatasetError

MESH_SUFFIXES = (".ply", ".obj", ".stl", ".off", ".vtk", ".vtp")

def read_mesh_file(path: str | Path) -> tuple[np.ndarray, np.ndarray]:
    """Read a triangle mesh file as ``(V float64, F int64)``, untouched.

    Raises :class:`DatasetError` naming the file when it is missing, empty,
    unreadable or has no triangles (open3d only warns about these).
    """
    path = Path(path)
    if not path.is_file():
        broken = path.is_symlink()
        raise DatasetError(f"{path}: {'a broken link' if broken else 'file not found'}")
    if path.stat().st_size == 0:
        raise DatasetError(f"{path}: file is empty")
    suffix = path.suffix.lower()
    if suffix == ".vtp":
        V, F = _read_vtp(path)
    elif suffix == ".vtk":
        import meshio

        try:
            m = meshio.read(path)
        except (Exception, SystemExit) as exc:  # meshio raises many types for bad files,
            # and calls sys.exit(1) on a truncated one (having printed why)
            why = f" ({exc})" if not isinstance(exc, SystemExit) else " (truncated or damaged)"
            raise DatasetError(f"{path}: cannot be read as {suffix}{why}") from None
        tris = [c.data for c in m.cells if c.type == "triangle"]
        # other faces, left out, would leave holes: a misleading topology error later
        others = sum(len(c.data) for c in m.cells
                     if c.type == "quad" or c.type.startswith("polygon"))
        if others:
            raise _not_triangles(path, others)
        V = np.asarray(m.points, dtype=np.float64)
        F = np.concatenate(tris).astype(np.int64) if tris else np.zeros((0, 3), np.int64)
    elif suffix == ".ply" and (simple := _read_simple_ply(path)) is not None:
        V, F = simple
    elif suffix in MESH_SUFFIXES:
        if suffix == ".ply":
            _check_binary_ply_size(path)
        o3d = _open3d()
        mesh = o3d.io.read_triangle_mesh(str(path), enable_post_processing=False,
                                         print_progress=False)
        V = np.asarray(mesh.vertices, dtype=np.float64)
        F = np.asarray(mesh.triangles, dtype=np.int64)
        _check_declared_counts(path, len(V), len(F))
    else:
        raise DatasetError(f"{path}: unsupported mesh format {suffix!r}; "
                           f"use one of {', '.join(MESH_SUFFIXES)}")
    if len(F) == 0:
        raise DatasetError(f"{path}: no triangles could be read (broken or not a triangle mesh)")
    if V.shape[1:] != (3,) or F.shape[1:] != (3,):
        raise DatasetError(f"{path}: expected 3-D vertices and triangles, "
                           f"found vertices {V.shape} and faces {F.shape}")
    if F.min() < 0 or F.max() >= len(V):
        raise DatasetError(f"{path}: face indices out of range 0..{len(V) - 1}")
    return V, F


@functools.cache
def _open3d():
    """open3d, with its own warnings off: it prints them to stdout (into `oftimg
    validate --json`), and every problem they name stops the read with a message
    of oftimg's that names the file."""
    import open3d as o3d

    o3d.utility.set_verbosity_level(o3d.utility.VerbosityLevel.Error)
    return o3d


_OBJ_FACE_LINE = re.compile(rb"\n[ \t]*f[ \t]")   # 4x faster than a (?m)^ pattern
# a face line of one or two corners: what cutting a file inside its last face leaves
_OBJ_SHORT_FACE = re.compile(rb"\n[ \t]*f[ \t]+[^ \t\r\n]+(?:[ \t]+[^ \t\r\n]+)?[ \t]*(?:\r?\n|$)")


def declared_counts(path: Path) -> tuple[int | None, int | None]:
    """Vertices and faces a .ply, .off, .obj or .stl file says it holds, from its
    header or its lines (None where the format does not say or cannot be parsed).

    open3d reads as much of a truncated file as it can and only prints a
    warning; it leaves out .obj faces that are not triangles or whose line
    begins with a blank, and stops at the first polygon it cannot split.
    Comparing with these counts catches all three (except an .obj cut exactly
    between two lines: nothing in it says so). Raises :class:`DatasetError` for an
    .obj face line of fewer than 3 corners (a file cut inside its last face).
    """
    suffix = path.suffix.lower()
    if suffix == ".ply":
        counts = {name: count for name, count, _ in _ply_header(path)[2]}
        return counts.get("vertex"), counts.get("face")
    if suffix == ".off":
        with open(path, "rb") as fh:
            head = fh.read(4096)
        tokens = re.sub(rb"#[^\n]*", b"", head).split()
        if len(tokens) >= 4 and tokens[0] in (b"OFF", b"COFF", b"NOFF", b"CNOFF") \
                and all(t.isdigit() for t in tokens[1:3]):
            return int(tokens[1]), int(tokens[2])
        return None, None
    if suffix == ".obj":   # the vertex count is open3d's own (one per index combination)
        data = b"\n" + path.read_bytes()
        short = len(_OBJ_SHORT_FACE.findall(data))
        if short:  # open3d 0.18 completes such a face with an index from nowhere
            raise DatasetError(f"{path}: {short} face lines with fewer than 3 corners "
                               "(the file is truncated or damaged)")
        return None, len(_OBJ_FACE_LINE.findall(data))
    if suffix == ".stl":
        data = path.read_bytes()
        n_binary = int.from_bytes(data[80:84], "little") if len(data) >= 84 else None
        if n_binary is not None and len(data) == 84 + 50 * n_binary:
            return None, n_binary
        text = data.lower()
        # ascii, unless bytes 80-84 hold a binary count (below 2^24: a zero byte)
        if text.lstrip()[:5] == b"solid" and b"\0" not in data[80:84]:
            # the facets begun, between the first line (the solid's name) and endsolid
            start = text.find(b"\n")
            stop = text.rfind(b"endsolid")
            body = text[start:stop if stop > start else len(text)]
            return None, body.count(b"facet") - body.count(b"endfacet")
        return None, n_binary
    return None, None


_PLY_TYPES = {"char": "i1", "uchar": "u1", "int8": "i1", "uint8": "u1", "short": "i2",
              "ushort": "u2", "int16": "i2", "uint16": "u2", "int": "i4", "uint": "u4",
              "int32": "i4", "uint32": "u4", "float": "f4", "float32": "f4", "double": "f8",
              "float64": "f8"}
_PLY_SIZES = {name: int(kind[1]) for name, kind in _PLY_TYPES.items()}


def _ply_header(path: Path) -> tuple[bool, int, list[tuple[str, int, int | None]]]:
    """``(binary, data_start, elements)`` of a .ply: whether its data are binary, the
    byte where they begin, and per element its name, count and least bytes per record
    (a face's list taken as a triangle; None for a property type not known here)."""
    with open(path, "rb") as fh:
        head = fh.read(65536)
    end = head.find(b"end_header")
    if end < 0:
        end = len(head)
    data_start = head.find(b"\n", end) + 1 or len(head)
    elements = []
    for line in head[:end].decode("ascii", "replace").splitlines():
        words = line.split()
        if words[:1] == ["element"] and len(words) == 3 and words[2].isdigit():
            elements.append([words[1], int(words[2]), 0])
        elif words[:1] == ["property"] and elements and elements[-1][2] is not None:
            item = elements[-1]
            if len(words) == 5 and words[1] == "list" and words[2] in _PLY_SIZES \
                    and words[3] in _PLY_SIZES:
                items = 3 if item[0] == "face" else 0
                item[2] += _PLY_SIZES[words[2]] + items * _PLY_SIZES[words[3]]
            elif len(words) == 3 and words[1] in _PLY_SIZES:
                item[2] += _PLY_SIZES[words[1]]
            else:
                item[2] = None
    binary = head.startswith(b"ply") and b"format binary" in head[:end]
    return binary, data_start, [tuple(e) for e in elements]


def _read_simple_ply(path: Path) -> tuple[np.ndarray, np.ndarray] | None:
    """``(V float64, F int64)`` of a little-endian binary .ply that holds vertices (x,
    y, z among scalar properties) and triangles (one list of integers) and nothing
    else, read with NumPy: 7-15x faster than open3d, which a process then need not
    load (0.7 s, 0.2 GB). None for any other .ply, or one whose size or face lists
    do not match that exactly (open3d reads it, and the checks say what is wrong)."""
    data = path.read_bytes()
    end = data.find(b"end_header")
    start = data.find(b"\n", end) + 1 if end >= 0 else 0
    if not data.startswith(b"ply") or start == 0:
        return None
    lines = [line.split() for line in data[:end].decode("ascii", "replace").splitlines()]
    if ["format", "binary_little_endian", "1.0"] not in lines:
        return None
    elements = []
    for words in lines:
        if words[:1] == ["element"] and len(words) == 3 and words[2].isdigit():
            elements.append((words[1], int(words[2]), []))
        elif words[:1] in (["element"], ["property"]):
            if not elements or words[0] == "element":
                return None
            elements[-1][2].append(words[1:])
    if [name for name, _, _ in elements] != ["vertex", "face"]:
        return None
    (_, n_vert, vertex_props), (_, n_face, face_props) = elements
    names = [p[-1] for p in vertex_props]
    if (any(len(p) != 2 or p[0] not in _PLY_TYPES for p in vertex_props)
            or len(set(names)) != len(names) or not {"x", "y", "z"} <= set(names)):
        return None
    if len(face_props) != 1 or len(face_props[0]) != 4 or face_props[0][0] != "list" \
            or any(_PLY_TYPES.get(t, "f")[0] == "f" for t in face_props[0][1:3]):
        return None
    vertex = np.dtype([(name, "<" + _PLY_TYPES[kind]) for kind, name in vertex_props])
    _, count, index, _ = face_props[0]
    face = np.dtype([("n", "<" + _PLY_TYPES[count]), ("idx", "<" + _PLY_TYPES[index], (3,))])
    if len(data) != start + n_vert * vertex.itemsize + n_face * face.itemsize:
        return None                     # other faces than triangles, or a damaged file
    faces = np.frombuffer(data, face, n_face, start + n_vert * vertex.itemsize)
    if np.any(faces["n"] != 3):
        return None
    verts = np.frombuffer(data, vertex, n_vert, start)
    V = np.column_stack([verts["x"], verts["y"], verts["z"]]).astype(np.float64)
    return V, faces["idx"].astype(np.int64)


def _check_binary_ply_size(path: Path) -> None:
    """Refuse a binary .ply shorter than its header's vertices and (at least
    triangular) faces need, saying among which it ends: open3d reads a file cut
    among its vertices as all the vertices (the rest zeros) and no faces."""
    binary, data_start, elements = _ply_header(path)
    if not binary:
        return
    have = path.stat().st_size - data_start
    offset = 0
    for name, count, size in elements:
        if size is None:
            return                      # a property type not known here: open3d's word
        if name in ("vertex", "face") and have < offset + count * size:
            done = max(0, have - offset) // size if size else 0
            what = "faces" if name == "face" else "vertices"
            raise DatasetError(f"{path}: the file is truncated: it ends among its {what}, "
                               f"with {done} of the {count} {what} its header lists whole")
        offset += count * size


def _check_declared_counts(path: Path, n_vertices: int, n_faces: int) -> None:
    """Refuse a file of which open3d read another number of vertices or faces
    than the file declares, naming the file (see :func:`declared_counts`)."""
    want_v, want_f = declared_counts(path)
    if want_v is not None and n_vertices != want_v:
        raise DatasetError(f"{path}: lists {want_v} vertices but {n_vertices} could be read "
                           "(the file is truncated or damaged)")
    if want_f is not None and n_faces != want_f:
        blanks = ", or face lines that begin with blanks" if path.suffix.lower() == ".obj" else ""
        raise DatasetError(f"{path}: lists {want_f} faces but {n_faces} triangles could be "
                           f"read: the file is truncated or damaged, or has faces that are not "
                           f"triangles{blanks} (oftimg reads triangle meshes: triangulate it "
                           "first)")


def _not_triangles(path: Path, count: int) -> DatasetError:
    return DatasetError(f"{path}: {count} faces are not triangles (quads or polygons); "
                        "oftimg reads triangle meshes: triangulate it first")


def _read_vtp(path: Path) -> tuple[np.ndarray, np.ndarray]:
    """VTK XML PolyData through the vtk package (meshio does not read .vtp)."""
    try:
        from vtkmodules.util.numpy_support import vtk_to_numpy
        from vtkmodules.vtkFiltersCore import vtkTriangleFilter
        from vtkmodules.vtkIOXML import vtkXMLPolyDataReader
    except ImportError:
        raise DatasetError(f"{path}: reading .vtp needs the vtk package "
                           "(pip install 'oftimg[vtk]')") from None
    reader = vtkXMLPolyDataReader()
    if not reader.CanReadFile(str(path)):
        raise DatasetError(f"{path}: cannot be read as VTK XML PolyData")
    reader.SetFileName(str(path))
    reader.Update()
    polys = reader.GetOutput().GetPolys()
    others = int(np.count_nonzero(np.diff(vtk_to_numpy(polys.GetOffsetsArray())) != 3)
                 if polys is not None and polys.GetNumberOfCells() else 0)
    if others:
        raise _not_triangles(path, others)
    tri = vtkTriangleFilter()                   # triangle strips, if any, to triangles
    tri.SetInputConnection(reader.GetOutputPort())
    tri.Update()
    poly = tri.GetOutput()
    if poly.GetNumberOfPoints() == 0 or poly.GetNumberOfPolys() == 0:
        return np.zeros((0, 3)), np.zeros((0, 3), np.int64)
    V = vtk_to_numpy(poly.GetPoints().GetData()).astype(np.float64)
    conn = vtk_to_numpy(poly.GetPolys().GetConnectivityArray()).astype(np.int64)
    return V, conn.reshape(-1, 3)


def write_ply(path: str | Path, V: np.ndarray, F: np.ndarray) -> None:
    """Write a binary little-endian PLY (float32 vertices, int32 faces)."""
    V = np.ascontiguousarray(V, dtype="<f4")
    rec = np.empty(len(F), dtype=[("n", "u1"), ("idx", "<i4", (3,))])
    rec["n"] = 3
    rec["idx"] = F
    header = ("ply\nformat binary_little_endian 1.0\n"
              f"element vertex {len(V)}\nproperty float x\nproperty float y\nproperty float z\n"
              f"element face {len(F)}\nproperty list uchar int vertex_indices\nend_header\n")
    with open(path, "wb") as fh:
        fh.write(header.encode("ascii"))
        fh.write(V.tobytes())
        fh.write(rec.tobytes())
