"""The sphere checker's checks (numba), built on sphere_kernels' verdict: a state in bounds
and free, a batch of them, and certified straight motions (an interval is cut until every
sphere's swept reach is free, or a state on it is hit).

The kernels here inline sphere_kernels' (verdict, ...) and sphere_layout's (unpack, ...);
mpnet.jit's cache stamps them with those files' text, so a change there recompiles these too.

Compile time: numba compiles a kernel once per argument types, and a literal (`0`) is a type of
its own, so `known` is always passed as int64 (`np.int64(0)`): one compilation of the motion
check (three once, ~25 s each); a plain verdict is one kernel (_plain_verdict), not a copy
inlined into each check; every kernel that reaches verdict's code compiles it again.
"""

from __future__ import annotations

import numpy as np

from mpnet.envs.arm.kinematics import forward
from mpnet.envs.checkers.sphere_bounds import SWEPT, growth_from, growths, lever_second_order, swept_second_order
from mpnet.envs.checkers.sphere_kernels import (
    FREE,
    HIT,
    NEAR,
    NEAR_HIT,
    _axes,
    _dist2,
    _place,
    unpack_obstacles,
    verdict,
)
from mpnet.envs.checkers.sphere_layout import (
    AXDIR,
    AXIS,
    AXPOINT,
    BLOCAL,
    BOUND,
    BRADIUS,
    COORD,
    DQ,
    GA,
    GB,
    GCENTRES,
    GLEVER,
    GLOCAL,
    GNJ,
    GRADIUS,
    GREL,
    GROUP_FRAME,
    GSPEED,
    KIND,
    LA,
    LB,
    LCENTRES,
    LINK_FRAME,
    LLEVER,
    LNJ,
    LREL,
    LSPEED,
    ORIGIN,
    PAIR_B,
    PAIR_J0,
    PARENT,
    POSE,
    PRIS,
    QUEUE,
    QVEC,
    SDQ,
    T0S,
    T1S,
    TOP,
    unpack,
    unpack_buffers,
)
from mpnet.jit import njit


@njit(cache=True, borrowed=True)
def _plain_verdict(q, m, obs, bufs):
    """verdict's plain check of q, compiled once for every caller (a state, a batch, a motion's
    ends): each inlined copy of verdict costs every kernel that reaches it seconds of compiling."""
    return verdict(q, m, obs, bufs, False, 0.0, q)


@njit(cache=True, borrowed=True, inline="always")
def _state_free(q, m, obs, lower, upper, bufs):
    for d in range(q.shape[0]):
        if not lower[d] <= q[d] <= upper[d]:
            return False
    return _plain_verdict(q, m, obs, bufs) != HIT


@njit(cache=True, borrowed=True)
def state_free(q, mi, mf, ob, lower, upper, buf):
    """In bounds and no sphere touching (a plain check)."""
    return _state_free(q, unpack(mi, mf), unpack_obstacles(ob), lower, upper, unpack_buffers(mi, buf))


@njit(cache=True)
def states_free(qs, mi, mf, ob, lower, upper, buf):
    """state_free for each row of qs."""
    out = np.empty(qs.shape[0], np.bool_)
    _states_into(qs, mi, mf, ob, lower, upper, buf, out)
    return out


@njit(cache=True, borrowed=True)
def _states_into(qs, mi, mf, ob, lower, upper, buf, out):
    m, obs, bufs = unpack(mi, mf), unpack_obstacles(ob), unpack_buffers(mi, buf)
    for i in range(qs.shape[0]):
        out[i] = _state_free(qs[i], m, obs, lower, upper, bufs)


@njit(cache=True, borrowed=True)
def _steps(a, b, m, bufs):
    """The motion a -> b's joint steps (signed and absolute) and its bound's second-order terms."""
    sdq, dq = bufs[SDQ], bufs[DQ]
    for d in range(a.shape[0]):
        sdq[d] = b[d] - a[d]
        dq[d] = abs(sdq[d])
    if m[BOUND] == SWEPT:
        swept_second_order(m[LLEVER], m[BRADIUS], m[LNJ], dq, bufs[LA])
        swept_second_order(m[GLEVER], m[GRADIUS], m[GNJ], dq, bufs[GA])
    else:
        lever_second_order(m[LLEVER], m[BRADIUS], dq, bufs[LB])
        lever_second_order(m[GLEVER], m[GRADIUS], dq, bufs[GB])


@njit(cache=True, borrowed=True)
def interval_growth(a, b, t, h, mi, mf, buf, links, groups, pairs):
    """How far each link's and group's bounding sphere can move (the model's bound) in the
    interval [t - h, t + h] of the motion a -> b: what a motion's verdict grows them by, into
    links (L,) and groups (G,); pairs (P,): link b's growth relative to link a for a pair whose
    a is b's ancestor (-1 for the others). For audits and tests."""
    m, bufs = unpack(mi, mf), unpack_buffers(mi, buf)
    _steps(a, b, m, bufs)
    q, pose, ap, au, pris = bufs[QVEC], bufs[POSE], bufs[AXPOINT], bufs[AXDIR], bufs[PRIS]
    for d in range(a.shape[0]):
        q[d] = a[d] + t * (b[d] - a[d])
    forward(q, m[PARENT], m[ORIGIN], m[KIND], m[AXIS], m[COORD], pose)
    _axes(m, pose, ap, au, pris)
    grow = (h, bufs[DQ], ap, au, pris, bufs[SDQ])
    lc, gc, bound = bufs[LCENTRES], bufs[GCENTRES], m[BOUND]
    for li in range(links.shape[0]):
        _place(pose, m[LINK_FRAME][li], m[BLOCAL], li, lc, li)
    for g in range(groups.shape[0]):
        _place(pose, m[GROUP_FRAME][g], m[GLOCAL], g, gc, g)
    growths(bound, lc, m[BRADIUS], m[LNJ], grow, bufs[LSPEED], bufs[LB], bufs[LA], bufs[LREL], links)
    growths(bound, gc, m[GRADIUS], m[GNJ], grow, bufs[GSPEED], bufs[GB], bufs[GA], bufs[GREL], groups)
    for pi in range(pairs.shape[0]):
        j0, lb = m[PAIR_J0][pi], m[PAIR_B][pi]
        pairs[pi] = -1.0
        if j0 >= 0:
            pairs[pi] = growth_from(bound, lb, m[BRADIUS], m[LLEVER], j0, grow, bufs[LSPEED], bufs[LREL])


@njit(cache=True, borrowed=True)
def _motion_free(a, b, m, obs, lower, upper, tol, bufs, known):
    """Is the straight joint motion a -> b free everywhere along it? Returns (free,
    configurations evaluated). known: how many of its ends the caller already knows are
    free (0; 1: a; 2: a and b, e.g. a tree's states), which are then not checked first: an
    early exit only, as an interval is certified free only when all of it is, its ends too.

    Certified, not sampled. Within an interval [m - h, m + h] of the motion
    q(t) = a + t (b - a), a sphere moves at most a bound from where it is at m (the model's:
    sphere_bounds). An interval is free when its midpoint is free with every sphere (and
    group and link bounding sphere) grown by that much; intervals that are only NEAR are
    halved; a HIT at any midpoint, a NEAR interval whose largest growth is below `tol`
    metres, or more than QUEUE pending intervals, and the motion is called blocked. Joint
    limits are a box: the motion stays inside when its ends do. (Joint coordinates must
    run along the chain: SphereModel checks it.)"""
    D = a.shape[0]
    for d in range(D):
        if not (lower[d] <= a[d] <= upper[d] and lower[d] <= b[d] <= upper[d]):
            return False, 0
    q, dq, t0s, t1s = bufs[QVEC], bufs[DQ], bufs[T0S], bufs[T1S]
    _steps(a, b, m, bufs)
    evaluated = 0
    for e in range(2 - known):  # the ends not known free, exactly, first: a blocked motion is most often found there
        evaluated += 1
        if _plain_verdict(b if e == 0 else a, m, obs, bufs) == HIT:
            return False, evaluated
    head, tail = 0, 1
    t0s[0], t1s[0] = 0.0, 1.0
    while head != tail:
        t0, t1 = t0s[head % QUEUE], t1s[head % QUEUE]
        head += 1
        half = (t1 - t0) / 2
        mid = t0 + half
        for d in range(D):
            q[d] = a[d] + mid * (b[d] - a[d])
        evaluated += 1
        v = verdict(q, m, obs, bufs, True, half, dq)
        if v == FREE:
            continue
        top = bufs[TOP][0]
        if v == NEAR or v == NEAR_HIT:  # a grown sphere touches; verdict then scanned q plain (counted)
            evaluated += 1
        if v == HIT or v == NEAR_HIT or top < tol or tail - head + 2 > QUEUE:
            return False, evaluated
        t0s[tail % QUEUE], t1s[tail % QUEUE] = t0, mid
        tail += 1
        t0s[tail % QUEUE], t1s[tail % QUEUE] = mid, t1
        tail += 1
    return True, evaluated


@njit(cache=True, borrowed=True)
def motion_free(a, b, mi, mf, ob, lower, upper, tol, buf):
    """Is the straight joint motion a -> b free everywhere along it? (free, configurations
    evaluated); see _motion_free."""
    return motion_free_known(a, b, mi, mf, ob, lower, upper, tol, buf, np.int64(0))


@njit(cache=True, borrowed=True)
def motion_free_known(a, b, mi, mf, ob, lower, upper, tol, buf, known):
    """motion_free, `known` of its ends (1: a; 2: a and b) already known to be free."""
    return _motion_free(a, b, unpack(mi, mf), unpack_obstacles(ob), lower, upper, tol, unpack_buffers(mi, buf), known)


@njit(cache=True)
def motions_free(A, B, mi, mf, ob, lower, upper, tol, buf):
    """motion_free for each row pair (A[i], B[i]); also the configurations evaluated in all."""
    out = np.empty(A.shape[0], np.bool_)
    return out, _motions_into(A, B, mi, mf, ob, lower, upper, tol, buf, out)


@njit(cache=True, borrowed=True)
def _motions_into(A, B, mi, mf, ob, lower, upper, tol, buf, out):
    m, obs, bufs = unpack(mi, mf), unpack_obstacles(ob), unpack_buffers(mi, buf)
    total = 0
    for i in range(A.shape[0]):
        ok, n = _motion_free(A[i], B[i], m, obs, lower, upper, tol, bufs, np.int64(0))
        total += n
        out[i] = ok
    return total


@njit(cache=True, borrowed=True)
def any_hit(centres, radii, ob):
    """Does any sphere (centres, radii) touch an obstacle?"""
    boxes, cyls, balls, margin, _ = unpack_obstacles(ob)
    counts = (boxes.shape[0], cyls.shape[0], balls.shape[0])
    for k in range(centres.shape[0]):
        for kind in range(3):
            for j in range(counts[kind]):
                r = radii[k] + margin
                if _dist2(centres, k, boxes, cyls, balls, kind, j) <= r * r:
                    return True
    return False
