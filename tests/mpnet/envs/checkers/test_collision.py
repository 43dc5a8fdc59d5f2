"""Geometry: known answers, batch == single, continuous checks agree with dense sampling,
and the rigid body's separating-axis test agrees with python-fcl."""

import math

import fcl
import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

from mpnet.envs import Workspace, get_spec
from mpnet.envs.checkers import rigid_kernels as R
from mpnet.envs.checkers.collision import PointChecker
from mpnet.envs.checkers.rigid import RigidChecker
from mpnet.envs.scenes.generators import make_workspace
from mpnet.motion import interpolate
from mpnet.planners.compiled.planner import kernel_env

S2D = get_spec("s2d")
C3D = get_spec("c3d")
RIGID = get_spec("rigid")
ONE_BOX = Workspace("one", "file", [[0.0, 0.0]], [[2.0, 2.0]])

coord = st.floats(-20, 20, allow_nan=False)
angle = st.floats(-math.pi, math.pi, allow_nan=False)


def test_point_known_answers():
    ch = PointChecker(S2D, ONE_BOX, margin=0.0)
    assert not ch.is_valid((0.0, 0.0))
    assert not ch.is_valid((1.0, 1.0))  # closed box: the corner collides
    assert ch.is_valid((1.0001, 0.0))
    assert not ch.is_valid((20.5, 0.0))  # out of bounds
    assert not ch.motion_valid((-5.0, 0.0), (5.0, 0.0))  # straight through
    assert not ch.motion_valid((-5.0, 1.0), (5.0, 1.0))  # along the top face
    assert not ch.motion_valid((0.0, 2.0), (2.0, 0.0))  # touches the corner (1, 1) only
    assert ch.motion_valid((0.0, 2.01), (2.01, 0.0))
    assert ch.motion_valid((-5.0, 1.01), (5.0, 1.01))
    assert ch.state_checks == 4 and ch.motion_checks == 5


def test_corner_cut_is_caught():
    """A diagonal that clips a corner by a hair: sampled checking at 0.2 misses it, we don't."""
    ch = PointChecker(S2D, ONE_BOX, margin=0.0)
    a, b = (-6.0, -4.05), (4.05, 6.0)  # y = x + 1.95: a 0.07-long chord across the corner (-1, 1)
    dense = ch.states_valid(interpolate(S2D, a, b, 1e-4))
    assert not dense.all()
    assert ch.states_valid(interpolate(S2D, a, b, 0.2)).all()
    assert not ch.motion_valid(a, b)


@settings(max_examples=300, deadline=None)
@given(st.tuples(coord, coord), st.tuples(coord, coord), st.integers(0, 109))
@example((-12.988639045026328, 9.0), (20.0, 6.0), 0)  # the last sample rounded past the bound
def test_point_motion_matches_dense_sampling(a, b, wsi):
    ws = make_workspace(S2D, wsi, "seen")
    ch = PointChecker(S2D, ws, margin=0.0)
    free = ch.motion_valid(a, b)
    samples_free = ch.states_valid(interpolate(S2D, a, b, 0.005)).all()
    if free:
        assert samples_free
    assert ch.motions_valid(np.array([a]), np.array([b]))[0] == free


@settings(max_examples=200, deadline=None)
@given(st.lists(st.tuples(coord, coord, coord), min_size=2, max_size=2))
def test_c3d_batch_equals_single(pts):
    ws = make_workspace(C3D, 3, "seen")
    ch = C3D.make_checker(ws)
    a, b = pts
    assert ch.states_valid(np.array([a]))[0] == ch.is_valid(a)
    assert ch.motions_valid(np.array([a]), np.array([b]))[0] == ch.motion_valid(a, b)


def _fcl_rect_collides(q, ws):
    """python-fcl as an independent oracle: 2 x 5 box turned by theta vs the blocks."""
    body = fcl.CollisionObject(
        fcl.Box(2.0, 5.0, 1.0),
        fcl.Transform(
            np.array([[math.cos(q[2]), -math.sin(q[2]), 0], [math.sin(q[2]), math.cos(q[2]), 0], [0, 0, 1.0]]),
            np.array([q[0], q[1], 0.0]),
        ),
    )
    for c, s in zip(ws.centers, ws.sizes):
        box = fcl.CollisionObject(fcl.Box(s[0], s[1], 1.0), fcl.Transform(np.array([c[0], c[1], 0.0])))
        if fcl.collide(body, box, fcl.CollisionRequest(), fcl.CollisionResult()):
            return True
    return False


@settings(max_examples=400, deadline=None)
@given(coord, coord, angle, st.integers(0, 109))
def test_rigid_state_matches_fcl(x, y, th, wsi):
    ws = make_workspace(RIGID, wsi, "seen")
    ch = RigidChecker(RIGID, ws, margin=0.0)
    gap = ch.clearance(x, y, th)
    if abs(gap) < 1e-6:
        return  # touching: closed-box tie, either answer is fine
    assert ch.is_valid((x, y, th)) == (not _fcl_rect_collides((x, y, th), ws))
    assert ch.states_valid(np.array([[x, y, th]]))[0] == ch.is_valid((x, y, th))


@settings(max_examples=200, deadline=None)
@given(coord, coord, angle, st.floats(-6, 6), st.floats(-6, 6), angle, st.integers(0, 109))
def test_rigid_motion_never_lies(x, y, th, dx, dy, th2, wsi):
    """Conservative advancement: a motion called free is free at a 0.002 step."""
    ws = make_workspace(RIGID, wsi, "seen")
    ch = RigidChecker(RIGID, ws, margin=0.0)
    a, b = (x, y, th), (x + dx, y + dy, th2)
    if ch.motion_valid(a, b):
        assert ch.states_valid(interpolate(RIGID, a, b, 0.002)).all()


def test_rigid_rotation_in_place_hits():
    """Rotating in place sweeps the body's corners into a block beside it."""
    ws = Workspace("w", "file", [[3.2, 0.0]], [[2.0, 2.0]])
    ch = RigidChecker(RIGID, ws, margin=0.0)
    assert ch.is_valid((0.0, 0.0, 0.0)) and ch.is_valid((0.0, 0.0, math.pi))
    assert not ch.motion_valid((0.0, 0.0, 0.0), (0.0, 0.0, 3.0))
    # the shorter arc from 3.0 to -3.0 crosses pi, not 0
    assert (
        ch.motion_valid((0.0, 0.0, 3.0), (0.0, 0.0, -3.0))
        == ch.states_valid(interpolate(RIGID, (0.0, 0.0, 3.0), (0.0, 0.0, -3.0), 0.001)).all()
    )


def test_rigid_bounds_are_the_centre():
    ch = RigidChecker(RIGID, Workspace("w", "file", [[0.0, 10.0]], [[1.0, 1.0]]), margin=0.0)
    assert ch.is_valid((19.9, -19.9, 0.3))  # body pokes out, centre inside: valid
    assert not ch.is_valid((20.1, 0.0, 0.0))


def test_dimension_mismatch_is_an_error():
    with pytest.raises(ValueError, match="workspace"):
        PointChecker(C3D, ONE_BOX)


@settings(max_examples=150, deadline=None)
@given(coord, coord, angle, st.floats(-6, 6), st.floats(-6, 6), angle, st.integers(0, 109))
def test_fcl_backend_agrees(x, y, th, dx, dy, th2, wsi):
    ws = make_workspace(RIGID, wsi, "seen")
    native, viafcl = RIGID.make_checker(ws), RIGID.make_checker(ws, backend="fcl")
    a, b = (x, y, th), (x + dx, y + dy, th2)
    if abs(native.clearance(x, y, th)) > 1e-4:
        assert native.is_valid(a) == viafcl.is_valid(a)
    if native.motion_valid(a, b) != viafcl.motion_valid(a, b):
        # only a graze within the margin may differ; both are then sound
        assert min(native.clearance(*q) for q in interpolate(RIGID, a, b, 0.001)) < 1e-3


def test_unknown_backend():
    with pytest.raises(ValueError, match="backend"):
        RIGID.make_checker(ONE_BOX, backend="bullet")


@pytest.mark.parametrize("env,blocks", [("s2d", 7), ("c2d", 7), ("c3d", 10), ("rigid", 7)])
def test_point_cloud_inside_obstacles(env, blocks):
    from mpnet.envs.scenes.clouds import point_cloud

    spec = get_spec(env)
    ws = make_workspace(spec, 5, "seen")
    pts = point_cloud(ws, 200 * spec.blocks, np.random.default_rng(0))
    assert pts.shape == (blocks * 200, spec.workspace_dim)
    inside = np.all((pts[:, None] >= ws.lo[None]) & (pts[:, None] <= ws.hi[None]), axis=2)
    assert inside.any(axis=1).all()
    assert (inside.sum(axis=0) >= 200).all()  # every block gets its 200 points
    odd = Workspace("w", "file", ws.centers[:3], ws.sizes[:3])
    assert point_cloud(odd, 200 * spec.blocks, np.random.default_rng(0)).shape == pts.shape


def test_layouts():
    from mpnet.envs.scenes.generators import c3d_layouts, s2d_layouts, split_ids

    centres, perm = s2d_layouts()
    assert np.allclose(centres[0], [1.8171, 8.4540], atol=1e-4)
    assert perm[0].tolist() == [1, 7, 8, 10, 13, 15, 19]
    assert split_ids("seen", 3) == [0, 1, 2] and split_ids("unseen", 2) == [100, 101]
    with pytest.raises(ValueError):
        split_ids("unseen", 11)
    c, rows = c3d_layouts(0)
    assert np.all(np.abs(c) <= 15) and len({tuple(r) for r in rows}) == 110
    assert np.array_equal(c3d_layouts(0)[0], c) and not np.array_equal(c3d_layouts(1)[0], c)
    c2d = make_workspace(get_spec("c2d"), 0, "seen")
    sizes = [(10, 5), (5, 10), (10, 10), (10, 5), (5, 10), (10, 5), (5, 10)]  # the layout's, in its own order
    boxes = list(zip(map(tuple, c2d.centers.tolist()), map(tuple, c2d.sizes.tolist())))
    assert sorted(boxes) == sorted(zip(map(tuple, centres[perm[0]].tolist()), sizes))
    assert boxes == sorted(boxes)  # kept in the canonical order (by centre, then size)


def test_generated_queries_are_valid_blocked_and_seed_independent():
    from mpnet.data.queries import make_testset

    for env in ("s2d", "rigid"):
        spec = get_spec(env)
        a = make_testset(spec, {"seen": (2, 3), "unseen": (1, 3)}, seed=0)
        b = make_testset(spec, {"seen": (2, 3), "unseen": (1, 3)}, seed=0)
        assert [q.start.tolist() for q in a.queries] == [q.start.tolist() for q in b.queries]
        assert len(a.queries) == 9 and len({q.id for q in a.queries}) == 9
        for q in a.queries:
            ch = spec.make_checker(a.workspace(q.workspace_id, q.split), margin=0.0)
            assert ch.is_valid(q.start.tolist()) and ch.is_valid(q.goal.tolist())
            assert not ch.motion_valid(q.start.tolist(), q.goal.tolist())


def _steps(ch, a, b) -> tuple[bool, int]:
    """The motion's verdict and its advancement steps, from the checker's compiled form."""
    _, near, floats, centres, halves, *_ = kernel_env(ch)
    return R.advance(np.asarray(a, float), np.asarray(b, float), centres, halves, floats, near)


def test_rigid_slides_along_a_face_quickly():
    """Translating parallel to a face 1e-3 away is free and takes a handful of steps."""
    ws = Workspace("w", "file", [[0.0, -5.0]], [[30.0, 4.0]])  # top face at y = -3
    ch = RigidChecker(RIGID, ws)
    a, b = (-10.0, -3.0 + 2.5 + 1e-3, 0.0), (10.0, -3.0 + 2.5 + 1e-3, 0.0)
    free, steps = _steps(ch, a, b)
    assert free and ch.motion_valid(a, b)
    assert steps < 10
    assert not ch.motion_valid(a, (10.0, -3.0 + 2.5 - 1e-3, 0.0))


def test_rigid_motion_checks_stay_cheap():
    """Conservative advancement must not creep toward a contact (a bug once made head-on
    approaches take 20000 steps); a head-on approach stops in a few."""
    ws = make_workspace(RIGID, 0, "seen")
    ch = RigidChecker(RIGID, ws)
    rng = np.random.default_rng(0)
    worst = 0
    for _ in range(2000):
        a = np.r_[rng.uniform(-20, 20, 2), rng.uniform(-3, 3)]
        b = a + np.r_[rng.normal(0, 3, 2), rng.normal(0, 1)]
        free, steps = _steps(ch, a, b)
        assert free == ch.motion_valid(a.tolist(), b.tolist())
        worst = max(worst, steps)
    assert worst < 500
    head_on = RigidChecker(RIGID, Workspace("w", "file", [[5.0, 0.0]], [[2.0, 2.0]]))
    free, steps = _steps(head_on, (-5.0, 0.0, 0.3), (5.0, 0.0, 0.3))
    assert not free and steps < 10


@pytest.mark.parametrize(
    "env,backend",
    [("s2d", "native"), ("c3d", "fcl"), ("rigid", "native"), ("rigid", "fcl"), ("panda_mbm", "spheres")],
)
def test_warm_up_checks_each_kind_and_leaves_no_counts(env, backend):
    """run_bench warms the first checker up before query 1's clock (a fresh clone compiles the
    sphere kernels there: ~18 s, once logged as query 1's timeout); the counts stay clean."""
    spec = get_spec(env)
    ws = make_workspace(spec, 0, "seen")
    checker = spec.make_checker(ws, backend=backend)
    calls = []
    for name in ("is_valid", "motion_valid", "states_valid", "motions_valid"):
        method = getattr(checker, name)
        setattr(checker, name, lambda *a, _m=method, _n=name: calls.append(_n) or _m(*a))
    checker.warm_up(spec.space.upper)  # a state on the bounds: the second state stays inside
    assert calls == ["is_valid", "motion_valid", "states_valid", "motions_valid"]
    assert set(checker.counts().values()) == {0}
    if backend == "spheres":
        from mpnet.envs.checkers import sphere_checks as C

        assert C.state_free.signatures and C.motions_free.signatures  # compiled (or loaded) now
