"""The compiled checks (the checkers' own and the compiled planner's) against the numpy and
Python code they were ported from (tests/oracles.py), bit for bit: the point robot's
(mpnet.envs.checkers.point_kernels) on segments that graze faces, run along them, or stand still in a
coordinate, where the one-motion and batch tests' arithmetic matter; the rigid body's
(mpnet.envs.checkers.rigid_kernels), short and long motions, turning both ways."""

from __future__ import annotations

import re

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from mpnet.envs.checkers import point_kernels as P
from mpnet.envs.checkers import rigid_kernels as R
from mpnet.envs.scenes.generators import make_workspace
from mpnet.envs.specs import get_spec
from mpnet.planners.compiled.planner import kernel_env
from tests import oracles as O


def _points(rng, checker, n):
    """Uniform states, and states on the boxes' faces and corners (grown by the margin)."""
    spec, lo, hi = checker.spec, checker.lo, checker.hi
    q = rng.uniform(spec.space.lower, spec.space.upper, (n, spec.state_dim))
    j = rng.integers(0, len(lo), n)
    face = np.where(rng.random((n, spec.state_dim)) < 0.5, lo[j], hi[j])
    pick = rng.random((n, spec.state_dim))
    q = np.where(pick < 0.3, face, q)
    return np.where(pick > 0.97, spec.space.upper, q)  # some on the bounds


@settings(deadline=None, max_examples=15)
@given(env=st.sampled_from(["s2d", "c2d", "c3d"]), index=st.integers(0, 109), seed=st.integers(0, 2**31 - 1))
def test_the_kernels_answer_as_the_checker(env, index, seed):
    spec = get_spec(env)
    checker = spec.make_checker(make_workspace(spec, index, "train" if index < 100 else "unseen"))
    rng = np.random.default_rng(seed)
    a, b = _points(rng, checker, 400), _points(rng, checker, 400)
    still = rng.random(a.shape) < 0.2  # a coordinate that does not move
    b = np.where(still, a, b)
    _, _, _, lo, hi, lower, upper, _, _ = kernel_env(checker)  # the compiled planner's own arrays
    args = (lo, hi, lower, upper)
    d = np.empty(spec.state_dim)
    for x, y in zip(a, b):
        assert P.state_free(x, *args) == checker.is_valid(x.tolist()) == O.point_state_free(x, *args)
        free = O.point_motion_free(x.tolist(), y.tolist(), *args)
        assert P.motion_free(x, y, *args, d) == checker.motion_valid(x.tolist(), y.tolist()) == free
    out = np.empty(len(a), np.bool_)
    P.motions_free(a, b, *args, d, out)
    assert np.array_equal(out, checker.motions_valid(a, b))
    assert np.array_equal(out, O.point_motions_free(a, b, *args))
    assert np.array_equal(checker.states_valid(a), [O.point_state_free(x, *args) for x in a])


@pytest.mark.parametrize("env", ["s2d", "c3d"])
def test_a_segment_along_a_face_and_a_point_on_a_corner_collide(env):
    spec = get_spec(env)
    checker = spec.make_checker(make_workspace(spec, 0, "train"))
    lo, hi = checker.lo[0], checker.hi[0]
    args = (checker.lo, checker.hi, spec.space.lower, spec.space.upper)
    assert not P.state_free(lo.copy(), *args)
    end = lo.copy()
    end[0] = hi[0]
    assert not P.motion_free(lo.copy(), end, *args, np.empty(spec.state_dim))
    out = np.empty(1, np.bool_)
    P.motions_free(lo[None], end[None], *args, np.empty(spec.state_dim), out)
    assert not out[0]


@settings(deadline=None, max_examples=10)
@given(index=st.integers(0, 109), seed=st.integers(0, 2**31 - 1))
def test_the_rigid_kernels_answer_as_the_checker(index, seed):
    spec = get_spec("rigid")
    c = spec.make_checker(make_workspace(spec, index, "train" if index < 100 else "unseen"))
    _, near, floats, centres, halves, *_ = kernel_env(c)  # the compiled planner's own arrays
    hx, hy, margin = floats[R.HX], floats[R.HY], floats[R.MARGIN]
    boxes = np.hstack([centres, halves]).tolist()
    bounds = spec.space.bounds[:2]
    rng = np.random.default_rng(seed)
    states = []
    for _ in range(300):
        a = spec.space.sample(rng)
        b = a + rng.normal(0, 3, 3) if rng.random() < 0.7 else spec.space.sample(rng)
        b[2] = rng.uniform(-np.pi, np.pi)
        inside = bounds[0][0] <= a[0] <= bounds[0][1] and bounds[1][0] <= a[1] <= bounds[1][1]
        expected = inside and O.rigid_clearance(hx, hy, *a, boxes) > 0.0
        assert R.state_free(a, centres, halves, floats) == c.is_valid(a.tolist()) == expected
        expected = O.rigid_motion_free(hx, hy, margin, bounds, boxes, a.tolist(), b.tolist())
        assert R.motion_free(a, b, centres, halves, floats, near) == c.motion_valid(a.tolist(), b.tolist()) == expected
        assert c.clearance(*a) == O.rigid_clearance(hx, hy, *a, boxes)
        states.append(a)
    assert c.states_valid(np.array(states)).tolist() == [c.is_valid(q.tolist()) for q in states]


def test_a_checker_that_changes_the_geometry_has_no_compiled_form():
    """Its parent's kernels would answer for other geometry (fcl's rigid checker is such a
    subclass): a subclass that overrides a check and not compiled_env has none."""
    from mpnet.envs.checkers.collision import PointChecker
    from mpnet.envs.checkers.rigid import FclRigidChecker, RigidChecker

    class Everywhere(PointChecker):
        def _state_free(self, q) -> bool:
            return True

    spec = get_spec("s2d")
    checker = Everywhere(spec, make_workspace(spec, 0, "train"))
    assert PointChecker.compiled and RigidChecker.compiled and not Everywhere.compiled and not FclRigidChecker.compiled
    with pytest.raises(ValueError, match="no kernels for Everywhere"):
        kernel_env(checker)


@pytest.mark.slow  # compiles a caller of the rigid and point checks
def test_an_env_of_an_unknown_kind_is_refused_not_checked_as_a_rigid_body():
    from mpnet.envs.checkers.boxes_compiled import UNKNOWN
    from mpnet.envs.checkers.compiled_env import motion_free, state_free
    from mpnet.jit import njit

    @njit
    def check(env, counts, a, b):
        return state_free(env, counts, a) and motion_free(env, counts, a, b)

    spec = get_spec("rigid")
    env = spec.make_checker(make_workspace(spec, 0, "train")).compiled_env()
    counts, a, b = np.zeros(4, np.int64), np.array([0.0, 0.0, 0.0]), np.array([0.1, 0.0, 0.0])
    check(env, counts, a, b)  # the rigid body's own kind: answered
    with pytest.raises(ValueError, match=re.escape(UNKNOWN)):
        check((type(env[0])(7), *env[1:]), counts, a, b)


@pytest.mark.slow  # compiles RRT-Connect's search for a kind of its own
def test_a_kind_of_ones_own_registers_its_checks_and_an_unregistered_one_is_refused_by_name():
    """The compiled planners dispatch on an env's tag alone: a kind registered from outside the
    library (a disc in the plane, free outside a circle) runs the compiled RRT-Connect with no
    edit of compiled_env; an env whose tag nobody registers is a typing error naming it."""
    from numba.core.errors import TypingError

    from mpnet.envs.checkers.compiled_env import KINDS, CompiledKind, register, state_free, tag
    from mpnet.jit import njit
    from mpnet.search.rrt_connect import RRTConnectSearch

    @njit
    def disc_state(env, counts, q):
        counts[2] += 1
        return (q[0] - env[0][0]) ** 2 + (q[1] - env[0][1]) ** 2 > env[0][2] ** 2

    @njit
    def disc_motion(env, counts, a, b):
        for i in range(101):  # sampled: enough for the test's circle
            t = i / 100.0
            if not disc_state(env, counts, a + t * (b - a)):
                return False
        return True

    @njit
    def disc_motions(env, counts, A, B, out):
        for i in range(A.shape[0]):
            out[i] = disc_motion(env, counts, A[i], B[i])

    register(CompiledKind("test_disc", disc_state, disc_motion, disc_motions))
    try:
        env = (np.array([0.5, 0.5, 0.3]), tag("test_disc"))
        spec = get_spec("s2d")
        found = RRTConnectSearch(range=0.2).run(
            env, spec, np.array([0.1, 0.1]), np.array([0.9, 0.9]), np.array([7], np.uint64)
        )
        assert found.path is not None and found.counts[2] > 0
        path = np.asarray(found.path)
        dense = np.concatenate([a + np.linspace(0, 1, 50)[:, None] * (b - a) for a, b in zip(path[:-1], path[1:])])
        assert (np.hypot(dense[:, 0] - 0.5, dense[:, 1] - 0.5) > 0.3 - 1e-9).all()  # around the disc
    finally:
        KINDS.pop("test_disc")

    @njit
    def check(env, counts, q):
        return state_free(env, counts, q)

    with pytest.raises(TypingError, match="an env of kind 'nobody', which no \\*_compiled.py module registers"):
        check((np.zeros(3), tag("nobody")), np.zeros(3, np.int64), np.zeros(2))
