"""In-surface strain of a deforming grid against a reference frame (paper section 6.2)."""

from __future__ import annotations

import numpy as np


def grid_triangles(n_u: int, n_v: int) -> np.ndarray:
    """Triangles ``(2 n_u (n_v - 1), 3)`` of a grid periodic in u (node index i * n_v + j)."""
    idx = np.arange(n_u * n_v).reshape(n_u, n_v)
    a, b = idx[:, :-1], np.roll(idx, -1, axis=0)[:, :-1]
    c, d = np.roll(idx, -1, axis=0)[:, 1:], idx[:, 1:]
    return np.concatenate(
        [np.stack([a, b, c], -1).reshape(-1, 3), np.stack([a, c, d], -1).reshape(-1, 3)]
    )


def _upper(e1, e2):
    """Triangles with edges ``e1, e2`` (each a tuple of x, y, z arrays) in their own
    orthonormal basis (x along e1, y towards e2), as the upper-triangular
    ``(a, b, c)``: e1 = (a, 0), e2 = (b, c)."""
    (x1, y1, z1), (x2, y2, z2) = e1, e2
    a = np.sqrt(x1 * x1 + y1 * y1 + z1 * z1)
    twice_area = np.sqrt(
        (y1 * z2 - z1 * y2) ** 2 + (z1 * x2 - x1 * z2) ** 2 + (x1 * y2 - y1 * x2) ** 2
    )  # |e1 x e2|, no cancellation
    return a, (x1 * x2 + y1 * y2 + z1 * z2) / a, twice_area / a


def _stretches(reference, deformed) -> np.ndarray:
    """Principal stretches ``(..., 2)`` (largest first) from the :func:`_upper` forms
    of the same triangles before and after: the singular values of the 2-D
    deformation gradient that maps each triangle's reference edges to its
    deformed ones (each in its own basis), i.e. the square roots of the
    eigenvalues of C = F^T F. NaN where either triangle is degenerate."""
    a0, b0, c0 = reference
    a, b, c = deformed
    with np.errstate(invalid="ignore", divide="ignore"):  # degenerate triangles: NaN
        bad = ~(np.isfinite(a0) & np.isfinite(c0)) | (a0 * c0 < 1e-300)
        # upper-triangular deformation gradient [[p, q], [0, r]] = M M0^-1
        p = a / a0
        q = (b - p * b0) / c0
        r = c / c0
        c11, c12, c22 = p * p, p * q, q * q + r * r
        # eigenvalues of the symmetric 2 x 2 C, closed form
        mean = 0.5 * (c11 + c22)
        radius = np.hypot(0.5 * (c11 - c22), c12)
        lam = np.empty(mean.shape + (2,))
        np.sqrt(np.maximum(mean + radius, 0.0), out=lam[..., 0])
        np.sqrt(np.maximum(mean - radius, 0.0), out=lam[..., 1])
    ok = np.isfinite(lam[..., 0]) & np.isfinite(lam[..., 1]) & (a * c > 0)  # not collapsed
    lam[bad | ~ok] = np.nan
    return lam


def strain_energy(stretches: np.ndarray) -> np.ndarray:
    """E = (l1 - 1)^2 + (l2 - 1)^2 for stretches ``(..., 2)``."""
    return ((stretches - 1.0) ** 2).sum(axis=-1)


def _quad_triangles(P: np.ndarray):
    """Edges e1, e2 of the four triangles of every quad of grids ``P (n_u, n_v, ..., 3)``
    (periodic in u): both splits of the quad (i, j), (i+1, j), (i+1, j+1), (i, j+1)
    = A, B, C, D, i.e. ABC, ACD, ABD, BCD; each a tuple of x, y, z arrays
    ``(4, n_u, n_v - 1, ...)``. Slices of the grid, no index lists."""
    e1, e2 = [], []
    for k in range(3):
        x = P[..., k]
        nxt = np.roll(x, -1, axis=0)
        A, B, C, D = x[:, :-1], nxt[:, :-1], nxt[:, 1:], x[:, 1:]
        e1.append(np.stack([B - A, C - A, B - A, C - B]))
        e2.append(np.stack([C - A, D - A, D - A, D - B]))
    return tuple(e1), tuple(e2)


def _at_nodes(values: np.ndarray) -> np.ndarray:
    """Sums ``(n_u, n_v, ...)`` over the triangles at each node of per-triangle
    ``values (4, n_u, n_v - 1, ...)`` of :func:`_quad_triangles`."""
    abc, acd, abd, bcd = values
    out = np.zeros((values.shape[1], values.shape[2] + 1) + values.shape[3:])
    out[:, :-1] += abc + acd + abd  # A = (i, j)
    out[:, :-1] += np.roll(abc + abd + bcd, 1, axis=0)  # B = (i + 1, j)
    out[:, 1:] += np.roll(abc + acd + bcd, 1, axis=0)  # C = (i + 1, j + 1)
    out[:, 1:] += acd + abd + bcd  # D = (i, j + 1)
    return out


def grid_strain(G: np.ndarray, *, reference: int = 0, chunk: int = 32):
    """Strain fields of a deforming grid ``G (n_u, n_v, n_t, 3)`` against frame ``reference``.

    Returns ``energy (n_u, n_v, n_t)`` and ``stretches (n_u, n_v, n_t, 2)``
    (principal stretches l1 >= l2), averaged from triangles to nodes over both
    splits of every quad (NaN triangles left out; NaN where all are): one split
    alone makes the fields depend on which diagonal it takes (a mirrored
    embryo's strain energy came out up to 0.007 different on the outer wall,
    0.05 on the inner; both splits are also closer to a 8x finer grid's values,
    0.011 off at most instead of 0.017). Works on ``chunk`` frames at a time.
    """
    n_u, n_v, n_t, _ = G.shape
    energy = np.empty((n_u, n_v, n_t))
    stretches = np.empty((n_u, n_v, n_t, 2))
    before = _upper(*_quad_triangles(G[:, :, reference : reference + 1]))
    for start in range(0, n_t, chunk):
        t = slice(start, start + chunk)
        lam = _stretches(before, _upper(*_quad_triangles(G[:, :, t])))  # (4, n_u, n_v-1, c, 2)
        ok = np.isfinite(lam[..., 0])
        with np.errstate(invalid="ignore", divide="ignore"):
            count = _at_nodes(ok.astype(float))
            for out, value in (
                (energy, strain_energy(lam)),
                (stretches[..., 0], lam[..., 0]),
                (stretches[..., 1], lam[..., 1]),
            ):
                out[:, :, t] = np.where(
                    count > 0, _at_nodes(np.where(ok, value, 0.0)) / count, np.nan
                )
    return energy, stretches


def surface_kinematics(
    G: np.ndarray, stretches: np.ndarray, period_ms: float
) -> tuple[np.ndarray, np.ndarray]:
    """How the tissue moves within its surface, from a grid that follows it ``G (n_u,
    n_v, n_t, 3)`` mm over one cycle and its principal stretches against t = 0
    ``(n_u, n_v, n_t, 2)``: the speed of each node along the surface (its velocity,
    central differences round the cycle, less the part along the surface's normal)
    ``(n_u, n_v, n_t)`` mm/s, and the surface divergence, the rate of local area
    change d ln(l1 l2) / dt ``(n_u, n_v, n_t)`` 1/s (positive where the tissue spreads).
    The wave's motion towards and away from the axis is left out of the speed: what
    remains is the tissue sliding and turning, which only a texture shows."""
    n_t = G.shape[2]
    dt_s = period_ms / n_t / 1000.0
    velocity = (np.roll(G, -1, axis=2) - np.roll(G, 1, axis=2)) / (2 * dt_s)
    along_u = np.roll(G, -1, axis=0) - np.roll(G, 1, axis=0)
    along_v = np.gradient(G, axis=1)
    normal = np.cross(along_u, along_v)
    normal /= np.linalg.norm(normal, axis=-1, keepdims=True)
    tangential = velocity - np.einsum("...i,...i", velocity, normal)[..., None] * normal
    log_area = np.log(stretches[..., 0] * stretches[..., 1])
    divergence = (np.roll(log_area, -1, axis=2) - np.roll(log_area, 1, axis=2)) / (2 * dt_s)
    return np.linalg.norm(tangential, axis=-1), divergence
