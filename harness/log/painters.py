"""How each robot kind is drawn: one painter per (robot kind, workspace dimension).

A painter turns the log's own messages (/workspace and /query as JSON) into Foxglove scene
primitives, Rerun archetypes, and the report's example figure (matplotlib, through
harness.log.mpl). The writer, the Rerun sink, the Foxglove module and the report only call a
painter, so a new robot kind is a new painter class, registered with `register` in its own
module `harness/log/<kind>_painter.py` (as arm_painter's ArmPainter), which `painter_for` finds
and imports: nothing else changes.

    painter = painter_for(ws_msg["robot"], workspace_dim)
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from typing import Any, ClassVar

import numpy as np

from harness.log import mpl
from harness.log.foxglove import LINE_LIST, YAW_CUBE, cube, fx, jcolor, label_of, line, p3
from harness.log.style import (
    C_BOUNDS,
    C_FAILURE,
    C_GOAL,
    C_OBSTACLE,
    C_ROBOT,
    C_START,
    C_SUCCESS,
    PARTIAL_STYLE,
    THIN_Z,
    rgba8,
)
from mpnet.discover import import_named

_PAINTERS: dict[tuple[str, int], type[Painter]] = {}


def register(cls: type[Painter]) -> type[Painter]:
    """Class decorator: make `cls` the painter of its (kind, workspace_dim)."""
    _PAINTERS[(cls.kind, cls.workspace_dim)] = cls
    return cls


def painter_for(robot: dict | str, workspace_dim: int) -> Painter:
    """The painter of a /workspace message's `robot` ({"kind": ...}, or an arm's name)
    in a workspace of `workspace_dim` dimensions."""
    kind = robot.get("kind") if isinstance(robot, dict) else robot
    cls = _PAINTERS.get((kind, int(workspace_dim)))
    if cls is None:  # a kind whose painter module is not imported yet: every `*_painter.py` beside this one
        import_named(__package__, "_painter")
        cls = _PAINTERS.get((kind, int(workspace_dim)))
    if cls is None:
        known = ", ".join(f"{k} ({d}D)" for k, d in sorted(_PAINTERS))
        raise ValueError(f"no painter for robot {robot!r} in a {workspace_dim}D workspace; painters: {known}")
    return cls(robot)


class Painter(ABC):
    """Draws one robot kind in one workspace dimension, from the log's JSON messages.

    Subclasses set `kind` and `workspace_dim`; the planar and spatial bases below draw the
    workspace, paths and endpoints, a robot with a body adds its footprints and bodies.
    """

    kind: ClassVar[str]
    workspace_dim: ClassVar[int]
    # What the report says about this robot's path costs: their metric, and whether a query's
    # reference cost is the exact shortest path (2D point robots) rather than a planned one.
    cost_metric: ClassVar[str] = "the env's path cost"
    exact_reference: ClassVar[bool] = False
    marker_size: ClassVar[float] = 0.8  # start and goal markers' diameter (workspace units)
    line_width: ClassVar[float] = 0.15  # path strips' width
    mpl_projection: ClassVar[str | None] = None  # the example figure's axes: None (2D) or "3d"

    def __init__(self, robot: dict | str):
        self.robot = robot

    # ------------------------------------------------------------- geometry
    def trace(self, msg: dict) -> tuple[list, list | None, list | None]:
        """A /query's path, start and goal as workspace points (for a body: its reference point)."""
        d = self.workspace_dim
        return [p[:d] for p in (msg.get("path") or [])], msg["start"][:d], msg["goal"][:d]

    def states_trace(self, states) -> np.ndarray:
        """Workspace points (n, workspace_dim) drawn for a list of states (for a body: its
        reference point); states with a missing (non-finite) value are left out."""
        pts = np.array(states, dtype=float).reshape(len(states), -1)[:, : self.workspace_dim]
        return pts[np.isfinite(pts).all(axis=1)]

    def partial_strips(self, msg: dict) -> list[tuple[str, list[np.ndarray]]]:
        """A failed /query's partial paths (`partial`) as (kind, strips) in PARTIAL_STYLE's
        order: the path as one strip, a dashed kind as its dashes (2-point strips). Kinds
        the message lacks, or that have no style, are left out."""
        partial = msg.get("partial") or {}
        out = []
        for kind, (_, dashed, _) in PARTIAL_STYLE.items():
            pts = self.states_trace(partial[kind]) if partial.get(kind) else np.zeros((0, self.workspace_dim))
            if len(pts):
                pts = pts.round(4)  # a drawing (0.1 mm on the arm): shorter JSON text
                out.append((kind, dashes(pts, 1.5 * self.marker_size) if dashed else [pts]))
        return out

    def legend_layout(self, msg: dict) -> tuple[np.ndarray, np.ndarray, float]:
        """Where Foxglove's legend goes for a /workspace message: its first line's position,
        the step from line to line, and the font size (workspace units): beside the bounds."""
        b = np.array(msg["bounds"][: self.workspace_dim], float)
        size = 0.04 * float(np.max(b[:, 1] - b[:, 0]))
        corner = np.array([b[0, 1] + size, b[1, 1], b[2, 1] if self.workspace_dim > 2 else 0.0])
        return corner, np.array([0.0, -1.6 * size, 0.0]), size

    def footprints(self, states) -> np.ndarray:
        """Closed outlines of the robot's body at each state, (n, k, workspace_dim) in
        workspace coordinates (what the report draws along a path); a point has none (n = 0)."""
        return np.zeros((0, 0, self.workspace_dim))

    # --------------------------------------------- the report's example figure (matplotlib)
    @abstractmethod
    def mpl_workspace(self, ax, msg: dict) -> list[np.ndarray]:
        """Draw a /workspace message's obstacles on axes of `mpl_projection`; return the points
        they span (for mpl_frame's limits)."""
        ...

    def mpl_query(self, ax, msg: dict, color, label: str) -> list[np.ndarray]:
        """Draw a /query's path (and the robot's body along it); return the points drawn."""
        pts = np.asarray(self.trace(msg)[0], float).reshape(-1, self.workspace_dim)
        if len(pts) < 2:
            return []
        mpl.path(ax, pts, color, label)
        return [pts]

    def mpl_endpoints(self, ax, msg: dict) -> list[np.ndarray]:
        """Draw a /query's start and goal; return their points."""
        _, start, goal = self.trace(msg)
        mpl.endpoints(ax, start, goal)
        return [np.array([start, goal], float)]

    @abstractmethod
    def mpl_frame(self, ax, msg: dict, drawn: list[np.ndarray]) -> None:
        """Axis limits that hold the workspace's bounds and everything drawn (a body whole),
        equal scales, axis labels."""
        ...

    # -------------------------------------------------------------- Foxglove
    @abstractmethod
    def foxglove_scene(self, msg: dict) -> dict:
        """Foxglove primitive lists by SceneEntity field ("cubes", "lines", ...) of a
        /workspace message (painters with posed obstacles add "cylinders", "spheres")."""
        ...

    def foxglove_bodies(self, msg: dict) -> str:
        """JSON text of the cube primitives (comma-separated) that show the robot's body
        along a /query's path; empty for a point."""
        return ""

    # ----------------------------------------------------------------- Rerun
    @abstractmethod
    def rerun_types(self, rr) -> tuple[Any, Any, Any]:
        """Rerun's box, line-strip and point archetypes of this dimension."""
        ...

    @abstractmethod
    def rerun_static(self, rr, bounds: list) -> list[tuple[str, Any]]:
        """(entity path, archetype) logged once: the world frame and the state bounds."""
        ...

    @abstractmethod
    def rerun_view(self, rrb, bounds: list):
        """The blueprint's view of /scene."""
        ...

    def rerun_obstacles(self, rr, msg: dict):
        """A /workspace message's obstacles as boxes."""
        d = self.workspace_dim
        obs = msg["obstacles"]
        c = np.array([o["center"][:d] for o in obs], float).reshape(-1, d)
        s = np.array([o["size"][:d] for o in obs], float).reshape(-1, d)
        return self.rerun_types(rr)[0](centers=c, sizes=s, colors=[rgba8(C_OBSTACLE)])

    def rerun_obstacle_entities(self, rr, msg: dict) -> list[tuple[str, Any]]:
        """(sub-entity, archetype) pairs of a /workspace message's obstacles ("" for one)."""
        return [("", self.rerun_obstacles(rr, msg))]

    def rerun_trace_strips(self, msgs: list[dict]) -> tuple[list[np.ndarray], np.ndarray]:
        """Each query's path as workspace points, and its start and goal (2 rows per query)."""
        d = self.workspace_dim
        strips = [
            np.asarray(m.get("path") or np.zeros((0, d)), float).reshape(-1, max(len(m["start"]), d))[:, :d]
            for m in msgs
        ]
        return strips, np.array([[m["start"][:d], m["goal"][:d]] for m in msgs], float).reshape(2 * len(msgs), d)

    def rerun_queries(self, rr, msgs: list[dict], planner: str = "") -> list[tuple[str, Any]]:
        """(entity path, columns) with one row per /query message: path strips labelled
        with the planner, split, query and outcome, start and goal points."""
        _, strips_t, points_t = self.rerun_types(rr)
        n = len(msgs)
        ok = np.array([bool(m.get("success")) for m in msgs])
        colors = np.where(ok[:, None], np.array(rgba8(C_SUCCESS), np.uint8), np.array(rgba8(C_FAILURE), np.uint8))
        strips, ends = self.rerun_trace_strips(msgs)
        labels = [f"{planner} {label_of(m)}".strip() for m in msgs]
        end_colors = np.tile(np.array([rgba8(C_START), rgba8(C_GOAL)], np.uint8), (n, 1))
        return [
            ("scene/world/path", strips_t.columns(strips=strips, colors=colors, labels=labels)),
            (
                "scene/world/endpoints",
                points_t.columns(
                    positions=ends, colors=end_colors, radii=np.full(2 * n, self.marker_size / 2, np.float32)
                ).partition([2] * n),
            ),
        ]

    def rerun_partials(self, rr, msgs: list[dict], planner: str, shown: set) -> list[tuple[str, list[int], Any]]:
        """(scene/world/partial/<kind>, rows, columns) of the failures' partial paths in
        /query messages: strips in the kind's colour, one label (planner, split, query, kind).

        A kind has a row only where a query has it, and an empty row at the next query that
        has not (clearing it), so successes cost nothing; `shown` holds the kinds on screen
        after the previous batch and is updated."""
        strips_t = self.rerun_types(rr)[1]
        drawn = [dict(self.partial_strips(m)) if m.get("partial") else {} for m in msgs]
        out = []
        for kind, (color, _, _) in PARTIAL_STYLE.items():
            rows, prev = [], kind in shown
            for i, d in enumerate(drawn):
                if kind in d or prev:
                    rows.append(i)
                prev = kind in d
            (shown.add if prev else shown.discard)(kind)
            if not rows:
                continue
            strips = [drawn[i].get(kind, []) for i in rows]
            has = [int(bool(s)) for s in strips]
            labels = [
                f"{planner} {msgs[i]['split']} {msgs[i]['query_id']}: {kind}".strip() for i in rows if kind in drawn[i]
            ]
            columns = strips_t.columns(strips=[s for r in strips for s in r]).partition([len(r) for r in strips])
            style = strips_t.columns(
                colors=np.tile(np.array(rgba8(color), np.uint8), (len(labels), 1)), labels=labels
            ).partition(has)
            out.append((f"scene/world/partial/{kind}", rows, [*columns, *style]))
        return out


class _Boxes(Painter):
    """A workspace of axis-aligned boxes: its Foxglove scene is cubes and lines."""

    @abstractmethod
    def foxglove_workspace(self, msg: dict) -> tuple[list[dict], list[dict]]:
        """Cube and line primitives of a /workspace message: its obstacles and bounds."""
        ...

    def foxglove_scene(self, msg: dict) -> dict:
        cubes, lines = self.foxglove_workspace(msg)
        return {"cubes": cubes, "lines": lines}


class _Planar(_Boxes):
    """A 2D workspace: obstacles as thin boxes below z = 0 in Foxglove, Rerun's 2D view
    with y pointing up."""

    workspace_dim = 2

    def foxglove_workspace(self, msg):
        cubes = [
            cube(
                {"x": o["center"][0], "y": o["center"][1], "z": -THIN_Z / 2},
                {"x": o["size"][0], "y": o["size"][1], "z": THIN_Z},
                C_OBSTACLE,
            )
            for o in msg["obstacles"]
        ]
        (x0, x1), (y0, y1) = msg["bounds"][0], msg["bounds"][1]
        c = [(x0, y0), (x1, y0), (x1, y1), (x0, y1)]
        edges = [p for i in range(4) for p in (c[i], c[(i + 1) % 4])]
        return cubes, [line(LINE_LIST, edges, C_BOUNDS, 0.1)]

    def mpl_workspace(self, ax, msg):
        obs = msg["obstacles"]
        c = np.array([o["center"][:2] for o in obs], float).reshape(-1, 2)
        s = np.array([o["size"][:2] for o in obs], float).reshape(-1, 2)
        mpl.rectangles_2d(ax, c, s)
        mpl.bounds_2d(ax, *_lo_hi(msg["bounds"], 2))
        return [c - s / 2, c + s / 2]

    def mpl_frame(self, ax, msg, drawn):
        mpl.limits(ax, drawn, msg["bounds"][:2])
        ax.set_xlabel("x (workspace units)")
        ax.set_ylabel("y (workspace units)")

    def rerun_types(self, rr):
        return rr.Boxes2D, rr.LineStrips2D, rr.Points2D

    def rerun_static(self, rr, bounds):
        lo, hi = _lo_hi(bounds, 2)
        # Rerun's 2D views draw y down; flip the world so y points up as in the paper.
        return [
            ("scene/world", rr.Transform3D(scale=[1.0, -1.0, 1.0])),
            (
                "scene/world/bounds",
                rr.LineStrips2D([[lo, [hi[0], lo[1]], hi, [lo[0], hi[1]], lo]], colors=[rgba8(C_BOUNDS)]),
            ),
        ]

    def rerun_view(self, rrb, bounds):
        lo, hi = _lo_hi(bounds, 2)
        pad = 0.05 * float(max(hi - lo))
        return rrb.Spatial2DView(
            name="scene",
            origin="/scene",
            visual_bounds=rrb.VisualBounds2D(x_range=[lo[0] - pad, hi[0] + pad], y_range=[-hi[1] - pad, -lo[1] + pad]),
        )


class _Spatial(_Boxes):
    """A 3D workspace: obstacles as boxes, Rerun's 3D view."""

    workspace_dim = 3
    mpl_projection = "3d"

    def foxglove_workspace(self, msg):
        cubes = [cube(p3(o["center"]), p3(o["size"]), C_OBSTACLE) for o in msg["obstacles"]]
        lo, hi = (list(x) for x in zip(*msg["bounds"][:3]))
        edges = []
        for a in range(3):  # the 12 edges, 4 along each axis
            b, d = [k for k in range(3) if k != a]
            for vb in (lo[b], hi[b]):
                for vd in (lo[d], hi[d]):
                    p, q = [0.0] * 3, [0.0] * 3
                    p[a], q[a] = lo[a], hi[a]
                    p[b] = q[b] = vb
                    p[d] = q[d] = vd
                    edges += [p, q]
        return cubes, [line(LINE_LIST, edges, C_BOUNDS, 0.1)]

    def mpl_workspace(self, ax, msg):
        corners = [mpl.box_corners(o["center"][:3], o["size"][:3]) for o in msg["obstacles"]]
        mpl.boxes_3d(ax, corners)
        return corners

    def mpl_frame(self, ax, msg, drawn):
        mpl.limits(ax, drawn, msg["bounds"][:3])
        mpl.axes_3d(ax, "workspace units")

    def rerun_types(self, rr):
        return rr.Boxes3D, rr.LineStrips3D, rr.Points3D

    def rerun_static(self, rr, bounds):
        lo, hi = _lo_hi(bounds, 3)
        return [("scene/world/bounds", rr.Boxes3D(mins=[lo], sizes=[hi - lo], colors=[rgba8(C_BOUNDS)]))]

    def rerun_view(self, rrb, bounds):
        return rrb.Spatial3DView(name="scene", origin="/scene")


@register
class PointPainter2D(_Planar):
    """A point robot in the plane (s2d, c2d): the state is the position."""

    kind = "point"
    cost_metric = "Euclidean length"
    exact_reference = True


@register
class PointPainter3D(_Spatial):
    """A point robot in space (c3d): the state is the position."""

    kind = "point"
    cost_metric = "Euclidean length"


@register
class RectanglePainter(_Planar):
    """A rigid rectangle in the plane (rigid), state (x, y, theta): its footprint is drawn
    at every state of a path (at start and goal when there is no path)."""

    kind = "rectangle"
    cost_metric = "OMPL's SE(2) metric, |Δxy| + 0.5·|Δθ| per segment (Δθ along the shorter arc)"

    def __init__(self, robot: dict):
        super().__init__(robot)
        if not isinstance(robot, dict) or len(robot.get("size") or ()) < 2:
            raise ValueError(f"a rectangle robot needs its size [w, h], got {robot!r}")
        self.size = (float(robot["size"][0]), float(robot["size"][1]))

    def footprints(self, states) -> np.ndarray:
        return rect_outlines(states, self.size)

    def mpl_query(self, ax, msg, color, label):
        drawn = super().mpl_query(ax, msg, color, label)
        if not drawn:
            return drawn
        loops = self.footprints(np.asarray(msg["path"], float))
        mpl.outlines(ax, loops, color)
        return drawn + [loops.reshape(-1, 2)]

    def foxglove_bodies(self, msg):
        states = msg.get("path") or [msg["start"], msg["goal"]]
        sx, sy = repr(self.size[0]), repr(self.size[1])
        return ",".join(
            [
                YAW_CUBE
                % (
                    fx(q[0]),
                    fx(q[1]),
                    "0.01",
                    repr(math.sin(_f(q[2]) / 2)),
                    repr(math.cos(_f(q[2]) / 2)),
                    sx,
                    sy,
                    "0.02",
                    _J_ROBOT,
                )
                for q in states
            ]
        )

    def rerun_queries(self, rr, msgs, planner=""):
        out = super().rerun_queries(rr, msgs, planner)
        outl = [self.footprints(np.asarray(m.get("path") or [m["start"], m["goal"]], float)) for m in msgs]
        lens = [len(o) for o in outl]
        outl = np.concatenate(outl)
        out.append(
            (
                "scene/world/robot",
                rr.LineStrips2D.columns(
                    strips=outl, colors=np.tile(np.array(rgba8(C_ROBOT), np.uint8), (len(outl), 1))
                ).partition(lens),
            )
        )
        return out


def dashes(points: np.ndarray, length: float, most: int = 30) -> list[np.ndarray]:
    """A polyline as dashes of `length` with gaps as long (2-point strips; at most `most`
    dashes, longer ones on a long path): how a dashed line is drawn."""
    seg = np.linalg.norm(np.diff(points, axis=0), axis=1)
    cum = np.concatenate([[0.0], np.cumsum(seg)])
    total = float(cum[-1])
    if total <= 0:
        return [points[[0, 0]]]
    length = max(length, total / (2 * most))
    starts = np.arange(0.0, total, 2 * length)

    def at(s):
        k = np.clip(np.searchsorted(cum, s, side="right") - 1, 0, len(seg) - 1)
        frac = np.where(seg[k] > 0, (s - cum[k]) / np.where(seg[k] > 0, seg[k], 1.0), 0.0)
        return points[k] + frac[:, None] * (points[k + 1] - points[k])

    return list(np.stack([at(starts), at(np.minimum(starts + length, total))], axis=1).round(4))


def rect_outlines(states, size) -> np.ndarray:
    """Closed outlines (n, 5, 2) of a rectangle body at each (x, y, theta).

    Body extents `size` = (along body x, along body y); body x axis is (cos, sin).
    """
    states = np.asarray(states, float).reshape(-1, 3)
    c, s = np.cos(states[:, 2]), np.sin(states[:, 2])
    hx, hy = size[0] / 2, size[1] / 2
    sx = np.array([-1, 1, 1, -1, -1], float) * hx  # corner loop, closed
    sy = np.array([-1, -1, 1, 1, -1], float) * hy
    x = states[:, :1] + sx[None] * c[:, None] - sy[None] * s[:, None]
    y = states[:, 1:2] + sx[None] * s[:, None] + sy[None] * c[:, None]
    return np.stack([x, y], axis=2)


def _lo_hi(bounds: list, d: int) -> tuple[np.ndarray, np.ndarray]:
    """Lower and upper corners of the first `d` state bounds (the workspace's)."""
    b = np.array(bounds[:d], float)
    return b[:, 0], b[:, 1]


def _f(x) -> float:
    return 0.0 if x is None else float(x)


_J_ROBOT = jcolor(C_ROBOT)
