"""A serial arm described by data (`mpnet/data_files/robots/<name>.yaml`): its URDF, which
joints are planned and within which limits, where the fingers are held, the end-effector
link, the collision sphere set and the link pairs allowed to touch.

Every arm part of the project (the sphere checker, the pybullet checker, the painter, the
MotionBenchMaker importer) is built from an `ArmModel`, so a second arm, or the same arm
with other fingers or limits, is a new data file, not new code.

The kinematics are read from the URDF itself: a tree of frames, each a fixed origin
transform followed by its joint's motion. Joints that are not planned (the fingers) are
held at their model position and folded into the fixed transform.
"""

from __future__ import annotations

import hashlib
import math
import os
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field
from functools import cache, cached_property
from importlib import resources
from pathlib import Path

import numpy as np

FIXED, REVOLUTE, PRISMATIC = 0, 1, 2
_JOINT_TYPES = {"fixed": FIXED, "revolute": REVOLUTE, "continuous": REVOLUTE, "prismatic": PRISMATIC}


class ArmModelError(ValueError):
    """A robot description that cannot be used, named by its file."""


def rpy_matrix(rpy) -> np.ndarray:
    """URDF's fixed-axis roll, pitch, yaw: Rz(yaw) Ry(pitch) Rx(roll)."""
    r, p, y = (float(v) for v in rpy)
    cr, sr, cp, sp, cy, sy = math.cos(r), math.sin(r), math.cos(p), math.sin(p), math.cos(y), math.sin(y)
    return np.array(
        [
            [cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
            [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
            [-sp, cp * sr, cp * cr],
        ]
    )


def transform(xyz=(0.0, 0.0, 0.0), rpy=(0.0, 0.0, 0.0)) -> np.ndarray:
    t = np.eye(4)
    t[:3, :3] = rpy_matrix(rpy)
    t[:3, 3] = [float(v) for v in xyz]
    return t


def _origin(el) -> np.ndarray:
    o = el.find("origin") if el is not None else None
    if o is None:
        return np.eye(4)
    return transform(o.get("xyz", "0 0 0").split(), o.get("rpy", "0 0 0").split())


@dataclass(frozen=True)
class Frame:
    """One link's frame: parent frame index (-1: the base), the fixed origin transform of
    its joint, the joint's kind and axis, and which planned coordinate drives it (-1: none)."""

    link: str
    parent: int
    origin: np.ndarray
    kind: int
    axis: np.ndarray
    coordinate: int


@dataclass(frozen=True)
class CollisionShape:
    """A link's collision geometry and its pose in the link frame: a mesh file (`path`, its
    `scale`), or a URDF primitive (`geometry` "box" with `size` (x, y, z), "sphere" with
    `size` (radius,))."""

    link: str
    path: Path | None
    origin: np.ndarray
    geometry: str = "mesh"
    size: tuple[float, ...] = (1.0, 1.0, 1.0)


@dataclass(frozen=True)
class Kinematics:
    """The URDF's tree as frames in parent-before-child order, with the collision shapes."""

    frames: tuple[Frame, ...]
    shapes: tuple[CollisionShape, ...]
    urdf_limits: tuple[tuple[float, float], ...]

    def index(self, link: str) -> int:
        for i, f in enumerate(self.frames):
            if f.link == link:
                return i
        raise KeyError(link)

    def arrays(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """The frames as mpnet.envs.arm.kinematics.forward's arrays (new ones each call): parent,
        origin (F, 3, 4), joint kind, axis (F, 3), driving coordinate."""
        frames = self.frames
        return (
            np.array([f.parent for f in frames], np.int64),
            np.ascontiguousarray(np.array([f.origin[:3] for f in frames], float)),
            np.array([f.kind for f in frames], np.int64),
            np.array([f.axis for f in frames], float),
            np.array([f.coordinate for f in frames], np.int64),
        )

    @cached_property
    def _forward_arrays(self) -> tuple[np.ndarray, ...]:
        return self.arrays()

    def link_transforms(self, q) -> np.ndarray:
        """(n_frames, 4, 4): every link frame in the base frame at configuration q, the sphere
        checker's poses (mpnet.envs.arm.kinematics.forward)."""
        from mpnet.envs.arm.kinematics import forward  # numba: loaded where poses are asked for, not with a model

        F = len(self.frames)
        pose = np.zeros((F + 1, 3, 4))
        forward(np.ascontiguousarray(q, float), *self._forward_arrays, pose)
        out = np.zeros((F, 4, 4))
        out[:, :3] = pose[:F]
        out[:, 3, 3] = 1.0
        return out


def joint_motion(kind: int, axis: np.ndarray, v: float) -> np.ndarray:
    """The 4x4 motion of a revolute (angle v about axis: kinematics.joint_rotation) or
    prismatic (v along axis) joint."""
    m = np.eye(4)
    if kind == REVOLUTE:
        from mpnet.envs.arm.kinematics import joint_rotation  # numba: loaded by a held revolute joint only

        x, y, z = (float(a) for a in axis)
        m[:3, :3] = np.reshape(joint_rotation(x, y, z, float(v)), (3, 3))
    elif kind == PRISMATIC:
        m[:3, 3] = axis * v
    return m


def read_urdf(path: Path, planned: tuple[str, ...], held: dict[str, float]) -> Kinematics:
    """The kinematic tree of a URDF: planned joints are coordinates 0.. in `planned`'s order,
    joints named in `held` are fixed at that value, any other moving joint is an error."""
    try:
        root = ET.parse(path).getroot()
    except (OSError, ET.ParseError) as e:
        raise ArmModelError(f"{path}: cannot read the URDF ({e})") from None
    links = {el.get("name"): el for el in root.findall("link")}
    joints = root.findall("joint")
    children = {j.find("child").get("link") for j in joints}
    roots = [name for name in links if name not in children]
    if len(roots) != 1:
        raise ArmModelError(f"{path}: expected one root link, found {roots}")
    by_parent: dict[str, list] = {}
    for j in joints:
        by_parent.setdefault(j.find("parent").get("link"), []).append(j)
    frames: list[Frame] = [Frame(roots[0], -1, np.eye(4), FIXED, np.zeros(3), -1)]
    limits: dict[str, tuple[float, float]] = {}
    queue = [roots[0]]
    while queue:
        parent = queue.pop(0)
        pi = next(i for i, f in enumerate(frames) if f.link == parent)
        for j in by_parent.get(parent, []):
            name, kind = j.get("name"), _JOINT_TYPES.get(j.get("type"))
            if kind is None:
                raise ArmModelError(f"{path}: joint {name!r} has unsupported type {j.get('type')!r}")
            axis_el = j.find("axis")
            axis = np.array([float(v) for v in (axis_el.get("xyz") if axis_el is not None else "1 0 0").split()])
            if kind != FIXED:
                axis = axis / np.linalg.norm(axis)
            origin, coordinate = _origin(j), -1
            if name in planned:
                coordinate = planned.index(name)
                lim = j.find("limit")
                limits[name] = (float(lim.get("lower")), float(lim.get("upper")))
            elif name in held:
                origin = origin @ joint_motion(kind, axis, held[name])
                kind = FIXED
            elif kind != FIXED:
                raise ArmModelError(f"{path}: joint {name!r} moves but is neither planned nor held")
            child = j.find("child").get("link")
            frames.append(Frame(child, pi, origin, kind, axis, coordinate))
            queue.append(child)
    missing = [j for j in planned if j not in limits]
    if missing:
        raise ArmModelError(f"{path}: no joints named {missing}")
    shapes = [_collision(path, f.link, links[f.link]) for f in frames if links[f.link].find("collision") is not None]
    return Kinematics(tuple(frames), tuple(shapes), tuple(limits[j] for j in planned))


def _collision(path: Path, link: str, el) -> CollisionShape:
    """A link's one <collision>: a mesh (package:// stripped, relative to the URDF) or a box
    or sphere primitive; anything else is an error, as is a second <collision>."""
    collisions = el.findall("collision")
    if len(collisions) > 1:
        raise ArmModelError(f"{path}: link {link!r} has {len(collisions)} <collision> elements; one is supported")
    col = collisions[0]
    geometry = col.find("geometry")
    shape = geometry[0] if geometry is not None and len(geometry) else None
    kind = shape.tag if shape is not None else None
    try:
        if kind == "mesh":
            rel = shape.get("filename").removeprefix("package://")
            scale = tuple(float(v) for v in shape.get("scale", "1 1 1").split())
            return CollisionShape(link, path.parent / rel, _origin(col), "mesh", scale)
        if kind == "box":
            return CollisionShape(link, None, _origin(col), "box", tuple(float(v) for v in shape.get("size").split()))
        if kind == "sphere":
            return CollisionShape(link, None, _origin(col), "sphere", (float(shape.get("radius")),))
    except (AttributeError, ValueError):
        raise ArmModelError(f"{path}: link {link!r}'s collision {kind} is malformed") from None
    raise ArmModelError(f"{path}: link {link!r}'s collision geometry {kind!r} is not supported (mesh, box, sphere)")


def _data_dir():
    return resources.files("mpnet") / "data_files" / "robots"


ROBOTS_VAR = "MPNET_BENCH_ROBOTS"


def _given_dirs() -> list[Path]:
    """The folders of $MPNET_BENCH_ROBOTS, in order."""
    return [Path(p).expanduser() for p in os.environ.get(ROBOTS_VAR, "").split(os.pathsep) if p]


def user_robot_dir() -> Path:
    """Where `python -m harness.fetch_mbm` installs robots whose files the package cannot ship
    (MotionBenchMaker's UR5 and Fetch): the first folder of $MPNET_BENCH_ROBOTS, else
    $XDG_DATA_HOME/mpnet-bench/robots (~/.local/share/mpnet-bench/robots)."""
    given = _given_dirs()
    if given:
        return given[0]
    home = os.environ.get("XDG_DATA_HOME") or Path.home() / ".local" / "share"
    return Path(home) / "mpnet-bench" / "robots"


def robot_dirs() -> list[Path]:
    """Where a robot's files (description, sphere set, URDF) are looked for, in order: the
    package's, each folder of $MPNET_BENCH_ROBOTS, the user's robot folder."""
    return list(dict.fromkeys([Path(str(_data_dir())), *_given_dirs(), user_robot_dir()]))


def robot_file(name: str) -> Path | None:
    """The first robot folder's file of that name (None: in none of them)."""
    return next((d / name for d in robot_dirs() if (d / name).is_file()), None)


def _urdf_path(urdf: str) -> Path:
    """A URDF path: absolute, or relative to a robot folder (robot_dirs), or else to
    pybullet_data (which ships the Panda's URDF and meshes)."""
    p = Path(urdf)
    if p.is_absolute():
        return p
    found = robot_file(urdf)
    if found is not None:
        return found
    import pybullet_data

    return Path(pybullet_data.getDataPath()) / urdf


@dataclass(frozen=True)
class ArmModel:
    """An arm as data (see the module docstring). `limits` are the planned joints' bounds
    (MoveIt's, where a benchmark uses them, not necessarily the URDF's); `fingers` maps
    each held joint to its position; `allowed` holds the link pairs never checked against
    each other (adjacent links, and pairs that cannot meet within the limits)."""

    name: str
    urdf: str
    joints: tuple[str, ...]
    limits: tuple[tuple[float, float], ...]
    fingers: dict[str, float]
    end_effector: str
    allowed: frozenset[tuple[str, str]]
    spheres: str
    source: str = ""
    kinematics: Kinematics = field(repr=False, compare=False, default=None)
    # MotionBenchMaker's name for this robot in its scene files (default: `name`)
    scene_robot: str = ""
    # harness.spherize's settings for a robot without a sphere set yet
    spherize: dict = field(repr=False, compare=False, default_factory=dict)
    # link pairs the checker tests on their convex hulls, not their spheres (hull_kernels)
    exact_pairs: frozenset[tuple[str, str]] = frozenset()

    @property
    def dof(self) -> int:
        return len(self.joints)

    @property
    def urdf_path(self) -> Path:
        return _urdf_path(self.urdf)

    def is_allowed(self, a: str, b: str) -> bool:
        return a == b or (min(a, b), max(a, b)) in self.allowed

    def to_json(self) -> dict:
        """What a log records of the model: enough to rebuild it and to tell two apart."""
        return {
            "name": self.name,
            "urdf": self.urdf,
            "joints": list(self.joints),
            "limits": [list(b) for b in self.limits],
            "fingers": dict(self.fingers),
            "end_effector": self.end_effector,
            "spheres": self.spheres,
            "sha256": self.digest(),
        }

    def digest(self) -> str:
        """sha256 of the description file and the sphere file: a model's identity in
        cache keys and logs."""
        h = hashlib.sha256()
        for name in (f"{self.name}.yaml", self.spheres):
            found = robot_file(name)
            if found is None and name == self.spheres:
                make = f"python -m harness.spherize {self.name}"
                raise ArmModelError(f"arm model {self.name}: no sphere set {name} yet ({make})")
            if found is None:
                raise ArmModelError(f"arm model {self.name}: no {name} in {', '.join(map(str, robot_dirs()))}")
            h.update(found.read_bytes())
        return h.hexdigest()[:16]

    @property
    def spheres_path(self) -> Path | None:
        """The sphere set's file (None: not made yet: `python -m harness.spherize <name>`)."""
        return robot_file(self.spheres)

    def link_transforms(self, q) -> np.ndarray:
        return self.kinematics.link_transforms(q)

    def end_effector_position(self, q) -> np.ndarray:
        return self.link_transforms(q)[self.kinematics.index(self.end_effector), :3, 3]


def _pairs(items, where: str) -> frozenset[tuple[str, str]]:
    try:
        return frozenset((min(a, b), max(a, b)) for a, b in items)
    except (TypeError, ValueError):
        raise ArmModelError(f"{where}: allowed and exact_pairs must be lists of [link, link] pairs") from None


@cache
def load_arm_model(name: str) -> ArmModel:
    """The arm model `name` from the robot folders (robot_dirs: the package's, then the user's)."""
    import yaml

    path = robot_file(f"{name}.yaml")
    if path is None:
        known = sorted({p.name.removesuffix(".yaml") for d in robot_dirs() if d.is_dir() for p in d.glob("*.yaml")})
        raise ArmModelError(f"unknown arm model {name!r}; choices: {', '.join(known)}")
    doc = yaml.safe_load(path.read_text(encoding="utf-8"))
    try:
        joints = tuple(doc["joints"])
        fingers = {str(k): float(v) for k, v in (doc.get("fingers") or {}).items()}
        urdf = _urdf_path(doc["urdf"])
        if not urdf.is_file():
            hint = doc.get("install", "")
            raise ArmModelError(f"{path}: its URDF {doc['urdf']} is in no robot folder ({hint or 'see the file'})")
        kin = read_urdf(urdf, joints, fingers)
        limits = tuple((float(lo), float(hi)) for lo, hi in doc.get("limits") or kin.urdf_limits)
        model = ArmModel(
            name=str(doc["name"]),
            urdf=str(doc["urdf"]),
            joints=joints,
            limits=limits,
            fingers=fingers,
            end_effector=str(doc["end_effector"]),
            allowed=_pairs(doc.get("allowed") or [], str(path)),
            spheres=str(doc["spheres"]),
            source=str(doc.get("source", "")),
            kinematics=kin,
            scene_robot=str(doc.get("scene_robot", doc["name"])),
            spherize=dict(doc.get("spherize") or {}),
            exact_pairs=_pairs(doc.get("exact_pairs") or [], str(path)),
        )
    except (KeyError, TypeError) as e:
        raise ArmModelError(f"{path}: missing or malformed key {e}") from None
    if len(model.limits) != len(joints) or any(lo >= hi for lo, hi in model.limits):
        raise ArmModelError(f"{path}: limits must be one [lower, upper] pair per joint, lower < upper")
    names = {f.link for f in kin.frames}
    for key, pairs in (("allowed", model.allowed), ("exact_pairs", model.exact_pairs)):
        for a, b in pairs:
            if a not in names or b not in names:
                raise ArmModelError(f"{path}: {key} pair ({a}, {b}) names a link the URDF lacks")
    kin.index(model.end_effector)
    return model
