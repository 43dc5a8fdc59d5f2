"""panda_mbm's scenes and queries (mpnet.envs.mbm.generator): scenes depend on (seed, index)
only, a scene's queries start where MBM starts and end where a goal object asks panda_link8
to be, both valid; the split ids follow the generator's sizes."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from mpnet.envs.arm.ik import IKTarget, meets
from mpnet.envs.mbm.generator import FAMILY_ORDER, poses_of
from mpnet.envs.mbm.scenes import default_start, families, ik_tip
from mpnet.envs.scenes.generators import split_ids, split_sizes
from mpnet.envs.specs import get_spec

SPEC = get_spec("panda_mbm")
SCENES = SPEC.generator.scenes
FAMILIES = families(SCENES)
family_of = SPEC.generator.family_of


def _target(f, ws, query, name) -> IKTarget:
    (p,) = [p for p in ws.primitives if p.name == name]  # by name: the workspace's order is canonical
    pose = np.eye(4)
    pose[:3, :3] = p.rotation()
    pose[:3, 3] = p.center
    link8 = pose @ query.offset @ np.linalg.inv(f.ee_offset)
    return IKTarget(ik_tip(SCENES), link8, query.position_tol, query.orientation_tol)


@pytest.fixture(scope="module")
def scenes():
    """Scene 0 (bookshelf_small) and scene 6 (table_under_pick, whose start is IK too)."""
    return {i: SPEC.generator.make(i, "train", 0) for i in (0, 6)}


def test_a_scene_is_its_index_s_family_and_depends_on_seed_and_index_only(scenes):
    ws = scenes[0]
    assert family_of(ws).name == FAMILY_ORDER[0] == "bookshelf_small"
    assert family_of(scenes[6]).name == "table_under_pick"
    assert SPEC.generator.make(0, "train", 0).primitives == ws.primitives
    assert SPEC.generator.make(0, "train", 1).primitives != ws.primitives
    assert len(ws.primitives) == len(FAMILIES["bookshelf_small"].objects)


def test_poses_read_back_from_the_workspace_give_the_scene_again(scenes):
    f = family_of(scenes[0])
    again = f.primitives(poses_of(f, scenes[0]))
    by_name = {p.name: p for p in scenes[0].primitives}  # the workspace's own order is canonical, not the family's
    assert sorted(by_name) == sorted(p.name for p in again)
    for a in again:
        b = by_name[a.name]
        assert a.type == b.type and np.allclose(a.center, b.center) and np.allclose(a.size, b.size)
        assert np.allclose(a.rotation(), b.rotation(), atol=1e-9)


@pytest.mark.parametrize("index", [0, 6])
def test_a_scene_s_pairs_are_valid_and_meet_the_queries(scenes, index):
    ws = scenes[index]
    f = family_of(ws)
    checker = SPEC.make_checker(ws)
    pairs = list(itertools.islice(SPEC.pairs(SPEC, ws, checker, np.random.default_rng(5)), 3))
    assert pairs, "a screened scene gives at least one pair"
    model = SPEC.robot.model
    for start, goal in pairs:
        assert checker.is_valid(start.tolist()) and checker.is_valid(goal.tolist())
        assert any(meets(model, goal, _target(f, ws, f.goals, n)) for n in f.goals.objects)
        if f.starts is None:
            assert np.array_equal(start, default_start(SCENES))
        else:  # table_under_pick: the start is under the table top
            assert any(meets(model, start, _target(f, ws, f.starts, n)) for n in f.starts.objects)


def test_pairs_end_when_no_start_is_valid(scenes):
    """A scene whose start collides (a box over the arm) yields nothing, and ends."""
    from mpnet.envs.shapes import Primitive
    from mpnet.envs.workspace import Workspace

    ws = scenes[0]
    blocked = Workspace(
        ws.id, ws.split, ws.centers, ws.sizes, ws.primitives + (Primitive("box", (0, 0, 0.5), (1, 1, 1)),)
    )
    checker = SPEC.make_checker(blocked)
    assert list(SPEC.pairs(SPEC, blocked, checker, np.random.default_rng(0))) == []
    from mpnet.data.queries import make_queries

    assert make_queries(SPEC, blocked, 1, 0, "seen") == []  # the test set goes without it, as MBM does


def test_split_ids_follow_the_generator_s_sizes():
    n_train, n_unseen = split_sizes(SPEC)
    assert (n_train, n_unseen) == (7000, 700) and n_train % 7 == 0
    assert split_ids("unseen", 2, (n_train, n_unseen)) == [7000, 7001]
    assert split_sizes(get_spec("arm7")) == (100, 10)
    with pytest.raises(ValueError, match="700 workspaces"):
        split_ids("unseen", 701, (n_train, n_unseen))


def test_training_goes_on_past_the_unseen_block_where_the_generator_makes_any_scene():
    """A dataset larger than the seen split (issue 65's 500k paths) takes ids after the unseen
    block: the first 7000 are a smaller dataset's, no unseen scene is trained on, and the
    families stay even (7700 % 7 == 0); an env whose layouts are fixed refuses."""
    from mpnet.envs.scenes.generators import env_split_ids

    ids = env_split_ids(SPEC, "seen", 7003)
    assert ids[:7000] == list(range(7000)) and ids[7000:] == [7700, 7701, 7702]
    assert env_split_ids(SPEC, "seen", 12) == list(range(12)) and env_split_ids(SPEC, "unseen", 2) == [7000, 7001]
    assert [i % 7 for i in ids[6993:7003]] == [0, 1, 2, 3, 4, 5, 6, 0, 1, 2]
    assert not set(env_split_ids(SPEC, "seen", 20000)) & set(env_split_ids(SPEC, "unseen", 700))
    with pytest.raises(ValueError, match="the seen split has 100 workspaces, 101 asked"):
        env_split_ids(get_spec("s2d"), "seen", 101)
    with pytest.raises(ValueError, match="the unseen split has 700 workspaces"):
        env_split_ids(SPEC, "unseen", 701)


AUDITED_BUILD = """
import json, runpy, sys
opened = []
sys.addaudithook(lambda e, a: opened.append(a[0]) if e == "open" and str(a[0]).endswith((".yaml", ".yml")) else None)
sys.argv = ["harness.data", *sys.argv[1:]]
try:
    runpy.run_module("harness.data", run_name="__main__", alter_sys=True)
finally:
    print("OPENED " + json.dumps([str(p) for p in opened]))
"""


@pytest.mark.slow
def test_the_training_set_is_built_without_any_mbm_problem(tmp_path, repo):
    """Issue 26: MBM's 700 problems are test data only. The tiny panda_mbm build (data and
    test set) opens no YAML but the configs, Hydra's own and the package's env files, scene
    families and robot model: never a MoveIt scene or request."""
    import json
    import os
    import subprocess
    import sys

    p = subprocess.run(
        [
            sys.executable,
            "-c",
            AUDITED_BUILD,
            "+env=panda_mbm",
            "scale=tiny",
            "progress=false",
            f"cache_dir={tmp_path}",
        ],
        cwd=tmp_path,
        env={**os.environ, "PYTHONPATH": str(repo)},  # this checkout's code, whichever one is installed
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert p.returncode == 0, p.stderr
    assert "expert paths over 2 workspaces" in p.stdout and "8 queries" in p.stdout
    opened = json.loads(p.stdout.split("OPENED ", 1)[1])
    package = repo / "mpnet" / "data_files"
    allowed = (str(repo / "conf"), str(package / "envs"), str(package / "mbm" / "panda_scenes.yaml"))
    others = [
        f for f in opened if not f.startswith(allowed) and not any(s in f for s in ("/hydra/", "/.hydra/", "/robots/"))
    ]
    assert others == [] and any(f.endswith("panda_scenes.yaml") for f in opened)


def test_problem_files_read_as_yaml_safe_load_reads_them(mbm_dir, tmp_path):
    """The problem files' reader (libyaml's parser: ~7x faster on MBM's 1,400 files) gives the
    documents yaml.safe_load gives, and a malformed file is one line naming it."""
    import yaml

    from mpnet.envs.mbm.files import _load_yaml
    from mpnet.envs.spec import ProblemFileError

    paths = sorted(mbm_dir.rglob("*.yaml"))
    assert len(paths) >= 12
    for p in paths:
        assert _load_yaml(p) == yaml.safe_load(p.read_text(encoding="utf-8"))
    bad = tmp_path / "scene0001.yaml"
    bad.write_text("world: [1, 2\n")
    with pytest.raises(ProblemFileError, match="scene0001.yaml") as e:
        _load_yaml(bad)
    assert "\n" not in str(e.value)
