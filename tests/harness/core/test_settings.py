"""harness.core.settings: the composed config parsed once into frozen settings, and the cache
keys derived from them exactly as before they existed (tests/data/cache_keys.json: every env x
scale tiny, quick and paper x {mpnet_nr, mpnet_nr_dense}, computed by revision be8f9e8, which read the DictConfig;
recomputed since: when a workspace's cloud became a function of its geometry alone (issue 42): every
data key, and so every models key, moved then, and no test set's; when panda_mbm's expert began to stop
on an iteration count (env.expert.run_iterations, issue 42): panda_mbm's data and models keys only; and
when panda_mbm's recipe took a collision loss (networks.collision_loss, issue 42), and when that loss
was measured along each step (networks.collision_motion): its models keys only; and when the sphere
checker became VERSION 3 (issue 64): every arm7 and panda_mbm key; when the tiny scale took a 0.2 s
reference BIT* run (scale.reference_bit_star_s): the tiny test set keys of the envs with planned references)."""

from __future__ import annotations

import copy
import dataclasses
import json

import pytest
from omegaconf import open_dict

from harness.artifacts import ensure as artifacts
from harness.core.cli import UsageError
from harness.core.settings import settings_of
from mpnet.data.store import content_key


@pytest.mark.slow  # over ~1.3 s: out of the fast loop
def test_cache_keys_are_the_ones_the_config_gave(repo):
    from hydra import compose, initialize_config_dir

    want = json.loads((repo / "tests" / "data" / "cache_keys.json").read_text())
    with initialize_config_dir(str(repo / "conf"), version_base="1.3"):  # once; each env x scale composed once
        dense = compose("config", ["+env=s2d", "+planner=mpnet_nr_dense"]).planner
        plain = {
            (e, s): compose("config", [f"+env={e}", f"scale={s}", "+planner=mpnet_nr"])
            for e, s in {tuple(n.split("/")[:2]) for n in want}
        }
    got = {}
    for name in want:
        env, scale, planner = name.split("/")
        cfg = copy.deepcopy(plain[env, scale])
        if planner == "mpnet_nr_dense":  # its section in place of mpnet_nr's: the same config (test_configs)
            with open_dict(cfg):
                cfg.planner = copy.deepcopy(dense)
        run = settings_of(cfg)
        got[name] = {
            "data": content_key({"kind": "data", **run.data.key_config()}),
            "testset": content_key({"kind": "testset", **artifacts.testset_key_config(run)}),
            "models": content_key({"kind": "models", **artifacts.models_key_config(run)}),
        }
    assert got == want


def test_settings_are_frozen_and_typed(settings):
    run = settings(["+env=arm7", "+planner=bit_star_to_nr_x1.1", "seed=3", "splits=[unseen]"])
    with pytest.raises(dataclasses.FrozenInstanceError):
        run.seed = 4
    with pytest.raises(dataclasses.FrozenInstanceError):
        run.env.expert.iterations = 1
    assert (run.seed, run.splits, run.planner.name, run.planner.stop) == (3, ("unseen",), "bit_star_to_nr_x1.1", "cost")
    assert run.planner.cost_target.name == "mpnet_nr" and run.planner.cost_target.key == "planner.cost_target"
    assert run.env.spec.motion_step == run.env.geometry["motion_step"]
    assert run.facts["planner"]["target"] == "nr" and run.results["seed"] == 3 and "cache_dir" not in run.results


def test_data_and_training_need_no_planner(settings):
    run = settings(["+env=s2d", "scale=tiny"])
    assert run.planner is None and run.data.train_workspaces > 0


@pytest.mark.parametrize(
    "override,key",
    [("env.expert.chunk=0", "env.expert.chunk"), ("train.devices=2", "train.strategy"), ("shard=3", "shard")],
)
def test_each_part_is_checked_when_parsed(override, key, settings):
    with pytest.raises(UsageError, match=f"config key {key}"):
        settings(["+env=s2d", "scale=tiny", override])
