"""OUT/README.md: where the logs came from (their /run messages), what the report warned about, what each
output is, how its numbers are computed and how they compare with the paper's."""

from __future__ import annotations

import re
import textwrap
from collections.abc import Iterable
from pathlib import Path

import numpy as np
import pandas as pd

from harness.log import painter_for, run_segments
from harness.report.commands import sweep_commands
from harness.report.equal_quality import REACH_RTOL
from harness.report.facts import logged_facts
from harness.report.load import TrialFile
from harness.report.names import APPROX, CITATION, PAPER_PNET_HIDDEN, PAPER_SCALE, PAPER_SCALE_TEXT, env_label, env_rank
from harness.report.stats import BOOT_N, BOOT_SEED
from mpnet.envs.specs import SPECS
from mpnet.settings import EXPERT


def scale_sizes(scale) -> tuple[int, ...] | None:
    """A config's `scale:` section as PAPER_SCALE's six sizes, None when any is missing."""
    try:
        sizes = (
            scale["train"]["workspaces"],
            scale["train"]["paths"],
            scale["test"]["seen"]["workspaces"],
            scale["test"]["seen"]["queries"],
            scale["test"]["unseen"]["workspaces"],
            scale["test"]["unseen"]["queries"],
        )
    except (KeyError, TypeError, IndexError):
        return None
    return sizes if all(isinstance(v, int) and not isinstance(v, bool) for v in sizes) else None


def _smaller_net(scale) -> bool:
    try:
        hidden = scale["model"]["pnet_hidden"]
        return sum(int(h) for h in hidden) < sum(PAPER_PNET_HIDDEN)
    except (KeyError, TypeError, ValueError):
        return False


def scale_bullet(name: str, sizes: tuple[int, ...] | None, smaller_net: bool = False, envs: str = "") -> str:
    """How a scale found in the logs compares with the paper's sizes, from the sizes its runs
    logged; from its name alone when they did not log them. `envs` (e.g. "arm7") names the
    envs whose runs had these sizes, where one scale name has several (env-specific sizes)."""
    if sizes is None:
        if name == "unknown":
            return f"The logs do not say at which scale they ran; the paper: {PAPER_SCALE_TEXT}."
        return (
            f"Scale `{name}`: the paper's sizes." if name == "paper" else f"Scale `{name}`: smaller than the paper's."
        )
    nets = "smaller networks " if smaller_net else ""
    ours = f"Our `{name}` scale" + (f" for {envs}" if envs else "")
    if tuple(sizes) == PAPER_SCALE:
        return f"{ours} has the paper's sizes ({PAPER_SCALE_TEXT})" + (
            ", with smaller networks." if smaller_net else "."
        )
    tw, tp, sw, sq, uw, uq = sizes
    return (
        f"{ours} trains {nets}on {tw} workspaces × {tp} expert paths and tests on "
        f"{sw * sq} seen + {uw * uq} unseen queries per seed; the paper: {PAPER_SCALE_TEXT}."
    )


def provenance(files: list[TrialFile]) -> dict:
    """Where the logs came from, read from their /run messages: git revisions, hosts,
    dates, scales (with their sizes where logged), budgets, versions and the commands."""
    revs, hosts, scales, budgets, starts, scale_rows, overrides = set(), set(), set(), set(), [], {}, []
    judges: dict[str, set] = {}
    versions: dict[str, set] = {}
    for f in files:
        r = f.run
        for seg in run_segments(r):  # a resumed log: every session that planned some of it
            revs.add(str(seg["git_rev"] or "unknown"))
            hosts.add(str(seg["host"] or "unknown"))
            if seg["started_at"]:
                starts.append(str(seg["started_at"]))
        vers = r.get("versions")
        for k, v in vers.items() if isinstance(vers, dict) else ():
            versions.setdefault(k, set()).add(str(v))
        facts = logged_facts(r)
        scale = facts["scale"]
        name = str(scale.get("name")) if isinstance(scale, dict) else "unknown"
        scales.add(name)
        scale_rows.setdefault((name, scale_sizes(scale), _smaller_net(scale)), set()).add(str(r.get("env")))
        if facts["budget_s"] is not None:
            budgets.add(str(facts["budget_s"]))
        logged = r.get("overrides")
        overrides.append(logged if isinstance(logged, list) else None)
        settings = r.get("settings")
        step = settings.get("env.validation_step") if isinstance(settings, dict) else None
        judges.setdefault(str(r.get("env")), set()).add(step)
    return {
        "git_rev": sorted(revs),
        "host": sorted(hosts),
        "scale": sorted(scales),
        "budget_s": sorted(budgets),
        "scales": _scale_rows(scale_rows),
        "from": min(starts) if starts else "unknown",
        "to": max(starts) if starts else "unknown",
        "versions": {k: sorted(v) for k, v in sorted(versions.items())},
        "commands": sweep_commands(overrides),
        "judges": judges,
    }


def judge_bullet(judges: dict[str, set]) -> str:
    """How the runs' successes were judged, env by env: the fine re-check's step (as each run
    logged it; the env's default for older logs) and what its checker tests."""
    parts = []
    for env in sorted(judges, key=env_rank):
        spec = SPECS.get(env)
        if spec is None:
            parts.append(f"{env}: as its runs' config says")
            continue
        steps = sorted({float(s) for s in judges[env] if s is not None} or {spec.validation_step})
        step = " or ".join(f"{s:g}{spec.robot.step_unit}" for s in steps)
        parts.append(f"{env}: every {step} along the path, {spec.robot.judge_text}")
    how = "; ".join(parts) or "every step of the env's `validation_step` along the path, no margin"
    return (
        f"A success here is a path that passed the harness's fine re-check ({how}); the paper does not "
        "say how its paths were checked."
    )


def _scale_rows(rows: dict) -> list[tuple]:
    """(name, sizes, smaller_net, envs) per scale found; envs named only where one scale name
    comes with several sizes (an env's own sizes, e.g. arm7's quick)."""
    names = [k[0] for k in rows]
    out = []
    for key in sorted(rows, key=lambda t: (t[0], t[1] or (), t[2])):
        envs = ", ".join(sorted(rows[key], key=env_rank)) if names.count(key[0]) > 1 else ""
        out.append((*key, envs))
    return out


def _painter(ws):
    """The painter of a logged /workspace (None when none fits): what it says about costs."""
    if not isinstance(ws, dict):
        return None
    wd = len((ws.get("obstacles") or [{"center": ws.get("bounds") or []}])[0]["center"])
    try:
        return painter_for(ws.get("robot"), wd)
    except ValueError:
        return None


def reference_notes(q: pd.DataFrame, files: list[TrialFile]) -> list[str]:
    """Per env with logged reference costs: the path cost metric and how the references were
    computed, from the logs (the workspace's robot, the runs' configs)."""
    out = []
    d = q[np.isfinite(q["reference_cost"])] if "reference_cost" in q else q.iloc[:0]
    for env in sorted(d["env"].unique(), key=env_rank):
        de = d[d["env"] == env]
        fidx = sorted(de["file"].unique())
        ws = next((w for i in fidx for w in files[int(i)].workspaces.values()), None)
        painter = _painter(ws)
        metric = painter.cost_metric if painter else "the env's path cost"
        if painter is not None and painter.exact_reference:
            ref = (
                "the exact shortest path (Dijkstra on the visibility graph of start, goal and the box corners); "
                "it may touch obstacles, so it is a lower bound and quality >= 1"
            )
        else:
            facts = [logged_facts(files[int(i)].run) for i in fidx]
            experts = sorted({str(f["expert_planner"]) for f in facts if f["expert_planner"]}) or [EXPERT.planner]
            expert = {"rrt_star": "RRT*", "rrt_connect": "RRT-Connect"}
            its = sorted({str(f["expert_iterations"]) for f in facts if f["expert_iterations"] is not None})
            bit = sorted({str(f["reference_bit_star_s"]) for f in facts if f["reference_bit_star_s"] is not None})
            what = "/".join(expert.get(e, e) for e in experts)
            runs = "iterations" if experts == [EXPERT.planner] else "runs"
            ref = (
                f"the better of the expert's {what} path ({'/'.join(its) or 'unknown'} {runs}, "
                f"`env.expert.iterations`) and BIT* run for {'/'.join(bit) or 'unknown'} s "
                "(`env.reference.bit_star_s`), each shortened by lazy states contraction and kept only if it "
                "passes the fine re-check; a planner can beat it (quality < 1)"
            )
        if (de["split"] == "file").any():
            ref += "; queries of a problem file: its own `reference_cost` where given"
        out.append(f"{env} ({env_label(env)}): path cost = {metric}; reference = {ref}.")
    return out


RECHECK_FILE = "recheck.md"  # written into a report folder by `python -m harness.recheck LOGS --out FOLDER`


def recheck_bullet(out: Path) -> str:
    """What the folder's re-check says ("N successes, N verified"), or how to make one: a
    report's "0 false successes" is quoted from its recheck.md, never from memory."""
    try:
        text = (out / RECHECK_FILE).read_text()
    except OSError:
        return (
            f"Re-check: not in this folder; `python -m harness.recheck <the runs' folders> --out {out}` re-checks "
            f"every success from its log alone and writes {RECHECK_FILE} (a later report links it)"
        )
    found = re.search(r"\*\*(\d+) successes, (\d+) verified\*\*", text)
    said = f"{found[1]} successes, {found[2]} verified" if found else "unreadable"
    return f"Re-check: [{RECHECK_FILE}]({RECHECK_FILE}): {said} (`python -m harness.recheck`)"


def readme_text(
    n_files: int,
    n_queries: int,
    with_paper: bool,
    prov: dict | None = None,
    args: str = "",
    warnings: Iterable[str] = (),
    extra: dict | None = None,
    out: str = "reports",
) -> str:
    """OUT/README.md: where the logs came from, what went wrong reading them, what each
    output is, how its numbers are computed, and how they compare with the paper's. `args`:
    the command line's arguments that wrote it; `extra`: which of quality, ablations,
    equal_quality were written, and reference_notes."""
    paper_rows = " (and the paper's rows)" if with_paper else ""
    extra = extra or {}
    refs = extra.get("reference_notes") or []
    ref_text = "\n".join(
        textwrap.fill(n, 95, initial_indent="  - ", subsequent_indent="    ")
        for n in refs or ["no query in the logs has a reference cost."]
    )
    files_extra = "".join(
        textwrap.fill(line, 95, subsequent_indent="  ") + "\n"
        for line in [
            "- `quality.md`, `quality.csv`: path quality per env × split × planner (ablations included): median "
            "and p90 of path cost / reference cost, and the median ratio to BIT*'s path cost on the same queries."
            if extra.get("quality")
            else "- `quality.*`: not written: the logs have no reference costs and no queries solved by BIT* "
            "and another planner.",
            "- `ablations.md`, `ablations.csv`: MPNet (NR) and (HR) against their ablations (success with its "
            "interval, median time with its interval, quality, cost / BIT*), with the not-significant marks."
            if extra.get("ablations")
            else "- `ablations.*`: not written: no ablation runs in the logs.",
            "- `diagnostics.md`, `diagnostics.csv`: what Pnet proposed, per env × split × MPNet planner: shares "
            "of proposals in collision and reachable from their tree end, the first proposal's validity and "
            "visibility, Pnet calls by stage, the workspace-code sensitivity (from `/query` `diagnostics`), and "
            "where the failed queries stopped (first run, replanning, HR's planner, the clock)."
            if extra.get("diagnostics")
            else "- `diagnostics.*`: not written: no MPNet query in the logs carries diagnostics.",
            "- `equal_quality.md`, `equal_quality.csv`: time to equal quality: BIT* / Informed-RRT* run until their "
            "path cost is within a factor (1.0, 1.1) of MPNet (NR)'s on the same query, beside MPNet (NR)'s time."
            if extra.get("equal_quality")
            else "- `equal_quality.*`: not written: no time-to-equal-quality runs (`*_to_nr*`) in the logs.",
        ]
    )
    prov = prov or provenance([])
    vers = ", ".join(f"{k} {'/'.join(v)}" for k, v in prov["versions"].items()) or "unknown"
    scale_text = "\n".join("- " + scale_bullet(*row) for row in prov.get("scales") or [("unknown", None, False)])
    judge_text = textwrap.fill(judge_bullet(prov.get("judges") or {}), 95, initial_indent="- ", subsequent_indent="  ")
    warn_text = "\n".join(f"- {w.removeprefix('warning: ')}" for w in warnings) or "none"
    missing = extra.get("missing") or []
    lack_text = (
        "\n".join(textwrap.fill(line, 95, initial_indent="- ", subsequent_indent="  ") for line in missing)
        if missing
        else "nothing: every env has runs of Table I's four planners (and of MPNet-NR's ablations where it ran)."
    )
    commands = prov.get("commands")
    if commands:
        regen_intro = "To regenerate them (the logs are not in git): the runs' own commands, as they logged them"
        regen = "\n".join(commands) + f"\npython -m harness.report <their output folders> ... --out {out}   # as above"
    else:
        regen_intro = (
            "To regenerate them (the logs are not in git; they predate the logging of each run's command, "
            "so these are the usual commands, not necessarily theirs)"
        )
        if extra.get("ablations") or extra.get("equal_quality"):
            regen = (
                "python -m harness -m +experiment=findings [scale=quick]   "
                "# Table I planners + NR ablations, 5 seeds\n"
                "python -m harness -m +experiment=equal_quality            # time to equal quality\n"
                f"python -m harness.report multirun/<date>/<time> multirun/<date>/<time> --paper --out {out}"
            )
        else:
            regen = (
                "python -m harness -m +experiment=table1 [scale=quick]     # 4 envs x 4 planners x 5 seeds\n"
                f"python -m harness.report multirun/<date>/<time> --paper --out {out}"
            )
    return f"""# mpnet-bench report

Regenerated by `python -m harness.report {args}`
from {n_files} trial logs ({n_queries} queries); do not edit by hand.

## Where the numbers come from

- Git revision of the runs: {", ".join(prov["git_rev"])}
- Machine: {", ".join(prov["host"])}
- Runs started between {prov["from"]} and {prov["to"]} (UTC)
- Scale: {", ".join(prov["scale"]) or "unknown"}; budget per query: {", ".join(prov["budget_s"]) or "unknown"} s
- Versions: {vers}
- {recheck_bullet(Path(out))}

{regen_intro}:

```bash
{regen}
```

## What these runs lack

Table I's columns (MPNet (NR), MPNet (HR), Informed-RRT*, BIT*) and MPNet-NR's ablations that
have no run here, per env, and the command that makes them (the same env, seeds and other
overrides as the env's runs):

{lack_text}

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
{judge_text}

## Files

- `results.csv`: one row per env × split × planner: queries, seeds, success, time, cost,
  collision checks, planner stats.
- `table1.md`, `table1.tex`, `table1.csv`: Table I, planning time mean ± std [s] per env × split
  and planner, and the BIT*/MPNet (NR) ratio (runs given as `--label NAME=DIR` after them, with
  that label's own ratio){paper_rows}.
- `success_cost.md`, `success_cost.tex`, `success_cost.csv`: success rate [%] (mean ± std over
  seeds; pooled with its Wilson 95% interval) and mean path cost.
{files_extra}- `figures/` (PNG and SVG; each says its n): `success` (per env, each split × planner's pooled
  success rate with its Wilson 95% interval, n queries in its label; the axis spans the
  intervals, not 0-100); `success_vs_time` (per env × split, each planner's share of queries
  solved within a time budget, log axis, with a Wilson 95% band at each budget; a success
  without a logged time never counts as within one; n in the legend); `time_boxplot` (per env,
  the times of the successes of each split × planner on a log axis: box quartiles, whiskers
  5th-95th percentile, solved / queries in the labels); `example_<env>` (one query: a
  workspace with an MPNet and a BIT* path; a 3D workspace in 3D, a rigid body whole at each
  vertex of its path, the state bounds dashed).
- `benchmark.db`: an OMPL benchmark database (one experiment per env, with the split as a
  problem parameter; one run per query); open it in Planner Arena (plannerarena.org).

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
- `cpu_share`: the planned queries' CPU time over their wall time, pooled; below 90% they
  waited for the CPU, above 110% a second thread ran, and a warning says so.
- `timeouts`, `timeout_cpu_share`: the queries that ran out of budget and their CPU time over
  their wall time, pooled; below 90% the machine was loaded, a warning says so, and that
  row's success rate is a lower bound.
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
  query), crash (an exception), abort (the planner gave up within the budget), invalid
  solution (a path that failed the harness's re-check), not run (a time-to-equal-quality
  query whose MPNet target failed, so there was nothing to chase); `solved` and `correct_solution` are
  the harness's verdict, `solution_length` the path cost, `solution_segments` the path's
  points less one (NULL for a failure or an empty path); no `memory` (not measured); the
  seed, split, workspace and query ids and failure reason in `run_queries` (by run id);
  `progress`: `best_cost` of OMPL's optimizing planners, sampled from each query's logged
  improvements every (longest such query in the experiment / 100) s and at its end, NULL
  before the first solution, and `best_quality` (best cost / the query's reference cost, the
  attribute comparable across an experiment's queries). One planner config per planner name and
  settings (the run config's `planner:` section); each experiment's `version` is the OMPL
  version its own runs logged.

Paper numbers: {CITATION}.
"""
