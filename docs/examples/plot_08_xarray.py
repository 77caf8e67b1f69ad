"""
Results as xarray
=================

Every array of a results folder on named axes (u around, v along with ``s_mm`` as a
coordinate, t in ms), with units and descriptions: select, average and plot by name.
"""

import matplotlib.pyplot as plt

import oftimg

results = oftimg.example_results()  # 2 normal + 2 banded phantoms, analysed once (a minute)
res = oftimg.load_results(results / "normal_0")
ds = res.to_xarray()
thickness = ds["wall_thickness_mm"]  # dims (u, v, t)
print(thickness.attrs["units"], "-", thickness.attrs["description"][:80], "...")

fig, ax = plt.subplots(figsize=(4.2, 2.8), layout="constrained")
profile = thickness.mean("u")  # mm, as every oftimg figure gives it
for t_ms, colour in ((0, "tab:blue"), (profile.t.values[len(profile.t) // 2], "tab:orange")):
    profile.sel(t=t_ms, method="nearest").plot(
        ax=ax, x="s_mm", color=colour, label=f"t = {t_ms:.0f} ms"
    )
ax.set_xlabel("position along the tube s (mm)")
ax.set_ylabel("wall thickness (mm)")
ax.set_title("mean around the tube", fontsize=8)
ax.legend(fontsize=7)
plt.show()
