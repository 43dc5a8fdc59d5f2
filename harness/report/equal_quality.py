"""equal_quality.csv: how long a classical planner takes to reach MPNet's path cost on the same query
(time to equal quality), from the runs whose config gives a `planner.cost_target`."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd

from harness.report.facts import Facts, logged_facts, run_facts
from harness.report.load import TrialFile
from harness.report.names import env_rank, labelled, split_rank
from harness.report.stats import boot_interval, boot_medians, excludes_one, wilson
from harness.report.tables import equal_quality_planners

# A logged success of a time-to-equal-quality run counts as reaching the target only with a
# path cost <= factor x target cost, up to this relative slack (float noise in the two cost sums).
REACH_RTOL = 1e-6

EQ_COLS = [
    "env",
    "split",
    "planner",
    "label",
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


def equal_quality_table(q: pd.DataFrame, files: list[TrialFile], facts: Facts) -> tuple[pd.DataFrame, list[str]]:
    """equal_quality.csv: per env x split x (algorithm, factor) x label (`--label NAME=DIR`, the target
    planner of that label's runs) of the time-to-equal-quality runs, and warning lines. A query is
    targeted when its target planner's cost (`target_cost`) was logged; it is reached when it logged
    success with a path cost <= factor x target cost (a success above that is a miss, with a warning).
    The median time to reach is over all targeted queries, a miss counting as +inf (censored: the median
    is a miss, beyond the budget); beside it the median over the reached ones, the target planner's
    median time (`target_time_s`) over the targeted queries, and the ratio of the two medians.
    Algorithm, factor and target come from each run's config (facts.py)."""
    eqp = equal_quality_planners(q, facts)
    d = q[q["planner"].isin(eqp)].copy()
    if d.empty:
        return pd.DataFrame(columns=EQ_COLS), []
    meta = {}
    for f in sorted(d["file"].unique()):
        tf = files[int(f)]
        eq = (run_facts(tf.run) or facts.of(tf.planner)).equal_quality
        if eq is not None:
            alg, target, factor = eq[0], "mpnet_" + eq[1], eq[2]
        else:  # no cost target in its config, but its queries log a target planner
            pf = run_facts(tf.run)
            alg, target, factor = str((pf and pf.algorithm) or tf.run["planner"]), None, 1.0
        meta[f] = (alg, factor, target, logged_facts(tf.run)["budget_s"], tf.label or "")
    d["algorithm"] = [meta[f][0] for f in d["file"]]
    d["factor"] = [meta[f][1] for f in d["file"]]
    d["budget_s"] = [meta[f][3] for f in d["file"]]
    d["label"] = [meta[f][4] for f in d["file"]]
    d["target_planner"] = [  # the target of a labelled run: its own label's
        labelled(t if t is not None else meta[f][2] or "unknown", meta[f][4] or None)
        for t, f in zip(d["target_planner"], d["file"])
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
    group = ["env", "split", "algorithm", "factor", "label"]
    for key, g in d.groupby(group, sort=False):
        env, split, alg, factor, label = key
        unknown = labelled("unknown", label or None)
        targets = sorted(set(g["target_planner"]) - {unknown}) or [unknown]
        t = g[g["targeted"]]
        k, n = int(t["reached"].sum()), len(t)
        ci = wilson(k, n)
        tag = (env, split, alg, factor) + ((label,) if label else ())
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
                "planner": ", ".join(sorted(g["planner"].unique(), key=facts.rank)),
                "label": label,  # "" for unlabelled runs
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
    out["_alg"] = [facts.rank(a) for a in out["algorithm"]]
    order = sorted(
        range(len(out)),
        key=lambda i: (
            env_rank(out["env"].iat[i]),
            split_rank(out["split"].iat[i]),
            out["_alg"].iat[i],
            out["factor"].iat[i],
            out["label"].iat[i],
        ),
    )
    return out.iloc[order].drop(columns="_alg").reset_index(drop=True), warns
