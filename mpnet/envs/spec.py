"""An environment as one object: its state space, robot, workspace generator and point
cloud sampler, plus the fixed facts the stages share (docs/environments.md). Also what the
readers of test sets from files (problem files, MotionBenchMaker's YAML pairs) share: their
split (SPLIT) and their one-line error (ProblemFileError)."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, replace

import numpy as np

from mpnet.envs.checkers.collision import PLANNING_MARGIN, CollisionChecker
from mpnet.envs.robots import Robot
from mpnet.envs.scenes.clouds import point_cloud, workspace_cloud
from mpnet.envs.spaces import StateSpace
from mpnet.envs.workspace import Query, Workspace


def random_pairs(spec: EnvSpec, ws: Workspace, checker: CollisionChecker, rng: np.random.Generator):
    """Start/goal candidates for expert paths and test queries: two uniform states at a time,
    without end (the caller keeps the valid ones it wants)."""
    while True:
        yield spec.space.sample(rng), spec.space.sample(rng)


@dataclass(frozen=True)
class EnvSpec:
    """What an environment is. `space` holds the state bounds, metric and interpolation;
    `robot` the log description and checkers; `generator` makes its workspaces
    (`make(index, split, seed)`, `make_many`); `sample_cloud(ws, total, rng)` draws the
    obstacle points Enet sees. `exact_reference`: path costs have an exact reference (the
    2D visibility graph) instead of a planned one. `pairs(spec, ws, checker, rng)` yields
    the start/goal candidates of expert paths and test queries (uniform states by default;
    MotionBenchMaker's queries for panda_mbm) and ends when the workspace has no more."""

    name: str
    space: StateSpace
    robot: Robot
    workspace_dim: int
    generator: object
    blocks: int = 7  # obstacles per generated workspace: sizes the point cloud
    validation_step: float = 0.01
    exact_reference: bool = False
    sample_cloud: Callable = point_cloud
    # Checkers that sample motions (the arm) sample them this far apart; None: continuous.
    motion_step: float | None = None
    # Obstacles inflated by this much while planning (metres for the arm); the re-check uses none.
    planning_margin: float = PLANNING_MARGIN
    # OMPL tree planners' default maximum edge length (RRT-Connect, RRT*, Informed-RRT*; a
    # planner config's `range` overrides it); None: OMPL's own, 0.2 x the space's extent.
    planner_range: float | None = None
    # Per-axis scale the networks divide cloud points by; None: the workspace axes' state bounds.
    cloud_scale: tuple[float, ...] | None = None
    pairs: Callable = random_pairs

    @property
    def state_dim(self) -> int:
        return self.space.dim

    @property
    def bounds(self) -> tuple[tuple[float, float], ...]:
        return self.space.bounds

    @property
    def lower(self) -> np.ndarray:
        return self.space.lower

    @property
    def upper(self) -> np.ndarray:
        return self.space.upper

    def bounds_json(self) -> list[list[float]]:
        return self.space.bounds_json()

    def robot_json(self) -> dict:
        return self.robot.to_json()

    def in_bounds(self, q) -> bool:
        return self.space.in_bounds(q)

    def distance(self, a, b) -> float:
        """The env's metric (the space's): path costs are sums of it."""
        return self.space.distance(a, b)

    def workspace_scale(self) -> list[float]:
        """Per-axis scale the networks divide cloud points by: `cloud_scale`, or the
        workspace's largest absolute bound (the state bounds of the workspace axes)."""
        if self.cloud_scale is not None:
            return list(self.cloud_scale)
        return [max(abs(lo), abs(hi)) for lo, hi in self.space.bounds[: self.workspace_dim]]

    def make_checker(self, ws: Workspace, margin: float | None = None, backend: str | None = None) -> CollisionChecker:
        """The robot's checker for `ws` (margin None: the planning margin; backend None:
        the robot's default)."""
        return self.robot.make_checker(self, ws, self.planning_margin if margin is None else margin, backend)

    def judge_checker(self, ws: Workspace) -> CollisionChecker:
        """The checker of the independent fine re-check: no margin, the robot's judge."""
        return self.robot.make_checker(self, ws, 0.0, self.robot.judge_backend)

    def for_logged_robot(self, robot) -> EnvSpec:
        """This env with the robot model a log was written with (the same env when it is)."""
        logged = self.robot.as_logged(robot)
        if logged is self.robot:
            return self
        return replace(self, robot=logged, space=logged.joint_space())

    def cloud_size(self, points_per_block: int) -> int:
        return points_per_block * self.blocks

    def cloud(self, ws: Workspace, points_per_block: int, seed: int) -> np.ndarray:
        """The workspace's point cloud as training and planning both draw it."""
        return workspace_cloud(ws, self.cloud_size(points_per_block), seed, self.sample_cloud)


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


# The split of every workspace and query read from a file (problem files, MotionBenchMaker's
# YAML pairs): their readers' shared vocabulary, with the error they raise.
SPLIT = "file"


class ProblemFileError(ValueError):
    """A problem file that cannot be used. `str(e)` is a single line.

    Attributes: `path` (as given), `workspace_id` / `workspace_index` / `query_index`
    (None where they do not apply) and `detail` (the message without the location).
    """

    def __init__(
        self,
        path,
        detail: str,
        *,
        workspace_index: int | None = None,
        workspace_id: str | None = None,
        query_index: int | None = None,
        where: str | None = None,
    ):
        self.path = str(path)
        self.detail = detail
        self.workspace_index = workspace_index
        self.workspace_id = workspace_id
        self.query_index = query_index
        loc = []
        if workspace_index is not None:
            if workspace_id is not None:
                loc.append(f"workspace {workspace_id!r} (#{workspace_index})")
            else:
                loc.append(f"workspace #{workspace_index}")
        if query_index is not None:
            loc.append(f"query #{query_index}")
        if where:
            loc.append(where)
        parts = [self.path] + ([", ".join(loc)] if loc else []) + [detail]
        super().__init__(_one_line(": ".join(parts)))


def _one_line(s: str) -> str:
    return s.replace("\r", "\\r").replace("\n", "\\n")
