"""Seeded arm7 workspaces: the Panda (base at the origin) on a table, with shelves, a wall,
a bin and clutter around it, as oriented boxes, cylinders and spheres in the base frame.

Workspace i depends on (seed, i) only. Ids 0-99 are training workspaces (the seen test
split draws from them), 100-109 the unseen ones, as for every env. The obstacles' point
cloud is points on their surfaces (what a depth camera sees, without occlusion).
"""

from __future__ import annotations

import math

import numpy as np

from mpnet.envs.shapes import Primitive, surface_cloud, yaw_quat
from mpnet.envs.workspace import Workspace

# The arm stands on the table; its base link reaches down to z = 0. 1.5 cm below: the sphere
# covering of the base reaches at most ~1 cm beyond its mesh (at -0.01 every scene's base
# spheres touched the table).
TABLE_TOP = -0.015
CLEAR = 0.3  # nothing but the table within this distance of the base's axis


def _part(yaw: float, along: float, across: float, z: float, size) -> Primitive:
    """An oriented box whose centre sits at (along, across) in the frame turned by yaw."""
    c, s = math.cos(yaw), math.sin(yaw)
    return Primitive("box", (along * c - across * s, along * s + across * c, z), size, yaw_quat(yaw))


def shelf(yaw: float, dist: float, width: float, depth: float, height: float, boards: int, t: float = 0.02):
    """An open shelf unit facing the base: sides, back, top and `boards` shelves, its front
    `dist` from the base along the direction `yaw`."""
    mid = dist + depth / 2
    z0 = TABLE_TOP
    parts = [
        _part(yaw, mid, -width / 2, z0 + height / 2, (depth, t, height)),
        _part(yaw, mid, width / 2, z0 + height / 2, (depth, t, height)),
        _part(yaw, dist + depth - t / 2, 0.0, z0 + height / 2, (t, width, height)),
        _part(yaw, mid, 0.0, z0 + height - t / 2, (depth, width, t)),
    ]
    for k in range(1, boards + 1):
        parts.append(_part(yaw, mid, 0.0, z0 + k * height / (boards + 1), (depth, width, t)))
    return parts


def wall(yaw: float, dist: float, width: float, height: float, t: float = 0.03):
    return [_part(yaw, dist + t / 2, 0.0, TABLE_TOP + height / 2, (t, width, height))]


def bin_(yaw: float, dist: float, width: float, depth: float, height: float, t: float = 0.015):
    """An open box on the table: four walls."""
    mid, z = dist + depth / 2, TABLE_TOP + height / 2
    return [
        _part(yaw, dist + t / 2, 0.0, z, (t, width, height)),
        _part(yaw, dist + depth - t / 2, 0.0, z, (t, width, height)),
        _part(yaw, mid, -width / 2, z, (depth, t, height)),
        _part(yaw, mid, width / 2, z, (depth, t, height)),
    ]


def clutter(rng: np.random.Generator, yaw: float, dist: float) -> Primitive:
    """A small box, can or ball standing on the table."""
    c, s = math.cos(yaw), math.sin(yaw)
    kind = rng.choice(["box", "cylinder", "sphere"])
    if kind == "box":
        size = rng.uniform([0.04, 0.04, 0.05], [0.15, 0.15, 0.25])
        return Primitive(
            "box", (dist * c, dist * s, TABLE_TOP + size[2] / 2), size, yaw_quat(rng.uniform(-math.pi, math.pi))
        )
    if kind == "cylinder":
        r, h = rng.uniform(0.03, 0.07), rng.uniform(0.08, 0.3)
        return Primitive.cylinder((dist * c, dist * s, TABLE_TOP + h / 2), r, h)
    r = rng.uniform(0.04, 0.09)
    return Primitive.sphere((dist * c, dist * s, TABLE_TOP + r), r)


class ArmScenes:
    """arm7's generator: a table always; one or two shelves, maybe a wall and a bin, and
    clutter, at seeded directions around the base (shelves and wall never face the same
    way)."""

    def make(self, index: int, split: str, seed: int = 0) -> Workspace:
        rng = np.random.default_rng([seed, 17, index])
        table = Primitive("box", (0.35, 0.0, TABLE_TOP - 0.025), (1.1, 1.6, 0.05))
        parts: list[Primitive] = [table]
        taken: list[float] = []

        def direction(spread: float = math.radians(150)) -> float:
            for _ in range(100):
                a = rng.uniform(-spread, spread)
                if all(abs(math.remainder(a - b, 2 * math.pi)) > math.radians(60) for b in taken):
                    taken.append(a)
                    return a
            taken.append(a)
            return a

        for _ in range(rng.integers(1, 3)):
            parts += shelf(
                direction(),
                rng.uniform(0.5, 0.75),
                rng.uniform(0.5, 0.9),
                rng.uniform(0.25, 0.4),
                rng.uniform(0.6, 1.1),
                int(rng.integers(1, 4)),
            )
        if rng.uniform() < 0.5:
            parts += wall(direction(math.pi), rng.uniform(0.6, 0.9), rng.uniform(0.8, 1.6), rng.uniform(0.6, 1.2))
        if rng.uniform() < 0.6:
            parts += bin_(
                direction(), rng.uniform(CLEAR + 0.05, 0.55), *rng.uniform([0.2, 0.2, 0.1], [0.4, 0.35, 0.25])
            )
        for _ in range(rng.integers(1, 5)):
            parts.append(clutter(rng, rng.uniform(-math.pi, math.pi), rng.uniform(CLEAR + 0.05, 0.75)))
        return Workspace(str(index), split, np.zeros((0, 3)), np.zeros((0, 3)), tuple(parts))

    def make_many(self, indices: list[int], split: str, seed: int = 0) -> list[Workspace]:
        return [self.make(i, split, seed) for i in indices]


def arm_cloud(ws: Workspace, total: int, rng: np.random.Generator) -> np.ndarray:
    """Points on the obstacles' surfaces, shared by area (the arm's Enet input)."""
    return surface_cloud(ws.all_primitives(), total, rng)
