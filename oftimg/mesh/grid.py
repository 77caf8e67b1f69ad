"""One consistent (u, v) grid per frame: seam, temporal smoothing, map, resample.

The steps of the paper's section 4.1, each a function of one frame's arrays
except :func:`smooth_endpoints`, which couples frames in time.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.ndimage import gaussian_filter1d

from ..errors import InputError
from .geodesic import METHODS, GeodesicSolver, insert_boundary_point, insert_path, locate_on_edges
from .parameterize import FlatSampler, cut_and_map, even_grid
from .topology import MeshError


@dataclass(frozen=True)
class GridOptions:
    """Options of the parameterization (same names everywhere)."""

    n_u: int = 80
    n_v: int = 50
    authalic_weight: float = 0.5
    respace: bool = True
    seam_smoothing_frames: float = 1.0
    seam_method: str = "graph"
    # Taubin steps on every wall's mesh before anything is measured on it: "auto" takes
    # ROUGH_STEPS where the mesh is rough at its vertices (curvature.vertex_roughness over
    # the median edge at least ROUGH_SHARE) and none elsewhere; 0: never (the paper); a
    # dict: wall -> steps (the pipeline's decision for a whole dataset)
    rough_mesh_smoothing: int | str = "auto"

    def __post_init__(self):
        if self.n_u < 3 or self.n_v < 2:
            raise InputError(f"grid must be at least 3 x 2, found {self.n_u} x {self.n_v}")
        steps = self.rough_mesh_smoothing
        if not (
            steps == "auto"
            or isinstance(steps, dict)
            or (
                isinstance(steps, (int, np.integer))
                and not isinstance(steps, bool)
                and 0 <= steps <= 1000
            )
        ):
            raise InputError(
                'rough_mesh_smoothing must be "auto" or a whole number of '
                f"Taubin steps from 0 to 1000, found {steps!r}"
            )
        if self.seam_smoothing_frames < 0:
            raise InputError("seam_smoothing_frames must be >= 0")
        if self.seam_method not in METHODS:
            raise InputError(f"seam_method must be one of {METHODS}, found {self.seam_method!r}")


@dataclass(frozen=True)
class FrameGrid:
    """Grid of one frame: ``X (n_u, n_v, 3)`` mm plus diagnostics."""

    X: np.ndarray
    seam_length_mm: float
    flipped: int
    seam_in: np.ndarray
    seam_out: np.ndarray
    flipped_before_repair: int = 0
    values: np.ndarray | None = None  # (n_u, n_v): per-vertex values given to grid_frame


def seam_endpoints(
    V, F, inlet, outlet, *, method: str = "graph"
) -> tuple[np.ndarray, np.ndarray, float]:
    """End points (mm) and length of the shortest inlet-to-outlet geodesic."""
    src, tgt, length = GeodesicSolver(V, F, method=method).shortest_between(inlet, outlet)
    return V[src].copy(), V[tgt].copy(), length


# the seam's ends: edge-path lengths around each loop, smoothed over this angle, within
# this share of the shortest are ties (on independent meshes of a rigid cylinder the
# smoothed lengths spread by 0.6-1.6 % around the loop)
SEAM_PROFILE_SIGMA = np.radians(6.0)
SEAM_TIE_TOLERANCE = 0.02
# a loop has no one shortest seam end when the longest smoothed length is within this
# share of the shortest (the phantoms' bends: 18-45 %), or when ties lie apart from the
# shortest's own arc (two sides equally short): its end continues its neighbours'
SEAM_FLAT_CONTRAST = 0.05
# consecutive seam ends farther apart than this are a jump: never smoothed across
SEAM_JUMP = np.radians(60.0)


@dataclass(frozen=True)
class SeamCandidates:
    """One frame's choices for the seam's ends, from :func:`seam_candidates`.

    ``best (2, 3)`` mm: the ends of the shortest inlet-to-outlet geodesic;
    ``loops``: the inlet and outlet loops' points ``(n_k, 3)`` mm in loop order;
    ``lengths``: each loop point's edge-path distance (mm) to the other loop.
    """

    best: np.ndarray
    loops: tuple[np.ndarray, np.ndarray]
    lengths: tuple[np.ndarray, np.ndarray]


def seam_candidates(V, F, inlet, outlet, *, method: str = "graph") -> SeamCandidates:
    """The shortest seam's ends and how long a seam from every other loop point runs."""
    solver = GeodesicSolver(V, F, method=method)
    src, tgt, _ = solver.shortest_between(inlet, outlet)
    return SeamCandidates(
        best=np.stack([V[src], V[tgt]]),
        loops=(V[inlet].copy(), V[outlet].copy()),
        lengths=(solver.distance_to_loop(inlet, outlet), solver.distance_to_loop(outlet, inlet)),
    )


def _loop_angles(P: np.ndarray, axis: np.ndarray, reference: np.ndarray, extra: np.ndarray):
    """Angles (rad) of the points ``P (n, 3)`` of a loop and of ``extra (3,)`` about
    the loop's centroid, in the plane normal to ``axis`` (3,), from ``reference``
    (3,) projected on it, and a function taking angles back to points on the loop."""
    centre = P.mean(axis=0)
    n = axis / np.linalg.norm(axis)
    e1 = reference - (reference @ n) * n
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(n, e1)
    d = np.vstack([P, extra]) - centre
    phi = np.arctan2(d @ e2, d @ e1)
    order = np.argsort(phi[:-1])

    def at(theta):
        return np.array(
            [
                np.interp(_gap(theta, 0.0), phi[order], P[order, k], period=2 * np.pi)
                for k in range(3)
            ]
        )

    return phi[:-1], phi[-1], at


def _tie_angles(phi: np.ndarray, lengths: np.ndarray, n_bins: int = 360):
    """Angles ``(n_bins,)`` around a loop (symmetric about 0: a mirrored loop gives
    the same), whether a seam from there ties the shortest
    (:data:`SEAM_TIE_TOLERANCE`, lengths smoothed over :data:`SEAM_PROFILE_SIGMA`),
    and whether the loop has no one shortest end (:data:`SEAM_FLAT_CONTRAST`)."""
    grid = (np.arange(n_bins) + 0.5) * (2 * np.pi / n_bins) - np.pi
    order = np.argsort(phi)
    profile = np.interp(grid, phi[order], lengths[order], period=2 * np.pi)
    profile = gaussian_filter1d(profile, SEAM_PROFILE_SIGMA / (2 * np.pi / n_bins), mode="wrap")
    near = profile <= profile.min() * (1 + SEAM_TIE_TOLERANCE)
    if near.all() or profile.max() < profile.min() * (1 + SEAM_FLAT_CONTRAST):
        return grid, near, True
    start = int(np.argmin(near))  # a bin that is no tie: arcs from there
    arcs = np.cumsum(np.diff(np.roll(near, -start).astype(int), prepend=0) == 1)
    arcs = np.roll(arcs, start)
    return grid, near, bool(len(np.unique(arcs[near])) > 1)


def _gap(a, b):
    """Angle (rad) from ``b`` to ``a``, wrapped into [-pi, pi)."""
    return np.mod(np.asarray(a) - b + np.pi, 2 * np.pi) - np.pi


def smooth_angles(theta: np.ndarray, sigma_frames: float) -> np.ndarray:
    """Periodic Gaussian smoothing in time of angles ``theta (n_t,)`` rad that wrap,
    never across a jump of more than :data:`SEAM_JUMP` between frames (the runs
    between jumps are smoothed each on its own)."""
    n_t = len(theta)
    if sigma_frames <= 0 or n_t < 3:
        return theta.copy()
    step = _gap(np.roll(theta, -1), theta)  # t -> t + 1, the last to the first
    jumps = np.nonzero(np.abs(step) > SEAM_JUMP)[0]
    if len(jumps) == 0:
        z = gaussian_filter1d(
            np.exp(1j * theta).real, sigma_frames, mode="wrap"
        ) + 1j * gaussian_filter1d(np.exp(1j * theta).imag, sigma_frames, mode="wrap")
        return np.angle(z)
    out = np.empty(n_t)
    starts = (jumps + 1) % n_t
    for a, length in zip(starts, np.diff(np.append(jumps, jumps[0] + n_t))):
        run = (a + np.arange(length)) % n_t
        unwrapped = theta[run[0]] + np.concatenate([[0.0], np.cumsum(step[run[:-1]])])
        out[run] = gaussian_filter1d(unwrapped, sigma_frames, mode="nearest")
    return _gap(out, 0.0)


def continuous_seam_ends(
    frames: list[SeamCandidates], sigma_frames: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The seam's ends for every frame of a cycle, continuous in time.

    Where a loop has one shortest seam end, that is the end. Where seams from a
    wide arc of the loop tie the shortest within the edge paths' accuracy (a
    straight or nearly round tube, a bend that flattens), the end is the tie
    nearest the ends of the closest frames before and after that have one
    (interpolated between them in time), or, when no frame has one, nearest the
    end of the frame whose lengths vary most around the loop: on a cylinder
    every straight line is a shortest seam, and a free choice spun the grid from
    frame to frame. The rule reads the cycle the same from any start and either
    way round. The ends' angles about their loops are then smoothed in time
    (:func:`smooth_angles`).

    Returns ``p_in, p_out (n_t, 3)`` mm on the loops and ``chosen (n_t,)`` bool:
    frames whose seam continues its neighbours' rather than its own shortest.
    """
    n_t = len(frames)
    contrast = np.zeros(n_t)
    for t, c in enumerate(frames):  # a frame's seam: unique by how much?
        for e in (0, 1):
            contrast[t] += np.ptp(c.lengths[e]) / c.lengths[e].min()
    lead = frames[int(np.argmax(contrast))]
    axis = lead.loops[1].mean(axis=0) - lead.loops[0].mean(axis=0)
    reference = lead.best[0] - lead.loops[0].mean(axis=0)
    ends, chosen = [], np.zeros(n_t, dtype=bool)
    for e in (0, 1):
        best, ties, back = np.empty(n_t), [], []
        ambiguous = np.zeros(n_t, dtype=bool)
        for t, c in enumerate(frames):
            phi, best[t], at = _loop_angles(c.loops[e], axis, reference, c.best[e])
            back.append(at)
            grid, near, ambiguous[t] = _tie_angles(phi, c.lengths[e])
            ties.append((grid, near))
        theta = best.copy()
        anchors = np.nonzero(~ambiguous)[0]
        lead_theta = best[int(np.argmax(contrast))]
        for t in np.nonzero(ambiguous)[0]:
            target = lead_theta
            if len(anchors):
                before = anchors[np.argmin((t - anchors) % n_t)]
                after = anchors[np.argmin((anchors - t) % n_t)]
                a, b = (t - before) % n_t, (after - t) % n_t
                target = best[before] + _gap(best[after], best[before]) * a / (a + b)
            grid, near = ties[t]
            if not near[int(np.argmin(np.abs(_gap(grid, target))))]:  # else: target itself
                gap = _gap(grid[near], target)
                target = target + gap[np.argmin(np.abs(gap))]
            theta[t] = target
        chosen |= ambiguous
        theta = smooth_angles(theta, sigma_frames)
        ends.append(np.array([back[t](theta[t]) for t in range(n_t)]))
    return ends[0], ends[1], chosen


def grid_frame(
    V, F, inlet, outlet, p_in, p_out, options: GridOptions, values: np.ndarray | None = None
) -> FrameGrid:
    """Grid of one frame whose seam joins the loop points nearest ``p_in``, ``p_out``.

    Per-vertex ``values (n_vert,)`` (a curvature, say) are interpolated at the
    grid nodes like the positions are (``FrameGrid.values``).
    """
    n_vert = len(V)
    V, F, inlet, a = insert_boundary_point(V, F, inlet, p_in)
    V, F, outlet, b = insert_boundary_point(V, F, outlet, p_out)
    solver = GeodesicSolver(V, F)
    path = solver.path(a, b)
    events = locate_on_edges(V, F, path, a, b)
    V2, F2, chain = insert_path(V, F, events)
    chain = trim_to_loops(chain, inlet, outlet)
    a, b = int(chain[0]), int(chain[-1])
    flat = cut_and_map(V2, F2, inlet, outlet, chain, authalic_weight=options.authalic_weight)
    sample = FlatSampler(flat)
    X, U, v = even_grid(sample, options.n_u, options.n_v, respace=options.respace)
    at_nodes = None
    if values is not None:
        refined = _refined_values(values, V2, n_vert, (inlet, outlet), events)
        at_nodes = sample(
            U, np.broadcast_to(v, U.shape), values=np.concatenate([refined, refined[chain]])
        )  # cut: seam twice
    seam_len = float(np.linalg.norm(np.diff(V2[chain], axis=0), axis=1).sum())
    return FrameGrid(
        X=X,
        seam_length_mm=seam_len,
        flipped=flat.flipped,
        seam_in=V2[a].copy(),
        seam_out=V2[b].copy(),
        flipped_before_repair=flat.flipped_before_repair,
        values=at_nodes,
    )


def _refined_values(values: np.ndarray, V: np.ndarray, n_vert: int, loops, events) -> np.ndarray:
    """``values (n_vert,)`` extended to the vertices :func:`grid_frame` inserted, each
    on an edge of the mesh before: first the loop points (between their loop
    neighbours), then the seam's edge crossings (``events``), in that order."""
    out = np.empty(len(V))
    out[:n_vert] = values
    crossings = np.array([ev[1:] for ev in events if ev[0] == "e"]).reshape(-1, 3)
    n_before_path = len(V) - len(crossings)
    for x in range(n_vert, n_before_path):
        loop = next(lp for lp in loops if x in lp)
        k = int(np.nonzero(loop == x)[0][0])
        i, j = loop[k - 1], loop[(k + 1) % len(loop)]
        t = np.linalg.norm(V[x] - V[i]) / np.linalg.norm(V[j] - V[i])
        out[x] = (1 - t) * out[i] + t * out[j]
    i, j, t = crossings[:, 0].astype(np.int64), crossings[:, 1].astype(np.int64), crossings[:, 2]
    out[n_before_path:] = (1 - t) * out[i] + t * out[j]
    return out


def trim_to_loops(chain: np.ndarray, inlet: np.ndarray, outlet: np.ndarray) -> np.ndarray:
    """The part of a seam chain between its last inlet vertex and the first outlet
    vertex after it (a geodesic may run along a boundary edge at either end)."""
    on_in = np.isin(chain, inlet)
    on_out = np.isin(chain, outlet)
    start = int(np.nonzero(on_in)[0].max())
    after = np.nonzero(on_out[start:])[0]
    if len(after) == 0:
        raise MeshError("the seam does not reach the outlet loop")
    return chain[start : start + int(after[0]) + 1]


def project_towards_axis(
    V: np.ndarray,
    F: np.ndarray,
    inlet: np.ndarray,
    outlet: np.ndarray,
    X: np.ndarray,
    centre: np.ndarray | None = None,
    *,
    uncounted_rows: np.ndarray | None = None,
) -> tuple[np.ndarray, int]:
    """The grid ``X (n_u, n_v, 3)`` of the outer wall carried onto the inner wall
    ``(V, F)`` (paper section 4.1): each node along the line towards its row's
    centre (``centre (n_v, 3)`` mm; by default the mean of the row's nodes), to
    the first point of the wall on the way; the first and last rows to the points
    of the wall's ``inlet`` and ``outlet`` loops nearest those lines, on the same
    side of the centre. (Given the inner grid and the outer rows' centres, it
    carries the inner grid on along the same lines onto the lumen.)

    The paper takes the closest point of the inner surface, which for a round
    tube is the same point. On a mesh of flat triangles the closest point sticks
    to the edges and vertices that bulge towards the outer wall (a wedge of
    nodes lands on one edge, a cone on one vertex), and along the outer wall's
    normals the nodes crowd where the wall is more curved than it is thick:
    either way the inner grid's strain against t = 0 ran into thousands. The
    line towards the centre meets the facets smoothly and keeps the nodes' order
    around any section that is star-shaped about its centre. A node whose line
    meets no wall before the centre goes the other way along it, away from the
    centre, to the wall within the same distance (the walls cross there: a
    segmentation's inner wall outside its outer one; :func:`signed_thickness` is
    then negative); one that meets no wall either way takes the closest point.
    Returns the positions ``(n_u, n_v, 3)`` mm and how many nodes took the
    closest point (not counting those in ``uncounted_rows (n_v,)`` bool: rows where the
    lumen is closed, whose thin bridge the lines may miss).
    """
    import open3d as o3d

    mid = V.mean(axis=0)  # float32 about the mesh's own centre: ~1 nm steps at 10 mm
    scene = o3d.t.geometry.RaycastingScene()
    scene.add_triangles(
        o3d.core.Tensor((V - mid).astype(np.float32)), o3d.core.Tensor(F.astype(np.uint32))
    )
    q = X - mid
    ends = q.mean(axis=0, keepdims=True) if centre is None else (centre - mid)[None]
    towards = ends - q  # to the row's centre
    reach = np.linalg.norm(towards, axis=-1)
    D = towards / reach[..., None]
    rays = np.concatenate([q, D], axis=-1).reshape(-1, 6).astype(np.float32)
    t_hit = scene.cast_rays(o3d.core.Tensor(rays))["t_hit"].numpy().reshape(reach.shape)
    found = t_hit <= reach
    out = np.where(found[..., None], q + np.where(found, t_hit, 0.0)[..., None] * D, np.nan)
    if not found.all():  # the walls cross: the wall is behind the node
        missed = np.nonzero(~found)
        back = np.concatenate([q[missed], -D[missed]], axis=-1).astype(np.float32)
        t_back = scene.cast_rays(o3d.core.Tensor(back))["t_hit"].numpy()
        behind = t_back <= reach[missed]
        hit = tuple(i[behind] for i in missed)
        out[hit] = q[hit] - t_back[behind, None] * D[hit]
        found[hit] = True
    for row, loop in ((0, inlet), (-1, outlet)):
        out[:, row] = nearest_on_loop_to_rays(V[loop] - mid, q[:, row], D[:, row], reach[:, row])
        found[:, row] = True
    if not found.all():
        near = scene.compute_closest_points(o3d.core.Tensor(q[~found].astype(np.float32)))
        out[~found] = near["points"].numpy()
    if uncounted_rows is not None:  # rows whose misses are expected (no lumen there)
        found[:, np.asarray(uncounted_rows, bool)] = True
    return out + mid, int((~found).sum())


def signed_thickness(X: np.ndarray, Y: np.ndarray, centre: np.ndarray) -> np.ndarray:
    """Distance (mm) from each node of a grid ``X (n_u, n_v, ..., 3)`` to its node of
    ``Y`` (another wall's, :func:`project_towards_axis`), ``(n_u, n_v, ...)``;
    negative where ``Y`` lies away from its row's ``centre (n_v, ..., 3)`` mm:
    where the walls cross."""
    step = Y - X
    towards = np.einsum("...k,...k->...", step, centre[None] - X)
    return np.where(towards < 0, -1.0, 1.0) * np.linalg.norm(step, axis=-1)


def nearest_on_loop_to_rays(
    P: np.ndarray, X: np.ndarray, D: np.ndarray, reach: np.ndarray
) -> np.ndarray:
    """For each ray from ``X (n, 3)`` along unit ``D (n, 3)``, ``reach (n,)`` long, the
    point of the closed polyline ``P (m, 3)`` nearest it, ``(n, 3)``."""
    E = np.roll(P, -1, axis=0) - P  # segments (m, 3)
    W = P[None] - X[:, None]  # (n, m, 3)
    # each segment's point nearest the ray's line: normal equations in (lam, mu)
    de, ee = D @ E.T, np.einsum("mk,mk->m", E, E)
    dw, ew = np.einsum("nk,nmk->nm", D, W), np.einsum("mk,nmk->nm", E, W)
    det = ee - de**2  # 0: parallel
    with np.errstate(invalid="ignore", divide="ignore"):
        mu = np.clip(np.where(det > 1e-12 * ee, (de * dw - ew) / det, 0.0), 0.0, 1.0)
    Q = P[None] + mu[..., None] * E  # (n, m, 3)
    lam = np.clip(np.einsum("nk,nmk->nm", D, Q - X[:, None]), 0.0, reach[:, None])
    gap = np.linalg.norm(Q - X[:, None] - lam[..., None] * D[:, None], axis=-1)
    return Q[np.arange(len(X)), np.argmin(gap, axis=1)]
