"""One Planner protocol for neural and classical planners alike (OMPL's shape):
a problem (workspace, checker, start, goal, objective) solved within a budget."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Protocol, runtime_checkable

import numpy as np

from mpnet.envs.checkers.collision import CollisionChecker
from mpnet.envs.spec import EnvSpec
from mpnet.envs.workspace import Workspace

# Result.status values: why a planner stopped. Only "exact" claims a solution.
EXACT = "exact"
TIMEOUT = "timeout"
INVALID_QUERY = "invalid_query"
NO_SOLUTION = "no_solution"

# Result.partial's keys: what a planner had when it failed, each a list of states.
FORWARD = "forward"  # MPNet: the last NeuralPlanner run's path grown from its start
BACKWARD = "backward"  # ... and the one grown from its goal, when they did not connect
LAST_PATH = "last_path"  # MPNet: the last coarse or replanned path, which was not feasible
APPROXIMATE = "approximate"  # OMPL: its approximate solution, start to the state nearest the goal
# (under stop=cost, the best path, which missed the cost target)
PARTIAL_KINDS = (FORWARD, BACKWARD, LAST_PATH, APPROXIMATE)

RANDOM_TRIES = 1000  # the random proposals' rejection sampling: draws before the last one is taken


@dataclass
class Problem:
    """A start and goal in one workspace, the shared checker, the query's reference
    cost when known (a planner that stops at a cost target scales it), and the query's
    own seed: a planner given one draws all its randomness from it, so a query plans the
    same whatever ran before it in the process (a resumed run, a warm or cold cache)."""

    spec: EnvSpec
    workspace: Workspace
    checker: CollisionChecker
    start: np.ndarray
    goal: np.ndarray
    reference_cost: float | None = None
    seed: int | None = None


def sub_seed(seed: int, *path: int) -> int:
    """A seed in [1, 2^31 - 1] derived from a seed of any size and a path of non-negative
    integers (OMPL's seeds must be positive and fit 32 bits; numpy's take any)."""
    state = np.random.SeedSequence([int(seed), *map(int, path)]).generate_state(1, np.uint64)[0]
    return int(state % np.uint64(2**31 - 1)) + 1


@dataclass
class Result:
    """What a planner returns: its path (None when it claims none), why it stopped, its stats.

    partial: on a failure, what the planner had when it stopped, so a recording can show
    where it got stuck: {kind: list of states} with kinds from PARTIAL_KINDS (only those it
    had); None on success, and when it had nothing (an invalid query, BIT*'s timeout).
    Planners copy these states only when they fail, so successes cost nothing."""

    path: list[list[float]] | None
    status: str
    stats: dict = field(default_factory=dict)
    partial: dict[str, list[list[float]]] | None = None

    @property
    def solved(self) -> bool:
        return self.status == EXACT and self.path is not None


@runtime_checkable
class Planner(Protocol):
    """solve(problem, budget) -> Result. A planner may also have `warm_up(problem)`: what its
    first call would pay (a compilation, a cache load), paid before the first timed query;
    the bench calls it once per run with the first query, then resets the checker's counts."""

    name: str

    def solve(self, problem: Problem, budget_s: float) -> Result: ...


def check_endpoints(problem: Problem) -> Result | None:
    """Start and goal validated before solving: OMPL would burn the whole budget on them."""
    bad = [
        which
        for which, q in (("start", problem.start), ("goal", problem.goal))
        if not problem.checker.is_valid(q.tolist())
    ]
    if bad:
        return Result(None, INVALID_QUERY, {"invalid": "+".join(bad)})
    return None
