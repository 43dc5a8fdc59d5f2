"""Motion primitives and the fine re-check."""

import math

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from mpnet.envs import Workspace, get_spec
from mpnet.motion import interpolate, is_feasible, lazy_states_contraction, path_cost, steer_to, verify_path

S2D, RIGID = get_spec("s2d"), get_spec("rigid")
WALL = Workspace("wall", "file", [[0.0, 0.0]], [[4.0, 30.0]])


def test_lsc_removes_lazy_states():
    ch = S2D.make_checker(WALL)
    path = [(-10, 0), (-10, 10), (-10, 16), (-5, 16), (0, 16), (5, 16), (10, 16), (10, 0)]
    out = lazy_states_contraction(ch, path)
    assert out[0] == path[0] and out[-1] == path[-1]
    assert len(out) < len(path)
    assert is_feasible(ch, out)
    assert path_cost(S2D, out) <= path_cost(S2D, path)


def test_lsc_keeps_a_needed_detour():
    ch = S2D.make_checker(WALL)
    path = [(-10, 0), (-2.5, 16), (2.5, 16), (10, 0)]
    assert lazy_states_contraction(ch, path) == path


def test_steer_and_feasible():
    ch = S2D.make_checker(WALL)
    assert not steer_to(ch, (-10, 0), (10, 0))
    assert steer_to(ch, (-10, 0), (-10, 10))
    assert not is_feasible(ch, [(-10, 0), (10, 0)])
    assert not is_feasible(ch, [])
    assert is_feasible(ch, [(-10, 0)])


def test_coarse_steer_step_can_jump_a_thin_wall_the_continuous_check_cannot():
    """The T-RO code's discretised steerTo at step 2.0 samples x = -0.5, 1.17 around a
    0.4-wide wall: it passes; step 0.1 and the continuous check see the wall."""
    thin = Workspace("thin", "file", [[0.0, 0.0]], [[0.4, 30.0]])
    ch = S2D.make_checker(thin)
    a, b = (-5.5, 0.0), (4.5, 0.0)
    assert steer_to(ch, a, b, step=2.0)
    assert not steer_to(ch, a, b, step=0.1)
    assert not steer_to(ch, a, b)
    assert lazy_states_contraction(ch, [a, (-1, 16), (1, 16), b], step=2.0) == [a, b]
    assert len(lazy_states_contraction(ch, [a, (-1, 16), (1, 16), b])) == 4


def test_rigid_cost_uses_shorter_arc():
    assert math.isclose(path_cost(RIGID, [(0, 0, 3.0), (0, 0, -3.0)]), 0.5 * (2 * math.pi - 6.0))
    assert math.isclose(path_cost(RIGID, [(0, 0, 0), (3, 4, 0)]), 5.0)


def test_verify_path_reasons():
    start, goal = np.array([-10.0, 0.0]), np.array([10.0, 0.0])
    good = [start.tolist(), [-10, 16], [10, 16], goal.tolist()]
    assert verify_path(S2D, WALL, good, start, goal) is None
    assert verify_path(S2D, WALL, [start.tolist(), goal.tolist()], start, goal) == "collision"
    assert verify_path(S2D, WALL, [start.tolist(), [-10, 25], [10, 25], goal.tolist()], start, goal) == "out_of_bounds"
    assert verify_path(S2D, WALL, good[1:], start, goal) == "wrong_endpoints"
    assert verify_path(S2D, WALL, [start.tolist()], start, goal) == "no_path"
    assert verify_path(S2D, WALL, [[0, float("nan")], goal.tolist()], start, goal) == "malformed_path"


def test_verify_catches_a_grazing_corner_that_planning_would_refuse():
    """The planner's boxes carry a margin; the re-check's are exact and closed."""
    start, goal = np.array([-10.0, 15.0]), np.array([10.0, 15.0])  # along the wall's top face
    assert verify_path(S2D, WALL, [start.tolist(), goal.tolist()], start, goal) == "collision"
    assert not steer_to(S2D.make_checker(WALL), start, goal)


@settings(max_examples=100, deadline=None)
@given(
    st.tuples(st.floats(-20, 20), st.floats(-20, 20), st.floats(-10, 10)),
    st.tuples(st.floats(-20, 20), st.floats(-20, 20), st.floats(-10, 10)),
    st.floats(0.01, 1.0),
)
def test_interpolate_step_bound(a, b, step):
    pts = interpolate(RIGID, a, b, step)
    assert np.allclose(pts[0], a) and np.isclose(pts[-1][:2], b[:2]).all()
    radius = math.hypot(1.0, 2.5)
    d = np.diff(pts, axis=0)
    assert np.all(np.maximum(np.hypot(d[:, 0], d[:, 1]), np.abs(d[:, 2]) * radius) <= step + 1e-9)


@settings(max_examples=100, deadline=None)
@given(
    st.lists(st.tuples(st.floats(-20, 20), st.floats(-20, 20), st.floats(-4, 4)), min_size=2, max_size=6),
    st.floats(0.05, 2.0),
)
def test_interpolate_path_is_interpolate_per_segment(path, step):
    from mpnet.motion import interpolate_path

    for spec in (RIGID, get_spec("s2d")):
        p = np.array(path)[:, : spec.state_dim]
        want = np.concatenate([interpolate(spec, a, b, step) for a, b in zip(p[:-1], p[1:])])
        assert np.allclose(interpolate_path(spec, p, step), want)


def test_a_state_on_the_bound_stays_in_bounds():
    """a + 1.0 * (b - a) rounds to 20.000000000000004 here: the fine re-check sampled the
    goal (20, 6) out of bounds (found by hypothesis in CI)."""
    from mpnet.envs import Workspace, get_spec
    from mpnet.motion import interpolate, interpolate_path, verify_path

    spec = get_spec("s2d")
    a, b = (-12.988639045026328, 9.0), (20.0, 6.0)
    assert interpolate(spec, a, b, 0.005)[-1].tolist() == [20.0, 6.0]
    assert interpolate_path(spec, np.array([a, b, a]), 0.005).max(axis=0)[0] == 20.0
    empty = Workspace("e", "file", np.zeros((0, 2)), np.zeros((0, 2)))
    assert verify_path(spec, empty, [list(a), list(b)], a, b, 0.005) is None


def test_motion_memo_same_verdicts_and_checks_each_motion_once():
    from mpnet.envs import get_spec
    from mpnet.envs.scenes.generators import make_workspace
    from mpnet.motion import MotionMemo

    spec = get_spec("s2d")
    ws = make_workspace(spec, 1, "seen")
    plain, memo = spec.make_checker(ws), MotionMemo(spec.make_checker(ws))
    rng = np.random.default_rng(0)
    a = rng.uniform(spec.lower, spec.upper, size=(50, 2))
    b = rng.uniform(spec.lower, spec.upper, size=(50, 2))
    expect = plain.motions_valid(a, b)
    assert 0 < expect.sum() < 50  # both verdicts occur
    assert (memo.motions_valid(a[:20], b[:20]) == expect[:20]).all()
    assert (memo.motions_valid(a, b) == expect).all()  # 20 known, 30 new
    assert [memo.motion_valid(x.tolist(), y.tolist()) for x, y in zip(a, b)] == expect.tolist()
    assert memo.checker.motion_checks == 50  # each motion checked once
    assert memo.is_valid(a[0].tolist()) == plain.is_valid(a[0].tolist())  # the rest goes to the checker
