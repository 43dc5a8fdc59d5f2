"""Plain data types shared by every stage: a workspace and a query."""

from __future__ import annotations

import hashlib
from dataclasses import dataclass, field

import numpy as np

from mpnet.envs.shapes import IDENTITY, Primitive


@dataclass
class Workspace:
    """Axis-aligned box obstacles, stored as min and max corners (closed boxes), and, in 3D
    workspaces (problems@2, the arm), posed primitives: oriented boxes, cylinders, spheres.

    Both are kept in one canonical order (boxes by center then size, primitives by type,
    center, size, orientation), whatever order they were given in: the point cloud Enet reads
    is drawn obstacle by obstacle, so a scene listed in two orders would otherwise get two
    codes and two sets of plans (MotionBenchMaker's files list objects alphabetically, our
    generators by family). The meaning of a scene, not its listing, decides every result."""

    id: str
    split: str
    centers: np.ndarray
    sizes: np.ndarray
    primitives: tuple[Primitive, ...] = ()
    lo: np.ndarray = field(init=False, repr=False)
    hi: np.ndarray = field(init=False, repr=False)
    _geometry_key: int | None = field(init=False, repr=False, compare=False, default=None)

    def __post_init__(self):
        c = np.asarray(self.centers, float)
        c = c if c.ndim == 2 else c.reshape(len(c), -1)  # (0, dim) arrays: no obstacles
        s = np.asarray(self.sizes, float).reshape(c.shape)
        order = np.lexsort(np.hstack([c, s]).T[::-1])  # rows by their first column, then the next, ...
        self.centers, self.sizes = np.ascontiguousarray(c[order]), np.ascontiguousarray(s[order])
        self.lo = self.centers - self.sizes / 2
        self.hi = self.centers + self.sizes / 2
        self.primitives = tuple(sorted(self.primitives, key=lambda p: (p.type, p.center, p.size, p.orientation)))
        if self.primitives and self.dim != 3:
            raise ValueError(f"workspace {self.id!r}: posed primitives need a 3D workspace")

    def geometry_key(self) -> int:
        """A 63-bit digest of the obstacles (canonical order, exact float bits): the same scene
        gives the same key whatever its id or listing (the cloud's seed: clouds.cloud_rng)."""
        if self._geometry_key is None:
            h = hashlib.sha256(np.float64(self.dim).tobytes() + self.centers.tobytes() + self.sizes.tobytes())
            for p in self.primitives:
                h.update(p.type.encode() + np.array([*p.center, *p.size, *p.orientation], float).tobytes())
            self._geometry_key = int.from_bytes(h.digest()[:8], "little") >> 1
        return self._geometry_key

    @property
    def dim(self) -> int:
        return self.centers.shape[1]

    def all_primitives(self) -> list[Primitive]:
        """Every obstacle as a primitive (the axis-aligned boxes first)."""
        return [Primitive("box", c, s) for c, s in zip(self.centers.tolist(), self.sizes.tolist())] + list(
            self.primitives
        )

    @classmethod
    def from_json(cls, id: str, split: str, obstacles: list[dict], dim: int) -> Workspace:
        """The workspace of a logged obstacle list (obstacles_json's output)."""
        boxes = [o for o in obstacles if "type" not in o and "orientation" not in o]
        prims = tuple(
            Primitive(o.get("type", "box"), o["center"], o["size"], o.get("orientation", IDENTITY))
            for o in obstacles
            if "type" in o or "orientation" in o
        )
        shape = (len(boxes), dim)
        return cls(
            id,
            split,
            np.reshape([o["center"] for o in boxes], shape),
            np.reshape([o["size"] for o in boxes], shape),
            prims,
        )

    def obstacles_json(self) -> list[dict]:
        """Axis-aligned boxes as {center, size} (problems@1), then the primitives (@2)."""
        boxes = [{"center": c.tolist(), "size": s.tolist()} for c, s in zip(self.centers, self.sizes)]
        return boxes + [p.to_json() for p in self.primitives]


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
