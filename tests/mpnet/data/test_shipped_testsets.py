"""The quick test sets shipped in the package: each is the artifact its key names (today's
config of that env and scale computes the same key: a config change fails here, regenerate
with harness.export_weights), its files are the ones meta.json records, and a fresh cache
copies it instead of building one."""

import json

import pytest

from mpnet.data.shipped import SHIPPED, copy_testset, find_testset, read_meta
from mpnet.data.store import ArtifactError, content_key

SETS = sorted(p.parent for p in SHIPPED.glob("*/meta.json"))


def test_every_env_ships_a_quick_test_set():
    assert {p.name for p in SETS} == {f"{e}-quick" for e in ("s2d", "c2d", "c3d", "rigid", "arm7", "panda_mbm")}


@pytest.mark.parametrize("folder", SETS, ids=[p.name for p in SETS])
def test_shipped_test_set_is_the_artifact_of_its_key(folder, tmp_path, settings):
    from harness.artifacts.ensure import testset_key_config
    from mpnet.problems import load_problems

    meta = read_meta(folder)
    env, scale = folder.name.rsplit("-", 1)
    run = settings([f"+env={env}", f"scale={scale}"])
    key_config = testset_key_config(run)
    assert meta["config"] == json.loads(json.dumps(key_config))
    assert meta["key"] == content_key({"kind": "testset", **key_config}) and find_testset(meta["key"]) == folder
    fields = copy_testset(folder, tmp_path)  # verifies every file's sha256
    for split, name in zip(("seen", "unseen"), fields["files"]):
        ts = load_problems(tmp_path / name, run.env.spec)
        assert len(ts.queries) == fields["queries"][split] == meta["manifest"]["queries"][split] > 0


def test_a_damaged_shipped_test_set_is_refused(tmp_path):
    src = tmp_path / "set"
    src.mkdir()
    for f in SETS[0].iterdir():
        (src / f.name).write_bytes(f.read_bytes())
    seen = src / "seen.json"
    seen.write_text(seen.read_text().replace("0", "1", 1))
    (tmp_path / "out").mkdir()
    with pytest.raises(ArtifactError, match="seen.json"):
        copy_testset(src, tmp_path / "out")


@pytest.mark.slow  # a subprocess
def test_a_fresh_cache_plans_on_the_shipped_test_set_and_networks(tmp_path, run_cli):
    cache = tmp_path / "cache"
    p = run_cli(
        "harness", "+env=rigid", "+planner=mpnet_nr", "splits=[seen]", f"cache_dir={cache}", "rerun=false",
        "progress=false", f"hydra.run.dir={tmp_path / 'r'}",
    )  # fmt: skip
    assert "test set: the shipped set rigid-quick" in p.stderr and "shipped pretrained set rigid-quick" in p.stderr
    assert sorted(d.name for d in cache.iterdir()) == ["pretrained", "testset"]  # nothing built but copies
    assert "seen         200" in p.stdout
