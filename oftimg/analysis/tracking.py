"""Material tracking: the (u, v) grid turned with the tissue from frame to frame.

Each frame's grid is made on its own (seam, map, resample), so node (i, j) of one
frame and node (i, j) of the next are the same tissue only approximately: as the
wave passes, the shortest seam and the map turn each row about the tube (by up to a
third of a turn on a real gut, in jumps where the geodesic changes its route). Here
each row of the next frame is turned about the tube (a circular shift in u) to lie
as close as it can to the ring of tissue the row held, in 3-D (a least-squares ring
registration by FFT, :func:`ring_turns`); the turns are followed over the cycle from
frame 0, and what they miss by when they come back to frame 0 (the closure error)
is taken off in equal shares over the frames (:func:`row_turns`). Every per-pixel
field is then read along the turned rows (:func:`follow`).

What this follows: the tissue whose motion is across the surface (the wave: towards
and away from the axis) keeps its u in every frame, however the seam and the map
turned. What it does not: a twist of the tissue about the axis (a minimal-turn
registration takes it back out) and sliding along the tube (each node keeps its row,
the map's even spacing in arc length). Optical flow on images of the surface's shape
(OpenCV's DIS) was tried for both and left out (docs/methods.md): along the tube the
shape's features travel with the wave, and the phantoms' nodes drifted by 8 % of the
length instead of 2.6 %; around it, the flow took 0.02 % of the length off a twisted
gut's drift and made the phantoms' angle drift 1.7 times larger.

Coordinates are in grid steps: ``i`` around (periodic, ``n_u``), ``j`` along
(``0 .. n_v - 1``). Functions of arrays; no file access.
"""

from __future__ import annotations

import numpy as np
from scipy.ndimage import map_coordinates

# the rows' turns are found on a grid this many times finer than the steps around
TURN_OVERSAMPLE = 8


def _wrapped(steps: np.ndarray, n: int) -> np.ndarray:
    """Steps around a loop of ``n`` into [-n/2, n/2)."""
    return (steps + n / 2) % n - n / 2


def sample(field: np.ndarray, coords: np.ndarray) -> np.ndarray:
    """A frame's field ``(n_u, n_v)`` read at ``coords (..., 2)`` grid steps (around,
    along): cubic, periodic around, held at the end rows along; NaN where a NaN cell
    (a closed lumen's rows) is among the point's linear neighbours. (Padded by 12 steps
    around: the cubic spline's prefilter then sees the wrap to 1e-7, the same
    whichever way the tube is entered. Its prefilter is global: a NaN would reach
    every point, so NaN cells are given their nearest known value first.)"""
    from scipy import ndimage

    pad = 12
    wrapped = np.pad(field, ((pad, pad), (0, 0)), mode="wrap")
    i = np.mod(coords[..., 0], field.shape[0]) + pad
    unknown = ~np.isfinite(wrapped)
    if not unknown.any():
        return map_coordinates(wrapped, [i, coords[..., 1]], order=3, mode="nearest")
    if unknown.all():
        return np.full(coords.shape[:-1], np.nan, np.result_type(field.dtype, np.float32))
    nearest = ndimage.distance_transform_edt(unknown, return_distances=False, return_indices=True)
    out = map_coordinates(wrapped[tuple(nearest)], [i, coords[..., 1]], order=3, mode="nearest")
    near_unknown = map_coordinates(
        unknown.astype(np.float32), [i, coords[..., 1]], order=1, mode="nearest"
    )
    return np.where(near_unknown > 0, np.nan, out)


def follow(field: np.ndarray, coords: np.ndarray) -> np.ndarray:
    """A field ``(n_u, n_v, n_t, ...)`` (a grid's positions, a curvature, a thickness)
    read along the pathlines ``coords (n_u, n_v, n_t, 2)``: each node the same tissue
    in every frame (:func:`sample`; NaN next to a NaN cell)."""
    n_u, n_v, n_t = field.shape[:3]
    flat = field.reshape(n_u, n_v, n_t, -1)
    out = np.empty(flat.shape, dtype=np.result_type(field.dtype, np.float32))
    for t in range(n_t):
        for k in range(flat.shape[-1]):
            out[:, :, t, k] = sample(flat[:, :, t, k], coords[:, :, t])
    return out.reshape(field.shape)


def _frame_positions(G: np.ndarray, coords: np.ndarray) -> np.ndarray:
    """A frame's grid ``G (n_u, n_v, 3)`` read at ``coords (n_u, n_v, 2)``."""
    return np.stack([sample(G[..., k], coords) for k in range(3)], axis=-1)


def ring_turns(A: np.ndarray, B: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """For each row ``j``, the circular shift ``s_j`` (grid steps, sub-step) that brings
    ring ``B[:, j]`` closest to ring ``A[:, j]``: ``B(i + s_j) ~ A(i)``, each ring about
    its own centroid; ``A, B (n_u, n_v, 3)`` mm. Returns the shifts ``(n_v,)`` and each
    row's RMS distance (mm) after the shift.

    The least-squares shift maximises the cross-correlation ``sum_i A(i) . B(i + s)``,
    found by FFT on a :data:`TURN_OVERSAMPLE` times finer grid (the spectrum padded),
    then a parabola through the peak."""
    n = A.shape[0]
    A = A - A.mean(axis=0, keepdims=True)
    B = B - B.mean(axis=0, keepdims=True)
    spectrum = (np.conj(np.fft.fft(A, axis=0)) * np.fft.fft(B, axis=0)).sum(axis=-1)
    fine = np.zeros((n * TURN_OVERSAMPLE, A.shape[1]), dtype=complex)
    half = (n + 1) // 2
    fine[:half] = spectrum[:half]
    fine[-(n - half) :] = spectrum[half:]
    corr = np.fft.ifft(fine, axis=0).real
    peak = np.argmax(corr, axis=0)
    j = np.arange(A.shape[1])
    m = len(corr)
    before, at, after = corr[(peak - 1) % m, j], corr[peak, j], corr[(peak + 1) % m, j]
    curve = before - 2 * at + after
    frac = np.where(curve < 0, 0.5 * (before - after) / np.where(curve < 0, curve, 1.0), 0.0)
    shifts = _wrapped((peak + frac) / TURN_OVERSAMPLE, n)
    energy = (A * A).sum(axis=(0, 2)) + (B * B).sum(axis=(0, 2))
    best = corr.max(axis=0) * TURN_OVERSAMPLE  # ifft divided by the padded length
    rms = np.sqrt(np.maximum(energy - 2 * best, 0.0) / n)
    return shifts, rms


def row_turns(G: np.ndarray) -> tuple[np.ndarray, dict]:
    """How far each row of each frame's grid ``G (n_u, n_v, n_t, 3)`` mm is turned
    about the tube against the tissue of frame 0: ``(n_v, n_t)`` grid steps (node i of
    row j in frame 0 is at ``i + turn[j, t]`` of frame t), step 1 of the module.

    Frame by frame: the tissue's ring in frame t (frame t's grid read at the turns so
    far) against frame t + 1's own row (:func:`ring_turns`), the last frame against
    frame 0 closing the cycle; the miss there spread over the frames. Also returns
    ``{"ring_rms_mm": median over rows and frames of the RMS distance between
    consecutive frames' rings after the turn, "ring_rms_unturned_mm": the same without
    turning, "closure_deg": median and largest closure miss}``.
    """
    n_u, n_v, n_t, _ = G.shape
    turn = np.zeros((n_v, n_t + 1))
    nodes = np.stack(
        np.meshgrid(np.arange(n_u, dtype=float), np.arange(n_v, dtype=float), indexing="ij"),
        axis=-1,
    )
    rms, unturned = [], []
    for t in range(n_t):
        here = nodes.copy()
        here[..., 0] += turn[None, :, t]
        ring = _frame_positions(G[:, :, t], here)
        nxt = G[:, :, (t + 1) % n_t]
        shifts, after = ring_turns(ring, nxt)
        turn[:, t + 1] = turn[:, t] + _wrapped(shifts - turn[:, t], n_u)
        rms.append(after)
        unturned.append(np.sqrt(((G[:, :, t] - nxt) ** 2).sum(axis=-1).mean(axis=0)))
    miss = turn[:, n_t] - turn[:, 0]
    turn = turn[:, :n_t] - np.arange(n_t)[None, :] / n_t * miss[:, None]
    degrees = np.abs(miss) * 360.0 / n_u
    return turn, {
        "ring_rms_mm": float(np.median(rms)),
        "ring_rms_unturned_mm": float(np.median(unturned)),
        "closure_deg": {"median": float(np.median(degrees)), "max": float(degrees.max())},
    }


def track_grid(G: np.ndarray) -> tuple[np.ndarray, dict]:
    """Pathlines ``(n_u, n_v, n_t, 2)`` grid steps (around, along) that carry each node
    of frame 0 of the grid ``G (n_u, n_v, n_t, 3)`` mm with its tissue through the
    cycle (:func:`row_turns`; each node keeps its row), and the turns' diagnostics."""
    n_u, n_v, n_t, _ = G.shape
    turn, info = row_turns(G)
    nodes = np.stack(
        np.meshgrid(np.arange(n_u, dtype=float), np.arange(n_v, dtype=float), indexing="ij"),
        axis=-1,
    )
    coords = np.broadcast_to(nodes[:, :, None], (n_u, n_v, n_t, 2)).copy()
    coords[..., 0] += turn[None]
    return coords, info
