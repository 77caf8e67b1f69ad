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
    """The pieces of a lumen's boolean ``mask (z, y, x)`` (6-connected: voxels that
    touch only at an edge or a corner are apart to marching cubes, whose surface parts
    there), specks under :data:`PIECE_MIN_SHARE` of the largest dropped: ``(labels (z,
    y, x) int32, count)``, pieces numbered 1..count from the largest."""
    from scipy import ndimage

    out = np.zeros(mask.shape, np.int32)
    box = _box(mask)
    if box is None:
        return out, 0
    labels, n = ndimage.label(mask[box])
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
    where = [np.flatnonzero(mask.any(axis=tuple(a for a in range(3) if a != k))) for k in range(3)]
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


# a tube's end reached by the lumen: a lumen voxel within this many voxels (the largest
# side) of the inner wall's voxels there
END_REACH_VOXELS = 2.0
# the inner wall's voxels at an end it is cut by a plane: on it and this many voxels beyond
END_SLAB_VOXELS = 3.0


def tube_ends(inner: np.ndarray, voxel_size_xyz, ends=None) -> list[np.ndarray]:
    """The inner wall's voxels ``(k, 3)`` (z, y, x indices) at each of the tube's two
    ends: where its mask meets the volume's faces (its two largest patches there), or,
    with ``ends`` (two ``(point, normal)`` planes, x y z in the voxels' length unit, the
    normals into the part kept), its voxels on each plane and up to
    :data:`END_SLAB_VOXELS` beyond it. Fewer than two when the mask shows fewer."""
    from scipy import ndimage

    size_zyx = np.asarray(voxel_size_xyz, float)[::-1]
    if ends:
        voxels = np.argwhere(inner)
        points = voxels[:, ::-1] * size_zyx[::-1]  # x y z
        out = []
        for point, normal in ends:
            normal = np.asarray(normal, float) / np.linalg.norm(normal)
            d = (points - np.asarray(point, float)) @ normal
            # on the plane (it may be a volume's face) and beyond it, where the cut falls
            slab = (d <= 0.5 * size_zyx.min()) & (d >= -END_SLAB_VOXELS * size_zyx.max())
            if slab.any():
                out.append(voxels[slab])
        return out
    shell = np.zeros(inner.shape, bool)
    for axis in range(3):
        for side in (0, -1):
            index = [slice(None)] * 3
            index[axis] = side
            shell[tuple(index)] = True
    patches, n = ndimage.label(inner & shell, structure=np.ones((3, 3, 3), bool))
    if n == 0:
        return []
    sizes = np.bincount(patches.ravel())[1:]
    largest = np.argsort(-sizes)[:2] + 1
    return [np.argwhere(patches == k) for k in largest]


def _unreached_ends(
    lumen_surface: np.ndarray, ends: list[np.ndarray], zyx: np.ndarray
) -> list[np.ndarray]:
    """Of the tube's ``ends`` (:func:`tube_ends`), those no voxel of the lumen's surface
    ``(n, 3)`` comes within :data:`END_REACH_VOXELS` of: the lumen closed up to it."""
    from scipy.spatial import cKDTree

    tree = cKDTree(lumen_surface * zyx)
    reach = END_REACH_VOXELS * zyx.max()
    return [
        end
        for end in ends
        if not np.isfinite(tree.query(end * zyx, distance_upper_bound=reach)[0]).any()
    ]


def centred_path(
    start: np.ndarray, end: np.ndarray, inner: np.ndarray, voxel_size_zyx: np.ndarray
) -> np.ndarray:
    """The voxels ``(n, 3)`` (z, y, x) of a path from voxel ``start`` to voxel ``end``
    inside the boolean ``inner`` mask: the straight chord (:func:`bridge_path`) where it
    stays inside, else through the mask's middle: the centroid of the mask's voxels
    in each slab square to the chord (one every two of the finest voxel sides, within
    half the chord's length of it) joined by :func:`bridge_path`. A straight chord
    leaves a bent tube's inner wall over a long closed stretch (zoo cushion draw 402:
    the bridge clipped to the mask fell in two); the middle of the mask is where the
    apposed lumen lies."""
    zyx = np.asarray(voxel_size_zyx, float)
    chord = bridge_path(start, end, zyx)
    if inner[tuple(chord.T)].all():  # the usual: a short stretch, a straight tube
        return chord
    a, b = np.asarray(start, float) * zyx, np.asarray(end, float) * zyx
    length = float(np.linalg.norm(b - a))
    step = 2.0 * zyx.min()
    if length <= 2 * step:
        return chord
    along = (b - a) / length
    reach = max(length / 2, 10 * zyx.max())
    low = np.maximum(np.floor((np.minimum(a, b) - reach) / zyx).astype(int), 0)
    high = np.minimum(np.ceil((np.maximum(a, b) + reach) / zyx).astype(int) + 1, inner.shape)
    voxels = np.argwhere(inner[tuple(slice(lo, hi) for lo, hi in zip(low, high))]) + low
    X = voxels * zyx - a
    t = X @ along
    apart = np.linalg.norm(X - t[:, None] * along, axis=1)
    near = (t > step) & (t < length - step) & (apart <= reach)
    slab = (t[near] // step).astype(int)
    count = np.bincount(slab)
    held = np.flatnonzero(count > 0)
    middles = np.stack(
        [np.bincount(slab, voxels[near][:, k])[held] / count[held] for k in range(3)], axis=1
    )
    points = [np.asarray(start, float), *middles, np.asarray(end, float)]
    return np.unique(
        np.concatenate([bridge_path(p, q, zyx) for p, q in zip(points[:-1], points[1:])]), axis=0
    )


def bridged_lumen(
    lumen: np.ndarray,
    inner: np.ndarray,
    voxel_size_xyz,
    *,
    ends: list[np.ndarray] | None = None,
    radius_voxels: float = BRIDGE_RADIUS_VOXELS,
) -> tuple[np.ndarray, np.ndarray] | None:
    """A lumen's boolean mask ``(z, y, x)`` in pieces joined into one tube, with the
    bridge's voxels: ``(mask, bridge)``; None when the lumen is not in pieces (and, with
    the tube's ``ends``, reaches both), or is in more than :data:`MAX_PIECES`.

    Pieces are joined nearest first (each time the two groups with the closest
    surface voxels, in um), by :func:`centred_path` thickened to
    ``radius_voxels`` (at least the level set's sampling step, or the bridge falls
    between its samples) and kept inside the ``inner`` mask (the inner wall's, which
    holds the lumen; its middle line kept 6-connected where that mask pinches it). With ``ends`` (:func:`tube_ends`), an end the lumen does
    not reach (closed up to the volume's face or the cutting plane) is bridged to as
    well, from the lumen's nearest voxel to the end's middle voxel.
    """
    from scipy import ndimage
    from scipy.spatial import cKDTree

    labels, n = lumen_pieces(lumen)
    zyx = np.asarray(voxel_size_xyz, float)[::-1]
    if n == 0 or n > MAX_PIECES:
        return None
    surfaces = [_surface_voxels(labels == k) for k in range(1, n + 1)]
    unreached = _unreached_ends(np.concatenate(surfaces), ends or [], zyx)
    if n == 1 and not unreached:
        return None
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
        path[tuple(centred_path(start, end, inner, zyx).T)] = True
        old, new = group[b], group[a]
        group = [new if g == old else g for g in group]
    every = np.concatenate(surfaces)
    tree = cKDTree(every * zyx)
    for end in unreached:  # to the end's voxel nearest its middle
        middle = end[np.argmin(np.linalg.norm((end - end.mean(axis=0)) * zyx, axis=1))]
        start = every[tree.query(middle * zyx)[1]]
        path[tuple(centred_path(start, middle, inner, zyx).T)] = True
    radius = radius_voxels
    reach = np.ceil(radius).astype(int)
    offsets = np.stack(np.meshgrid(*[np.arange(-reach, reach + 1)] * 3, indexing="ij"), -1)
    ball = (offsets**2).sum(-1) <= radius**2
    # the bridge inside the inner wall's mask, and its middle line made 6-connected
    # wherever that mask pinches it (beside a slit): a bridge that met a piece only at
    # a voxel's edge would leave marching cubes two surfaces
    core = ndimage.binary_dilation(path, structure=ndimage.generate_binary_structure(3, 1))
    bridge = ((ndimage.binary_dilation(path, structure=ball) & inner) | core) & ~(labels > 0)
    return (labels > 0) | bridge, bridge


def bridge_flags(
    V: np.ndarray, bridge: np.ndarray, lumen: np.ndarray, voxel_size_xyz, origin=(0.0, 0.0, 0.0)
) -> np.ndarray:
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
            padded, sampling=np.asarray(voxel_size_xyz, float)[::-1]
        )[1:-1, 1:-1, 1:-1]
    return out


def is_one_frame_gap(
    bridge_xyz: np.ndarray, lumen: np.ndarray, before: np.ndarray, after: np.ndarray, voxel_size_xyz
) -> bool:
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
    middle = bridge_xyz[
        np.argmin(np.linalg.norm(bridge_xyz - np.median(bridge_xyz, axis=0), axis=1))
    ]
    reach = np.ceil(0.5 * widest / size_xyz).astype(int)[::-1]  # z y x
    centre = np.rint(middle / size_xyz).astype(int)[::-1]
    box = tuple(slice(max(c - r, 0), c + r + 1) for c, r in zip(centre, reach))
    return all(
        float(half_widths(other, voxel_size_xyz)[box].max(initial=0.0)) >= GAP_OPEN_SHARE * widest
        for other in (before, after)
    )
