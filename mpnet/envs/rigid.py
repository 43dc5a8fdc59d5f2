"""Collision checking of the rigid body: a rectangle at (x, y, theta) among 2D boxes,
by exact separating-axis tests (native) or python-fcl (same answers, slower)."""

from __future__ import annotations

import math

import numpy as np

from mpnet.envs.collision import PLANNING_MARGIN, CollisionChecker
from mpnet.envs.spaces import wrap_angle
from mpnet.envs.workspace import Workspace


class RigidChecker(CollisionChecker):
    """A rectangle (body extents w x h) at (x, y, theta) among 2D boxes.

    States are exact separating-axis tests. A motion (straight in x, y; theta along the
    shorter arc) is checked by conservative advancement: at each step the largest
    separating-axis gap is a lower bound on the distance to the boxes, and no point of
    the body moves more than |dxy| + |dtheta| * half-diagonal per unit of the motion's
    parameter, so the body can advance by gap / that rate and stay free (_safe_step).
    """

    MAX_STEPS = 20000
    compiled = True

    def compiled_env(self) -> tuple:
        from mpnet.envs.compiled_env import RIGID  # numba's kernels load with the compiled planner only

        floats = np.array([self.hx, self.hy, self.radius, self.margin, self._x0, self._x1, self._y0, self._y1], float)
        centres = np.array([b[:2] for b in self._boxes], float).reshape(-1, 2)
        halves = np.array([b[2:] for b in self._boxes], float).reshape(-1, 2)
        lower, upper = (np.ascontiguousarray(v, float) for v in (self.spec.space.lower, self.spec.space.upper))
        d = self.spec.state_dim
        return (RIGID, np.empty(len(centres), np.int64), floats, centres, halves, lower, upper, np.empty(d))

    def __init__(self, spec, ws: Workspace, margin: float = PLANNING_MARGIN):
        super().__init__(spec, ws, margin)
        self.hx, self.hy = spec.robot.size[0] / 2, spec.robot.size[1] / 2
        self.radius = math.hypot(self.hx, self.hy)
        c = (self.lo + self.hi) / 2
        h = (self.hi - self.lo) / 2
        self._boxes = [(float(cx), float(cy), float(bx), float(by)) for (cx, cy), (bx, by) in zip(c, h)]
        self._c, self._h = c, h
        (self._x0, self._x1), (self._y0, self._y1) = spec.space.bounds[0], spec.space.bounds[1]

    def _in_bounds(self, x, y) -> bool:
        return self._x0 <= x <= self._x1 and self._y0 <= y <= self._y1

    def clearance(self, x, y, th, boxes) -> float:
        """Lower bound on the distance from the body to the nearest box (<= 0: overlap)."""
        c, s = math.cos(th), math.sin(th)
        ac, as_ = abs(c), abs(s)
        hx, hy = self.hx, self.hy
        ex = ac * hx + as_ * hy
        ey = as_ * hx + ac * hy
        best = math.inf
        for bx, by, bhx, bhy in boxes:
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

    def _state_free(self, q) -> bool:
        x, y, th = q[0], q[1], q[2]
        if not self._in_bounds(x, y):
            return False
        return self.clearance(x, y, th, self._boxes) > 0.0

    def _motion_free(self, a, b) -> bool:
        ax, ay, ath = a[0], a[1], a[2]
        dx, dy = b[0] - ax, b[1] - ay
        dth = wrap_angle(b[2] - ath)
        if not (self._in_bounds(ax, ay) and self._in_bounds(ax + dx, ay + dy)):
            return False
        # Only boxes that meet the swept disc hull can be hit.
        r = self.radius
        xmin, xmax = min(ax, ax + dx) - r, max(ax, ax + dx) + r
        ymin, ymax = min(ay, ay + dy) - r, max(ay, ay + dy) + r
        boxes = [
            bx
            for bx in self._boxes
            if bx[0] + bx[2] >= xmin and bx[0] - bx[2] <= xmax and bx[1] + bx[3] >= ymin and bx[1] - bx[3] <= ymax
        ]
        if not boxes:
            return True
        t = 0.0
        for _ in range(self.MAX_STEPS):
            step = self._safe_step(ax + t * dx, ay + t * dy, ath + t * dth, boxes, dx, dy, dth)
            if step is None:
                return False
            if t >= 1.0:
                return True
            t = min(1.0, t + step)
        return False

    def _safe_step(self, x, y, th, boxes, dx, dy, dth) -> float | None:
        """How far the motion's parameter may advance from (x, y, th) without touching any
        (margin-inflated) box; None when one is within the margin already. Stepping the
        whole gap lands a head-on approach on the contact, where the next call stops it.

        Two certificates per box, the larger wins: the overall gap (a distance bound) over
        the fastest any body point moves, |dxy| + |dtheta| * half-diagonal; and the gap
        along a world axis over how fast the body's extent on that axis can grow,
        |d(axis)| + |dtheta| * half-diagonal. The second lets a body slide along a face
        close by in one step instead of thousands."""
        c, s = math.cos(th), math.sin(th)
        ac, as_ = abs(c), abs(s)
        hx, hy, m = self.hx, self.hy, self.margin
        ex, ey = ac * hx + as_ * hy, as_ * hx + ac * hy
        spin = abs(dth) * self.radius
        rate, rate_x, rate_y = math.hypot(dx, dy) + spin, abs(dx) + spin, abs(dy) + spin
        best = math.inf
        for bx, by, bhx, bhy in boxes:
            ddx, ddy = bx - x, by - y
            gx = abs(ddx) - ex - bhx
            gy = abs(ddy) - ey - bhy
            g = max(
                gx,
                gy,
                abs(ddx * c + ddy * s) - hx - bhx * ac - bhy * as_,
                abs(ddy * c - ddx * s) - hy - bhx * as_ - bhy * ac,
            )
            if g <= m:
                return None
            step = g / rate if rate > 0 else math.inf
            if gx > m:
                step = max(step, gx / rate_x if rate_x > 0 else math.inf)
            if gy > m:
                step = max(step, gy / rate_y if rate_y > 0 else math.inf)
            if step < best:
                best = step
        return best

    def _states_free(self, qs: np.ndarray) -> np.ndarray:
        inb = (qs[:, 0] >= self._x0) & (qs[:, 0] <= self._x1) & (qs[:, 1] >= self._y0) & (qs[:, 1] <= self._y1)
        if not self._boxes:
            return inb
        return inb & (rect_box_gaps(qs, self.hx, self.hy, self._c, self._h).min(axis=1) > 0.0)


def rect_box_gaps(qs: np.ndarray, hx: float, hy: float, centers: np.ndarray, halves: np.ndarray) -> np.ndarray:
    """(N, M) separating-axis gaps between rectangles at states qs and boxes (<= 0: overlap).

    One box at a time on whole columns: the few boxes make this ~5x faster than (N, M)
    broadcasting."""
    x, y = qs[:, 0], qs[:, 1]
    c, s = np.cos(qs[:, 2]), np.sin(qs[:, 2])
    ac, as_ = np.abs(c), np.abs(s)
    ex, ey = ac * hx + as_ * hy, as_ * hx + ac * hy
    out = np.empty((len(qs), len(centers)))
    for j, ((bx, by), (bhx, bhy)) in enumerate(zip(centers.tolist(), halves.tolist())):
        dx, dy = bx - x, by - y
        g = np.abs(dx) - ex - bhx
        np.maximum(g, np.abs(dy) - ey - bhy, out=g)
        np.maximum(g, np.abs(dx * c + dy * s) - hx - bhx * ac - bhy * as_, out=g)
        np.maximum(g, np.abs(dy * c - dx * s) - hy - bhx * as_ - bhy * ac, out=g)
        out[:, j] = g
    return out


class FclRigidChecker(RigidChecker):
    """The rigid body through python-fcl: states by its collision query, motions by
    conservative advancement on its exact distance. The blocks are extruded boxes, the
    body a box of the same height, so 3D distances equal the 2D ones."""

    def __init__(self, spec, ws: Workspace, margin: float = PLANNING_MARGIN):
        import fcl

        super().__init__(spec, ws, margin)
        self._fcl = fcl
        self._objects = [
            fcl.CollisionObject(fcl.Box(2 * bx, 2 * by, 1.0), fcl.Transform(np.array([cx, cy, 0.0])))
            for cx, cy, bx, by in self._boxes
        ]
        self._manager = fcl.DynamicAABBTreeCollisionManager()
        self._manager.registerObjects(self._objects)
        self._manager.setup()
        self._body = fcl.CollisionObject(fcl.Box(2 * self.hx, 2 * self.hy, 1.0), fcl.Transform())

    def _place(self, x, y, th):
        c, s = math.cos(th), math.sin(th)
        rot = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
        self._body.setTransform(self._fcl.Transform(rot, np.array([x, y, 0.0])))

    def _state_free(self, q) -> bool:
        if not self._in_bounds(q[0], q[1]):
            return False
        self._place(q[0], q[1], q[2])
        data = self._fcl.CollisionData(request=self._fcl.CollisionRequest())
        self._manager.collide(self._body, data, self._fcl.defaultCollisionCallback)
        return not data.result.is_collision

    def _safe_step(self, x, y, th, boxes, dx, dy, dth) -> float | None:
        g = self.clearance(x, y, th, boxes)
        if g <= self.margin:
            return None
        rate = math.hypot(dx, dy) + abs(dth) * self.radius
        return g / rate if rate > 0 else math.inf

    def clearance(self, x, y, th, boxes) -> float:
        self._place(x, y, th)
        data = self._fcl.DistanceData()
        self._manager.distance(self._body, data, self._fcl.defaultDistanceCallback)
        return data.result.min_distance
