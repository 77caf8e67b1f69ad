"""The wave's fronts on each wall of one dataset (:mod:`oftimg.image.activation` on
its tracked grids): the arrays a run writes (activation times, their noise, the
surface wave velocity, each node's phase) and the summary's ``wave_fronts``."""

from __future__ import annotations

import numpy as np

from ..image.activation import (
    ACTIVATION_FLOOR_SHARE,
    activation_times,
    auto_smoothing,
    normal_displacement,
    ring_swing,
    strong,
    surface_velocity,
    wave_summary,
)


def wave_fronts(grids: dict, s_mm: np.ndarray, period_ms: float) -> tuple[dict, dict]:
    """``(arrays, summary)`` of the wave's fronts on each wall of ``grids`` (wall ->
    grid ``(n_u, n_v, n_t, 3)`` mm over one cycle of equal frames): per wall
    ``activation_time_<wall>_ms`` and ``activation_sd_<wall>_ms`` ``(n_u, n_v)`` (the
    larger of the noise of the node's own motion and the times' scatter about the
    plane the velocity fits round it, and at least
    :data:`~oftimg.image.activation.ACTIVATION_FLOOR_SHARE` of the period),
    ``wave_velocity_<wall>_mm_s`` ``(n_u, n_v, 2)`` (along, around) and ``phase_<wall>``
    ``(n_u, n_v, n_t)`` (radians, 0 at activation); the summary per wall
    (:func:`~oftimg.image.activation.wave_summary`, with the rings' sideways swing,
    which reads as a front on one side, the activation's median noise SD and the share
    of nodes that move enough to read the wave, :func:`~oftimg.image.activation.strong`:
    the velocity is NaN at the others)."""
    arrays, summary = (
        {},
        {
            "marker": "first harmonic of each node's motion along the "
            "wall's outward normal; activation at its "
            "steepest rise"
        },
    )
    for wall, grid in grids.items():
        activation = activation_times(normal_displacement(grid), period_ms)
        reads = strong(activation)
        sigma = auto_smoothing(activation.time_ms, period_ms, reads)
        velocity = surface_velocity(
            activation.time_ms, grid.mean(axis=2), period_ms, smoothing_nodes=sigma, use=reads
        )
        arrays[f"activation_time_{wall}_ms"] = activation.time_ms.astype(np.float32)
        # a node's error: its own motion's noise, or its times' scatter about the plane
        # fitted round it where that is larger (errors unlike from node to node), and no
        # less than the floor the zoo finds
        sd_ms = np.fmax(
            np.fmax(activation.sd_ms, velocity.scatter_ms), ACTIVATION_FLOOR_SHARE * period_ms
        )
        arrays[f"activation_sd_{wall}_ms"] = sd_ms.astype(np.float32)
        arrays[f"wave_velocity_{wall}_mm_s"] = np.stack(
            [velocity.along_mm_s, velocity.around_mm_s], axis=-1
        ).astype(np.float32)
        arrays[f"phase_{wall}"] = activation.phase.astype(np.float32)
        summary[wall] = {
            **wave_summary(activation, velocity, s_mm, period_ms),
            "activation_sd_ms_median": float(np.nanmedian(sd_ms)),
            "strong_share": float(reads.mean()),
            "smoothing_nodes": sigma,
            "ring_swing_mm_median": float(np.median(ring_swing(grid))),
        }
    return arrays, summary
