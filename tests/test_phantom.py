import json

import numpy as np
import pytest

from oftimg.io.dataset import load_dataset, validate_dataset
from oftimg.mesh.sections import contour_around, plane_contours, polygon_area
from oftimg.mesh.topology import capped_signed_volume
from oftimg.synthetic.phantom import Phantom, PhantomParams, read_truth, sample_params


def test_every_frame_is_a_tube_and_frames_differ(phantom_normal):
    ds = load_dataset(phantom_normal)
    checked = []
    report = validate_dataset(ds, progress=lambda: checked.append(1))
    assert len(checked) == 3 * 36  # progress after every mesh
    assert set(report["surfaces"]) == {"outer", "inner", "lumen"}
    assert all(s["frames"] == 36 for s in report["surfaces"].values())
    a, b = ds.tube("outer", 0), ds.tube("outer", 1)
    assert len(a.V) != len(b.V) or not np.allclose(a.V[:50], b.V[:50])
    counts = {len(ds.tube("outer", t).V) for t in range(10)}
    assert len(counts) > 5
    # vertex order is shuffled: neighbours in the file are not neighbours on the tube
    step = np.linalg.norm(np.diff(a.V, axis=0), axis=1)
    assert np.median(step) > 0.1


def test_loader_ignores_truth_and_picks_inlet(phantom_normal):
    ds = load_dataset(phantom_normal)
    ph, _ = read_truth(phantom_normal)
    tube = ds.tube("outer", 0)
    s, _ = ph.window_coordinates(tube.V[tube.inlet])
    assert np.abs(s).max() < 1e-5


@pytest.mark.parametrize("wall", ["outer", "inner", "lumen"])
def test_meshed_section_area_matches_analytic(phantom_normal, wall):
    ds = load_dataset(phantom_normal)
    ph, truth = read_truth(phantom_normal)
    t_ms = truth["t_ms"]
    errors = []
    for t in (0, 3, 7):
        tube = ds.tube(wall, t)
        for s in np.linspace(0.1, 0.9, 5) * ph.p.length_mm:
            c, N, B = ph.frame_axes(s)
            tangent = np.cross(B, N)
            C = contour_around(plane_contours(tube.V, tube.F, c, tangent), c, tangent)
            meshed = polygon_area(C, tangent)
            errors.append(meshed / ph.area_mm2(wall, s, t_ms[t]) - 1)
    assert np.max(np.abs(errors)) < 0.01


def test_truth_volume_matches_capped_mesh_volume(phantom_normal):
    ds = load_dataset(phantom_normal)
    _, truth = read_truth(phantom_normal)
    for t in (0, 5):
        tube = ds.tube("outer", t)
        vol = capped_signed_volume(tube.V, tube.F, [tube.inlet, tube.outlet])
        assert vol == pytest.approx(truth["volume_mm3"]["outer"][t], rel=0.01)


def test_truth_fields_are_consistent(phantom_normal):
    truth = json.loads((phantom_normal / "truth.json").read_text())
    p = truth["params"]
    for key in (
        "speed_mm_s",
        "arrival_ms",
        "area_mm2",
        "volume_mm3",
        "expand_fraction",
        "wave_speed_mm_s",
        "band_position_mm",
        "corner_count",
        "expanded_fraction_75",
    ):
        assert key in truth
    assert truth["expand_fraction"] + truth["contract_fraction"] == pytest.approx(1.0)
    assert truth["expand_ms"] + truth["contract_ms"] == pytest.approx(p["period_ms"])
    assert 0.3 < truth["expand_fraction"] < 0.55
    assert np.array(truth["area_mm2"]["outer"]).shape == (len(truth["s_mm"]), p["n_frames"])
    a = np.array(truth["area_mm2"]["outer"])
    assert np.all(a > np.array(truth["area_mm2"]["inner"]))
    assert np.all(np.array(truth["area_mm2"]["inner"]) > np.array(truth["area_mm2"]["lumen"]))
    assert 0.15 <= truth["myocardial_volume_change"] <= 0.25
    c = truth["wave_speed_mm_s"]
    assert c["min"] <= c["cycle"] <= c["max"]
    assert truth["band_position_mm"] is None


def test_banded_max_area_has_a_neck_at_the_band(phantom_banded):
    truth = json.loads((phantom_banded / "truth.json").read_text())
    s = np.array(truth["s_mm"])
    amax = np.array(truth["max_area_mm2"]["outer"])
    k = np.argmin(np.abs(s - truth["band_position_mm"]))
    window = np.arange(k - 8, k + 9)
    k_min = window[np.argmin(amax[window])]
    # a true local minimum (the taper alone is monotone) close to the band
    assert amax[k_min] < amax[k_min - 8] and amax[k_min] < amax[k_min + 8]
    assert abs(s[k_min] - truth["band_position_mm"]) < 0.03


def test_wave_timing_and_shapes():
    ph = Phantom(PhantomParams(n_frames=20))
    s = np.linspace(0, ph.p.length_mm, 50)
    t_max = ph.arrival_ms(s) + ph.p.expand_fraction * ph.p.period_ms
    assert np.allclose(ph.expansion(s, t_max), 1.0)
    assert np.allclose(ph.expansion(s, ph.arrival_ms(s)), 0.0)
    # thicker myocardium when contracted
    th = 0.3
    assert ph.wall_thickness(0.5, th, ph.arrival_ms(0.5)) > ph.wall_thickness(0.5, th, t_max[24])
    # material coordinates: the outlet end is fixed, the inlet slides
    X = ph.point("outer", np.array([0.0, ph.p.length_mm]), np.array([0.0, 0.0]), 0.0)
    S, theta = ph.material_coordinates(X, 0.0)
    assert S[1] == pytest.approx(ph.p.length_mm) and S[0] > 0.1
    assert np.allclose(theta, 0.0, atol=1e-9)


def test_expansion_share_changing_along_the_tube_moves_the_ridge():
    """The truth's ridge is where the area peaks, and its speed is the ridge's slope."""
    base = sample_params("normal", 2, n_frames=20)
    ph = Phantom(sample_params("normal", 2, n_frames=20, expand_change=0.2))
    assert ph.p.expand_fraction_outlet == pytest.approx(base.expand_fraction + 0.2)
    truth = ph.truth(n_s=41)
    s = np.array(truth["s_mm"])
    # each row's peak in time: on a grid of 1800 steps of the cycle, then on one 400 times
    # finer within 2 steps of it (one fine grid over the whole cycle took 9 GB and 40 s)
    step = ph.p.period_ms / 1800
    t_coarse = np.arange(1800) * step
    peak = t_coarse[np.argmax(ph.area_mm2("outer", s[:, None], t_coarse[None, :]), axis=1)]
    t_fine = peak[:, None] + np.linspace(-2 * step, 2 * step, 1601)
    peak = np.take_along_axis(
        t_fine, np.argmax(ph.area_mm2("outer", s[:, None], t_fine), axis=1)[:, None], axis=1
    )[:, 0]
    ridge = np.array(truth["ridge_t_ms"])
    half = ph.p.period_ms / 2  # times are periodic
    assert np.abs((peak - ridge + half) % ph.p.period_ms - half).max() < 0.02
    # the peak lags more and more behind the onset: slower than the onset wave
    assert ridge[-1] - ridge[0] == pytest.approx(np.ptp(truth["arrival_ms"]) + 0.2 * ph.p.period_ms)
    slope = np.gradient(ridge, s)  # ms per mm
    speed = np.array(truth["ridge_speed_mm_s"])
    assert np.allclose(speed[1:-1], 1e3 / slope[1:-1], rtol=0.02)
    assert np.all(speed < np.array(truth["speed_mm_s"]))
    assert truth["wave_speed_mm_s"]["cycle"] == pytest.approx(
        1e3 * ph.p.length_mm / (ridge[-1] - ridge[0])
    )
    # the same share all along: the ridge runs with the onset
    same = Phantom(base).truth(n_s=41)
    assert same["ridge_speed_mm_s"] == same["speed_mm_s"]


def test_bad_parameters_are_refused():
    with pytest.raises(ValueError, match="group"):
        PhantomParams(group="mutant")
    with pytest.raises(ValueError, match="expand_fraction"):
        PhantomParams(expand_fraction=1.2)
    with pytest.raises(ValueError, match="expand_fraction_outlet"):
        PhantomParams(expand_fraction_outlet=1.0)
    with pytest.raises(ValueError, match="bend_radius"):
        PhantomParams(bend_radius_mm=0.2)
    for noise in (-0.01, float("nan")):  # were taken for no noise
        with pytest.raises(ValueError, match="noise_mm must be >= 0"):
            PhantomParams(noise_mm=noise)


def test_sampled_parameters_vary_by_seed_and_group():
    a, b = sample_params("normal", 0), sample_params("normal", 1)
    assert a.period_ms != b.period_ms and a.band_position_mm is None
    c = sample_params("banded", 0)
    assert 0.4 * c.length_mm <= c.band_position_mm <= 0.65 * c.length_mm


def test_phantom_cli_passes_every_option(tmp_path):
    from oftimg.cli import main

    out = tmp_path / "ph"
    assert (
        main(
            [
                "phantom",
                str(out),
                "--group",
                "banded",
                "--seed",
                "3",
                "--frames",
                "3",
                "--vertices",
                "900",
                "1000",
                "--noise-mm",
                "0.002",
                "--expand-change",
                "0.1",
                "--quiet",
            ]
        )
        == 0
    )
    params = json.loads((out / "truth.json").read_text())["params"]
    assert params["noise_mm"] == 0.002 and params["n_frames"] == 3
    assert params["expand_fraction_outlet"] == pytest.approx(params["expand_fraction"] + 0.1)
    assert (params["vertices_min"], params["vertices_max"]) == (900, 1000)
    assert params["band_position_mm"] is not None  # banded


@pytest.mark.parametrize("sharpness", [-1.5, -0.4, 0.0, 0.7, 1.5])
def test_sharper_corners_keep_the_areas_and_sharpen_the_curvature(sharpness):
    """corner_profile: mean 0 and peak 1 at every sharpness (the inner wall's area formula
    holds: its myocardial area is kept), the peak's curvature grows with |sharpness| (at
    the corners for > 0, in the notches between for < 0), and a meshed section's area is
    the truth's."""
    from oftimg.synthetic.phantom import corner_profile, profile_power

    phase = np.linspace(0, 2 * np.pi, 4096, endpoint=False)
    g = corner_profile(phase, sharpness)
    assert abs(g.mean()) < 1e-12 and np.isclose(np.abs(g).max(), 1.0)
    assert np.isclose((g**2).mean(), profile_power(sharpness), rtol=1e-9)
    ph = Phantom(PhantomParams(n_frames=8, corners=5, corner_sharpness=sharpness))
    s, t = 0.5 * ph.p.length_mm, 0.0
    theta = np.linspace(-np.pi, np.pi, 4096, endpoint=False)
    rho_out, rho_in = (ph.radius(w, s, theta, t) for w in ("outer", "inner"))
    myocardium = 0.5 * np.mean(rho_out**2 - rho_in**2) * 2 * np.pi
    assert np.isclose(
        myocardium,
        ph.p.myocardial_fraction * np.pi * ph.base_radius(s) ** 2 / ph.stretch(t),
        rtol=1e-6,
    )
    kappa = ph.section_curvature("outer", s, theta, t)
    cosine = Phantom(PhantomParams(n_frames=8, corners=5)).section_curvature("outer", s, theta, t)
    if sharpness > 0:
        assert kappa.max() > cosine.max() * (1 + 0.3 * sharpness)
    elif sharpness < 0:
        assert kappa.min() < cosine.min() - 3 * abs(sharpness)
    rng = np.random.default_rng(0)
    V, F = ph.mesh("outer", t, rng)
    c, N, B = ph.frame_axes(s)
    tangent = np.cross(B, N)
    C = contour_around(plane_contours(V, F, c, tangent), c, tangent)
    assert np.isclose(polygon_area(C, tangent), ph.area_mm2("outer", s, t), rtol=0.01)
