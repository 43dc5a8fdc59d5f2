"""A scene's meaning, not its listing, decides every result: the same obstacles listed in another
order (a problem file's workspaces reversed, MotionBenchMaker's objects reversed) give the same
workspace, the same cloud and code bit for bit, and the same plans, in every env. Before, the
cloud was drawn obstacle by obstacle in the file's order: MotionBenchMaker's files (objects in
alphabetical order) got other codes than our generators' (family order) for the same scene."""

from __future__ import annotations

import json
import shutil

import numpy as np
import pytest
import yaml

from mpnet.data.shipped import SHIPPED as TESTSETS
from mpnet.envs.mbm.files import load_mbm
from mpnet.envs.specs import generated, get_spec
from mpnet.envs.workspace import Workspace
from mpnet.models.pretrained import SHIPPED, write_checkpoint
from mpnet.planners.base import Problem
from mpnet.planners.mpnet import from_checkpoint
from mpnet.problems import load_problems

ENVS = sorted(generated())
QUERIES = {"arm7": 12, "panda_mbm": 12}  # the arms' queries cost more: fewer of them
SLOW = {"c2d", "c3d", "rigid", "arm7", "panda_mbm"}


def _reversed_file(src, dst):
    """The problem file with every workspace's obstacles listed in reverse."""
    data = json.loads(src.read_text())
    for w in data["workspaces"]:
        w["obstacles"] = w["obstacles"][::-1]
    dst.write_text(json.dumps(data))
    return dst


def _plans(spec, testset, models, n):
    """(status, path, partial) of the first n queries, MPNet-NR compiled, each with its index as seed."""
    planner = from_checkpoint(models, spec, 0, lambda ws: spec.cloud(ws, 200, 0), name="mpnet_nr", compiled=True)
    by_id = {w.id: w for w in testset.workspaces}
    q = testset.queries[0]  # compiled before the first query's budget runs (as the bench does)
    planner.warm_up(Problem(spec, by_id[q.workspace_id], spec.make_checker(by_id[q.workspace_id]), q.start, q.goal))
    out = []
    for i, q in enumerate(testset.queries[:n]):
        ws = by_id[q.workspace_id]
        r = planner.solve(Problem(spec, ws, spec.make_checker(ws), q.start, q.goal, seed=i), 10.0)
        out.append((r.status, None if r.path is None else np.asarray(r.path).tolist(), r.partial))
    return out


@pytest.mark.parametrize("env", [pytest.param(e, marks=pytest.mark.slow) if e in SLOW else e for e in ENVS], ids=ENVS)
def test_a_problem_file_listed_in_reverse_plans_the_same(env, tmp_path):
    spec = get_spec(env)
    src = TESTSETS / f"{env}-quick" / "seen.json"
    given, reverse = load_problems(src, spec), load_problems(_reversed_file(src, tmp_path / "r.json"), spec)
    for a, b in zip(given.workspaces, reverse.workspaces):
        assert a.obstacles_json() == b.obstacles_json() and a.geometry_key() == b.geometry_key()
        assert np.array_equal(spec.cloud(a, 200, 0), spec.cloud(b, 200, 0))  # bit for bit
    write_checkpoint(SHIPPED / f"{env}-quick", tmp_path / "pnet.ckpt")
    n = QUERIES.get(env, 40)
    want, got = _plans(spec, given, tmp_path, n), _plans(spec, reverse, tmp_path, n)
    assert want == got
    assert any(s == "exact" for s, _, _ in want)  # successes are compared too


def test_the_scene_not_its_id_or_listing_seeds_the_cloud():
    """Two ids, two listings, one scene: one cloud; another scene: another cloud."""
    spec = get_spec("s2d")
    rng = np.random.default_rng(0)
    centers, sizes = rng.uniform(-15, 15, (7, 2)), rng.uniform(1, 5, (7, 2))
    perm = rng.permutation(7)
    a = Workspace("3", "seen", centers, sizes)
    b = Workspace("kitchen", "unseen", centers[perm], sizes[perm])
    c = Workspace("3", "seen", centers + 1e-9, sizes)
    assert np.array_equal(spec.cloud(a, 200, 0), spec.cloud(b, 200, 0))
    assert not np.array_equal(spec.cloud(a, 200, 0), spec.cloud(c, 200, 0))
    assert np.array_equal(a.lo, b.lo) and np.array_equal(a.hi, b.hi)


def test_primitives_in_any_order_are_one_workspace():
    from mpnet.envs.shapes import Primitive

    prims = [Primitive("box", (0.5, 0, 0.2), (0.1, 0.2, 0.3)), Primitive.cylinder((0.4, 0.1, 0.3), 0.05, 0.2)]
    prims += [Primitive.sphere((0.6, -0.2, 0.4), 0.07), Primitive("box", (0.5, 0, 0.2), (0.1, 0.2, 0.4))]
    empty = np.zeros((0, 3))
    a, b = Workspace("a", "file", empty, empty, prims), Workspace("b", "file", empty, empty, prims[::-1])
    assert a.primitives == b.primitives and a.geometry_key() == b.geometry_key()
    spec = get_spec("panda_mbm")
    assert np.array_equal(spec.cloud(a, 200, 0), spec.cloud(b, 200, 0))


@pytest.mark.slow
def test_motionbenchmaker_scenes_with_their_objects_reversed_plan_the_same(mbm_dir, tmp_path):
    """The issue's case: MotionBenchMaker's scene files with every object (and each object's
    primitives) listed in reverse give the same workspaces and plans."""
    spec = get_spec("panda_mbm")
    flipped = tmp_path / "mbm"
    shutil.copytree(mbm_dir, flipped)
    scenes = sorted(p for p in flipped.rglob("*.yaml") if "scene" in p.name)
    assert scenes
    for path in scenes:
        data = yaml.safe_load(path.read_text())
        objs = data["world"]["collision_objects"][::-1]
        for o in objs:
            for key in ("primitives", "primitive_poses"):
                if key in o:
                    o[key] = o[key][::-1]
        data["world"]["collision_objects"] = objs
        path.write_text(yaml.safe_dump(data))
    given, reverse = load_mbm(mbm_dir, spec), load_mbm(flipped, spec)
    assert [w.obstacles_json() for w in given.workspaces] == [w.obstacles_json() for w in reverse.workspaces]
    write_checkpoint(SHIPPED / "panda_mbm-quick", tmp_path / "pnet.ckpt")
    assert _plans(spec, given, tmp_path, 6) == _plans(spec, reverse, tmp_path, 6)
