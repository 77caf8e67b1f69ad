"""Where two groups' maps differ: the max-statistic permutation test, corrected over
the map (family-wise), exact and with random relabellings."""

import numpy as np
import pytest

from oftimg.analysis.group_maps import group_differences
from oftimg.analysis.stats import _cluster_labels, map_cluster_test, map_permutation_test


def test_complete_separation_everywhere_gives_the_least_exact_p():
    base = np.arange(4.0)[:, None, None] * np.ones((4, 3, 5))
    difference, p = map_permutation_test(base + 10, base)
    assert difference == pytest.approx(np.full((3, 5), 10.0))
    assert p == pytest.approx(np.full((3, 5), 2 / 70))  # 2 of C(8, 4)
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
    assert np.all(p >= 2 / 924 - 1e-12)  # exact: C(12, 6) relabellings
    np.testing.assert_allclose(difference, a.mean(0) - b.mean(0))


def test_family_wise_error_under_the_null_is_at_most_alpha():
    """300 cohorts of 5 + 5 noise maps: the share with any pixel p < 0.05 stays near
    0.05 (the exact test's 12/252 = 0.048), where uncorrected pixels would flag most."""
    rng = np.random.default_rng(7)
    any_flagged = [
        np.nanmin(map_permutation_test(rng.normal(size=(5, 8, 8)), rng.normal(size=(5, 8, 8)))[1])
        < 0.05
        for _ in range(300)
    ]
    rate = np.mean(any_flagged)
    assert 0.015 < rate < 0.05 + 3 * np.sqrt(0.05 * 0.95 / 300)


def test_random_relabellings_agree_with_every_relabelling():
    rng = np.random.default_rng(5)
    a, b = rng.normal(0.8, 1, (8, 6, 6)), rng.normal(0, 1, (8, 6, 6))  # C(16, 8) = 12870
    _, exact = map_permutation_test(a, b)
    _, sampled = map_permutation_test(a, b, exact_max=100, n_random=4000, seed=1)
    assert np.abs(sampled - exact).max() < 0.03  # 4 standard errors
    assert sampled.min() >= 1 / 4001
    _, again = map_permutation_test(a, b, exact_max=100, n_random=4000, seed=1)
    np.testing.assert_array_equal(sampled, again)


def test_missing_maps_and_pixels():
    rng = np.random.default_rng(0)
    a, b = rng.normal(1, 1, (4, 5, 5)), rng.normal(0, 1, (4, 5, 5))
    difference, p = map_permutation_test(a, b)
    without_inner = np.full((1, 5, 5), np.nan)  # an embryo without that field
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
    compared = group_differences(maps, groups)
    assert compared["names"] == ["KO - normal", "banded - normal"]
    for key in ("difference", "p_fwer", "p_cluster"):
        assert compared[key].shape == (2, 4, 6)
    g = np.array(groups)
    np.testing.assert_allclose(
        compared["difference"][1], maps[g == "banded"].mean(0) - maps[g == "normal"].mean(0)
    )
    np.testing.assert_array_equal(
        compared["p_cluster"][1],
        map_cluster_test(maps[g == "banded"], maps[g == "normal"], periodic_axis=1),
    )
    p_fwer = compared["p_fwer"]
    compared = group_differences(maps, ["normal"] * 7)
    assert compared["names"] == [] and compared["p_cluster"].shape == (0, 4, 6)
    wider = group_differences(maps, groups, cluster_alpha=0.3)  # the clusters' only
    np.testing.assert_array_equal(
        wider["p_cluster"][1],
        map_cluster_test(
            maps[g == "banded"], maps[g == "normal"], periodic_axis=1, cluster_alpha=0.3
        ),
    )
    np.testing.assert_array_equal(wider["p_fwer"], p_fwer)


def test_a_weak_extended_difference_is_found_as_a_cluster():
    """4 + 4 embryos, a band of rows 2.5 sd apart running round the whole cycle: hardly
    a pixel reaches p < 0.05 over the map alone, most of the band does as clusters."""
    rng = np.random.default_rng(0)
    a, b = rng.normal(0, 1, (4, 50, 100)), rng.normal(0, 1, (4, 50, 100))
    a[:, 20:30, :] += 2.5
    _, p_pixels = map_permutation_test(a, b)
    p = map_cluster_test(a, b, periodic_axis=1)
    band = np.zeros((50, 100), bool)
    band[20:30] = True
    assert np.mean(p_pixels[band] < 0.05) < 0.05
    assert np.mean(np.isclose(p[band], 2 / 70)) > 0.7  # 2 of C(8, 4)
    assert np.mean(p[~band] < 0.05) < 0.01  # the band's fringe
    assert np.all(np.isclose(p[p < 0.05], 2 / 70))


def test_a_higher_cluster_forming_threshold_finds_more_of_a_weak_difference():
    """4 + 4 embryos, a band 1.5 SD apart: clusters formed at uncorrected p <= 0.2 find
    twice as much of it (p < 0.05) as at 0.05, for a wider fringe outside it (still a
    few % of the map); the threshold must be a p strictly between 0 and 1."""
    rng = np.random.default_rng(1)
    a, b = rng.normal(0, 1, (4, 30, 40)), rng.normal(0, 1, (4, 30, 40))
    a[:, 10:20, :] += 1.5
    band = np.zeros((30, 40), bool)
    band[10:20] = True
    found, fringe = {}, {}
    for alpha in (0.01, 0.05, 0.2):
        p = map_cluster_test(a, b, periodic_axis=1, cluster_alpha=alpha)
        found[alpha], fringe[alpha] = np.mean(p[band] < 0.05), np.mean(p[~band] < 0.05)
    assert found[0.01] < found[0.05] < 0.5 < 2 * found[0.05] < found[0.2]
    assert fringe[0.01] <= fringe[0.05] < fringe[0.2] < 0.05
    for bad in (0, 1, -0.1, 1.5, float("nan"), True, "0.05"):
        with pytest.raises(ValueError, match="between 0 and 1"):
            map_cluster_test(a, b, cluster_alpha=bad)


def test_clusters_join_across_the_cycles_end():
    mask = np.zeros((4, 6), bool)
    mask[1, 0] = mask[1, 5] = mask[2, 5] = mask[3, 2] = True
    labels, count = _cluster_labels(mask, 1)
    np.testing.assert_array_equal(
        labels, [[0, 0, 0, 0, 0, 0], [1, 0, 0, 0, 0, 1], [0, 0, 0, 0, 0, 1], [0, 0, 2, 0, 0, 0]]
    )
    assert count == 2 and _cluster_labels(mask, None)[1] == 3
    other = np.zeros((4, 6), bool)
    other[0, 1] = other[2, 3] = True
    stack, count = _cluster_labels(np.stack([mask, other, mask]), 1)
    assert count == 6  # 2 + 2 + 2: no link between maps
    np.testing.assert_array_equal(stack[2] > 0, mask)
    rng = np.random.default_rng(2)
    a, b = rng.normal(0, 1, (5, 20, 40)), rng.normal(0, 1, (5, 20, 40))
    a[:, 5:10, :4] += 3.0
    a[:, 5:10, -4:] += 3.0
    wrapped = map_cluster_test(a, b, periodic_axis=1)
    cut = map_cluster_test(a, b)
    assert np.mean(wrapped[5:10, :4] < 0.05) > 0.8 and np.mean(wrapped[5:10, -4:] < 0.05) > 0.8
    # one cluster across the wrap: one p on both sides; cut apart, each half weighs less
    assert wrapped[7, 0] == wrapped[7, -1] < 0.05
    assert cut[7, 0] >= wrapped[7, 0] and cut[7, -1] >= wrapped[7, -1]


def test_cluster_family_wise_error_under_the_null():
    rng = np.random.default_rng(1)
    flagged = [
        np.nanmin(
            map_cluster_test(
                rng.normal(size=(5, 8, 8)), rng.normal(size=(5, 8, 8)), periodic_axis=1
            )
        )
        < 0.05
        for _ in range(300)
    ]
    assert 0.015 < np.mean(flagged) < 0.05 + 3 * np.sqrt(0.05 * 0.95 / 300)


def test_cluster_test_refuses_what_it_cannot_cluster():
    rng = np.random.default_rng(0)
    with pytest.raises(ValueError, match="2-D maps"):
        map_cluster_test(rng.normal(size=(3, 5)), rng.normal(size=(3, 5)))
    assert np.isnan(map_cluster_test(rng.normal(size=(1, 4, 4)), rng.normal(size=(3, 4, 4)))).all()
    a, b = rng.normal(size=(3, 4, 4)), rng.normal(size=(3, 4, 4))
    a[0, 2, 2] = np.nan
    p = map_cluster_test(a, b)
    assert np.isnan(p[2, 2]) and np.isfinite(np.delete(p.ravel(), 10)).all()


def test_cluster_test_equals_a_plain_loop_over_every_relabelling():
    """The stacked labelling against one relabelling at a time, from first principles:
    thresholds, clusters across the wrap, weights, p; with a NaN pixel."""
    from itertools import combinations

    from scipy import ndimage

    rng = np.random.default_rng(4)
    a, b = rng.normal(0, 1, (5, 6, 9)), rng.normal(0, 1, (4, 6, 9))
    a[:, 2:4, :3] += 2.0
    a[:, 2:4, -2:] += 2.0
    a[1, 5, 4] = np.nan
    pooled = np.concatenate([a, b])
    valid = ~np.isnan(pooled).any(axis=0)
    diffs = np.array(
        [
            pooled[list(s)].mean(0) - np.delete(pooled, list(s), 0).mean(0)
            for s in combinations(range(9), 5)
        ]
    )  # 126 relabellings
    absd = np.where(valid, np.abs(diffs), 0.0)
    k = int(np.floor(0.05 * len(diffs)))
    threshold = np.sort(absd, axis=0)[-k]

    def heaviest_and_labels(abs_d):
        labels, count = ndimage.label((abs_d >= threshold) & (abs_d > 0))
        for row in range(labels.shape[0]):  # join across the columns' ends
            x, y = labels[row, 0], labels[row, -1]
            if x and y and x != y:
                labels[labels == y] = x
        weights = {lab: abs_d[labels == lab].sum() for lab in np.unique(labels) if lab}
        return max(weights.values(), default=0.0), labels, weights

    null = np.array([heaviest_and_labels(d)[0] for d in absd])
    _, labels, weights = heaviest_and_labels(absd[0])  # the first 5: group a
    expected = np.ones((6, 9))
    for lab, w in weights.items():
        expected[labels == lab] = np.mean(null >= w - 1e-12)
    expected[~valid] = np.nan
    p = map_cluster_test(a, b, periodic_axis=1)
    np.testing.assert_allclose(p, expected, rtol=1e-12)
    assert np.nanmin(p) < 0.05 and len(weights) > 1
    assert p[2, 0] == p[2, -1] < 0.05  # one cluster across the wrap
