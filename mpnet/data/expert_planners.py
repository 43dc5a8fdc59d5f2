"""The expert planners: a path for one start/goal pair of a workspace. OMPL's RRT* for a fixed
number of iterations (its raw vertex list, as the original trained on), and RRT-Connect's
recipe (the shortest of a few runs, each rope-shortcut and contracted) with OMPL's search or
with the search compiled on the checker's compiled form (mpnet.search). mpnet.data.expert
plans a dataset's paths with them."""

from __future__ import annotations

import hashlib
import math
import time

import numpy as np

from mpnet.envs.spec import EnvSpec
from mpnet.motion import lazy_states_contraction, path_cost


def _budget(iterations: int):
    """A termination test that is true from its (iterations + 1)-th call on, and its call count."""
    count = [0]

    def spent() -> bool:
        count[0] += 1
        return count[0] > iterations

    return spent, count


def rrt_star_path(
    spec: EnvSpec,
    checker,
    start,
    goal,
    iterations: int,
    max_seconds: float,
    clock: list | None = None,
    run_iterations: int | None = None,
) -> list | None:
    """RRT* run for `iterations` iterations (or max_seconds, whichever ends first; clock: gets
    one entry when max_seconds ended it). run_iterations is RRT-Connect's: here it must be None
    (the configs refuse it with rrt_star, harness.core.config)."""
    if run_iterations is not None:
        raise ValueError("run_iterations is the rrt_connect expert's budget; rrt_star's is `iterations`")
    from ompl import base as ob
    from ompl import geometric as og

    from mpnet.envs.ompl_space import deadline_condition, make_problem

    si, pdef, to_tuple, keep = make_problem(spec, checker, start, goal)
    planner = og.RRTstar(si)
    planner.setProblemDefinition(pdef)
    planner.setup()
    spent, count = _budget(iterations)
    planner.solve(
        ob.plannerOrTerminationCondition(deadline_condition(max_seconds), ob.PlannerTerminationCondition(spent))
    )
    if count[0] <= iterations and clock is not None:  # the clock ended it, not the count
        clock.append(1)
    if not pdef.hasExactSolution():
        return None
    path = [list(to_tuple(x)) for x in pdef.getSolutionPath().getStates()]
    path[0], path[-1] = list(map(float, start)), list(map(float, goal))
    return path


def _shortest_of_runs(spec: EnvSpec, checker, start, goal, runs: int, clock, run_iterations, solve_run) -> list | None:
    """RRT-Connect's expert recipe around one run's search (`solve_run(run)`: (space
    information, its PathGeometric, to_tuple), or None when the run found no path): each
    found path shortened by OMPL's rope shortcut, its ends the query's exactly, contracted
    (lazy states contraction); the shortest kept. The runs stop at the first that finds no
    path (a pair RRT-Connect cannot solve costs one run, not `runs`), which is a clock stop
    when no run_iterations budget ended it."""
    from ompl import geometric as og

    best, best_cost = None, math.inf
    for run in range(runs):
        found = solve_run(run)
        if found is None:
            if clock is not None and run_iterations is None:  # the clock ended the run
                clock.append(1)
            break
        si, solution, to_tuple = found
        og.PathSimplifier(si).ropeShortcutPath(solution)
        path = [list(to_tuple(x)) for x in solution.getStates()]
        del found, solution  # before the next run's path is made
        path[0], path[-1] = list(map(float, start)), list(map(float, goal))
        path = lazy_states_contraction(checker, dedupe(path))
        cost = path_cost(spec, path)
        if cost < best_cost:
            best, best_cost = path, cost
    return best


def rrt_connect_path(
    spec: EnvSpec,
    checker,
    start,
    goal,
    runs: int,
    max_seconds: float,
    clock: list | None = None,
    run_iterations: int | None = None,
) -> list | None:
    """The shortest of `runs` RRT-Connect paths (the env's planner_range), each shortened by
    OMPL's rope shortcut and lazy states contraction: the expert where RRT* for a fixed number
    of iterations rarely solves the queries (panda_mbm's goals deep in shelves; FINDINGS,
    issue 26, compares its costs with BIT*'s). The runs stop at the first that finds no path.

    run_iterations: each run ends after this many iterations (calls of its termination
    condition) and max_seconds is unused, so that the paths depend on the seed alone; None:
    max_seconds ends a run without a path (clock gets an entry: the result then depends on
    the machine's speed and load; the datasets built before run_iterations existed)."""
    from ompl import base as ob
    from ompl import geometric as og

    from mpnet.envs.ompl_space import deadline_condition, make_problem

    keep = []  # each run's setup lives until the expert returns (OMPL only references it)

    def solve_run(run: int):
        si, pdef, to_tuple, held = make_problem(spec, checker, start, goal)
        keep.append(held)
        planner = og.RRTConnect(si)
        if spec.planner_range is not None:
            planner.setRange(float(spec.planner_range))
        planner.setProblemDefinition(pdef)
        planner.setup()
        if run_iterations is None:
            planner.solve(deadline_condition(max_seconds))
        else:
            planner.solve(ob.PlannerTerminationCondition(_budget(run_iterations)[0]))
        return (si, pdef.getSolutionPath(), to_tuple) if pdef.hasExactSolution() else None

    return _shortest_of_runs(spec, checker, start, goal, runs, clock, run_iterations, solve_run)


def _query_stream(start, goal, run: int) -> np.ndarray:
    """A compiled search's random stream (rrt_kernels' splitmix64 state) for one run of one
    query: from the query's coordinates and the run's number alone (no process-wide RNG), so a
    path depends on its query and nothing else."""
    digest = hashlib.blake2b(np.asarray([*start, *goal, run], float).tobytes(), digest_size=8).digest()
    return np.array([int.from_bytes(digest, "little")], np.uint64)


def rrt_connect_compiled_path(
    spec: EnvSpec,
    checker,
    start,
    goal,
    runs: int,
    max_seconds: float,
    clock: list | None = None,
    run_iterations: int | None = None,
) -> list | None:
    """rrt_connect_path's recipe (_shortest_of_runs) with each run's search compiled on the
    checker's compiled form (mpnet.search.rrt_connect: no Python between a sample and its
    checks, where OMPL's RRTConnect asks Python about each). Its random stream is each run's
    own (_query_stream), not OMPL's: the paths are RRT-Connect's in kind, not OMPL's state for
    state. run_iterations / max_seconds / clock: as rrt_connect_path's."""
    from ompl import geometric as og

    from mpnet.envs.ompl_space import make_space_information
    from mpnet.search.rrt_connect import RRTConnectSearch, add_counts

    env = checker.compiled_env()
    search = RRTConnectSearch()
    # one SpaceInformation for every run's shortcut, alive (with its Python motion validator,
    # `held`) until every path made from it is gone
    si, to_tuple, set_state, held = make_space_information(spec, checker)

    def solve_run(run: int):
        deadline = math.inf if run_iterations is not None else time.perf_counter() + max_seconds
        found = search.run(env, spec, start, goal, _query_stream(start, goal, run), deadline, run_iterations)
        add_counts(checker, found.counts)
        if found.path is None:
            return None
        solution = og.PathGeometric(si)
        state = si.allocState()  # the binding frees it (a freeState here freed it twice)
        for q in found.path:
            set_state(state, q)
            solution.append(state)  # a copy
        return si, solution, to_tuple

    best = _shortest_of_runs(spec, checker, start, goal, runs, clock, run_iterations, solve_run)
    del held
    return best


EXPERTS = {
    "rrt_star": rrt_star_path,
    "rrt_connect": rrt_connect_path,
    "rrt_connect_compiled": rrt_connect_compiled_path,
}
# the experts that plan with the env's planner_range and take a budget in rounds (run_iterations)
TREE_EXPERTS = ("rrt_connect", "rrt_connect_compiled")
# the experts whose paths draw on OMPL's process-wide RNG (seeded once per process): each chunk of
# their workspaces needs a fresh process. The compiled expert's stream is each query's own
# (_query_stream) and OMPL's rope shortcut draws nothing: its chunks share long-lived workers.
PROCESS_SEEDED = ("rrt_star", "rrt_connect")


def dedupe(path: list) -> list:
    """The path without states equal to the one before them (the original's data generator
    drops repeated states the same way)."""
    out = [path[0]]
    for q in path[1:]:
        if list(q) != list(out[-1]):
            out.append(q)
    return out
