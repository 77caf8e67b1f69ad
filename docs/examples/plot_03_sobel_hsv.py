"""
The Sobel-HSV derivative image
==============================

The area map's gradient as colour: hue is the gradient's direction (expanding or
contracting, along the tube or in time), value its size. A travelling wave shows as
bands of one hue slanting across the map.
"""

import matplotlib.pyplot as plt

import oftimg
from oftimg.image.gradient import colour_wheel, gradient_hsv

results = oftimg.example_results()  # 2 normal + 2 banded phantoms, analysed once (a minute)
res = oftimg.load_results(results / "normal_0")
area = res["area_outer_mm2"]
rgb = gradient_hsv(area)  # (v, t, 3) in [0, 1]
s_mm, t_ms = res["s_mm"], res["t_ms"]

fig, (ax, key) = plt.subplots(1, 2, figsize=(5.5, 2.8), width_ratios=[4, 1], layout="constrained")
ax.imshow(rgb, origin="lower", aspect="auto", extent=[t_ms[0], t_ms[-1], s_mm[0], s_mm[-1]])
ax.set_xlabel("time (ms)")
ax.set_ylabel("position along the tube s (mm)")
key.imshow(colour_wheel())  # d/dt to the right, d/dv up
key.set_title("gradient direction\n→ time, ↑ along", fontsize=7)
key.axis("off")
plt.show()
