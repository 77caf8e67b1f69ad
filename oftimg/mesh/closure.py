"""A lumen the cushions close, bridged so that its wall stays one tube (issue 85).

Where the endocardial cushions appose, a segmentation has no lumen voxel over a stretch
of the tube: the lumen's mask falls into pieces, each ending blind. The lumen's grid
needs one tube from end to end, so the pieces are joined by a thin bridge along the
closed stretch (through the middle of the inner wall's mask, where the apposed lumen
lies) and the bridge's part of the surface is flagged: its rows are measured as closed
(area 0, curvature masked), not as a lumen.
"""
from __future__ import annotations

import numpy as np

# a piece of the lumen's mask smaller than this share of the largest is a speck, not a
# piece of the lumen the closure left
PIECE_MIN_SHARE = 0.02
# the bridge's radius, voxels: thick enough that the level set's blur keeps it a tube
BRIDGE_RADIUS_VOXELS = 1.5
# a lumen in more pieces than this is no closure (the cushions close it once or twice
# along the tube) but a segmentation's defect: not bridged
MAX_PIECES = 6


def lumen_pieces(mask: np.ndarray) -> tuple[np.ndarray, int]:
    """The pieces of a lumen's boolean ``mask (z, y, x)`` (26-connected), specks under
    :data:`PIECE_MIN_SHARE` of the largest dropped: ``(labels (z, y, x) int32, count)``,
    pieces numbered 1..count from the largest."""
    from scipy import ndimage

    out = np.zeros(mask.shape, np.int32)
    box = _box(mask)
    if box is None:
        return out, 0
    labels, n = ndimage.label(mask[box], structure=np.ones((3, 3, 3), bool))
    sizes = np.bincount(labels.ravel())[1:]
    keep = np.flatnonzero(sizes >= PIECE_MIN_SHARE * sizes.max())
    keep = keep[np.argsort(-sizes[keep], kind="stable")]
    renumber = np.zeros(n + 1, np.int32)
    renumber[keep + 1] = np.arange(1, len(keep) + 1)
    out[box] = renumber[labels]
    return out, len(keep)


def _box(mask: np.ndarray) -> tuple[slice, ...] | None:
    """The slices of the smallest box holding ``mask``'s True voxels (None: none): the
    lumen fills a few % of an OCT volume, and labelling only its box is 5-10x faster."""
    where = [np.flatnonzero(mask.any(axis=tuple(a for a in range(3) if a != k)))
             for k in range(3)]
    if not len(where[0]):
        return None
    return tuple(slice(int(w[0]), int(w[-1]) + 1) for w in where)


def _surface_voxels(piece: np.ndarray) -> np.ndarray:
    """Indices ``(n, 3)`` of the voxels of boolean ``piece`` with a neighbour outside it."""
    from scipy import ndimage

    return np.argwhere(piece & ~ndimage.binary_erosion(piece))


def bridge_path(start: np.ndarray, end: np.ndarray, voxel_size_zyx: np.ndarray) -> np.ndarray:
    """The voxels ``(n, 3)`` (z, y, x) on the straight line from voxel ``start`` to voxel
    ``end``, one at least every half of the finest voxel side (a closed stretch is short
    beside the tube's bend: its chord stays inside the inner wall)."""
    start, end = np.asarray(start, float), np.asarray(end, float)
    length = np.linalg.norm((end - start) * voxel_size_zyx)
    n = int(np.ceil(2 * length / np.min(voxel_size_zyx))) + 2
    points = start + np.linspace(0.0, 1.0, n)[:, None] * (end - start)
    return np.unique(np.rint(points).astype(int), axis=0)


def bridged_lumen(lumen: np.ndarray, inner: np.ndarray, voxel_size_xyz
                  ) -> tuple[np.ndarray, np.ndarray] | None:
    """A lumen's boolean mask ``(z, y, x)`` in pieces joined into one tube, with the
    bridge's voxels: ``(mask, bridge)``; None when the lumen is not in pieces, or in more
    than :data:`MAX_PIECES`.

    Pieces are joined nearest first (each time the two groups with the closest
    surface voxels, in um), by :func:`bridge_path` thickened to
    :data:`BRIDGE_RADIUS_VOXELS` and kept inside the ``inner`` mask (the inner wall's,
    which holds the lumen).
    """
    from scipy import ndimage
    from scipy.spatial import cKDTree

    labels, n = lumen_pieces(lumen)
    if not 2 <= n <= MAX_PIECES:
        return None
    zyx = np.asarray(voxel_size_xyz, float)[::-1]
    surfaces = [_surface_voxels(labels == k) for k in range(1, n + 1)]
    group = list(range(n))
    path = np.zeros(lumen.shape, bool)
    for _ in range(n - 1):
        best = None
        for a in range(n):
            tree = cKDTree(surfaces[a] * zyx)
            for b in range(n):
                if group[b] == group[a] or b <= a:
                    continue
                d, i = tree.query(surfaces[b] * zyx)
                j = int(np.argmin(d))
                if best is None or d[j] < best[0]:
                    best = (d[j], a, b, surfaces[a][i[j]], surfaces[b][j])
        _, a, b, start, end = best
        path[tuple(bridge_path(start, end, zyx).T)] = True
        old, new = group[b], group[a]
        group = [new if g == old else g for g in group]
    radius = BRIDGE_RADIUS_VOXELS
    reach = np.ceil(radius).astype(int)
    offsets = np.stack(np.meshgrid(*[np.arange(-reach, reach + 1)] * 3, indexing="ij"), -1)
    ball = (offsets ** 2).sum(-1) <= radius ** 2
    bridge = ndimage.binary_dilation(path, structure=ball) & inner & ~(labels > 0)
    return (labels > 0) | bridge, bridge


def bridge_flags(V: np.ndarray, bridge: np.ndarray, lumen: np.ndarray, voxel_size_xyz,
                 origin=(0.0, 0.0, 0.0)) -> np.ndarray:
    """For each vertex ``V (n, 3)`` (x, y, z, the voxels' length unit) of a bridged
    lumen's surface, True where its nearest voxel of the bridged mask is a bridge's
    (``bridge``, ``lumen`` boolean ``(z, y, x)``: the bridge and the lumen's own)."""
    from scipy.spatial import cKDTree

    size = np.asarray(voxel_size_xyz, float)
    own, joined = np.argwhere(lumen), np.argwhere(bridge)
    points = np.concatenate([own, joined])[:, ::-1] * size + np.asarray(origin)
    is_bridge = np.r_[np.zeros(len(own), bool), np.ones(len(joined), bool)]
    _, nearest = cKDTree(points).query(V)
    return is_bridge[nearest]


# a closure seen in one frame alone is a gap in the segmentation (the lumen labelled as
# jelly over a stretch), not the cushions, when the frames either side are open there at
# least this share of the frame's own widest lumen (half-widths): the cushions close a
# lumen that narrows to a slit over the frames before and after
GAP_OPEN_SHARE = 0.5


def half_widths(mask: np.ndarray, voxel_size_xyz) -> np.ndarray:
    """Each voxel's distance to the nearest voxel outside the boolean ``mask (z, y, x)``
    (the same length unit as ``voxel_size_xyz``; 0 outside): a lumen's local half-width
    on its middle line."""
    from scipy import ndimage

    out = np.zeros(mask.shape, np.float32)
    box = _box(mask)
    if box is not None:
        padded = np.pad(mask[box], 1)
        out[box] = ndimage.distance_transform_edt(
            padded, sampling=np.asarray(voxel_size_xyz, float)[::-1])[1:-1, 1:-1, 1:-1]
    return out


def is_one_frame_gap(bridge_xyz: np.ndarray, lumen: np.ndarray, before: np.ndarray,
                     after: np.ndarray, voxel_size_xyz) -> bool:
    """Whether a frame's closure is a segmentation's gap: the lumen masks ``(z, y, x)``
    of the frame ``before`` and the frame ``after`` it are both, within half the frame's
    widest half-width of the middle of its bridge (``bridge_xyz (k, 3)``: the bridge's
    vertices, voxel index times side, x y z), at least :data:`GAP_OPEN_SHARE` as wide as
    the frame's own ``lumen`` mask is at its widest: wide open where it closed. A closure
    the neighbours share or approach (a slit a few voxels across) is the cushions'."""
    if not len(bridge_xyz):
        return False
    widest = float(half_widths(lumen, voxel_size_xyz).max())
    size_xyz = np.asarray(voxel_size_xyz, float)
    middle = bridge_xyz[np.argmin(np.linalg.norm(bridge_xyz - np.median(bridge_xyz, axis=0),
                                                 axis=1))]
    reach = np.ceil(0.5 * widest / size_xyz).astype(int)[::-1]            # z y x
    centre = np.rint(middle / size_xyz).astype(int)[::-1]
    box = tuple(slice(max(c - r, 0), c + r + 1) for c, r in zip(centre, reach))
    return all(float(half_widths(other, voxel_size_xyz)[box].max(initial=0.0))
               >= GAP_OPEN_SHARE * widest for other in (before, after))
