"""
Cross-section shape modes
=========================

The contours of one row of the clipped (Lagrangian) grid over the expansion phase,
their Karcher mean (in the square-root velocity framework, size kept) and the first
modes of how they vary, drawn as the mean plus and minus a number of standard
deviations that makes each mode's shape visible.
"""

import matplotlib.pyplot as plt
import numpy as np

import oftimg

results = oftimg.example_results()  # 2 normal + 2 banded phantoms, analysed once (a minute)
res = oftimg.load_results(results / "normal_0")
row = 1  # rows at v = 0.1, 0.5, 0.9
mean = res[f"pca_row{row}_expansion_mean_mm"]  # (n, 2) mm
modes = res[f"pca_row{row}_expansion_displacement_mm"]  # (n_modes, n, 2) mm
explained = res[f"pca_row{row}_expansion_explained"]

fig, axes = plt.subplots(1, 2, figsize=(5.5, 2.8), layout="constrained")
for ax, m in zip(axes, range(2)):
    closed = np.vstack([mean, mean[:1]])
    ax.plot(*(1e3 * closed).T, color="0.3", label="mean")
    size = np.ptp(mean, axis=0).max()
    k = max(1, round(0.1 * size / np.abs(modes[m]).max()))  # sds shown: a tenth of the size
    for sign, colour in ((1, "tab:blue"), (-1, "tab:orange")):
        shape = mean + sign * k * modes[m]
        ax.plot(
            *(1e3 * np.vstack([shape, shape[:1]])).T,
            color=colour,
            label=f"mean {'+' if sign > 0 else '-'} {k} sd",
        )
    ax.legend(fontsize=6, loc="lower left")
    ax.set_aspect("equal")
    ax.set_title(f"mode {m + 1}: {100 * explained[m]:.0f} % of the variance", fontsize=8)
    ax.set_xlabel("µm")
    ax.set_ylabel("µm")
plt.show()
