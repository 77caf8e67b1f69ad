"""
Wave fronts on the wall: activation map and surface velocity
============================================================

As optical mapping reads a flat video of a beating heart, oftimg reads the tube's
wall: each grid node's activation time (when the wall there moves outward fastest),
and from their gradient on the wall, the wave's speed and direction at each node.
Isochrones are lines of equal activation; a front that runs along the tube has
isochrones across it, a helical one has them slanted. Here the phantom's wave runs
along the tube, and its speed on the wall is set beside the paper's ridge speed.
"""

import matplotlib.pyplot as plt
import numpy as np

import oftimg
from oftimg.image.activation import unwrapped

results = oftimg.example_results()  # 2 normal + 2 banded phantoms, analysed once (a minute)
res = oftimg.load_results(results / "normal_0")
period = res.summary["period_ms"]
act = unwrapped(res["activation_time_outer_ms"], period)  # (u, v) ms
act -= np.nanmin(act)
velocity = res["wave_velocity_outer_mm_s"]  # (u, v, along/around)
speed = np.hypot(velocity[..., 0], velocity[..., 1])
found = res.summary["wave_fronts"]["outer"]

fig, axes = plt.subplots(1, 2, figsize=(7.1, 2.9), layout="constrained")
im = axes[0].imshow(act.T, origin="lower", aspect="auto", extent=[0, 1, 0, 1])
axes[0].contour(
    np.linspace(0, 1, act.shape[0]),
    np.linspace(0, 1, act.shape[1]),
    act.T,
    levels=8,
    colors="k",
    linewidths=0.5,
)
fig.colorbar(im, ax=axes[0], label="activation time (ms)")
axes[0].set_title("activation, 0 at the earliest node; isochrones", fontsize=8)
im = axes[1].imshow(
    speed.T,
    origin="lower",
    aspect="auto",
    extent=[0, 1, 0, 1],
    vmin=0,
    vmax=np.nanpercentile(speed, 95),
)
fig.colorbar(im, ax=axes[1], label="speed (mm/s)")
axes[1].set_title("the wave's speed on the wall", fontsize=8)
for ax in axes:
    ax.set_xlabel("u, around the tube (0: seam)")
    ax.set_ylabel("v, along (0: inlet)")
fig.suptitle(
    f"normal_0: {found['speed_mm_s']:.1f} mm/s on the wall, "
    f"{found['axial_speed_mm_s']:.1f} along the tube (ridge, whole cycle: "
    f"{res.summary['wave_speed_mm_s']['cycle']:.1f}), helix angle "
    f"{round(found['helix_angle_deg']):d}°",
    fontsize=9,
)
plt.show()
