"""Robot descriptions: what a robot looks like in the logs and which collision checkers
can check it (by backend name: `env.collision`)."""

from __future__ import annotations

import math
from functools import cache
from importlib import resources

import yaml

from mpnet.envs.arm.model import ArmModel, load_arm_model
from mpnet.envs.checkers.collision import PLANNING_MARGIN, CollisionChecker, PointChecker
from mpnet.envs.checkers.pybullet_arm import PybulletArmChecker
from mpnet.envs.checkers.rigid import FclRigidChecker, RigidChecker
from mpnet.envs.checkers.spheres import SphereChecker, SweptSphereChecker, obstacle_arrays, sphere_model
from mpnet.envs.spaces import EuclideanSpace, SE2Space, StateSpace
from mpnet.envs.workspace import Workspace


class Robot:
    """A kind of robot: its log description and its checkers."""

    kind: str = ""
    checkers: dict[str, type[CollisionChecker]] = {}
    default_backend: str = "native"
    judge_backend: str | None = None  # the checker of the fine re-check (None: the default)
    posed_obstacles: bool = False  # whether its checkers handle posed primitives (problems@2)
    judge_text: str = "the env's judge checker, no margin"  # what the fine re-check tests (reports)
    step_unit: str = ""  # the unit of the re-check's step along a path ("": workspace units)
    offers_clearance: bool = False  # whether clearance_arrays gives a collision loss its arrays

    def to_json(self) -> dict:
        return {"kind": self.kind}

    @property
    def label(self) -> str:
        """The robot as a run's facts name it: its kind (an arm: its model)."""
        return self.kind

    def as_logged(self, robot: dict | str | None) -> Robot:
        """This robot as a log describes it (a log written with another model of it)."""
        return self

    def cache_identity(self) -> dict:
        """What of the robot decides generated data beyond the env's name (cache keys):
        nothing for the fixed planar and point robots."""
        return {}

    def clearance_arrays(self, workspaces: list[Workspace]) -> dict | None:
        """What a differentiable collision loss needs (mpnet.models.clearance): the robot's
        moving body as spheres on its chain ("body") and each workspace's primitives
        ("obstacles", one dict a workspace); None: this robot offers none."""
        return None

    def space(self, bounds) -> StateSpace:
        """The robot's state space in a workspace of these bounds (an env file's `bounds`)."""
        return EuclideanSpace(bounds)

    def make_checker(
        self, spec, ws: Workspace, margin: float = PLANNING_MARGIN, backend: str | None = None
    ) -> CollisionChecker:
        backend = backend or self.default_backend
        try:
            cls = self.checkers[backend]
        except KeyError:
            raise ValueError(f"unknown collision backend {backend!r}; choices: {', '.join(self.checkers)}") from None
        return cls(spec, ws, margin)


class PointRobot(Robot):
    """A point: it collides when it lies in a closed box. Always the exact slab test."""

    kind = "point"
    checkers = {"native": PointChecker, "fcl": PointChecker}
    judge_text = "a point against the boxes, exact"


class RectangleRobot(Robot):
    """A rectangle `size` = (body x, body y) centred on (x, y), turned by theta.

    native: separating axes (~5x faster per motion); fcl: python-fcl, same answers."""

    kind = "rectangle"
    checkers = {"native": RigidChecker, "fcl": FclRigidChecker}
    judge_text = "the rectangle against the boxes, exact (separating axes)"

    def __init__(self, size: tuple[float, float]):
        self.size = tuple(float(s) for s in size)

    @property
    def radius(self) -> float:
        """The body's farthest point from its centre (the half-diagonal)."""
        return math.hypot(*(s / 2 for s in self.size))

    def to_json(self) -> dict:
        return {"kind": self.kind, "size": list(self.size)}

    def space(self, bounds) -> StateSpace:
        """(x, y, theta) over the bounds, theta weighted by the body's half-diagonal."""
        return SE2Space(bounds, radius=self.radius)


class ArmRobot(Robot):
    """A serial arm built from its data description (mpnet.envs.arm.model): the state is the
    planned joint vector. spheres: the compiled sphere covering, certified motions (the
    default); spheres_swept: the same with a tighter motion bound (fewer configurations a
    motion, a planning choice); pybullet: the collision meshes, sampled motions (the judge of every success)."""

    kind = "arm"
    checkers = {"spheres": SphereChecker, "spheres_swept": SweptSphereChecker, "pybullet": PybulletArmChecker}
    default_backend = "spheres"
    judge_backend = "pybullet"
    posed_obstacles = True
    judge_text = "pybullet on the arm model's collision meshes, no margin"
    step_unit = " rad"
    offers_clearance = True

    def __init__(self, model: str):
        self.model_name = model

    @property
    def model(self) -> ArmModel:
        """Loaded on first use (the URDF is read then)."""
        return load_arm_model(self.model_name)

    @property
    def label(self) -> str:
        return str(self.model_name)

    @property
    def name(self) -> str:
        return self.model.name

    def to_json(self) -> dict:
        """The model (name, URDF, joints, limits, held fingers, sphere set, digest): what a
        re-check needs to rebuild it."""
        return {"kind": self.kind, **self.model.to_json()}

    def as_logged(self, robot: dict | str | None) -> Robot:
        name = logged_model_name(robot) if isinstance(robot, dict) else self.model_name
        return self if name == self.model_name else ArmRobot(name)

    def cache_identity(self) -> dict:
        """The model (its description and sphere files' digest) and the checker that builds
        data: a changed model or checker is another dataset, never a stale one."""
        checker = self.checkers[self.default_backend]
        return {
            "robot": f"{self.model.name}:{self.model.digest()}",
            "checker": f"{self.default_backend}@{getattr(checker, 'VERSION', 1)}",
        }

    def joint_space(self):
        return EuclideanSpace(self.model.limits)

    def space(self, bounds=None) -> StateSpace:
        """The joint space: the model's limits are its bounds (an env file gives none)."""
        if bounds is not None:
            raise ValueError("an arm's bounds are its joint limits: its env file gives no `bounds`")
        return self.joint_space()

    def clearance_arrays(self, workspaces: list[Workspace]) -> dict:
        """The sphere model's moving spheres (the sphere checker's) and each workspace's primitives."""
        return {
            "body": sphere_model(self.model.name).moving_body(),
            "obstacles": [obstacle_arrays(ws) for ws in workspaces],
        }


@cache
def _older_logs() -> dict:
    return yaml.safe_load((resources.files("mpnet") / "data_files" / "logged_robots.yaml").read_text())


def logged_model_name(robot: dict) -> str:
    """The arm model a log's robot description names (data_files/logged_robots.yaml: what
    logs written before arm models were data, or naming none, name)."""
    if isinstance(robot.get("fingers"), (int, float)):
        return str(_older_logs()["numeric_fingers"])
    return str(robot.get("name", _older_logs()["unnamed"]))
