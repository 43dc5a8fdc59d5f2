"""The arm's compiled form (mpnet.envs.checkers.compiled_env): the sphere model's checks
(mpnet.envs.checkers.sphere_checks, which counts the configurations it evaluates in counts[2]).

The env: (0, the model's packed ints and floats, the packed obstacles as lo's one row, hi's one
row (certify tolerance, base blocked), joint lower and upper bounds, scratch, tag): its
checker's compiled_env (mpnet.envs.checkers.spheres.SphereChecker).
"""

from __future__ import annotations

import numpy as np

from mpnet.envs.checkers import sphere_checks as S
from mpnet.envs.checkers.compiled_env import CompiledKind, register, tag
from mpnet.jit import njit

NAME = "spheres"


def env(ints, floats, obstacles, tolerance: float, base_blocked: bool, lower, upper, scratch) -> tuple:
    """The sphere checker's env tuple."""
    status = np.array([[tolerance, 1.0 if base_blocked else 0.0]])
    return (0, ints, floats, np.ascontiguousarray(obstacles, float)[None], status, lower, upper, scratch, tag(NAME))


@njit(cache=True, borrowed=True)
def state_free(env, counts, q):  # SphereChecker._state_free
    _, ints, floats, lo, hi, lower, upper, scratch, _ = env
    counts[2] += 1
    return hi[0, 1] == 0.0 and S.state_free(q, ints, floats, lo[0], lower, upper, scratch)


@njit(cache=True, borrowed=True)
def motion_free_known(env, counts, a, b, known):
    _, ints, floats, lo, hi, lower, upper, scratch, _ = env
    if hi[0, 1] != 0.0:
        return False
    ok, n = S.motion_free_known(a, b, ints, floats, lo[0], lower, upper, hi[0, 0], scratch, known)
    counts[2] += n
    return ok


@njit(cache=True, borrowed=True)
def motion_free(env, counts, a, b):  # SphereChecker._motion_free
    return motion_free_known(env, counts, a, b, np.int64(0))  # int64, not a literal: see sphere_checks


@njit(cache=True)  # S.motions_free allocates its answers
def motions_free(env, counts, A, B, out):  # SphereChecker._motions_free
    _, ints, floats, lo, hi, lower, upper, scratch, _ = env
    if hi[0, 1] != 0.0:
        out[:] = False
        return
    res, n = S.motions_free(A, B, ints, floats, lo[0], lower, upper, hi[0, 0], scratch)
    out[:] = res
    counts[2] += n


register(CompiledKind(NAME, state_free, motion_free, motions_free, motion_free_known=motion_free_known))
