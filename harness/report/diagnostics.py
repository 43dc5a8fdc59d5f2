"""What Pnet proposed, per env × split × planner: the `diagnostics` of every MPNet /query
(mpnet.planners.diagnostics), pooled over seeds. Shares are over all proposals (in
collision, out of bounds, reachable from their tree end) or over the queries with a
first proposal (its validity and visibility); code sensitivity is the median shift of
Pnet's deterministic output when the workspace code is swapped for another workspace's,
beside the median spread of its dropout samples. Where the failures end: each failed query
(a valid one) by the step of Algorithm 1 it stopped at (`/query` `replans`, `fallback_used`,
`failure`, and the run's `planner.replan_rounds`)."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd

from harness.report.load import TrialFile
from harness.report.names import KEYS, env_rank, split_rank
from harness.report.render import _md_table

# failed valid queries, and where they stopped (failure_stage)
FAILS = ("failed", "fail_first_run", "fail_stuck", "fail_rounds", "fail_fallback", "fail_timeout")
COLUMNS = [
    *KEYS,
    "queries",
    "success",
    "proposals_per_query",
    "first_run_calls",
    "replan_calls",
    "in_collision",
    "out_of_bounds",
    "reachable",
    "first_valid",
    "first_visible_from_start",
    "first_visible_to_goal",
    "code_shift",
    "dropout_spread",
    *FAILS,
]


def failure_stage(query: dict, replan_rounds) -> str | None:
    """Where a failed MPNet query stopped (a FAILS name), None for a success or an invalid
    query: its clock ran out (`fail_timeout`); HR's classical planner did not complete the path
    (`fail_fallback`); the first NeuralPlanner run did not connect (`fail_first_run`); every
    replanning round ran and the path stayed infeasible (`fail_rounds`); or a replanned segment
    stayed unconnected in a round before (`fail_stuck`, the original replanning's end)."""
    if query.get("success") is not False or query.get("failure") == "invalid_query":
        return None
    if query.get("failure") == "timeout":
        return "fail_timeout"
    if query.get("fallback_used") is True:
        return "fail_fallback"
    replans = query.get("replans")
    if not replans:
        return "fail_first_run"
    if isinstance(replan_rounds, int) and replans >= replan_rounds:
        return "fail_rounds"
    return "fail_stuck"


def _num(v) -> float:
    return float(v) if isinstance(v, (int, float)) and not isinstance(v, bool) else math.nan


def diagnostics_table(files: list[TrialFile]) -> pd.DataFrame:
    """One row per (env, split, planner) whose queries carry diagnostics."""
    acc: dict[tuple, dict] = {}
    for tf in files:
        env, planner = str(tf.run["env"]), tf.planner  # with its label: labelled runs are never pooled
        rounds = (tf.run.get("settings") or {}).get("planner.replan_rounds")
        for m in tf.queries:
            d = m.get("diagnostics")
            if not isinstance(d, dict):
                continue
            a = acc.setdefault((env, str(m.get("split")), planner), {k: [] for k in COLUMNS[3:]})
            a["success"].append(m.get("success") is True)
            stage = failure_stage(m, rounds)
            if stage is not None:
                a["failed"].append(1)
                a[stage].append(1)
            for k in ("proposals", "proposals_first", "proposals_replan"):
                a.setdefault(k, []).append(_num(d.get(k)))
            for k in ("proposals_in_collision", "proposals_out_of_bounds", "proposals_reachable"):
                a.setdefault(k, []).append(_num(d.get(k, 0)))
            for k in ("first_valid", "first_visible_from_start", "first_visible_to_goal"):
                if isinstance(d.get(k), bool):
                    a[k].append(float(d[k]))
            for k in ("code_shift", "dropout_spread"):
                if _num(d.get(k)) == _num(d.get(k)):
                    a[k].append(_num(d[k]))
    rows = []
    for (env, split, planner), a in acc.items():
        n_prop = float(np.nansum(a["proposals"]))

        def share(k, a=a, n=n_prop):
            return float(np.nansum(a[k])) / n if n else math.nan

        def mean(v):
            return float(np.mean(v)) if v else math.nan

        def median(v):
            return float(np.median(v)) if v else math.nan

        rows.append(
            {
                "env": env,
                "split": split,
                "planner": planner,
                "queries": len(a["success"]),
                "success": mean(a["success"]),
                "proposals_per_query": float(np.nanmean(a["proposals"])),
                "first_run_calls": float(np.nanmean(a["proposals_first"])),
                "replan_calls": float(np.nanmean(a["proposals_replan"])),
                "in_collision": share("proposals_in_collision"),
                "out_of_bounds": share("proposals_out_of_bounds"),
                "reachable": share("proposals_reachable"),
                "first_valid": mean(a["first_valid"]),
                "first_visible_from_start": mean(a["first_visible_from_start"]),
                "first_visible_to_goal": mean(a["first_visible_to_goal"]),
                "code_shift": median(a["code_shift"]),
                "dropout_spread": median(a["dropout_spread"]),
                **{k: len(a[k]) for k in FAILS},
            }
        )
    if not rows:
        return pd.DataFrame(columns=COLUMNS)
    df = pd.DataFrame(rows, columns=COLUMNS)
    order = sorted(range(len(df)), key=lambda i: (env_rank(df.env[i]), split_rank(df.split[i]), df.planner[i]))
    return df.iloc[order].reset_index(drop=True)


def _pct(x) -> str:
    return "–" if x != x else f"{100 * x:.1f}%"


def _g(x) -> str:
    return "–" if x != x else f"{x:.3g}"


def render_diagnostics(df: pd.DataFrame, facts=None) -> str:
    """The table as Markdown; facts (harness.report.facts.Facts) marks the planners from a dirty tree."""
    head = [
        "env",
        "split",
        "planner",
        "queries",
        "success",
        "Pnet calls / query (first run + replanning)",
        "in collision",
        "out of bounds",
        "reachable from tree end",
        "first valid",
        "first visible from start",
        "goal visible from first",
        "code shift (median)",
        "dropout spread (median)",
    ]
    lines = [
        "# What Pnet proposed",
        "",
        "Every MPNet query logs its Pnet proposals (`/query` `diagnostics.trace`: stage, the tree end it grew from,"
        " the proposal); these figures are computed from them with an exact checker (no margin), after the query's"
        " time. Shares of all proposals: in collision (an invalid state: inside an obstacle or out of bounds; out of"
        " bounds also on its own), reachable (a free straight motion from the tree end that produced it). The first"
        " proposal (from the start): valid, visible from the start, the goal visible from it (shares of queries)."
        " Code shift: how far Pnet's deterministic output at (start, goal) moves when the workspace code is swapped"
        " for another workspace's; dropout spread: the median distance of its dropout samples from that output (a"
        " code shift below the spread means Pnet barely uses the workspace). Distances in the env's metric.",
        "",
    ]
    rows = []
    for r in df.itertuples(index=False):
        calls = f"{r.proposals_per_query:.1f} ({r.first_run_calls:.1f} + {r.replan_calls:.1f})"
        rows.append(
            [
                r.env,
                r.split,
                r.planner + (facts.mark(r.planner) if facts is not None else ""),
                str(r.queries),
                _pct(r.success),
                calls,
                _pct(r.in_collision),
                _pct(r.out_of_bounds),
                _pct(r.reachable),
                _pct(r.first_valid),
                _pct(r.first_visible_from_start),
                _pct(r.first_visible_to_goal),
                _g(r.code_shift),
                _g(r.dropout_spread),
            ]
        )
    return "\n".join([*lines, _md_table(head, rows), *render_failures(df, facts)]) + "\n"


def render_failures(df: pd.DataFrame, facts=None) -> list[str]:
    """The failures' table (diagnostics_table's FAILS columns) as Markdown lines."""
    head = [
        "env",
        "split",
        "planner",
        "failed",
        "first run did not connect",
        "a replanned segment stayed unconnected",
        "every replanning round ran, path still infeasible",
        "HR's classical planner did not complete it",
        "timed out",
    ]
    lines = [
        "",
        "## Where the failures end",
        "",
        "Each failed valid query by the step of Algorithm 1 it stopped at (`/query` `replans`, `fallback_used`,"
        " `failure`; the run's `planner.replan_rounds`). NeuralPlanner appends Pnet's proposals without checking"
        " the steps between them (only the step that joins the two trees is checked), so a first run that"
        " connects can still be infeasible: neural replanning then drops the colliding states and reconnects"
        " each gap with a short NeuralPlanner run, round after round. The original replanning (the public"
        " code's) fails a query whose gap stays unconnected; HR hands such a path to its classical planner.",
        "",
    ]
    rows = []
    for r in df.itertuples(index=False):
        name = r.planner + (facts.mark(r.planner) if facts is not None else "")
        rows.append([r.env, r.split, name, str(r.failed), *(_of(getattr(r, k), r.failed) for k in FAILS[1:])])
    return [*lines, _md_table(head, rows)]


def _of(v: int, n: int) -> str:
    """A count and its share of n (the count alone when n is 0)."""
    return f"{v} ({100 * v / n:.0f}%)" if n else str(v)
