"""Each shape field's and the cycle wave speed's 95 % band: the frame-to-frame noise a
run measures in it (``field_noise``: :func:`~oftimg.image.normalize.smooth_field`; the
speed's noise spread) widened as calibrated on the randomized phantom zoo.

The noise a run measures is the part of its error that changes from frame to frame.
What stays put in space it cannot see: the voxel lattice of a label volume (a wall
sampled by the same voxels in every frame), the mesh's roughness at its own vertices
around a section, the model's curvature changing across a node's jitter. On the zoo's
draws 1.96 times that noise held only part of the true error (docs/accuracy.md); the
factors below widen it so that the band holds 95 % of the nodes and frames of the draws
it was fitted on, and they were checked on draws it was not fitted on
(``scripts/zoo_calibration.py``; docs/accuracy.md, "The runs' own error bars").
"""

from __future__ import annotations

import numpy as np

# input kind -> field -> factor k (95 % band = 1.96 k x the noise after smoothing)
BAND_FACTORS = {  # fitted 2026-12-05: meshes on the zoo's seeds 0-9, labels on 0-8
    "meshes": {
        "radial_curvature_outer": 1.68,
        "radial_curvature_inner": 1.59,
        "mean_curvature_lumen": 1.81,
        "wall_thickness": 1.05,
        "jelly_thickness": 1.09,
    },
    "labels": {
        "radial_curvature_outer": 3.92,
        "radial_curvature_inner": 3.31,
        "mean_curvature_lumen": 11.12,
        "wall_thickness": 2.89,
        "jelly_thickness": 3.97,
    },
}
# the cycle wave speed's error its noise spread cannot see (the ridge sampled by the
# frames and rows, the ridge smoothing's pull, a crossing in few frames), as a share of
# the speed: 1.96 x the spread alone held the truth in 73 % of the zoo's draws, with
# this share added in quadrature in 96 % (45 draws of every input kind, 2026-12-05;
# scripts/accuracy_zoo.py --tables prints both)
SPEED_SYSTEMATIC_SHARE = 0.05
# probability maps: fitted on the zoo's probability draws 0-9, 2026-12-05 (95-97 % of the
# 40 others' nodes inside; docs/accuracy.md)
BAND_FACTORS["probabilities"] = {
    "radial_curvature_outer": 3.62,
    "radial_curvature_inner": 3.79,
    "mean_curvature_lumen": 14.66,
    "wall_thickness": 1.84,
    "jelly_thickness": 4.36,
}
# node by node (issue 84): each curvature node's band is 1.96 k sqrt(noise^2 +
# unresolved^2) (oftimg.analysis.radial_curvature.node_band_95: the noise the frames show,
# what the scale and the smoothing in time may flatten), each strain energy node's 1.96 k
# sqrt(noise^2 + flattened in time^2) (its nodes' noise added once more); k by input kind,
# the median over the zoo's feature draws of the factor that makes each draw's band hold
# 95 % of its nodes: meshes on seeds 100-124 (held out: 125-149), labels on 0-2 (held
# out: 3-5), 40 frames, 2026-12-06. The draws' own factors spread widely (meshes / labels:
# radial curvature 0.7-3.2 / 1.5-8.1, the lumen's 0.9-2.7 / 3.3-9.7, strain energy
# 0.5-9.5 / 2.0-10): where a fold or a notch is sharper than anything the mesh or the
# voxels resolve, or the grid slides along the wall, the band still falls short
# (docs/accuracy.md). Probability maps: the labels' (not fitted on their own)
NODE_BAND_FACTORS = {
    "meshes": {
        "radial_curvature_outer": 1.26,
        "radial_curvature_inner": 1.19,
        "mean_curvature_lumen": 1.44,
        "strain_energy_outer": 3.76,
        "strain_energy_inner": 1.80,
    },
    "labels": {
        "radial_curvature_outer": 2.78,
        "radial_curvature_inner": 2.45,
        "mean_curvature_lumen": 8.4,
        "strain_energy_outer": 8.3,
        "strain_energy_inner": 3.5,
    },
}
NODE_BAND_FACTORS["probabilities"] = dict(NODE_BAND_FACTORS["labels"])
# a node whose band is wider than this share of its value's size is marked (greyed in the
# figures, counted in summary.json: field_noise: band95_wide_share)
BAND_WIDE_SHARE = 0.5
FIELD_OF = {
    "radial_curvature_outer_per_mm": "radial_curvature_outer",
    "radial_curvature_inner_per_mm": "radial_curvature_inner",
    "mean_curvature_lumen_per_mm": "mean_curvature_lumen",
    "wall_thickness_mm": "wall_thickness",
    "jelly_thickness_mm": "jelly_thickness",
}


def input_kind(inputs_by_kind: dict) -> str:
    """ "meshes", "labels" or "probabilities": what the dataset's walls were made from
    (:meth:`~oftimg.io.dataset.Dataset.inputs_by_kind`'s keys)."""
    return next((k for k in ("probabilities", "labels") if k in inputs_by_kind), "meshes")


def with_bands(field_noise: dict, kind: str) -> dict:
    """``field_noise`` (field -> its noise entry) with each field's ``band_95`` (the
    field's unit: half the width of its 95 % band, 1.96 k times ``noise_sd_smoothed``)
    and ``band_factor`` k for input ``kind``; None for a field without a factor or a
    measured noise."""
    out = {}
    for name, noise in field_noise.items():
        k = BAND_FACTORS.get(kind, {}).get(FIELD_OF.get(name))
        sd = noise.get("noise_sd_smoothed")
        finite = k is not None and sd is not None and np.isfinite(sd)
        out[name] = {
            **noise,
            "band_factor": k if finite else None,
            "band_95": float(1.96 * k * sd) if finite else None,
        }
    return out


def speed_band_95(speed_mm_s, noise_sd_mm_s) -> float | None:
    """Half the width of the cycle wave speed's 95 % band (mm/s): 1.96 x its noise spread
    and :data:`SPEED_SYSTEMATIC_SHARE` of it, added in quadrature; None without a speed
    or a spread."""
    if speed_mm_s is None or noise_sd_mm_s is None:
        return None
    if not (np.isfinite(speed_mm_s) and np.isfinite(noise_sd_mm_s)):
        return None
    return float(1.96 * np.hypot(noise_sd_mm_s, SPEED_SYSTEMATIC_SHARE * speed_mm_s))


def wide_band_share(band: np.ndarray, value: np.ndarray) -> float | None:
    """The share of nodes with a value whose 95 % band ``band`` (half-width) is wider than
    :data:`BAND_WIDE_SHARE` of the value's size ``|value|``; None without any."""
    known = np.isfinite(band) & np.isfinite(value)
    if not known.any():
        return None
    return float(np.mean(band[known] > BAND_WIDE_SHARE * np.abs(value[known])))
