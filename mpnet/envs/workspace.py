"""Plain data types shared by every stage: the env's spec, a workspace, a query."""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

ROBOT_POINT = "point"
ROBOT_RECTANGLE = "rectangle"


@dataclass(frozen=True)
class EnvSpec:
    """What an environment is: state and workspace dimensions, bounds, robot, metric.

    `bounds` are the state bounds, one [lo, hi] per state dimension (rigid: x, y, theta).
    """

    name: str
    state_dim: int
    workspace_dim: int
    bounds: tuple[tuple[float, float], ...]
    robot: str = ROBOT_POINT
    robot_size: tuple[float, ...] = ()
    theta_weight: float = 0.5
    validation_step: float = 0.01
    blocks: int = 7  # obstacles per generated workspace: sizes the point cloud

    @property
    def is_se2(self) -> bool:
        return self.robot == ROBOT_RECTANGLE

    @property
    def lower(self) -> np.ndarray:
        return np.array([b[0] for b in self.bounds], float)

    @property
    def upper(self) -> np.ndarray:
        return np.array([b[1] for b in self.bounds], float)

    def robot_json(self) -> dict:
        if self.robot == ROBOT_RECTANGLE:
            return {"kind": "rectangle", "size": list(self.robot_size)}
        return {"kind": "point"}

    def bounds_json(self) -> list[list[float]]:
        return [[float(lo), float(hi)] for lo, hi in self.bounds]

    def in_bounds(self, q) -> bool:
        """Bounds of the positional part; theta wraps and is never out of bounds."""
        n = 2 if self.is_se2 else self.state_dim
        return all(self.bounds[d][0] <= q[d] <= self.bounds[d][1] for d in range(n))

    def distance(self, a, b) -> float:
        """The env's metric: Euclidean for points; for rigid OMPL's SE(2) metric,
        |dxy| + theta_weight * |shorter-arc dtheta| (theta_weight 0.5 as OMPL's SE2StateSpace)."""
        if self.is_se2:
            return math.hypot(b[0] - a[0], b[1] - a[1]) + self.theta_weight * abs(wrap_angle(b[2] - a[2]))
        return math.dist(a, b)


def wrap_angle(a):
    """Angle into [-pi, pi)."""
    return (a + math.pi) % (2 * math.pi) - math.pi


@dataclass
class Workspace:
    """Axis-aligned box obstacles, stored as min and max corners (closed boxes)."""

    id: str
    split: str
    centers: np.ndarray
    sizes: np.ndarray
    lo: np.ndarray = field(init=False, repr=False)
    hi: np.ndarray = field(init=False, repr=False)

    def __post_init__(self):
        c = np.asarray(self.centers, float)
        self.centers = c if c.ndim == 2 else c.reshape(len(c), -1)  # (0, dim) arrays: no obstacles
        self.sizes = np.asarray(self.sizes, float).reshape(self.centers.shape)
        self.lo = self.centers - self.sizes / 2
        self.hi = self.centers + self.sizes / 2

    @property
    def dim(self) -> int:
        return self.centers.shape[1]

    def obstacles_json(self) -> list[dict]:
        return [{"center": c.tolist(), "size": s.tolist()} for c, s in zip(self.centers, self.sizes)]


@dataclass
class Query:
    """A start and goal in one workspace; `id` is stable (workspace id plus index)."""

    id: str
    workspace_id: str
    split: str
    start: np.ndarray
    goal: np.ndarray
    reference_cost: float | None = None

    def __post_init__(self):
        self.start = np.asarray(self.start, float)
        self.goal = np.asarray(self.goal, float)


@dataclass
class TestSet:
    """Workspaces and their queries, for one or more splits."""

    spec: EnvSpec
    workspaces: list[Workspace]
    queries: list[Query]

    def workspace(self, wid: str, split: str) -> Workspace:
        for ws in self.workspaces:
            if ws.id == wid and ws.split == split:
                return ws
        raise KeyError(f"no workspace {wid!r} in split {split!r}")
