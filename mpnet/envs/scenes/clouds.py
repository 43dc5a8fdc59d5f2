"""Obstacle point clouds, the one home of their sampling and seeding: training and
planning draw a workspace's cloud the same way, so Pnet sees at planning time what it
was trained on."""

from __future__ import annotations

import numpy as np

from mpnet.envs.workspace import Workspace
from mpnet.jit import njit


def point_cloud(ws: Workspace, total: int, rng: np.random.Generator) -> np.ndarray:
    """`total` points drawn uniformly inside the obstacles, (total, dim): an equal share
    per block (the first blocks take the remainder), so every workspace of an env gives
    Enet an input of the same size. No obstacles: all points at the origin.

    Compiled (planning draws it per query, inside the query's time): numpy's
    `lo[idx] + rng.uniform(size=(total, dim)) * (hi - lo)[idx]`, draw for draw."""
    n = len(ws.centers)
    if n == 0:
        return np.zeros((total, ws.dim))
    out = np.empty((total, ws.dim))
    _point_cloud(np.ascontiguousarray(ws.lo, float), np.ascontiguousarray(ws.hi, float), rng, out)
    return out


@njit(cache=True)
def _point_cloud(lo, hi, rng, out):
    """Block i takes total // n points (the first total % n one more), each coordinate
    lo + U * (hi - lo) with U the Generator's next double: uniform(0, 1)'s draw, in row order."""
    n, dim = lo.shape
    total = out.shape[0]
    r = 0
    for i in range(n):
        for _ in range(total // n + (1 if i < total % n else 0)):
            for k in range(dim):
                out[r, k] = lo[i, k] + rng.random() * (hi[i, k] - lo[i, k])
            r += 1


def cloud_rng(seed: int, ws: Workspace) -> np.random.Generator:
    """A workspace's cloud depends on the data seed and its geometry only (Workspace.geometry_key:
    its obstacles in their canonical order), not on its id or the order a file lists them in."""
    return np.random.default_rng([seed, 6, ws.geometry_key()])


def workspace_cloud(ws: Workspace, total: int, seed: int, sampler=point_cloud) -> np.ndarray:
    """The cloud Enet sees for `ws` (float32, (total, dim))."""
    return sampler(ws, total, cloud_rng(seed, ws)).astype(np.float32)


def clouds(workspaces: list[Workspace], total: int, seed: int, sampler=point_cloud) -> np.ndarray:
    """The clouds of several workspaces, stacked: (n, total, dim) float32."""
    return np.stack([workspace_cloud(ws, total, seed, sampler) for ws in workspaces])
