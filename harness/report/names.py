"""Names, orders, labels and fixed numbers the tables and figures share."""

from __future__ import annotations

import re
from importlib import resources

import pandas as pd

from harness.report.facts import facts_of

ENV_ORDER = ("s2d", "c2d", "c3d", "rigid")
ENV_LABELS = {"s2d": "Simple 2D", "c2d": "Complex 2D", "c3d": "Complex 3D", "rigid": "Rigid body"}
SPLIT_ORDER = ("seen", "unseen")
PAPER_PLANNERS = ("mpnet_nr", "mpnet_hr", "informed_rrt_star", "bit_star")
KNOWN_EXTRAS = ("rrt_star", "rrt_connect")
PLANNER_LABELS = {
    "mpnet_nr": "MPNet (NR)",
    "mpnet_hr": "MPNet (HR)",
    "informed_rrt_star": "Informed-RRT*",
    "bit_star": "BIT*",
    "rrt_star": "RRT*",
    "rrt_connect": "RRT-Connect",
}
PLANNER_COLORS = {
    "mpnet_nr": "#1f77b4",
    "mpnet_hr": "#17becf",
    "informed_rrt_star": "#d62728",
    "bit_star": "#ff7f0e",
    "rrt_star": "#9467bd",
    "rrt_connect": "#2ca02c",
}
RATIO_COL = "bit_star_over_mpnet_nr"
RATIO_LABEL = "BIT*/MPNet (NR)"
PAPER = 'Qureshi, Simeonov, Bency, Yip, "Motion Planning Networks", ICRA 2019, arXiv:1806.05767'
CITATION = (
    PAPER + ", Table I; their Informed-RRT* and BIT* were Python implementations, MPNet's times are "
    "CPU time on an i7 with a GTX 1080"
)
# The paper's sizes: train workspaces x expert paths, then seen and unseen test workspaces x
# queries per workspace; and its Pnet's hidden layers (to tell a smaller network).
PAPER_SCALE = (100, 4000, 100, 200, 10, 2000)
PAPER_SCALE_TEXT = "100 × 4000 paths; 100 × 200 seen, 10 × 2000 unseen"
PAPER_PNET_HIDDEN = (1280, 1024, 896, 768, 512, 384, 256, 256, 128, 64, 32)
QUERY_COLS = (
    "query_id",
    "workspace_id",
    "split",
    "success",
    "failure",
    "time_s",
    "cpu_s",
    "path_cost",
    "collision_checks",
    "state_checks",
    "motion_checks",
    "pnet_calls",
    "replans",
    "fallback_used",
    "reference_cost",
    "target_planner",
    "target_cost",
    "target_time_s",
)
KEYS = ["env", "split", "planner"]
RESULT_COLS = KEYS + [
    "queries",
    "seeds",
    "successes",
    "success_mean",
    "success_std",
    "success_rate",
    "success_ci_low",
    "success_ci_high",
    "time_mean_s",
    "time_std_s",
    "time_median_s",
    "time_median_ci_low",
    "time_median_ci_high",
    "time_p90_s",
    "cpu_mean_s",
    "cost_mean",
    "quality_n",
    "quality_median",
    "quality_p90",
    "cost_over_bit_star_n",
    "cost_over_bit_star_median",
    "collision_checks_median",
    "pnet_calls_median",
    "replans_mean",
    "fallback_rate",
    "comparator",
    "success_p_vs",
    "success_diff_significant",
    "time_ratio_vs",
    "time_ratio_vs_ci_low",
    "time_ratio_vs_ci_high",
    "time_diff_significant",
    "failures",
]

# Ablations of MPNet: `<base>_<variant>`, each logged under its own planner name.
ABLATION_BASES = ("mpnet_nr", "mpnet_hr")
ABLATIONS = {
    "random": "a uniformly random valid state instead of Pnet's proposal",
    "straight": "a fixed-length step toward the other tree's end instead of Pnet's proposal",
    "zeros": "Pnet given a zero workspace code",
    "nodropout": "Pnet deterministic (no dropout) at planning time",
}
# Time to equal quality: `<algorithm>_to_<target>[_x<factor>]`, e.g. bit_star_to_nr_x1.1.
# Statistics: 95% intervals; bootstrap resamples and their fixed seed (the report is reproducible).
ALPHA = 0.05
BOOT_N = 10_000
BOOT_SEED = 20190521
APPROX = "≈"
# A logged success of a time-to-equal-quality run counts as reaching the target only with a
# path cost <= factor x target cost, up to this relative slack (float noise in the two cost sums).
REACH_RTOL = 1e-6

# OMPL's PlannerStatus, in the order its Benchmark writes the `status` enum.
OMPL_STATUS = (
    "Unknown status",
    "Invalid start",
    "Invalid goal",
    "Unrecognized goal type",
    "Timeout",
    "Approximate solution",
    "Exact solution",
    "Crash",
    "Abort",
    "Infeasible",
)
ST_UNKNOWN, ST_INVALID_START, ST_TIMEOUT, ST_EXACT, ST_CRASH = 0, 1, 4, 6, 7


def env_rank(env: str) -> tuple:
    return (ENV_ORDER.index(env), "") if env in ENV_ORDER else (len(ENV_ORDER), env)


def split_rank(split: str) -> tuple:
    return (SPLIT_ORDER.index(split), "") if split in SPLIT_ORDER else (len(SPLIT_ORDER), split)


def ablation_of(planner: str) -> tuple[str, str] | None:
    """(base, variant) of an MPNet ablation (from its run's config), else None."""
    return facts_of(planner).ablation


def equal_quality_of(planner: str) -> tuple[str, str, float | None] | None:
    """(algorithm, target, factor) of a time-to-equal-quality planner (from its run's
    config; factor None for 1), else None."""
    return facts_of(planner).equal_quality


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


def sort_rows(df: pd.DataFrame, cols=("env", "split", "planner")) -> pd.DataFrame:
    rank = {"env": env_rank, "split": split_rank, "planner": planner_rank}
    if df.empty:
        return df
    order = sorted(range(len(df)), key=lambda i: tuple(rank[c](df[c].iat[i]) for c in cols))
    return df.iloc[order].reset_index(drop=True)


def natural_key(s: str) -> tuple:
    """'ws10-2' after 'ws9-3': digit runs compare as numbers (types line up by position)."""
    parts = re.split(r"(\d+)", str(s))
    return tuple(int(p) if i % 2 else p for i, p in enumerate(parts))


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
