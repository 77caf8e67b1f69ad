"""
The tissue's texture on the grid, and where it goes
===================================================

With the intensity volumes a segmentation came from (``intensity/``), oftimg pulls the
intensity across the myocardium back onto each frame's grid (``pullback_outer_mean``,
``(u_fine, v_fine, t)``), and moves the grid with that texture (``--tracking texture``,
the default then). ``pathlines_uv`` says where each tracked node's tissue lies in every
frame's own grid: here the textured label phantom, whose tissue slides along the tube
and twists beneath its walls, with a few nodes' paths over the beat drawn on the
first frame's pullback.
"""

import tempfile
import warnings
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

import oftimg

root = Path(tempfile.mkdtemp())
oftimg.make_phantom(root / "data" / "textured", labels=True, intensity=True, frames=10, quiet=True)
with warnings.catch_warnings():  # 10 frames: noisy fields, said in its summary.json
    warnings.simplefilter("ignore")
    results = oftimg.run(root / "data", root / "results", quiet=True, jobs=2)
res = oftimg.load_results(results / "textured")
pullback = res["pullback_outer_mean"]  # (u_fine, v_fine, t), each frame's own grid
paths = res["pathlines_uv"]  # (u, v, t, 2): grid steps around, along
n_u, n_v = paths.shape[:2]

fig, ax = plt.subplots(figsize=(5.5, 4), layout="constrained")
ax.imshow(pullback[:, :, 0].T, origin="lower", aspect="auto", cmap="gray", extent=[0, 1, 0, 1])
for path in paths[::10, ::7].reshape(-1, paths.shape[2], 2):
    u, v = np.mod(path[:, 0] / n_u, 1.0), path[:, 1] / (n_v - 1)
    seam = np.flatnonzero(np.abs(np.diff(u)) > 0.5) + 1  # the path crosses the seam
    for piece_u, piece_v in zip(np.split(u, seam), np.split(v, seam)):
        ax.plot(piece_u, piece_v, color="tab:orange", lw=0.8)
    ax.plot(u[0], v[0], ".", color="tab:orange")
ax.set_xlim(0, 1)
ax.set_ylim(0, 1)
ax.set_xlabel("u, around the tube from the seam")
ax.set_ylabel("v, along the tube (inlet 0)")
ax.set_title(
    "intensity across the myocardium at t = 0, and the tissue's paths over the beat", fontsize=8
)
plt.show()
