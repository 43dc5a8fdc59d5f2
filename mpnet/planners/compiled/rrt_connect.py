"""`rrt_connect_compiled`: RRT-Connect compiled on the env's compiled checks
(mpnet.search.rrt_connect), beside OMPL's `rrt_connect`, which stays the reference.

Why: every OMPL planner asks Python about each state and each motion (mpnet.envs.ompl_space),
while MPNet's compiled loop calls the kernels directly; a classical planner on the same
kernels, called the same way, makes a time ratio compare algorithms rather than plumbing.
The search (OMPL's RRTConnect's growth, its own random stream, a clock read between compiled
slices): mpnet.search.rrt_connect.
"""

from __future__ import annotations

import time

import numpy as np

from mpnet.planners.base import EXACT, TIMEOUT, Problem, Result, check_endpoints, sub_seed
from mpnet.planners.compiled.planner import kernel_env, supports
from mpnet.search.rrt_connect import RRTConnectSearch, add_counts


class CompiledRRTConnect:
    """RRT-Connect on the checker's compiled form (CollisionChecker.compiled_env); every env
    whose default checker has one. `range`: the maximum edge length (None: the env's
    `planner_range`, else OMPL's default); `seed`: the run's, used when a problem brings no
    seed of its own."""

    def __init__(self, name: str = "rrt_connect_compiled", range: float | None = None, seed: int = 0):
        if range is not None and not float(range) > 0:
            raise ValueError(f"config key planner.range: expected a length > 0 or null, got {range!r}")
        self.name = name
        self.range = None if range is None else float(range)
        self.rng = np.array([sub_seed(seed, 0)], np.uint64)  # the kernels' splitmix64 state (rrt_kernels.uniform)
        self._envs: dict[int, tuple] = {}  # id(checker) -> (checker, its kernel env)
        self.search = RRTConnectSearch(self.range)

    def check_env(self, env, collision: str | None = None) -> None:
        """The env's checker must have a compiled form (ValueError naming the key)."""
        if not supports(env, collision):
            raise ValueError(
                f"config key planner: rrt_connect_compiled plans on compiled checks, and env {env.name}'s "
                f"{collision or 'default'} checker has none (use +planner=rrt_connect, OMPL's)"
            )

    def _env_of(self, checker) -> tuple:
        """The checker's kernel env, made once per checker (a checker without one: ValueError)."""
        known = self._envs.get(id(checker))
        if known is None or known[0] is not checker:  # a new checker (an id may be reused)
            known = self._envs[id(checker)] = (checker, kernel_env(checker))
        return known[1]

    def solve(self, problem: Problem, budget_s: float) -> Result:
        t0 = time.perf_counter()
        bad = check_endpoints(problem)
        if bad is not None:
            return bad
        checker = problem.checker
        env = self._env_of(checker)
        # a query's stream from its own seed alone (a query seed is already mixed: sub_seed)
        rng = self.rng if problem.seed is None else np.array([problem.seed], np.uint64)
        counts = np.zeros(3, np.int64)
        try:
            found = self.search.run(env, problem.spec, problem.start, problem.goal, rng, t0 + budget_s, counts=counts)
        finally:  # counted even when stopped by an exception
            add_counts(checker, counts)
        stats = {"iterations": found.rounds, "tree_states": found.tree_states, "trees_full": found.full}
        if found.path is None:
            return Result(None, TIMEOUT, stats)
        return Result(found.path.tolist(), EXACT, stats)

    def warm_up(self, problem: Problem) -> None:
        """The search's kernels compiled (or loaded from numba's cache) before the first timed
        query (Planner.warm_up): one round of the search on the problem, and a path read back."""
        self.search.warm_up(self._env_of(problem.checker), problem.spec, problem.start, problem.goal)
