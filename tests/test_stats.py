"""Where two groups' maps differ: the max-statistic permutation test, corrected over
the map (family-wise), exact and with random relabellings."""
import numpy as np
import pytest

from oftimg.image.group_maps import group_differences
from oftimg.stats import map_permutation_test


def test_complete_separation_everywhere_gives_the_least_exact_p():
    base = np.arange(4.0)[:, None, None] * np.ones((4, 3, 5))
    difference, p = map_permutation_test(base + 10, base)
    assert difference == pytest.approx(np.full((3, 5), 10.0))
    assert p == pytest.approx(np.full((3, 5), 2 / 70))              # 2 of C(8, 4)
    _, same = map_permutation_test(base, base.copy())
    assert same == pytest.approx(np.ones((3, 5)))


def test_a_block_that_differs_is_found_and_noise_is_not():
    rng = np.random.default_rng(3)
    a, b = rng.normal(0, 1, (6, 20, 30)), rng.normal(0, 1, (6, 20, 30))
    a[:, 5:10, 5:10] += 6.0
    difference, p = map_permutation_test(a, b)
    block = np.zeros((20, 30), bool)
    block[5:10, 5:10] = True
    assert np.all(p[block] < 0.05)
    assert np.all(p[~block] > 0.05)
    assert np.all(p >= 2 / 924 - 1e-12)            # exact: C(12, 6) relabellings
    np.testing.assert_allclose(difference, a.mean(0) - b.mean(0))


def test_family_wise_error_under_the_null_is_at_most_alpha():
    """300 cohorts of 5 + 5 noise maps: the share with any pixel p < 0.05 stays near
    0.05 (the exact test's 12/252 = 0.048), where uncorrected pixels would flag most."""
    rng = np.random.default_rng(7)
    any_flagged = [np.nanmin(map_permutation_test(rng.normal(size=(5, 8, 8)),
                                                  rng.normal(size=(5, 8, 8)))[1]) < 0.05
                   for _ in range(300)]
    rate = np.mean(any_flagged)
    assert 0.015 < rate < 0.05 + 3 * np.sqrt(0.05 * 0.95 / 300)


def test_random_relabellings_agree_with_every_relabelling():
    rng = np.random.default_rng(5)
    a, b = rng.normal(0.8, 1, (8, 6, 6)), rng.normal(0, 1, (8, 6, 6))   # C(16, 8) = 12870
    _, exact = map_permutation_test(a, b)
    _, sampled = map_permutation_test(a, b, exact_max=100, n_random=4000, seed=1)
    assert np.abs(sampled - exact).max() < 0.03                  # 4 standard errors
    assert sampled.min() >= 1 / 4001
    _, again = map_permutation_test(a, b, exact_max=100, n_random=4000, seed=1)
    np.testing.assert_array_equal(sampled, again)


def test_missing_maps_and_pixels():
    rng = np.random.default_rng(0)
    a, b = rng.normal(1, 1, (4, 5, 5)), rng.normal(0, 1, (4, 5, 5))
    difference, p = map_permutation_test(a, b)
    without_inner = np.full((1, 5, 5), np.nan)          # an embryo without that field
    d2, p2 = map_permutation_test(np.concatenate([a, without_inner]), b)
    np.testing.assert_array_equal(p2, p)
    np.testing.assert_array_equal(d2, difference)
    a[2, 1, 3] = np.nan
    d3, p3 = map_permutation_test(a, b)
    assert np.isnan(p3[1, 3]) and np.isnan(d3[1, 3])
    assert np.isfinite(np.delete(p3.ravel(), 8)).all()
    d1, p1 = map_permutation_test(a[:1], b)
    assert np.isnan(p1).all() and d1[0, 0] == pytest.approx(a[0, 0, 0] - b[:, 0, 0].mean())
    with pytest.raises(ValueError, match="maps of shapes"):
        map_permutation_test(a, b[:, :4])


def test_each_group_against_the_normals():
    rng = np.random.default_rng(0)
    maps = rng.normal(size=(7, 4, 6))
    groups = ["KO", "normal", "banded", "normal", "banded", "KO", "normal"]
    names, difference, p = group_differences(maps, groups)
    assert names == ["KO - normal", "banded - normal"]
    assert difference.shape == p.shape == (2, 4, 6)
    g = np.array(groups)
    np.testing.assert_allclose(difference[1], maps[g == "banded"].mean(0)
                               - maps[g == "normal"].mean(0))
    names, difference, p = group_differences(maps, ["normal"] * 7)
    assert names == [] and difference.shape == p.shape == (0, 4, 6)
