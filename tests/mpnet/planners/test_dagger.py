"""The DAgger recipe option: which visited states are labelled, toward which end; its settings
in the models key; a round built and trained end to end at tiny scale."""

from __future__ import annotations

import json

import numpy as np
import pytest
from mcap.reader import make_reader

from harness.core.cli import UsageError
from mpnet.envs import get_spec
from mpnet.envs.scenes.generators import make_workspace
from mpnet.planners.base import Problem
from mpnet.planners.dagger import visited
from tests.harness._cli import printed_folder


class _Rollout:
    """A planner whose first run proposed `states` (stage 0) then replanned once (stage 1)."""

    def __init__(self, states):
        self.states = states

    def solve(self, problem, budget_s):
        self.trace = [(0, None, np.asarray(x, float)) for x in self.states]
        self.trace.append((1, None, np.asarray(self.states[0], float)))


def test_visited_states_are_the_first_runs_valid_proposals_toward_their_trees_end():
    spec = get_spec("s2d")
    ws = make_workspace(spec, 0, "train")
    checker = spec.make_checker(ws)
    rng = np.random.default_rng(0)
    free = [s for s in (spec.space.sample(rng) for _ in range(200)) if checker.is_valid(s.tolist())][:4]
    blocked = next(s for s in (spec.space.sample(rng) for _ in range(2000)) if not checker.is_valid(s.tolist()))
    start, goal = free[0], free[1]
    proposals = [free[2], blocked, free[3], [np.nan, 0.0]]  # start's tree, goal's, start's, goal's
    problem = Problem(spec, ws, checker, start, goal)
    got = visited(_Rollout(proposals), problem, 10, 1.0, rng)
    assert [x.tolist() for x, _ in got] == [free[2].tolist(), free[3].tolist()]  # valid, finite, stage 0 only
    assert all(np.array_equal(end, goal) for _, end in got)  # both grew from the start's tree
    got = visited(_Rollout([free[2], free[3]]), problem, 10, 1.0, rng)
    assert np.array_equal(got[1][1], start)  # the second proposal grew from the goal's tree
    assert len(visited(_Rollout(free * 3), problem, 2, 1.0, rng)) == 2  # at most `states`


def test_dagger_settings_are_in_the_models_key_and_need_rounds(settings):
    from harness.artifacts.ensure import models_key_config
    from harness.log.facts import planner_facts

    plain = models_key_config(settings(["+env=s2d", "+planner=mpnet_nr"]))
    one = models_key_config(settings(["+env=s2d", "+planner=mpnet_nr", "+planner.networks.dagger_rounds=1"]))
    assert one == {**plain, "dagger_rounds": 1, "dagger_queries": 5, "dagger_states": 3, "dagger_budget_s": 2.0}
    with pytest.raises(UsageError, match="dagger_rounds"):
        settings(["+env=s2d", "+planner=mpnet_nr", "+planner.networks.dagger_states=2"])
    facts = planner_facts({"hybrid": False, "replanning": "original", "networks": {"dagger_rounds": 2}})
    assert facts["variant"] == "dagger2"


@pytest.mark.slow  # trains twice and plans expert paths in spawned processes
def test_a_dagger_round_trains_on_the_expert_paths_and_the_labelled_rollouts(tmp_path, run_cli, sweeps_cache):
    """docs/arm.md's DAgger command at tiny scale: round 1 rolls out the round-0 networks (the
    same recipe without DAgger), the expert labels what they visited, round 1 trains on more
    pairs, and MPNet plans with round 1's networks."""
    run_cli(
        "harness", "+env=panda_mbm", "+planner=mpnet_nr", "+planner.networks.bounded=true",
        "+planner.networks.dagger_rounds=1", "scale=tiny", "progress=false", "splits=[unseen]", "budget_s=1",
        f"cache_dir={sweeps_cache}", f"hydra.run.dir={tmp_path / 'r'}",
    )  # fmt: skip
    (dagger,) = [json.loads(p.read_text()) for p in (sweeps_cache / "dagger").glob("*/manifest.json")]
    models = {
        m["key"]: m for m in (json.loads(p.read_text()) for p in (sweeps_cache / "models").glob("*/manifest.json"))
    }
    round0 = models[dagger["config"]["models"]]
    (round1,) = [m for m in models.values() if m["config"].get("dagger_rounds") == 1]
    assert dagger["paths"] > 0 and dagger["config"]["round"] == 1
    assert round0["config"] == {k: v for k, v in round1["config"].items() if not k.startswith("dagger_")}
    assert round0["config"]["bounded"] is True
    assert round1["fit"]["pnet"]["pairs"] > round0["fit"]["pnet"]["pairs"]
    with open(tmp_path / "r" / "trials.mcap", "rb") as f:
        msgs = [(c.topic, json.loads(m.data)) for _, c, m in make_reader(f).iter_messages()]
    assert next(m for t, m in msgs if t == "/run")["planner"] == "mpnet_nr"
    assert len([m for t, m in msgs if t == "/query"]) == 4


@pytest.mark.slow  # trains at tiny scale in a subprocess
def test_bounded_networks_train_on_symmetric_bounds(tmp_path, run_cli, sweeps_cache):
    """s2d's bounds are centred on 0: the centred normaliser keeps no offset, and a bounded
    Pnet's module once refused it ("needs the centred normaliser"). (The session's cache: its
    data and Enet are the other tiny s2d networks'.)"""
    out = run_cli(
        "harness.train", "+env=s2d", "scale=tiny", "+planner=mpnet_nr", "+planner.networks.bounded=true",
        "progress=false", f"cache_dir={sweeps_cache}", f"hydra.run.dir={tmp_path / 'r'}",
    ).stdout  # fmt: skip
    manifest = json.loads((printed_folder(out) / "manifest.json").read_text())
    assert manifest["config"]["bounded"] is True
