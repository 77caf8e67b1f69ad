"""(v, t) maps with known answers (issue 6)."""

import numpy as np
import pytest

from oftimg.image.band import detect_band
from oftimg.image.gradient import area_rates, colour_wheel, gradient_hsv
from oftimg.errors import InputError
from oftimg.analysis.maps import FRAME_LIMITED_CROSSING, analyse_area_maps
from oftimg.image.kymograph import (
    at_fixed_positions,
    auto_ridge_smoothing,
    cycle_speed,
    local_speed,
    map_noise_sd,
    noise_colour,
    ridge_times,
    smooth_in_time,
    speed_spread,
    two_segment_fit,
    wave_speed_summary,
    wave_speeds,
)
from oftimg.image.cycle import periodic_peak
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
    arrival = 20.0 + 1e3 * s / 8.0  # 3.2 ms per row, wraps past 100 ms
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
    assert abs(fit.knee_mm - knee) <= 2 * (s[1] - s[0])
    assert fit.knee_t_ms == pytest.approx(1e3 * knee / c1, abs=1.0)  # the line at the knee


def test_backward_wave_gives_negative_speeds():
    s = np.linspace(0, 1.0, 50)
    arrival = 1e3 * np.abs(s - 0.4) / 10.0  # starts in the middle, runs both ways
    speed = local_speed(s, ridge_times(pulse_map(arrival), PERIOD))
    assert np.all(speed[:15] < 0) and np.all(speed[-15:] > 0)
    assert speed[:15] == pytest.approx(-10.0, rel=0.02)
    summary = wave_speed_summary(speed, 10.0)
    assert summary["min"] < 0 < summary["max"]


def test_median_speed_ignores_a_row_where_the_ridge_is_flat():
    """Where the ridge is nearly flat along the tube one row's speed shoots up (the
    paper's Table 1 has maxima up to 2923 mm/s): the mean follows it, the median not."""
    speed = np.linspace(8.0, 12.0, 51)
    speed[40] = 2900.0
    summary = wave_speed_summary(speed, 10.0)
    assert summary["median"] == pytest.approx(10.0, abs=0.1) and summary["mean"] > 60
    assert summary["max"] == 2900.0 and summary["cycle"] == 10.0


def test_constant_map_gives_nan_speeds_with_a_warning():
    area = np.ones((20, 30))
    with pytest.warns(RuntimeWarning, match="do not change"):
        ridge = ridge_times(area, PERIOD)
    assert np.all(np.isnan(ridge))
    s = np.linspace(0, 1, 20)
    assert np.all(np.isnan(local_speed(s, ridge)))
    assert np.isnan(cycle_speed(s, ridge))
    empty = wave_speed_summary(local_speed(s, ridge), np.nan)
    assert np.isnan(empty["mean"]) and np.isnan(empty["median"])


def hump_map(arrival_ms, period_ms, n_t, expand_fraction=0.4, rng=None, frame_noise=0.0):
    """The phantom's asymmetric beat: a raised-cosine expansion over ``expand_fraction``
    of the cycle, then a slower contraction; the area peaks at ``arrival + expand_fraction
    period``. ``frame_noise``: relative error of each frame's areas (all rows alike, as
    when each frame is meshed independently), plus a tenth of it per cell."""
    t = np.arange(n_t) * period_ms / n_t
    phi = ((t[None, :] - arrival_ms[:, None]) / period_ms) % 1.0
    h = np.where(
        phi < expand_fraction,
        0.5 - 0.5 * np.cos(np.pi * phi / expand_fraction),
        0.5 + 0.5 * np.cos(np.pi * (phi - expand_fraction) / (1 - expand_fraction)),
    )
    area = 0.12 * (1 - 0.3 * (1 - h)) ** 2
    if frame_noise:
        area *= 1 + frame_noise * (
            rng.standard_normal(n_t)[None, :] + 0.1 * rng.standard_normal(area.shape)
        )
    return area


def test_ridge_smoothing_takes_out_each_frames_own_error():
    """195 frames of a 360 ms beat whose areas each carry a 0.02 % error of their own
    (as the phantoms' independent meshes do): the peak is flat over several frames, so
    the raw ridge is off by ~1 ms RMS and some local speeds by 20-500 %. Smoothed by 5 ms
    the ridge keeps a constant shift (the asymmetric peak) and loses the noise."""
    period, n_t, c = 360.0, 195, 12.0
    s = np.linspace(0, 1.2, 50)
    arrival = 1e3 * s / c
    area = hump_map(arrival, period, n_t, rng=np.random.default_rng(3), frame_noise=2e-4)
    truth = arrival + 0.4 * period

    def errors(smoothing_ms):
        ridge = ridge_times(area, period, smoothing_ms=smoothing_ms)
        d = (ridge - truth + period / 2) % period - period / 2
        speed = local_speed(s, ridge)
        return (
            d.mean(),
            np.sqrt(np.mean((d - d.mean()) ** 2)),
            np.abs(speed / c - 1).max(),
            cycle_speed(s, ridge) / c - 1,
        )

    shift, rms, worst, cycle = errors(5.0)
    assert 1.0 < shift < 2.5  # later: the contraction is the slower side
    assert rms < 0.2 and worst < 0.1 and abs(cycle) < 0.005
    raw_shift, raw_rms, raw_worst, _ = errors(0.0)
    assert abs(raw_shift) < 1.0 and raw_rms > 0.7 and raw_worst > 0.15  # what smoothing avoids


def test_smooth_in_time_keeps_symmetric_peaks_and_nan_cells():
    arrival = np.array([5.0, 50.0, 97.5])  # the first and last wrap around the cycle
    area = pulse_map(arrival)
    smooth = smooth_in_time(area, PERIOD, 5.0)
    assert np.allclose(
        ridge_times(smooth, PERIOD, smoothing_ms=0) % PERIOD,
        ridge_times(area, PERIOD, smoothing_ms=0) % PERIOD,
        atol=0.05,
    )
    assert smooth.max() < area.max() and np.isclose(smooth.mean(), area.mean())
    assert np.array_equal(smooth_in_time(area, PERIOD, 0.0), area)
    holed = area.copy()
    holed[1, 40:45] = np.nan
    out = smooth_in_time(holed, PERIOD, 5.0)
    assert np.isnan(out[1, 40:45]).all() and np.isfinite(np.delete(out[1], range(40, 45))).all()
    assert np.allclose(out[[0, 2]], smooth[[0, 2]])
    for bad in (-1.0, np.nan, np.inf):
        with pytest.raises(InputError, match="smoothing sigma"):
            smooth_in_time(area, PERIOD, bad)


def test_map_noise_sd_measures_white_noise_and_not_the_beat():
    period, n_t = 360.0, 195
    s = np.linspace(0, 1.2, 60)
    clean = hump_map(1e3 * s / 12.0, period, n_t)
    sd = np.linspace(1e-4, 1e-3, 60)  # mm^2, one per row
    noisy = clean + np.random.default_rng(5).standard_normal(clean.shape) * sd[:, None]
    ratio = map_noise_sd(noisy) / sd
    assert abs(ratio.mean() - 1) < 0.05 and np.all(np.abs(ratio - 1) < 0.3)
    amplitude = clean.max(axis=1) - clean.min(axis=1)
    assert np.all(map_noise_sd(clean) < 1e-5 * amplitude)  # the beat is not noise
    assert np.isnan(map_noise_sd(noisy[:, :9])).all()  # too few frames to tell
    assert np.isfinite(map_noise_sd(noisy[:, :10])).all()


def test_speed_spread_matches_the_scatter_of_repeated_measurements():
    """One noisy map's spread against the scatter of the speeds measured on 40 maps of
    the same beat, each with noise of its own (1 % of the area's range per cell)."""
    period, n_t, c = 360.0, 195, 12.0
    s = np.linspace(0, 1.2, 50)
    clean = hump_map(1e3 * s / c, period, n_t)
    rng = np.random.default_rng(11)
    noise = 0.01 * (clean.max() - clean.min())

    def measure():
        area = clean + noise * rng.standard_normal(clean.shape)
        ridge = ridge_times(area, period)
        speeds = wave_speeds(s, ridge)
        return area, ridge, speeds["local"], speeds["summary"]["cycle"]

    def sd(x):  # robust, as the spread is measured
        lo, hi = np.percentile(x, [16, 84], axis=0)
        return (hi - lo) / 2

    repeats = [measure() for _ in range(40)]
    ridge_sd = sd([r[1] for r in repeats])
    local_sd = sd([r[2] for r in repeats])
    cycle_sd = sd([r[3] for r in repeats])
    spread = speed_spread(repeats[0][0], s, period)
    assert np.allclose(spread["noise_sd"], noise, rtol=0.25)
    assert 0.7 < np.median(spread["ridge_t_ms"] / ridge_sd) < 1.4
    resolved = np.isfinite(spread["local_speed_mm_s"])  # not the 1-2 end rows: 4 points
    assert resolved.mean() > 0.9
    assert 0.7 < np.median(spread["local_speed_mm_s"][resolved] / local_sd[resolved]) < 1.4
    assert 0.6 < spread["speeds"]["cycle"] / cycle_sd < 1.6
    assert set(spread["speeds"]) == {"min", "max", "mean", "median", "cycle", "proximal", "distal"}
    assert speed_spread(repeats[0][0], s, period, draws=20, seed=4)["speeds"] != spread["speeds"]
    assert speed_spread(repeats[0][0], s, period)["speeds"] == spread["speeds"]  # seeded


def test_an_unresolved_wave_speed_is_said():
    """A stretch where the wave arrives everywhere at once (infinite local speed): noise
    alone turns its speeds from large positive to negative, so those rows' speeds have
    no spread (NaN) and are left out of the speed statistics, which the analysis says;
    the maximum is then resolved, beside the stretch, and the cycle speed stays
    resolved. (Before, the maximum was the stretch's 7e4 mm/s, without a spread.)"""
    period, n_t = 360.0, 195
    s = np.linspace(0, 1.2, 50)
    arrival = 1e3 * np.minimum(s, 0.5) / 8.0 + 1e3 * np.maximum(s - 0.8, 0) / 8.0
    clean = hump_map(arrival, period, n_t)
    area = clean + 0.005 * (clean.max() - clean.min()) * np.random.default_rng(2).standard_normal(
        clean.shape
    )
    arrays, summary = analyse_area_maps({"outer": area}, s, period)
    sd, speed = summary["wave_speed_noise_sd_mm_s"], summary["wave_speed_mm_s"]
    # the max is a row beside the stretch, whose 7-row slope takes in part of it
    assert 8.0 < speed["max"] < 40 and sd["max"] < 0.5 * speed["max"]
    assert speed["min"] == pytest.approx(8.0, rel=0.15) and 8.0 < speed["mean"] < 10.0
    assert sd["cycle"] < 0.05 * speed["cycle"]
    with_speed = np.count_nonzero(np.isfinite(arrays["local_speed_mm_s"]))
    assert 30 <= speed["rows_used"] < with_speed
    note = [n for n in summary["image_analysis_notes"] if "whose speed the map's noise" in n]
    assert len(note) == 1 and f"the {speed['rows_used']} of {with_speed} rows" in note[0]
    flat = (s > 0.55) & (s < 0.75)
    assert np.all(
        ~np.isfinite(arrays["local_speed_noise_sd_mm_s"][flat])
        | (arrays["local_speed_noise_sd_mm_s"][flat] > 100)
    )
    assert np.all(arrays["local_speed_noise_sd_mm_s"][s < 0.4] < 2.0)
    assert arrays["ridge_t_noise_sd_ms"].shape == s.shape


def test_auto_smoothing_is_as_much_as_the_noise_needs():
    """A clean beat keeps the least smoothing; under noise of 1 % of the area's range the
    smoothing grows until the local speeds' spread is 10 % of them, and the local speeds
    come out nearer the truth than with 5 ms."""
    period, n_t, c = 360.0, 195, 12.0
    s = np.linspace(0, 1.2, 50)
    clean = hump_map(1e3 * s / c, period, n_t, rng=np.random.default_rng(1), frame_noise=2e-4)
    sigma, spread = auto_ridge_smoothing(clean, s, period)
    assert sigma == 5.0
    noisy = clean + 0.01 * np.ptp(clean) * np.random.default_rng(2).standard_normal(clean.shape)
    sigma, spread = auto_ridge_smoothing(noisy, s, period)
    assert 5.0 < sigma < 20.0
    local = spread["measured"]["local"]
    assert np.median(spread["local_speed_mm_s"] / np.abs(local)) <= 0.10
    at_5 = speed_spread(noisy, s, period, smoothing_ms=5.0)
    assert np.nanmedian(at_5["local_speed_mm_s"] / np.abs(at_5["measured"]["local"])) > 0.10
    error = {
        k: np.median(np.abs(v / c - 1))
        for k, v in (("auto", local), ("5 ms", at_5["measured"]["local"]))
    }
    assert error["auto"] < 0.6 * error["5 ms"]
    arrays, summary = analyse_area_maps({"outer": noisy}, s, period)  # auto by default
    assert summary["ridge_smoothing_ms"] == sigma
    assert np.array_equal(arrays["local_speed_mm_s"], local)
    assert (
        analyse_area_maps({"outer": noisy}, s, period, ridge_smoothing_ms=7)[1][
            "ridge_smoothing_ms"
        ]
        == 7.0
    )
    assert auto_ridge_smoothing(noisy[:, :9], s, period)[0] == 5.0  # no noise measure


def test_noise_correlated_from_frame_to_frame_is_pointed_out():
    """White noise (as from frames segmented one by one) has as much power near half the
    frame rate as at a quarter of it; noise smoothed in time (a segmentation that
    smooths over frames) has far less, and its spread would be underestimated."""
    from scipy.ndimage import gaussian_filter1d

    period, n_t = 360.0, 195
    s = np.linspace(0, 1.2, 50)
    clean = hump_map(1e3 * s / 12.0, period, n_t)
    white = np.random.default_rng(3).standard_normal(clean.shape)
    smoothed = gaussian_filter1d(white, 1.0, axis=1, mode="wrap")
    noise = 0.005 * np.ptp(clean)
    colours, notes = [], []
    for e in (white, smoothed):
        arrays, summary = analyse_area_maps({"outer": clean + noise * e / e.std()}, s, period)
        colours.append(summary["area_noise_colour"])
        notes.append([n for n in summary["image_analysis_notes"] if "correlated" in n])
    assert 0.8 < colours[0] < 1.25 and colours[1] > 10
    assert notes[0] == [] and len(notes[1]) == 1
    assert np.isnan(noise_colour(clean[:, :15]))


def test_a_map_too_short_to_measure_its_noise_says_so():
    s = np.linspace(0, 1.2, 30)
    area = hump_map(1e3 * s / 10.0, 360.0, 9)
    arrays, summary = analyse_area_maps({"outer": area}, s, 360.0)
    assert np.isnan(arrays["area_noise_sd_outer_mm2"]).all()
    assert all(np.isnan(v) for v in summary["wave_speed_noise_sd_mm_s"].values())
    notes = summary["image_analysis_notes"]
    assert any("cannot be measured on 9 frames" in n for n in notes)
    assert not any("not resolved" in n for n in notes)


def test_speed_spread_refuses_bad_arguments():
    area = pulse_map(np.linspace(10, 40, 20))
    with pytest.raises(InputError, match="draws"):
        speed_spread(area, np.linspace(0, 1, 20), PERIOD, draws=5)
    with pytest.raises(InputError, match="one value per row"):
        speed_spread(area, np.linspace(0, 1, 19), PERIOD)


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
    assert np.allclose(mask_s.mean(axis=1), share_s, atol=1.5 / N_T)  # the mask is that share


def _neck_map(s_at, t_ms):
    """Area of a tube with a neck at 0.3 mm (a steep gradient along s) and a pulse
    travelling at 10 mm/s, at positions ``s_at (n_v, n_t)``."""
    dt = (t_ms - 1e3 * s_at / 10.0 + PERIOD / 2) % PERIOD - PERIOD / 2
    neck = 1 - 0.5 * np.exp(-0.5 * ((s_at - 0.3) / 0.04) ** 2)
    return neck * (1 + 0.05 * np.exp(-0.5 * (dt / 8.0) ** 2))


def test_rows_drifting_along_a_neck_are_put_back_in_place():
    """Rows that move 10 um back and forth over the cycle (ends fixed) sample the
    neck's steep gradient: their map is off by up to ~10 % and the ridge by several
    ms. Put back at fixed positions, both are right again."""
    s = np.linspace(0, 0.6, 61)
    t = np.arange(N_T) * PERIOD / N_T
    drift = 0.01 * np.sin(np.pi * s / 0.6)[:, None] * np.sin(2 * np.pi * t / PERIOD)[None, :]
    s_rows = s[:, None] + drift
    measured = _neck_map(s_rows, t[None, :])
    truth = _neck_map(s[:, None] + 0 * t[None, :], t[None, :])
    fixed = at_fixed_positions(measured, s_rows, s)
    assert np.abs(measured / truth - 1).max() > 0.05
    assert np.abs(fixed / truth - 1).max() < 2e-3
    ridge_rows, ridge_fixed = (ridge_times(a, PERIOD) for a in (measured, fixed))
    true_ridge = ridge_times(truth, PERIOD)
    assert np.abs(ridge_rows - true_ridge).max() > 3.0
    assert np.abs(ridge_fixed - true_ridge).max() < 0.5


def test_fixed_positions_follow_a_tube_whose_length_changes():
    """Rows at the same fraction of each frame's length: a map that depends on
    s / length alone comes back unchanged, whatever the rows' spacing."""
    u = np.linspace(0, 1, 31) ** 1.3  # uneven rows
    length = 1.0 + 0.1 * np.sin(2 * np.pi * np.arange(8) / 8)
    s_rows = u[:, None] * length[None, :]
    area = np.cos(u)[:, None] * np.ones((1, 8))
    s_mm = s_rows.mean(axis=1)
    fixed = at_fixed_positions(area, s_rows, s_mm)
    assert np.allclose(fixed, np.cos(s_mm / s_mm[-1])[:, None], atol=1e-6)


def test_fixed_positions_leave_out_nan_cells_and_check_shapes():
    s = np.linspace(0, 1, 11)
    s_rows = np.repeat(s[:, None], 4, axis=1)
    area = np.repeat((1 + s)[:, None], 4, axis=1)
    area[5, 1] = np.nan  # interpolated over
    area[1:, 2] = np.nan  # one value left: NaN frame
    fixed = at_fixed_positions(area, s_rows, s)
    assert np.allclose(fixed[:, [0, 1, 3]], (1 + s)[:, None])
    assert np.isnan(fixed[:, 2]).all()
    with pytest.raises(InputError, match="s_rows_mm must have the map's shape"):
        at_fixed_positions(area, s_rows[:, :3], s)
    with pytest.raises(InputError, match="s_mm must have one value per row"):
        at_fixed_positions(area, s_rows, s[:5])


def test_gaussian_fit_is_the_least_squares_over_all_widths():
    """A narrow beat on a broad swell, noisy: the fit's sum of squares is the least
    over 4000 widths from 0.5 frame to the whole cycle, each with its own best base
    and amplitude (amplitude >= 0), and R^2 is that fit's."""
    t = np.arange(N_T)
    rng = np.random.default_rng(4)
    dt = (t - 40.3 + N_T / 2) % N_T - N_T / 2
    rows = np.array(
        [
            1
            + 0.3 * np.exp(-0.5 * (dt / 3) ** 2)
            + w * np.exp(-0.5 * (dt / 25) ** 2)
            + 0.01 * rng.standard_normal(N_T)
            for w in (0.1, 0.2, 0.3, 0.4)
        ]
    )
    _, sigma, r2, _ = expanded_sigma(rows, min_r2=0.0)

    def sse(y, width):
        g = np.exp(
            -0.5 * (((t - periodic_peak(y, find="max") + N_T / 2) % N_T - N_T / 2) / width) ** 2
        )
        (base, amp), *_ = np.linalg.lstsq(np.column_stack([np.ones(N_T), g]), y, rcond=None)
        return ((y - y.mean()) ** 2).sum() if amp < 0 else ((y - base - amp * g) ** 2).sum()

    for y, s, r in zip(rows, sigma, r2):
        brute = min(sse(y, w) for w in np.geomspace(0.5, N_T, 4000))
        assert sse(y, s) <= brute * (1 + 1e-9)
        assert r == pytest.approx(1 - sse(y, s) / ((y - y.mean()) ** 2).sum(), abs=1e-12)


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
    assert res["summary"]["band_position_mm"] == pytest.approx(truth["band_position_mm"], abs=0.08)
    assert res["summary"]["wave_speed_mm_s"]["cycle"] == pytest.approx(
        truth["wave_speed_mm_s"]["cycle"], rel=0.10
    )


@pytest.mark.slow
def test_fixed_map_positions_on_a_banded_phantom(analysed_banded, phantom_banded):
    """Next to the band, the grid rows drift along the neck's steep gradient: with
    map_positions="fixed" the area map is twice as close to the truth (95th
    percentile 1.2 % -> 0.6 % on this phantom) and the mean wave speed is right
    (13.6 -> 10.9 mm/s, truth 10.7). The rows' own areas are kept."""
    from oftimg.io.dataset import load_dataset
    from oftimg.analysis.pipeline import PipelineOptions, analyse_dataset

    ph, truth, by_rows = analysed_banded
    fixed = analyse_dataset(
        load_dataset(phantom_banded), PipelineOptions(map_positions="fixed"), quiet=True
    )
    a, b = by_rows["arrays"], fixed["arrays"]
    assert "area_rows_outer_mm2" not in a
    assert np.allclose(b["area_rows_outer_mm2"], a["area_outer_mm2"])
    assert np.allclose(
        b["area_outer_mm2"], at_fixed_positions(a["area_outer_mm2"], a["s_rows_mm"], a["s_mm"])
    )
    assert fixed["summary"]["provenance"]["options"]["map_positions"] == "fixed"
    t_ms = np.roll(truth["t_ms"], -by_rows["summary"]["t0_frame"])
    expected = ph.area_mm2("outer", a["s_mm"][:, None], t_ms[None, :])
    p95 = {
        k: np.percentile(np.abs(r["area_outer_mm2"] / expected - 1), 95)
        for k, r in (("rows", a), ("fixed", b))
    }
    assert p95["fixed"] < 0.01 and p95["fixed"] < 0.7 * p95["rows"]
    assert fixed["summary"]["wave_speed_mm_s"]["mean"] == pytest.approx(
        truth["wave_speed_mm_s"]["mean"], rel=0.10
    )


def test_map_positions_are_checked():
    from oftimg.analysis.pipeline import PipelineOptions

    with pytest.raises(InputError, match="map_positions must be one of"):
        PipelineOptions(map_positions="eulerian")
    for bad in (-1, "5 ms", None, float("nan"), float("inf")):
        with pytest.raises(InputError, match="ridge_smoothing_ms must be 'auto' or a number"):
            PipelineOptions(ridge_smoothing_ms=bad)
    assert PipelineOptions(ridge_smoothing_ms=0).as_dict()["ridge_smoothing_ms"] == 0.0
    for bad in (-1, "5 ms", None, float("nan"), float("inf")):
        with pytest.raises(InputError, match="field_smoothing_ms must be 'auto' or a number"):
            PipelineOptions(field_smoothing_ms=bad)
    assert PipelineOptions(field_smoothing_ms="7").as_dict()["field_smoothing_ms"] == 7.0
    assert PipelineOptions().as_dict()["field_smoothing_ms"] == "auto"
    for bad in (-1, "5 ms", None, float("nan")):
        with pytest.raises(InputError, match="strain_smoothing_ms must be 'auto' or a number"):
            PipelineOptions(strain_smoothing_ms=bad)
    assert PipelineOptions(strain_smoothing_ms="0").as_dict()["strain_smoothing_ms"] == 0.0
    assert PipelineOptions().as_dict()["strain_smoothing_ms"] == "auto"


def test_cells_without_a_contour_are_filled_periodically_in_time_and_rows_along_v():
    """A NaN cell gets its row's value interpolated over the cycle's end (periodic); a
    row with no value at all gets its neighbours' mean, frame by frame."""
    from oftimg.analysis.maps import fill_gaps

    n_v, n_t = 6, 20
    t = np.arange(n_t)
    area = 1.0 + np.arange(n_v)[:, None] + 0.1 * np.cos(2 * np.pi * t / n_t)[None, :]
    holes = area.copy()
    holes[1, [0, n_t - 1]] = np.nan  # across the cycle's end: needs the period
    holes[3] = np.nan
    filled, count = fill_gaps(holes)
    assert count == 2 + n_t
    # rows 2 and 4 are linear in v: row 3 is their mean exactly
    assert np.allclose(filled[3], area[3])
    # periodic linear interpolation between frames n_t - 2 and 1 (3 steps apart)
    a, b = area[1, n_t - 2], area[1, 1]
    assert np.allclose(filled[1, [n_t - 1, 0]], [a + (b - a) / 3, a + 2 * (b - a) / 3])
    assert np.array_equal(filled[~np.isnan(holes)], area[~np.isnan(holes)])
    same, none = fill_gaps(area)
    assert none == 0 and np.array_equal(same, area)
    s = np.linspace(0, 0.3, 50)
    pulse = pulse_map(17.3 + 1e3 * s / 10.0)
    pulse[[5, 20, 33], [40, 0, 71]] = np.nan  # sections without a contour
    _, summary = analyse_area_maps({"outer": pulse}, s, PERIOD, ridge_smoothing_ms=5)
    assert summary["area_cells_interpolated"] == {"outer": 3}
    assert summary["wave_speed_mm_s"]["cycle"] == pytest.approx(10.0, rel=0.01)


def test_a_neck_that_barely_moves_is_bridged_for_the_speeds():
    """A wave at 10 mm/s along a tube whose rows 22-27 barely move (a band's neck: a
    tenth of the others' swing) and peak 12 ms early there, as the banded phantoms'
    neck did: a systematic error the noise spread cannot see. The neck's rows are found
    still, the speeds bridge them, and the mean of the local speeds is the wave's."""
    from oftimg.image.kymograph import bridged_ridge, speed_spread, still_rows

    period, n_t, c = 360.0, 195, 10.0
    s = np.linspace(0, 1.2, 50)
    neck = (np.arange(50) >= 22) & (np.arange(50) <= 27)
    arrival = 1e3 * s / c - 12.0 * neck
    area = hump_map(arrival, period, n_t, rng=np.random.default_rng(4), frame_noise=2e-4)
    mean = area.mean(axis=1, keepdims=True)
    area = np.where(neck[:, None], mean + 0.1 * (area - mean), area)
    assert np.array_equal(still_rows(area), neck)
    spread = speed_spread(area, s, period, smoothing_ms=5.0)
    summary = spread["measured"]["summary"]
    assert summary["mean"] == pytest.approx(c, rel=0.03)
    assert summary["max"] < 1.2 * c and summary["min"] > 0.8 * c
    assert np.array_equal(spread["still_rows"], neck)
    assert np.isfinite(spread["ridge"][neck]).all()  # the map's own ridge kept
    # the bridge: the line between the nearest moving rows; an end has none beyond it
    t = np.array([0.0, 1.0, 9.0, 3.0, 4.0, 5.0])
    x = np.arange(6.0)
    assert np.allclose(bridged_ridge(t, x, x == 2), [0, 1, 2, 3, 4, 5])
    assert np.allclose(bridged_ridge(t, x, x >= 4), [0, 1, 9, 3, np.nan, np.nan], equal_nan=True)


@pytest.mark.parametrize("speed, limited", [(80.0, True), (30.0, True), (15.0, False)])
def test_a_wave_faster_than_the_frames_is_said_to_be(speed, limited):
    """A wave crossing a 1.3 mm tube in 16 ms, under one frame of 30 over 490 ms (the
    zoo's draw 10: its cycle speed came out 40 % slow with a spread of 1 %) or in 43 ms
    (2.7 frames: draw 34 came out 20 % slow) is said to be at the frame rate's limit;
    one crossing it in 87 ms (5 frames) is not."""
    period, n_t = 490.0, 30
    s = np.linspace(0, 1.3, 50)
    area = hump_map(1e3 * s / speed, period, n_t)
    arrays, summary = analyse_area_maps({"outer": area}, s, period)
    crossing = summary["wave_crossing_frames"]
    assert crossing == pytest.approx(
        1.3 / summary["wave_speed_mm_s"]["cycle"] * 1e3 / (period / n_t)
    )
    notes = [n for n in summary["image_analysis_notes"] if "limit of the frame rate" in n]
    assert (len(notes) == 1) == limited
    assert (crossing < FRAME_LIMITED_CROSSING) == limited


def test_a_map_whose_areas_barely_change_has_no_wave_to_time():
    """A wave that moves the ring's parts in turn (a helix on the wall) leaves each
    section's area all but constant: a map whose rows swing by 1 % holds no wave, even
    where a ridge can be found in it (issue 83, point 4: a helical phantom gave -8.7 mm/s
    and a 58 % expansion share); no speed, said in one note that points to the wall."""
    s = np.linspace(0, 1.2, 40)
    arrival = 1e3 * s / 12.0
    travelling = hump_map(arrival, 360.0, 60)
    flat = 1 + 0.01 * (travelling - travelling.min()) / np.ptp(travelling)  # 0.99 %
    for area, moves in ((travelling, True), (flat, False)):
        arrays, summary = analyse_area_maps({"outer": area}, s, 360.0)
        assert summary["area_wave"] is moves
        speeds = summary["wave_speed_mm_s"]
        assert bool(np.isfinite(speeds["cycle"])) is moves
        said = [n for n in summary["image_analysis_notes"] if "holds no wave" in n]
        assert bool(said) is not moves
    assert "change by 0.99 % over the beat" in said[0] and "wave_fronts" in said[0]
    assert summary["area_swing"] == pytest.approx(0.01 / 1.01, rel=0.02)
