"""MotionBenchMaker's Panda problems (Chamzas et al., RA-L 2022; the scene/request YAML pairs
MoveIt writes) as a test set for arm7.

A scene folder (e.g. `box_panda/`) holds `sceneNNNN.yaml` (world.collision_objects: boxes
[x, y, z], cylinders [height, radius] and spheres [radius] with poses in the base frame)
and `requestNNNN.yaml` (start_state.joint_state: 7 arm joints, then the fingers, which are
ignored: the arm model holds them (panda.yaml: 0.065, as every MBM request sets them);
goal_constraints[0].joint_constraints). Each
problem is one workspace and one query, both named by the folder and number
(`box_panda/0001`). A start or goal that collides with our Panda model is not an error:
the bench logs it as `invalid_query` (VAMP counts solved / valid / total the same way).

These problems are for testing only: never train on them.
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from mpnet.envs.shapes import IDENTITY, Primitive
from mpnet.envs.spec import SPLIT, EnvSpec, ProblemFileError, TestSet
from mpnet.envs.workspace import Query, Workspace

_SCENE = re.compile(r"scene(\d+)\.ya?ml$")


def is_mbm(path: str | Path) -> bool:
    """A folder (of scene/request pairs, or of such folders) or one scene/request YAML file."""
    p = Path(path)
    return p.is_dir() or p.suffix in (".yaml", ".yml")


def scene_robot(scene: Path) -> str | None:
    """The robot a MoveIt scene file is for (its robot_model_name; None: it names none)."""
    for line in scene.read_text(encoding="utf-8").splitlines():
        if line.startswith("robot_model_name:"):
            return line.partition(":")[2].strip().strip("'\"") or None
    return None


def _pairs(path: Path, robot: str) -> list[tuple[str, Path, Path]]:
    """(problem id, scene file, request file), sorted by id: a folder of folders gives the
    folders whose scenes are for `robot` (MotionBenchMaker's robot_model_name); a folder or
    file for another robot is an error."""
    if not path.exists():
        raise ProblemFileError(path, "no such file or folder")
    if path.is_file():
        m = re.search(r"(scene|request)(\d+)\.ya?ml$", path.name)
        if not m:
            raise ProblemFileError(path, "expected a sceneNNNN.yaml or requestNNNN.yaml file of MotionBenchMaker")
        folders, only = [path.parent], m.group(2)
    else:
        subs = sorted(d for d in path.iterdir() if d.is_dir())
        folders, only = ([path] if any(_SCENE.search(f.name) for f in path.iterdir()) else subs), None
        if folders == subs:
            firsts = {d: next((f for f in sorted(d.iterdir()) if _SCENE.search(f.name)), None) for d in subs}
            robots = {d: scene_robot(f) for d, f in firsts.items() if f is not None}
            folders = [d for d, r in robots.items() if r in (robot, None)]
            if robots and not folders:
                named = ", ".join(sorted({str(r) for r in robots.values()}))
                raise ProblemFileError(path, f"no problems for robot {robot} here (its scenes are for {named})")
    out = []
    for folder in folders:
        for scene in sorted(folder.iterdir()):
            m = _SCENE.search(scene.name)
            if not m or (only is not None and m.group(1) != only):
                continue
            request = scene.with_name(f"request{m.group(1)}{scene.suffix}")
            if not request.exists():
                raise ProblemFileError(scene, f"no {request.name} beside it")
            out.append((f"{folder.name}/{m.group(1)}", scene, request))
    if not out:
        raise ProblemFileError(path, "no MotionBenchMaker sceneNNNN.yaml / requestNNNN.yaml pairs found")
    return out


def _load_yaml(path: Path):
    """One scene or request file, by libyaml's parser where PyYAML has it (its wheels do): the
    same documents as yaml.safe_load's pure-Python parser, ~7x faster (a run of MBM's 700 read
    its 1,400 files in ~17 s)."""
    import yaml

    try:
        return yaml.load(path.read_text(encoding="utf-8"), Loader=getattr(yaml, "CSafeLoader", yaml.SafeLoader))
    except (OSError, UnicodeDecodeError, yaml.YAMLError) as e:
        raise ProblemFileError(path, f"cannot read it as YAML: {str(e).splitlines()[0]}") from None


_DIMS = {"box": 3, "cylinder": 2, "sphere": 1}  # MoveIt's SolidPrimitive dimension counts


def _numbers(path: Path, obj: str, value, keys: str, what: str) -> list[float]:
    """A vector written as a list or as a MoveIt message dict ({x: .., y: .., z: ..})."""
    if isinstance(value, dict):
        value = [value.get(k) for k in keys]
    try:
        out = [float(v) for v in value]
    except (TypeError, ValueError):
        out = []
    if len(out) != len(keys) or not all(np.isfinite(out)):
        raise ProblemFileError(path, f"object {obj!r}: {what} must be {len(keys)} finite numbers, got {value!r}")
    return out


def _pose(path: Path, obj: str, pose, what: str) -> tuple[np.ndarray, np.ndarray]:
    if not isinstance(pose, dict):
        raise ProblemFileError(path, f"object {obj!r}: {what} must have a position and an orientation")
    position = np.array(_numbers(path, obj, pose.get("position"), "xyz", f"{what} position"))
    quat = np.array(_numbers(path, obj, pose.get("orientation"), "xyzw", f"{what} orientation"))
    norm = float(np.linalg.norm(quat))
    if norm < 1e-9:
        raise ProblemFileError(path, f"object {obj!r}: {what} orientation is a zero quaternion")
    return position, quat / norm


def scene_primitives(path: Path, robot: str | None = None) -> list[Primitive]:
    """The collision objects of a MoveIt scene file as posed primitives (an object's own
    `pose`, where given, composed with its primitives' poses, as MoveIt does); robot: a scene
    naming another robot (robot_model_name) is refused."""
    from scipy.spatial.transform import Rotation  # here: scipy.spatial costs ~0.25 s (arm.ik.solve)

    doc = _load_yaml(path)
    named = doc.get("robot_model_name") if isinstance(doc, dict) else None
    if robot is not None and named not in (robot, None):
        raise ProblemFileError(path, f"a scene for robot {named}, not {robot}")
    world = doc.get("world") if isinstance(doc, dict) else None
    objects = world.get("collision_objects") if isinstance(world, dict) else None
    if not isinstance(objects, list):
        raise ProblemFileError(path, "not a MoveIt scene: no world.collision_objects list")
    out = []
    for i, o in enumerate(objects):
        obj = o.get("id", f"#{i}") if isinstance(o, dict) else f"#{i}"
        if not isinstance(o, dict):
            raise ProblemFileError(path, f"object {obj!r}: not a mapping")
        if o.get("meshes") or o.get("planes"):
            raise ProblemFileError(path, f"object {obj!r}: meshes and planes are not supported")
        prims, poses = o.get("primitives") or [], o.get("primitive_poses") or []
        if not isinstance(prims, list) or not isinstance(poses, list) or len(prims) != len(poses):
            raise ProblemFileError(path, f"object {obj!r}: needs as many primitive_poses as primitives")
        base_at, base_quat = _pose(path, obj, o["pose"], "pose") if "pose" in o else (np.zeros(3), IDENTITY)
        base_rot = Rotation.from_quat(base_quat)
        for prim, pose in zip(prims, poses):
            kind = prim.get("type") if isinstance(prim, dict) else None
            if kind not in _DIMS:
                raise ProblemFileError(path, f"object {obj!r}: unsupported primitive type {kind!r}")
            dims = _numbers(path, obj, prim.get("dimensions"), "xyz"[: _DIMS[kind]], f"a {kind}'s dimensions")
            if min(dims) <= 0:
                raise ProblemFileError(path, f"object {obj!r}: a {kind}'s dimensions must be positive, got {dims}")
            position, quat = _pose(path, obj, pose, "primitive pose")
            center = tuple(float(x) for x in base_at + base_rot.apply(position))
            quat = tuple(float(x) for x in (base_rot * Rotation.from_quat(quat)).as_quat())
            if kind == "box":
                out.append(Primitive("box", center, tuple(dims), quat))
            elif kind == "cylinder":
                out.append(Primitive.cylinder(center, radius=dims[1], height=dims[0], orientation=quat))
            else:
                out.append(Primitive.sphere(center, dims[0]))
    return out


def request_states(path: Path, joints: tuple[str, ...]) -> tuple[list[float], list[float]]:
    """(start, goal) vectors of the planned joints (the arm model's, by name) of a MoveIt
    motion plan request."""
    doc = _load_yaml(path)
    try:
        js = doc["start_state"]["joint_state"]
        named = dict(zip(js["name"], js["position"]))
        start = [float(named[j]) for j in joints]
        goal_by = {c["joint_name"]: float(c["position"]) for c in doc["goal_constraints"][0]["joint_constraints"]}
        goal = [goal_by[j] for j in joints]
        return start, goal
    except (KeyError, TypeError, ValueError, IndexError) as e:
        what = f"{type(e).__name__}: {e}"
        raise ProblemFileError(
            path, f"not a MoveIt request with the arm's {len(joints)} joints in start and goal ({what})"
        ) from None


def load_mbm(path: str | Path, spec: EnvSpec, per_set: int | None = None) -> TestSet:
    """Every scene/request pair under `path` as one workspace and one query each; per_set:
    only the first that many of each problem set (folder), by number."""
    model = getattr(spec.robot, "model", None)  # an arm's: its planned joints name the request's
    if model is None or spec.workspace_dim != 3:
        raise ProblemFileError(
            path, f"MotionBenchMaker's problems need an env whose robot is an arm model, not {spec.name}"
        )
    workspaces, queries = [], []
    taken: dict[str, int] = {}
    for pid, scene, request in _pairs(Path(path), model.scene_robot):
        folder = pid.rsplit("/", 1)[0]
        if per_set is not None and taken.get(folder, 0) >= per_set:
            continue
        taken[folder] = taken.get(folder, 0) + 1
        start, goal = request_states(request, model.joints)
        ws = Workspace(
            pid, SPLIT, np.zeros((0, 3)), np.zeros((0, 3)), tuple(scene_primitives(scene, model.scene_robot))
        )
        workspaces.append(ws)
        queries.append(Query(pid, pid, SPLIT, start, goal))
    return TestSet(spec, workspaces, queries)
