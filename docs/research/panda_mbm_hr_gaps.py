"""Issue 42: where MPNet-HR's RRT* fails on MotionBenchMaker's problems. From an MPNet-HR run
on MBM (problems=DIR), every failed query whose classical planner ran: the path HR handed it
(the logged `partial.last_path`, its interior states in collision dropped as HR's repair drops
them) and that path's first segment the continuous check finds blocked: the first its RRT* had to
close (HR closes them in order and stops at the first it cannot; where the path had one blocked
segment, this is the one it did not complete). On each such gap, one run of each planner below
with the same budget, from a fixed seed:

- rrt_star: as HR runs it (OMPL's defaults: k-nearest rewiring, goal bias 0.05; range 1.0 rad);
- rrt_star, reversed: the same, planning from the gap's far end back to its near end;
- rrt_star, radius rewiring: k-nearest off (rewiring radius min(OMPL's r_rrt, range));
- rrt_connect: the planner of `mpnet_hr_rrtc`, and of the expert's paths.

    PYTHONPATH=<checkout> python docs/research/panda_mbm_hr_gaps.py HR_RUN_DIR PROBLEMS_DIR
        [--budget 1.0] [--out reports/panda_mbm_hr_gaps]

HR_RUN_DIR: a folder holding the MPNet-HR run's trials.mcap (at any depth, one run).
"""

from __future__ import annotations

import argparse
import math
import time
from pathlib import Path

import numpy as np

from harness.core.provenance import generated_by, machine_info, write_readme
from harness.report.load import find_logs, read_trials
from mpnet.envs.mbm.files import load_mbm
from mpnet.envs.specs import get_spec
from mpnet.planners.base import Problem
from mpnet.planners.classical import OmplPlanner

RANGE = 1.0  # conf/env/panda_mbm.yaml planner_range: HR's RRT* and RRT-Connect take it
VARIANTS = {  # name: (algorithm, OMPL parameters, plan from the far end)
    "rrt_star (HR's)": ("rrt_star", {}, False),
    "rrt_star, reversed": ("rrt_star", {}, True),
    "rrt_star, radius rewiring": ("rrt_star", {"k_nearest": False}, False),
    "rrt_connect": ("rrt_connect", {}, False),
}


def hr_gaps(run_dir: Path, problems: Path, spec) -> tuple[list[dict], dict]:
    """The first blocked segment of each failed HR query whose fallback ran (with the number of
    blocked segments of the path handed over), and the run's own figures."""
    logs, _ = find_logs([run_dir])
    if len(logs) != 1:
        raise SystemExit(f"{run_dir}: expected one trials.mcap, found {len(logs)}")
    f, warning = read_trials(logs[0])
    if f is None:
        raise SystemExit(warning)
    workspaces = {w.id: w for w in load_mbm(problems, spec).workspaces}
    gaps, run = [], {"queries": len(f.queries), "solved": 0, "fallback_failed": 0, "fallback_s": 0.0}
    run["git_rev"] = f.run.get("git_rev")
    for q in f.queries:
        run["solved"] += bool(q["success"])
        run["fallback_s"] += float(q.get("fallback_s") or 0.0)
        lp = (q.get("partial") or {}).get("last_path")
        if q["success"] or not q.get("fallback_used") or not lp:
            continue
        run["fallback_failed"] += 1
        ws = workspaces[q["workspace_id"]]
        checker = spec.make_checker(ws)
        states = [lp[0], *[x for x in lp[1:-1] if checker.is_valid(tuple(x))], lp[-1]]
        free = [checker.motion_valid(tuple(a), tuple(b)) for a, b in zip(states[:-1], states[1:])]
        if all(free):
            continue
        i = free.index(False)
        a, b = states[i], states[i + 1]
        gaps.append(
            {
                "query": q["query_id"],
                "workspace": ws,
                "a": np.asarray(a, float),
                "b": np.asarray(b, float),
                "length": float(np.linalg.norm(np.subtract(b, a))),
                "at_start": i == 0,
                "at_goal": i == len(states) - 2,
                "blocked": free.count(False),
            }
        )
    return gaps, run


def time_variant(spec, gaps: list[dict], algorithm: str, params: dict, reverse: bool, budget: float) -> dict:
    planner = OmplPlanner(algorithm, algorithm, stop="first", range=RANGE, params=params, keep_partial=False)
    solved, times, motions = 0, [], 0
    for k, g in enumerate(gaps):
        checker = spec.make_checker(g["workspace"])
        a, b = (g["b"], g["a"]) if reverse else (g["a"], g["b"])
        t0 = time.perf_counter()
        res = planner.solve(Problem(spec, g["workspace"], checker, a, b, seed=k), budget)
        times.append(time.perf_counter() - t0)
        solved += res.path is not None
        motions += checker.motion_checks
    total = sum(times)
    return {"solved": solved, "median_s": float(np.median(times)), "total_s": total, "motions_per_s": motions / total}


def rrt_star_k0(dim: int, rewire_factor: float = 1.1) -> int:
    """OMPL's RRT* first k-nearest value: ceil(k_rrt log 2), k_rrt = rewire factor x 2^(d+1) e (1 + 1/d)
    (ompl/geometric/planners/rrt/src/RRTstar.cpp, calculateRewiringLowerBounds)."""
    return math.ceil(rewire_factor * 2 ** (dim + 1) * math.e * (1 + 1 / dim) * math.log(2))


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("run_dir", type=Path)
    ap.add_argument("problems", type=Path)
    ap.add_argument("--budget", type=float, default=1.0)
    ap.add_argument("--out", type=Path, default=Path("reports/panda_mbm_hr_gaps"))
    args = ap.parse_args()
    spec = get_spec("panda_mbm")
    machine = machine_info()
    gaps, run = hr_gaps(args.run_dir, args.problems, spec)
    lengths = np.array([g["length"] for g in gaps])
    blocked = np.median([g["blocked"] for g in gaps])
    one = sum(g["blocked"] == 1 for g in gaps)
    rows = []
    for name, (algorithm, params, reverse) in VARIANTS.items():
        r = time_variant(spec, gaps, algorithm, params, reverse, args.budget)
        cells = (f"{r['solved']} of {len(gaps)}", f"{r['median_s']:.3f}", f"{r['total_s']:.0f}")
        cells += (f"{r['motions_per_s']:,.0f}",)
        rows.append(f"| {name} | {' | '.join(cells)} |")
    p10, p50, p90 = np.percentile(lengths, [10, 50, 90])
    command = f"python docs/research/panda_mbm_hr_gaps.py {args.run_dir} {args.problems} --budget {args.budget}"
    lines = [
        "# MPNet-HR's RRT* on the gaps it left (MotionBenchMaker)",
        "",
        generated_by(command, machine),
        "",
        f"The MPNet-HR run (git {run['git_rev']}): {run['solved']} of {run['queries']} solved; "
        f"{run['fallback_failed']} failed after its classical planner ran (RRT*, restarted after 0.5 s, 1 s, 2 s, ... "
        f"within the query's budget; {run['fallback_s']:.0f} s in it over the run). Each such query's first blocked "
        f"segment (the first its RRT* had to close): {len(gaps)} gaps, {p50:.2f} rad long (median; p10 {p10:.2f}, "
        f"p90 {p90:.2f}); {sum(g['at_goal'] for g in gaps)} end at the query's goal, "
        f"{sum(g['at_start'] for g in gaps)} begin at its start. The path HR handed over had {blocked:.0f} blocked "
        f"segment(s) (median); on {one} of the {len(gaps)} this gap was the only one, so the one RRT* did not "
        "complete.",
        "",
        f"One run of each planner on each gap, {args.budget:g} s, seed = the gap's index, range {RANGE} rad, "
        "one at a time on an otherwise idle machine. Motion checks per second: the checker's motion checks over the "
        "planners' whole time (OMPL's own work included).",
        "",
        f"| planner | gaps solved in {args.budget:g} s | median time [s] | total [s] | motion checks / s |",
        "| --- | --- | --- | --- | --- |",
        *rows,
        "",
        f"OMPL's RRT* rewires over the k nearest states, k = ceil(k_rrt log n), k_rrt = 1.1 x 2^(d+1) e (1 + 1/d): "
        f"in 7-D its first k is {rrt_star_k0(7)} (2-D: {rrt_star_k0(2)}), so each new state is weighed against "
        "every state of a small tree (radius rewiring caps the neighbours at the range).",
        "",
    ]
    write_readme(args.out, lines)


if __name__ == "__main__":
    main()
