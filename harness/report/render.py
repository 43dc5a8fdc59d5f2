"""Writing the tables as text: number formats, Markdown and booktabs LaTeX tables, and the Markdown /
LaTeX of Table I, success and cost, path quality, the ablations and time to equal quality."""

from __future__ import annotations

import math
import re

import numpy as np
import pandas as pd

from harness.report.facts import Facts
from harness.report.names import APPROX, CITATION, PAPER, RATIO_LABEL, env_label, labelled
from harness.report.stats import BOOT_N
from harness.report.tables import ratio_col

ROW_KEY = ("Env", "Split", "Planner")  # the first columns of every table a row per planner


def _decimals(x: float, digits: int = 3) -> int:
    """Decimals that show `digits` significant digits of x (0 for large x)."""
    return max(0, digits - 1 - math.floor(math.log10(abs(x)))) if x else digits - 1


def fmt_g(x, digits: int = 3) -> str:
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


def _tex_table(
    header: list[str], rows: list[list[str]], groups: list, caption: str, notes: list[str], n_text: int = 2
) -> str:
    """A booktabs table, its first n_text columns left-aligned, the rest right; `groups` gives
    each row's group so a \\midrule separates groups."""
    spec = "l" * n_text + "r" * (len(header) - n_text)
    out = [
        r"\begin{table}[t]",
        r"\centering",
        r"\caption{" + caption + "}",
        r"\begin{tabular}{" + spec + "}",
        r"\toprule",
        " & ".join(header) + r" \\",
        r"\midrule",
    ]
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


def _checks_table(t: pd.DataFrame, planners: list[str], res: pd.DataFrame | None, facts: Facts) -> str:
    """Table I's rows with each planner's median collision checks a solved query (results.csv's
    collision_checks_median; where a checker counts them, the configurations its certified
    motions evaluated, in parentheses): the work, which another machine does the same."""
    if res is None or "collision_checks_median" not in res:
        return ""
    found = {(e, s, p): r for e, s, p, r in zip(res["env"], res["split"], res["planner"], res.to_dict("records"))}

    def cell(key) -> str:
        r = found.get(key)
        if r is None:
            return ""
        text = fmt_g(r["collision_checks_median"])
        conf = r.get("configurations_checked_median")
        return text + (f" ({fmt_g(conf)})" if text and conf is not None and np.isfinite(conf) else "")

    rows, prev = [], None
    for r in t.to_dict("records"):
        if r["source"] != "ours" or (r["env"], r["split"]) == prev:
            continue
        prev = (r["env"], r["split"])
        rows.append([env_label(r["env"]), r["split"]] + [cell((r["env"], r["split"], p)) for p in planners])
    if not rows:
        return ""
    return (
        "\n## Collision checks a solved query\n\n"
        + _md_table(["Env", "Split"] + [facts.label(p) for p in planners], rows)
        + "\n\nMedian over the solved queries of state and motion checks (results.csv: "
        "collision_checks_median); in parentheses, where the checker counts them, the configurations "
        "its certified motions evaluated (configurations_checked_median). Unlike the times above, the "
        "same queries need the same checks on any machine.\n"
    )


def render_table1(
    t: pd.DataFrame,
    layout: list[tuple[str, str | None]],
    with_paper: bool,
    facts: Facts,
    res: pd.DataFrame | None = None,
    paper: pd.DataFrame | None = None,
) -> tuple[str, str]:
    """Table I as (Markdown, LaTeX), columns as table1's layout gives them (the paper's planners,
    the ratio, the others; then each label's). A planner of res that ran but has no time to show
    reads "— (successes/queries)" rather than blank, which is kept for a planner not run; the
    paper's rows are its numbers as printed (load_paper's text columns)."""
    counts = (
        {}
        if res is None
        else {
            (e, s, p): (int(k), int(n))
            for e, s, p, k, n in zip(res["env"], res["split"], res["planner"], res["successes"], res["queries"])
        }
    )
    same_time = (
        set()
        if res is None or "time_diff_significant" not in res
        else {
            (e, s, p)
            for e, s, p, sig in zip(res["env"], res["split"], res["planner"], res["time_diff_significant"])
            if _is_false(sig)
        }
    )
    printed = (
        {}
        if paper is None or "time_mean_text" not in paper
        else {
            (e, s, p): (m, sd)
            for e, s, p, m, sd in zip(
                paper["env"], paper["split"], paper["planner"], paper["time_mean_text"], paper["time_std_text"]
            )
        }
    )
    head = (
        ["Env", "Split"]
        + (["Source"] if with_paper else [])
        + [facts.label(k) if what == "time" else labelled(RATIO_LABEL, k) for what, k in layout]
    )

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

    def ratio_cell(r: dict, label: str | None, tex: bool) -> str:
        text = fmt_g(r[ratio_col(label)])
        if text and r["source"] == "ours" and (r["env"], r["split"], labelled("bit_star", label)) in same_time:
            return (r"$\approx$ " if tex else APPROX + " ") + text
        return text

    def cells(r: dict, tex: bool) -> list[str]:
        sep, dash = (r" $\pm$ ", "---") if tex else (" ± ", "—")
        return [cell(r, k, sep, dash) if what == "time" else ratio_cell(r, k, tex) for what, k in layout]

    md_rows, tex_rows, groups = [], [], []
    prev = None
    for r in t.to_dict("records"):  # not itertuples: a labelled planner's columns are no identifiers
        first = (r["env"], r["split"]) != prev
        prev = (r["env"], r["split"])
        lead = [env_label(r["env"]) if first else "", r["split"] if first else ""]
        src = [r["source"]] if with_paper else []
        md_rows.append(lead + src + cells(r, False))
        tex_rows.append([_tex_escape(x) for x in lead + src] + cells(r, True))
        groups.append(r["env"])
    what = (
        "Planning time in seconds, mean ± std over the successful queries of all seeds; "
        f"{RATIO_LABEL}: ratio of mean times. — (0/N): the planner ran N queries here and solved none "
        "(— (k/N): k solved, none with a logged time); blank: the planner was not run."
    )
    mark = (
        f"{APPROX} before a time: that planner's median time does not differ significantly (5%) from MPNet "
        f"(NR)'s in the same row (the 95% bootstrap interval of the ratio of median times contains 1); "
        f"{APPROX} before {RATIO_LABEL}: the same for BIT* against MPNet (NR). The test is on median times "
        "(results.csv: time_ratio_vs, time_diff_significant); the cells show means."
    )
    which = (
        "Times are time_s: each query timed as if it were the first in its workspace, MPNet's point-cloud "
        "sampling and encoding included (the paper-like time). results.csv also has plan_median_s / "
        "plan_p90_s: plan_s, the time given the workspace's code (time_s less the cloud and Enet), as a "
        "robot that encodes its scene once and then plans many queries would see it."
    )
    clock = (
        "The clock: MPNet's planning loop and RRT-Connect (compiled) call the collision kernels directly, "
        "compiled; OMPL's planners (BIT*, Informed-RRT*, RRT*, RRT-Connect, and MPNet (HR)'s RRT*) call back "
        "into Python for every state and motion they check. What that crossing costs per check, env by env: "
        "`python -m harness.perf`'s section 'The price of a check'."
    )
    notes = [f"Layout of Table I of {CITATION}.", mark, which, clock]
    if any(k and (what == "ratio" or facts.tag(k)[1]) for what, k in layout):
        notes.append(
            f"Columns marked [NAME] are the runs given as `--label NAME=DIR`; {RATIO_LABEL} [NAME], where "
            "shown, is the ratio of that label's BIT* and MPNet (NR) mean times, and ≈ compares a labelled "
            "planner with MPNet (NR) of the same label."
        )
    if with_paper:
        notes.append(
            "Rows 'paper' are the paper's own numbers as printed; their BIT*/MPNet (NR) is the ratio of "
            "the paper's mean times, computed here. Our baselines are OMPL's C++ planners, so ratios "
            "are expected to differ."
        )
    md = (
        "# Table I: planning time [s]\n\n"
        + _md_table(head, md_rows)
        + "\n\n"
        + what
        + "\n\n"
        + "\n".join(f"Note: {n}" for n in notes)
        + "\n"
        + _checks_table(t, [k for what, k in layout if what == "time"], res, facts)
    )
    tex = _tex_table(
        [_tex_escape(h) for h in head],
        tex_rows,
        groups,
        r"Planning time [s], mean $\pm$ std over successful queries; "
        + _tex_escape(RATIO_LABEL)
        + r": ratio of mean times. --- (0/$N$): ran $N$ queries, solved none; blank: not run.",
        [_tex_escape(n) for n in notes],
        3 if with_paper else 2,
    )
    return md, tex


def _ci(lo, hi, fmt=None) -> str:
    """'[lo, hi]' (3 significant digits, or fmt), +inf as ∞; blank when missing."""
    fmt = fmt or fmt_g
    if (
        lo is None
        or hi is None
        or (isinstance(lo, float) and math.isnan(lo))
        or (isinstance(hi, float) and math.isnan(hi))
    ):
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
    return (
        f"{APPROX}: the planner's {what} does not differ significantly (5%) from its comparator's in the same "
        "env and split: MPNet (NR) for every planner but MPNet (NR) itself (not marked) and the MPNet (HR) "
        f"ablations, which are compared with MPNet (HR); {test}."
    )


def render_success_cost(sc: pd.DataFrame, with_paper: bool, facts: Facts) -> tuple[str, str]:
    """The success / path cost table as (Markdown, LaTeX)."""
    head = [*ROW_KEY, "Success [%]", "Pooled [%] [95% CI]", "Path cost", "Queries", "Seeds"]
    md_rows, tex_rows, groups = [], [], []
    prev = None
    for r in sc.itertuples(index=False):
        first = (r.env, r.split) != prev
        prev = (r.env, r.split)
        lead = [env_label(r.env) if first else "", r.split if first else ""]
        same = _is_false(r.success_diff_significant)
        succ = (APPROX + " " if same else "") + _pm(r.success_mean_pct, r.success_std_pct, 1)
        pooled = _with_ci(fmt_g1(r.success_rate_pct), r.success_ci_low_pct, r.success_ci_high_pct, fmt_g1)
        rest = [facts.label(r.planner), succ, pooled, fmt_g(r.cost_mean), str(r.queries), str(r.seeds)]
        md_rows.append(lead + rest)
        tex_rows.append(
            [_tex_escape(x) for x in lead + rest[:1]]
            + [(r"$\approx$ " if same else "") + _pm(r.success_mean_pct, r.success_std_pct, 1, sep=r" $\pm$ ")]
            + rest[2:]
        )
        groups.append(r.env)
    what = (
        "Success: mean ± std over seeds of the per-seed success rate (std: ddof=1 with two seeds or "
        "more, else 0). Pooled: successes / queries of all seeds, with its Wilson score 95% interval. "
        "Path cost: mean over successful queries."
    )
    notes = [
        _comparator_note(
            "success rate",
            "two-sided Fisher exact test on the pooled successes / queries, p >= 0.05 (results.csv: success_p_vs)",
        )
    ]
    if with_paper:
        notes.append(f"The paper reports MPNet (NR) succeeding about 97% and MPNet (HR) 100% of the time ({PAPER}).")
    md = (
        "# Success rate and path cost\n\n"
        + _md_table(head, md_rows)
        + "\n\n"
        + what
        + "\n"
        + "".join(f"\nNote: {n}\n" for n in notes)
    )
    tex = _tex_table(
        [_tex_escape(h) for h in head],
        tex_rows,
        groups,
        r"Success rate [\%], mean $\pm$ std over seeds and pooled with its Wilson 95\% interval, "
        r"and mean path cost of successful queries.",
        [_tex_escape(n) for n in notes],
        3,
    )
    return md, tex


def fmt_g1(x) -> str:
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


def render_quality(qt: pd.DataFrame, notes: list[str], facts: Facts) -> str:
    """quality.md."""
    head = [*ROW_KEY, "Quality median", "Quality p90", "n", "Cost / BIT* median", "Pairs"]
    rows = _group_rows(
        qt,
        lambda r: [
            facts.label(r["planner"]),
            fmt_g(r["quality_median"]),
            fmt_g(r["quality_p90"]),
            str(int(r["quality_n"])),
            fmt_g(r["cost_over_bit_star_median"]),
            str(int(r["cost_over_bit_star_n"])),
        ],
    )
    what = (
        "Quality: path cost / the query's reference cost, over the successful queries of all seeds that have a "
        "reference (n); median and 90th percentile (linear interpolation). Cost / BIT*: median over the "
        "queries solved by both this planner and BIT* (paired on env, split, seed and query id; Pairs) of "
        "this planner's path cost / BIT*'s (BIT*'s first solution in the Table I runs)."
    )
    return f"# Path quality\n\n{_md_table(head, rows)}\n\n{what}\n" + "".join(f"\nNote: {n}\n" for n in notes)


def _against_base(r, value: str, ci: str, test: str, fmt=None) -> str:
    """An ablation's cell: its value, the 95% interval in r's `{ci}_ci_low/high`, marked the
    same as its base's where r's `{test}_diff_significant` is false."""
    return _with_ci(value, r[f"{ci}_ci_low"], r[f"{ci}_ci_high"], fmt, _is_false(r[f"{test}_diff_significant"]))


def render_ablations(ab: pd.DataFrame, facts: Facts) -> str:
    """ablations.md."""
    head = [*ROW_KEY, "Change", "Success [%] [95% CI]", "Median time [s] [95% CI]", "Time / base [95% CI]"]
    head += ["Quality median", "Cost / BIT* median"]

    def cells(r):
        return [
            facts.label(r["planner"]),
            r["change"] or "(base)",
            _against_base(r, _pct(r["success_rate"]), "success", "success", _pct),
            _against_base(r, fmt_g(r["time_median_s"]), "time_median", "time"),
            _with_ci(fmt_g(r["time_ratio_vs"]), r["time_ratio_vs_ci_low"], r["time_ratio_vs_ci_high"]),
            fmt_g(r["quality_median"]),
            fmt_g(r["cost_over_bit_star_median"]),
        ]

    what = (
        "Each ablation is its base planner (MPNet (NR) or MPNet (HR), the row above it marked (base)) with one "
        "piece changed. Success: successes / queries of all seeds with the Wilson score 95% interval. Median "
        f"time: over the successful queries of all seeds, with a 95% bootstrap interval ({BOOT_N} resamples). "
        "Time / base: ratio of median times, with the 95% bootstrap interval of the ratio. Quality and Cost / "
        "BIT*: as in quality.md."
    )
    note = (
        f"{APPROX}: the ablation's success rate (Fisher exact test, two-sided, p >= 0.05) or median time (the "
        "interval of Time / base contains 1) does not differ significantly from its base's."
    )
    return f"# MPNet ablations\n\n{_md_table(head, _group_rows(ab, cells))}\n\n{what}\n\nNote: {note}\n"


def _budget_text(b) -> str:
    return f"> budget ({fmt_g(b)} s)" if b is not None and np.isfinite(b) else "> budget"


def render_equal_quality(eq: pd.DataFrame, facts: Facts) -> str:
    """equal_quality.md."""
    head = [*ROW_KEY, "Stops at", "No target", "Targeted", "Reached [%] [95% CI]"]
    head += ["Median time to reach, all targeted [s] [95% CI]", "Median time, reached only [s] [95% CI]"]
    head += ["Target planner's median time [s] [95% CI]", "Ratio [95% CI]"]

    def cells(r):
        target = ", ".join(facts.label(t) for t in str(r["target_planner"]).split(", "))
        if _is_true(r["censored"]):
            to_reach = _budget_text(r["budget_s"]) + (
                f" {_ci(r['time_to_reach_ci_low'], r['time_to_reach_ci_high'])}"
                if not math.isnan(r["time_to_reach_ci_low"])
                else ""
            )
            nr = r["target_time_median_s"]
            ratio = f"> {fmt_g(r['budget_s'] / nr)}" if np.isfinite(r["budget_s"]) and nr > 0 else "∞"
            ratio = (APPROX + " " if _is_false(r["time_ratio_significant"]) else "") + ratio
        else:
            to_reach = _with_ci(
                fmt_g(r["time_to_reach_median_s"]), r["time_to_reach_ci_low"], r["time_to_reach_ci_high"]
            )
            ratio = _with_ci(
                fmt_g(r["time_ratio"]),
                r["time_ratio_ci_low"],
                r["time_ratio_ci_high"],
                None,
                _is_false(r["time_ratio_significant"]),
            )
        return [
            facts.label(labelled(r["algorithm"], r["label"] or None)),
            f"cost ≤ {r['factor']:g} × {target}'s",
            str(r["no_target"]),
            str(r["targeted"]),
            _with_ci(_pct(r["reach_rate"]), r["reach_ci_low"], r["reach_ci_high"], _pct),
            to_reach,
            _with_ci(fmt_g(r["time_reached_median_s"]), r["time_reached_ci_low"], r["time_reached_ci_high"]),
            _with_ci(fmt_g(r["target_time_median_s"]), r["target_time_ci_low"], r["target_time_ci_high"]),
            ratio,
        ]

    what = (
        "Time to equal quality: on each query the target planner (MPNet (NR)) plans first, untimed; the "
        "classical planner then runs until its path cost is at most the factor × the target's verified path "
        "cost, within the budget. No target: queries the target planner failed (logged `no_target`, left out "
        "of every other column). Targeted: the other queries. Reached: targeted queries whose run logged "
        "success with a path cost within the target, with the Wilson score 95% interval. Median time to "
        "reach: over all targeted queries, a miss counting as +∞; '> budget': at least half of them were "
        "missed, so the median lies beyond the budget. Reached only: over the reached queries. Target "
        "planner's median time: its `target_time_s` over the targeted queries. Ratio: median time to reach "
        f"(all targeted) / the target planner's median time. Intervals: 95% bootstrap ({BOOT_N} resamples; "
        "the ratio's two medians resampled independently)."
    )
    note = f"{APPROX} before a ratio: its interval contains 1 (the two median times do not differ significantly)."
    return f"# Time to equal quality\n\n{_md_table(head, _group_rows(eq, cells))}\n\n{what}\n\nNote: {note}\n"
