"""Group statistics of a cohort: permutation tests of the difference of group means,
for one number per embryo and for whole maps (corrected over the map), and Holm's
adjustment over several comparisons."""
from __future__ import annotations

from functools import lru_cache
from math import comb

import numpy as np

CHUNK = 2000        # relabellings at a time: bounded memory


def relabellings(n: int, m: int, *, exact: bool, n_random: int, seed: int):
    """Chunks ``(k, n)`` of the members of the first group under relabellings of
    ``n + m`` embryos: every n-subset when ``exact`` (the observed labelling, the
    first n, among them), else ``n_random`` random ones."""
    if exact:
        subsets = _subsets(n + m, n)
        for start in range(0, len(subsets), CHUNK):
            yield subsets[start:start + CHUNK]
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


def map_permutation_test(a: np.ndarray, b: np.ndarray, *, n_random: int = 10000,
                         seed: int = 0, exact_max: int = 20000):
    """Where two groups' maps differ: the difference of the group means of maps
    ``a (n, ...)`` and ``b (m, ...)``, and each pixel's two-sided p-value corrected
    for the whole map (family-wise), by the max-statistic permutation test (Nichols &
    Holmes 2002): the share of relabellings whose largest |difference of means| over
    the map reaches the pixel's own. Exact (every relabelling) while there are at most
    ``exact_max``, else ``n_random`` random ones.

    A map that is all NaN (an embryo without that field) is left out; a pixel NaN in
    any other map has NaN difference and p. With fewer than 2 maps in either group
    the difference is given and every p is NaN. Returns ``(difference, p)``, each of
    a map's shape.
    """
    a, b = (np.asarray(x, dtype=float) for x in (a, b))
    if a.shape[1:] != b.shape[1:]:
        raise ValueError(f"maps of shapes {a.shape[1:]} and {b.shape[1:]}")
    shape = a.shape[1:]
    a, b = (x.reshape(len(x), -1) for x in (a, b))
    a, b = (x[~np.all(np.isnan(x), axis=1)] for x in (a, b))
    n, m = len(a), len(b)
    pooled = np.concatenate([a, b])
    valid = ~np.any(np.isnan(pooled), axis=0)
    difference = np.full(pooled.shape[1], np.nan)
    p = np.full(pooled.shape[1], np.nan)
    if n == 0 or m == 0 or not valid.any():
        return difference.reshape(shape), p.reshape(shape)
    X = pooled[:, valid]
    total = X.sum(axis=0)
    observed = X[:n].mean(axis=0) - X[n:].mean(axis=0)
    difference[valid] = observed
    if n < 2 or m < 2:
        return difference.reshape(shape), p.reshape(shape)
    exact = comb(n + m, n) <= exact_max
    # a relabelling's differences in one product: [member, 1] @ [X (1/n + 1/m); -total/m]
    weighted = np.vstack([X * (1.0 / n + 1.0 / m), -total / m])
    largest = []                   # each relabelling's largest |difference| over the map
    for first in relabellings(n, m, exact=exact, n_random=n_random, seed=seed):
        member = np.zeros((len(first), n + m + 1))
        member[np.arange(len(first))[:, None], first] = 1.0
        member[:, -1] = 1.0
        d = member @ weighted
        largest.append(np.maximum(d.max(axis=1), -d.min(axis=1)))
    largest = np.sort(np.concatenate(largest))
    tol = 1e-12 * max(1.0, float(np.max(np.abs(observed))))
    reached = len(largest) - np.searchsorted(largest, np.abs(observed) - tol, side="left")
    p[valid] = reached / len(largest) if exact else (reached + 1) / (n_random + 1)
    return difference.reshape(shape), p.reshape(shape)


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
