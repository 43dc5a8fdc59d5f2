"""Statistics: Wilson score intervals, Fisher's exact test, the seeded order-statistic bootstrap of
medians, and the pairing of each planner's path costs with BIT*'s on the same queries."""

from __future__ import annotations

import math
import zlib

import numpy as np
import pandas as pd

from harness.report.names import KEYS

# Statistics: 95% intervals; bootstrap resamples and their fixed seed (the report is reproducible).
ALPHA = 0.05
BOOT_N = 10_000
BOOT_SEED = 20190521


def std_or_zero(g, n_min: int = 2) -> pd.Series:
    """Sample std (ddof=1) where a group has n_min values or more, else 0 (NaN when empty)."""
    s1, n = g.std(ddof=1), g.count()
    return s1.where(n >= n_min, 0.0).where(n > 0)


def wilson(k: int, n: int) -> tuple[float, float]:
    """The Wilson score 95% interval of a success rate k / n (scipy's binomtest; no continuity
    correction); NaN for n == 0."""
    if n <= 0:
        return math.nan, math.nan
    from scipy.stats import binomtest

    ci = binomtest(int(k), int(n)).proportion_ci(confidence_level=1 - ALPHA, method="wilson")
    return float(ci.low), float(ci.high)


def wilson_arrays(k, n) -> tuple[np.ndarray, np.ndarray]:
    """wilson() for arrays of counts at once (the closed form, the same numbers): a curve's band
    at thousands of points costs no test per point; NaN where n == 0."""
    from scipy.stats import norm

    k, n = np.asarray(k, float), np.asarray(n, float)
    z = float(norm.ppf(1 - ALPHA / 2))
    with np.errstate(divide="ignore", invalid="ignore"):
        p = k / n
        mid = (p + z * z / (2 * n)) / (1 + z * z / n)
        half = z / (1 + z * z / n) * np.sqrt(p * (1 - p) / n + z * z / (4 * n * n))
        lo, hi = np.clip(mid - half, 0.0, 1.0), np.clip(mid + half, 0.0, 1.0)
    return np.where(n > 0, lo, np.nan), np.where(n > 0, hi, np.nan)


def fisher_p(k1: int, n1: int, k2: int, n2: int) -> float:
    """Two-sided Fisher exact test of k1 / n1 against k2 / n2 (scipy); NaN when either is empty."""
    if n1 <= 0 or n2 <= 0:
        return math.nan
    from scipy.stats import fisher_exact

    return float(fisher_exact([[int(k1), int(n1 - k1)], [int(k2), int(n2 - k2)]]).pvalue)


def _rng(key: tuple) -> np.random.Generator:
    """A generator seeded by BOOT_SEED and the row's key: each row's resamples are the same
    whatever else the report reads."""
    return np.random.default_rng([BOOT_SEED, zlib.crc32("|".join(map(str, key)).encode())])


def boot_medians(x, key: tuple) -> np.ndarray | None:
    """BOOT_N bootstrap medians of x (NaNs dropped; +inf allowed, e.g. a censored time): the
    distribution of the median of n values drawn from x with replacement, or None for no values.

    Drawn exactly without materialising the resamples: a resample is x_sorted[floor(n U_i)]
    for n uniforms U_i, a monotone map, so its k-th smallest value is x_sorted[floor(n U_(k))]
    with U_(k) ~ Beta(k, n - k + 1); for even n the next order statistic is
    U_(k+1) = U_(k) + (1 - U_(k)) Beta(1, n - k). O(BOOT_N) per row whatever n is."""
    x = np.sort(np.asarray(x, float))
    x = x[~np.isnan(x)]
    n = len(x)
    if n == 0:
        return None
    rng = _rng(key)
    m = (n + 1) // 2
    u = rng.beta(m, n - m + 1, BOOT_N)
    lo = x[np.minimum((u * n).astype(np.int64), n - 1)]
    if n % 2:
        return lo
    v = u + (1.0 - u) * rng.beta(1, n - m, BOOT_N)
    return (lo + x[np.minimum((v * n).astype(np.int64), n - 1)]) / 2


def boot_interval(draws: np.ndarray | None) -> tuple[float, float]:
    """The 95% percentile interval of bootstrap draws (the inverted empirical CDF, so +inf draws
    are allowed); NaN without draws."""
    if draws is None:
        return math.nan, math.nan
    d = np.sort(draws[~np.isnan(draws)])
    if len(d) == 0:
        return math.nan, math.nan
    b = len(d)
    return float(d[max(math.ceil(ALPHA / 2 * b) - 1, 0)]), float(d[math.ceil((1 - ALPHA / 2) * b) - 1])


def excludes_one(lo: float, hi: float) -> bool | None:
    """Whether an interval of a ratio excludes 1 (a significant difference); None without one."""
    if math.isnan(lo) or math.isnan(hi):
        return None
    return bool(lo > 1.0 or hi < 1.0)


PAIR_KEY = ["env", "split", "seed", "query_id"]


def bit_star_pairs(q: pd.DataFrame) -> pd.DataFrame:
    """Per query solved by a planner and by bit_star of the same run label (paired on env, split,
    seed, query id): env, split, planner, seed, query_id, path_cost, bit_star_cost, ratio. A query
    logged in several files of the same (env, planner, seed) counts once, with the mean of its costs."""
    cols = KEYS + ["seed", "query_id", "path_cost", "bit_star_cost", "ratio"]
    solved = q[q["success"] & np.isfinite(q["path_cost"])]
    if solved.empty:
        return pd.DataFrame(columns=cols)
    key = PAIR_KEY + ["run_label"]
    c = solved.groupby(["planner", "logged_planner"] + key, sort=False)["path_cost"].mean().reset_index()
    bit = c["logged_planner"] == "bit_star"
    b = c[bit & (c["path_cost"] > 0)].drop(columns=["planner", "logged_planner"])
    m = c[~bit].merge(b.rename(columns={"path_cost": "bit_star_cost"}), on=key)
    m["ratio"] = m["path_cost"] / m["bit_star_cost"]
    return m[cols]
