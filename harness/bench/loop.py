"""The timed loop: every query of a test set planned once, handed to the log.

The loop records what the planner claims (its path, status, time and checks); whether a
query is a success is decided later, once, by the log process's independent re-check
(harness.log.judge).
"""

from __future__ import annotations

import hashlib
import math
import os
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass, field, replace

import numpy as np

from mpnet.envs.spec import TestSet
from mpnet.motion import path_cost, verify_path
from mpnet.planners.base import Planner, Problem, Result, sub_seed


@dataclass
class QueryTiming:
    """Where a query's wall time went in the planning loop: the planner, the harness
    (set-up, bookkeeping, the hand-off to the log process), the planner's diagnostics
    after the clock (MPNet); and the log process's CPU time for the whole run (judging
    and writing)."""

    plan_s: list[float] = field(default_factory=list)
    harness_s: list[float] = field(default_factory=list)
    diagnostics_s: list[float] = field(default_factory=list)
    log_cpu_s: float = 0.0
    log_peak_rss_mb: float = float("nan")


def _jsonable(v):
    if isinstance(v, (np.floating, np.integer, np.bool_)):
        return v.item()
    if isinstance(v, float) and not math.isfinite(v):
        return None
    return v


def query_seed(seed: int, split: str, query_id: str) -> int:
    """A query's seed, from the run's seed and the query's identity alone: the query plans
    the same in a resumed run, in another order, or after the cache was built in-process."""
    ident = int.from_bytes(hashlib.sha256(f"{split}/{query_id}".encode()).digest()[:8], "little")
    return sub_seed(seed, ident)


def plan_time(wall: float, stats: dict) -> float:
    """`plan_s`: the query's time given its workspace's code, as a robot that encodes its
    scene once and then plans many queries would see it: `time_s` less the planner's own
    `encode_s` (MPNet: the point cloud and Enet); a planner that encodes nothing has
    plan_s == time_s."""
    enc = stats.get("encode_s")
    return wall if enc is None else max(0.0, wall - float(enc))


# A failed query's partial paths are logged thinned to at most this many states each (ends
# kept): enough to see where a planner got stuck, while an OMPL approximate path in a long
# narrow passage cannot blow up trials.mcap.
PARTIAL_MAX_STATES = 200


def logged_partial(partial: dict | None, most: int = PARTIAL_MAX_STATES) -> dict | None:
    """Result.partial as /query's `partial`: each path thinned evenly to `most` states."""
    if not partial:
        return None
    out = {}
    for kind, states in partial.items():
        if len(states) > most:
            states = [states[i] for i in np.linspace(0, len(states) - 1, most).round().astype(int)]
        out[kind] = states
    return out


def plan_query(planner: Planner, problem: Problem, budget_s: float) -> dict:
    """Solve one query, timed: the record's fields. `failure` is None when the planner
    claims an exact path within the budget; the log process re-checks that claim."""
    # A fresh time slice for the query: on a loaded machine the scheduler preempts a process that
    # has used its slice, and what the harness did since the last query (a planner's diagnostics,
    # logging) used some of it; without this, a planner with more work between queries (MPNet)
    # waited more inside its queries than one with less (BIT*). A no-op on an idle machine.
    os.sched_yield()
    t_wall, t_cpu = time.perf_counter(), time.process_time()
    try:
        res = planner.solve(problem, budget_s)
    except Exception as e:  # noqa: BLE001  (one query's exception is a logged failure; the run goes on)
        res = Result(None, "error", {"error": f"{type(e).__name__}: {e}"})
    wall, cpu = time.perf_counter() - t_wall, time.process_time() - t_cpu
    failure = None if res.solved else res.status
    if failure is None and wall > budget_s:
        failure = "timeout"
    rec = {
        "failure": failure,
        "path": res.path if res.path is not None else [],
        "partial": logged_partial(res.partial) if failure is not None else None,
        "time_s": wall,
        "plan_s": plan_time(wall, res.stats),
        "cpu_s": cpu,
        **problem.checker.counts(),
        "planner_status": res.status,
    }
    for k, v in res.stats.items():
        rec.setdefault(k, _jsonable(v))
    diagnose = getattr(planner, "diagnose", None)
    if diagnose is not None:  # after the clock: what the planner proposed (MPNet), for the log
        t_diag = time.perf_counter()
        rec["diagnostics"] = {k: _jsonable(v) for k, v in diagnose(problem, res).items()}
        rec["diagnostics"]["seconds"] = time.perf_counter() - t_diag
    return rec


def unplanned(problem: Problem, reason: str) -> dict:
    """The record of a query that was not planned (e.g. no cost target)."""
    return {
        "failure": reason,
        "path": [],
        "partial": None,
        "time_s": 0.0,
        "plan_s": 0.0,
        "cpu_s": 0.0,
        **problem.checker.counts(),
        "planner_status": reason,
    }


class CostTarget:
    """Pre-query hook for time to equal quality: `target` plans each query first, untimed;
    its verified path's cost becomes the reference cost of the problem the timed planner
    gets (stop=cost). A query it fails has no target."""

    def __init__(self, target: Planner):
        self.target = target

    def __call__(self, problem: Problem, budget_s: float) -> tuple[Problem | None, dict]:
        rec = plan_query(self.target, problem, budget_s)
        ok = (
            rec["failure"] is None
            and verify_path(
                problem.spec, problem.workspace, rec["path"], problem.start, problem.goal, problem.spec.validation_step
            )
            is None
        )
        cost = path_cost(problem.spec, rec["path"]) if ok else None
        fields = {
            "target_planner": self.target.name,
            "target_cost": cost if cost else None,
            "target_time_s": rec["time_s"],
        }
        problem.checker.reset_counts()
        if fields["target_cost"] is None:
            return None, fields
        return replace(problem, reference_cost=fields["target_cost"]), fields


PreQuery = Callable[[Problem, float], tuple[Problem | None, dict]]


def _warm_up(planner, problem: Problem) -> None:
    """The planner's warm_up (Planner), if it has one (a cost target's planner is untimed)."""
    warm_up = getattr(planner, "warm_up", None)
    if warm_up is not None:
        warm_up(problem)


def warm_up(planner: Planner, problem: Problem) -> None:
    """The checker's and the planner's kernels compiled or loaded from numba's cache, and the
    libraries they load loaded (with their thread pools), before the first timed query: a fresh
    clone compiles them here, not in query 1's time."""
    t0 = time.perf_counter()
    problem.checker.warm_up(problem.start)
    _warm_up(planner, replace(problem, reference_cost=None, seed=0))
    if (took := time.perf_counter() - t0) > 5.0:
        print(
            f"warm-up: the kernels compiled in {took:.0f} s, before the first query (once: numba keeps them on disk)",
            file=sys.stderr,
        )
    problem.checker.reset_counts()


def first_problem(testset: TestSet, collision: str = "native") -> Problem | None:
    """The test set's first query as a problem on its own checker (warm_up's), None if it has none."""
    if not testset.queries:
        return None
    q = testset.queries[0]
    ws = next(w for w in testset.workspaces if (w.split, w.id) == (q.split, q.workspace_id))
    return Problem(testset.spec, ws, testset.spec.make_checker(ws, backend=collision), q.start, q.goal, seed=0)


def run_bench(
    testset: TestSet,
    planner: Planner,
    log,
    *,
    budget_s: float,
    seed: int = 0,
    collision: str = "native",
    progress: bool = True,
    timing: QueryTiming | None = None,
    pre_query: PreQuery | None = None,
) -> None:
    """Plan every query of the test set not already in the log, handing each to the log;
    each query's randomness comes from `seed` and its id (query_seed).

    pre_query(problem, budget_s) -> (problem to plan or None, fields for the record) runs
    before each query, outside its time (a cost target); None logs failure "no_target"."""
    from tqdm import tqdm

    spec = testset.spec
    by_ws: dict[tuple[str, str], list] = {}
    for q in testset.queries:
        if (q.split, q.id) not in log.done:
            by_ws.setdefault((q.split, q.workspace_id), []).append(q)
    bar = tqdm(
        total=sum(map(len, by_ws.values())),
        disable=not progress,
        desc=f"{spec.name} {planner.name}",
        unit="query",
        file=sys.stderr,
        dynamic_ncols=True,
    )
    warm = False
    try:
        for ws in testset.workspaces:
            queries = by_ws.get((ws.split, ws.id), [])
            log.add_workspace(ws)
            if not queries:
                continue
            checker = spec.make_checker(ws, backend=collision)
            if not warm:
                warm_up(planner, Problem(spec, ws, checker, queries[0].start, queries[0].goal))
                warm = True
            for q in queries:
                t0 = time.perf_counter()
                checker.reset_counts()
                problem = Problem(spec, ws, checker, q.start, q.goal, q.reference_cost, query_seed(seed, q.split, q.id))
                rec = {
                    "query_id": q.id,
                    "workspace_id": ws.id,
                    "split": q.split,
                    "start": q.start.tolist(),
                    "goal": q.goal.tolist(),
                }
                if pre_query is not None:
                    target_problem, fields = pre_query(problem, budget_s)
                    rec.update(fields)
                    rec.update(
                        unplanned(problem, "no_target")
                        if target_problem is None
                        else plan_query(planner, target_problem, budget_s)
                    )
                else:
                    rec.update(plan_query(planner, problem, budget_s))
                if q.reference_cost is not None:
                    rec["reference_cost"] = q.reference_cost
                log.add_query(rec)
                bar.update(1)
                if timing is not None:
                    diag_s = rec.get("diagnostics", {}).get("seconds", 0.0)
                    timing.plan_s.append(rec["time_s"])
                    timing.diagnostics_s.append(diag_s)
                    timing.harness_s.append(time.perf_counter() - t0 - rec["time_s"] - diag_s)
    finally:
        bar.close()
