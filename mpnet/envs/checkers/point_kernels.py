"""The point robot's checks (numba): PointChecker's, and the compiled planner's through it. The
one-motion slab test multiplies by the reciprocal, the batch test divides (as the numpy
checker they were ported from did: the two can differ in the last bit at a box's face, and
the planners' decisions stay the ones they made; tests/oracles.py keeps that numpy twin).

Boxes come as `lo`, `hi` (M, d): the checker's, grown by its margin; `lower`, `upper` are
the state bounds. Closed boxes: a point on a face collides.
"""

from __future__ import annotations

import numpy as np

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
    if not (in_bounds(a, lower, upper) and in_bounds(b, lower, upper)):
        return False
    for k in range(a.shape[0]):
        d[k] = b[k] - a[k]
    for j in range(lo.shape[0]):
        t0, t1 = 0.0, 1.0
        hit = True
        for k in range(a.shape[0]):
            if d[k] == 0.0:
                if a[k] < lo[j, k] or a[k] > hi[j, k]:
                    hit = False
                    break
                continue
            inv = 1.0 / d[k]
            ta, tb = (lo[j, k] - a[k]) * inv, (hi[j, k] - a[k]) * inv
            if ta > tb:
                ta, tb = tb, ta
            if ta > t0:
                t0 = ta
            if tb < t1:
                t1 = tb
            if t0 > t1:
                hit = False
                break
        if hit:
            return False
    return True


@njit(cache=True, borrowed=True)
def motions_free(A, B, lo, hi, lower, upper, out):
    """For each motion A[i] -> B[i], into out: both ends in bounds and no box met (slab test by
    division; a still coordinate inside its slab or not)."""
    n, dim = A.shape
    for i in range(n):
        ok = in_bounds(A[i], lower, upper) and in_bounds(B[i], lower, upper)
        if ok:
            for j in range(lo.shape[0]):
                tmin_max, tmax_min = -np.inf, np.inf
                for k in range(dim):
                    a, dk = A[i, k], B[i, k] - A[i, k]
                    if dk == 0.0:
                        inside = a >= lo[j, k] and a <= hi[j, k]
                        tmin, tmax = (-np.inf, np.inf) if inside else (np.inf, -np.inf)
                    else:
                        ta, tb = (lo[j, k] - a) / dk, (hi[j, k] - a) / dk
                        tmin, tmax = min(ta, tb), max(ta, tb)
                    tmin_max = max(tmin_max, tmin)
                    tmax_min = min(tmax_min, tmax)
                if max(tmin_max, 0.0) <= min(tmax_min, 1.0):
                    ok = False
                    break
        out[i] = ok
