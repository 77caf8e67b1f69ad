"""
The area map, its ridge and the expansion masks
===============================================

Each row of the (v, t) map is one cross-section's area over the cycle (v up, inlet at
the bottom; t = 0 at the minimum volume). The ridge (each row's time of maximum area)
gives the wave speeds; the masks mark where each section is expanded: above 75 % of
its range, and within one sigma of a Gaussian fitted to its peak.
"""

import matplotlib.pyplot as plt

import oftimg

results = oftimg.example_results()  # 2 normal + 2 banded phantoms, analysed once (a minute)
res = oftimg.load_results(results / "normal_0")
area = res["area_outer_mm2"]  # (v, t) mm^2
s_mm, t_ms = res["s_mm"], res["t_ms"]
extent = [t_ms[0], t_ms[-1], s_mm[0], s_mm[-1]]

fig, axes = plt.subplots(1, 3, figsize=(7.1, 2.6), sharey=True, layout="constrained")
im = axes[0].imshow(area, origin="lower", aspect="auto", extent=extent, cmap="viridis")
axes[0].plot(res["ridge_t_ms"], s_mm, "w.", markersize=3, label="ridge")
axes[0].legend(loc="upper left", fontsize=7)
fig.colorbar(im, ax=axes[0], label="outer area (mm²)")
for ax, key, title in (
    (axes[1], "expanded_mask_75_outer", "above 75 % of range"),
    (axes[2], "expanded_mask_sigma_outer", "within one sigma"),
):
    ax.imshow(
        res[key].astype(float),
        origin="lower",
        aspect="auto",
        extent=extent,
        cmap="Greys",
        vmin=0,
        vmax=1,
    )
    ax.set_title(title, fontsize=8)
axes[0].set_ylabel("position along the tube s (mm)")
for ax in axes:
    ax.set_xlabel("time (ms)")
speed = res.summary["wave_speed_mm_s"]["cycle"]
fig.suptitle(f"normal_0: wave speed over the cycle {speed:.1f} mm/s", fontsize=9)
plt.show()
