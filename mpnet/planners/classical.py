"""OMPL's C++ planners behind the Planner protocol."""

from __future__ import annotations

import math
import time

from ompl import base as ob
from ompl import geometric as og

from mpnet.envs.ompl_space import deadline_condition, make_problem, set_ompl_seed
from mpnet.motion import path_cost
from mpnet.planners.base import (
    APPROXIMATE,
    EXACT,
    NO_SOLUTION,
    TIMEOUT,
    Problem,
    Result,
    check_endpoints,
    sub_seed,
)

ALGORITHMS = {
    "informed_rrt_star": og.InformedRRTstar,
    "bit_star": og.BITstar,
    "rrt_star": og.RRTstar,
    "rrt_connect": og.RRTConnect,
    "aorrtc": og.AORRTC,  # asymptotically optimal RRT-Connect (OMPL 2.0): MPNet-HR's optimal, bidirectional gap closer
}
OPTIMIZING = {"informed_rrt_star", "bit_star", "rrt_star", "aorrtc"}
# stop=time leaves the larger of this share of the budget and these seconds to hand the path back
# within the budget (OMPL stops an iteration past its time; a loaded machine may preempt it then).
TIME_STOP_MARGIN = (0.02, 0.05)


class OmplPlanner:
    """An OMPL geometric planner.

    stop="first": return the first exact solution (the paper's initial path); OMPL's
    exact-solution condition does not stop optimizing planners, so a condition on the
    planner's best cost does. stop="cost": run until the path cost reaches
    cost_factor x the problem's reference cost; a path that never gets there is no
    solution (timeout). stop="time": run to the budget less a margin (TIME_STOP_MARGIN: 2%, at
    least 50 ms) and return the best path (a budgeted reference run, back within the budget).
    `range` is the planner's maximum edge length (None: the env's `planner_range`, else
    OMPL's default); `params` are OMPL planner parameters by snake_case name
    (rewire_factor -> setRewireFactor). keep_partial: a failed solve's
    Result carries OMPL's approximate solution when there is one (MPNet-HR's fallback,
    which may fail and restart many times in one query, turns it off). An optimizing planner's
    stats carry `progress`: [seconds since solve began, best cost] at each improvement, what
    Planner Arena's progress page plots (see BestCostWatch).
    """

    def __init__(
        self,
        name: str,
        algorithm: str,
        stop: str = "first",
        cost_factor: float = 1.0,
        range: float | None = None,
        params: dict | None = None,
        keep_partial: bool = True,
    ):
        if algorithm not in ALGORITHMS:
            raise ValueError(
                f"config key planner.algorithm: unknown OMPL algorithm {algorithm!r}; choices: {', '.join(ALGORITHMS)}"
            )
        if stop not in ("first", "cost", "time"):
            raise ValueError(f"config key planner.stop must be 'first', 'cost' or 'time', not {stop!r}")
        self.name = name
        self.algorithm = algorithm
        self.stop = stop
        self.cost_factor = float(cost_factor)
        self.range = range
        self.params = dict(params or {})
        self.keep_partial = keep_partial

    def solve(self, problem: Problem, budget_s: float) -> Result:
        t0 = time.perf_counter()
        if problem.seed is not None:
            seed_ompl(problem.seed)
        bad = check_endpoints(problem)
        if bad is not None:
            return bad
        target = None
        if self.stop == "cost":
            if problem.reference_cost is None:
                raise ValueError("planner.stop=cost needs a reference cost for the query")
            target = self.cost_factor * problem.reference_cost
        si, pdef, to_tuple, keep = make_problem(problem.spec, problem.checker, problem.start, problem.goal)
        if self.stop == "cost":
            pdef.getOptimizationObjective().setCostThreshold(ob.Cost(target))
        planner = ALGORITHMS[self.algorithm](si)
        reach = self.range if self.range is not None else problem.spec.planner_range
        if reach is not None and hasattr(planner, "setRange"):
            planner.setRange(float(reach))
        for key, value in self.params.items():
            # OMPL's ParamSet is not bound in the 2.0.1 wheel: call the setter by name.
            setter = getattr(planner, "set" + "".join(w.capitalize() for w in str(key).split("_")), None)
            if setter is None:
                raise ValueError(f"OMPL {self.algorithm} has no parameter {key!r} (config key planner.params)")
            setter(value)
        planner.setProblemDefinition(pdef)
        planner.setup()

        # stop=time stops a margin short of the budget: a path handed back after it is a timeout.
        share, least_s = TIME_STOP_MARGIN
        plan_s = budget_s - (max(share * budget_s, least_s) if self.stop == "time" else 0.0)
        # The budget is kept on the trial's own (monotonic) clock, never OMPL's wall clock; no
        # period argument: a periodic condition runs on a thread and aborts at exit.
        clock, end = time.perf_counter, t0 + plan_s
        if self.algorithm in OPTIMIZING:
            watch = BestCostWatch(planner, t0, self.stop, target, end, clock)
            ptc = ob.PlannerTerminationCondition(watch)
        else:
            watch, ptc = None, deadline_condition(end - clock(), clock)
        status = planner.solve(ptc)
        exact = pdef.hasExactSolution()
        path = partial = None
        if exact:
            path = [list(to_tuple(s)) for s in pdef.getSolutionPath().getStates()]
            path = snap_endpoints(path, problem)
        elif self.keep_partial and pdef.hasApproximateSolution():  # a failure: copied only now
            partial = {APPROXIMATE: [list(to_tuple(s)) for s in pdef.getSolutionPath().getStates()]}
        stats = {"planner_status": status.asString() if hasattr(status, "asString") else str(status)}
        if watch is not None:  # an optimizing planner
            cost = planner.bestCost().value()
            stats["best_cost"] = cost if math.isfinite(cost) else None
            stats["progress"] = watch.seen(cost, clock() - t0)
        if watch is not None:  # AORRTC keeps the termination condition, which holds the watch: the cycle broken
            watch.planner = None
        del planner, pdef, si, keep
        if path is not None and target is not None and path_cost(problem.spec, path) > target * (1 + 1e-9):
            # stop=cost claims a solution only at the target: a longer path is not one
            path, partial = None, ({APPROXIMATE: path} if self.keep_partial else None)
        if path is None:
            timed_out = clock() - t0 >= budget_s * 0.999
            return Result(None, TIMEOUT if timed_out else NO_SOLUTION, stats, partial)
        return Result(path, EXACT, stats)


class BestCostWatch:
    """An optimizing planner's stop rule, polled by OMPL at every iteration of its solve, that
    also records each new best cost with its time. (OMPL 2.0.1's Python binding cannot take
    the problem's intermediate-solution callback: its std::function over State pointers has no
    converter; the poll sees an improvement at the next iteration, microseconds later.)
    stop: "first" (any solution), "cost" (best cost <= target) or "time" (never); whatever the
    stop, `clock()` reaching `end` ends the solve (the budget, on the trial's clock)."""

    def __init__(
        self, planner, t0: float, stop: str, target: float | None, end: float = math.inf, clock=time.perf_counter
    ):
        self.planner, self.t0, self.stop, self.target = planner, t0, stop, target
        self.end, self.clock = end, clock
        self.last = math.inf
        self.progress: list[list[float]] = []

    def seen(self, cost: float, t: float) -> list[list[float]]:
        """Record `cost` at time `t` if it is a new best; the progress so far."""
        if cost < self.last:
            self.last = cost
            self.progress.append([t, cost])
        return self.progress

    def __call__(self) -> bool:
        now = self.clock()
        cost = self.planner.bestCost().value()
        if cost < self.last:
            self.seen(cost, now - self.t0)
        if now >= self.end:
            return True
        if self.stop == "first":
            return math.isfinite(cost)
        return self.stop == "cost" and cost <= self.target


def seed_ompl(seed: int) -> None:
    """Restart OMPL's seed generator from `seed`: every RNG made after this (the planner and
    samplers `solve` builds fresh per query) draws the same numbers whatever ran before."""
    set_ompl_seed(sub_seed(seed, 0))


def snap_endpoints(path: list, problem: Problem) -> list:
    """The path's ends as the query's exact start and goal: OMPL stores theta wrapped into
    [-pi, pi) and a goal within its tolerance; a one-state path (start == goal) gets both."""
    if len(path) == 1:
        path = [path[0], path[0]]
    return [problem.start.tolist(), *path[1:-1], problem.goal.tolist()]
