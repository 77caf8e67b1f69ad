"""Plane sections of triangle meshes: closed contours and their areas."""
from __future__ import annotations

import numpy as np

from .topology import edge_incidence


def plane_contours(V: np.ndarray, F: np.ndarray, origin: np.ndarray, normal: np.ndarray
                   ) -> list[tuple[np.ndarray, bool]]:
    """All contours where the plane ``(origin, normal)`` cuts the mesh.

    Returns a list of ``(points (n_pts, 3) mm, closed)``; a closed contour's
    first point is not repeated; open ones end on the mesh boundary.
    """
    return planes_contours(V, F, np.asarray(origin)[None], np.asarray(normal)[None])[0]


def planes_contours(V: np.ndarray, F: np.ndarray, origins: np.ndarray, normals: np.ndarray
                    ) -> list[list[tuple[np.ndarray, bool]]]:
    """:func:`plane_contours` for many planes ``(n_planes, 3)`` at once.

    The signed distances of all vertices to all planes are one matrix product,
    and each plane then only touches the faces it cuts.
    """
    normals = np.asarray(normals, float)
    normals = normals / np.linalg.norm(normals, axis=1, keepdims=True)
    D = V @ normals.T - np.einsum("ij,ij->i", origins, normals)[None, :]   # (n_vert, n_planes)
    scale = np.abs(D).max(axis=0, keepdims=True)
    D = np.where(np.abs(D) < 1e-12 * scale, 1e-12 * scale, D)  # no vertex exactly on a plane
    DT = np.ascontiguousarray(D.T)                                          # (n_planes, n_vert)
    a, b, c = DT[:, F[:, 0]], DT[:, F[:, 1]], DT[:, F[:, 2]]
    cut = (np.maximum(np.maximum(a, b), c) > 0) & (np.minimum(np.minimum(a, b), c) < 0)
    return [_contours_of(V, F[cut[k]], DT[k]) for k in range(len(normals))]


def _contours_of(V: np.ndarray, Fc: np.ndarray, d: np.ndarray) -> list[tuple[np.ndarray, bool]]:
    """Chain the segments of the cut faces ``Fc`` of one plane into contours."""
    if len(Fc) == 0:
        return []
    side = d > 0
    edges, face_edge, _ = edge_incidence(Fc)
    crosses = side[edges[:, 0]] != side[edges[:, 1]]
    da, db = d[edges[:, 0]], d[edges[:, 1]]
    t = np.where(crosses, da / np.where(crosses, da - db, 1.0), 0.0)
    P = V[edges[:, 0]] + t[:, None] * (V[edges[:, 1]] - V[edges[:, 0]])
    # each cut face joins its two crossing edges
    fe_cross = crosses[face_edge]
    pairs = face_edge[fe_cross].reshape(-1, 2)
    nbrs: dict[int, list[int]] = {}
    for a, b in pairs.tolist():
        nbrs.setdefault(a, []).append(b)
        nbrs.setdefault(b, []).append(a)
    seen = set()
    contours = []
    # open chains first (start at an end), then closed loops
    starts = [e for e, nb in nbrs.items() if len(nb) == 1] + list(nbrs)
    for start in starts:
        if start in seen:
            continue
        chain = [start]
        seen.add(start)
        prev, cur = None, start
        while True:
            nxt = [x for x in nbrs[cur] if x != prev and x not in seen]
            if not nxt:
                break
            prev, cur = cur, nxt[0]
            chain.append(cur)
            seen.add(cur)
        closed = len(chain) > 2 and chain[0] in nbrs[chain[-1]]
        contours.append((P[chain], closed))
    return contours


def polygon_area(P: np.ndarray, normal: np.ndarray | None = None) -> float:
    """Area (mm^2) enclosed by a closed polygon ``P (n, 3)`` (projected on ``normal``)."""
    A = 0.5 * np.cross(P, np.roll(P, -1, axis=0)).sum(axis=0)
    if normal is None:
        return float(np.linalg.norm(A))
    return float(abs(A @ (np.asarray(normal) / np.linalg.norm(normal))))


def contour_around(contours: list[tuple[np.ndarray, bool]], center: np.ndarray,
                   normal: np.ndarray) -> np.ndarray | None:
    """The closed contour whose projection on the plane encloses ``center``.

    Among several, the one whose centroid is nearest. ``None`` if none does.
    """
    normal = np.asarray(normal, float) / np.linalg.norm(normal)
    e1 = np.cross(normal, [1.0, 0, 0])
    if np.linalg.norm(e1) < 0.1:
        e1 = np.cross(normal, [0, 1.0, 0])
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(normal, e1)
    best, best_d = None, np.inf
    for C, closed in contours:
        if not closed:
            continue  # ends on the mesh boundary
        Q = np.column_stack([(C - center) @ e1, (C - center) @ e2])
        if _winding(Q) == 0:
            continue
        dist = np.linalg.norm(C.mean(axis=0) - center)
        if dist < best_d:
            best, best_d = C, dist
    return best



def _winding(Q: np.ndarray) -> int:
    """Winding number of the closed 2-D polygon ``Q`` around the origin."""
    ang = np.arctan2(Q[:, 1], Q[:, 0])
    dang = np.diff(np.concatenate([ang, ang[:1]]))
    dang = (dang + np.pi) % (2 * np.pi) - np.pi
    return int(round(dang.sum() / (2 * np.pi)))


def ring_point(X: np.ndarray, u: float) -> np.ndarray:
    """Position at parameter ``u`` on grid rings ``X (n_u, ...)`` (linear, periodic in u)."""
    n_u = X.shape[0]
    x = u * n_u
    i = int(np.floor(x)) % n_u
    f = x - np.floor(x)
    return (1 - f) * X[i] + f * X[(i + 1) % n_u]


def section_planes(X: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Planes through ``G(0, v), G(1/3, v), G(2/3, v)`` of a grid ``X (n_u, n_v, ..., 3)``.

    Returns ``origins`` (the three points' mean) and unit ``normals`` pointing
    towards the outlet (increasing v), each ``(n_v, ..., 3)``.
    """
    a, b, c = X[0], ring_point(X, 1 / 3), ring_point(X, 2 / 3)
    n = np.cross(b - a, c - a)
    n /= np.linalg.norm(n, axis=-1, keepdims=True)
    axis = np.gradient(X.mean(axis=0), axis=0)  # along v
    sign = np.sign(np.einsum("...i,...i", n, axis))
    sign[sign == 0] = 1
    return (a + b + c) / 3.0, n * sign[..., None]


def crossing_planes(X: np.ndarray, origins: np.ndarray, normals: np.ndarray) -> np.ndarray:
    """Rows whose section meets another row's section inside the tube, per frame.

    For one frame, ``X (n_u, n_v, 3)``, ``origins``/``normals (n_v, 3)``.
    Sections j and k meet when their chords on the line where planes j and k
    intersect overlap; each chord is spanned by the points where the other
    ring crosses the plane (its ends for a convex section, a superset
    otherwise). A plane that only passes through a far part of a folded tube
    does not count. Neighbouring rows must also keep their order (row j + 1
    in front of plane j). Returns a boolean ``(n_v,)``.
    """
    n_v = X.shape[1]
    rings = X.transpose(1, 0, 2)                                        # (n_v, n_u, 3)
    # side[j, k, i]: signed distance of node i of ring k from plane j
    side = np.einsum("kiv,jv->jki", rings, normals) \
        - np.einsum("jv,jv->j", origins, normals)[:, None, None]
    nxt = np.roll(side, -1, axis=2)
    cuts = (side < 0) != (nxt < 0)                                      # ring k's edge i cuts plane j
    frac = side / np.where(cuts, side - nxt, 1.0)
    line = np.cross(normals[:, None, :], normals[None, :, :])          # direction of plane j ^ plane k
    proj = np.einsum("kiv,jkv->jki", rings, line)
    at = proj + frac * (np.roll(proj, -1, axis=2) - proj)
    lo = np.where(cuts, at, np.inf).min(axis=2)                         # chord of section k on the line
    hi = np.where(cuts, at, -np.inf).max(axis=2)
    # section j's chord on the same line: ring j against plane k, direction reversed
    lo_j, hi_j = -hi.T, -lo.T
    meet = (np.maximum(lo, lo_j) <= np.minimum(hi, hi_j)) & np.isfinite(lo) & np.isfinite(lo_j)
    meet &= ~np.eye(n_v, dtype=bool)
    k = np.arange(n_v - 1)
    lo_side, hi_side = side.min(axis=2), side.max(axis=2)
    order = np.zeros(n_v, dtype=bool)
    order[k] = (lo_side[k, k + 1] <= 0) | (hi_side[k + 1, k] >= 0)     # neighbours swapped
    return meet.any(axis=1) | order


def fix_crossing_planes(X: np.ndarray, origins: np.ndarray, normals: np.ndarray, *,
                        max_iter: int = 100) -> tuple[np.ndarray, int, np.ndarray]:
    """Blend the normals of crossing planes toward their neighbours until none cross.

    One frame: ``X (n_u, n_v, 3)``, ``origins``/``normals (n_v, 3)``. The end
    rows keep their planes. A run of changed rows that still crosses after
    ``max_iter`` rounds gets its original normals back: blending that cannot
    separate the sections (at a deep neck next to a bulge, say) only tilts
    them, which biases their areas. Returns the normals, how many row normals
    were changed, and a boolean ``(n_v,)`` of rows still crossing (data, not
    an error: the caller counts and reports them).
    """
    original = normals
    normals = normals.copy()
    changed = np.zeros(len(normals), dtype=bool)
    for _ in range(max_iter):
        bad = crossing_planes(X, origins, normals)
        if not bad.any():
            return normals, int(changed.sum()), bad
        rows = np.nonzero(bad)[0]
        rows = rows[(rows > 0) & (rows < len(normals) - 1)]
        if len(rows) == 0:
            break
        blended = normals[rows] + 0.5 * (normals[rows - 1] + normals[rows + 1])
        normals[rows] = blended / np.linalg.norm(blended, axis=1, keepdims=True)
        changed[rows] = True
    bad = crossing_planes(X, origins, normals)
    for run in _runs(changed):
        if bad[max(run[0] - 1, 0):run[-1] + 2].any():
            normals[run] = original[run]
            changed[run] = False
    return normals, int(changed.sum()), crossing_planes(X, origins, normals)


def _runs(mask: np.ndarray) -> list[np.ndarray]:
    """Index arrays of the runs of consecutive True values in ``mask``."""
    idx = np.nonzero(mask)[0]
    return np.split(idx, np.nonzero(np.diff(idx) > 1)[0] + 1) if len(idx) else []


def orient_and_resample(C: np.ndarray, normal: np.ndarray, start: np.ndarray, n: int
                        ) -> np.ndarray:
    """Contour ``C`` as ``n`` points evenly spaced by arc length, in u order.

    Starts at the contour point nearest ``start`` (the seam node) and turns
    positively about ``normal`` (the v direction), as u does.
    """
    if loop_vector(C) @ normal < 0:
        C = C[::-1]
    closed = np.concatenate([C, C[:1]])
    seg = np.linalg.norm(np.diff(closed, axis=0), axis=1)
    s = np.concatenate([[0.0], np.cumsum(seg)])
    # arc-length position of the point of the contour closest to ``start``
    A, AB = closed[:-1], np.diff(closed, axis=0)
    t = np.clip(np.einsum("ij,ij->i", start - A, AB) / np.maximum(seg ** 2, 1e-300), 0, 1)
    k = int(np.argmin(np.linalg.norm(A + t[:, None] * AB - start, axis=1)))
    s0 = s[k] + t[k] * seg[k]
    target = (s0 + np.arange(n) / n * s[-1]) % s[-1]
    return np.stack([np.interp(target, s, closed[:, d]) for d in range(3)], axis=-1)


def loop_vector(C: np.ndarray) -> np.ndarray:
    """Vector area of a closed polygon (its norm is the area)."""
    return 0.5 * np.cross(C, np.roll(C, -1, axis=0)).sum(axis=0)


def polygon_centroid(C: np.ndarray, normal: np.ndarray) -> np.ndarray:
    """Area centroid of a planar closed polygon ``C (n, 3)``."""
    c0 = C.mean(axis=0)
    P, Q = C - c0, np.roll(C, -1, axis=0) - c0
    w = np.cross(P, Q) @ normal  # twice the signed triangle areas
    if abs(w.sum()) < 1e-300:
        return c0
    return c0 + ((P + Q) * w[:, None]).sum(axis=0) / (3.0 * w.sum())


def sections_of_mesh(V: np.ndarray, F: np.ndarray, origins: np.ndarray, normals: np.ndarray,
                     rings: np.ndarray, n_points: int, *, max_offset: float = 0.5):
    """Cut one frame's mesh with every plane; keep the contour that follows the grid ring.

    ``origins``, ``normals`` are ``(n_v, 3)``; ``rings (n_u, n_v, 3)`` is the
    wall's grid (on the surface, ``rings[0]`` the seam). The section of row j
    is the closed contour around the plane's origin; it is accepted when it
    and ring j, projected onto the plane, are within ``max_offset`` x the
    ring's mean radius of each other (symmetric Hausdorff distance). A plane
    through a neck of a folded or chambered tube can also cut a neighbouring
    bulge and return a merged contour; there, and where no closed contour
    exists, the section is ring j projected onto the plane.

    Returns ``area (n_v,)`` mm^2, ``centroid (n_v, 3)`` mm, ``contour
    (n_points, n_v, 3)`` mm and ``from_ring (n_v,)`` (True where the
    projected ring was used).
    """
    n_v = len(origins)
    area = np.empty(n_v)
    centroid = np.empty((n_v, 3))
    contour = np.empty((n_points, n_v, 3))
    from_ring = np.zeros(n_v, dtype=bool)
    # The end planes lie on the mesh's boundary loops: cut 5 % of a row inside,
    # and move what is found back onto the plane.
    step = np.linalg.norm(np.diff(origins, axis=0), axis=1).mean()
    shift = np.zeros((n_v, 3))
    shift[0] = 0.05 * step * normals[0]
    shift[-1] = -0.05 * step * normals[-1]
    all_contours = planes_contours(V, F, origins + shift, normals)
    # rings projected onto their planes
    height = np.einsum("ijk,jk->ij", rings - origins, normals)
    flat = rings - height[..., None] * normals
    radius = np.linalg.norm(flat - flat.mean(axis=0), axis=2).mean(axis=0)
    for j in range(n_v):
        C = contour_around(all_contours[j], origins[j] + shift[j], normals[j])
        if C is not None:
            C = C - shift[j]
            if _hausdorff(C, flat[:, j]) > max_offset * radius[j]:
                C = None
        if C is None:
            C = flat[:, j]
            from_ring[j] = True
        area[j] = polygon_area(C, normals[j])
        centroid[j] = polygon_centroid(C, normals[j])
        contour[:, j] = orient_and_resample(C, normals[j], rings[0, j], n_points)
    return area, centroid, contour, from_ring


def _hausdorff(P: np.ndarray, Q: np.ndarray) -> float:
    """Symmetric Hausdorff distance between point sets ``P (n, 3)`` and ``Q (m, 3)``."""
    d = np.linalg.norm(P[:, None, :] - Q[None, :, :], axis=2)
    return float(max(d.min(axis=1).max(), d.min(axis=0).max()))


def slab_thickness(centroid: np.ndarray, normals: np.ndarray) -> np.ndarray:
    """Thickness (mm) of the slab between consecutive sections, ``(n_v - 1, ...)``.

    The centroid step along the two planes' mean normal: the height of the
    slab whose volume is area x thickness (Pappus), which the centroid
    distance overestimates where the centroid line zig-zags sideways.
    ``centroid``, ``normals``: ``(n_v, ..., 3)``.
    """
    mean_normal = normals[1:] + normals[:-1]
    mean_normal = mean_normal / np.linalg.norm(mean_normal, axis=-1, keepdims=True)
    return np.einsum("...i,...i", np.diff(centroid, axis=0), mean_normal)


def volume_from_sections(area: np.ndarray, thickness: np.ndarray) -> np.ndarray:
    """Volume (mm^3) by the trapezoid rule: ``area (n_v, ...)``, ``thickness (n_v - 1, ...)``."""
    return (0.5 * (area[1:] + area[:-1]) * thickness).sum(axis=0)
