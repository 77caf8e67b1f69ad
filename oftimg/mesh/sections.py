"""Plane sections of triangle meshes: closed contours and their areas."""

from __future__ import annotations

import numpy as np

from .topology import cross3, interp_grouped, loop_vector_area


def plane_contours(
    V: np.ndarray, F: np.ndarray, origin: np.ndarray, normal: np.ndarray
) -> list[tuple[np.ndarray, bool]]:
    """All contours where the plane ``(origin, normal)`` cuts the mesh.

    Returns a list of ``(points (n_pts, 3) mm, closed)``; a closed contour's
    first point is not repeated; open ones end on the mesh boundary.
    """
    return planes_contours(V, F, np.asarray(origin)[None], np.asarray(normal)[None])[0]


def planes_contours(
    V: np.ndarray, F: np.ndarray, origins: np.ndarray, normals: np.ndarray
) -> list[list[tuple[np.ndarray, bool]]]:
    """:func:`plane_contours` for many planes ``(n_planes, 3)`` at once.

    The signed distances of all vertices to all planes are one matrix product,
    packed into one bit per plane: a face is cut where its corners' bits
    differ, and every (plane, cut face) pair is handled in one array. Each cut
    face is entered through one edge and left through another (outward-oriented
    faces give every contour the same sense), so a contour is a walk from face
    to face: the next face enters through the edge this one leaves by.
    """
    normals = np.asarray(normals, float)
    normals = normals / np.linalg.norm(normals, axis=1, keepdims=True)
    n_planes, n = len(normals), len(V)
    D = V @ normals.T - np.einsum("ij,ij->i", origins, normals)[None, :]  # (n_vert, n_planes)
    scale = np.abs(D).max(axis=0, keepdims=True)
    D = np.where(np.abs(D) < 1e-12 * scale, 1e-12 * scale, D)  # no vertex exactly on a plane
    words = -(-n_planes // 64)
    bits = np.zeros((n, 8 * words), np.uint8)
    bits[:, : -(-n_planes // 8)] = np.packbits(D > 0, axis=1, bitorder="little")
    bits = bits.view(np.uint64)  # (n_vert, words)
    differ = (bits[F[:, 0]] ^ bits[F[:, 1]]) | (bits[F[:, 1]] ^ bits[F[:, 2]])
    cut_faces = np.nonzero(differ.any(axis=1))[0]
    cut = np.unpackbits(differ[cut_faces].view(np.uint8), axis=1, bitorder="little")
    plane, k = np.nonzero(cut[:, :n_planes].T)  # cut pairs, by plane then face
    face = cut_faces[k]
    corners = F[face]  # (m, 3)
    pos = D[corners, plane[:, None]] > 0
    nxt_pos = np.roll(pos, -1, axis=1)
    pair = np.arange(len(face))

    def edge(k_corner):
        """The edge from corner k to k + 1 of each cut face, as ``(first, second)``."""
        return corners[pair, k_corner], corners[pair, (k_corner + 1) % 3]

    def crossing(i, j):
        i, j = np.minimum(i, j), np.maximum(i, j)  # both faces of an edge get the same point
        di, dj = D[i, plane], D[j, plane]
        t = di / (di - dj)
        return V[i] + t[:, None] * (V[j] - V[i])

    a_in, b_in = edge(np.argmax(~pos & nxt_pos, axis=1))  # - -> + across it
    a_out, b_out = edge(np.argmax(pos & ~nxt_pos, axis=1))  # + -> -
    P_in, P_out = crossing(a_in, b_in), crossing(a_out, b_out)
    in_key = (plane * n + b_in) * n + a_in  # a neighbour runs the shared edge backwards
    out_key = (plane * n + a_out) * n + b_out
    by_key = np.argsort(in_key)
    at = by_key[np.clip(np.searchsorted(in_key[by_key], out_key), 0, len(by_key) - 1)]
    nxt = np.where(in_key[at] == out_key, at, -1)  # -1: boundary
    has_prev = np.zeros(len(face), dtype=bool)
    has_prev[nxt[nxt >= 0]] = True
    out = [[] for _ in range(len(normals))]
    nxt_l = nxt.tolist()
    plane_l = plane.tolist()
    seen = [False] * len(face)
    # per plane: open chains first (from a face entered through the boundary), then loops
    for start in np.r_[np.nonzero(~has_prev)[0], np.arange(len(face))].tolist():
        if seen[start]:
            continue
        chain, f = [], start
        while f != -1 and not seen[f]:
            seen[f] = True
            chain.append(f)
            f = nxt_l[f]
        closed = f == start and len(chain) > 2
        pts = P_in[chain] if closed else np.concatenate([P_in[chain], P_out[chain[-1:]]])
        out[plane_l[start]].append((pts, closed))
    return out


def polygon_area(P: np.ndarray, normal: np.ndarray | None = None) -> float:
    """Area (mm^2) enclosed by a closed polygon ``P (n, 3)`` (projected on ``normal``)."""
    A = loop_vector_area(P)
    if normal is None:
        return float(np.linalg.norm(A))
    return float(abs(A @ (np.asarray(normal) / np.linalg.norm(normal))))


def contour_around(
    contours: list[tuple[np.ndarray, bool]], center: np.ndarray, normal: np.ndarray
) -> np.ndarray | None:
    """The closed contour whose projection on the plane encloses ``center``.

    Among several, the one whose centroid is nearest. ``None`` if none does.
    """
    normal = np.asarray(normal, float) / np.linalg.norm(normal)
    return _contours_around([contours], np.asarray(center, float)[None], normal[None])[0]


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
    rings = X.transpose(1, 0, 2)  # (n_v, n_u, 3)
    # side[j, k, i]: signed distance of node i of ring k from plane j
    side = (
        np.einsum("kiv,jv->jki", rings, normals)
        - np.einsum("jv,jv->j", origins, normals)[:, None, None]
    )
    lo_side, hi_side = side.min(axis=2), side.max(axis=2)
    straddle = (lo_side < 0) & (hi_side > 0)  # plane j cuts ring k
    row = np.arange(n_v - 1)
    bad = np.zeros(n_v, dtype=bool)
    bad[row] = (lo_side[row, row + 1] <= 0) | (hi_side[row + 1, row] >= 0)  # neighbours swapped
    j, k = np.nonzero(np.triu(straddle & straddle.T, 1))  # candidate pairs
    if len(j) == 0:
        return bad
    line = np.cross(normals[j], normals[k])  # planes' common line
    chord_k = _chord(rings[k], side[j, k], line)  # section k on it
    chord_j = _chord(rings[j], side[k, j], line)
    meet = np.maximum(chord_k[0], chord_j[0]) <= np.minimum(chord_k[1], chord_j[1])
    bad[j[meet]] = True
    bad[k[meet]] = True
    return bad


def _chord(rings: np.ndarray, side: np.ndarray, line: np.ndarray):
    """Extent along ``line (m, 3)`` of the points where ``rings (m, n_u, 3)``
    cross a plane (``side (m, n_u)``: signed distances of their nodes)."""
    nxt = np.roll(side, -1, axis=1)
    cuts = (side < 0) != (nxt < 0)
    frac = side / np.where(cuts, side - nxt, 1.0)
    proj = np.einsum("miv,mv->mi", rings, line)
    at = proj + frac * (np.roll(proj, -1, axis=1) - proj)
    return np.where(cuts, at, np.inf).min(axis=1), np.where(cuts, at, -np.inf).max(axis=1)


def fix_crossing_planes(
    X: np.ndarray, origins: np.ndarray, normals: np.ndarray, *, max_iter: int = 100
) -> tuple[np.ndarray, int, np.ndarray]:
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
    best, stalled = len(normals) + 1, 0
    for _ in range(max_iter):
        bad = crossing_planes(X, origins, normals)
        if not bad.any():
            return normals, int(changed.sum()), bad
        best, stalled = (bad.sum(), 0) if bad.sum() < best else (best, stalled + 1)
        if stalled >= 10:  # no progress in 10 rounds: these cannot be separated
            break
        rows = np.nonzero(bad)[0]
        rows = rows[(rows > 0) & (rows < len(normals) - 1)]
        if len(rows) == 0:
            break
        blended = normals[rows] + 0.5 * (normals[rows - 1] + normals[rows + 1])
        normals[rows] = blended / np.linalg.norm(blended, axis=1, keepdims=True)
        changed[rows] = True
    bad = crossing_planes(X, origins, normals)
    for run in _runs(changed):
        if bad[max(run[0] - 1, 0) : run[-1] + 2].any():
            normals[run] = original[run]
            changed[run] = False
    return normals, int(changed.sum()), crossing_planes(X, origins, normals)


def _runs(mask: np.ndarray) -> list[np.ndarray]:
    """Index arrays of the runs of consecutive True values in ``mask``."""
    idx = np.nonzero(mask)[0]
    return np.split(idx, np.nonzero(np.diff(idx) > 1)[0] + 1) if len(idx) else []


def orient_and_resample(C: np.ndarray, normal: np.ndarray, start: np.ndarray, n: int) -> np.ndarray:
    """Contour ``C`` as ``n`` points evenly spaced by arc length, in u order.

    Starts at the contour point nearest ``start`` (the seam node) and turns
    positively about ``normal`` (the v direction), as u does.
    """
    normal = np.asarray(normal, float) / np.linalg.norm(normal)
    return _measure_polygons(
        [np.asarray(C, float)], normal[None], np.asarray(start, float)[None], n
    )[2][0]


def sections_of_mesh(
    V: np.ndarray,
    F: np.ndarray,
    origins: np.ndarray,
    normals: np.ndarray,
    rings: np.ndarray,
    n_points: int,
    *,
    max_offset: float = 0.5,
    curvature: bool = False,
    curvature_at: np.ndarray | None = None,
):
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
    projected ring was used); with ``curvature``, also each contour's radial curvature at
    its points at each scale, ``(n_scales, n_points, n_v)`` 1/mm, from the section's own
    polygon (:func:`~oftimg.mesh.curvature.polygon_curvature`), and each polygon's mean
    vertex spacing ``(n_v,)`` mm; with ``curvature_at (m, n_v, 3)`` mm too, the curvature
    at the polygon's points nearest these points instead, ``(n_scales, m, n_v)`` (the
    lumen's mean curvature is read at its own grid's nodes).
    """
    n_v = len(origins)
    at = None if curvature_at is None else np.asarray(curvature_at, float).transpose(1, 0, 2)
    normals = normals / np.linalg.norm(normals, axis=1, keepdims=True)
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

    chosen = _contours_around(all_contours, origins + shift, normals)
    from_ring = np.array([C is None for C in chosen])
    polygons = [flat[:, j] if C is None else C - shift[j] for j, C in enumerate(chosen)]
    area, centroid, resampled, *kappa = _measure_polygons(
        polygons, normals, rings[0], n_points, curvature=curvature, at=at
    )
    # symmetric Hausdorff distance of each (resampled) contour to its projected ring
    B = flat.transpose(1, 0, 2)  # (n_v, n_u, 3)
    d2 = (
        np.einsum("vpk,vpk->vp", resampled, resampled)[:, :, None]
        + np.einsum("vuk,vuk->vu", B, B)[:, None]
        - 2 * resampled @ B.transpose(0, 2, 1)
    )
    offset = np.sqrt(
        np.maximum(np.maximum(d2.min(axis=2).max(axis=1), d2.min(axis=1).max(axis=1)), 0)
    )
    redo = np.nonzero(~from_ring & (offset > max_offset * radius))[0]
    if len(redo):
        from_ring[redo] = True
        redone = _measure_polygons(
            [flat[:, j] for j in redo],
            normals[redo],
            rings[0, redo],
            n_points,
            curvature=curvature,
            at=None if at is None else at[redo],
        )
        for whole, part in zip([area, centroid, resampled], redone):
            whole[redo] = part
        if curvature:
            kappa[0][:, redo], kappa[1][redo] = redone[3], redone[4]
    out = (area, centroid, resampled.transpose(1, 0, 2), from_ring)
    return out + ((kappa[0].transpose(0, 2, 1), kappa[1]) if curvature else ())


def _closed_polygons(polygons: list[np.ndarray]):
    """Closed polygons of different lengths as one array: points ``(N, 3)``, each
    polygon's first index, its length, each point's polygon and its successor."""
    lengths = np.array([len(P) for P in polygons])
    starts = np.concatenate([[0], np.cumsum(lengths)[:-1]])
    poly = np.repeat(np.arange(len(polygons)), lengths)
    succ = np.arange(lengths.sum()) + 1
    succ[starts + lengths - 1] = starts
    return np.concatenate(polygons), starts, lengths, poly, succ


def _plane_bases(normals: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Two unit vectors spanning each plane, ``(n, 3)`` each."""
    e1 = cross3(normals, np.array([1.0, 0, 0]))
    tilted = np.linalg.norm(e1, axis=1) < 0.1
    e1[tilted] = cross3(normals[tilted], np.array([0, 1.0, 0]))
    e1 /= np.linalg.norm(e1, axis=1, keepdims=True)
    return e1, cross3(normals, e1)


def _contours_around(all_contours: list, centers: np.ndarray, normals: np.ndarray) -> list:
    """:func:`contour_around` for every plane at once: per plane the closed contour
    whose projection encloses its center (the nearest by centroid), or None."""
    rows = [j for j, cs in enumerate(all_contours) for _, closed in cs if closed]
    found = [C for cs in all_contours for C, closed in cs if closed]
    chosen = [None] * len(all_contours)
    if not found:
        return chosen
    P, starts, lengths, poly, succ = _closed_polygons(found)
    rows = np.asarray(rows)
    row = rows[poly]
    e1, e2 = _plane_bases(normals)
    rel = P - centers[row]
    ang = np.arctan2(np.einsum("ij,ij->i", rel, e2[row]), np.einsum("ij,ij->i", rel, e1[row]))
    turn = (ang[succ] - ang + np.pi) % (2 * np.pi) - np.pi
    winding = np.rint(np.add.reduceat(turn, starts) / (2 * np.pi))
    dist = np.linalg.norm(np.add.reduceat(P, starts) / lengths[:, None] - centers[rows], axis=1)
    for c in np.lexsort((np.arange(len(found)), dist, rows)):  # by plane, nearest first
        if winding[c] != 0 and chosen[rows[c]] is None:
            chosen[rows[c]] = found[c]
    return chosen


def _measure_polygons(
    polygons: list[np.ndarray],
    normals: np.ndarray,
    starts_near: np.ndarray,
    n: int,
    *,
    curvature: bool = False,
    at: np.ndarray | None = None,
):
    """Area (mm^2), area centroid ``(k, 3)`` and ``n`` points evenly spaced by arc
    length ``(k, n, 3)`` of planar closed polygons, all at once.

    The points turn positively about the polygon's unit normal (``normals (k,
    3)``) and start at the polygon point nearest ``starts_near (k, 3)`` (the
    seam). With ``curvature``, also the polygons' curvature at those points at each
    scale of :func:`~oftimg.mesh.curvature.polygon_curvature`, ``(n_scales, k, n)``
    1/mm, from the polygons' own vertices, not the resample, and their mean vertex
    spacing ``(k,)`` mm; with ``at (k, m, 3)`` mm, the curvature at each polygon's points
    nearest these, ``(n_scales, k, m)``, instead.
    """
    P, starts, lengths, poly, succ = _closed_polygons(polygons)
    k = len(polygons)
    c0 = np.add.reduceat(P, starts) / lengths[:, None]
    Pc = P - c0[poly]
    Qc = Pc[succ]
    w = np.einsum("ij,ij->i", cross3(Pc, Qc), normals[poly])  # twice the signed triangle areas
    total = np.add.reduceat(w, starts)
    degenerate = np.abs(total) < 1e-300
    safe = np.where(degenerate, 1.0, total)
    centroid = c0 + np.where(
        degenerate[:, None],
        0.0,
        np.add.reduceat((Pc + Qc) * w[:, None], starts) / (3.0 * safe[:, None]),
    )
    area = 0.5 * np.abs(total)
    # orient: reverse the polygons that turn negatively
    idx = np.arange(len(P))
    flip = (total < 0)[poly]
    idx[flip] = (2 * starts + lengths - 1)[poly[flip]] - idx[flip]
    P = P[idx]
    AB = P[succ] - P
    seg = np.sqrt(np.einsum("ij,ij->i", AB, AB))
    length = np.add.reduceat(seg, starts)
    s = np.cumsum(seg) - seg  # arc length at each point
    s -= s[starts][poly]
    # arc-length position of the point of each polygon closest to its start point
    near = starts_near[poly]
    t = np.clip(np.einsum("ij,ij->i", near - P, AB) / np.maximum(seg**2, 1e-300), 0, 1)
    off = P + t[:, None] * AB - near
    d2 = np.einsum("ij,ij->i", off, off)
    is_min = d2 == np.minimum.reduceat(d2, starts)[poly]
    first = np.minimum.reduceat(np.where(is_min, np.arange(len(P)), len(P)), starts)
    s0 = s[first] + t[first] * seg[first]
    target = (s0[:, None] + np.arange(n) / n * length[:, None]) % length[:, None]  # (k, n)
    # one np.interp for all: each polygon closed (first point again at its length),
    # its arc length shifted past the previous polygon's
    ends = starts + lengths  # each polygon closed: its first point again
    resampled = interp_grouped(
        target,
        np.insert(s, ends, length),
        np.insert(P, ends, P[starts], axis=0),
        np.insert(poly, ends, np.arange(k)),
    )
    if not curvature:
        return area, centroid, resampled
    from .curvature import polygon_curvature

    if at is not None:
        target = _nearest_arc(P, AB, seg, s, starts, lengths, at)
    return (area, centroid, resampled, *polygon_curvature(P, poly, s, length, target, normals))


def _nearest_arc(
    P: np.ndarray,
    AB: np.ndarray,
    seg: np.ndarray,
    s: np.ndarray,
    starts: np.ndarray,
    lengths: np.ndarray,
    at: np.ndarray,
) -> np.ndarray:
    """The arc length ``(k, m)`` (mm from each polygon's first point) of the point of each
    of ``k`` closed polygons nearest each of its ``at (k, m, 3)`` points: ``P (N, 3)`` the
    polygons' points one after another, ``AB`` each edge's vector to the next point,
    ``seg`` its length, ``s`` each point's arc length. Looked for on the two edges at each
    of the :data:`NEAREST_VERTICES` vertices of its own polygon nearest it (a k-d tree,
    each polygon apart from the others in a fourth coordinate)."""
    from scipy.spatial import cKDTree

    k, m = at.shape[:2]
    poly = np.repeat(np.arange(k), lengths)
    apart = 10.0 * (np.ptp(P, axis=0).max() + np.ptp(at.reshape(-1, 3), axis=0).max() + 1.0)
    tree = cKDTree(np.column_stack([P, poly * apart]))
    points = at.reshape(-1, 3)
    _, near = tree.query(
        np.column_stack([points, np.repeat(np.arange(k), m) * apart]), k=NEAREST_VERTICES
    )  # (k m, n)
    first = starts[poly]
    before = np.where(
        np.arange(len(P)) == first, first + lengths[poly] - 1, np.arange(len(P)) - 1
    )  # the edge arriving at each point
    edges = np.concatenate([near, before[near]], axis=1)  # (k m, 2 n)
    rel = points[:, None, :] - P[edges]
    along = np.clip(
        np.einsum("ijk,ijk->ij", rel, AB[edges]) / np.maximum(seg[edges] ** 2, 1e-300), 0.0, 1.0
    )
    gap = rel - along[..., None] * AB[edges]
    best = np.argmin(np.einsum("ijk,ijk->ij", gap, gap), axis=1)
    rows = np.arange(len(points))
    edge = edges[rows, best]
    return (s[edge] + along[rows, best] * seg[edge]).reshape(k, m)


# the polygon's vertices nearest a point whose two edges are searched for its nearest point
# (3 missed one point in 1300 at a deep fold's valley, where the far wall is as near)
NEAREST_VERTICES = 6


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


def slab_volumes(area: np.ndarray, thickness: np.ndarray) -> np.ndarray:
    """Volume (mm^3) of each slab between consecutive sections, trapezoid rule:
    ``area (n_v, ...)``, ``thickness (n_v - 1, ...)`` -> ``(n_v - 1, ...)``."""
    return 0.5 * (area[1:] + area[:-1]) * thickness


def volume_from_sections(area: np.ndarray, thickness: np.ndarray) -> np.ndarray:
    """Sum of :func:`slab_volumes` (mm^3)."""
    return slab_volumes(area, thickness).sum(axis=0)
