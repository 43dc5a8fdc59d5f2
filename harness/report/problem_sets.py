"""problem_sets.md: solved / valid / total per problem set of a problem-file run (the
MotionBenchMaker scenes: workspace ids `box_panda/0001` form the set `box_panda`), the way
VAMP counts them: a query whose start or goal is invalid for our robot model
(`invalid_query`) is not valid, a solved one passed the fine re-check."""

from __future__ import annotations

import pandas as pd

from harness.report.facts import Facts
from harness.report.names import env_rank
from harness.report.own_data import own_table
from harness.report.render import _md_table, _pct, fmt_g
from harness.report.stats import wilson

COLS = [
    "env",
    "problem_set",
    "planner",
    "total",
    "valid",
    "solved",
    "solved_rate",
    "solved_ci_low",
    "solved_ci_high",
    "time_median_s",
    "time_p90_s",
    "timeouts",
    "timeout_cpu_share",
]


# Published figures beside a report's problem sets, by the sets' name suffix (data: published.yaml)
PUBLISHED = own_table("published")


def problem_set_table(q: pd.DataFrame, facts: Facts) -> pd.DataFrame:
    """One row per env x problem set x planner, all seeds together; empty without problem sets."""
    f = q[(q["split"] == "file") & q["workspace_id"].astype(str).str.contains("/", regex=False)].copy()
    if f.empty:
        return pd.DataFrame(columns=COLS)
    f["problem_set"] = f["workspace_id"].astype(str).str.rsplit("/", n=1).str[0]
    rows = []
    for (env, pset, planner), g in f.groupby(["env", "problem_set", "planner"], sort=False):
        valid = g[g["failure"] != "invalid_query"]
        solved = valid[valid["success"].astype(bool)]
        lo, hi = wilson(len(solved), len(valid)) if len(valid) else (float("nan"), float("nan"))
        t = solved["time_s"].astype(float)
        out = g[g["failure"] == "timeout"]
        rows.append(
            {
                "env": env,
                "problem_set": pset,
                "planner": planner,
                "total": len(g),
                "valid": len(valid),
                "solved": len(solved),
                "solved_rate": len(solved) / len(valid) if len(valid) else float("nan"),
                "solved_ci_low": lo,
                "solved_ci_high": hi,
                "time_median_s": float(t.median()) if len(t) else float("nan"),
                "time_p90_s": float(t.quantile(0.9)) if len(t) else float("nan"),
                "timeouts": len(out),
                "timeout_cpu_share": float(out["cpu_s"].sum() / out["time_s"].sum()) if len(out) else float("nan"),
            }
        )
    df = pd.DataFrame(rows, columns=COLS)
    key = [(env_rank(r["env"]), r["problem_set"], facts.rank(r["planner"])) for r in df.to_dict("records")]
    return df.iloc[sorted(range(len(df)), key=key.__getitem__)].reset_index(drop=True)


def render_problem_sets(df: pd.DataFrame, facts: Facts) -> str:
    head = ["Env", "Problem set", "Planner", "Solved / valid / total", "Solved [%] [95% CI]", "Median [s]", "p90 [s]"]
    head.append("Timed out (CPU)")
    rows = [
        [
            r["env"],
            r["problem_set"],
            facts.label(r["planner"]),
            f"{r['solved']} / {r['valid']} / {r['total']}",
            f"{_pct(r['solved_rate'])} [{_pct(r['solved_ci_low'])}, {_pct(r['solved_ci_high'])}]",
            fmt_g(r["time_median_s"]),
            fmt_g(r["time_p90_s"]),
            f"{r['timeouts']} ({_pct(r['timeout_cpu_share'])})" if r["timeouts"] else "0",
        ]
        for r in df.to_dict("records")
    ]
    note = (
        "Problem sets are the workspace-id prefixes of problem-file runs (MotionBenchMaker's scenes, e.g. "
        f"`{df['problem_set'].iloc[0]}`). Valid: start and goal are valid for our robot model (the others are logged "
        "`invalid_query`, as VAMP counts them); solved: the path passed the fine re-check. Times are over the "
        "solved queries, all seeds together; the success interval is Wilson's 95%. Timed out: queries that ran out "
        "of budget, with the share of a CPU they got (below 90%: a loaded machine, the rate a lower bound)."
    )
    sets = df["problem_set"].astype(str)
    shown = [p for suffix, p in PUBLISHED.items() if sets.str.endswith(suffix).any()]
    note += "".join(f" {p['robot']}" for p in shown)
    text = f"# Problem sets\n\n{_md_table(head, rows)}\n\n{note}\n"
    for p in shown:
        published = _md_table(["Planner", "Solved / valid / total", "Time", "Source"], [list(f) for f in p["figures"]])
        per_set = "neither publishes per-set figures" if len(p["figures"]) > 1 else "no per-set figures are published"
        text += (
            f"\n## {p['title']}\n\n"
            f"{published}\n\nPooled over the seven sets ({per_set}); other machines, "
            "other collision models: for orientation, not a comparison on equal terms.\n"
        )
    return text
