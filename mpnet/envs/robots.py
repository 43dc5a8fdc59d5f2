"""Robot descriptions: what a robot looks like in the logs and which collision checkers
can check it (by backend name: `env.collision`)."""

from __future__ import annotations

import math

from mpnet.envs.collision import PLANNING_MARGIN, CollisionChecker, PointChecker
from mpnet.envs.panda import PandaChecker
from mpnet.envs.rigid import FclRigidChecker, RigidChecker
from mpnet.envs.workspace import Workspace


class Robot:
    """A kind of robot: its log description and its checkers."""

    kind: str = ""
    checkers: dict[str, type[CollisionChecker]] = {}
    default_backend: str = "native"
    posed_obstacles: bool = False  # whether its checkers handle posed primitives (problems@2)

    def to_json(self) -> dict:
        return {"kind": self.kind}

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


class RectangleRobot(Robot):
    """A rectangle `size` = (body x, body y) centred on (x, y), turned by theta.

    native: separating axes (~5x faster per motion); fcl: python-fcl, same answers."""

    kind = "rectangle"
    checkers = {"native": RigidChecker, "fcl": FclRigidChecker}

    def __init__(self, size: tuple[float, float]):
        self.size = tuple(float(s) for s in size)

    @property
    def radius(self) -> float:
        """The body's farthest point from its centre (the half-diagonal)."""
        return math.hypot(*(s / 2 for s in self.size))

    def to_json(self) -> dict:
        return {"kind": self.kind, "size": list(self.size)}


class ArmRobot(Robot):
    """A serial arm by name (arm7: the Franka Panda of pybullet_data). Its state is the
    joint vector; pybullet is the reference checker."""

    kind = "arm"
    checkers = {"pybullet": PandaChecker}
    default_backend = "pybullet"
    posed_obstacles = True

    def __init__(self, name: str, urdf: str, fingers: float):
        self.name = name
        self.urdf = urdf
        self.fingers = fingers

    def to_json(self) -> dict:
        """Name, the pybullet_data URDF, and the fixed finger joints (what a re-check needs)."""
        return {"kind": self.kind, "name": self.name, "urdf": self.urdf, "fingers": self.fingers}
