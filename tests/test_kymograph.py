"""(v, t) maps with known answers (issue 6)."""
import numpy as np
import pytest

from oftimg.image.band import detect_band
from oftimg.image.gradient import area_rates, colour_wheel, gradient_hsv
from oftimg.image.kymograph import (cycle_speed, local_speed, ridge_times, two_segment_fit,
                                    wave_speed_summary)
from oftimg.image.masks import expanded_75, expanded_sigma

PERIOD = 100.0  # ms
N_T = 100


def pulse_map(arrival_ms, width_ms=6.0, base=1.0):
    """Periodic Gaussian pulse peaking at ``arrival_ms (n_v,)``."""
    t = np.arange(N_T) * PERIOD / N_T
    dt = (t[None, :] - arrival_ms[:, None] + PERIOD / 2) % PERIOD - PERIOD / 2
    return base + np.exp(-0.5 * (dt / width_ms) ** 2)


def test_travelling_pulse_speed_within_1_percent():
    s = np.linspace(0, 0.5, 50)
    c = 10.0  # mm/s
    area = pulse_map(17.3 + 1e3 * s / c)
    ridge = ridge_times(area, PERIOD)
    assert np.allclose(np.diff(ridge), 1e3 * np.diff(s) / c, atol=0.3)
    speed = local_speed(s, ridge)
    assert np.allclose(speed, c, rtol=0.01)
    assert cycle_speed(s, ridge) == pytest.approx(c, rel=0.01)


def test_ridge_unwraps_across_the_cycle_end():
    s = np.linspace(0, 1.0, 40)
    area = pulse_map((80.0 + 1e3 * s / 12.0) % PERIOD)  # wraps past 100 ms
    ridge = ridge_times(area, PERIOD)
    assert np.all(np.diff(ridge) > 0)
    assert cycle_speed(s, ridge) == pytest.approx(12.0, rel=0.01)


def test_one_ill_defined_row_does_not_shift_the_rest_of_the_ridge():
    """A neck row whose maximum sits almost half a cycle early (as on the animated
    midgut): the next row is then more than half a period from it, and unwrapping
    against that row alone (np.unwrap) would move the rest of the ridge a period."""
    s = np.linspace(0, 1.0, 40)
    arrival = 20.0 + 1e3 * s / 8.0           # 3.2 ms per row, wraps past 100 ms
    area = pulse_map(arrival % PERIOD)
    area[18] = pulse_map(np.array([(arrival[18] - 48.0) % PERIOD]))[0]
    ridge = ridge_times(area, PERIOD)
    good = np.arange(40) != 18
    assert np.allclose(ridge[good], arrival[good], atol=0.5)
    assert cycle_speed(s, ridge) == pytest.approx(8.0, rel=0.02)
    naive = np.unwrap(np.where(good, arrival, arrival - 48.0) % PERIOD, period=PERIOD)
    assert not np.allclose(naive[good], arrival[good], atol=0.5)  # the failure avoided


def test_knee_recovers_both_speeds_and_position():
    s = np.linspace(0, 1.0, 50)
    knee = s[20] + 0.004
    c1, c2 = 5.0, 20.0
    arrival = np.where(s < knee, 1e3 * s / c1, 1e3 * knee / c1 + 1e3 * (s - knee) / c2)
    area = pulse_map(arrival % PERIOD, width_ms=8.0)
    fit = two_segment_fit(s, ridge_times(area, PERIOD))
    assert fit.speed_proximal_mm_s == pytest.approx(c1, rel=0.03)
    assert fit.speed_distal_mm_s == pytest.approx(c2, rel=0.03)
    assert abs(fit.knee_row - 20) <= 2


def test_backward_wave_gives_negative_speeds():
    s = np.linspace(0, 1.0, 50)
    arrival = 1e3 * np.abs(s - 0.4) / 10.0  # starts in the middle, runs both ways
    speed = local_speed(s, ridge_times(pulse_map(arrival), PERIOD))
    assert np.all(speed[:15] < 0) and np.all(speed[-15:] > 0)
    assert speed[:15] == pytest.approx(-10.0, rel=0.02)
    summary = wave_speed_summary(speed, 10.0)
    assert summary["min"] < 0 < summary["max"]


def test_constant_map_gives_nan_speeds_with_a_warning():
    area = np.ones((20, 30))
    with pytest.warns(RuntimeWarning, match="do not change"):
        ridge = ridge_times(area, PERIOD)
    assert np.all(np.isnan(ridge))
    s = np.linspace(0, 1, 20)
    assert np.all(np.isnan(local_speed(s, ridge)))
    assert np.isnan(cycle_speed(s, ridge))
    assert np.isnan(wave_speed_summary(local_speed(s, ridge), np.nan)["mean"])


def test_bad_map_shapes_are_refused():
    with pytest.raises(ValueError, match="2-D"):
        ridge_times(np.ones(10), PERIOD)


def test_sobel_hsv_of_a_linear_ramp_has_one_hue():
    from matplotlib.colors import rgb_to_hsv

    v_ramp = np.linspace(0, 1, 30)[:, None] * np.ones((1, 40))
    hsv = rgb_to_hsv(gradient_hsv(v_ramp))
    assert np.ptp(hsv[..., 0]) < 1e-9 and hsv[..., 2].min() > 0.4
    t_ramp = np.ones((30, 1)) * np.linspace(0, 1, 40)[None, :]
    hsv_t = rgb_to_hsv(gradient_hsv(t_ramp, periodic_t=False))
    assert np.ptp(hsv_t[..., 0]) < 1e-9
    assert abs(hsv_t[0, 0, 0] - hsv[0, 0, 0]) == pytest.approx(0.25)  # 90 degrees apart
    wheel = colour_wheel(51)
    assert wheel.shape == (51, 51, 4) and wheel[0, 0, 3] == 0 and wheel[25, 25, 3] == 1


def test_area_rates_of_a_sine():
    t = np.arange(N_T)
    area = 2.0 + np.sin(2 * np.pi * t / N_T)[None, :] * np.ones((5, 1))
    expand, contract = area_rates(area, frame_ms=PERIOD / N_T)
    assert expand == pytest.approx(2 * np.pi / PERIOD, rel=0.01)
    assert contract == pytest.approx(2 * np.pi / PERIOD, rel=0.01)


def test_expanded_fractions_of_known_shapes():
    t = np.arange(N_T)
    cosine = 0.5 + 0.5 * np.cos(2 * np.pi * (t - 30.4) / N_T)
    share, up, down, mask = expanded_75(cosine[None, :])
    assert share[0] == pytest.approx(1 / 3, abs=0.01)
    assert mask.mean() == pytest.approx(1 / 3, abs=0.02)
    sigma_true = 7.0
    area = pulse_map(np.array([42.0, 70.0]), width_ms=sigma_true)
    share_s, sigma, r2, mask_s = expanded_sigma(area)
    assert np.allclose(sigma, sigma_true, rtol=0.02) and np.all(r2 > 0.99)
    assert np.allclose(share_s, 2 * sigma_true / N_T, rtol=0.02)


def test_gaussian_fit_reports_nan_for_non_gaussian_rows():
    t = np.arange(N_T)
    square = (np.abs(t - 50) < 30).astype(float) + np.where(t % 2 == 0, 0.3, 0.0)
    with pytest.warns(RuntimeWarning, match="Gaussian"):
        share, sigma, r2, _ = expanded_sigma(square[None, :])
    assert np.isnan(sigma[0]) and np.isnan(share[0])


def test_band_detection():
    s = np.linspace(0, 1.2, 50)
    taper = 0.12 - 0.05 * s / 1.2
    t = np.arange(N_T)
    motion = 0.3 * (0.5 + 0.5 * np.cos(2 * np.pi * t / N_T))[None, :]
    normal = taper[:, None] * (1 + motion)
    assert detect_band(normal, s) is None
    neck = np.exp(-0.5 * ((s - 0.7) / 0.06) ** 2)
    banded = (taper * (1 - 0.4 * neck))[:, None] * (1 + motion * (1 - 0.9 * neck)[:, None])
    assert detect_band(banded, s) == pytest.approx(0.7, abs=0.03)


# ----------------------------------------------------------------- phantom truth
@pytest.mark.slow
def test_phantom_wave_speeds(analysed_normal):
    ph, truth, res = analysed_normal
    speeds = res["summary"]["wave_speed_mm_s"]
    assert speeds["cycle"] == pytest.approx(truth["wave_speed_mm_s"]["cycle"], rel=0.10)
    assert speeds["mean"] == pytest.approx(truth["wave_speed_mm_s"]["mean"], rel=0.15)
    assert res["summary"]["band_position_mm"] is None


@pytest.mark.slow
def test_phantom_expanded_fractions(analysed_normal):
    ph, truth, res = analysed_normal
    s_mm = res["arrays"]["s_mm"]
    expected = np.interp(s_mm, truth["s_mm"], truth["expanded_fraction_75"])
    measured = res["arrays"]["expanded_fraction_75_outer"]
    assert np.abs(measured - expected).max() < 0.05


@pytest.mark.slow
def test_phantom_band_position(analysed_banded):
    _, truth, res = analysed_banded
    assert res["summary"]["band_position_mm"] == pytest.approx(truth["band_position_mm"],
                                                               abs=0.08)
    assert res["summary"]["wave_speed_mm_s"]["cycle"] == pytest.approx(
        truth["wave_speed_mm_s"]["cycle"], rel=0.10)
