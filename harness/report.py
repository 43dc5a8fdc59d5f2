"""`python -m harness.report DIR... [--out OUT] [--paper]`: the paper's tables, figures and an
OMPL benchmark database, regenerated from trial logs alone (DESIGN §6 "Report").

Only the `trials.mcap` files found under the given directories are read (topics `/run`,
`/workspace`, `/query`): no planning, no artifacts, no torch or OMPL. A file that cannot be
read (empty, corrupt, no `/run`) is skipped with one warning line; a file cut short (a
killed writer, or truncated by hand) is read up to where it breaks, with one warning line;
a file with a `/run` but no `/query` gets one warning line. No query at all is an error.

How the numbers are computed (also written to OUT/README.md):
- Rows are env x split x planner, where split is each query's own `split` (a run's `/run`
  may say "seen+unseen" or "file").
- `queries` counts every logged query of every seed; `seeds` is the number of distinct
  seeds. Several files with the same (env, planner, seed), e.g. a sweep run twice, all
  count: their queries are pooled into that seed, with one warning line per (env, planner,
  seed) whose queries appear in more than one file. A file whose `/run` has no integer
  seed counts as a seed of its own (with a warning), so such files are never pooled.
- `success_mean` / `success_std`: mean and standard deviation of the per-seed success rates,
  the std with ddof=1 (sample std) when there are two seeds or more, 0 for a single seed.
- Time statistics (`time_*`) are over the successful queries of all seeds pooled that logged
  a finite time (the paper's convention: time to a first solution); `time_std_s` uses ddof=1
  when there are two such queries or more, else 0. `cpu_mean_s`, `cost_mean` and
  `collision_checks_median` are over all successful queries (each over those that logged it).
- `pnet_calls_median`, `replans_mean` and `fallback_rate` are over every query that logged
  the field (NaN for planners that do not).
- Table I: mean ± std time in seconds, and the BIT*/MPNet (NR) ratio of mean times; other
  planners come after the ratio, so the first columns are the paper's layout. Table I,
  success_cost and the figures leave out the MPNet ablations (`mpnet_nr_*`, `mpnet_hr_*`:
  ablations.*); results.csv leaves out the time-to-equal-quality runs (`*_to_nr*`:
  equal_quality.*), whose success means "reached MPNet-NR's cost".
- Intervals (95%): Wilson score for every success rate (pooled successes / queries);
  percentile bootstrap (BOOT_N resamples, seeded per row) for every median time and ratio of
  medians. Significance against the comparator (comparator_of) at 5%: Fisher's exact test
  for success, the ratio-of-medians interval excluding 1 for time; "≈" marks a difference
  that is not significant.
- Path quality: path cost / the query's logged `reference_cost` (median, p90) over
  successful queries, and the median ratio to bit_star's path cost on the queries both
  solved (paired on env, split, seed, query id): quality.*.
"""
from __future__ import annotations

import argparse
import math
import re
import sqlite3
import sys
import textwrap
import zlib
from collections.abc import Iterable
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path

import numpy as np
import pandas as pd

from harness.trial_log import MCAP_NAME, read_log, rect_outlines

ENV_ORDER = ("s2d", "c2d", "c3d", "rigid")
ENV_LABELS = {"s2d": "Simple 2D", "c2d": "Complex 2D", "c3d": "Complex 3D", "rigid": "Rigid body"}
SPLIT_ORDER = ("seen", "unseen")
PAPER_PLANNERS = ("mpnet_nr", "mpnet_hr", "informed_rrt_star", "bit_star")
KNOWN_EXTRAS = ("rrt_star", "rrt_connect")
PLANNER_LABELS = {"mpnet_nr": "MPNet (NR)", "mpnet_hr": "MPNet (HR)", "informed_rrt_star": "Informed-RRT*",
                  "bit_star": "BIT*", "rrt_star": "RRT*", "rrt_connect": "RRT-Connect"}
PLANNER_COLORS = {"mpnet_nr": "#1f77b4", "mpnet_hr": "#17becf", "informed_rrt_star": "#d62728",
                  "bit_star": "#ff7f0e", "rrt_star": "#9467bd", "rrt_connect": "#2ca02c"}
RATIO_COL = "bit_star_over_mpnet_nr"
RATIO_LABEL = "BIT*/MPNet (NR)"
PAPER = 'Qureshi, Simeonov, Bency, Yip, "Motion Planning Networks", ICRA 2019, arXiv:1806.05767'
CITATION = (PAPER + ", Table I; their Informed-RRT* and BIT* were Python implementations, MPNet's times are "
            "CPU time on an i7 with a GTX 1080")
# The paper's sizes: train workspaces x expert paths, then seen and unseen test workspaces x
# queries per workspace; and its Pnet's hidden layers (to tell a smaller network).
PAPER_SCALE = (100, 4000, 100, 200, 10, 2000)
PAPER_SCALE_TEXT = "100 × 4000 paths; 100 × 200 seen, 10 × 2000 unseen"
PAPER_PNET_HIDDEN = (1280, 1024, 896, 768, 512, 384, 256, 256, 128, 64, 32)
QUERY_COLS = ("query_id", "workspace_id", "split", "success", "failure", "time_s", "cpu_s", "path_cost",
              "collision_checks", "state_checks", "motion_checks", "pnet_calls", "replans", "fallback_used",
              "reference_cost", "target_planner", "target_cost", "target_time_s")
KEYS = ["env", "split", "planner"]
RESULT_COLS = KEYS + ["queries", "seeds", "successes", "success_mean", "success_std", "success_rate",
                      "success_ci_low", "success_ci_high", "time_mean_s", "time_std_s", "time_median_s",
                      "time_median_ci_low", "time_median_ci_high", "time_p90_s", "cpu_mean_s", "cost_mean",
                      "quality_n", "quality_median", "quality_p90", "cost_over_bit_star_n",
                      "cost_over_bit_star_median", "collision_checks_median", "pnet_calls_median", "replans_mean",
                      "fallback_rate", "comparator", "success_p_vs", "success_diff_significant", "time_ratio_vs",
                      "time_ratio_vs_ci_low", "time_ratio_vs_ci_high", "time_diff_significant", "failures"]

# Ablations of MPNet: `<base>_<variant>`, each logged under its own planner name.
ABLATION_BASES = ("mpnet_nr", "mpnet_hr")
ABLATIONS = {"random": "a uniformly random valid state instead of Pnet's proposal",
             "straight": "a fixed-length step toward the other tree's end instead of Pnet's proposal",
             "zeros": "Pnet given a zero workspace code",
             "nodropout": "Pnet deterministic (no dropout) at planning time"}
# Time to equal quality: `<algorithm>_to_<target>[_x<factor>]`, e.g. bit_star_to_nr_x1.1.
EQ_RE = re.compile(r"(?P<alg>.+?)_to_(?P<target>nr|hr)(?:_x(?P<factor>\d+(?:\.\d+)?))?")
# Statistics: 95% intervals; bootstrap resamples and their fixed seed (the report is reproducible).
ALPHA = 0.05
BOOT_N = 10_000
BOOT_SEED = 20190521
APPROX = "≈"
# A logged success of a time-to-equal-quality run counts as reaching the target only with a
# path cost <= factor x target cost, up to this relative slack (float noise in the two cost sums).
REACH_RTOL = 1e-6

# OMPL's PlannerStatus, in the order its Benchmark writes the `status` enum.
OMPL_STATUS = ("Unknown status", "Invalid start", "Invalid goal", "Unrecognized goal type", "Timeout",
               "Approximate solution", "Exact solution", "Crash", "Abort", "Infeasible")
ST_UNKNOWN, ST_INVALID_START, ST_TIMEOUT, ST_EXACT, ST_CRASH = 0, 1, 4, 6, 7


# --------------------------------------------------------------------------- reading

@dataclass
class TrialFile:
    """One readable trials.mcap: its /run message, workspaces by (split, id), queries."""

    path: Path
    run: dict
    workspaces: dict[tuple[str, str], dict] = field(default_factory=dict)
    queries: list[dict] = field(default_factory=list)
    finalised: bool = True


def find_logs(dirs: Iterable[str | Path]) -> tuple[list[Path], list[str]]:
    """Every trials.mcap under the given directories (a file path is taken as is), sorted and
    without duplicates; plus one warning per argument that is neither."""
    found, warns = {}, []
    for d in dirs:
        p = Path(d)
        if p.is_file():
            found.setdefault(p.resolve(), p)
        elif p.is_dir():
            for f in p.rglob(MCAP_NAME):
                if f.is_file():
                    found.setdefault(f.resolve(), f)
        else:
            warns.append(f"warning: {d}: no such file or directory")
    return sorted(found.values(), key=str), warns


def read_trials(path: Path) -> tuple[TrialFile | None, str | None]:
    """The file's contents, or None; and a one-line warning when it is skipped or cut short."""
    try:
        msgs, finalised = read_log(path, ("/run", "/workspace", "/query"))
    except Exception as e:  # noqa: BLE001 - unreadable for any reason: skipped, never a traceback
        return None, f"warning: skipped {path}: cannot read it ({type(e).__name__}: {e})"
    run, out = None, None
    for m in msgs:
        if m.topic == "/run":
            if run is None:
                run = m.data
                if not isinstance(run, dict) or not run.get("env") or not run.get("planner"):
                    return None, f"warning: skipped {path}: its /run message names no env or planner"
                out = TrialFile(path, run, finalised=finalised)
        elif out is None or not isinstance(m.data, dict):
            continue
        elif m.topic == "/query":
            out.queries.append(m.data)
        else:
            out.workspaces.setdefault((str(m.data.get("split")), str(m.data.get("workspace_id"))), m.data)
    if out is None:
        why = "no /run message" if msgs else "empty file" if _size(path) == 0 else "not a readable MCAP trial log"
        return None, f"warning: skipped {path}: {why}"
    if not finalised:
        return out, (f"warning: {path} was not finalised (cut short?): read its {len(out.queries)} "
                     "queries up to where it breaks")
    if not out.queries:
        return out, f"warning: {path}: no queries"
    return out, None


def _size(path: Path) -> int | None:
    try:
        return path.stat().st_size
    except OSError:
        return None


def run_seed(run: dict) -> int | None:
    """The /run message's seed when it is an integer, else None."""
    seed = run.get("seed")
    return seed if isinstance(seed, (int, np.integer)) and not isinstance(seed, (bool, np.bool_)) else None


def load(dirs: Iterable[str | Path]) -> tuple[list[TrialFile], list[str], int]:
    """Readable trial files, warnings (one line each) and the number of files skipped."""
    paths, warns = find_logs(dirs)
    files, skipped = [], 0
    for p in paths:
        tf, w = read_trials(p)
        if w:
            warns.append(w)
        if tf is None:
            skipped += 1
            continue
        files.append(tf)
        if tf.queries and run_seed(tf.run) is None:
            warns.append(f"warning: {p}: its /run has no integer seed ({tf.run.get('seed')!r}): "
                         "its queries count as a seed of their own")
    return files, warns, skipped


def _flag(v) -> float:
    """A logged boolean as 1.0 / 0.0, anything else (missing, null) as NaN."""
    return float(v) if isinstance(v, (bool, np.bool_)) else math.nan


def _numbers(col: pd.Series) -> pd.Series:
    """A column as floats; anything that is not a number (null, text, a list) becomes NaN."""
    try:
        return pd.to_numeric(col, errors="coerce").astype(float)
    except (TypeError, ValueError):
        return col.map(lambda v: float(v) if isinstance(v, (int, float)) and not isinstance(v, bool) else math.nan)


def queries_frame(files: list[TrialFile]) -> pd.DataFrame:
    """One row per logged query (no paths): the run's env, planner and seed, the query's
    scalar fields, and (file, qidx) to find the full message again. A file without an
    integer seed gets a negative seed of its own, below every logged one, so that it is
    neither pooled with another file nor lost."""
    parts = []
    free_seed = min([s for s in map(run_seed, (tf.run for tf in files)) if s is not None] + [0]) - 1
    for i, tf in enumerate(files):
        if not tf.queries:
            continue
        df = pd.DataFrame.from_records(tf.queries, columns=list(QUERY_COLS))
        df["success"] = [_flag(v) == 1.0 for v in df["success"]]
        df["fallback_used"] = [_flag(v) for v in df["fallback_used"]]
        for c in ("time_s", "cpu_s", "path_cost", "collision_checks", "state_checks", "motion_checks",
                  "pnet_calls", "replans", "reference_cost", "target_cost", "target_time_s"):
            df[c] = _numbers(df[c])
        df["target_planner"] = [v if isinstance(v, str) else None for v in df["target_planner"]]
        for c in ("query_id", "workspace_id", "split"):
            df[c] = df[c].astype(str)
        df["failure"] = df["failure"].astype(object).where(df["failure"].notna(), None)
        df["file"] = i
        df["qidx"] = np.arange(len(df))
        df["env"] = str(tf.run["env"])
        df["planner"] = str(tf.run["planner"])
        seed = run_seed(tf.run)
        if seed is None:
            seed, free_seed = free_seed, free_seed - 1
        df["seed"] = int(seed)
        parts.append(df)
    if not parts:
        return pd.DataFrame(columns=list(QUERY_COLS) + ["file", "qidx", "env", "planner", "seed"])
    df = pd.concat(parts, ignore_index=True)
    df["success"] = df["success"].astype(bool)
    return df


# ------------------------------------------------------------------------- ordering

def env_rank(env: str) -> tuple:
    return (ENV_ORDER.index(env), "") if env in ENV_ORDER else (len(ENV_ORDER), env)


def split_rank(split: str) -> tuple:
    return (SPLIT_ORDER.index(split), "") if split in SPLIT_ORDER else (len(SPLIT_ORDER), split)


def ablation_of(planner: str) -> tuple[str, str] | None:
    """(base, variant) for an MPNet ablation's planner name (mpnet_nr_random -> ("mpnet_nr",
    "random")), else None."""
    if equal_quality_of(planner) is not None:
        return None
    for base in ABLATION_BASES:
        if planner.startswith(base + "_") and len(planner) > len(base) + 1:
            return base, planner[len(base) + 1:]
    return None


def equal_quality_of(planner: str) -> tuple[str, str, float | None] | None:
    """(algorithm, target, factor) for a time-to-equal-quality planner name
    (informed_rrt_star_to_nr_x1.1 -> ("informed_rrt_star", "nr", 1.1); factor None when the
    name gives none), else None."""
    m = EQ_RE.fullmatch(planner)
    if m is None:
        return None
    return m["alg"], m["target"], float(m["factor"]) if m["factor"] else None


def comparator_of(planner: str) -> str | None:
    """The planner a row's significance marks compare with: an ablation's own base (mpnet_nr or
    mpnet_hr), none for mpnet_nr itself, mpnet_nr for every other planner (MPNet (HR) included)."""
    ab = ablation_of(planner)
    if ab is not None:
        return ab[0]
    return None if planner == "mpnet_nr" else "mpnet_nr"


def planner_rank(planner: str) -> tuple:
    """The paper's planners, the known extras, any other planner by name, then the ablations
    (by base, then variant), then the time-to-equal-quality planners."""
    known = PAPER_PLANNERS + KNOWN_EXTRAS
    if planner in known:
        return (0, known.index(planner), "")
    ab = ablation_of(planner)
    if ab is not None:
        variants = list(ABLATIONS)
        v = variants.index(ab[1]) if ab[1] in variants else len(variants)
        return (2, ABLATION_BASES.index(ab[0]) * (len(variants) + 1) + v, planner)
    if equal_quality_of(planner) is not None:
        return (3, 0, planner)
    return (1, 0, planner)


def planner_label(planner: str) -> str:
    if planner in PLANNER_LABELS:
        return PLANNER_LABELS[planner]
    ab = ablation_of(planner)
    if ab is not None:
        return f"{PLANNER_LABELS[ab[0]]}: {ab[1]}"
    eq = equal_quality_of(planner)
    if eq is not None:
        alg, target, factor = eq
        return f"{PLANNER_LABELS.get(alg, alg)} to {target.upper()}" + (f" ×{factor:g}" if factor else "")
    return planner


def env_label(env: str) -> str:
    return ENV_LABELS.get(env, env)


def _sort(df: pd.DataFrame, cols=("env", "split", "planner")) -> pd.DataFrame:
    rank = {"env": env_rank, "split": split_rank, "planner": planner_rank}
    if df.empty:
        return df
    order = sorted(range(len(df)), key=lambda i: tuple(rank[c](df[c].iat[i]) for c in cols))
    return df.iloc[order].reset_index(drop=True)


def natural_key(s: str) -> tuple:
    """'ws10-2' after 'ws9-3': digit runs compare as numbers (types line up by position)."""
    parts = re.split(r"(\d+)", str(s))
    return tuple(int(p) if i % 2 else p for i, p in enumerate(parts))


# ------------------------------------------------------------------------ statistics

def _std(g, n_min: int = 2) -> pd.Series:
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


def equal_quality_planners(q: pd.DataFrame) -> set[str]:
    """Planners that ran to a cost target (time to equal quality): named `<alg>_to_<target>...`
    or logging a `target_planner`. Their success means "reached the target", so they have a
    table of their own, never rows of results.csv."""
    out = {p for p in q["planner"].unique() if equal_quality_of(str(p)) is not None}
    if "target_planner" in q:
        out |= set(q.loc[q["target_planner"].notna(), "planner"].unique())
    return out


PAIR_KEY = ["env", "split", "seed", "query_id"]


def bit_star_pairs(q: pd.DataFrame) -> pd.DataFrame:
    """Per query solved by a planner and by bit_star (paired on env, split, seed, query id):
    env, split, planner, seed, query_id, path_cost, bit_star_cost, ratio. A query logged in
    several files of the same (env, planner, seed) counts once, with the mean of its costs."""
    cols = KEYS + ["seed", "query_id", "path_cost", "bit_star_cost", "ratio"]
    solved = q[q["success"] & np.isfinite(q["path_cost"])]
    if solved.empty:
        return pd.DataFrame(columns=cols)
    c = solved.groupby(["planner"] + PAIR_KEY, sort=False)["path_cost"].mean().reset_index()
    b = c[(c["planner"] == "bit_star") & (c["path_cost"] > 0)].drop(columns="planner")
    m = c[c["planner"] != "bit_star"].merge(b.rename(columns={"path_cost": "bit_star_cost"}), on=PAIR_KEY)
    m["ratio"] = m["path_cost"] / m["bit_star_cost"]
    return m[cols]


def results_table(q: pd.DataFrame) -> pd.DataFrame:
    """results.csv: one row per env x split x planner (see the module docstring); the
    time-to-equal-quality planners are left out (equal_quality_table)."""
    q = q[~q["planner"].isin(equal_quality_planners(q))]
    if q.empty:
        return pd.DataFrame(columns=RESULT_COLS)
    g = q.groupby(KEYS, sort=False)
    res = pd.DataFrame({"queries": g.size(), "seeds": g["seed"].nunique(), "successes": g["success"].sum()})
    per_seed = q.groupby(KEYS + ["seed"], sort=False)["success"].mean().groupby(level=KEYS, sort=False)
    res["success_mean"] = per_seed.mean()
    res["success_std"] = _std(per_seed)
    solved = q[q["success"]]
    t = solved[np.isfinite(solved["time_s"])].groupby(KEYS, sort=False)["time_s"]
    res["time_mean_s"] = t.mean()
    res["time_std_s"] = _std(t)
    res["time_median_s"] = t.median()
    res["time_p90_s"] = t.quantile(0.9)
    by = solved.groupby(KEYS, sort=False)
    res["cpu_mean_s"] = by["cpu_s"].mean()
    res["cost_mean"] = by["path_cost"].mean()
    ref = solved["reference_cost"]
    has_ref = np.isfinite(solved["path_cost"]) & np.isfinite(ref) & (ref > 0)
    qual = solved.loc[has_ref, KEYS].assign(quality=(solved["path_cost"] / ref)[has_ref]) \
        .groupby(KEYS, sort=False)["quality"]
    res["quality_n"] = qual.size()
    res["quality_median"] = qual.median()
    res["quality_p90"] = qual.quantile(0.9)
    pairs = bit_star_pairs(q).groupby(KEYS, sort=False)["ratio"]
    res["cost_over_bit_star_n"] = pairs.size()
    res["cost_over_bit_star_median"] = pairs.median()
    res["collision_checks_median"] = by["collision_checks"].median()
    res["pnet_calls_median"] = g["pnet_calls"].median()
    res["replans_mean"] = g["replans"].mean()
    res["fallback_rate"] = g["fallback_used"].mean()
    fails = q[~q["success"]]
    if len(fails):
        counts = fails.assign(failure=fails["failure"].fillna("unknown")).groupby(KEYS + ["failure"]).size()
        res["failures"] = counts.groupby(level=KEYS).apply(
            lambda s: "; ".join(f"{k[-1]}: {v}" for k, v in sorted(s.items(), key=lambda kv: (-kv[1], kv[0][-1]))))
    else:
        res["failures"] = ""
    res["failures"] = res["failures"].fillna("")
    draws = {k: boot_medians(v.to_numpy(), ("time",) + k) for k, v in t}
    res = res.reset_index()
    for c in ("queries", "seeds", "successes", "quality_n", "cost_over_bit_star_n"):
        res[c] = res[c].fillna(0).astype(int)
    res["success_rate"] = res["successes"] / res["queries"]
    keys = list(zip(res["env"], res["split"], res["planner"]))
    ci = [wilson(k, n) for k, n in zip(res["successes"], res["queries"])]
    res["success_ci_low"], res["success_ci_high"] = [c[0] for c in ci], [c[1] for c in ci]
    ci = [boot_interval(draws.get(k)) for k in keys]
    res["time_median_ci_low"], res["time_median_ci_high"] = [c[0] for c in ci], [c[1] for c in ci]
    _compare(res, keys, draws)
    return _sort(res[RESULT_COLS])


def _compare(res: pd.DataFrame, keys: list[tuple], draws: dict) -> None:
    """Each row against its comparator (comparator_of) in the same env x split, in place:
    success by Fisher's exact test, median time by the bootstrap interval of the ratio of
    medians (the two rows resampled independently); significant at ALPHA."""
    row = {k: i for i, k in enumerate(keys)}
    out = {c: [None] * len(keys) for c in ("comparator", "success_p_vs", "success_diff_significant",
                                           "time_ratio_vs", "time_ratio_vs_ci_low", "time_ratio_vs_ci_high",
                                           "time_diff_significant")}
    k_, n_, med = res["successes"].tolist(), res["queries"].tolist(), res["time_median_s"].tolist()
    for i, (env, split, planner) in enumerate(keys):
        c = comparator_of(planner)
        j = row.get((env, split, c))
        if j is None:
            continue
        out["comparator"][i] = c
        p = fisher_p(k_[i], n_[i], k_[j], n_[j])
        out["success_p_vs"][i] = p
        out["success_diff_significant"][i] = bool(p < ALPHA)
        a, b = draws.get(keys[i]), draws.get(keys[j])
        if a is None or b is None or not med[j] > 0:
            continue
        with np.errstate(divide="ignore", invalid="ignore"):
            lo, hi = boot_interval(a / b)
        out["time_ratio_vs"][i] = med[i] / med[j]
        out["time_ratio_vs_ci_low"][i], out["time_ratio_vs_ci_high"][i] = lo, hi
        out["time_diff_significant"][i] = excludes_one(lo, hi)
    for c, v in out.items():
        res[c] = pd.Series(v, index=res.index, dtype=object if c in ("comparator", "success_diff_significant",
                                                                     "time_diff_significant") else float)


def duplicate_warnings(q: pd.DataFrame, files: list[TrialFile]) -> list[str]:
    """One line per (env, planner, seed) with queries (same split, workspace and query id)
    logged in more than one file: they all count, as documented, but it is seldom meant
    (e.g. a sweep run twice into different directories)."""
    key = ["env", "planner", "seed", "split", "workspace_id", "query_id"]
    per_file = q[key + ["file"]].drop_duplicates()
    d = per_file[per_file.duplicated(key, keep=False)]
    out = []
    groups = sorted(d.groupby(["env", "planner", "seed"], sort=False),
                    key=lambda kv: (env_rank(kv[0][0]), planner_rank(kv[0][1]), kv[0][2]))
    for (env, planner, seed), g in groups:
        n = len(g.drop_duplicates(key))
        names = ", ".join(str(files[i].path) for i in sorted(g["file"].unique()))
        out.append(f"warning: {env} {planner} seed {seed}: {n} queries logged in more than one file, "
                   f"all counted: {names}")
    return out


def _planner_columns(planners: Iterable[str]) -> list[str]:
    """Table I's columns: the paper's four planners always, then any other logged planner."""
    extra = sorted(set(planners) - set(PAPER_PLANNERS), key=planner_rank)
    return list(PAPER_PLANNERS) + extra


def load_paper() -> pd.DataFrame:
    """The paper's Table I (harness/paper_table1.csv: env, split, planner, time_mean_s, time_std_s),
    with the times also as printed (`time_mean_text`, `time_std_text`): the tables show the
    paper's numbers exactly as given, never reformatted."""
    with resources.files("harness").joinpath("paper_table1.csv").open("r") as f:
        df = pd.read_csv(f, dtype=str, keep_default_na=False)
    for c, text in (("time_mean_s", "time_mean_text"), ("time_std_s", "time_std_text")):
        df[text] = df[c].str.strip()
        df[c] = pd.to_numeric(df[text], errors="coerce").astype(float)
    return df


def _time_cols(planners: Iterable[str]) -> list[str]:
    return [f"{p}_{s}" for p in planners for s in ("time_mean_s", "time_std_s")]


def table1(res: pd.DataFrame, paper: pd.DataFrame | None = None) -> tuple[pd.DataFrame, list[str]]:
    """Table I as numbers: rows env x split (x source: ours, then the paper's where asked),
    `<planner>_time_mean_s` / `_time_std_s` per planner column, the paper's four planners
    first, then the BIT*/NR ratio, then any other planner (so the paper's layout comes first)."""
    planners = _planner_columns(res["planner"] if len(res) else [])
    sources = [("ours", res)] + ([("paper", paper)] if paper is not None else [])
    vals = {(src, e, s, p): (m, sd) for src, df in sources
            for e, s, p, m, sd in zip(df["env"], df["split"], df["planner"], df["time_mean_s"], df["time_std_s"])}
    rows = []
    for env, split in sorted(set(zip(res["env"], res["split"])), key=lambda k: (env_rank(k[0]), split_rank(k[1]))):
        for src, _ in sources:
            if src != "ours" and not any((src, env, split, p) in vals for p in planners):
                continue
            row = {"env": env, "split": split, "source": src}
            for p in planners:
                m, sd = vals.get((src, env, split, p), (math.nan, math.nan))
                row[f"{p}_time_mean_s"], row[f"{p}_time_std_s"] = float(m), float(sd)
            rows.append(row)
    t = pd.DataFrame(rows, columns=["env", "split", "source"] + _time_cols(planners))
    t[RATIO_COL] = t["bit_star_time_mean_s"] / t["mpnet_nr_time_mean_s"]
    extra = [p for p in planners if p not in PAPER_PLANNERS]
    t = t[["env", "split", "source"] + _time_cols(PAPER_PLANNERS) + [RATIO_COL] + _time_cols(extra)]
    return t.reset_index(drop=True), planners


def main_planners(res: pd.DataFrame) -> pd.DataFrame:
    """The rows of Table I, success_cost and the figures: every planner but the ablations."""
    return res[[ablation_of(str(p)) is None for p in res["planner"]]].reset_index(drop=True)


def success_cost(res: pd.DataFrame) -> pd.DataFrame:
    """Success rate (mean and std over seeds, %; the pooled rate with its Wilson interval, %;
    the test against the comparator) and mean path cost per env x split x planner."""
    cols = ["env", "split", "planner", "success_mean_pct", "success_std_pct", "success_rate_pct",
            "success_ci_low_pct", "success_ci_high_pct", "comparator", "success_p_vs", "success_diff_significant",
            "cost_mean", "queries", "seeds"]
    if res.empty:
        return pd.DataFrame(columns=cols)
    out = res[["env", "split", "planner", "comparator", "success_p_vs", "success_diff_significant", "cost_mean",
               "queries", "seeds"]].copy()
    out["success_mean_pct"] = 100.0 * res["success_mean"]
    out["success_std_pct"] = 100.0 * res["success_std"]
    for c in ("success_rate", "success_ci_low", "success_ci_high"):
        out[c + "_pct"] = 100.0 * res[c]
    return out[cols]


QUALITY_COLS = ["env", "split", "planner", "successes", "quality_n", "quality_median", "quality_p90",
                "cost_over_bit_star_n", "cost_over_bit_star_median"]


def quality_table(res: pd.DataFrame) -> pd.DataFrame:
    """quality.csv: per env x split x planner (ablations included), path quality (path cost /
    the query's reference cost: median, p90, n) and the median ratio to BIT*'s path cost on
    the same queries; empty when the logs have neither (no reference cost, no BIT* pairs)."""
    if res.empty or not (res["quality_n"].sum() > 0 or res["cost_over_bit_star_n"].sum() > 0):
        return pd.DataFrame(columns=QUALITY_COLS)
    return res[QUALITY_COLS].reset_index(drop=True)


ABLATION_COLS = ["env", "split", "planner", "base", "variant", "change", "queries", "successes", "success_rate",
                 "success_ci_low", "success_ci_high", "success_p_vs", "success_diff_significant", "time_median_s",
                 "time_median_ci_low", "time_median_ci_high", "time_ratio_vs", "time_ratio_vs_ci_low",
                 "time_ratio_vs_ci_high", "time_diff_significant", "quality_n", "quality_median",
                 "cost_over_bit_star_n", "cost_over_bit_star_median"]
_VS_COLS = ["success_p_vs", "success_diff_significant", "time_ratio_vs", "time_ratio_vs_ci_low",
            "time_ratio_vs_ci_high", "time_diff_significant"]


def ablation_table(res: pd.DataFrame) -> pd.DataFrame:
    """ablations.csv: per env x split, each base (mpnet_nr, mpnet_hr) that has an ablation there,
    then its ablations; an ablation's comparisons are against its base (results.csv's), the
    base row has none. Empty without ablations."""
    if res.empty:
        return pd.DataFrame(columns=ABLATION_COLS)
    rows = []
    for (env, split), d in _sort(res, ("env", "split")).groupby(["env", "split"], sort=False):
        by = {p: r for p, r in zip(d["planner"], d.to_dict("records"))}
        for base in ABLATION_BASES:
            abl = sorted((p for p in by if (ablation_of(p) or ("",))[0] == base), key=planner_rank)
            if not abl:
                continue
            for p in ([base] if base in by else []) + abl:
                r = dict(by[p])
                variant = ablation_of(p)[1] if p != base else ""
                r.update(base=base, variant=variant, change=ABLATIONS.get(variant, variant) if variant else "")
                if p == base:
                    r.update({c: None for c in _VS_COLS})
                rows.append(r)
    return pd.DataFrame(rows, columns=ABLATION_COLS)


EQ_COLS = ["env", "split", "planner", "algorithm", "factor", "target_planner", "queries", "no_target", "targeted",
           "reached", "reach_rate", "reach_ci_low", "reach_ci_high", "time_to_reach_median_s",
           "time_to_reach_ci_low", "time_to_reach_ci_high", "censored", "time_reached_median_s",
           "time_reached_ci_low", "time_reached_ci_high", "target_time_median_s", "target_time_ci_low",
           "target_time_ci_high", "time_ratio", "time_ratio_ci_low", "time_ratio_ci_high", "time_ratio_significant",
           "budget_s"]


def run_config(run: dict) -> dict:
    """A run's resolved config (its YAML text) as a dict; {} when it is not one."""
    import yaml

    try:
        cfg = yaml.safe_load(str(run.get("config") or "")) or {}
    except yaml.YAMLError:
        return {}
    return cfg if isinstance(cfg, dict) else {}


def _cfg_get(cfg: dict, *keys):
    for k in keys:
        if not isinstance(cfg, dict):
            return None
        cfg = cfg.get(k)
    return cfg


def _number(v) -> float | None:
    if isinstance(v, bool) or not isinstance(v, (int, float, str)):
        return None
    try:
        v = float(v)
    except ValueError:
        return None
    return v if math.isfinite(v) else None


def equal_quality_table(q: pd.DataFrame, files: list[TrialFile]) -> tuple[pd.DataFrame, list[str]]:
    """equal_quality.csv: per env x split x (algorithm, factor) of the time-to-equal-quality runs,
    and warning lines. A query is targeted when its target planner's cost (`target_cost`) was
    logged; it is reached when it logged success with a path cost <= factor x target cost (a
    success above that is a miss, with a warning). The median time to reach is over all
    targeted queries, a miss counting as +inf (censored: the median is a miss, beyond the
    budget); beside it the median over the reached ones, the target planner's median time
    (`target_time_s`) over the targeted queries, and the ratio of the two medians."""
    eqp = equal_quality_planners(q)
    d = q[q["planner"].isin(eqp)].copy()
    if d.empty:
        return pd.DataFrame(columns=EQ_COLS), []
    meta = {}
    for f in sorted(d["file"].unique()):
        run = files[int(f)].run
        cfg = run_config(run)
        name = str(run["planner"])
        eq = equal_quality_of(name)
        factor = _number(_cfg_get(cfg, "planner", "cost_factor")) or (eq[2] if eq and eq[2] else 1.0)
        alg = eq[0] if eq else str(_cfg_get(cfg, "planner", "algorithm") or name)
        target = ("mpnet_" + eq[1]) if eq else None
        meta[f] = (alg, factor, target, _budget(run.get("config")))
    d["algorithm"] = [meta[f][0] for f in d["file"]]
    d["factor"] = [meta[f][1] for f in d["file"]]
    d["budget_s"] = [meta[f][3] for f in d["file"]]
    d["target_planner"] = [t if t is not None else meta[f][2] or "unknown"
                           for t, f in zip(d["target_planner"], d["file"])]
    tgt = d["target_cost"]
    d["targeted"] = np.isfinite(tgt) & (tgt > 0)
    above = d["success"] & d["targeted"] & (d["path_cost"] > d["factor"] * tgt * (1 + REACH_RTOL))
    d["reached"] = d["success"] & d["targeted"] & ~above
    warns = []
    for planner, n in d[above].groupby("planner").size().items():
        warns.append(f"warning: {planner}: {n} of its logged successes have a path cost above factor x target "
                     "cost: counted as not reaching the target")
    rows = []
    group = ["env", "split", "algorithm", "factor"]
    for key, g in d.groupby(group, sort=False):
        env, split, alg, factor = key
        targets = sorted(set(g["target_planner"]) - {"unknown"}) or ["unknown"]
        t = g[g["targeted"]]
        k, n = int(t["reached"].sum()), len(t)
        ci = wilson(k, n)
        tag = (env, split, alg, factor)
        all_t = np.where(t["reached"], t["time_s"], np.inf)
        all_t = all_t[~np.isnan(all_t)]
        reached_t = t.loc[t["reached"], "time_s"].to_numpy(float)
        reached_t = reached_t[np.isfinite(reached_t)]
        nr_t = t["target_time_s"].to_numpy(float)
        nr_t = nr_t[np.isfinite(nr_t)]
        b_all = boot_medians(all_t, ("eq_all",) + tag)
        b_reached = boot_medians(reached_t, ("eq_reached",) + tag)
        b_nr = boot_medians(nr_t, ("eq_target",) + tag)
        m_all = float(np.median(all_t)) if len(all_t) else math.nan
        m_nr = float(np.median(nr_t)) if len(nr_t) else math.nan
        ratio, rlo, rhi = math.nan, math.nan, math.nan
        if b_all is not None and b_nr is not None and m_nr > 0:
            ratio = m_all / m_nr
            with np.errstate(divide="ignore", invalid="ignore"):
                rlo, rhi = boot_interval(b_all / b_nr)
        budgets = [b for b in g["budget_s"] if b is not None and math.isfinite(b)]
        rows.append({
            "env": env, "split": split, "planner": ", ".join(sorted(g["planner"].unique(), key=planner_rank)),
            "algorithm": alg, "factor": factor, "target_planner": ", ".join(targets), "queries": len(g),
            "no_target": int((~g["targeted"]).sum()), "targeted": n, "reached": k,
            "reach_rate": k / n if n else math.nan, "reach_ci_low": ci[0], "reach_ci_high": ci[1],
            "time_to_reach_median_s": m_all, **dict(zip(("time_to_reach_ci_low", "time_to_reach_ci_high"),
                                                        boot_interval(b_all))),
            "censored": bool(np.isinf(m_all)) if len(all_t) else None,
            "time_reached_median_s": float(np.median(reached_t)) if len(reached_t) else math.nan,
            **dict(zip(("time_reached_ci_low", "time_reached_ci_high"), boot_interval(b_reached))),
            "target_time_median_s": m_nr,
            **dict(zip(("target_time_ci_low", "target_time_ci_high"), boot_interval(b_nr))),
            "time_ratio": ratio, "time_ratio_ci_low": rlo, "time_ratio_ci_high": rhi,
            "time_ratio_significant": excludes_one(rlo, rhi),
            "budget_s": max(budgets) if budgets else math.nan})
    out = pd.DataFrame(rows, columns=EQ_COLS)
    if out.empty:
        return out, warns
    out["_alg"] = [planner_rank(a) for a in out["algorithm"]]
    order = sorted(range(len(out)), key=lambda i: (env_rank(out["env"].iat[i]), split_rank(out["split"].iat[i]),
                                                  out["_alg"].iat[i], out["factor"].iat[i]))
    return out.iloc[order].drop(columns="_alg").reset_index(drop=True), warns


# ------------------------------------------------------------------------ rendering

def _decimals(x: float, digits: int = 3) -> int:
    """Decimals that show `digits` significant digits of x (0 for large x)."""
    return max(0, digits - 1 - math.floor(math.log10(abs(x)))) if x else digits - 1


def _g(x, digits: int = 3) -> str:
    """A number with `digits` significant digits (fixed point), blank when missing."""
    if x is None or not np.isfinite(x):
        return ""
    return f"{x:.{_decimals(x, digits)}f}"


def _pm(m, s, decimals: int | None = None, sep: str = " ± ") -> str:
    """'mean ± std', both with the decimals that give the mean 3 significant digits."""
    if m is None or not np.isfinite(m):
        return ""
    d = _decimals(m) if decimals is None else decimals
    return f"{m:.{d}f}" + ("" if s is None or not np.isfinite(s) else f"{sep}{s:.{d}f}")


def _tex_escape(s: str) -> str:
    s = re.sub(r"([&%$#_{}])", r"\\\1", s).replace("~", r"\textasciitilde{}")
    return s.replace(APPROX, r"$\approx$").replace("±", r"$\pm$").replace("×", r"$\times$")


def _md_table(header: list[str], rows: list[list[str]]) -> str:
    lines = ["| " + " | ".join(header) + " |", "|" + "|".join(["---"] * len(header)) + "|"]
    lines += ["| " + " | ".join(r) + " |" for r in rows]
    return "\n".join(lines)


def _tex_table(header: list[str], rows: list[list[str]], groups: list, caption: str, notes: list[str],
               n_text: int = 2) -> str:
    """A booktabs table, its first n_text columns left-aligned, the rest right; `groups` gives
    each row's group so a \\midrule separates groups."""
    spec = "l" * n_text + "r" * (len(header) - n_text)
    out = [r"\begin{table}[t]", r"\centering", r"\caption{" + caption + "}", r"\begin{tabular}{" + spec + "}",
           r"\toprule", " & ".join(header) + r" \\", r"\midrule"]
    last = None
    for g, r in zip(groups, rows):
        if last is not None and g != last:
            out.append(r"\midrule")
        out.append(" & ".join(r) + r" \\")
        last = g
    out += [r"\bottomrule", r"\end{tabular}"]
    out += [r"\par\smallskip{\footnotesize " + n + "}" for n in notes]
    out.append(r"\end{table}")
    return "\n".join(out) + "\n"


def render_table1(t: pd.DataFrame, planners: list[str], with_paper: bool, res: pd.DataFrame | None = None,
                  paper: pd.DataFrame | None = None) -> tuple[str, str]:
    """Table I as (Markdown, LaTeX), columns in t's order (the paper's planners, the ratio, the
    others). A planner of res that ran but has no time to show reads "— (successes/queries)"
    rather than blank, which is kept for a planner not run; the paper's rows are its numbers
    as printed (load_paper's text columns)."""
    counts = {} if res is None else {
        (e, s, p): (int(k), int(n)) for e, s, p, k, n in
        zip(res["env"], res["split"], res["planner"], res["successes"], res["queries"])}
    same_time = set() if res is None or "time_diff_significant" not in res else {
        (e, s, p) for e, s, p, sig in zip(res["env"], res["split"], res["planner"], res["time_diff_significant"])
        if _is_false(sig)}
    printed = {} if paper is None or "time_mean_text" not in paper else {
        (e, s, p): (m, sd) for e, s, p, m, sd in
        zip(paper["env"], paper["split"], paper["planner"], paper["time_mean_text"], paper["time_std_text"])}
    main = [p for p in planners if p in PAPER_PLANNERS]
    extra = [p for p in planners if p not in PAPER_PLANNERS]
    head = (["Env", "Split"] + (["Source"] if with_paper else []) + [planner_label(p) for p in main]
            + [RATIO_LABEL] + [planner_label(p) for p in extra])

    def cell(r: dict, p: str, sep: str, dash: str) -> str:
        key = (r["env"], r["split"], p)
        if r["source"] == "paper" and key in printed:
            m, sd = printed[key]
            return m + (f"{sep}{sd}" if sd else "")
        text = _pm(r[f"{p}_time_mean_s"], r[f"{p}_time_std_s"], sep=sep)
        if not text and r["source"] == "ours" and key in counts:
            return f"{dash} ({counts[key][0]}/{counts[key][1]})"
        if text and r["source"] == "ours" and key in same_time:
            return (APPROX + " " if sep == " ± " else r"$\approx$ ") + text
        return text

    def ratio_cell(r: dict, tex: bool) -> str:
        text = _g(r[RATIO_COL])
        if text and r["source"] == "ours" and (r["env"], r["split"], "bit_star") in same_time:
            return (r"$\approx$ " if tex else APPROX + " ") + text
        return text

    md_rows, tex_rows, groups = [], [], []
    prev = None
    for r in t.itertuples(index=False):
        r = r._asdict()
        first = (r["env"], r["split"]) != prev
        prev = (r["env"], r["split"])
        lead = [env_label(r["env"]) if first else "", r["split"] if first else ""]
        src = [r["source"]] if with_paper else []
        md_rows.append(lead + src + [cell(r, p, " ± ", "—") for p in main] + [ratio_cell(r, False)]
                       + [cell(r, p, " ± ", "—") for p in extra])
        tex_rows.append([_tex_escape(x) for x in lead + src] + [cell(r, p, r" $\pm$ ", "---") for p in main]
                        + [ratio_cell(r, True)] + [cell(r, p, r" $\pm$ ", "---") for p in extra])
        groups.append(r["env"])
    what = ("Planning time in seconds, mean ± std over the successful queries of all seeds; "
            f"{RATIO_LABEL}: ratio of mean times. — (0/N): the planner ran N queries here and solved none "
            "(— (k/N): k solved, none with a logged time); blank: the planner was not run.")
    mark = (f"{APPROX} before a time: that planner's median time does not differ significantly (5%) from MPNet "
            f"(NR)'s in the same row (the 95% bootstrap interval of the ratio of median times contains 1); "
            f"{APPROX} before {RATIO_LABEL}: the same for BIT* against MPNet (NR). The test is on median times "
            "(results.csv: time_ratio_vs, time_diff_significant); the cells show means.")
    notes = [f"Layout of Table I of {CITATION}.", mark]
    if with_paper:
        notes.append("Rows 'paper' are the paper's own numbers as printed; their BIT*/MPNet (NR) is the ratio of "
                     "the paper's mean times, computed here. Our baselines are OMPL's C++ planners, so ratios "
                     "are expected to differ.")
    md = "# Table I: planning time [s]\n\n" + _md_table(head, md_rows) + "\n\n" + what + "\n\n" + \
        "\n".join(f"Note: {n}" for n in notes) + "\n"
    tex = _tex_table([_tex_escape(h) for h in head], tex_rows, groups,
                     r"Planning time [s], mean $\pm$ std over successful queries; " + _tex_escape(RATIO_LABEL)
                     + r": ratio of mean times. --- (0/$N$): ran $N$ queries, solved none; blank: not run.",
                     [_tex_escape(n) for n in notes], 3 if with_paper else 2)
    return md, tex


def _ci(lo, hi, fmt=None) -> str:
    """'[lo, hi]' (3 significant digits, or fmt), +inf as ∞; blank when missing."""
    fmt = fmt or _g
    if lo is None or hi is None or (isinstance(lo, float) and math.isnan(lo)) or \
            (isinstance(hi, float) and math.isnan(hi)):
        return ""
    a, b = ("∞" if np.isposinf(x) else fmt(x) for x in (lo, hi))
    return f"[{a}, {b}]"


def _pct(x) -> str:
    return "" if x is None or not np.isfinite(x) else f"{100.0 * x:.1f}"


def _with_ci(value: str, lo, hi, fmt=None, same: bool = False) -> str:
    """'value [lo, hi]', with the not-significant mark in front when `same`."""
    if not value:
        return ""
    ci = _ci(lo, hi, fmt)
    return (APPROX + " " if same else "") + value + (f" {ci}" if ci else "")


def _is_false(v) -> bool:
    """A flag that says False (not None, not NaN), e.g. 'not significant'."""
    return isinstance(v, (bool, np.bool_)) and not v


def _is_true(v) -> bool:
    return isinstance(v, (bool, np.bool_)) and bool(v)


def _comparator_note(what: str, test: str) -> str:
    return (f"{APPROX}: the planner's {what} does not differ significantly (5%) from its comparator's in the same "
            "env and split: MPNet (NR) for every planner but MPNet (NR) itself (not marked) and the MPNet (HR) "
            f"ablations, which are compared with MPNet (HR); {test}.")


def render_success_cost(sc: pd.DataFrame, with_paper: bool) -> tuple[str, str]:
    """The success / path cost table as (Markdown, LaTeX)."""
    head = ["Env", "Split", "Planner", "Success [%]", "Pooled [%] [95% CI]", "Path cost", "Queries", "Seeds"]
    md_rows, tex_rows, groups = [], [], []
    prev = None
    for r in sc.itertuples(index=False):
        first = (r.env, r.split) != prev
        prev = (r.env, r.split)
        lead = [env_label(r.env) if first else "", r.split if first else ""]
        same = _is_false(r.success_diff_significant)
        succ = (APPROX + " " if same else "") + _pm(r.success_mean_pct, r.success_std_pct, 1)
        pooled = _with_ci(_g1(r.success_rate_pct), r.success_ci_low_pct, r.success_ci_high_pct, _g1)
        rest = [planner_label(r.planner), succ, pooled, _g(r.cost_mean), str(r.queries), str(r.seeds)]
        md_rows.append(lead + rest)
        tex_rows.append([_tex_escape(x) for x in lead + rest[:1]]
                        + [(r"$\approx$ " if same else "")
                           + _pm(r.success_mean_pct, r.success_std_pct, 1, sep=r" $\pm$ ")] + rest[2:])
        groups.append(r.env)
    what = ("Success: mean ± std over seeds of the per-seed success rate (std: ddof=1 with two seeds or "
            "more, else 0). Pooled: successes / queries of all seeds, with its Wilson score 95% interval. "
            "Path cost: mean over successful queries.")
    notes = [_comparator_note("success rate", "two-sided Fisher exact test on the pooled successes / queries, "
                              "p >= 0.05 (results.csv: success_p_vs)")]
    if with_paper:
        notes.append(f"The paper reports MPNet (NR) succeeding about 97% and MPNet (HR) 100% of the time ({PAPER}).")
    md = "# Success rate and path cost\n\n" + _md_table(head, md_rows) + "\n\n" + what + "\n" + \
        "".join(f"\nNote: {n}\n" for n in notes)
    tex = _tex_table([_tex_escape(h) for h in head], tex_rows, groups,
                     r"Success rate [\%], mean $\pm$ std over seeds and pooled with its Wilson 95\% interval, "
                     r"and mean path cost of successful queries.",
                     [_tex_escape(n) for n in notes], 3)
    return md, tex


def _g1(x) -> str:
    """A percentage with one decimal, blank when missing."""
    return "" if x is None or not np.isfinite(x) else f"{x:.1f}"


def _group_rows(df: pd.DataFrame, cells) -> list[list[str]]:
    """Markdown rows: env and split shown on the first row of each env x split group."""
    rows, prev = [], None
    for r in df.to_dict("records"):
        first = (r["env"], r["split"]) != prev
        prev = (r["env"], r["split"])
        rows.append([env_label(r["env"]) if first else "", r["split"] if first else ""] + cells(r))
    return rows


def render_quality(qt: pd.DataFrame, notes: list[str]) -> str:
    """quality.md."""
    head = ["Env", "Split", "Planner", "Quality median", "Quality p90", "n", "Cost / BIT* median", "Pairs"]
    rows = _group_rows(qt, lambda r: [planner_label(r["planner"]), _g(r["quality_median"]), _g(r["quality_p90"]),
                                      str(int(r["quality_n"])), _g(r["cost_over_bit_star_median"]),
                                      str(int(r["cost_over_bit_star_n"]))])
    what = ("Quality: path cost / the query's reference cost, over the successful queries of all seeds that have a "
            "reference (n); median and 90th percentile (linear interpolation). Cost / BIT*: median over the "
            "queries solved by both this planner and BIT* (paired on env, split, seed and query id; Pairs) of "
            "this planner's path cost / BIT*'s (BIT*'s first solution in the Table I runs).")
    return f"# Path quality\n\n{_md_table(head, rows)}\n\n{what}\n" + "".join(f"\nNote: {n}\n" for n in notes)


def render_ablations(ab: pd.DataFrame) -> str:
    """ablations.md."""
    head = ["Env", "Split", "Planner", "Change", "Success [%] [95% CI]", "Median time [s] [95% CI]",
            "Time / base [95% CI]", "Quality median", "Cost / BIT* median"]

    def cells(r):
        return [planner_label(r["planner"]), r["change"] or "(base)",
                _with_ci(_pct(r["success_rate"]), r["success_ci_low"], r["success_ci_high"], _pct,
                         _is_false(r["success_diff_significant"])),
                _with_ci(_g(r["time_median_s"]), r["time_median_ci_low"], r["time_median_ci_high"], None,
                         _is_false(r["time_diff_significant"])),
                _with_ci(_g(r["time_ratio_vs"]), r["time_ratio_vs_ci_low"], r["time_ratio_vs_ci_high"]),
                _g(r["quality_median"]), _g(r["cost_over_bit_star_median"])]

    what = ("Each ablation is its base planner (MPNet (NR) or MPNet (HR), the row above it marked (base)) with one "
            "piece changed. Success: successes / queries of all seeds with the Wilson score 95% interval. Median "
            f"time: over the successful queries of all seeds, with a 95% bootstrap interval ({BOOT_N} resamples). "
            "Time / base: ratio of median times, with the 95% bootstrap interval of the ratio. Quality and Cost / "
            "BIT*: as in quality.md.")
    note = (f"{APPROX}: the ablation's success rate (Fisher exact test, two-sided, p >= 0.05) or median time (the "
            "interval of Time / base contains 1) does not differ significantly from its base's.")
    return f"# MPNet ablations\n\n{_md_table(head, _group_rows(ab, cells))}\n\n{what}\n\nNote: {note}\n"


def _budget_text(b) -> str:
    return f"> budget ({_g(b)} s)" if b is not None and np.isfinite(b) else "> budget"


def render_equal_quality(eq: pd.DataFrame) -> str:
    """equal_quality.md."""
    head = ["Env", "Split", "Planner", "Stops at", "No target", "Targeted", "Reached [%] [95% CI]",
            "Median time to reach, all targeted [s] [95% CI]", "Median time, reached only [s] [95% CI]",
            "Target planner's median time [s] [95% CI]", "Ratio [95% CI]"]

    def cells(r):
        target = ", ".join(planner_label(t) for t in str(r["target_planner"]).split(", "))
        if _is_true(r["censored"]):
            to_reach = _budget_text(r["budget_s"]) + (f" {_ci(r['time_to_reach_ci_low'], r['time_to_reach_ci_high'])}"
                                                      if not math.isnan(r["time_to_reach_ci_low"]) else "")
            nr = r["target_time_median_s"]
            ratio = (f"> {_g(r['budget_s'] / nr)}" if np.isfinite(r["budget_s"]) and nr > 0 else "∞")
            ratio = (APPROX + " " if _is_false(r["time_ratio_significant"]) else "") + ratio
        else:
            to_reach = _with_ci(_g(r["time_to_reach_median_s"]), r["time_to_reach_ci_low"],
                                r["time_to_reach_ci_high"])
            ratio = _with_ci(_g(r["time_ratio"]), r["time_ratio_ci_low"], r["time_ratio_ci_high"], None,
                             _is_false(r["time_ratio_significant"]))
        return [planner_label(r["algorithm"]), f"cost ≤ {r['factor']:g} × {target}'s", str(r["no_target"]),
                str(r["targeted"]),
                _with_ci(_pct(r["reach_rate"]), r["reach_ci_low"], r["reach_ci_high"], _pct),
                to_reach,
                _with_ci(_g(r["time_reached_median_s"]), r["time_reached_ci_low"], r["time_reached_ci_high"]),
                _with_ci(_g(r["target_time_median_s"]), r["target_time_ci_low"], r["target_time_ci_high"]),
                ratio]

    what = ("Time to equal quality: on each query the target planner (MPNet (NR)) plans first, untimed; the "
            "classical planner then runs until its path cost is at most the factor × the target's verified path "
            "cost, within the budget. No target: queries the target planner failed (logged `no_target`, left out "
            "of every other column). Targeted: the other queries. Reached: targeted queries whose run logged "
            "success with a path cost within the target, with the Wilson score 95% interval. Median time to "
            "reach: over all targeted queries, a miss counting as +∞; '> budget': at least half of them were "
            "missed, so the median lies beyond the budget. Reached only: over the reached queries. Target "
            "planner's median time: its `target_time_s` over the targeted queries. Ratio: median time to reach "
            f"(all targeted) / the target planner's median time. Intervals: 95% bootstrap ({BOOT_N} resamples; "
            "the ratio's two medians resampled independently).")
    note = f"{APPROX} before a ratio: its interval contains 1 (the two median times do not differ significantly)."
    return f"# Time to equal quality\n\n{_md_table(head, _group_rows(eq, cells))}\n\n{what}\n\nNote: {note}\n"


# ---------------------------------------------------------------------------- figures

def _figure(n_panels: int, w: float = 4.0, h: float = 3.4):
    from matplotlib.figure import Figure

    ncols = min(max(n_panels, 1), 4)
    nrows = math.ceil(max(n_panels, 1) / ncols)
    fig = Figure(figsize=(w * ncols, h * nrows), layout="constrained")
    axes = fig.subplots(nrows, ncols, squeeze=False).ravel()
    for ax in axes[n_panels:]:
        ax.set_visible(False)
    return fig, axes[:n_panels]


def _save(fig, out: Path, name: str) -> list[Path]:
    import matplotlib

    paths = []
    with matplotlib.rc_context({"svg.hashsalt": "mpnet-bench"}):
        for ext in ("png", "svg"):
            p = out / f"{name}.{ext}"
            fig.savefig(p, dpi=120 if ext == "png" else None, metadata={"Date": None} if ext == "svg" else None)
            paths.append(p)
    return paths


def _grouped_bars(res: pd.DataFrame, value: str, err: str, scale: float, ylabel: str, log: bool, title: str):
    """One panel per env: splits on x, one bar per planner (error bar: std), as the paper's Fig. 4."""
    envs = sorted(res["env"].unique(), key=env_rank)
    planners = sorted(res["planner"].unique(), key=planner_rank)
    fig, axes = _figure(len(envs))
    width = 0.8 / max(len(planners), 1)
    for ax, env in zip(axes, envs):
        d = res[res["env"] == env]
        splits = sorted(d["split"].unique(), key=split_rank)
        x = np.arange(len(splits))
        for k, p in enumerate(planners):
            dp = d[d["planner"] == p].set_index("split").reindex(splits)
            m = dp[value].to_numpy(float) * scale
            s = np.nan_to_num(dp[err].to_numpy(float) * scale)
            lower = np.minimum(s, 0.9 * m) if log else s  # a log axis has no zero: clip the lower bar
            ax.bar(x - 0.4 + width * (k + 0.5), m, width, yerr=np.vstack([lower, s]), capsize=2,
                   color=PLANNER_COLORS.get(p), label=planner_label(p), error_kw={"elinewidth": 0.8})
        ax.set_xticks(x, splits)
        ax.set_title(env_label(env))
        ax.set_ylabel(ylabel)
        if log:
            ax.set_yscale("log")
        ax.grid(axis="y", alpha=0.3)
    handles, labels = axes[0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="outside lower center", ncols=min(len(labels), 6), frameon=False)
    fig.suptitle(title)
    return fig


def fig_time_per_planner(res: pd.DataFrame):
    d = res[np.isfinite(res["time_mean_s"].astype(float))] if len(res) else res
    if d.empty:
        return None
    return _grouped_bars(d, "time_mean_s", "time_std_s", 1.0, "planning time [s]", True,
                         "Mean planning time ± std (successful queries)")


def fig_success(res: pd.DataFrame):
    if res.empty:
        return None
    return _grouped_bars(res, "success_mean", "success_std", 100.0, "success [%]", False,
                         "Success rate, mean ± std over seeds")


def fig_time_boxplot(q: pd.DataFrame):
    ok = q[q["success"] & (q["time_s"] > 0)]
    if ok.empty:
        return None
    envs = sorted(ok["env"].unique(), key=env_rank)
    fig, axes = _figure(len(envs))
    for ax, env in zip(axes, envs):
        d = ok[ok["env"] == env]
        planners = sorted(d["planner"].unique(), key=planner_rank)
        data = [d.loc[d["planner"] == p, "time_s"].to_numpy() for p in planners]
        bp = ax.boxplot(data, tick_labels=[planner_label(p) for p in planners], whis=(5, 95), showfliers=False,
                        patch_artist=True, medianprops={"color": "black"})
        for box, p in zip(bp["boxes"], planners):
            box.set_facecolor(PLANNER_COLORS.get(p, "#bbbbbb"))
        ax.set_yscale("log")
        ax.set_title(env_label(env))
        ax.set_ylabel("planning time [s]")
        ax.tick_params(axis="x", labelrotation=30)
        ax.grid(axis="y", alpha=0.3)
    fig.suptitle("Per-query planning time of successes (box: quartiles, whiskers: 5th-95th percentile)")
    return fig


def pick_example(q: pd.DataFrame, env: str) -> tuple[dict[str, int], int] | None:
    """Rows of q to draw for env ({planner: row}, and the row whose workspace is drawn): the
    first query, in (split, workspace, query, seed) order, that an MPNet planner (mpnet_nr,
    else mpnet_hr) and BIT* both solved in the same workspace; failing that, the first solved
    query of any planner, with every planner that solved it too."""
    d = q[(q["env"] == env) & q["success"]]
    if d.empty:
        return None
    keys = [(split_rank(s), natural_key(w), natural_key(i), seed) for s, w, i, seed in
            zip(d["split"].tolist(), d["workspace_id"].tolist(), d["query_id"].tolist(), d["seed"].tolist())]
    d = d.iloc[sorted(range(len(d)), key=keys.__getitem__)]
    d = d.drop_duplicates(["planner", "split", "workspace_id", "query_id"])  # each planner's first seed
    solved = {p: dict(zip(zip(g["split"], g["workspace_id"], g["query_id"]), g.index))
              for p, g in d.groupby("planner", sort=False)}
    bit = solved.get("bit_star", {})
    for mp in ("mpnet_nr", "mpnet_hr"):
        for key, r in solved.get(mp, {}).items():  # in the sorted order
            if key in bit:
                return {mp: r, "bit_star": bit[key]}, r
    r = d.index[0]
    key = (d.at[r, "split"], d.at[r, "workspace_id"], d.at[r, "query_id"])
    return {p: rows[key] for p, rows in solved.items() if key in rows}, r


def fig_example(q: pd.DataFrame, files: list[TrialFile], env: str):
    """One workspace of env: obstacles, start, goal and the chosen planners' paths."""
    from matplotlib.patches import Rectangle

    pick = pick_example(q, env)
    if pick is None:
        return None
    chosen, ref = pick
    tf = files[int(q.at[ref, "file"])]
    msg = tf.queries[int(q.at[ref, "qidx"])]
    ws = tf.workspaces.get((str(msg.get("split")), str(msg.get("workspace_id"))))
    robot = ws.get("robot") if ws else None
    kind = robot.get("kind") if isinstance(robot, dict) else None
    if ws is None or kind not in ("point", "rectangle"):
        return None
    fig, (ax,) = _figure(1, 6.0, 6.0)
    bounds = ws.get("bounds") or [[-20, 20], [-20, 20]]
    wd = len((ws.get("obstacles") or [{"center": [0, 0]}])[0]["center"])
    for o in ws.get("obstacles", []):
        c, s = np.asarray(o["center"], float), np.asarray(o["size"], float)
        ax.add_patch(Rectangle(tuple(c[:2] - s[:2] / 2), s[0], s[1], facecolor="0.55",
                               alpha=0.85 if wd == 2 else 0.35, edgecolor="0.3", lw=0.5))
    for p in sorted(chosen, key=planner_rank):
        r = chosen[p]
        m = files[int(q.at[r, "file"])].queries[int(q.at[r, "qidx"])]
        path = np.asarray(m.get("path") or [], float)
        if path.ndim != 2 or len(path) < 2:
            continue
        color = PLANNER_COLORS.get(p, "black")
        ax.plot(path[:, 0], path[:, 1], "-o", color=color, ms=3, lw=1.8,
                label=f"{planner_label(p)} (cost {_g(q.at[r, 'path_cost'])}, {_g(q.at[r, 'time_s'])} s)")
        if kind == "rectangle" and path.shape[1] >= 3:
            for o in rect_outlines(path[:, :3], robot.get("size", (2.0, 5.0))):
                ax.plot(o[:, 0], o[:, 1], color=color, lw=0.7, alpha=0.6)
    start, goal = np.asarray(msg["start"], float), np.asarray(msg["goal"], float)
    ax.plot(*start[:2], "o", color="#2050f0", ms=9, label="start", zorder=5)
    ax.plot(*goal[:2], "*", color="#f09000", ms=14, label="goal", zorder=5)
    ax.set_xlim(*bounds[0])
    ax.set_ylim(*bounds[1])
    ax.set_aspect("equal")
    proj = ", x-y projection" if wd == 3 else ""
    ax.set_title(f"{env_label(env)}: {msg.get('split')} workspace {msg.get('workspace_id')}, "
                 f"query {msg.get('query_id')}{proj}", fontsize=10)
    fig.legend(loc="outside lower center", ncols=2, fontsize=8, frameon=False)
    return fig


def write_figures(res: pd.DataFrame, q: pd.DataFrame, files: list[TrialFile], out: Path
                  ) -> tuple[list[Path], list[str]]:
    """Every figure the data allows, as PNG and SVG; a figure without data is left out, one
    whose data is malformed is left out with a warning line. The PNG and SVG files of an
    earlier report in out are removed first, so none outlives the data it was drawn from."""
    out.mkdir(parents=True, exist_ok=True)
    for old in out.iterdir():
        if old.suffix.lower() in (".png", ".svg") and (old.is_file() or old.is_symlink()):
            old.unlink()
    makers = [("time_per_planner", lambda: fig_time_per_planner(res)), ("success", lambda: fig_success(res)),
              ("time_boxplot", lambda: fig_time_boxplot(q))]
    makers += [(f"example_{env}", lambda env=env: fig_example(q, files, env))
               for env in sorted(q["env"].unique(), key=env_rank)]
    written, warns = [], []
    for name, make in makers:
        try:
            fig = make()
        except (KeyError, IndexError, TypeError, ValueError) as e:
            warns.append(f"warning: figure {name} left out: malformed data in the logs ({type(e).__name__}: {e})")
            continue
        if fig is not None:
            written += _save(fig, out, name)
    return written, warns


# ----------------------------------------------------------------- OMPL benchmark db

_RUN_COLUMNS = (  # OMPL's own run properties first, then ours
    ("time", "REAL"), ("memory", "REAL"), ("solved", "BOOLEAN"), ("status", "ENUM"),
    ("approximate_solution", "BOOLEAN"), ("correct_solution", "BOOLEAN"), ("solution_length", "REAL"),
    ("solution_segments", "INTEGER"), ("cpu_time", "REAL"), ("collision_checks", "INTEGER"),
    ("state_checks", "INTEGER"), ("motion_checks", "INTEGER"), ("pnet_calls", "INTEGER"),
    ("replans", "INTEGER"), ("fallback_used", "BOOLEAN"), ("seed", "INTEGER"), ("split", "VARCHAR(64)"),
    ("workspace_id", "VARCHAR(256)"), ("query_id", "VARCHAR(256)"), ("failure", "VARCHAR(256)"),
)

_SCHEMA = """
CREATE TABLE experiments
    (id INTEGER PRIMARY KEY AUTOINCREMENT, name VARCHAR(512),
    totaltime REAL, timelimit REAL, memorylimit REAL, runcount INTEGER,
    version VARCHAR(128), hostname VARCHAR(1024), cpuinfo TEXT,
    date DATETIME, seed VARCHAR(24), setup TEXT);
CREATE TABLE plannerConfigs
    (id INTEGER PRIMARY KEY AUTOINCREMENT,
    name VARCHAR(512) NOT NULL, settings TEXT);
CREATE TABLE enums
    (name VARCHAR(512), value INTEGER, description TEXT,
    PRIMARY KEY (name, value));
CREATE TABLE runs
    (id INTEGER PRIMARY KEY AUTOINCREMENT, experimentid INTEGER, plannerid INTEGER,
    FOREIGN KEY (experimentid) REFERENCES experiments(id) ON DELETE CASCADE,
    FOREIGN KEY (plannerid) REFERENCES plannerConfigs(id) ON DELETE CASCADE);
CREATE TABLE progress
    (runid INTEGER, time REAL, PRIMARY KEY (runid, time),
    FOREIGN KEY (runid) REFERENCES runs(id) ON DELETE CASCADE);
"""

_VIEWS = """
CREATE VIEW bestPlannerConfigsPerExperiment AS
SELECT plannerid, experimentid, MIN(avg_solved) AS avg_solved, avg_total_time FROM
  (SELECT plannerid, plannerName, experimentid, AVG(solved) AS avg_solved, AVG(total_time) AS avg_total_time
   FROM (SELECT plannerid, plannerConfigs.name AS plannerName, experimentid, solved, time AS total_time
         FROM plannerConfigs INNER JOIN experiments INNER JOIN runs
         ON plannerConfigs.id=runs.plannerid AND experiments.id=runs.experimentid)
   GROUP BY plannerid, experimentid)
GROUP BY plannerName, experimentid ORDER BY avg_solved DESC, avg_total_time ASC;
CREATE VIEW bestPlannerConfigs AS
SELECT plannerid, MIN(avg_solved) AS avg_solved, avg_total_time FROM
  (SELECT plannerid, plannerName, AVG(solved) AS avg_solved, AVG(total_time) AS avg_total_time
   FROM (SELECT plannerid, plannerConfigs.name AS plannerName, experimentid, solved, time AS total_time
         FROM plannerConfigs INNER JOIN experiments INNER JOIN runs
         ON plannerConfigs.id=runs.plannerid AND experiments.id=runs.experimentid)
   GROUP BY plannerid)
GROUP BY plannerName ORDER BY avg_solved DESC, avg_total_time ASC;
"""


def planner_settings(config) -> str:
    """The `planner:` section of a run's resolved config (YAML text), or all of it."""
    import yaml

    text = str(config or "")
    try:
        cfg = yaml.safe_load(text)
    except yaml.YAMLError:
        return text
    if isinstance(cfg, dict) and isinstance(cfg.get("planner"), dict):
        return yaml.safe_dump(cfg["planner"], sort_keys=False)
    return text


def ompl_status(success: pd.Series, failure: pd.Series) -> np.ndarray:
    """OMPL PlannerStatus values: exact solution for a success; timeout, invalid start,
    crash (an exception in the planner) or unknown (no solution, a path that failed the
    harness's re-check, ...) for a failure."""
    f = failure.fillna("").astype(str)
    st = np.full(len(f), ST_UNKNOWN)
    st[f.eq("timeout").to_numpy()] = ST_TIMEOUT
    st[f.eq("invalid_query").to_numpy()] = ST_INVALID_START
    st[f.isin(("error", "exception", "crash")).to_numpy()] = ST_CRASH
    st[success.to_numpy(bool)] = ST_EXACT
    return st


def _budget(config: str) -> float | None:
    m = re.search(r"^budget_s:\s*([0-9.eE+-]+)\s*$", str(config or ""), re.MULTILINE)
    try:
        return float(m.group(1)) if m else None
    except ValueError:
        return None


def _none(v):
    """NaN to None (NULL); numpy scalars to Python ones."""
    if v is None:
        return None
    if isinstance(v, float) and not math.isfinite(v):
        return None
    return v.item() if isinstance(v, np.generic) else v


def _path_len(v) -> int:
    return len(v) if isinstance(v, (list, tuple)) else 0


def write_benchmark_db(q: pd.DataFrame, files: list[TrialFile], path: Path) -> int:
    """OUT/benchmark.db in the schema of OMPL's benchmark statistics script, so Planner Arena
    opens it: one experiment per env x split, one planner config per (planner name, settings)
    as that script keys them (runs of one planner with other settings get their own), one run
    per query. Replaces any earlier file. Returns the number of runs written."""
    if path.exists():
        path.unlink()
    conn = sqlite3.connect(path)
    try:
        c = conn.cursor()
        c.execute("PRAGMA FOREIGN_KEYS = ON")
        c.executescript(_SCHEMA)
        for name, typ in _RUN_COLUMNS:
            c.execute(f"ALTER TABLE runs ADD {name} {typ}")
        c.executemany("INSERT INTO enums VALUES (?,?,?)", [("status", i, d) for i, d in enumerate(OMPL_STATUS)])
        configs = [(str(tf.run["planner"]), planner_settings(tf.run.get("config"))) for tf in files]
        config_ids = {}
        for p, settings in sorted(set(configs), key=lambda k: (planner_rank(k[0]), k[1])):
            c.execute("INSERT INTO plannerConfigs (name, settings) VALUES (?,?)", (f"geometric_{p}", settings))
            config_ids[(p, settings)] = c.lastrowid
        file_config = [config_ids[k] for k in configs]
        if q.empty:
            conn.commit()
            return 0
        n = 0
        order = _sort(q[["env", "split"]].drop_duplicates(), ("env", "split"))
        for env, split in zip(order["env"], order["split"]):
            d = q[(q["env"] == env) & (q["split"] == split)]
            fruns = [files[i].run for i in sorted(d["file"].unique())]
            ompl = sorted({str(r["versions"]["ompl"]) for r in fruns
                           if isinstance(r.get("versions"), dict) and r["versions"].get("ompl") is not None})
            logged_seed = np.array([run_seed(files[f].run) is not None for f in d["file"]], bool)
            budgets = {b for b in (_budget(r.get("config")) for r in fruns) if b is not None}
            started = sorted(str(r.get("started_at")) for r in fruns if r.get("started_at") is not None)
            hosts = sorted({str(r.get("host")) for r in fruns if r.get("host")})
            git = sorted({str(r.get("git_rev")) for r in fruns if r.get("git_rev")})
            c.execute("INSERT INTO experiments (name, totaltime, timelimit, memorylimit, runcount, version, hostname,"
                      " cpuinfo, date, seed, setup) VALUES (?,?,?,?,?,?,?,?,?,?,?)",
                      (f"{env} {split}", float(np.nansum(d["time_s"])), max(budgets) if budgets else None, 0.0,
                       int(d.groupby("planner").size().max()), "OMPL " + (",".join(ompl) or "unknown"),
                       ", ".join(hosts), None, started[0] if started else None,
                       ",".join(str(s) for s in sorted(d.loc[logged_seed, "seed"].unique())),
                       f"mpnet-bench trial logs: env {env}, split {split}, git {', '.join(git) or 'unknown'}"))
            exp_id = c.lastrowid
            ok = d["success"].to_numpy(bool)
            status = ompl_status(d["success"], d["failure"])
            plen = np.array([_path_len(files[f].queries[i].get("path")) for f, i in zip(d["file"], d["qidx"])], int)
            cols = {
                "time": d["time_s"], "memory": np.full(len(d), np.nan), "solved": ok.astype(int),
                "status": status, "approximate_solution": np.zeros(len(d), int), "correct_solution": ok.astype(int),
                "solution_length": d["path_cost"].where(ok),
                "solution_segments": np.where(ok & (plen > 0), np.maximum(plen - 1, 0), np.nan),
                "cpu_time": d["cpu_s"], "collision_checks": d["collision_checks"], "state_checks": d["state_checks"],
                "motion_checks": d["motion_checks"], "pnet_calls": d["pnet_calls"], "replans": d["replans"],
                "fallback_used": d["fallback_used"], "seed": d["seed"].where(logged_seed), "split": d["split"],
                "workspace_id": d["workspace_id"], "query_id": d["query_id"], "failure": d["failure"],
            }
            ints = {"solution_segments", "collision_checks", "state_checks", "motion_checks", "pnet_calls",
                    "replans", "fallback_used", "seed"}
            data = [[exp_id] * len(d), [file_config[f] for f in d["file"]]]
            for name, _ in _RUN_COLUMNS:
                v = np.asarray(cols[name], dtype=object)
                data.append([None if x is None or (isinstance(x, float) and not math.isfinite(x))
                             else (int(x) if name in ints else _none(x)) for x in v])
            names = ["experimentid", "plannerid"] + [n for n, _ in _RUN_COLUMNS]
            c.executemany(f"INSERT INTO runs ({','.join(names)}) VALUES ({','.join('?' * len(names))})",
                          list(zip(*data)))
            n += len(d)
        c.executescript(_VIEWS)
        conn.commit()
        return n
    finally:
        conn.close()


# ------------------------------------------------------------------------ the report

def scale_sizes(scale) -> tuple[int, ...] | None:
    """A config's `scale:` section as PAPER_SCALE's six sizes, None when any is missing."""
    try:
        sizes = (scale["train"]["workspaces"], scale["train"]["paths"], scale["test"]["seen"]["workspaces"],
                 scale["test"]["seen"]["queries"], scale["test"]["unseen"]["workspaces"],
                 scale["test"]["unseen"]["queries"])
    except (KeyError, TypeError, IndexError):
        return None
    return sizes if all(isinstance(v, int) and not isinstance(v, bool) for v in sizes) else None


def _smaller_net(scale) -> bool:
    try:
        hidden = scale["model"]["pnet_hidden"]
        return sum(int(h) for h in hidden) < sum(PAPER_PNET_HIDDEN)
    except (KeyError, TypeError, ValueError):
        return False


def scale_bullet(name: str, sizes: tuple[int, ...] | None, smaller_net: bool = False) -> str:
    """How a scale found in the logs compares with the paper's sizes, from the sizes its runs
    logged; from its name alone when they did not log them."""
    if sizes is None:
        if name == "unknown":
            return f"The logs do not say at which scale they ran; the paper: {PAPER_SCALE_TEXT}."
        return f"Scale `{name}`: the paper's sizes." if name == "paper" else \
            f"Scale `{name}`: smaller than the paper's."
    nets = "smaller networks " if smaller_net else ""
    if tuple(sizes) == PAPER_SCALE:
        return f"Our `{name}` scale has the paper's sizes ({PAPER_SCALE_TEXT})" + \
            (", with smaller networks." if smaller_net else ".")
    tw, tp, sw, sq, uw, uq = sizes
    return (f"Our `{name}` scale trains {nets}on {tw} workspaces × {tp} expert paths and tests on "
            f"{sw * sq} seen + {uw * uq} unseen queries per seed; the paper: {PAPER_SCALE_TEXT}.")


def provenance(files: list[TrialFile]) -> dict:
    """Where the logs came from, read from their /run messages: git revisions, hosts,
    dates, scales (with their sizes where logged), budgets and versions."""
    import yaml

    revs, hosts, scales, budgets, starts, scale_rows = set(), set(), set(), set(), [], set()
    versions: dict[str, set] = {}
    for f in files:
        r = f.run
        revs.add(str(r.get("git_rev", "unknown")))
        hosts.add(str(r.get("host", "unknown")))
        if r.get("started_at"):
            starts.append(str(r["started_at"]))
        vers = r.get("versions")
        for k, v in (vers.items() if isinstance(vers, dict) else ()):
            versions.setdefault(k, set()).add(str(v))
        try:
            cfg = yaml.safe_load(r.get("config") or "") or {}
        except yaml.YAMLError:
            cfg = {}
        scale = cfg.get("scale") if isinstance(cfg, dict) else None
        name = str(scale.get("name")) if isinstance(scale, dict) else "unknown"
        scales.add(name)
        scale_rows.add((name, scale_sizes(scale), _smaller_net(scale)))
        if isinstance(cfg, dict) and cfg.get("budget_s") is not None:
            budgets.add(str(cfg["budget_s"]))
    return {"git_rev": sorted(revs), "host": sorted(hosts), "scale": sorted(scales), "budget_s": sorted(budgets),
            "scales": sorted(scale_rows, key=lambda t: (t[0], t[1] or (), t[2])),
            "from": min(starts) if starts else "unknown", "to": max(starts) if starts else "unknown",
            "versions": {k: sorted(v) for k, v in sorted(versions.items())}}


def reference_notes(q: pd.DataFrame, files: list[TrialFile]) -> list[str]:
    """Per env with logged reference costs: the path cost metric and how the references were
    computed, from the logs (the workspace's robot, the runs' configs)."""
    out = []
    d = q[np.isfinite(q["reference_cost"])] if "reference_cost" in q else q.iloc[:0]
    for env in sorted(d["env"].unique(), key=env_rank):
        de = d[d["env"] == env]
        fidx = sorted(de["file"].unique())
        ws = next((w for i in fidx for w in files[int(i)].workspaces.values()), None)
        robot = ws.get("robot") if isinstance(ws, dict) else None
        kind = robot.get("kind") if isinstance(robot, dict) else None
        dims = len(ws.get("bounds") or []) if isinstance(ws, dict) else 0
        metric = {"point": "Euclidean length",
                  "rectangle": "OMPL's SE(2) metric, |Δxy| + 0.5·|Δθ| per segment (Δθ along the shorter arc)"
                  }.get(kind, "the env's path cost")
        if kind == "point" and dims == 2:
            ref = ("the exact shortest path (Dijkstra on the visibility graph of start, goal and the box corners); "
                   "it may touch obstacles, so it is a lower bound and quality >= 1")
        else:
            cfgs = [run_config(files[int(i)].run) for i in fidx]
            its = sorted({str(v) for v in (_cfg_get(c, "env", "expert", "iterations") for c in cfgs) if v is not None})
            bit = sorted({str(v) for v in (_cfg_get(c, "env", "reference", "bit_star_s") for c in cfgs)
                          if v is not None})
            ref = (f"the better of the expert's RRT* path ({'/'.join(its) or 'unknown'} iterations, "
                   f"`env.expert.iterations`) and BIT* run for {'/'.join(bit) or 'unknown'} s "
                   "(`env.reference.bit_star_s`), each shortened by lazy states contraction and kept only if it "
                   "passes the fine re-check; a planner can beat it (quality < 1)")
        if (de["split"] == "file").any():
            ref += "; queries of a problem file: its own `reference_cost` where given"
        out.append(f"{env} ({env_label(env)}): path cost = {metric}; reference = {ref}.")
    return out


def readme_text(n_files: int, n_queries: int, with_paper: bool, prov: dict | None = None,
                dirs: Iterable[str] = (), warnings: Iterable[str] = (), extra: dict | None = None) -> str:
    """OUT/README.md: where the logs came from, what went wrong reading them, what each
    output is, how its numbers are computed, and how they compare with the paper's. `extra`:
    which of quality, ablations, equal_quality were written, and reference_notes."""
    paper_rows = " (and the paper's rows)" if with_paper else ""
    extra = extra or {}
    refs = extra.get("reference_notes") or []
    ref_text = "\n".join(textwrap.fill(n, 95, initial_indent="  - ", subsequent_indent="    ")
                         for n in refs or ["no query in the logs has a reference cost."])
    files_extra = "".join(textwrap.fill(line, 95, subsequent_indent="  ") + "\n" for line in [
        "- `quality.md`, `quality.csv`: path quality per env × split × planner (ablations included): median "
        "and p90 of path cost / reference cost, and the median ratio to BIT*'s path cost on the same queries."
        if extra.get("quality") else
        "- `quality.*`: not written: the logs have no reference costs and no queries solved by BIT* and another "
        "planner.",
        "- `ablations.md`, `ablations.csv`: MPNet (NR) and (HR) against their ablations (success with its "
        "interval, median time with its interval, quality, cost / BIT*), with the not-significant marks."
        if extra.get("ablations") else "- `ablations.*`: not written: no ablation runs in the logs.",
        "- `equal_quality.md`, `equal_quality.csv`: time to equal quality: BIT* / Informed-RRT* run until their "
        "path cost is within a factor (1.0, 1.1) of MPNet (NR)'s on the same query, beside MPNet (NR)'s time."
        if extra.get("equal_quality") else
        "- `equal_quality.*`: not written: no time-to-equal-quality runs (`*_to_nr*`) in the logs."])
    prov = prov or provenance([])
    vers = ", ".join(f"{k} {'/'.join(v)}" for k, v in prov["versions"].items()) or "unknown"
    scale_text = "\n".join("- " + scale_bullet(*row) for row in prov.get("scales") or [("unknown", None, False)])
    warn_text = "\n".join(f"- {w.removeprefix('warning: ')}" for w in warnings) or "none"
    if extra.get("ablations") or extra.get("equal_quality"):
        regen = ("python -m harness -m +experiment=findings [scale=quick]   # Table I planners + NR ablations, 5 seeds\n"
                 "python -m harness -m +experiment=equal_quality            # time to equal quality\n"
                 "python -m harness.report multirun/<date>/<time> multirun/<date>/<time> --paper")
    else:
        regen = ("python -m harness -m +experiment=table1 [scale=quick]     # 4 envs x 4 planners x 5 seeds\n"
                 "python -m harness.report multirun/<date>/<time> --paper")
    return f"""# mpnet-bench report

Regenerated by `python -m harness.report {' '.join(map(str, dirs))}{' --paper' if with_paper else ''}`
from {n_files} trial logs ({n_queries} queries); do not edit by hand.

## Where the numbers come from

- Git revision of the runs: {', '.join(prov["git_rev"])}
- Machine: {', '.join(prov["host"])}
- Runs started between {prov["from"]} and {prov["to"]} (UTC)
- Scale: {', '.join(prov["scale"]) or "unknown"}; budget per query: {', '.join(prov["budget_s"]) or "unknown"} s
- Versions: {vers}

To regenerate them (the logs are not in git):

```bash
{regen}
```

## Warnings

What the report warned about (files skipped or partly read, files without queries, queries
logged in more than one file, figures left out):

{warn_text}

## Compared with the paper

- The paper's Informed-RRT* and BIT* (2D, 3D and rigid-body cases) were Python
  implementations; ours are OMPL's C++ planners, called with a Python collision checker.
  Their times, and so the BIT*/MPNet ratios, differ from the paper's by design: never read
  our ratios as a failure to reproduce, nor the paper's as ours.
- The paper timed MPNet on a machine with a GPU (i7 + GTX 1080); ours plan on the CPU of
  the machine above, Pnet as numpy matmuls on one thread.
{scale_text}
- A success here is a path that passed the harness's fine re-check (every 0.01 along the
  path, exact boxes); the paper does not say how its paths were checked.

## Files

- `results.csv`: one row per env × split × planner: queries, seeds, success, time, cost,
  collision checks, planner stats.
- `table1.md`, `table1.tex`, `table1.csv`: Table I, planning time mean ± std [s] per env × split
  and planner, and the BIT*/MPNet (NR) ratio{paper_rows}.
- `success_cost.md`, `success_cost.tex`, `success_cost.csv`: success rate [%] (mean ± std over
  seeds; pooled with its Wilson 95% interval) and mean path cost.
{files_extra}- `figures/`: `time_per_planner` (bars: mean; error bars: std, the lower one clipped at a tenth
  of the mean on the log axis), `success`, `time_boxplot`, `example_<env>`; PNG and SVG.
- `benchmark.db`: an OMPL benchmark database (one experiment per env × split, one run per
  query); open it in Planner Arena (plannerarena.org).

How the numbers are computed:

- The split of a row is each query's own `split`.
- `queries` counts every logged query of every seed; `seeds` is the number of distinct seeds.
  Files with the same env, planner and seed (e.g. a sweep run twice) all count: their queries
  are pooled into that seed (listed under Warnings when the same query is in several files).
  A file whose run logged no integer seed counts as a seed of its own.
- Success: mean ± std over seeds of each seed's success rate; the std is the sample std
  (ddof=1) with two seeds or more, 0 with one.
- Time (mean, std, median, p90): over the successful queries of all seeds pooled that logged a
  finite time; the std is the sample std (ddof=1), 0 for a single one.
- CPU time, path cost and collision checks: over all successful queries of all seeds pooled.
- `pnet_calls_median`, `replans_mean`, `fallback_rate`: over the queries that logged them.
- Which planners go where: results.csv has every planner but the time-to-equal-quality ones
  (`*_to_nr*`, whose success means "reached the target"; they are in `equal_quality.*`);
  Table I, `success_cost.*` and the figures leave out the ablations (`mpnet_nr_*`,
  `mpnet_hr_*`: `ablations.*`). Ablations: random = a uniformly random valid state instead of
  Pnet's proposal; straight = a fixed-length step toward the other tree's end; zeros = Pnet
  given a zero workspace code; nodropout = Pnet deterministic at planning time.
- Success intervals (`success_ci_low`/`_high`): Wilson score 95% interval (no continuity
  correction; scipy's `binomtest(k, n).proportion_ci(0.95, method="wilson")`) of the pooled
  `success_rate` = successes / queries over all seeds.
- Median time intervals (`time_median_ci_low`/`_high`): 95% percentile bootstrap interval over
  the pooled successful queries: {BOOT_N} resamples, numpy's generator seeded with {BOOT_SEED}
  and a CRC-32 of the row's key (so the report is reproducible and a row's interval does not
  depend on the other rows); each resample's median is drawn exactly from the order statistics
  of uniforms (the same distribution as resampling n times with replacement); the interval's
  ends are the 2.5% and 97.5% points of the inverted empirical CDF of the draws.
- Significance (`comparator`, `success_p_vs`, `success_diff_significant`, `time_ratio_vs`,
  `time_ratio_vs_ci_low`/`_high`, `time_diff_significant`): each planner against its
  comparator in the same env × split: the ablations of MPNet (HR) against MPNet (HR), MPNet
  (NR) against nothing, every other planner (MPNet (HR), its own NR ablations and the
  classical planners) against MPNet (NR). Success: two-sided Fisher exact test on the pooled
  counts, significant when p < 0.05. Median time: `time_ratio_vs` = this planner's median time
  / the comparator's, with the 95% percentile interval of the ratio of the two rows' bootstrap
  medians (resampled independently); significant when the interval excludes 1. A difference
  that is not significant is marked {APPROX} in the tables (Table I's times are means; their
  mark is the median-time test; BIT*/MPNet (NR) is marked when BIT*'s median-time interval
  against MPNet (NR) contains 1).
- What the intervals assume: every logged query (a query of one seed) is an independent
  trial. The seeds of one scale plan the same test queries, so with several seeds the
  intervals say how precisely these queries were measured, and understate how much the
  numbers would move on other queries; `scale=stats` (1000 distinct queries per split, one
  seed) is the setting where they mean the latter.
- Path quality (`quality_median`, `quality_p90` with linear interpolation, `quality_n`): path
  cost / the query's `reference_cost` over the successful queries that logged one (blank when
  none). `cost_over_bit_star_median` (`_n` pairs): the median, over the queries solved by both
  this planner and bit_star with the same env, split, seed and query id, of this planner's path
  cost / bit_star's (a query logged in several files of one seed: the mean of its costs);
  blank for bit_star and when there are no pairs. Path cost and references per env:
{ref_text}
- Time to equal quality (`equal_quality.*`): per env × split × algorithm × factor (the run
  config's `planner.cost_factor`). MPNet (NR) plans each query first, untimed; a query it
  fails has no target (`no_target`, left out). A targeted query is reached when it logged
  success with a path cost <= factor × `target_cost` (relative slack {REACH_RTOL:g}; a success
  above is counted as a miss, with a warning). Median time to reach: over all targeted queries,
  a miss counting as +inf (CSV `inf`, `censored` true; "> budget" in the Markdown); beside it
  the median over the reached ones and MPNet (NR)'s median `target_time_s` over the targeted
  ones, and the ratio of the first to the last, each with its bootstrap interval.
- Table I: the paper's four planners, the BIT*/MPNet (NR) ratio, then any other planner;
  "— (0/N)": the planner ran N queries there and solved none; blank: not run.
- `benchmark.db` status: exact solution for a success, timeout, invalid start (an invalid
  query), crash (an exception), unknown (no solution, or a path that failed the harness's
  re-check); `solved` and `correct_solution` are the harness's verdict, `solution_length`
  the path cost, `solution_segments` the path's points less one (NULL for a failure or an
  empty path), `memory` NULL (not measured). One planner config per planner name and
  settings (the run config's `planner:` section); each experiment's `version` is the OMPL
  version its own runs logged.

Paper numbers: {CITATION}.
"""


def write_report(dirs: Iterable[str | Path], out: str | Path = "reports", paper: bool = False) -> dict:
    """Read the trial logs under dirs and write every output into out. Returns a summary
    dict (files, skipped, warnings, queries, outputs); files == 0 or queries == 0 means nothing
    was written."""
    files, warns, skipped = load(dirs)
    summary = {"files": len(files), "skipped": skipped, "warnings": warns, "queries": 0, "outputs": []}
    if not files or not any(tf.queries for tf in files):
        return summary
    q = queries_frame(files)
    summary["queries"] = len(q)
    warns += duplicate_warnings(q, files)
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    res = results_table(q)
    res.to_csv(out / "results.csv", index=False)
    written = [out / "results.csv"]
    main_res = main_planners(res)
    paper_df = load_paper() if paper else None
    t, planners = table1(main_res, paper_df)
    t.to_csv(out / "table1.csv", index=False)
    md, tex = render_table1(t, planners, paper, main_res, paper_df)
    (out / "table1.md").write_text(md)
    (out / "table1.tex").write_text(tex)
    sc = success_cost(main_res)
    sc.to_csv(out / "success_cost.csv", index=False)
    md, tex = render_success_cost(sc, paper)
    (out / "success_cost.md").write_text(md)
    (out / "success_cost.tex").write_text(tex)
    written += [out / n for n in ("table1.md", "table1.tex", "table1.csv",
                                  "success_cost.md", "success_cost.tex", "success_cost.csv")]
    refs = reference_notes(q, files)
    eq, eq_warns = equal_quality_table(q, files)
    warns += eq_warns
    optional = {"quality": (quality_table(res), lambda d: render_quality(
                    d, refs or ["no query in these logs has a reference cost: the quality columns are blank."])),
                "ablations": (ablation_table(res), render_ablations),
                "equal_quality": (eq, render_equal_quality)}
    extra = {"reference_notes": refs}
    for name, (df, render) in optional.items():
        for ext in ("md", "csv", "tex"):  # an earlier report's table must not outlive its data
            (out / f"{name}.{ext}").unlink(missing_ok=True)
        extra[name] = not df.empty
        if df.empty:
            continue
        df.to_csv(out / f"{name}.csv", index=False)
        (out / f"{name}.md").write_text(render(df))
        written += [out / f"{name}.md", out / f"{name}.csv"]
    shown = set(main_res["planner"])
    summary["figures"], fig_warns = write_figures(main_res, q[q["planner"].isin(shown)], files, out / "figures")
    warns += fig_warns
    write_benchmark_db(q, files, out / "benchmark.db")
    (out / "README.md").write_text(readme_text(len(files), len(q), paper, provenance(files), dirs, warns, extra))
    summary["outputs"] = written + [out / "benchmark.db", out / "README.md"]
    return summary


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m harness.report",
                                 description="Table I, figures and an OMPL benchmark database from trial logs.")
    ap.add_argument("dirs", nargs="+", metavar="DIR", help="directories searched recursively for trials.mcap")
    ap.add_argument("--out", default="reports", help="output directory (default: reports/)")
    ap.add_argument("--paper", action="store_true", help="put the paper's Table I numbers beside ours")
    args = ap.parse_args(argv)
    try:
        s = write_report(args.dirs, args.out, args.paper)
    except OSError as e:
        print(f"error: cannot write the report to {args.out}: {e.strerror or e}", file=sys.stderr)
        return 1
    for w in s["warnings"]:
        print(w, file=sys.stderr)
    if not s["files"]:
        print(f"error: no readable trials.mcap under {', '.join(args.dirs)}", file=sys.stderr)
        return 1
    if not s["queries"]:
        print(f"error: no queries in the {s['files']} readable trials.mcap under {', '.join(args.dirs)}",
              file=sys.stderr)
        return 1
    out = Path(args.out)
    print(f"read {s['files']} trial logs ({s['queries']} queries), skipped {s['skipped']}")
    tables = "".join(f", {n}.{{md,csv}}" for n in ("quality", "ablations", "equal_quality")
                     if out / f"{n}.csv" in s["outputs"])
    print(f"wrote {out}/: results.csv, table1.{{md,tex,csv}}, success_cost.{{md,tex,csv}}{tables}, benchmark.db, "
          f"README.md, figures/ ({len(s['figures']) // 2} figures)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
