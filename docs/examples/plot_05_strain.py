"""
Strain against t = 0
====================

The in-surface strain energy of the outer wall, (l1 - 1)^2 + (l2 - 1)^2 from the
principal stretches of each grid triangle against the same triangle at t = 0 (the
minimum volume). On the tracked grid each triangle is the same tissue all cycle, so
a rigid tube gives 0. Left: its mean around the tube over (v, t); right: one frame.
"""

import matplotlib.pyplot as plt
import numpy as np

import oftimg

results = oftimg.example_results()  # 2 normal + 2 banded phantoms, analysed once (a minute)
res = oftimg.load_results(results / "normal_0")
energy = res["strain_energy_outer"]  # (u, v, t)
s_mm, t_ms = res["s_mm"], res["t_ms"]
t = int(np.argmax(np.nanmean(energy, axis=(0, 1))))

fig, axes = plt.subplots(1, 2, figsize=(7.1, 2.8), layout="constrained")
im = axes[0].imshow(
    np.nanmean(energy, axis=0),
    origin="lower",
    aspect="auto",
    cmap="viridis",
    extent=[t_ms[0], t_ms[-1], s_mm[0], s_mm[-1]],
)
axes[0].axvline(t_ms[t], color="w", linewidth=0.8, label="frame at right")
axes[0].legend(loc="upper right", fontsize=7)
axes[0].set_xlabel("time (ms)")
axes[0].set_ylabel("position along the tube s (mm)")
fig.colorbar(im, ax=axes[0], label="strain energy, mean around")
im = axes[1].imshow(
    energy[:, :, t].T, origin="lower", aspect="auto", cmap="viridis", extent=[0, 1, 0, 1]
)
axes[1].set_xlabel("u, around the tube (0: seam)")
axes[1].set_ylabel("v, along (0: inlet)")
fig.colorbar(im, ax=axes[1], label=f"strain energy at {t_ms[t]:.0f} ms")
plt.show()
