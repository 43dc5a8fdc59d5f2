"""State spaces, one per kind of robot configuration, in the spirit of OMPL's StateSpace.

A space knows its dimension and bounds, its metric, how a straight motion interpolates
(angles along the shorter arc), how a state is drawn, the scale the networks normalise
by (from the bounds) and how its states map to and from OMPL's. Everything else in the
project asks the space instead of testing what kind of robot it has.
"""

from __future__ import annotations

import math
import operator
from abc import ABC, abstractmethod

import numpy as np


def wrap_angle(a):
    """Angle into [-pi, pi)."""
    return (a + math.pi) % (2 * math.pi) - math.pi


class StateSpace(ABC):
    """Bounds, metric, interpolation, sampling, normalisation and OMPL conversion."""

    def __init__(self, bounds):
        self.bounds: tuple[tuple[float, float], ...] = tuple((float(lo), float(hi)) for lo, hi in bounds)
        self.lower = np.array([b[0] for b in self.bounds], float)
        self.upper = np.array([b[1] for b in self.bounds], float)

    @property
    def dim(self) -> int:
        return len(self.bounds)

    def bounds_json(self) -> list[list[float]]:
        return [[lo, hi] for lo, hi in self.bounds]

    def sample(self, rng: np.random.Generator) -> np.ndarray:
        """A state drawn uniformly within the bounds."""
        return rng.uniform(self.lower, self.upper)

    def scale(self) -> list[float]:
        """Per-dimension scale the networks divide states by: the largest absolute bound
        ([-20, 20]^2 x [-pi, pi) gives [20, 20, pi])."""
        return [max(abs(lo), abs(hi)) for lo, hi in self.bounds]

    def half_widths(self) -> np.ndarray:
        return (self.upper - self.lower) / 2.0

    def maximum_extent(self) -> float:
        """The largest distance between two states (OMPL's getMaximumExtent)."""
        return float(np.linalg.norm(self.upper - self.lower))

    def metric_weights(self) -> np.ndarray:
        """Per coordinate, the weight of |difference| in `distance` for the wrapped coordinates
        (those past bounded_dims; the bounded ones are Euclidean): the compiled planners' metric."""
        return np.ones(self.dim)

    @abstractmethod
    def distance(self, a, b) -> float:
        """The metric path costs are measured in."""

    @abstractmethod
    def difference(self, a: np.ndarray, b: np.ndarray) -> np.ndarray:
        """b - a along the straight motion (rows of arrays too)."""

    @abstractmethod
    def motion_length(self, d: np.ndarray) -> np.ndarray:
        """How far any point of the robot moves along displacements d (rows): what an
        interpolation step bounds."""

    @abstractmethod
    def segment_length(self, d: np.ndarray) -> float:
        """motion_length of one displacement (scalar arithmetic, as OMPL-side code uses)."""

    @abstractmethod
    def wrap(self, q) -> np.ndarray:
        """The state's canonical coordinates (angles into [-pi, pi))."""

    @abstractmethod
    def in_bounds(self, q) -> bool:
        """Whether the bounded coordinates of q are within the bounds (angles never leave)."""

    @property
    @abstractmethod
    def bounded_dims(self) -> int:
        """The leading coordinates that are bounded (and land exactly on a segment's end)."""

    def clip(self, q) -> np.ndarray:
        """q in canonical coordinates with its bounded coordinates clipped into the bounds
        (the nearest state inside them: a joint past its limit is held at it)."""
        out = np.array(self.wrap(q), float)
        k = self.bounded_dims
        out[..., :k] = np.clip(out[..., :k], self.lower[:k], self.upper[:k])
        return out

    def interpolate(self, a, b, step: float) -> np.ndarray:
        """States along a -> b no farther apart than `step` (motion_length)."""
        a = np.asarray(a, float)
        b = np.asarray(b, float)
        d = self.difference(a, b)
        length = self.segment_length(d)
        n = int(math.ceil(length / step)) + 1
        out = a + np.linspace(0.0, 1.0, n + 1)[:, None] * d
        k = self.bounded_dims
        out[-1, :k] = b[:k]  # a + 1.0 * d can round past b: a state on the bound must stay on it
        return out

    def interpolate_path(self, path: np.ndarray, step: float) -> np.ndarray:
        """Every segment of the path sampled as `interpolate` does, in one vectorised pass."""
        a, d = path[:-1], self.difference(path[:-1], path[1:])
        n = np.ceil(self.motion_length(d) / step).astype(int) + 2  # samples per segment, both ends included
        seg = np.repeat(np.arange(len(d)), n)
        first = np.cumsum(n) - n
        t = (np.arange(n.sum()) - np.repeat(first, n)) / np.repeat(n - 1, n)
        out = a[seg] + t[:, None] * d[seg]
        last = np.cumsum(n) - 1
        k = self.bounded_dims
        out[last, :k] = path[1:, :k]  # as in interpolate: each segment ends exactly at its state
        return out

    @abstractmethod
    def ompl_space(self):
        """A fresh OMPL state space (one per setup: a shared one crashed OMPL's Benchmark)."""

    @abstractmethod
    def ompl_codec(self):
        """(to_tuple, set_state) for this space's OMPL states."""


class EuclideanSpace(StateSpace):
    """R^n in a box: points in 2D and 3D, joint vectors."""

    bounded_dims = property(lambda self: self.dim)

    def distance(self, a, b) -> float:
        return math.dist(a, b)

    def difference(self, a, b):
        return np.asarray(b, float) - np.asarray(a, float)

    def motion_length(self, d):
        return np.linalg.norm(d, axis=-1)

    def segment_length(self, d) -> float:
        return float(np.linalg.norm(d))

    def wrap(self, q):
        return np.asarray(q, float)

    def in_bounds(self, q) -> bool:
        return all(lo <= v <= hi for v, (lo, hi) in zip(q, self.bounds))

    def ompl_space(self):
        from ompl import base as ob

        space = ob.RealVectorStateSpace(self.dim)
        b = ob.RealVectorBounds(self.dim)
        for d, (lo, hi) in enumerate(self.bounds):
            b.setLow(d, lo)
            b.setHigh(d, hi)
        space.setBounds(b)
        return space

    def ompl_codec(self):
        n = self.dim

        if n == 2:  # the expert's RRT* converts ~23k states per path: no generator for the usual sizes

            def to_tuple(s):
                return (s[0], s[1])

        elif n == 3:

            def to_tuple(s):
                return (s[0], s[1], s[2])

        else:  # an arm's: one C-level call for all coordinates (the expert's OMPL search converts every state)
            to_tuple = operator.itemgetter(*range(n))

        def set_state(s, q):
            for i in range(n):
                s[i] = float(q[i])

        return to_tuple, set_state


class SE2Space(StateSpace):
    """(x, y, theta): x, y in a box, theta in [-pi, pi) along the shorter arc.

    The metric is OMPL's SE(2) one, |dxy| + theta_weight * |dtheta|. `radius` is the body's
    farthest point from (x, y): a turn by dtheta moves it by radius * dtheta, which bounds
    interpolation steps.
    """

    bounded_dims = 2

    def __init__(self, xy_bounds, radius: float, theta_weight: float = 0.5):
        super().__init__((*xy_bounds, (-math.pi, math.pi)))
        self.radius = float(radius)
        self.theta_weight = float(theta_weight)

    def distance(self, a, b) -> float:
        return math.hypot(b[0] - a[0], b[1] - a[1]) + self.theta_weight * abs(wrap_angle(b[2] - a[2]))

    def maximum_extent(self) -> float:
        """OMPL's SE(2): the planar diagonal plus theta_weight x pi (the farthest turn)."""
        return math.hypot(*(self.upper[:2] - self.lower[:2])) + self.theta_weight * math.pi

    def metric_weights(self) -> np.ndarray:
        return np.array([1.0, 1.0, self.theta_weight])

    def difference(self, a, b):
        d = np.asarray(b, float) - np.asarray(a, float)
        d[..., 2] = wrap_angle(d[..., 2])
        return d

    def motion_length(self, d):
        return np.maximum(np.hypot(d[..., 0], d[..., 1]), np.abs(d[..., 2]) * self.radius)

    def segment_length(self, d) -> float:
        return max(math.hypot(d[0], d[1]), abs(d[2]) * self.radius)

    def wrap(self, q):
        q = np.array(q, float)
        q[..., 2] = wrap_angle(q[..., 2])
        return q

    def in_bounds(self, q) -> bool:
        return all(self.bounds[d][0] <= q[d] <= self.bounds[d][1] for d in range(2))

    def ompl_space(self):
        from ompl import base as ob

        space = ob.SE2StateSpace()
        b = ob.RealVectorBounds(2)
        for d in range(2):
            b.setLow(d, self.bounds[d][0])
            b.setHigh(d, self.bounds[d][1])
        space.setBounds(b)
        return space

    def ompl_codec(self):
        def to_tuple(s):
            return (s.getX(), s.getY(), s.getYaw())

        def set_state(s, q):
            s.setX(float(q[0]))
            s.setY(float(q[1]))
            s.setYaw(wrap_angle(float(q[2])))  # OMPL's SO2 expects [-pi, pi)

        return to_tuple, set_state
