"""rrt_connect_compiled: RRT-Connect on the compiled checks solves what OMPL's solves, every
path passes the fine re-check, edges respect the range, budgets and bad input are honoured."""

from dataclasses import replace

import numpy as np
import pytest

from mpnet.envs import Workspace, get_spec
from mpnet.envs.scenes.generators import make_workspace
from mpnet.motion import path_cost, verify_path
from mpnet.planners import EXACT, INVALID_QUERY, TIMEOUT, Planner, Problem
from mpnet.planners.compiled.rrt_connect import CompiledRRTConnect
from mpnet.search import rrt_connect as R
from mpnet.search import rrt_kernels as K

WALL = Workspace("wall", "file", [[0.0, 0.0]], [[4.0, 30.0]])
RING = Workspace("ring", "file", [[0, 3], [0, -3], [3, 0], [-3, 0]], [[8, 2], [8, 2], [2, 8], [2, 8]])


def problem(env, ws, start, goal, seed=None, spec=None):
    spec = spec or get_spec(env)
    return Problem(spec, ws, spec.make_checker(ws), np.array(start, float), np.array(goal, float), seed=seed)


@pytest.fixture(scope="module", autouse=True)
def compiled():
    """The kernels compiled (or loaded) before any budget runs, as the bench's warm-up does."""
    for env, start, goal in (("s2d", (-10.0, 0.0), (10.0, 0.0)), ("rigid", (-10.0, 0.0, 0.0), (10.0, 0.0, 0.0))):
        CompiledRRTConnect().warm_up(problem(env, WALL, start, goal))


@pytest.mark.parametrize(
    "env,start,goal",
    [("s2d", (-10.0, 0.0), (10.0, 0.0)), ("rigid", (-10.0, 0.0, 3.0), (10.0, 0.0, -2.9))],
)
def test_solves_around_a_wall(env, start, goal):
    planner = CompiledRRTConnect()
    assert isinstance(planner, Planner)
    p = problem(env, WALL, start, goal, seed=3)
    res = planner.solve(p, 5.0)
    assert res.status == EXACT and res.solved
    assert res.path[0] == list(start) and res.path[-1] == list(goal)  # the query's ends, exactly
    assert verify_path(p.spec, WALL, res.path, p.start, p.goal) is None
    assert path_cost(p.spec, res.path) > 20.0  # it went around
    assert p.checker.state_checks > 0 and p.checker.motion_checks > 0  # counted on the checker


@pytest.mark.parametrize("env", ["c2d", "c3d", "rigid"])
def test_generated_workspaces_every_query_re_checked(env):
    from mpnet.data.queries import make_queries

    spec = get_spec(env)
    ws = make_workspace(spec, 0, "seen")
    planner = CompiledRRTConnect()
    for i, q in enumerate(make_queries(spec, ws, 5, seed=0, split="seen")):
        p = Problem(spec, ws, spec.make_checker(ws), q.start, q.goal, seed=i)
        res = planner.solve(p, 5.0)
        assert res.solved and verify_path(spec, ws, res.path, q.start, q.goal) is None


def test_edges_are_at_most_the_range():
    """The env's planner_range bounds each edge unless the config sets one (as OMPL's RRTConnect)."""
    spec = replace(get_spec("s2d"), planner_range=0.5)
    for planner, bound in ((CompiledRRTConnect(), 0.5), (CompiledRRTConnect(range=2.0), 2.0)):
        res = planner.solve(problem("s2d", WALL, (-10.0, 0.0), (10.0, 0.0), seed=1, spec=spec), 5.0)
        seg = np.linalg.norm(np.diff(np.asarray(res.path), axis=0), axis=1)
        assert res.solved and seg.max() <= bound + 1e-9 and seg.max() > bound / 2


def test_without_a_range_ompls_default_a_fifth_of_the_extent():
    res = CompiledRRTConnect().solve(problem("s2d", WALL, (-15.0, -15.0), (15.0, 15.0), seed=2), 5.0)
    seg = np.linalg.norm(np.diff(np.asarray(res.path), axis=0), axis=1)
    assert res.solved and seg.max() <= 0.2 * np.hypot(40, 40) + 1e-9


@pytest.mark.parametrize("start,goal", [((0.0, 0.0), (10.0, 0.0)), ((-10.0, 0.0), (25.0, 0.0))])
def test_invalid_endpoints_fail_fast(start, goal):
    res = CompiledRRTConnect().solve(problem("s2d", WALL, start, goal), 10.0)
    assert res.status == INVALID_QUERY and res.path is None


@pytest.mark.parametrize("env", ["s2d", "panda_mbm"])
def test_a_search_from_a_state_in_collision_finds_no_path(env):
    """The search's motions do not test the trees' states first (known free), so it checks
    its roots itself: a caller that does not (the expert) gets no path from a blocked start or
    goal, at once, not after its budget."""
    spec = get_spec(env)
    if env == "s2d":
        ws, start, goal = WALL, (0.0, 0.0), (10.0, 0.0)  # the start inside the wall
    else:
        ws = Workspace("box", "file", [[0.09, 0.0, 1.0]], [[0.1, 0.1, 0.1]])  # a box around the hand at zero
        start, goal = np.zeros(spec.state_dim), np.array([1.5, 0.0, 0.0, -1.5, 0.0, 1.5, 0.8])  # the goal turned away
    checker = spec.make_checker(ws)
    assert not checker.is_valid(list(start)) and checker.is_valid(list(goal))
    for a, b in ((start, goal), (goal, start)):
        found = R.RRTConnectSearch().run(checker.compiled_env(), spec, a, b, np.array([1], np.uint64), max_rounds=2000)
        assert found.path is None and found.rounds == 0


def test_warm_up_compiles_the_rounds_even_from_a_blocked_root(monkeypatch):
    """harness.compile_kernels warms the search up from random states, which on an arm are
    mostly blocked: a search from a blocked root returns before its rounds' kernel, which every
    process that planned first then compiled again (~40 s an arm). warm_up calls it anyway."""
    calls = []
    grow = K.grow
    monkeypatch.setattr(K, "grow", lambda *a: calls.append(a[13]) or grow(*a))  # a[13]: the rounds asked
    spec = get_spec("s2d")
    checker = spec.make_checker(WALL)
    start, goal = np.array([0.0, 0.0]), np.array([10.0, 0.0])  # the start inside the wall
    assert not checker.is_valid(list(start))
    R.RRTConnectSearch().warm_up(checker.compiled_env(), spec, start, goal)
    assert calls == [0]  # compiled for the env's types, no round run


def test_the_trees_are_doubled_only_when_that_ends_within_the_budget(monkeypatch):
    """Doubling the trees' arrays is not a slice of the search (0.24-0.29 s at 262,144 states
    here, fresh memory under huge-page compaction: 0.44 s for a 0.3 s budget): with each doubling
    taking 0.15 s the search still ends within its budget, the trees doubled at least once, and
    it says it ended full when it did not use all of it."""
    import time

    grown = R.RRTConnectSearch._grown
    doublings = []

    def slow(self):
        time.sleep(0.15)
        doublings.append(time.perf_counter())
        return grown(self)

    monkeypatch.setattr(R.RRTConnectSearch, "_grown", slow)
    planner = CompiledRRTConnect()
    query = problem("s2d", RING, (-10.0, -10.0), (0.0, 0.0), seed=0)
    query.checker.warm_up(query.start)
    planner.warm_up(query)
    t = time.perf_counter()
    res = planner.solve(query, 0.4)
    elapsed = time.perf_counter() - t
    assert res.status == TIMEOUT and doublings and elapsed < 0.4 + 4 * R.SLICE_S + 0.05
    assert all(d < t + 0.4 for d in doublings)
    assert res.stats["trees_full"] and elapsed < 0.39  # the next doubling (~0.15 s) would not have fitted


def test_unreachable_goal_times_out_within_its_budget():
    """A goal boxed in by four walls: the budget ends the search (or its trees fill when a
    doubling would not end within it), and the trees, grown past their first capacity, keep
    every state they had."""
    import time

    planner = CompiledRRTConnect()
    query = problem("s2d", RING, (-10.0, -10.0), (0.0, 0.0), seed=0)
    query.checker.warm_up(query.start)
    planner.warm_up(query)  # as the bench does: loading the kernels is not the search's time
    t = time.perf_counter()
    res = planner.solve(query, 0.3)
    elapsed = time.perf_counter() - t
    assert res.status == TIMEOUT and res.path is None
    assert elapsed < 0.3 + 4 * R.SLICE_S + 0.05 and (elapsed > 0.29 or res.stats["trees_full"])
    assert planner.search._trees[0].shape[1] > R.CAPACITY and res.stats["tree_states"] > R.CAPACITY  # doubled
    assert res.stats["iterations"] >= res.stats["tree_states"] / 2  # a round adds to a tree at most its connection


def test_trees_grown_past_their_capacity_still_give_a_valid_path(monkeypatch):
    monkeypatch.setattr(R, "CAPACITY", 8)  # the first capacity is then twice a round's room
    spec = replace(get_spec("s2d"), planner_range=0.3)  # many short edges: several doublings
    planner = CompiledRRTConnect()
    res = planner.solve(problem("s2d", WALL, (-15.0, 0.0), (15.0, 0.0), seed=5, spec=spec), 5.0)
    room = planner.search.space_of(spec)[4]
    assert res.solved and planner.search._trees[0].shape[1] >= 4 * room  # doubled at least once
    assert verify_path(spec, WALL, res.path, res.path[0], res.path[-1]) is None


@pytest.mark.parametrize("seed", range(5))
def test_nearest_is_the_first_node_of_least_distance(seed):
    """The scan a coordinate at a time over the nodes' columns finds the node a scan node by node
    finds: the least squared distance, the first of equals (duplicated nodes, ties included)."""
    rng = np.random.default_rng(seed)
    d, n = 7, int(rng.integers(1, 3000))
    nodes = rng.uniform(-3, 3, (n, d))
    nodes[rng.integers(0, n, n // 3)] = nodes[rng.integers(0, n, n // 3)]  # repeated states
    q = nodes[rng.integers(n)] if seed % 2 else rng.uniform(-3, 3, d)
    env = get_spec("panda_mbm").make_checker(make_workspace(get_spec("panda_mbm"), 0, "train")).compiled_env()
    cols = np.ascontiguousarray(nodes.T)
    got = K.nearest(env, np.ones(d), nodes, cols, n, q, np.empty(d), np.empty(n))
    squared = ((nodes - q) ** 2).sum(axis=1)
    assert got == int(np.flatnonzero(squared == squared.min())[0])


def test_a_seeded_problem_plans_the_same_whatever_ran_before():
    planner = CompiledRRTConnect()
    p = lambda seed: problem("s2d", WALL, (-10.0, 0.0), (10.0, 5.0), seed=seed)
    first = planner.solve(p(11), 5.0).path
    for seed in (1, 2, 3):
        planner.solve(p(seed), 5.0)
    assert planner.solve(p(11), 5.0).path == first
    assert any(planner.solve(p(s), 5.0).path != first for s in (12, 13, 14))


def test_a_checker_without_compiled_checks_is_refused_in_one_line():
    spec = get_spec("rigid")
    with pytest.raises(ValueError, match="^config key planner: rrt_connect_compiled .* fcl checker has none"):
        CompiledRRTConnect().check_env(spec, "fcl")
    with pytest.raises(ValueError, match="^config key planner.range"):
        CompiledRRTConnect(range=0.0)


def test_mbm_problems_on_the_arm(mbm_dir):
    """MotionBenchMaker's six bundled Panda problems: each valid one solved, each path passing
    the sphere checker's certified motions and pybullet's fine re-check."""
    from mpnet.data.expert import planner_check
    from mpnet.envs.mbm.files import load_mbm

    spec = get_spec("panda_mbm")
    ts = load_mbm(mbm_dir, spec)
    planner = CompiledRRTConnect()
    first = ts.queries[0]
    ws0 = next(w for w in ts.workspaces if w.id == first.workspace_id)
    planner.warm_up(Problem(spec, ws0, spec.make_checker(ws0), first.start, first.goal))  # compiled before any budget
    solved = 0
    for i, q in enumerate(ts.queries):
        ws = next(w for w in ts.workspaces if w.id == q.workspace_id)
        checker = spec.make_checker(ws)
        res = planner.solve(Problem(spec, ws, checker, q.start, q.goal, seed=i), 10.0)
        if res.status == INVALID_QUERY:
            continue
        assert res.solved and planner_check(spec, ws, checker, res.path, q.start, q.goal)
        assert verify_path(spec, ws, res.path, q.start, q.goal) is None
        solved += 1
    assert solved >= 5


@pytest.mark.slow
def test_rrt_connect_compiled_runs_mbm_problems_from_the_command_line(tmp_path, run_cli, mbm_dir):
    """docs/arm.md's command on the six bundled problems: every valid query solved, each
    success the judge's, and the independent re-check finds no false one."""
    import json

    from mcap.reader import make_reader

    run_cli(
        "harness", "+env=panda_mbm", "+planner=rrt_connect_compiled", f"problems={mbm_dir}", "rerun=false",
        f"hydra.run.dir={tmp_path}",
    )  # fmt: skip
    with open(tmp_path / "trials.mcap", "rb") as f:
        queries = [json.loads(m.data) for _, _, m in make_reader(f).iter_messages(topics=["/query"])]
    valid = [q for q in queries if q["failure"] != "invalid_query"]
    assert len(queries) == 6 and len(valid) >= 5 and all(q["success"] for q in valid)
    assert all(q["configurations_checked"] > 0 and q["tree_states"] >= 2 for q in valid)
    p = run_cli("harness.recheck", str(tmp_path))
    assert "false successes 0" in p.stdout


def test_the_trees_arrays_are_asked_for_small_pages(monkeypatch):
    """Every array of the trees (the k-d trees' too) is advised into small pages, whole pages
    inside it only: numpy asks for huge pages from 4 MB on, and where the kernel compacts memory
    to find them a doubling first touched its memory in 0.19-0.71 s instead of 23-40 ms (262,144
    and 524,288 states), past what the last doubling predicted and past the search's budget."""
    import mmap

    calls = []
    monkeypatch.setattr(R, "_madvise", lambda: lambda start, n, advice: calls.append((start, n, advice)))
    arrays = R.RRTConnectSearch._arrays(1 << 17, 7)
    flat = [*arrays[:4], *arrays[4]]
    page = mmap.PAGESIZE
    for a in flat:
        lo, hi = a.ctypes.data, a.ctypes.data + a.nbytes
        mine = [(s, n) for s, n, _ in calls if lo <= s < hi]
        if a.nbytes >= 2 * page:  # an array of two pages or more holds a whole page
            assert len(mine) == 1, a.shape
            s, n = mine[0]
            assert s % page == 0 and n % page == 0 and s + n <= hi and s - lo < page and hi - (s + n) < page
    assert {advice for *_, advice in calls} == {mmap.MADV_NOHUGEPAGE}
