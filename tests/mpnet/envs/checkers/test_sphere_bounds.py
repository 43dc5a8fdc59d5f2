"""The sphere checker's two motion bounds (mpnet.envs.checkers.sphere_bounds): each holds how
far every link and group moves in a motion interval, absolutely and relative to an ancestor
link, sampled finely; the swept bound's checker keeps the certified checker's promises in
fewer configurations."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from mpnet.envs.arm.kinematics import forward
from mpnet.envs.checkers import sphere_checks as C
from mpnet.envs.checkers.sphere_bounds import LEVER, SWEPT
from mpnet.envs.checkers.spheres import SphereChecker, SphereModel, SweptSphereChecker, sphere_model
from mpnet.envs.mbm.files import load_mbm
from mpnet.envs.specs import get_spec

ARM = get_spec("arm7")
# material points of a unit ball: its centre and 26 points on its surface
_D = np.array([(x, y, z) for x in (-1, 0, 1) for y in (-1, 0, 1) for z in (-1, 0, 1) if (x, y, z) != (0, 0, 0)], float)
BALL = np.vstack([np.zeros(3), _D / np.linalg.norm(_D, axis=1, keepdims=True)])


def _poses(m, q):
    pose = np.zeros((len(m.parent) + 1, 3, 4))
    forward(np.asarray(q, float), m.parent, m.origin, m.kind, m.axis, m.coord, pose)
    return pose


def _points(pose, frame, local, radius):
    """The material points (BALL scaled) of a sphere of `radius` at `local` in `frame`, in the base frame."""
    p = local + radius * BALL
    return p @ pose[frame, :, :3].T + pose[frame, :, 3]


def _relative(pose, frame, points):
    """Points in the base frame, in frame `frame`'s coordinates."""
    r, t = pose[frame, :, :3], pose[frame, :, 3]
    return (points - t) @ r


@pytest.mark.slow  # ~4 s: out of the fast loop
@settings(deadline=None, max_examples=25)
@given(seed=st.integers(0, 10_000), bound=st.sampled_from([LEVER, SWEPT]))
def test_the_bounds_hold_how_far_spheres_move_in_an_interval(seed, bound):
    """A motion of up to 1.5 rad, an interval of it (half-width 1/2 to 1/64): no material
    point of a link's or a group's bounding sphere, sampled at 65 parameters across the
    interval, moves farther from where it is at the midpoint than the bound says; nor a point
    of a pair's lower link, in its ancestor link's frame, than the relative bound says."""
    m = sphere_model("panda", bound)
    rng = np.random.default_rng(seed)
    a = rng.uniform(m.lower, m.upper)
    step = rng.normal(size=len(a))
    b = np.clip(a + step / np.linalg.norm(step) * rng.uniform(0.05, 1.5), m.lower, m.upper)
    h = 0.5 ** rng.integers(1, 7)
    t = rng.uniform(h, 1 - h)
    links, groups, pairs = np.zeros(len(m.link_frame)), np.zeros(len(m.group_frame)), np.zeros(len(m.pair_a))
    C.interval_growth(a, b, t, h, m.mi, m.mf, m.buffers(), links, groups, pairs)
    mid = _poses(m, a + t * (b - a))
    ts = np.linspace(t - h, t + h, 65)
    for s in ts:
        pose = _poses(m, a + s * (b - a))
        for li, f in enumerate(m.link_frame):
            moved = _points(pose, f, m.blocal[li], m.bradius[li]) - _points(mid, f, m.blocal[li], m.bradius[li])
            assert np.linalg.norm(moved, axis=1).max() <= links[li] + 1e-12, (li, s)
        for g, f in enumerate(m.group_frame):
            moved = _points(pose, f, m.glocal[g], m.gradius[g]) - _points(mid, f, m.glocal[g], m.gradius[g])
            assert np.linalg.norm(moved, axis=1).max() <= groups[g] + 1e-12, (g, s)
        for pi in np.flatnonzero(pairs >= 0):
            la, lb = m.pair_a[pi], m.pair_b[pi]
            fa, fb = m.link_frame[la], m.link_frame[lb]
            now = _relative(pose, fa, _points(pose, fb, m.blocal[lb], m.bradius[lb]))
            then = _relative(mid, fa, _points(mid, fb, m.blocal[lb], m.bradius[lb]))
            assert np.linalg.norm(now - then, axis=1).max() <= pairs[pi] + 1e-12, (pi, s)


def test_the_swept_bound_is_tighter_where_it_matters():
    """Over random short intervals the swept bound grows the hand by less than the lever
    bound, and a proximal link by far less (the lever bound counts the joints below it)."""
    rng = np.random.default_rng(0)
    lever, swept = sphere_model("panda", LEVER), sphere_model("panda", SWEPT)
    hand, link2 = lever.links.index("panda_hand"), lever.links.index("panda_link2")
    ratios = []
    for _ in range(200):
        a = ARM.space.sample(rng)
        b = np.clip(a + rng.normal(0, 0.4, 7), ARM.lower, ARM.upper)
        out = []
        for m in (lever, swept):
            links = np.zeros(len(m.link_frame))
            C.interval_growth(a, b, 0.5, 1 / 64, m.mi, m.mf, m.buffers(), links, np.zeros(len(m.group_frame)),
                              np.zeros(len(m.pair_a)))  # fmt: skip
            out.append(links)
        ratios.append(out[1] / out[0])
    ratios = np.array(ratios)
    assert np.median(ratios[:, hand]) < 0.75
    assert np.median(ratios[:, link2]) < 0.3


def _motions(mbm_dir, n: int = 400):
    """Motions between random free states (RRT-Connect's range, 1 rad, and longer ones) in
    MotionBenchMaker's scenes, with each scene's checker of both bounds."""
    rng = np.random.default_rng(5)
    for ws in load_mbm(mbm_dir, ARM).workspaces:
        lever = ARM.make_checker(ws, margin=0.0, backend="spheres")
        swept = ARM.make_checker(ws, margin=0.0, backend="spheres_swept")
        qs = np.array([ARM.space.sample(rng) for _ in range(6 * n)])
        ok = qs[lever.states_valid(qs)]
        a, b = ok[: len(ok) // 2][:n], ok[len(ok) // 2 :][:n]
        length = np.linalg.norm(b - a, axis=1, keepdims=True)
        b = np.where(rng.uniform(size=(len(a), 1)) < 0.5, a + (b - a) * np.minimum(1.0, 1.0 / length), b)
        yield ws, lever, swept, a, b


@pytest.mark.slow  # ~5 s: out of the fast loop
def test_the_swept_checker_agrees_in_fewer_configurations(mbm_dir):
    """On MotionBenchMaker's scenes the two bounds call the same motions free but for a few
    that pass within the certification's tolerance of a contact, and the swept bound
    certifies them in at most 80% of the configurations; every motion it calls free is free
    at a 0.002 rad step."""
    same = total = 0
    configurations = {"spheres": 0, "spheres_swept": 0}
    for _, lever, swept, a, b in _motions(mbm_dir):
        assert isinstance(lever, SphereChecker) and isinstance(swept, SweptSphereChecker)
        x, y = lever.motions_valid(a, b), swept.motions_valid(a, b)
        same += int((x == y).sum())
        total += len(a)
        for name, ch in (("spheres", lever), ("spheres_swept", swept)):
            configurations[name] += ch.configurations
        for p, q in zip(a[y], b[y]):
            n = int(np.ceil(np.linalg.norm(q - p) / 0.002)) + 1
            states = p + np.linspace(0, 1, n)[:, None] * (q - p)
            states[-1] = q
            assert lever.states_valid(states).all()
    assert total > 1000 and same >= 0.995 * total
    assert configurations["spheres_swept"] <= 0.8 * configurations["spheres"]


def test_a_lever_counts_a_prismatic_joint_below_its_joint_at_its_farthest_limit():
    """A point 0.1 m out from a revolute joint, beyond a prismatic joint that slides up to
    0.5 m: it can be 0.6 m from the revolute axis, so its lever is 0.6, not the fixed offset's
    0.1 (no shipped model has such a chain: their levers are unchanged)."""
    from types import SimpleNamespace

    from mpnet.envs.arm.model import PRISMATIC, REVOLUTE

    def frame(parent, kind, coordinate, x):
        origin = np.eye(4)
        origin[0, 3] = x
        return SimpleNamespace(parent=parent, kind=kind, coordinate=coordinate, origin=origin)

    chain = [frame(-1, REVOLUTE, 0, 0.0), frame(0, PRISMATIC, 1, 0.1)]
    fake = SimpleNamespace(model=SimpleNamespace(kinematics=SimpleNamespace(frames=chain), limits=[(-3, 3), (0, 0.5)]))
    levers = SphereModel._levers(fake, np.array([1]), np.zeros((1, 3)), 2)
    assert np.allclose(levers, [[0.6, 1.0]])
