"""A mesh dataset whose lumen the cushions close in some frames (issue 85): those frames'
lumens joined into one tube each, in a folder beside the results, before the run reads
them.

A frame's lumen file in pieces, or closed up to an end
(:func:`~oftimg.mesh.closed_meshes.is_closed_lumen`), is bridged inside the frame's
inner wall (:func:`~oftimg.mesh.closed_meshes.closed_lumen_from_meshes`) and written
with its bridge flagged (the PLY property the label route writes), so the run measures
its rows there as closed. A closure in one frame alone where the frames either side are
wide open there (:func:`~oftimg.mesh.closure.is_one_frame_gap`) is a gap in the
segmentation, not the cushions: that frame's lumen is filled from the two around it and
named as a repair.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np

from ..errors import DatasetError
from .meshfile import read_mesh_file, write_ply


def closed_frames(ds, executor=None) -> list[int]:
    """The frames of mesh dataset ``ds`` whose lumen file the cushions closed (read
    once each, in ``executor``'s workers when given)."""
    if "lumen" not in ds.frames or "inner" not in ds.frames:
        return []
    paths = [str(p) for p in ds.frames["lumen"]]
    states = list(map(_is_closed, paths) if executor is None else executor.map(_is_closed, paths))
    return [t for t, closed in enumerate(states) if closed]


def _is_closed(path: str) -> bool:
    from ..mesh.closed_meshes import is_closed_lumen

    try:
        return is_closed_lumen(*read_mesh_file(path))
    except (DatasetError, ValueError):  # unreadable: the validation says why
        return False


def bridge_frame(
    t: int,
    files: dict[str, str],
    neighbours: tuple[str, str] | None,
    out: str,
    options,
    length_unit: str,
) -> dict | DatasetError:
    """Frame ``t``'s closed lumen (``files``: its ``lumen`` and ``inner`` files)
    bridged, or, when ``neighbours`` (the lumen files of the frames before and after,
    given when neither is closed) are wide open where it closed, filled from them: the
    mesh written to ``out`` (PLY, the bridge flagged) and its record; or the error
    naming the file."""
    from ..mesh.closed_meshes import (
        closed_lumen_from_meshes,
        lumen_and_inner_masks,
        tube_end_planes,
        voxel_box,
    )
    from ..mesh.closure import is_one_frame_gap
    from ..mesh.labels import CLOSED_PROPERTY, mesh_wall
    from ..mesh.topology import MeshError
    from ..mesh.mask_blend import blended_occupancy

    lumen, inner = read_mesh_file(files["lumen"]), read_mesh_file(files["inner"])
    name = Path(files["lumen"]).name
    try:
        mesh = closed_lumen_from_meshes(lumen, inner, options, length_unit=length_unit)
    except MeshError as exc:
        return DatasetError(
            f"{files['inner']}: the inner wall, around a lumen the cushions close, {exc}"
        )
    if mesh is None:
        return DatasetError(
            f"{files['lumen']}: the lumen is in pieces (or closed up to an "
            "end), and its pieces cannot be joined inside the inner wall "
            "into one tube"
        )
    if mesh.closed is None:  # holes through a slit, closed nowhere
        write_ply(out, mesh.V, mesh.F)
        what = mesh.repair.what if mesh.repair is not None else "meshed from voxels"
        return {
            "frame": t,
            "file": name,
            "source": files["lumen"],
            "repaired": True,
            "why": (
                f"its lumen had holes through a narrowing slit but closed "
                f"nowhere: filled into voxels and meshed again ({what})"
            ),
        }
    if neighbours is not None:
        planes = tube_end_planes(*inner)
        origin, side, shape = voxel_box(inner[0], *lumen)
        local = [(point - origin, normal) for point, normal in planes]
        own, inner_mask = lumen_and_inner_masks(lumen, inner, origin, side, shape, local)
        around = [
            lumen_and_inner_masks(read_mesh_file(f), inner, origin, side, shape, local)[0]
            for f in neighbours
        ]
        voxel = (side, side, side)
        if is_one_frame_gap(mesh.V[mesh.closed] - origin, own, *around, voxel):
            try:
                filled = mesh_wall(
                    blended_occupancy(*around, 0.5, voxel, within=inner_mask.astype(np.float32)),
                    voxel,
                    options,
                    local,
                    length_unit=length_unit,
                )
            except MeshError as exc:
                return DatasetError(
                    f"{files['lumen']}: the lumen, closed in this frame "
                    "alone (a gap in the segmentation), filled from the "
                    f"frames around it, {exc}"
                )
            write_ply(out, filled.V + origin, filled.F)
            return {
                "frame": t,
                "file": name,
                "source": files["lumen"],
                "repaired": True,
                "why": (
                    "its lumen closed over a stretch in this frame alone, wide "
                    "open there in the frames either side: a gap in the "
                    "segmentation, not the cushions; filled from them"
                ),
            }
    write_ply(out, mesh.V, mesh.F, {CLOSED_PROPERTY: mesh.closed.astype(np.float32)})
    return {
        "frame": t,
        "file": name,
        "source": files["lumen"],
        "repaired": False,
        **{
            k: (round(v, 6) if isinstance(v, float) else v) for k, v in (mesh.closure or {}).items()
        },
    }


def bridged_dataset(
    ds, folder: Path, options, executor=None, progress=None, closed: list[int] | None = None
):
    """Mesh dataset ``ds`` with the lumens the cushions closed bridged (or, a one-frame
    gap, filled) into ``folder`` (created; beside the kept results, removed with them)
    and read from there; ``ds`` itself when no lumen is closed. Its ``lumen_bridged``
    records the frames (``closures``; ``repaired``, with ``why``: each one's ``file`` and
    the ``source`` it replaced).
    Raises one :class:`DatasetError` for the frames that cannot be joined.
    ``progress()``: called after each closed frame; ``closed``: :func:`closed_frames`
    when known."""
    from .label_dataset import _raise_for_bad_files

    closed = closed_frames(ds, executor) if closed is None else closed
    if not closed:
        return ds
    folder.mkdir(parents=True, exist_ok=True)
    n = ds.n_frames
    shut = set(closed)
    tasks = []
    for t in closed:
        around = ((t - 1) % n, (t + 1) % n)
        neighbours = (
            None
            if any(f in shut for f in around)
            else tuple(str(ds.frames["lumen"][f]) for f in around)
        )
        tasks.append(
            (
                t,
                {"lumen": str(ds.frames["lumen"][t]), "inner": str(ds.frames["inner"][t])},
                neighbours,
                str(folder / ds.frames["lumen"][t].name),
                options,
                ds.meta.length_unit,
            )
        )
    results = []
    for result in (
        map(bridge_frame, *zip(*tasks))
        if executor is None
        else executor.map(bridge_frame, *zip(*tasks))
    ):
        results.append(result)
        if progress is not None:
            progress()
    _raise_for_bad_files(results, n)
    lumen = list(ds.frames["lumen"])
    for t in closed:
        lumen[t] = folder / ds.frames["lumen"][t].name
    record = {
        "closures": [r for r in results if not r["repaired"]],
        "repaired": [r for r in results if r["repaired"]],
    }
    return dataclasses.replace(
        ds, frames={**ds.frames, "lumen": lumen}, lumen_bridged=record, checked={}
    )


def bridged_notes(path: Path, record: dict | None, n_frames: int) -> list[str]:
    """What a user should know of the lumens bridged or filled in a mesh dataset at
    ``path`` (``record``: its ``lumen_bridged``)."""
    if not record:
        return []
    notes = []
    if record["closures"]:
        notes.append(
            f"{path}: the lumen is in pieces (the cushions closed it over a "
            f"stretch) in {len(record['closures'])} of {n_frames} frames; its "
            "pieces were joined by a thin bridge to grid it, and its rows there are "
            "measured as closed (area 0, no curvature: lumen_closed in arrays.npz; "
            "summary.json provenance.lumen_bridged)"
        )
    for repaired in record["repaired"]:
        notes.append(
            f"{path}: repaired frame {repaired['frame']} ({repaired['file']}): {repaired['why']}"
        )
    return notes
