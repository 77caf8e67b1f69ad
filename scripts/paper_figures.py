"""Regenerate every figure type of the paper from a results folder alone.

    python scripts/paper_figures.py OUT [--to OUT/paper_figures]

Reads OUT/<name>/arrays.npz, grids.npz and summary.json (no recomputation) and
writes PNG and PDF files named after the paper's figures (Phan, Rugonyi, Grimm):
fig03 cross-sections, fig04 area-to-line A-D, fig05 radial-curvature frames,
fig06 strain frames, fig08 volume normalisation, fig09 area maps, fig10 maximum
area and ridge time, fig11 time expanded, fig12 derivative images, fig13 lumen
curvature frames, fig07 / fig14 cross-section shape PCA.
"""
from __future__ import annotations

import argparse
import json
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from oftimg.output import figures  # noqa: E402
from oftimg.image.gradient import gradient_hsv  # noqa: E402


def field_pair(field, area, path, title, cmap="coolwarm"):
    """Two (u, v) frames of a field: maximum contraction (t = 0) and maximum expansion."""
    t_exp = int(np.argmax(np.nansum(area, axis=0)))
    lo, hi = np.nanpercentile(field, [1, 99])
    fig, axes = plt.subplots(1, 2, figsize=(8, 3.4))
    for ax, t, label in zip(axes, (0, t_exp), ("maximum contraction", "maximum expansion")):
        im = ax.imshow(field[:, :, t].T, origin="lower", aspect="auto", cmap=cmap, vmin=lo,
                       vmax=hi, extent=[0, 1, 0, 1])
        ax.set_xlabel("u (around)")
        ax.set_ylabel("v (along, inlet at 0)")
        ax.set_title(f"{label} (frame {t})", fontsize=9)
    fig.colorbar(im, ax=axes, shrink=0.8)
    fig.suptitle(figures.plain_text(title), fontsize=10)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def main():
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("results", type=Path)
    ap.add_argument("--to", type=Path, default=None)
    args = ap.parse_args()
    out = args.to or args.results / "paper_figures"
    out.mkdir(parents=True, exist_ok=True)
    summaries = [json.loads(p.read_text()) for p in sorted(args.results.glob("*/summary.json"))]
    if not summaries:
        raise SystemExit(f"{args.results}: no */summary.json (not an oftimg results folder)")
    written = []
    for summ in summaries:
        name = summ["name"]
        a = dict(np.load(args.results / name / "arrays.npz"))
        g = dict(np.load(args.results / name / "grids.npz"))
        s, t = a["s_mm"], a["t_ms"]
        for ext in ("png", "pdf"):
            f = lambda tag: out / f"{tag}_{name}.{ext}"  # noqa: E731
            contours = {w: a[f"contour_{w}_mm"][:, :, 0] for w in ("outer", "inner", "lumen")
                        if f"contour_{w}_mm" in a}
            written.append(figures.frame_with_contours(g["outer"][:, :, 0], contours,
                                                       f("fig03_cross_sections")))
            written.append(figures.area_map(
                a["area_outer_mm2"], s, t, f("fig04A_area_to_line"), ridge_t_ms=a["ridge_t_ms"],
                crossings_75_ms=a["crossing_75_outer_ms"], sigma_ms=a["gaussian_sigma_outer_ms"],
                title=name))
            walls = [w for w in ("outer", "inner", "lumen") if f"max_area_{w}_mm2" in a]
            written.append(figures.max_area_profile(
                s, {w: a[f"max_area_{w}_mm2"] for w in walls}, f("fig04B_max_area"), title=name))
            written.append(figures.time_expanded(
                s, {"75 %": a["expanded_fraction_75_outer"],
                    "one sigma": a["expanded_fraction_sigma_outer"]},
                f("fig04C_time_expanded"), title=name))
            rates = (summ["max_expansion_rate_mm2_ms"], summ["max_contraction_rate_mm2_ms"])
            for tag in ("fig04D_derivative", "fig12_derivative"):
                written.append(figures.derivative_image(gradient_hsv(a["area_outer_mm2"]), s, t,
                                                        f(tag), rates=rates, title=name))
            written.append(field_pair(a["radial_curvature_outer_per_mm"], a["area_outer_mm2"],
                                      f("fig05_radial_curvature"), f"{name}: radial curvature"))
            written.append(field_pair(a["strain_energy_outer"], a["area_outer_mm2"],
                                      f("fig06_strain_energy"), f"{name}: strain energy",
                                      cmap="RdYlGn_r"))
            if "trim_percent" in a:
                written.append(figures.trim_over_cycle(t, a["trim_percent"],
                                                       a["volume_myocardium_mm3"],
                                                       f("fig08_volume_normalization"),
                                                       title=name))
            written.append(figures.area_map(a["area_outer_mm2"], s, t, f("fig09_area_map"),
                                            title=name))
            written.append(figures.ridge_plot(s, a["ridge_t_ms"], f("fig10_ridge_time"),
                                              knee=summ["wave_two_segment"],
                                              speed=a["local_speed_mm_s"], title=name))
            written.append(figures.time_expanded(
                s, {"one sigma": a["expanded_fraction_sigma_outer"]}, f("fig11_time_expanded"),
                title=name))
            pca_file = args.results / name / "pca.npz"
            if pca_file.exists():
                pca = dict(np.load(pca_file))
                for tag in ("fig07_pca_example", "fig14_pca_modes"):
                    written.append(figures.pca_figure(pca, summ["pca"], f(tag),
                                                      title=f"{name}: shape modes"))
            if "mean_curvature_lumen_per_mm" in a:
                written.append(field_pair(a["mean_curvature_lumen_per_mm"], a["area_outer_mm2"],
                                          f("fig13_lumen_mean_curvature"),
                                          f"{name}: lumen mean curvature"))
    if len({s["group"] for s in summaries}) >= 2:
        tmp = out / "groups"
        tmp.mkdir(exist_ok=True)
        written += figures.group_figures(args.results, summaries, tmp)
    print(f"{len(written)} figures in {out}")


if __name__ == "__main__":
    main()
