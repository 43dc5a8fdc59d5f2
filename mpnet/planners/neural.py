"""MPNet's online planner (Algorithms 1-3): NeuralPlanner, lazy states contraction,
the feasibility check, and neural (NR) or hybrid (HR) replanning.

The networks come in as two callables so that planning needs neither torch nor
Lightning: `encode(cloud) -> Z` and `step(Z, x, goal, rng) -> x_next` (Pnet with its
dropout kept on, drawn from `rng`), both in the env's state coordinates.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import replace

import numpy as np

from mpnet.motion import MotionMemo, is_feasible, lazy_states_contraction, steer_to
from mpnet.planners.base import (
    BACKWARD,
    EXACT,
    FORWARD,
    LAST_PATH,
    NO_SOLUTION,
    RANDOM_TRIES,
    TIMEOUT,
    Problem,
    Result,
    check_endpoints,
    sub_seed,
)
from mpnet.settings import NeuralSettings, ablation_of


class MPNetPlanner:
    """MPNet with neural replanning (hybrid=False) or hybrid replanning (hybrid=True).

    cloud(workspace) gives the obstacle point cloud the planner sees (sampled per query,
    its time included). max_steps bounds the first NeuralPlanner call, replan_steps each
    replanning call; replan_rounds bounds neural replanning. HR then plans each segment
    that is still unconnectable with OMPL's RRT* (`fallback`), within the budget left.

    replanning: "original" follows the public code (ahq1993/MPNet, neuralplanner.py) and
    Algorithm 1: a first NeuralPlanner run that does not connect within max_steps fails the
    query, and so does a replanning round that leaves a segment unconnected (HR hands that
    path to the classical planner instead). "forgiving" is CMPNet's neural_replan
    (MiaoDragon/CMPNet, plan_general.py), as this project first ran it: a first run that
    fails leaves [start, goal] to replanning, an unconnected segment waits for the next
    round (and the round goes on with the next segments), and a free straight start-goal
    line is taken before any Pnet call.

    steer_steps: None, steerTo is the continuous check throughout; or the T-RO code's
    coarse-to-fine schedule, the steerTo step of the first NeuralPlanner run and of each
    replanning round (the last entry repeats; an entry None is continuous). Whether a path
    is feasible is always decided by the continuous check. fallback_restart_s: HR restarts
    a segment's RRT* after this long, then after twice that, ... (None: one run).

    proposal: where NeuralPlanner's next state comes from: "pnet" (the network), or, to
    ablate it with everything else unchanged, "random" (a uniformly random valid state),
    "random_any" (a uniformly random state, valid or not, as Pnet's may be) or "straight"
    (a step of straight_step toward the other tree's end, measured in the networks'
    normalised coordinates: state / the bounds' half-widths). encoding ("cloud"
    or "zeros") and dropout record how the networks were wired (mpnet.planners.mpnet); an
    ablated planner may not carry MPNet's own name, so the logs never mix the two.

    Every proposal is kept (stage, the tree end it grew from, the proposal) for
    `diagnose`, which the harness calls after the query's time is taken. A failed query's
    Result.partial holds the two paths of the last NeuralPlanner run that did not connect
    (`forward` from its start, `backward` from its goal, each in the order grown: the
    query's ends in the first run, a segment's in replanning) and the last coarse or
    replanned path, which was not feasible (`last_path`; for HR, the path its fallback
    could not complete). Only references are kept while planning; the states are copied
    when the query fails.
    """

    def __init__(
        self,
        name: str,
        encode: Callable | None,
        step: Callable | None,
        cloud: Callable | None,
        *,
        hybrid: bool = False,
        seed: int = 0,
        fallback=None,
        **settings,
    ):
        """settings: NeuralSettings' (their defaults there); checked, ValueError naming the key."""
        s = NeuralSettings(**settings)
        check_settings(name, **s.shared())
        self.name = name
        self.encode = encode
        self.step = step
        self.cloud = cloud
        self.hybrid = hybrid
        self.max_steps = s.max_steps
        self.replan_steps = s.replan_steps
        self.replan_rounds = s.replan_rounds
        self.rng = np.random.default_rng(seed)
        self.fallback = fallback
        self.steer_steps = list(s.steer_steps) if s.steer_steps else [None]
        self.proposal = s.proposal
        self.fallback_restart_s = None if s.fallback_restart_s is None else float(s.fallback_restart_s)
        self.straight_step = float(s.straight_step)
        self.encoding = s.encoding
        self.dropout = s.dropout
        self.replanning = s.replanning
        self.anytime = s.anytime
        self.trace: list[tuple[int, np.ndarray, np.ndarray]] = []
        self.codes: dict[str, np.ndarray] = {}
        self.last_code = None
        self._trees: tuple[list, list] | None = None  # the last unconnected NeuralPlanner run's paths

    def steer_step(self, stage: int) -> float | None:
        """steerTo's step at stage 0 (first NeuralPlanner run) or replanning round `stage`."""
        return self.steer_steps[min(stage, len(self.steer_steps) - 1)]

    def solve(self, problem: Problem, budget_s: float, *, code=None, first: Callable | None = None) -> Result:
        """The Planner protocol's solve. Batched planning (mpnet.planners.compiled.batched) gives the
        workspace's `code` (encoded once for the batch: no cloud or Enet here) and `first`,
        first(self, stats) -> the first NeuralPlanner run's path or None, run elsewhere."""
        t0 = time.perf_counter()
        deadline = t0 + budget_s
        self.trace, self.last_code, self._trees = [], None, None
        if problem.seed is not None:  # the query's own stream: the same draws whatever ran before
            self.rng = np.random.default_rng(sub_seed(problem.seed, 1))
        bad = check_endpoints(problem)
        if bad is not None:
            return bad
        stats = {
            "pnet_calls": 0,
            "replans": 0,
            "fallback_used": False,
            **dict.fromkeys(SPLIT_KEYS, 0.0),
        }
        if code is None:
            t = time.perf_counter()
            cloud = self.cloud(problem.workspace)
            stats["cloud_s"] = time.perf_counter() - t
            code = self.encode(cloud)
            stats["encode_s"] = time.perf_counter() - t  # the cloud and Enet: what plan_s leaves out
        z = self.last_code = code
        raw = problem.checker  # HR's classical planner checks on it directly
        problem = replace(problem, checker=MotionMemo(raw))
        if self.anytime:
            stats["restarts"] = 0
        while True:
            result = self._attempt(problem, raw, z, stats, deadline, first)
            if result.path is not None or not self.anytime:
                return result
            if time.perf_counter() > deadline:  # anytime ends on the budget: a timeout, whenever its last run failed
                return replace(result, status=TIMEOUT) if result.status == NO_SOLUTION else result
            stats["restarts"] += 1  # anytime: the paper's loop again, its draws (dropout, proposals) fresh
            first = None

    def _attempt(self, problem: Problem, raw, z, stats: dict, deadline: float, first: Callable | None) -> Result:
        """One run of the paper's loop (Algorithm 1; HR's fallback at its end): the first
        NeuralPlanner run, its contraction, replanning rounds until the path is feasible."""
        checker = problem.checker
        forgiving = self.replanning == "forgiving"
        start, goal = problem.start.astype(float), problem.goal.astype(float)
        step = self.steer_step(0)
        if first is None:
            path = self.neural_planner(problem, z, start, goal, self.max_steps, stats, deadline, step, 0, forgiving)
        else:
            path = first(self, stats)
        if path is None:
            if not forgiving:  # Algorithm 1: no coarse path, no replanning
                return self.failed(deadline, stats)
            path = [start, goal]  # every segment of [start, goal] is left to replanning
        else:
            path = self.contract(checker, path, step, stats)
        ok = self.feasible(checker, path, stats)
        rounds = 0
        while not ok and rounds < self.replan_rounds:
            if time.perf_counter() > deadline:
                return self.failed(deadline, stats, path)
            rounds += 1
            stats["replans"] += 1
            step = self.steer_step(rounds)
            t, inner = time.perf_counter(), stats["pnet_s"] + stats["steer_s"]
            path, stuck = self.replan(problem, z, path, stats, deadline, step)
            stats["replan_s"] += time.perf_counter() - t - (stats["pnet_s"] + stats["steer_s"] - inner)
            path = self.contract(checker, path, step, stats)
            if stuck and not forgiving and not self.hybrid:  # the public code: an unconnected segment fails the query
                return self.failed(deadline, stats, path)
            ok = self.feasible(checker, path, stats)
            if stuck and not forgiving:
                break  # HR: the classical planner takes the path as it stands
        if not ok and self.hybrid:
            stats["fallback_used"] = True
            t, handed = time.perf_counter(), path
            path = self.classical_replan(problem, path, deadline, stats, raw)
            stats["fallback_s"] += time.perf_counter() - t
            if path is not None:
                path = self.contract(checker, path, None, stats)
                ok = self.feasible(checker, path, stats)
            else:
                path = handed
        if not ok:
            return self.failed(deadline, stats, path)
        path = [problem.start.tolist(), *_states(path[1:-1]), problem.goal.tolist()]
        return Result(path, EXACT, stats)

    def failed(self, deadline: float, stats: dict, path=None) -> Result:
        """A failed query's Result (timeout past the deadline), with what the planner had
        (Result.partial): the states are copied here, never while planning."""
        status = TIMEOUT if time.perf_counter() > deadline else NO_SOLUTION
        partial = {}
        if self._trees is not None:
            partial[FORWARD], partial[BACKWARD] = map(_states, self._trees)
        if path is not None:
            partial[LAST_PATH] = _states(path)
        return Result(None, status, stats, partial or None)

    @staticmethod
    def contract(checker, path, step, stats: dict) -> list:
        """lazy_states_contraction, its time in stats["contract_s"]."""
        t = time.perf_counter()
        out = lazy_states_contraction(checker, path, step)
        stats["contract_s"] += time.perf_counter() - t
        return out

    @staticmethod
    def feasible(checker, path, stats: dict) -> bool:
        """is_feasible, its time in stats["feasible_s"]."""
        t = time.perf_counter()
        ok = is_feasible(checker, path)
        stats["feasible_s"] += time.perf_counter() - t
        return ok

    def propose(self, problem: Problem, z, x, target) -> np.ndarray:
        """NeuralPlanner's next state from x toward the other tree's end `target`."""
        if self.proposal == "pnet":
            return np.asarray(self.step(z, x, target, self.rng), float)
        spec = problem.spec
        if self.proposal == "random":
            return random_valid_state(spec, problem.checker, self.rng)
        if self.proposal == "random_any":
            return spec.space.sample(self.rng)
        return straight_step(spec, x, target, self.straight_step)

    def neural_planner(
        self,
        problem: Problem,
        z,
        start,
        goal,
        max_steps: int,
        stats: dict,
        deadline: float,
        step: float | None = None,
        stage: int = 0,
        precheck: bool = False,
    ):
        """Algorithm 2: grow a path from each end by Pnet, alternating, until steer_to
        connects their tips; None when max_steps pass first. precheck: first try the
        straight line start-goal (not in Algorithm 2)."""
        checker = problem.checker
        a, b = [start], [goal]
        if precheck and steer_to(checker, start.tolist(), goal.tolist(), step):
            return [start, goal]
        for _ in range(max_steps):
            if time.perf_counter() > deadline:
                break
            t = time.perf_counter()
            x_new = self.propose(problem, z, a[-1], b[-1])
            stats["pnet_s"] += time.perf_counter() - t
            stats["pnet_calls"] += 1
            self.trace.append((stage, a[-1], x_new))
            a.append(x_new)
            t = time.perf_counter()
            connected = steer_to(checker, a[-1].tolist(), b[-1].tolist(), step)
            stats["steer_s"] += time.perf_counter() - t
            if connected:
                return a + b[::-1] if a[0] is start else b + a[::-1]
            a, b = b, a
        self._trees = (a, b) if a[0] is start else (b, a)  # references only: copied if the query fails
        return None

    def replan(self, problem: Problem, z, path, stats: dict, deadline: float, step: float | None = None):
        """Algorithm 3 (neural): replan each unconnectable pair with a short NeuralPlanner
        run. Returns (path, stuck): stuck when a pair stayed unconnected; the original
        replanning stops the round there (the rest of the path kept as it was), the
        forgiving one goes on with the next pairs."""
        stage = stats["replans"]

        def connect(x, y):
            mini = self.neural_planner(problem, z, x, y, self.replan_steps, stats, deadline, step, stage)
            return None if mini is None else mini[1:-1]

        return self.repair(problem.checker, path, connect, step, stop_on_fail=self.replanning == "original")

    def classical_replan(self, problem: Problem, path, deadline: float, stats: dict, checker):
        """HR: RRT* on every segment that is still unconnectable, within the budget left;
        None when one of them fails.

        With fallback_restart_s, each segment's RRT* restarts from scratch after
        fallback_restart_s, then twice that, and so on: in narrow passages RRT*'s time to a
        first solution is heavy-tailed (on one rigid query: 0.5 s, 2.6 s, > 10 s in three
        runs), and restarts cut the tail."""

        def connect(x, y):
            slice_s = self.fallback_restart_s
            while (left := deadline - time.perf_counter()) > 0:
                calls = stats.get("fallback_calls", 0)
                seed = None if problem.seed is None else sub_seed(problem.seed, 2, calls)
                res = self.fallback.solve(
                    Problem(problem.spec, problem.workspace, checker, x, y, seed=seed),
                    left if slice_s is None else min(left, slice_s),
                )
                stats["fallback_calls"] = stats.get("fallback_calls", 0) + 1
                if res.solved:
                    return [np.asarray(q, float) for q in res.path[1:-1]]
                if slice_s is None or res.status != TIMEOUT:
                    return None
                slice_s *= 2
            return None

        path, stuck = self.repair(problem.checker, path, connect, stop_on_fail=True)
        return None if stuck else path

    def repair(self, checker, path, connect, step: float | None = None, stop_on_fail: bool = False):
        """_repair with this planner's checks (a subclass may check elsewhere: the compiled
        planner, on its compiled memo)."""
        return _repair(checker, path, connect, step, stop_on_fail)

    def diagnose(self, problem: Problem, result: Result) -> dict:
        """What Pnet proposed in the last solve and how good it was (not timed: the harness
        calls this after the query; mpnet.planners.diagnostics)."""
        from mpnet.planners.diagnostics import query_diagnostics

        return query_diagnostics(self, problem)


# Where an MPNet query's time goes, disjoint (seconds, in every query's stats): the point
# cloud, Pnet's steps, NeuralPlanner's steerTo checks, the feasibility checks, lazy states
# contraction, replanning's own work beside its Pnet and steerTo (dropping colliding states,
# checking segments) and HR's classical planner. `encode_s` is the cloud and Enet together.
SPLIT_KEYS = ("cloud_s", "encode_s", "pnet_s", "steer_s", "feasible_s", "contract_s", "replan_s", "fallback_s")

# The T-RO code's steerTo schedule (CMPNet gem_eval.py): 2.0 for the first run (t = 0) and
# round 1, then 1.2, 0.5, and 0.1 from round 4 on.
TRO_STEER_STEPS = (2.0, 2.0, 1.2, 0.5, 0.1)
PROPOSALS = ("pnet", "random", "random_any", "straight")
REPLANNING = ("original", "forgiving")
ENCODINGS = ("cloud", "zeros")
BASE_NAMES = ("mpnet_nr", "mpnet_hr")


def _count(key: str, value, least: int) -> None:
    if isinstance(value, bool) or not isinstance(value, int) or value < least:
        raise ValueError(f"config key planner.{key}: expected an integer >= {least}, got {value!r}")


def _positive(value) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value) and value > 0


def check_settings(
    name: str,
    *,
    max_steps,
    replan_steps,
    replan_rounds,
    steer_steps,
    proposal,
    straight_step,
    fallback_restart_s,
    encoding,
    dropout,
    replanning="original",
    anytime=False,
    clip=False,
) -> None:
    """Every MPNet setting, checked once: ValueError naming the config key."""
    _count("max_steps", max_steps, 1)
    _count("replan_steps", replan_steps, 1)
    _count("replan_rounds", replan_rounds, 0)
    if steer_steps is not None and (
        isinstance(steer_steps, (str, bytes))
        or not hasattr(steer_steps, "__iter__")
        or not all(x is None or _positive(x) for x in steer_steps)
    ):
        raise ValueError(
            f"config key planner.steer_steps: expected null or a list of positive steps "
            f"(null entries: continuous), got {steer_steps!r}"
        )
    if proposal not in PROPOSALS:
        raise ValueError(f"config key planner.proposal: expected one of {', '.join(PROPOSALS)}, got {proposal!r}")
    if not _positive(straight_step):
        raise ValueError(f"config key planner.straight_step: expected a positive step, got {straight_step!r}")
    if fallback_restart_s is not None and not _positive(fallback_restart_s):
        raise ValueError(
            f"config key planner.fallback_restart_s: expected null or a positive number of seconds, "
            f"got {fallback_restart_s!r}"
        )
    if encoding not in ENCODINGS:
        raise ValueError(f"config key planner.encoding: expected one of {', '.join(ENCODINGS)}, got {encoding!r}")
    if not isinstance(dropout, bool):
        raise ValueError(f"config key planner.dropout: expected true or false, got {dropout!r}")
    if replanning not in REPLANNING:
        raise ValueError(f"config key planner.replanning: expected one of {', '.join(REPLANNING)}, got {replanning!r}")
    if not isinstance(clip, bool):
        raise ValueError(f"config key planner.clip: expected true or false, got {clip!r}")
    if not isinstance(anytime, bool):
        raise ValueError(f"config key planner.anytime: expected true or false, got {anytime!r}")
    ablated = ablation_of(
        proposal=proposal, encoding=encoding, dropout=dropout, replanning=replanning, anytime=anytime, clip=clip
    )
    if ablated and name in BASE_NAMES:
        raise ValueError(
            f"config key planner.name: an ablation ({ablated}) is logged under its own name, "
            f"not {name!r}: use its config (+planner=mpnet_nr_random, ...) or set planner.name"
        )


def random_valid_state(spec, checker, rng: np.random.Generator, tries: int = RANDOM_TRIES) -> np.ndarray:
    """A uniformly random valid state (rejection sampling in the state bounds); after
    `tries` invalid draws the last one, which replanning then drops."""
    for _ in range(tries):
        q = spec.space.sample(rng)
        if checker.is_valid(q.tolist()):
            break
    return q


def straight_step(spec, x, target, length: float) -> np.ndarray:
    """x moved toward target by `length` in normalised coordinates (state / the bounds'
    half-widths; angles along the shorter arc), or to target when closer."""
    space = spec.space
    d = space.difference(x, target)
    norm = float(np.linalg.norm(d / space.half_widths()))
    nxt = np.asarray(x, float) + (d if norm <= length else d * (length / norm))
    return space.wrap(nxt)


def _states(path) -> list[list[float]]:
    """A copy of a path's states as plain lists."""
    return [np.asarray(q, float).tolist() for q in path]


def _repair(checker, path, connect, step: float | None = None, stop_on_fail: bool = False):
    """repair_path with the checker's is_valid and steer_to."""
    return repair_path(
        lambda q: checker.is_valid(np.asarray(q).tolist()),
        lambda x, y: steer_to(checker, np.asarray(x).tolist(), np.asarray(y).tolist(), step),
        path,
        connect,
        stop_on_fail,
    )


def repair_path(is_valid, steer, path, connect, stop_on_fail: bool = False):
    """Drop interior states in collision (start and goal are valid), keep neighbours
    steer(x, y) connects, and put connect(x, y)'s states between the others. Returns
    (path, stuck): stuck when connect gave None for a pair, which stays as it was; with
    stop_on_fail the rest of the path is then kept unchanged."""
    states = [path[0], *[q for q in path[1:-1] if is_valid(q)], path[-1]]
    out = [states[0]]
    stuck = False
    for k, (x, y) in enumerate(zip(states[:-1], states[1:])):
        if not steer(x, y):
            mid = connect(np.asarray(x, float), np.asarray(y, float))
            if mid is None:
                stuck = True
                if stop_on_fail:
                    return out + states[k + 1 :], True
            else:
                out.extend(mid)
        out.append(y)
    return out, stuck
