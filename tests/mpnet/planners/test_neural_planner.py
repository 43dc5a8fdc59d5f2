"""MPNet's planning machinery (NeuralPlanner, LSC, replanning, HR fallback) driven by
simple proposal functions in place of a trained Pnet."""

from dataclasses import replace

import numpy as np
import pytest

from mpnet.data.queries import make_queries
from mpnet.envs import Workspace, get_spec
from mpnet.envs.scenes.generators import make_workspace
from mpnet.motion import verify_path
from mpnet.planners import EXACT, INVALID_QUERY, NO_SOLUTION, Problem
from mpnet.planners.classical import OmplPlanner
from mpnet.planners.mpnet import MPNetSettings
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


def make(step, hybrid, seed=0, steer_steps=None, replanning="original"):
    base = "mpnet_hr" if hybrid else "mpnet_nr"
    return MPNetPlanner(
        base if replanning == "original" else f"{base}_{replanning}",
        encode=lambda cloud: np.zeros(4),
        step=step,
        cloud=CLOUD,
        hybrid=hybrid,
        seed=seed,
        fallback=OmplPlanner("rrt_star", "rrt_star") if hybrid else None,
        steer_steps=steer_steps,
        replanning=replanning,
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


WALL = Workspace("wall", "file", [[0.0, 0.0]], [[4.0, 30.0]])


def wall_problem():
    return Problem(S2D, WALL, S2D.make_checker(WALL), np.array([-10.0, 0.0]), np.array([10.0, 0.0]))


def stuck(z, x, goal, rng):
    return x


def test_hybrid_falls_back_when_proposals_are_useless():
    """Proposals stuck at the start, forgiving replanning: NR gives up after its 10 rounds,
    HR's RRT* still solves it."""
    p = wall_problem()
    nr = make(stuck, False, replanning="forgiving").solve(p, 2.0)
    assert not nr.solved and nr.stats["replans"] == 10
    hr = make(stuck, True, replanning="forgiving").solve(p, 5.0)
    assert hr.solved and hr.stats["fallback_used"] and verify_path(S2D, WALL, hr.path, p.start, p.goal) is None


@pytest.mark.parametrize("hybrid", [False, True])
def test_original_replanning_fails_when_the_first_run_does_not_connect(hybrid):
    """Algorithm 1 and the public code: no coarse path after max_steps, no replanning, no
    fallback: the query fails (HR too) after exactly max_steps Pnet calls."""
    res = make(stuck, hybrid).solve(wall_problem(), 5.0)
    assert not res.solved and res.status == "no_solution"
    counts = {k: v for k, v in res.stats.items() if not k.endswith("_s")}
    assert counts == {"pnet_calls": 80, "replans": 0, "fallback_used": False}
    assert res.stats["fallback_s"] == 0.0 and 0 < res.stats["pnet_s"] and 0 < res.stats["encode_s"]


def test_original_nr_fails_on_a_segment_replanning_cannot_connect_and_hr_hands_it_on():
    """A coarse path whose segments pass through the wall; replanning cannot connect one:
    original NR fails the query in round 1, HR stops neural replanning there and RRT*
    solves; forgiving NR goes through all 10 rounds."""
    p = wall_problem()

    def through(z, x, goal, rng):  # the first proposal lands right of the wall; then stuck
        return np.array([5.0, 0.0]) if np.allclose(x, p.start) and goal[0] == 10.0 else x

    nr = make(through, False).solve(p, 5.0)
    assert not nr.solved and nr.stats["replans"] == 1 and nr.stats["pnet_calls"] == 1 + 50
    hr = make(through, True).solve(p, 5.0)
    assert hr.solved and hr.stats["replans"] == 1 and hr.stats["fallback_used"]
    assert verify_path(S2D, WALL, hr.path, p.start, p.goal) is None
    forgiving = make(through, False, replanning="forgiving").solve(wall_problem(), 5.0)
    assert not forgiving.solved and forgiving.stats["replans"] == 10


def test_original_skips_the_straight_line_precheck_forgiving_takes_it():
    """A free start-goal line: forgiving returns it with no Pnet call; the original asks
    Pnet first (Algorithm 2 has no such check), then connects and contracts to it."""
    ws = Workspace("empty", "file", [[15.0, 15.0]], [[1.0, 1.0]])
    p = Problem(S2D, ws, S2D.make_checker(ws), np.array([-10.0, 0.0]), np.array([10.0, 0.0]))
    forgiving = make(straight(), False, replanning="forgiving").solve(p, 5.0)
    assert forgiving.solved and forgiving.stats["pnet_calls"] == 0
    original = make(straight(), False).solve(p, 5.0)
    assert original.solved and original.stats["pnet_calls"] == 1 and len(original.path) == 2


def test_forgiving_is_a_named_variant():
    with pytest.raises(ValueError, match="replanning=forgiving"):
        MPNetPlanner("mpnet_nr", None, None, None, replanning="forgiving")
    with pytest.raises(ValueError, match="planner.replanning"):
        MPNetPlanner("x", None, None, None, replanning="lenient")


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
    planner = make(over, False, steer_steps=[2.0, 2.0, 1.2, 0.5, 0.1, None])
    assert [planner.steer_step(i) for i in (0, 2, 4, 5, 50)] == [2.0, 1.2, 0.1, None, None]
    res = planner.solve(p, 5.0)
    assert res.solved and verify_path(S2D, thin, res.path, p.start, p.goal) is None
    # Two Pnet calls in the first run (Algorithm 2 has no straight-line pre-check), two in
    # the 0.1 round: rounds 1-3 (2.0, 1.2, 0.5) replan nothing, their steps miss the wall.
    assert res.stats["replans"] == 4 and res.stats["pnet_calls"] == 4
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


@pytest.mark.parametrize("proposal", ["random", "random_any", "straight"])
def test_ablated_proposals_never_call_pnet(proposal):
    """proposal=random / random_any / straight replace Pnet and keep the rest: NR's paths
    still verify, HR (forgiving, so that a failed first run still reaches RRT*) solves every
    query."""
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
            replanning="forgiving",
        )
        solved = 0
        for q in queries:
            res = planner.solve(Problem(S2D, ws, S2D.make_checker(ws), q.start, q.goal), 5.0)
            if res.solved:
                assert verify_path(S2D, ws, res.path, q.start, q.goal) is None
                solved += 1
        assert solved == len(queries) if hybrid else solved >= (6 if proposal.startswith("random") else 0)


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
    ws = WALL
    p = wall_problem()
    fallback = FlakyFallback(misses=2)
    planner = MPNetPlanner(
        "mpnet_hr_forgiving",
        encode=lambda cloud: np.zeros(4),
        step=stuck,
        cloud=CLOUD,
        hybrid=True,
        fallback=fallback,
        fallback_restart_s=0.05,
        replanning="forgiving",
    )
    res = planner.solve(p, 5.0)
    assert res.solved and verify_path(S2D, ws, res.path, p.start, p.goal) is None
    assert fallback.budgets == pytest.approx([0.05, 0.1, 0.2])
    assert res.stats["fallback_calls"] == 3
    once = FlakyFallback(misses=1)
    planner = MPNetPlanner(
        "mpnet_hr_forgiving",
        encode=lambda cloud: np.zeros(4),
        step=stuck,
        cloud=CLOUD,
        hybrid=True,
        fallback=once,
        fallback_restart_s=None,
        replanning="forgiving",
    )
    res = planner.solve(p, 0.5)  # one run with the whole budget left: it times out, nothing is left
    assert not res.solved and len(once.budgets) == 1 and once.budgets[0] > 0.4


def test_tro_schedule_matches_the_public_code(repo):
    """CMPNet's gem_eval.py: step 2.0 at t = 0 (the first run) and 1, 1.2 at t = 2, 0.5 at
    t = 3, 0.1 after; the documented schedule gives the same step at every stage."""
    from mpnet.planners.neural import TRO_STEER_STEPS

    def public(t):
        return 1.2 if t == 2 else 0.5 if t == 3 else 0.1 if t > 3 else 2.0

    planner = make(stuck, False, steer_steps=list(TRO_STEER_STEPS))
    assert [planner.steer_step(t) for t in range(11)] == [public(t) for t in range(11)]
    listed = "[" + ", ".join(map(str, TRO_STEER_STEPS)) + "]"
    assert listed in (repo / "conf/planner/mpnet_nr.yaml").read_text()  # mpnet_hr's settings are mpnet_nr's
    assert listed.replace(" ", "") in (repo / "README.md").read_text()


@pytest.mark.parametrize("hybrid", [False, True])
def test_time_split_is_disjoint_and_within_the_query(hybrid):
    """Every query's stats say where its time went (harness.perf's split): each part is
    non-negative, the cloud is part of encode_s, and the disjoint parts sum to at most
    the query's own time."""
    import time

    from mpnet.planners.neural import SPLIT_KEYS

    ws = make_workspace(S2D, 3, "seen")
    for q in make_queries(S2D, ws, 5, seed=2, split="seen"):
        p = Problem(S2D, ws, S2D.make_checker(ws), q.start, q.goal)
        t = time.perf_counter()
        res = make(random_free(S2D, ws), hybrid).solve(p, 5.0)
        wall = time.perf_counter() - t
        s = res.stats
        assert all(s[k] >= 0.0 for k in SPLIT_KEYS)
        assert s["cloud_s"] <= s["encode_s"]
        disjoint = sum(s[k] for k in SPLIT_KEYS if k != "cloud_s")
        assert disjoint <= wall
        assert s["pnet_s"] > 0 and s["feasible_s"] > 0


def test_plan_s_leaves_out_the_encoding():
    from harness.bench.loop import plan_time

    assert plan_time(0.010, {"encode_s": 0.004}) == pytest.approx(0.006)
    assert plan_time(0.010, {}) == 0.010  # a classical planner encodes nothing
    assert plan_time(0.001, {"encode_s": 0.002}) == 0.0  # never negative


def test_motion_memo_changes_no_decision(monkeypatch):
    """The memo is pure speed: the same seed plans the same paths with and without it."""
    import mpnet.planners.neural as neural

    ws = make_workspace(S2D, 4, "seen")
    queries = make_queries(S2D, ws, 8, seed=3, split="seen")

    def paths():
        planner = make(straight(), hybrid=False, seed=5)
        return [planner.solve(Problem(S2D, ws, S2D.make_checker(ws), q.start, q.goal), 5.0).path for q in queries]

    with_memo = paths()
    monkeypatch.setattr(neural, "MotionMemo", lambda checker: checker)
    assert paths() == with_memo
    assert any(p is not None for p in with_memo)


def test_a_seeded_problem_plans_the_same_whatever_ran_before():
    """Problem.seed: the query's own draws, so a resumed run (other queries before it, or
    none) plans it as an uninterrupted run does."""
    ws = make_workspace(S2D, 4, "seen")
    qs = make_queries(S2D, ws, 4, seed=2, split="seen")
    planner = make(straight(), False, seed=7)

    def proposals(q, seed):
        planner.solve(Problem(S2D, ws, S2D.make_checker(ws), q.start, q.goal, seed=seed), 5.0)
        return [p.tolist() for _, _, p in planner.trace]

    in_order = [proposals(q, 100 + i) for i, q in enumerate(qs)]
    assert in_order[3] and proposals(qs[3], 103) == in_order[3]
    assert proposals(qs[3], 104) != in_order[3]  # the seed does decide the draws


def test_clipped_proposals_stay_in_the_joint_bounds():
    """mpnet_nr_clip: a Pnet proposal past a joint limit is held at it; angles still wrap."""
    from mpnet.envs import get_spec

    arm = get_spec("panda_mbm").space
    q = arm.upper + np.array([0.5, -0.1, 0, 0, 0, 2.0, 0])
    out = arm.clip(q)
    assert arm.in_bounds(out) and out[1] == q[1] and out[0] == arm.upper[0] and out[5] == arm.upper[5]
    rigid = get_spec("rigid").space
    np.testing.assert_allclose(rigid.clip([25.0, -3.0, 3.5]), [20.0, -3.0, 3.5 - 2 * np.pi])
    with pytest.raises(ValueError, match="planner.clip"):
        MPNetSettings(name="mpnet_nr_clip", clip="yes")
    with pytest.raises(ValueError, match="planner.name"):
        MPNetSettings(name="mpnet_nr", clip=True)


def stuck_at_first(calls: int):
    """Proposals stuck at the tree's end for the first `calls` calls, then random valid states."""
    count, go = [0], random_free(S2D, WALL)

    def step(z, x, goal, rng):
        count[0] += 1
        return x if count[0] <= calls else go(z, x, goal, rng)

    return step


def anytime(step, budget_s, **settings):
    planner = MPNetPlanner("mpnet_nr_anytime", lambda cloud: np.zeros(4), step, CLOUD, anytime=True, **settings)
    return planner.solve(wall_problem(), budget_s)


def test_anytime_restarts_the_papers_loop_until_it_succeeds():
    """The paper's NR gives up when its first run does not connect; anytime runs the loop again
    (its proposals no longer stuck) until a run solves it."""
    p = wall_problem()
    assert not make(stuck_at_first(80), False).solve(p, 5.0).solved
    res = anytime(stuck_at_first(80), 5.0)
    assert res.solved and res.stats["restarts"] >= 1 and verify_path(S2D, WALL, res.path, p.start, p.goal) is None
    assert res.stats["pnet_calls"] > 80  # every run counted


def test_anytime_stops_at_the_budget():
    anytime(stuck, 0.05)  # the checks' kernels loaded first (run alone, their load took the whole budget)
    res = anytime(stuck, 0.3)
    assert not res.solved and res.status == "timeout" and res.stats["restarts"] >= 2
    # each run before the last makes its 80 calls; the last, cut by the budget, 0 to 80 (0 when the
    # budget ends as it starts: seen once in a loaded run, 138,240 calls at 1,728 restarts)
    assert 80 * res.stats["restarts"] <= res.stats["pnet_calls"] <= 80 * (res.stats["restarts"] + 1)


def test_anytime_that_ran_out_is_a_timeout_even_if_its_last_run_failed_before_the_deadline(monkeypatch):
    """A run that failed just before the deadline said no_solution, and anytime, finding the
    budget spent, returned it (seen once in a loaded full suite): anytime ends on its budget."""
    failed = MPNetPlanner.failed

    def early(self, deadline, stats, path=None):  # every run's failure decided before the deadline
        return replace(failed(self, deadline, stats, path), status=NO_SOLUTION)

    monkeypatch.setattr(MPNetPlanner, "failed", early)
    res = anytime(stuck, 0.05)
    assert not res.solved and res.status == "timeout" and res.stats["restarts"] >= 1


def test_anytime_is_a_named_variant():
    with pytest.raises(ValueError, match="anytime=true"):
        MPNetPlanner("mpnet_nr", None, None, None, anytime=True)
    with pytest.raises(ValueError, match="planner.anytime"):
        MPNetPlanner("x", None, None, None, anytime="yes")
