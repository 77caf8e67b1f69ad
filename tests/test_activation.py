"""Wave fronts on the wall (issue 76): activation times from each node's motion, the
surface wave velocity from their gradient on the wall, on analytic tubes whose wave
is known: along the axis, a helix, one that starts on one side, a tube that moves at
once and one that does not move."""

import numpy as np
import pytest

from oftimg.image.activation import (
    activation_times,
    normal_displacement,
    propagates,
    strong,
    surface_velocity,
    unwrapped,
    wave_summary,
)

PERIOD_MS = 360.0
N_U, N_V, N_T = 80, 50, 120
RADIUS_MM, LENGTH_MM = 0.15, 1.2


def cylinder(n_t=N_T, radius=RADIUS_MM):
    """A cylinder's grid ``(n_u, n_v, n_t, 3)`` about z, the same at every frame."""
    u = np.arange(N_U) / N_U * 2 * np.pi
    z = np.linspace(0, LENGTH_MM, N_V)
    U, Z = np.meshgrid(u, z, indexing="ij")
    ring = np.stack([radius * np.cos(U), radius * np.sin(U), Z], axis=-1)
    return np.repeat(ring[:, :, None], n_t, axis=2)


def beating(arrival_ms, noise_mm=0.0, seed=0, amplitude_mm=0.02):
    """The cylinder's wall moving radially, a cosine that peaks ``arrival_ms`` ``(n_u,
    n_v)`` after t = 0 (whose steepest rise is a quarter period earlier)."""
    grid = cylinder()
    t = np.arange(N_T) * PERIOD_MS / N_T
    r = RADIUS_MM + amplitude_mm * np.cos(2 * np.pi * (t - arrival_ms[..., None]) / PERIOD_MS)
    r = r + np.random.default_rng(seed).normal(0, noise_mm, r.shape) if noise_mm else r
    scale = r / RADIUS_MM
    grid[..., 0] *= scale
    grid[..., 1] *= scale
    return grid


def node_coordinates():
    u = np.arange(N_U)[:, None] / N_U * np.ones((1, N_V))
    s = np.linspace(0, LENGTH_MM, N_V)[None, :] * np.ones((N_U, 1))
    return u, s


def test_activation_is_the_steepest_rise_sub_frame_and_its_noise_is_calibrated():
    """Arrival 7.3 ms a mm along (a 3 ms frame): each node's activation a quarter
    period before its peak, to 0.05 ms without noise; with 1 um of noise on 20 um of
    motion the errors' SD is the stated SD within 20 %."""
    u, s = node_coordinates()
    arrival = 7.3 * s + 100.0
    act = activation_times(normal_displacement(beating(arrival)), PERIOD_MS)
    expected = np.mod(arrival - PERIOD_MS / 4, PERIOD_MS)
    assert np.abs(act.time_ms - expected).max() < 0.05
    noisy = activation_times(normal_displacement(beating(arrival, noise_mm=0.001)), PERIOD_MS)
    error = unwrapped(noisy.time_ms - expected, PERIOD_MS)
    assert abs(np.std(error) / np.median(noisy.sd_ms) - 1) < 0.2
    assert noisy.phase.shape == (N_U, N_V, N_T)
    frame = np.argmin(np.abs(np.arange(N_T) * 3.0 - expected[5, 10]))
    assert abs(noisy.phase[5, 10, frame]) < 2 * np.pi * 3.0 / PERIOD_MS  # 0 at activation


@pytest.mark.parametrize("noise_mm, expected", [(0.0, 2.0), (0.0005, 3.0), (0.006, 4.0)])
def test_the_smoothing_is_chosen_from_the_times_scatter(noise_mm, expected):
    """A wave along the tube at 20 mm/s (a 3 ms frame; 1.2 ms a row): without noise the
    narrowest plane fit (2 nodes); the noisier the motion, the wider (3, then 4 nodes:
    0.5 and 6 um of noise on 20 um of motion), the speed within 3 % and the nodes'
    speeds closer together than at 2 nodes (white noise, unlike from node to node,
    biases the median little: 2 % at 6 um and 2 nodes; the zoo's errors, alike over a
    few nodes, more)."""
    from oftimg.image.activation import auto_smoothing

    u, s = node_coordinates()
    arrival = s / 0.02 + 50.0
    grid = beating(arrival, noise_mm=noise_mm)
    act = activation_times(normal_displacement(grid), PERIOD_MS)
    reads = strong(act)
    sigma = auto_smoothing(act.time_ms, PERIOD_MS, reads)
    assert sigma == expected
    chosen = surface_velocity(
        act.time_ms, grid.mean(axis=2), PERIOD_MS, smoothing_nodes=sigma, use=reads
    )
    assert np.nanmedian(chosen.speed_mm_s) == pytest.approx(20.0, rel=0.03)
    if noise_mm:  # the nodes' speeds closer together than at 2 nodes
        narrow = surface_velocity(act.time_ms, grid.mean(axis=2), PERIOD_MS, use=reads)
        assert np.subtract(*np.nanpercentile(chosen.speed_mm_s, [75, 25])) < 0.6 * np.subtract(
            *np.nanpercentile(narrow.speed_mm_s, [75, 25])
        )


def test_a_run_s_activation_sd_is_the_larger_of_the_node_s_noise_and_the_times_scatter():
    """wave_fronts' SD: without noise, the floor (a share of the period); with 3 um of
    noise on 20 um of motion, the nodes' own noise (the errors' SD within 20 %), the
    times' scatter about the plane fitted round each node alike; the arrays' shapes."""
    from oftimg.analysis.wave_fronts import wave_fronts
    from oftimg.image.activation import ACTIVATION_FLOOR_SHARE

    u, s = node_coordinates()
    arrival = 7.3 * s + 100.0
    arrays, summary = wave_fronts({"outer": beating(arrival)}, s[0], PERIOD_MS)
    np.testing.assert_allclose(
        arrays["activation_sd_outer_ms"], ACTIVATION_FLOOR_SHARE * PERIOD_MS, rtol=1e-6
    )
    arrays, summary = wave_fronts({"outer": beating(arrival, noise_mm=0.003)}, s[0], PERIOD_MS)
    error = unwrapped(arrays["activation_time_outer_ms"] - (arrival - PERIOD_MS / 4), PERIOD_MS)
    assert np.median(arrays["activation_sd_outer_ms"]) > ACTIVATION_FLOOR_SHARE * PERIOD_MS
    assert abs(np.std(error) / np.median(arrays["activation_sd_outer_ms"]) - 1) < 0.2
    assert arrays["wave_velocity_outer_mm_s"].shape == (N_U, N_V, 2)
    assert arrays["phase_outer"].shape == (N_U, N_V, N_T)
    assert summary["outer"]["strong_share"] == 1.0


@pytest.mark.parametrize("k", [0, 1, -1])
def test_a_helical_wave_s_speed_and_angle_on_the_wall(k):
    """A wave at c = 10 mm/s along the axis whose front winds k times round the tube
    in a cycle (arrival + k T u): on the wall its speed is 1 / |grad t| =
    1 / sqrt(1/c^2 + (kT / 2 pi R)^2) and its angle to the axis atan(k T c / 2 pi R);
    the axial speed stays c. Within 1 % and 0.5 degrees away from the ends."""
    u, s = node_coordinates()
    c = 10.0 / 1e3  # mm/ms
    arrival = s / c + k * PERIOD_MS * u
    grid = beating(arrival)
    act = activation_times(normal_displacement(grid), PERIOD_MS)
    vel = surface_velocity(act.time_ms, grid.mean(axis=2), PERIOD_MS)
    around = k * PERIOD_MS / (2 * np.pi * RADIUS_MM)  # ms/mm
    speed = 1e3 / np.hypot(1 / c, around)
    angle = np.degrees(np.arctan2(around, 1 / c))
    inner = (slice(None), slice(5, -5))
    np.testing.assert_allclose(vel.speed_mm_s[inner], speed, rtol=0.01)
    np.testing.assert_allclose(vel.angle_deg[inner], angle, atol=0.5)
    np.testing.assert_allclose(1 / vel.axial_slowness_ms_mm[inner], c, rtol=0.01)
    summary = wave_summary(act, vel, s[0], PERIOD_MS)
    assert summary["propagates"]
    assert summary["axial_speed_mm_s"] == pytest.approx(10.0, rel=0.01)
    assert summary["helix_angle_deg"] == pytest.approx(angle, abs=0.5)
    if k == 0:  # a helix has no first node: each ring meets every time
        assert summary["earliest_s_mm"] < 0.1  # it starts at the inlet


def test_a_wave_that_starts_on_one_side_is_found_there():
    """A wave that reaches u = 0.25 first and the far side 60 ms later: the earliest
    node is on that side, and the fronts run round the tube from it both ways."""
    u, s = node_coordinates()
    arrival = s / 0.01 + 30.0 * (1 - np.cos(2 * np.pi * (u - 0.25)))
    grid = beating(arrival)
    act = activation_times(normal_displacement(grid), PERIOD_MS)
    vel = surface_velocity(act.time_ms, grid.mean(axis=2), PERIOD_MS)
    summary = wave_summary(act, vel, s[0], PERIOD_MS)
    assert abs(summary["earliest_node"][0] - 20) <= 1 and summary["earliest_node"][1] <= 2
    mid = slice(10, 40)
    assert np.all(vel.around_mm_s[30:38, mid] > 0)  # from u = 0.25 towards u = 0.5
    assert np.all(vel.around_mm_s[3:10, mid] < 0)  # and back towards u = 0


@pytest.mark.parametrize("case", ["at_once", "still"])
def test_a_tube_moving_at_once_or_not_at_all_has_no_propagation(case):
    """Every node at the same time (with noise), or no motion but noise: no
    propagation, not a huge speed."""
    u, s = node_coordinates()
    grid = beating(
        np.full((N_U, N_V), 50.0), noise_mm=0.001, amplitude_mm=0.02 if case == "at_once" else 0.0
    )
    act = activation_times(normal_displacement(grid), PERIOD_MS)
    assert not propagates(act, PERIOD_MS)
    assert act.moving.mean() > 0.99 if case == "at_once" else act.moving.mean() < 0.01
    summary = wave_summary(
        act, surface_velocity(act.time_ms, grid.mean(axis=2), PERIOD_MS), s[0], PERIOD_MS
    )
    assert summary["propagates"] is False and summary["speed_mm_s"] is None


@pytest.mark.slow
def test_a_phantom_s_helical_front_that_comes_first_on_one_side_is_found(tmp_path):
    """A phantom whose wave winds once round the tube and comes first on one side, 40
    ms before the far side (40 frames), through a run: on the outer wall the wave's
    speed (node by node, against the truth's on the same wall) within 5 % at the
    median and in the summary, the helix angle within 3 degrees (the zoo's random
    fronts: tests/test_zoo_subset.py)."""
    from oftimg.analysis.pipeline import PipelineOptions, analyse_dataset
    from oftimg.io.dataset import load_dataset
    from oftimg.synthetic.phantom import Phantom, sample_params, write_phantom

    params = sample_params(
        "normal", 3, n_frames=40, helix_starts=1, side_lag_ms=40.0, side_deg=90.0
    )
    write_phantom(tmp_path / "ph", params)
    res = analyse_dataset(load_dataset(tmp_path / "ph"), PipelineOptions(), quiet=True)
    phantom = Phantom(params)
    mean = res["grids"]["outer"].mean(axis=2)
    along, around = np.moveaxis(res["arrays"]["wave_velocity_outer_mm_s"], -1, 0)
    reads = np.isfinite(along)
    assert reads.mean() > 0.9
    truth = surface_velocity(
        phantom.activation_ms(*phantom.window_coordinates(mean)),
        mean,
        params.period_ms,
        smoothing_nodes=0,
        use=reads,
    )
    speed = np.hypot(along, around)
    inner = (slice(None), slice(4, -4))
    assert np.nanmedian(speed[inner] / truth.speed_mm_s[inner] - 1) == pytest.approx(0, abs=0.05)
    found = res["summary"]["wave_fronts"]["outer"]
    assert found["propagates"]
    assert found["speed_mm_s"] == pytest.approx(np.nanmedian(truth.speed_mm_s), rel=0.05)
    slant = np.mod(truth.angle_deg + 90.0, 180.0) - 90.0
    assert found["helix_angle_deg"] == pytest.approx(np.nanmedian(slant), abs=3.0)


def test_a_band_that_barely_moves_is_not_where_the_wave_starts_nor_its_speed():
    """A band of rows moving a tenth as much, its timing early (its neighbours' pull):
    the earliest node is the inlet's, where the wave starts, not the band's; the band
    gives no velocity, and its times do not reach its neighbours' speeds through the
    smoothing (10 mm/s within 3 %; over 20 % off when they do)."""
    u, s = node_coordinates()
    arrival = s / 0.01 + 20.0
    arrival[:, 24:28] -= 70.0  # earlier than the inlet, and barely moving
    grid = beating(arrival)
    r = normal_displacement(grid)
    r[:, 24:28] *= 0.1
    act = activation_times(r, PERIOD_MS)
    reads = strong(act)
    assert not reads[:, 24:28].any() and reads[:, :24].all() and reads[:, 28:].all()
    velocity = surface_velocity(act.time_ms, grid.mean(axis=2), PERIOD_MS, use=reads)
    assert np.isnan(velocity.speed_mm_s[:, 24:28]).all()
    summary = wave_summary(act, velocity, s[0], PERIOD_MS)
    assert summary["earliest_node"][1] <= 1  # the inlet row
    assert summary["speed_mm_s"] == pytest.approx(10.0, rel=0.01)
    beside = np.r_[20:24, 28:32]  # the band's neighbours: their own times
    np.testing.assert_allclose(velocity.speed_mm_s[:, beside], 10.0, rtol=0.03)
    every = surface_velocity(act.time_ms, grid.mean(axis=2), PERIOD_MS)  # the band's too
    assert np.median(np.abs(every.speed_mm_s[:, beside] / 10.0 - 1)) > 0.2
