"""The stages wired together for one dataset. Reads frames through the
:class:`~oftimg.io.dataset.Dataset` it is given and returns arrays; writes nothing."""

from __future__ import annotations

import time
import warnings
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path

import numpy as np

from .. import __version__
from ..errors import DatasetError, InputError, OftimgWarning
from ..memory import release_freed
from ..io.dataset import Dataset, check_enough_frames
from ..io.label_dataset import listed_files, meshing_notes
from ..image.cycle import (
    cycle_timing,
    resample_time,
    standout_frames,
    two_segment_warp,
    volume_change,
    wrap_step_ratio,
)
from .maps import analyse_area_maps
from ..image.kymograph import at_fixed_positions
from ..image.pca import contour_pca
from .pullback import PullbackOptions
from .texture_tracking import fallback_note, texture_match_note
from .tracking import follow, track_grid
from .wave_fronts import wave_fronts
from .fields import NOISY_FIELD_SHARE, NOISY_STRAIN_SHARE, shape_fields
from ..mesh.clip import clip_positions, clipped_grids
from ..mesh.grid import GridOptions, continuous_seam_ends, signed_thickness
from ..mesh.labels import MeshOptions
from ..mesh.sections import slab_thickness, volume_from_sections
from .radial_curvature import node_band_95, scale_chosen_curvature
from ..mesh.strain import surface_kinematics
from .per_frame import (
    frame_seam_candidates,
    process_frame,
    rough_mesh_steps,
    run_tasks,
    wall_pullbacks,
)
from .cushions import closed_map, cushion_measures
from .uncertainty import NODE_BAND_FACTORS, input_kind, wide_band_share, with_bands
from ..progress import FramePasses, Progress


# where the rows of the (v, t) area maps lie: at the grid rows, as in the paper (they
# drift along the tube as the surface's shape changes), or at fixed fractions of the
# centroid line's length in every frame
MAP_POSITIONS = ("rows", "fixed")
# how the grid follows the tissue from frame to frame: "none", each frame's own grid
# (the paper's); "material", each row turned with the tissue (oftimg.analysis.tracking);
# "texture", each node moved with the intensity's texture (oftimg.analysis.texture_tracking);
# "auto", texture where a dataset has intensity volumes, else material
TRACKING = ("auto", "material", "texture", "none")


@dataclass(frozen=True)
class PipelineOptions:
    """All options of a run (recorded in summary.json)."""

    grid: GridOptions = field(default_factory=GridOptions)
    warp: bool = False
    map_positions: str = "rows"
    ridge_smoothing_ms: float | str = "auto"
    field_smoothing_ms: float | str = "auto"
    strain_smoothing_ms: float | str = "auto"
    tracking: str = "auto"
    meshing: MeshOptions = field(default_factory=MeshOptions)  # of label datasets
    pullback: PullbackOptions = field(default_factory=PullbackOptions)  # with intensity/

    def __init__(
        self,
        grid: GridOptions | dict | None = None,
        *,
        warp: bool = False,
        map_positions: str = "rows",
        ridge_smoothing_ms: float | str = "auto",
        field_smoothing_ms: float | str = "auto",
        strain_smoothing_ms: float | str = "auto",
        tracking: str = "auto",
        meshing: MeshOptions | dict | None = None,
        pullback: PullbackOptions | dict | None = None,
        **grid_kwargs,
    ):
        if isinstance(pullback, dict):
            pullback = PullbackOptions(**pullback)
        object.__setattr__(self, "pullback", pullback or PullbackOptions())
        if isinstance(grid, dict):
            grid = GridOptions(**grid)
        if isinstance(meshing, dict):
            meshing = MeshOptions(**meshing)
        object.__setattr__(self, "meshing", meshing or MeshOptions())
        if tracking not in TRACKING:
            raise InputError(f"tracking must be one of {TRACKING}, found {tracking!r}")
        object.__setattr__(self, "tracking", tracking)
        if map_positions not in MAP_POSITIONS:
            raise InputError(
                f"map_positions must be one of {MAP_POSITIONS}, found {map_positions!r}"
            )
        if ridge_smoothing_ms != "auto":
            ridge_smoothing_ms = _sigma_ms(
                ridge_smoothing_ms,
                "ridge_smoothing_ms must be 'auto' or a number of ms >= 0 (0: none)",
            )
        if field_smoothing_ms != "auto":
            field_smoothing_ms = _sigma_ms(
                field_smoothing_ms,
                "field_smoothing_ms must be 'auto' or a number of ms >= 0 (0: none)",
            )
        object.__setattr__(self, "grid", grid or GridOptions(**grid_kwargs))
        object.__setattr__(self, "warp", bool(warp))
        object.__setattr__(self, "map_positions", map_positions)
        object.__setattr__(self, "ridge_smoothing_ms", ridge_smoothing_ms)
        object.__setattr__(self, "field_smoothing_ms", field_smoothing_ms)
        if strain_smoothing_ms != "auto":
            strain_smoothing_ms = _sigma_ms(
                strain_smoothing_ms,
                "strain_smoothing_ms must be 'auto' or a number of ms >= 0 (0: none)",
            )
        object.__setattr__(self, "strain_smoothing_ms", strain_smoothing_ms)

    def as_dict(self) -> dict:
        return {
            "grid": asdict(self.grid),
            "warp": self.warp,
            "map_positions": self.map_positions,
            "ridge_smoothing_ms": self.ridge_smoothing_ms,
            "field_smoothing_ms": self.field_smoothing_ms,
            "strain_smoothing_ms": self.strain_smoothing_ms,
            "tracking": self.tracking,
            "meshing": self.meshing.as_dict(),
            "pullback": self.pullback.as_dict(),
        }


def _sigma_ms(given, must: str) -> float:
    """``given`` as a smoothing sigma (ms, finite, >= 0); else InputError ``must``, found ..."""
    try:
        sigma = float(given)
    except (TypeError, ValueError):
        sigma = float("nan")
    if not 0 <= sigma < float("inf"):
        raise InputError(f"{must}, found {given!r}")
    return sigma


# the last-to-first step of the outer volume, over the largest step between frames,
# above which the frames may not be one whole cycle (one cycle: at most 1)
WRAP_STEP_WARN = 2.0


def check_series(ds: Dataset, volume: dict) -> dict:
    """Warn when the frames may not be one whole cycle, or a frame's volume stands out
    as a frame segmented wrongly does; ``volume``: wall -> ``(n_t,)`` mm^3 in input
    order. Returns what was found (for summary.json)."""
    ratio = wrap_step_ratio(volume["outer"])
    if ratio > WRAP_STEP_WARN:
        warnings.warn(
            f"{ds.path}: the outer volume steps {ratio:.1f} times more from the last "
            "frame back to the first than between any two consecutive frames; "
            "oftimg takes the frames as one whole cycle: do they cover exactly one "
            "(none missing or repeated at the ends)?",
            OftimgWarning,
            stacklevel=3,
        )
    standout = {}
    for wall, v in volume.items():
        odd = standout_frames(v, periodic=ratio <= WRAP_STEP_WARN)
        standout[wall] = [ds.frames[wall][t].name for t in odd]
        if len(odd):
            around = 0.5 * (np.roll(v, 1) + np.roll(v, -1))
            named = ", ".join(
                f"{ds.frames[wall][t].name} ({v[t] / around[t] - 1:+.1%} "
                "against its neighbours' mean)"
                for t in odd[:3]
            )
            warnings.warn(
                f"{ds.path / wall}: {len(odd)} frame(s) whose volume stands out of "
                f"its neighbours' as a frame segmented wrongly does: {named}"
                f"{' and more' if len(odd) > 3 else ''}; check them",
                OftimgWarning,
                stacklevel=3,
            )
    return {
        "wrap_step_ratio": round(ratio, 3),
        "one_cycle_warning": ratio > WRAP_STEP_WARN,
        "standout_frames": standout,
        "standout_frame_count": sum(len(names) for names in standout.values()),
    }


def seam_end_points(ds: Dataset, options: GridOptions, progress=None, executor=None):
    """Pass 1: the seam's end points ``(n_t, 3)`` each, continuous and smoothed in
    time (:func:`~oftimg.mesh.grid.continuous_seam_ends`), and how many frames' seams
    continue their neighbours' rather than their own shortest."""
    candidates = run_tasks(
        frame_seam_candidates,
        [
            (ds.frame(t), options.seam_method, options.rough_mesh_smoothing)
            for t in range(ds.n_frames)
        ],
        executor=executor,
        progress=progress,
    )
    p_in, p_out, chosen = continuous_seam_ends(candidates, options.seam_smoothing_frames)
    return p_in, p_out, int(chosen.sum())


def _retime(f, grid, area, contour, volume, per_row):
    """Apply ``f(array, time_axis)`` to every per-frame series of a dataset."""
    return (
        {w: f(g, 2) for w, g in grid.items()},
        {w: f(a, 1) for w, a in area.items()},
        {w: f(c, 2) for w, c in contour.items()},
        {w: f(v, 0) for w, v in volume.items()},
        {k: f(x, 1) for k, x in per_row.items()},
    )


def centroid_arc_length(centroid: np.ndarray) -> np.ndarray:
    """Arc length (mm) from the inlet along the centroid line, ``(n_v, n_t)``."""
    step = np.linalg.norm(np.diff(centroid, axis=0), axis=-1)
    step = np.where(np.isfinite(step), step, 0.0)
    return np.concatenate([np.zeros((1,) + step.shape[1:]), np.cumsum(step, axis=0)], axis=0)


def analyse_dataset(
    ds: Dataset,
    options: PipelineOptions,
    *,
    quiet: bool = False,
    executor=None,
    on_aligned=None,
    progress=None,
) -> dict:
    """All stages for one dataset. Returns ``summary``, ``arrays``, ``grids``, ``pca``.

    Every time axis of the result starts at the frame of minimum outer volume
    (``summary["t0_frame"]`` is its input index). The per-frame work runs in
    ``executor``'s workers when one is given; the temporally coupled steps
    (seam end-point smoothing, alignment, tracking, clipping) run here.
    ``on_aligned(arrays, grids)``, if given, is called as soon as the aligned
    times, area maps, grids and lumen mean curvature exist (before clipping,
    fields, image analysis and PCA), e.g. to start rendering videos; it must
    not change them. ``progress()``, if given, is called after each frame of
    each of the two per-frame passes (``2 n_t`` calls) instead of drawing a bar.
    """
    check_enough_frames(ds)
    timings = {}
    # 1. each frame on its own: seam, (u, v) map, grid, sections, curvature
    frames, seams_continued = _per_frame_passes(
        ds, options.grid, quiet=quiet, executor=executor, progress=progress, timings=timings
    )
    # 2. the cycle: t = 0 at minimum outer volume, every series stacked in that order
    volume_in_order = {w: np.array([f["volume"][w] for f in frames]) for w in frames[0]["grid"]}
    series_checks = check_series(ds, volume_in_order)
    timing = cycle_timing(volume_in_order["outer"], ds.meta.period_ms)
    t0 = timing["t0_frame"]
    st = _stack_frames(frames[t0:] + frames[:t0])
    del frames  # each frame's arrays, stacked: ~120 MB for 195 frames
    release_freed()  # which the heap would otherwise keep (oftimg.memory)
    _warn_about_frames(ds, st)
    _refuse_implausible(ds, st, t0)
    pullbacks = None
    if ds.intensity is not None:
        tick = time.perf_counter()
        pullbacks = wall_pullbacks(
            ds.intensity,
            st["grid"],
            [(t0 + k) % ds.n_frames for k in range(ds.n_frames)],
            options.pullback,
            executor=executor,
        )
        timings["pullbacks_s"] = time.perf_counter() - tick
    from_ring = {
        w: int(
            (
                (st["rows"][f"from_ring_{w}"] > 0)
                & ~(st["rows"].get("lumen_closed", 0.0) > 0.5 if w == "lumen" else False)
            ).sum()
        )
        for w in st["walls"]
    }
    # 3. the time axis (warped or not) and the per-row series on it
    t_frames, st = _time_axis(ds, options, st, timing, t0)
    if pullbacks is not None and options.warp:
        pullbacks = {k: resample_time(v, t_frames, axis=2) for k, v in pullbacks.items()}
    shut = _closed_lumen(st)
    arrays, maps, thickness = _section_arrays(ds, options, st, t_frames)
    grid, H, jelly = st["grid"], st["H"], st["jelly"]
    if H is not None and options.warp:
        H = resample_time(H, t_frames, axis=2)
    if H is not None and shut is not None:  # no curvature where there is no lumen
        H = np.where(shut[None, :, :, None], np.nan, H)
    # 4. the grid follows the tissue
    coords = None
    tracking = tracking_mode(ds, options.tracking, pullbacks is not None)
    if tracking != "none":
        tick = time.perf_counter()
        coords, tracked = track_grid(grid["outer"])
        tracked = {"kind": "material", **tracked}
        if tracking == "texture":  # the texture's motion beyond the shape's
            coords, texture = _texture_pathlines(pullbacks, coords)
            tracked = {**texture, "shape": tracked}
            arrays["texture_support"] = tracked.pop("support")
            arrays["texture_fallback"] = tracked.pop("fallback")
            for note in (
                texture_match_note(tracked["forward_backward_gap_steps"]["median"]),
                fallback_note(tracked["fallback_share"]),
            ):
                if note:
                    warnings.warn(f"{ds.path}: {note}", OftimgWarning, stacklevel=2)
            tracked["support_median"] = float(np.median(arrays["texture_support"]))
            arrays["grid_in_view"] = (coords[..., 1] >= 0) & (
                coords[..., 1] <= grid["outer"].shape[1] - 1
            )
        arrays["pathlines_uv"] = coords.astype(np.float32)
        grid = {w: follow(g, coords) for w, g in grid.items()}
        H = follow(H, coords) if H is not None else None
        jelly = follow(jelly, coords) if jelly is not None else None
        timings["tracking_s"] = time.perf_counter() - tick
    lumen_noise = None
    if H is not None:  # each scale's (n_u, n_v, n_t, n_scales): one chosen
        H, lumen_noise, node_sd, unresolved = scale_chosen_curvature(
            np.moveaxis(H, -1, 0),
            ds.meta.period_ms,
            options.field_smoothing_ms,
            st["vertex_spacing"]["lumen"],
            grid["lumen"],
        )
        arrays["mean_curvature_lumen_per_mm"] = H
        band = node_band_95(
            node_sd,
            unresolved,
            NODE_BAND_FACTORS[input_kind(ds.inputs_by_kind())]["mean_curvature_lumen"],
        )
        arrays["mean_curvature_lumen_band95_per_mm"] = band
        lumen_noise["band95_wide_share"] = wide_band_share(band, H)
    if on_aligned is not None:
        on_aligned(arrays, grid)
    summary = _cycle_summary(ds, timing, t0, arrays["s_mm"], options.warp)
    # 5. the myocardium's volume, and every grid clipped to its constant volume
    summary.update(_myocardium(ds, st, arrays, grid, thickness))
    release_freed()  # the clipping's working copies
    # 6. curvature, thickness and strain fields on the (u, v, t) grid
    tick = time.perf_counter()
    summary.update(_field_stage(ds, options, grid, st, H, lumen_noise, jelly, coords, arrays))
    release_freed()  # the strain noise's grid copies
    if "lumen" in st["walls"]:  # 6a. the cushions: the lumen's closure, ellipticity
        cushion_arrays, summary["cushions"] = cushion_measures(
            st["area"]["lumen"],
            st["contour"]["lumen"],
            st["rows"]["normal"],
            st["rows"]["centroid_lumen"],
            arrays["s_mm"],
            ds.meta.period_ms,
            jelly=arrays.get("jelly_thickness_mm"),
            inner_grid=grid.get("inner"),
        )
        arrays.update(cushion_arrays)
    if tracking == "texture":  # the tissue's motion within the surface
        speed, divergence = surface_kinematics(
            grid["outer"], arrays["principal_stretch_outer"], ds.meta.period_ms
        )
        arrays["surface_speed_outer_mm_s"] = speed.astype(np.float32)
        arrays["surface_divergence_outer_per_s"] = divergence.astype(np.float32)
        blank_out_of_view(arrays, grid["outer"].shape[:3])
    timings["fields_s"] = time.perf_counter() - tick
    # 6b. the wave's fronts on each wall: activation times, the velocity on the wall
    if not options.warp:  # a warped cycle's frames are not equal times
        tick = time.perf_counter()
        walls = {w: grid[w] for w in st["walls"]}
        wave_arrays, summary["wave_fronts"] = wave_fronts(walls, arrays["s_mm"], ds.meta.period_ms)
        arrays.update(wave_arrays)
        timings["wave_fronts_s"] = time.perf_counter() - tick
    # 7. the (v, t) area maps as images: derivatives, ridges, wave speeds, masks
    tick = time.perf_counter()
    map_arrays, map_summary = analyse_area_maps(
        maps, arrays["s_mm"], ds.meta.period_ms, ridge_smoothing_ms=options.ridge_smoothing_ms
    )
    timings["image_analysis_s"] = time.perf_counter() - tick
    for note in map_summary["image_analysis_notes"]:
        warnings.warn(f"{ds.path}: {note}", OftimgWarning, stacklevel=2)
    arrays.update(map_arrays)
    summary.update(map_summary)
    if not map_summary["area_wave"]:  # the areas all but constant: no beat to share out
        summary.update(
            dict.fromkeys(
                (
                    "expand_fraction",
                    "contract_fraction",
                    "expand_contract_ratio",
                    "expand_ms",
                    "contract_ms",
                )
            )
        )
    # 8. the cross-sections' shape modes at maximum expansion
    tick = time.perf_counter()
    n_t = ds.n_frames
    t_max = int(round((timing["t_max_frame"] - t0) % n_t)) if not options.warp else n_t // 2
    source = grid.get("outer_clipped", grid["outer"])
    pca = contour_pca(source, min(max(t_max, 2), n_t - 3))
    pca["summary"]["grid"] = "outer_clipped" if "outer_clipped" in grid else "outer"
    summary["pca"] = pca["summary"]
    timings["pca_s"] = time.perf_counter() - tick
    # 9. what was repaired, assumed and checked on the way
    summary.update(
        _quality_summary(
            st, seams_continued, series_checks, from_ring, tracked if coords is not None else None
        )
    )
    summary["section_volume_error"] = {
        w: float(
            np.median(
                np.abs(arrays[f"volume_from_sections_{w}_mm3"] / arrays[f"volume_{w}_mm3"] - 1)
            )
        )
        for w in st["walls"]
    }
    inputs = {
        kind: (
            {w: listed_files(p) for w, p in paths.items()}
            if isinstance(paths, dict)
            else listed_files(paths)
        )
        for kind, paths in ds.inputs_by_kind().items()
    }
    summary["provenance"] = {
        "oftimg_version": __version__,
        "options": options.as_dict(),
        "length_unit": ds.meta.length_unit,
        "voxel_size": (
            ds.labels["meshing"]["voxel_size"] if ds.labels is not None else ds.meta.voxel_size
        ),
        "dataset": {"path": str(Path(ds.path).resolve())},
        "inputs": inputs,
    }
    if ds.labels is not None:  # meshed from label volumes: those are the inputs
        summary["provenance"]["meshing"] = ds.labels["meshing"]
        for note in meshing_notes(ds.path, ds.labels["meshing"]):
            warnings.warn(note, OftimgWarning, stacklevel=2)
        kind = {"labels": "label volumes", "probabilities": "probability maps"}[
            ds.labels["meshing"].get("kind", "labels")
        ]
        warnings.warn(
            f"{ds.path}: curvature fields from {kind} are less exact than "
            "their areas, speeds and volumes: the voxels leave an error fixed in "
            "space, which the fields' noise share does not see (oftimg's "
            f"docs/accuracy.md, from {kind})",
            OftimgWarning,
            stacklevel=2,
        )
    if ds.lumen_bridged:  # meshes whose lumen the cushions closed, joined
        from ..io.lumen_closures import bridged_notes

        summary["provenance"]["lumen_bridged"] = ds.lumen_bridged
        for note in bridged_notes(ds.path, ds.lumen_bridged, ds.n_frames):
            warnings.warn(note, OftimgWarning, stacklevel=2)
    summary["timings_s"] = timings
    if pullbacks is not None:
        summary["pullbacks"] = {
            "shape_uvt": list(pullbacks["pullback_outer_mean"].shape),
            "shell": (
                "myocardium"
                if "inner" in grid
                else f"{options.pullback.shell_um[0]:g} to "
                f"{options.pullback.shell_um[1]:g} µm along the "
                "outer wall's normal"
            ),
            "in_view": float(np.isfinite(pullbacks["pullback_outer_mean"]).mean()),
            "layers": options.pullback.layers,
            "walls": sorted({k.split("_")[1] for k in pullbacks}),
        }
    return {
        "summary": summary,
        "arrays": arrays,
        "grids": grid,
        "pca": pca["arrays"],
        **({"pullbacks": pullbacks} if pullbacks is not None else {}),
    }


def blank_out_of_view(arrays: dict, shape_uvt: tuple) -> None:
    """NaN in every per-pixel field ``(n_u, n_v, n_t[, k])`` of ``arrays`` where the
    node's tissue has left the grid along the tube (not ``grid_in_view``), and one node
    along the tube beside it (a strain reads its neighbours): the grid holds such a
    node at the end row, where its values are not its tissue's. In place."""
    gone = ~arrays["grid_in_view"]
    out = gone.copy()
    out[:, 1:] |= gone[:, :-1]  # the rows beside it
    out[:, :-1] |= gone[:, 1:]
    for name, values in arrays.items():
        if (
            name not in ("grid_in_view", "pathlines_uv")
            and values.shape[:3] == shape_uvt
            and np.issubdtype(values.dtype, np.floating)
        ):
            values[out] = np.nan


def tracking_mode(ds: Dataset, asked: str, has_pullbacks: bool) -> str:
    """The tracking a dataset gets: ``asked``, with "auto" as texture where it has
    pullbacks (intensity volumes) and material elsewhere. Raises
    :class:`DatasetError` for texture without pullbacks."""
    if asked == "auto":
        return "texture" if has_pullbacks else "material"
    if asked == "texture" and not has_pullbacks:
        raise DatasetError(
            f"{ds.path}: --tracking texture follows the intensity volumes' "
            "texture: the dataset needs intensity/ (one volume per frame)"
        )
    return asked


def _texture_pathlines(pullbacks: dict, shape_coords: np.ndarray) -> tuple[np.ndarray, dict]:
    """:func:`~oftimg.analysis.texture_tracking.texture_pathlines` of the mean
    myocardium pullback beyond the shape's pathlines ``shape_coords (n_u, n_v, n_t,
    2)``."""
    from .texture_tracking import texture_pathlines

    mean = pullbacks["pullback_outer_mean"]
    n_u, n_v = shape_coords.shape[:2]
    factors = (mean.shape[0] // n_u, (mean.shape[1] - 1) // (n_v - 1))
    return texture_pathlines(mean, factors, shape_coords)


FRAME_PASSES = ("seams", "grids and sections")  # what each pass over the frames makes


def _per_frame_passes(
    ds: Dataset, opts: GridOptions, *, quiet, executor, progress, timings: dict
) -> tuple[list[dict], int]:
    """The two per-frame passes (seam end points, then everything else of a frame),
    in input order, and the number of frames whose seam was continued from their
    neighbours'. Adds their wall and CPU seconds to ``timings``."""
    n_t = ds.n_frames
    opts = replace(
        opts,
        rough_mesh_smoothing=rough_mesh_steps(
            [ds.frame(t) for t in sorted({0, n_t // 2, n_t - 1})], opts.rough_mesh_smoothing
        ),
    )
    with Progress(n_t, f"{ds.meta.name}", quiet=quiet or progress is not None) as bar:
        advance = progress or FramePasses(bar, FRAME_PASSES)
        tick = time.perf_counter()
        p_in, p_out, seams_continued = seam_end_points(
            ds, opts, progress=advance, executor=executor
        )
        timings["seam_end_points_s"] = time.perf_counter() - tick
        tick = time.perf_counter()
        frames = run_tasks(
            process_frame,
            [(ds.frame(t), p_in[t], p_out[t], opts) for t in range(n_t)],
            executor=executor,
            progress=advance,
        )
    timings["frames_s"] = time.perf_counter() - tick
    cpu = {}
    for f in frames:
        for k, v in f["cpu_s"].items():
            cpu[k] = cpu.get(k, 0.0) + v
    timings["frames_cpu_s"] = cpu
    return frames, seams_continued


def _stack_frames(frames: list[dict]) -> dict:
    """The per-frame results stacked along a time axis (grids ``(n_u, n_v, n_t, 3)``,
    areas and per-row series ``(n_v, n_t, ...)``, volumes ``(n_t,)``) and the
    per-frame counts summed."""
    walls = list(frames[0]["grid"])

    def optional(key):
        return np.stack([f[key] for f in frames], axis=2) if key in frames[0] else None

    return {
        "walls": walls,
        "n_t": len(frames),
        "grid": {w: np.stack([f["grid"][w] for f in frames], axis=2) for w in walls},
        "area": {w: np.stack([f["area"][w] for f in frames], axis=1) for w in walls},
        "contour": {w: np.stack([f["contour"][w] for f in frames], axis=2) for w in walls},
        "radial_curvature": {
            w: np.stack([f["radial_curvature"][w] for f in frames], axis=3)
            for w in frames[0]["radial_curvature"]
        },
        "vertex_spacing": {
            w: np.stack([f["vertex_spacing"][w] for f in frames], axis=1)
            for w in frames[0]["vertex_spacing"]
        },
        "volume": {w: np.array([f["volume"][w] for f in frames]) for w in walls},
        "rows": {
            "origin": np.stack([f["origins"] for f in frames], axis=1),
            "normal": np.stack([f["normals"] for f in frames], axis=1),
            "crossing": np.stack([f["crossing"] for f in frames], axis=1).astype(float),
            **{
                f"centroid_{w}": np.stack([f["centroid_" + w] for f in frames], axis=1)
                for w in walls
            },
            **{
                f"from_ring_{w}": np.stack([f["from_ring"][w] for f in frames], axis=1).astype(
                    float
                )
                for w in walls
            },
            **(
                {
                    "lumen_closed": np.stack(
                        [f["lumen_closed_rows"] for f in frames], axis=1
                    ).astype(float)
                }
                if "lumen_closed_rows" in frames[0]
                else {}
            ),
        },
        "H": optional("mean_curvature_lumen"),  # (n_u, n_v, n_t, n_scales)
        "jelly": optional("jelly_thickness"),  # (n_u, n_v, n_t)
        "flipped": {w: int(sum(f["flipped"][w] for f in frames)) for w in walls},
        "repaired": {w: int(sum(f["repaired"][w] for f in frames)) for w in walls},
        "smoothed": {w: int(sum(bool(f["smoothed"][w]) for f in frames)) for w in walls},
        "inner_closest": int(sum(f.get("inner_at_closest", 0) for f in frames)),
        "jelly_closest": int(sum(f.get("jelly_at_closest", 0) for f in frames)),
        "outside": {
            w: int(sum(f.get(f"{w}_outside", 0) for f in frames)) for w in ("inner", "lumen")
        },
        "plane_fixes": int(sum(f["plane_fixes"] for f in frames)),
    }


def _warn_about_frames(ds: Dataset, st: dict) -> None:
    """One warning per kind of trouble the per-frame work met, each naming the
    summary.json entry or array that counts it."""
    walls, n_t, volume = st["walls"], st["n_t"], st["volume"]
    crossing = st["rows"]["crossing"] > 0
    if crossing.any():
        warnings.warn(
            f"{ds.path}: {int(crossing.sum())} section planes still cross another "
            "inside the tube after blending (see plane_crossing)",
            OftimgWarning,
            stacklevel=3,
        )
    nested = [w for w in ("outer", "inner", "lumen") if w in walls]
    for out_w, in_w in zip(nested, nested[1:]):  # each wall inside the one before
        n_bad = int((volume[in_w] >= volume[out_w]).sum())
        if n_bad:
            warnings.warn(
                f"{ds.path}: the {in_w} wall encloses as much as the {out_w} one or "
                f"more in {n_bad} of {n_t} frames: are {in_w}/ and {out_w}/ swapped?",
                OftimgWarning,
                stacklevel=3,
            )
    for w in walls:
        from_ring = st["rows"][f"from_ring_{w}"] > 0
        if w == "lumen" and "lumen_closed" in st["rows"]:  # the bridge's sections: no lumen
            from_ring = from_ring & ~(st["rows"]["lumen_closed"] > 0.5)
        if from_ring.any():
            warnings.warn(
                f"{ds.path}: {int(from_ring.sum())} of {from_ring.size} {w} sections "
                "had no clean closed contour (none, or one merged with another part "
                "of the tube) and were measured on the grid ring projected onto the "
                f"plane (see section_from_ring_{w})",
                OftimgWarning,
                stacklevel=3,
            )
    for closest, wall, what in (
        (st["inner_closest"], "inner", "inner grid nodes"),
        (st["jelly_closest"], "lumen", "lines from the inner grid nodes"),
    ):
        if closest:
            warnings.warn(
                f"{ds.path}: {closest} {what} met no {wall} wall on the way to "
                "their row's centre and took the closest point (see "
                f"{'inner' if wall == 'inner' else 'jelly'}_nodes_at_closest_point)",
                OftimgWarning,
                stacklevel=3,
            )
    n_nodes = st["grid"]["outer"][..., 0].size
    for wall, out_wall, layer in (("inner", "outer", "wall"), ("lumen", "inner", "jelly")):
        if st["outside"][wall]:
            warnings.warn(
                f"{ds.path}: the {wall} wall lies outside the {out_wall} one at "
                f"{st['outside'][wall]} of {n_nodes} grid nodes over the "
                f"frames, where {layer}_thickness_mm is negative: do the "
                f"segmentations cross? (see {wall}_nodes_outside_{out_wall})",
                OftimgWarning,
                stacklevel=3,
            )
    if sum(st["flipped"].values()):
        warnings.warn(
            f"{ds.path}: {sum(st['flipped'].values())} flipped triangles in the "
            "(u, v) maps (the map is not one-to-one there)",
            OftimgWarning,
            stacklevel=3,
        )


def _refuse_implausible(ds: Dataset, st: dict, t0: int) -> None:
    """Stop with one :class:`DatasetError` when the stacked per-frame results (frames
    from ``t0`` on) cannot be right (:func:`~oftimg.analysis.plausibility.implausible`),
    before anything is written."""
    from .plausibility import implausible

    names = [ds.frames["outer"][(t0 + k) % st["n_t"]].name for k in range(st["n_t"])]
    grid = st["grid"]
    thickness = {}
    if "inner" in grid:
        thickness["inner"] = signed_thickness(
            grid["outer"], grid["inner"], grid["outer"].mean(axis=0)
        )
    if st["jelly"] is not None:
        thickness["lumen"] = st["jelly"]
    problems = implausible(st["volume"], thickness, frame_names=names)
    if problems:
        raise DatasetError(
            f"{ds.path}: results that cannot be right, so none are written: " + "; ".join(problems)
        )


def _time_axis(
    ds: Dataset, options: PipelineOptions, st: dict, timing: dict, t0: int
) -> tuple[np.ndarray, dict]:
    """The frames' times (in frames from t0) and the stacked series on them: with
    ``options.warp``, two segments (minimum volume at 0, maximum expansion at half
    the cycle) and every series resampled; else each frame where it was taken."""
    n_t = st["n_t"]
    if not options.warp:
        return np.arange(n_t, dtype=float), st
    t_frames = two_segment_warp(n_t, (timing["t_max_frame"] - t0) % n_t)
    grid, area, contour, volume, rows = _retime(
        lambda a, axis: resample_time(a, t_frames, axis=axis),
        st["grid"],
        st["area"],
        st["contour"],
        st["volume"],
        st["rows"],
    )
    rows["normal"] /= np.linalg.norm(rows["normal"], axis=-1, keepdims=True)
    jelly = resample_time(st["jelly"], t_frames, axis=2) if st["jelly"] is not None else None
    curvature = {w: resample_time(k, t_frames, axis=3) for w, k in st["radial_curvature"].items()}
    spacing = {w: resample_time(d, t_frames, axis=1) for w, d in st["vertex_spacing"].items()}
    return t_frames, {
        **st,
        "grid": grid,
        "area": area,
        "contour": contour,
        "volume": volume,
        "rows": rows,
        "jelly": jelly,
        "radial_curvature": curvature,
        "vertex_spacing": spacing,
    }


def _closed_lumen(st: dict) -> np.ndarray | None:
    """``(n_v, n_t)`` bool where the cushions close the lumen: its rows on the bridge a
    label dataset's meshing laid across, and its sections of at most
    :data:`~oftimg.analysis.cushions.LUMEN_CLOSED_SHARE` of their row's largest area;
    its area there set to 0 in ``st`` (the bridge's own section is no lumen). None
    without a lumen or a closure."""
    if "lumen" not in st["area"]:
        return None
    shut = closed_map(st["area"]["lumen"]) | (st["rows"].get("lumen_closed", 0.0) > 0.5)
    if not shut.any():
        return None
    st["area"]["lumen"] = np.where(shut, 0.0, st["area"]["lumen"])
    return shut


def _section_arrays(
    ds: Dataset, options: PipelineOptions, st: dict, t_frames: np.ndarray
) -> tuple[dict, dict, dict]:
    """The cross-sections' series as result arrays (positions, times, area maps,
    volumes, contours, planes), the area maps by wall (at the rows or at fixed
    positions) and each wall's slab thickness per section ``(n_v, n_t)`` mm."""
    walls, rows, area, volume = st["walls"], st["rows"], st["area"], st["volume"]
    normals = rows["normal"]
    thickness = {w: slab_thickness(rows[f"centroid_{w}"], normals) for w in walls}
    s_rows = centroid_arc_length(rows["centroid_outer"])  # (n_v, n_t)
    s_mm = s_rows.mean(axis=1)
    arrays = {"s_mm": s_mm, "t_ms": t_frames * ds.meta.period_ms / st["n_t"], "s_rows_mm": s_rows}
    maps = area
    if options.map_positions == "fixed":
        maps = {w: at_fixed_positions(area[w], s_rows, s_mm) for w in walls}
    for w in walls:
        arrays[f"area_{w}_mm2"] = maps[w]
        if options.map_positions == "fixed":
            arrays[f"area_rows_{w}_mm2"] = area[w]
        arrays[f"volume_{w}_mm3"] = volume[w]
        arrays[f"contour_{w}_mm"] = st["contour"][w].astype(np.float32)
        arrays[f"volume_from_sections_{w}_mm3"] = volume_from_sections(area[w], thickness[w])
        arrays[f"section_from_ring_{w}"] = rows[f"from_ring_{w}"] > 0
    if "inner" in walls and "lumen" in walls:  # the cardiac jelly between them
        arrays["area_jelly_mm2"] = maps["inner"] - maps["lumen"]
        arrays["volume_jelly_mm3"] = volume["inner"] - volume["lumen"]
    arrays["centroid_outer_mm"] = rows["centroid_outer"]
    arrays["plane_origin_mm"] = rows["origin"]
    arrays["plane_normal"] = normals
    arrays["plane_crossing"] = rows["crossing"] > 0  # after a warp: any blended frame crossed
    return arrays, maps, thickness


def _cycle_summary(ds: Dataset, timing: dict, t0: int, s_mm: np.ndarray, warp: bool) -> dict:
    """The dataset's name and group and the cycle's timing (summary.json)."""
    n_t = ds.n_frames
    return {
        "name": ds.meta.name,
        "group": ds.meta.group,
        "n_frames": n_t,
        "period_ms": ds.meta.period_ms,
        "period_from": ds.meta.period_from,
        "t0_frame": t0,
        "time_warp": warp,
        "expand_fraction": timing["expand_fraction"],
        "contract_fraction": timing["contract_fraction"],
        "expand_contract_ratio": timing["expand_contract_ratio"],
        "expand_ms": timing["expand_ms"],
        "contract_ms": timing["contract_ms"],
        "tube_length_mm": float(s_mm[-1]),
        "t_max_volume_ms": ((timing["t_max_frame"] - t0) % n_t) * ds.meta.period_ms / n_t,
    }


def _myocardium(ds: Dataset, st: dict, arrays: dict, grid: dict, thickness: dict) -> dict:
    """The jelly's and the myocardium's volume change over the cycle; with an inner
    wall, the clip position of constant myocardial volume in every frame and each
    wall's grid clipped there (``grid["<wall>_clipped"]``). Adds to ``arrays`` and
    ``grid``; returns the summary's entries."""
    summary = {}
    n_t, walls, volume, area = st["n_t"], st["walls"], st["volume"], st["area"]
    if "volume_jelly_mm3" in arrays:
        summary["jelly_volume_change"] = volume_change(arrays["volume_jelly_mm3"])
        crossed = int(np.count_nonzero(arrays["volume_jelly_mm3"] <= 0))
        if crossed:
            warnings.warn(
                f"{ds.path}: the lumen holds as much as the inner wall or more in "
                f"{crossed} of {n_t} frames (walls crossing?): jelly_volume_change "
                "is NaN",
                OftimgWarning,
                stacklevel=3,
            )
    if "inner" not in walls:
        return summary
    myo = volume["outer"] - volume["inner"]
    arrays["volume_myocardium_mm3"] = myo
    summary["myocardial_volume_change"] = volume_change(myo)
    clip_v, target = clip_positions(area["outer"] - area["inner"], thickness["outer"])
    s_rows = arrays["s_rows_mm"]
    n_v = len(arrays["s_mm"])
    arrays["clip_v"] = clip_v
    arrays["trim_percent"] = 100.0 * np.array(
        [
            np.interp(v * (n_v - 1), np.arange(n_v), s_rows[:, t]) / s_rows[-1, t]
            for t, v in enumerate(clip_v)
        ]
    )
    summary["clipped_myocardial_volume_mm3"] = target
    grid.update(
        clipped_grids(
            {w: grid[w] for w in walls}, st["rows"]["origin"], st["rows"]["normal"], clip_v
        )
    )
    return summary


def _field_stage(
    ds: Dataset,
    options: PipelineOptions,
    grid: dict,
    st: dict,
    H,
    lumen_noise,
    jelly,
    coords,
    arrays: dict,
) -> dict:
    """:func:`shape_fields` on the (tracked) grids, its arrays added to ``arrays``;
    returns its summary entries with the smoothing taken for each field, and warns
    of each field that is mostly noise."""
    fields = shape_fields(
        grid,
        st["contour"],
        st["rows"]["normal"],
        st["area"],
        H,
        ds.meta.period_ms,
        options.field_smoothing_ms,
        lumen_smoothed_ms=lumen_noise["smoothing_ms"] if H is not None else 0.0,
        strain_smoothing_ms=options.strain_smoothing_ms,
        jelly_thickness=jelly,
        coords=coords,
        radial_curvature=st.get("radial_curvature"),
        vertex_spacing=st.get("vertex_spacing"),
        kind=input_kind(ds.inputs_by_kind()),
    )
    arrays.update(fields.pop("arrays"))
    if H is not None:
        fields["field_noise"]["mean_curvature_lumen_per_mm"] = lumen_noise
    fields["field_noise"] = with_bands(fields["field_noise"], input_kind(ds.inputs_by_kind()))
    # the sigma taken for each curvature and thickness field ("auto": as much as its noise asks)
    fields["field_smoothing_ms"] = {
        name: noise["smoothing_ms"] for name, noise in fields["field_noise"].items()
    }
    # and for each strain field ("auto": as much as its nodes' noise asks)
    fields["strain_smoothing_ms"] = {
        name: noise["smoothing_ms"] for name, noise in fields["strain_noise"].items()
    }
    for name, noise in fields["field_noise"].items():
        if noise["noise_share"] > NOISY_FIELD_SHARE:
            warnings.warn(
                f"{ds.path}: {name} is mostly noise: after {noise['smoothing_ms']:g} ms of "
                f"smoothing, {100 * noise['noise_share']:.0f} % of each pixel's variance over "
                "the cycle is frame-to-frame noise (median pixel; summary.json: field_noise), "
                "so its per-pixel normalised video and phase maps show noise more than the "
                "beat; smoother surfaces, finer meshes or a larger --field-smoothing-ms help "
                "(oftimg's docs/accuracy.md)",
                OftimgWarning,
                stacklevel=3,
            )
    for name, noise in fields["strain_noise"].items():
        if noise["error_share"] > NOISY_STRAIN_SHARE:
            warnings.warn(
                f"{ds.path}: {name} is noisy: its grid nodes move by "
                f"{1000 * noise['node_noise_mm']:.1f} µm from frame to frame (median), which "
                f"after {noise['smoothing_ms']:g} ms of smoothing alone changes the energy by "
                f"{100 * noise['error_share']:.0f} % of its median size (summary.json: "
                "strain_noise); a square, it is biased up; smoother surfaces, finer meshes "
                "or a larger --strain-smoothing-ms help (oftimg's docs/accuracy.md)",
                OftimgWarning,
                stacklevel=3,
            )
    return fields


def _quality_summary(
    st: dict, seams_continued: int, series_checks: dict, from_ring: dict, tracked: dict | None
) -> dict:
    """The summary's counts of what was repaired, assumed or could not be done."""
    return {
        "flipped_triangles": st["flipped"],
        "maps_with_clamped_weights": st["repaired"],
        "frames_smoothed_as_rough": st["smoothed"],
        "inner_nodes_at_closest_point": st["inner_closest"],
        "jelly_nodes_at_closest_point": st["jelly_closest"],
        "inner_nodes_outside_outer": st["outside"]["inner"],
        "lumen_nodes_outside_inner": st["outside"]["lumen"],
        "seam_frames_continued": seams_continued,
        "tracking": {"grid": "tracked", **tracked}
        if tracked is not None
        else {"grid": "per-frame"},
        "section_plane_fixes": st["plane_fixes"],
        "section_planes_still_crossing": int((st["rows"]["crossing"] > 0).sum()),
        "frame_series_checks": series_checks,
        "sections_from_ring": from_ring,
    }
