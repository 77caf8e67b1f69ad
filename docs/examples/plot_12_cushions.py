"""
The cushions: where and when the lumen closes
=============================================

The endocardial cushions make the lumen an ellipse and, as the myocardium contracts,
bulge until they close it by apposition: a primitive valve. oftimg measures each
lumen section's aspect ratio (minor over major axis) and the major axis's direction,
marks the sections closed (``lumen_closed``, their area 0), and gives per row when the
lumen closes and opens and for how much of the beat; the rows' closing times along the
tube give the closure's speed. Here a label phantom whose elliptical lumen closes over
the middle third of the tube for about half the beat (16 frames: a quick look; the
accuracy pages measure it at 40).
"""

import tempfile
import warnings
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

import oftimg

root = Path(tempfile.mkdtemp())
oftimg.make_phantom(
    root / "data" / "cushions",
    labels=True,
    frames=16,
    quiet=True,
    cushion_aspect_expanded=0.6,
    cushion_aspect_contracted=-0.4,
    cushion_deg=30.0,
    cushion_from_mm=0.45,
    cushion_to_mm=0.75,
)
with warnings.catch_warnings():  # 16 frames: noisy fields, said in its summary.json
    warnings.simplefilter("ignore")
    results = oftimg.run(root / "data", root / "results", quiet=True, jobs=2)
res = oftimg.load_results(results / "cushions")
s, t = res["s_mm"], res["t_ms"]
aspect = np.where(res["lumen_closed"], np.nan, res["lumen_aspect_ratio"])  # (v, t)
cushions = res.summary["cushions"]
print(
    {
        key: cushions[key]
        for key in (
            "closed_rows",
            "closed_share_max",
            "closure_speed_mm_s",
            "aspect_ratio_narrowest",
        )
    }
)

fig, axes = plt.subplots(1, 2, figsize=(7.1, 2.9), layout="constrained", width_ratios=(1.6, 1))
step = t[1] - t[0]
extent = [t[0] - step / 2, t[-1] + step / 2, s[0], s[-1]]
axes[0].imshow(
    np.where(res["lumen_closed"], 0.0, np.nan),
    origin="lower",
    aspect="auto",
    extent=extent,
    cmap="gray",
    vmin=0,
    vmax=1,
)
im = axes[0].imshow(
    aspect, origin="lower", aspect="auto", extent=extent, cmap="viridis", vmin=0, vmax=1
)
axes[0].plot(res["lumen_close_ms"], s, "w.", ms=3)
axes[0].set_xlabel("time since minimum volume (ms)")
axes[0].set_ylabel("position along the tube s (mm)")
axes[0].set_title("lumen aspect ratio (black: closed; dots: each row closes)", fontsize=8)
fig.colorbar(im, ax=axes[0], label="minor over major axis")
shut = 100 * res["lumen_closed_share"]
axes[1].plot(shut, s, color="tab:red")
axes[1].set_xlabel("share of the beat closed (%)")
axes[1].set_ylabel("position along the tube s (mm)")
axes[1].set_xlim(0, 100)
axes[1].set_title(f"closure travels at {cushions['closure_speed_mm_s']:.0f} mm/s", fontsize=8)
plt.show()
