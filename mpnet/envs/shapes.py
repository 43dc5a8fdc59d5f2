"""Posed obstacle primitives for 3D workspaces (problems@2): oriented boxes, cylinders and
spheres, as MotionBenchMaker's MoveIt scenes have them.

Every primitive has a `center`, a `size` (its extents in its own frame, as Foxglove's
primitives: a box's edge lengths, a cylinder's [diameter, diameter, height] along its own
z axis, a sphere's [diameter] * 3) and an `orientation` quaternion [x, y, z, w] (MoveIt's
and pybullet's order). An axis-aligned box is a box with the identity orientation.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

TYPES = ("box", "cylinder", "sphere")
IDENTITY = (0.0, 0.0, 0.0, 1.0)


def quat_matrix(q) -> np.ndarray:
    """Rotation matrix of a unit quaternion [x, y, z, w] (normalised here)."""
    x, y, z, w = np.asarray(q, float) / np.linalg.norm(q)
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
        ]
    )


def yaw_quat(yaw: float) -> tuple[float, float, float, float]:
    """The quaternion of a turn by `yaw` about z."""
    return (0.0, 0.0, float(np.sin(yaw / 2)), float(np.cos(yaw / 2)))


@dataclass(frozen=True)
class Primitive:
    """One posed obstacle: `type` box, cylinder or sphere (see the module docstring)."""

    type: str
    center: tuple[float, float, float]
    size: tuple[float, float, float]
    orientation: tuple[float, float, float, float] = IDENTITY
    # Which object of a generated scene it is (MotionBenchMaker's object names: its queries name
    # their targets): not geometry, so no part of equality, order, cloud or file; a workspace keeps
    # its primitives in a canonical order, so a scene's objects are found by name, never by place.
    name: str | None = field(default=None, compare=False)

    def __post_init__(self):
        if self.type not in TYPES:
            raise ValueError(f"unknown primitive type {self.type!r}; choices: {', '.join(TYPES)}")
        object.__setattr__(self, "center", tuple(float(v) for v in self.center))
        object.__setattr__(self, "size", tuple(float(v) for v in self.size))
        q = np.asarray(self.orientation, float)
        object.__setattr__(self, "orientation", tuple(float(v) for v in q / np.linalg.norm(q)))

    @staticmethod
    def cylinder(center, radius: float, height: float, orientation=IDENTITY) -> Primitive:
        return Primitive("cylinder", center, (2 * radius, 2 * radius, height), orientation)

    @staticmethod
    def sphere(center, radius: float) -> Primitive:
        return Primitive("sphere", center, (2 * radius,) * 3)

    @property
    def radius(self) -> float:
        """Cylinders and spheres: half the diameter."""
        return self.size[0] / 2

    @property
    def height(self) -> float:
        return self.size[2]

    def rotation(self) -> np.ndarray:
        return quat_matrix(self.orientation)

    def to_json(self) -> dict:
        return {
            "type": self.type,
            "center": list(self.center),
            "size": list(self.size),
            "orientation": list(self.orientation),
        }

    def area(self) -> float:
        if self.type == "box":
            a, b, c = self.size
            return 2 * (a * b + b * c + a * c)
        r, h = self.radius, self.height
        if self.type == "cylinder":
            return 2 * np.pi * r * (r + h)
        return 4 * np.pi * r * r

    def sample_surface(self, n: int, rng: np.random.Generator) -> np.ndarray:
        """`n` points uniform on the surface, (n, 3) in the workspace frame."""
        local = {"box": _box_surface, "cylinder": _cylinder_surface, "sphere": _sphere_surface}[self.type](self, n, rng)
        return local @ self.rotation().T + np.asarray(self.center)


def _box_surface(p: Primitive, n: int, rng) -> np.ndarray:
    a, b, c = p.size
    faces = np.array([b * c, b * c, a * c, a * c, a * b, a * b])  # -x, +x, -y, +y, -z, +z
    face = rng.choice(6, size=n, p=faces / faces.sum())
    pts = (rng.uniform(size=(n, 3)) - 0.5) * np.array(p.size)
    axis, sign = face // 2, np.where(face % 2 == 0, -0.5, 0.5)
    pts[np.arange(n), axis] = sign * np.array(p.size)[axis]
    return pts


def _cylinder_surface(p: Primitive, n: int, rng) -> np.ndarray:
    r, h = p.radius, p.height
    side = rng.uniform(size=n) < h / (h + r)  # side 2 pi r h against two caps 2 pi r^2
    phi = rng.uniform(0, 2 * np.pi, n)
    rad = np.where(side, r, r * np.sqrt(rng.uniform(size=n)))
    z = np.where(side, rng.uniform(-h / 2, h / 2, n), np.where(rng.uniform(size=n) < 0.5, -h / 2, h / 2))
    return np.stack([rad * np.cos(phi), rad * np.sin(phi), z], axis=1)


def _sphere_surface(p: Primitive, n: int, rng) -> np.ndarray:
    v = rng.normal(size=(n, 3))
    return p.radius * v / np.linalg.norm(v, axis=1, keepdims=True)


def surface_cloud(primitives, total: int, rng: np.random.Generator) -> np.ndarray:
    """`total` points on the obstacles' surfaces, shared by area, (total, 3): what a depth
    camera sees of them, without occlusion. No obstacles: all points at the origin."""
    if not primitives:
        return np.zeros((total, 3))
    areas = np.array([p.area() for p in primitives])
    counts = rng.multinomial(total, areas / areas.sum())
    return np.concatenate([p.sample_surface(int(k), rng) for p, k in zip(primitives, counts) if k])
