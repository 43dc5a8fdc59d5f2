"""Collision checking against closed axis-aligned boxes, with every check counted.

One checker per workspace serves every planner, for single states (OMPL calls it per state)
and for batches. The point robots' and the rigid body's checks are their compiled kernels
(mpnet.envs.checkers.point_kernels, rigid_kernels: ~1 us a state from Python, the compiled planner
inlines the same code), and their motions are checked continuously, never by sampling:
exactly for point robots (slab test), and by conservative advancement on a proven clearance
bound for the rigid body, so a motion called free is free at any resolution.
The arm's checkers evaluate configurations along a motion: the sphere checker
(mpnet.envs.checkers.spheres) with a bound on how far its spheres move between them, pybullet's
(mpnet.envs.checkers.pybullet_arm) at env.motion_step; the fine re-check then judges every path.

A robot kind's checker subclasses CollisionChecker and implements the four `_free`
methods; everything else uses only the public, counted calls.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from typing import NamedTuple

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
        """This checker's geometry as the compiled planner's `env` tuple (mpnet.envs.checkers.compiled_env):
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


class _Kernels(NamedTuple):
    """A robot's compiled checks, as its checker calls them (dispatchers pickle; a module does not)."""

    state_free: object
    motion_free: object
    states_free: object
    motions_free: object


class PointChecker(CollisionChecker):
    """A point robot in 2D or 3D: a point collides when it lies in a closed box. Its checks are
    the compiled ones (mpnet.envs.checkers.point_kernels), the compiled planner's too: one implementation."""

    compiled = True

    def compiled_env(self) -> tuple:
        from mpnet.envs.checkers import boxes_compiled as B  # numba's kernels load with the compiled planner only

        ints, floats, scratch = np.zeros(0, np.int64), np.zeros(0), np.empty(self.spec.state_dim)
        return B.env(B.POINT, ints, floats, self._lo, self._hi, self._lower, self._upper, scratch)

    def __init__(self, spec, ws: Workspace, margin: float = PLANNING_MARGIN):
        from mpnet.envs.checkers import point_kernels as k  # numba: loaded with the first checker, not on import

        super().__init__(spec, ws, margin)
        d = spec.state_dim
        self._k = _Kernels(k.state_free, k.motion_free, k.states_free, k.motions_free)
        self._lo, self._hi = (np.ascontiguousarray(v, float).reshape(-1, d) for v in (self.lo, self.hi))
        self._lower, self._upper = (np.ascontiguousarray(v, float) for v in (self._lower, self._upper))
        self._scratch = np.empty(d)

    def _state_free(self, q) -> bool:
        return self._k.state_free(np.asarray(q, float), self._lo, self._hi, self._lower, self._upper)

    def _motion_free(self, a, b) -> bool:
        a, b = np.asarray(a, float), np.asarray(b, float)
        return self._k.motion_free(a, b, self._lo, self._hi, self._lower, self._upper, self._scratch)

    def _states_free(self, qs: np.ndarray) -> np.ndarray:
        out = np.empty(len(qs), np.bool_)
        self._k.states_free(np.ascontiguousarray(qs), self._lo, self._hi, self._lower, self._upper, out)
        return out

    def _motions_free(self, a: np.ndarray, b: np.ndarray) -> np.ndarray:
        out = np.empty(len(a), np.bool_)
        a, b = np.ascontiguousarray(a), np.ascontiguousarray(b)
        self._k.motions_free(a, b, self._lo, self._hi, self._lower, self._upper, self._scratch, out)
        return out
