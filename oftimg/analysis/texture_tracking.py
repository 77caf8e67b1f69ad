"""Texture tracking: the grid moved with the tissue's texture, along the tube as well as
around it.

The shape alone cannot show the tissue sliding along the tube (the shape's features
travel with the wave; :mod:`oftimg.analysis.tracking`). The intensity can: each
frame's myocardium pullback (:mod:`oftimg.analysis.pullback`) is an image of the
tissue's texture on that frame's own grid, and dense optical flow between
pullbacks (OpenCV's DIS, periodic around the tube) gives where each pixel's
tissue lies in another frame's grid. Each analysis grid node of frame 0 is carried
to every frame by the flows between frame 0 and that frame, both ways
(:func:`texture_pathlines`).

Images are ``(n_u, n_v)``: u around (rows, periodic), v along (columns). Positions are
in fine pixels ``(around, along)`` or in grid steps (:mod:`oftimg.analysis.tracking`).
Functions of arrays; no file access.
"""
from __future__ import annotations

import numpy as np

WRAP_PAD = 24               # fine pixels of the image repeated beyond u's ends for the flow
NORMALISE_PX = 6.0          # the local mean and contrast taken out: Gaussian sigma, pixels
CLIP_SD = 3.0               # normalised intensities beyond this many local SDs clipped
SMOOTH_STEPS = 1.0          # the displacements' smoothing over nodes (Gaussian sigma, steps)
INVERSE_STEPS = 5           # fixed-point steps inverting the flow back to frame 0
# the forward-backward gap (median, grid steps) above which a run warns: over the accuracy
# zoo's 49 labels-with-intensity draws the grid's drift from the tissue rose with it (log-log
# correlation 0.97): at or under 0.15 steps (38 draws) at most 0.27 % of the length along
# and 0.020 rad around, above it (11 draws) 0.23-1.9 % and 0.021-0.20 rad (docs/accuracy.md)
GAP_WARN_STEPS = 0.15


def normalised(image: np.ndarray) -> np.ndarray:
    """A pullback ``(n_u, n_v)`` as an 8-bit image of its texture: the local mean and
    contrast (:data:`NORMALISE_PX`) taken out, periodic around, NaN (not imaged) as the
    mean. A beam's attenuation and a layer's brightness then do not pull the flow."""
    from scipy import ndimage

    img = np.where(np.isfinite(image), image, np.nanmean(image)).astype(np.float32)
    mode = ("wrap", "nearest")
    high = img - ndimage.gaussian_filter(img, NORMALISE_PX, mode=mode)
    sd = np.sqrt(ndimage.gaussian_filter(high ** 2, NORMALISE_PX, mode=mode)) + 1e-6
    z = np.clip(high / sd, -CLIP_SD, CLIP_SD)
    return np.round((z + CLIP_SD) / (2 * CLIP_SD) * 255).astype(np.uint8)


def flow_between(a: np.ndarray, b: np.ndarray, flow=None, initial: np.ndarray | None = None
                 ) -> np.ndarray:
    """Dense optical flow ``(n_u, n_v, 2)`` fine pixels (around, along) from image ``a``
    to ``b`` (8-bit, :func:`normalised`): the pixel at ``(i, j)`` of ``a`` is at ``(i,
    j) + flow`` of ``b``. DIS (OpenCV, medium preset) on the images repeated by
    :data:`WRAP_PAD` rows around, so the flow crosses the seam. ``flow``: a DIS
    object to reuse; ``initial``: a flow ``(n_u, n_v, 2)`` to start from."""
    if flow is None:
        flow = dis_flow()
    pad = ((WRAP_PAD, WRAP_PAD), (0, 0))
    start = None
    if initial is not None:                    # to cv2's (x = along, y = around), padded
        start = np.pad(np.ascontiguousarray(initial[..., ::-1], dtype=np.float32),
                       pad + ((0, 0),), mode="wrap")
    f = flow.calc(np.pad(a, pad, mode="wrap"), np.pad(b, pad, mode="wrap"), start)
    f = f[WRAP_PAD:-WRAP_PAD]
    return np.stack([f[..., 1], f[..., 0]], axis=-1)       # cv2: (x = along, y = around)


def dis_flow():
    """OpenCV's DIS optical flow, medium preset, with its variational refinement."""
    import cv2

    return cv2.DISOpticalFlow_create(cv2.DISOPTICAL_FLOW_PRESET_MEDIUM)


def _at(field: np.ndarray, points: np.ndarray) -> np.ndarray:
    """A field ``(n_u, n_v, k)`` read at ``points (..., 2)`` fine pixels: linear,
    periodic around, held at the end columns along."""
    from scipy.ndimage import map_coordinates

    n_u = field.shape[0]
    wrapped = np.concatenate([field, field[:1]], axis=0)
    i = np.mod(points[..., 0], n_u)
    return np.stack([map_coordinates(wrapped[..., k], [i, points[..., 1]], order=1,
                                     mode="nearest") for k in range(field.shape[-1])], axis=-1)


def _smoothed_displacements(coords: np.ndarray, nodes: np.ndarray) -> np.ndarray:
    """Pathlines ``(n_u, n_v, n_t, 2)`` whose displacements from their ``nodes (n_u,
    n_v, 2)`` are smoothed over neighbouring nodes (:data:`SMOOTH_STEPS`, periodic
    around): a node's own flow error is strain to the fields (on the textured phantom,
    48 frames, the strain energy's median came out 10 % high without it, 6 % with it,
    both before the flows started from the frame before's)."""
    from scipy import ndimage

    moved = coords - nodes[:, :, None]
    moved = ndimage.gaussian_filter(moved, (SMOOTH_STEPS, SMOOTH_STEPS, 0, 0),
                                    mode=("wrap", "nearest", "nearest", "nearest"))
    return nodes[:, :, None] + moved


def texture_pathlines(pullbacks: np.ndarray, factors: tuple[int, int], n_u: int, n_v: int
                      ) -> tuple[np.ndarray, dict]:
    """Pathlines ``(n_u, n_v, n_t, 2)`` grid steps (around, along) that carry each node
    of the analysis grid of frame 0 with the texture of ``pullbacks (n_u f_u, (n_v - 1)
    f_v + 1, n_t)`` (each frame's on its own grid refined by ``factors (f_u, f_v)``)
    through the cycle.

    Each frame is registered to frame 0 directly, not through the frames between, each
    flow starting from the one found for the frame before (DIS's initial flow: the
    deformation grows from frame to frame, and the pyramid then need not find it
    afresh; on 195 frames the strain energy's median came out 12 % high without it,
    right with it): the flow from frame 0 to frame t carries the nodes there, and the
    flow from frame t back to frame 0, inverted at the nodes (a fixed point: q +
    flow(q) = node), gives a second estimate; their mean, its displacements smoothed over neighbouring nodes
    (:func:`_smoothed_displacements`), is the pathline. Chained frame to frame, the flows'
    sub-pixel errors add up over the cycle (on the textured phantom, 48 frames: 0.12 %
    of the length along and 0.016 rad around, against 0.07 % and 0.006 rad directly),
    and the cycle closes by itself. Also returns the diagnostics: the gap between the
    two estimates (grid steps, median and largest over nodes and frames: where it is
    large, the texture did not match) and the share of nodes and frames whose tissue
    lies within the grid along the tube (``in_view``)."""
    n_t = pullbacks.shape[2]
    f = np.array(factors, float)
    images = [normalised(pullbacks[:, :, t]) for t in range(n_t)]
    dis = dis_flow()
    nodes = np.stack(np.meshgrid(np.arange(n_u, dtype=float), np.arange(n_v, dtype=float),
                                 indexing="ij"), axis=-1) * f                # fine pixels
    tracked = np.empty((n_t, n_u, n_v, 2))
    tracked[0] = nodes
    gaps = []
    ahead = back = None                       # each flow starts from the frame before's
    for t in range(1, n_t):
        ahead = flow_between(images[0], images[t], dis, ahead)
        there = nodes + _at(ahead, nodes)
        back = flow_between(images[t], images[0], dis, back)
        inverse = there.copy()
        for _ in range(INVERSE_STEPS):              # q + back(q) = node
            inverse = nodes - _at(back, inverse)
        tracked[t] = 0.5 * (there + inverse)
        gaps.append(np.linalg.norm((there - inverse) / f, axis=-1))
    coords = np.moveaxis(tracked, 0, 2) / f                                 # grid steps
    coords = _smoothed_displacements(coords, nodes / f)
    gap = np.array(gaps) if gaps else np.zeros(1)
    in_view = (coords[..., 1] >= 0) & (coords[..., 1] <= n_v - 1)
    return coords, {"kind": "texture",
                    "forward_backward_gap_steps": {"median": float(np.median(gap)),
                                                   "max": float(gap.max())},
                    "in_view": float(in_view.mean())}


def texture_match_note(gap_median_steps: float) -> str | None:
    """A warning when the texture matched poorly from frame to frame: the median gap
    between the forward and backward estimates over :data:`GAP_WARN_STEPS` grid steps
    (on the zoo, where the grid drifted from the tissue); else None. Faint texture
    under strong speckle, or texture finer than the voxels, does it."""
    if not gap_median_steps > GAP_WARN_STEPS:
        return None
    return (f"the texture matched poorly from frame to frame (forward-backward gap: median "
            f"{gap_median_steps:.2g} grid steps, over {GAP_WARN_STEPS:g}): on the accuracy "
            "zoo's draws such a gap came with the tracked grid drifting 0.2-1.9 % of the "
            "tube's length and 0.02-0.2 rad around from the tissue (at most 0.27 % and 0.02 "
            "rad below it), as when the texture is fainter than its speckle or finer than "
            "the voxels; look at pullback_outer.png, or compare with --tracking material")
