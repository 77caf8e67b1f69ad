"""Lagrangian clipping of the ventricular end (paper section 4.4).

The myocardium is taken as incompressible and the aortic end as fixed, so the
tissue inside the window at the minimum-volume frame is followed by clipping
every other frame's ventricular end at the plane that leaves the same
myocardial volume.
"""

from __future__ import annotations

import numpy as np

from .sections import slab_volumes
from .topology import interp_grouped


def cumulative_from_outlet(area_mm2: np.ndarray, thickness_mm: np.ndarray) -> np.ndarray:
    """Volume (mm^3) between each row and the outlet, ``(n_v, n_t)``.

    ``area_mm2 (n_v, n_t)``: section areas; ``thickness_mm (n_v - 1, n_t)``:
    the slabs between consecutive sections (:func:`~oftimg.mesh.sections.slab_thickness`);
    trapezoid rule.
    """
    slab = slab_volumes(area_mm2, thickness_mm)
    rev = np.cumsum(slab[::-1], axis=0)[::-1]
    return np.concatenate([rev, np.zeros((1, area_mm2.shape[1]))], axis=0)


def clip_positions(myo_area_mm2: np.ndarray, thickness_mm: np.ndarray) -> tuple[np.ndarray, float]:
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
    """Re-parameterize grid lines ``X (..., n_v, 3)`` to their part beyond a plane.

    Each line (a u-line of a frame's grid ``(n_u, n_v, 3)``, or of several
    frames at once with ``origin``, ``normal`` broadcasting against ``X[..., 0, :]``)
    is cut where it last crosses to the plane's positive side and resampled by
    arc length into ``n_v`` nodes from the plane to the outlet end.
    """
    n_v = X.shape[-2]
    lines = X.reshape(-1, n_v, 3)
    origin = np.broadcast_to(origin, X.shape[:-2] + (3,)).reshape(-1, 3)
    normal = np.broadcast_to(normal, X.shape[:-2] + (3,)).reshape(-1, 3)
    rows = np.arange(len(lines))
    d = np.einsum("lvk,lk->lv", lines - origin[:, None], normal)
    behind = d < 0
    k = np.where(behind.any(axis=1), n_v - 1 - np.argmax(behind[:, ::-1], axis=1), 0)
    k = np.minimum(k, n_v - 2)
    dk, dk1 = d[rows, k], d[rows, k + 1]
    with np.errstate(invalid="ignore", divide="ignore"):
        f = np.where((dk != dk1) & behind.any(axis=1), dk / (dk - dk1), 0.0)
    f = np.clip(f, 0.0, 1.0)
    # arc length along each whole line; the clipped line is its part from s_start
    s = np.concatenate(
        [
            np.zeros((len(lines), 1)),
            np.cumsum(np.linalg.norm(np.diff(lines, axis=1), axis=2), axis=1),
        ],
        axis=1,
    )
    s_start = s[rows, k] + f * (s[rows, k + 1] - s[rows, k])
    target = s_start[:, None] + np.linspace(0.0, 1.0, n_v) * (s[:, -1] - s_start)[:, None]
    out = interp_grouped(target, s.ravel(), lines.reshape(-1, 3), np.repeat(rows, n_v))
    return out.reshape(X.shape)


def clipped_grids(
    grids: dict[str, np.ndarray],
    plane_origin: np.ndarray,
    plane_normal: np.ndarray,
    clip_v: np.ndarray,
) -> dict[str, np.ndarray]:
    """Each wall's grid ``(n_u, n_v, n_t, 3)`` mm clipped in every frame at the plane
    of constant myocardial volume, as ``"<wall>_clipped"`` ``(n_u, n_v, n_t, 3)``:
    frame t's plane lies at ``clip_v[t]`` between its section planes ``plane_origin``
    / ``plane_normal`` ``(n_v, n_t, 3)`` (:func:`plane_at`), and each u-line is cut there
    and resampled from it to the outlet (:func:`clip_grid`). Made from what a run
    stores, so that the clipped grids need not be stored too."""
    planes = [
        plane_at(plane_origin[:, t], plane_normal[:, t], float(v)) for t, v in enumerate(clip_v)
    ]
    origin = np.array([o for o, _ in planes])  # (n_t, 3)
    normal = np.array([n for _, n in planes])
    return {
        f"{w}_clipped": clip_grid(
            np.asarray(g, float).transpose(0, 2, 1, 3), origin, normal
        ).transpose(0, 2, 1, 3)  # u-lines of all frames
        for w, g in grids.items()
    }
