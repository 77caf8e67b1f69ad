"""A wall's mask in a frame where the segmentation lost it, from the frames around it:
the two masks' signed distances blended by time, so the shape moves between them
(an average of the masks themselves would keep the union's or the intersection's
outline, not the one halfway).

Masks are ``(z, y, x)`` bool, voxel sizes ``(dx, dy, dz)``, as in
:mod:`oftimg.mesh.labels`; the result is an occupancy in [0, 1] (float32) whose level
0.5 is the blended surface, meshed like a mask.
"""

from __future__ import annotations

import numpy as np


def signed_distance(mask: np.ndarray, voxel_size_xyz) -> np.ndarray:
    """Distance ``(z, y, x)`` float32 from each voxel centre to the mask's outline in
    length units, positive outside the mask and negative inside (half a voxel off at
    the outline either way, the same for every mask, so blends keep it)."""
    from scipy import ndimage

    sampling = tuple(float(d) for d in voxel_size_xyz[::-1])
    outside = ndimage.distance_transform_edt(~mask, sampling=sampling)
    inside = ndimage.distance_transform_edt(mask, sampling=sampling)
    return (outside - inside).astype(np.float32)


def blended_occupancy(
    before: np.ndarray,
    after: np.ndarray,
    weight: float,
    voxel_size_xyz,
    *,
    within: np.ndarray | None = None,
    around: np.ndarray | None = None,
) -> np.ndarray:
    """The mask a share ``weight`` (0: ``before``, 1: ``after``) of the way from one
    mask to the other, as an occupancy ``(z, y, x)`` float32 in [0, 1]: the blended
    signed distance as a ramp one voxel wide (0.5 on the blended outline), kept
    inside ``within`` (the enclosing wall's mask in this frame) and around
    ``around`` (the enclosed wall's mask), when given, so the walls stay nested."""
    if not 0.0 <= weight <= 1.0:
        raise ValueError(f"weight must lie in [0, 1], found {weight}")
    distance = (1.0 - weight) * signed_distance(before, voxel_size_xyz) + weight * signed_distance(
        after, voxel_size_xyz
    )
    occupancy = np.clip(0.5 - distance / float(min(voxel_size_xyz)), 0.0, 1.0)
    if within is not None:
        occupancy = np.minimum(occupancy, within)
    if around is not None:
        occupancy = np.maximum(occupancy, around)
    return occupancy.astype(np.float32)
