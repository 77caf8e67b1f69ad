"""Radial curvature node by node (issue 84): each section's own polygon at several
scales, the scale chosen per node from the noise the frames show."""

import numpy as np
import pytest

from oftimg.analysis.radial_curvature import (
    ALONG_ROWS,
    UNMEASURED_SCALE,
    along_tube,
    least_error_scale,
    node_band_95,
    scale_chosen_curvature,
)
from oftimg.analysis.uncertainty import BAND_WIDE_SHARE, wide_band_share
from oftimg.image.normalize import smooth_field
from oftimg.mesh.curvature import CURVATURE_SCALES, contour_curvature
from oftimg.mesh.sections import _measure_polygons, contour_around, planes_contours
from oftimg.synthetic.phantom import Phantom, PhantomParams


def _polygon_curvature(P, normal, n=80):
    """The contour's n points and their curvature at every scale, one polygon."""
    _, _, points, kappa, spacing = _measure_polygons(
        [P], np.asarray(normal, float)[None], P[:1], n, curvature=True
    )
    assert np.isclose(spacing[0], np.linalg.norm(np.diff(P, axis=0, append=P[:1]), axis=1).mean())
    return points[0], kappa[:, 0]


def test_a_circle_is_exact_at_every_scale_on_irregular_vertices():
    rng = np.random.default_rng(3)
    r = 0.15
    theta = np.sort(rng.uniform(0, 2 * np.pi, 120))
    P = np.stack([r * np.cos(theta), r * np.sin(theta), np.zeros_like(theta)], axis=1)
    _, kappa = _polygon_curvature(P, [0, 0, 1])
    assert kappa.shape == (len(CURVATURE_SCALES), 80)
    assert np.abs(kappa * r - 1).max() < 0.005  # the chords' own shortfall
    _, turned = _polygon_curvature(P[::-1], [0, 0, -1])  # the other way round, seen so
    assert np.allclose(turned * r, 1, atol=0.005)


def test_the_fine_scales_keep_a_notch_the_grid_resample_flattens():
    """A section with five sharp notches (curvature to -25 /mm), 300 vertices round it:
    the finest scale within 10 % of the median |truth| at the 90th percentile, the
    80-point resample's Savitzky-Golay fit (before issue 84) 62 %; the widest scale
    flattens it as the resample does."""
    ph = Phantom(PhantomParams(n_frames=8, corners=5, corner_sharpness=-1.5, contraction=0.0))
    s = 0.5 * ph.p.length_mm
    theta = np.sort(np.random.default_rng(1).uniform(-np.pi, np.pi, 300))
    P = ph.point("outer", s, theta, 0.0)
    c, N, B = ph.frame_axes(s)
    normal = np.cross(B, N)
    points, kappa = _polygon_curvature(P, normal)
    truth = ph.section_curvature("outer", s, ph.window_coordinates(points)[1], 0.0)
    assert truth.min() < -20
    scale = np.median(np.abs(truth))

    def p90(estimate):
        return 100 * np.percentile(np.abs(estimate - truth), 90) / scale

    resampled = contour_curvature(points, normal)
    assert p90(kappa[0]) < 12 and p90(resampled) > 50
    assert p90(kappa[-1]) > 0.8 * p90(resampled)


def test_the_scale_of_least_error_balances_noise_and_bias():
    """Four scales, noise SD 2, 1, 0.5, 0.25 round a curvature (mean square 62.5) that
    the wider scales flatten by 0, 1, 6 and 20 %: mean squared errors 4, 1.01, 0.48,
    2.56 (the third taken); without the flattening, the widest; the noise not known,
    the fixed scale."""
    rng = np.random.default_rng(0)
    truth = np.tile([10.0, -5.0], 5000)
    noise_sd = np.array([2.0, 1.0, 0.5, 0.25])
    flattened = np.array([0.0, 0.1, 0.6, 2.0])
    estimates = np.stack(
        [truth * (1 - f / 10) + rng.normal(0, s, truth.shape) for s, f in zip(noise_sd, flattened)]
    )
    assert least_error_scale(estimates, noise_sd) == 2
    unbiased = np.stack([truth + rng.normal(0, s, truth.shape) for s in noise_sd])
    assert least_error_scale(unbiased, noise_sd) == 3
    assert least_error_scale(estimates, np.full(4, np.nan)) == min(UNMEASURED_SCALE, 3)


def test_along_the_tube_leaves_nan_rows_out():
    K = np.ones((2, 3, 7, 4))
    K[:, :, 3] = np.nan
    K[:, :, 5] = 4.0
    out = along_tube(K, ALONG_ROWS)
    assert np.isnan(out[:, :, 3]).all() and np.isfinite(np.delete(out, 3, axis=2)).all()
    assert 1 < out[0, 0, 5, 0] < 4 and out[0, 0, 0, 0] < 1.2


@pytest.fixture(scope="module")
def noisy_frames():
    """A phantom tube that does not contract (its notches sharpen and soften over the
    beat) meshed on its own in each of 24 frames with 2 um of radial roughness, its
    sections cut square to the centre line: each scale's curvature ``(n_scales, 80, n_v,
    24)``, the resample's, the truth ``(80, n_v, 24)``, the period (ms), the polygons'
    vertex spacing ``(n_v, 24)`` mm and the contours' points ``(80, n_v, 24, 3)``."""
    ph = Phantom(
        PhantomParams(
            n_frames=24,
            corners=4,
            corner_sharpness=-1.0,
            contraction=0.0,
            noise_mm=0.002,
            vertices_min=12000,
            vertices_max=12000,
            stretch=0.0,
        )
    )
    s = np.linspace(0.25, 0.75, 12) * ph.p.length_mm
    c, N, B = ph.frame_axes(s)
    normals = np.cross(B, N)
    starts = ph.point("outer", s, np.zeros_like(s), 0.0)
    rng = np.random.default_rng(7)
    scales, resampled, truth, spacing, contours = [], [], [], [], []
    for t in ph.frame_times_ms():
        V, F = ph.mesh("outer", t, rng)
        polygons = [
            contour_around(cs, o, n)
            for cs, o, n in zip(planes_contours(V, F, c, normals), c, normals)
        ]
        _, _, points, kappa, gaps = _measure_polygons(polygons, normals, starts, 80, curvature=True)
        scales.append(kappa.transpose(0, 2, 1))
        spacing.append(gaps)
        points = points.transpose(1, 0, 2)
        contours.append(points)
        resampled.append(contour_curvature(points, normals[None]))
        truth.append(ph.section_curvature("outer", s[None, :], ph.window_coordinates(points)[1], t))
    return (
        np.stack(scales, axis=-1),
        np.stack(resampled, axis=-1),
        np.stack(truth, axis=-1),
        ph.p.period_ms,
        np.stack(spacing, axis=-1),
        np.stack(contours, axis=2),
    )


def test_the_chosen_scales_beat_the_resample_at_the_notches(noisy_frames):
    """On the noisy frames, the field node by node: the scale-chosen curvature's 90th
    percentile error under 0.9 times the resample's (smoothed alike), its concave
    nodes' too, and each node's noise SD positive and finite."""
    K, resampled, truth, period, spacing, contour = noisy_frames
    field, noise, node_sd, unresolved = scale_chosen_curvature(K, period, "auto", spacing, contour)
    old, _ = smooth_field(resampled, period, noise["smoothing_ms"])
    scale = np.median(np.abs(truth))
    new_error = np.abs(field - truth)[:, 1:-1]  # the rows inside
    old_error = np.abs(old - truth)[:, 1:-1]
    concave = (truth < 0)[:, 1:-1]
    assert concave.mean() > 0.1
    new_p90, old_p90 = (100 * np.percentile(e, 90) / scale for e in (new_error, old_error))
    assert new_p90 < 0.9 * old_p90, (new_p90, old_p90)  # 28.8 against 33.6 %
    assert np.percentile(new_error[concave], 90) < 0.9 * np.percentile(old_error[concave], 90)
    assert np.isfinite(node_sd).all() and (node_sd > 0).all()


def test_each_node_band_adds_what_its_scale_may_not_resolve(noisy_frames):
    """The band's second part, a Gaussian's flattening estimated from the field's second
    difference round the section, is twice as large at the notches (where the scale
    flattens) as on the flat sides (the error is too: 1.8 and 0.8 /mm at the median
    node); the band is 1.96 k
    times the two added in quadrature; the share of nodes marked counts those whose band
    is over BAND_WIDE_SHARE of their value."""
    K, _, truth, period, spacing, contour = noisy_frames
    _, _, node_sd, unresolved = scale_chosen_curvature(K, period, "auto", spacing, contour)
    notch = truth < np.percentile(truth, 10)
    flat = np.abs(truth - np.median(truth)) < 0.1 * np.median(np.abs(truth))
    assert np.median(unresolved[notch]) > 1.7 * np.median(unresolved[flat])
    band = node_band_95(node_sd, unresolved, 1.5)
    assert np.allclose(band, 1.96 * 1.5 * np.hypot(node_sd, unresolved), rtol=1e-6)
    value = np.array([1.0, -2.0, 4.0, np.nan])
    assert wide_band_share(
        np.array([0.4, 1.2, 1.0, 1.0]) * BAND_WIDE_SHARE / 0.5, value
    ) == pytest.approx(1 / 3)
    assert wide_band_share(np.full(2, np.nan), np.ones(2)) is None


def test_the_corners_are_counted_on_the_field_as_read(noisy_frames):
    """Four notched corners: counted as 4 on every row of the scale-chosen field (five
    frames averaged, as the run counts them); two zoo draws with three broad lobes
    counted 0 on the raw frames of the usual scale (their noise floor over the lobes)."""
    from oftimg.mesh.curvature import count_corners

    K, _, _, period, spacing, contour = noisy_frames
    field, *_ = scale_chosen_curvature(K, period, "auto", spacing, contour)
    counts = [count_corners(field[:, j, :5].mean(axis=1)) for j in range(field.shape[1])]
    assert counts == [4] * field.shape[1]


def test_the_curvature_at_given_points_is_the_polygons_nearest_them():
    """An ellipse of irregular vertices, read at points off its plane and round it in no
    order: each is the ellipse's curvature at the nearest point (at the finest scale
    within 2 %, measured 1.1 %: the vertices' irregular gaps)."""
    a, b = 0.2, 0.12
    rng = np.random.default_rng(4)
    phi = np.sort(rng.uniform(0, 2 * np.pi, 400))
    P = np.stack([a * np.cos(phi), b * np.sin(phi), np.zeros_like(phi)], axis=1)
    at_phi = rng.uniform(0, 2 * np.pi, 30)
    at = np.stack([a * np.cos(at_phi), b * np.sin(at_phi), rng.uniform(-0.01, 0.01, 30)], 1)
    _, _, _, kappa, _ = _measure_polygons(
        [P], np.array([[0, 0, 1.0]]), P[:1], 80, curvature=True, at=at[None]
    )
    truth = a * b / (a**2 * np.sin(at_phi) ** 2 + b**2 * np.cos(at_phi) ** 2) ** 1.5
    assert kappa.shape == (len(CURVATURE_SCALES), 1, 30)
    assert np.abs(kappa[0, 0] / truth - 1).max() < 0.02


def test_a_mean_curvature_is_half_the_sections_and_across_them():
    """A tube whose radius waves along it, r = R + A sin(k z): Meusnier's factor and the
    normal curvature across the sections from an 80 x 50 grid of it, against the
    surface's own (1 / sqrt(1 + r'^2) and -r'' / (1 + r'^2)^1.5), and the mean curvature
    they make with the sections' exact curvature, 1 / r, within 0.5 % (the rows' second
    difference over two rows)."""
    from oftimg.mesh.curvature import across_section_terms

    R, A, k = 0.2, 0.03, 8.0
    u, z = np.meshgrid(
        np.linspace(0, 2 * np.pi, 80, endpoint=False), np.linspace(0, 1, 50), indexing="ij"
    )
    r, slope, bend = R + A * np.sin(k * z), A * k * np.cos(k * z), -A * k * k * np.sin(k * z)
    X = np.stack([r * np.cos(u), r * np.sin(u), z], axis=-1)
    meusnier, across = across_section_terms(X, np.tile([0, 0, 1.0], (50, 1)))
    inside = (slice(None), slice(2, -2))
    assert np.abs(meusnier - 1 / np.sqrt(1 + slope**2))[inside].max() < 1e-3
    assert np.abs(across + bend / (1 + slope**2) ** 1.5)[inside].max() < 0.02 * np.abs(bend).max()
    H = 0.5 * (meusnier / r + across)
    truth = 0.5 * (1 / (r * np.sqrt(1 + slope**2)) - bend / (1 + slope**2) ** 1.5)
    assert np.abs(H / truth - 1)[inside].max() < 0.005
    # the grid turned the other way round gives the same
    assert np.allclose(
        across_section_terms(X[::-1], np.tile([0, 0, 1.0], (50, 1)))[1][::-1], across
    )


def test_the_flattening_in_time_is_what_the_smoothing_took_off():
    """A beat of two harmonics smoothed in time by 10 ms: what the smoothing took off its
    peaks and troughs, against sigma^2 / 2 times the smoothed beat's second derivative
    (the bands' share for the smoothing in time), within 10 % where it is over a tenth of
    its largest."""
    from oftimg.image.normalize import smooth_field_in_time, time_flattening

    period, n_t, sigma = 400.0, 120, 10.0
    t = np.arange(n_t) * period / n_t
    beat = (np.cos(2 * np.pi * t / period) + 0.4 * np.sin(4 * np.pi * t / period))[None]
    smoothed = smooth_field_in_time(beat, period, sigma)
    taken, estimated = np.abs(beat - smoothed)[0], time_flattening(smoothed, period, sigma)[0]
    large = taken > 0.1 * taken.max()
    assert np.abs(estimated[large] / taken[large] - 1).max() < 0.1
    assert np.allclose(time_flattening(smoothed, period, 0.0), 0.0)


def test_the_nearest_points_are_found_in_deep_folds():
    """Five deep folds, 300 vertices jittered by 0.3 of their spacing round the tube (as
    the phantom's meshes are), points off the plane near both walls of each valley: the
    k-d tree's nearest points are as near as the brute force's (every edge searched)."""
    from oftimg.mesh.sections import _closed_polygons, _nearest_arc

    rng = np.random.default_rng(2)
    th = (np.arange(300) + rng.uniform(-0.3, 0.3, 300)) * 2 * np.pi / 300
    r = 0.1 * (1 - 0.8 * ((1 + np.cos(5 * th)) / 2) ** 4)
    P = np.stack([r * np.cos(th), r * np.sin(th), np.zeros_like(th)], axis=1)
    tq = rng.uniform(0, 2 * np.pi, 400)
    rq = 0.1 * (1 - 0.8 * ((1 + np.cos(5 * tq)) / 2) ** 4)
    at = np.stack([rq * np.cos(tq), rq * np.sin(tq), rng.uniform(-0.005, 0.005, 400)], 1)
    _, starts, lengths, _, succ = _closed_polygons([P])
    AB = P[succ] - P
    seg = np.linalg.norm(AB, axis=1)
    s = np.cumsum(seg) - seg
    found = _nearest_arc(P, AB, seg, s, starts, lengths, at[None])[0]
    edge = np.searchsorted(s, found, side="right") - 1
    where = P[edge] + ((found - s[edge]) / seg[edge])[:, None] * AB[edge]
    rel = at[:, None] - P[None]  # every edge, brute force
    along = np.clip(np.einsum("mpk,pk->mp", rel, AB) / seg**2, 0, 1)
    nearest = np.linalg.norm(rel - along[..., None] * AB, axis=-1).min(axis=1)
    assert np.allclose(np.linalg.norm(where - at, axis=1), nearest, rtol=0, atol=1e-12)
