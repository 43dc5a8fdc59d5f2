"""The report's tables as frames: results.csv (one row per env x split x planner, with its intervals and
its test against the comparator), Table I, success and cost, path quality and the MPNet ablations."""

from __future__ import annotations

import math
from collections.abc import Iterable
from importlib import resources

import numpy as np
import pandas as pd

from harness.report.facts import Facts
from harness.report.names import KEYS, PAPER_PLANNERS, RATIO_COL, describe_variant, env_rank, labelled, split_rank
from harness.report.stats import (
    ALPHA,
    bit_star_pairs,
    boot_interval,
    boot_medians,
    excludes_one,
    fisher_p,
    std_or_zero,
    wilson,
)

# A row's test against its comparator (Facts.comparator); an ablation's against its base.
_VS_COLS = [
    "success_p_vs",
    "success_diff_significant",
    "time_ratio_vs",
    "time_ratio_vs_ci_low",
    "time_ratio_vs_ci_high",
    "time_diff_significant",
]
COMPARISON_COLS = ["comparator", *_VS_COLS]

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
    "plan_median_s",
    "plan_p90_s",
    "cpu_mean_s",
    "cpu_share",
    "timeouts",
    "timeout_cpu_share",
    "cost_mean",
    "quality_n",
    "quality_median",
    "quality_p90",
    "cost_over_bit_star_n",
    "cost_over_bit_star_median",
    "collision_checks_median",
    "configurations_checked_median",
    "encode_s_median",
    "pnet_s_median",
    "fallback_s_median",
    "pnet_calls_median",
    "replans_mean",
    "fallback_rate",
    *COMPARISON_COLS,
    "failures",
]


LOADED = 0.9  # a run whose timed-out queries got less CPU than this share of their time is flagged


THREADED = 1.1  # a row whose queries used more CPU than this share of their time ran a second thread


def loaded_warnings(res: pd.DataFrame) -> list[str]:
    """One line per row whose queries waited for a CPU (cpu_share under LOADED: their times
    include the waiting), whose timed-out queries got less than LOADED of a CPU (a lower bound
    on its success), or whose queries ran more than one thread (cpu_share over THREADED)."""
    waited = [
        f"warning: {r.env} {r.split} {r.planner}: its queries got {r.cpu_share:.0%} of a CPU (< {LOADED:.0%}): "
        "they waited for the CPU (a loaded machine), so their times are longer than the planner's work"
        for r in res[res["cpu_share"] < LOADED].itertuples()
    ]
    threaded = [
        f"warning: {r.env} {r.split} {r.planner}: its queries used {r.cpu_share:.0%} of a CPU: more than one "
        "thread, so its times are not one core's (a run before harness.core.threads, or a pool it did not limit)"
        for r in res[res["cpu_share"] > THREADED].itertuples()
    ]
    timeouts = [
        f"warning: {r.env} {r.split} {r.planner}: its {r.timeouts} timed-out queries got "
        f"{r.timeout_cpu_share:.0%} of a CPU (< {LOADED:.0%}): the machine was loaded, so its success "
        "rate is a lower bound"
        for r in res[res["timeout_cpu_share"] < LOADED].itertuples()
    ]
    return waited + threaded + timeouts


def equal_quality_planners(q: pd.DataFrame, facts: Facts) -> set[str]:
    """Planners that ran to a cost target (time to equal quality): their config has a
    `planner.cost_target`, or their queries log a `target_planner`. Their success means "reached
    the target", so they have a table of their own, never rows of results.csv."""
    out = {p for p in q["planner"].unique() if facts.equal_quality(str(p)) is not None}
    if "target_planner" in q:
        out |= set(q.loc[q["target_planner"].notna(), "planner"].unique())
    return out


def results_table(q: pd.DataFrame, facts: Facts) -> pd.DataFrame:
    """results.csv: one row per env x split x planner (see the package docstring); the
    time-to-equal-quality planners are left out (equal_quality_table)."""
    q = q[~q["planner"].isin(equal_quality_planners(q, facts))]
    if q.empty:
        return pd.DataFrame(columns=RESULT_COLS)
    g = q.groupby(KEYS, sort=False)
    res = pd.DataFrame({"queries": g.size(), "seeds": g["seed"].nunique(), "successes": g["success"].sum()})
    per_seed = q.groupby(KEYS + ["seed"], sort=False)["success"].mean().groupby(level=KEYS, sort=False)
    res["success_mean"] = per_seed.mean()
    res["success_std"] = std_or_zero(per_seed)
    solved = q[q["success"]]
    t = solved[np.isfinite(solved["time_s"])].groupby(KEYS, sort=False)["time_s"]
    res["time_mean_s"] = t.mean()
    res["time_std_s"] = std_or_zero(t)
    res["time_median_s"] = t.median()
    res["time_p90_s"] = t.quantile(0.9)
    plan = solved[np.isfinite(solved["plan_s"])].groupby(KEYS, sort=False)["plan_s"]
    res["plan_median_s"] = plan.median()
    res["plan_p90_s"] = plan.quantile(0.9)
    by = solved.groupby(KEYS, sort=False)
    res["cpu_mean_s"] = by["cpu_s"].mean()
    # How much of a CPU the planned queries got (CPU time over wall time, pooled): well under
    # one, they waited for the CPU; over one, a second thread ran.
    planned = q[q["time_s"] > 0].groupby(KEYS, sort=False)
    res["cpu_share"] = planned["cpu_s"].sum() / planned["time_s"].sum()
    # How much of a CPU the timed-out queries got: on a loaded machine a planner that ran out
    # of time got less than its budget of computing, and its success rate is a lower bound.
    out_of_time = q[q["failure"] == "timeout"].groupby(KEYS, sort=False)
    res["timeouts"] = out_of_time.size()
    res["timeout_cpu_share"] = out_of_time["cpu_s"].sum() / out_of_time["time_s"].sum()
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
    # Checkers that sample motions (the arm) count the configurations they evaluated; MPNet logs
    # where a query's time goes (the cloud and Enet, Pnet, HR's classical planner; the rest is checks).
    for c in ("configurations_checked", "encode_s", "pnet_s", "fallback_s"):
        res[f"{c}_median"] = by[c].median()
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
    for c in ("queries", "seeds", "successes", "timeouts", "quality_n", "cost_over_bit_star_n"):
        res[c] = res[c].fillna(0).astype(int)
    res["success_rate"] = res["successes"] / res["queries"]
    keys = list(zip(res["env"], res["split"], res["planner"]))
    ci = [wilson(k, n) for k, n in zip(res["successes"], res["queries"])]
    res["success_ci_low"], res["success_ci_high"] = [c[0] for c in ci], [c[1] for c in ci]
    ci = [boot_interval(draws.get(k)) for k in keys]
    res["time_median_ci_low"], res["time_median_ci_high"] = [c[0] for c in ci], [c[1] for c in ci]
    _compare(res, keys, draws, facts)
    return facts.sort(res[RESULT_COLS])


def _compare(res: pd.DataFrame, keys: list[tuple], draws: dict, facts: Facts) -> None:
    """Each row against its comparator (Facts.comparator) in the same env x split, in place:
    success by Fisher's exact test, median time by the bootstrap interval of the ratio of
    medians (the two rows resampled independently); significant at ALPHA."""
    row = {k: i for i, k in enumerate(keys)}
    out = {c: [None] * len(keys) for c in COMPARISON_COLS}
    k_, n_, med = res["successes"].tolist(), res["queries"].tolist(), res["time_median_s"].tolist()
    for i, (env, split, planner) in enumerate(keys):
        c = facts.comparator(planner)
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


def table1_layout(planners: Iterable[str], facts: Facts, with_paper: bool = False) -> list[tuple[str, str | None]]:
    """Table I's columns in order, as ("time", planner) and ("ratio", label) items: the paper's four
    planners and the BIT*/MPNet (NR) ratio (always, unless every planner logged is a labelled one
    and the paper's rows are not asked for), then every other unlabelled planner; then, per label
    (`--label NAME=DIR`, by name), its planners in the same order, with its own ratio after its
    paper planners when it has both BIT* and MPNet (NR)."""
    by_label: dict[str | None, list[str]] = {}
    for p in sorted(set(planners), key=facts.rank):
        by_label.setdefault(facts.tag(p)[1], []).append(p)
    out: list[tuple[str, str | None]] = []
    plain = by_label.pop(None, [])
    if plain or with_paper or not by_label:
        out += [("time", p) for p in PAPER_PLANNERS] + [("ratio", None)]
        out += [("time", p) for p in plain if p not in PAPER_PLANNERS]
    for label in sorted(by_label):
        shown = by_label[label]
        main = [p for p in shown if facts.tag(p)[0] in PAPER_PLANNERS]
        out += [("time", p) for p in main]
        if {labelled(b, label) for b in ("bit_star", "mpnet_nr")} <= set(main):
            out.append(("ratio", label))
        out += [("time", p) for p in shown if p not in main]
    return out


def ratio_col(label: str | None) -> str:
    """table1.csv's column of BIT*'s mean time over MPNet (NR)'s (of one label's runs)."""
    return labelled(RATIO_COL, label)


def load_paper() -> pd.DataFrame:
    """The paper's Table I (harness/report/paper_table1.csv: env, split, planner, time_mean_s, time_std_s),
    with the times also as printed (`time_mean_text`, `time_std_text`): the tables show the
    paper's numbers exactly as given, never reformatted."""
    with resources.files("harness.report").joinpath("paper_table1.csv").open("r") as f:
        df = pd.read_csv(f, dtype=str, keep_default_na=False)
    for c, text in (("time_mean_s", "time_mean_text"), ("time_std_s", "time_std_text")):
        df[text] = df[c].str.strip()
        df[c] = pd.to_numeric(df[text], errors="coerce").astype(float)
    return df


def _time_cols(planners: Iterable[str]) -> list[str]:
    return [f"{p}_{s}" for p in planners for s in ("time_mean_s", "time_std_s")]


def table1(
    res: pd.DataFrame, facts: Facts, paper: pd.DataFrame | None = None
) -> tuple[pd.DataFrame, list[tuple[str, str | None]]]:
    """Table I as numbers, and its columns (table1_layout): rows env x split (x source: ours, then
    the paper's where asked), `<planner>_time_mean_s` / `_time_std_s` per planner column and the
    BIT*/NR ratio of mean times (`bit_star_over_mpnet_nr`, `... [label]` within a label's runs)."""
    layout = table1_layout(res["planner"] if len(res) else [], facts, paper is not None)
    planners = [k for what, k in layout if what == "time"]
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
            for what, label in layout:
                if what == "ratio":
                    bit, nr = (row[f"{labelled(b, label)}_time_mean_s"] for b in ("bit_star", "mpnet_nr"))
                    row[ratio_col(label)] = bit / nr if nr else math.nan
            rows.append(row)
    cols = ["env", "split", "source"]
    for what, k in layout:
        cols += _time_cols([k]) if what == "time" else [ratio_col(k)]
    return pd.DataFrame(rows, columns=cols).reset_index(drop=True), layout


def main_planners(res: pd.DataFrame, facts: Facts) -> pd.DataFrame:
    """The rows of Table I, success_cost and the figures: every planner but the ablations."""
    return res[[facts.ablation(str(p)) is None for p in res["planner"]]].reset_index(drop=True)


def success_cost(res: pd.DataFrame) -> pd.DataFrame:
    """Success rate (mean and std over seeds, %; the pooled rate with its Wilson interval, %;
    the test against the comparator) and mean path cost per env x split x planner."""
    pct = ["success_mean_pct", "success_std_pct", "success_rate_pct", "success_ci_low_pct", "success_ci_high_pct"]
    kept = ["comparator", "success_p_vs", "success_diff_significant", "cost_mean", "queries", "seeds"]
    cols = [*KEYS, *pct, *kept]
    if res.empty:
        return pd.DataFrame(columns=cols)
    out = res[[*KEYS, *kept]].copy()
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


def ablation_table(res: pd.DataFrame, facts: Facts) -> pd.DataFrame:
    """ablations.csv: per env x split, each base (mpnet_nr, mpnet_hr) that has an ablation there,
    then its ablations; an ablation's comparisons are against its base (results.csv's), the
    base row has none. Empty without ablations."""
    if res.empty:
        return pd.DataFrame(columns=ABLATION_COLS)
    rows = []
    for _, d in facts.sort(res, ("env", "split")).groupby(["env", "split"], sort=False):
        by = {p: r for p, r in zip(d["planner"], d.to_dict("records"))}
        bases = sorted({ab[0] for ab in map(facts.ablation, by) if ab}, key=facts.rank)
        for base in bases:
            # a labelled run of its own recipe is its own base (mpnet_nr [bounded]): one row, not two
            abl = sorted((p for p in by if p != base and (facts.ablation(p) or ("",))[0] == base), key=facts.rank)
            if not abl and base not in by:
                continue
            for p in ([base] if base in by else []) + abl:
                r = dict(by[p])
                variant = facts.ablation(p)[1] if p != base else ""
                r.update(base=base, variant=variant, change=describe_variant(variant) if variant else "")
                if p == base:
                    r.update({c: None for c in _VS_COLS})
                rows.append(r)
    return pd.DataFrame(rows, columns=ABLATION_COLS)
