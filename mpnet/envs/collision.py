"""Collision checking against closed axis-aligned boxes, with every check counted.

One checker per workspace serves every planner, for single states (plain Python: OMPL
calls it per state, where a numpy call costs ~30 us) and for batches (numpy). The point
robots' and the rigid body's motions are checked continuously, never by sampling: exactly
for point robots (slab test), and by conservative advancement on a proven clearance bound
for the rigid body (mpnet.envs.rigid), so a motion called free is free at any resolution.
The arm's checkers evaluate configurations along a motion: the sphere checker
(mpnet.envs.spheres) with a bound on how far its spheres move between them, pybullet's
(mpnet.envs.pybullet_arm) at env.motion_step; the fine re-check then judges every path.

A robot kind's checker subclasses CollisionChecker and implements the four `_free`
methods; everything else uses only the public, counted calls.
"""

from __future__ import annotations

from abc import ABC, abstractmethod

import numpy as np

from mpnet.envs.workspace import Workspace

# Boxes are inflated by this much while planning, so that a path accepted by the exact
# test is not rejected by rounding in a sampled re-check; verification uses exact boxes.
PLANNING_MARGIN = 1e-6


GEOMETRY = ("_state_free", "_motion_free", "_states_free", "_motions_free")  # what a checker answers with


class CollisionChecker(ABC):
    """The public interface every planner uses: single and batch state and motion checks,
    each counted. Subclasses implement the geometry (`_state_free`, `_motion_free`,
    `_states_free`, `_motions_free`)."""

    def __init__(self, spec, ws: Workspace, margin: float = PLANNING_MARGIN):
        if ws.dim != spec.workspace_dim:
            raise ValueError(
                f"workspace {ws.id!r} has {ws.dim}-D obstacles, env {spec.name} needs {spec.workspace_dim}-D"
            )
        self.spec = spec
        self.workspace = ws
        self.margin = margin
        self.lo = ws.lo - margin
        self.hi = ws.hi + margin
        self._lower = spec.space.lower
        self._upper = spec.space.upper
        self.state_checks = 0
        self.motion_checks = 0

    compiled = False  # whether compiled_env gives the compiled planner this checker's form

    def compiled_env(self) -> tuple:
        """This checker's geometry as the compiled planner's `env` tuple (mpnet.envs.compiled_env):
        the one interface through which the planner reaches a robot's kernels."""
        raise ValueError(f"the compiled planner has no kernels for {type(self).__name__}")

    def __init_subclass__(cls, **kwargs):
        """A subclass that changes the geometry (fcl's rigid checker) and not the compiled form
        has none: its parent's kernels would answer for other geometry, silently."""
        super().__init_subclass__(**kwargs)
        own = vars(cls)
        if "compiled_env" not in own and any(k in own for k in GEOMETRY):
            cls.compiled = False
            cls.compiled_env = CollisionChecker.compiled_env

    @property
    def checks(self) -> int:
        return self.state_checks + self.motion_checks

    def reset_counts(self) -> None:
        self.state_checks = 0
        self.motion_checks = 0

    def counts(self) -> dict:
        return {"collision_checks": self.checks, "state_checks": self.state_checks, "motion_checks": self.motion_checks}

    def is_valid(self, q) -> bool:
        self.state_checks += 1
        return self._state_free(q)

    def motion_valid(self, a, b) -> bool:
        """The whole straight motion a -> b (endpoints included) is free and in bounds."""
        self.motion_checks += 1
        return self._motion_free(a, b)

    def states_valid(self, qs) -> np.ndarray:
        """One bool per state (rows of qs)."""
        qs = np.asarray(qs, float).reshape(-1, self.spec.state_dim)
        self.state_checks += len(qs)
        return self._states_free(qs)

    def motions_valid(self, a, b) -> np.ndarray:
        """One bool per straight motion a[i] -> b[i]."""
        a = np.asarray(a, float).reshape(-1, self.spec.state_dim)
        b = np.asarray(b, float).reshape(-1, self.spec.state_dim)
        self.motion_checks += len(a)
        return self._motions_free(a, b)

    def warm_up(self, q) -> None:
        """Each kind of check once from the valid-or-not state q, then the counts reset: what a
        first call pays (numba's compilation or its on-disk cache load, lazy set-up) is paid
        here, before a timed query, and not by the first query's clock."""
        q = np.asarray(q, float).reshape(self.spec.state_dim)
        r = np.clip(q + 0.01 * (self._upper - self._lower), self._lower, self._upper)
        self.is_valid(q)
        self.motion_valid(q, r)
        self.states_valid(np.stack([q, r]))
        self.motions_valid(np.stack([q, r]), np.stack([r, q]))
        self.reset_counts()

    @abstractmethod
    def _state_free(self, q) -> bool: ...

    @abstractmethod
    def _motion_free(self, a, b) -> bool: ...

    def _states_free(self, qs: np.ndarray) -> np.ndarray:
        return np.array([self._state_free(q) for q in qs.tolist()], bool)

    def _motions_free(self, a: np.ndarray, b: np.ndarray) -> np.ndarray:
        return np.array([self._motion_free(x, y) for x, y in zip(a, b)], bool)


class SampledConfigurations(CollisionChecker):
    """A checker that evaluates configurations one by one (the arm's): it also counts them,
    motions' included, as `configurations_checked`."""

    def __init__(self, spec, ws: Workspace, margin: float = PLANNING_MARGIN):
        super().__init__(spec, ws, margin)
        self.configurations = 0

    def counts(self) -> dict:
        return {**super().counts(), "configurations_checked": self.configurations}

    def reset_counts(self) -> None:
        super().reset_counts()
        self.configurations = 0


class PointChecker(CollisionChecker):
    """A point robot in 2D or 3D: a point collides when it lies in a closed box."""

    compiled = True

    def compiled_env(self) -> tuple:
        from mpnet.envs.compiled_env import POINT  # numba's kernels load with the compiled planner only

        d = self.spec.state_dim
        lo, hi = (np.ascontiguousarray(v, float).reshape(-1, d) for v in (self.lo, self.hi))
        lower, upper = (np.ascontiguousarray(v, float) for v in (self.spec.space.lower, self.spec.space.upper))
        return (POINT, np.zeros(0, np.int64), np.zeros(0), lo, hi, lower, upper, np.empty(d))

    def __init__(self, spec, ws: Workspace, margin: float = PLANNING_MARGIN):
        super().__init__(spec, ws, margin)
        self._boxes = [(tuple(lo), tuple(hi)) for lo, hi in zip(self.lo.tolist(), self.hi.tolist())]
        self._bounds = [tuple(b) for b in spec.space.bounds]
        self._d = spec.state_dim
        if self._d == 2:  # the plane: an unrolled slab test (steerTo's one motion is MPNet's hot path)
            self._boxes2 = [(lo[0], lo[1], hi[0], hi[1]) for lo, hi in self._boxes]
            self._motion_free = self._motion_free_2d

    def _in_bounds(self, q) -> bool:
        for v, (lo, hi) in zip(q, self._bounds):
            if not lo <= v <= hi:
                return False
        return True

    def _state_free(self, q) -> bool:
        if not self._in_bounds(q):
            return False
        for lo, hi in self._boxes:
            for v, vlo, vhi in zip(q, lo, hi):
                if v < vlo or v > vhi:
                    break
            else:
                return False
        return True

    def _motion_free(self, a, b) -> bool:
        # Bounds are convex: the segment is inside when both endpoints are.
        if not (self._in_bounds(a) and self._in_bounds(b)):
            return False
        d = [y - x for x, y in zip(a, b)]
        for lo, hi in self._boxes:
            if _segment_hits_box(a, d, lo, hi):
                return False
        return True

    def _motion_free_2d(self, a, b) -> bool:
        """_motion_free in the plane, the slab test of _segment_hits_box unrolled (the same
        operations in the same order, so the same answers), ~2x faster."""
        ax, ay, bx, by = a[0], a[1], b[0], b[1]
        (lx, hx), (ly, hy) = self._bounds
        if not (lx <= ax <= hx and ly <= ay <= hy and lx <= bx <= hx and ly <= by <= hy):
            return False
        dx, dy = bx - ax, by - ay
        for x0, y0, x1, y1 in self._boxes2:
            t0, t1 = 0.0, 1.0
            if dx == 0.0:
                if ax < x0 or ax > x1:
                    continue
            else:
                inv = 1.0 / dx
                ta, tb = (x0 - ax) * inv, (x1 - ax) * inv
                if ta > tb:
                    ta, tb = tb, ta
                if ta > t0:
                    t0 = ta
                if tb < t1:
                    t1 = tb
                if t0 > t1:
                    continue
            if dy == 0.0:
                if ay < y0 or ay > y1:
                    continue
            else:
                inv = 1.0 / dy
                ta, tb = (y0 - ay) * inv, (y1 - ay) * inv
                if ta > tb:
                    ta, tb = tb, ta
                if ta > t0:
                    t0 = ta
                if tb < t1:
                    t1 = tb
                if t0 > t1:
                    continue
            return False
        return True

    def _states_free(self, qs: np.ndarray) -> np.ndarray:
        # A loop over the few boxes on whole columns: ~20x faster than one (N, M, D) broadcast.
        cols = [np.ascontiguousarray(qs[:, d]) for d in range(self._d)]
        free = np.ones(len(qs), bool)
        for c, (lo, hi) in zip(cols, self._bounds):
            free &= (c >= lo) & (c <= hi)
        for lo, hi in self._boxes:
            inside = (cols[0] >= lo[0]) & (cols[0] <= hi[0])
            for d in range(1, self._d):
                inside &= (cols[d] >= lo[d]) & (cols[d] <= hi[d])
            free &= ~inside
        return free

    def _motions_free(self, a: np.ndarray, b: np.ndarray) -> np.ndarray:
        inb = np.all((a >= self._lower) & (a <= self._upper) & (b >= self._lower) & (b <= self._upper), axis=1)
        return inb & ~segments_hit_boxes(a, b, self.lo, self.hi).any(axis=1)


def _segment_hits_box(a, d, lo, hi) -> bool:
    """Slab test: does a + t d, t in [0, 1], meet the closed box [lo, hi]?"""
    t0, t1 = 0.0, 1.0
    for ai, di, blo, bhi in zip(a, d, lo, hi):
        if di == 0.0:
            if ai < blo or ai > bhi:
                return False
            continue
        inv = 1.0 / di
        ta, tb = (blo - ai) * inv, (bhi - ai) * inv
        if ta > tb:
            ta, tb = tb, ta
        if ta > t0:
            t0 = ta
        if tb < t1:
            t1 = tb
        if t0 > t1:
            return False
    return True


def segments_hit_boxes(a: np.ndarray, b: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """Batch slab test: (N, M) array, True where segment i meets closed box j."""
    d = (b - a)[:, None, :]
    a = a[:, None, :]
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        ta = (lo[None] - a) / d
        tb = (hi[None] - a) / d
    still = d == 0.0
    inside = (a >= lo[None]) & (a <= hi[None])
    tmin = np.where(still, np.where(inside, -np.inf, np.inf), np.minimum(ta, tb))
    tmax = np.where(still, np.where(inside, np.inf, -np.inf), np.maximum(ta, tb))
    t0 = np.maximum(tmin.max(axis=2), 0.0)
    t1 = np.minimum(tmax.min(axis=2), 1.0)
    return t0 <= t1
