"""The sphere checker's verdicts and certified motions: one scan answers what a grown scan
and then a plain scan of the same configuration answered, and motions' answers are the ones
the two-scan kernels gave (recorded at f9c0b80; their counts at checker VERSION 3)."""

from __future__ import annotations

import hashlib
import math
import sys

import numpy as np
import pytest

from mpnet.envs.arm.kinematics import forward
from mpnet.envs.checkers import sphere_checks as C
from mpnet.envs.checkers import sphere_kernels as K
from mpnet.envs.checkers import sphere_layout as L
from mpnet.envs.checkers.compiled_env import motion_free, motions_free, state_free
from mpnet.envs.checkers.spheres import CERTIFY_TOL
from mpnet.envs.mbm.files import load_mbm
from mpnet.envs.specs import get_spec
from mpnet.jit import njit

SPEC = get_spec("panda_mbm")

# (workspace, free motions of 200, configurations evaluated, sha256 of the answers' bytes):
# the answers from the kernels that scanned a NEAR midpoint again, plain (f9c0b80), the
# counts from checker VERSION 3's (a pair table reads a box of any size: the same answers,
# fewer configurations than VERSION 2's 1710, 1762, 1602, 1912, 1843, 1989)
RECORDED = [
    ("bookshelf_small_panda/0001", 131, 1035, "dffe647c8e6ec767"),
    ("bookshelf_small_panda/0002", 132, 1168, "d00c2e346e2a3e54"),
    ("box_panda/0001", 116, 1401, "83cf969f8c1cea15"),
    ("box_panda/0002", 120, 1606, "d36d382602e0bf16"),
    ("table_pick_panda/0001", 143, 1261, "71278479d9f046af"),
    ("table_pick_panda/0002", 136, 1440, "35587fc404602a7e"),
]


@pytest.fixture(scope="module")
def checkers(mbm_dir):
    ts = load_mbm(mbm_dir, SPEC)
    ws = {w.id: w for w in ts.workspaces}
    return [(q.workspace_id, SPEC.make_checker(ws[q.workspace_id])) for q in ts.queries]


def _motions(seed: int, lo: np.ndarray, up: np.ndarray, n: int = 200) -> tuple[np.ndarray, np.ndarray]:
    """n motions from uniform states, each up to 1.5 rad long, inside the limits."""
    rng = np.random.default_rng(seed)
    a = rng.uniform(lo, up, (n, len(lo)))
    step = rng.normal(size=a.shape)
    step *= (rng.uniform(0, 1.5, n) / np.linalg.norm(step, axis=1))[:, None]
    return a, np.clip(a + step, lo, up)


def test_motions_answer_as_the_two_scan_kernels_did(checkers):
    got = []
    for i, (name, ch) in enumerate(checkers):
        mi, mf, ob, lo, up = ch._args
        a, b = _motions(i, lo, up)
        free, n = C.motions_free(a, b, mi, mf, ob, lo, up, CERTIFY_TOL, ch._buf)
        got.append((name, int(free.sum()), int(n), hashlib.sha256(free.tobytes()).hexdigest()[:16]))
    assert got == RECORDED


def test_a_motion_from_known_free_ends_answers_the_same_and_checks_them_no_more(checkers):
    """motion_free_known (the compiled RRT-Connect's: a tree's states are free) gives
    motion_free's answers, evaluating one configuration fewer per known free end; the ends'
    own checks are an early exit only (an interval is certified free only when all of it is,
    its ends included), so an end wrongly said known still blocks the motion."""
    _, ch = checkers[2]
    mi, mf, ob, lo, up = ch._args
    a, b = _motions(5, lo, up, 300)
    ends = C.states_free(a, mi, mf, ob, lo, up, ch._buf) & C.states_free(b, mi, mf, ob, lo, up, ch._buf)
    assert 50 < ends.sum() < len(a)
    for i in range(len(a)):
        ok, n = C.motion_free(a[i], b[i], mi, mf, ob, lo, up, CERTIFY_TOL, ch._buf)
        for known in (1, 2):
            got, m = C.motion_free_known(a[i], b[i], mi, mf, ob, lo, up, CERTIFY_TOL, ch._buf, known)
            assert got == ok and (m == n - known if ends[i] else not got)


@njit(cache=True)
def _verdicts(a, b, hs, mi, mf, ob, buf):
    """(growing verdict, plain verdict) of each motion's midpoint, grown by hs."""
    m, obs, bufs = L.model_views(mi, mf), K.obstacle_views(ob), L.scratch_views(mi, buf)  # this kernel counts
    out = np.empty((a.shape[0], 2), np.int64)
    qs, dqs = 0.5 * (a + b), np.abs(b - a)
    for i in range(qs.shape[0]):
        C._steps(a[i], b[i], m, bufs)
        for plain in range(2):  # one call site: verdict is inlined once (half the compilation)
            out[i, plain] = K.verdict(qs[i], m, obs, bufs, plain == 0, 0.0 if plain else hs[i], dqs[i])
    return out


@pytest.mark.parametrize("backend", ["spheres", "spheres_swept"])
def test_a_grown_scan_answers_hit_exactly_where_a_plain_one_does(checkers, backend):
    """HIT or NEAR_HIT where the plain scan hits, NEAR or FREE where it does not; with no
    growth there is no NEAR; a wide interval finds grown contacts (either motion bound)."""
    for i, (_, default) in enumerate(checkers):
        ch = SPEC.make_checker(default.workspace, backend=backend)
        mi, mf, ob, lo, up = ch._args
        a, b = _motions(100 + i, lo, up, 400)
        hs = np.random.default_rng(i).choice([0.0, 0.03, 0.125, 0.5], 400)
        v = _verdicts(a, b, hs, mi, mf, ob, ch._buf)
        hit = v[:, 1] == K.HIT
        assert set(v[:, 1]) <= {K.FREE, K.HIT}
        assert (np.isin(v[:, 0], [K.HIT, K.NEAR_HIT]) == hit).all()
        assert (v[hs == 0.0, 0] != K.NEAR).all() and (v[hs == 0.0, 0] != K.NEAR_HIT).all()
        assert (v[hs == 0.5, 0] != K.FREE).any() and hit.any() and (~hit).any()


@njit(cache=True)
def _counting_caller(qs, a, b, mi, mf, ob, lo, up, buf):
    """A kernel with numba's reference counts (as the compiled planners are) calling the borrowed
    checks: how many states are free, how many of the motions a[i] -> b[i] are."""
    n = 0
    for i in range(qs.shape[0]):
        n += C.state_free(qs[i], mi, mf, ob, lo, up, buf)
        ok, _ = C.motion_free(a[i], b[i], mi, mf, ob, lo, up, CERTIFY_TOL, buf)
        n += ok
    return n


@njit(cache=True)
def _through_the_env(env, counts, A, B):
    """The compiled planners' way in (a counting kernel, the env's overloads)."""
    n = 0
    for i in range(A.shape[0]):
        n += state_free(env, counts, A[i]) + motion_free(env, counts, A[i], B[i])
    out = np.empty(A.shape[0], np.bool_)
    motions_free(env, counts, A, B, out)
    return n + out.sum()


def test_the_borrowed_kernels_neither_keep_nor_drop_a_reference(checkers):
    """The checks run without numba's reference counts (mpnet.jit's borrowed): from Python, from
    a counting kernel and through the compiled planners' env (the checks, the compiled
    RRT-Connect's search, IK's restarts), every array they are handed keeps its reference count,
    numba's allocations all come back, and the answers are the same every time."""
    from numba.core.runtime import _nrt_python, rtsys

    from mpnet.envs.arm import ik_kernels
    from mpnet.envs.arm.ik import chain_arrays
    from mpnet.planners.base import Problem
    from mpnet.planners.compiled.planner import kernel_env
    from mpnet.planners.compiled.rrt_connect import CompiledRRTConnect

    _nrt_python.memsys_enable_stats()
    _, ch = checkers[0]
    mi, mf, ob, lo, up = ch._args
    buf = ch._buf
    a, b = _motions(7, lo, up, 50)
    free = a[C.states_free(a, mi, mf, ob, lo, up, buf)]
    env, rrt = kernel_env(ch), CompiledRRTConnect()
    problem = Problem(SPEC, None, ch, free[0], free[1], seed=1)
    chain = chain_arrays(SPEC.robot.model, "panda_link8")
    centres, radii = np.ascontiguousarray(a[:, :3]), np.full(len(a), 0.05)
    held = (mi, mf, ob, lo, up, buf, a, b, centres, radii, *chain, *env)

    def calls():
        n = int(C.states_free(a, mi, mf, ob, lo, up, buf).sum())
        n += sum(C.state_free(q, mi, mf, ob, lo, up, buf) for q in a)
        n += int(C.motions_free(a, b, mi, mf, ob, lo, up, CERTIFY_TOL, buf)[0].sum())
        n += sum(C.motion_free(p, q, mi, mf, ob, lo, up, CERTIFY_TOL, buf)[0] for p, q in zip(a, b))
        n += _counting_caller(a, a, b, mi, mf, ob, lo, up, buf) + C.any_hit(centres, radii, ob)
        n += _through_the_env(env, np.zeros(3, np.int64), a, b)
        n += len(rrt.solve(problem, 1.0).path or [])
        q, T = ik_kernels.dls(a[0], T0[:3, 3], np.ascontiguousarray(T0[:3, :3]), lo, up, *chain, 100, 0.05)
        return n, q.tobytes()

    T0 = ik_kernels.chain_pose(b[0], *chain)
    first = calls()  # compiles or loads everything first
    refs = [sys.getrefcount(x) for x in held]
    stats = rtsys.get_allocation_stats()
    assert [calls() for _ in range(5)] == [first] * 5
    after = rtsys.get_allocation_stats()
    assert [sys.getrefcount(x) for x in held] == refs
    assert after.alloc - stats.alloc == after.free - stats.free > 0
    assert after.mi_alloc - stats.mi_alloc == after.mi_free - stats.mi_free
    views = K.obstacle_views(ob)  # the counting twin of the kernels' unpack_obstacles, from Python
    assert views[0].shape[1] == 15 and views[4].shape == (sum(len(v) for v in views[:3]), 6)


def _general_forward(q, parent, origin, coord, axis) -> np.ndarray:
    """forward's revolute-joint arithmetic for any axis, in Python floats, in its order."""
    out = np.zeros((len(parent), 3, 4))
    for f in range(len(parent)):
        m = origin[f].copy()
        x, y, z = (float(v) for v in axis[f])
        cs, sn = math.cos(q[coord[f]]), math.sin(q[coord[f]])
        C = 1.0 - cs
        r = [
            [cs + x * x * C, x * y * C - z * sn, x * z * C + y * sn],
            [y * x * C + z * sn, cs + y * y * C, y * z * C - x * sn],
            [z * x * C - y * sn, z * y * C + x * sn, cs + z * z * C],
        ]
        for i in range(3):
            a0, a1, a2 = (float(v) for v in origin[f, i, :3])
            for j in range(3):
                m[i, j] = a0 * r[0][j] + a1 * r[1][j] + a2 * r[2][j]
        p = parent[f]
        if p < 0:
            out[f] = m
            continue
        for i in range(3):
            p0, p1, p2 = (float(v) for v in out[p, i, :3])
            for j in range(3):
                out[f, i, j] = p0 * m[0, j] + p1 * m[1, j] + p2 * m[2, j]
            out[f, i, 3] = p0 * m[0, 3] + p1 * m[1, 3] + p2 * m[2, 3] + out[p, i, 3]
    return out


def test_forward_about_z_gives_the_general_rotations_numbers_bit_for_bit():
    """forward's shortcut for joints about z drops the general product's zero terms only:
    the same poses to the last bit, so no answer of the checker moves (no new VERSION)."""
    rng = np.random.default_rng(3)
    F = 5
    parent, coord, kind = np.arange(-1, F - 1), np.arange(F), np.ones(F, np.int64)
    origin = np.zeros((F, 3, 4))
    for f in range(F):
        origin[f, :, :3] = np.linalg.qr(rng.normal(size=(3, 3)))[0]
        origin[f, :, 3] = rng.normal(size=3)
    axis = np.tile([0.0, 0.0, 1.0], (F, 1))
    for _ in range(200):
        q = rng.uniform(-3.0, 3.0, F)
        out = np.zeros((F + 1, 3, 4))
        forward(q, parent, origin, kind, axis, coord, out)
        assert np.array_equal(out[:F], _general_forward(q, parent, origin, coord, axis))
