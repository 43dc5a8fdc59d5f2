"""The compiled planner (mpnet.planners.compiled.planner) against the numpy planner it compiles: on every
query of the shipped quick test set (400 per env: s2d, c2d, c3d, rigid; the arms' 100 and 138
reversed and with other seeds: 400 and 552; the variants every 4th of them), the same status, path, check counts, Pnet
calls, partial trees and Pnet trace, with the shipped networks and each query's seed (HR's
classical planner runs in time slices: where it ran, the path and checks after it depend on the
machine's load, so there the status, the Pnet trace and that it ran are compared)."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from mpnet.data.shipped import SHIPPED as TESTSETS
from mpnet.envs.specs import get_spec
from mpnet.models.pretrained import SHIPPED, write_checkpoint
from mpnet.planners.base import Problem
from mpnet.planners.mpnet import MPNetSettings, from_checkpoint
from mpnet.problems import load_problems


def _queries(spec):
    """(workspace, start, goal, seed): the shipped quick set's queries with their index as the
    seed; the arms' sets (100, 138) also reversed, and all of them again with other seeds
    (other dropout masks, so other decisions): >= 400 runs per env."""
    out = []
    for split in ("seen", "unseen"):
        ts = load_problems(TESTSETS / f"{spec.name}-quick" / f"{split}.json", spec)
        by_id = {w.id: w for w in ts.workspaces}
        out += [(by_id[q.workspace_id], q.start, q.goal) for q in ts.queries]
    if len(out) < 400:
        out += [(ws, goal, start) for ws, start, goal in out]
        out += out
    return [(*q, i) for i, q in enumerate(out)]


def _run(planner, spec, queries):
    checkers, out = {}, []
    ws, start, goal, _ = queries[0]
    first = Problem(spec, ws, spec.make_checker(ws), start, goal, seed=0)
    first.checker.warm_up(start)  # kernels loaded before the first query's budget runs (as the bench does)
    if hasattr(planner, "warm_up"):
        planner.warm_up(first)
    for ws, start, goal, seed in queries:
        checker = checkers.setdefault(id(ws), spec.make_checker(ws))
        checker.reset_counts()
        r = planner.solve(Problem(spec, ws, checker, start, goal, seed=seed), 10.0)
        trace = [(s, a.tolist(), b.tolist()) for s, a, b in planner.trace]
        # HR's RRT* runs in time slices: where it ran, its path and checks depend on the machine's load
        fallback = r.stats.get("fallback_calls", 0) > 0
        path, counts, partial = (None, None, None) if fallback else (r.path, checker.counts(), r.partial)
        out.append((r.status, path, counts, r.stats["pnet_calls"], partial, trace, fallback))
    return out


SLOW = pytest.mark.slow


@pytest.mark.parametrize(
    "env,name,settings",
    [("s2d", "mpnet_nr", {}), pytest.param("s2d", "mpnet_hr", {"hybrid": True}, marks=SLOW),
     pytest.param("c2d", "mpnet_nr", {}, marks=SLOW),
     pytest.param("c3d", "mpnet_nr_forgiving", {"replanning": "forgiving"}, marks=SLOW),
     pytest.param("rigid", "mpnet_nr", {}, marks=SLOW), pytest.param("rigid", "mpnet_hr", {"hybrid": True}, marks=SLOW),
     pytest.param("arm7", "mpnet_nr", {}, marks=SLOW), pytest.param("panda_mbm", "mpnet_nr", {}, marks=SLOW),
     pytest.param("s2d", "mpnet_nr_random", {"proposal": "random"}, marks=SLOW),
     pytest.param("s2d", "mpnet_nr_clip", {"clip": True}, marks=SLOW),
     pytest.param("c2d", "mpnet_nr_straight", {"proposal": "straight", "replanning": "forgiving"}, marks=SLOW),
     pytest.param("rigid", "mpnet_nr_straight", {"proposal": "straight", "replanning": "forgiving"}, marks=SLOW),
     pytest.param("rigid", "mpnet_nr_random_any", {"proposal": "random_any", "replanning": "forgiving"}, marks=SLOW),
     pytest.param("rigid", "mpnet_nr_clip", {"clip": True, "dropout": False}, marks=SLOW),
     pytest.param("c3d", "mpnet_nr_zeros", {"encoding": "zeros"}, marks=SLOW),
     pytest.param("arm7", "mpnet_nr_random", {"proposal": "random"}, marks=SLOW),
     pytest.param("panda_mbm", "mpnet_nr_clip", {"clip": True}, marks=SLOW)],
)  # fmt: skip
def test_the_compiled_planner_decides_as_the_numpy_planner(env, name, settings, tmp_path):
    spec = get_spec(env)
    write_checkpoint(SHIPPED / f"{env}-quick", tmp_path / "pnet.ckpt")
    cloud = lambda ws: spec.cloud(ws, 200, 0)  # noqa: E731 - the env configs' points_per_block and data_seed
    queries = _queries(spec)
    assert len(queries) >= 400
    if name not in ("mpnet_nr", "mpnet_hr"):  # a variant's own pieces: every 4th query (>= 100)
        queries = queries[::4]
    numpy_planner = from_checkpoint(tmp_path, spec, 0, cloud, name=name, **settings)
    compiled = from_checkpoint(tmp_path, spec, 0, cloud, name=name, compiled=True, **settings)
    want, got = _run(numpy_planner, spec, queries), _run(compiled, spec, queries)
    for i, (w, g) in enumerate(zip(want, got)):
        assert w[:4] == g[:4] and w[6] == g[6], i  # status, path, counts, Pnet calls; the same queries fall back
        assert (w[4] is None) == (g[4] is None) and (w[4] or {}) == (g[4] or {}), i
        assert w[5] == g[5], i
    if settings.get("proposal") != "straight":  # straight steps meet the obstacle between the ends: no success
        assert sum(w[0] == "exact" for w in want) > 0.2 * len(want)  # successes compared too (panda_mbm: 33 of 138)


def test_what_the_compiled_planner_does_not_run_is_refused():
    with pytest.raises(ValueError, match="config key planner.compiled: the compiled planner runs continuous"):
        MPNetSettings(name="mpnet_nr_tro", steer_steps=[2.0, 0.1], compiled=True)
    with pytest.raises(ValueError, match="config key planner.compiled"):
        MPNetSettings(name="mpnet_nr", compiled="yes")
    settings = MPNetSettings(name="mpnet_nr", compiled=True)
    settings.check_env(get_spec("rigid"), "native")
    with pytest.raises(ValueError, match="env rigid.s fcl checker has no compiled kernels .*planner.compiled=false"):
        settings.check_env(get_spec("rigid"), "fcl")
    with pytest.raises(ValueError, match="env arm7's pybullet checker has no compiled kernels"):
        settings.build(None, get_spec("arm7"), 0, lambda ws: np.zeros((1, 3)), "pybullet")


def test_the_warm_up_calls_every_kernel_whatever_the_clock_says(tmp_path, monkeypatch):
    """A cold cache compiles the cloud and Enet for longer than any short solve's budget: the
    warm-up must not be a solve, or the loop's kernels compile inside the first timed query."""
    from mpnet.planners.compiled import planner as C

    spec = get_spec("s2d")
    write_checkpoint(SHIPPED / "s2d-quick", tmp_path / "pnet.ckpt")
    planner = from_checkpoint(tmp_path, spec, 0, lambda ws: spec.cloud(ws, 200, 0), name="mpnet_nr", compiled=True)
    ws, start, goal, _ = _queries(spec)[0]
    called = []
    for name in ("neural_planner", "contract", "is_feasible", "is_valid", "motion_valid"):
        kernel = getattr(C.K, name)
        monkeypatch.setattr(C.K, name, lambda *a, _k=kernel, _n=name: called.append(_n) or _k(*a))
    clock = itertools.count(0.0, 10.0)
    monkeypatch.setattr(C.time, "perf_counter", lambda: next(clock))  # 10 s pass between any two readings
    planner.warm_up(Problem(spec, ws, spec.make_checker(ws), start, goal, seed=0))
    assert set(called) == {"neural_planner", "contract", "is_feasible", "is_valid", "motion_valid"}
