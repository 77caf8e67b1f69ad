"""Shape fields with analytic answers (issue 7)."""

import numpy as np
import pytest

from helpers import tube_mesh
from oftimg.image.normalize import (
    field_noise,
    per_pixel_normalize,
    phase_maps,
    smooth_field_in_time,
)
from oftimg.mesh.curvature import (
    contour_curvature,
    count_corners,
    mixed_areas,
    taubin_smooth,
    vertex_mean_curvature,
)
from oftimg.mesh.parameterize import corner_terms
from oftimg.mesh.strain import grid_strain, grid_triangles
from oftimg.mesh.topology import check_tube
from oftimg.analysis.fields import thickness_by_row, thickness_summary

Z = np.array([0.0, 0.0, 1.0])


def even_ellipse(a, b, n=400):
    """Ellipse points evenly spaced by arc length (counter-clockwise about +z)."""
    th = np.linspace(0, 2 * np.pi, 20000, endpoint=False)
    P = np.stack([a * np.cos(th), b * np.sin(th)], -1)
    s = np.concatenate(
        [[0], np.cumsum(np.linalg.norm(np.diff(np.vstack([P, P[:1]]), axis=0), axis=1))]
    )
    target = np.linspace(0, s[-1], n, endpoint=False)
    th_even = np.interp(target, s, np.concatenate([th, [2 * np.pi]]))
    return np.stack([a * np.cos(th_even), b * np.sin(th_even), np.zeros(n)], -1), th_even


def test_circle_curvature():
    r = 0.15
    th = np.linspace(0, 2 * np.pi, 80, endpoint=False)
    C = np.stack([r * np.cos(th), r * np.sin(th), np.zeros_like(th)], -1)
    k = contour_curvature(C, Z)
    assert np.allclose(k, 1 / r, rtol=0.01)
    assert np.allclose(contour_curvature(C[::-1], Z), -1 / r, rtol=0.01)  # turning the other way


def test_ellipse_curvature():
    a, b = 0.2, 0.1
    C, th = even_ellipse(a, b, 200)
    k = contour_curvature(C, Z)
    exact = a * b / (a**2 * np.sin(th) ** 2 + b**2 * np.cos(th) ** 2) ** 1.5
    assert np.allclose(k, exact, rtol=0.03)


def test_curvature_is_stable_under_noise():
    r = 0.15
    th = np.linspace(0, 2 * np.pi, 80, endpoint=False)
    rng = np.random.default_rng(0)
    C = np.stack([r * np.cos(th), r * np.sin(th), np.zeros_like(th)], -1)
    C[:, :2] += rng.normal(0, 2e-4, (80, 2))  # 0.2 um noise on a 150 um circle
    assert np.median(np.abs(contour_curvature(C, Z) * r - 1)) < 0.1


def test_corner_count():
    th = np.linspace(0, 2 * np.pi, 120, endpoint=False)
    for k in (3, 4, 5):
        r = 0.1 * (1 + 0.08 * np.cos(k * th) + 0.03 * np.cos(2 * th))
        C = np.stack([r * np.cos(th), r * np.sin(th), np.zeros_like(th)], -1)
        assert count_corners(contour_curvature(C, Z)) == k


def five_frames_curvature(r_of_theta, roughness: float, seed: int, n: int = 80):
    """The curvature round a contour ``r_of_theta(theta)`` (mm) averaged over 5 frames,
    each with its own radial noise of ``roughness`` of 0.1 mm at ``n`` points, as the
    run averages the frames around each row's maximum contraction before it counts
    corners."""
    th = np.linspace(0, 2 * np.pi, n, endpoint=False)
    frames = []
    for f in range(5):
        r = r_of_theta(th) + 0.1 * np.random.default_rng([seed, f]).normal(0, roughness, n)
        frames.append(
            contour_curvature(np.stack([r * np.cos(th), r * np.sin(th), np.zeros_like(th)], -1), Z)
        )
    return np.mean(frames, axis=0)


def test_corner_count_under_segmentation_roughness():
    """1.5 % radial noise at 80 points (1.5 um on a 0.1 mm section), 5 frames averaged
    as the run does: unsmoothed, the count was right in 27 % of these contours; now in
    all."""
    for k in (3, 4, 5, 6):
        for seed in range(10):
            curvature = five_frames_curvature(
                lambda th: 0.1 * (1 + 0.08 * np.cos(k * th) + 0.03 * np.cos(2 * th)), 0.015, seed
            )
            assert count_corners(curvature) == k, (k, seed)


def test_a_round_tube_has_no_corners_however_rough():
    """A round section's curvature is its noise (issue 84, point 4: a round tube was
    reported with 7 corners): no maximum stands out of it at 0.5-3 % of radial
    roughness (one noise pattern in 50 here, at every roughness: the floor scales with
    it; the run then takes the rows' most common count), nor on a perfect circle."""
    wrong = {
        seed
        for roughness in (0.005, 0.015, 0.03)
        for seed in range(50)
        if count_corners(five_frames_curvature(lambda th: 0.1 + 0 * th, roughness, seed)) != 0
    }
    assert len(wrong) <= 1, wrong
    th = np.linspace(0, 2 * np.pi, 80, endpoint=False)
    circle = np.stack([0.1 * np.cos(th), 0.1 * np.sin(th), np.zeros_like(th)], -1)
    assert count_corners(contour_curvature(circle, Z)) == 0


def test_cylinder_mean_curvature():
    r = 0.2
    V, F = tube_mesh(r, length=1.0, n_theta=64, n_s=60)
    topo = check_tube(V, F)
    H = vertex_mean_curvature(V, topo.F, np.concatenate(topo.loops))
    interior = (V[:, 2] > 0.1) & (V[:, 2] < 0.9)
    assert np.allclose(H[interior], 1 / (2 * r), rtol=0.02)
    assert np.isnan(H[np.concatenate(topo.loops)]).all()


def test_taubin_steps_take_roughness_off_a_cylinder_and_keep_its_shape():
    r = 0.2
    V, F = tube_mesh(r, length=1.0, n_theta=64, n_s=60)
    topo = check_tube(V, F)
    rim = np.concatenate(topo.loops)
    interior = (V[:, 2] > 0.2) & (V[:, 2] < 0.8)
    # a smooth cylinder stays one: radius within 0.2 %, rims exactly where they were
    smooth = taubin_smooth(V, topo.F, 10, fixed=rim)
    assert np.allclose(np.hypot(*smooth[interior, :2].T), r, rtol=2e-3)
    assert np.array_equal(smooth[rim], V[rim])
    # 1 % radial roughness: the mean curvature's error drops several times
    radial = V[:, :2] / np.linalg.norm(V[:, :2], axis=1, keepdims=True)
    noise = np.random.default_rng(1).normal(0.0, 0.01 * r, len(V))
    rough = V + np.concatenate([radial * noise[:, None], np.zeros((len(V), 1))], axis=1)
    before = np.median(np.abs(vertex_mean_curvature(rough, topo.F)[interior] - 1 / (2 * r)))
    after = np.median(
        np.abs(
            vertex_mean_curvature(taubin_smooth(rough, topo.F, 10, fixed=rim), topo.F)[interior]
            - 1 / (2 * r)
        )
    )
    assert after < before / 4
    assert np.array_equal(taubin_smooth(rough, topo.F, 0), rough)


def _areas(V, F):
    cots, l2 = corner_terms(V, F)
    area = 0.5 * np.linalg.norm(np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]]), axis=1)
    return mixed_areas(cots, l2, area), area


def test_mixed_areas_are_voronoi_cells_and_halve_obtuse_faces():
    # a flat mesh of equilateral triangles: an interior vertex's cell is a hexagon
    a, n = 1.0, 7
    P = np.array(
        [[i * a + (j % 2) * a / 2, j * a * np.sqrt(3) / 2, 0.0] for j in range(n) for i in range(n)]
    )
    F = []
    for j in range(n - 1):
        for i in range(n - 1):
            p, q, r, t = j * n + i, j * n + i + 1, (j + 1) * n + i, (j + 1) * n + i + 1
            F += [[p, q, t], [p, t, r]] if j % 2 else [[p, q, r], [q, t, r]]
    F = np.array(F)
    shares, area = _areas(P, F)
    assert np.allclose(shares.sum(axis=1), area)
    per_vertex = np.bincount(F.ravel(), shares.ravel(), minlength=len(P))
    centre = 3 * n + 3
    assert per_vertex[centre] == pytest.approx(np.sqrt(3) / 2 * a**2)
    # an acute triangle: each corner's share is its quadrilateral corner - edge midpoint -
    # circumcentre - edge midpoint (not a third of the face)
    V = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.3, 0.8, 0.0]])
    (x1, y1), (x2, y2) = V[1, :2], V[2, :2]
    d = 2 * (x1 * y2 - y1 * x2)
    centre = (
        np.array(
            [
                y2 * (x1**2 + y1**2) - y1 * (x2**2 + y2**2),
                x1 * (x2**2 + y2**2) - x2 * (x1**2 + y1**2),
            ]
        )
        / d
    )
    shares, area = _areas(V, np.array([[0, 1, 2]]))
    for k in range(3):
        a, b = V[(k + 1) % 3, :2], V[(k + 2) % 3, :2]
        quad = np.array([V[k, :2], (V[k, :2] + a) / 2, centre, (V[k, :2] + b) / 2])
        x, y = quad.T
        shoelace = 0.5 * abs(x @ np.roll(y, -1) - y @ np.roll(x, -1))
        assert shares[0, k] == pytest.approx(shoelace)
    assert not np.allclose(shares[0], area[0] / 3)
    # an obtuse triangle: half its area at the obtuse corner, a quarter at the others
    V = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.5, 0.1, 0.0]])
    shares, area = _areas(V, np.array([[0, 1, 2]]))
    assert np.allclose(shares[0] / area[0], [0.25, 0.25, 0.5])


def grid_of(points_fn, n_u=12, n_v=6, n_t=3):
    u = np.arange(n_u) / n_u
    v = np.linspace(0, 1, n_v)
    G = np.empty((n_u, n_v, n_t, 3))
    for t in range(n_t):
        G[:, :, t] = points_fn(u[:, None], v[None, :], t)
    return G


def cylinder(r, length):
    def fn(u, v, t):
        th = 2 * np.pi * u * np.ones_like(v)
        return np.stack([r * np.cos(th), r * np.sin(th), length * v * np.ones_like(u)], -1)

    return fn


def test_rigid_motion_has_no_strain():
    from scipy.spatial.transform import Rotation

    R = Rotation.from_euler("xyz", [0.3, -0.2, 1.0]).as_matrix()
    base = cylinder(0.2, 1.0)
    G = grid_of(lambda u, v, t: base(u, v, t) @ (R.T if t else np.eye(3)) + t * 0.5)
    energy, stretch = grid_strain(G)
    assert np.abs(energy).max() < 1e-20 and np.allclose(stretch, 1.0)


def test_uniform_stretch_and_pure_shear():
    lam = 1.3
    G = grid_of(lambda u, v, t: cylinder(0.2 * (lam if t else 1), 1.0 * (lam if t else 1))(u, v, t))
    energy, stretch = grid_strain(G)
    assert np.allclose(energy[:, :, 1], 2 * (lam - 1) ** 2)
    # a twist: the cylinder's surface sheared by g = r dphi/dz, F = [[1, g], [0, 1]]
    g, r = 0.4, 0.2

    def twisted(u, v, t):
        th = 2 * np.pi * u + t * g * v / r * np.ones_like(u)
        return np.stack(np.broadcast_arrays(r * np.cos(th), r * np.sin(th), v), -1)

    energy, stretch = grid_strain(grid_of(twisted, 400, 40, 2))
    c = (2 + g**2 + np.array([1, -1]) * g * np.sqrt(g**2 + 4)) / 2
    assert np.allclose(stretch[:, :, 1], np.sqrt(c), atol=5e-4)  # the chords': 1e-4
    assert grid_triangles(4, 3).shape == (16, 3)


def waving_tube(u, v, t):
    """A cylinder (t = 0) and the same tube deformed unevenly (t = 1): its radius
    waving around it and growing along it, a twist, an axial stretch growing
    towards the outlet."""
    r = 0.2 * (1 + t * 0.3 * np.sin(2 * np.pi * u) * (1 + v))
    th = 2 * np.pi * u + t * 0.3 * np.sin(2 * np.pi * u) * v
    return np.stack(np.broadcast_arrays(r * np.cos(th), r * np.sin(th), v * (1 + t * 0.2 * v)), -1)


def test_strain_from_a_rough_grid_smoothed_in_time_is_the_walls():
    """A cylinder whose radius beats by 20 % over 195 frames of 1.85 ms, every node
    moved by 0.5 % of the radius at random in every frame (as a mesh segmented on
    its own moves it): the strain energy (circumferential stretch r / r0, none along)
    is a square, so the roughness lifts it: +58 % in the median unsmoothed and +5 % after
    5 ms of smoothing the nodes in time before the lift was measured and taken off
    (issue 84), -3 % and -0.4 % since; its median |error| 29 % and 7 % (59 % and 8 %
    before). Without the roughness 5 ms costs 0.8 % on this beat, and unsmoothed the lift
    measured takes 0.4 % off (the beat's own fastest part read as noise)."""
    from oftimg.analysis.fields import smoothed_strain

    n_t, period, r0 = 195, 360.0, 0.2
    radius = r0 * (1 + 0.2 * np.sin(np.pi * np.arange(n_t) / n_t) ** 2)
    u, v = np.meshgrid(np.arange(40) / 40, np.linspace(0, 1, 20), indexing="ij")
    smooth = np.stack([cylinder(r, 1.0)(u, v, 0) for r in radius], axis=2)  # (40, 20, n_t, 3)
    rough = smooth + 0.005 * r0 * np.random.default_rng(1).standard_normal(smooth.shape)
    truth = np.broadcast_to((radius / r0 - 1) ** 2, (40, 20, n_t))[:, 1:-1, 20:]

    def errors(G, sigma):  # over the median truth, where it strains: median |.|, bias
        error = smoothed_strain(G, period, sigma)[0][:, 1:-1, 20:] - truth
        return np.median(np.abs(error)) / np.median(truth), np.median(error) / np.median(truth)

    off, bias = errors(rough, 0.0)
    assert off > 0.2 and abs(bias) < 0.06  # noisy, but not lifted
    off, bias = errors(rough, 5.0)
    assert off < 0.09 and abs(bias) < 0.01
    assert errors(smooth, 0.0)[0] < 0.006 and errors(smooth, 5.0)[0] < 0.012
    assert np.array_equal(
        smoothed_strain(smooth, period, 0.0, noise_seed=None)[0], grid_strain(smooth)[0]
    )  # nothing measured: as it is


def test_strain_noise_is_the_change_the_roughness_makes():
    """The beating cylinder above, its nodes moved at random by 0.2 %, 0.5 % or 1 % of
    the radius: the share by which oftimg says the noise moves the strain energy
    against the change it makes (rough minus smooth grid's energy before the lift is
    taken off, median |.| over the median energy; measured 0.85-1.14x of it where it is
    under 0.35, as on the phantoms)."""
    from oftimg.analysis.fields import NOISY_STRAIN_SHARE, smoothed_strain

    n_t, period, r0 = 195, 360.0, 0.2
    radius = r0 * (1 + 0.2 * np.sin(np.pi * np.arange(n_t) / n_t) ** 2)
    u, v = np.meshgrid(np.arange(40) / 40, np.linspace(0, 1, 20), indexing="ij")
    smooth = np.stack([cylinder(r, 1.0)(u, v, 0) for r in radius], axis=2)
    jitter = np.random.default_rng(1).standard_normal(smooth.shape)
    for size, sigma in ((0.002, 0.0), (0.002, 5.0), (0.005, 5.0), (0.005, 10.0), (0.01, 10.0)):
        rough = smooth + size * r0 * jitter
        _, stretch, noise, _ = smoothed_strain(rough, period, sigma)
        energy = smoothed_strain(rough, period, sigma, noise_seed=None)[0]  # lift and all
        clean, clean_stretch, _, _ = smoothed_strain(smooth, period, sigma, noise_seed=None)
        change = np.median(np.abs(energy - clean)) / np.median(clean)
        assert 0.8 * change < noise["error_share"] < 1.25 * change
        stretch_change = np.median(np.abs(stretch - clean_stretch))  # what arrays.npz's
        assert 0.7 * stretch_change < noise["stretch_noise_median"] < 1.4 * stretch_change
        assert noise["smoothing_ms"] == sigma
        # the median length of a 3-D normal vector of SD s: 1.54 s
        assert noise["node_noise_mm"] == pytest.approx(1.54 * size * r0, rel=0.05)
    rough = smoothed_strain(smooth + 0.005 * r0 * jitter, period, 0.0)[2]
    assert rough["error_share"] > NOISY_STRAIN_SHARE  # says it is noise
    assert smoothed_strain(smooth, period, 5.0)[2]["error_share"] < 0.002
    short = smoothed_strain(smooth[:, :, :8], period, 5.0)[2]  # under 10 frames
    assert np.isnan(short["error_share"]) and np.isnan(short["node_noise_mm"])
    assert np.isnan(smoothed_strain(smooth, period, 5.0, noise_seed=None)[2]["error_share"])


def test_strain_smoothing_auto_takes_the_least_sigma_its_noise_allows():
    """ "auto" smooths the beating cylinder's nodes by the least sigma of the ladder
    after which their noise moves the strain energy by at most STRAIN_NOISE_TARGET
    (the one before moves it more), and only as much as that: 5 ms on the smooth
    cylinder, the same field as 5 ms given; more with the roughness, and closer to
    the truth for it."""
    from oftimg.image.kymograph import RIDGE_SMOOTHING_LADDER_MS as LADDER
    from oftimg.image.normalize import STRAIN_NOISE_TARGET
    from oftimg.analysis.fields import smoothed_strain

    n_t, period, r0 = 195, 360.0, 0.2
    radius = r0 * (1 + 0.2 * np.sin(np.pi * np.arange(n_t) / n_t) ** 2)
    u, v = np.meshgrid(np.arange(40) / 40, np.linspace(0, 1, 20), indexing="ij")
    smooth = np.stack([cylinder(r, 1.0)(u, v, 0) for r in radius], axis=2)
    truth = np.broadcast_to((radius / r0 - 1) ** 2, (40, 20, n_t))[:, 1:-1, 20:]
    jitter = np.random.default_rng(1).standard_normal(smooth.shape)

    def off(energy):
        return np.median(np.abs(energy[:, 1:-1, 20:] - truth)) / np.median(truth)

    energy, stretch, noise, _ = smoothed_strain(smooth, period, "auto")
    fixed = smoothed_strain(smooth, period, LADDER[0])
    assert noise["smoothing_ms"] == LADDER[0]
    assert np.array_equal(energy, fixed[0]) and np.array_equal(stretch, fixed[1])
    rough = smooth + 0.005 * r0 * jitter
    energy, _, noise, _ = smoothed_strain(rough, period, "auto")
    k = LADDER.index(noise["smoothing_ms"])
    assert k > 0 and noise["error_share"] <= STRAIN_NOISE_TARGET
    assert smoothed_strain(rough, period, LADDER[k - 1])[2]["error_share"] > STRAIN_NOISE_TARGET
    assert np.array_equal(energy, smoothed_strain(rough, period, LADDER[k])[0])
    assert off(energy) < 0.85 * off(smoothed_strain(rough, period, LADDER[0])[0])  # 0.74


def test_strain_smoothing_auto_stops_before_it_flattens_a_sharp_beat():
    """A cylinder beating sharply (radius r0 (1 + 0.25 sin^16(pi t / T)): a peak about
    a fifth of the 400 ms cycle wide, 40 frames) with its nodes moved at random by 0.3 or
    0.6 % of the radius: the noise moves the energy by more than STRAIN_NOISE_TARGET at
    every sigma (its median is small), so a climb on the noise alone took 20 ms, 1.7-2.9
    times the best sigma's error at the peak; "auto" stops where the flattening of the
    peak outweighs the noise removed: 7 and 10 ms, each the ladder's best. On a broad
    beat (sin^2) at 0.6 % it still climbs (14-20 ms; each within 6 % of the best)."""
    from oftimg.image.kymograph import RIDGE_SMOOTHING_LADDER_MS as LADDER
    from oftimg.image.normalize import STRAIN_NOISE_TARGET
    from oftimg.analysis.fields import smoothed_strain

    n_t, period, r0 = 40, 400.0, 0.2
    t_ms = np.arange(n_t) * period / n_t
    u, v = np.meshgrid(np.arange(40) / 40, np.linspace(0, 1, 20), indexing="ij")
    jitter = np.random.default_rng(1).standard_normal((40, 20, n_t, 3))
    for power, size, sharp in ((8, 0.003, True), (8, 0.006, True), (1, 0.006, False)):
        radius = r0 * (1 + 0.25 * np.sin(np.pi * t_ms / period) ** (2 * power))
        smooth = np.stack([cylinder(r, 1.0)(u, v, 0) for r in radius], axis=2)
        truth = np.broadcast_to((radius / r0 - 1) ** 2, (40, 20, n_t))[:, 1:-1]
        peak = truth > 0.5 * truth.max()
        rough = smooth + size * r0 * jitter

        def off(energy):  # RMS error over the peak's nodes and frames, over the peak
            return np.sqrt(np.mean((energy[:, 1:-1] - truth)[peak] ** 2)) / truth.max()

        errors = [off(smoothed_strain(rough, period, sigma)[0]) for sigma in LADDER]
        energy, _, noise, _ = smoothed_strain(rough, period, "auto")
        assert noise["error_share"] > STRAIN_NOISE_TARGET  # the noise alone: 20 ms
        assert off(energy) <= 1.06 * min(errors)
        if sharp:
            assert noise["smoothing_ms"] < LADDER[-1] and errors[-1] > 1.5 * off(energy)
            assert 0 < noise["flattening_share"] < noise["error_share"]
        else:
            assert noise["smoothing_ms"] >= 14.0


def test_strain_does_not_depend_on_which_way_the_grid_runs():
    """Mirrored with u reversed, or with v reversed, the grid gives the same strain
    reversed; and within 0.012 of an 8x finer grid's. (With each quad split along one
    diagonal only: 0.01 different mirrored, 0.017 from the fine grid.)"""
    G = grid_of(waving_tube, 80, 50, 2)
    energy, stretch = grid_strain(G)
    back = (-np.arange(80)) % 80
    mirrored = grid_strain(G[back] * [-1, 1, 1])
    reversed_v = grid_strain(G[:, ::-1])
    assert np.allclose(mirrored[0][back], energy, atol=1e-12)
    assert np.allclose(mirrored[1][back], stretch, atol=1e-12)
    assert np.allclose(reversed_v[0][:, ::-1], energy, atol=1e-12)
    fine = grid_strain(grid_of(waving_tube, 640, 393, 2))[0][::8, ::8]
    assert np.abs(energy - fine).max() < 0.012 and np.median(np.abs(energy - fine)) < 5e-4


def test_strain_in_chunks_of_frames_is_against_the_one_reference():
    # frame t stretched uniformly by 1 + 0.1 t; chunks of 2 frames, reference 0 in the first
    scale = 1 + 0.1 * np.arange(7)
    G = grid_of(lambda u, v, t: cylinder(0.2 * scale[t], 1.0 * scale[t])(u, v, t), n_t=7)
    G[3, 2, 5] = np.nan  # a node lost in frame 5
    energy, stretch = grid_strain(G, chunk=2)
    whole_e, whole_s = grid_strain(G, chunk=7)
    assert np.array_equal(energy, whole_e, equal_nan=True)
    assert np.array_equal(stretch, whole_s, equal_nan=True)
    ok = np.isfinite(energy)
    assert ok.sum() == energy.size - 1 and not ok[3, 2, 5]
    expected = np.broadcast_to(2 * (scale - 1) ** 2, energy.shape)
    assert np.allclose(energy[ok], expected[ok])


def test_per_pixel_normalization_and_phase():
    t = np.arange(20)
    f = np.stack([np.sin(2 * np.pi * (t - 3) / 20) * 5 + 7, np.ones(20)])[None]  # (1, 2, 20)
    n = per_pixel_normalize(f)
    assert n[0, 0].min() == 0 and n[0, 0].max() == 1 and np.all(n[0, 1] == 0.5)
    tmax, tmin = phase_maps(f, 200.0)
    assert tmax[0, 0] == pytest.approx(80.0) and tmin[0, 0] == pytest.approx(180.0)


def test_phase_maps_are_smoothed_in_time_and_sub_frame():
    """A wave of asymmetric beats (expansion in 40 % of the cycle) under noise of 2 %
    of its range per pixel and frame: the raw frame of each pixel's maximum scatters
    by ~8 ms, the smoothed sub-frame one by ~5 ms, and a NaN pixel does not matter."""
    rng = np.random.default_rng(0)
    n_t, period = 195, 360.0
    t = np.arange(n_t) * period / n_t
    arrival = np.linspace(20.0, 200.0, 50)
    phi = ((t[None, :] - arrival[:, None]) / period) % 1.0
    beat = np.where(
        phi < 0.4,
        0.5 - 0.5 * np.cos(np.pi * phi / 0.4),
        0.5 + 0.5 * np.cos(np.pi * (phi - 0.4) / 0.6),
    )
    field = np.broadcast_to(beat, (40, 50, n_t)) + 0.02 * rng.standard_normal((40, 50, n_t))
    field[3, 4, 7] = np.nan

    def scatter(t_max):
        d = (t_max - (arrival + 0.4 * period) + period / 2) % period - period / 2
        return np.sqrt(np.mean((d - np.median(d)) ** 2))

    raw = np.argmax(np.where(np.isfinite(field), field, 0), axis=-1) * period / n_t
    t_max, t_min = phase_maps(field, period)
    assert t_max.shape == t_min.shape == (40, 50)
    assert scatter(raw) > 7.0 and scatter(t_max) < 5.5
    assert scatter(t_min - 0.4 * period) < 7.0  # the minimum: at the arrival


def test_surface_render_covers_the_view_and_follows_the_motion():
    from oftimg.output.video import SurfaceCamera

    n_t = 8

    def pulsing(u, v, t):
        r = 0.2 * (1 + 0.4 * np.sin(2 * np.pi * t / n_t))
        th = 2 * np.pi * u * np.ones_like(v)
        return np.stack([r * np.cos(th), 1.0 * v * np.ones_like(u), r * np.sin(th)], -1)

    G = grid_of(pulsing, n_u=40, n_v=20, n_t=n_t)
    cam = SurfaceCamera(G, size=160)
    values = np.broadcast_to(np.linspace(0, 1, 20)[None, :], (40, 20))
    imgs = [cam.render(G[:, :, t], values, vmin=0, vmax=1) for t in (0, 2)]
    covered = [(img < 250).any(axis=-1).mean() for img in imgs]
    assert all(0.05 < c < 0.9 for c in covered)
    assert covered[1] > covered[0] * 1.2  # expanded tube covers more of the picture
    # rays are cast only in the window the tube can cover: the same pictures
    rows, cols = cam._window
    assert (rows.stop - rows.start) * (cols.stop - cols.start) < 0.8 * 160**2
    whole = SurfaceCamera(G, size=160, crop=False)
    for t, img in zip((0, 2), imgs):
        assert np.array_equal(whole.render(G[:, :, t], values, vmin=0, vmax=1), img)


@pytest.mark.parametrize(
    "noise_sd, expected_ms", [(0.0, 5.0), (0.8, 7.0), (1.15, 14.0), (3.0, 20.0)]
)
def test_auto_field_smoothing_takes_the_least_sigma_that_quiets_the_noise(noise_sd, expected_ms):
    """A beat of amplitude 1 (variance 1/2) under white noise of SD s: after a Gaussian
    of noise gain g the noise share is (g s)^2 / (1/2 + (g s)^2). For 195 frames of
    1.85 ms, g = 0.32, 0.27, 0.23, 0.19, 0.16 for the ladder's 5, 7, 10, 14, 20 ms:
    s = 0.8 gives 0.12 at 5 ms and 0.087 at 7; s = 1.15 0.12 at 10 ms and 0.090 at 14;
    s = 3 never gets under 0.10 (0.32 at 20 ms) and takes the most."""
    from oftimg.image.normalize import FIELD_NOISE_TARGET, smooth_field

    period, n_t = 360.0, 195
    rng = np.random.default_rng(2)
    t = np.arange(n_t) / n_t
    field = np.sin(2 * np.pi * t) + noise_sd * rng.standard_normal((30, 40, n_t))
    smoothed, noise = smooth_field(field, period, "auto")
    assert noise["smoothing_ms"] == expected_ms
    assert noise["noise_share"] <= FIELD_NOISE_TARGET or expected_ms == 20.0
    assert np.allclose(smoothed, smooth_field_in_time(field, period, expected_ms))
    assert smooth_field(field, period, 7.0)[1]["smoothing_ms"] == 7.0  # a sigma given
    short = field[..., :8]  # under 10 frames: no noise measure
    assert smooth_field(short, period, "auto")[1]["smoothing_ms"] == 5.0


def test_field_noise_measures_white_noise_and_its_smoothing():
    """A travelling pattern plus white noise of known SD in every pixel and frame."""
    rng = np.random.default_rng(0)
    n_u, n_v, n_t, period = 40, 20, 195, 360.0
    u, v, t = np.meshgrid(
        np.arange(n_u) / n_u, np.arange(n_v) / n_v, np.arange(n_t) / n_t, indexing="ij"
    )
    clean = 2.0 * np.sin(2 * np.pi * (t + u)) + np.cos(4 * np.pi * (t - v))
    for sd in (0.0, 0.5, 2.0):
        noise = rng.normal(0.0, sd, clean.shape)
        f = clean + noise
        r = field_noise(f, smooth_field_in_time(f, period, 5.0), period, 5.0)
        assert r["noise_sd"] == pytest.approx(sd, rel=0.05, abs=1e-9)
        smoothed_noise = np.std(smooth_field_in_time(noise, period, 5.0))
        assert r["noise_sd_smoothed"] == pytest.approx(smoothed_noise, rel=0.05, abs=1e-9)
        signal = np.var(smooth_field_in_time(clean, period, 5.0), axis=-1).mean()
        assert r["noise_share"] == pytest.approx(
            smoothed_noise**2 / (signal + smoothed_noise**2), rel=0.1, abs=1e-9
        )
    # NaN cells stay NaN and do not spread; under 10 frames the noise is not measured
    f = clean.copy()
    f[3, 4, 7] = np.nan
    sm = smooth_field_in_time(f, period, 5.0)
    assert (
        np.isnan(sm[3, 4, 7])
        and np.isfinite(np.delete(sm.ravel(), 3 * n_v * n_t + 4 * n_t + 7)).all()
    )
    assert np.isfinite(field_noise(f, sm, period, 5.0)["noise_sd"])
    short = clean[..., :8]
    assert np.isnan(field_noise(short, short, period, 5.0)["noise_share"])


@pytest.mark.slow
def test_a_rough_phantom_counts_its_corners_and_says_its_curvature_is_noise(tmp_path):
    """Every vertex moved radially by 5 um (2.5 % of the radius): the corner count
    used to come out as 10 for the phantom's 4. Each frame meshed on its own, and left
    rough (--rough-mesh-smoothing 0, as the paper; tests/test_roughness.py smooths it):
    the curvature read at the scale the noise allows is off by a quarter of its size at
    the median node (the 80-point resample's, before issue 84: by 120 %, all noise), the
    noise it reports is part of that error (its spread over the beat, against the model
    where the points are on average), and it says the field is still mostly noise."""
    from oftimg.errors import OftimgWarning
    from oftimg.io.dataset import load_dataset
    from oftimg.synthetic.phantom import read_truth, sample_params, write_phantom
    from oftimg.analysis.pipeline import PipelineOptions, analyse_dataset

    path = write_phantom(
        tmp_path / "rough",
        sample_params(
            "normal", 0, n_frames=20, vertices_min=2500, vertices_max=3500, noise_mm=0.005
        ),
    )
    ph, truth = read_truth(path)
    # on the per-frame grid, whose field pixels are the section contours' points, where
    # the model's curvature is known exactly
    with pytest.warns(OftimgWarning, match="radial_curvature_outer_per_mm is mostly noise"):
        result = analyse_dataset(
            load_dataset(path), PipelineOptions(tracking="none", rough_mesh_smoothing=0), quiet=True
        )
    assert result["summary"]["corner_count"] == truth["corner_count"] == 4
    assert np.mean(result["arrays"]["corner_count_per_row"] == 4) > 0.8
    t_ms = np.roll(np.asarray(truth["t_ms"]), -result["summary"]["t0_frame"])[None, None, :]
    for wall in ("outer", "inner"):
        name = f"radial_curvature_{wall}_per_mm"
        noise = result["summary"]["field_noise"][name]
        s, theta = ph.window_coordinates(result["arrays"][f"contour_{wall}_mm"][:, 2:-2])
        at_nodes = ph.section_curvature(wall, s, theta, t_ms)
        error = result["arrays"][name][:, 2:-2] - at_nodes
        # against the model where the contour points are on average over the smoothing
        # (they slide along the wall from frame to frame; the field cannot follow them)
        points = result["arrays"][f"contour_{wall}_mm"][:, 2:-2].astype(float)
        mean_points = np.moveaxis(
            smooth_field_in_time(
                np.moveaxis(points, -1, 0), truth["params"]["period_ms"], noise["smoothing_ms"]
            ),
            0,
            -1,
        )
        s_m, theta_m = ph.window_coordinates(mean_points)
        at_mean = result["arrays"][name][:, 2:-2] - ph.section_curvature(wall, s_m, theta_m, t_ms)
        size = np.median(np.abs(at_nodes))
        # measured 1.9 and 2.6 /mm off at the median node of 7.7 and 9.6 /mm; noise 0.62
        # and 0.90 /mm of spreads 1.4 and 2.5 /mm (the rest: the scale's flattening of
        # the corners, changing as they sharpen over the beat)
        assert np.median(np.abs(error)) < 0.3 * size
        spread = np.median(np.std(at_mean, axis=-1))
        assert 0.2 * spread < noise["noise_sd_smoothed"] < spread
        assert noise["noise_share"] > 0.3
        assert noise["smoothing_ms"] == 20.0  # auto: the most, and not enough (warned)


def test_thickness_summary():
    """A wall of 30 um beating by +-20 %: thickening 1.2 / 0.8 - 1 = 0.5 in every row
    (one pixel all NaN, left out), the median thickness 30 um; with white noise of
    a tenth of the beat's amplitude on every pixel the rows' means stay within 2 %
    (each pixel's own largest over smallest: 0.56, 13 % high); the keys name the
    layer."""
    t = np.arange(40) / 40
    thickness = np.broadcast_to(0.03 * (1 + 0.2 * np.sin(2 * np.pi * t)), (80, 5, 40)).copy()
    thickness[2, 3] = np.nan
    found = thickness_summary(thickness)
    assert found["wall_thickening"] == pytest.approx(0.5, rel=1e-9)
    assert found["wall_thickness_median_mm"] == pytest.approx(0.03, rel=1e-9)
    noisy = thickness + 0.0006 * np.random.default_rng(0).standard_normal(thickness.shape)
    assert thickness_summary(noisy)["wall_thickening"] == pytest.approx(0.5, rel=0.02)
    assert thickness_summary(thickness, "jelly") == pytest.approx(
        {"jelly_thickening": 0.5, "jelly_thickness_median_mm": 0.03}, rel=1e-9
    )
    ok = np.isfinite(noisy).all(axis=-1)
    assert np.median(noisy.max(axis=-1)[ok] / noisy.min(axis=-1)[ok]) - 1 > 0.55


def test_thickness_by_row():
    """Row j beating by +-a_j around b_j: mean b_j, thickening (1 + a_j) / (1 - a_j) - 1;
    a row without any value NaN, and the thickening of a row whose walls cross (mean
    thickness 0 or below at some time)."""
    a, b = np.linspace(0.05, 0.3, 6), np.linspace(0.02, 0.04, 6)
    beat = np.sin(2 * np.pi * np.arange(40) / 40)
    thickness = np.broadcast_to(b[:, None] * (1 + a[:, None] * beat), (16, 6, 40)).copy()
    thickness[:, 4] = np.nan
    thickness[:, 2] -= 0.03  # crosses 0 in the beat
    mean, thickening = thickness_by_row(thickness)
    assert mean[2] == pytest.approx(b[2] - 0.03, rel=1e-12) and np.isnan(thickening[2])
    keep = ~np.isin(np.arange(6), [2, 4])
    assert mean[keep] == pytest.approx(b[keep], rel=1e-12)
    assert thickening[keep] == pytest.approx(2 * a[keep] / (1 - a[keep]), rel=1e-12)
    assert np.isnan(mean[4]) and np.isnan(thickening[4])


@pytest.mark.slow
@pytest.mark.parametrize("layer", ["wall", "jelly"])
def test_thickness_is_the_models(analysed_normal, layer):
    """The myocardium's thickness at each outer grid node, and the cardiac jelly's at
    each inner node (on along the same line to the lumen), against the model's
    radial thickness at the node's position (averaged in time as the field is):
    measured 0.3 % and 0.4 % off (median), 1.5 % and 1.5 % (95th percentile); the
    thickening over the beat against the model's."""
    ph, truth, res = analysed_normal
    name = f"{layer}_thickness_mm"
    sigma = res["summary"]["field_noise"][name]["smoothing_ms"]
    X = np.moveaxis(
        smooth_field_in_time(np.moveaxis(res["grids"]["outer"], -1, 0), ph.p.period_ms, sigma),
        0,
        -1,
    )
    t_ms = np.roll(np.asarray(truth["t_ms"]), -res["summary"]["t0_frame"])[None, None, :]
    model = getattr(ph, f"{layer}_thickness")(*ph.window_coordinates(X), t_ms)
    found = res["arrays"][name]
    rel = np.abs(found / model - 1)
    assert np.median(rel) < 0.01 and np.percentile(rel, 95) < 0.04
    thickening = thickness_summary(model, layer)[f"{layer}_thickening"]
    assert res["summary"][f"{layer}_thickening"] == pytest.approx(thickening, rel=0.03)
    assert res["summary"]["field_noise"][name]["noise_share"] < 0.05
    assert res["arrays"][f"phase_max_{name}_ms"].shape == found.shape[:2]


@pytest.mark.slow
@pytest.mark.parametrize("wall", ["outer", "inner"])
def test_radial_curvature_is_the_models(analysed_normal, wall):
    """Each section contour's curvature against the model's cross-section, the polar
    curve rho(theta), at each pixel's own grid node's angle and time (the model's
    section is across its centreline; ours in the grid's plane, tilted a little)."""
    ph, truth, res = analysed_normal
    # each field pixel's own point: the tracked grid's node (its contour points are the
    # per-frame rows')
    C = res["grids"][wall][:, 2:-2].astype(float)  # (n_u, n_v, n_t, 3)
    k = res["arrays"][f"radial_curvature_{wall}_per_mm"][:, 2:-2]
    t_ms = np.roll(np.asarray(truth["t_ms"]), -res["summary"]["t0_frame"])[None, None, :]
    s, theta = ph.window_coordinates(C)
    model = ph.section_curvature(wall, s, theta, t_ms)
    off = np.abs(k - model)
    # measured 6.0 % and 0.995 (6.3-6.4 % and 0.994 unsmoothed in time); the same fields 3
    # frames late: 15-18 % and 0.96-0.97
    assert np.median(off) < 0.09 * np.median(np.abs(model))
    assert np.corrcoef(k.ravel(), model.ravel())[0, 1] > 0.985
    # the smooth phantom's curvatures are not called noisy: measured 0.02, 0.02, 0.10
    assert all(n["noise_share"] < 0.15 for n in res["summary"]["field_noise"].values())
    # so auto smoothing takes the least sigma for the radial curvatures (the lumen's, at
    # 0.10 just over the target, took 7 ms)
    taken = res["summary"]["field_smoothing_ms"]
    assert taken["radial_curvature_outer_per_mm"] == taken["radial_curvature_inner_per_mm"] == 5
    assert taken["mean_curvature_lumen_per_mm"] <= 7
