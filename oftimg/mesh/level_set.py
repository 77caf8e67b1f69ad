"""The mean curvature of a volume's level sets, read at points: the lumen's curvature
from a label volume without taking second differences of a marching-cubes mesh.

A marching-cubes mesh's vertices follow the sampling lattice, and a mesh's curvature
is a second difference of their positions: on the label phantom (4 x 4 x 8 um voxels)
the lumen's came out 51 % off the truth, where the curvature of the mask's level sets
after a Gaussian of 8 um came out 33 % off (``scripts/label_curvature.py``,
docs/methods.md). Volumes are ``(z, y, x)``, points ``(n, 3)`` (x, y, z) in the
voxel size's length unit, as in :mod:`oftimg.mesh.labels`.
"""

from __future__ import annotations

import numpy as np
from numpy.lib.stride_tricks import sliding_window_view

CHUNK = 500  # points gathered at once: 9.6 MB, cached and reused (2000: 20 % slower)
TRUNCATE = 4.0  # the Gaussians' reach, in sigmas (at 3 a 40 um cylinder reads 20 % high)
# the derivatives a mean curvature needs: name -> order along (z, y, x)
_ORDERS = {
    "z": (1, 0, 0),
    "y": (0, 1, 0),
    "x": (0, 0, 1),
    "zz": (2, 0, 0),
    "yy": (0, 2, 0),
    "xx": (0, 0, 2),
    "zy": (1, 1, 0),
    "zx": (1, 0, 1),
    "yx": (0, 1, 1),
}


def level_set_derivatives(
    field: np.ndarray, voxel_size_xyz, points: np.ndarray, sigma: float, origin_xyz=(0.0, 0.0, 0.0)
) -> tuple[np.ndarray, np.ndarray]:
    """The gradient ``(n, 3)`` and Hessian ``(n, 3, 3)`` (along x, y, z; per length unit
    and its square) of ``field`` (``(z, y, x)``, larger inside: a mask or an occupancy)
    blurred by a Gaussian of ``sigma`` (length units), at ``points (n, 3)``. Voxel ``(k,
    j, i)`` of ``field`` sits at ``origin + (i dx, j dy, k dz)``; outside the volume its
    border voxels continue.

    The Gaussian's derivatives are taken at each point itself, from the voxels within
    :data:`TRUNCATE` sigmas of it (one axis after another), not by filtering the whole
    volume: the work goes with the points, not with the volume's box (a curved tube's
    box is mostly empty), and no interpolation between voxels is needed. The points'
    box is read once, as float32, and each point's rows along x are taken from it as
    windows (twice as fast as gathering voxel by voxel, the same numbers)."""
    size = np.asarray(voxel_size_xyz, float)[::-1]  # (dz, dy, dx)
    at = ((np.asarray(points, float) - np.asarray(origin_xyz, float)) / size[::-1])[:, ::-1]
    # plus a linear interpolation's variance (1/6 voxel^2): without it the lattice shows
    # where sigma is about a voxel (a cylinder across 2 x 2 x 4 um voxels read 11 % high)
    sig = np.sqrt((sigma / size) ** 2 + 1.0 / 6.0)
    weights, first, box = [], [], []
    for axis in range(3):  # each axis's voxels near each point
        reach = int(np.ceil(TRUNCATE * sig[axis]))
        start = np.floor(at[:, axis]).astype(np.int64) - reach  # each point's first voxel
        u = (at[:, axis, None] - start[:, None] - np.arange(2 * reach + 2)) / sig[axis]
        g = np.exp(-0.5 * u**2)
        g /= g.sum(axis=1, keepdims=True)  # sums to one, as scipy's
        s = sig[axis] * size[axis]  # sigma, length units
        weights.append(
            np.stack((g, -u / s * g, (u**2 - 1) / s**2 * g), axis=-1).astype(np.float32)
        )  # (n, k, 3): orders 0, 1, 2
        # a window wholly outside the volume reads its border voxel throughout, from
        # wherever it starts out there: so the box stays within a window of the volume
        start = np.clip(start, -2 * reach - 2, field.shape[axis] - 1)
        lo, hi = (int(start.min()), int(start.max())) if len(start) else (0, 0)
        first.append(start - lo)
        box.append(np.clip(np.arange(lo, hi + 2 * reach + 2), 0, field.shape[axis] - 1))
    # the voxels around all the points as float32 once, the border continued outside
    # the volume; each point's rows along x are then windows of it, gathered whole
    near = field.take(box[0], 0).take(box[1], 1).take(box[2], 2).astype(np.float32)
    rows = sliding_window_view(near, weights[2].shape[1], axis=2)  # (z, y, x, k)
    full = np.empty((len(at), 3, 3, 3), np.float32)  # (n, oz, oy, ox)
    nz, ny = weights[0].shape[1], weights[1].shape[1]
    for chunk in range(0, len(at), CHUNK):  # CHUNK points' voxels at a time
        c = slice(chunk, chunk + CHUNK)
        kz = first[0][c, None, None] + np.arange(nz)[:, None]
        ky = first[1][c, None, None] + np.arange(ny)
        patch = rows[kz, ky, first[2][c, None, None]]  # (n, z, y, x)
        n, nx = len(patch), patch.shape[-1]
        # along x, then y, then z, as batched products: (n, z, y, ox) -> (n, z, ox, oy)
        along_x = np.matmul(patch.reshape(n, nz * ny, nx), weights[2][c])
        along_xy = np.matmul(
            along_x.reshape(n, nz, ny, 3).transpose(0, 1, 3, 2), weights[1][c][:, None]
        )
        full[c] = np.einsum("nzab,nzc->ncba", along_xy, weights[0][c])
    d = {name: full[:, oz, oy, ox].astype(float) for name, (oz, oy, ox) in _ORDERS.items()}
    gradient = np.stack([d["x"], d["y"], d["z"]], axis=-1)
    hessian = np.array(
        [[d["xx"], d["yx"], d["zx"]], [d["yx"], d["yy"], d["zy"]], [d["zx"], d["zy"], d["zz"]]]
    ).transpose(2, 0, 1)
    return gradient, hessian


def level_set_mean_curvature(
    field: np.ndarray, voxel_size_xyz, points: np.ndarray, sigma: float, origin_xyz=(0.0, 0.0, 0.0)
) -> np.ndarray:
    """Mean curvature ``(n,)`` (1 / length unit) of the level sets of ``field`` blurred
    by a Gaussian of ``sigma``, at ``points (n, 3)`` (:func:`level_set_derivatives`):
    div(n) / 2 of the outward unit normal n = -grad f over its length. Positive where
    the surface is convex (a cylinder of radius R: 1 / 2R), as
    :func:`~oftimg.mesh.curvature.vertex_mean_curvature` on an outward mesh."""
    g, Hs = level_set_derivatives(field, voxel_size_xyz, points, sigma, origin_xyz)
    g2 = np.einsum("ni,ni->n", g, g)
    # div(grad f / |grad f|) = (|g|^2 trace(H) - g.H.g) / |g|^3
    div = g2 * np.trace(Hs, axis1=1, axis2=2) - np.einsum("ni,nij,nj->n", g, Hs, g)
    with np.errstate(divide="ignore", invalid="ignore"):
        return -div / (2 * g2**1.5)
