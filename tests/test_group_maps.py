"""Embryos' maps on one common grid: known answers from an analytic wave."""

import numpy as np
import pytest

from oftimg.analysis.group_maps import common_grid, group_mean_maps, on_common_grid, row_normalized


def wave(fraction, phase):
    """A smooth travelling bump in (position fraction, cycle fraction), periodic."""
    return 1.0 + 0.4 * np.cos(np.pi * (phase - 0.3 - 0.25 * fraction)) ** 8


@pytest.mark.parametrize("n_t, length", [(195, 1.3), (40, 0.9)])
def test_a_travelling_wave_comes_out_on_the_common_grid(n_t, length):
    """Sampled at uneven positions along a tube of its own length and at its own
    frame times, the same wave lands on the same common map."""
    period = 375.0
    s = length * np.sort(np.r_[0.0, np.random.default_rng(1).random(48), 1.0])
    t = np.arange(n_t) * period / n_t
    values = wave((s / length)[:, None], (t / period)[None, :])
    found = on_common_grid(values, s, t, period)
    position, phase = common_grid()
    assert found.shape == (len(position), len(phase)) == (50, 100)
    expected = wave(position[:, None], phase[None, :])
    # linear interpolation of a bump sampled every 1/40 of its cycle at worst
    assert np.abs(found - expected).max() < (0.01 if n_t == 195 else 0.04)
    # at the samples themselves (the tube's ends; every other frame, at 0.05 k of the
    # cycle, is on the grid) exactly
    if n_t == 40:
        assert found[[0, -1]][:, ::5] == pytest.approx(values[[0, -1]][:, ::2], abs=1e-12)


def test_bad_maps_are_refused():
    with pytest.raises(ValueError, match="shape"):
        on_common_grid(np.zeros((3, 4)), np.arange(3.0), np.arange(5.0), 10.0)
    with pytest.raises(ValueError, match="increase"):
        on_common_grid(np.zeros((3, 4)), np.array([0.0, 2.0, 1.0]), np.arange(4.0), 10.0)


def test_rows_over_their_maximum_and_group_means():
    values = np.array([[1.0, 2.0, 4.0], [np.nan, np.nan, np.nan], [3.0, np.nan, 1.5]])
    norm = row_normalized(values)
    assert norm[0] == pytest.approx([0.25, 0.5, 1.0])
    assert np.isnan(norm[1]).all() and norm[2, 2] == pytest.approx(0.5)
    maps = np.stack([np.full((2, 3), k, dtype=float) for k in (1, 3, 5, 10)])
    means = group_mean_maps(maps, ["b", "a", "b", "a"])
    assert list(means) == ["b", "a"]  # in the order groups appear
    mean, sd, n = means["b"]
    assert n == 2 and np.all(mean == 3.0) and sd == pytest.approx(np.full((2, 3), 2**1.5))
    one = group_mean_maps(maps[:1], ["x"])["x"]
    assert one[2] == 1 and np.isnan(one[1]).all()


def test_cohort_maps_of_a_dataset_without_an_inner_wall(tmp_path):
    """Its wall thickness map is NaN throughout (and said by nothing but NaN); the
    other's is its rows' mean around the tube."""
    from oftimg.output.export import cohort_maps

    s, t = np.linspace(0.0, 1.2, 50), np.arange(20) * 18.0
    area = wave((s / s[-1])[:, None], (t / 360.0)[None, :])
    thickness = np.broadcast_to(0.03 + 0.01 * (s / s[-1])[None, :, None], (8, 50, 20))
    summaries = []
    for name, extra in (("with", {"wall_thickness_mm": thickness}), ("without", {})):
        (tmp_path / name).mkdir()
        np.savez(tmp_path / name / "arrays.npz", s_mm=s, t_ms=t, area_outer_mm2=area, **extra)
        summaries.append({"name": name, "group": "normal", "period_ms": 360.0})
    maps = cohort_maps(tmp_path, summaries)
    position, _ = common_grid()
    assert maps["wall_thickness_mm"][0] == pytest.approx(
        np.broadcast_to((0.03 + 0.01 * position)[:, None], (50, 100)), rel=1e-12
    )
    assert np.isnan(maps["wall_thickness_mm"][1]).all()
    assert maps["area_outer_mm2"][0] == pytest.approx(maps["area_outer_mm2"][1])
