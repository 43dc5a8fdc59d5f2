"""Colours and sizes shared by the Foxglove scenes and the Rerun recording, so both views
of a run look alike."""

from __future__ import annotations

C_OBSTACLE = (0.55, 0.55, 0.6, 0.85)
C_BOUNDS = (0.3, 0.3, 0.3, 1.0)
C_SUCCESS = (0.1, 0.75, 0.2, 1.0)
C_FAILURE = (0.9, 0.15, 0.1, 1.0)
C_START = (0.15, 0.35, 0.95, 1.0)
C_GOAL = (1.0, 0.6, 0.0, 1.0)
C_ROBOT = (0.35, 0.35, 0.35, 0.35)
C_ARM = (0.45, 0.6, 0.85, 0.3)  # the arm's links along a path: translucent, apart from the grey obstacles
# A failed query's partial paths (/query `partial`, mpnet.planners.base.PARTIAL_KINDS, spelled out:
# the report reads harness.log and may not import mpnet.planners; a test keeps them equal): kind ->
# (colour, dashed, what it is). Orange is the goal's, so the forward tree is cyan.
PARTIAL_STYLE = {
    "forward": ((0.0, 0.8, 0.9, 1.0), False, "forward tree: MPNet's path grown from the start"),
    "backward": ((0.6, 0.3, 0.9, 1.0), False, "backward tree: MPNet's path grown from the goal"),
    "last_path": ((0.8, 0.8, 0.8, 1.0), True, "last path: MPNet's last coarse or replanned path, not feasible"),
    "approximate": ((0.95, 0.85, 0.15, 1.0), False, "approximate solution: OMPL's path toward the goal"),
}
_NAMES = {"forward": "cyan", "backward": "purple", "last_path": "grey dashes", "approximate": "yellow"}
# What the colours mean, as (text, colour) lines: Foxglove's legend and Rerun's /legend.
LEGEND = (
    ("blue point: start", C_START),
    ("orange point: goal", C_GOAL),
    ("green path: a success", C_SUCCESS),
    ("red path: a failure", C_FAILURE),
    *((f"{_NAMES[k]}: {what}", c) for k, (c, _, what) in PARTIAL_STYLE.items()),
)

THIN_Z = 0.1  # height of a 2D obstacle drawn as a cube; its top face is z = 0


def rgba(c) -> dict:
    """Foxglove's Color."""
    return {"r": c[0], "g": c[1], "b": c[2], "a": c[3]}


def rgba8(c) -> tuple[int, int, int, int]:
    """Rerun's 8-bit colour."""
    return tuple(int(round(255 * x)) for x in c)
