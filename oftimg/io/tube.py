"""One frame of one wall: a mesh file read, repaired, checked as an open tube and
its inlet loop picked (:func:`load_tube`), or the checks' record that lets a
second read of an unchanged file skip them (:class:`Checked`).
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from ..errors import DatasetError, OftimgWarning
from ..mesh.topology import (
    MeshError,
    RepairCounts,
    check_tube,
    loop_centroid,
    loop_vector_area,
    repair,
)
from .meshfile import read_mesh_file


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


def load_tube(
    path: str | Path,
    *,
    unit_scale: float | tuple = 1.0,
    inlet_point: np.ndarray | None = None,
    checked: Checked | None = None,
    warn: bool = True,
) -> Tube:
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
            return Tube(
                V=V * np.asarray(unit_scale),
                F=F[:, ::-1].copy() if checked.reverse else F,
                inlet=checked.inlet.astype(np.int64),
                outlet=checked.outlet.astype(np.int64),
                source=str(path),
            )
    tube, _, repairs = check_tube_file(path, unit_scale=unit_scale, inlet_point=inlet_point)
    if warn and repairs:
        warnings.warn(f"{path}: {repairs.describe()}", OftimgWarning, stacklevel=2)
    return tube


def check_tube_file(
    path: str | Path, *, unit_scale: float | tuple = 1.0, inlet_point: np.ndarray | None = None
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
    if Path(path).suffix.lower() == ".stl":  # STL stores every triangle's corners apart:
        counts = replace(counts, merged_vertices=0)  # merging them is no repair
    # faces against the rest (all of them reversed is no repair: the reading order)
    kept = len(F) - topo.island_faces
    against = min(topo.flipped_faces, kept - topo.flipped_faces)
    counts = replace(
        counts,
        flipped_faces=against,
        islands=topo.islands,
        island_faces=topo.island_faces,
        holes=topo.holes,
        hole_edges=topo.hole_edges,
    )
    if topo.V is not None:
        V = topo.V
    a, b = topo.loops
    if inlet_point is None:
        inlet_first = np.linalg.norm(loop_vector_area(V[a])) >= np.linalg.norm(
            loop_vector_area(V[b])
        )
    else:
        inlet_first = np.linalg.norm(loop_centroid(V[a]) - inlet_point) <= np.linalg.norm(
            loop_centroid(V[b]) - inlet_point
        )
    inlet, outlet = (a, b) if inlet_first else (b, a)
    tube = Tube(V=V, F=topo.F, inlet=inlet, outlet=outlet, source=str(path))
    record = None
    stored_apart = Path(path).suffix.lower() == ".stl"  # needs its corners merged each read
    if not counts and st is not None and not stored_apart:
        record = Checked(
            st.st_size,
            st.st_mtime_ns,
            topo.flipped_faces == len(F),
            inlet.astype(np.int32),
            outlet.astype(np.int32),
        )
    return tube, record, counts
