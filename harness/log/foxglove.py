"""`/scene`: Foxglove `foxglove.SceneUpdate` messages, one per workspace shown and one per
query. This module knows the message's layout; what is drawn comes from the painter
(harness.log.painters), so nothing here depends on the robot."""

from __future__ import annotations

import json

from harness.log.mcap_io import dumps
from harness.log.style import C_FAILURE, C_GOAL, C_START, C_SUCCESS, LEGEND, PARTIAL_STYLE, rgba

FRAME_ID = "world"
LINE_STRIP, LINE_LOOP, LINE_LIST = 0, 1, 2
ID_QUAT = {"x": 0.0, "y": 0.0, "z": 0.0, "w": 1.0}
ORIGIN_POSE = {"position": {"x": 0.0, "y": 0.0, "z": 0.0}, "orientation": ID_QUAT}
_ZERO_DURATION = {"sec": 0, "nsec": 0}


def stamp(ns: int) -> dict:
    return {"sec": ns // 1_000_000_000, "nsec": ns % 1_000_000_000}


def p3(p) -> dict:
    """A Foxglove Vector3/Point3 of a 2D or 3D point (z = 0 in 2D)."""
    return {"x": float(p[0]), "y": float(p[1]), "z": float(p[2]) if len(p) > 2 else 0.0}


def cube(position: dict, size: dict, color, orientation: dict = ID_QUAT) -> dict:
    return {"pose": {"position": position, "orientation": orientation}, "size": size, "color": rgba(color)}


def line(kind: int, points: list, color, thickness: float) -> dict:
    return {
        "type": kind,
        "pose": ORIGIN_POSE,
        "thickness": thickness,
        "scale_invariant": False,
        "points": [p3(p) for p in points],
        "color": rgba(color),
        "colors": [],
        "indices": [],
    }


def entity(eid: str, stamp: dict, **prims) -> dict:
    e = {
        "timestamp": stamp,
        "frame_id": FRAME_ID,
        "id": eid,
        "lifetime": _ZERO_DURATION,
        "frame_locked": False,
        "metadata": prims.pop("metadata", []),
        "arrows": [],
        "cubes": [],
        "spheres": [],
        "cylinders": [],
        "lines": [],
        "triangles": [],
        "texts": [],
        "models": [],
    }
    e.update(prims)
    return e


def text(position, words: str, color, font_size: float, scale_invariant: bool = False) -> dict:
    """A Foxglove TextPrimitive facing the camera."""
    pose = {"position": p3(position), "orientation": ID_QUAT}
    return {
        "pose": pose,
        "billboard": True,
        "font_size": font_size,
        "scale_invariant": scale_invariant,
        "color": rgba(color),
        "text": words,
    }


def legend_texts(painter, msg: dict) -> list[dict]:
    """What the scene's colours mean, one text per colour in that colour, stacked down from
    the painter's legend corner (Foxglove's 3D panel has no legend of its own)."""
    corner, down, size = painter.legend_layout(msg)
    return [text(corner + k * down, words, color, size) for k, (words, color) in enumerate(LEGEND)]


def workspace_scene(painter, msg: dict, t: int) -> bytes:
    """Clear the scene and draw the workspace of a /workspace message (obstacles, bounds),
    with the legend."""
    st = stamp(t)
    split, wid = msg["split"], msg["workspace_id"]
    ent = entity(
        f"workspace/{split}/{wid}",
        st,
        **painter.foxglove_scene(msg),
        metadata=[{"key": "workspace_id", "value": wid}, {"key": "split", "value": split}],
    )
    key = entity("legend", st, texts=legend_texts(painter, msg))
    return dumps({"deletions": [{"timestamp": st, "type": 1, "id": ""}], "entities": [ent, key]})


def partial_lines(painter, msg: dict) -> str:
    """JSON text of a failed query's partial paths (comma-separated line primitives): a
    strip per kind in its colour, a dashed kind as a line list of its dashes."""
    out = []
    for kind, strips in painter.partial_strips(msg):
        color, dashed, _ = PARTIAL_STYLE[kind]
        pts = [p for s in strips for p in s] if dashed else strips[0]
        out.append(dumps(line(LINE_LIST if dashed else LINE_STRIP, pts, color, painter.line_width * 0.7)).decode())
    return "".join("," + x for x in out)


def query_scene(painter, msg: dict, t: int, planner: str = "") -> bytes:
    """A /query message's scene: its path as a line strip (green on success, red on failure),
    a failure's partial paths (`partial`) in their colours, start and goal as spheres, the
    painter's robot bodies as cubes, and a label at the start (planner, split, query, outcome).

    Encoded from string templates because it is on the per-query path and json.dumps of
    these nested dicts costs ~50 us; tests validate the output against the
    foxglove.SceneUpdate schema.
    """
    ok = bool(msg.get("success"))
    trace, start, goal = painter.trace(msg)
    pts = ",".join([P3 % (fx(p[0]), fx(p[1]), fx(p[2]) if len(p) > 2 else "0.0") for p in trace])
    spheres = ",".join(
        [
            _SPHERE % (fx(p[0]), fx(p[1]), fx(p[2]) if len(p) > 2 else "0.0", *(repr(painter.marker_size),) * 3, c)
            for p, c in ((start, _J_START), (goal, _J_GOAL))
            if p is not None
        ]
    )
    cubes = painter.foxglove_bodies(msg)
    meta = [{"key": k, "value": str(msg.get(k))} for k in _SCENE_META]
    meta = json.dumps([{"key": "planner", "value": planner}, *meta], separators=(",", ":"))
    label = json.dumps(f"{planner} {label_of(msg)}".strip())
    label_color = _J_SUCCESS if ok else _J_FAILURE
    ent = _ENTITY % (
        t // 1_000_000_000,
        t % 1_000_000_000,
        json.dumps(f"query/{msg['split']}/{msg['query_id']}"),
        meta,
        cubes,
        spheres,
        _STRIP % (repr(painter.line_width), pts, _J_SUCCESS if ok else _J_FAILURE)
        + ("" if ok or not msg.get("partial") else partial_lines(painter, msg)),
        _LABEL % (fx(start[0]), fx(start[1]), fx(start[2]) if len(start) > 2 else "0.0", label_color, label)
        if start is not None
        else "",
    )
    return ('{"deletions":[],"entities":[%s]}' % ent).encode()  # noqa: UP031  (the templates above are %-style)


def label_of(msg: dict) -> str:
    """A query's label: split, id and outcome (the recordings put the planner before it)."""
    return f"{msg['split']} {msg['query_id']}: " + ("ok" if msg.get("success") else str(msg.get("failure")))


def fx(x) -> str:
    """JSON text of a plain number (None, from a non-finite value, draws at 0)."""
    return "0.0" if x is None else repr(x)


def jcolor(c) -> str:
    """JSON text of a Foxglove Color."""
    return json.dumps(rgba(c), separators=(",", ":"))


_J_SUCCESS, _J_FAILURE, _J_START, _J_GOAL = map(jcolor, (C_SUCCESS, C_FAILURE, C_START, C_GOAL))
_J_ID_QUAT = json.dumps(ID_QUAT, separators=(",", ":"))
P3 = '{"x":%s,"y":%s,"z":%s}'
# A cube turned about z: position x, y, z, quaternion z, w, size x, y, z (JSON number texts), color (JSON).
YAW_CUBE = '{"pose":{"position":' + P3 + ',"orientation":{"x":0.0,"y":0.0,"z":%s,"w":%s}},"size":' + P3 + ',"color":%s}'
_SPHERE = '{"pose":{"position":' + P3 + ',"orientation":' + _J_ID_QUAT + '},"size":' + P3 + ',"color":%s}'
_STRIP = (
    '{"type":0,"pose":'
    + json.dumps(ORIGIN_POSE, separators=(",", ":"))
    + ',"thickness":%s,"scale_invariant":false,"points":[%s],"color":%s,"colors":[],"indices":[]}'
)
_ENTITY = (
    '{"timestamp":{"sec":%d,"nsec":%d},"frame_id":"' + FRAME_ID + '","id":%s,'
    '"lifetime":{"sec":0,"nsec":0},"frame_locked":false,"metadata":%s,"arrows":[],"cubes":[%s],'
    '"spheres":[%s],"cylinders":[],"lines":[%s],"triangles":[],"texts":[%s],"models":[]}'
)
# The query's label at its start, in its path's colour: position x, y, z (JSON number texts),
# color (JSON), text (JSON string); its size in pixels, whatever the zoom.
_LABEL = (
    '{"pose":{"position":' + P3 + ',"orientation":' + _J_ID_QUAT + '},"billboard":true,"font_size":14.0,'
    '"scale_invariant":true,"color":%s,"text":%s}'
)
_SCENE_META = ("query_id", "workspace_id", "split", "success", "failure", "time_s", "path_cost", "collision_checks")
