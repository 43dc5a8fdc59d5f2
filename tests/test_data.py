"""The data stage: expert paths, the dataset on disk, the artifact cache."""
import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from mpnet.data.expert import expert_paths
from mpnet.data.store import ArtifactError, content_key, ensure, read_manifest
from mpnet.envs import get_spec
from mpnet.envs.generators import make_workspace
from mpnet.motion import verify_path

REPO = Path(__file__).resolve().parent.parent


@pytest.mark.parametrize("env", ["s2d", "rigid"])
def test_expert_paths_valid_and_reproducible(env):
    spec = get_spec(env)
    wss = [(i, make_workspace(spec, i, "train")) for i in range(2)]
    a = expert_paths(spec, wss, 4, seed=3, iterations=300, max_seconds=2.0, jobs=2)
    b = expert_paths(spec, wss, 4, seed=3, iterations=300, max_seconds=2.0, jobs=1)
    assert len(a) == 8 and np.array_equal(a.states, b.states) and np.array_equal(a.workspace, [0] * 4 + [1] * 4)
    for i in range(len(a)):
        p = a.path(i)
        assert verify_path(spec, wss[a.workspace[i]][1], p, p[0], p[-1]) is None
        assert len(p) >= 3  # blocked_only: the straight line start -> goal is blocked, as in the test queries
    assert np.all(a.cost <= a.raw_cost + 1e-9)


def test_store_builds_once_and_checks_manifest(tmp_path):
    calls = []

    def build(folder):
        calls.append(folder)
        (folder / "x.txt").write_text("hi")
        return {"files": ["x.txt"]}

    f1, m1, built1 = ensure(tmp_path, "thing", {"a": 1}, build)
    f2, m2, built2 = ensure(tmp_path, "thing", {"a": 1}, build)
    assert built1 and not built2 and f1 == f2 and len(calls) == 1
    assert m1["key"] == content_key({"kind": "thing", "a": 1}) and "created_at" in m1
    f3, _, built3 = ensure(tmp_path, "thing", {"a": 2}, build)
    assert built3 and f3 != f1
    (f1 / "x.txt").unlink()
    with pytest.raises(ArtifactError, match="missing"):
        read_manifest(f1, m1["key"])
    _, _, rebuilt = ensure(tmp_path, "thing", {"a": 1}, build)  # a damaged artifact is rebuilt
    assert rebuilt and (f1 / "x.txt").exists()


def test_failed_build_leaves_nothing(tmp_path):
    def build(folder):
        (folder / "half").write_text("x")
        raise RuntimeError("boom")

    with pytest.raises(RuntimeError):
        ensure(tmp_path, "thing", {"a": 1}, build)
    assert [p.name for p in (tmp_path / "thing").iterdir() if not p.name.endswith(".lock")] == []


def test_data_cli_builds_once_under_concurrency(tmp_path):
    """Two jobs asking for the same dataset at once: one builds, the other waits and reuses."""
    cmd = [sys.executable, "-m", "harness.data", "+env=s2d", "scale=tiny", "progress=false",
           f"cache_dir={tmp_path}", f"hydra.run.dir={tmp_path / 'run'}"]
    procs = [subprocess.Popen(cmd, cwd=REPO, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
             for _ in range(2)]
    outs = [p.communicate(timeout=600) for p in procs]
    assert all(p.returncode == 0 for p in procs), outs
    firsts = sorted(o[0].splitlines()[0].split(":")[0] for o in outs)
    assert firsts == ["built", "cached"]
    folders = [d for d in (tmp_path / "data").iterdir() if d.is_dir()]
    assert len(folders) == 1
    manifest = json.loads((folders[0] / "manifest.json").read_text())
    assert manifest["config"]["env"] == "s2d" and manifest["expert"]["paths"] == 20
    assert {"git_rev", "versions", "created_at"} <= set(manifest)
    with np.load(folders[0] / "data.npz") as z:
        assert z["train_clouds"].shape == (2, 1400, 2) and z["ae_clouds"].shape == (20, 1400, 2)
        assert z["path_offsets"][-1] == len(z["path_states"])
