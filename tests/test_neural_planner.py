"""MPNet's planning machinery (NeuralPlanner, LSC, replanning, HR fallback) driven by
simple proposal functions in place of a trained Pnet."""

import numpy as np
import pytest

from mpnet.data.queries import make_queries
from mpnet.envs import Workspace, get_spec
from mpnet.envs.generators import make_workspace
from mpnet.motion import verify_path
from mpnet.planners import EXACT, INVALID_QUERY, Problem
from mpnet.planners.classical import OmplPlanner
from mpnet.planners.neural import MPNetPlanner

S2D = get_spec("s2d")
CLOUD = lambda ws: S2D.cloud(ws, 200, 0)  # noqa: E731


def straight(step_len=3.0):
    def step(z, x, goal, rng):
        d = goal - x
        n = np.linalg.norm(d[:2])
        return x + d * min(1.0, step_len / max(n, 1e-9)) + rng.normal(0, 0.5, size=x.shape)

    return step


def random_free(spec, ws):
    checker = spec.make_checker(ws)

    def step(z, x, goal, rng):
        while True:
            q = rng.uniform(spec.lower, spec.upper)
            if checker.is_valid(q.tolist()):
                return q

    return step


def make(step, hybrid, seed=0, steer_steps=None):
    return MPNetPlanner(
        "mpnet_hr" if hybrid else "mpnet_nr",
        encode=lambda cloud: np.zeros(4),
        step=step,
        cloud=CLOUD,
        hybrid=hybrid,
        seed=seed,
        fallback=OmplPlanner("rrt_star", "rrt_star") if hybrid else None,
        steer_steps=steer_steps,
    )


@pytest.mark.parametrize("hybrid", [False, True])
def test_plans_verified_paths(hybrid):
    ws = make_workspace(S2D, 3, "seen")
    queries = make_queries(S2D, ws, 15, seed=1, split="seen")
    ok = 0
    for q in queries:
        p = Problem(S2D, ws, S2D.make_checker(ws), q.start, q.goal)
        res = make(random_free(S2D, ws), hybrid).solve(p, 5.0)
        if res.status == EXACT:
            assert verify_path(S2D, ws, res.path, q.start, q.goal) is None
            assert res.path[0] == q.start.tolist() and res.path[-1] == q.goal.tolist()
            ok += 1
        assert res.stats["pnet_calls"] > 0
    assert ok == 15 if hybrid else ok >= 12


def test_hybrid_falls_back_when_proposals_are_useless():
    """Proposals stuck at the start: NR fails, HR's RRT* still solves it."""
    ws = Workspace("wall", "file", [[0.0, 0.0]], [[4.0, 30.0]])
    p = Problem(S2D, ws, S2D.make_checker(ws), np.array([-10.0, 0.0]), np.array([10.0, 0.0]))
    stuck = lambda z, x, goal, rng: x  # noqa: E731
    nr = make(stuck, False).solve(p, 2.0)
    assert not nr.solved and nr.stats["replans"] == 10
    hr = make(stuck, True).solve(p, 5.0)
    assert hr.solved and hr.stats["fallback_used"] and verify_path(S2D, ws, hr.path, p.start, p.goal) is None


def test_invalid_query_fails_fast():
    ws = Workspace("wall", "file", [[0.0, 0.0]], [[4.0, 30.0]])
    p = Problem(S2D, ws, S2D.make_checker(ws), np.array([0.0, 0.0]), np.array([10.0, 0.0]))
    assert make(straight(), True).solve(p, 5.0).status == INVALID_QUERY


def test_same_seed_same_path():
    ws = make_workspace(S2D, 4, "seen")
    q = make_queries(S2D, ws, 1, seed=2, split="seen")[0]
    paths = [
        make(straight(), False, seed=7).solve(Problem(S2D, ws, S2D.make_checker(ws), q.start, q.goal), 5.0).path
        for _ in range(2)
    ]
    assert paths[0] == paths[1]


def test_coarse_to_fine_steer_steps():
    """With the T-RO schedule the coarse steps (2.0, 1.2, 0.5) all miss the 0.4-wide wall
    between start and goal; the continuous feasibility check refuses [start, goal] each
    round, and the 0.1 round sees the wall and replans over it."""
    thin = Workspace("thin", "file", [[0.0, 0.0]], [[0.4, 30.0]])
    p = Problem(S2D, thin, S2D.make_checker(thin), np.array([-5.5, 0.0]), np.array([4.5, 0.0]))
    over = lambda z, x, goal, rng: np.array([x[0] / 2, 17.5])  # noqa: E731  (a waypoint above the wall)
    planner = make(over, False, steer_steps=[2.0, 2.0, 2.0, 1.2, 0.5, 0.1, None])
    assert [planner.steer_step(i) for i in (0, 3, 5, 6, 50)] == [2.0, 1.2, 0.1, None, None]
    res = planner.solve(p, 5.0)
    assert res.solved and verify_path(S2D, thin, res.path, p.start, p.goal) is None
    assert res.stats["replans"] == 5 and res.stats["pnet_calls"] == 2
    continuous = make(over, False).solve(p, 5.0)
    assert continuous.solved and continuous.stats["replans"] == 0
    assert make(over, False).steer_step(4) is None


def test_straight_step_known_answers():
    from mpnet.planners.neural import straight_step

    assert straight_step(S2D, np.array([0.0, 0.0]), np.array([20.0, 0.0]), 0.1).tolist() == pytest.approx([2.0, 0.0])
    assert straight_step(S2D, np.array([0.0, 0.0]), np.array([1.0, 1.0]), 0.1).tolist() == [1.0, 1.0]
    rigid = get_spec("rigid")
    nxt = straight_step(rigid, np.array([0.0, 0.0, 3.0]), np.array([0.0, 0.0, -3.0]), 0.05)
    assert nxt[2] == pytest.approx(3.0 + 0.05 * np.pi) or nxt[2] == pytest.approx(3.0 + 0.05 * np.pi - 2 * np.pi)


def never(*_):
    raise AssertionError("Pnet was asked for a proposal")


@pytest.mark.parametrize("proposal", ["random", "straight"])
def test_ablated_proposals_never_call_pnet(proposal):
    """proposal=random / straight replace Pnet and keep the rest: NR's paths still verify,
    HR still solves every query."""
    ws = make_workspace(S2D, 4, "seen")
    queries = make_queries(S2D, ws, 8, seed=3, split="seen")
    for hybrid in (False, True):
        planner = MPNetPlanner(
            "x",
            encode=lambda cloud: np.zeros(4),
            step=never,
            cloud=CLOUD,
            hybrid=hybrid,
            fallback=OmplPlanner("rrt_star", "rrt_star") if hybrid else None,
            proposal=proposal,
        )
        solved = 0
        for q in queries:
            res = planner.solve(Problem(S2D, ws, S2D.make_checker(ws), q.start, q.goal), 5.0)
            if res.solved:
                assert verify_path(S2D, ws, res.path, q.start, q.goal) is None
                solved += 1
        assert solved == len(queries) if hybrid else solved >= (6 if proposal == "random" else 0)


def test_random_proposals_are_valid_states():
    from mpnet.planners.neural import random_valid_state

    ws = make_workspace(S2D, 1, "seen")
    checker = S2D.make_checker(ws)
    rng = np.random.default_rng(0)
    states = [random_valid_state(S2D, checker, rng) for _ in range(50)]
    assert all(checker.is_valid(q.tolist()) for q in states)
    assert len({tuple(q) for q in states}) == 50


def test_unknown_proposal_names_its_key():
    with pytest.raises(ValueError, match="planner.proposal"):
        MPNetPlanner("x", encode=None, step=None, cloud=None, proposal="bogus")


class FlakyFallback:
    """A fallback that times out on its first `misses` calls (using its whole slice), then
    hands the real RRT*'s path back; records the budget of every call."""

    def __init__(self, misses: int):
        self.misses, self.budgets = misses, []
        self.real = OmplPlanner("rrt_star", "rrt_star")

    def solve(self, problem, budget_s):
        import time

        from mpnet.planners import Result

        self.budgets.append(budget_s)
        if len(self.budgets) <= self.misses:
            time.sleep(budget_s)
            return Result(None, "timeout", {})
        return self.real.solve(problem, budget_s)


def test_hybrid_restarts_a_timed_out_fallback_with_doubling_slices():
    """HR's RRT* is restarted after 0.05 s, then 0.1 s, 0.2 s: the third run solves."""
    ws = Workspace("wall", "file", [[0.0, 0.0]], [[4.0, 30.0]])
    p = Problem(S2D, ws, S2D.make_checker(ws), np.array([-10.0, 0.0]), np.array([10.0, 0.0]))
    stuck = lambda z, x, goal, rng: x  # noqa: E731
    fallback = FlakyFallback(misses=2)
    planner = MPNetPlanner(
        "mpnet_hr",
        encode=lambda cloud: np.zeros(4),
        step=stuck,
        cloud=CLOUD,
        hybrid=True,
        fallback=fallback,
        fallback_restart_s=0.05,
    )
    res = planner.solve(p, 5.0)
    assert res.solved and verify_path(S2D, ws, res.path, p.start, p.goal) is None
    assert fallback.budgets == pytest.approx([0.05, 0.1, 0.2])
    assert res.stats["fallback_calls"] == 3
    once = FlakyFallback(misses=1)
    planner = MPNetPlanner(
        "mpnet_hr",
        encode=lambda cloud: np.zeros(4),
        step=stuck,
        cloud=CLOUD,
        hybrid=True,
        fallback=once,
        fallback_restart_s=None,
    )
    res = planner.solve(p, 0.5)  # one run with the whole budget left: it times out, nothing is left
    assert not res.solved and len(once.budgets) == 1 and once.budgets[0] > 0.4
