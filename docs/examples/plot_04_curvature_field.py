"""
A curvature field and its per-pixel normalised version
======================================================

The outer wall's radial curvature (the curvature of each section's contour) as a
(u, v) image at one time, on the tracked grid: each pixel the same tissue in every
frame. Normalising each pixel over the cycle (its minimum to 0, its maximum to 1)
shows when each piece of wall is most curved, whatever its mean curvature.
"""

import matplotlib.pyplot as plt
import numpy as np

import oftimg
from oftimg.image.normalize import per_pixel_normalize

results = oftimg.example_results()  # 2 normal + 2 banded phantoms, analysed once (a minute)
res = oftimg.load_results(results / "normal_0")
k = res["radial_curvature_outer_per_mm"]  # (u, v, t) 1/mm
t = k.shape[2] // 3
frames = {
    "radial curvature (1/mm)": (k[:, :, t], "RdBu_r", None),  # as oftimg draws it
    "normalised over the cycle (0-1)": (per_pixel_normalize(k)[:, :, t], "gray", (0, 1)),
}

fig, axes = plt.subplots(1, 2, figsize=(7.1, 2.8), layout="constrained")
for ax, (label, (image, cmap, limits)) in zip(axes, frames.items()):
    if limits is None:  # signed: diverging, centred on 0
        top = np.nanpercentile(np.abs(image), 99)
        limits = (-top, top)
    im = ax.imshow(
        image.T,
        origin="lower",
        aspect="auto",
        cmap=cmap,
        vmin=limits[0],
        vmax=limits[1],
        extent=[0, 1, 0, 1],
    )
    fig.colorbar(im, ax=ax, label=label)
    ax.set_xlabel("u, around the tube (0: seam)")
    ax.set_ylabel("v, along (0: inlet)")
fig.suptitle(
    f"normal_0, t = {res['t_ms'][t]:.0f} ms, {res.summary['tracking']['grid']} grid", fontsize=9
)
plt.show()
