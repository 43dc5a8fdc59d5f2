"""The tables as frames: results.csv, Table I, success/cost, quality, ablations, time to equal quality."""

from __future__ import annotations

import math
from collections.abc import Iterable

import numpy as np
import pandas as pd

from harness.report.facts import budget_of, cfg_get, finite_number, run_config
from harness.report.load import TrialFile
from harness.report.names import (
    ABLATION_BASES,
    ABLATIONS,
    ALPHA,
    KEYS,
    PAPER_PLANNERS,
    RATIO_COL,
    REACH_RTOL,
    RESULT_COLS,
    ablation_of,
    comparator_of,
    env_rank,
    equal_quality_of,
    planner_rank,
    sort_rows,
    split_rank,
)
from harness.report.stats import (
    bit_star_pairs,
    boot_interval,
    boot_medians,
    equal_quality_planners,
    excludes_one,
    fisher_p,
    sample_std,
    wilson,
)


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
    res["success_std"] = sample_std(per_seed)
    solved = q[q["success"]]
    t = solved[np.isfinite(solved["time_s"])].groupby(KEYS, sort=False)["time_s"]
    res["time_mean_s"] = t.mean()
    res["time_std_s"] = sample_std(t)
    res["time_median_s"] = t.median()
    res["time_p90_s"] = t.quantile(0.9)
    by = solved.groupby(KEYS, sort=False)
    res["cpu_mean_s"] = by["cpu_s"].mean()
    res["cost_mean"] = by["path_cost"].mean()
    ref = solved["reference_cost"]
    has_ref = np.isfinite(solved["path_cost"]) & np.isfinite(ref) & (ref > 0)
    qual = (
        solved.loc[has_ref, KEYS]
        .assign(quality=(solved["path_cost"] / ref)[has_ref])
        .groupby(KEYS, sort=False)["quality"]
    )
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
            lambda s: "; ".join(f"{k[-1]}: {v}" for k, v in sorted(s.items(), key=lambda kv: (-kv[1], kv[0][-1])))
        )
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
    return sort_rows(res[RESULT_COLS])


def _compare(res: pd.DataFrame, keys: list[tuple], draws: dict) -> None:
    """Each row against its comparator (comparator_of) in the same env x split, in place:
    success by Fisher's exact test, median time by the bootstrap interval of the ratio of
    medians (the two rows resampled independently); significant at ALPHA."""
    row = {k: i for i, k in enumerate(keys)}
    out = {
        c: [None] * len(keys)
        for c in (
            "comparator",
            "success_p_vs",
            "success_diff_significant",
            "time_ratio_vs",
            "time_ratio_vs_ci_low",
            "time_ratio_vs_ci_high",
            "time_diff_significant",
        )
    }
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
        res[c] = pd.Series(
            v,
            index=res.index,
            dtype=object if c in ("comparator", "success_diff_significant", "time_diff_significant") else float,
        )


def duplicate_warnings(q: pd.DataFrame, files: list[TrialFile]) -> list[str]:
    """One line per (env, planner, seed) with queries (same split, workspace and query id)
    logged in more than one file: they all count, as documented, but it is seldom meant
    (e.g. a sweep run twice into different directories)."""
    key = ["env", "planner", "seed", "split", "workspace_id", "query_id"]
    per_file = q[key + ["file"]].drop_duplicates()
    d = per_file[per_file.duplicated(key, keep=False)]
    out = []
    groups = sorted(
        d.groupby(["env", "planner", "seed"], sort=False),
        key=lambda kv: (env_rank(kv[0][0]), planner_rank(kv[0][1]), kv[0][2]),
    )
    for (env, planner, seed), g in groups:
        n = len(g.drop_duplicates(key))
        names = ", ".join(str(files[i].path) for i in sorted(g["file"].unique()))
        out.append(
            f"warning: {env} {planner} seed {seed}: {n} queries logged in more than one file, all counted: {names}"
        )
    return out


def _planner_columns(planners: Iterable[str]) -> list[str]:
    """Table I's columns: the paper's four planners always, then any other logged planner."""
    extra = sorted(set(planners) - set(PAPER_PLANNERS), key=planner_rank)
    return list(PAPER_PLANNERS) + extra


def _time_cols(planners: Iterable[str]) -> list[str]:
    return [f"{p}_{s}" for p in planners for s in ("time_mean_s", "time_std_s")]


def table1(res: pd.DataFrame, paper: pd.DataFrame | None = None) -> tuple[pd.DataFrame, list[str]]:
    """Table I as numbers: rows env x split (x source: ours, then the paper's where asked),
    `<planner>_time_mean_s` / `_time_std_s` per planner column, the paper's four planners
    first, then the BIT*/NR ratio, then any other planner (so the paper's layout comes first)."""
    planners = _planner_columns(res["planner"] if len(res) else [])
    sources = [("ours", res)] + ([("paper", paper)] if paper is not None else [])
    vals = {
        (src, e, s, p): (m, sd)
        for src, df in sources
        for e, s, p, m, sd in zip(df["env"], df["split"], df["planner"], df["time_mean_s"], df["time_std_s"])
    }
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
    cols = [
        "env",
        "split",
        "planner",
        "success_mean_pct",
        "success_std_pct",
        "success_rate_pct",
        "success_ci_low_pct",
        "success_ci_high_pct",
        "comparator",
        "success_p_vs",
        "success_diff_significant",
        "cost_mean",
        "queries",
        "seeds",
    ]
    if res.empty:
        return pd.DataFrame(columns=cols)
    out = res[
        [
            "env",
            "split",
            "planner",
            "comparator",
            "success_p_vs",
            "success_diff_significant",
            "cost_mean",
            "queries",
            "seeds",
        ]
    ].copy()
    out["success_mean_pct"] = 100.0 * res["success_mean"]
    out["success_std_pct"] = 100.0 * res["success_std"]
    for c in ("success_rate", "success_ci_low", "success_ci_high"):
        out[c + "_pct"] = 100.0 * res[c]
    return out[cols]


QUALITY_COLS = [
    "env",
    "split",
    "planner",
    "successes",
    "quality_n",
    "quality_median",
    "quality_p90",
    "cost_over_bit_star_n",
    "cost_over_bit_star_median",
]


def quality_table(res: pd.DataFrame) -> pd.DataFrame:
    """quality.csv: per env x split x planner (ablations included), path quality (path cost /
    the query's reference cost: median, p90, n) and the median ratio to BIT*'s path cost on
    the same queries; empty when the logs have neither (no reference cost, no BIT* pairs)."""
    if res.empty or not (res["quality_n"].sum() > 0 or res["cost_over_bit_star_n"].sum() > 0):
        return pd.DataFrame(columns=QUALITY_COLS)
    return res[QUALITY_COLS].reset_index(drop=True)


ABLATION_COLS = [
    "env",
    "split",
    "planner",
    "base",
    "variant",
    "change",
    "queries",
    "successes",
    "success_rate",
    "success_ci_low",
    "success_ci_high",
    "success_p_vs",
    "success_diff_significant",
    "time_median_s",
    "time_median_ci_low",
    "time_median_ci_high",
    "time_ratio_vs",
    "time_ratio_vs_ci_low",
    "time_ratio_vs_ci_high",
    "time_diff_significant",
    "quality_n",
    "quality_median",
    "cost_over_bit_star_n",
    "cost_over_bit_star_median",
]
_VS_COLS = [
    "success_p_vs",
    "success_diff_significant",
    "time_ratio_vs",
    "time_ratio_vs_ci_low",
    "time_ratio_vs_ci_high",
    "time_diff_significant",
]


def ablation_table(res: pd.DataFrame) -> pd.DataFrame:
    """ablations.csv: per env x split, each base (mpnet_nr, mpnet_hr) that has an ablation there,
    then its ablations; an ablation's comparisons are against its base (results.csv's), the
    base row has none. Empty without ablations."""
    if res.empty:
        return pd.DataFrame(columns=ABLATION_COLS)
    rows = []
    for _, d in sort_rows(res, ("env", "split")).groupby(["env", "split"], sort=False):
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


EQ_COLS = [
    "env",
    "split",
    "planner",
    "algorithm",
    "factor",
    "target_planner",
    "queries",
    "no_target",
    "targeted",
    "reached",
    "reach_rate",
    "reach_ci_low",
    "reach_ci_high",
    "time_to_reach_median_s",
    "time_to_reach_ci_low",
    "time_to_reach_ci_high",
    "censored",
    "time_reached_median_s",
    "time_reached_ci_low",
    "time_reached_ci_high",
    "target_time_median_s",
    "target_time_ci_low",
    "target_time_ci_high",
    "time_ratio",
    "time_ratio_ci_low",
    "time_ratio_ci_high",
    "time_ratio_significant",
    "budget_s",
]


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
        factor = finite_number(cfg_get(cfg, "planner", "cost_factor")) or (eq[2] if eq and eq[2] else 1.0)
        alg = eq[0] if eq else str(cfg_get(cfg, "planner", "algorithm") or name)
        target = ("mpnet_" + eq[1]) if eq else None
        meta[f] = (alg, factor, target, budget_of(run.get("config")))
    d["algorithm"] = [meta[f][0] for f in d["file"]]
    d["factor"] = [meta[f][1] for f in d["file"]]
    d["budget_s"] = [meta[f][3] for f in d["file"]]
    d["target_planner"] = [
        t if t is not None else meta[f][2] or "unknown" for t, f in zip(d["target_planner"], d["file"])
    ]
    tgt = d["target_cost"]
    d["targeted"] = np.isfinite(tgt) & (tgt > 0)
    above = d["success"] & d["targeted"] & (d["path_cost"] > d["factor"] * tgt * (1 + REACH_RTOL))
    d["reached"] = d["success"] & d["targeted"] & ~above
    warns = []
    for planner, n in d[above].groupby("planner").size().items():
        warns.append(
            f"warning: {planner}: {n} of its logged successes have a path cost above factor x target "
            "cost: counted as not reaching the target"
        )
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
        rows.append(
            {
                "env": env,
                "split": split,
                "planner": ", ".join(sorted(g["planner"].unique(), key=planner_rank)),
                "algorithm": alg,
                "factor": factor,
                "target_planner": ", ".join(targets),
                "queries": len(g),
                "no_target": int((~g["targeted"]).sum()),
                "targeted": n,
                "reached": k,
                "reach_rate": k / n if n else math.nan,
                "reach_ci_low": ci[0],
                "reach_ci_high": ci[1],
                "time_to_reach_median_s": m_all,
                **dict(zip(("time_to_reach_ci_low", "time_to_reach_ci_high"), boot_interval(b_all))),
                "censored": bool(np.isinf(m_all)) if len(all_t) else None,
                "time_reached_median_s": float(np.median(reached_t)) if len(reached_t) else math.nan,
                **dict(zip(("time_reached_ci_low", "time_reached_ci_high"), boot_interval(b_reached))),
                "target_time_median_s": m_nr,
                **dict(zip(("target_time_ci_low", "target_time_ci_high"), boot_interval(b_nr))),
                "time_ratio": ratio,
                "time_ratio_ci_low": rlo,
                "time_ratio_ci_high": rhi,
                "time_ratio_significant": excludes_one(rlo, rhi),
                "budget_s": max(budgets) if budgets else math.nan,
            }
        )
    out = pd.DataFrame(rows, columns=EQ_COLS)
    if out.empty:
        return out, warns
    out["_alg"] = [planner_rank(a) for a in out["algorithm"]]
    order = sorted(
        range(len(out)),
        key=lambda i: (
            env_rank(out["env"].iat[i]),
            split_rank(out["split"].iat[i]),
            out["_alg"].iat[i],
            out["factor"].iat[i],
        ),
    )
    return out.iloc[order].drop(columns="_alg").reset_index(drop=True), warns
