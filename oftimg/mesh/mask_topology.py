"""A wall's mask brought to the topology of a solid tube: one piece, no cavity, no
handle or tunnel (Euler characteristic 1, as a ball), by the smallest morphological
change that does it.

A segmentation's noise opens a handle (a thin strand outside the wall), a tunnel (a
hole through it) or a bridge across the lumen in a frame now and then; the wall's
surface is then no open tube, and that one frame stopped a whole run. An opening
removes strands and bridges thinner than its ball, a closing fills holes and gaps
narrower than it; the first radius at which either gives a solid tube, the one
changing fewer voxels, is kept. Masks are ``(z, y, x)`` bool, as in
:mod:`oftimg.mesh.labels`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

MAX_RADIUS = 3  # voxels: a larger defect is no segmentation noise
MAX_CHANGED_SHARE = 0.05  # of the mask's voxels: a larger change would reshape the wall


@dataclass(frozen=True)
class MaskRepair:
    """What :func:`solid_tube_mask` did: ``what`` ("opening, radius 1 voxel"), the
    voxels it changed, and the mask's Euler characteristic before (1: a solid tube;
    each handle or tunnel takes 1 away)."""

    what: str
    voxels: int
    euler_before: int

    def describe(self) -> str:
        return (
            f"{self.what}, {self.voxels} voxels changed (Euler characteristic "
            f"{self.euler_before} -> 1)"
        )


def core(mask: np.ndarray) -> np.ndarray:
    """The mask's largest 26-connected piece with its cavities filled: what the
    meshing keeps of it anyway (specks and pinholes' cavities are dropped there)."""
    from scipy import ndimage

    labels, n = ndimage.label(mask, structure=np.ones((3, 3, 3)))
    if n > 1:
        sizes = np.bincount(labels.ravel())
        sizes[0] = 0
        mask = labels == np.argmax(sizes)
    return ndimage.binary_fill_holes(mask)


def euler(mask: np.ndarray) -> int:
    """Euler characteristic of a 26-connected mask (6-connected background)."""
    from skimage.measure import euler_number

    return int(euler_number(mask, connectivity=3))


def _ball(radius: int) -> np.ndarray:
    r = np.arange(-radius, radius + 1)
    return (r[:, None, None] ** 2 + r[None, :, None] ** 2 + r[None, None, :] ** 2) <= radius**2


def solid_tube_mask(
    mask: np.ndarray, *, max_radius: int = MAX_RADIUS, max_share: float = MAX_CHANGED_SHARE
) -> tuple[np.ndarray | None, MaskRepair | None]:
    """``mask`` (``(z, y, x)`` bool) as a solid tube: ``(mask, None)`` when its core
    (:func:`core`) is one already; else the core opened or closed by a ball of the
    least radius (1 to ``max_radius`` voxels) that makes it one, the smaller change
    of the two at that radius, and what was done; ``(None, None)`` when no radius
    does it within ``max_share`` of the mask's voxels changed."""
    from scipy import ndimage

    solid = core(mask)
    before = euler(solid)
    if before == 1:
        return mask, None
    limit = max_share * max(int(solid.sum()), 1)
    pad = max_radius + 1
    padded = np.pad(solid, pad, mode="edge")  # the tube's open ends stay open
    for radius in range(1, max_radius + 1):
        ball = _ball(radius)
        tried = []
        for what, op in (("opening", ndimage.binary_opening), ("closing", ndimage.binary_closing)):
            out = core(op(padded, structure=ball)[pad:-pad, pad:-pad, pad:-pad])
            changed = int(np.count_nonzero(out != solid))
            if changed <= limit and out.any() and euler(out) == 1:
                tried.append((changed, what, out))
        if tried:
            changed, what, out = min(tried, key=lambda c: c[0])
            return out, MaskRepair(
                f"{what}, radius {radius} voxel{'s' * (radius > 1)}", changed, before
            )
    return None, None
