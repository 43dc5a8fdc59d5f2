"""Scale-out on Hydra launchers: sweeps through joblib and submitit's local executor (what
SLURM runs, minus the queue), the data stage sharded and merged into the same artifact, and
the checks of the sharding and Lightning keys."""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pytest
from mcap.reader import make_reader
from omegaconf import OmegaConf

from harness.core.cli import UsageError
from harness.core.config import lightning_params
from harness.core.settings import settings_of
from mpnet.data.expert import chunks_of
from tests.harness._cli import printed_folder


def _topics(path) -> list[tuple[str, dict]]:
    with open(path, "rb") as f:
        return [(c.topic, json.loads(m.data)) for _, c, m in make_reader(f).iter_messages()]


@pytest.mark.slow
@pytest.mark.parametrize("launcher", [["hydra/launcher=joblib", "hydra.launcher.n_jobs=2"], ["hydra/launcher=local"]])
def test_sweep_of_two_seeds_on_a_launcher(tmp_path, run_cli, launcher):
    sweep = tmp_path / "sweep"
    run_cli(
        "harness",
        "+env=s2d",
        "+planner=rrt_connect",
        "scale=tiny",
        "rerun=false",
        "progress=false",
        f"cache_dir={tmp_path / 'cache'}",
        f"hydra.sweep.dir={sweep}",
        *launcher,
        "-m",
        "seed=0,1",
    )
    for seed in (0, 1):
        msgs = _topics(sweep / "s2d" / "rrt_connect" / f"seed{seed}" / "trials.mcap")
        assert next(m for t, m in msgs if t == "/run")["seed"] == seed
        assert sum(t == "/query" for t, _ in msgs) == 8  # tiny: 2 + 2 workspaces, 2 queries each


def _data(folder):
    (path,) = folder.glob("data/*/data.npz")
    return _data_at(path.parent)


@pytest.mark.slow
def test_sharded_data_build_merges_into_the_unsharded_dataset(tmp_path, run_cli, sweeps_cache):
    tiny = ("harness.data", "+env=s2d", "scale=tiny", "progress=false")
    # the unsharded build: the session's (built once, by whichever test needs it first)
    unsharded = printed_folder(run_cli(*tiny, f"cache_dir={sweeps_cache}", f"hydra.run.dir={tmp_path / 'run'}").stdout)
    sharded = (*tiny, f"cache_dir={tmp_path / 'sharded'}", "shards=3")
    # three shards for two workspaces: shard 2 has none, and must still finish
    run_cli(*sharded, "hydra/launcher=local", f"hydra.sweep.dir={tmp_path / 'sweep'}", "-m", "shard=0,1,2")
    assert not list((tmp_path / "sharded").glob("data/*/data.npz"))  # shards never build the artifact
    assert {p.name for p in (tmp_path / "sweep" / "s2d" / "data").iterdir()} == {"shard0", "shard1", "shard2"}
    run_cli(*sharded, "merge=true", f"hydra.run.dir={tmp_path / 'merge'}")
    assert _data(tmp_path / "sharded") == _data_at(unsharded)
    assert not list((tmp_path / "sharded").glob("data/.*.partial"))  # the merge cleans up


@pytest.mark.slow
def test_merge_names_the_unfinished_shards(tmp_path, run_cli):
    args = ("harness.data", "+env=s2d", "scale=tiny", "progress=false", f"cache_dir={tmp_path}", "shards=3")
    run_cli(*args, "shard=1", f"hydra.run.dir={tmp_path / 'r1'}")
    p = run_cli(*args, "merge=true", f"hydra.run.dir={tmp_path / 'r2'}", check=False)
    assert p.returncode == 1 and "Traceback" not in p.stderr
    (line,) = p.stderr.strip().splitlines()
    assert line.startswith("error: config key merge: 1 of 2 chunks") and "shard 0 of shards=3" in line


def _with(cfg, keys: dict):
    """cfg with the sharding keys set as a user would type them (any type)."""
    return OmegaConf.merge(cfg, OmegaConf.create(keys))


@pytest.mark.parametrize(
    "keys,name",
    [
        ({"shards": 0}, "shards"),
        ({"shards": "two"}, "shards"),
        ({"shards": True}, "shards"),
        ({"shards": 4, "shard": 4}, "shard"),
        ({"shards": 4, "shard": -1}, "shard"),
        ({"shards": 4, "shard": 1.5}, "shard"),
        ({"merge": "yes"}, "merge"),
        ({"shards": 4, "shard": 1, "merge": True}, "merge"),
    ],
)
def test_bad_sharding_keys(keys, name, compose_config):
    with pytest.raises(UsageError, match=f"^config key {name}:"):
        settings_of(_with(compose_config(["+env=s2d", "scale=tiny"]), keys))


def test_good_sharding_keys(compose_config):
    for keys in ({}, {"shards": 100, "shard": 99}, {"shards": 100, "merge": True}):
        run = settings_of(_with(compose_config(["+env=s2d", "scale=tiny"]), keys))
        assert (run.shards, run.shard, run.merge) == (keys.get("shards", 1), keys.get("shard"), "merge" in keys)


def test_shards_partition_the_chunks():
    chunks = chunks_of(10, chunk_size=3)
    assert chunks == {0: range(0, 3), 1: range(3, 6), 2: range(6, 9), 3: range(9, 10)}
    shards = [chunks_of(10, 3, (i, 3)) for i in range(3)]
    assert sorted(k for s in shards for k in s) == list(chunks) and shards[0] == {0: chunks[0], 3: chunks[3]}


def test_sharding_keys_leave_the_data_key_alone(settings):
    keys = [settings(["+env=s2d", "scale=tiny", *o]).data.key_config() for o in ([], ["shards=9"])]
    assert keys[0] == keys[1]


@pytest.mark.parametrize(
    "overrides,name",
    [
        (["train.num_nodes=2"], "train.num_nodes"),
        (["train.devices=2", "train.strategy=ddp"], "train.strategy"),
        (["train.devices=[0,1]"], "train.strategy"),
    ],
)
def test_lightning_settings_that_would_hang(compose_config, overrides, name):
    with pytest.raises(UsageError, match=f"^config key {name}:"):
        lightning_params(compose_config(["+env=s2d", *overrides]))


def test_lightning_settings_from_config(compose_config):
    cfg = compose_config(["+env=s2d", "train.accelerator=gpu", "train.devices=4", "train.strategy=ddp_spawn"])
    assert lightning_params(cfg) == {"accelerator": "gpu", "devices": 4, "strategy": "ddp_spawn", "num_nodes": 1}


def test_launcher_configs_compose(compose_config):
    for launcher, cpus, gpus in (("slurm", 32, 0), ("slurm_gpu", 8, 4), ("local", 32, 0)):
        cfg = compose_config(
            ["+env=s2d", f"hydra/launcher={launcher}", "jobs=32", "train.devices=4"], return_hydra_config=True
        )
        params = OmegaConf.to_container(cfg.hydra.launcher, resolve=True)
        assert (params["cpus_per_task"], params["gpus_per_node"]) == (cpus, gpus)
        assert params["_target_"].endswith("SlurmLauncher" if "slurm" in launcher else "LocalLauncher")


@pytest.mark.slow
def test_datasets_of_other_sizes_share_their_chunks(tmp_path, run_cli):
    """A learning curve's small dataset is the first chunks of a larger one, and a larger one
    begins with a smaller one's: built from a cache holding the other, a dataset plans only
    the chunks it does not share, and equals the same dataset built from nothing."""
    base = ("harness.data", "+env=s2d", "scale=tiny", "progress=false", "env.expert.chunk=2", "scale.train.paths=3")

    def build(n, cache, run):
        return run_cli(*base, f"scale.train.workspaces={n}", f"cache_dir={tmp_path / cache}", f"hydra.run.dir={run}")

    build(4, "big", tmp_path / "r1")
    assert "1 chunks from the dataset" in build(3, "big", tmp_path / "r2").stderr  # its last is shorter
    build(3, "new", tmp_path / "r3")
    small = next(f for f in (tmp_path / "big").glob("data/*/manifest.json") if '"train_workspaces": 3' in f.read_text())
    assert _data(tmp_path / "new") == _data_at(small.parent)
    assert "1 chunks from the dataset" in build(5, "new", tmp_path / "r4").stderr  # chunk 0 of the 3
    build(5, "five", tmp_path / "r5")
    grown = next(f for f in (tmp_path / "new").glob("data/*/manifest.json") if '"train_workspaces": 5' in f.read_text())
    assert _data(tmp_path / "five") == _data_at(grown.parent)


def _data_at(folder):
    key = json.loads((folder / "manifest.json").read_text())["key"]
    with np.load(folder / "data.npz") as z:
        return key, {k: (z[k].dtype, z[k].shape, z[k].tobytes()) for k in z.files}


SPAWN_UNDER_LOKY = """
import multiprocessing as mp, os
from joblib.externals.loky.backend import context  # registers 'loky', as joblib's workers run
mp.set_start_method("loky", force=True)
from harness.log.process import spawning
if __name__ == "__main__":
    with spawning() as ctx:
        p = ctx.Process(target=os.getpid)
        p.start()
    p.join()
    print(p.exitcode, mp.get_start_method())
    q = mp.get_context("spawn").Process(target=os.getpid)  # without spawning(): the child fails
    q.start()
    q.join()
    print(q.exitcode)
"""


@pytest.mark.slow
def test_a_child_spawned_in_a_loky_worker_starts_and_the_worker_keeps_its_method(tmp_path):
    """spawning() changes the default start method only while its block starts children."""
    import subprocess
    import sys

    script = tmp_path / "spawn.py"
    script.write_text(SPAWN_UNDER_LOKY)
    out = subprocess.run([sys.executable, str(script)], capture_output=True, text=True, timeout=120).stdout.split()
    assert out == ["0", "loky", "1"]


@pytest.mark.slow
def test_a_training_sweep_on_the_local_launcher(tmp_path, run_cli, sweeps_cache):
    """docs/cluster.md's `harness.train scale=tiny hydra/launcher=local -m +env=s2d,c2d`: one
    job per env through submitit's local executor (the networks from the suite's shared cache
    when a sweep trained them first)."""
    run_cli(
        "harness.train", "scale=tiny", "hydra/launcher=local", "-m", "+env=s2d,c2d", "progress=false",
        f"cache_dir={sweeps_cache}", f"hydra.sweep.dir={tmp_path}",
    )  # fmt: skip
    logs = "".join(f.read_text() for f in tmp_path.rglob("*_log.out"))  # each job's stdout (submitit)
    folders = set(re.findall(r"^(?:trained|cached): (.+)$", logs, re.M))
    assert len(folders) == 2 and all(Path(f, "pnet.ckpt").exists() for f in folders)
