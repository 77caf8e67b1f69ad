"""From a label volume to the walls' surfaces: one frame's masks cleaned and meshed by
marching cubes, open where the tube leaves the volume (issue 53, first part).

Volumes are arrays ``(z, y, x)`` as TIFF readers and scikit-image give them; a voxel
``(k, j, i)`` sits at ``x = i * dx, y = j * dy, z = k * dz``. Surfaces come out as
``V (n, 3)`` in (x, y, z), the voxel size's unit, and ``F (m, 3)`` int64, outward.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import InputError
from .topology import boundary_loops, capped_signed_volume

# which labels each wall encloses: outer all three, inner the jelly and the lumen
WALL_LAYERS = {"outer": ("myocardium", "jelly", "lumen"), "inner": ("jelly", "lumen"),
               "lumen": ("lumen",)}


def wall_masks(labels: np.ndarray, label_ids: dict[str, int]) -> dict[str, np.ndarray]:
    """Boolean masks ``(z, y, x)`` of what each wall encloses, for the layers that
    ``label_ids`` (layer name -> label value) names: with one layer, the outer wall
    alone. Raises :class:`~oftimg.errors.InputError` for float labels."""
    if not np.issubdtype(labels.dtype, np.integer) and labels.dtype != bool:
        raise InputError(f"labels are {labels.dtype}, not integers: a label volume holds "
                         "whole numbers (0 background)")
    masks = {}
    for wall, layers in WALL_LAYERS.items():
        present = [label_ids[layer] for layer in layers if layer in label_ids]
        if len(present) == len(layers) or (wall == "outer" and present):
            masks[wall] = np.isin(labels, present)
    return masks


@dataclass(frozen=True)
class Cleaned:
    """What :func:`clean_mask` removed: voxels of islands apart from the largest
    piece, and voxels of pinholes filled."""

    island_voxels: int
    hole_voxels: int


def clean_mask(mask: np.ndarray, *, max_hole_voxels: int = 64) -> tuple[np.ndarray, Cleaned]:
    """The largest connected piece of ``mask`` (face-connected) with its enclosed
    holes of at most ``max_hole_voxels`` filled: a segmentation's specks and
    pinholes would each become a handle or an island of the surface."""
    from scipy import ndimage

    pieces, n = ndimage.label(mask)
    if n == 0:
        return mask.copy(), Cleaned(0, 0)
    sizes = np.bincount(pieces.ravel())
    sizes[0] = 0
    kept = pieces == int(np.argmax(sizes))
    holes, n_holes = ndimage.label(~kept)
    hole_sizes = np.bincount(holes.ravel())
    border = np.unique(np.concatenate([holes[[0, -1]].ravel(), holes[:, [0, -1]].ravel(),
                                       holes[:, :, [0, -1]].ravel()]))
    small = np.flatnonzero(hole_sizes <= max_hole_voxels)
    small = np.setdiff1d(small, np.append(border, 0))
    filled = kept | np.isin(holes, small)
    return filled, Cleaned(int(mask.sum() - kept.sum()), int(filled.sum() - kept.sum()))


def mesh_mask(mask: np.ndarray, voxel_size_xyz) -> tuple[np.ndarray, np.ndarray]:
    """The surface of ``mask (z, y, x)`` by marching cubes at level 0.5, in (x, y, z)
    with ``voxel_size_xyz`` (dx, dy, dz), faces outward. The volume is not padded, so
    the surface stays open where the mask meets the volume's border."""
    from skimage.measure import marching_cubes

    dx, dy, dz = (float(d) for d in voxel_size_xyz)
    verts, faces, _, _ = marching_cubes(mask.astype(np.float32), 0.5, spacing=(dz, dy, dx))
    V = np.ascontiguousarray(verts[:, ::-1], dtype=np.float64)         # (z, y, x) -> (x, y, z)
    F = np.ascontiguousarray(faces[:, ::-1], dtype=np.int64)           # the swap mirrors: re-turn
    if capped_signed_volume(V, F, boundary_loops(F)) < 0:
        F = F[:, ::-1].copy()
    return V, F
