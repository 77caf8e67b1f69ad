"""Lagrangian clipping of the ventricular end (paper section 4.4).

The myocardium is taken as incompressible and the aortic end as fixed, so the
tissue inside the window at the minimum-volume frame is followed by clipping
every other frame's ventricular end at the plane that leaves the same
myocardial volume.
"""
from __future__ import annotations

import numpy as np

from .sections import slab_volumes


def cumulative_from_outlet(area_mm2: np.ndarray, thickness_mm: np.ndarray) -> np.ndarray:
    """Volume (mm^3) between each row and the outlet, ``(n_v, n_t)``.

    ``area_mm2 (n_v, n_t)``: section areas; ``thickness_mm (n_v - 1, n_t)``:
    the slabs between consecutive sections (:func:`~oftimg.mesh.sections.slab_thickness`);
    trapezoid rule.
    """
    slab = slab_volumes(area_mm2, thickness_mm)
    rev = np.cumsum(slab[::-1], axis=0)[::-1]
    return np.concatenate([rev, np.zeros((1, area_mm2.shape[1]))], axis=0)


def clip_positions(myo_area_mm2: np.ndarray, thickness_mm: np.ndarray
                   ) -> tuple[np.ndarray, float]:
    """Per frame, the v at which clipping leaves the minimum myocardial volume.

    Returns ``v_c (n_t,)`` in [0, 1] (0 at the frame of minimum volume) and the
    target volume (mm^3).
    """
    cum = cumulative_from_outlet(myo_area_mm2, thickness_mm)
    target = float(np.nanmin(cum[0]))
    n_v = cum.shape[0]
    v = np.linspace(0.0, 1.0, n_v)
    v_c = np.empty(cum.shape[1])
    for t in range(cum.shape[1]):
        # cum[:, t] decreases along v; interpolate on the reversed (increasing) profile
        v_c[t] = np.interp(target, cum[::-1, t], v[::-1])
    return v_c, target


def plane_at(origins: np.ndarray, normals: np.ndarray, v: float):
    """Plane at fractional ``v`` in [0, 1], interpolated between rows ``(n_v, 3)``."""
    x = v * (len(origins) - 1)
    j = min(int(np.floor(x)), len(origins) - 2)
    f = x - j
    o = (1 - f) * origins[j] + f * origins[j + 1]
    n = (1 - f) * normals[j] + f * normals[j + 1]
    return o, n / np.linalg.norm(n)


def clip_grid(X: np.ndarray, origin: np.ndarray, normal: np.ndarray) -> np.ndarray:
    """Re-parameterize one frame's grid ``X (n_u, n_v, 3)`` to the part beyond a plane.

    Each u-line is cut where it crosses the plane and resampled by arc length
    into ``n_v`` nodes from the plane to the outlet.
    """
    n_u, n_v, _ = X.shape
    out = np.empty_like(X)
    for i in range(n_u):
        line = X[i]
        d = (line - origin) @ normal
        behind = np.nonzero(d < 0)[0]
        if len(behind) == 0:
            start, seg = line[0], line
        else:
            k = min(int(behind.max()), n_v - 2)
            f = d[k] / (d[k] - d[k + 1]) if d[k] != d[k + 1] else 0.0
            start = line[k] + np.clip(f, 0, 1) * (line[k + 1] - line[k])
            seg = np.concatenate([start[None], line[k + 1:]])
        step = np.linalg.norm(np.diff(seg, axis=0), axis=1)
        s = np.concatenate([[0.0], np.cumsum(step)])
        target = np.linspace(0, s[-1], n_v)
        out[i] = np.stack([np.interp(target, s, seg[:, c]) for c in range(3)], axis=-1)
    return out
