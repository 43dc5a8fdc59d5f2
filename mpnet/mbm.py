"""MotionBenchMaker's Panda problems (Chamzas et al., RA-L 2022; the scene/request YAML pairs
MoveIt writes) as a test set for arm7.

A scene folder (e.g. `box_panda/`) holds `sceneNNNN.yaml` (world.collision_objects: boxes
[x, y, z], cylinders [height, radius] and spheres [radius] with poses in the base frame)
and `requestNNNN.yaml` (start_state.joint_state: 7 arm joints, then the fingers, which are
ignored: our Panda's fingers are fixed open; goal_constraints[0].joint_constraints). Each
problem is one workspace and one query, both named by the folder and number
(`box_panda/0001`). A start or goal that collides with our Panda model is not an error:
the bench logs it as `invalid_query` (VAMP counts solved / valid / total the same way).

These problems are for testing only: never train on them.
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from mpnet.envs.shapes import Primitive
from mpnet.envs.spec import EnvSpec, TestSet
from mpnet.envs.workspace import Query, Workspace
from mpnet.problems import SPLIT, ProblemFileError

ARM_JOINTS = tuple(f"panda_joint{i}" for i in range(1, 8))
_SCENE = re.compile(r"scene(\d+)\.ya?ml$")


def is_mbm(path: str | Path) -> bool:
    """A folder (of scene/request pairs, or of such folders) or one scene/request YAML file."""
    p = Path(path)
    return p.is_dir() or p.suffix in (".yaml", ".yml")


def _pairs(path: Path) -> list[tuple[str, Path, Path]]:
    """(problem id, scene file, request file), sorted by id."""
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
    import yaml

    try:
        return yaml.safe_load(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, yaml.YAMLError) as e:
        raise ProblemFileError(path, f"cannot read it as YAML: {str(e).splitlines()[0]}") from None


def scene_primitives(path: Path) -> list[Primitive]:
    """The collision objects of a MoveIt scene file as posed primitives."""
    doc = _load_yaml(path)
    try:
        objects = (doc.get("world") or {}).get("collision_objects") or []
        out = []
        for o in objects:
            for prim, pose in zip(o.get("primitives") or [], o.get("primitive_poses") or [], strict=True):
                kind, dims = prim["type"], [float(x) for x in prim["dimensions"]]
                center, quat = [float(x) for x in pose["position"]], [float(x) for x in pose["orientation"]]
                if kind == "box":
                    out.append(Primitive("box", center, dims, quat))
                elif kind == "cylinder":
                    out.append(Primitive.cylinder(center, radius=dims[1], height=dims[0], orientation=quat))
                elif kind == "sphere":
                    out.append(Primitive.sphere(center, dims[0]))
                else:
                    raise ProblemFileError(path, f"object {o.get('id')!r}: unsupported primitive type {kind!r}")
            if o.get("meshes"):
                raise ProblemFileError(path, f"object {o.get('id')!r}: meshes are not supported")
        return out
    except (KeyError, TypeError, ValueError, AttributeError, IndexError) as e:
        if isinstance(e, ProblemFileError):
            raise
        raise ProblemFileError(
            path, f"not a MoveIt scene with world.collision_objects ({type(e).__name__}: {e})"
        ) from None


def request_states(path: Path) -> tuple[list[float], list[float]]:
    """(start, goal) joint vectors of the 7 arm joints of a MoveIt motion plan request."""
    doc = _load_yaml(path)
    try:
        js = doc["start_state"]["joint_state"]
        named = dict(zip(js["name"], js["position"]))
        start = [float(named[j]) for j in ARM_JOINTS]
        goal_by = {c["joint_name"]: float(c["position"]) for c in doc["goal_constraints"][0]["joint_constraints"]}
        goal = [goal_by[j] for j in ARM_JOINTS]
        return start, goal
    except (KeyError, TypeError, ValueError, IndexError) as e:
        raise ProblemFileError(
            path, f"not a MoveIt request with the Panda's 7 joints in start and goal ({type(e).__name__}: {e})"
        ) from None


def load_mbm(path: str | Path, spec: EnvSpec) -> TestSet:
    """Every scene/request pair under `path` as one workspace and one query each."""
    if spec.state_dim != len(ARM_JOINTS) or spec.workspace_dim != 3:
        raise ProblemFileError(path, f"MotionBenchMaker's Panda problems need env arm7, not {spec.name}")
    workspaces, queries = [], []
    for pid, scene, request in _pairs(Path(path)):
        start, goal = request_states(request)
        ws = Workspace(pid, SPLIT, np.zeros((0, 3)), np.zeros((0, 3)), tuple(scene_primitives(scene)))
        workspaces.append(ws)
        queries.append(Query(pid, pid, SPLIT, start, goal))
    return TestSet(spec, workspaces, queries)
