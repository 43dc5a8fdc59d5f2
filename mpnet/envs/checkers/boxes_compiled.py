"""The box robots' compiled form (mpnet.envs.checkers.compiled_env): the point robot among boxes
(mpnet.envs.checkers.point_kernels) and the rectangle in SE(2) (rigid_kernels), one kind: their
env is one layout, told apart by its first field, so one compilation, cached on disk, serves
both (a test between two small checks).

The env: (kind POINT or RIGID, ints, floats, lo, hi, lower, upper, scratch, tag). POINT: the
boxes' low and high corners in lo, hi. RIGID: box centres and halves in lo, hi, the body and
bounds in floats, ints scratch. An env of this layout with another first field is refused when
checked (ValueError), never checked as one of the two.
"""

from __future__ import annotations

from mpnet.envs.checkers import point_kernels as P
from mpnet.envs.checkers import rigid_kernels as R
from mpnet.envs.checkers.compiled_env import CompiledKind, register, tag
from mpnet.jit import njit

POINT, RIGID = 0, 1
NAME = "boxes"
UNKNOWN = "boxes_compiled: an env of the box robots' layout whose first field is neither POINT nor RIGID"


def env(kind: int, ints, floats, lo, hi, lower, upper, scratch) -> tuple:
    """A box robot's env tuple (its checker's compiled_env)."""
    return (kind, ints, floats, lo, hi, lower, upper, scratch, tag(NAME))


@njit(cache=True, borrowed=True)
def state_free(env, counts, q):
    kind, ints, floats, lo, hi, lower, upper, scratch, _ = env
    if kind == POINT:
        return P.state_free(q, lo, hi, lower, upper)
    if kind != RIGID:
        raise ValueError(UNKNOWN)
    return R.state_free(q, lo, hi, floats)


@njit(cache=True, borrowed=True)
def motion_free(env, counts, a, b):
    kind, ints, floats, lo, hi, lower, upper, scratch, _ = env
    if kind == POINT:
        return P.motion_free(a, b, lo, hi, lower, upper, scratch)
    if kind != RIGID:
        raise ValueError(UNKNOWN)
    return R.motion_free(a, b, lo, hi, floats, ints)


@njit(cache=True)
def motions_free(env, counts, A, B, out):
    kind, ints, floats, lo, hi, lower, upper, scratch, _ = env
    if kind == POINT:
        P.motions_free(A, B, lo, hi, lower, upper, scratch, out)
    elif kind != RIGID:
        raise ValueError(UNKNOWN)
    else:  # the rigid checker's batch is its one-motion test in a loop (CollisionChecker)
        for i in range(A.shape[0]):
            out[i] = R.motion_free(A[i], B[i], lo, hi, floats, ints)


@njit(cache=True, borrowed=True)
def canonical(env, q):
    if env[0] == RIGID:
        q[2] = R.wrap_angle(q[2])


@njit(cache=True, borrowed=True)
def wrap_difference(env, d):
    if env[0] == RIGID:
        d[2] = R.wrap_angle(d[2])


@njit(cache=True, borrowed=True)
def bounded_dims(env, n):
    return 2 if env[0] == RIGID else n


register(CompiledKind(NAME, state_free, motion_free, motions_free, canonical, wrap_difference, bounded_dims))
