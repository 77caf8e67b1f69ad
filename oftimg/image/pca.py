"""Cross-section shape statistics in the square-root velocity framework (Kurtek et al.).

Closed planar curves ``beta (n_pts, 2)`` mm are represented by their SRVF
``q = beta' / sqrt(|beta'|)`` (derivative per unit parameter, parameter in
[0, 1)). Size is kept (no scaling to unit length): the first mode of a beating
tube is its size change. Curves are aligned to the mean by rotation and by
the choice of start point (cyclic shift, a search over all n_pts seeds).
oftimg's contours come from a consistent grid, evenly spaced by arc length
from the seam, so the point correspondence is already given: there is no
elastic re-parameterisation (the part of fdasrsf that dominates its run time
and that would move points along the contour). The mean is the Karcher mean
of the aligned SRVFs, iterated until the alignment stops changing.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import InputError
from ..mesh.topology import loop_vector_area


def srvf(beta: np.ndarray) -> np.ndarray:
    """SRVF ``(..., n, 2)`` of closed curves ``beta (..., n, 2)``.

    Forward differences (velocity on the segment k -> k+1), so that
    :func:`curve_from_srvf` gives the points back exactly.
    """
    n = beta.shape[-2]
    d = (np.roll(beta, -1, axis=-2) - beta) * n
    speed = np.linalg.norm(d, axis=-1, keepdims=True)
    return d / np.sqrt(np.maximum(speed, 1e-300))


def curve_from_srvf(q: np.ndarray) -> np.ndarray:
    """Closed curve ``(n, 2)`` (centroid at 0) whose SRVF is ``q``: integrates q|q|."""
    n = q.shape[-2]
    d = q * np.linalg.norm(q, axis=-1, keepdims=True) / n
    d = d - d.mean(axis=-2, keepdims=True)  # a closed curve's steps sum to zero
    beta = np.concatenate(
        [np.zeros_like(d[..., :1, :]), np.cumsum(d[..., :-1, :], axis=-2)], axis=-2
    )
    return beta - beta.mean(axis=-2, keepdims=True)


def align(beta: np.ndarray, ref: np.ndarray) -> np.ndarray:
    """``beta (n, 2)`` rotated and cyclically re-seeded to best match ``ref (n, 2)``.

    Both centred. For every start point the optimal rotation is the 2-D Kabsch
    solution; the pair with the smallest squared distance wins.
    """
    shift, R = align_transform(beta, ref)
    b = beta - beta.mean(axis=0)
    return np.roll(b, -shift, axis=0) @ R.T


def align_transform(beta: np.ndarray, ref: np.ndarray) -> tuple[int, np.ndarray]:
    """The start-point shift and rotation ``R (2, 2)`` used by :func:`align`."""
    b = beta - beta.mean(axis=0)
    r = ref - ref.mean(axis=0)
    n = len(b)
    shifts = b[(np.arange(n)[:, None] + np.arange(n)) % n]  # (n, n, 2): row k = roll -k
    # sum over points of x_b*x_r + y_b*y_r and x_b*y_r - y_b*x_r
    c = np.einsum("kij,ij->k", shifts, r)
    s = np.einsum("ki,i->k", shifts[:, :, 0], r[:, 1]) - np.einsum(
        "ki,i->k", shifts[:, :, 1], r[:, 0]
    )
    k = int(np.argmax(np.hypot(c, s)))
    angle = np.arctan2(s[k], c[k])
    return k, np.array([[np.cos(angle), -np.sin(angle)], [np.sin(angle), np.cos(angle)]])


@dataclass(frozen=True)
class ShapePCA:
    """Mean shape, modes and their variances for a set of closed curves (mm)."""

    mean: np.ndarray  # (n, 2) mean curve
    aligned: np.ndarray  # (n_curves, n, 2) curves aligned to the mean
    displacement: np.ndarray  # (n_modes, n, 2) linearised displacement at 1 sd of each mode
    variance: np.ndarray  # (n_modes,) variance of each mode's score (SRVF units)
    explained: np.ndarray  # (n_modes,) share of the total variance
    scores: np.ndarray  # (n_curves, n_modes)
    iterations: int
    converged: bool


def karcher_mean(curves: np.ndarray, *, max_iter: int = 30, tol: float = 1e-6):
    """Mean of closed curves ``(n_curves, n, 2)`` under rotation and re-seeding.

    Returns ``(mean (n, 2), aligned (n_curves, n, 2), iterations, converged)``;
    converged when the mean moves by less than ``tol`` (relative, squared).
    """
    curves = curves - curves.mean(axis=1, keepdims=True)
    mean = curves[0]
    for it in range(1, max_iter + 1):
        aligned = np.stack([align(c, mean) for c in curves])
        new = curve_from_srvf(srvf(aligned).mean(axis=0))
        change = np.sum((new - mean) ** 2) / np.sum(mean**2)
        mean = new
        if change < tol:
            return mean, aligned, it, True
    return mean, aligned, max_iter, False


def shape_pca(
    curves: np.ndarray, *, n_modes: int = 3, max_iter: int = 30, tol: float = 1e-6
) -> ShapePCA:
    """Principal modes of closed curves ``(n_curves, n, 2)`` in SRVF space, size kept."""
    curves = np.asarray(curves, float)
    if curves.ndim != 3 or curves.shape[2] != 2 or len(curves) < 3:
        raise InputError(f"need at least 3 planar curves (n_curves, n, 2), found {curves.shape}")
    mean, aligned, iterations, converged = karcher_mean(curves, max_iter=max_iter, tol=tol)
    Q = srvf(aligned).reshape(len(curves), -1)
    q_mean = Q.mean(axis=0)
    U, s, Vt = np.linalg.svd(Q - q_mean, full_matrices=False)
    n_modes = min(n_modes, len(s))
    variance = s**2 / (len(curves) - 1)
    modes = Vt[:n_modes].copy()
    base = curve_from_srvf(q_mean.reshape(-1, 2))
    normals = outward_normals(base)
    eps = 1e-3 * np.linalg.norm(q_mean)

    def tangent(mode):
        """Displacement of the curve per unit step along ``mode`` (central difference:
        the map from q to the curve is quadratic, so +/- steps differ)."""
        return (
            curve_from_srvf((q_mean + eps * mode).reshape(-1, 2))
            - curve_from_srvf((q_mean - eps * mode).reshape(-1, 2))
        ) / (2 * eps)

    disp = []
    for k in range(n_modes):  # sign convention: a mode's mean displacement points outwards
        d = tangent(modes[k]) * np.sqrt(variance[k])
        if np.sum(d * normals) < 0:
            modes[k], d = -modes[k], -d
        disp.append(d)
    disp = np.stack(disp)
    return ShapePCA(
        mean=base,
        aligned=aligned,
        displacement=disp,
        variance=variance[:n_modes],
        # all sections the same shape (a still tube): no mode explains anything
        explained=variance[:n_modes] / max(variance.sum(), np.finfo(float).tiny),
        scores=(Q - q_mean) @ modes.T,
        iterations=iterations,
        converged=converged,
    )


def outward_normals(curve: np.ndarray) -> np.ndarray:
    """Unit outward normals ``(n, 2)`` of a closed curve (either orientation)."""
    t = np.roll(curve, -1, axis=0) - np.roll(curve, 1, axis=0)
    n = np.stack([t[:, 1], -t[:, 0]], axis=1)
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    if np.sum(n * (curve - curve.mean(axis=0))) < 0:
        n = -n
    return n


def ring_to_plane(ring: np.ndarray) -> np.ndarray:
    """Planar coordinates ``(..., n, 2)`` mm of nearly planar 3-D rings ``(..., n, 3)``.

    Each ring's best-fit plane; x from its centroid towards its first point
    (the seam), y completing a right-handed frame with the ring's turning
    direction as the normal.
    """
    c = ring.mean(axis=-2, keepdims=True)
    X = ring - c
    vec_area = loop_vector_area(X)
    normal = vec_area / np.linalg.norm(vec_area, axis=-1, keepdims=True)
    first = X[..., 0, :]
    e1 = first - np.sum(first * normal, axis=-1, keepdims=True) * normal
    e1 /= np.linalg.norm(e1, axis=-1, keepdims=True)
    e2 = np.cross(normal, e1)
    return np.stack(
        [np.sum(X * e1[..., None, :], axis=-1), np.sum(X * e2[..., None, :], axis=-1)], axis=-1
    )


PHASES = ("expansion", "contraction")


def contour_pca(grid: np.ndarray, t_max: int, *, rows_v=(0.1, 0.5, 0.9), n_modes: int = 3) -> dict:
    """Shape PCA of grid rings ``grid (n_u, n_v, n_t, 3)`` per row and cycle phase.

    The expansion phase is frames 0..t_max (minimum to maximum volume), the
    contraction phase the rest. Returns ``{"arrays": {...}, "summary": {...}}``
    with, per row k and phase, the mean contour (mm, in its plane), each
    mode's displacement at one standard deviation (mm), explained variance
    and convergence.
    """
    n_u, n_v, n_t, _ = grid.shape
    arrays, summary = {}, {"rows_v": list(rows_v), "n_modes": n_modes, "rows": []}
    for k, v in enumerate(rows_v):
        j = int(round(v * (n_v - 1)))
        row = {"v": float(v), "row": j}
        for phase, frames in zip(PHASES, (np.arange(0, t_max + 1), np.arange(t_max, n_t))):
            curves = ring_to_plane(np.moveaxis(grid[:, j, frames], 1, 0))  # (n_f, n_u, 2)
            res = shape_pca(curves, n_modes=n_modes)
            key = f"row{k}_{phase}"
            arrays[f"pca_{key}_mean_mm"] = res.mean
            arrays[f"pca_{key}_displacement_mm"] = res.displacement
            arrays[f"pca_{key}_explained"] = res.explained
            arrays[f"pca_{key}_scores"] = res.scores
            row[phase] = {
                "explained": res.explained.tolist(),
                "converged": res.converged,
                "iterations": res.iterations,
                "n_contours": len(frames),
            }
        summary["rows"].append(row)
    return {"arrays": arrays, "summary": summary}
