"""Triangle mesh formats parsed from their bytes with NumPy: PLY (ASCII and binary,
either byte order), OBJ, STL (ASCII and binary), OFF, and legacy VTK (POLYDATA and
UNSTRUCTURED_GRID, ASCII and binary).

Each parser takes a file's whole content and returns ``V (n_vert, 3) float64`` and
``F (n_face, 3) int64`` as written, or raises :class:`MeshFormatError` saying what
is wrong in words (never the file's own bytes, which may be anything). Every count
a header gives is checked against the bytes that are there before anything is
allocated, and a file must hold exactly what it declares: a lying header is an
error, never a mesh read short. Why our own: open3d's readers crash the process
(SIGSEGV) on damaged PLY files and read short ones without an error, and meshio
reads no legacy VTK POLYDATA.
"""

from __future__ import annotations

import re

import numpy as np

__all__ = [
    "MeshFormatError",
    "PARSERS",
    "not_triangles",
    "parse_ply",
    "parse_obj",
    "parse_stl",
    "parse_off",
    "parse_vtk",
    "ply_vertex_property",
]

MAX_COUNT = 2**31 - 1  # int32 indices: a count beyond is a damaged header

PLY_TYPES = {
    "char": "i1",
    "uchar": "u1",
    "int8": "i1",
    "uint8": "u1",
    "short": "i2",
    "ushort": "u2",
    "int16": "i2",
    "uint16": "u2",
    "int": "i4",
    "uint": "u4",
    "int32": "i4",
    "uint32": "u4",
    "float": "f4",
    "float32": "f4",
    "double": "f8",
    "float64": "f8",
}
VTK_TYPES = {
    "float": "f4",
    "double": "f8",
    "int": "i4",
    "unsigned_int": "u4",
    "long": "i8",
    "unsigned_long": "u8",
    "short": "i2",
    "unsigned_short": "u2",
    "char": "i1",
    "unsigned_char": "u1",
    "vtktypeint64": "i8",
    "vtktypeint32": "i4",
    "vtkidtype": "i4",
}  # VTK's legacy writer stores vtkIdType as 32 bits
VTK_TRIANGLE, VTK_POLYGON, VTK_QUAD = 5, 7, 9

_NOT_NUMERIC = re.compile(rb"[^0-9eE+\-.\s]")  # hex floats, nan, inf, words
_NOT_INTEGER = re.compile(rb"[^0-9+\-\s]")


class MeshFormatError(ValueError):
    """What is wrong with a mesh file's content, in words."""


def not_triangles(count: int) -> MeshFormatError:
    """The error for ``count`` faces of more than three corners (never split: a
    triangulation oftimg chose would change the tube's shape unseen)."""
    return MeshFormatError(
        f"{count} faces are not triangles (quads or polygons); oftimg reads "
        "triangle meshes: triangulate it first"
    )


def _truncated(where: str) -> MeshFormatError:
    return MeshFormatError(
        f"the file is truncated (or a count in its header is wrong): it ends {where}"
    )


def _count(word: bytes | str, what: str) -> int:
    """A header's count, a whole number within int32."""
    text = word.decode("ascii", "replace") if isinstance(word, bytes) else word
    if not text.isdigit() or int(text) > MAX_COUNT:
        raise MeshFormatError(
            f"its header gives {what} a count that is not a whole number from 0 to {MAX_COUNT}"
        )
    return int(text)


def _floats(text: bytes, n: int, what: str) -> np.ndarray:
    """``n`` decimal numbers from ASCII ``text`` (no hexadecimal, nan or inf)."""
    if _NOT_NUMERIC.search(text):
        raise MeshFormatError(f"its {what} hold something that is not a decimal number")
    tokens = text.split()
    if len(tokens) != n:
        raise MeshFormatError(f"its {what} hold {len(tokens)} numbers where {n} belong")
    try:
        return np.array(tokens, dtype=np.float64) if n else np.zeros(0)
    except ValueError:
        raise MeshFormatError(f"its {what} hold something that is not a decimal number") from None


def _ints(tokens: list[bytes], what: str) -> np.ndarray:
    """Whole numbers from ASCII tokens (int64)."""
    if _NOT_INTEGER.search(b" ".join(tokens)):
        raise MeshFormatError(f"its {what} hold something that is not a whole number")
    try:
        values = np.array(tokens, dtype=np.int64) if tokens else np.zeros(0, np.int64)
    except (ValueError, OverflowError):
        raise MeshFormatError(f"its {what} hold something that is not a whole number") from None
    return values


def _check_faces(F: np.ndarray, n_vert: int) -> np.ndarray:
    if len(F) and (F.min() < 0 or F.max() >= n_vert):
        raise MeshFormatError(f"face indices out of range 0..{n_vert - 1}")
    return F.astype(np.int64, copy=False)


def _split_header(data: bytes, end_marker: bytes, what: str) -> tuple[list[list[str]], int]:
    """The header's lines as words, and the byte at which the body begins. A header
    of any length (a PLY's comments can fill many kilobytes): the file is in memory
    and a search for its end runs at memory speed."""
    end = data.find(end_marker)
    if end < 0:
        raise MeshFormatError(f"no {end_marker.decode()} line: not a {what} file, or damaged")
    newline = data.find(b"\n", end)
    start = len(data) if newline < 0 else newline + 1
    head = data[:end]
    if any(b < 9 or b > 126 for b in head.translate(None, b"\r\n\t")):
        raise MeshFormatError("its header holds bytes that are not text: damaged")
    return [line.split() for line in head.decode("ascii").splitlines()], start


# --- PLY --------------------------------------------------------------------------------


def parse_ply(data: bytes) -> tuple[np.ndarray, np.ndarray]:
    """A .ply file: ASCII or binary (little or big endian); vertex x, y, z among
    scalar properties, faces as one list of indices (triangles), other elements of
    scalar properties skipped."""
    fmt, elements, start = _ply_header(data)
    if fmt == "ascii":
        return _ply_ascii(data[start:], elements)
    return _ply_binary(data, start, elements, "<" if fmt == "binary_little_endian" else ">")


def ply_vertex_property(data: bytes, name: str) -> np.ndarray | None:
    """The scalar vertex property ``name`` of a .ply file (float64, one per vertex in
    the file's order), or None when its vertices have none (or other elements
    come before them, which oftimg does not write)."""
    fmt, elements, start = _ply_header(data)
    if elements[0][0] != "vertex":
        return None
    _, count, props = elements[0]
    column = next((k for k, p in enumerate(props) if p[-1] == name), None)
    if column is None:
        return None
    if fmt == "ascii":
        rows = [line for line in data[start:].splitlines() if line.strip()][:count]
        values = _floats(b" ".join(rows), count * len(props), "vertex lines")
        return values.reshape(count, len(props))[:, column]
    order = "<" if fmt == "binary_little_endian" else ">"
    dtype = np.dtype([(f"p{k}", order + PLY_TYPES[p[0]]) for k, p in enumerate(props)])
    if len(data) - start < count * dtype.itemsize:
        raise _truncated("among its vertices")
    return np.frombuffer(data, dtype, count, start)[f"p{column}"].astype(np.float64)


def _ply_header(data: bytes) -> tuple[str, list, int]:
    """A .ply header checked: its format, its elements ``(name, count, properties)``
    and where its body starts."""
    if not data.startswith(b"ply"):
        raise MeshFormatError("does not begin with 'ply': not a PLY file")
    lines, start = _split_header(data, b"end_header", "PLY")
    fmt = next((w for w in lines if w[:1] == ["format"]), None)
    if (
        fmt is None
        or len(fmt) != 3
        or fmt[1] not in ("ascii", "binary_little_endian", "binary_big_endian")
    ):
        raise MeshFormatError(
            "its header has no valid 'format' line (ascii, "
            "binary_little_endian or binary_big_endian)"
        )
    elements: list[tuple[str, int, list[list[str]]]] = []
    for k, words in enumerate(lines):
        if words[:1] == ["element"]:
            if len(words) != 3:
                raise MeshFormatError(
                    f"header line {k + 1}: an element line is 'element NAME COUNT'"
                )
            elements.append((words[1], _count(words[2], f"element {words[1][:20]!r}"), []))
        elif words[:1] == ["property"]:
            ok = (len(words) == 3 and words[1] in PLY_TYPES) or (
                len(words) == 5
                and words[1] == "list"
                and words[2] in PLY_TYPES
                and words[3] in PLY_TYPES
            )
            if not ok or not elements:
                raise MeshFormatError(
                    f"header line {k + 1}: not a property line PLY knows "
                    "('property TYPE NAME' or 'property list TYPE TYPE NAME' "
                    "after an element line)"
                )
            elements[-1][2].append(words[1:])
        elif words[:1] not in ([], ["ply"], ["format"], ["comment"], ["obj_info"]):
            raise MeshFormatError(f"header line {k + 1}: not a line a PLY header holds")
    names = [e[0] for e in elements]
    if "vertex" not in names or "face" not in names:
        raise MeshFormatError("its header declares no 'vertex' and 'face' elements")
    vertex_props = elements[names.index("vertex")][2]
    if any(p[0] == "list" for p in vertex_props) or not {"x", "y", "z"} <= {
        p[-1] for p in vertex_props
    }:
        raise MeshFormatError("its vertices need scalar properties x, y and z")
    face_props = elements[names.index("face")][2]
    if sum(p[0] == "list" for p in face_props) != 1 or any(
        PLY_TYPES[t][0] == "f" for p in face_props if p[0] == "list" for t in p[1:3]
    ):
        raise MeshFormatError("its faces need one list property of whole-number indices")
    return fmt[1], elements, start


def _ply_binary(data: bytes, start: int, elements, order: str):
    body = memoryview(data)[start:]
    offset = 0
    V = F = None
    for name, count, props in elements:
        scalars = [p for p in props if p[0] != "list"]
        if name == "face":
            F, used = _ply_binary_faces(body, offset, count, props, order)
        else:
            if len(scalars) != len(props):
                raise MeshFormatError(
                    f"element {name[:20]!r} has list properties; oftimg reads lists in faces only"
                )
            dtype = np.dtype([(f"p{k}", order + PLY_TYPES[p[0]]) for k, p in enumerate(props)])
            used = count * dtype.itemsize
            if len(body) - offset < used:
                whole = max(0, len(body) - offset) // max(dtype.itemsize, 1)
                what = "vertices" if name == "vertex" else f"{name[:20]!r} elements"
                raise _truncated(
                    f"among its {what}, with {whole} of the {count} {what} its header lists whole"
                )
            if name == "vertex":
                rec = np.frombuffer(body, dtype, count, offset)
                cols = {p[-1]: f"p{k}" for k, p in enumerate(props)}
                V = np.column_stack([rec[cols[c]] for c in "xyz"]).astype(np.float64)
        offset += used
    if len(body) != offset:
        raise MeshFormatError(
            f"it holds {len(body) - offset} bytes more than its header "
            "declares (a count in the header is wrong, or the file is damaged)"
        )
    return V, _check_faces(F, len(V) if V is not None else 0)


def _ply_binary_faces(body, offset: int, count: int, props, order: str):
    """Triangles of a binary face element and the bytes it takes."""
    fields = []
    for k, p in enumerate(props):
        if p[0] == "list":
            fields += [("n", order + PLY_TYPES[p[1]]), ("idx", order + PLY_TYPES[p[2]], (3,))]
        else:
            fields.append((f"p{k}", order + PLY_TYPES[p[0]]))
    dtype = np.dtype(fields)
    size = count * dtype.itemsize
    if len(body) - offset >= size:
        rec = np.frombuffer(body, dtype, count, offset)
        if np.all(rec["n"] == 3):
            return rec["idx"].astype(np.int64), size
    # faces of other sizes, or a short file: walk the records to say which
    list_at = next(k for k, p in enumerate(props) if p[0] == "list")
    before = sum(np.dtype(PLY_TYPES[p[0]]).itemsize for p in props[:list_at])
    after = sum(np.dtype(PLY_TYPES[p[0]]).itemsize for p in props[list_at + 1 :])
    count_type = np.dtype(order + PLY_TYPES[props[list_at][1]])
    index_size = np.dtype(PLY_TYPES[props[list_at][2]]).itemsize
    at, others = offset, 0
    for k in range(count):
        n = (
            int(np.frombuffer(body, count_type, 1, at + before)[0])
            if len(body) >= at + before + count_type.itemsize
            else -1
        )
        at += before + count_type.itemsize + max(n, 0) * index_size + after
        if at > len(body) or n < 0:
            if others:
                raise MeshFormatError(
                    f"its faces do not fit the file ({others} "
                    f"{'is' if others == 1 else 'are'} not a triangle before "
                    "it ends): the file is damaged"
                )
            raise _truncated(
                f"among its faces, with {k} of the {count} faces its header lists whole"
            )
        others += n != 3
    if others:
        raise not_triangles(others)
    raise _truncated("among its faces")  # not reached: all triangles fit the fast path


def _ply_ascii(body: bytes, elements):
    lines = [line for line in body.splitlines() if line.strip()]
    at = 0
    V = F = None
    for name, count, props in elements:
        if count > len(lines) - at:
            what = (
                "vertices"
                if name == "vertex"
                else ("faces" if name == "face" else f"{name[:20]!r} elements")
            )
            raise _truncated(
                f"among its {what}, with {max(0, len(lines) - at)} of the "
                f"{count} {what} its header lists"
            )
        rows = lines[at : at + count]
        at += count
        if name == "vertex":
            values = _floats(b" ".join(rows), count * len(props), "vertex lines")
            values = values.reshape(count, len(props))
            cols = [next(k for k, p in enumerate(props) if p[-1] == c) for c in "xyz"]
            V = values[:, cols]
        elif name == "face":
            F = _ascii_polygons(rows, props)
    if at != len(lines):
        raise MeshFormatError(
            f"it holds {len(lines) - at} lines more than its header declares "
            "(a count in the header is wrong, or the file is damaged)"
        )
    return V, _check_faces(F, len(V))


def _ascii_polygons(rows: list[bytes], props=None, skip_after: int = 0) -> np.ndarray:
    """Triangles of ASCII face lines ``n i j k ...`` (PLY: scalar properties may come
    before or after the list; OFF: colours after it)."""
    before = 0
    if props is not None:
        list_at = next(k for k, p in enumerate(props) if p[0] == "list")
        before, skip_after = list_at, len(props) - list_at - 1
    tokens = [row.split() for row in rows]
    counts = _ints([t[before] if len(t) > before else b"x" for t in tokens], "face lines")
    if np.any(counts != 3):
        short = int(np.count_nonzero(counts < 3))
        if short:
            raise MeshFormatError(f"{short} faces have fewer than 3 corners (the file is damaged)")
        raise not_triangles(int(np.count_nonzero(counts != 3)))
    width = before + 4 + skip_after
    if props is not None and any(len(t) != width for t in tokens):
        raise MeshFormatError("its face lines do not hold the values its header declares")
    if props is None and any(len(t) < 4 for t in tokens):
        raise MeshFormatError("its face lines hold fewer indices than they say")
    return _ints([x for t in tokens for x in t[before + 1 : before + 4]], "face lines").reshape(
        -1, 3
    )


# --- OFF --------------------------------------------------------------------------------


def parse_off(data: bytes) -> tuple[np.ndarray, np.ndarray]:
    """An .off file (OFF, COFF, NOFF, CNOFF: x y z first on each vertex line)."""
    lines = [line.split(b"#", 1)[0] for line in data.splitlines()]
    lines = [line for line in lines if line.strip()]
    if not lines or lines[0].split()[0] not in (b"OFF", b"COFF", b"NOFF", b"CNOFF"):
        raise MeshFormatError("does not begin with 'OFF': not an OFF file")
    first = lines[0].split()
    counts_line, at = (
        (first[1:], 1) if len(first) > 1 else (lines[1].split() if len(lines) > 1 else [], 2)
    )
    if len(counts_line) < 2:
        raise MeshFormatError("no line of vertex and face counts after 'OFF'")
    n_vert, n_face = _count(counts_line[0], "vertices"), _count(counts_line[1], "faces")
    if n_vert + n_face > len(lines) - at:
        raise _truncated(
            f"before the {n_vert} vertex and {n_face} face lines its header "
            f"lists (it has {len(lines) - at} lines)"
        )
    if n_vert + n_face < len(lines) - at:
        raise MeshFormatError(
            f"it holds {len(lines) - at - n_vert - n_face} lines more than "
            "its header declares (a count is wrong, or the file is damaged)"
        )
    rows = [line.split()[:3] for line in lines[at : at + n_vert]]
    if any(len(r) < 3 for r in rows):
        raise MeshFormatError("a vertex line holds fewer than 3 coordinates")
    V = _floats(b" ".join(x for r in rows for x in r), 3 * n_vert, "vertex lines")
    F = _ascii_polygons(lines[at + n_vert :], skip_after=0)
    return V.reshape(-1, 3), _check_faces(F, n_vert)


# --- OBJ --------------------------------------------------------------------------------


def parse_obj(data: bytes) -> tuple[np.ndarray, np.ndarray]:
    """An .obj file: ``v x y z`` lines and ``f`` lines of 1-based (or negative,
    relative) vertex indices, each corner ``i``, ``i/t``, ``i//n`` or ``i/t/n``;
    texture coordinates, normals, groups and materials ignored."""
    verts: list[bytes] = []
    faces: list[list[bytes]] = []
    starts: list[int] = []  # vertex count when each face was read (negative indices)
    for line in data.splitlines():
        words = line.split()
        if not words:
            continue
        if words[0] == b"v":
            if len(words) < 4:
                raise MeshFormatError(f"vertex {len(verts) + 1} has fewer than 3 coordinates")
            verts += words[1:4]
        elif words[0] == b"f":
            faces.append([w.split(b"/", 1)[0] for w in words[1:]])
            starts.append(len(verts) // 3)
    if not faces:
        raise MeshFormatError("no face lines ('f'): not a triangle mesh")
    sizes = np.array([len(f) for f in faces])
    if np.any(sizes < 3):
        raise MeshFormatError(
            f"{int(np.count_nonzero(sizes < 3))} face lines with fewer than 3 "
            "corners (the file is truncated or damaged)"
        )
    if np.any(sizes != 3):
        raise not_triangles(int(np.count_nonzero(sizes != 3)))
    V = _floats(b" ".join(verts), len(verts), "vertex lines").reshape(-1, 3)
    F = _ints([i for f in faces for i in f], "face lines").reshape(-1, 3)
    if np.any(F == 0):
        raise MeshFormatError("a face line has index 0 (.obj indices begin at 1)")
    F = np.where(F < 0, F + np.asarray(starts)[:, None], F - 1)
    return V, _check_faces(F, len(V))


# --- STL --------------------------------------------------------------------------------

_STL_VERTEX = re.compile(rb"vertex\s+(\S+)\s+(\S+)\s+(\S+)")


def parse_stl(data: bytes) -> tuple[np.ndarray, np.ndarray]:
    """An .stl file, binary or ASCII: three corners a triangle, stored apart (the
    repair merges them)."""
    n_binary = int.from_bytes(data[80:84], "little") if len(data) >= 84 else None
    if n_binary is not None and len(data) == 84 + 50 * n_binary:
        rec = np.frombuffer(
            data, [("n", "<f4", 3), ("p", "<f4", (3, 3)), ("a", "<u2")], n_binary, 84
        )
        V = rec["p"].reshape(-1, 3).astype(np.float64)
        return V, np.arange(len(V), dtype=np.int64).reshape(-1, 3)
    text = data.lower()
    if not text.lstrip().startswith(b"solid") or b"\0" in data[80:84]:
        if n_binary is None:
            raise MeshFormatError("shorter than a binary STL's 84-byte header, and not ASCII STL")
        raise MeshFormatError(
            f"a binary STL of {n_binary} triangles is "
            f"{84 + 50 * n_binary} bytes long, this file {len(data)}: "
            "truncated or damaged"
        )
    ended = text.count(b"endfacet")
    begun = text.count(b"facet") - ended
    if begun != ended or b"endsolid" not in text:
        raise _truncated(
            f"inside its facets ({ended} of {begun} facets whole, "
            f"{'no' if b'endsolid' not in text else 'an'} endsolid)"
        )
    corners = _STL_VERTEX.findall(text)
    if len(corners) != 3 * begun:
        raise MeshFormatError(f"its {begun} facets hold {len(corners)} vertices; a triangle has 3")
    V = _floats(b" ".join(x for c in corners for x in c), 3 * len(corners), "vertex lines")
    return V.reshape(-1, 3), np.arange(len(corners), dtype=np.int64).reshape(-1, 3)


# --- legacy VTK -------------------------------------------------------------------------


class _Cursor:
    """A read position in a legacy VTK file: keyword lines, then ASCII tokens or
    big-endian binary arrays."""

    def __init__(self, data: bytes, at: int, binary: bool):
        self.data, self.at, self.binary = data, at, binary

    def line(self) -> list[str]:
        """The next non-blank line's words (empty at the end)."""
        while self.at < len(self.data):
            end = self.data.find(b"\n", self.at)
            end = len(self.data) if end < 0 else end
            raw, self.at = self.data[self.at : end], end + 1
            if raw.strip():
                if any(b < 9 or b > 126 for b in raw.translate(None, b"\r\t")):
                    raise MeshFormatError("a keyword line holds bytes that are not text: damaged")
                return raw.decode("ascii").split()
        return []

    def array(self, count: int, kind: str, what: str) -> np.ndarray:
        dtype = np.dtype(">" + VTK_TYPES[kind])
        if self.binary:
            if len(self.data) - self.at < count * dtype.itemsize:
                raise _truncated(f"among its {what}")
            values = np.frombuffer(self.data, dtype, count, self.at)
            self.at += count * dtype.itemsize
            return values.astype(np.float64 if dtype.kind == "f" else np.int64)
        tokens: list[bytes] = []
        while len(tokens) < count:
            words = self.line_bytes()
            if words is None:
                raise _truncated(f"among its {what}")
            tokens += words
        if len(tokens) != count:
            raise MeshFormatError(f"its {what} do not end at a line's end: a count is wrong")
        if dtype.kind == "f":
            return _floats(b" ".join(tokens), count, what)
        return _ints(tokens, what)

    def skip_block(self) -> None:
        """Past the lines up to the next empty one (a METADATA block's end)."""
        while self.at < len(self.data):
            end = self.data.find(b"\n", self.at)
            end = len(self.data) if end < 0 else end
            raw, self.at = self.data[self.at : end], end + 1
            if not raw.strip():
                return

    def line_bytes(self) -> list[bytes] | None:
        while self.at < len(self.data):
            end = self.data.find(b"\n", self.at)
            end = len(self.data) if end < 0 else end
            raw, self.at = self.data[self.at : end], end + 1
            if raw.strip():
                return raw.split()
        return None


def parse_vtk(data: bytes) -> tuple[np.ndarray, np.ndarray]:
    """A legacy .vtk file (versions 2 to 5.1): POLYDATA with POLYGONS, or an
    UNSTRUCTURED_GRID of triangles; cells in the classic layout (``n i j k``) or
    the 5.1 one (OFFSETS and CONNECTIVITY)."""
    if not data.startswith(b"# vtk DataFile"):
        raise MeshFormatError("does not begin with '# vtk DataFile': not a legacy VTK file")
    first_end = data.find(b"\n")
    title_end = data.find(b"\n", first_end + 1)
    if first_end < 0 or title_end < 0:
        raise _truncated("in its header")
    cur = _Cursor(data, title_end + 1, binary=False)
    mode = cur.line()
    if mode not in (["ASCII"], ["BINARY"]):
        raise MeshFormatError("its third line is neither ASCII nor BINARY")
    cur.binary = mode == ["BINARY"]
    dataset = cur.line()
    if (
        dataset[:1] != ["DATASET"]
        or len(dataset) != 2
        or dataset[1] not in ("POLYDATA", "UNSTRUCTURED_GRID")
    ):
        raise MeshFormatError(
            "its DATASET is not POLYDATA or UNSTRUCTURED_GRID: not a surface mesh oftimg reads"
        )
    V = cells = types = None
    while (words := cur.line()) and words[0] not in ("POINT_DATA", "CELL_DATA"):
        key = words[0]
        if key == "POINTS":
            if len(words) != 3 or words[2].lower() not in VTK_TYPES:
                raise MeshFormatError("its POINTS line is not 'POINTS COUNT TYPE'")
            n = _count(words[1], "POINTS")
            _fits(data, cur.at, 3 * n, "POINTS")
            V = cur.array(3 * n, words[2].lower(), "points").reshape(-1, 3)
        elif key in ("POLYGONS", "CELLS", "VERTICES", "LINES", "TRIANGLE_STRIPS"):
            if len(words) != 3:
                raise MeshFormatError(f"its {key} line is not '{key} COUNT SIZE'")
            polys = _vtk_cells(cur, _count(words[1], key), _count(words[2], key), key)
            if key in ("POLYGONS", "CELLS"):
                cells = polys
            elif key == "TRIANGLE_STRIPS" and len(polys[0]):
                raise MeshFormatError(
                    "it holds triangle strips; save the surface as "
                    "triangles (in ParaView: Triangulate)"
                )
        elif key == "CELL_TYPES":
            if len(words) != 2:
                raise MeshFormatError("its CELL_TYPES line is not 'CELL_TYPES COUNT'")
            n = _count(words[1], "CELL_TYPES")
            _fits(data, cur.at, n, "CELL_TYPES")
            types = cur.array(n, "int", "cell types")
        elif key == "METADATA":  # VTK 9 writes one after an array
            cur.skip_block()
        elif key == "FIELD":
            break  # nothing oftimg reads follows
        else:
            raise MeshFormatError(f"its section {key[:20]!r} is not one of legacy VTK's")
    if V is None or cells is None:
        raise MeshFormatError("it has no POINTS or no POLYGONS/CELLS")
    offsets, conn = cells
    sizes = np.diff(offsets)
    if dataset[1] == "UNSTRUCTURED_GRID":
        if types is None or len(types) != len(sizes):
            raise MeshFormatError("its CELL_TYPES do not match its CELLS")
        surface = np.isin(types, (VTK_TRIANGLE, VTK_QUAD, VTK_POLYGON))
        if np.any(~surface & (sizes > 2)):
            raise MeshFormatError(
                f"{int(np.count_nonzero(~surface & (sizes > 2)))} cells are "
                "volume cells; oftimg reads surfaces of triangles"
            )
        conn = conn[np.repeat(surface, sizes)]  # vertices and lines left out
        sizes = sizes[surface]
    if np.any(sizes != 3):
        raise not_triangles(int(np.count_nonzero(sizes != 3)))
    return V, _check_faces(conn.reshape(-1, 3), len(V))


def _fits(data: bytes, at: int, count: int, what: str) -> None:
    """Refuse a count that the rest of the file cannot hold (one byte a value at
    least), before anything is allocated."""
    if count > len(data) - at:
        raise _truncated(f"before the {count} values its {what} line announces")


def _vtk_cells(cur: _Cursor, n: int, size: int, key: str) -> tuple[np.ndarray, np.ndarray]:
    """A cell section as ``(offsets (n_cell + 1,), connectivity)``."""
    _fits(cur.data, cur.at, size, key)
    save = cur.at
    nxt = cur.line() if not cur.binary or cur.data[cur.at : cur.at + 7] == b"OFFSETS" else []
    if nxt[:1] == ["OFFSETS"]:  # 5.1: n is offsets, size connectivity
        offsets = cur.array(
            n,
            nxt[1].lower() if len(nxt) == 2 and nxt[1].lower() in VTK_TYPES else "vtktypeint64",
            "cell offsets",
        )
        nxt = cur.line()
        if nxt[:1] != ["CONNECTIVITY"] or len(nxt) != 2 or nxt[1].lower() not in VTK_TYPES:
            raise MeshFormatError(f"its {key} has OFFSETS but no CONNECTIVITY")
        conn = cur.array(size, nxt[1].lower(), "cell connectivity")
        if n and (offsets[0] != 0 or offsets[-1] != size or np.any(np.diff(offsets) < 0)):
            raise MeshFormatError(
                f"its {key} OFFSETS do not run from 0 to its connectivity's length"
            )
        return (offsets if n else np.zeros(1, np.int64)), conn
    cur.at = save
    flat = cur.array(size, "int", f"{key} cells")
    if size == 4 * n and np.all(flat[::4] == 3):  # all triangles: no walk
        return np.arange(0, 3 * n + 1, 3), flat.reshape(-1, 4)[:, 1:].ravel()
    offsets, at = np.zeros(n + 1, np.int64), 0
    for k in range(n):  # classic: n i j k ...
        if at >= size or flat[at] < 0 or at + 1 + flat[at] > size:
            raise MeshFormatError(f"its {key} cell sizes do not add up to its size line")
        offsets[k + 1] = offsets[k] + flat[at]
        at += 1 + flat[at]
    if at != size:
        raise MeshFormatError(f"its {key} cell sizes do not add up to its size line")
    keep = np.ones(size, bool)
    keep[np.cumsum(np.concatenate([[0], 1 + np.diff(offsets)]))[:-1]] = False
    return offsets, flat[keep]


PARSERS = {
    ".ply": parse_ply,
    ".obj": parse_obj,
    ".stl": parse_stl,
    ".off": parse_off,
    ".vtk": parse_vtk,
}
