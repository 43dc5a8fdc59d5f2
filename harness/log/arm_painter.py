"""How the arm is drawn: posed obstacles (oriented boxes, cylinders, spheres) in the base
frame, the end-effector trace of each path, and the arm's links as boxes at states along
the path (from pybullet's collision meshes), in Foxglove and Rerun.

The joint-space path is what the log holds; everything spatial here comes from the
logged arm model's forward kinematics in pybullet (mpnet.envs.checkers.pybullet_arm)."""

from __future__ import annotations

import json
from functools import cache, cached_property
from typing import Any

import numpy as np

from harness.log import mpl
from harness.log.foxglove import LINE_LIST, cube, line, p3, rgba
from harness.log.painters import Painter, register
from harness.log.style import C_ARM, C_BOUNDS, C_OBSTACLE, rgba8
from mpnet.envs.arm.model import load_arm_model
from mpnet.envs.checkers.pybullet_arm import ArmWorld, borrow_world, lent_world
from mpnet.envs.robots import logged_model_name
from mpnet.envs.shapes import IDENTITY, quat_matrix

TRACE_STEP = 0.05  # joint-space step of the end-effector trace (rad)
MAX_TRACE_POINTS = 300  # partial paths' traces are coarser when longer: the log process keeps up with the planner
GHOSTS = 6  # arm poses drawn along each path (start and goal included)


@cache
def link_boxes(model: str) -> list[tuple[int, np.ndarray, np.ndarray]]:
    """(link index in the pose list, centre, size) of each link's collision mesh, as a box
    in the link's inertial frame (where getMeshData's vertices are)."""
    out = []
    with lent_world(load_arm_model(model)) as w:
        for k, link in enumerate(w.links):
            n, verts = w.pb.getMeshData(w.robot, link, physicsClientId=w.client)
            if n:
                v = np.asarray(verts, float)
                out.append((k, (v.min(0) + v.max(0)) / 2, v.max(0) - v.min(0)))
    return out


def arm_boxes(q, model: str, world: ArmWorld | None = None) -> list[tuple[np.ndarray, list[float], np.ndarray]]:
    """(centre, quaternion, size) of every link box at configuration q (in `world` when the
    caller holds one of the model: a painter's)."""
    if world is not None:
        poses = world.link_poses(q)
    else:
        with lent_world(load_arm_model(model)) as w:
            poses = w.link_poses(q)
    out = []
    for k, c, s in link_boxes(model):
        pos, quat = poses[k]
        out.append((np.asarray(pos) + quat_matrix(quat) @ c, quat, s))
    return out


def _states(msg: dict) -> np.ndarray:
    path = msg.get("path") or [msg["start"], msg["goal"]]
    return np.asarray(path, float).reshape(len(path), -1)


def _dense(states: np.ndarray, step: float) -> np.ndarray:
    """The joint-space path sampled at `step` (the trace of a straight joint motion bends)."""
    out = [states[:1]]
    for a, b in zip(states[:-1], states[1:]):
        n = max(1, int(np.ceil(np.linalg.norm(b - a) / step)))
        out.append(a + np.linspace(0, 1, n + 1)[1:, None] * (b - a))
    return np.concatenate(out)


def ghost_states(msg: dict) -> np.ndarray:
    """GHOSTS states evenly spaced along the path (by joint-space length)."""
    s = _dense(_states(msg), TRACE_STEP)
    return s[np.unique(np.linspace(0, len(s) - 1, GHOSTS).round().astype(int))]


def _fquat(q) -> dict:
    return {"x": float(q[0]), "y": float(q[1]), "z": float(q[2]), "w": float(q[3])}


@register
class ArmPainter(Painter):
    """A serial arm in 3D (arm7): state = joint vector; the trace is the hand's position."""

    kind = "arm"
    workspace_dim = 3
    cost_metric = "joint-space Euclidean length (rad)"
    marker_size = 0.04  # start and goal spheres (metres)
    line_width = 0.008

    @property
    def model(self) -> str:
        return logged_model_name(self.robot if isinstance(self.robot, dict) else {})

    @cached_property
    def world(self) -> ArmWorld:
        """The painter's own pybullet world of the logged model (no obstacles): the hand's positions."""
        return borrow_world(load_arm_model(self.model), self)

    def trace(self, msg):
        w = self.world
        path = msg.get("path") or []
        pts = [w.hand_position(q) for q in _dense(np.asarray(path, float), TRACE_STEP)] if len(path) else []
        return pts, w.hand_position(msg["start"]), w.hand_position(msg["goal"])

    def states_trace(self, states):
        """The hand's trace along a list of joint states (missing values left out)."""
        q = np.array(states, dtype=float).reshape(len(states), -1)
        q = q[np.isfinite(q).all(axis=1)]
        if not len(q):
            return np.zeros((0, 3))
        w = self.world
        length = float(np.linalg.norm(np.diff(q, axis=0), axis=1).sum()) if len(q) > 1 else 0.0
        step = max(TRACE_STEP, length / MAX_TRACE_POINTS)  # a failed MPNet query's trees span many radians
        return np.array([w.hand_position(x) for x in _dense(q, step)], float).reshape(-1, 3)

    def legend_layout(self, msg):
        """Beside the arm's reach (the bounds are joint limits), stacked downward."""
        return np.array([0.0, -0.9, 1.2]), np.array([0.0, 0.0, -0.06]), 0.04

    def footprints(self, states):
        return np.zeros((0, 0, 3))

    # --------------------------------------------- the report's example figure (matplotlib)
    mpl_projection = "3d"

    def mpl_workspace(self, ax, msg):
        boxes, spans = [], []
        for o in msg["obstacles"]:
            rot = quat_matrix(o.get("orientation", IDENTITY))
            spans.append(mpl.box_corners(o["center"], o["size"], rot))
            kind = o.get("type", "box")
            if kind == "box":
                boxes.append(spans[-1])
            else:
                grid = mpl.cylinder_grid if kind == "cylinder" else mpl.ellipsoid_grid
                mpl.mesh_3d(ax, *grid(o["center"], o["size"], rot))
        mpl.boxes_3d(ax, boxes)
        return spans

    def mpl_query(self, ax, msg, color, label):
        pts = np.asarray(self.trace(msg)[0], float).reshape(-1, 3)
        if len(pts) < 2:
            return []
        w = self.world
        mpl.path(ax, pts, color, label, marks=[w.hand_position(q) for q in _states(msg)])
        return [pts]

    def mpl_frame(self, ax, msg, drawn):
        mpl.limits(ax, drawn)  # the logged bounds are the joints'
        mpl.axes_3d(ax, "m")

    # -------------------------------------------------------------- Foxglove
    def foxglove_scene(self, msg: dict) -> dict:
        prims: dict[str, list] = {"cubes": [], "cylinders": [], "spheres": []}
        for o in msg["obstacles"]:
            pose = {"position": p3(o["center"]), "orientation": _fquat(o.get("orientation", IDENTITY))}
            kind = {"box": "cubes", "cylinder": "cylinders", "sphere": "spheres"}[o.get("type", "box")]
            item = {"pose": pose, "size": p3(o["size"]), "color": rgba(C_OBSTACLE)}
            if kind == "cylinders":
                item.update(bottom_scale=1.0, top_scale=1.0)
            prims[kind].append(item)
        axes = [[0, 0, 0], [0.2, 0, 0], [0, 0, 0], [0, 0.2, 0], [0, 0, 0], [0, 0, 0.2]]
        prims["lines"] = [line(LINE_LIST, axes, C_BOUNDS, 0.005)]
        return prims

    def foxglove_bodies(self, msg):
        return ",".join(
            json.dumps(cube(p3(c), p3(s), C_ARM, _fquat(q)), separators=(",", ":"))
            for state in ghost_states(msg)
            for c, q, s in arm_boxes(state, self.model, self.world)
        )

    # ----------------------------------------------------------------- Rerun
    def rerun_types(self, rr):
        return rr.Boxes3D, rr.LineStrips3D, rr.Points3D

    def rerun_static(self, rr, bounds):
        return [
            ("scene/world/base", rr.Arrows3D(vectors=np.eye(3) * 0.2, colors=[(255, 0, 0), (0, 255, 0), (0, 0, 255)])),
            ("scene/world/arm", rr.Boxes3D.from_fields(fill_mode="solid")),  # translucent links, not wireframes
        ]

    def rerun_view(self, rrb, bounds):
        eye = rrb.EyeControls3D(position=[1.7, -1.3, 1.2], look_target=[0.25, 0.0, 0.35], eye_up=[0.0, 0.0, 1.0])
        return rrb.Spatial3DView(name="scene", origin="/scene", eye_controls=eye)

    def rerun_obstacle_entities(self, rr, msg: dict) -> list[tuple[str, Any]]:
        by: dict[str, list] = {"box": [], "cylinder": [], "sphere": []}
        for o in msg["obstacles"]:
            by[o.get("type", "box")].append(o)

        def arr(items, key, default=None, n=3):
            return np.array([o.get(key, default) for o in items], float).reshape(-1, n)

        color = [rgba8(C_OBSTACLE)]
        b, c, s = by["box"], by["cylinder"], by["sphere"]
        return [
            (
                "boxes",
                rr.Boxes3D(
                    centers=arr(b, "center"),
                    sizes=arr(b, "size"),
                    quaternions=arr(b, "orientation", IDENTITY, 4),
                    colors=color,
                    fill_mode="solid",
                ),
            ),
            (
                "cylinders",
                rr.Cylinders3D(
                    centers=arr(c, "center"),
                    lengths=arr(c, "size")[:, 2],
                    radii=arr(c, "size")[:, 0] / 2,
                    quaternions=arr(c, "orientation", IDENTITY, 4),
                    colors=color,
                    fill_mode="solid",
                ),
            ),
            (
                "spheres",
                rr.Ellipsoids3D(
                    centers=arr(s, "center"), half_sizes=arr(s, "size") / 2, colors=color, fill_mode="solid"
                ),
            ),
        ]

    def rerun_queries(self, rr, msgs, planner=""):
        out = super().rerun_queries(rr, msgs, planner)  # end-effector traces (via trace) and end points
        boxes = [[b for st in ghost_states(m) for b in arm_boxes(st, self.model, self.world)] for m in msgs]
        lens = [len(b) for b in boxes]
        flat = [b for bs in boxes for b in bs]
        out.append(
            (
                "scene/world/arm",
                rr.Boxes3D.columns(
                    centers=np.array([b[0] for b in flat]),
                    quaternions=np.array([b[1] for b in flat]),
                    half_sizes=np.array([b[2] for b in flat]) / 2,
                    colors=np.tile(np.array(rgba8(C_ARM), np.uint8), (len(flat), 1)),
                ).partition(lens),
            )
        )
        return out

    def rerun_trace_strips(self, msgs) -> tuple[list[np.ndarray], np.ndarray]:
        """End-effector traces and the start/goal hand positions of each query."""
        strips, ends = [], []
        for m in msgs:
            pts, s, g = self.trace(m)
            strips.append(np.asarray(pts, float).reshape(-1, 3))
            ends += [s, g]
        return strips, np.asarray(ends, float).reshape(-1, 3)
