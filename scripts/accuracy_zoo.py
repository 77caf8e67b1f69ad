"""Accuracy over the randomized phantom zoo: every metric as a distribution over draws.

    python scripts/accuracy_zoo.py [--draws 50] [--seed 0] [--kinds meshes labels ...]
                                   [--frames N] [--voxel-min-um U] [--jobs 2]
                                   [--cache DIR] [--json FILE] [--no-pair] [--fronts]
                                   [--cut oblique|square] [--features] [--cushions]
    python scripts/accuracy_zoo.py --tables FILE.json [...] [--markdown]
    python scripts/accuracy_zoo.py --paired OBLIQUE.json SQUARE.json [--markdown]

Draws ``--draws`` scenarios per input kind (oftimg.synthetic.zoo: seeds S, S+1, ...,
the kind given), writes each as a dataset (kept in --cache), runs oftimg on it, and
compares the results with its truth (scripts/accuracy.py's errors: Table 1's numbers,
the maps, the fields). For label kinds it also runs the same phantom as meshes
(unless --no-pair) and compares the (u, v, t) fields node by node (labels against
meshes: what the voxels alone cost); with intensity, how far texture tracking's grid
drifts from the tissue along and around (scripts/texture_accuracy.py's drift). Kind
"real": the midgut of tests/data animated with a drawn wave, twist and shortening, and
how far material tracking's grid drifts from its tissue (the animation's truth).
Prints per kind and metric the median, the 90th percentile and the worst |error| with
the worst draw's seed (rerun it with --seed SEED --draws 1 --kinds KIND). ``--frames``
and ``--voxel-min-um`` make quick draws (the rest of each draw unchanged). ``--fronts``
draws the same scenarios with helical or one-sided wave fronts
(``draw_scenario(..., fronts=True)``) and tabulates the fronts' metrics alone.
``--features`` draws the same scenarios with sharper corners or concave notches (3-6)
and meshes of 40-200 vertices round the tube (``draw_scenario(..., features=True)``):
where the node-by-node curvature is tested. ``--cushions`` draws them with an
elliptical lumen that falls towards a slit and, in label kinds, closes over a stretch of
the tube for part of the beat (``draw_scenario(..., cushions=True)``), and adds the
cushions' metrics (closing and opening times, closed share, aspect ratio, axis).
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
import warnings
from dataclasses import replace
from pathlib import Path

import numpy as np

import oftimg
from oftimg.analysis.uncertainty import SPEED_SYSTEMATIC_SHARE
from oftimg.image.kymograph import cycle_speed
from oftimg.synthetic.animate import grid_material_points, wave_arrival_ms
from oftimg.synthetic.labels import LabelGrid, label_params
from oftimg.synthetic.phantom import read_truth, write_phantom
from oftimg.synthetic.zoo import KINDS, draw_scenario, volume_offset_um, write_scenario

sys.path.insert(0, str(Path(__file__).resolve().parent))
from accuracy import embryo_errors, pixel_differences, wave_front_errors  # noqa: E402
from texture_accuracy import drift  # noqa: E402

# (key, unit, what): the headline metrics, in this order (|error| unless said)
HEADLINE = [
    ("area_outer_p95_pct", "%", "section area, outer (95th percentile over v, t)"),
    (
        "area_outer_end_rows_p95_pct",
        "%",
        "section area, outer, the first and last 5 rows (95th percentile)",
    ),
    ("volume_outer_pct", "%", "volume of the outer wall (worst frame)"),
    ("myocardial_change_pp", "pp", "myocardial volume change"),
    ("expand_pp", "pp", "expansion share of the cycle"),
    ("speed_cycle_pct", "%", "wave speed over the cycle"),
    ("knee_mm", "mm", "the two-segment fit's knee (signed)"),
    ("local_speed_median_pct", "%", "local wave speeds, row by row (median)"),
    ("wall_thickness_pct", "%", "wall thickness"),
    ("radial_curvature_outer_pct", "%", "radial curvature, outer wall"),
    ("radial_curvature_outer_p90_pct", "%", "radial curvature, outer wall: 90th pct node"),
    (
        "radial_curvature_outer_contracted_concave_p90_pct",
        "%",
        "radial curvature, outer: 90th pct node, contracted, concave",
    ),
    ("radial_curvature_inner_pct", "%", "radial curvature, inner wall"),
    ("radial_curvature_inner_p90_pct", "%", "radial curvature, inner wall: 90th pct node"),
    (
        "radial_curvature_outer_expanded_concave_p90_pct",
        "%",
        "radial curvature, outer: 90th pct node, expanded, concave",
    ),
    (
        "radial_curvature_outer_contracted_convex_p90_pct",
        "%",
        "radial curvature, outer: 90th pct node, contracted, convex",
    ),
    (
        "radial_curvature_outer_band95_wide_share",
        "1",
        "radial curvature, outer: share of nodes whose band is over half the value",
    ),
    ("mean_curvature_lumen_pct", "%", "mean curvature, lumen"),
    ("mean_curvature_lumen_p90_pct", "%", "mean curvature, lumen: 90th pct node"),
    (
        "mean_curvature_lumen_contracted_concave_p90_pct",
        "%",
        "mean curvature, lumen: 90th pct node, contracted, concave",
    ),
    (
        "mean_curvature_lumen_contracted_convex_p90_pct",
        "%",
        "mean curvature, lumen: 90th pct node, contracted, convex",
    ),
    (
        "mean_curvature_lumen_expanded_convex_p90_pct",
        "%",
        "mean curvature, lumen: 90th pct node, expanded, convex",
    ),
    (
        "mean_curvature_lumen_band95_wide_share",
        "1",
        "mean curvature, lumen: share of nodes whose band is over half the value",
    ),
    ("corners_wrong", "", "corner count, outer wall: wrong (1) or right (0)"),
    ("strain_energy_inner_pct", "%", "strain energy, inner wall"),
    ("strain_energy_inner_p90_pct", "%", "strain energy, inner wall: 90th pct node"),
    ("strain_energy_outer_bias_pct", "%", "strain energy, outer: median bias (signed)"),
    ("strain_energy_inner_bias_pct", "%", "strain energy, inner: median bias (signed)"),
    (
        "labels_vs_meshes_radial_curvature_outer_pct",
        "%",
        "radial curvature, outer: labels against meshes, node by node",
    ),
    (
        "labels_vs_meshes_radial_curvature_inner_pct",
        "%",
        "radial curvature, inner: labels against meshes, node by node",
    ),
    (
        "labels_vs_meshes_mean_curvature_lumen_pct",
        "%",
        "mean curvature, lumen: labels against meshes, node by node",
    ),
    (
        "labels_vs_meshes_strain_energy_inner_pct",
        "%",
        "strain energy, inner: labels against meshes, node by node",
    ),
    (
        "labels_vs_meshes_strain_energy_inner_bias_pct",
        "%",
        "strain energy, inner: labels' median over the meshes' (signed)",
    ),
    ("drift_along_pct", "% L", "texture tracking: drift along the tube (median node)"),
    ("drift_around_rad", "rad", "texture tracking: drift around the tube (median node)"),
    ("real_drift_median_pct", "% L", "real shape, material tracking: drift (median node)"),
    ("real_drift_p90_pct", "% L", "real shape, material tracking: drift (90th pct node)"),
    ("real_speed_cycle_pct", "%", "real shape: wave speed over the cycle"),
] + [
    ("front_speed_pct", "%", "wave fronts, outer wall: speed on the wall (median node)"),
    ("front_axial_speed_pct", "%", "wave fronts, outer wall: axial speed"),
    ("front_helix_deg", "deg", "wave fronts, outer wall: helix angle"),
    ("front_activation_rms_ms", "ms", "wave fronts, outer wall: activation time, RMS"),
]
# with --fronts (helical and one-sided fronts): the paper's numbers of the (v, t) area
# map average a helix away, so only the fronts' metrics are tabulated
FRONT_METRICS = [row for row in HEADLINE if row[0].startswith("front_")]
# with --cushions: the cushions' measures against the model's (scripts/accuracy.py's
# cushion_errors), after the headline's
CUSHION_METRICS = [
    ("cushion_close_median_pct", "% T", "cushions: closing time (median row)"),
    ("cushion_close_worst_pct", "% T", "cushions: closing time (worst row)"),
    ("cushion_open_median_pct", "% T", "cushions: opening time (median row)"),
    ("cushion_open_worst_pct", "% T", "cushions: opening time (worst row)"),
    ("cushion_closed_share_median_pp", "pp", "cushions: closed share (median row)"),
    ("cushion_closed_share_worst_pp", "pp", "cushions: closed share (worst row)"),
    ("cushion_rows_wrong_pct", "%", "cushions: rows closing in one of run and truth"),
    ("cushion_closed_cells_wrong_pct", "%", "cushions: (v, t) cells closed in one of them"),
    ("cushion_aspect_median_pct", "%", "cushions: lumen aspect ratio (median section)"),
    ("cushion_aspect_p90_pct", "%", "cushions: lumen aspect ratio (90th pct section)"),
    ("cushion_axis_median_deg", "deg", "cushions: major axis (median section)"),
    ("cushion_axis_p90_deg", "deg", "cushions: major axis (90th pct section)"),
]
CUSHIONS_TAG = " (cushions)"
FRONTS_TAG = " (fronts)"  # after the kind's name in the JSON and the tables
FEATURES_TAG = " (features)"
# with --cut: label draws cut obliquely or square by the volume's faces at both ends
CUT_TAGS = {"oblique": " (oblique)", "square": " (square)"}
# (key, what): the run's own error bars against the truth, % of nodes and frames (or
# rows) whose error lies within the band the run reports (its noise: summary.json's
# field_noise, the speeds' noise spreads); a calibrated band holds about 95 %
CALIBRATION = [
    ("radial_curvature_outer_within_95_pct", "radial curvature, outer, within its 95 % band"),
    ("radial_curvature_inner_within_95_pct", "radial curvature, inner, within its 95 % band"),
    (
        "radial_curvature_outer_node_band_within_pct",
        "radial curvature, outer, within each node's own 95 % band",
    ),
    (
        "radial_curvature_outer_node_band_within_contracted_pct",
        "radial curvature, outer, within each node's own band: contracted",
    ),
    (
        "radial_curvature_outer_node_band_within_expanded_pct",
        "radial curvature, outer, within each node's own band: expanded",
    ),
    (
        "radial_curvature_inner_node_band_within_pct",
        "radial curvature, inner, within each node's own 95 % band",
    ),
    ("mean_curvature_lumen_within_95_pct", "mean curvature, lumen, within its 95 % band"),
    (
        "mean_curvature_lumen_node_band_within_pct",
        "mean curvature, lumen, within each node's own 95 % band",
    ),
    (
        "mean_curvature_lumen_node_band_within_contracted_pct",
        "mean curvature, lumen, within each node's own band: contracted",
    ),
    (
        "strain_energy_outer_node_band_within_pct",
        "strain energy, outer, within each node's own 95 % band",
    ),
    (
        "strain_energy_inner_node_band_within_pct",
        "strain energy, inner, within each node's own 95 % band",
    ),
    (
        "strain_energy_inner_node_band_within_expanded_pct",
        "strain energy, inner, within each node's own band: expanded",
    ),
    ("wall_thickness_within_95_pct", "wall thickness within its 95 % band"),
    ("jelly_thickness_within_95_pct", "jelly thickness within its 95 % band"),
    ("local_within_2_spreads_pct", "local wave speeds within 2 noise spreads"),
    ("ridge_within_2_spreads_pct", "ridge times within 2 noise spreads"),
    ("front_activation_within_95_pct", "wave fronts: activation times within their 95 % band"),
]
MIDGUT = Path(__file__).resolve().parent.parent / "tests" / "data" / "midgut_8k.ply"
MIDGUT_SCALE_TO_MM = 0.2619e-3  # tests/data/README.md


def run_quietly(dataset: Path, out: Path, jobs: int) -> Path:
    """``oftimg run --numbers-only`` of one dataset into ``out`` (its warnings kept
    quiet); the dataset's results folder."""
    if not (out / dataset.name / "summary.json").is_file():
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            oftimg.run(dataset, out, quiet=True, jobs=jobs, overwrite=True, figures=False)
    return out / dataset.name


def draw_errors(
    seed: int,
    kind: str,
    root: Path,
    *,
    frames,
    voxel_min_um,
    jobs: int,
    pair: bool,
    fronts: bool = False,
    oblique: bool | None = None,
    features: bool = False,
    cushions: bool = False,
) -> dict[str, float]:
    """One draw written, run and compared with its truth: every metric's error
    (``fronts``: the draw with a helical or one-sided front, no meshes' pair;
    ``oblique``: the label draw cut obliquely (True) or square (False) by its volume's
    faces at both ends, None as drawn; ``features``: sharper corners, finer and coarser
    meshes; ``cushions``: an elliptical lumen, closing in label kinds)."""
    scenario = draw_scenario(
        seed,
        kind,
        n_frames=frames,
        voxel_um_min=voxel_min_um,
        fronts=fronts,
        oblique=oblique,
        features=features,
        cushions=cushions,
    )
    cut = {None: "", True: "_oblique", False: "_square"}[oblique]
    dataset = (
        root
        / "data"
        / (
            f"{kind.replace('+', '_')}_{seed}{'_fronts' * fronts}{cut}"
            f"{'_features' * features}{'_cushions' * cushions}"
        )
    )
    if not (dataset / "scenario.json").is_file():
        write_scenario(scenario, dataset, real_shape=MIDGUT, real_scale_to_mm=MIDGUT_SCALE_TO_MM)
    results = run_quietly(dataset, root / "results" / dataset.name, jobs)
    if kind == "real":
        return {**real_shape_errors(dataset, results), "draw": conditions(scenario)}
    if fronts:
        return {**wave_front_errors(dataset, results), "draw": conditions(scenario)}
    errors = {**embryo_errors(dataset, results), "draw": conditions(scenario)}
    if kind != "meshes" and pair and not fronts and not scenario.oblique_deg:
        # the same geometry as meshes (not where the ends were cut square inside the
        # window: the grids then span another part of the tube)
        meshes = root / "data" / f"{dataset.name}_meshes"
        if not (meshes / "truth.json").is_file():
            write_phantom(meshes, replace(label_params(scenario.phantom), noise_mm=0.0))
        paired = run_quietly(meshes, root / "results" / meshes.name, jobs)
        for name, pct in pixel_differences(results, paired).items():
            key = name.removesuffix("_per_mm")
            errors[f"labels_vs_meshes_{key}_pct"] = pct
        a, b = (np.load(r / "arrays.npz")["strain_energy_inner"] for r in (results, paired))
        errors["labels_vs_meshes_strain_energy_inner_bias_pct"] = float(
            100 * (np.nanmedian(a) / np.nanmedian(b) - 1)
        )
    if kind == "labels+intensity":
        ph, truth = read_truth(dataset)
        summary = json.loads((results / "summary.json").read_text())
        arrays = np.load(results / "arrays.npz")
        t_ms = np.roll(np.asarray(truth["t_ms"]), -summary["t0_frame"])
        grid = LabelGrid(ph, scenario.voxel_um, oblique_deg=scenario.oblique_deg)
        G = np.load(results / "grids.npz")["outer"].astype(float)  # in the volume, mm
        G -= 1e-3 * volume_offset_um(json.loads((dataset / "scenario.json").read_text()))
        d = drift(
            ph, grid, G, t_ms, arrays["grid_in_view"] if "grid_in_view" in arrays.files else None
        )
        errors["drift_along_pct"], errors["drift_around_rad"] = d["along_pct"], d["around_rad"]
    return errors


def conditions(scenario) -> dict:
    """What a draw is, in the words a reader of its errors needs: its frames, voxels,
    segmentation's faults, twist, slide and mesh roughness (the whole draw: the
    dataset's scenario.json)."""
    p, seg = scenario.phantom, scenario.segmentation
    out = {
        "frames": p.n_frames,
        "twist_deg": round(p.twist_deg, 1),
        "front": ", ".join(
            [f"helix {p.helix_starts:+d}"] * bool(p.helix_starts)
            + [f"side lag {p.side_lag_ms:.0f} ms at {p.side_deg:.0f} deg"] * bool(p.side_lag_ms)
        )
        or "cross-sections",
        "twist": f"{p.twist_profile}, phase {p.twist_phase:.2f}",
        "slide_pct": round(100 * p.stretch, 1),
    }
    out |= {"corners": p.corners, "corner_sharpness": round(p.corner_sharpness, 2)}
    if p.cushion_aspect_expanded < 1.0:
        out["cushions"] = (
            f"aspect {p.cushion_aspect_expanded:.2f} -> "
            f"{p.cushion_aspect_contracted:.2f} at {p.cushion_deg:.0f} deg, "
            f"{p.cushion_from_mm:.2f}-{p.cushion_to_mm:.2f} mm"
        )
    if scenario.kind == "meshes":
        out |= {"roughness_um": round(1000 * p.noise_mm, 2), "vertices_min": p.vertices_min}
    if scenario.voxel_um is not None:
        out["voxel_um"] = [round(v, 2) for v in scenario.voxel_um]
        out["ends_inside"] = (
            f"{scenario.end_inside}, {scenario.end_inside_voxels} voxels on"
            if scenario.end_inside
            else None
        )
        out["oblique_deg"] = round(scenario.oblique_deg, 1)
    if seg is not None:
        out |= {
            "flip_pct": round(100 * seg.flip, 1),
            "islands": seg.islands,
            "wall_shifted": (
                f"{seg.systematic[0]} {seg.systematic[1]:+d} voxel"
                if seg.systematic and scenario.kind != "probabilities"
                else None
            ),  # (probability maps: not written)
            "defects": {str(k): v for k, v in seg.defects.items()},
        }
    return out


def real_shape_errors(dataset: Path, results: Path) -> dict[str, float]:
    """A real shape's draw: how far the tracked grid drifts from the tissue (each
    node's static point in each frame against its point at t = 0, median and 90th
    percentile over nodes and frames, % of the tube's length), and the cycle's wave
    speed against the true one in the run's own coordinates: each row's tissue (its
    nodes at t = 0) reached by the drawn wave when it is, over the run's ``s_mm``, end
    to end as the run measures it (the rows whose ridge it has)."""
    summary = json.loads((results / "summary.json").read_text())
    res = oftimg.load_results(results)
    G = np.load(results / "grids.npz")["outer"].astype(float)
    S = grid_material_points(dataset, G, summary["t0_frame"])
    drift_mm = np.linalg.norm(S - S[:, :, :1], axis=-1)[:, :, 1:]
    length = summary["tube_length_mm"]
    cycle = summary["wave_speed_mm_s"]["cycle"]  # None: no speed given (said why)
    arrival = wave_arrival_ms(dataset, S[:, :, 0].reshape(-1, 3)).reshape(S.shape[:2])
    rows = np.where(np.isfinite(res["ridge_t_ms"]), arrival.mean(axis=0), np.nan)
    true_cycle = cycle_speed(res["s_mm"], rows)
    sd = summary["wave_speed_noise_sd_mm_s"]["cycle"]
    return {
        "real_drift_median_pct": float(100 * np.median(drift_mm) / length),
        "real_drift_p90_pct": float(100 * np.percentile(drift_mm, 90) / length),
        "real_speed_cycle_pct": (
            np.nan if cycle is None else float(100 * (cycle / true_cycle - 1))
        ),
        "speed_cycle_spreads": (
            np.nan if cycle is None or not sd else float((cycle - true_cycle) / sd)
        ),
    }


def unshifted(errors: dict[int, dict]) -> dict[int, dict]:
    """The draws whose segmentation has no wall grown or shrunk by a voxel: against
    the same geometry as meshes, the others carry the segmentation's own shift."""
    return {s: e for s, e in errors.items() if not e.get("draw", {}).get("wall_shifted")}


def distribution(errors: dict[int, dict], key: str) -> dict | None:
    """|error| of ``key`` over the draws that have it: n, median, 90th percentile,
    worst and its seed; signed keys (``_bias_``) as they are. A draw whose run gave no
    value (NaN: no wave speed where the ridge is synchronous within the noise) is left
    out here and named by :func:`print_tables`."""
    pairs = [(seed, e[key]) for seed, e in errors.items() if key in e and np.isfinite(e[key])]
    if not pairs:
        return None
    seeds = np.array([s for s, _ in pairs])
    x = np.array([v for _, v in pairs], float)
    x = x if "_bias_" in key else np.abs(x)
    worst = int(np.argmax(np.abs(x)))
    return {
        "n": len(x),
        "median": float(np.median(x)),
        "p90": float(np.percentile(x, 90)),
        "worst": float(x[worst]),
        "worst_seed": int(seeds[worst]),
    }


def shifted(errors: dict[int, dict]) -> dict[int, dict]:
    """The draws whose segmentation grew or shrank a wall by a voxel."""
    return {s: e for s, e in errors.items() if e.get("draw", {}).get("wall_shifted")}


def print_tables(every: dict[str, dict], markdown: bool = False) -> None:
    """Per kind, each headline metric's distribution over the draws (seeds as keys),
    as text or as Markdown tables (docs/accuracy.md): over the draws whose segmentation
    shifted no wall (what oftimg does with the voxels), then over those whose did (a
    wall grown or shrunk by a voxel: the segmentation's own error, carried into every
    number), and the runs' own error bars against the truth."""
    for kind, errors in every.items():
        seeds = sorted(int(seed) for seed in errors)
        refused = sorted(int(s) for s, e in errors.items() if "refused" in e)
        clean, biased = unshifted(errors), shifted(errors)
        no_speed = sorted(
            int(s)
            for s, e in errors.items()
            if "speed_cycle_pct" in e and not np.isfinite(e["speed_cycle_pct"])
        )
        print(
            f"\n{kind}: {len(errors)} draws (seeds {seeds[0]}-{seeds[-1]})"
            + (f", refused: {refused}" if refused else "")
            + (f"; no wave speed given: {no_speed}" if no_speed else "")
            + (f"; {len(biased)} with a wall shifted by a voxel" if biased else "")
        )
        apart = " | shifted: median | 90th percentile | draws" if biased else ""
        if markdown:
            print(
                f"\n| metric | unit | median | 90th percentile | worst | its seed | draws"
                f"{apart} |\n|---|---|---|---|---|---|---" + "|---" * (3 * bool(biased)) + "|"
            )
        else:
            print(
                f"  {'metric':<62}{'unit':>6}{'median':>9}{'p90':>9}{'worst':>9}  seed    n"
                + ("   shifted: median, p90, n" if biased else "")
            )
        metrics = (
            FRONT_METRICS
            if kind.endswith(FRONTS_TAG)
            else HEADLINE + CUSHION_METRICS * kind.endswith(CUSHIONS_TAG)
        )
        for key, unit, what in metrics:
            d = distribution(clean, key)
            if d is None:
                continue
            b = distribution(biased, key) if biased else None
            worst = f"{d['worst']:.3g}"
            if markdown:
                more = (
                    f" | {b['median']:.3g} | {b['p90']:.3g} | {b['n']}"
                    if b
                    else " | | |"
                    if biased
                    else ""
                )
                print(
                    f"| {what} | {unit} | {d['median']:.3g} | {d['p90']:.3g} | {worst} "
                    f"| {d['worst_seed']} | {d['n']}{more} |"
                )
            else:
                more = f"   {b['median']:9.3g}{b['p90']:9.3g}  {b['n']}" if b else ""
                print(
                    f"  {what:<62}{unit:>6}{d['median']:9.3g}{d['p90']:9.3g}{worst:>9}"
                    f"  {d['worst_seed']:<6}{d['n']}{more}"
                )
        print_calibration(clean, markdown)


def print_calibration(errors: dict[int, dict], markdown: bool = False) -> None:
    """The run's own error bars against the truth: per band, the median share within
    it over the draws, the 10th percentile and the lowest (with its seed); the share
    of draws whose cycle speed lies within 1.96 of its noise spreads, within its 95 %
    band (:func:`~oftimg.analysis.uncertainty.speed_band_95`), and the systematic share
    that would put 95 % of these draws inside."""
    rows = []
    for key, what in CALIBRATION:
        pairs = [(int(s), e[key]) for s, e in errors.items() if key in e and np.isfinite(e[key])]
        if pairs:
            x = np.array([v for _, v in pairs])
            rows.append(
                (
                    what,
                    np.median(x),
                    np.percentile(x, 10),
                    x.min(),
                    pairs[int(np.argmin(x))][0],
                    len(x),
                )
            )
    spreads = [
        abs(e["speed_cycle_spreads"])
        for e in errors.values()
        if np.isfinite(e.get("speed_cycle_spreads", np.nan))
    ]
    # each draw's |relative error| and noise SD relative to the true speed
    pct = {s: e.get("speed_cycle_pct", e.get("real_speed_cycle_pct")) for s, e in errors.items()}
    relative = np.array(
        [
            (abs(pct[s]) / 100, abs(pct[s]) / 100 / abs(e["speed_cycle_spreads"]))
            for s, e in errors.items()
            if np.isfinite(e.get("speed_cycle_spreads", np.nan)) and e["speed_cycle_spreads"] != 0
        ]
    ).reshape(-1, 2)
    if not rows:
        pass  # real shapes: no field bands, the speed's below
    elif markdown:
        print(
            "\n| the run's own band | median over draws | 10th percentile | lowest | "
            "its seed | draws |\n|---|---|---|---|---|---|"
        )
        for what, med, p10, low, seed, n in rows:
            print(f"| {what} | {med:.0f} % | {p10:.0f} % | {low:.0f} % | {seed} | {n} |")
    else:
        print(f"  {'calibration':<62}{'median':>9}{'p10':>9}{'lowest':>9}  seed    n")
        for what, med, p10, low, seed, n in rows:
            print(f"  {what:<62}{med:9.0f}{p10:9.0f}{low:9.0f}  {seed:<6}{n}")
    if spreads:
        share = 100 * np.mean(np.array(spreads) <= 1.96)
        print(
            f"{'  ' if not markdown else chr(10)}cycle speed within 1.96 noise spreads of the "
            f"truth: {share:.0f} % of {len(spreads)} draws"
        )
    if len(relative):

        def inside(f):
            return np.mean(relative[:, 0] <= 1.96 * np.hypot(relative[:, 1], f))

        fitted = next((f for f in np.arange(0, 0.5, 0.0025) if inside(f) >= 0.95), np.nan)
        print(
            f"{'  ' if not markdown else chr(10)}cycle speed within its 95 % band (noise and "
            f"{SPEED_SYSTEMATIC_SHARE:.1%} of the speed): {100 * inside(SPEED_SYSTEMATIC_SHARE):.0f} "
            f"% of {len(relative)} draws; 95 % of them inside with {fitted:.1%}"
        )


def print_paired(first: dict, second: dict, markdown: bool = False) -> None:
    """The same draws run two ways (``--cut oblique`` and ``--cut square``: their
    ``--json`` files' one kind each): per headline metric, over the draws both have
    whose segmentation shifted no wall, the first's and the second's median and worst
    |error|, and the median and worst of the first's |error| less the second's (the
    cost of what differs, draw by draw)."""
    (name_a, a), (name_b, b) = next(iter(first.items())), next(iter(second.items()))
    seeds = sorted(set(unshifted(a)) & set(unshifted(b)), key=int)
    print(
        f"\n{name_a} against {name_b}: {len(seeds)} draws whose segmentation shifted no wall"
        f" (seeds {seeds[0]}-{seeds[-1]})"
    )
    if markdown:
        print(
            f"\n| metric | unit | {name_a}: median, worst | {name_b}: median, worst | "
            "difference of |error|: median, worst |\n|---|---|---|---|---|"
        )
    for key, unit, what in HEADLINE:
        pairs = np.array(
            [
                (abs(a[s][key]), abs(b[s][key]))
                for s in seeds
                if np.isfinite(a[s].get(key, np.nan)) and np.isfinite(b[s].get(key, np.nan))
            ]
        )
        if not len(pairs):
            continue
        d = pairs[:, 0] - pairs[:, 1]
        worst = d[np.argmax(np.abs(d))]
        cells = (
            f"{np.median(pairs[:, 0]):.3g}, {pairs[:, 0].max():.3g}",
            f"{np.median(pairs[:, 1]):.3g}, {pairs[:, 1].max():.3g}",
            f"{np.median(d):+.3g}, {worst:+.3g}",
        )
        if markdown:
            print(f"| {what} | {unit} | " + " | ".join(cells) + " |")
        else:
            print(f"  {what:<62}{unit:>6}  " + "   ".join(f"{c:>18}" for c in cells))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--draws", type=int, default=50, help="draws per input kind")
    ap.add_argument("--seed", type=int, default=0, help="the first draw's seed")
    ap.add_argument("--kinds", nargs="+", default=list(KINDS), choices=KINDS)
    ap.add_argument("--frames", type=int, default=None, help="every draw's frames (quick)")
    ap.add_argument(
        "--voxel-min-um", type=float, default=None, help="the finest voxel side drawn (quick)"
    )
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--cache", type=Path, default=None, help="keep the draws and runs here")
    ap.add_argument(
        "--json",
        type=Path,
        default=None,
        help="every draw's errors and conditions (written after each draw)",
    )
    ap.add_argument(
        "--tables",
        type=Path,
        nargs="+",
        default=None,
        metavar="JSON",
        help="print the tables of earlier runs' --json files (merged), run nothing",
    )
    ap.add_argument("--markdown", action="store_true", help="--tables as Markdown tables")
    ap.add_argument(
        "--paired",
        type=Path,
        nargs=2,
        default=None,
        metavar="JSON",
        help="two --json files of the same draws run two ways (--cut oblique, "
        "--cut square): each metric's errors side by side, run nothing",
    )
    ap.add_argument(
        "--fronts",
        action="store_true",
        help="draws with helical or one-sided wave fronts (their metrics only)",
    )
    ap.add_argument(
        "--features",
        action="store_true",
        help="draws with sharper corners or concave notches (3-6) and meshes of "
        "40-200 vertices round the tube (the node-by-node curvature's test)",
    )
    ap.add_argument(
        "--cushions",
        action="store_true",
        help="draws whose elliptical lumen falls towards a slit and (label kinds) "
        "closes over a stretch for part of the beat, with the cushions' "
        "metrics",
    )
    ap.add_argument(
        "--cut",
        choices=sorted(CUT_TAGS),
        default=None,
        help="label draws whose volume's faces cut the tube at both ends obliquely "
        "(20-50 deg) or square (the same draws otherwise: a paired comparison)",
    )
    ap.add_argument(
        "--no-pair",
        action="store_true",
        help="label kinds without their meshes' run (no node-by-node metrics)",
    )
    args = ap.parse_args()
    if args.paired:
        first, second = (json.loads(path.read_text()) for path in args.paired)
        print_paired(first, second, args.markdown)
        return
    if args.tables:
        every: dict[str, dict] = {}
        for path in args.tables:
            for kind, errors in json.loads(path.read_text()).items():
                every.setdefault(kind, {}).update(errors)
        print_tables(every, args.markdown)
        return
    started = time.perf_counter()
    oblique = {None: None, "oblique": True, "square": False}[args.cut]
    every = {}
    with tempfile.TemporaryDirectory() as tmp:
        root = args.cache or Path(tmp)
        for kind in args.kinds:
            drawn = every[
                kind
                + FRONTS_TAG * args.fronts
                + CUT_TAGS.get(args.cut, "")
                + FEATURES_TAG * args.features
                + CUSHIONS_TAG * args.cushions
            ] = {}
            for seed in range(args.seed, args.seed + args.draws):
                tick = time.perf_counter()
                try:
                    drawn[seed] = draw_errors(
                        seed,
                        kind,
                        root,
                        frames=args.frames,
                        voxel_min_um=args.voxel_min_um,
                        jobs=args.jobs,
                        pair=not args.no_pair,
                        fronts=args.fronts,
                        oblique=oblique,
                        features=args.features,
                        cushions=args.cushions,
                    )
                except oftimg.InputError as exc:  # refused: a fault of the zoo or of oftimg
                    drawn[seed] = {
                        "refused": str(exc),
                        "draw": conditions(
                            draw_scenario(
                                seed,
                                kind,
                                n_frames=args.frames,
                                voxel_um_min=args.voxel_min_um,
                                fronts=args.fronts,
                                oblique=oblique,
                                features=args.features,
                                cushions=args.cushions,
                            )
                        ),
                    }
                print(
                    f"{kind} draw {seed}: {time.perf_counter() - tick:.0f} s"
                    + (f", refused: {drawn[seed]['refused']}" if "refused" in drawn[seed] else ""),
                    flush=True,
                )
                if args.json:
                    args.json.write_text(json.dumps(every, indent=1, default=str))
    print(
        f"\n{sum(len(v) for v in every.values())} draws, {time.perf_counter() - started:.0f} s"
        f" (frames {args.frames or 'drawn'}, voxels from {args.voxel_min_um or 'drawn'} um)"
    )
    print_tables(every)


if __name__ == "__main__":
    main()
