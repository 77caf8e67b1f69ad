"""Group statistics of a cohort: permutation tests of the difference of group means,
for one number per embryo and for whole maps (corrected over the map), and Holm's
adjustment over several comparisons."""

from __future__ import annotations

from functools import lru_cache
from math import comb

import numpy as np

CHUNK = 2000  # relabellings at a time: bounded memory


def relabellings(n: int, m: int, *, exact: bool, n_random: int, seed: int):
    """Chunks ``(k, n)`` of the members of the first group under relabellings of
    ``n + m`` embryos: every n-subset when ``exact`` (the observed labelling, the
    first n, among them), else ``n_random`` random ones."""
    if exact:
        subsets = _subsets(n + m, n)
        for start in range(0, len(subsets), CHUNK):
            yield subsets[start : start + CHUNK]
        return
    rng = np.random.default_rng(seed)
    for start in range(0, n_random, CHUNK):
        rows = min(CHUNK, n_random - start)
        yield np.argsort(rng.random((rows, n + m)), axis=1)[:, :n]  # a random n-subset


@lru_cache(maxsize=8)
def _subsets(size: int, k: int) -> np.ndarray:
    """Every k-subset of ``range(size)`` as rows, ``(C(size, k), k)`` (184756 x 10
    for 10 + 10)."""
    from itertools import chain, combinations

    dtype = np.int8 if size <= 127 else np.int32
    flat = np.fromiter(chain.from_iterable(combinations(range(size), k)), dtype=dtype)
    return flat.reshape(-1, k)


def smallest_permutation_p(n: int, m: int, *, n_random: int = 20000) -> float:
    """The smallest p :func:`permutation_test` can give groups of ``n`` and ``m`` (no
    NaN): exact, the most extreme relabelling alone (and its mirror when ``n == m``)
    of all C(n + m, n); random, 1 / (n_random + 1). Three against three cannot go
    under 0.10, whatever the difference: a reader must be told."""
    from math import comb

    if n < 2 or m < 2:
        return float("nan")
    if n <= 10 and m <= 10:
        return (2 if n == m else 1) / comb(n + m, n)
    return 1 / (n_random + 1)


def permutation_test(a, b, *, n_random: int = 20000, seed: int = 0) -> float:
    """Two-sided permutation test of the difference of means; returns the p-value.

    Exact (every relabelling) when both groups have at most 10 members, else
    ``n_random`` random relabellings. NaN values are left out.
    """
    a = np.asarray([x for x in a if x == x], float)
    b = np.asarray([x for x in b if x == x], float)
    if len(a) < 2 or len(b) < 2:
        return float("nan")
    pooled = np.concatenate([a, b])
    observed = abs(a.mean() - b.mean())
    n, m = len(a), len(b)
    tol = 1e-12 * max(1.0, abs(observed))
    total = pooled.sum()
    exact = n <= 10 and m <= 10
    count = total_relabellings = 0
    for first in relabellings(n, m, exact=exact, n_random=n_random, seed=seed):
        sums = pooled[first].sum(axis=1)
        count += int(np.count_nonzero(np.abs(sums / n - (total - sums) / m) >= observed - tol))
        total_relabellings += len(first)
    if exact:
        return count / total_relabellings
    return (count + 1) / (n_random + 1)


def _map_groups(a: np.ndarray, b: np.ndarray):
    """Maps ``a (n, ...)``, ``b (m, ...)`` as ``(shape, X (n' + m', pixels), n', m',
    valid (pixels,))``: all-NaN maps left out, X only at pixels finite in every map."""
    a, b = (np.asarray(x, dtype=float) for x in (a, b))
    if a.shape[1:] != b.shape[1:]:
        raise ValueError(f"maps of shapes {a.shape[1:]} and {b.shape[1:]}")
    shape = a.shape[1:]
    a, b = (x.reshape(len(x), -1) for x in (a, b))
    a, b = (x[~np.all(np.isnan(x), axis=1)] for x in (a, b))
    pooled = np.concatenate([a, b])
    valid = ~np.any(np.isnan(pooled), axis=0) if len(pooled) else np.zeros(pooled.shape[1], bool)
    return shape, pooled[:, valid], len(a), len(b), valid


def _relabelled_differences(X: np.ndarray, n: int, m: int, **relabelling):
    """Chunks ``(k, pixels)`` of the difference of the group means of ``X (n + m,
    pixels)`` under the :func:`relabellings` (keywords ``exact``, ``n_random``,
    ``seed``)."""
    # in one product: [member, 1] @ [X (1/n + 1/m); -total/m]
    weighted = np.vstack([X * (1.0 / n + 1.0 / m), -X.sum(axis=0) / m])
    for first in relabellings(n, m, **relabelling):
        member = np.zeros((len(first), n + m + 1))
        member[np.arange(len(first))[:, None], first] = 1.0
        member[:, -1] = 1.0
        yield member @ weighted


def _share_reaching(null: np.ndarray, values: np.ndarray, *, exact: bool) -> np.ndarray:
    """Permutation p of each of ``values``: the share of ``null`` (one statistic per
    relabelling) that reaches it; with random relabellings (count + 1) / (R + 1)."""
    null = np.sort(null)
    tol = 1e-12 * max(1.0, float(np.max(values, initial=0.0)))
    reached = len(null) - np.searchsorted(null, values - tol, side="left")
    return reached / len(null) if exact else (reached + 1) / (len(null) + 1)


def map_permutation_test(
    a: np.ndarray, b: np.ndarray, *, n_random: int = 10000, seed: int = 0, exact_max: int = 20000
):
    """Where two groups' maps differ: the difference of the group means of maps
    ``a (n, ...)`` and ``b (m, ...)``, and each pixel's two-sided p-value corrected
    for the whole map (family-wise), by the max-statistic permutation test (Nichols &
    Holmes 2002): the share of relabellings whose largest absolute difference of means over
    the map reaches the pixel's own. Exact (every relabelling) while there are at most
    ``exact_max``, else ``n_random`` random ones.

    A map that is all NaN (an embryo without that field) is left out; a pixel NaN in
    any other map has NaN difference and p. With fewer than 2 maps in either group
    the difference is given and every p is NaN. Returns ``(difference, p)``, each of
    a map's shape.
    """
    shape, X, n, m, valid = _map_groups(a, b)
    difference = np.full(valid.shape, np.nan)
    p = np.full(valid.shape, np.nan)
    if n == 0 or m == 0 or not valid.any():
        return difference.reshape(shape), p.reshape(shape)
    observed = X[:n].mean(axis=0) - X[n:].mean(axis=0)
    difference[valid] = observed
    if n < 2 or m < 2:
        return difference.reshape(shape), p.reshape(shape)
    exact = comb(n + m, n) <= exact_max
    largest = np.concatenate(
        [
            np.maximum(d.max(axis=1), -d.min(axis=1))
            for d in _relabelled_differences(X, n, m, exact=exact, n_random=n_random, seed=seed)
        ]
    )
    p[valid] = _share_reaching(largest, np.abs(observed), exact=exact)
    return difference.reshape(shape), p.reshape(shape)


def map_cluster_test(
    a: np.ndarray,
    b: np.ndarray,
    *,
    cluster_alpha: float = 0.05,
    periodic_axis: int | None = None,
    n_random: int = 10000,
    seed: int = 0,
    exact_max: int = 20000,
) -> np.ndarray:
    """Where two groups' 2-D maps ``a (n, rows, cols)``, ``b (m, rows, cols)`` differ
    over a connected region: the cluster-mass permutation test (Maris & Oostenveld
    2007), corrected for the whole map. A pixel joins a cluster where its absolute
    difference of group means is among the ``cluster_alpha`` largest of its own over every
    relabelling (uncorrected p <= ``cluster_alpha``); a cluster (4-connected, joined
    across the ends of ``periodic_axis``: the cycle) weighs the sum of its
    absolute differences; its p is the share of relabellings whose heaviest cluster reaches
    its weight. Exact up to ``exact_max`` relabellings, else ``n_random`` random ones
    (the same ones in both passes).

    Returns p ``(rows, cols)``: each pixel of a cluster carries the cluster's p, the
    other pixels 1, NaN where a map is NaN (or every pixel with fewer than 2 maps in
    a group); maps all NaN are left out, as in :func:`map_permutation_test`.
    """
    shape, X, n, m, valid = _map_groups(a, b)
    if len(shape) != 2:
        raise ValueError(f"clusters need 2-D maps, not of shape {shape}")
    check_cluster_alpha(cluster_alpha)
    p = np.full(valid.shape, np.nan)
    if n < 2 or m < 2 or not valid.any():
        return p.reshape(shape)
    exact = comb(n + m, n) <= exact_max
    relabelling = dict(exact=exact, n_random=n_random, seed=seed)
    total = comb(n + m, n) if exact else n_random
    n_top = max(1, int(np.floor(cluster_alpha * total)))
    top = np.empty((0, X.shape[1]))  # each pixel's n_top largest |difference| so far
    for d in _relabelled_differences(X, n, m, **relabelling):
        top = np.concatenate([top, np.abs(d)])
        if len(top) > n_top:
            top = np.partition(top, len(top) - n_top, axis=0)[-n_top:]
    threshold = top.min(axis=0)  # the n_top-th largest: uncorrected p <= cluster_alpha

    def clusters(abs_difference):
        """Cluster labels ``(k, rows, cols)`` of the maps ``abs_difference (k, valid
        pixels)``, numbered across them, and each cluster's weight (0: outside)."""
        supra = (abs_difference >= threshold * (1 - 1e-12)) & (abs_difference > 0)
        if not valid.all():  # back onto every pixel of the map
            abs_difference, supra = _on_map(abs_difference, valid), _on_map(supra, valid)
        labels, count = _cluster_labels(supra.reshape((-1,) + shape), periodic_axis)
        return labels, np.bincount(
            labels.ravel(), weights=abs_difference.ravel(), minlength=count + 1
        )

    heaviest = []  # each relabelling's heaviest cluster
    for d in _relabelled_differences(X, n, m, **relabelling):
        labels, weights = clusters(np.abs(d))
        # each map's clusters are numbered after the previous map's: up to its largest
        last = np.maximum.accumulate(labels.reshape(len(d), -1).max(axis=1))
        first = np.concatenate([[0], last[:-1]]) + 1
        most = np.maximum.reduceat(np.append(weights, 0.0), np.minimum(first, len(weights)))
        heaviest.append(np.where(last >= first, most, 0.0))
    labels, weights = clusters(np.abs(X[:n].mean(axis=0) - X[n:].mean(axis=0))[None])
    cluster_p = np.concatenate(
        [[1.0], _share_reaching(np.concatenate(heaviest), weights[1:], exact=exact)]
    )
    p[valid] = cluster_p[labels[0].ravel()[valid]]
    return p.reshape(shape)


def check_cluster_alpha(cluster_alpha) -> None:
    """A cluster-forming threshold must be an uncorrected p strictly between 0 and 1."""
    if not (isinstance(cluster_alpha, (int, float)) and 0 < cluster_alpha < 1):
        raise ValueError(
            f"the cluster-forming threshold (--cluster-alpha) must be an "
            f"uncorrected p between 0 and 1, found {cluster_alpha!r}"
        )


def _on_map(values: np.ndarray, valid: np.ndarray) -> np.ndarray:
    """``values (k, valid pixels)`` on every pixel ``(k, pixels)``, 0 (False) elsewhere."""
    out = np.zeros((len(values), valid.size), dtype=values.dtype)
    out[:, valid] = values
    return out


def _cluster_labels(mask: np.ndarray, periodic_axis: int | None) -> tuple[np.ndarray, int]:
    """The 4-connected components of each map of ``mask (..., rows, cols)``, numbered
    1, 2, ... across the maps (0 outside), those touching across the two ends of the
    maps' ``periodic_axis`` (0: rows, 1: columns) joined; and how many."""
    from scipy import ndimage
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    structure = np.zeros((3,) * mask.ndim, bool)  # no link between maps
    structure[(1,) * (mask.ndim - 2)] = ndimage.generate_binary_structure(2, 1)
    labels, count = ndimage.label(mask, structure)
    if periodic_axis is None or count < 2:
        return labels, count
    axis = mask.ndim - 2 + periodic_axis
    first, last = np.take(labels, 0, axis=axis), np.take(labels, -1, axis=axis)
    touching = (first > 0) & (last > 0)
    if not touching.any():
        return labels, count
    graph = coo_matrix(
        (np.ones(touching.sum()), (first[touching], last[touching])), shape=(count + 1, count + 1)
    )
    joined, root = connected_components(graph, directed=False)  # 0 (outside) stays 0
    return root[labels], joined - 1


def holm(p: list[float]) -> list[float]:
    """Holm-Bonferroni adjusted p-values, in the order given; NaN stays NaN and
    does not count as a test."""
    p = np.asarray(p, float)
    out = np.full(len(p), np.nan)
    tested = np.nonzero(np.isfinite(p))[0]
    order = tested[np.argsort(p[tested], kind="stable")]
    m = len(order)
    adjusted = np.maximum.accumulate((m - np.arange(m)) * p[order])
    out[order] = np.minimum(adjusted, 1.0)
    return out.tolist()
