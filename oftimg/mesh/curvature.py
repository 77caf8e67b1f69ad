"""Curvature: radial (in-plane) curvature of section contours, mean curvature of surfaces."""

from __future__ import annotations

import numpy as np

from .parameterize import corner_terms
from .topology import interp_grouped


def contour_curvature(C: np.ndarray, normal: np.ndarray, *, window: int = 7) -> np.ndarray:
    """Signed curvature (1/mm) of closed planar contours within their plane.

    ``C (n, ..., 3)``: points evenly spaced by arc length, turning positively
    about ``normal (..., 3)`` (as u does); positive where the contour is
    convex. Derivatives come from a Savitzky-Golay fit (quadratic, ``window``
    points, periodic), which keeps point noise from blowing up the second
    derivative.
    """
    from scipy.signal import savgol_filter  # here: 0.8 s to import, not needed by the workers

    C = np.asarray(C, float)
    normal = np.asarray(normal, float)
    normal = normal / np.linalg.norm(normal, axis=-1, keepdims=True)
    # derivatives per sample: (x' x x'') . n / |x'|^3 does not depend on the parameter
    d1 = savgol_filter(C, window, 2, deriv=1, axis=0, mode="wrap")
    d2 = savgol_filter(C, window, 2, deriv=2, axis=0, mode="wrap")
    cross = np.einsum("...i,...i", np.cross(d1, d2), np.broadcast_to(normal, C.shape))
    with np.errstate(invalid="ignore", divide="ignore"):
        return cross / np.linalg.norm(d1, axis=-1) ** 3


# a corner stands out of the curvature's own noise by this many SDs of the smoothed
# curvature's noise (of a difference of two values): a round tube's noise maxima
# counted as 7 corners before
CORNER_NOISE_SDS = 4.5


def count_corners(
    curvature: np.ndarray, *, min_prominence: float = 0.2, smooth: float = 1 / 40
) -> int:
    """Number of curvature maxima around a closed contour ``(n,)`` that stand out of
    its own noise.

    The curvature is first smoothed around the contour (periodic Gaussian,
    sigma ``smooth`` of its length: 2 of 80 points); a maximum counts when its
    prominence is at least ``min_prominence`` times the smoothed curvature's
    range and :data:`CORNER_NOISE_SDS` SDs of the smoothed curvature's noise, that
    noise measured on the contour itself (:func:`curvature_noise_sd`). Without the
    smoothing, a radial roughness of 1 % of the radius (2 um on the phantoms) made 4
    corners count as 6, and 2.5 % as 10; without the noise's floor, a round tube's
    noise made 7 corners.
    """
    from scipy.ndimage import gaussian_filter1d
    from scipy.signal import find_peaks  # here: 0.8 s to import, not needed by the workers

    k = np.asarray(curvature, float)
    if not np.all(np.isfinite(k)) or np.ptp(k) == 0:
        return 0
    n = len(k)
    floor = 0.0
    if smooth > 0:
        sigma = smooth * n
        weights = np.exp(-0.5 * (np.arange(-4 * sigma, 4 * sigma + 1) / sigma) ** 2)
        gain = float(np.sqrt(np.sum((weights / weights.sum()) ** 2)))  # noise left, a share
        floor = CORNER_NOISE_SDS * np.sqrt(2) * gain * curvature_noise_sd(k)
        k = gaussian_filter1d(k, sigma, mode="wrap")
    tiled = np.concatenate([k, k, k])
    peaks, _ = find_peaks(tiled, prominence=max(min_prominence * np.ptp(k), floor))
    return int(np.count_nonzero((peaks >= n) & (peaks < 2 * n)))


def curvature_noise_sd(curvature: np.ndarray) -> float:
    """The point-to-point noise SD of a curvature ``(n,)`` sampled round a closed
    contour: from its second differences (white noise of SD s gives SD s sqrt(6)), as
    a robust SD (a few corners, each spread over several points, barely move it)."""
    k = np.asarray(curvature, float)
    d2 = np.roll(k, 1) - 2 * k + np.roll(k, -1)
    return float(1.4826 * np.median(np.abs(d2 - np.median(d2))) / np.sqrt(6))


def vertex_mean_curvature(
    V: np.ndarray, F: np.ndarray, boundary: np.ndarray | None = None
) -> np.ndarray:
    """Mean curvature (1/mm) at each vertex: half the cotangent-Laplacian
    mean-curvature normal's length over the vertex's mixed Voronoi area (Meyer
    et al. 2003), signed positive where the surface bends away from its
    (outward) normal, as a cylinder does. Boundary vertices (``boundary``) are
    NaN: their one-ring is not closed.
    """
    cots, l2 = corner_terms(V, F)
    n = len(V)
    i, j = F.ravel(), F[:, [1, 2, 0]].ravel()  # edge k: corner k -> k + 1
    w = cots[:, [2, 0, 1]].ravel()[:, None] * (V[j] - V[i])  # cot of the opposite angle
    LV = _sum_at(np.concatenate([i, j]), np.concatenate([w, -w]), n)
    fn = np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]])
    A = _sum_at(F.ravel(), mixed_areas(cots, l2, 0.5 * np.linalg.norm(fn, axis=1)).ravel(), n)
    normals = _sum_at(F.ravel(), np.repeat(fn, 3, axis=0), n)
    # LV = sum_j (cot a_ij + cot b_ij) (x_j - x_i) = -4 A H n (Meyer et al. 2003)
    H = np.linalg.norm(LV, axis=1) / (4.0 * np.maximum(A, 1e-300))
    sign = -np.sign(np.einsum("ij,ij->i", LV, normals))
    H = H * np.where(sign == 0, 1.0, sign)
    if boundary is not None:
        H[np.asarray(boundary)] = np.nan
    return H


def neighbour_mean(F: np.ndarray, n: int):
    """The sparse ``(n, n)`` operator that takes each vertex's values to the mean of its
    neighbours' (an edge shared by two faces counted once)."""
    import scipy.sparse as sp

    i, j = F.ravel(), F[:, [1, 2, 0]].ravel()
    A = sp.csr_matrix(
        (np.ones(2 * len(i)), (np.concatenate([i, j]), np.concatenate([j, i]))), shape=(n, n)
    )
    A.data[:] = 1.0  # an edge of two faces counts once
    return sp.diags(1.0 / np.maximum(np.asarray(A.sum(axis=1)).ravel(), 1)) @ A


def taubin_smooth(
    V: np.ndarray,
    F: np.ndarray,
    steps: int,
    *,
    fixed: np.ndarray | None = None,
    lam: float = 0.5,
    mu: float = -0.53,
) -> np.ndarray:
    """Vertex positions ``(n, 3)`` after ``steps`` Taubin lambda|mu steps (Taubin 1995):
    each vertex moved ``lam`` of the way to its neighbours' mean, then back by
    ``mu``, which takes roughness at the scale of the edges away with little
    shrinkage of the shape. ``fixed`` vertices (the rims) stay where they are."""
    V = np.asarray(V, float)
    if steps == 0:
        return V
    n = len(V)
    mean_of_neighbours = neighbour_mean(F, n)
    free = np.ones((n, 1))
    if fixed is not None:
        free[np.asarray(fixed)] = 0.0
    for _ in range(int(steps)):
        for factor in (lam, mu):
            V = V + factor * free * (mean_of_neighbours @ V - V)
    return V


def vertex_roughness(V: np.ndarray, F: np.ndarray) -> tuple[float, float]:
    """How rough a mesh is at its own vertices: ``(sigma, edge)`` in V's unit, sigma the
    robust SD of each vertex's normal offset from its neighbours' mean less the mean of
    its neighbours' offsets (a smooth surface's offsets, its curvature, vary smoothly
    from vertex to vertex and cancel there; noise at each vertex does not), edge the
    median edge length. On the phantoms' meshes sigma came out 1.3 times the SD of a
    radial noise drawn at each vertex (0.5-5 um), and at most 1.6 % of the edge
    without noise."""
    V = np.asarray(V, float)
    i, j = F.ravel(), F[:, [1, 2, 0]].ravel()
    mean_of_neighbours = neighbour_mean(F, len(V))
    face_normals = np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]])
    normals = np.zeros_like(V)
    for k in range(3):
        np.add.at(normals, F[:, k], face_normals)
    normals /= np.maximum(np.linalg.norm(normals, axis=1, keepdims=True), 1e-300)
    offset = np.einsum("ij,ij->i", V - mean_of_neighbours @ V, normals)
    own = offset - mean_of_neighbours @ offset
    sigma = 1.4826 * float(np.median(np.abs(own - np.median(own))))
    edges = np.linalg.norm(V[i] - V[j], axis=1)
    return sigma, float(np.median(edges))


ROUGH_SHARE = 0.03  # of the median edge: a mesh this rough at its vertices is smoothed
ROUGH_STEPS = 30  # Taubin steps then (as a label volume's meshes get)


def smoothing_steps(V: np.ndarray, F: np.ndarray, setting: int | str) -> int:
    """Taubin steps for a wall's mesh: ``setting`` when a number; for "auto",
    :func:`steps_for_roughness` of its own roughness."""
    if setting != "auto":
        return int(setting)
    sigma, edge = vertex_roughness(V, F)
    return steps_for_roughness(sigma / edge)


def steps_for_roughness(share: float) -> int:
    """``ROUGH_STEPS`` for a roughness of at least ``ROUGH_SHARE`` of the median edge
    (:func:`vertex_roughness`), else 0. Each frame is segmented and meshed on its own,
    and a curvature or a strain, a second derivative, carries roughness at the vertices
    several times over: in the zoo's mesh draws (0-5 um of it) the radial curvature was
    27 % off in the median and the lumen's mean curvature 108 %."""
    return ROUGH_STEPS if share >= ROUGH_SHARE else 0


def mixed_areas(cots: np.ndarray, l2: np.ndarray, area: np.ndarray) -> np.ndarray:
    """Each face corner's share of its face's area ``(n_face, 3)`` mm^2: its
    Voronoi region where the face has no obtuse angle, else half the face at the
    obtuse corner and a quarter at the others (Meyer et al. 2003: the shares sum
    to the face's area, and to the vertices' Voronoi cells on a good mesh).
    ``cots``, ``l2``: :func:`~oftimg.mesh.parameterize.corner_terms`; ``area (n_face,)``.
    """
    # corner k: 1/8 (|edge k, k+1|^2 cot(k+2) + |edge k+2, k|^2 cot(k+1))
    voronoi = (l2 * cots[:, [2, 0, 1]] + l2[:, [2, 0, 1]] * cots[:, [1, 2, 0]]) / 8.0
    obtuse = cots < 0
    share = np.where(obtuse, 0.5, 0.25) * area[:, None]
    return np.where(obtuse.any(axis=1, keepdims=True), share, voronoi)


def fill_boundary(values: np.ndarray, F: np.ndarray, boundary: np.ndarray) -> np.ndarray:
    """Boundary vertices get the mean of their interior neighbours' values."""
    out = values.copy()
    b = np.zeros(len(values), dtype=bool)
    b[boundary] = True
    i, j = F.ravel(), F[:, [1, 2, 0]].ravel()
    x, y = np.concatenate([i, j]), np.concatenate([j, i])  # both ways along each edge
    take = b[x] & ~b[y] & np.isfinite(values[y])
    total = np.bincount(x[take], values[y[take]], minlength=len(values))
    count = np.bincount(x[take], minlength=len(values))
    fill = b & (count > 0)
    out[fill] = total[fill] / count[fill]
    return out


def _sum_at(index: np.ndarray, values: np.ndarray, n: int) -> np.ndarray:
    """Sums of ``values (m,)`` or ``(m, d)`` by ``index (m,)``: ``(n,)`` or ``(n, d)``
    (``np.add.at``, by ``np.bincount``: ~10x faster)."""
    if values.ndim == 1:
        return np.bincount(index, values, minlength=n)
    return np.stack(
        [np.bincount(index, values[:, c], minlength=n) for c in range(values.shape[1])], axis=1
    )


# -- radial curvature from a section's full-resolution polygon (issue 84) -----------
# A polygon's edge direction, taken at each edge's midpoint (where a circle's tangent
# has the chord's direction) and joined linearly between them, turns at a rate that is
# the curvature at the polygon's own resolution; smoothed by a Gaussian along the arc
# at each of these scales (in the polygon's mean vertex spacings) it is the curvature
# at that scale. Which scale a wall takes is chosen later, over the frames, where each
# scale's noise can be measured (oftimg.analysis.radial_curvature). The polygon's own
# vertices, not a resample: the 80-point resample's Savitzky-Golay fit (before issue
# 84) spans a fixed share of the contour whatever the mesh resolves. Exact on a circle
# at every scale, however irregular its vertices (a polynomial in arc length bends a
# circle's curvature by (scale / radius)^2, turning angles taken at the vertices make
# an irregular polygon's curvature jump from gap to gap).
CURVATURE_SCALES = (1.5, 2.0, 2.8, 4.0, 5.6, 8.0, 11.0)
# the smoothing is done on a periodic grid of this many bins per contour point
BINS_PER_POINT = 16


def polygon_curvature(
    P: np.ndarray,
    poly: np.ndarray,
    arc: np.ndarray,
    length: np.ndarray,
    target: np.ndarray,
    normals: np.ndarray,
    *,
    scales=CURVATURE_SCALES,
) -> tuple[np.ndarray, np.ndarray]:
    """Signed curvature (1/mm, positive where convex) of closed planar polygons at given
    arc-length positions, at each of ``scales``: ``(n_scales, k, n)``, and each polygon's
    mean vertex spacing ``(k,)`` mm (the scales' unit).

    ``P (N, 3)`` mm: the polygons' vertices one after another, each polygon turning
    positively about its ``normals (k, 3)``; ``poly (N,)`` each vertex's polygon,
    ``arc (N,)`` its arc length from its polygon's first vertex (mm), ``length (k,)``
    the polygons' perimeters (mm), ``target (k, n)`` where to measure (mm of arc, from
    ``target[:, 0]`` on round the polygon); ``scales``: the Gaussian's SDs in each
    polygon's mean vertex spacings. The turning is integrated over :data:`BINS_PER_POINT`
    x n bins round each polygon and smoothed there by FFT.
    """
    P, arc, length = np.asarray(P, float), np.asarray(arc, float), np.asarray(length, float)
    target = np.asarray(target, float)
    k, n = target.shape
    counts = np.bincount(poly, minlength=k)
    first = np.concatenate([[0], np.cumsum(counts)[:-1]])
    last = first + counts - 1
    succ = np.arange(len(P)) + 1
    succ[last] = first
    pred = np.empty_like(succ)
    pred[succ] = np.arange(len(P))
    normals = np.asarray(normals, float)
    normals = normals / np.linalg.norm(normals, axis=-1, keepdims=True)
    edge = P[succ] - P
    # each edge's direction at its midpoint, unwrapped round its polygon
    arriving = edge[pred]
    turn = np.arctan2(
        np.einsum("ij,ij->i", np.cross(arriving, edge), normals[poly]),
        np.einsum("ij,ij->i", arriving, edge),
    )
    total = np.bincount(poly, weights=turn, minlength=k)  # 2 pi for a simple polygon
    turn[first] = 0.0  # the first edge's heading: 0
    heading = np.cumsum(turn)
    heading -= np.repeat(heading[first], counts)
    middle = arc + 0.5 * np.linalg.norm(edge, axis=1)
    # one lap before and after each polygon's midpoints: the heading is periodic up to
    # its total turning; abscissae shifted by one perimeter (interp_grouped needs >= 0)
    lap = np.repeat(np.arange(-1, 2), len(P))
    xp = np.tile(middle, 3) + (lap + 1) * np.tile(length[poly], 3)
    fp = np.tile(heading, 3) + lap * np.tile(total[poly], 3)
    group = np.tile(poly, 3)
    order = np.lexsort((xp, group))
    m = BINS_PER_POINT * n
    bounds = (target[:, :1] + np.arange(m + 1)[None, :] * (length[:, None] / m)) % length[
        :, None
    ] + length[:, None]  # (k, m + 1)
    wrapped = np.diff(bounds, axis=1) < 0
    angle = interp_grouped(bounds, xp[order], fp[order, None], group[order])[..., 0]
    step = np.diff(angle, axis=1) + wrapped * total[:, None]
    density = step * (m / length[:, None])  # 1/mm, per bin
    spectrum = np.fft.rfft(density, axis=1)
    cycles = np.arange(m // 2 + 1)  # per perimeter
    spacing = length / np.maximum(counts, 1)
    # the targets on the bins' centres
    where = ((target - target[:, :1]) % length[:, None]) / length[:, None] * m - 0.5
    lo = np.floor(where).astype(int)
    frac = where - lo
    rows = np.arange(k)[:, None]
    out = []
    for scale in scales:
        sigma = scale * spacing / length  # perimeters
        gauss = np.exp(-2 * (np.pi * sigma[:, None] * cycles[None, :]) ** 2)
        # 2 G(sigma) - G(sqrt 2 sigma): the Gaussian's flattening (sigma^2 / 2 times the
        # curvature's second derivative) cancelled, a fourth-order kernel
        smooth = np.fft.irfft(spectrum * (2 * gauss - gauss**2), n=m, axis=1)
        out.append(smooth[rows, lo % m] * (1 - frac) + smooth[rows, (lo + 1) % m] * frac)
    return np.stack(out), spacing


def across_section_terms(X: np.ndarray, plane_normals: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """What a wall's mean curvature needs beyond its sections' curvature, at each node of
    its grid ``X (n_u, n_v, 3)`` mm (u round the tube, periodic; rows ``j`` near the
    section planes of unit normals ``plane_normals (n_v, 3)``).

    Returns Meusnier's factor ``(n_u, n_v)``, by which a section's curvature is the
    surface's normal curvature along the section (the sine of the angle between the
    surface's normal and the plane's normal: 1 where the plane cuts the wall square),
    and the normal curvature ``(n_u, n_v)`` 1/mm across the section (the surface's
    direction at right angles to the section's tangent), from the grid's fundamental
    forms by finite differences (its second derivative along the tube over two rows).
    The mean curvature is half their sum with the section's: the normal curvatures of
    any two orthogonal directions add up to twice it (Euler), and across the sections of a
    tube it changes slowly, where round them a fold or a corner needs the polygon's
    resolution (:func:`polygon_curvature`). Positive where convex, as a cylinder.
    """
    X = np.asarray(X, float)
    Xu = 0.5 * (np.roll(X, -1, axis=0) - np.roll(X, 1, axis=0))
    Xv = np.gradient(X, axis=1)
    Xuu = np.roll(X, -1, axis=0) - 2 * X + np.roll(X, 1, axis=0)
    Xvv = np.gradient(Xv, axis=1)
    Xuv = np.gradient(Xu, axis=1)
    n = np.cross(Xu, Xv)
    n /= np.maximum(np.linalg.norm(n, axis=-1, keepdims=True), 1e-300)
    outward = np.einsum("uvk,uvk->uv", n, X - X.mean(axis=0))
    n *= np.sign(np.median(outward)) or 1.0  # the grid's own turning, once
    nu = np.asarray(plane_normals, float)
    nu = nu / np.linalg.norm(nu, axis=-1, keepdims=True)
    across_plane = np.einsum("uvk,vk->uv", n, nu)
    meusnier = np.sqrt(np.clip(1.0 - across_plane**2, 0.0, 1.0))
    tangent = np.cross(n, nu[None])  # the section's, at each node
    tangent /= np.maximum(np.linalg.norm(tangent, axis=-1, keepdims=True), 1e-300)
    across = np.cross(n, tangent)
    E, F, G = (np.einsum("uvk,uvk->uv", a, b) for a, b in ((Xu, Xu), (Xu, Xv), (Xv, Xv)))
    pu, pv = np.einsum("uvk,uvk->uv", across, Xu), np.einsum("uvk,uvk->uv", across, Xv)
    det = np.where(np.abs(E * G - F * F) > 1e-300, E * G - F * F, np.nan)
    alpha, beta = (G * pu - F * pv) / det, (E * pv - F * pu) / det  # across = a Xu + b Xv
    e, f, g = (np.einsum("uvk,uvk->uv", a, n) for a in (Xuu, Xuv, Xvv))
    return meusnier, -(alpha**2 * e + 2 * alpha * beta * f + beta**2 * g)
