"""Numpy and plain-Python twins of the compiled geometric checks, kept only as the tests'
oracles: the arithmetic the kernels were ported from (and must still answer as, bit for bit),
never used by the package."""

from __future__ import annotations

import math

import numpy as np


def point_state_free(q, lo, hi, lower, upper) -> bool:
    """In bounds and in no closed box [lo[j], hi[j]]."""
    if not all(lw <= v <= up for v, lw, up in zip(q, lower, upper)):
        return False
    return not any(all(a <= v <= b for v, a, b in zip(q, blo, bhi)) for blo, bhi in zip(lo, hi))


def segments_hit_boxes(a: np.ndarray, b: np.ndarray, lo: np.ndarray, hi: np.ndarray, by_reciprocal=False) -> np.ndarray:
    """Slab test: (N, M) array, True where segment i meets closed box j; dividing (the batch
    check's arithmetic) or multiplying by the reciprocal (the one-motion check's)."""
    d = (b - a)[:, None, :]
    a = a[:, None, :]
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        if by_reciprocal:
            inv = 1.0 / d
            ta, tb = (lo[None] - a) * inv, (hi[None] - a) * inv
        else:
            ta, tb = (lo[None] - a) / d, (hi[None] - a) / d
    still = d == 0.0
    inside = (a >= lo[None]) & (a <= hi[None])
    tmin = np.where(still, np.where(inside, -np.inf, np.inf), np.minimum(ta, tb))
    tmax = np.where(still, np.where(inside, np.inf, -np.inf), np.maximum(ta, tb))
    t0 = np.maximum(tmin.max(axis=2), 0.0)
    t1 = np.minimum(tmax.min(axis=2), 1.0)
    return t0 <= t1


def point_motion_free(a, b, lo, hi, lower, upper) -> bool:
    """One motion, by the reciprocal."""
    a, b = np.asarray(a, float)[None], np.asarray(b, float)[None]
    return bool(point_motions_free(a, b, lo, hi, lower, upper, by_reciprocal=True)[0])


def point_motions_free(a, b, lo, hi, lower, upper, by_reciprocal=False) -> np.ndarray:
    """Both ends in bounds (the bounds are convex) and no box met."""
    inb = np.all((a >= lower) & (a <= upper) & (b >= lower) & (b <= upper), axis=1)
    return inb & ~segments_hit_boxes(a, b, lo, hi, by_reciprocal).any(axis=1)


def segments_visible(p, q, lo, hi, eps=1e-9) -> np.ndarray:
    """(m, k): segment p_i -> q_j enters no box's open interior (mpnet.planners.reference.visible
    as it was written in numpy: Liang-Barsky clipping, a piece longer than eps with its midpoint
    inside by more than eps crosses)."""
    if len(lo) == 0:
        return np.ones((len(p), len(q)), bool)
    a = p[:, None, None, :]
    d = q[None, :, None, :] - a
    flat = d == 0
    inside = (a >= lo[None, None]) & (a <= hi[None, None])
    with np.errstate(divide="ignore", invalid="ignore"):
        t_lo = (lo[None, None] - a) / d
        t_hi = (hi[None, None] - a) / d
        enter = np.where(flat, np.where(inside, -np.inf, np.inf), np.minimum(t_lo, t_hi))
        leave = np.where(flat, np.where(inside, np.inf, -np.inf), np.maximum(t_lo, t_hi))
        t0 = np.maximum(enter.max(-1), 0.0)
        t1 = np.minimum(leave.min(-1), 1.0)
        mid = a + d * ((t0 + t1) / 2)[..., None]
    strictly_in = ((mid > lo[None, None] + eps) & (mid < hi[None, None] - eps)).all(-1)
    return ~((t1 - t0 > eps) & strictly_in).any(-1)


def ray_box_entries(o, d, half) -> np.ndarray:
    """Where rays o + t d (o (n, 3) or (3,), d (n, 3)) enter the box of half extents `half`
    about the origin, inf where never or from inside (mpnet.envs.scenes.camera's, in numpy)."""
    with np.errstate(divide="ignore", invalid="ignore"):
        t1, t2 = (-half - o) / d, (half - o) / d
    near = np.nanmax(np.minimum(t1, t2), axis=1)
    far = np.nanmin(np.maximum(t1, t2), axis=1)
    return np.where((near <= far) & (near > 0), near, np.inf)


def _gaps(hx, hy, x, y, th, boxes):
    """Per box: the separating-axis gaps along the world x and y axes and the overall gap (the
    largest of the four axes'), as arrays; math.cos and math.sin as the kernels call them."""
    c, s = math.cos(th), math.sin(th)
    ac, as_ = abs(c), abs(s)
    bx, by, bhx, bhy = np.asarray(boxes, float).reshape(-1, 4).T
    dx, dy = bx - x, by - y
    gx = np.abs(dx) - (ac * hx + as_ * hy) - bhx
    gy = np.abs(dy) - (as_ * hx + ac * hy) - bhy
    along = np.abs(dx * c + dy * s) - hx - bhx * ac - bhy * as_
    across = np.abs(-dx * s + dy * c) - hy - bhx * as_ - bhy * ac
    return gx, gy, np.maximum(np.maximum(gx, gy), np.maximum(along, across))


def rigid_clearance(hx, hy, x, y, th, boxes) -> float:
    """Separating-axis lower bound on the distance from the rectangle to the boxes
    ((cx, cy, half-x, half-y) each; <= 0: overlap)."""
    return float(_gaps(hx, hy, x, y, th, boxes)[2].min(initial=math.inf))


def rigid_motion_free(hx, hy, margin, bounds, boxes, a, b, max_steps=20000) -> bool:
    """Conservative advancement of the rectangle from a to b (theta along the shorter arc)
    against the boxes that meet the swept disc hull: each step is, over the boxes, the least of
    the larger of two certificates (the gap over the fastest point speed; a world axis's gap
    over how fast the body's extent on it grows)."""
    (x0, x1), (y0, y1) = bounds
    radius = math.hypot(hx, hy)
    ax, ay, ath = a[0], a[1], a[2]
    dx, dy = b[0] - ax, b[1] - ay
    dth = (b[2] - ath + math.pi) % (2 * math.pi) - math.pi
    if not (x0 <= ax <= x1 and y0 <= ay <= y1 and x0 <= ax + dx <= x1 and y0 <= ay + dy <= y1):
        return False
    box = np.asarray(boxes, float).reshape(-1, 4)
    lo_x, hi_x = min(ax, ax + dx) - radius, max(ax, ax + dx) + radius
    lo_y, hi_y = min(ay, ay + dy) - radius, max(ay, ay + dy) + radius
    box = box[(box[:, 0] + box[:, 2] >= lo_x) & (box[:, 0] - box[:, 2] <= hi_x)]
    box = box[(box[:, 1] + box[:, 3] >= lo_y) & (box[:, 1] - box[:, 3] <= hi_y)]
    if not len(box):
        return True
    spin = abs(dth) * radius
    speeds = (math.hypot(dx, dy) + spin, abs(dx) + spin, abs(dy) + spin)
    per = lambda g, v: g / v if v > 0 else np.full_like(g, math.inf)  # noqa: E731
    t = 0.0
    for _ in range(max_steps):
        gx, gy, g = _gaps(hx, hy, ax + t * dx, ay + t * dy, ath + t * dth, box)
        if (g <= margin).any():
            return False
        if t >= 1.0:
            return True
        step = per(g, speeds[0])
        step = np.where(gx > margin, np.maximum(step, per(gx, speeds[1])), step)
        step = np.where(gy > margin, np.maximum(step, per(gy, speeds[2])), step)
        t = min(1.0, t + float(step.min()))
    return False
