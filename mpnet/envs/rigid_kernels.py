"""The rigid body's checks compiled (numba), for the compiled planner: RigidChecker's separating
axes and conservative advancement, the same operations in the same order.

`centres`, `halves` (M, 2) are the checker's margin-grown boxes; `f` holds the body and the
bounds: hx, hy, radius, margin, x0, x1, y0, y1 (RigidChecker's own floats, computed once by
Python, so that the radius is math.hypot's own bits).
"""

from __future__ import annotations

import math

from mpnet.jit import njit

HX, HY, RADIUS, MARGIN, X0, X1, Y0, Y1 = range(8)
MAX_STEPS = 20000  # RigidChecker.MAX_STEPS


@njit(cache=True)
def wrap_angle(a):
    """mpnet.envs.spaces.wrap_angle: into [-pi, pi)."""
    return (a + math.pi) % (2 * math.pi) - math.pi


@njit(cache=True)
def _in_bounds(f, x, y):
    return f[X0] <= x <= f[X1] and f[Y0] <= y <= f[Y1]


@njit(cache=True)
def state_free(q, centres, halves, f):
    """RigidChecker._state_free: in bounds and every box separated (clearance > 0)."""
    x, y, th = q[0], q[1], q[2]
    if not _in_bounds(f, x, y):
        return False
    c, s = math.cos(th), math.sin(th)
    ac, as_ = abs(c), abs(s)
    hx, hy = f[HX], f[HY]
    ex = ac * hx + as_ * hy
    ey = as_ * hx + ac * hy
    best = math.inf
    for j in range(centres.shape[0]):
        bx, by, bhx, bhy = centres[j, 0], centres[j, 1], halves[j, 0], halves[j, 1]
        dx, dy = bx - x, by - y
        g = max(
            abs(dx) - ex - bhx,
            abs(dy) - ey - bhy,
            abs(dx * c + dy * s) - hx - bhx * ac - bhy * as_,
            abs(-dx * s + dy * c) - hy - bhx * as_ - bhy * ac,
        )
        if g < best:
            best = g
    return best > 0.0


@njit(cache=True)
def _safe_step(x, y, th, centres, halves, near, n_near, f, dx, dy, dth):
    """RigidChecker._safe_step over the boxes near[:n_near]: -1.0 where it returns None."""
    c, s = math.cos(th), math.sin(th)
    ac, as_ = abs(c), abs(s)
    hx, hy, m = f[HX], f[HY], f[MARGIN]
    ex, ey = ac * hx + as_ * hy, as_ * hx + ac * hy
    spin = abs(dth) * f[RADIUS]
    rate, rate_x, rate_y = math.hypot(dx, dy) + spin, abs(dx) + spin, abs(dy) + spin
    best = math.inf
    for i in range(n_near):
        j = near[i]
        ddx, ddy = centres[j, 0] - x, centres[j, 1] - y
        bhx, bhy = halves[j, 0], halves[j, 1]
        gx = abs(ddx) - ex - bhx
        gy = abs(ddy) - ey - bhy
        g = max(
            gx,
            gy,
            abs(ddx * c + ddy * s) - hx - bhx * ac - bhy * as_,
            abs(ddy * c - ddx * s) - hy - bhx * as_ - bhy * ac,
        )
        if g <= m:
            return -1.0
        step = g / rate if rate > 0 else math.inf
        if gx > m:
            step = max(step, gx / rate_x if rate_x > 0 else math.inf)
        if gy > m:
            step = max(step, gy / rate_y if rate_y > 0 else math.inf)
        if step < best:
            best = step
    return best


@njit(cache=True)
def motion_free(a, b, centres, halves, f, near):
    """RigidChecker._motion_free: ends in bounds, then conservative advancement against the
    boxes that meet the swept disc hull. near: (M,) int64 scratch."""
    ax, ay, ath = a[0], a[1], a[2]
    dx, dy = b[0] - ax, b[1] - ay
    dth = wrap_angle(b[2] - ath)
    if not (_in_bounds(f, ax, ay) and _in_bounds(f, ax + dx, ay + dy)):
        return False
    r = f[RADIUS]
    xmin, xmax = min(ax, ax + dx) - r, max(ax, ax + dx) + r
    ymin, ymax = min(ay, ay + dy) - r, max(ay, ay + dy) + r
    n = 0
    for j in range(centres.shape[0]):
        bx, by, bhx, bhy = centres[j, 0], centres[j, 1], halves[j, 0], halves[j, 1]
        if bx + bhx >= xmin and bx - bhx <= xmax and by + bhy >= ymin and by - bhy <= ymax:
            near[n] = j
            n += 1
    if n == 0:
        return True
    t = 0.0
    for _ in range(MAX_STEPS):
        step = _safe_step(ax + t * dx, ay + t * dy, ath + t * dth, centres, halves, near, n, f, dx, dy, dth)
        if step < 0.0:
            return False
        if t >= 1.0:
            return True
        t = min(1.0, t + step)
    return False
