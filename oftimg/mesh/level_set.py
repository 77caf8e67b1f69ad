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

TRUNCATE = 4.0          # the Gaussians' reach, in sigmas (at 3 a 40 um cylinder reads 20 % high)
# the derivatives a mean curvature needs: name -> order along (z, y, x)
_ORDERS = {"z": (1, 0, 0), "y": (0, 1, 0), "x": (0, 0, 1), "zz": (2, 0, 0), "yy": (0, 2, 0),
           "xx": (0, 0, 2), "zy": (1, 1, 0), "zx": (1, 0, 1), "yx": (0, 1, 1)}


def level_set_mean_curvature(field: np.ndarray, voxel_size_xyz, points: np.ndarray,
                             sigma: float, origin_xyz=(0.0, 0.0, 0.0)) -> np.ndarray:
    """Mean curvature ``(n,)`` (1 / length unit) of the level sets of ``field`` (``(z, y,
    x)``, larger inside: a mask or an occupancy) blurred by a Gaussian of ``sigma``
    (length units), at ``points (n, 3)``: div(n) / 2 of the outward unit normal n =
    -grad f over its length, from Gaussian derivatives interpolated trilinearly. Positive
    where the surface is convex (a cylinder of radius R: 1 / 2R), as
    :func:`~oftimg.mesh.curvature.vertex_mean_curvature` on an outward mesh.
    Voxel ``(k, j, i)`` of ``field`` sits at ``origin + (i dx, j dy, k dz)``; only the
    box around the points (and the blur's reach) is filtered."""
    from scipy import ndimage

    size = np.asarray(voxel_size_xyz, float)[::-1]                   # (dz, dy, dx)
    at = ((np.asarray(points, float) - np.asarray(origin_xyz, float)) / size[::-1])[:, ::-1]
    reach = np.ceil(TRUNCATE * sigma / size).astype(int) + 2
    lo = np.maximum(np.floor(at.min(axis=0)).astype(int) - reach, 0)
    hi = np.minimum(np.ceil(at.max(axis=0)).astype(int) + reach + 1, field.shape)
    box = field[tuple(slice(a, b) for a, b in zip(lo, hi))].astype(np.float32)
    coords = (at - lo).T
    sig = sigma / size
    d = {}
    # separable, one axis after another, each pass's result used by the next and let go
    # (18 one-axis passes, not 27; at most four volumes held: the 256^3 series' memory)
    for ox in range(3):
        along_x = ndimage.gaussian_filter1d(box, sig[2], axis=2, order=ox, mode="nearest",
                                            truncate=TRUNCATE)
        for oy in range(3 - ox):
            along_xy = ndimage.gaussian_filter1d(along_x, sig[1], axis=1, order=oy,
                                                 mode="nearest", truncate=TRUNCATE)
            for name, order in _ORDERS.items():
                if order[1:] != (oy, ox):
                    continue
                smooth = ndimage.gaussian_filter1d(along_xy, sig[0], axis=0, order=order[0],
                                                   mode="nearest", truncate=TRUNCATE)
                d[name] = ndimage.map_coordinates(smooth, coords, order=1, mode="nearest") \
                    / np.prod(size ** np.array(order))
                del smooth
            del along_xy
        del along_x
    gx, gy, gz = d["x"], d["y"], d["z"]
    div = (d["xx"] * (gy ** 2 + gz ** 2) + d["yy"] * (gx ** 2 + gz ** 2)
           + d["zz"] * (gx ** 2 + gy ** 2)
           - 2 * (gx * gy * d["yx"] + gx * gz * d["zx"] + gy * gz * d["zy"]))
    with np.errstate(divide="ignore", invalid="ignore"):
        return -div / (2 * (gx ** 2 + gy ** 2 + gz ** 2) ** 1.5)
