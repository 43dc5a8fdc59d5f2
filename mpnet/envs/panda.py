"""The Franka Panda of `pybullet_data` (the paper's Baxter is not installable): the arm7
robot's model, its reference collision checker, and forward kinematics for the logs.

pybullet is the reference: one DIRECT client per process holds the arm (loading it costs
~0.3 s, so checkers share it) and the obstacles of the checker that used it last; a
checker whose workspace is not the loaded one swaps its obstacles in first. A
configuration collides when any link of the arm (fingers fixed open) is closer than the
margin to an obstacle, or two links that are not an allowed pair touch (self-collision:
the pairs in contact in every configuration are allowed, see NOTES-dependencies).
"""

from __future__ import annotations

import math
from functools import cache

import numpy as np

from mpnet.envs.collision import CollisionChecker
from mpnet.envs.shapes import Primitive
from mpnet.envs.workspace import Workspace

URDF = "franka_panda/panda.urdf"
ARM_JOINTS = (0, 1, 2, 3, 4, 5, 6)
FINGER_JOINTS = (9, 10)
FINGERS_OPEN = 0.04
HAND_LINK = 8
# Joint limits of pybullet_data's panda.urdf (tests/test_arm.py checks them against the URDF).
LIMITS = (
    (-2.9671, 2.9671),
    (-1.8326, 1.8326),
    (-2.9671, 2.9671),
    (-3.1416, 0.0),
    (-2.9671, 2.9671),
    (-0.0873, 3.8223),
    (-2.9671, 2.9671),
)
ALLOWED_SAMPLES = 300  # configurations sampled to find the always-touching link pairs


class PandaWorld:
    """A pybullet DIRECT client with the Panda at the origin, fixed base, fingers open."""

    def __init__(self):
        import pybullet as pb
        import pybullet_data

        self.pb = pb
        self.client = pb.connect(pb.DIRECT)
        pb.setAdditionalSearchPath(pybullet_data.getDataPath(), physicsClientId=self.client)
        flags = pb.URDF_USE_SELF_COLLISION | pb.URDF_USE_SELF_COLLISION_EXCLUDE_PARENT
        self.robot = pb.loadURDF(URDF, [0, 0, 0], useFixedBase=True, flags=flags, physicsClientId=self.client)
        self.joints = list(ARM_JOINTS + FINGER_JOINTS)
        self.links = [j for j in range(-1, pb.getNumJoints(self.robot, physicsClientId=self.client))]
        self.owner: object = None
        self.bodies: list[int] = []
        self.shapes: dict[tuple, int] = {}
        self.margin = 0.0
        self.base_blocked = False
        self.allowed = self._always_touching()

    def limits(self) -> list[tuple[float, float]]:
        """The arm joints' limits as the URDF gives them."""
        pb = self.pb
        return [pb.getJointInfo(self.robot, j, physicsClientId=self.client)[8:10] for j in ARM_JOINTS]

    def set_q(self, q) -> None:
        self.pb.resetJointStatesMultiDof(
            self.robot,
            self.joints,
            [[float(v)] for v in q[:7]] + [[FINGERS_OPEN], [FINGERS_OPEN]],
            physicsClientId=self.client,
        )

    def _self_pairs(self) -> set[tuple[int, int]]:
        pb, r = self.pb, self.robot
        pb.performCollisionDetection(physicsClientId=self.client)
        return {
            (min(c[3], c[4]), max(c[3], c[4]))
            for c in pb.getContactPoints(bodyA=r, bodyB=r, physicsClientId=self.client)
            if c[8] < 0.0
        }

    def _always_touching(self) -> frozenset[tuple[int, int]]:
        """Link pairs in contact in every one of a fixed set of random configurations (the
        hand and link 6 touch everywhere in this model)."""
        rng = np.random.default_rng(0)
        lo, hi = np.array(LIMITS).T
        common: set | None = None
        for _ in range(ALLOWED_SAMPLES):
            self.set_q(rng.uniform(lo, hi))
            pairs = self._self_pairs()
            common = pairs if common is None else common & pairs
        return frozenset(common or ())

    def load(self, owner: object, primitives: list[Primitive], margin: float) -> None:
        """Make `primitives` the world's obstacles for collision tests at `margin` (no-op
        when `owner` loaded them last)."""
        if self.owner is owner:
            return
        pb, c = self.pb, self.client
        for b in self.bodies:
            pb.removeBody(b, physicsClientId=c)
        self.bodies = [
            pb.createMultiBody(
                0, self._shape(p), basePosition=p.center, baseOrientation=p.orientation, physicsClientId=c
            )
            for p in primitives
        ]
        self.margin = margin
        # The fixed base and the obstacles are both static, so Bullet never pairs them in
        # performCollisionDetection: the base is tested once here, at load.
        self.base_blocked = any(
            pb.getClosestPoints(self.robot, b, margin, linkIndexA=-1, physicsClientId=c) for b in self.bodies
        )
        self.owner = owner

    def _shape(self, p: Primitive) -> int:
        """A collision shape per distinct geometry, shared by bodies and kept: pybullet 3.2.7
        refuses removeCollisionShape for a shape once any body used it, so shapes made
        per load would pile up with every workspace swap."""
        key = (p.type, tuple(p.size))
        if key not in self.shapes:
            pb, c = self.pb, self.client
            if p.type == "box":
                shape = pb.createCollisionShape(pb.GEOM_BOX, halfExtents=[s / 2 for s in p.size], physicsClientId=c)
            elif p.type == "cylinder":
                shape = pb.createCollisionShape(pb.GEOM_CYLINDER, radius=p.radius, height=p.height, physicsClientId=c)
            else:
                shape = pb.createCollisionShape(pb.GEOM_SPHERE, radius=p.radius, physicsClientId=c)
            self.shapes[key] = shape
        return self.shapes[key]

    def collides(self, q) -> bool:
        """Does configuration q touch an obstacle (closer than the loaded margin) or itself?"""
        if self.base_blocked:
            return True
        pb, r, c = self.pb, self.robot, self.client
        self.set_q(q)
        pb.performCollisionDetection(physicsClientId=c)
        allowed = self.allowed
        for cp in pb.getContactPoints(bodyA=r, physicsClientId=c):
            if cp[2] == r:
                if cp[8] < 0.0 and (min(cp[3], cp[4]), max(cp[3], cp[4])) not in allowed:
                    return True
            elif cp[8] < 0.0:
                return True
        if self.margin > 0.0:
            # Contact manifolds only keep points within Bullet's breaking threshold, so a
            # margin is measured with closest-point queries, obstacle by obstacle.
            return any(pb.getClosestPoints(r, b, self.margin, physicsClientId=c) for b in self.bodies)
        return False

    def link_poses(self, q) -> list[tuple[list[float], list[float]]]:
        """(position, quaternion [x, y, z, w]) of every link's inertial (centre-of-mass)
        frame, the base first: the frame pybullet's collision meshes are given in."""
        pb, r, c = self.pb, self.robot, self.client
        self.set_q(q)
        base = pb.getBasePositionAndOrientation(r, physicsClientId=c)
        states = pb.getLinkStates(r, self.links[1:], computeForwardKinematics=True, physicsClientId=c)
        return [(list(base[0]), list(base[1]))] + [(list(s[0]), list(s[1])) for s in states]

    def hand_position(self, q) -> list[float]:
        """Where the hand's frame is: the end-effector trace of a path."""
        pb = self.pb
        self.set_q(q)
        s = pb.getLinkState(self.robot, HAND_LINK, computeForwardKinematics=True, physicsClientId=self.client)
        return list(s[4])


@cache
def panda_world() -> PandaWorld:
    """This process's Panda world (created on first use; checkers take turns with it)."""
    return PandaWorld()


class PandaChecker(CollisionChecker):
    """The reference checker: pybullet, one configuration at a time; a motion is free when
    every state along it, at most `spec.motion_step` apart (joint-space distance), is."""

    def __init__(self, spec, ws: Workspace, margin: float):
        super().__init__(spec, ws, margin)
        self.world = panda_world()
        self._primitives = ws.all_primitives()
        self._step = float(spec.motion_step)
        self.configurations = 0  # pybullet evaluations, motions' states included

    def counts(self) -> dict:
        return {**super().counts(), "configurations_checked": self.configurations}

    def reset_counts(self) -> None:
        super().reset_counts()
        self.configurations = 0

    def _free(self, q) -> bool:
        self.world.load(self, self._primitives, self.margin)
        self.configurations += 1
        return not self.world.collides(q)

    def _state_free(self, q) -> bool:
        return self.spec.space.in_bounds(q) and self._free(q)

    def _motion_free(self, a, b) -> bool:
        # Joint limits are a box: the segment is inside when both ends are.
        if not (self.spec.space.in_bounds(a) and self.spec.space.in_bounds(b)):
            return False
        a = np.asarray(a, float)
        d = np.asarray(b, float) - a
        n = max(1, math.ceil(float(np.linalg.norm(d)) / self._step))
        for i in coarse_to_fine(n):
            if not self._free(a + (i / n) * d):
                return False
        return True


@cache
def coarse_to_fine(n: int) -> tuple[int, ...]:
    """0..n with the ends first, then midpoints of ever finer halvings (where a blocked
    motion is found soonest, as OMPL's DiscreteMotionValidator orders them)."""
    order, seen = [0, n], {0, n}
    k = 2
    while len(order) < n + 1:
        for j in range(1, k, 2):
            i = round(j * n / k)
            if i not in seen:
                seen.add(i)
                order.append(i)
        k *= 2
    return tuple(order)
