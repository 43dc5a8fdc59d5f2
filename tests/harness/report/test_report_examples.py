"""The report's example figures, drawn by each robot's painter: the 3D point robot (c3d) and the arm
on 3D axes, the rigid body whole (its footprint inside the axes at every vertex), 2D points flat."""

from __future__ import annotations

import numpy as np
from mpl_toolkits.mplot3d.art3d import Line3DCollection, Poly3DCollection

from harness.log import painter_for
from harness.report.facts import planner_facts
from harness.report.figures import fig_example
from harness.report.load import load, queries_frame
from tests.harness.report._helpers import Q, write_log


def example(tmp_path, env: str, path: list) -> tuple:
    """The example figure of one logged BIT* query along path (its first and last states are the
    start and goal), and that query's /workspace message."""
    path = [list(map(float, s)) for s in path]
    stats = {"path": path, "start": path[0], "goal": path[-1]}
    write_log(tmp_path / env, env, "bit_star", 0, [Q("seen", "0", 0, True, 1.0, stats=stats)])
    files, _, _ = load([tmp_path / env])
    facts, _ = planner_facts(files)
    fig = fig_example(queries_frame(files), files, env, facts)
    return fig, files[0].workspaces[("seen", "0")]


def test_c3d_example_is_3d(tmp_path):
    """c3d: one 3D axes, a translucent Poly3DCollection per obstacle box and a Line3DCollection per
    path segment (so that mplot3d orders each by its depth)."""
    fig, ws = example(tmp_path, "c3d", [(-15, -15, -15), (0, 15, -5), (15, 15, 15)])
    (ax,) = fig.axes
    assert ax.name == "3d"
    boxes = [c for c in ax.collections if isinstance(c, Poly3DCollection)]
    assert len(boxes) == len(ws["obstacles"]) == 2
    assert len([c for c in ax.collections if isinstance(c, Line3DCollection)]) == 2
    for lim in (ax.get_xlim(), ax.get_ylim(), ax.get_zlim()):
        assert lim[0] <= -20 and lim[1] >= 20
    assert "x-y projection" not in ax.get_title()


def test_s2d_example_stays_flat(tmp_path):
    fig, _ = example(tmp_path, "s2d", [(-15, -15), (0, 15), (15, 15)])
    (ax,) = fig.axes
    assert ax.name == "rectilinear" and ax.get_aspect() == 1.0


def test_rigid_example_holds_the_robot_whole(tmp_path):
    """Poses at the bounds' corner and edges: every corner of every footprint drawn lies inside the
    axes, which reach past the bounds by no more than the robot's half-diagonal and a margin."""
    fig, ws = example(tmp_path, "rigid", [(-19.5, -19.5, np.pi / 4), (19.5, 0, 0), (0, 19.5, np.pi / 2)])
    (ax,) = fig.axes
    painter = painter_for(ws["robot"], 2)
    corners = painter.footprints(np.array([(-19.5, -19.5, np.pi / 4), (19.5, 0, 0), (0, 19.5, np.pi / 2)]))
    corners = corners.reshape(-1, 2)
    assert corners.min() < -20 and corners.max() > 20  # the poses do reach past the bounds
    reach = 0.5 * float(np.hypot(*ws["robot"]["size"]))
    for k, (lo, hi) in enumerate((ax.get_xlim(), ax.get_ylim())):
        assert lo <= corners[:, k].min() and hi >= corners[:, k].max()
        assert lo >= -20 - 1.2 * reach - 2 and hi <= 20 + 1.2 * reach + 2
    assert len(ax.lines) >= 3 + 2  # the footprints and the path (and its vertices)


def test_arm_example_is_3d(tmp_path):
    """arm7: the hand's trace in 3D (metres), not joint angles on a workspace plot; the axes hold it."""
    q0, q1 = np.zeros(7), np.array([0.5, -0.3, 0.2, -1.5, 0.1, 1.2, 0.3])
    fig, ws = example(tmp_path, "arm7", [q0, q1])
    (ax,) = fig.axes
    assert ax.name == "3d"
    hand = np.asarray(painter_for(ws["robot"], 3).trace({"path": [q0, q1], "start": q0, "goal": q1})[0])
    assert len(hand) > 2 and np.abs(hand).max() < 1.5  # the Panda's reach
    assert len([c for c in ax.collections if isinstance(c, Line3DCollection)]) == len(hand) - 1
    for k, lim in enumerate((ax.get_xlim(), ax.get_ylim(), ax.get_zlim())):
        assert lim[0] <= hand[:, k].min() and lim[1] >= hand[:, k].max()
