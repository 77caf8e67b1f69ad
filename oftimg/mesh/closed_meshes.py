"""A lumen given as meshes that the cushions close (issue 85): its pieces joined into one
tube the way a label volume's are.

A lab that meshes each surface on its own gets, where the cushions appose, a lumen in
pieces (each ending blind at the closure) or one piece closed up to an end of the tube;
neither is a tube, and no grid can be laid on it. Here the frame's lumen and inner wall
are filled into voxels (each closed with a flat cap on its open ends first), continued a
few voxels past the tube's ends (so the cut there is square, not the blur's rounded
end), and the lumen's mask is bridged and meshed by
:func:`~oftimg.mesh.labels.closed_lumen_mesh`: its bridge's vertices flagged, its rows
measured as closed. Coordinates stay in the files' length unit.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components

from .closure import MAX_PIECES, PIECE_MIN_SHARE
from .topology import MeshError, boundary_loops, loop_centroid, loop_vector_area, repair

# the voxels' side: the lumen's median edge (a lab's mesh of a segmentation has about
# one edge per voxel), coarsened until the box holds at most this many voxels
MAX_VOXELS = 16_000_000
# voxels the masks are continued past each end of the tube (the level set's blur
# reaches about 3 voxels: its surface is then a straight tube where it is cut)
PAST_END_VOXELS = 4
# rays cast per voxel for its inside test (odd; more than one: a voxel centre on the
# edge of a marching-cubes mesh's triangle is common)
OCCUPANCY_RAYS = 3


def surface_pieces(F: np.ndarray, n_vertices: int) -> list[np.ndarray]:
    """The faces of each connected piece of a surface ``F (m, 3)`` (joined through
    their vertices), pieces under :data:`~oftimg.mesh.closure.PIECE_MIN_SHARE` of the largest's
    faces dropped, largest first: ``[face indices (k,)]``."""
    if len(F) == 0:
        return []
    edges = np.concatenate([F[:, [0, 1]], F[:, [1, 2]]])  # a face's vertices joined
    A = sp.coo_matrix(
        (np.ones(len(edges)), (edges[:, 0], edges[:, 1])), shape=(n_vertices, n_vertices)
    )
    n, label = connected_components(A, directed=False)
    label = label[F[:, 0]]
    sizes = np.bincount(label, minlength=n)
    order = [
        k for k in np.argsort(-sizes, kind="stable") if sizes[k] >= PIECE_MIN_SHARE * sizes.max()
    ]
    return [np.flatnonzero(label == k) for k in order]


def is_closed_lumen(V: np.ndarray, F: np.ndarray) -> bool:
    """Whether a lumen surface ``(V, F)`` is one the cushions close: in 2 to
    :data:`~oftimg.mesh.closure.MAX_PIECES` pieces, in one piece open at one end only
    (closed up to the other), or one piece open at both ends but with handles (a slit
    closing: where its two faces touch, a mesh of the segmentation has holes through
    it). A tube, or anything else (a sieve of pieces, a surface with no open end), is
    not: it is left to the usual checks."""
    V, F, _ = repair(V, F)
    pieces = surface_pieces(F, len(V))
    if 2 <= len(pieces) <= MAX_PIECES:
        return True
    if len(pieces) != 1:
        return False
    F = F[pieces[0]]
    try:
        loops = len(boundary_loops(F))
    except MeshError:
        return False
    edges = np.unique(
        np.sort(np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]]), axis=1), axis=0
    )
    euler = len(np.unique(F)) - len(edges) + len(F)
    return loops == 1 or (loops == 2 and euler < 0)


def capped(V: np.ndarray, F: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(V, F)`` with each boundary loop closed by a fan around its centroid: a
    watertight surface for an inside test (the fans' orientation is immaterial to it)."""
    loops = boundary_loops(F)
    if not loops:
        return V, F
    centres = np.array([loop_centroid(V[loop]) for loop in loops])
    fans = [
        np.column_stack([np.roll(loop, -1), loop, np.full(len(loop), len(V) + i)])
        for i, loop in enumerate(loops)
    ]
    return np.concatenate([V, centres]), np.concatenate([F, *fans])


def tube_end_planes(V: np.ndarray, F: np.ndarray) -> list[tuple[np.ndarray, np.ndarray]]:
    """A tube's two ends as planes ``(point, normal)``: each boundary loop's centroid
    and its vector area's direction, turned to point into the tube (towards the other
    end). Raises :class:`MeshError` unless ``(V, F)`` has two loops."""
    loops = boundary_loops(F)
    if len(loops) != 2:
        raise MeshError(f"has {len(loops)} boundary loops; a tube has 2")
    centres = [loop_centroid(V[loop]) for loop in loops]
    planes = []
    for k, loop in enumerate(loops):
        normal = loop_vector_area(V[loop])
        normal = normal / np.linalg.norm(normal)
        if normal @ (centres[1 - k] - centres[k]) < 0:
            normal = -normal
        planes.append((centres[k], normal))
    return planes


def occupancy(
    surfaces: list[tuple[np.ndarray, np.ndarray]],
    origin_xyz: np.ndarray,
    side: float,
    shape_zyx: tuple[int, int, int],
) -> np.ndarray:
    """Which voxel centres ``(z, y, x)`` bool lie inside the watertight ``surfaces``
    (each ``(V, F)``, disjoint), voxel ``(k, j, i)`` centred at ``origin + side * (i,
    j, k)``: open3d's ray-casting inside test (its RaycastingScene, C++ and threaded:
    some 10 million voxels a second here)."""
    import open3d as o3d

    scene = o3d.t.geometry.RaycastingScene()
    for V, F in surfaces:
        mesh = o3d.t.geometry.TriangleMesh()
        mesh.vertex.positions = o3d.core.Tensor(np.asarray(V, np.float32))
        mesh.triangle.indices = o3d.core.Tensor(np.asarray(F, np.int32))
        scene.add_triangles(mesh)
    nz, ny, nx = shape_zyx
    out = np.zeros(shape_zyx, bool)
    x = origin_xyz[0] + side * np.arange(nx)
    y = origin_xyz[1] + side * np.arange(ny)
    for k in range(nz):  # a plane at a time: the points take 12 bytes each
        P = np.stack(
            np.broadcast_arrays(x[None, :], y[:, None], origin_xyz[2] + side * k), axis=-1
        ).astype(np.float32)
        out[k] = scene.compute_occupancy(o3d.core.Tensor(P), nsamples=OCCUPANCY_RAYS).numpy() > 0.5
    return out


def continued_past_ends(mask: np.ndarray, side: float, planes, reach_voxels: int) -> np.ndarray:
    """``mask (z, y, x)`` (voxel centres at ``side * (i, j, k)``) continued up to
    ``reach_voxels`` past each end plane (``(point, normal)``, normal into the tube): a
    voxel beyond a plane takes the value of the voxel half a side inside the plane
    straight below it, so the tube goes on as its end section."""
    out = mask.copy()
    index = np.indices(mask.shape).reshape(3, -1).T  # z y x
    X = index[:, ::-1] * side  # x y z
    for point, normal in planes:
        d = (X - point) @ normal
        beyond = (d < 0) & (d >= -reach_voxels * side)
        source = X[beyond] - (d[beyond, None] - 0.5 * side) * normal
        k = np.rint(source / side).astype(int)[:, ::-1]  # z y x
        inside = np.all((k >= 0) & (k < mask.shape), axis=1)
        out.reshape(-1)[np.flatnonzero(beyond)[inside]] = mask[tuple(k[inside].T)]
    return out


def voxel_box(
    inner_V: np.ndarray, lumen_V: np.ndarray, lumen_F: np.ndarray
) -> tuple[np.ndarray, float, tuple[int, int, int]]:
    """The voxel grid a frame is filled into: its first voxel centre (x y z), its side
    (the lumen's median edge, coarser where the box would pass :data:`MAX_VOXELS`) and
    its shape ``(z, y, x)``: the inner wall's box (``inner_V (n, 3)``) and
    :data:`PAST_END_VOXELS` + 2 voxels more each side."""
    edges = lumen_V[lumen_F] - lumen_V[np.roll(lumen_F, -1, axis=1)]
    side = float(np.median(np.linalg.norm(edges, axis=-1)))
    low, high = inner_V.min(axis=0), inner_V.max(axis=0)
    margin = PAST_END_VOXELS + 2
    while True:
        shape = np.ceil((high - low) / side).astype(int) + 1 + 2 * margin
        if np.prod(shape.astype(float)) <= MAX_VOXELS:
            break
        side *= 1.25
    return low - margin * side, side, (int(shape[2]), int(shape[1]), int(shape[0]))


def lumen_and_inner_masks(
    lumen: tuple[np.ndarray, np.ndarray],
    inner: tuple[np.ndarray, np.ndarray],
    origin: np.ndarray,
    side: float,
    shape_zyx: tuple[int, int, int],
    planes,
) -> tuple[np.ndarray, np.ndarray]:
    """The lumen's and the inner wall's masks ``(z, y, x)`` bool on the grid
    (:func:`voxel_box`), each surface capped (:func:`capped`, a lumen piece by piece)
    and filled (:func:`occupancy`), then continued past the tube's ends
    (:func:`continued_past_ends`; ``planes`` relative to ``origin``)."""
    V, F, _ = repair(*lumen)
    pieces = [capped(*_compact(V, F[faces])) for faces in surface_pieces(F, len(V))]
    masks = (
        occupancy(pieces, origin, side, shape_zyx),
        occupancy([capped(*inner)], origin, side, shape_zyx),
    )
    return tuple(
        continued_past_ends(m, side, planes, PAST_END_VOXELS)  # type: ignore
        for m in masks
    )


def _compact(V: np.ndarray, F: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(V, F)`` with only the vertices ``F`` uses, renumbered."""
    used, F = np.unique(F, return_inverse=True)
    return V[used], F.reshape(-1, 3)


def closed_lumen_from_meshes(
    lumen: tuple[np.ndarray, np.ndarray],
    inner: tuple[np.ndarray, np.ndarray],
    options,
    *,
    length_unit: str = "mm",
):
    """One frame's lumen ``(V, F)`` the cushions closed (:func:`is_closed_lumen`) as one
    tube with its bridge flagged, inside the frame's inner wall ``(V, F)`` (an open
    tube; both in the files' length unit): a :class:`~oftimg.mesh.labels.WallMesh`
    in that unit, its ``closure`` recording the voxel side; a lumen closed nowhere (its
    handles a slit's holes, no piece apart after opening) meshed from its mended mask
    with no bridge (``closed`` and ``closure`` None, ``repair`` saying what); None when
    neither can be meshed as a tube. ``options``: :class:`~oftimg.mesh.labels.MeshOptions`."""
    from .labels import _mesh_or_mend, closed_lumen_mesh

    planes = tube_end_planes(*inner)
    origin, side, shape = voxel_box(inner[0], *lumen)
    local = [(point - origin, normal) for point, normal in planes]
    mask, inner_mask = lumen_and_inner_masks(lumen, inner, origin, side, shape, local)
    voxel = (side, side, side)
    mesh = closed_lumen_mesh(
        mask,
        inner_mask,
        voxel,
        options,
        local,
        openings=(0, 1, 2, 3),
        to_ends=True,
        length_unit=length_unit,
    )
    if mesh is None:  # a slit's holes, but closed nowhere: one tube, mended
        mended, _ = _mesh_or_mend("lumen", mask, voxel, options, local, length_unit=length_unit)
        if isinstance(mended, str):
            return None
        return replace(mended, V=mended.V + origin, mean_curvature=None, closed=None, closure=None)
    return replace(
        mesh,
        V=mesh.V + origin,
        mean_curvature=None,
        closure={**(mesh.closure or {}), "voxel_side": side},
    )
