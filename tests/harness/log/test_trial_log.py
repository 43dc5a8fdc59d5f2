"""The per-run trial log (docs/reports.md, docs/reliability.md): MCAP topics and schemas, Foxglove scenes,
crash safety, resume without duplicates, the Rerun recording and queries.csv."""

from __future__ import annotations

import csv
import json
import math
import shutil
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import jsonschema
import numpy as np
import pytest
from mcap.reader import make_reader
from mcap.records import Channel, Message
from mcap.stream_reader import StreamReader

from harness.log import (
    CSV_FIXED,
    QUERY_FIELDS,
    TrialLog,
    judge,
    painter_for,
    plain,
    read_log,
    rect_outlines,
    run_segments,
    scene_update_schema,
)
from mpnet.envs.specs import SPECS
from mpnet.envs.workspace import Workspace

REPO = Path(__file__).resolve().parents[1]  # the kill scripts run from outside pytest
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


@pytest.mark.parametrize("env", ["s2d", "c2d", "c3d", "rigid"])
@pytest.mark.slow  # over ~1.3 s: out of the fast loop
def test_scene_validates_against_foxglove_schema(tmp_path, env):
    spec = SPECS[env]
    with TrialLog(tmp_path, make_run(env), spec, rerun=False) as log:
        log.add_workspace(make_ws(env))
        log.add_workspace(make_ws(env, "ws1"))
        log.add_query(make_rec(env, "ws0-0", n=6))
        log.add_query(make_rec(env, "ws1-0", wid="ws1", success=False))
        log.add_query(make_rec(env, "ws0-1"))  # back to ws0: its obstacles are drawn again
    schemas, msgs = read_all(tmp_path / "trials.mcap")
    ours = scene_update_schema()
    stored = json.loads(schemas["/scene"].data)
    assert stored == scene_update_schema(inline=True)  # the $ref-free form goes into the file
    assert stored["title"] == ours["title"] == "foxglove.SceneUpdate"
    scenes = by_topic(msgs, "/scene")
    for s in scenes:
        jsonschema.validate(s, ours)
        jsonschema.validate(s, stored)
    ids = [e["id"] for s in scenes for e in s["entities"]]
    ws_scenes = [s for s in scenes if s["entities"][0]["id"].startswith("workspace/")]
    q_scenes = [s for s in scenes if s["entities"][0]["id"].startswith("query/")]
    assert len(q_scenes) == 3 and len(ws_scenes) == 3  # ws0, ws1, then ws0 again before ws0-1
    assert len(set(e for e in ids if e.startswith("query/"))) == 3
    for s in ws_scenes:
        e, legend = s["entities"]  # the workspace, and the legend drawn again after the clear
        assert legend["id"] == "legend" and legend["texts"]
        assert e["frame_id"] == "world" and len(e["cubes"]) == 2
        assert s["deletions"][0]["type"] == 1  # a new workspace clears the scene
        (cube,) = [c for c in e["cubes"] if c["pose"]["position"]["x"] == 10.0]  # make_ws's first box
        if spec.workspace_dim == 2:
            assert cube["size"]["z"] == pytest.approx(0.1)
            assert (cube["size"]["x"], cube["size"]["y"]) == (5.0, 5.0)
        else:
            assert (cube["size"]["x"], cube["size"]["y"], cube["size"]["z"]) == (5.0, 5.0, 10.0)
    ok_scene = q_scenes[0]["entities"][0]
    assert ok_scene["id"] == "query/seen/ws0-0"
    (strip,) = ok_scene["lines"]
    assert strip["type"] == 0  # LINE_STRIP
    assert len(strip["points"]) == 6
    assert strip["points"][0]["x"] == -15.0 and strip["points"][-1]["x"] == 15.0
    assert strip["color"]["g"] > strip["color"]["r"]  # green for success
    assert len(ok_scene["spheres"]) == 2
    assert ok_scene["timestamp"]["nsec"] < 10**9 and ok_scene["timestamp"]["sec"] > 1_600_000_000
    fail_scene = q_scenes[1]["entities"][0]
    assert fail_scene["lines"][0]["points"] == []
    assert fail_scene["lines"][0]["color"]["r"] > fail_scene["lines"][0]["color"]["g"]
    if is_rect(spec):
        assert len(ok_scene["cubes"]) == 6  # the body's footprint at every state
        assert ok_scene["cubes"][0]["size"]["x"] == 2.0 and ok_scene["cubes"][0]["size"]["y"] == 5.0
        assert len(fail_scene["cubes"]) == 2  # at start and goal
    else:
        assert ok_scene["cubes"] == []


def _foxglove_readable(schema: dict, path: str = "") -> None:
    """What Foxglove's JSON Schema reader (@foxglove/mcap-support parseJsonSchema) needs:
    objects list `properties`, each field is a `oneOf` of numeric consts or gives its own
    `type` (no `$ref`), arrays give their items' `type`."""
    assert schema.get("type") == "object" and isinstance(schema.get("properties"), dict), path
    for name, f in schema["properties"].items():
        where = f"{path}.{name}"
        assert "$ref" not in f, where
        if "oneOf" in f:
            assert all(isinstance(a.get("const"), int) and a.get("title") for a in f["oneOf"]), where
        elif f.get("type") == "object":
            _foxglove_readable(f, where)
        elif f.get("type") == "array":
            item = f["items"]
            assert "$ref" not in item, where
            assert item.get("type") in ("object", "number", "integer", "string", "boolean"), where
            if item["type"] == "object":
                _foxglove_readable(item, where + "[]")
        else:
            assert f.get("type") in ("number", "integer", "string", "boolean"), where


def test_scene_schema_is_ours_and_matches_foxglove_field_names():
    s = scene_update_schema()
    jsonschema.validators.validator_for(s).check_schema(s)
    assert s["title"] == "foxglove.SceneUpdate"
    assert "Generated by" not in s.get("$comment", "")
    defs = s["$defs"]
    # Field names as in Foxglove's message-schema docs.
    assert set(s["properties"]) == {"deletions", "entities"}
    assert set(defs["SceneEntity"]["properties"]) == {
        "timestamp",
        "frame_id",
        "id",
        "lifetime",
        "frame_locked",
        "metadata",
        "arrows",
        "cubes",
        "spheres",
        "cylinders",
        "lines",
        "triangles",
        "texts",
        "models",
    }
    assert set(defs["SceneEntityDeletion"]["properties"]) == {"timestamp", "type", "id"}
    assert set(defs["LinePrimitive"]["properties"]) == {
        "type",
        "pose",
        "thickness",
        "scale_invariant",
        "points",
        "color",
        "colors",
        "indices",
    }
    assert [o["title"] for o in defs["LinePrimitive"]["properties"]["type"]["oneOf"]] == [
        "LINE_STRIP",
        "LINE_LOOP",
        "LINE_LIST",
    ]
    assert set(defs["CubePrimitive"]["properties"]) == {"pose", "size", "color"}
    assert set(defs["Color"]["properties"]) == {"r", "g", "b", "a"}
    # The form written to MCAP has no $ref and is one Foxglove's reader can parse.
    inline = scene_update_schema(inline=True)
    assert '"$ref":' not in json.dumps(inline) and "$defs" not in inline
    jsonschema.validators.validator_for(inline).check_schema(inline)
    _foxglove_readable(inline)


def _broken(scene: dict, edit) -> dict:
    bad = json.loads(json.dumps(scene))
    edit(bad)
    return bad


@pytest.mark.slow  # over ~1.3 s: out of the fast loop
def test_malformed_scene_is_rejected(tmp_path):
    with TrialLog(tmp_path, make_run(), SPECS["s2d"], rerun=False) as log:
        log.add_workspace(make_ws("s2d"))
        log.add_query(make_rec("s2d", "ws0-0", n=4))
    schemas, msgs = read_all(tmp_path / "trials.mcap")
    ws_scene, q_scene = by_topic(msgs, "/scene")

    def cube(m):
        return m["entities"][0]["cubes"][0]

    def line(m):
        return m["entities"][0]["lines"][0]

    bad_scenes = {
        "cube without size": _broken(ws_scene, lambda m: cube(m).pop("size")),
        "colour component as a string": _broken(ws_scene, lambda m: cube(m)["color"].update(r="0.5")),
        "colour component above 1": _broken(ws_scene, lambda m: cube(m)["color"].update(a=2.0)),
        "unknown deletion type": _broken(ws_scene, lambda m: m["deletions"][0].update(type=3)),
        "unknown line type": _broken(q_scene, lambda m: line(m).update(type=4)),
        "point without z": _broken(q_scene, lambda m: line(m)["points"].append({"x": 1.0, "y": 2.0})),
        "lifetime not {sec, nsec}": _broken(q_scene, lambda m: m["entities"][0].update(lifetime=0)),
        "nsec out of range": _broken(q_scene, lambda m: m["entities"][0]["timestamp"].update(nsec=10**9)),
        "misspelt field": _broken(q_scene, lambda m: m["entities"][0].update(frameid="world")),
        "entity without frame_id": _broken(q_scene, lambda m: m["entities"][0].pop("frame_id")),
        "metadata value not a string": _broken(
            q_scene, lambda m: m["entities"][0]["metadata"].append({"key": "k", "value": 1})
        ),
        "no deletions": _broken(q_scene, lambda m: m.pop("deletions")),
        "bare entity": {"deletions": [], "entities": [{"id": "x"}]},
    }
    for schema in (scene_update_schema(), json.loads(schemas["/scene"].data)):
        jsonschema.validate(ws_scene, schema)
        jsonschema.validate(q_scene, schema)
        for why, bad in bad_scenes.items():
            with pytest.raises(jsonschema.ValidationError):
                jsonschema.validate(bad, schema)
                pytest.fail(f"accepted a scene with {why}")


def test_rect_outlines_match_design_geometry():
    # theta = 0: body x (width 2) along world x, body y (5) along world y
    o = rect_outlines(np.array([[1.0, 2.0, 0.0]]), (2.0, 5.0))[0]
    assert np.allclose(o[0], o[-1])
    assert np.allclose(o[:4].min(axis=0), [0.0, -0.5]) and np.allclose(o[:4].max(axis=0), [2.0, 4.5])
    o = rect_outlines(np.array([[0.0, 0.0, math.pi / 2]]), (2.0, 5.0))[0]
    assert np.allclose(o[:4].min(axis=0), [-2.5, -1.0]) and np.allclose(o[:4].max(axis=0), [2.5, 1.0])


# ------------------------------------------------------------------------ painters

WS2 = {
    "workspace_id": "w",
    "split": "seen",
    "bounds": [[-20.0, 20.0], [-10.0, 10.0], [-math.pi, math.pi]],
    "obstacles": [{"center": [1.0, 2.0], "size": [3.0, 4.0]}],
}
WS3 = {
    "workspace_id": "w",
    "split": "seen",
    "bounds": [[-20.0, 20.0]] * 3,
    "obstacles": [{"center": [1.0, 2.0, 3.0], "size": [3.0, 4.0, 5.0]}],
}


def scene_entity(painter, msg):
    from harness.log.foxglove import query_scene

    (e,) = json.loads(query_scene(painter, msg, 1_700_000_000_123_456_789))["entities"]
    jsonschema.validate({"deletions": [], "entities": [e]}, scene_update_schema())
    return e


def test_painter_registry():
    from harness.log.painters import PointPainter2D, PointPainter3D, RectanglePainter

    assert type(painter_for({"kind": "point"}, 2)) is PointPainter2D
    assert type(painter_for({"kind": "point"}, 3)) is PointPainter3D
    rect = painter_for({"kind": "rectangle", "size": [2, 5]}, 2)
    assert type(rect) is RectanglePainter and rect.size == (2.0, 5.0)
    for spec in SPECS.values():  # every env's robot has a painter
        assert painter_for(spec.robot_json(), spec.workspace_dim).workspace_dim == spec.workspace_dim
    with pytest.raises(ValueError, match="no painter"):
        painter_for({"kind": "rectangle", "size": [2, 5]}, 3)
    with pytest.raises(ValueError, match="no painter"):
        painter_for("panda", 3)
    with pytest.raises(ValueError, match="size"):
        painter_for({"kind": "rectangle"}, 2)


def test_rectangle_painter_known_answer():
    import rerun as rr

    p = painter_for({"kind": "rectangle", "size": [2, 5]}, 2)
    (o,) = p.footprints([[1.0, 2.0, 0.0]])
    assert o.tolist() == [[0.0, -0.5], [2.0, -0.5], [2.0, 4.5], [0.0, 4.5], [0.0, -0.5]]
    msg = {
        "query_id": "q",
        "split": "seen",
        "start": [1.0, 2.0, 0.0],
        "goal": [3.0, 4.0, math.pi],
        "path": [[1.0, 2.0, 0.0], [3.0, 4.0, math.pi]],
        "success": True,
        "failure": None,
    }
    e = scene_entity(p, msg)
    assert [c["pose"]["position"] for c in e["cubes"]] == [
        {"x": 1.0, "y": 2.0, "z": 0.01},
        {"x": 3.0, "y": 4.0, "z": 0.01},
    ]
    q0, q1 = (c["pose"]["orientation"] for c in e["cubes"])
    assert (q0["z"], q0["w"]) == (0.0, 1.0) and q1["z"] == 1.0 and abs(q1["w"]) < 1e-12  # yaw 0, yaw pi
    assert all(c["size"] == {"x": 2.0, "y": 5.0, "z": 0.02} for c in e["cubes"])
    assert [(q["x"], q["y"], q["z"]) for q in e["lines"][0]["points"]] == [(1.0, 2.0, 0.0), (3.0, 4.0, 0.0)]
    no_path = scene_entity(p, {**msg, "path": [], "success": False, "failure": "timeout"})
    assert len(no_path["cubes"]) == 2  # the body at start and goal
    assert [e for e, _ in p.rerun_queries(rr, [msg])] == [
        "scene/world/path",
        "scene/world/endpoints",
        "scene/world/robot",
    ]
    cubes, _ = p.foxglove_workspace(WS2)
    assert cubes[0]["pose"]["position"] == {"x": 1.0, "y": 2.0, "z": -0.05}
    assert cubes[0]["size"] == {"x": 3.0, "y": 4.0, "z": 0.1}


def test_point_painter_2d_draws_a_plane():
    import rerun as rr

    p = painter_for({"kind": "point"}, 2)
    msg = {
        "query_id": "q",
        "split": "seen",
        "start": [-1.0, -2.0],
        "goal": [3.0, 4.0],
        "path": [[-1.0, -2.0], [0.5, 1.5], [3.0, 4.0]],
        "success": True,
        "failure": None,
    }
    e = scene_entity(p, msg)
    assert e["cubes"] == [] and p.footprints(msg["path"]).shape[0] == 0
    assert [(q["x"], q["y"], q["z"]) for q in e["lines"][0]["points"]] == [
        (-1.0, -2.0, 0.0),
        (0.5, 1.5, 0.0),
        (3.0, 4.0, 0.0),
    ]
    assert [s["pose"]["position"] for s in e["spheres"]] == [
        {"x": -1.0, "y": -2.0, "z": 0.0},
        {"x": 3.0, "y": 4.0, "z": 0.0},
    ]
    _, (bounds,) = p.foxglove_workspace(WS2)
    assert {(q["x"], q["y"], q["z"]) for q in bounds["points"]} == {
        (-20.0, -10.0, 0.0),
        (20.0, -10.0, 0.0),
        (20.0, 10.0, 0.0),
        (-20.0, 10.0, 0.0),
    }
    assert len(bounds["points"]) == 8  # 4 edges as a line list
    assert isinstance(p.rerun_obstacles(rr, WS2), rr.Boxes2D)
    assert [e for e, _ in p.rerun_queries(rr, [msg])] == ["scene/world/path", "scene/world/endpoints"]


def test_point_painter_3d_draws_a_3d_path_as_3d_points():
    import rerun as rr

    p = painter_for({"kind": "point"}, 3)
    msg = {
        "query_id": "q",
        "split": "seen",
        "start": [-1.0, -2.0, -3.0],
        "goal": [3.0, 4.0, 5.0],
        "path": [[-1.0, -2.0, -3.0], [0.5, 1.5, 2.5], [3.0, 4.0, 5.0]],
        "success": False,
        "failure": "recheck_collision",
    }
    e = scene_entity(p, msg)
    assert [(q["x"], q["y"], q["z"]) for q in e["lines"][0]["points"]] == [
        (-1.0, -2.0, -3.0),
        (0.5, 1.5, 2.5),
        (3.0, 4.0, 5.0),
    ]
    assert e["lines"][0]["color"]["r"] > e["lines"][0]["color"]["g"]  # a failure is red
    assert [s["pose"]["position"]["z"] for s in e["spheres"]] == [-3.0, 5.0]
    assert e["cubes"] == []
    cubes, (bounds,) = p.foxglove_workspace(WS3)
    assert cubes[0]["pose"]["position"] == {"x": 1.0, "y": 2.0, "z": 3.0}
    assert cubes[0]["size"] == {"x": 3.0, "y": 4.0, "z": 5.0}
    assert len(bounds["points"]) == 24  # 12 edges
    assert isinstance(p.rerun_obstacles(rr, WS3), rr.Boxes3D)
    assert p.rerun_types(rr) == (rr.Boxes3D, rr.LineStrips3D, rr.Points3D)


def test_arm_painter_draws_posed_obstacles_the_hand_trace_and_the_links():
    import rerun as rr

    from harness.log.arm_painter import GHOSTS, ArmPainter, link_boxes
    from harness.log.foxglove import workspace_scene

    p = painter_for(SPECS["arm7"].robot_json(), 3)
    assert type(p) is ArmPainter
    home = [0.0, -0.785, 0.0, -2.356, 0.0, 1.571, 0.785]
    other = [0.8, -0.3, 0.2, -2.0, 0.1, 1.9, 0.5]
    msg = {"query_id": "q", "split": "file", "start": home, "goal": other, "path": [home, other], "success": True}
    e = scene_entity(p, msg)
    assert len(e["lines"][0]["points"]) > 2  # the hand's trace of a straight joint motion bends
    hand = e["spheres"][0]["pose"]["position"]
    assert 0.2 < hand["x"] < 0.7 and 0.3 < hand["z"] < 0.8  # the home pose's hand, in metres
    assert len(e["cubes"]) == GHOSTS * len(link_boxes()) == GHOSTS * 11  # base, 7 links, hand, 2 fingers
    ws = {
        "workspace_id": "w",
        "split": "file",
        "bounds": SPECS["arm7"].bounds_json(),
        "robot": SPECS["arm7"].robot_json(),
        "obstacles": [
            {"center": [0.5, 0.0, 0.0], "size": [0.2, 0.2, 0.2]},
            {"type": "cylinder", "center": [0.5, 0.3, 0.1], "size": [0.1, 0.1, 0.3], "orientation": [0, 0, 0, 1]},
            {"type": "sphere", "center": [0.5, -0.3, 0.1], "size": [0.1, 0.1, 0.1], "orientation": [0, 0, 0, 1]},
        ],
    }
    scene = json.loads(workspace_scene(p, ws, 1))
    jsonschema.validate(scene, scene_update_schema())
    ent, _legend = scene["entities"]
    assert (len(ent["cubes"]), len(ent["cylinders"]), len(ent["spheres"])) == (1, 1, 1)
    kinds = dict(p.rerun_obstacle_entities(rr, ws))
    assert isinstance(kinds["cylinders"], rr.Cylinders3D) and isinstance(kinds["spheres"], rr.Ellipsoids3D)
    assert [n for n, _ in p.rerun_queries(rr, [msg])] == [
        "scene/world/path",
        "scene/world/endpoints",
        "scene/world/arm",
    ]


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


# ------------------------------------------------------------------ crash safety

KILL_SCRIPT = textwrap.dedent("""
    import os, sys
    sys.path.insert(0, {repo!r}); sys.path.insert(0, {tests!r})
    from test_trial_log import make_run, make_ws, make_rec
    from harness.log import TrialLog
    from mpnet.envs.specs import SPECS
    log = TrialLog({run_dir!r}, make_run("s2d"), SPECS["s2d"], rerun={rerun})
    log.add_workspace(make_ws("s2d"))
    for i in range(3):
        log.add_query(make_rec("s2d", "ws0-%d" % i, success=i != 1))
    os.kill(os.getpid(), 9)
""")


def run_and_kill(run_dir: Path, rerun=False):
    script = KILL_SCRIPT.format(repo=str(REPO), tests=str(REPO / "tests"), run_dir=str(run_dir), rerun=rerun)
    p = subprocess.run([sys.executable, "-c", script], cwd=str(REPO), capture_output=True, text=True, timeout=120)
    assert p.returncode == -signal.SIGKILL, p.stderr
    return run_dir / "trials.mcap"


@pytest.mark.slow  # a subprocess
@pytest.mark.parametrize("rerun", [False, True])
def test_sigkill_leaves_every_finished_query(tmp_path, rerun):
    path = run_and_kill(tmp_path, rerun)
    # Not finalised: the indexed reader refuses it ...
    with pytest.raises(Exception):  # noqa: B017  (whatever the indexed reader raises)
        with open(path, "rb") as f:
            list(make_reader(f).iter_messages())
    # ... but mcap's StreamReader reads every finished query (as check_trials.py does).
    chans, got = {}, []
    with open(path, "rb") as f:
        try:
            for rec in StreamReader(f, skip_magic=False).records:
                if isinstance(rec, Channel):
                    chans[rec.id] = rec.topic
                elif isinstance(rec, Message):
                    got.append((chans[rec.channel_id], json.loads(rec.data)))
        except Exception:  # noqa: BLE001 - the stream ends without a footer
            pass
    assert [d["query_id"] for t, d in got if t == "/query"] == ["ws0-0", "ws0-1", "ws0-2"]
    assert len([d for t, d in got if t == "/run"]) == 1
    assert [d["workspace_id"] for t, d in got if t == "/workspace"] == ["ws0"]
    msgs, finalised = read_log(path)
    assert not finalised and len([m for m in msgs if m.topic == "/query"]) == 3
    rows = read_csv(tmp_path / "queries.csv")
    assert [r["query_id"] for r in rows] == ["ws0-0", "ws0-1", "ws0-2"]


@pytest.mark.parametrize("exc", [RuntimeError, KeyboardInterrupt])
def test_exceptions_finalise_the_file(tmp_path, exc):
    with pytest.raises(exc):
        with TrialLog(tmp_path, make_run(), SPECS["s2d"], rerun=True) as log:
            log.add_workspace(make_ws("s2d"))
            log.add_query(make_rec("s2d", "ws0-0"))
            raise exc()
    _, msgs = read_all(tmp_path / "trials.mcap")
    assert [d["query_id"] for d in by_topic(msgs, "/query")] == ["ws0-0"]
    assert read_log(tmp_path / "trials.mcap")[1] is True


def test_close_is_idempotent_and_closed_log_refuses(tmp_path):
    log = TrialLog(tmp_path, make_run(), SPECS["s2d"], rerun=False)
    log.add_workspace(make_ws("s2d"))
    log.add_query(make_rec("s2d", "ws0-0"))
    log.close()
    log.close()
    with pytest.raises(ValueError):
        log.add_query(make_rec("s2d", "ws0-1"))
    assert len(by_topic(read_all(tmp_path / "trials.mcap")[1], "/query")) == 1


@pytest.mark.slow  # a subprocess
def test_unclosed_log_is_finalised_at_exit(tmp_path):
    script = textwrap.dedent(f"""
        import sys
        sys.path.insert(0, {str(REPO)!r}); sys.path.insert(0, {str(REPO / "tests")!r})
        from test_trial_log import make_run, make_ws, make_rec
        from harness.log import TrialLog
        from mpnet.envs.specs import SPECS
        log = TrialLog({str(tmp_path)!r}, make_run("s2d"), SPECS["s2d"], rerun=True)
        log.add_workspace(make_ws("s2d"))
        log.add_query(make_rec("s2d", "ws0-0"))
    """)
    p = subprocess.run([sys.executable, "-c", script], cwd=str(REPO), capture_output=True, text=True, timeout=120)
    assert p.returncode == 0, p.stderr
    assert read_log(tmp_path / "trials.mcap")[1] is True
    from rerun.chunk import RrdReader

    rows = sum(
        c.num_rows for c in RrdReader(tmp_path / "trials.rrd").stream() if str(c.entity_path) == "/scene/world/path"
    )
    assert rows == 1  # the buffered query was sent before the recording closed


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


# ----------------------------------------------------------------------- resume


def check_resumed(tmp_path, expect_ids):
    schemas, msgs = read_all(tmp_path / "trials.mcap")
    assert len(by_topic(msgs, "/run")) == 1
    qs = by_topic(msgs, "/query")
    keys = [(q["split"], q["query_id"]) for q in qs]
    assert len(keys) == len(set(keys))
    assert sorted(q for _, q in keys) == sorted(expect_ids)
    assert len(by_topic(msgs, "/workspace")) == len(
        {(w["split"], w["workspace_id"]) for w in by_topic(msgs, "/workspace")}
    )
    for s in by_topic(msgs, "/scene"):
        jsonschema.validate(s, scene_update_schema())
    assert not list(tmp_path.glob("trials.mcap.resume-*"))  # moved-aside files are gone
    rows = read_csv(tmp_path / "queries.csv")
    assert sorted(r["query_id"] for r in rows) == sorted(expect_ids)
    return msgs


@pytest.mark.slow  # a subprocess
def test_resume_after_close_skips_done_and_never_duplicates(tmp_path):
    log_some(tmp_path, n=3)
    _, first = read_all(tmp_path / "trials.mcap")
    old_q = by_topic(first, "/query")
    with TrialLog(tmp_path, make_run(started_at="later"), SPECS["s2d"], rerun=True, resume=True) as log:
        assert log.done == {("seen", "ws0-0"), ("seen", "ws0-1"), ("seen", "ws0-2")}
        log.add_workspace(make_ws("s2d"))  # already there: no second /workspace
        for i in range(5):
            if ("seen", f"ws0-{i}") in log.done:
                with pytest.raises(ValueError):
                    log.add_query(make_rec("s2d", f"ws0-{i}"))
                continue
            log.add_query(make_rec("s2d", f"ws0-{i}"))
    msgs = check_resumed(tmp_path, [f"ws0-{i}" for i in range(5)])
    (run,) = by_topic(msgs, "/run")
    assert run["started_at"] == "later" and run["resumed_from"]["queries"] == 3
    assert by_topic(msgs, "/query")[:3] == old_q  # re-written unchanged
    assert (
        subprocess.run(
            rerun_cli() + ["rrd", "verify", str(tmp_path / "trials.rrd")], capture_output=True, timeout=120
        ).returncode
        == 0
    )


@pytest.mark.slow  # a subprocess
def test_resume_after_sigkill(tmp_path):
    run_and_kill(tmp_path)
    with TrialLog(tmp_path, make_run(), SPECS["s2d"], rerun=False, resume=True) as log:
        assert log.done == {("seen", f"ws0-{i}") for i in range(3)}
        log.add_query(make_rec("s2d", "ws0-3"))
    check_resumed(tmp_path, [f"ws0-{i}" for i in range(4)])
    # and again, from the finalised resumed file
    with TrialLog(tmp_path, make_run(), SPECS["s2d"], rerun=False, resume=True) as log:
        assert len(log.done) == 4
        log.add_query(make_rec("s2d", "ws0-4"))
    check_resumed(tmp_path, [f"ws0-{i}" for i in range(5)])


def test_resume_killed_during_resume_keeps_everything(tmp_path):
    """A moved-aside file that is still there (the resumed run died too) is read again."""
    log_some(tmp_path, n=2)
    log = TrialLog(tmp_path, make_run(), SPECS["s2d"], rerun=False, resume=True)
    log.add_query(make_rec("s2d", "ws0-2"))
    log._finalizer.detach()  # simulate a crash: nothing finalised, nothing cleaned up
    log._f.flush()
    assert list(tmp_path.glob("trials.mcap.resume-*"))
    with TrialLog(tmp_path, make_run(), SPECS["s2d"], rerun=False, resume=True) as log2:
        assert log2.done == {("seen", f"ws0-{i}") for i in range(3)}
    check_resumed(tmp_path, ["ws0-0", "ws0-1", "ws0-2"])
    log._f.close()
    log._csv.close()


def test_resume_without_previous_file_starts_fresh(tmp_path):
    with TrialLog(tmp_path, make_run(), SPECS["s2d"], rerun=False, resume=True) as log:
        assert log.done == set()


def test_resume_refuses_another_runs_log(tmp_path):
    log_some(tmp_path)
    with pytest.raises(ValueError, match="seed"):
        TrialLog(tmp_path, make_run(seed=1), SPECS["s2d"], rerun=False, resume=True)
    assert (tmp_path / "trials.mcap").exists()  # left in place


# ------------------------------------------------------------------------ Rerun


def rerun_cli():
    exe = shutil.which("rerun")
    return [exe] if exe else [sys.executable, "-m", "rerun"]


@pytest.mark.slow  # a subprocess
@pytest.mark.parametrize("env", ["s2d", "rigid", "c3d"])
def test_rrd_verifies_and_reads_back(tmp_path, env):
    with TrialLog(tmp_path, make_run(env), SPECS[env], rerun=True, rerun_batch=2) as log:
        log.add_workspace(make_ws(env))
        log.add_workspace(make_ws(env, "ws1", "unseen"))
        for i in range(3):
            log.add_query(make_rec(env, f"ws0-{i}", success=i != 1))
        log.add_query(make_rec(env, "ws1-0", wid="ws1", split="unseen"))
    rrd = tmp_path / "trials.rrd"
    p = subprocess.run(rerun_cli() + ["rrd", "verify", str(rrd)], capture_output=True, text=True, timeout=120)
    assert p.returncode == 0, p.stdout + p.stderr

    from rerun.chunk import RrdReader

    reader = RrdReader(rrd)
    (store,) = reader.recordings()
    assert store.application_id == "mpnet_bench"
    assert reader.blueprints()  # the default blueprint travels with the recording
    chunks = [c for c in reader.stream() if not c.is_empty]  # a property in 0.41
    assert chunks
    paths = {str(c.entity_path) for c in chunks}
    for e in (
        "/scene/world/path",
        "/scene/world/endpoints",
        "/scene/world/obstacles",
        "/stats/time_s",
        "/stats/collision_checks",
        "/workspaces/seen/ws0/obstacles",
        "/workspaces/unseen/ws1/obstacles",
        "/legend",  # what the colours mean, with the planner and env
    ):
        assert e in paths, (e, paths)
    assert ("/scene/world/robot" in paths) == is_rect(SPECS[env])
    rows = {}
    for c in chunks:
        if str(c.entity_path) == "/scene/world/path":
            assert "query" in c.timeline_names
            rows["path"] = rows.get("path", 0) + c.num_rows
    assert rows["path"] == 4


def test_rerun_off_writes_no_rrd(tmp_path):
    log_some(tmp_path, rerun=False)
    assert not (tmp_path / "trials.rrd").exists()


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


def test_arm_link_boxes_cover_the_links_where_pybullet_has_them():
    """Each drawn link box matches the world AABB of that link's collision mesh (the
    boxes were once placed in the link frame, 2-13 cm off)."""
    from harness.log.arm_painter import arm_boxes, link_boxes
    from mpnet.envs.arm.model import load_arm_model
    from mpnet.envs.checkers.pybullet_arm import lent_world
    from mpnet.envs.shapes import quat_matrix

    q = [0.3, -0.5, 0.2, -2.0, 0.4, 1.8, 0.5]
    corners = np.array([[x, y, z] for x in (-0.5, 0.5) for y in (-0.5, 0.5) for z in (-0.5, 0.5)])
    boxes = list(zip(link_boxes(), arm_boxes(q), strict=True))
    with lent_world(load_arm_model("panda")) as w:
        w.set_q(q)
        for (k, _, _), (centre, quat, size) in boxes:
            world = (corners * size) @ quat_matrix(quat).T + centre
            lo, hi = np.array(w.pb.getAABB(w.robot, w.links[k], physicsClientId=w.client))
            assert np.abs(world.min(0) - lo).max() < 0.015 and np.abs(world.max(0) - hi).max() < 0.015, k


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
    from tests.test_report import Q, write_log

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
