"""Reference path costs: the exact 2D shortest path (known answers, and never above a
verified planned path) and the planned reference of the other envs."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from mpnet.data.queries import make_queries
from mpnet.envs import Workspace, get_spec
from mpnet.envs.scenes.generators import make_workspace
from mpnet.motion import lazy_states_contraction, path_cost, verify_path
from mpnet.planners import Problem
from mpnet.planners.classical import OmplPlanner
from mpnet.planners.reference import planned_cost, reference_costs, shortest_path_cost_2d, visible

S2D = get_spec("s2d")


def boxes(*specs):
    return Workspace(
        "w",
        "file",
        np.array([c for c, _ in specs], float).reshape(-1, 2),
        np.array([s for _, s in specs], float).reshape(-1, 2),
    )


def test_free_workspace_is_the_straight_line():
    assert shortest_path_cost_2d(S2D, boxes(), [-10, 0], [10, 3]) == pytest.approx(math.hypot(20, 3))


def test_around_one_box_through_its_corners():
    ws = boxes(([0, 0], [4, 4]))
    assert shortest_path_cost_2d(S2D, ws, [-10, 0], [10, 0]) == pytest.approx(2 * math.hypot(8, 2) + 4)
    assert shortest_path_cost_2d(S2D, ws, [-10, 0], [-10, 0]) == 0.0


def test_a_wall_to_the_bound_forces_the_other_side():
    """A box from the bottom bound up to y=10: the path goes over its top corners, never
    around a corner outside the bounds."""
    ws = boxes(([0, -10], [2, 40]))  # spans y in [-30, 10]: its lower corners are out of bounds
    want = 2 * math.hypot(9, 10) + 2
    assert shortest_path_cost_2d(S2D, ws, [-10, 0], [10, 0]) == pytest.approx(want)


def test_visibility_along_edges_and_through_corners():
    lo, hi = np.array([[0.0, 0.0]]), np.array([[2.0, 2.0]])
    p = np.array([[0.0, 0.0], [-1.0, -1.0], [-1.0, 1.0]])
    q = np.array([[2.0, 0.0], [3.0, 3.0], [3.0, 1.0]])
    seen = visible(p, q, lo, hi)
    assert seen[0, 0]  # along the bottom edge
    assert not seen[1, 1]  # the diagonal through the box
    assert not seen[2, 2]  # straight through the middle
    assert seen[1, 0]  # (-1,-1) -> (2,0) passes below, touching the corner (2,0)


@settings(max_examples=15, deadline=None)
@given(ws_index=st.integers(0, 99), seed=st.integers(0, 10_000))
def test_exact_reference_never_exceeds_a_planned_path(ws_index, seed):
    """The exact cost is a lower bound of every verified path (here BIT*'s, contracted) and
    at least the straight-line distance."""
    for env in ("s2d", "c2d"):
        spec = get_spec(env)
        ws = make_workspace(spec, ws_index, "seen")
        (q,) = make_queries(spec, ws, 1, seed=seed, split="seen")
        ref = shortest_path_cost_2d(spec, ws, q.start, q.goal)
        checker = spec.make_checker(ws)
        res = OmplPlanner("bit_star", "bit_star", stop="first").solve(Problem(spec, ws, checker, q.start, q.goal), 2.0)
        assert res.solved
        path = lazy_states_contraction(checker, res.path)
        assert verify_path(spec, ws, path, q.start, q.goal) is None
        assert np.linalg.norm(q.goal - q.start) - 1e-9 <= ref <= path_cost(spec, path) + 1e-9


@pytest.mark.slow
def test_reference_is_reached_by_a_long_bit_star_run():
    """BIT* given seconds on an s2d query gets within a few percent of the exact cost."""
    ws = make_workspace(S2D, 5, "seen")
    qs = make_queries(S2D, ws, 3, seed=2, split="seen")
    checker = S2D.make_checker(ws)
    for q in qs:
        ref = shortest_path_cost_2d(S2D, ws, q.start, q.goal)
        got = planned_cost(S2D, ws, checker, q.start, q.goal, iterations=200, expert_s=1.0, bit_star_s=1.0)
        assert ref <= got <= 1.05 * ref


@pytest.mark.slow  # over ~1.3 s: out of the fast loop
def test_planned_references_for_rigid_are_set_and_sane():
    spec = get_spec("rigid")
    ws = make_workspace(spec, 0, "seen")
    qs = make_queries(spec, ws, 2, seed=0, split="seen")
    reference_costs(spec, [ws], qs, iterations=300, expert_s=1.0, bit_star_s=0.2, seed=0, jobs=1)
    for q in qs:
        assert q.reference_cost is not None and q.reference_cost >= spec.distance(q.start, q.goal) - 1e-9


def test_the_reference_takes_the_data_s_expert():
    """panda_mbm's expert is RRT-Connect, shortened: its references use it (with BIT* given
    almost no time, the RRT-Connect expert's path is what the reference is), never RRT*."""
    ws = make_workspace(S2D, 5, "seen")
    q = make_queries(S2D, ws, 1, seed=2, split="seen")[0]
    checker = S2D.make_checker(ws)
    exact = shortest_path_cost_2d(S2D, ws, q.start, q.goal)
    got = planned_cost(S2D, ws, checker, q.start, q.goal, 3, 1.0, 1e-4, expert="rrt_connect")
    assert exact - 1e-9 <= got < math.inf
    assert planned_cost(S2D, ws, checker, q.start, q.goal, 0, 1.0, 1e-4) == math.inf  # RRT*, no iterations
