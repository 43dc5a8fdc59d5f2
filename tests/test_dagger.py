"""The DAgger recipe option: which visited states are labelled, toward which end; its settings
in the models key; a round built and trained end to end at tiny scale."""

from __future__ import annotations

import json

import numpy as np
import pytest

from harness.cli import UsageError
from mpnet.envs import get_spec
from mpnet.envs.generators import make_workspace
from mpnet.planners.base import Problem
from mpnet.planners.dagger import visited


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
    from harness.artifacts import models_key_config
    from harness.log.facts import planner_facts

    plain = models_key_config(settings(["+env=s2d", "+planner=mpnet_nr"]))
    one = models_key_config(settings(["+env=s2d", "+planner=mpnet_nr", "+planner.networks.dagger_rounds=1"]))
    assert one == {**plain, "dagger_rounds": 1, "dagger_queries": 5, "dagger_states": 3, "dagger_budget_s": 2.0}
    with pytest.raises(UsageError, match="dagger_rounds"):
        settings(["+env=s2d", "+planner=mpnet_nr", "+planner.networks.dagger_states=2"])
    facts = planner_facts({"hybrid": False, "replanning": "original", "networks": {"dagger_rounds": 2}})
    assert facts["variant"] == "dagger2"


@pytest.mark.slow  # trains twice and plans expert paths in spawned processes
def test_a_dagger_round_trains_on_the_expert_paths_and_the_labelled_rollouts(tmp_path, run_cli):
    common = ["+env=s2d", "scale=tiny", "+planner=mpnet_nr", f"cache_dir={tmp_path / 'cache'}"]
    run_cli("harness.train", *common, "+planner.networks.dagger_rounds=1", f"hydra.run.dir={tmp_path / 'r'}")
    dagger = [json.loads(p.read_text()) for p in (tmp_path / "cache" / "dagger").glob("*/manifest.json")]
    models = {
        "dagger_rounds" in m["config"]: m
        for m in (json.loads(p.read_text()) for p in (tmp_path / "cache" / "models").glob("*/manifest.json"))
    }
    assert len(dagger) == 1 and dagger[0]["paths"] > 0 and dagger[0]["config"]["round"] == 1
    assert dagger[0]["config"]["models"] == models[False]["key"]  # round 1 rolled out the plain networks
    assert models[True]["fit"]["pnet"]["pairs"] > models[False]["fit"]["pnet"]["pairs"]
