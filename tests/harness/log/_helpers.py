"""The trial log's tests' records and readers: a run, a workspace and a query as the harness
logs them (make_run, make_ws, make_rec), a few logged (log_some), and the log read back raw
(read_all, by_topic, read_csv). The kill scripts import them in their own interpreters."""

from __future__ import annotations

import csv
import json

import numpy as np
from mcap.reader import make_reader

from harness.log import TrialLog
from mpnet.envs.specs import SPECS
from mpnet.envs.workspace import Workspace

TOPIC_SCHEMAS = {
    "/run": "mpnet_bench.Run",
    "/workspace": "mpnet_bench.Workspace",
    "/query": "mpnet_bench.Query",
    "/scene": "foxglove.SceneUpdate",
}


def is_rect(spec):
    return spec.robot_json()["kind"] == "rectangle"


def make_run(env="s2d", seed=0, **kw):
    run = dict(
        env=env,
        planner="mpnet_nr",
        seed=seed,
        split="seen+unseen",
        config="env: s2d\nseed: 0\n",
        git_rev="0123abc",
        versions={"numpy": np.__version__, "mcap": "1.6.0"},
        host="testhost",
        started_at="2026-11-21T12:00:00+00:00",
    )
    run.update(kw)
    return run


def make_ws(env, wid="ws0", split="seen"):
    """Two obstacles far from the corridor the test paths use (y = -15 and x = 15 lines)."""
    wd = SPECS[env].workspace_dim
    centers = np.array([[10.0, 10.0, 0.0][:wd], [-10.0, 10.0, 0.0][:wd]])
    sizes = np.array([[5.0, 5.0, 10.0][:wd], [5.0, 5.0, 5.0][:wd]])
    return Workspace(wid, split, centers, sizes)


def make_rec(env, qid, wid="ws0", split="seen", success=True, n=4, **extra):
    """A query record as a planner hands it over: numpy arrays and numpy scalars included."""
    spec = SPECS[env]
    d = spec.state_dim
    start = np.full(d, -15.0)
    goal = np.array([15.0, -15.0] + [0.0] * (d - 2))
    if is_rect(spec):
        start[2] = 0.0
    path = np.linspace(start, goal, n) if success else []
    rec = dict(
        query_id=qid,
        workspace_id=wid,
        split=split,
        start=start,
        goal=goal,
        success=np.bool_(success),
        failure=None if success else "timeout",
        path=path,
        time_s=np.float64(0.0042),
        cpu_s=0.0041,
        path_cost=float(np.linalg.norm(goal[:2] - start[:2])) if success else float("inf"),
        collision_checks=np.int64(321),
        state_checks=np.int32(200),
        motion_checks=121,
        pnet_calls=7,
        replans=0,
        fallback_used=False,
        planner_status="exact",
    )
    rec.update(extra)
    return rec


def read_all(path):
    """(schemas by topic, [(topic, message dict)]) of a finalised file, via the indexed reader."""
    with open(path, "rb") as f:
        reader = make_reader(f)
        out = [(c.topic, s, json.loads(m.data)) for s, c, m in reader.iter_messages()]
    schemas = {}
    for topic, s, _ in out:
        schemas[topic] = s
    return schemas, [(t, d) for t, _, d in out]


def read_csv(path):
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def by_topic(msgs, topic):
    return [d for t, d in msgs if t == topic]


def log_some(run_dir, env="s2d", n=3, rerun=False, **kw):
    with TrialLog(run_dir, make_run(env), SPECS[env], rerun=rerun, **kw) as log:
        log.add_workspace(make_ws(env))
        for i in range(n):
            log.add_query(make_rec(env, f"ws0-{i}", success=i % 3 != 2))
    return run_dir / "trials.mcap"
