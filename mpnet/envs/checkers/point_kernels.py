"""The point robot's checks (numba): PointChecker's, and the compiled planner's through it. A
motion's segment against the boxes is mpnet.envs.geometry's slab test: the one-motion check
multiplies by the reciprocal, the batch check divides (as the numpy checker they were ported
from did: the two can differ in the last bit at a box's face, and the planners' decisions stay
the ones they made; tests/oracles.py keeps that numpy twin).

Boxes come as `lo`, `hi` (M, d): the checker's, grown by its margin; `lower`, `upper` are
the state bounds. Closed boxes: a point on a face collides.
"""

from __future__ import annotations

from mpnet.envs.geometry import clip
from mpnet.jit import njit


@njit(cache=True, borrowed=True)
def in_bounds(q, lower, upper):
    for k in range(q.shape[0]):
        if not lower[k] <= q[k] <= upper[k]:
            return False
    return True


@njit(cache=True, borrowed=True)
def state_free(q, lo, hi, lower, upper):
    """In bounds and in no closed box."""
    if not in_bounds(q, lower, upper):
        return False
    for j in range(lo.shape[0]):
        inside = True
        for k in range(q.shape[0]):
            if q[k] < lo[j, k] or q[k] > hi[j, k]:
                inside = False
                break
        if inside:
            return False
    return True


@njit(cache=True, borrowed=True)
def states_free(qs, lo, hi, lower, upper, out):
    """state_free for each row of qs, into out."""
    for i in range(qs.shape[0]):
        out[i] = state_free(qs[i], lo, hi, lower, upper)


@njit(cache=True, borrowed=True)
def motion_free(a, b, lo, hi, lower, upper, d):
    """Both ends in bounds and the segment meets no box (slab test by the reciprocal). d: scratch."""
    return _segment_free(a, b, lo, hi, lower, upper, d, True)


@njit(cache=True, borrowed=True)
def motions_free(A, B, lo, hi, lower, upper, d, out):
    """For each motion A[i] -> B[i], into out: both ends in bounds and no box met (slab test by
    division). d: scratch."""
    for i in range(A.shape[0]):
        out[i] = _segment_free(A[i], B[i], lo, hi, lower, upper, d, False)


@njit(cache=True, borrowed=True, inline="always")
def _segment_free(a, b, lo, hi, lower, upper, d, reciprocal):
    """Both ends in bounds and the segment a -> b meets no closed box (mpnet.envs.geometry.clip)."""
    if not (in_bounds(a, lower, upper) and in_bounds(b, lower, upper)):
        return False
    for k in range(a.shape[0]):
        d[k] = b[k] - a[k]
    for j in range(lo.shape[0]):
        t0, t1 = clip(a, d, lo, hi, j, 0.0, 1.0, reciprocal)
        if t0 <= t1:
            return False
    return True
