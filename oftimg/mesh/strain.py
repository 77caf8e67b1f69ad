"""In-surface strain of a deforming grid against a reference frame (paper section 6.2)."""
from __future__ import annotations

import numpy as np


def grid_triangles(n_u: int, n_v: int) -> np.ndarray:
    """Triangles ``(2 n_u (n_v - 1), 3)`` of a grid periodic in u (node index i * n_v + j)."""
    idx = np.arange(n_u * n_v).reshape(n_u, n_v)
    a, b = idx[:, :-1], np.roll(idx, -1, axis=0)[:, :-1]
    c, d = np.roll(idx, -1, axis=0)[:, 1:], idx[:, 1:]
    return np.concatenate([np.stack([a, b, c], -1).reshape(-1, 3),
                           np.stack([a, c, d], -1).reshape(-1, 3)])


def _local_frame(P: np.ndarray):
    """2-D coordinates of each triangle's edge vectors in its own orthonormal basis."""
    e1 = P[..., 1, :] - P[..., 0, :]
    e2 = P[..., 2, :] - P[..., 0, :]
    x = e1 / np.linalg.norm(e1, axis=-1, keepdims=True)
    n = np.cross(e1, e2)
    y = np.cross(n / np.linalg.norm(n, axis=-1, keepdims=True), x)
    M = np.stack([np.stack([np.einsum("...i,...i", e, x), np.einsum("...i,...i", e, y)], -1)
                  for e in (e1, e2)], axis=-1)  # columns: edges in the local basis
    return M


def principal_stretches(X_ref: np.ndarray, X: np.ndarray, F: np.ndarray) -> np.ndarray:
    """Principal stretches ``(..., n_tri, 2)`` (largest first) of each triangle.

    ``X_ref (n_node, 3)`` the reference positions, ``X (..., n_node, 3)`` the
    deformed ones. The 2-D deformation gradient maps the reference edges to
    the deformed ones (each in its triangle's own basis); the stretches are
    the square roots of the eigenvalues of C = F^T F.
    """
    with np.errstate(invalid="ignore", divide="ignore"):  # degenerate triangles: NaN
        M0 = _local_frame(X_ref[F])
        M = _local_frame(X[..., F, :])
        bad = ~np.isfinite(M0).all(axis=(-2, -1)) | (np.abs(np.linalg.det(M0)) < 1e-300)
        M0 = np.where(bad[:, None, None], np.eye(2), M0)
        Fd = M @ np.linalg.inv(M0)
        C = np.swapaxes(Fd, -1, -2) @ Fd
        C = np.where(np.isfinite(C), C, 0.0)
        ev = np.linalg.eigvalsh(C)[..., ::-1]
        lam = np.sqrt(np.clip(ev, 0, None))
    bad = bad | ~np.isfinite(M).all(axis=(-2, -1))
    return np.where(bad[..., None], np.nan, lam)


def strain_energy(stretches: np.ndarray) -> np.ndarray:
    """E = (l1 - 1)^2 + (l2 - 1)^2 for stretches ``(..., 2)``."""
    return ((stretches - 1.0) ** 2).sum(axis=-1)


def node_average(values: np.ndarray, F: np.ndarray, n_node: int) -> np.ndarray:
    """Average of per-triangle ``values (..., n_tri)`` over the triangles at each node
    (NaN triangles left out; NaN where all are)."""
    ok = np.isfinite(values)
    vals = np.where(ok, values, 0.0)
    out = np.zeros(values.shape[:-1] + (n_node,))
    count = np.zeros(values.shape[:-1] + (n_node,))
    for k in range(3):
        np.add.at(out, (..., F[:, k]), vals)
        np.add.at(count, (..., F[:, k]), ok.astype(float))
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(count > 0, out / np.where(count > 0, count, 1), np.nan)


def grid_strain(G: np.ndarray, *, reference: int = 0):
    """Strain fields of a deforming grid ``G (n_u, n_v, n_t, 3)`` against frame ``reference``.

    Returns ``energy (n_u, n_v, n_t)`` and ``stretches (n_u, n_v, n_t, 2)``
    (principal stretches l1 >= l2), averaged from triangles to nodes.
    """
    n_u, n_v, n_t, _ = G.shape
    F = grid_triangles(n_u, n_v)
    X = np.moveaxis(G, 2, 0).reshape(n_t, n_u * n_v, 3)
    lam = principal_stretches(X[reference], X, F)                 # (n_t, n_tri, 2)
    energy = node_average(strain_energy(lam), F, n_u * n_v)     # (n_t, n_node)
    l1 = node_average(lam[..., 0], F, n_u * n_v)
    l2 = node_average(lam[..., 1], F, n_u * n_v)
    to_grid = lambda a: np.moveaxis(a.reshape(n_t, n_u, n_v), 0, 2)  # noqa: E731
    return to_grid(energy), np.stack([to_grid(l1), to_grid(l2)], axis=-1)
