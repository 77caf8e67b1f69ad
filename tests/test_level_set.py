"""The lumen's mean curvature from a label volume's level sets (issue 60): analytic
shapes, the label phantom's truth against the mesh's own curvature, and the value
stored with each vertex read back by the run."""

import numpy as np
import pytest

from oftimg.io.dataset import Frame
from oftimg.io.label_dataset import DEFAULT_LABEL_IDS
from oftimg.io.meshfile import read_vertex_values, write_ply
from oftimg.io.tube import load_tube
from oftimg.mesh.curvature import fill_boundary, vertex_mean_curvature
from oftimg.mesh.labels import CURVATURE_PROPERTY, MeshOptions, mesh_wall, wall_masks
from oftimg.mesh.level_set import level_set_mean_curvature
from oftimg.mesh.topology import boundary_loops


def cylinder(radius_um, voxel_xyz, shape=(24, 80, 80), axis="z"):
    """A solid cylinder of ``radius_um`` through the volume's middle along ``axis``."""
    k, j, i = np.indices(shape).astype(float)
    x, y, z = i * voxel_xyz[0], j * voxel_xyz[1], k * voxel_xyz[2]
    cx, cy, cz = [(n - 1) / 2 * d for n, d in zip(shape[::-1], voxel_xyz)]
    if axis == "z":
        return np.hypot(x - cx, y - cy) < radius_um
    return np.hypot(y - cy, z - cz) < radius_um


@pytest.mark.parametrize(
    "radius, voxel, axis",
    [(20.0, (2.0, 2.0, 2.0), "z"), (40.0, (2.0, 2.0, 2.0), "z"), (30.0, (2.0, 2.0, 4.0), "x")],
)
def test_a_cylinder_reads_one_over_twice_its_radius(radius, voxel, axis):
    """Right in the median with the default blur (2 voxels), and vertex by vertex
    within a third with 3 voxels: at 2 the voxels' staircase still shows in the second
    derivatives (measured: 17-38 % median |error| a vertex, 3-11 % at 3 voxels)."""
    shape = (24, 80, 80) if axis == "z" else (40, 80, 40)
    mask = cylinder(radius, voxel, shape, axis)
    for blur, median_within in ((MeshOptions().lumen_curvature_blur, 0.08), (3.0, 0.07)):
        wall = mesh_wall(mask, voxel, MeshOptions(lumen_curvature_blur=blur), curvature=True)
        away = np.ones(len(wall.V), bool)
        away[np.concatenate(boundary_loops(wall.F))] = False
        ratio = wall.mean_curvature[away] * 2 * radius
        assert abs(np.median(ratio) - 1) < median_within, (blur, np.median(ratio))
    assert np.percentile(np.abs(ratio - 1), 90) < 0.35


def test_a_ball_reads_one_over_its_radius_wherever_the_volume_starts():
    """A ball of 20 voxels: right within 3 % with a blur of 6 voxels; at 3 its poles read
    0.67 of the truth (a voxelised sphere is flat there over about sqrt(R) voxels, and
    a blur must reach past that flat facet), elsewhere 1.01."""
    k, j, i = np.indices((80, 80, 80)) * 1.0
    ball = np.sqrt((i - 40) ** 2 + (j - 40) ** 2 + (k - 40) ** 2) < 20
    points = 40 + 20 * np.array([[1.0, 0, 0], [0, 1.0, 0], [0, 0, -1.0], [0.6, 0.8, 0]])
    H = level_set_mean_curvature(ball, (1.0, 1.0, 1.0), points, 6.0)
    assert np.allclose(H, 1 / 20, rtol=0.03), H * 20
    moved = level_set_mean_curvature(
        ball, (1.0, 1.0, 1.0), points + 100, 6.0, origin_xyz=(100, 100, 100)
    )
    assert np.allclose(moved, H)
    facets = level_set_mean_curvature(ball, (1.0, 1.0, 1.0), points, 3.0) * 20
    assert np.all(facets[:3] < 0.75) and abs(facets[3] - 1) < 0.03


def test_on_the_label_phantom_the_level_sets_beat_the_mesh():
    """One frame of the label phantom at 4 x 4 x 8 um with segmentation noise: the
    level sets' curvature at the lumen's vertices is nearer the truth than the
    mesh's own (measured: 36 % and 52 % median error, scripts/label_curvature.py)."""
    from oftimg.synthetic.labels import LabelGrid, label_params, segmentation_noise
    from oftimg.synthetic.phantom import Phantom, sample_params

    phantom = Phantom(label_params(sample_params("normal", 0, n_frames=195)))
    grid = LabelGrid(phantom, (4.0, 4.0, 8.0))
    t = phantom.frame_times_ms()[80]
    labels = segmentation_noise(grid.labels(t), 0.05, np.random.default_rng(1))
    wall = mesh_wall(
        wall_masks(labels, DEFAULT_LABEL_IDS)["lumen"], (4.0, 4.0, 8.0), curvature=True
    )
    s, theta = phantom.window_coordinates((wall.V * 1e-3 - grid.shift) @ grid.turn.T)
    inside = (s > 0.05 * phantom.p.length_mm) & (s < 0.95 * phantom.p.length_mm)
    true = phantom.mean_curvature("lumen", s, theta, t)[inside]
    rim = np.concatenate(boundary_loops(wall.F))
    from_mesh = fill_boundary(vertex_mean_curvature(wall.V, wall.F, rim), wall.F, rim)

    def error(H_per_um):
        return np.median(np.abs(H_per_um[inside] * 1e3 - true)) / np.median(np.abs(true))

    assert error(wall.mean_curvature) < 0.8 * error(from_mesh)
    assert error(wall.mean_curvature) < 0.4


def test_the_stored_curvature_is_read_back_at_the_tubes_vertices(tmp_path):
    """Written with each vertex in the file's unit, read back per mm at the tube's
    vertices, though the reading merged a duplicate vertex (the order changes)."""
    z, y, x = np.indices((20, 30, 30))
    wall = mesh_wall(np.hypot(y - 15, x - 15) < 8, (10.0, 10.0, 10.0), curvature=True)
    V = np.concatenate([wall.V[:1], wall.V])  # vertex 0 twice, the first unused
    F = wall.F + 1
    H = np.concatenate([wall.mean_curvature[:1], wall.mean_curvature])
    path = tmp_path / "f0.ply"
    write_ply(path, V, F, {CURVATURE_PROPERTY: H})
    assert np.allclose(read_vertex_values(path, CURVATURE_PROPERTY), H, rtol=1e-6)
    frame = Frame({"lumen": str(path)}, 1e-3, (0.0, 0.0, 0.0))
    tube = load_tube(path, unit_scale=1e-3, warn=False)
    assert len(tube.V) == len(wall.V)
    stored = frame.stored_mean_curvature("lumen", tube)
    assert np.allclose(stored, wall.mean_curvature * 1e3, rtol=1e-5)
    write_ply(path, wall.V, wall.F)  # a plain mesh: none stored
    assert frame.stored_mean_curvature("lumen", load_tube(path, unit_scale=1e-3)) is None


def test_the_curvature_blur_is_checked():
    with pytest.raises(Exception, match="lumen curvature's blur must lie in 0..20 voxels"):
        MeshOptions(lumen_curvature_blur=-1.0)
    z, y, x = np.indices((20, 30, 30))
    plain = mesh_wall(
        np.hypot(y - 15, x - 15) < 8,
        (10.0, 10.0, 10.0),
        MeshOptions(lumen_curvature_blur=0.0),
        curvature=True,
    )
    assert plain.mean_curvature is None


def test_the_derivatives_are_scipys_gaussian_derivatives_with_the_border_continued():
    """At voxel centres, near the volume's faces and beyond them, the gradient and
    Hessian are scipy's Gaussian derivatives of the volume with its border voxels
    continued (``mode="nearest"``), in length units; a point far outside reads what
    one just outside the same face does (the border continued)."""
    from scipy import ndimage

    from oftimg.mesh.level_set import level_set_derivatives

    rng = np.random.default_rng(3)
    field = ndimage.gaussian_filter(rng.random((16, 20, 24)), 1.5).astype(np.float32)
    size_xyz = (2.0, 3.0, 4.0)
    sigma = 8.0  # 2-4 voxels: the kernels' tails negligible
    sig = np.sqrt((sigma / np.array(size_xyz[::-1])) ** 2 + 1 / 6)  # voxels, (z, y, x)
    kji = np.array([[0, 0, 0], [15, 19, 23], [5, 0, 7], [2, 9, 23], [8, 10, 12]])
    points = kji[:, ::-1] * np.array(size_xyz)
    gradient, hessian = level_set_derivatives(field, size_xyz, points, sigma)
    length = np.array(size_xyz[::-1])
    for axis in range(3):  # z, y, x; the gradient is (x, y, z)
        order = [0, 0, 0]
        order[axis] = 1
        d = (
            ndimage.gaussian_filter(
                field.astype(float), sig, order=order, mode="nearest", truncate=4.0
            )
            / length[axis]
        )
        assert np.allclose(gradient[:, 2 - axis], d[tuple(kji.T)], rtol=1e-3, atol=1e-5)
        for other in range(3):
            order = [0, 0, 0]
            order[axis] += 1
            order[other] += 1
            d = ndimage.gaussian_filter(
                field.astype(float), sig, order=order, mode="nearest", truncate=4.0
            ) / (length[axis] * length[other])
            assert np.allclose(
                hessian[:, 2 - axis, 2 - other], d[tuple(kji.T)], rtol=1e-3, atol=1e-5
            )
    beyond = np.array([[-100.0, 20.0, 30.0], [-1000.0, 20.0, 30.0]])
    far = level_set_derivatives(field, size_xyz, beyond, sigma)
    assert np.array_equal(far[0][0], far[0][1]) and np.array_equal(far[1][0], far[1][1])
