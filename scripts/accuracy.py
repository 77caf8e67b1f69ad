"""Accuracy against the phantoms' truth: the paper's Table 1 numbers and the maps.

    python scripts/accuracy.py [--seeds 3] [--frames 195] [--noise-mm 0 0.002]
                               [--map-positions rows fixed] [--expand-change 0.2]
                               [--ridge-smoothing-ms auto] [--vertices 2000]
                               [--jobs 2] [--cache DIR] [--json]

Makes (or reuses, in --cache) normal and banded phantoms with seeds 0 .. n-1 at
each noise level (`noise_mm`: the standard deviation of a radial displacement of
every vertex, a segmentation's roughness), runs oftimg on them as one cohort (once
per --map-positions) and
compares each embryo's results with its `truth.json` and the analytic model.
Prints, per group and metric, the bias (median signed error), the median and the
largest absolute error over the embryos; `--json` gives every embryo's errors as well.
`--expand-change D` makes phantoms whose expansion share of the cycle changes by D
(0.2: 20 percentage points) from inlet to outlet, so that the beat's peak, the
ridge, travels at a speed of its own; the speeds are then compared with the
ridge's (the truth's `ridge_speed_mm_s`). `--vertices N` meshes every frame with
0.75 N to 1.25 N vertices (default: the phantoms' 4000-8000), to see how the
numbers depend on the meshes' resolution.

Errors (measured minus true; "%" relative to the truth, "pp" percentage points):
- Table 1: expansion share of the cycle (pp) and time (ms); wave speed min, max,
  mean, median and cycle (%), the local speed row by row (median of |error| along
  the tube, %), and the two-segment fit's speeds (%) and knee (mm);
- the noise spreads oftimg gives the speeds: the cycle and two-segment speeds'
  errors in spreads (SD), the share of the resolved local speeds (and of the ridge
  times, less their median error) within 2 spreads of the truth, and of the local
  speeds not resolved (%);
- timing: the ridge (time of maximum area) along the tube, mean and RMS over the
  rows, ms;
- size: tube length (%), volumes of each wall (largest over the frames, %), the
  myocardial volume change (pp), the cardiac jelly's (inner - lumen) volume change
  (%), section areas of each wall and of the jelly (median and 95th percentile over the
  (v, t) map, %), the share of the cycle above 75 % of the
  maximum area (largest over the rows, pp);
- shape: band position (mm, banded embryos), corner count (wrong ones counted);
  the shape fields at their own positions (rows 2 to n_v - 3: the end rows' values
  are their neighbours'): radial curvature of the outer and inner walls and mean
  curvature of the lumen, the wall thickness (outer to inner grid node against the
  model's radial thickness; its thickening over the beat, as summary.json's, against
  the model's, every row), the cardiac jelly's thickness (inner grid node to the
  lumen, against the model's radial inner-minus-lumen distance; its thickening
  alike), and the inner wall's strain energy against that of the
  model's inner wall at each grid node's position along and angle around the tube
  (each: median |error| over the median |truth|, %); each curvature also against
  the model at its points' positions averaged in time as the field is, and the
  strain at the grid nodes' positions averaged as its nodes were (a rough mesh moves
  them along the wall from frame to frame); for each curvature, the noise
  oftimg reports (`field_noise`, after its smoothing) over the true error's spread
  (each pixel's SD over the cycle, median, against the model at the mean positions;
  about 1 where the error is noise), and the
  noise share it reports (a value, not an error);
- with noise 0 among the levels: each noisy phantom's outer and inner strain energy
  against the same phantom's analysed without noise (what the roughness alone does
  to the field), and the share by which oftimg says its noise moves it
  (`strain_noise`) over that (about 1 where it is right).
"""

from __future__ import annotations

import argparse
import json
import tempfile
from pathlib import Path

import numpy as np

import oftimg
from oftimg.image.activation import helix_angle, surface_velocity, unwrapped
from oftimg.image.normalize import smooth_field_in_time
from oftimg.mesh.strain import grid_strain
from oftimg.analysis.fields import smoothed_strain, thickness_summary
from oftimg.synthetic.labels import NOISE, label_params, volume_transform, write_label_phantom
from oftimg.synthetic.phantom import read_truth, sample_params, write_phantom
from oftimg.synthetic.zoo import volume_offset_um

WALLS = ("outer", "inner", "lumen")
SLIT_AREA = 0.05  # a section under this share of its row's largest: a slit
# the fields smoothed in time as their noise asks
CURVATURES = [
    ("radial_curvature_outer", "radial curvature, outer"),
    ("radial_curvature_inner", "radial curvature, inner"),
    ("mean_curvature_lumen", "mean curvature, lumen"),
    ("wall_thickness", "wall thickness"),
    ("jelly_thickness", "jelly thickness"),
]

# (key, unit, what): the rows of the printed table, in this order
METRICS = [
    ("expand_pp", "pp", "expansion share of the cycle"),
    ("expand_ms", "ms", "expansion time"),
    ("speed_min_pct", "%", "wave speed, minimum"),
    ("speed_max_pct", "%", "wave speed, maximum"),
    ("speed_mean_pct", "%", "wave speed, mean"),
    ("speed_median_pct", "%", "wave speed, median (not in the paper)"),
    ("speed_cycle_pct", "%", "wave speed, cycle (ends only)"),
    ("local_speed_median_pct", "%", "local wave speed along the tube (median |error|)"),
    ("speed_proximal_pct", "%", "two-segment fit, proximal speed"),
    ("speed_distal_pct", "%", "two-segment fit, distal speed"),
    ("knee_mm", "mm", "two-segment fit, knee position"),
    ("speed_cycle_spreads", "SD", "wave speed, cycle, in its noise spreads"),
    ("speed_proximal_spreads", "SD", "two-segment proximal speed, in its noise spreads"),
    ("speed_distal_spreads", "SD", "two-segment distal speed, in its noise spreads"),
    ("local_within_2_spreads_pct", "%", "resolved local speeds within 2 noise spreads"),
    ("local_unresolved_pct", "%", "local speeds not resolved (no noise spread)"),
    ("ridge_within_2_spreads_pct", "%", "ridge times (less their median) within 2 spreads"),
    ("ridge_bias_ms", "ms", "ridge time along the tube (mean)"),
    ("ridge_rms_ms", "ms", "ridge time along the tube (RMS)"),
    ("length_pct", "%", "tube length"),
    *[(f"volume_{w}_pct", "%", f"volume of the {w} wall (worst frame)") for w in WALLS],
    ("myocardial_change_pp", "pp", "myocardial volume change"),
    ("jelly_change_pct", "%", "cardiac jelly's volume change (inner - lumen)"),
    ("area_jelly_median_pct", "%", "section area, cardiac jelly (median over v, t)"),
    ("area_jelly_p95_pct", "%", "section area, cardiac jelly (95th percentile)"),
    *[(f"area_{w}_median_pct", "%", f"section area, {w} (median over v, t)") for w in WALLS],
    *[(f"area_{w}_p95_pct", "%", f"section area, {w} (95th percentile)") for w in WALLS],
    ("expanded_75_pp", "pp", "share of the cycle above 75 % of max area (worst row)"),
    ("band_mm", "mm", "band position (banded)"),
    ("corners_wrong", "", "corner count wrong (1) or right (0)"),
    *[
        (f"radial_curvature_{w}_pct", "%", f"radial curvature, {w} (median |error|)")
        for w in ("outer", "inner")
    ],
    ("mean_curvature_lumen_pct", "%", "mean curvature, lumen (median |error|)"),
    ("wall_thickness_pct", "%", "wall thickness (median |error|)"),
    ("wall_thickening_pct", "%", "wall thickening over the beat (median row)"),
    ("jelly_thickness_pct", "%", "jelly thickness (median |error|)"),
    ("jelly_thickening_pct", "%", "jelly thickening over the beat (median row)"),
    *[
        (f"{name}_mean_position_pct", "%", f"{what}, truth at mean positions")
        for name, what in CURVATURES
    ],
    ("strain_energy_inner_pct", "%", "strain energy, inner wall (median |error|)"),
    (
        "strain_energy_inner_mean_position_pct",
        "%",
        "strain energy, inner wall, truth at mean positions",
    ),
    *[
        (
            f"strain_energy_{w}_vs_noise_free_pct",
            "%",
            f"strain energy, {w} wall, against the run without noise",
        )
        for w in ("outer", "inner")
    ],
    *[
        (f"{name}_noise_ratio", "x", f"{what}: noise oftimg reports / true error's SD")
        for name, what in CURVATURES
    ],
    *[
        (
            f"strain_energy_{w}_noise_ratio",
            "x",
            f"strain energy, {w}: noise share oftimg reports / change",
        )
        for w in ("outer", "inner")
    ],
    *[
        (f"strain_energy_{w}_error_share", "", f"strain energy, {w}: noise share oftimg reports")
        for w in ("outer", "inner")
    ],
    *[
        (f"{name}_noise_share", "", f"{what}: noise share oftimg reports (not an error)")
        for name, what in CURVATURES
    ],
    *[
        (f"{name}_smoothing_ms", "ms", f"{what}: smoothing taken (not an error)")
        for name, what in CURVATURES
    ],
    *[
        (
            f"strain_energy_{w}_smoothing_ms",
            "ms",
            f"strain energy, {w}: smoothing taken (not an error)",
        )
        for w in ("outer", "inner")
    ],
]


def make_cohort(
    folder: Path,
    seeds: int,
    frames: int,
    noise_mm: float,
    expand_change: float = 0.0,
    vertices: int | None = None,
    *,
    labels=None,
    segmentation_noise: float | None = None,
    bent: bool = False,
    probabilities: bool = False,
) -> Path:
    """Normal and banded phantoms ``<group>_<seed>`` in ``folder`` (kept if there),
    meshed with 0.75 to 1.25 ``vertices`` (default: the phantoms' own range); with
    ``labels`` (voxel size, um), as label volumes with ``segmentation_noise``; with
    ``bent``, meshes of the phantoms that labels make (bent to a quarter circle); with
    ``probabilities`` (and ``labels``), probability maps with noise of SD
    ``segmentation_noise`` instead of label volumes."""
    sizes = (
        {}
        if vertices is None
        else dict(vertices_min=round(0.75 * vertices), vertices_max=round(1.25 * vertices))
    )
    for group in ("normal", "banded"):
        for seed in range(seeds):
            path = folder / f"{group}_{seed}"
            if (path / "truth.json").exists():
                continue
            params = sample_params(
                group,
                seed,
                n_frames=frames,
                noise_mm=noise_mm,
                expand_change=expand_change,
                **sizes,
            )
            if labels is not None:
                write_label_phantom(
                    path, params, labels, noise=segmentation_noise, probabilities=probabilities
                )
            else:
                write_phantom(path, label_params(params) if bent else params)
    return folder


def in_phantom_frame(dataset: Path, npz, points=lambda key: True) -> dict:
    """The arrays of ``npz`` whose key ``points`` accepts, points (mm) along their
    last axis, in the phantom's own frame: a label phantom's volume is turned and
    shifted (:func:`oftimg.synthetic.labels.volume_transform`)."""
    arrays = {k: npz[k] for k in npz.files}
    if not ((dataset / "labels").is_dir() or (dataset / "probabilities").is_dir()):
        return arrays
    turn, shift = volume_transform(dataset)
    drawn = dataset / "scenario.json"  # a zoo draw: its tube may end inside
    if drawn.is_file():
        shift = shift + 1e-3 * volume_offset_um(json.loads(drawn.read_text()))
    return {
        k: ((a.astype(float) - shift) @ turn.T if points(k) and a.shape[-1:] == (3,) else a)
        for k, a in arrays.items()
    }


PIXEL_FIELDS = (
    "radial_curvature_outer_per_mm",
    "radial_curvature_inner_per_mm",
    "mean_curvature_lumen_per_mm",
    "strain_energy_outer",
    "strain_energy_inner",
)


def pixel_differences(labels: Path, meshes: Path) -> dict[str, float]:
    """Each (u, v, t) field of a label run against the same phantom's mesh run, node by
    node: median |labels - meshes| over median |meshes|, in %. Both runs start their
    time axis at the minimum outer volume and grid the tube alike, so that node (i, j,
    k) is about the same place and time in both."""
    a, b = np.load(labels / "arrays.npz"), np.load(meshes / "arrays.npz")
    return {
        name: float(100 * np.nanmedian(np.abs(a[name] - b[name])) / np.nanmedian(np.abs(b[name])))
        for name in PIXEL_FIELDS
        if name in a.files and name in b.files and a[name].shape == b[name].shape
    }


def _relative_pct(measured, true) -> float:
    """(measured / true - 1) in %; NaN where nothing was measured (null in JSON: a
    wave speed that the run could not give)."""
    if measured is None or true is None:
        return float("nan")
    return float(100.0 * (measured / true - 1.0))


def _in_spreads(measured, true, spread) -> float:
    """Error over the noise spread (NaN: not resolved, or no spread given)."""
    return float((measured - true) / spread) if spread and measured is not None else float("nan")


def embryo_errors(dataset: Path, results: Path, keep: dict | None = None) -> dict[str, float]:
    """Every metric's error (measured minus true) for one analysed phantom."""
    ph, truth = read_truth(dataset)
    p = truth["params"]
    summ = json.loads((results / "summary.json").read_text())
    arr = in_phantom_frame(
        dataset,
        np.load(results / "arrays.npz"),
        lambda key: key.startswith(("contour_", "centroid_")),
    )
    period = p["period_ms"]
    t0 = summ["t0_frame"]
    t_ms = np.roll(np.array(truth["t_ms"]), -t0)  # phantom time of each aligned frame
    s_mm = arr["s_mm"]
    if summ["provenance"].get("meshing", {}).get("ends_squared"):
        # ends cut square inside the window: each row at its own place, the truth of
        # the part kept
        s_mm = ph.window_coordinates(arr["centroid_outer_mm"])[0].mean(axis=1)
        truth = {**truth, **ph.truth(s_range=(float(s_mm[0]), float(s_mm[-1])))}
    e = {
        "expand_pp": 100.0 * (summ["expand_fraction"] - truth["expand_fraction"]),
        "expand_ms": summ["expand_ms"] - truth["expand_ms"],
    }
    for k in ("min", "max", "mean", "cycle"):
        e[f"speed_{k}_pct"] = _relative_pct(summ["wave_speed_mm_s"][k], truth["wave_speed_mm_s"][k])
    ridge_speed = truth.get("ridge_speed_mm_s", truth["speed_mm_s"])  # older truth files
    e["speed_median_pct"] = _relative_pct(summ["wave_speed_mm_s"]["median"], np.median(ridge_speed))
    two = summ["wave_two_segment"]
    true_speed = np.interp(s_mm, truth["s_mm"], ridge_speed)
    true_two = {
        side: float(ph.ridge_speed_from(p[f"speed_{side}_mm_s"])) for side in ("proximal", "distal")
    }
    local = np.abs(arr["local_speed_mm_s"] / true_speed - 1.0)
    # no local speed at all where the run says the tube moves at once (right, and said)
    e["local_speed_median_pct"] = (
        float(100.0 * np.nanmedian(local)) if np.isfinite(local).any() else float("nan")
    )
    e["speed_proximal_pct"] = _relative_pct(two["speed_proximal_mm_s"], true_two["proximal"])
    e["speed_distal_pct"] = _relative_pct(two["speed_distal_mm_s"], true_two["distal"])
    offset = float(s_mm[0] - arr["s_mm"][0])  # where the run's tube begins in the window
    e["knee_mm"] = (
        (two["knee_mm"] + offset - p["speed_knee_mm"])
        if two["knee_mm"] is not None
        else float("nan")
    )
    # the errors in units of the spread that the map's own noise gives (docs/accuracy.md)
    spread = summ["wave_speed_noise_sd_mm_s"]
    e["speed_cycle_spreads"] = _in_spreads(
        summ["wave_speed_mm_s"]["cycle"], truth["wave_speed_mm_s"]["cycle"], spread["cycle"]
    )
    for side in ("proximal", "distal"):
        e[f"speed_{side}_spreads"] = _in_spreads(
            two[f"speed_{side}_mm_s"], true_two[side], two[f"speed_{side}_noise_sd_mm_s"]
        )
    local_sd = arr["local_speed_noise_sd_mm_s"]
    resolved = np.isfinite(local_sd)
    e["local_unresolved_pct"] = float(100.0 * (1 - resolved.mean()))
    e["local_within_2_spreads_pct"] = (
        float(
            100.0
            * np.mean(
                np.abs(arr["local_speed_mm_s"] - true_speed)[resolved] < 2 * local_sd[resolved]
            )
        )
        if resolved.any()
        else float("nan")
    )
    # ridge: aligned time back to phantom time, compared around the cycle
    ridge = arr["ridge_t_ms"] + t_ms[0]
    true_ridge = np.interp(s_mm, truth["s_mm"], truth["ridge_t_ms"])
    d = (ridge - true_ridge + period / 2) % period - period / 2
    e["ridge_bias_ms"] = float(np.nanmean(d))
    e["ridge_within_2_spreads_pct"] = float(
        100.0 * np.nanmean(np.abs(d - np.nanmedian(d)) < 2 * arr["ridge_t_noise_sd_ms"])
    )
    e["ridge_rms_ms"] = float(np.sqrt(np.nanmean(d**2)))
    e["length_pct"] = _relative_pct(summ["tube_length_mm"], truth["tube_length_mm"])
    for w in WALLS:
        rel = arr[f"volume_{w}_mm3"] / np.roll(truth["volume_mm3"][w], -t0) - 1.0
        e[f"volume_{w}_pct"] = float(100.0 * rel[np.argmax(np.abs(rel))])
        true_area = ph.area_mm2(w, s_mm[:, None], t_ms[None, :])
        # relative where the section is open: a slit closing between the cushions
        # (under SLIT_AREA of its row's largest) has the cushions' own metrics
        true_area = np.where(
            true_area >= SLIT_AREA * true_area.max(axis=1, keepdims=True), true_area, np.nan
        )
        area_rel = np.abs(arr[f"area_{w}_mm2"] / true_area - 1.0)
        e[f"area_{w}_median_pct"] = float(100.0 * np.nanmedian(area_rel))
        e[f"area_{w}_p95_pct"] = float(100.0 * np.nanpercentile(area_rel, 95))
        # the first and last 5 rows: where a face that cuts the tube obliquely shows
        ends = np.r_[area_rel[:5], area_rel[-5:]]
        e[f"area_{w}_end_rows_p95_pct"] = float(100.0 * np.nanpercentile(ends, 95))
    e["myocardial_change_pp"] = 100.0 * (
        summ["myocardial_volume_change"] - truth["myocardial_volume_change"]
    )
    jelly = np.subtract(truth["volume_mm3"]["inner"], truth["volume_mm3"]["lumen"])
    e["jelly_change_pct"] = _relative_pct(
        summ["jelly_volume_change"], (jelly.max() - jelly.min()) / jelly.min()
    )
    at = (s_mm[:, None], t_ms[None, :])
    jelly_rel = np.abs(
        arr["area_jelly_mm2"] / (ph.area_mm2("inner", *at) - ph.area_mm2("lumen", *at)) - 1.0
    )
    e["area_jelly_median_pct"] = float(100.0 * np.nanmedian(jelly_rel))
    e["area_jelly_p95_pct"] = float(100.0 * np.nanpercentile(jelly_rel, 95))
    frac = arr["expanded_fraction_75_outer"] - np.interp(
        s_mm, truth["s_mm"], truth["expanded_fraction_75"]
    )
    e["expanded_75_pp"] = float(100.0 * frac[np.nanargmax(np.abs(frac))])
    if truth["band_position_mm"] is not None:
        found = summ["band_position_mm"]
        e["band_mm"] = np.nan if found is None else found + offset - truth["band_position_mm"]
    e["corners_wrong"] = float(summ["corner_count"] != truth["corner_count"])
    grids = in_phantom_frame(dataset, np.load(results / "grids.npz"))
    e.update(field_errors(ph, arr, grids, t_ms, summ, period, keep))
    if "wave_fronts" in summ:
        e.update(front_errors(ph, arr, grids["outer"], t_ms, summ["wave_fronts"]["outer"], period))
    if p.get("cushion_aspect_expanded", 1.0) < 1.0:
        e.update(cushion_errors(ph, arr, t_ms, period))
    return {k: float(v) for k, v in e.items()}


# the sections whose aspect and axis are compared: open by this much in the model
# (a slit about to close is a few voxels across), and elliptic for the axis
CUSHION_OPEN_ASPECT = 0.02
CUSHION_AXIS_ASPECT = 0.8
CUSHION_END_ROWS = 2  # rows left out at each end (their sections are cut)
FINE_CLOCK = 3600  # the truth's closing and opening times on this clock


def cushion_errors(ph, arr, t_ms: np.ndarray, period_ms: float) -> dict[str, float]:
    """The cushions' measures (:mod:`oftimg.analysis.cushions`) against the model's:
    per row the closing and opening times (circular error, % of the period: median and
    worst over the rows that close in both), the closed share (percentage points),
    the rows that close in one and not the other (% of the rows), the aspect ratio
    (%, median over the open sections) and the major axis's angle (deg, median over the
    elliptic ones), rows :data:`CUSHION_END_ROWS` from each end left out. ``arr``: the
    run's arrays in the phantom's frame; ``t_ms (n_t,)``: the model's time of each
    aligned frame."""
    inner = slice(CUSHION_END_ROWS, -CUSHION_END_ROWS)
    s_row, _ = ph.window_coordinates(arr["centroid_outer_mm"])  # (n_v, n_t)
    s_v = np.nanmedian(s_row, axis=1)
    _, seam = ph.window_coordinates(arr["contour_lumen_mm"][0])  # (n_v, n_t)
    aspect, major = ph.section_ellipse("lumen", s_row, t_ms[None, :])
    model = ph.cushion_aspect(s_row, t_ms[None, :])
    fine = np.linspace(0.0, period_ms, FINE_CLOCK, endpoint=False)  # run's clock
    shut = ph.cushion_aspect(s_v[:, None], fine[None, :] + t_ms[0]) <= 0
    close, opened = np.full(len(s_v), np.nan), np.full(len(s_v), np.nan)
    for j, row in enumerate(shut):
        if row.any() and not row.all():
            falls = np.flatnonzero(~row & np.roll(row, -1))[0]
            rises = np.flatnonzero(row & ~np.roll(row, -1))[0]
            close[j] = fine[(falls + 1) % FINE_CLOCK]
            opened[j] = fine[(rises + 1) % FINE_CLOCK]

    def circular_pct(measured, true):
        d = np.abs((measured - true + period_ms / 2) % period_ms - period_ms / 2)
        return 100.0 * d / period_ms

    e = {}
    found = np.isfinite(arr["lumen_close_ms"])[inner]
    truth_closes = np.isfinite(close)[inner]
    e["cushion_rows_wrong_pct"] = float(100.0 * np.mean(found != truth_closes))
    both = found & truth_closes
    if both.any():
        for key, measured, true in (
            ("close", arr["lumen_close_ms"], close),
            ("open", arr["lumen_open_ms"], opened),
        ):
            err = circular_pct(measured[inner][both], true[inner][both])
            e[f"cushion_{key}_median_pct"] = float(np.median(err))
            e[f"cushion_{key}_worst_pct"] = float(err.max())
    share = np.abs(arr["lumen_closed_share"] - shut.mean(axis=1))[inner]
    e["cushion_closed_share_median_pp"] = float(100.0 * np.median(share))
    e["cushion_closed_share_worst_pp"] = float(100.0 * share.max())
    e["cushion_closed_cells_wrong_pct"] = float(
        100.0 * np.mean((arr["lumen_closed"] != (model <= 0))[inner])
    )
    open_ = (model > CUSHION_OPEN_ASPECT) & np.isfinite(arr["lumen_aspect_ratio"])
    open_[:CUSHION_END_ROWS], open_[-CUSHION_END_ROWS:] = False, False
    if open_.any():
        rel = 100.0 * np.abs(arr["lumen_aspect_ratio"] / aspect - 1.0)[open_]
        e["cushion_aspect_median_pct"] = float(np.median(rel))
        e["cushion_aspect_p90_pct"] = float(np.percentile(rel, 90))
        relative = (major - np.degrees(seam)) % 180.0  # the run's angle: from the seam
        axis = np.abs((arr["lumen_major_axis_deg"] - relative + 90.0) % 180.0 - 90.0)
        elliptic = open_ & (aspect < CUSHION_AXIS_ASPECT) & np.isfinite(axis)
        if elliptic.any():
            e["cushion_axis_median_deg"] = float(np.median(axis[elliptic]))
            e["cushion_axis_p90_deg"] = float(np.percentile(axis[elliptic], 90))
    return e


def wave_front_errors(dataset: Path, results: Path) -> dict[str, float]:
    """:func:`front_errors` of one analysed phantom alone (a helical front: the (v, t)
    area map's numbers have nothing to measure)."""
    ph, truth = read_truth(dataset)
    summ = json.loads((results / "summary.json").read_text())
    grids = in_phantom_frame(dataset, np.load(results / "grids.npz"))
    t_ms = np.roll(np.array(truth["t_ms"]), -summ["t0_frame"])
    return front_errors(
        ph,
        np.load(results / "arrays.npz"),
        grids["outer"],
        t_ms,
        summ["wave_fronts"]["outer"],
        truth["params"]["period_ms"],
    )


def front_errors(
    ph, arr, grid: np.ndarray, t_ms: np.ndarray, found: dict, period_ms: float
) -> dict[str, float]:
    """The wave's fronts on the outer wall (summary.json's ``wave_fronts``) against
    the model's: its activation along each node's path (``Phantom.activation_along``:
    the tracked ``grid (n_u, n_v, n_t, 3)``, mm in the phantom's frame, at the phantom's
    times ``t_ms (n_t,)``), through the same gradient on the same wall (its mean shape)
    without smoothing, over the nodes the
    run reads the wave at (its velocity finite there: the others barely move); the
    median speed, the axial speed and the helix angle (degrees, signed), the
    activation's RMS error after its median (ms, the 4 end rows left out) and the share
    of nodes within 1.96 of their stated noise SD after it (%). ``front_propagates`` 0
    where the run says the wall does not propagate (then no other number)."""
    mean = grid.mean(axis=2)
    s_path, theta_path = ph.window_coordinates(grid)
    true_ms = ph.activation_along(s_path, theta_path, t_ms)
    reads = np.isfinite(arr["wave_velocity_outer_mm_s"][..., 0])
    truth = surface_velocity(true_ms, mean, period_ms, smoothing_nodes=0, use=reads)
    if not found["propagates"]:
        return {"front_propagates": 0.0}
    inner = reads[:, 4:-4]
    error = unwrapped(arr["activation_time_outer_ms"] - true_ms, period_ms)[:, 4:-4][inner]
    error -= np.median(error)
    sd = arr["activation_sd_outer_ms"][:, 4:-4][inner]
    return {
        "front_propagates": 1.0,
        "front_speed_pct": _relative_pct(found["speed_mm_s"], np.nanmedian(truth.speed_mm_s)),
        "front_axial_speed_pct": _relative_pct(
            found["axial_speed_mm_s"], 1e3 / np.nanmedian(truth.axial_slowness_ms_mm)
        ),
        "front_helix_deg": found["helix_angle_deg"] - helix_angle(truth),
        "front_activation_rms_ms": float(np.sqrt(np.mean(error**2))),
        "front_activation_within_95_pct": float(100 * np.mean(np.abs(error) <= 1.96 * sd)),
    }


def on_tissue(contour: np.ndarray, arr) -> np.ndarray:
    """Each frame's section contour points ``(n_u, n_v, n_t, 3)`` read along the run's
    pathlines (``pathlines_uv`` in ``arr``, where the grid was tracked): where the
    tracked curvature fields were read. (Before 2026-12-07 the zoo took the truth at
    each frame's own contour points: with texture tracking, whose nodes slide along
    the tube, the radial curvature's error was the model's change between the two.)"""
    from oftimg.analysis.tracking import follow

    if "pathlines_uv" not in arr:
        return contour
    return follow(contour, np.asarray(arr["pathlines_uv"], float))


def field_errors(
    ph, arr, grids, t_ms: np.ndarray, summ: dict, period_ms: float, keep: dict | None = None
) -> dict[str, float]:
    """The shape fields' errors against the model, away from the end rows; each
    curvature and the wall thickness (smoothed in time:
    ``field_noise[name]["smoothing_ms"]``) also against
    the model at its points' positions averaged alike (on a rough mesh a contour
    point moves along the wall by several um from frame to frame, the smoothed
    field does not follow it, and the model's curvature changes fast around a
    cornered section); for each curvature, the noise oftimg reports (``summary.json:
    field_noise``, after its smoothing) over the true error's spread (each
    pixel's SD over the cycle, median, against the model at the mean positions),
    and the noise share it reports. ``keep``: a dict given the node errors, name ->
    ``(error (n_u, n_v - 4, n_t) against the mean positions, the noise reported)``
    (scripts/zoo_calibration.py)."""
    field_noise, strain_noise = summ.get("field_noise") or {}, summ["strain_noise"]
    rows, t = slice(2, -2), t_ms[None, None, :]

    def median_pct(measured, true):
        return 100.0 * np.nanmedian(np.abs(measured - true)) / np.nanmedian(np.abs(true))

    def truth_at(points, model, array):
        """The model at ``points (n_u, n_v, n_t, 3)``, and at their positions averaged
        in time as the field ``array`` is."""
        sigma = field_noise[array]["smoothing_ms"]
        mean_points = np.moveaxis(
            smooth_field_in_time(np.moveaxis(points, -1, 0), period_ms, sigma), 0, -1
        )
        return [model(*ph.window_coordinates(p), t) for p in (points, mean_points)]

    truths = {}  # metric name: (array, truth, truth at the mean positions)
    for w in ("outer", "inner"):
        array = f"radial_curvature_{w}_per_mm"
        truths[f"radial_curvature_{w}"] = (
            array,
            *truth_at(
                on_tissue(arr[f"contour_{w}_mm"].astype(float), arr)[:, rows],
                lambda s, theta, t, w=w: ph.section_curvature(w, s, theta, t),
                array,
            ),
        )
    truths["mean_curvature_lumen"] = (
        "mean_curvature_lumen_per_mm",
        *truth_at(
            grids["lumen"][:, rows].astype(float),
            lambda s, theta, t: ph.mean_curvature("lumen", s, theta, t),
            "mean_curvature_lumen_per_mm",
        ),
    )
    for layer in ("wall", "jelly"):  # both measured along the lines from the outer nodes
        truths[f"{layer}_thickness"] = (
            f"{layer}_thickness_mm",
            *truth_at(
                grids["outer"][:, rows].astype(float),
                getattr(ph, f"{layer}_thickness"),
                f"{layer}_thickness_mm",
            ),
        )
    e = {}
    # each node's phase: expanded where the wall there is past half its expansion
    s_nodes, theta_nodes = ph.window_coordinates(grids["outer"][:, rows].astype(float))
    expanded = ph.expansion(s_nodes, t, theta_nodes) > 0.5
    for name, (array, truth, truth_at_mean) in truths.items():
        measured = arr[array][:, rows]
        if keep is not None:
            keep[name] = (
                measured - truth_at_mean,
                (field_noise.get(array) or {}).get("noise_sd_smoothed") or np.nan,
            )
        e[f"{name}_pct"] = median_pct(measured, truth)
        # the tail, node by node (issue 84): the 90th percentile of |error| over the
        # median |truth|, in all, by phase and by feature (convex: the truth > 0)
        scale = np.nanmedian(np.abs(truth))
        error = np.abs(measured - truth)
        e[f"{name}_p90_pct"] = float(100.0 * np.nanpercentile(error, 90) / scale)
        for phase, at in (("expanded", expanded), ("contracted", ~expanded)):
            for feature, where in (("convex", truth > 0), ("concave", truth < 0)):
                picked = error[at & where]
                e[f"{name}_{phase}_{feature}_p90_pct"] = (
                    float(100.0 * np.nanpercentile(picked, 90) / scale)
                    if np.isfinite(picked).sum() >= 20
                    else np.nan
                )
        e[f"{name}_mean_position_pct"] = median_pct(measured, truth_at_mean)
        noise = field_noise.get(array) or {}
        spread = np.nanmedian(np.nanstd(measured - truth_at_mean, axis=-1))
        e[f"{name}_noise_ratio"] = (noise.get("noise_sd_smoothed") or np.nan) / spread
        # calibration: the share of nodes and frames whose error lies within the 95 %
        # band the run reports (1.96 times its noise after the smoothing)
        band = 1.96 * (noise.get("noise_sd_smoothed") or np.nan)
        e[f"{name}_within_95_pct"] = (
            float(100.0 * np.nanmean(np.abs(measured - truth_at_mean) <= band))
            if np.isfinite(band)
            else np.nan
        )
        # what a calibrated band would need: the error's 95th percentile (the field's
        # unit) beside the noise the run reports
        e[f"{name}_error_p95"] = float(np.nanpercentile(np.abs(measured - truth_at_mean), 95))
        # each node's own band (issue 84), against the model at the node
        node_band = (
            arr.get(array.replace("_per_mm", "_band95_per_mm")) if "_per_mm" in array else None
        )
        if node_band is not None:
            band = node_band[:, rows].astype(float)
            inside = np.abs(measured - truth) <= band
            known = np.isfinite(measured - truth) & np.isfinite(band)
            e[f"{name}_node_band_within_pct"] = float(100 * inside[known].mean())
            for phase, at in (("expanded", expanded), ("contracted", ~expanded)):
                e[f"{name}_node_band_within_{phase}_pct"] = float(100 * inside[known & at].mean())
            e[f"{name}_node_band_ratio_p95"] = float(
                np.nanpercentile(np.abs(measured - truth)[known] / band[known], 95)
            )
            wide = noise.get("band95_wide_share")  # None: no node with a band
            e[f"{name}_band95_wide_share"] = np.nan if wide is None else wide
        e[f"{name}_noise_sd"] = noise.get("noise_sd_smoothed") or np.nan
        e[f"{name}_noise_share"] = noise.get("noise_share") or np.nan
        e[f"{name}_smoothing_ms"] = noise.get("smoothing_ms", np.nan)
        if "scale" in noise:  # the radial curvature's scale (issue 84)
            e[f"{name}_scale"] = noise["scale"]
    for w in ("outer", "inner"):
        e[f"strain_energy_{w}_error_share"] = strain_noise[f"strain_energy_{w}"]["error_share"]
        e[f"strain_energy_{w}_smoothing_ms"] = strain_noise[f"strain_energy_{w}"]["smoothing_ms"]
    # the thickening over the beat, as summary.json's: every row
    for layer in ("wall", "jelly"):
        model = truth_at(
            grids["outer"].astype(float), getattr(ph, f"{layer}_thickness"), f"{layer}_thickness_mm"
        )[1]
        e[f"{layer}_thickening_pct"] = _relative_pct(
            summ[f"{layer}_thickening"], thickness_summary(model, layer)[f"{layer}_thickening"]
        )
    # the strain: against the model's at the outer grid nodes' own positions in each
    # frame, and at their positions averaged in time as the field's nodes were: the grid
    # of a smooth wall (at its own positions the model shares the nodes' jitter along
    # the wall, which the grid's strain suffers too, and so hides it)
    measured = arr["strain_energy_inner"][:, rows]
    G = grids["outer"].astype(float)
    mean_G = np.moveaxis(
        smooth_field_in_time(
            np.moveaxis(G, -1, 0), period_ms, strain_noise["strain_energy_inner"]["smoothing_ms"]
        ),
        0,
        -1,
    )
    for key, points in (
        ("strain_energy_inner_pct", G),
        ("strain_energy_inner_mean_position_pct", mean_G),
    ):
        s, theta = ph.window_coordinates(points)
        e[key] = median_pct(measured, grid_strain(ph.point("inner", s, theta, t))[0][:, rows])
    # each wall's energy against the model's at the outer nodes' own positions: its median
    # bias (issue 84: a square, lifted by the nodes' noise) and its nodes' 95 % bands
    s, theta = ph.window_coordinates(G)
    for w in ("outer", "inner"):
        measured = arr[f"strain_energy_{w}"][:, rows].astype(float)
        truth = grid_strain(ph.point(w, s, theta, t))[0][:, rows]
        scale = np.nanmedian(np.abs(truth))
        e[f"strain_energy_{w}_bias_pct"] = float(100 * np.nanmedian(measured - truth) / scale)
        e[f"strain_energy_{w}_p90_pct"] = float(
            100 * np.nanpercentile(np.abs(measured - truth), 90) / scale
        )
        e[f"strain_energy_{w}_bias_removed"] = strain_noise[f"strain_energy_{w}"].get(
            "bias_removed", np.nan
        )
        band = arr.get(f"strain_energy_{w}_band95")
        if band is not None:
            band = band[:, rows].astype(float)
            known = np.isfinite(measured - truth) & np.isfinite(band)
            inside = np.abs(measured - truth) <= band
            e[f"strain_energy_{w}_node_band_within_pct"] = float(100 * inside[known].mean())
            for phase, at in (("expanded", expanded), ("contracted", ~expanded)):
                e[f"strain_energy_{w}_node_band_within_{phase}_pct"] = float(
                    100 * inside[known & at].mean()
                )
            e[f"strain_energy_{w}_node_band_ratio_p95"] = float(
                np.nanpercentile(np.abs(measured - truth)[known] / band[known], 95)
            )
    return e


def strain_noise_errors(results: Path, noise_free: Path) -> dict[str, float]:
    """Each wall's strain energy against the same phantom's without noise (median
    |difference| over the median |energy without|: what the roughness alone does,
    the grid nodes' slow sliding along the wall included, which a truth at the nodes'
    mean positions hides), both strained against the same input frame, each with the
    sigma its run took (``strain_noise: smoothing_ms``; with "auto", the noisy run's
    larger sigma's bias is part of the difference); and the share oftimg reports
    (``summary.json: strain_noise``) over it."""
    runs = [
        (json.loads((r / "summary.json").read_text()), np.load(r / "grids.npz"))
        for r in (results, noise_free)
    ]
    (summ, grids), (summ_free, grids_free) = runs
    shift = summ["t0_frame"] - summ_free["t0_frame"]  # the same input frame first
    period_ms = summ["period_ms"]
    e = {}
    for w in ("outer", "inner"):
        sigma, sigma_free = (
            s["strain_noise"][f"strain_energy_{w}"]["smoothing_ms"] for s in (summ, summ_free)
        )
        energy = smoothed_strain(
            np.roll(grids[w].astype(float), shift, axis=2), period_ms, sigma, noise_seed=None
        )[0]
        free = smoothed_strain(grids_free[w].astype(float), period_ms, sigma_free, noise_seed=None)[
            0
        ]
        change = np.nanmedian(np.abs(energy - free)) / np.nanmedian(np.abs(free))
        e[f"strain_energy_{w}_vs_noise_free_pct"] = 100.0 * change
        e[f"strain_energy_{w}_noise_ratio"] = (
            summ["strain_noise"][f"strain_energy_{w}"]["error_share"] / change
        )
    return e


def summarise(errors: dict[str, dict[str, float]]) -> dict[str, dict]:
    """Per metric over the embryos: n, bias (median signed), median and worst |error|
    (NaN, as when no band is found, counts as worst)."""
    out = {}
    for key, unit, what in METRICS:
        x = np.array([e[key] for e in errors.values() if key in e])
        if len(x) == 0:
            continue
        found = x[np.isfinite(x)]
        worst = np.inf if len(found) < len(x) else float(np.abs(x).max())
        out[key] = {
            "unit": unit,
            "what": what,
            "n": len(x),
            "not_found": len(x) - len(found),
            "bias": float(np.median(found)) if len(found) else np.nan,
            "median_abs": float(np.median(np.abs(found))) if len(found) else np.nan,
            "worst_abs": worst,
        }
    return out


def print_table(title: str, table: dict[str, dict], n_embryos: int, frames: int) -> None:
    print(f"\n{n_embryos} phantoms of {frames} frames, {title}: error = measured - true")
    print(f"  {'metric':<56}{'unit':>5}{'bias':>9}{'median':>9}{'worst':>9}")
    for key, row in table.items():
        worst = "not found" if not np.isfinite(row["worst_abs"]) else f"{row['worst_abs']:9.2f}"
        print(
            f"  {row['what']:<56}{row['unit']:>5}{row['bias']:9.2f}"
            f"{row['median_abs']:9.2f}{worst:>9}"
        )


def _finite_or_none(x):
    """JSON has no NaN or infinity: null instead."""
    if isinstance(x, dict):
        return {k: _finite_or_none(v) for k, v in x.items()}
    if isinstance(x, float) and not np.isfinite(x):
        return None
    return x


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seeds", type=int, default=3, help="phantoms per group")
    ap.add_argument("--frames", type=int, default=195)
    ap.add_argument("--noise-mm", type=float, nargs="+", default=[0.0])
    ap.add_argument(
        "--map-positions",
        nargs="+",
        default=["rows"],
        choices=("rows", "fixed"),
        help="where the area maps' rows lie (oftimg run --map-positions)",
    )
    ap.add_argument(
        "--expand-change",
        type=float,
        default=0.0,
        help="change of the expansion share from inlet to outlet (0.2: 20 pp)",
    )
    ap.add_argument(
        "--ridge-smoothing-ms",
        default="auto",
        help="oftimg run --ridge-smoothing-ms: 'auto' or a sigma in ms",
    )
    ap.add_argument(
        "--vertices",
        type=int,
        default=None,
        help="mesh every frame with 0.75 to 1.25 times this many vertices (default: 4000-8000)",
    )
    ap.add_argument("--field-smoothing-ms", default="auto", help="oftimg run --field-smoothing-ms")
    ap.add_argument(
        "--strain-smoothing-ms", default="auto", help="oftimg run --strain-smoothing-ms"
    )
    ap.add_argument(
        "--labels",
        type=float,
        nargs=3,
        metavar=("DX", "DY", "DZ"),
        default=None,
        help="label phantoms of this voxel size (um), meshed by oftimg run, and "
        "beside them the same phantoms as meshes",
    )
    ap.add_argument(
        "--segmentation-noise",
        type=float,
        default=None,
        help="with --labels: share of boundary voxels flipped (default 0.05; with "
        "--probabilities: the SD of the noise on the log-probabilities, "
        "default 0.3)",
    )
    ap.add_argument(
        "--probabilities",
        action="store_true",
        help="with --labels: probability maps of that voxel size instead, alone",
    )
    ap.add_argument("--jobs", type=int, default=None)
    ap.add_argument(
        "--cache",
        type=Path,
        default=None,
        help="keep the phantoms here (default: a temporary folder)",
    )
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args()
    if args.seeds < 1 or args.frames < 5:
        ap.error("need --seeds >= 1 and --frames >= 5")
    if args.vertices is not None and args.vertices < 200:
        ap.error("need --vertices >= 200")
    smoothing = (
        args.ridge_smoothing_ms
        if args.ridge_smoothing_ms == "auto"
        else float(args.ridge_smoothing_ms)
    )
    with tempfile.TemporaryDirectory() as tmp:
        cache = args.cache or Path(tmp)
        report = {}
        noise_free = {}  # map positions -> the run without noise, if made
        for noise in sorted(args.noise_mm):
            changing = f"_expand{args.expand_change:+g}" if args.expand_change else ""
            sized = f"_{args.vertices}v" if args.vertices else ""
            name = f"accuracy_{args.frames}f_noise{noise:g}mm{changing}{sized}"
            kinds = [(name, {})]
            if args.labels:
                voxel = "x".join(f"{d:g}" for d in args.labels)
                seg = (
                    args.segmentation_noise
                    if args.segmentation_noise is not None
                    else NOISE["probabilities" if args.probabilities else "labels"]
                )
                kinds = [
                    (
                        f"{name}_labels{voxel}um_seg{seg:g}",
                        {"labels": args.labels, "segmentation_noise": seg},
                    ),
                    (f"{name}_bent", {"bent": True}),
                ]
                if args.probabilities:  # the maps alone: the rest is measured above
                    kinds = [
                        (
                            f"{name}_probabilities{voxel}um_logsd{seg:g}",
                            {
                                "labels": args.labels,
                                "probabilities": True,
                                "segmentation_noise": seg,
                            },
                        )
                    ]
            for (cohort_name, how), positions in (
                (k, p) for k in kinds for p in args.map_positions
            ):
                cohort = make_cohort(
                    cache / cohort_name,
                    args.seeds,
                    args.frames,
                    noise,
                    args.expand_change,
                    args.vertices,
                    **how,
                )
                kind = (
                    "probabilities"
                    if how.get("probabilities")
                    else "labels"
                    if "labels" in how
                    else "meshes, bent as labels"
                    if how
                    else "meshes"
                )
                results = Path(tmp) / f"results_{cohort_name}_{positions}"
                oftimg.run(
                    cohort,
                    results,
                    quiet=args.json,
                    jobs=args.jobs,
                    options={
                        "map_positions": positions,
                        "ridge_smoothing_ms": smoothing,
                        "field_smoothing_ms": args.field_smoothing_ms,
                        "strain_smoothing_ms": args.strain_smoothing_ms,
                    },
                )
                errors = {
                    d.name: embryo_errors(d, results / d.name)
                    for d in sorted(cohort.iterdir())
                    if (d / "truth.json").exists()
                }
                if noise == 0:
                    noise_free[positions] = results
                elif positions in noise_free:
                    for name, e in errors.items():
                        e.update(strain_noise_errors(results / name, noise_free[positions] / name))
                tables = {}
                for group in ("normal", "banded"):
                    tables[group] = summarise(
                        {k: e for k, e in errors.items() if k.startswith(group)}
                    )
                    if not args.json:
                        print_table(
                            f"{group} ({kind}), noise {noise * 1000:g} um, "
                            f"map rows: {positions}"
                            f"{changing and f', expansion share {args.expand_change:+g} along'}",
                            tables[group],
                            args.seeds,
                            args.frames,
                        )
                report[f"{cohort_name}_{positions}"] = {
                    "noise_mm": noise,
                    "input": kind,
                    "map_positions": positions,
                    "summary": tables,
                    "embryos": errors,
                }
            if args.labels and not args.probabilities:  # labels against the meshes
                for positions in args.map_positions:
                    runs = [Path(tmp) / f"results_{c}_{positions}" for c, _ in kinds]
                    against = {
                        d.name: pixel_differences(runs[0] / d.name, runs[1] / d.name)
                        for d in sorted(runs[0].iterdir())
                        if (d / "arrays.npz").exists()
                    }
                    report[f"labels_against_meshes_{positions}"] = against
                    if not args.json:
                        print(
                            "\nlabels against the same phantom as meshes, pixel by pixel: "
                            "median |labels - meshes| / median |meshes|, %"
                        )
                        for name, diffs in against.items():
                            print(
                                f"  {name}: " + ", ".join(f"{k} {v:.1f}" for k, v in diffs.items())
                            )
    if args.json:
        print(
            json.dumps(
                _finite_or_none(
                    {
                        "frames": args.frames,
                        "seeds": args.seeds,
                        "vertices": args.vertices,
                        "expand_change": args.expand_change,
                        "ridge_smoothing_ms": smoothing,
                        "runs": report,
                    }
                ),
                indent=1,
            )
        )


if __name__ == "__main__":
    main()
