"""Small-sample inference for the studies: exact tests, their power, and intervals.

- :func:`permutation_u`: the exact permutation distribution of Mann–Whitney's U over every arrangement
  of the pooled values (ties allowed, one trial per side allowed), its two-sided p and the smallest p
  any arrangement of the same values could give (what the test can detect at this n).
- :func:`completion_test`: Barnard's exact unconditional test of two completion counts, and the smallest
  p it can give at these sample sizes.
- :func:`wilson` and :func:`newcombe`: the Wilson score interval of a rate and Newcombe's hybrid score
  interval of the difference of two rates.
- :func:`bootstrap_effects`: percentile bootstrap intervals over trials (resampled within each sample)
  of P(a > b) + ½ P(a = b) and of the Hodges–Lehmann shift, from a given generator.

Two-sided p-values double the smaller tail (capped at 1), as scipy does, so every test of a table
follows one convention.
"""

from __future__ import annotations

import itertools
import math
from functools import lru_cache

import numpy as np
from scipy.stats import barnard_exact, norm, rankdata

#: Most arrangements :func:`permutation_u` enumerates (6 vs 6: 924; 10 vs 10: 184,756).
EXACT_PERMUTATIONS = 200_000
_TOL = 1e-9  # U takes multiples of 1/2: a tolerance far below that compares them exactly


def u_statistic(a: np.ndarray, b: np.ndarray) -> float:
    """Mann–Whitney's U of ``a`` (n,) against ``b`` (m,): pairs with a > b, plus half the ties."""
    a, b = np.asarray(a, float), np.asarray(b, float)
    return float((a[:, None] > b[None, :]).sum() + 0.5 * (a[:, None] == b[None, :]).sum())


def permutation_u(a: np.ndarray, b: np.ndarray) -> tuple[float, float, float] | None:
    """The exact permutation test of U: ``(U, two-sided p, smallest attainable p)``, or ``None`` where
    there are more than :data:`EXACT_PERMUTATIONS` arrangements of the pooled values (or a side is
    empty). The smallest attainable p is the least p of any arrangement of these pooled values: below
    it the test cannot go whatever the data; with ties it is larger than 2 / C(n + m, n)."""
    a, b = np.asarray(a, float), np.asarray(b, float)
    n, m = len(a), len(b)
    if not n or not m or math.comb(n + m, n) > EXACT_PERMUTATIONS:
        return None
    pooled = np.concatenate([a, b])
    null = _null_u(tuple(rankdata(pooled)), n)
    u = u_statistic(a, b)
    return u, _two_sided(null, u), min(_two_sided(null, v) for v in np.unique(null))


@lru_cache(maxsize=256)
def _null_u(ranks: tuple[float, ...], n: int) -> np.ndarray:
    """U of the first sample over every choice of ``n`` of the pooled midranks (sorted)."""
    r = np.asarray(ranks)
    idx = np.fromiter(
        itertools.chain.from_iterable(itertools.combinations(range(len(r)), n)), dtype=np.int64
    ).reshape(-1, n)
    return np.sort(r[idx].sum(axis=1) - n * (n + 1) / 2)


def _two_sided(null: np.ndarray, u: float) -> float:
    less = np.searchsorted(null, u + _TOL, side="right") / len(null)
    greater = 1.0 - np.searchsorted(null, u - _TOL, side="left") / len(null)
    return float(min(1.0, 2.0 * min(less, greater)))


def smallest_u_p(n: int, m: int) -> float:
    """The smallest two-sided p of an exact Mann–Whitney test of n against m untied values:
    2 / C(n + m, n) (capped at 1)."""
    return min(1.0, 2.0 / math.comb(n + m, n)) if n and m else math.nan


def completion_test(k1: int, n1: int, k2: int, n2: int) -> tuple[float, float]:
    """Barnard's exact unconditional test (two-sided, Wald statistic with the pooled variance) of
    ``k1`` of ``n1`` against ``k2`` of ``n2`` completed: ``(p, smallest attainable p)``, the latter
    that of ``n1`` of ``n1`` against 0 of ``n2``. NaN for an empty side."""
    if not n1 or not n2:
        return math.nan, math.nan
    return _barnard(k1, n1, k2, n2), _barnard(n1, n1, 0, n2)


@lru_cache(maxsize=1024)
def _barnard(k1: int, n1: int, k2: int, n2: int) -> float:
    # scipy's table: the columns are the two samples (their totals fixed by the design)
    p = float(barnard_exact([[k1, k2], [n1 - k1, n2 - k2]], alternative="two-sided").pvalue)
    return min(1.0, p) if math.isfinite(p) else 1.0  # an all-alike table has no variance: nothing seen


def wilson(k: int, n: int, level: float = 0.95) -> tuple[float, float]:
    """The Wilson score interval of a rate of ``k`` of ``n`` (NaN for n = 0)."""
    if not n:
        return math.nan, math.nan
    z = norm.ppf(0.5 + level / 2)
    p = k / n
    centre = (p + z * z / (2 * n)) / (1 + z * z / n)
    half = z / (1 + z * z / n) * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n))
    return max(0.0, centre - half), min(1.0, centre + half)


def newcombe(k1: int, n1: int, k2: int, n2: int, level: float = 0.95) -> tuple[float, float, float]:
    """The difference of two rates ``k1/n1 - k2/n2`` and Newcombe's hybrid score interval (his method
    10, from the two Wilson intervals): ``(difference, low, high)``."""
    if not n1 or not n2:
        return math.nan, math.nan, math.nan
    p1, p2 = k1 / n1, k2 / n2
    (l1, u1), (l2, u2) = wilson(k1, n1, level), wilson(k2, n2, level)
    d = p1 - p2
    return d, d - math.hypot(p1 - l1, u2 - p2), d + math.hypot(u1 - p1, p2 - l2)


def bootstrap_effects(
    a: np.ndarray, b: np.ndarray, rng: np.random.Generator, resamples: int = 4000, level: float = 0.95
) -> tuple[tuple[float, float], tuple[float, float]]:
    """Percentile bootstrap intervals of P(a > b) + ½ P(a = b) and of the Hodges–Lehmann shift
    (median of a_i - b_j), resampling the trials of ``a`` and of ``b`` with replacement
    (``resamples`` times, from ``rng``). NaN where a side is empty."""
    a, b = np.asarray(a, float), np.asarray(b, float)
    if not len(a) or not len(b):
        nan = (math.nan, math.nan)
        return nan, nan
    ra = a[rng.integers(0, len(a), size=(resamples, len(a)))]
    rb = b[rng.integers(0, len(b), size=(resamples, len(b)))]
    diff = ra[:, :, None] - rb[:, None, :]
    prob = ((diff > 0).mean(axis=(1, 2)) + 0.5 * (diff == 0).mean(axis=(1, 2))).astype(float)
    shift = np.median(diff.reshape(resamples, -1), axis=1)
    q = [50 * (1 - level), 50 * (1 + level)]
    p_lo, p_hi = np.percentile(prob, q)
    s_lo, s_hi = np.percentile(shift, q)
    return (float(p_lo), float(p_hi)), (float(s_lo), float(s_hi))
