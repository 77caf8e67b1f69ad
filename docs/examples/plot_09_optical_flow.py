"""
Optical flow on a field video
=============================

The fields are images, so computer vision applies: here OpenCV's dense DIS optical
flow between two frames of the outer wall's radial-curvature video (u across, v up),
scaled to 8 bits over the whole cycle's range as a video frame is. On the tracked
grid the tissue holds still; what moves is the curvature pattern the wave carries.
"""

import cv2
import matplotlib.pyplot as plt
import numpy as np

import oftimg

results = oftimg.example_results()  # 2 normal + 2 banded phantoms, analysed once (a minute)
res = oftimg.load_results(results / "normal_0")
k = res["radial_curvature_outer_per_mm"]  # (u, v, t)
low, high = np.nanpercentile(k, [1, 99])
frames = np.clip(255 * (np.nan_to_num(k) - low) / (high - low), 0, 255).astype(np.uint8)
t = k.shape[2] // 4
scale = 4  # DIS works on 8-pixel patches: enlarge
a, b = (
    cv2.resize(
        np.ascontiguousarray(frames[:, :, i].T),
        None,
        fx=scale,
        fy=scale,
        interpolation=cv2.INTER_CUBIC,
    )
    for i in (t, t + 1)
)
flow = cv2.DISOpticalFlow_create(cv2.DISOPTICAL_FLOW_PRESET_MEDIUM).calc(a, b, None)

fig, ax = plt.subplots(figsize=(5.5, 3.2), layout="constrained")
ax.imshow(a, origin="lower", cmap="gray")  # the 8-bit frame OpenCV reads
step = 12
rows, cols = np.mgrid[step // 2 : a.shape[0] : step, step // 2 : a.shape[1] : step]
ax.quiver(
    cols,
    rows,
    flow[rows, cols, 0],
    flow[rows, cols, 1],
    color="k",
    angles="xy",
    scale_units="xy",
    scale=1,
    width=0.003,
)
ax.set_xlabel("u, around the tube (pixels)")
ax.set_ylabel("v, along (pixels; inlet at the bottom)")
ax.set_title(
    f"curvature at {res['t_ms'][t]:.0f} ms as an 8-bit frame (grey levels) and "
    "its flow to the next frame (arrows to scale)",
    fontsize=8,
)
plt.show()
