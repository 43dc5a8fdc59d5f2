"""Posed obstacle primitives for 3D workspaces (problems@2): oriented boxes, cylinders and
spheres, as MotionBenchMaker's MoveIt scenes have them.

Every primitive has a `center`, a `size` (its extents in its own frame, as Foxglove's
primitives: a box's edge lengths, a cylinder's [diameter, diameter, height] along its own
z axis, a sphere's [diameter] * 3) and an `orientation` quaternion [x, y, z, w] (MoveIt's
and pybullet's order). An axis-aligned box is a box with the identity orientation.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property

import numpy as np

from mpnet.jit import njit

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
        return self._rotation.copy()

    @cached_property
    def _rotation(self) -> np.ndarray:
        """quat_matrix of the orientation, once (a cloud transforms each primitive's points per query)."""
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
        return surface_points([self], np.array([n]), rng)


def surface_points(primitives, counts, rng: np.random.Generator) -> np.ndarray:
    """counts[i] points uniform on primitive i's surface, all of them in order, (sum, 3) in the
    workspace frame. Drawn in one compiled call (_local_surfaces: numba's unboxing of the
    Generator alone costs ~18 us a call), posed per primitive by numpy's product, as before."""
    counts = np.asarray(counts, np.int64)
    kinds = np.array([TYPES.index(p.type) for p in primitives], np.int64)
    sizes = np.array([p.size for p in primitives], float).reshape(-1, 3)
    local = _local_surfaces(kinds, sizes, counts, rng)
    at = 0
    for p, k in zip(primitives, counts):
        if k:
            local[at : at + k] = local[at : at + k] @ p._rotation.T + np.asarray(p.center)
            at += k
    return local


@njit(cache=True)
def _local_surfaces(kinds, sizes, counts, rng):
    """Each primitive's counts[i] points in its own frame, one after another (_local_surface)."""
    out = np.empty((counts.sum(), 3))
    at = 0
    for i in range(kinds.shape[0]):
        _local_surface(kinds[i], sizes[i], counts[i], rng, out[at : at + counts[i]])
        at += counts[i]
    return out


@njit(cache=True)
def _local_surface(kind, size, n, rng, out):
    """n points uniform on a primitive's surface in its own frame (kind: TYPES' index), into
    out, drawn from rng as numpy's vectorised draws were, block for block and double for double
    (a box: its faces by area, numpy's choice: the first face whose cumulative share exceeds a
    draw, then (n, 3) uniforms; a cylinder: side or cap, angle, radius, height, which cap, n of
    each; a sphere: (n, 3) standard normals): the same points, compiled (a cloud is drawn per
    query, inside its time, and numpy's calls cost ~0.1 ms a primitive)."""
    if kind == 0:
        a, b, c = size[0], size[1], size[2]
        faces = np.array([b * c, b * c, a * c, a * c, a * b, a * b])  # -x, +x, -y, +y, -z, +z
        cdf = np.cumsum(faces / faces.sum())
        cdf /= cdf[-1]
        face = np.empty(n, np.int64)
        for i in range(n):
            u, f = rng.random(), 0
            while f < 5 and cdf[f] <= u:
                f += 1
            face[i] = f
        for i in range(n):
            for k in range(3):
                out[i, k] = (rng.random() - 0.5) * size[k]
        for i in range(n):
            axis = face[i] // 2
            out[i, axis] = (-0.5 if face[i] % 2 == 0 else 0.5) * size[axis]
    elif kind == 1:
        r, h = size[0] / 2, size[2]
        share = h / (h + r)  # side 2 pi r h against two caps 2 pi r^2
        draws = np.empty((5, n))
        for j in range(5):
            for i in range(n):
                draws[j, i] = rng.random()
        turn, low = 2 * np.pi, -h / 2
        span = h / 2 - low
        for i in range(n):
            side = draws[0, i] < share
            phi = 0.0 + turn * draws[1, i]
            rad = r if side else r * np.sqrt(draws[2, i])
            out[i, 0] = rad * np.cos(phi)
            out[i, 1] = rad * np.sin(phi)
            out[i, 2] = low + span * draws[3, i] if side else (low if draws[4, i] < 0.5 else -low)
    else:
        r = size[0] / 2
        for i in range(n):
            for k in range(3):
                out[i, k] = rng.standard_normal()
        for i in range(n):
            norm = np.sqrt(out[i, 0] * out[i, 0] + out[i, 1] * out[i, 1] + out[i, 2] * out[i, 2])
            for k in range(3):
                out[i, k] = r * out[i, k] / norm


def surface_cloud(primitives, total: int, rng: np.random.Generator) -> np.ndarray:
    """`total` points on the obstacles' surfaces, shared by area, (total, 3): what a depth
    camera sees of them, without occlusion. No obstacles: all points at the origin."""
    if not primitives:
        return np.zeros((total, 3))
    areas = np.array([p.area() for p in primitives])
    return surface_points(primitives, rng.multinomial(total, areas / areas.sum()), rng)
