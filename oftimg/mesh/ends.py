"""A tube's ends: meshes cut by planes, and where a volume's face cuts a tube
obliquely, the plane perpendicular to its centre line that keeps only whole sections.

An OCT field of view cuts the outflow tract wherever it lies, seldom square to it:
the wall's rim then lies on the volume's face, and the grid's first rows and their
section planes follow that oblique rim (a section cut at 34 degrees reads 1 / cos
34 = +21 % of area). The ends found here are what a lab would draw by hand: the first
plane square to the centre line that the face leaves whole, in every frame.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .sections import planes_contours
from .topology import MeshError, boundary_loops, loop_centroid, loop_vector_area

# an end cut within this angle of square is left as it is (a section 3 degrees off
# square has 0.14 % more area than the square one)
SQUARE_ENOUGH_DEG = 3.0
# the perpendicular end lies this many sampling steps inside the innermost point of
# every frame's rim (the rim's vertices were held while the mesh was smoothed)
MARGIN_STEPS = 2.0


def cut_by_plane(V: np.ndarray, F: np.ndarray, point, normal, values: np.ndarray | None = None):
    """The part of a mesh on the side of the plane ``(point, normal)`` that the
    normal points to, its triangles split where they cross the plane (new vertices
    on the plane, shared by neighbouring triangles), so the cut leaves a boundary
    loop lying in the plane. Returns ``(V, F)``, or ``(V, F, values)`` when per-vertex
    ``values (n,)`` or ``(n, k)`` are given (interpolated along the cut edges)."""
    if len(F) == 0:  # cut away whole by a plane before
        return (V, F) if values is None else (V, F, values)
    normal = np.asarray(normal, float) / np.linalg.norm(normal)
    d = (V - np.asarray(point, float)) @ normal
    scale = max(float(np.ptp(V)), 1.0)
    d[np.abs(d) < 1e-12 * scale] = 0.0
    inside = d >= 0
    n_in = inside[F].sum(axis=1)
    keep = F[n_in == 3]
    crossing = F[(n_in > 0) & (n_in < 3)]
    # each crossing edge gets one new vertex, found by its (low, high) vertex pair
    edges = np.concatenate([crossing[:, [0, 1]], crossing[:, [1, 2]], crossing[:, [2, 0]]])
    edges = np.sort(edges, axis=1)
    cut = inside[edges[:, 0]] != inside[edges[:, 1]]
    pairs = np.unique(edges[cut], axis=0)
    a, b = pairs[:, 0], pairs[:, 1]
    w = d[a] / (d[a] - d[b])
    new_V = np.concatenate([V, V[a] + w[:, None] * (V[b] - V[a])])
    new_values = (
        None
        if values is None
        else np.concatenate(
            [values, values[a] + w.reshape(-1, *[1] * (values.ndim - 1)) * (values[b] - values[a])]
        )
    )
    # one vertex wherever the cut meets a place once: a vertex on the plane itself is
    # the cut's vertex there, and two edges cut at one point (a flat triangle's, as
    # marching cubes leaves on a grid line: speckled zoo draw 629's outer wall, frame
    # 65) share one new vertex. Twins at one place are merged by a reader into a pinched
    # boundary vertex, and the frame was refused.
    index = np.where(w == 0.0, a, np.where(w == 1.0, b, len(V) + np.arange(len(pairs))))
    fresh = np.flatnonzero(index >= len(V))
    if len(fresh):
        at = np.round(new_V[index[fresh]] / (1e-9 * scale)).astype(np.int64)
        _, first, same = np.unique(at, axis=0, return_index=True, return_inverse=True)
        index[fresh] = index[fresh][first][same.ravel()]
    key = {tuple(p): int(k) for p, k in zip(pairs.tolist(), index)}

    def on_plane(i, j):
        return key[(min(i, j), max(i, j))]

    faces = [keep]
    extra = []
    for tri in crossing.tolist():
        ins = [inside[v] for v in tri]
        # rotate so that the lone vertex (the one on its side alone) comes first
        lone = ins.index(True) if sum(ins) == 1 else ins.index(False)
        p, q, r = tri[lone:] + tri[:lone]
        pq, pr = on_plane(p, q), on_plane(p, r)
        if sum(ins) == 1:
            extra.append((p, pq, pr))
        else:
            extra += [(pq, q, r), (pq, r, pr)]
    if extra:
        extra = np.asarray(extra, dtype=np.int64)
        faces.append(
            extra[
                (extra[:, 0] != extra[:, 1])
                & (extra[:, 1] != extra[:, 2])
                & (extra[:, 2] != extra[:, 0])
            ]
        )  # none folded onto the plane
    F_out = np.concatenate(faces) if faces else np.empty((0, 3), np.int64)
    used = np.zeros(len(new_V), bool)
    used[F_out.ravel()] = True
    remap = np.cumsum(used) - 1
    if values is None:
        return new_V[used], remap[F_out]
    return new_V[used], remap[F_out], new_values[used]


def largest_piece(V: np.ndarray, F: np.ndarray):
    """The connected part of the mesh with the most faces: ``(V, F, kept, others)``,
    ``kept`` ``(n_vert,)`` bool over the vertices given, ``others`` the number of
    pieces dropped."""
    import scipy.sparse as sp
    from scipy.sparse.csgraph import connected_components

    n = len(V)
    i, j = F.ravel(), F[:, [1, 2, 0]].ravel()
    n_comp, label = connected_components(
        sp.coo_matrix((np.ones(len(i)), (i, j)), shape=(n, n)), directed=False
    )
    if n_comp == 1:
        return V, F, np.ones(n, bool), 0
    face_label = label[F[:, 0]]
    F = F[face_label == np.argmax(np.bincount(face_label))]
    used = np.zeros(n, bool)
    used[F.ravel()] = True
    return V[used], (np.cumsum(used) - 1)[F], used, n_comp - 1


def _area_centroid(P: np.ndarray) -> np.ndarray:
    """The area centroid of a planar closed polygon ``P (n, 3)``."""
    m = P.mean(axis=0)
    Q = np.roll(P, -1, axis=0)
    cross = np.cross(P - m, Q - m)
    normal = cross.sum(axis=0)
    weight = cross @ (normal / np.linalg.norm(normal))
    return m + (weight[:, None] * (P + Q - 2 * m) / 3).sum(axis=0) / weight.sum()


def _nearest_closed(contours: list, origin: np.ndarray) -> np.ndarray | None:
    """The area centroid of the closed contour (of a plane's ``contours``) whose
    centroid lies nearest ``origin`` (a tube cut askew: its section need not enclose
    the point the plane was placed at); None for none."""
    centroids = [_area_centroid(C) for C, closed in contours if closed and len(C) > 2]
    if not centroids:
        return None
    return min(centroids, key=lambda c: float(np.linalg.norm(c - origin)))


def _axis_of_normals(V: np.ndarray, F: np.ndarray, centre: np.ndarray, reach: float) -> np.ndarray:
    """The direction a tube's faces within ``reach`` of ``centre`` are most nearly
    square to (a tube's normals are square to its axis: the least eigenvector of their
    area-weighted scatter), unit, either sense. A start for :func:`end_axis` where a
    face cuts the tube steeply (planes parallel to the face then slice it lengthwise)."""
    corners = V[F]
    near = np.linalg.norm(corners.mean(axis=1) - centre, axis=1) < reach
    normals = np.cross(corners[near, 1] - corners[near, 0], corners[near, 2] - corners[near, 0])
    scatter = normals.T @ (
        normals / np.maximum(np.linalg.norm(normals, axis=1, keepdims=True), 1e-300)
    )
    return np.linalg.eigh(scatter)[1][:, 0]


# degrees: the centre line's tangent past a rim is settled when the last of end_axis's
# rounds turns it less than this (on the zoo's frames the fourth turns it 0-0.4 degrees)
SETTLED_DEG = 2.0


def end_axis(V: np.ndarray, F: np.ndarray, rim: np.ndarray, margin: float, *, rounds: int = 4):
    """The centre line just past a tube's rim: ``(point (3,), tangent (3,))``, the
    centroid of the first section square to the centre line that lies ``margin`` past
    the rim's innermost point, and the tangent there (unit, into the tube). None when
    no section there comes whole.

    ``V (n, 3)``, ``F (m, 3)``: the open tube; ``rim (k, 3)``: one of its boundary
    loops (lying in a volume's face, at any angle to the tube). The first tangent is
    the one the faces near the rim are square to; each round cuts three
    sections square to the current tangent, a third of a radius apart from that
    place on, and takes the tangent of the parabola through their centroids at the
    first (a bent tube's tangent changes over the span: read at the span's middle,
    it was 9 degrees off on a quarter-circle phantom); four rounds settle it, or it is
    None (the last round turned it more than :data:`SETTLED_DEG`: on one frame of a
    speckled zoo draw the sections' centroids pulled it round 10-30 degrees a round)."""
    area = loop_vector_area(rim)
    radius = float(np.sqrt(np.linalg.norm(area) / np.pi))
    point = loop_centroid(rim)
    tangent = _axis_of_normals(V, F, point, 2 * radius)
    near = V[np.linalg.norm(V - point, axis=1) < 3 * radius]
    if (near.mean(axis=0) - point) @ tangent < 0:  # into the tube
        tangent = -tangent
    h = radius / 3
    turned = np.inf
    for _ in range(rounds):
        clear = float(np.max((rim - point) @ tangent)) + margin + 0.01 * radius
        origins = point + tangent * (clear + h * np.arange(3)[:, None])
        contours = planes_contours(V, F, origins, np.stack([tangent] * 3))
        found = [_nearest_closed(c, o) for c, o in zip(contours, origins)]
        if any(f is None for f in found):
            return None
        c0, c1, c2 = found
        slope = -3 * c0 + 4 * c1 - c2  # the parabola's tangent at c0
        turned = float(
            np.degrees(np.arccos(np.clip(slope @ tangent / np.linalg.norm(slope), -1.0, 1.0)))
        )
        tangent = slope / np.linalg.norm(slope)
        point = c0
    if turned > SETTLED_DEG:
        return None
    return point, tangent


@dataclass(frozen=True)
class SquareEnd:
    """One end of a tube whose rim a volume's face cuts: the plane square to its
    centre line that keeps only whole sections (``point`` and ``normal``, into the
    tube, in the meshes' length unit), the angle between the face and the tube where
    the face cuts it (degrees), and how far in along its normal the plane lies from the rim's
    centre (length unit)."""

    point: tuple
    normal: tuple
    oblique_deg: float
    cut_in: float

    def as_dict(self) -> dict:
        return {
            "point": [round(x, 6) for x in self.point],
            "normal": [round(x, 6) for x in self.normal],
            "oblique_deg": round(self.oblique_deg, 2),
            "cut_in": round(self.cut_in, 6),
        }


def square_ends(
    reference: tuple[np.ndarray, np.ndarray], rims: list[list[np.ndarray]], margin: float
) -> list[SquareEnd | None]:
    """For each end of a tube cut by a volume's faces, the plane square to its centre
    line past every frame's rim (:class:`SquareEnd`), or None where the face cuts it
    square already (within :data:`SQUARE_ENOUGH_DEG`).

    ``reference``: one frame's open tube ``(V, F)``, whose two boundary loops name
    the ends (in its loop order); ``rims``: every frame's boundary loops (points ``(k,
    3)`` each; a frame's are matched to the reference's ends by their centroids);
    ``margin``: how far inside every rim the plane lies (length unit). None for
    both ends when the reference has not two loops. Raises :class:`MeshError` for an
    end cut obliquely where no section past the cut comes whole (or the centre line
    there does not settle: :func:`end_axis`)."""
    V, F = reference
    loops = [V[loop] for loop in boundary_loops(F)]
    if len(loops) != 2:
        return [None, None]
    centres = np.array([loop.mean(axis=0) for loop in loops])
    ends = []
    for k, rim in enumerate(loops):
        face = loop_vector_area(rim)
        # the face's angle to the tube where it cuts it: the faces' axis there
        radius = np.sqrt(np.linalg.norm(face) / np.pi)
        at_rim = _axis_of_normals(V, F, loop_centroid(rim), radius)
        oblique = float(np.degrees(np.arccos(min(1.0, abs(face @ at_rim) / np.linalg.norm(face)))))
        if oblique < SQUARE_ENOUGH_DEG:
            ends.append(None)
            continue
        axis = end_axis(V, F, rim, margin)
        if axis is None:
            raise MeshError(
                f"is cut by the volume's face {oblique:.0f} degrees from square, "
                "and no section square to its centre line past the cut comes "
                "whole (or that centre line does not settle)"
            )
        point, tangent = axis
        theirs = [
            r
            for frame in rims
            for r in frame
            if np.argmin(np.linalg.norm(centres - r.mean(axis=0), axis=1)) == k
        ]
        reach = max(float(np.max((r - point) @ tangent)) for r in theirs + [rim])
        at = point + tangent * (reach + margin)
        meets = float((loop_centroid(rim) - point) @ tangent)  # the rim's centre
        ends.append(
            SquareEnd(
                tuple(map(float, at)), tuple(map(float, tangent)), oblique, reach + margin - meets
            )
        )
    return ends


def section_aspects(V: np.ndarray, F: np.ndarray, *, sections: int = 12) -> np.ndarray:
    """How round an open tube is along its length: the minor over the major axis of
    about ``sections`` sections square to its centre line, evenly along it from a rim
    towards the other (from each section's second moments), ``(k,)`` in (0, 1]; fewer
    where the tube is too bent to trace, none where no section comes whole. For telling
    a volume read in the wrong order of its axes (its sections stretched along one
    axis) from a true one.

    The centre line is traced from each rim in turn (the longer trace kept): from its
    first whole section (:func:`end_axis`) in steps of a twelfth of the rims' distance,
    each section square to the line through the last two centroids."""
    loops = [V[loop] for loop in boundary_loops(F)]
    if len(loops) != 2:
        return np.empty(0)
    traces = [_traced(V, F, start, far, sections) for start, far in (loops, loops[::-1])]
    return max(traces, key=len)


def _traced(V, F, start: np.ndarray, far: np.ndarray, sections: int) -> np.ndarray:
    """:func:`section_aspects` from the rim ``start`` towards the rim ``far``."""
    axis = end_axis(V, F, start, 0.0)
    if axis is None:
        return np.empty(0)
    point, tangent = axis
    end = loop_centroid(far)
    step = float(np.linalg.norm(end - point)) / sections
    aspects, previous = [], None
    for _ in range(2 * sections):
        contours = planes_contours(V, F, point[None], tangent[None])[0]
        closed = [C for C, whole in contours if whole and len(C) > 2]
        if not closed:
            break
        C = min(closed, key=lambda c: float(np.linalg.norm(_area_centroid(c) - point)))
        centre = _area_centroid(C)
        moments = np.linalg.eigvalsh(np.cov((C - centre).T))[1:]  # in-plane pair
        aspects.append(float(np.sqrt(max(moments[0], 0.0) / moments[1])))
        if previous is not None:
            tangent = (centre - previous) / np.linalg.norm(centre - previous)
        previous, point = centre, centre + step * tangent
        if float(np.linalg.norm(end - centre)) < 1.5 * step:
            break
    return np.array(aspects)
