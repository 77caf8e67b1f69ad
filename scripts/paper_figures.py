"""Regenerate every figure type of the paper from a results folder alone.

    python scripts/paper_figures.py RESULTS --out FIGURES

Reads RESULTS/<name>/arrays.npz, grids.npz and summary.json (no recomputation) and
writes into FIGURES, a folder of its own (never inside RESULTS, which `oftimg run
--overwrite` would then refuse to replace), each figure in the house style as PNG
(300 dpi), PDF and SVG, named after the paper's figures (Phan, Rugonyi, Grimm):
fig03 cross-sections, fig04 area-to-line A-D, fig05 radial-curvature frames,
fig06 strain frames, fig08 volume normalisation, fig09 area maps, fig10 maximum
area and ridge time, fig11 time expanded, fig12 derivative images, fig13 lumen
curvature frames, fig07 / fig14 cross-section shape PCA.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

from oftimg.image.gradient import gradient_hsv
from oftimg.output import figures, style
from oftimg.output.video import uncertain_nodes


def inside(path: Path, folder: Path) -> bool:
    """Whether ``path`` is ``folder`` or lies in it."""
    path, folder = path.resolve(), folder.resolve()
    return path == folder or folder in path.parents


def main():
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("results", type=Path)
    ap.add_argument("--out", type=Path, required=True, help="a folder of their own")
    args = ap.parse_args()
    out = args.out
    if inside(out, args.results):
        raise SystemExit(
            f"--out {out}: inside the results folder {args.results}; choose a "
            "folder of its own (oftimg run --overwrite replaces only its own files)"
        )
    out.mkdir(parents=True, exist_ok=True)
    with style.vector_formats((".pdf", ".svg")):  # for a journal: both vector formats
        written = draw_all(args.results, out)
    print(f"{len(written)} figures in {out}")


def draw_all(results: Path, out: Path) -> list[Path]:
    """Every paper figure of every embryo in ``results`` (and the group figures) into
    ``out``; the PNGs written."""
    summaries = [json.loads(p.read_text()) for p in sorted(results.glob("*/summary.json"))]
    if not summaries:
        raise SystemExit(f"{results}: no */summary.json (not an oftimg results folder)")
    written = []
    for summ in summaries:
        name = summ["name"]
        a = dict(np.load(results / name / "arrays.npz"))
        g = dict(np.load(results / name / "grids.npz"))
        s, t = a["s_mm"], a["t_ms"]
        f = lambda tag: out / f"{tag}_{name}.png"  # noqa: E731  (PDF and SVG beside)
        contours = {
            w: a[f"contour_{w}_mm"][:, :, 0]
            for w in ("outer", "inner", "lumen")
            if f"contour_{w}_mm" in a
        }
        written.append(
            figures.frame_with_contours(g["outer"][:, :, 0], contours, f("fig03_cross_sections"))
        )
        written.append(
            figures.area_map(
                a["area_outer_mm2"],
                s,
                t,
                f("fig04A_area_to_line"),
                ridge_t_ms=a["ridge_t_ms"],
                crossings_75_ms=a["crossing_75_outer_ms"],
                sigma_ms=a["gaussian_sigma_outer_ms"],
                title=name,
            )
        )
        walls = [w for w in ("outer", "inner", "lumen") if f"max_area_{w}_mm2" in a]
        written.append(
            figures.max_area_profile(
                s, {w: a[f"max_area_{w}_mm2"] for w in walls}, f("fig04B_max_area"), title=name
            )
        )
        written.append(
            figures.time_expanded(
                s,
                {
                    "75 %": a["expanded_fraction_75_outer"],
                    "one sigma": a["expanded_fraction_sigma_outer"],
                },
                f("fig04C_time_expanded"),
                title=name,
            )
        )
        rates = (summ["max_expansion_rate_mm2_ms"], summ["max_contraction_rate_mm2_ms"])
        for tag in ("fig04D_derivative", "fig12_derivative"):
            written.append(
                figures.derivative_image(
                    gradient_hsv(a["area_outer_mm2"]), s, t, f(tag), rates=rates, title=name
                )
            )
        written.append(
            figures.field_pair(
                a["radial_curvature_outer_per_mm"],
                a["area_outer_mm2"],
                f("fig05_radial_curvature"),
                label="radial curvature (1/mm)",
                title=f"{name}: outer wall's radial curvature",
                **uncertain_nodes(a, "radial_curvature_outer_per_mm"),
            )
        )
        written.append(
            figures.field_pair(
                a["strain_energy_outer"],
                a["area_outer_mm2"],
                f("fig06_strain_energy"),
                label="strain energy against t = 0 (dimensionless)",
                against_t0=True,
                title=f"{name}: outer wall's strain energy",
                **uncertain_nodes(a, "strain_energy_outer"),
            )
        )
        if "trim_percent" in a:
            written.append(
                figures.trim_over_cycle(
                    t,
                    a["trim_percent"],
                    a["volume_myocardium_mm3"],
                    f("fig08_volume_normalization"),
                    title=name,
                )
            )
        written.append(figures.area_map(a["area_outer_mm2"], s, t, f("fig09_area_map"), title=name))
        written.append(
            figures.ridge_plot(
                s,
                a["ridge_t_ms"],
                f("fig10_ridge_time"),
                knee=summ["wave_two_segment"],
                speed=a["local_speed_mm_s"],
                title=name,
            )
        )
        written.append(
            figures.time_expanded(
                s,
                {"one sigma": a["expanded_fraction_sigma_outer"]},
                f("fig11_time_expanded"),
                title=name,
            )
        )
        pca_file = results / name / "pca.npz"
        if pca_file.exists():
            pca = dict(np.load(pca_file))
            for tag in ("fig07_pca_example", "fig14_pca_modes"):
                written.append(
                    figures.pca_figure(pca, summ["pca"], f(tag), title=f"{name}: shape modes")
                )
        if "mean_curvature_lumen_per_mm" in a:
            written.append(
                figures.field_pair(
                    a["mean_curvature_lumen_per_mm"],
                    a["area_outer_mm2"],
                    f("fig13_lumen_mean_curvature"),
                    label="mean curvature (1/mm)",
                    title=f"{name}: lumen's mean curvature",
                    **uncertain_nodes(a, "mean_curvature_lumen_per_mm"),
                )
            )
    if len({s["group"] for s in summaries}) >= 2:
        tmp = out / "groups"
        tmp.mkdir(exist_ok=True)
        written += figures.group_figures(results, summaries, tmp)
    return written


if __name__ == "__main__":
    main()
