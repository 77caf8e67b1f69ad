"""Defects a segmentation leaves now and then, put into one frame's label volume on
purpose: the known answer for the repairs that :mod:`oftimg.mesh.mask_topology` and
:mod:`oftimg.io.label_dataset` make (which frame, which wall, what was done).

Each defect sits where the tube crosses one row of voxels through the middle of its
lumen (the volume's row ``(k, j, :)``, ``k`` and ``j`` the lumen's median), so it
meets every layer of the wall; labels as in :mod:`oftimg.synthetic.labels`.
"""

from __future__ import annotations

import numpy as np

from ..io.label_dataset import DEFAULT_LABEL_IDS as LABELS

# defect -> the walls whose masks it damages (what a run must report there)
DEFECTS = {
    "handle": ("outer",),  # a strand of myocardium looping outside the tube
    "tunnel": ("outer", "inner", "lumen"),  # a channel of background across the tube
    "bridge": ("lumen",),  # a strand of jelly across the lumen
    "myocardium_hole": ("outer",),  # background through the myocardium to the jelly
    "no_lumen": ("lumen",),  # the lumen labelled as jelly in the whole frame
    "touching": ("inner",),  # the myocardium gone over a patch: jelly meets outside
}


def _row(labels: np.ndarray) -> tuple[int, int, np.ndarray]:
    """The middle row through the lumen: ``(k, j, x)``, ``x`` the row's tube voxels'
    indices along the volume's last axis (the stretch that holds the lumen)."""
    lumen = labels == LABELS["lumen"]
    k = int(np.median(np.nonzero(lumen)[0]))
    j = int(np.median(np.nonzero(lumen[k])[0]))
    inside = labels[k, j] > 0
    at = int(np.median(np.nonzero(lumen[k, j])[0]))
    start = at - int(np.argmin(inside[at::-1])) + 1  # the first background before
    stop = at + int(np.argmin(inside[at:]))  # and after the lumen
    return k, j, np.arange(start, stop)


def inject(labels: np.ndarray, defect: str) -> np.ndarray:
    """A copy of ``labels`` ``(z, y, x)`` with ``defect`` (a key of :data:`DEFECTS`)."""
    if defect not in DEFECTS:
        raise ValueError(f"defect must be one of {', '.join(DEFECTS)}, found {defect!r}")
    out = labels.copy()
    k, j, x = _row(labels)
    row = labels[k, j, x]
    myo = x[row == LABELS["myocardium"]]
    far_myo = myo[myo > x[np.argmax(row == LABELS["lumen"])]]  # the wall past the lumen
    near_myo = myo[myo < far_myo.min()]
    if defect == "handle":
        reach = 4  # a strand 2 voxels thick, 2 clear of the wall
        bar = slice(x[-1] + 2, x[-1] + 4)
        out[k - reach : k + reach + 2, j : j + 2, bar] = LABELS["myocardium"]
        for kk in (k - reach, k + reach):
            edge = np.nonzero(labels[kk, j] > 0)[0].max()
            out[kk : kk + 2, j : j + 2, edge : bar.stop] = LABELS["myocardium"]
    elif defect == "tunnel":
        out[k : k + 2, j : j + 2, x[0] - 1 : x[-1] + 2] = 0
    elif defect == "bridge":
        lumen = x[row == LABELS["lumen"]]
        box = (slice(k, k + 2), slice(j, j + 2), slice(lumen.min() - 1, lumen.max() + 2))
        out[box] = np.where(out[box] == LABELS["lumen"], LABELS["jelly"], out[box])
    elif defect == "myocardium_hole":
        box = (
            slice(k - 1, k + 2),
            slice(j - 1, j + 2),
            slice(near_myo.min() - 1, near_myo.max() + 1),
        )
        out[box] = np.where(out[box] == LABELS["myocardium"], 0, out[box])
    elif defect == "no_lumen":
        out[out == LABELS["lumen"]] = LABELS["jelly"]
    else:  # touching
        box = (slice(k - 3, k + 4), slice(j - 3, j + 4), slice(far_myo.min(), far_myo.max() + 2))
        out[box] = np.where(out[box] == LABELS["myocardium"], LABELS["jelly"], out[box])
    return out


def lumen_gap(labels: np.ndarray, share: float = 0.3) -> np.ndarray:
    """A copy of ``labels`` ``(z, y, x)`` whose lumen is labelled as jelly over the
    middle ``share`` of its extent along the volume's axis where it is longest: a
    segmentation that lost the lumen over a stretch of one frame (what the cushions'
    closure looks like in that frame alone; not in :data:`DEFECTS`, whose draws the
    zoo's seeds keep)."""
    out = labels.copy()
    lumen = labels == LABELS["lumen"]
    where = np.nonzero(lumen)
    axis = int(np.argmax([np.ptp(w) for w in where]))
    low, high = np.percentile(where[axis], [50 - 50 * share, 50 + 50 * share])
    index = np.arange(labels.shape[axis]).reshape([-1 if a == axis else 1 for a in range(3)])
    out[lumen & (index >= low) & (index <= high)] = LABELS["jelly"]
    return out
