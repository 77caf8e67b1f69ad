"""Pullbacks: the intensity volumes (the OCT images a segmentation came from) read
across the myocardium at every node of a grid finer than the analysis grid, so that
each frame's tissue texture becomes a (u, v) image: the input of texture tracking,
and what a lab looks at to see its tissue move.

The shell is the myocardium: at each (u, v) the segment from the outer wall's node
to the inner wall's (the inner grid is the outer one projected towards the axis, so
the segment runs about along the wall's normal), sampled at ``n_layers`` depths and
reduced to their mean and maximum. A dataset of one wall (a gut, a vessel) has no
inner wall: its shell runs along each node's normal across :data:`SHELL_MM`. Grids are ``(n_u, n_v, 3)`` mm, volumes ``(z, y,
x)``, voxel sizes ``(dx, dy, dz)`` and origins ``(x, y, z)`` mm. Functions of arrays;
the volumes are read by the caller.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np

from ..errors import InputError

LAYERS = 5  # depths sampled across the myocardium
SHELL_MM = (-0.01, 0.01)  # a wall alone: its shell along the outward normal, mm
MAX_REFINE = 6  # the fine grid's nodes per analysis grid step, at most


@dataclass(frozen=True)
class PullbackOptions:
    """How the intensity is pulled back: ``layers`` depths sampled across the shell;
    ``shell_um`` (inside, outside) the shell about a wall along its outward normal, um
    (the outer wall with an inner wall: the myocardium between them); ``walls`` the
    walls pulled back (the outer one always: texture tracking reads it)."""

    layers: int = LAYERS
    shell_um: tuple[float, float] = (1000 * SHELL_MM[0], 1000 * SHELL_MM[1])
    walls: tuple[str, ...] = ("outer",)

    def __post_init__(self):
        if not (isinstance(self.layers, int) and 1 <= self.layers <= 50):
            raise InputError(
                f"pullback layers must be a whole number in 1..50, found {self.layers!r}"
            )
        inside, outside = (tuple(self.shell_um) + (None, None))[:2]
        if not (
            len(tuple(self.shell_um)) == 2
            and all(np.isfinite([inside, outside]))
            and -1000 <= inside < outside <= 1000
        ):
            raise InputError(
                f"the pullback shell must be two offsets in um, inside < "
                f"outside, within 1 mm, found {self.shell_um!r}"
            )
        object.__setattr__(self, "shell_um", (float(inside), float(outside)))
        walls = tuple(self.walls)
        if not set(walls) <= {"outer", "inner", "lumen"}:
            raise InputError(f"pullback walls are outer, inner and lumen, found {walls!r}")
        object.__setattr__(
            self,
            "walls",
            tuple(w for w in ("outer", "inner", "lumen") if w in walls or w == "outer"),
        )

    def as_dict(self) -> dict:
        """As summary.json records it (lists, as JSON reads them back)."""
        return dict(asdict(self), shell_um=list(self.shell_um), walls=list(self.walls))


def refine_factors(grid: np.ndarray, voxel_mm, max_factor: int = MAX_REFINE) -> tuple[int, int]:
    """How many fine pixels per grid step around and along (at least 1, at most
    ``max_factor``) give about one pixel per voxel (the smallest side) on the grid
    ``(n_u, n_v, ..., 3)``: its median step around and along over the voxel."""
    step_u = np.nanmedian(np.linalg.norm(np.diff(grid, axis=0), axis=-1))
    step_v = np.nanmedian(np.linalg.norm(np.diff(grid, axis=1), axis=-1))
    voxel = float(np.min(voxel_mm))
    return tuple(int(np.clip(np.round(step / voxel), 1, max_factor)) for step in (step_u, step_v))


def refined(grid: np.ndarray, factor_u: int, factor_v: int) -> np.ndarray:
    """A grid ``(n_u, n_v, 3)`` on ``factor_u`` times as many nodes around (periodic)
    and ``(n_v - 1) factor_v + 1`` along, its first and last rows kept: cubic splines
    through the nodes, periodic around, so the fine nodes lie on the smooth surface
    the grid samples, not on its flat facets."""
    from scipy.interpolate import CubicSpline

    n_u, n_v = grid.shape[:2]
    closed = np.concatenate([grid, grid[:1]], axis=0)
    fine_u = CubicSpline(np.arange(n_u + 1), closed, axis=0, bc_type="periodic")(
        np.arange(n_u * factor_u) / factor_u
    )
    return CubicSpline(np.arange(n_v), fine_u, axis=1)(
        np.arange((n_v - 1) * factor_v + 1) / factor_v
    )


def sample_volume(volume: np.ndarray, points_mm: np.ndarray, voxel_mm, origin_mm) -> np.ndarray:
    """``volume (z, y, x)`` read at ``points_mm (..., 3)`` (x, y, z), trilinear; NaN
    outside the volume (the tissue there was not imaged)."""
    from scipy.ndimage import map_coordinates

    at = (np.asarray(points_mm, float) - np.asarray(origin_mm, float)) / np.asarray(voxel_mm)
    flat = at.reshape(-1, 3)[:, ::-1].T  # (z, y, x) rows
    values = map_coordinates(volume, flat, order=1, mode="nearest").astype(np.float32)
    outside = np.any((flat < -0.5) | (flat > np.array(volume.shape)[:, None] - 0.5), axis=0)
    values[outside] = np.nan
    return values.reshape(at.shape[:-1])


def shell_points(outer: np.ndarray, inner: np.ndarray, n_layers: int = LAYERS) -> np.ndarray:
    """Points ``(..., n_layers, 3)`` across the myocardium at each node: from the
    outer node to the inner one, at the layers' middles (depth (k + 1/2) / n)."""
    depth = (np.arange(n_layers) + 0.5) / n_layers
    return outer[..., None, :] + depth[:, None] * (inner - outer)[..., None, :]


def outward_normals(grid: np.ndarray) -> np.ndarray:
    """Unit normals ``(n_u, n_v, 3)`` of a grid ``(n_u, n_v, 3)`` (periodic around),
    turned away from each row's centroid."""
    along_u = np.roll(grid, -1, axis=0) - np.roll(grid, 1, axis=0)
    normal = np.cross(along_u, np.gradient(grid, axis=1))
    normal /= np.linalg.norm(normal, axis=-1, keepdims=True)
    out = grid - grid.mean(axis=0, keepdims=True)
    return normal * np.sign(np.sum(normal * out))


def normal_shell(grid: np.ndarray, shell_mm=SHELL_MM) -> tuple[np.ndarray, np.ndarray]:
    """The two faces ``(n_u, n_v, 3)`` of a shell about a wall's grid: each node moved
    along its outward normal by ``shell_mm`` (inner, outer offsets), outer face first,
    as :func:`pullback` takes the outer and inner walls."""
    normal = outward_normals(grid)
    return grid + shell_mm[1] * normal, grid + shell_mm[0] * normal


def pullback(
    volume: np.ndarray,
    outer: np.ndarray,
    inner: np.ndarray,
    voxel_mm,
    origin_mm,
    n_layers: int = LAYERS,
) -> tuple[np.ndarray, np.ndarray]:
    """One frame's myocardium pullback: the mean and the maximum ``(n_u, n_v)`` over
    its depths of ``volume`` at :func:`shell_points` of the (fine) grids ``outer`` and
    ``inner``; NaN where a depth lies outside the volume."""
    values = sample_volume(volume, shell_points(outer, inner, n_layers), voxel_mm, origin_mm)
    outside = np.isnan(values).any(axis=-1)
    with np.errstate(invalid="ignore"):
        mean, top = values.mean(axis=-1), values.max(axis=-1)
    mean[outside], top[outside] = np.nan, np.nan
    return mean, top
