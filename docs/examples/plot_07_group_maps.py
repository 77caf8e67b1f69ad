"""
Where two groups differ
=======================

Every embryo's outer area map on one (position along the tube, phase of the cycle)
grid, each row over its maximum; the groups' means and the banded group's difference
from the normal one. With two embryos a group this is a sketch: the cluster test
needs more to say where the difference is significant.
"""

import matplotlib.pyplot as plt

import oftimg

results = oftimg.example_results()  # 2 normal + 2 banded phantoms, analysed once (a minute)
maps = oftimg.load_cohort_maps(results)  # an xarray.Dataset
area = maps["area_outer_normalized"]  # (embryo, position, phase)
means = area.groupby("group").mean("embryo")

fig, axes = plt.subplots(1, 3, figsize=(7.1, 2.6), sharey=True, layout="constrained")
for ax, group in zip(axes, ("normal", "banded")):
    im = means.sel(group=group).plot.imshow(
        ax=ax, x="phase", y="position", vmin=0, vmax=1, cmap="viridis", add_colorbar=False
    )
    ax.set_title(f"{group} (n = {int((area.group == group).sum())})", fontsize=8)
fig.colorbar(im, ax=axes[1], label="area / row maximum")
diff = means.sel(group="banded") - means.sel(group="normal")
top = float(abs(diff).max())
im = diff.plot.imshow(
    ax=axes[2], x="phase", y="position", cmap="RdBu_r", vmin=-top, vmax=top, add_colorbar=False
)
axes[2].set_title("banded - normal", fontsize=8)
fig.colorbar(im, ax=axes[2], label="difference of the means")
for ax in axes:
    ax.set_xlabel("phase of the cycle (0-1)")
    ax.set_ylabel("")
axes[0].set_ylabel("position along the tube (0-1)")
plt.show()
