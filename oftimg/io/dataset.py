"""Reading and validating datasets: one folder per embryo, one mesh file per frame.

Dataset layout::

    DATASET/
      meta.json   optional: {"name", "group", "period_ms", "length_unit", "voxel_size",
                             "inlet"}
      outer/      one mesh file per time frame (required)
      inner/      same number of frames (optional)
      lumen/      same number of frames (optional)

Frames are read lazily, one at a time, and returned as plain arrays
``V (n_vert, 3) float64`` in mm and ``F (n_face, 3) int64``. Nothing in a
dataset folder is ever written to.
"""
from __future__ import annotations

import functools
import json
import re
import warnings
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from ..errors import InputError
from ..mesh.topology import (MeshError, RepairCounts, check_tube, loop_centroid,
                            loop_vector_area, repair)

SURFACES = ("outer", "inner", "lumen")
MESH_SUFFIXES = (".ply", ".obj", ".stl", ".off", ".vtk", ".vtp")
UNIT_TO_MM = {"mm": 1.0, "um": 1e-3}
DEFAULT_FRAME_MS = 2.0
FILES_NAMED = 6     # bad files an error names of a kind (the rest counted)
META_KEYS = {"name": str, "group": str, "period_ms": (int, float),
             "length_unit": str, "voxel_size": list, "inlet": list}


class DatasetError(InputError):
    """Bad input data: the message names the file and the problem."""


class OftimgWarning(UserWarning):
    """Something oftimg repaired or assumed; the run goes on."""


def natural_key(name: str):
    """Sort key that puts ``f2`` before ``f10``."""
    return [int(tok) if tok.isdigit() else tok.lower() for tok in re.split(r"(\d+)", name)]


def list_frames(folder: Path) -> list[Path]:
    """Mesh files of one surface folder in natural order (a broken link too: reading
    it says so, where leaving it out would drop a frame from the time series)."""
    files = [p for p in folder.iterdir()
             if (p.is_file() or p.is_symlink()) and p.suffix.lower() in MESH_SUFFIXES
             and not p.name.startswith(".")]
    return sorted(files, key=lambda p: natural_key(p.name))


# --------------------------------------------------------------------------- files
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


# --------------------------------------------------------------------------- tubes
@dataclass(frozen=True)
class Tube:
    """One frame of one wall: a validated open tube in mm.

    ``V (n_vert, 3) float64`` mm, ``F (n_face, 3) int64`` with outward normals,
    ``inlet`` and ``outlet`` ordered boundary-loop vertex indices (each running
    along its faces' half-edges), ``source`` the file it came from.
    """

    V: np.ndarray
    F: np.ndarray
    inlet: np.ndarray
    outlet: np.ndarray
    source: str = ""


@dataclass(frozen=True)
class Checked:
    """What the checks of :func:`load_tube` found for one unchanged, clean file:
    read again, it needs no repair and at most a reversal of all faces. The
    loops are kept as int32 (a run keeps a record per mesh of every dataset)."""

    size: int
    mtime_ns: int
    reverse: bool
    inlet: np.ndarray
    outlet: np.ndarray


def load_tube(path: str | Path, *, unit_scale: float | tuple = 1.0,
              inlet_point: np.ndarray | None = None, checked: Checked | None = None,
              warn: bool = True) -> Tube:
    """Read, repair and check one frame; pick the inlet loop.

    ``unit_scale`` multiplies the file's coordinates to give mm: one number, or
    one per axis (x, y, z) for a mesh in anisotropic voxel coordinates.
    The inlet is the loop whose centroid is nearest ``inlet_point`` (mm), or
    the loop with the larger enclosed area when no point is given. With
    ``checked`` (from :func:`check_tube_file`) and the file unchanged since
    (size and modification time), the repair and checks are skipped. A repair
    is reported as an :class:`OftimgWarning` naming the file, unless ``warn``
    is False (the validation has reported it).
    """
    if checked is not None:
        try:
            st = Path(path).stat()
        except OSError:  # gone since: the full read says so, naming the file
            st = None
        if st is not None and (st.st_size, st.st_mtime_ns) == (checked.size, checked.mtime_ns):
            V, F = read_mesh_file(path)
            return Tube(V=V * np.asarray(unit_scale), F=F[:, ::-1].copy() if checked.reverse else F,
                        inlet=checked.inlet.astype(np.int64),
                        outlet=checked.outlet.astype(np.int64), source=str(path))
    tube, _, repairs = check_tube_file(path, unit_scale=unit_scale, inlet_point=inlet_point)
    if warn and repairs:
        warnings.warn(f"{path}: {repairs.describe()}", OftimgWarning, stacklevel=2)
    return tube


def check_tube_file(path: str | Path, *, unit_scale: float | tuple = 1.0,
                    inlet_point: np.ndarray | None = None
                    ) -> tuple[Tube, Checked | None, RepairCounts]:
    """:func:`load_tube` with all checks and no warning: the tube, a :class:`Checked`
    record when the file needed no repair and no per-face reorientation (else
    None), and what was repaired."""
    st = Path(path).stat() if Path(path).is_file() else None
    V, F = read_mesh_file(path)
    V = V * np.asarray(unit_scale)
    if not np.all(np.isfinite(V)):
        bad = int(np.count_nonzero(~np.isfinite(V).all(axis=1)))
        raise DatasetError(f"{path}: {bad} vertices have NaN or infinite coordinates")
    V, F, counts = repair(V, F)
    try:
        topo = check_tube(V, F, mend=True)
    except MeshError as exc:
        raise DatasetError(f"{path}: {exc}") from None
    if Path(path).suffix.lower() == ".stl":  # STL stores every triangle's corners apart
        counts = replace(counts, merged_vertices=0)
    # faces against the rest (all of them reversed is no repair: the reading order)
    kept = len(F) - topo.island_faces
    against = min(topo.flipped_faces, kept - topo.flipped_faces)
    counts = replace(counts, flipped_faces=against, islands=topo.islands,
                     island_faces=topo.island_faces, holes=topo.holes, hole_edges=topo.hole_edges)
    if topo.V is not None:
        V = topo.V
    a, b = topo.loops
    if inlet_point is None:
        inlet_first = np.linalg.norm(loop_vector_area(V[a])) >= np.linalg.norm(loop_vector_area(V[b]))
    else:
        inlet_first = (np.linalg.norm(loop_centroid(V[a]) - inlet_point)
                       <= np.linalg.norm(loop_centroid(V[b]) - inlet_point))
    inlet, outlet = (a, b) if inlet_first else (b, a)
    tube = Tube(V=V, F=topo.F, inlet=inlet, outlet=outlet, source=str(path))
    record = None
    if not counts and st is not None:
        record = Checked(st.st_size, st.st_mtime_ns, topo.flipped_faces == len(F),
                         inlet.astype(np.int32), outlet.astype(np.int32))
    return tube, record, counts


# --------------------------------------------------------------------------- datasets
@dataclass(frozen=True)
class Meta:
    """Dataset metadata after defaults and unit conversion."""

    name: str
    group: str
    period_ms: float
    length_unit: str
    inlet_mm: tuple[float, float, float] | None
    period_assumed: bool = False
    voxel_size: tuple[float, float, float] | None = None   # in length_unit, x y z

    @property
    def scale_to_mm(self) -> float | tuple[float, float, float]:
        """What the files' coordinates are multiplied by to give mm: one number, or
        one per axis for meshes in (anisotropic) voxel coordinates."""
        return _scale_to_mm(self.length_unit, self.voxel_size)


def _scale_to_mm(unit: str, voxel_size) -> float | tuple[float, float, float]:
    """:attr:`Meta.scale_to_mm` of a length unit and a voxel size (or None)."""
    to_mm = UNIT_TO_MM[unit]
    return to_mm if voxel_size is None else tuple(to_mm * d for d in voxel_size)


def read_meta(folder: Path, n_frames: int) -> Meta:
    """Parse ``meta.json`` (optional) and fill in the documented defaults."""
    path = folder / "meta.json"
    raw: dict = {}
    if path.exists():
        try:
            raw = json.loads(path.read_text())
        except (json.JSONDecodeError, UnicodeDecodeError) as exc:
            raise DatasetError(f"{path}: not valid JSON ({exc})") from None
        if not isinstance(raw, dict):
            raise DatasetError(f"{path}: expected a JSON object, found {type(raw).__name__}")
        for key, value in raw.items():
            if key not in META_KEYS:
                raise DatasetError(f"{path}: unknown key {key!r}; "
                                   f"allowed: {', '.join(META_KEYS)}")
            if not isinstance(value, META_KEYS[key]) or isinstance(value, bool):
                raise DatasetError(f"{path}: {key!r} has the wrong type "
                                   f"({type(value).__name__})")
    unit = raw.get("length_unit", "mm")
    if unit not in UNIT_TO_MM:
        raise DatasetError(f"{path}: length_unit must be 'mm' or 'um', found {unit!r}")
    period_assumed = "period_ms" not in raw
    period = float(raw.get("period_ms", n_frames * DEFAULT_FRAME_MS))
    if not np.isfinite(period) or period <= 0:
        raise DatasetError(f"{path}: period_ms must be a positive number, found {period}")
    voxel = raw.get("voxel_size")
    if voxel is not None:
        if (len(voxel) != 3 or not all(isinstance(x, (int, float)) and not isinstance(x, bool)
                                       for x in voxel)
                or not all(np.isfinite(x) and x > 0 for x in voxel)):
            raise DatasetError(f"{path}: voxel_size must be three positive numbers [dx, dy, dz] "
                               f"in length_unit (the files' coordinates are voxel indices), "
                               f"found {voxel!r}")
        voxel = tuple(float(x) for x in voxel)
    inlet = raw.get("inlet")
    if inlet is not None:
        if len(inlet) != 3 or not all(isinstance(x, (int, float)) for x in inlet):
            raise DatasetError(f"{path}: inlet must be [x, y, z], found {inlet!r}")
        scale = np.broadcast_to(_scale_to_mm(unit, voxel), 3)   # in the files' coordinates
        inlet = tuple(float(x) * float(k) for x, k in zip(inlet, scale))
    name = str(raw.get("name", folder.name))
    if name in ("", ".", "..") or any(c in name for c in "/\\\0"):
        raise DatasetError(f"{path}: name {name!r} cannot be a folder name (the dataset's "
                           "results are written to a folder of that name)")
    return Meta(name=name, group=str(raw.get("group", "unknown")),
                period_ms=period, length_unit=unit, inlet_mm=inlet,
                period_assumed=period_assumed, voxel_size=voxel)


@dataclass(frozen=True)
class Frame:
    """The files of one time frame: what a worker needs to read it (small to send)."""

    files: dict[str, str]
    unit_scale: float | tuple[float, float, float]   # file coordinates to mm (per axis)
    inlet_mm: tuple[float, float, float]
    checked: dict = field(default_factory=dict)  # surface -> Checked, from validation
    validated: bool = False                      # repairs reported by the validation

    @property
    def surfaces(self) -> tuple[str, ...]:
        return tuple(s for s in SURFACES if s in self.files)

    def tube(self, surface: str) -> Tube:
        """This frame's ``surface`` as a validated :class:`Tube` in mm."""
        return load_tube(self.files[surface], unit_scale=self.unit_scale,
                         inlet_point=np.asarray(self.inlet_mm),
                         checked=self.checked.get(surface), warn=not self.validated)


@dataclass
class Dataset:
    """A dataset folder: metadata and the frame files of each surface.

    Frames are read on demand with :meth:`tube`; nothing is cached.
    """

    path: Path
    meta: Meta
    frames: dict[str, list[Path]]
    inlet_mm: np.ndarray = field(repr=False)
    checked: dict = field(default_factory=dict, repr=False)  # (surface, t) -> Checked
    validated: bool = False                 # set by validate_dataset

    @property
    def n_frames(self) -> int:
        return len(self.frames["outer"])

    @property
    def surfaces(self) -> tuple[str, ...]:
        return tuple(s for s in SURFACES if s in self.frames)

    @property
    def unit_scale(self) -> float | tuple[float, float, float]:
        return self.meta.scale_to_mm

    def frame(self, t: int) -> Frame:
        """The files of frame ``t``, as sent to worker processes."""
        return Frame({s: str(files[t]) for s, files in self.frames.items()}, self.unit_scale,
                     tuple(float(x) for x in self.inlet_mm),
                     {s: self.checked[s, t] for s in self.frames if (s, t) in self.checked},
                     self.validated)

    def tube(self, surface: str, t: int) -> Tube:
        """Frame ``t`` of ``surface`` as a validated :class:`Tube` in mm."""
        if surface not in self.frames:
            raise KeyError(f"{self.path}: has no {surface}/ surface")
        return self.frame(t).tube(surface)

    def iter_tubes(self, surface: str):
        """Every frame of ``surface`` in turn as a validated :class:`Tube` (mm), one
        frame read at a time: a long series never sits in memory whole."""
        for t in range(self.n_frames):
            yield self.tube(surface, t)


def _reference_inlet(frames: list[Path], unit_scale, n_probe: int = 5) -> np.ndarray:
    """Centroid (mm) of the inlet loop, chosen once for the whole series.

    The loops of a few evenly spaced frames are matched to the first frame's
    loops by centroid; the end whose enclosed area summed over these frames is
    larger is the inlet (the OFT tapers towards the outlet). A frame that cannot be
    read is passed over for the next one (the validation names every such frame);
    when none can, the first one's error is raised.
    """
    idx = np.unique(np.linspace(0, len(frames) - 1, min(n_probe, len(frames))).astype(int))
    order = [*idx, *sorted(set(range(len(frames))) - set(idx))]
    ref, refused, n_read = None, [], 0
    area = np.zeros(2)
    for i in order:
        if n_read == len(idx):
            break
        try:
            tube = load_tube(frames[i], unit_scale=unit_scale, warn=False)  # validation will
        except DatasetError as exc:
            refused.append(exc)
            continue
        n_read += 1
        loops = (tube.inlet, tube.outlet)
        cents = [loop_centroid(tube.V[lp]) for lp in loops]
        areas = [np.linalg.norm(loop_vector_area(tube.V[lp])) for lp in loops]
        if ref is None:
            ref = cents
        d_same = np.linalg.norm(cents[0] - ref[0]) + np.linalg.norm(cents[1] - ref[1])
        d_swap = np.linalg.norm(cents[0] - ref[1]) + np.linalg.norm(cents[1] - ref[0])
        if d_swap < d_same:
            areas = areas[::-1]
        area += areas
    if ref is None:
        refused[0].add_note(f"no frame of {frames[0].parent} can be read as a tube "
                            f"(all {len(frames)} were tried)")
        raise refused[0]
    return np.asarray(ref[0] if area[0] >= area[1] else ref[1])


def is_dataset(path: Path) -> bool:
    return (path / "outer").is_dir()


def load_dataset(path: str | Path) -> Dataset:
    """Open a dataset folder, check its layout and metadata, choose the inlet.

    Reads only a few outer frames (to choose the inlet end); the rest stay on
    disk until asked for.
    """
    path = Path(path)
    if not path.exists():
        raise DatasetError(f"{path}: folder not found")
    if not path.is_dir():
        raise DatasetError(f"{path}: not a folder")
    misnamed = sorted(p for p in path.iterdir()         # an Inner/ was left out, unread
                      if p.is_dir() and p.name.lower() in SURFACES and p.name not in SURFACES)
    if misnamed:
        raise DatasetError(f"{misnamed[0]}: surface folders are named in lower case "
                           f"({', '.join(SURFACES)}); rename it {misnamed[0].name.lower()}/")
    if not is_dataset(path):
        raise DatasetError(f"{path}: no outer/ folder; a dataset has outer/ "
                           "(and optionally inner/, lumen/) with one mesh file per frame")
    frames = {}
    for surface in SURFACES:
        folder = path / surface
        if folder.is_dir():
            files = list_frames(folder)
            if not files:
                raise DatasetError(f"{folder}: no mesh files ({', '.join(MESH_SUFFIXES)})")
            broken = [f for f in files if not f.exists()]     # a frame moved away
            if broken:
                raise DatasetError(f"{broken[0]}: a broken link" + (
                    f" (and {len(broken) - 1} more in {folder}: "
                    f"{', '.join(f.name for f in broken[1:FILES_NAMED + 1])}"
                    f"{', ...' if len(broken) > FILES_NAMED + 1 else ''})"
                    if len(broken) > 1 else ""))
            frames[surface] = files
    n = len(frames["outer"])
    for surface, files in frames.items():
        if len(files) != n:
            raise DatasetError(f"{path / surface}: {len(files)} frames, but outer/ has {n}")
    meta = read_meta(path, n)
    if meta.period_assumed:
        warnings.warn(f"{path / 'meta.json'}: no period_ms; assuming {DEFAULT_FRAME_MS} ms "
                      f"per frame ({meta.period_ms:g} ms)", OftimgWarning, stacklevel=2)
    if meta.inlet_mm is not None:
        inlet = np.asarray(meta.inlet_mm)
    else:
        inlet = _reference_inlet(frames["outer"], meta.scale_to_mm)
    return Dataset(path=path, meta=meta, frames=frames, inlet_mm=inlet)


def find_datasets(path: str | Path) -> list[Path]:
    """The dataset folders at ``path``: itself, or its sub-folders (a cohort)."""
    path = Path(path)
    if not path.is_dir():
        raise DatasetError(f"{path}: {'not a folder' if path.exists() else 'folder not found'}")
    if is_dataset(path):
        return [path]
    subs = sorted((p for p in path.iterdir() if p.is_dir() and is_dataset(p)),
                  key=lambda p: natural_key(p.name))
    if not subs:
        raise DatasetError(f"{path}: neither a dataset (no outer/ folder) nor a cohort "
                           "(no sub-folder has outer/)")
    return subs


def frame_facts(frame: Frame, surface: str
                ) -> tuple[tuple[int, int, float, float], Checked | None, str]:
    """Vertices, faces, inlet and outlet loop areas (mm^2) of one frame, checked in
    full; its :class:`Checked` record; what was repaired ("" for nothing)."""
    tube, record, repairs = check_tube_file(frame.files[surface], unit_scale=frame.unit_scale,
                                            inlet_point=np.asarray(frame.inlet_mm))
    facts = (len(tube.V), len(tube.F), float(np.linalg.norm(loop_vector_area(tube.V[tube.inlet]))),
             float(np.linalg.norm(loop_vector_area(tube.V[tube.outlet]))))
    return facts, record, repairs.describe()


def _facts_or_problem(frame: Frame, surface: str):
    """:func:`frame_facts`, or the :class:`DatasetError` that refuses the frame's
    mesh, returned: one pass finds every bad frame."""
    try:
        return frame_facts(frame, surface)
    except DatasetError as exc:
        return exc


def _every_bad_frame(ds: Dataset, problems: list[tuple[str, DatasetError]]) -> DatasetError:
    """One error for the meshes that cannot be used, ``problems`` (file, its error)
    in surface and time order: the first one's message, with how many more, and a
    note per kind of problem (the same message but for its numbers) giving its
    first file's message and naming the others, relative to the dataset."""
    if len(problems) == 1:
        error = problems[0][1]
        error.problems = [(problems[0][0], str(error))]
        return error
    kinds: dict[str, list[tuple[str, str]]] = {}
    for file, exc in problems:
        problem = str(exc).removeprefix(f"{file}: ")
        kinds.setdefault(re.sub(r"\d+", "#", problem), []).append(
            (Path(file).relative_to(ds.path).as_posix(), problem))
    error = DatasetError(f"{problems[0][1]} (and {len(problems) - 1} more of the dataset's "
                         f"{ds.n_frames * len(ds.surfaces)} meshes cannot be used: below)")
    for k, members in enumerate(kinds.values()):
        others = [file for file, _ in members[1:]]
        named = ", ".join(others[:FILES_NAMED]) + (f", ... {others[-1]}"
                                                   if len(others) > FILES_NAMED else "")
        same = (f"the same problem in {len(others)} more mesh{'es' if len(others) > 1 else ''}: "
                f"{named}") if others else ""
        if k == 0 and not others:       # the first line names it
            continue
        error.add_note(same if k == 0 else f"{members[0][0]}: {members[0][1]}"
                       + (f"; {same}" if same else ""))
    error.problems = [(file, str(exc)) for file, exc in problems]
    return error


def validate_dataset(ds: Dataset, *, executor=None, progress=None) -> dict:
    """Read every frame of every surface once; return a per-surface report.

    Raises one :class:`DatasetError` for every bad frame: the first one's message
    names its file, the notes the others by kind of problem (its ``problems``:
    each file and its message), so that one pass finds them all. With
    an ``executor`` (``concurrent.futures``), frames are checked in its workers.
    Remembers in ``ds.checked`` which files needed no repair, so that the
    analysis reads them again without the checks while they are unchanged.
    Repairs are listed per surface in the report (file name: what) and in one
    warning per surface; reading the frames again does not repeat them.
    ``progress()`` is called after each mesh.
    """
    report = {"name": ds.meta.name, "path": str(ds.path), "n_frames": ds.n_frames,
              "inlet_mm": [round(float(x), 6) for x in ds.inlet_mm],
              "inlet_from": "meta.json" if ds.meta.inlet_mm is not None else "larger end loop",
              "surfaces": {}}
    problems = []
    for surface in ds.surfaces:
        frames = [ds.frame(t) for t in range(ds.n_frames)]
        checks = (map(_facts_or_problem, frames, [surface] * ds.n_frames) if executor is None
                  else executor.map(_facts_or_problem, frames, [surface] * ds.n_frames))
        results = []
        for result in checks:
            results.append(result)
            if progress:
                progress()
        bad = [(ds.frames[surface][t], r) for t, r in enumerate(results)
               if isinstance(r, DatasetError)]
        if bad:
            problems += [(str(file), exc) for file, exc in bad]
            continue
        for t, (_, record, _) in enumerate(results):
            if record is not None:
                ds.checked[surface, t] = record
        repairs = {ds.frames[surface][t].name: what
                   for t, (_, _, what) in enumerate(results) if what}
        if repairs:
            listed = "; ".join(f"{name}: {what}" for name, what in list(repairs.items())[:3])
            more = (f"; {len(repairs) - 3} more, listed in the validation report"
                    if len(repairs) > 3 else "")
            warnings.warn(f"{ds.path / surface}: repaired {len(repairs)} of {ds.n_frames} "
                          f"frames ({listed}{more})", OftimgWarning, stacklevel=2)
        nv, nf, inlet_area, outlet_area = (list(x) for x in zip(*(f for f, _, _ in results)))
        report["surfaces"][surface] = {
            "frames": len(nv), "vertices_min": int(min(nv)), "vertices_max": int(max(nv)),
            "faces_min": int(min(nf)), "faces_max": int(max(nf)), "boundary_loops": 2,
            "inlet_area_mm2_median": float(np.median(inlet_area)),
            "outlet_area_mm2_median": float(np.median(outlet_area)),
            "repairs": repairs,
        }
    if problems:
        raise _every_bad_frame(ds, problems)
    ds.validated = True
    return report
