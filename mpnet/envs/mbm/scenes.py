"""MotionBenchMaker's seven Panda scene families as generators (issue 26): seeded scenes made
the way MBM's SceneSampler makes them, from data that quotes MBM's own configuration files
(`mpnet/data_files/mbm/panda_scenes.yaml`; docs/research/motionbenchmaker-scenes.md), and the
panda_link8 poses its queries ask for.

MBM's 700 packaged problems are test data: nothing here reads them, and no range is fitted to
them. Where MBM and we differ: MBM drew from one unseeded generator (its problems cannot be
made again); we draw from the caller's seeded numpy Generator, in a fixed order.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cache
from importlib import resources

import numpy as np
import yaml

from mpnet.envs.shapes import Primitive, quat_matrix

FORMAT = "mpnet-bench/mbm-scenes@1"


def pose(position, orientation=(0.0, 0.0, 0.0, 1.0)) -> np.ndarray:
    """4 x 4 homogeneous transform of a position and a quaternion [x, y, z, w]."""
    out = np.eye(4)
    out[:3, :3] = quat_matrix(orientation)
    out[:3, 3] = position
    return out


def _yaw_pose(translation, yaw: float) -> np.ndarray:
    """MBM's sampled variation: a translation and a turn about z (every Panda family's
    ranges are zero for roll and pitch, so RBX's uniformRPY reduces to a yaw)."""
    c, s = np.cos(yaw), np.sin(yaw)
    out = np.eye(4)
    out[:2, :2] = [[c, -s], [s, c]]
    out[:3, 3] = translation
    return out


@dataclass(frozen=True)
class SceneObject:
    name: str
    type: str  # box or cylinder
    dims: tuple[float, ...]  # box: full extents; cylinder: (height, radius), as MBM's files
    pose: np.ndarray  # 4 x 4, in the scene file's frame (before base_offset)


@dataclass(frozen=True)
class Variation:
    """Each named object (or the whole scene, "World") moved by its own draw of a uniform
    translation (half-widths `position`) and yaw (half-width `yaw`)."""

    names: tuple[str, ...]
    position: np.ndarray
    yaw: float

    def draw(self, rng: np.random.Generator) -> np.ndarray:
        return _yaw_pose(rng.uniform(-self.position, self.position), float(rng.uniform(-self.yaw, self.yaw)))


@dataclass(frozen=True)
class PoseQuery:
    """An MBM query: an object list and the offset of the wanted frame from the object, with
    its tolerances (a box of full size position_tol in the robot's frame; orientation_tol per
    axis, radians)."""

    objects: tuple[str, ...]
    offset: np.ndarray
    position_tol: np.ndarray
    orientation_tol: np.ndarray


@dataclass(frozen=True)
class SceneFamily:
    name: str
    files: tuple[str, ...]
    base_offset: np.ndarray
    ee_offset: np.ndarray
    objects: tuple[SceneObject, ...]
    world: Variation
    variations: tuple[Variation, ...]
    goals: PoseQuery
    starts: PoseQuery | None  # None: MBM's default start (the data's `start`)

    def sample(self, rng: np.random.Generator) -> dict[str, np.ndarray]:
        """Every object's pose in the robot's base frame: base_offset, then one World draw
        applied to all (P' = W P: about the base's origin), then each varied object's own
        draw in its own frame (P' = P T), in the data's order."""
        world = self.world.draw(rng) @ self.base_offset
        poses = {o.name: world @ o.pose for o in self.objects}
        for v in self.variations:
            for name in v.names:
                poses[name] = poses[name] @ v.draw(rng)
        return poses

    def primitives(self, poses: dict[str, np.ndarray]) -> tuple[Primitive, ...]:
        """The scene's obstacles, in the data's object order."""
        from scipy.spatial.transform import Rotation  # here: scipy.spatial costs ~0.25 s (arm.ik.solve)

        out = []
        for o in self.objects:
            p = poses[o.name]
            quat = tuple(Rotation.from_matrix(p[:3, :3]).as_quat())
            if o.type == "box":
                out.append(Primitive("box", p[:3, 3], o.dims, quat, name=o.name))
            else:
                height, radius = o.dims
                out.append(Primitive("cylinder", p[:3, 3], (2 * radius, 2 * radius, height), quat, name=o.name))
        return tuple(out)

    def tip_targets(self, poses: dict[str, np.ndarray], query: PoseQuery) -> dict[str, np.ndarray]:
        """The IK tip's wanted pose per object of the query (the Panda's: panda_link8): object *
        offset * inverse(ee_offset), as MBM's ProblemGenerator computes it."""
        inv = np.linalg.inv(self.ee_offset)
        return {name: poses[name] @ query.offset @ inv for name in query.objects}


def _query(d: dict) -> PoseQuery:
    off = d["offset"]
    return PoseQuery(
        tuple(d["objects"]),
        pose(off["position"], off["orientation"]),
        np.asarray(off["position_tol"], float),
        np.asarray(off["orientation_tol"], float),
    )


def _variation(d: dict, names=("World",)) -> Variation:
    return Variation(tuple(d.get("names", names)), np.asarray(d["position"], float), float(d["yaw"]))


def _family(name: str, d: dict) -> SceneFamily:
    objects = tuple(
        SceneObject(k, o["type"], tuple(float(x) for x in o["dims"]), pose(o["position"], o["orientation"]))
        for k, o in d["objects"].items()
    )
    return SceneFamily(
        name,
        tuple(d["files"]),
        pose(d["base_offset"]["position"], d["base_offset"]["orientation"]),
        pose(d["ee_offset"]["position"], d["ee_offset"]["orientation"]),
        objects,
        _variation(d["world"]),
        tuple(_variation(v) for v in d["variations"]),
        _query(d["goals"]),
        _query(d["starts"]) if "starts" in d else None,
    )


@cache
def _data(scenes: str) -> dict:
    text = (resources.files("mpnet") / "data_files" / "mbm" / scenes).read_text(encoding="utf-8")
    data = yaml.safe_load(text)
    if data.get("format") != FORMAT:
        raise ValueError(f"{scenes}: format {data.get('format')!r}, expected {FORMAT!r}")
    return data


def families(scenes: str) -> dict[str, SceneFamily]:
    """A robot's scene families (`scenes`: its file in data_files/mbm), by name, in the file's
    order (parsed once per process; a fresh dict per call)."""
    return dict(_families(scenes))


@cache
def _families(scenes: str) -> dict[str, SceneFamily]:
    return {name: _family(name, d) for name, d in _data(scenes)["families"].items()}


def default_start(scenes: str) -> np.ndarray:
    """The robot's start for every family that has no `starts` of its own (MBM's robot_state)."""
    return np.asarray(_data(scenes)["start"], float)


def ik_tip(scenes: str) -> str:
    """The link MBM's queries pose (the end of the SRDF's planning chain)."""
    return str(_data(scenes)["tip"])
