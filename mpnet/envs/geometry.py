"""A segment or ray against axis-aligned boxes, written once (numba): the slab test, `clip`, and
the loops its Python callers call. Its users: the point robot's checks
(mpnet.envs.checkers.point_kernels: a motion is free when its segment meets no closed box), the
exact 2D reference cost (mpnet.planners.reference.visible: `segments_cross`, a segment entering
a box's open interior) and the depth camera (mpnet.envs.scenes.camera: `ray_entries`, where a
ray enters a box).

The slab's ends are (lo - a) / d along each coordinate, or (lo - a) * (1 / d) where `reciprocal`
says so (the one-motion point check's arithmetic, the batch's divides): the two can differ in
the last bit at a box's face, and each caller keeps the arithmetic it planned with.
"""

from __future__ import annotations

import math

import numpy as np

from mpnet.jit import njit


@njit(cache=True, borrowed=True, inline="always")
def clip(a, d, lo, hi, j, t0, t1, reciprocal):
    """The part (t0', t1') of [t0, t1] where the line a + t d lies in the closed box
    [lo[j], hi[j]]; empty when t0' > t1'. A coordinate along which d is 0 is inside its slab
    (no bound) or outside it (empty: inf, -inf). Each arithmetic keeps the steps of the check it
    came from: by the reciprocal, ordered ends compared one by one, returning once empty (the
    one-motion check's); by division, min and max over every coordinate (the batch check's:
    an early return there cost it half again its time). Inlined, so `reciprocal` is folded."""
    for k in range(a.shape[0]):
        if d[k] == 0.0:
            if a[k] < lo[j, k] or a[k] > hi[j, k]:
                return math.inf, -math.inf
            continue
        if reciprocal:
            inv = 1.0 / d[k]
            ta, tb = (lo[j, k] - a[k]) * inv, (hi[j, k] - a[k]) * inv
            if ta > tb:
                ta, tb = tb, ta
            if ta > t0:
                t0 = ta
            if tb < t1:
                t1 = tb
            if t0 > t1:
                return t0, t1
        else:
            ta, tb = (lo[j, k] - a[k]) / d[k], (hi[j, k] - a[k]) / d[k]
            t0, t1 = max(t0, min(ta, tb)), min(t1, max(ta, tb))
    return t0, t1


@njit(cache=True)
def segments_cross(p, q, lo, hi, eps, out):
    """out[i, k]: whether segment p[i] -> q[k] enters the open interior of a box [lo[j], hi[j]]:
    its clipped piece is longer than eps (in the segment's parameter) and that piece's midpoint
    lies inside the box by more than eps along every coordinate (a chord of a convex set lies
    on its boundary or has its relative interior inside)."""
    dim = p.shape[1]
    d = np.empty(dim)
    for i in range(p.shape[0]):
        a = p[i]
        for k in range(q.shape[0]):
            for x in range(dim):
                d[x] = q[k, x] - a[x]
            crosses = False
            for j in range(lo.shape[0]):
                t0, t1 = clip(a, d, lo, hi, j, 0.0, 1.0, False)
                if not t1 - t0 > eps:
                    continue
                s = (t0 + t1) / 2
                inside = True
                for x in range(dim):
                    m = a[x] + d[x] * s
                    if not (m > lo[j, x] + eps and m < hi[j, x] - eps):
                        inside = False
                        break
                if inside:
                    crosses = True
                    break
            out[i, k] = crosses


@njit(cache=True)
def ray_entries(o, directions, lo, hi, out):
    """out[i]: where ray o + t directions[i] (t > 0) enters the closed box [lo[0], hi[0]] (its
    first t in it), inf where it never does or starts inside."""
    for i in range(directions.shape[0]):
        t0, t1 = clip(o, directions[i], lo, hi, 0, -math.inf, math.inf, False)
        out[i] = t0 if t0 <= t1 and t0 > 0.0 else math.inf
