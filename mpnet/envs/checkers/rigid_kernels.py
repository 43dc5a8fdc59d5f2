"""The rigid body's checks (numba): separating axes and conservative advancement, RigidChecker's
and the compiled planner's through it (one implementation; see RigidChecker for the bound).

`centres`, `halves` (M, 2) are the checker's margin-grown boxes; `f` holds the body and the
bounds: hx, hy, radius, margin, x0, x1, y0, y1 (RigidChecker's own floats, computed once by
Python, so that the radius is math.hypot's own bits).
"""

from __future__ import annotations

import math

from mpnet.jit import njit

HX, HY, RADIUS, MARGIN, X0, X1, Y0, Y1 = range(8)
MAX_STEPS = 20000  # advancement steps before a motion is called blocked


@njit(cache=True, borrowed=True)
def wrap_angle(a):
    """mpnet.envs.spaces.wrap_angle: into [-pi, pi)."""
    return (a + math.pi) % (2 * math.pi) - math.pi


@njit(cache=True, borrowed=True)
def _in_bounds(f, x, y):
    return f[X0] <= x <= f[X1] and f[Y0] <= y <= f[Y1]


@njit(cache=True, borrowed=True)
def clearance(x, y, th, centres, halves, f):
    """Lower bound on the distance from the body at (x, y, th) to the nearest box (<= 0: overlap)."""
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
    return best


@njit(cache=True, borrowed=True)
def state_free(q, centres, halves, f):
    """In bounds and every box separated (clearance > 0)."""
    if not _in_bounds(f, q[0], q[1]):
        return False
    return clearance(q[0], q[1], q[2], centres, halves, f) > 0.0


@njit(cache=True, borrowed=True)
def states_free(qs, centres, halves, f, out):
    """state_free for each row of qs, into out."""
    for i in range(qs.shape[0]):
        out[i] = state_free(qs[i], centres, halves, f)


@njit(cache=True, borrowed=True)
def _safe_step(x, y, th, centres, halves, near, n_near, f, dx, dy, dth):
    """How far the motion's parameter may advance from (x, y, th) without touching any of the
    boxes near[:n_near] (margin-grown); -1.0 when one is within the margin already. Stepping
    the whole gap lands a head-on approach on the contact, where the next call stops it.

    Two certificates per box, the larger wins: the overall gap (a distance bound) over the
    fastest any body point moves, |dxy| + |dtheta| * half-diagonal; and the gap along a world
    axis over how fast the body's extent on that axis can grow, |d(axis)| + |dtheta| *
    half-diagonal. The second lets a body slide along a face close by in one step instead of
    thousands."""
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


@njit(cache=True, borrowed=True)
def advance(a, b, centres, halves, f, near):
    """(free, steps): is the motion free (ends in bounds, then conservative advancement against
    the boxes that meet the swept disc hull), and how many advancement steps it took. x, y move
    straight, theta along the shorter arc. near: (M,) int64 scratch."""
    ax, ay, ath = a[0], a[1], a[2]
    dx, dy = b[0] - ax, b[1] - ay
    dth = wrap_angle(b[2] - ath)
    if not (_in_bounds(f, ax, ay) and _in_bounds(f, ax + dx, ay + dy)):
        return False, 0
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
        return True, 0
    t = 0.0
    for k in range(MAX_STEPS):
        step = _safe_step(ax + t * dx, ay + t * dy, ath + t * dth, centres, halves, near, n, f, dx, dy, dth)
        if step < 0.0:
            return False, k + 1
        if t >= 1.0:
            return True, k + 1
        t = min(1.0, t + step)
    return False, MAX_STEPS


@njit(cache=True, borrowed=True)
def motion_free(a, b, centres, halves, f, near):
    """Is the motion a -> b free (advance's verdict)?"""
    return advance(a, b, centres, halves, f, near)[0]
