"""A checker's compiled form: the `env` tuple a checker hands the compiled planner
(`CollisionChecker.compiled_env`), and the checks and state-space operations the planner's
kernels call on it, each robot kind's chosen here, so that the planner knows no robot kind.

An env is one tuple of arrays (kind, ints, floats, lo, hi, lower, upper, scratch): kind POINT is
the point robot's boxes (lo, hi; mpnet.envs.checkers.point_kernels), RIGID the rectangle's (box centres
and halves in lo, hi, the body and bounds in floats, ints scratch; mpnet.envs.checkers.rigid_kernels):
one compilation, cached on disk, serves both. ARM is the sphere model's (its packed ints and
floats, the packed obstacles as lo's one row, hi's one row (certify tolerance, base blocked),
its scratch, and one field more, so that the kernels compile apart for it;
mpnet.envs.checkers.sphere_checks, which counts the configurations it evaluates in counts[2]).
A robot kind of one's own: its checker's `compiled_env`, and its branch here (an 8-field env of
another kind is refused when checked, not run through the rigid body's kernels).
"""

from __future__ import annotations

from numba.extending import overload

from mpnet.envs.checkers import point_kernels as P
from mpnet.envs.checkers import rigid_kernels as R
from mpnet.envs.checkers import sphere_checks as S
from mpnet.jit import njit

POINT, RIGID, ARM = 0, 1, 2

# The env's checks, one implementation per env layout, chosen when a kernel is compiled (typing
# time): the arm's env has one field more (ARM_FIELDS), so every kernel compiles apart for the
# box robots (point, rigid: a kind test between two small checks) and for the arm (the sphere
# model). A cold cache then compiles only what the env planned on needs: the sphere model's
# checks inlined into every kernel tripled a point robot's first compilation.
BOX_FIELDS, ARM_FIELDS = 8, 9
# A box robot's env whose kind is neither POINT nor RIGID is refused, never checked as another kind's
UNKNOWN = "compiled_env: an env of an unknown robot kind (add its branch here)"


def state_free(env, counts, q):
    """Whether the state is free (the env's checker's _state_free); typed by the overload below."""
    raise NotImplementedError("compiled only")


def motion_free(env, counts, a, b):
    """Whether the motion is free (the env's checker's _motion_free); typed by the overload below."""
    raise NotImplementedError("compiled only")


def motions_free(env, counts, A, B, out):
    """out[i]: whether motion i is free (the env's checker's _motions_free); typed by the overload."""
    raise NotImplementedError("compiled only")


def _is_arm(env) -> bool:
    return len(env.types) == ARM_FIELDS


@overload(state_free, jit_options={"_nrt": False})  # borrowed (mpnet.jit), as the checks it calls
def _state_typed(env, counts, q):
    if _is_arm(env):

        def arm(env, counts, q):  # SphereChecker._state_free
            _, ints, floats, lo, hi, lower, upper, scratch, _ = env
            counts[2] += 1
            return hi[0, 1] == 0.0 and S.state_free(q, ints, floats, lo[0], lower, upper, scratch)

        return arm

    def boxes(env, counts, q):
        kind, ints, floats, lo, hi, lower, upper, scratch = env
        if kind == POINT:
            return P.state_free(q, lo, hi, lower, upper)
        if kind != RIGID:
            raise ValueError(UNKNOWN)
        return R.state_free(q, lo, hi, floats)

    return boxes


@overload(motion_free, jit_options={"_nrt": False})
def _motion_typed(env, counts, a, b):
    if _is_arm(env):

        def arm(env, counts, a, b):  # SphereChecker._motion_free
            _, ints, floats, lo, hi, lower, upper, scratch, _ = env
            if hi[0, 1] != 0.0:
                return False
            ok, n = S.motion_free(a, b, ints, floats, lo[0], lower, upper, hi[0, 0], scratch)
            counts[2] += n
            return ok

        return arm

    def boxes(env, counts, a, b):
        kind, ints, floats, lo, hi, lower, upper, scratch = env
        if kind == POINT:
            return P.motion_free(a, b, lo, hi, lower, upper, scratch)
        if kind != RIGID:
            raise ValueError(UNKNOWN)
        return R.motion_free(a, b, lo, hi, floats, ints)

    return boxes


@overload(motions_free, jit_options={"_nrt": True})  # counts: S.motions_free allocates its answers
def _motions_typed(env, counts, A, B, out):
    if _is_arm(env):

        def arm(env, counts, A, B, out):  # SphereChecker._motions_free
            _, ints, floats, lo, hi, lower, upper, scratch, _ = env
            if hi[0, 1] != 0.0:
                out[:] = False
                return
            res, n = S.motions_free(A, B, ints, floats, lo[0], lower, upper, hi[0, 0], scratch)
            out[:] = res
            counts[2] += n

        return arm

    def boxes(env, counts, A, B, out):
        kind, ints, floats, lo, hi, lower, upper, scratch = env
        if kind == POINT:
            P.motions_free(A, B, lo, hi, lower, upper, scratch, out)
        elif kind != RIGID:
            raise ValueError(UNKNOWN)
        else:  # the rigid checker's batch is its one-motion test in a loop (CollisionChecker)
            for i in range(A.shape[0]):
                out[i] = R.motion_free(A[i], B[i], lo, hi, floats, ints)

    return boxes


@njit(cache=True, borrowed=True)
def canonical(env, q):
    """The state space's wrap of a state (SE2: the angle into [-pi, pi)), in place."""
    if env[0] == RIGID:
        q[2] = R.wrap_angle(q[2])


@njit(cache=True, borrowed=True)
def wrap_difference(env, d):
    """A difference of states along the shorter way (SE2: the angle's into [-pi, pi)), in place."""
    if env[0] == RIGID:
        d[2] = R.wrap_angle(d[2])


@njit(cache=True, borrowed=True)
def bounded_dims(env, n):
    """How many leading coordinates of an n-D state have bounds to clip into (SE2: x and y; the
    angle wraps)."""
    return 2 if env[0] == RIGID else n
