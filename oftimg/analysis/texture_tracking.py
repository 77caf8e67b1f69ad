"""Texture tracking: the grid moved with the tissue's texture, along the tube as well as
around it.

The shape alone cannot show the tissue sliding along the tube or twisting about it
(the shape's features travel with the wave; :mod:`oftimg.analysis.tracking`). The
intensity can: each frame's myocardium pullback (:mod:`oftimg.analysis.pullback`) is
an image of the tissue's texture on that frame's own grid, and dense optical flow
between pullbacks (OpenCV's DIS, periodic around the tube) gives where each pixel's
tissue lies in another frame's grid. OCT's speckle is as strong as the texture (its
contrast about 1) and renewed as the tissue moves, so no two frames are matched to
each other in the end: every frame is matched to a template, the whole beat seen in
frame 0's pixels and averaged, where the speckle averages out and the texture stays
(:func:`texture_pathlines`). The shape's own pathlines are the prior: the texture
says how far the tissue moved beyond them, smoothly over nodes and frames, and only
where the images support it (each node's support and fallback are returned).

Images are ``(n_u, n_v)``: u around (rows, periodic), v along (columns). Positions are
in fine pixels ``(around, along)`` or in grid steps (:mod:`oftimg.analysis.tracking`).
Functions of arrays; no file access.
"""

from __future__ import annotations

import numpy as np

WRAP_PAD = 24  # fine pixels of the image repeated beyond u's ends for the flow
NORMALISE_PX = 6.0  # the local mean and contrast taken out: Gaussian sigma, pixels
CLIP_SD = 3.0  # normalised intensities beyond this many local SDs clipped
INVERSE_STEPS = 5  # fixed-point steps inverting the flow back to the template
# the texture's motion beyond the shape's, smoothed over nodes (Gaussian sigma, steps)
# and frames (a share of the cycle): the tissue's slide and twist are smooth, a node's
# own flow error is strain to the fields (on the speckled zoo's tuning draws 500-507,
# 48 frames: 1 step and no frames left the strain energy's median node error 1.2-2.7
# times the shape's on the draws of faint texture, 3 steps and 2 % of the cycle
# 0.7-1.6 times; 5 steps blurred the twist of the others)
SMOOTH_STEPS = 3.0
SMOOTH_CYCLE = 0.02
# each component (along, around) of that motion kept where it makes the template match
# frame t better than without it by this much correlation, judged over this window
# (Gaussian sigma, steps and share of the cycle); elsewhere the node follows the shape
SUPPORT_MARGIN = 0.01
SUPPORT_STEPS = 4.0
SUPPORT_CYCLE = 0.05
# a node has fallen back where the motion it left out is over this (grid steps)
FALLBACK_STEPS = 0.1
# the forward-backward gap (median, grid steps) above which a run warns: over the speckled
# zoo's 27 fresh draws (seeds 600-616, 660-669) the grid's drift from the tissue rose with
# it: at or under 0.075 steps (25 draws) at most 0.12 % of the length along and 0.012 rad
# around, above 0.1 (2 draws, speckle 73-98 % over a texture of 25-36 %) 0.20-0.21 % and
# 0.015-0.025 rad (docs/accuracy.md)
GAP_WARN_STEPS = 0.1
# the share of nodes and frames that fell back to the shape above which a run warns
FALLBACK_WARN_SHARE = 0.25


def normalised(image: np.ndarray) -> np.ndarray:
    """A pullback ``(n_u, n_v)`` as an 8-bit image of its texture: the local mean and
    contrast (:data:`NORMALISE_PX`) taken out, periodic around, NaN (not imaged) as the
    mean. A beam's attenuation and a layer's brightness then do not pull the flow."""
    from scipy import ndimage

    img = np.where(np.isfinite(image), image, np.nanmean(image)).astype(np.float32)
    mode = ("wrap", "nearest")
    high = img - ndimage.gaussian_filter(img, NORMALISE_PX, mode=mode)
    sd = np.sqrt(ndimage.gaussian_filter(high**2, NORMALISE_PX, mode=mode)) + 1e-6
    z = np.clip(high / sd, -CLIP_SD, CLIP_SD)
    return np.round((z + CLIP_SD) / (2 * CLIP_SD) * 255).astype(np.uint8)


def flow_between(
    a: np.ndarray, b: np.ndarray, flow=None, initial: np.ndarray | None = None
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
    if initial is not None:  # to cv2's (x = along, y = around), padded
        start = np.pad(
            np.ascontiguousarray(initial[..., ::-1], dtype=np.float32), pad + ((0, 0),), mode="wrap"
        )
    f = flow.calc(np.pad(a, pad, mode="wrap"), np.pad(b, pad, mode="wrap"), start)
    f = f[WRAP_PAD:-WRAP_PAD]
    return np.stack([f[..., 1], f[..., 0]], axis=-1)  # cv2: (x = along, y = around)


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
    return np.stack(
        [
            map_coordinates(wrapped[..., k], [i, points[..., 1]], order=1, mode="nearest")
            for k in range(field.shape[-1])
        ],
        axis=-1,
    )


def _warped(image: np.ndarray, flow: np.ndarray) -> np.ndarray:
    """``image (n_u, n_v)`` read at each pixel plus ``flow (n_u, n_v, 2)`` fine pixels
    (around, along): linear, periodic around, held at the ends along. The image of
    frame t seen in frame 0's pixels, for the flow from frame 0 to frame t. (OpenCV's
    remap: its weights are in 32nds of a pixel, finer than the flows' errors.)"""
    import cv2

    n_u, n_v = image.shape
    i, j = np.meshgrid(
        np.arange(n_u, dtype=np.float32), np.arange(n_v, dtype=np.float32), indexing="ij"
    )
    wrapped = np.concatenate([image, image[:1]], axis=0).astype(np.float32)
    return cv2.remap(
        wrapped,
        (j + flow[..., 1]).astype(np.float32),
        np.mod(i + flow[..., 0], n_u).astype(np.float32),
        cv2.INTER_LINEAR,
        borderMode=cv2.BORDER_REPLICATE,
    )


def _dense(displacement: np.ndarray, shape: tuple, f: np.ndarray) -> np.ndarray:
    """Node displacements ``(n_u, n_v, 2)`` grid steps as a dense flow ``shape + (2,)``
    fine pixels (linear between nodes, periodic around; OpenCV's remap)."""
    import cv2

    i, j = np.meshgrid(
        np.arange(shape[0], dtype=np.float32) / np.float32(f[0]),
        np.arange(shape[1], dtype=np.float32) / np.float32(f[1]),
        indexing="ij",
    )
    moved = (displacement * f).astype(np.float32)
    wrapped = np.concatenate([moved, moved[:1]], axis=0)
    return cv2.remap(wrapped, j, i, cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)


def _local_ncc(a: np.ndarray, b: np.ndarray, sigma: tuple) -> np.ndarray:
    """The normalised cross-correlation of images ``a`` and ``b`` ``(n_u, n_v)`` in a
    Gaussian window of ``sigma`` pixels (around, along) about each pixel, periodic
    around: 1 where they match, about 0 where they do not."""
    import cv2

    pad = int(np.ceil(4 * sigma[0]))

    def mean(x):  # OpenCV's blur, wrapped around by hand
        padded = np.pad(x.astype(np.float32), ((pad, pad), (0, 0)), mode="wrap")
        return cv2.GaussianBlur(
            padded,
            (0, 0),
            sigmaX=float(sigma[1]),
            sigmaY=float(sigma[0]),
            borderType=cv2.BORDER_REPLICATE,
        )[pad : pad + x.shape[0]]

    a = a - mean(a)
    b = b - mean(b)
    return mean(a * b) / np.sqrt(np.maximum(mean(a * a) * mean(b * b), 1e-12))


def _nodes(n_u: int, n_v: int) -> np.ndarray:
    """The grid's nodes ``(n_u, n_v, 2)`` in grid steps (around, along)."""
    return np.stack(
        np.meshgrid(np.arange(n_u, dtype=float), np.arange(n_v, dtype=float), indexing="ij"),
        axis=-1,
    )


def _wrapped_steps(step: np.ndarray, n_u: int) -> np.ndarray:
    """Differences of positions ``(..., 2)`` grid steps, around taken the short way."""
    out = step.copy()
    out[..., 0] = (out[..., 0] + n_u / 2) % n_u - n_u / 2
    return out


def _smoothed(field: np.ndarray, steps: float, cycle: float) -> np.ndarray:
    """A field ``(n_u, n_v, n_t[, k])`` smoothed over nodes (``steps``, periodic around,
    held at the ends along) and frames (``cycle`` of the cycle, periodic)."""
    from scipy import ndimage

    sigma = (steps, steps, cycle * field.shape[2]) + (0,) * (field.ndim - 3)
    mode = ("wrap", "nearest", "wrap") + ("nearest",) * (field.ndim - 3)
    return ndimage.gaussian_filter(field, sigma, mode=mode)


def texture_pathlines(
    pullbacks: np.ndarray, factors: tuple[int, int], shape_coords: np.ndarray
) -> tuple[np.ndarray, dict]:
    """Pathlines ``(n_u, n_v, n_t, 2)`` grid steps (around, along) that carry each node
    of the analysis grid of frame 0 with the texture of ``pullbacks (n_u f_u, (n_v - 1)
    f_v + 1, n_t)`` (each frame's on its own grid refined by ``factors (f_u, f_v)``)
    through the cycle, beyond the shape's own pathlines ``shape_coords (n_u, n_v, n_t,
    2)`` (:func:`~oftimg.analysis.tracking.track_grid`: the grid's turns from frame to
    frame, which the texture must not be asked to find again).

    1. Each frame registered to frame 0 directly, each flow starting from the one found
       for the frame before (DIS's initial flow: the deformation grows from frame to
       frame); 2. the template: every frame seen in frame 0's pixels along those flows
       and averaged (the speckle, renewed from frame to frame, averages out over the
       beat; on the speckled zoo's tuning draws the drift fell by 10-35 %); 3. each
       frame registered to the template, starting from step 1's flow: each node carried
       by the flow from the template, and by the flow back inverted at the nodes (a
       fixed point: q + flow(q) = node), the mean of the two; registered to one
       reference, the cycle closes by itself; 4. the motion beyond the shape's smoothed
       (:data:`SMOOTH_STEPS`, :data:`SMOOTH_CYCLE`); 5. each of its components kept where
       the texture supports it (:func:`_supported`), the shape's elsewhere.

    Returns the pathlines and the diagnostics: ``forward_backward_gap_steps`` (the
    gap between step 3's two estimates, median and largest: where it is large the
    texture did not match), ``support`` ``(n_u, n_v, n_t)`` (each node's local
    correlation of the template with frame t along its pathline: 1 a perfect match,
    about 0 none), ``fallback`` ``(n_u, n_v, n_t)`` bool (the node follows the shape
    along or around), its share ``fallback_share`` and by component, and ``in_view``
    (the share of nodes and frames whose tissue lies within the grid along the tube)."""
    n_u, n_v, n_t = shape_coords.shape[:3]
    f = np.array(factors, float)
    frames = [normalised(pullbacks[:, :, t]) for t in range(n_t)]  # 8-bit, for DIS
    images = [frame.astype(np.float32) for frame in frames]  # for warping
    dis = dis_flow()
    nodes = _nodes(n_u, n_v) * f  # fine pixels
    flows = [np.zeros(images[0].shape + (2,), np.float32)]
    ahead = None
    for t in range(1, n_t):  # 1. to frame 0 itself
        ahead = flow_between(frames[0], frames[t], dis, ahead)
        flows.append(ahead)
    seen = [_warped(images[t], flows[t]) for t in range(n_t)]
    total = np.sum(seen, axis=0)
    # 2. the beat's template, frame t left out
    references = [normalised((total - seen[t]) / max(n_t - 1, 1)) for t in range(n_t)]
    del seen
    tracked = np.empty((n_u, n_v, n_t, 2))
    gaps = []
    back = None
    for t in range(n_t):  # 3. to the template
        frame = frames[t]
        ahead = flow_between(references[t], frame, dis, flows[t])
        there = nodes + _at(ahead, nodes)
        back = flow_between(frame, references[t], dis, back)
        inverse = there.copy()
        for _ in range(INVERSE_STEPS):  # q + back(q) = node
            inverse = nodes - _at(back, inverse)
        tracked[:, :, t] = 0.5 * (there + inverse) / f
        gaps.append(np.linalg.norm((there - inverse) / f, axis=-1))
    beyond = _smoothed(
        _wrapped_steps(tracked - shape_coords, n_u),  # 4. smoothed
        SMOOTH_STEPS,
        SMOOTH_CYCLE,
    )
    keep, support = _supported(beyond, shape_coords, references, images, f)
    coords = shape_coords + keep * beyond  # 5. where the texture says so
    gap = np.array(gaps)
    ignored = np.abs((1 - keep) * beyond) > FALLBACK_STEPS
    fallback = ignored.any(axis=-1)
    in_view = (coords[..., 1] >= 0) & (coords[..., 1] <= n_v - 1)
    return coords, {
        "kind": "texture",
        "forward_backward_gap_steps": {"median": float(np.median(gap)), "max": float(gap.max())},
        "support": support.astype(np.float32),
        "fallback": fallback,
        "fallback_share": float(fallback.mean()),
        "fallback_share_along": float(ignored[..., 1].mean()),
        "fallback_share_around": float(ignored[..., 0].mean()),
        "in_view": float(in_view.mean()),
    }


def _support(coords: np.ndarray, references: list, images: list, f: np.ndarray) -> np.ndarray:
    """The texture's support ``(n_u, n_v, n_t)`` for pathlines ``coords (n_u, n_v, n_t,
    2)`` grid steps: the local correlation (:func:`_local_ncc`, a grid step's Gaussian
    window) of frame t's template (``references[t]``) with its image (``images[t]``)
    seen along them."""
    n_u, n_v, n_t, _ = coords.shape
    nodes = _nodes(n_u, n_v)
    step_u, step_v = (int(k) for k in f)
    out = np.empty((n_u, n_v, n_t))
    for t in range(n_t):
        template = references[t].astype(np.float32)
        seen = _warped(images[t], _dense(coords[:, :, t] - nodes, template.shape, f))
        out[:, :, t] = _local_ncc(template, seen, tuple(f))[::step_u, ::step_v]  # the nodes
    return out


def _supported(
    beyond: np.ndarray, shape: np.ndarray, references: list, images: list, f: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """How much of the texture's motion ``beyond (n_u, n_v, n_t, 2)`` the shape's
    pathlines ``shape`` each node keeps, around and along ``(n_u, n_v, n_t, 2)`` in
    [0, 1], and the support of the kept pathlines ``(n_u, n_v, n_t)``.

    The four candidates (both components, around alone, along alone, neither) are
    scored by their support (:func:`_support`) averaged over :data:`SUPPORT_STEPS` and
    :data:`SUPPORT_CYCLE`; a component is kept where its best candidate beats the best
    without it by :data:`SUPPORT_MARGIN` (where they tie, the shape's: the texture's
    sub-voxel guess adds noise, not tissue), the choice smoothed over the same window
    (a hard edge would be strain)."""
    scores = {
        keep: _smoothed(
            _support(shape + beyond * np.array(keep, float), references, images, f),
            SUPPORT_STEPS,
            SUPPORT_CYCLE,
        )
        for keep in ((1, 1), (1, 0), (0, 1), (0, 0))
    }

    def kept(k: int) -> np.ndarray:
        with_it = np.maximum(*(v for c, v in scores.items() if c[k]))
        without = np.maximum(*(v for c, v in scores.items() if not c[k]))
        return _smoothed(
            (with_it > without + SUPPORT_MARGIN).astype(float), SUPPORT_STEPS, SUPPORT_CYCLE
        )

    keep = np.stack([kept(0), kept(1)], axis=-1)
    support = _support(shape + keep * beyond, references, images, f)
    return keep, support


def fallback_note(share: float) -> str | None:
    """A warning when more than :data:`FALLBACK_WARN_SHARE` of the nodes and frames
    fell back to the shape (the texture did not support its own motion there); else
    None."""
    if not share > FALLBACK_WARN_SHARE:
        return None
    return (
        f"{100 * share:.0f} % of the nodes and frames follow the shape alone along or "
        "around the tube: there the texture did not match better with its own motion "
        "than without it (faint texture under speckle, or texture finer than the "
        "voxels); texture_fallback in arrays.npz shows where, pullback_outer.png the "
        "texture"
    )


def texture_match_note(gap_median_steps: float) -> str | None:
    """A warning when the texture matched poorly from frame to frame: the median gap
    between the forward and backward estimates over :data:`GAP_WARN_STEPS` grid steps
    (on the zoo, where the grid drifted from the tissue); else None. Faint texture
    under strong speckle, or texture finer than the voxels, does it."""
    if not gap_median_steps > GAP_WARN_STEPS:
        return None
    return (
        f"the texture matched poorly from frame to frame (forward-backward gap: median "
        f"{gap_median_steps:.2g} grid steps, over {GAP_WARN_STEPS:g}): on the speckled "
        "accuracy zoo such a gap came with the tracked grid drifting about 0.2 % of the "
        "tube's length and 0.015-0.025 rad around from the tissue (at most 0.12 % and "
        "0.012 rad under 0.075), as when the texture is fainter than its speckle or "
        "finer than the voxels; look at pullback_outer.png (the texture's support), or "
        "compare with --tracking material"
    )
