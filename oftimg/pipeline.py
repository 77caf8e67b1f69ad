"""The stages wired together for one dataset. Reads frames through the
:class:`~oftimg.io.Dataset` it is given and returns arrays; writes nothing."""
from __future__ import annotations

import time
import warnings
from dataclasses import asdict, dataclass, field

import numpy as np

from . import __version__
from .io import Dataset, OftimgWarning
from .mesh.grid import (GridOptions, closest_points, grid_frame, seam_endpoints,
                        smooth_endpoints)
from .progress import Progress


@dataclass(frozen=True)
class PipelineOptions:
    """All options of a run (recorded in summary.json)."""

    grid: GridOptions = field(default_factory=GridOptions)

    def __init__(self, grid: GridOptions | dict | None = None, **grid_kwargs):
        if isinstance(grid, dict):
            grid = GridOptions(**grid)
        object.__setattr__(self, "grid", grid or GridOptions(**grid_kwargs))

    def as_dict(self) -> dict:
        return {"grid": asdict(self.grid)}


@dataclass
class WallGrids:
    """Deforming grid of one wall: ``X (n_u, n_v, n_t, 3)`` mm, input time order."""

    X: np.ndarray
    seam_length_mm: np.ndarray
    flipped: np.ndarray
    seam_in: np.ndarray
    seam_out: np.ndarray


def _stack(frames) -> WallGrids:
    return WallGrids(
        X=np.stack([g.X for g in frames], axis=2),
        seam_length_mm=np.array([g.seam_length_mm for g in frames]),
        flipped=np.array([g.flipped for g in frames]),
        seam_in=np.stack([g.seam_in for g in frames]),
        seam_out=np.stack([g.seam_out for g in frames]),
    )


def parameterize_dataset(ds: Dataset, options: GridOptions, *, quiet: bool = False
                         ) -> dict[str, WallGrids]:
    """Grids of every wall of ``ds`` (paper section 4.1).

    Outer wall: per-frame shortest seam, end points smoothed in time,
    geodesic between the smoothed points, Desbrun map, even grid. Inner wall:
    closest-point projection of the outer grid. Lumen: its own map, its seam
    joining the outer seam's end points projected onto its loops.
    """
    n_t = ds.n_frames
    bar = Progress(n_t * (1 + len(ds.surfaces)), f"{ds.meta.name}: grids", quiet=quiet)
    p_in = np.empty((n_t, 3))
    p_out = np.empty((n_t, 3))
    for t in range(n_t):
        tb = ds.tube("outer", t)
        p_in[t], p_out[t], _ = seam_endpoints(tb.V, tb.F, tb.inlet, tb.outlet,
                                              method=options.seam_method)
        bar.advance()
    p_in = smooth_endpoints(p_in, options.seam_smoothing_frames)
    p_out = smooth_endpoints(p_out, options.seam_smoothing_frames)
    outer = []
    for t in range(n_t):
        tb = ds.tube("outer", t)
        outer.append(grid_frame(tb.V, tb.F, tb.inlet, tb.outlet, p_in[t], p_out[t], options))
        bar.advance()
    grids = {"outer": _stack(outer)}
    if "inner" in ds.surfaces:
        X = np.empty_like(grids["outer"].X)
        for t in range(n_t):
            tb = ds.tube("inner", t)
            X[:, :, t] = closest_points(tb.V, tb.F, grids["outer"].X[:, :, t])
            bar.advance()
        grids["inner"] = WallGrids(X=X, seam_length_mm=grids["outer"].seam_length_mm * np.nan,
                                   flipped=np.zeros(n_t, int), seam_in=X[0, 0].copy(),
                                   seam_out=X[0, -1].copy())
    if "lumen" in ds.surfaces:
        lumen = []
        for t in range(n_t):
            tb = ds.tube("lumen", t)
            lumen.append(grid_frame(tb.V, tb.F, tb.inlet, tb.outlet,
                                    grids["outer"].seam_in[t], grids["outer"].seam_out[t],
                                    options))
            bar.advance()
        grids["lumen"] = _stack(lumen)
    bar.close()
    n_flipped = sum(int(g.flipped.sum()) for g in grids.values())
    if n_flipped:
        warnings.warn(f"{ds.path}: {n_flipped} flipped triangles in the (u, v) maps "
                      "(the map is not one-to-one there)", OftimgWarning, stacklevel=2)
    return grids


def analyse_dataset(ds: Dataset, options: PipelineOptions, *, quiet: bool = False) -> dict:
    """All stages for one dataset; returns ``summary``, ``grids``, ``timings``."""
    timings = {}
    t0 = time.perf_counter()
    grids = parameterize_dataset(ds, options.grid, quiet=quiet)
    timings["parameterize_s"] = time.perf_counter() - t0
    summary = {
        "name": ds.meta.name, "group": ds.meta.group, "n_frames": ds.n_frames,
        "period_ms": ds.meta.period_ms,
        "flipped_triangles": {w: int(g.flipped.sum()) for w, g in grids.items()},
        "provenance": {
            "oftimg_version": __version__, "options": options.as_dict(),
            "inputs": {s: [{"file": str(p), "bytes": p.stat().st_size} for p in files]
                       for s, files in ds.frames.items()},
        },
        "timings_s": timings,
    }
    return {"summary": summary, "grids": grids}
