"""Obstacle point clouds, the one home of their sampling and seeding: training and
planning draw a workspace's cloud the same way, so Pnet sees at planning time what it
was trained on."""

from __future__ import annotations

import zlib

import numpy as np

from mpnet.envs.workspace import Workspace


def point_cloud(ws: Workspace, total: int, rng: np.random.Generator) -> np.ndarray:
    """`total` points drawn uniformly inside the obstacles, (total, dim): an equal share
    per block (the first blocks take the remainder), so every workspace of an env gives
    Enet an input of the same size. No obstacles: all points at the origin."""
    n = len(ws.centers)
    if n == 0:
        return np.zeros((total, ws.dim))
    counts = np.full(n, total // n)
    counts[: total % n] += 1
    idx = np.repeat(np.arange(n), counts)
    u = rng.uniform(size=(total, ws.dim))
    return ws.lo[idx] + u * (ws.hi - ws.lo)[idx]


def cloud_rng(seed: int, ws_id: str) -> np.random.Generator:
    """A workspace's cloud depends on the data seed and its id only (a numeric id as the
    number, any other id by its CRC-32)."""
    key = int(ws_id) if str(ws_id).isdigit() else zlib.crc32(str(ws_id).encode())
    return np.random.default_rng([seed, 5, key])


def workspace_cloud(ws: Workspace, total: int, seed: int, sampler=point_cloud) -> np.ndarray:
    """The cloud Enet sees for `ws` (float32, (total, dim))."""
    return sampler(ws, total, cloud_rng(seed, ws.id)).astype(np.float32)


def clouds(workspaces: list[Workspace], total: int, seed: int, sampler=point_cloud) -> np.ndarray:
    """The clouds of several workspaces, stacked: (n, total, dim) float32."""
    return np.stack([workspace_cloud(ws, total, seed, sampler) for ws in workspaces])
