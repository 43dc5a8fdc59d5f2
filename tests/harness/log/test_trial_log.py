"""The per-run trial log (docs/reports.md, docs/reliability.md): MCAP topics and schemas, the
judge, the structure an independent checker relies on, records refused, queries.csv, and the
helpers (plain values, cheap logging, best cost over time, the sweep summary, run segments)."""

from __future__ import annotations

import json
import math
import time
from pathlib import Path

import jsonschema
import numpy as np
import pytest
from mcap.reader import make_reader

from harness.log import CSV_FIXED, QUERY_FIELDS, TrialLog, judge, plain, run_segments
from mpnet.envs.specs import SPECS
from mpnet.envs.workspace import Workspace
from tests.harness.log._helpers import (
    TOPIC_SCHEMAS,
    by_topic,
    log_some,
    make_rec,
    make_run,
    make_ws,
    read_all,
    read_csv,
)

# ----------------------------------------------------------------------------- MCAP


def test_round_trip_all_topics_and_schemas(tmp_path):
    env = "s2d"
    spec = SPECS[env]
    run = make_run(env)
    recs = [
        make_rec(env, "ws0-0"),
        make_rec(env, "ws0-1", success=False),
        make_rec(env, "ws1-0", wid="ws1", split="unseen", extra_stat=np.float32(0.5)),
    ]
    with TrialLog(tmp_path, run, spec, rerun=False) as log:
        log.add_workspace(make_ws(env))
        log.add_workspace(make_ws(env))  # same key: a no-op
        log.add_workspace(make_ws(env, "ws1", "unseen"))
        for r in recs:
            log.add_query(r)
    assert {p.name for p in tmp_path.iterdir()} == {"trials.mcap", "queries.csv"}
    schemas, msgs = read_all(tmp_path / "trials.mcap")

    # Topics, schema names and encodings.
    assert set(schemas) == set(TOPIC_SCHEMAS)
    for topic, s in schemas.items():
        assert s.name == TOPIC_SCHEMAS[topic]
        assert s.encoding == "jsonschema"
    with open(tmp_path / "trials.mcap", "rb") as f:
        summary = make_reader(f).get_summary()
    assert {c.topic: c.message_encoding for c in summary.channels.values()} == {t: "json" for t in TOPIC_SCHEMAS}

    # Every message validates against the schema stored with its channel.
    for topic, d in msgs:
        jsonschema.validate(d, json.loads(schemas[topic].data))
    # Our own schemas are real JSON Schemas that list the required fields.
    qs = json.loads(schemas["/query"].data)
    jsonschema.Draft7Validator.check_schema(qs)
    assert set(QUERY_FIELDS) <= set(qs["required"])
    rs = json.loads(schemas["/run"].data)
    assert {"env", "planner", "seed", "split", "config", "git_rev", "versions", "host", "started_at"} <= set(
        rs["required"]
    )
    ws_s = json.loads(schemas["/workspace"].data)
    assert {"workspace_id", "split", "bounds", "obstacles", "robot"} <= set(ws_s["required"])
    with pytest.raises(jsonschema.ValidationError):
        jsonschema.validate({k: v for k, v in plain(recs[0]).items() if k != "time_s"}, qs)

    # /run: one message with every key given.
    (r,) = by_topic(msgs, "/run")
    for k, v in run.items():
        assert r[k] == v

    # /workspace: once per (split, id), with the env's bounds and robot.
    wss = by_topic(msgs, "/workspace")
    assert [(w["split"], w["workspace_id"]) for w in wss] == [("seen", "ws0"), ("unseen", "ws1")]
    assert wss[0]["bounds"] == spec.bounds_json()
    assert wss[0]["robot"] == spec.robot_json()
    assert wss[0]["obstacles"] == make_ws(env).obstacles_json()

    # /query: every key given, numpy values as plain JSON, inf as null.
    qs_msgs = by_topic(msgs, "/query")
    assert [q["query_id"] for q in qs_msgs] == ["ws0-0", "ws0-1", "ws1-0"]
    for q, rec in zip(qs_msgs, recs):
        assert set(q) == set(rec)
        assert q == plain(rec)
    assert qs_msgs[0]["path"] == np.linspace(recs[0]["start"], recs[0]["goal"], 4).tolist()
    assert qs_msgs[0]["collision_checks"] == 321 and qs_msgs[0]["success"] is True
    assert qs_msgs[1]["path_cost"] is None and qs_msgs[1]["failure"] == "timeout"
    assert qs_msgs[2]["extra_stat"] == 0.5

    # /scene: one per workspace (drawn with its first query) and one per query.
    assert len(by_topic(msgs, "/scene")) == 2 + 3


def test_log_times_are_ns_and_increasing(tmp_path):
    t0 = time.time_ns()
    path = log_some(tmp_path, n=5)
    t1 = time.time_ns()
    with open(path, "rb") as f:
        msgs = [(c.topic, m) for _, c, m in make_reader(f).iter_messages(log_time_order=False)]
    times = [m.log_time for _, m in msgs]
    pub = [m.publish_time for _, m in msgs]
    assert times == sorted(times)  # a query's /scene shares its /query's time
    q_times = [m.log_time for t, m in msgs if t == "/query"]
    assert len(set(q_times)) == len(q_times) == 5
    assert all(t0 <= t <= t1 + 10**6 for t in times)
    assert pub == times


# --------------------------------------------------------------------------- judge


def planner_rec(path, start, goal, failure=None):
    """A record as the bench hands it to the log process: no `success`, the planner's `failure`."""
    return {
        "query_id": "q",
        "workspace_id": "ws0",
        "split": "seen",
        "start": start,
        "goal": goal,
        "failure": failure,
        "path": path,
        "time_s": 0.01,
        "cpu_s": 0.01,
        "collision_checks": 5,
        "planner_status": "exact" if failure is None else failure,
    }


def test_judge_decides_success():
    spec, ws = SPECS["s2d"], make_ws("s2d")  # an obstacle fills [7.5, 12.5] x [7.5, 12.5]
    through = judge(spec, ws, planner_rec([[10.0, 0.0], [10.0, 20.0]], [10.0, 0.0], [10.0, 20.0]), 0.01)
    assert through["success"] is False and through["failure"] == "recheck_collision"
    free = judge(spec, ws, planner_rec(np.array([[-15.0, -15.0], [15.0, -15.0]]), [-15.0, -15.0], [15.0, -15.0]), 0.01)
    assert free["success"] is True and free["failure"] is None and free["path_cost"] == pytest.approx(30.0)
    assert free["path"] == [[-15.0, -15.0], [15.0, -15.0]] and type(free["path"][0][0]) is float
    keys = list(free)
    assert keys.index("success") == keys.index("failure") - 1 and keys[-1] == "path_cost"
    failed = judge(spec, ws, planner_rec([], [-15.0, -15.0], [15.0, -15.0], failure="timeout"), 0.01)
    assert failed["success"] is False and failed["failure"] == "timeout" and failed["path_cost"] is None
    claimed = judge(spec, ws, {**planner_rec([], [-15.0, -15.0], [15.0, -15.0]), "success": True}, 0.01)
    assert claimed["success"] is False and claimed["failure"] == "recheck_no_path"  # a claim is not trusted


# ------------------------------------------------------ an independent checker's structure


def test_structure_independent_checker_relies_on(tmp_path):
    """What an independent checker of the log (one with its own geometry) reads, asserted
    directly: a finalised file whose /run names the env, a /workspace for each query's (split,
    workspace_id), unique query keys, and successful paths running from start to goal through
    free space."""
    for env in ("s2d", "rigid", "c3d"):
        d = tmp_path / env
        path = log_some(d, env, n=4)
        _, msgs = read_all(path)  # make_reader reads it: the file is finalised
        (run,) = by_topic(msgs, "/run")
        assert run["env"] == env and isinstance(run["env"], str)
        wss = {(w["split"], str(w["workspace_id"])): w for w in by_topic(msgs, "/workspace")}
        qs = by_topic(msgs, "/query")
        keys = [(q["split"], str(q["workspace_id"]), str(q["query_id"])) for q in qs]
        assert len(keys) == len(set(keys)) == 4
        for q in qs:
            ws = wss[(q["split"], str(q["workspace_id"]))]
            assert ws["bounds"] and all("center" in o and "size" in o for o in ws["obstacles"])
            if q["success"]:
                assert len(q["path"]) >= 2
                assert np.allclose(q["path"][0], q["start"]) and np.allclose(q["path"][-1], q["goal"])
                assert isinstance(q["time_s"], float)


# ----------------------------------------------------------------- validation, dups


def test_bad_records_are_refused(tmp_path):
    with TrialLog(tmp_path, make_run(), SPECS["s2d"], rerun=False) as log:
        log.add_workspace(make_ws("s2d"))
        log.add_query(make_rec("s2d", "ws0-0"))
        with pytest.raises(ValueError, match="already logged"):
            log.add_query(make_rec("s2d", "ws0-0"))
        rec = make_rec("s2d", "ws0-1")
        del rec["cpu_s"]
        with pytest.raises(ValueError, match="cpu_s"):
            log.add_query(rec)
        with pytest.raises(ValueError, match="add_workspace"):
            log.add_query(make_rec("s2d", "ws9-0", wid="ws9"))
        # the same query id in another split is another query
        log.add_workspace(make_ws("s2d", split="unseen"))
        log.add_query(make_rec("s2d", "ws0-0", split="unseen"))
    qs = by_topic(read_all(tmp_path / "trials.mcap")[1], "/query")
    assert [(q["split"], q["query_id"]) for q in qs] == [("seen", "ws0-0"), ("unseen", "ws0-0")]
    with pytest.raises(ValueError, match="host"):
        TrialLog(tmp_path / "x", {k: v for k, v in make_run().items() if k != "host"}, SPECS["s2d"])


def test_existing_log_needs_resume(tmp_path):
    log_some(tmp_path)
    with pytest.raises(FileExistsError):
        TrialLog(tmp_path, make_run(), SPECS["s2d"], rerun=False)


# -------------------------------------------------------------------------- CSV


def test_csv_columns_and_late_keys(tmp_path):
    with TrialLog(tmp_path, make_run(), SPECS["s2d"], rerun=False, extra_fields=["pnet_calls"]) as log:
        log.add_workspace(make_ws("s2d"))
        log.add_query(make_rec("s2d", "ws0-0"))
        log.add_query(make_rec("s2d", "ws0-1", success=False))
        header = (tmp_path / "queries.csv").read_text().splitlines()[0].split(",")
        assert header[: len(CSV_FIXED)] == list(CSV_FIXED)
        assert header[len(CSV_FIXED)] == "pnet_calls"
        assert "path" not in header and "start" not in header and "goal" not in header
        log.add_query(make_rec("s2d", "ws0-2", late_stat=3, note_list=[1, 2]))  # a new key later on
    rows = read_csv(tmp_path / "queries.csv")
    assert [r["query_id"] for r in rows] == ["ws0-0", "ws0-1", "ws0-2"]
    assert rows[0]["late_stat"] == "" and rows[2]["late_stat"] == "3"
    assert "note_list" not in rows[0]  # not a scalar: in the MCAP only
    assert rows[0]["success"] == "True" and rows[1]["failure"] == "timeout"
    assert rows[1]["path_cost"] == ""  # inf -> null -> empty
    assert float(rows[0]["time_s"]) == 0.0042 and rows[0]["collision_checks"] == "321"
    assert rows[0]["state_checks"] == "200" and rows[0]["planner_status"] == "exact"
    assert not list(tmp_path.glob("*.tmp"))


# ------------------------------------------------------------------------ helpers


def test_plain_converts_numpy_and_non_finite():
    v = plain(
        {
            "a": np.float32(1.5),
            "b": np.int64(3),
            "c": np.bool_(True),
            "d": np.arange(3),
            "e": (np.float64(2.0), float("nan")),
            "f": np.array([[1.0, np.inf]]),
            "g": None,
            "h": [np.int8(1)],
            "i": Path("x"),
        }
    )
    assert v == {
        "a": 1.5,
        "b": 3,
        "c": True,
        "d": [0, 1, 2],
        "e": [2.0, None],
        "f": [[1.0, None]],
        "g": None,
        "h": [1],
        "i": "x",
    }
    assert type(v["b"]) is int and type(v["c"]) is bool and type(v["a"]) is float
    json.dumps(v, allow_nan=False)


def test_logging_is_cheap(tmp_path):
    """docs/performance.md: a query's log costs well under a millisecond (loose bound for slow CI)."""
    spec = SPECS["s2d"]
    times = []
    with TrialLog(tmp_path, make_run(), spec, rerun=False) as log:
        log.add_workspace(make_ws("s2d"))
        for i in range(300):
            rec = make_rec("s2d", f"ws0-{i}", n=10)
            t0 = time.perf_counter()
            log.add_query(rec)
            times.append(time.perf_counter() - t0)
    assert float(np.median(times)) < 2e-3


def test_an_optimizing_planners_best_cost_over_time_is_logged(tmp_path):
    """BIT*'s `progress` goes from its Result into /query, valid under the schema, and back."""
    from harness.bench.loop import plan_query
    from harness.log.schemas import QUERY_SCHEMA
    from mpnet.planners import Problem
    from mpnet.planners.classical import OmplPlanner

    spec = SPECS["s2d"]
    wall = Workspace("ws0", "seen", [[0.0, 0.0]], [[4.0, 30.0]])
    optimum = 2 * math.hypot(8.0, 15.0) + 4.0
    problem = Problem(spec, wall, spec.make_checker(wall), np.array([-10.0, 0.0]), np.array([10.0, 0.0]), optimum, 1)
    rec = plan_query(OmplPlanner("bit_star", "bit_star", stop="cost", cost_factor=1.1), problem, 5.0)
    assert rec["failure"] is None and len(rec["progress"]) > 1
    assert rec["progress"][-1][0] <= rec["time_s"] and rec["progress"][-1][1] == rec["best_cost"]
    full = {
        **rec,
        "query_id": "ws0/0",
        "workspace_id": "ws0",
        "split": "seen",
        "start": [-10.0, 0.0],
        "goal": [10.0, 0.0],
        "success": True,
        "path_cost": rec["best_cost"],
    }
    jsonschema.validate(full, QUERY_SCHEMA)
    with TrialLog(tmp_path, make_run(), spec, rerun=False) as log:
        log.add_workspace(wall)
        log.add_query(full)
    (q,) = by_topic(read_all(tmp_path / "trials.mcap")[1], "/query")
    assert q["progress"] == rec["progress"]


def test_sweep_summary_tells_apart_runs_of_one_env_planner_and_seed(tmp_path):
    """A learning curve's sweep: runs that differ only in training-set size (their folders)
    are counted and shown apart, not as one run."""
    from harness.bench.sweep import format_sweep, sweep_rows
    from tests.harness.report._helpers import Q, write_log

    for size in ("w70", "w210"):
        write_log(tmp_path / "s2d" / size / "mpnet_nr" / "seed0", "s2d", "mpnet_nr", 0, [Q("seen", "0", 0, True, 0.01)])
    rows = sweep_rows(tmp_path)
    assert sorted(r["run"] for r in rows) == ["s2d/w210/mpnet_nr/seed0", "s2d/w70/mpnet_nr/seed0"]
    table = format_sweep(rows, tmp_path)
    assert table.startswith(f"sweep summary: 2 runs in {tmp_path}") and "s2d/w70/mpnet_nr/seed0" in table


@pytest.mark.parametrize("resumed", [None, "x", {}, {"runs": "x"}, {"runs": [3, {"git_rev": "a1"}]}])
def test_run_segments_reads_what_it_can_of_resumed_from(resumed):
    """A /run from an older or damaged log: the run's own session always, earlier ones only where readable."""
    run = make_run(git_rev="b2", resumed_from=resumed)
    segs = run_segments(run)
    assert segs[-1] == {"git_rev": "b2", "host": "testhost", "started_at": "2026-11-21T12:00:00+00:00"}
    earlier = [s["git_rev"] for s in segs[:-1]]
    assert earlier == (["a1"] if isinstance(resumed, dict) and isinstance(resumed.get("runs"), list) else [])
