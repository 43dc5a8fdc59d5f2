"""Collision checking of the rigid body: a rectangle at (x, y, theta) among 2D boxes,
by exact separating-axis tests (native) or python-fcl (same answers, slower)."""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from mpnet.envs.checkers.collision import PLANNING_MARGIN, CollisionChecker
from mpnet.envs.spaces import wrap_angle
from mpnet.envs.workspace import Workspace


class _RigidKernels(NamedTuple):
    """The rigid body's compiled checks, as its checker calls them (dispatchers pickle; a module does not)."""

    state_free: object
    motion_free: object
    states_free: object
    clearance: object


class RigidChecker(CollisionChecker):
    """A rectangle (body extents w x h) at (x, y, theta) among 2D boxes, by the compiled checks
    (mpnet.envs.checkers.rigid_kernels; the compiled planner's too: one implementation).

    States are exact separating-axis tests. A motion (straight in x, y; theta along the
    shorter arc) is checked by conservative advancement: at each step the largest
    separating-axis gap is a lower bound on the distance to the boxes, and no point of
    the body moves more than |dxy| + |dtheta| * half-diagonal per unit of the motion's
    parameter, so the body can advance by gap / that rate and stay free.
    """

    compiled = True

    def compiled_env(self) -> tuple:
        from mpnet.envs.checkers import boxes_compiled as B  # numba's kernels load with the compiled planner only

        near = np.empty(len(self._centres), np.int64)
        d = self.spec.state_dim
        return B.env(B.RIGID, near, self._floats, self._centres, self._halves, self._lower, self._upper, np.empty(d))

    def __init__(self, spec, ws: Workspace, margin: float = PLANNING_MARGIN):
        from mpnet.envs.checkers import rigid_kernels as k  # numba: loaded with the first checker, not on import

        super().__init__(spec, ws, margin)
        self._k = _RigidKernels(k.state_free, k.motion_free, k.states_free, k.clearance)
        self.hx, self.hy = spec.robot.size[0] / 2, spec.robot.size[1] / 2
        self.radius = math.hypot(self.hx, self.hy)
        c = (self.lo + self.hi) / 2
        h = (self.hi - self.lo) / 2
        self._boxes = [(float(cx), float(cy), float(bx), float(by)) for (cx, cy), (bx, by) in zip(c, h)]
        (self._x0, self._x1), (self._y0, self._y1) = spec.space.bounds[0], spec.space.bounds[1]
        self._centres = np.ascontiguousarray(c, float).reshape(-1, 2)
        self._halves = np.ascontiguousarray(h, float).reshape(-1, 2)
        # the body and the bounds, as rigid_kernels reads them (HX ... Y1); the radius is math.hypot's own bits
        self._floats = np.array([self.hx, self.hy, self.radius, margin, self._x0, self._x1, self._y0, self._y1])
        self._lower, self._upper = (np.ascontiguousarray(v, float) for v in (self._lower, self._upper))
        self._near = np.empty(len(self._centres), np.int64)

    def _in_bounds(self, x, y) -> bool:
        return self._x0 <= x <= self._x1 and self._y0 <= y <= self._y1

    def clearance(self, x, y, th) -> float:
        """Lower bound on the distance from the body to the nearest box (<= 0: overlap)."""
        return self._k.clearance(float(x), float(y), float(th), self._centres, self._halves, self._floats)

    def _state_free(self, q) -> bool:
        return self._k.state_free(np.asarray(q, float), self._centres, self._halves, self._floats)

    def _motion_free(self, a, b) -> bool:
        a, b = np.asarray(a, float), np.asarray(b, float)
        return self._k.motion_free(a, b, self._centres, self._halves, self._floats, self._near)

    def _states_free(self, qs: np.ndarray) -> np.ndarray:
        out = np.empty(len(qs), np.bool_)
        self._k.states_free(np.ascontiguousarray(qs), self._centres, self._halves, self._floats, out)
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

    MAX_STEPS = 20000

    def _motion_free(self, a, b) -> bool:
        """Conservative advancement on fcl's exact distance: the body advances by the distance
        over the fastest any of its points moves, |dxy| + |dtheta| * half-diagonal."""
        ax, ay, ath = a[0], a[1], a[2]
        dx, dy = b[0] - ax, b[1] - ay
        dth = wrap_angle(b[2] - ath)
        if not (self._in_bounds(ax, ay) and self._in_bounds(ax + dx, ay + dy)):
            return False
        r = self.radius  # only boxes that meet the swept disc hull can be hit
        xmin, xmax = min(ax, ax + dx) - r, max(ax, ax + dx) + r
        ymin, ymax = min(ay, ay + dy) - r, max(ay, ay + dy) + r
        if not any(x + w >= xmin and x - w <= xmax and y + h >= ymin and y - h <= ymax for x, y, w, h in self._boxes):
            return True
        rate = math.hypot(dx, dy) + abs(dth) * r
        t = 0.0
        for _ in range(self.MAX_STEPS):
            g = self.clearance(ax + t * dx, ay + t * dy, ath + t * dth)
            if g <= self.margin:
                return False
            if t >= 1.0:
                return True
            t = min(1.0, t + (g / rate if rate > 0 else math.inf))
        return False

    def _states_free(self, qs: np.ndarray) -> np.ndarray:
        return np.array([self._state_free(q) for q in qs.tolist()], bool)

    def clearance(self, x, y, th) -> float:
        self._place(x, y, th)
        data = self._fcl.DistanceData()
        self._manager.distance(self._body, data, self._fcl.defaultDistanceCallback)
        return data.result.min_distance
