"""An arm model (mpnet.envs.arm.model) in pybullet: the mesh checker that judges every
logged arm success (`env.collision=pybullet` plans with it too), and link poses for the logs.

Each checker holds its own DIRECT client (an ArmWorld: the arm and that checker's obstacles)
for as long as it lives; no two checkers or painters ever use one world at once. Loading an arm
costs ~0.5 s and a checker is made per workspace, so a world its holder let go is emptied and
lent to the next holder instead of closed (`borrow_world`, `lent_world`). A configuration collides when any link of
the arm (fingers held where the model holds them) is closer than the margin to an obstacle,
or two links that are not an allowed pair of the model touch (parent and child links are
never checked). pybullet tests each collision mesh as its convex hull.
"""

from __future__ import annotations

import math
import os
import sys
import weakref
from collections.abc import Iterator
from contextlib import contextmanager
from functools import cache

import numpy as np

from mpnet.envs.arm.model import ArmModel, ArmModelError
from mpnet.envs.checkers.collision import SampledConfigurations
from mpnet.envs.shapes import Primitive
from mpnet.envs.workspace import Workspace


@contextmanager
def _quiet_stdout() -> Iterator[None]:
    """Bullet's URDF importer prints a warning per link without <inertial> (a UR5's fixed gripper
    links: dozens a load) to the process's stdout from C++; that output is dropped while it loads."""
    sys.stdout.flush()
    saved = os.dup(1)
    try:
        with open(os.devnull, "wb") as null:
            os.dup2(null.fileno(), 1)
        yield
    finally:
        os.dup2(saved, 1)
        os.close(saved)


class ArmWorld:
    """A pybullet DIRECT client with the model's arm at the origin, fixed base, fingers held."""

    def __init__(self, model: ArmModel):
        import pybullet as pb

        self.pb = pb
        self.model = model
        self.client = pb.connect(pb.DIRECT)
        flags = pb.URDF_USE_SELF_COLLISION | pb.URDF_USE_SELF_COLLISION_EXCLUDE_PARENT
        try:
            with _quiet_stdout():
                self.robot = pb.loadURDF(
                    str(model.urdf_path), [0, 0, 0], useFixedBase=True, flags=flags, physicsClientId=self.client
                )
        except pb.error:
            pb.disconnect(physicsClientId=self.client)
            why = "every mesh it names, <visual> ones too, must be there"
            raise ArmModelError(f"{model.urdf_path}: pybullet cannot load it ({why})") from None
        info = [pb.getJointInfo(self.robot, j, physicsClientId=self.client) for j in range(self._n_joints())]
        by_joint = {i[1].decode(): i[0] for i in info}
        self.link_names = {-1: model.kinematics.frames[0].link} | {i[0]: i[12].decode() for i in info}
        self.links = sorted(self.link_names)
        self.joints = [by_joint[j] for j in model.joints] + [by_joint[j] for j in model.fingers]
        self._held = [[v] for v in model.fingers.values()]
        self._ee = next(i for i, name in self.link_names.items() if name == model.end_effector)
        self.bodies: list[int] = []
        self.key: tuple = ()  # the pool's key (_key), set when taken
        self.shapes: dict[tuple, int] = {}
        self.margin = 0.0
        self.base_blocked = False
        self.allowed = frozenset(
            (a, b)
            for a in self.links
            for b in self.links
            if a < b and model.is_allowed(self.link_names[a], self.link_names[b])
        )
        # Bullet told not to pair the allowed links at all: collides() skipped their contacts
        # anyway, but Bullet still ran their narrow phase and getContactPoints built their tuples
        # on every check (the Panda's 34 allowed pairs: ~40% of a check). The same verdicts.
        for a, b in self.allowed:
            pb.setCollisionFilterPair(self.robot, self.robot, a, b, 0, physicsClientId=self.client)

    def _n_joints(self) -> int:
        return self.pb.getNumJoints(self.robot, physicsClientId=self.client)

    def set_q(self, q) -> None:
        self.pb.resetJointStatesMultiDof(
            self.robot,
            self.joints,
            [[float(v)] for v in q] + self._held,
            physicsClientId=self.client,
        )

    def load(self, primitives: list[Primitive], margin: float) -> None:
        """Make `primitives` the world's obstacles for collision tests at `margin`."""
        self.clear()
        pb, c = self.pb, self.client
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

    def clear(self) -> None:
        """No obstacles: the arm alone (for link poses, or before a new holder loads its own)."""
        for b in self.bodies:
            self.pb.removeBody(b, physicsClientId=self.client)
        self.bodies, self.margin, self.base_blocked = [], 0.0, False

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
            if cp[8] >= 0.0 or (cp[2] == r and (min(cp[3], cp[4]), max(cp[3], cp[4])) in allowed):
                continue
            if self._confirmed(cp[2], cp[3], cp[4]):
                return True
        if self.margin > 0.0:
            # Contact manifolds only keep points within Bullet's breaking threshold, so a
            # margin is measured with closest-point queries, obstacle by obstacle.
            return any(pb.getClosestPoints(r, b, self.margin, physicsClientId=c) for b in self.bodies)
        return False

    def _confirmed(self, body: int, link_a: int, link_b: int) -> bool:
        """A penetrating contact point, measured afresh for that pair of links. Bullet keeps
        contact manifolds between calls, and a point from the previous configuration can
        survive a refresh with a negative distance: one free state in ~125,000 read as colliding
        right after a colliding one (tests/mpnet/envs/checkers/test_spheres.py), so every hit is re-measured."""
        pts = self.pb.getClosestPoints(
            self.robot, body, 0.0, linkIndexA=link_a, linkIndexB=link_b, physicsClientId=self.client
        )
        return any(p[8] < 0.0 for p in pts)

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
        s = pb.getLinkState(self.robot, self._ee, computeForwardKinematics=True, physicsClientId=self.client)
        return list(s[4])


# Worlds no holder uses, by arm model: emptied, and lent again rather than closed. The only
# state kept across holders; a world is never lent to two at once.
_IDLE: dict[tuple, list[ArmWorld]] = {}  # by _key: what the world is built from


def borrow_world(model: ArmModel, holder: object) -> ArmWorld:
    """A world of `model` that `holder` alone uses until it is garbage-collected: an idle one
    (no obstacles) or, when none is idle, a new one."""
    world = _take(model)
    weakref.finalize(holder, _give_back, world).atexit = False
    return world


@contextmanager
def lent_world(model: ArmModel) -> Iterator[ArmWorld]:
    """A world of `model` for the length of a `with` block (link poses, mesh sizes)."""
    world = _take(model)
    try:
        yield world
    finally:
        _give_back(world)


def _take(model: ArmModel) -> ArmWorld:
    key = _key(model)
    idle = _IDLE.get(key)
    world = idle.pop() if idle else ArmWorld(model)
    world.key = key
    return world


def _give_back(world: ArmWorld) -> None:
    world.clear()
    _IDLE.setdefault(world.key, []).append(world)


def _key(model: ArmModel) -> tuple:
    """An idle world's identity: the model's fields and its files (where, and which version:
    a URDF or mesh rewritten under the same name is another robot, not the world loaded from
    the old one)."""
    files = [model.urdf_path] + [s.path for s in model.kinematics.shapes if s.path is not None]
    stats = ((str(p), p.stat()) for p in files)
    return (repr(model), *((p, st.st_mtime_ns, st.st_size) for p, st in stats))


class PybulletArmChecker(SampledConfigurations):
    """The reference checker: pybullet, one configuration at a time; a motion is free when
    every state along it, at most `spec.motion_step` apart (joint-space distance), is."""

    def __init__(self, spec, ws: Workspace, margin: float):
        super().__init__(spec, ws, margin)
        self._model: ArmModel = spec.robot.model
        self._world: ArmWorld | None = None  # borrowed at the first check: a checker never used costs nothing
        self._step = float(spec.motion_step)

    @property
    def world(self) -> ArmWorld:
        """This checker's own pybullet world, its workspace's obstacles loaded."""
        if self._world is None:
            self._world = borrow_world(self._model, self)
            self._world.load(self.workspace.all_primitives(), self.margin)
        return self._world

    def _free(self, q) -> bool:
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
