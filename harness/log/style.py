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

THIN_Z = 0.1  # height of a 2D obstacle drawn as a cube; its top face is z = 0


def rgba(c) -> dict:
    """Foxglove's Color."""
    return {"r": c[0], "g": c[1], "b": c[2], "a": c[3]}


def rgba8(c) -> tuple[int, int, int, int]:
    """Rerun's 8-bit colour."""
    return tuple(int(round(255 * x)) for x in c)
