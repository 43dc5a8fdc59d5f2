"""Matplotlib primitives the painters draw the report's example figures with: boxes, meshes,
paths and markers on 2D or 3D axes, and axis limits that hold everything drawn.

On 3D axes every box, every path segment and every marker is an artist of its own and a
collection, so that mplot3d orders each by its own depth: a segment behind a translucent box is
seen through it, one in front of it covers it (mplot3d draws a plain line below every
collection, and a whole path at a single depth)."""

from __future__ import annotations

import numpy as np

OBSTACLE = "0.55"
OBSTACLE_EDGE = "0.3"
START = "#2050f0"
GOAL = "#f09000"
BOUNDS = "0.35"
PAD = 0.03  # margin around what is drawn, as a share of the widest extent

# The corners of a unit cube centred at 0, and its six faces as corner indices.
_CORNERS = np.array([[x, y, z] for x in (-0.5, 0.5) for y in (-0.5, 0.5) for z in (-0.5, 0.5)])
_FACES = ((0, 1, 3, 2), (4, 5, 7, 6), (0, 1, 5, 4), (2, 3, 7, 6), (0, 2, 6, 4), (1, 3, 7, 5))


def box_corners(center, size, rotation=None) -> np.ndarray:
    """The 8 corners (8, 3) of a box: centre, edge lengths and a rotation matrix (None: axis-aligned)."""
    local = _CORNERS * np.asarray(size, float)
    if rotation is not None:
        local = local @ np.asarray(rotation, float).T
    return np.asarray(center, float) + local


def boxes_3d(ax, corners: list[np.ndarray], alpha: float = 0.22) -> None:
    """Translucent boxes, one collection each (given by box_corners)."""
    from mpl_toolkits.mplot3d.art3d import Poly3DCollection

    for c in corners:
        ax.add_collection3d(
            Poly3DCollection(
                [c[list(f)] for f in _FACES], facecolor=OBSTACLE, edgecolor=OBSTACLE_EDGE, lw=0.4, alpha=alpha
            )
        )


def mesh_3d(ax, x, y, z, alpha: float = 0.22) -> None:
    """A translucent surface given as grids (a cylinder, a sphere)."""
    ax.plot_surface(x, y, z, color=OBSTACLE, alpha=alpha, lw=0, shade=True)


def cylinder_grid(center, size, rotation=None, n: int = 24) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """x, y, z grids of a cylinder's side: size (diameter, diameter, height) along its local z."""
    t, h = np.meshgrid(np.linspace(0, 2 * np.pi, n), [-0.5, 0.5])
    local = np.stack([np.cos(t) * size[0] / 2, np.sin(t) * size[1] / 2, h * size[2]], axis=-1)
    return _posed(local, center, rotation)


def ellipsoid_grid(center, size, rotation=None, n: int = 16) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """x, y, z grids of an ellipsoid (a sphere) of axes `size`."""
    u, v = np.meshgrid(np.linspace(0, 2 * np.pi, n), np.linspace(0, np.pi, n // 2 + 1))
    local = np.stack([np.cos(u) * np.sin(v), np.sin(u) * np.sin(v), np.cos(v)], axis=-1) * np.asarray(size) / 2
    return _posed(local, center, rotation)


def _posed(local: np.ndarray, center, rotation) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    pts = local if rotation is None else local @ np.asarray(rotation, float).T
    pts = pts + np.asarray(center, float)
    return pts[..., 0], pts[..., 1], pts[..., 2]


def axes_3d(ax, unit: str, elev: float = 24.0, azim: float = -58.0) -> None:
    """Axis labels in `unit` and the viewpoint of a 3D example."""
    for set_label, name in zip((ax.set_xlabel, ax.set_ylabel, ax.set_zlabel), "xyz"):
        set_label(f"{name} ({unit})", labelpad=-2)
    ax.tick_params(labelsize=7, pad=0)
    ax.view_init(elev=elev, azim=azim)


def rectangles_2d(ax, centers, sizes) -> None:
    """Axis-aligned obstacle boxes in the plane."""
    from matplotlib.patches import Rectangle

    for c, s in zip(np.asarray(centers, float).reshape(-1, 2), np.asarray(sizes, float).reshape(-1, 2)):
        ax.add_patch(
            Rectangle(tuple(c - s / 2), s[0], s[1], facecolor=OBSTACLE, alpha=0.85, edgecolor=OBSTACLE_EDGE, lw=0.5)
        )


def bounds_2d(ax, lo, hi) -> None:
    """The state bounds as a dashed outline (the axes may reach past them)."""
    from matplotlib.patches import Rectangle

    ax.add_patch(Rectangle(tuple(lo), hi[0] - lo[0], hi[1] - lo[1], fill=False, ls="--", lw=0.8, edgecolor=BOUNDS))


def path(ax, pts, color, label: str, marks=None) -> None:
    """A path through pts (k, 2 or 3) with its vertices (or `marks`) marked; label names it in the legend."""
    pts = np.asarray(pts, float)
    marks = pts if marks is None else np.asarray(marks, float)
    if ax.name != "3d":
        ax.plot(*pts.T, "-", color=color, lw=1.8)
        ax.plot(*marks.T, "o", color=color, ms=3)
    else:
        from mpl_toolkits.mplot3d.art3d import Line3DCollection

        for a, b in zip(pts[:-1], pts[1:]):
            ax.add_collection3d(Line3DCollection([[a, b]], colors=color, lw=1.8))
        for m in marks:
            ax.scatter(*m, color=color, s=9, depthshade=False)
    ax.plot([], [], "-o", color=color, ms=3, lw=1.8, label=label)  # the legend's entry


def outlines(ax, loops, color) -> None:
    """Closed outlines (n, k, 2) of the robot's body, thin."""
    for o in loops:
        ax.plot(o[:, 0], o[:, 1], color=color, lw=0.7, alpha=0.6)


def endpoints(ax, start, goal) -> None:
    """The start (a disc) and goal (a star) markers."""
    if ax.name != "3d":
        ax.plot(*start, "o", color=START, ms=9, label="start", zorder=5)
        ax.plot(*goal, "*", color=GOAL, ms=14, label="goal", zorder=5)
    else:
        ax.scatter(*start, marker="o", color=START, s=70, depthshade=False, label="start")
        ax.scatter(*goal, marker="*", color=GOAL, s=180, depthshade=False, label="goal")


def limits(ax, drawn: list, bounds=None) -> None:
    """Axis limits holding every drawn point (arrays of (k, d)) and the bounds ((d, 2) or None),
    with a small margin; equal scales on every axis."""
    pts = [np.asarray(p, float).reshape(-1, np.shape(p)[-1]) for p in drawn if np.size(p)]
    d = 3 if ax.name == "3d" else 2
    if bounds is not None:
        b = np.asarray(bounds, float)[:d]
        pts.append(b.T)
    allp = np.concatenate([p[:, :d] for p in pts]) if pts else np.zeros((1, d))
    allp = allp[np.all(np.isfinite(allp), axis=1)]
    lo, hi = allp.min(0), allp.max(0)
    pad = PAD * float(max(hi - lo)) or 1.0
    lo, hi = lo - pad, hi + pad
    for set_lim, a, b in zip((ax.set_xlim, ax.set_ylim, getattr(ax, "set_zlim", None)), lo, hi):
        set_lim(a, b)
    if d == 3:
        ax.set_box_aspect(tuple(hi - lo))
    else:
        ax.set_aspect("equal")
