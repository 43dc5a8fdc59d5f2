"""The trial log's scenes (docs/reports.md): Foxglove SceneUpdates valid under Foxglove's schema,
malformed ones refused, and each robot's painter (rectangles, 2D and 3D points, the arm's posed
obstacles, hand trace and link boxes)."""

from __future__ import annotations

import json
import math

import jsonschema
import numpy as np
import pytest

from harness.log import TrialLog, painter_for, rect_outlines, scene_update_schema
from mpnet.envs.specs import SPECS, generated
from tests.harness.log._helpers import by_topic, is_rect, make_rec, make_run, make_ws, read_all


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
    for spec in (SPECS[e] for e in generated()):  # every env's robot has a painter
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
    assert len(e["cubes"]) == GHOSTS * len(link_boxes("panda")) == GHOSTS * 11  # base, 7 links, hand, 2 fingers
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


def test_arm_link_boxes_cover_the_links_where_pybullet_has_them():
    """Each drawn link box matches the world AABB of that link's collision mesh (the
    boxes were once placed in the link frame, 2-13 cm off)."""
    from harness.log.arm_painter import arm_boxes, link_boxes
    from mpnet.envs.arm.model import load_arm_model
    from mpnet.envs.checkers.pybullet_arm import lent_world
    from mpnet.envs.shapes import quat_matrix

    q = [0.3, -0.5, 0.2, -2.0, 0.4, 1.8, 0.5]
    corners = np.array([[x, y, z] for x in (-0.5, 0.5) for y in (-0.5, 0.5) for z in (-0.5, 0.5)])
    boxes = list(zip(link_boxes("panda"), arm_boxes(q, "panda"), strict=True))
    with lent_world(load_arm_model("panda")) as w:
        w.set_q(q)
        for (k, _, _), (centre, quat, size) in boxes:
            world = (corners * size) @ quat_matrix(quat).T + centre
            lo, hi = np.array(w.pb.getAABB(w.robot, w.links[k], physicsClientId=w.client))
            assert np.abs(world.min(0) - lo).max() < 0.015 and np.abs(world.max(0) - hi).max() < 0.015, k
