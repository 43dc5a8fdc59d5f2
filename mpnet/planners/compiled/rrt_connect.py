"""`rrt_connect_compiled`: RRT-Connect compiled on the env's compiled checks
(mpnet.planners.compiled.rrt_kernels), beside OMPL's `rrt_connect`, which stays the reference.

Why: every OMPL planner asks Python about each state and each motion (mpnet.envs.ompl_space),
while MPNet's compiled loop calls the kernels directly; a classical planner on the same
kernels, called the same way, makes a time ratio compare algorithms rather than plumbing.
Its search is OMPL's RRTConnect (same growth, same maximum edge length: the env's
`planner_range`, else OMPL's default of a fifth of the space's extent) with its own random
stream, so its paths are RRT-Connect's in kind, not OMPL's state for state.

The clock is read between compiled slices of the search (numba has none): each slice is sized
to take about SLICE_S at the mean rate so far, so a budget is overrun by about a slice (the
rounds slow as the trees grow: a few times SLICE_S at worst; the first slice is FIRST_SLICE
rounds whatever they take).
"""

from __future__ import annotations

import time

import numpy as np

from mpnet.planners.base import EXACT, TIMEOUT, Problem, Result, check_endpoints, sub_seed
from mpnet.planners.compiled import rrt_kernels as K
from mpnet.planners.compiled.planner import kernel_env, supports

SLICE_S = 0.005  # a slice of the search lasts about this long once its rate is known
FIRST_SLICE = 32  # iterations of the first slice: most arm queries connect within it
CAPACITY = 1024  # each tree's first capacity (states); doubled when full
DEFAULT_RANGE_SHARE = 0.2  # OMPL's RRTConnect: maxDistance = 0.2 x the space's maximum extent


def tree_range(spec, given: float | None = None) -> float:
    """A tree planner's maximum edge length: the one given, else the env's `planner_range`,
    else OMPL's default (DEFAULT_RANGE_SHARE of the space's maximum extent)."""
    reach = given if given is not None else spec.planner_range
    return float(reach if reach is not None else DEFAULT_RANGE_SHARE * spec.space.maximum_extent())


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
        self._spaces: dict[int, tuple] = {}  # id(spec) -> (spec, (lower, upper, weights, reach, room))
        self._trees: tuple | None = None

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

    def _space_of(self, spec) -> tuple:
        known = self._spaces.get(id(spec))
        if known is None or known[0] is not spec:
            space = spec.space
            reach = tree_range(spec, self.range)
            # a connection adds at most (extent / reach + 1) states to a tree: room for one round
            room = int(np.ceil(space.maximum_extent() / reach)) + 4
            lower, upper = (np.ascontiguousarray(v, float) for v in (space.lower, space.upper))
            known = self._spaces[id(spec)] = (spec, (lower, upper, space.metric_weights(), reach, room))
        return known[1]

    def _buffers(self, d: int, room: int) -> tuple:
        """The trees' arrays (nodes (2, cap, d), parents (2, cap)), kept between queries."""
        if self._trees is None or self._trees[0].shape[2] != d or self._trees[0].shape[1] < 2 * room:
            cap = max(CAPACITY, 2 * room)
            self._trees = (np.empty((2, cap, d)), np.zeros((2, cap), np.int64))
        return self._trees

    def _grown(self) -> tuple:
        """The trees' arrays at twice their capacity, every state and parent kept."""
        nodes, parents = self._trees
        cap = nodes.shape[1]
        more_nodes, more_parents = np.empty((2, 2 * cap, nodes.shape[2])), np.zeros((2, 2 * cap), np.int64)
        more_nodes[:, :cap], more_parents[:, :cap] = nodes, parents
        self._trees = (more_nodes, more_parents)
        return self._trees

    def solve(self, problem: Problem, budget_s: float) -> Result:
        t0 = time.perf_counter()
        deadline = t0 + budget_s
        bad = check_endpoints(problem)
        if bad is not None:
            return bad
        checker = problem.checker
        env = self._env_of(checker)
        lower, upper, weights, reach, room = self._space_of(problem.spec)
        # a query's stream from its own seed alone (a query seed is already mixed: sub_seed)
        rng = self.rng if problem.seed is None else np.array([problem.seed], np.uint64)
        start, goal = np.asarray(problem.start, float), np.asarray(problem.goal, float)
        nodes, parents = self._buffers(start.shape[0], room)
        nodes[0, 0], nodes[1, 0] = start, goal
        state = K.new_state()
        counts = np.zeros(3, np.int64)
        sample, diff = np.empty(start.shape[0]), np.empty(start.shape[0])
        chunk, outcome = FIRST_SLICE, K.RUNNING
        try:
            while True:
                outcome = K.grow(
                    env, counts, weights, lower, upper, reach, rng, nodes, parents, state, chunk, room, sample, diff
                )
                if outcome == K.FULL:
                    nodes, parents = self._grown()
                    continue
                now = time.perf_counter()
                if outcome == K.CONNECTED or now >= deadline:
                    break
                per = max(now - t0, 1e-9) / state[K.ROUNDS]
                chunk = int(max(1, min(SLICE_S, deadline - now) / per))
        finally:  # the checks count on the checker, as OMPL's planners' do
            checker.state_checks += int(counts[0])
            checker.motion_checks += int(counts[1])
            if hasattr(checker, "configurations"):
                checker.configurations += int(counts[2])
        stats = {"iterations": int(state[K.ROUNDS]), "tree_states": int(state[K.N0] + state[K.N1])}
        if outcome != K.CONNECTED:
            return Result(None, TIMEOUT, stats)
        path = K.solution(nodes, parents, state)
        return Result(path.tolist(), EXACT, stats)

    def warm_up(self, problem: Problem) -> None:
        """The search's kernels compiled (or loaded from numba's cache) before the first timed
        query (Planner.warm_up): one round of the search on the problem, and a path read back."""
        env = self._env_of(problem.checker)
        lower, upper, weights, reach, room = self._space_of(problem.spec)
        nodes, parents = self._buffers(len(problem.start), room)
        nodes[0, 0], nodes[1, 0] = problem.start, problem.goal
        state = K.new_state()
        K.grow(env, np.zeros(3, np.int64), weights, lower, upper, reach, np.zeros(1, np.uint64), nodes, parents,
               state, 1, room, np.empty(len(problem.start)), np.empty(len(problem.start)))  # fmt: skip
        state[K.JOIN0], state[K.JOIN1] = 0, 0
        K.solution(nodes, parents, state)
