"""Plain data types shared by every stage: a workspace and a query."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from mpnet.envs.shapes import IDENTITY, Primitive


@dataclass
class Workspace:
    """Axis-aligned box obstacles, stored as min and max corners (closed boxes), and, in 3D
    workspaces (problems@2, the arm), posed primitives: oriented boxes, cylinders, spheres."""

    id: str
    split: str
    centers: np.ndarray
    sizes: np.ndarray
    primitives: tuple[Primitive, ...] = ()
    lo: np.ndarray = field(init=False, repr=False)
    hi: np.ndarray = field(init=False, repr=False)

    def __post_init__(self):
        c = np.asarray(self.centers, float)
        self.centers = c if c.ndim == 2 else c.reshape(len(c), -1)  # (0, dim) arrays: no obstacles
        self.sizes = np.asarray(self.sizes, float).reshape(self.centers.shape)
        self.lo = self.centers - self.sizes / 2
        self.hi = self.centers + self.sizes / 2
        self.primitives = tuple(self.primitives)
        if self.primitives and self.dim != 3:
            raise ValueError(f"workspace {self.id!r}: posed primitives need a 3D workspace")

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
