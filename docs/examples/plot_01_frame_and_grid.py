"""
A frame and its grid
====================

One frame of a phantom embryo's outer wall (an independent triangle mesh) and the
(u, v) grid oftimg lays on it: u = 0 on the seam (the shortest inlet-to-outlet
geodesic, on the inside of the bend), v from the inlet (0) to the outlet (1).
"""

import tempfile
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

import oftimg
from oftimg.mesh.grid import GridOptions, grid_frame, seam_endpoints

folder = Path(tempfile.mkdtemp()) / "embryo"
oftimg.make_phantom(folder, frames=8, quiet=True, vertices_min=2000, vertices_max=2500)
tube = oftimg.load_dataset(folder).tube("outer", 0)
p_in, p_out, seam_mm = seam_endpoints(tube.V, tube.F, tube.inlet, tube.outlet)
grid = grid_frame(tube.V, tube.F, tube.inlet, tube.outlet, p_in, p_out, GridOptions()).X

fig = plt.figure(figsize=(6.5, 4))
ax = fig.add_subplot(projection="3d")
ax.plot_trisurf(*tube.V.T, triangles=tube.F, color="0.85", alpha=0.4, linewidth=0.1)
for j in range(0, grid.shape[1], 4):  # rings: constant v
    ring = np.vstack([grid[:, j], grid[:1, j]])
    ax.plot(*ring.T, color="tab:blue", linewidth=0.7)
ax.plot(*grid[0].T, color="tab:red", linewidth=2, label="seam, u = 0")
ax.set_xlabel("x (mm)")
ax.set_ylabel("y (mm)")
ax.set_zlabel("z (mm)")
ax.set_box_aspect(np.ptp(tube.V, axis=0))  # equal scales: the true shape
ax.legend(loc="upper left")
ax.set_title(f"outer wall, frame 0: {len(tube.V)} vertices; seam {seam_mm:.2f} mm")
plt.show()
