"""What a depth camera at a fixed viewpoint sees of a 3D workspace's obstacles (issue 26: the
paper's arm cloud came from a Kinect). Rays through a pixel grid are cast against the posed
primitives; each ray's nearest hit is a point. The surfaces facing away from the camera, and
whatever another obstacle hides, are not in the cloud (the robot is not in the scene).

Ray casting is written here in numpy (one array operation per primitive for all rays; a box's
is the point checker's slab test, compiled: mpnet.envs.geometry): a renderer or pybullet's
rayTestBatch would need a world per cloud, for a few dozen shapes.
"""

from __future__ import annotations

import numpy as np

from mpnet.envs.shapes import Primitive
from mpnet.envs.workspace import Workspace

# A Kinect v2's field of view (70 x 60 degrees) at a quarter of its depth resolution,
# behind and above the arm's base, looking at the space in front of it.
POSITION = np.array([-0.4, 0.0, 1.3])
TARGET = np.array([0.7, 0.0, 0.2])
FOV_DEG = (70.0, 60.0)
PIXELS = (128, 106)


def rays(position=POSITION, target=TARGET, fov_deg=FOV_DEG, pixels=PIXELS) -> np.ndarray:
    """Unit directions through the pixel centres, (w * h, 3), in the base frame."""
    forward = np.asarray(target, float) - position
    forward /= np.linalg.norm(forward)
    right = np.cross(forward, [0.0, 0.0, 1.0])
    right /= np.linalg.norm(right)
    up = np.cross(right, forward)
    w, h = pixels
    u = np.tan(np.radians(fov_deg[0]) / 2) * ((np.arange(w) + 0.5) / w * 2 - 1)
    v = np.tan(np.radians(fov_deg[1]) / 2) * ((np.arange(h) + 0.5) / h * 2 - 1)
    uu, vv = np.meshgrid(u, v)
    d = forward + uu.reshape(-1, 1) * right + vv.reshape(-1, 1) * up
    return d / np.linalg.norm(d, axis=1, keepdims=True)


def _box(o, d, half) -> np.ndarray:
    """Where each ray from o (3,) along d (n, 3) enters the box of half extents `half` about the
    origin (inf: never, or from inside): mpnet.envs.geometry's slab test."""
    from mpnet.envs.geometry import ray_entries  # numba: loaded by a camera cloud only

    out = np.empty(len(d))
    ray_entries(np.ascontiguousarray(o, float), np.ascontiguousarray(d, float), -half[None], half[None], out)
    return out


def _sphere(o, d, r) -> np.ndarray:
    b = np.sum(o * d, axis=1)
    disc = b * b - (np.sum(o * o, axis=1) - r * r)
    t = -b - np.sqrt(np.maximum(disc, 0.0))
    return np.where((disc >= 0) & (t > 0), t, np.inf)


def _cylinder(o, d, r, half) -> np.ndarray:
    a = d[:, 0] ** 2 + d[:, 1] ** 2
    b = o[:, 0] * d[:, 0] + o[:, 1] * d[:, 1]
    c = o[:, 0] ** 2 + o[:, 1] ** 2 - r * r
    disc = b * b - a * c
    with np.errstate(divide="ignore", invalid="ignore"):
        side = (-b - np.sqrt(np.maximum(disc, 0.0))) / a
        side = np.where((disc >= 0) & (a > 0) & (side > 0) & (np.abs(o[:, 2] + side * d[:, 2]) <= half), side, np.inf)
        caps = np.stack([(half - o[:, 2]) / d[:, 2], (-half - o[:, 2]) / d[:, 2]], axis=1)
        x = o[:, None, 0] + caps * d[:, None, 0]
        y = o[:, None, 1] + caps * d[:, None, 1]
        caps = np.where((caps > 0) & (x * x + y * y <= r * r), caps, np.inf)
    return np.minimum(side, np.nanmin(caps, axis=1))


def depth(primitives: list[Primitive], origin: np.ndarray, directions: np.ndarray) -> np.ndarray:
    """Distance along each ray to the nearest primitive (inf: none), (n,)."""
    best = np.full(len(directions), np.inf)
    for p in primitives:
        R = p.rotation()
        at = (origin - np.asarray(p.center)) @ R
        o = np.broadcast_to(at, directions.shape)
        d = directions @ R
        size = np.asarray(p.size)
        if p.type == "box":
            t = _box(at, d, size / 2)
        elif p.type == "sphere":
            t = _sphere(o, d, size[0] / 2)
        else:
            t = _cylinder(o, d, size[0] / 2, size[2] / 2)
        best = np.minimum(best, t)
    return best


def camera_cloud(ws: Workspace, total: int, rng: np.random.Generator) -> np.ndarray:
    """`total` of the points the camera sees (drawn with replacement when it sees fewer),
    (total, 3); all at the origin when it sees nothing."""
    directions = rays()
    t = depth(ws.all_primitives(), POSITION, directions)
    hit = np.isfinite(t)
    if not hit.any():
        return np.zeros((total, 3))
    points = POSITION + t[hit, None] * directions[hit]
    return points[rng.choice(len(points), size=total, replace=len(points) < total)]
