"""How close the lumen's mean curvature from a label volume comes to the truth, by the
way the surface and its curvature are made (issue 60, the choice of method).

    python scripts/label_curvature.py [--group normal] [--frames 5] [--voxel 4 4 8] [--radial]

One frame in every 195/--frames of the bench phantom, rasterized as the label phantom
is (with its segmentation noise, and without), and as partial-volume fractions (the
phantom rasterized at half the voxel size and averaged: a noise-free probability map).
For each way, at every vertex of the lumen's surface away from the window's ends:
median |H - H_true| / median |H_true| and the correlation with the truth, per frame
(no smoothing in time, unlike the run's fields), and the seconds it takes. The
phantom's own mesh gives the floor of this measure (a mesh's curvature is noisier
than the smooth model). Prints one row per way.

With ``--radial``: the radial curvature of the outer and inner walls instead, on 17
cross-sections square to the phantom's centre line (10-90 % of its length), 80 points
each as the run resamples them: from the label mesh's section contour (as the run
takes it, Savitzky-Golay windows of 7, 9 and 11 points) and from the curvature of the
blurred mask's level curves within the section plane (smoothed around the contour
alike), against the phantom's own mesh taken the same way.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from oftimg.io.label_dataset import DEFAULT_LABEL_IDS as LABELS
from oftimg.mesh.curvature import contour_curvature, fill_boundary, vertex_mean_curvature
from oftimg.mesh.labels import MeshOptions, mesh_wall, wall_masks
from oftimg.mesh.level_set import level_set_derivatives, level_set_mean_curvature
from oftimg.mesh.sections import contour_around, orient_and_resample, plane_contours
from oftimg.mesh.topology import boundary_loops
from oftimg.synthetic.labels import LabelGrid, label_params, segmentation_noise
from oftimg.synthetic.phantom import Phantom, sample_params


def mesh_curvature(V: np.ndarray, F: np.ndarray) -> np.ndarray:
    """Vertex mean curvature (1/length unit), as the run takes it from a lumen mesh."""
    rim = np.concatenate(boundary_loops(F))
    return fill_boundary(vertex_mean_curvature(V, F, rim), F, rim)


def partial_volume(phantom: Phantom, voxel_xyz, t_ms: float) -> tuple[np.ndarray, LabelGrid]:
    """The lumen's share of each voxel (2 x 2 x 2 samples), and the fine grid whose
    frame its voxel centres are in (offset by half a fine voxel, handled by the caller)."""
    fine = LabelGrid(phantom, tuple(d / 2 for d in voxel_xyz))
    lumen = (fine.labels(t_ms) == LABELS["lumen"]).astype(np.float32)
    n = np.array(lumen.shape) // 2
    blocks = lumen[: 2 * n[0], : 2 * n[1], : 2 * n[2]].reshape(n[0], 2, n[1], 2, n[2], 2)
    return blocks.mean(axis=(1, 3, 5)), fine


def errors(
    phantom: Phantom, grid: LabelGrid, points_um: np.ndarray, H_per_um: np.ndarray, t_ms: float
) -> tuple[float, float]:
    """(median |error| / median |truth|, correlation) at points (x, y, z) um of ``grid``."""
    X = (points_um * 1e-3 - grid.shift) @ grid.turn.T
    s, theta = phantom.window_coordinates(X)
    true = phantom.mean_curvature("lumen", s, theta, t_ms)
    keep = (s > 0.05 * phantom.p.length_mm) & (s < 0.95 * phantom.p.length_mm)
    H = H_per_um[keep] * 1e3
    r = np.corrcoef(H, true[keep])[0, 1]
    H = np.sign(r) * H  # the mesh's normals: outward; the model's sign
    return (float(np.median(np.abs(H - true[keep])) / np.median(np.abs(true[keep]))), float(abs(r)))


def level_curve_curvature(
    mask: np.ndarray, voxel_xyz, points_um: np.ndarray, normal: np.ndarray, sigma_um: float
) -> np.ndarray:
    """Curvature (1/um, positive where convex) of the blurred mask's level curves within
    the plane of ``normal``, at ``points_um (n, 3)``: the 2-D form of the mean curvature,
    from the gradient and Hessian projected onto the plane."""
    g, hessian = level_set_derivatives(mask, voxel_xyz, points_um, sigma_um)
    m = normal / np.linalg.norm(normal)
    P = np.eye(3) - np.outer(m, m)
    g, hessian = g @ P, P @ hessian @ P
    g2 = np.einsum("ni,ni->n", g, g)
    div = g2 * np.trace(hessian, axis1=1, axis2=2) - np.einsum("ni,nij,nj->n", g, hessian, g)
    return -div / g2**1.5


def radial_error(
    phantom: Phantom,
    grid: LabelGrid,
    V_um: np.ndarray,
    F: np.ndarray,
    wall: str,
    t_ms: float,
    window: int,
    mask: np.ndarray | None = None,
    sigma_um: float = 0.0,
) -> float:
    """Median |error| / median |truth| of the radial curvature on 17 sections of the mesh
    ``(V_um, F)`` in ``grid``'s frame: the contour's (Savitzky-Golay, ``window``
    points), or with ``mask`` its level curves' smoothed around the contour alike."""
    from scipy.signal import savgol_filter

    found, truth = [], []
    for s in np.linspace(0.1, 0.9, 17) * phantom.p.length_mm:
        centre, _, _ = phantom.frame_axes(s)
        a = phantom.alpha0 + s / phantom.p.bend_radius_mm
        origin = centre @ grid.turn + grid.shift  # mm
        normal = np.array([-np.sin(a), np.cos(a), 0.0]) @ grid.turn  # along the tube
        C = contour_around(plane_contours(V_um * 1e-3, F, origin, normal), origin, normal)
        C = orient_and_resample(C, normal, C[0], 80)
        if mask is None:
            k = contour_curvature(C, normal, window=window)
        else:
            k = savgol_filter(
                level_curve_curvature(mask, grid.voxel_mm * 1e3, C * 1e3, normal, sigma_um) * 1e3,
                window,
                2,
                mode="wrap",
            )
        s_c, theta = phantom.window_coordinates((C - grid.shift) @ grid.turn.T)
        found.append(k)
        truth.append(phantom.section_curvature(wall, s_c, theta, t_ms))
    k, true = np.concatenate(found), np.concatenate(truth)
    k *= np.sign(np.corrcoef(k, true)[0, 1])  # the contour's sense: the model's sign
    return float(np.median(np.abs(k - true)) / np.median(np.abs(true)))


def radial(phantom: Phantom, grid: LabelGrid, frames: int) -> None:
    """The ``--radial`` table: one row per wall and way, the mean over the frames."""
    rng = np.random.default_rng(0)
    rows: dict[str, list] = {}
    for t in phantom.frame_times_ms()[:: max(195 // frames, 1)][:frames]:
        masks = wall_masks(segmentation_noise(grid.labels(t), 0.05, rng), LABELS)
        for wall in ("outer", "inner"):
            V_mm, F = phantom.mesh(wall, t, rng)
            own = (V_mm @ grid.turn + grid.shift) * 1e3
            mesh = mesh_wall(
                masks[wall], tuple(grid.voxel_mm * 1e3), MeshOptions(lumen_curvature_blur=0.0)
            )
            for window in (7, 9, 11):
                rows.setdefault(f"{wall}: the phantom's own mesh, window {window}", []).append(
                    radial_error(phantom, grid, own, F, wall, t, window)
                )
                rows.setdefault(f"{wall}: label mesh, window {window}", []).append(
                    radial_error(phantom, grid, mesh.V, mesh.F, wall, t, window)
                )
            for sigma in (8.0, 12.0, 16.0):
                rows.setdefault(f"{wall}: level curves, sigma {sigma:g} um, window 11", []).append(
                    radial_error(phantom, grid, mesh.V, mesh.F, wall, t, 11, masks[wall], sigma)
                )
    print(f"radial curvature, {frames} frames, noisy labels: median |error| / median |truth|")
    for name, values in rows.items():
        print(f"  {name:50s} {100 * np.mean(values):5.1f} %")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--group", default="normal", choices=["normal", "banded"])
    ap.add_argument("--frames", type=int, default=5)
    ap.add_argument("--voxel", type=float, nargs=3, default=(4.0, 4.0, 8.0))
    ap.add_argument(
        "--radial", action="store_true", help="the outer and inner walls' radial curvature instead"
    )
    ap.add_argument(
        "--no-partial-volume",
        action="store_true",
        help="labels only (the partial volumes take 8 grids: 23 GB at 2 x 2 x 4 um)",
    )
    args = ap.parse_args()
    voxel = tuple(args.voxel)
    phantom = Phantom(label_params(sample_params(args.group, 0, n_frames=195)))
    grid = LabelGrid(phantom, voxel)
    if args.radial:
        return radial(phantom, grid, args.frames)
    rng = np.random.default_rng(0)
    rows: dict[str, list] = {}

    def add(name, grid_, points, H, seconds):
        rows.setdefault(name, []).append((*errors(phantom, grid_, points, H, t), seconds))

    for t in phantom.frame_times_ms()[:: max(195 // args.frames, 1)][: args.frames]:
        V_mm, F = phantom.mesh("lumen", t, rng)
        add(
            "the phantom's own mesh (floor)",
            grid,
            (V_mm @ grid.turn + grid.shift) * 1e3,
            mesh_curvature(V_mm, F) * 1e-3,
            0.0,
        )
        clean = grid.labels(t) == LABELS["lumen"]
        noisy = wall_masks(segmentation_noise(grid.labels(t), 0.05, rng), LABELS)["lumen"]
        for name, mask in (("labels, noise-free", clean), ("labels, noisy", noisy)):
            for how, options in (
                ("mesh (today)", MeshOptions()),
                ("mesh, 16000 vertices", MeshOptions(target_vertices=16000)),
                ("mesh, blur 1 voxel", MeshOptions(smoothing=1.0)),
            ):
                tick = time.perf_counter()
                wall = mesh_wall(mask, voxel, options)
                add(
                    f"{name}: {how}",
                    grid,
                    wall.V,
                    mesh_curvature(wall.V, wall.F),
                    time.perf_counter() - tick,
                )
            wall = mesh_wall(mask, voxel, MeshOptions(lumen_curvature_blur=0.0))
            for sigma in (5.0, 8.0, 10.0, 12.0, 16.0):
                tick = time.perf_counter()
                H = level_set_mean_curvature(mask, voxel, wall.V, sigma)
                add(
                    f"{name}: level sets, sigma {sigma:g} um",
                    grid,
                    wall.V,
                    H,
                    time.perf_counter() - tick,
                )
        if args.no_partial_volume:
            continue
        share, fine = partial_volume(phantom, voxel, t)
        offset = np.array(voxel) / 4  # a block's centre, in the fine frame
        wall = mesh_wall(share, voxel, MeshOptions(lumen_curvature_blur=0.0))
        add("partial volume: mesh", fine, wall.V + offset, mesh_curvature(wall.V, wall.F), 0.0)
        for sigma in (5.0, 8.0, 12.0):
            add(
                f"partial volume: level sets, sigma {sigma:g} um",
                fine,
                wall.V + offset,
                level_set_mean_curvature(share, voxel, wall.V, sigma),
                0.0,
            )
    print(
        f"lumen mean curvature, {args.group} phantom, {voxel} um voxels, "
        f"{args.frames} frames: median |error| / median |truth|, correlation, seconds"
    )
    for name, values in rows.items():
        v = np.mean(values, axis=0)
        print(f"  {name:45s} {100 * v[0]:5.1f} %  r {v[1]:.2f}  {v[2]:.2f} s")


if __name__ == "__main__":
    main()
