"""The work on one time frame, run in worker processes (its grids and sections, its
intensity pulled back), and :func:`run_tasks`, which hands the frames out.

Kept apart from :mod:`oftimg.analysis.pipeline` so that a worker imports only the mesh
modules: the image analysis pulls in scipy.signal, about 1 s of start-up.
"""

from __future__ import annotations

import time
import warnings
from dataclasses import replace

import numpy as np

from ..errors import DatasetError
from ..io.dataset import Frame
from ..io.tube import Tube
from ..mesh.curvature import (
    across_section_terms,
    smoothing_steps,
    steps_for_roughness,
    taubin_smooth,
    vertex_roughness,
)
from ..mesh.grid import (
    GridOptions,
    SeamCandidates,
    grid_frame,
    project_towards_axis,
    seam_candidates,
    signed_thickness,
)
from ..mesh.sections import fix_crossing_planes, section_planes, sections_of_mesh
from ..mesh.topology import MeshError, capped_signed_volume
from .pullback import PullbackOptions, normal_shell, pullback, refine_factors, refined


class _Clock:
    """Adds the seconds spent in ``with clock("stage"):`` blocks to a dict."""

    def __init__(self, totals: dict):
        self.totals = totals
        self.stage = None

    def __call__(self, stage: str):
        self.stage = stage
        return self

    def __enter__(self):
        self.start = time.perf_counter()

    def __exit__(self, *exc):
        self.totals[self.stage] = (
            self.totals.get(self.stage, 0.0) + time.perf_counter() - self.start
        )


def with_warnings(fn, *args):
    """``(fn(*args), the warnings it raised)``, each distinct warning once: run in a
    worker process, for the main process to raise them again (through its own
    filters, format and log)."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        result = fn(*args)
    return result, list({(type(w.message), str(w.message)): w.message for w in caught}.values())


def run_tasks(fn, arg_tuples: list[tuple], *, executor=None, progress=None) -> list:
    """``[fn(*args) for args in arg_tuples]``, in worker processes when an
    ``executor`` (any ``concurrent.futures.Executor``) is given; results in order.
    The workers' warnings are raised here, each distinct one once."""
    if executor is None:
        out = []
        for args in arg_tuples:
            out.append(fn(*args))
            if progress:
                progress()
        return out
    from concurrent.futures import as_completed

    futures = {executor.submit(with_warnings, fn, *args): k for k, args in enumerate(arg_tuples)}
    out = [None] * len(futures)
    seen = set()
    for fut in as_completed(futures):
        out[futures[fut]], raised = fut.result()
        for message in raised:
            if (type(message), str(message)) not in seen:
                seen.add((type(message), str(message)))
                warnings.warn(message, stacklevel=2)
        if progress:
            progress()
    return out


def _named(tube, fn, *args, **kwargs):
    """Run ``fn``; a mesh problem is reported with the frame's file name."""
    try:
        return fn(*args, **kwargs)
    except MeshError as exc:
        raise DatasetError(f"{tube.source}: {exc}") from None


def rough_mesh_steps(frames: list[Frame], setting: int | str) -> dict[str, int]:
    """Taubin steps for each wall of a dataset, one number for all its frames (each
    frame's mesh is made on its own, and a wall smoothed in some frames only would
    change from frame to frame by the smoothing): ``setting`` when a number; for
    "auto", :func:`~oftimg.mesh.curvature.steps_for_roughness` of the median roughness of
    ``frames`` (the first, middle and last are enough: a segmentation's roughness does
    not change with the beat)."""
    walls = frames[0].surfaces
    if setting != "auto":
        return {w: int(setting) for w in walls}
    steps = {}
    for wall in walls:
        rough = [vertex_roughness(t.V, t.F) for t in (f.tube(wall) for f in frames)]
        steps[wall] = steps_for_roughness(float(np.median([sigma / edge for sigma, edge in rough])))
    return steps


def measured_tube(frame: Frame, wall: str, options: GridOptions) -> tuple[Tube, int]:
    """The frame's ``wall`` as it is measured: Taubin-smoothed (its rims held) by
    ``options.rough_mesh_smoothing`` steps (a number, or wall -> number:
    :func:`rough_mesh_steps`; "auto": as this mesh's own roughness asks), and the
    steps taken."""
    tube = frame.tube(wall)
    setting = options.rough_mesh_smoothing
    steps = (
        setting.get(wall, 0)
        if isinstance(setting, dict)
        else smoothing_steps(tube.V, tube.F, setting)
    )
    if steps:
        rim = np.concatenate([tube.inlet, tube.outlet])
        tube = replace(tube, V=taubin_smooth(tube.V, tube.F, steps, fixed=rim))
    return tube, steps


def process_frame(frame: Frame, p_in: np.ndarray, p_out: np.ndarray, options: GridOptions) -> dict:
    """Everything that needs one frame's meshes, for all walls at once.

    Grids (paper section 4.1), section planes through G(0, v), G(1/3, v),
    G(2/3, v) made non-crossing, each wall's section areas and contours on its
    original mesh, each wall's capped volume, the lumen's mean curvature, the
    cardiac jelly's thickness at each inner grid node (on along the line from the
    outer node to the lumen; negative where the lumen lies outside the inner wall),
    how many inner (lumen) nodes lie outside the outer (inner) wall.
    ``out["cpu_s"]`` holds the seconds spent per stage.
    """
    n_c = options.n_u
    out = {
        "flipped": {},
        "area": {},
        "contour": {},
        "volume": {},
        "grid": {},
        "repaired": {},
        "from_ring": {},
        "cpu_s": {},
        "smoothed": {},
        "radial_curvature": {},
        "vertex_spacing": {},
    }
    clock = _Clock(out["cpu_s"])
    with clock("load"):
        tb, out["smoothed"]["outer"] = measured_tube(frame, "outer", options)
    with clock("grid"):
        g = _named(tb, grid_frame, tb.V, tb.F, tb.inlet, tb.outlet, p_in, p_out, options)
    X = g.X
    with clock("sections"):
        origins, normals = section_planes(X)
        normals, fixes, crossing = fix_crossing_planes(X, origins, normals)
    out.update(
        origins=origins,
        normals=normals,
        plane_fixes=fixes,
        crossing=crossing,
        seam_in=g.seam_in,
        seam_out=g.seam_out,
        seam_length_mm=g.seam_length_mm,
    )
    walls = {"outer": (tb, X, g)}
    if "inner" in frame.surfaces:
        with clock("load"):
            ti, out["smoothed"]["inner"] = measured_tube(frame, "inner", options)
        with clock("grid"):
            Xi, out["inner_at_closest"] = project_towards_axis(ti.V, ti.F, ti.inlet, ti.outlet, X)
            out["inner_outside"] = int((signed_thickness(X, Xi, X.mean(axis=0)) < 0).sum())
            walls["inner"] = (ti, Xi, None)
    if "lumen" in frame.surfaces:
        with clock("load"):
            tl, out["smoothed"]["lumen"] = measured_tube(frame, "lumen", options)
        with clock("fields"):  # a label volume's meshing stores it from its level sets
            stored = frame.stored_mean_curvature("lumen", tl)
        with clock("grid"):
            gl = _named(
                tl,
                grid_frame,
                tl.V,
                tl.F,
                tl.inlet,
                tl.outlet,
                g.seam_in,
                g.seam_out,
                options,
                values=stored,
            )
        walls["lumen"] = (tl, gl.X, gl)
        with clock("grid"):  # rows on the bridge laid across where the lumen is closed
            out["lumen_closed_rows"] = closed_rows(frame.stored_closed("lumen", tl), tl.V, gl.X)
        if stored is not None:  # one scale: the level sets' own
            out["mean_curvature_lumen"] = gl.values[:, :, None].astype(np.float32)
        if "inner" in walls:
            with clock("grid"):  # the cardiac jelly: inner node on along its line to the lumen
                Xj, out["jelly_at_closest"] = project_towards_axis(
                    tl.V,
                    tl.F,
                    tl.inlet,
                    tl.outlet,
                    walls["inner"][1],
                    centre=X.mean(axis=0),
                    uncounted_rows=out["lumen_closed_rows"],
                )
                out["jelly_thickness"] = signed_thickness(walls["inner"][1], Xj, X.mean(axis=0))
                out["lumen_outside"] = int((out["jelly_thickness"] < 0).sum())
    for wall, (tube, Xw, gw) in walls.items():
        with clock("sections"):
            lumen = wall == "lumen"
            area, centroid, contour, from_ring, kappa, spacing = sections_of_mesh(
                tube.V,
                tube.F,
                origins,
                normals,
                Xw,
                n_c,
                curvature=True,
                curvature_at=Xw if lumen and "mean_curvature_lumen" not in out else None,
            )
        out["vertex_spacing"][wall] = spacing
        if not lumen:  # (n_scales, n_u, n_v): chosen over the frames
            out["radial_curvature"][wall] = kappa.astype(np.float32)
        elif "mean_curvature_lumen" not in out:  # (a label volume's: its level sets'
            with clock("fields"):  # stored; its polygons' spacing kept)
                out["mean_curvature_lumen"] = lumen_mean_curvature(kappa, Xw, normals)
        out["grid"][wall] = Xw
        out["flipped"][wall] = gw.flipped if gw else 0
        out["repaired"][wall] = int(bool(gw and gw.flipped_before_repair))
        out["area"][wall] = area
        out["from_ring"][wall] = from_ring
        out["centroid_" + wall] = centroid
        out["contour"][wall] = contour
        with clock("volumes"):
            out["volume"][wall] = capped_signed_volume(tube.V, tube.F, [tube.inlet, tube.outlet])
    return out


def closed_rows(flags: np.ndarray | None, V: np.ndarray, X: np.ndarray) -> np.ndarray:
    """``(n_v,)`` bool: the rows of the lumen grid ``X (n_u, n_v, 3)`` most of whose
    nodes lie on the bridge across a closed lumen (``flags (n_vert,)`` at the mesh's
    vertices ``V``, each node taking its nearest vertex's); all False without flags."""
    if flags is None or not flags.any():
        return np.zeros(X.shape[1], bool)
    from scipy.spatial import cKDTree

    _, nearest = cKDTree(V).query(X.reshape(-1, 3))
    return flags[nearest].reshape(X.shape[:2]).mean(axis=0) > 0.5


def frame_seam_candidates(
    frame: Frame, method: str, rough_mesh_smoothing: int | str | dict = 0
) -> SeamCandidates:
    """The ends of the frame's shortest inlet-to-outlet geodesic and the seam
    lengths from every loop point (:func:`~oftimg.mesh.grid.seam_candidates`), on the
    outer wall as it is measured (``rough_mesh_smoothing``: :func:`measured_tube`)."""
    tb, _ = measured_tube(frame, "outer", GridOptions(rough_mesh_smoothing=rough_mesh_smoothing))
    return _named(tb, seam_candidates, tb.V, tb.F, tb.inlet, tb.outlet, method=method)


# the normal curvature across the sections is averaged over this many grid rows' SD along
# the tube and nodes' round it (a second derivative along the grid's rows, several um
# of each frame's roughness in it; a tube's shape changes slowly along it)
ACROSS_ROWS, ACROSS_NODES = 3.0, 1.0


def lumen_mean_curvature(kappa: np.ndarray, X: np.ndarray, plane_normals: np.ndarray) -> np.ndarray:
    """The lumen's mean curvature ``(n_u, n_v, n_scales)`` 1/mm, float32, at its grid's
    nodes ``X (n_u, n_v, 3)`` mm: half the sum of its sections' normal curvature, their
    polygons' curvature at each scale ``kappa (n_scales, n_u, n_v)`` read at the nodes
    times Meusnier's factor, and the normal curvature across the sections
    (:func:`~oftimg.mesh.curvature.across_section_terms`, averaged over
    :data:`ACROSS_ROWS` and :data:`ACROSS_NODES`). A fold of the lumen runs along the
    tube: round the section it needs the polygon's own resolution, as a corner does."""
    from scipy.ndimage import gaussian_filter

    meusnier, across = across_section_terms(X, plane_normals)
    across = gaussian_filter(
        np.nan_to_num(across), (ACROSS_NODES, ACROSS_ROWS), mode=("wrap", "nearest")
    )
    return (0.5 * (kappa * meusnier[None] + across[None])).transpose(1, 2, 0).astype(np.float32)


def wall_pullbacks(
    series,
    grids: dict,
    frames: list[int],
    options: PullbackOptions = PullbackOptions(),
    *,
    executor=None,
) -> dict[str, np.ndarray]:
    """The intensity pulled back onto each wall of ``options.walls`` that ``grids``
    (wall -> ``(n_u, n_v, n_t, 3)`` mm, each frame's own) has, at ``options.layers``
    depths: the outer wall's across the myocardium (to the inner wall; without one,
    across ``options.shell_um`` about it), the inner wall's and the lumen's across
    ``options.shell_um`` about them along their outward normals; on a grid finer than
    the analysis grid (:func:`~oftimg.analysis.pullback.refine_factors`: about a pixel
    a voxel): ``pullback_<wall>_mean`` and ``_max`` ``(n_u f_u, (n_v - 1) f_v + 1,
    n_t)`` float32, NaN where the shell leaves the imaged volume. Each frame's volume
    ``series.volume(frames[k])`` is read and sampled by :func:`frame_pullback` in
    ``executor``'s workers when one is given (one volume a worker in memory)."""
    walls = [w for w in options.walls if w in grids]
    factors = refine_factors(grids["outer"], series.voxel_size_mm)
    per_frame = run_tasks(
        frame_pullback,
        [
            (series, t, {w: g[:, :, k] for w, g in grids.items()}, factors, options)
            for k, t in enumerate(frames)
        ],
        executor=executor,
    )
    return {
        f"pullback_{w}_{what}": np.stack([f[w][j] for f in per_frame], axis=2, dtype=np.float32)
        for w in walls
        for j, what in enumerate(("mean", "max"))
    }


def frame_pullback(
    series, t: int, grids: dict, factors: tuple[int, int], options: PullbackOptions
) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """One frame's pullbacks (see :func:`wall_pullbacks`): wall -> (mean, max)
    ``(n_u f_u, (n_v - 1) f_v + 1)`` float32 from volume ``series.volume(t)`` and the
    frame's grids (wall -> ``(n_u, n_v, 3)`` mm) refined by ``factors``."""
    volume = series.volume(t)
    shell_mm = tuple(d / 1000 for d in options.shell_um)
    out = {}
    for w in (w for w in options.walls if w in grids):
        fine = refined(grids[w], *factors)
        faces = (
            (fine, refined(grids["inner"], *factors))
            if w == "outer" and "inner" in grids
            else normal_shell(fine, shell_mm)
        )
        out[w] = pullback(volume, *faces, series.voxel_size_mm, series.origin_mm, options.layers)
    return out
