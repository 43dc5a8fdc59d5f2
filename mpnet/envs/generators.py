"""Seeded workspace generators and obstacle point clouds (DESIGN §4).

Workspace ids follow the original MPNet split: ids 0-99 are the training workspaces
(the "seen" test split draws from them), ids 100-109 the "unseen" ones. s2d, c2d and
rigid use the original layout file: workspace i holds blocks at the centres of row i.
"""
from __future__ import annotations

from functools import lru_cache
from importlib import resources

import numpy as np

from mpnet.envs.workspace import EnvSpec, Workspace

N_TRAIN = 100
N_UNSEEN = 10
C2D_SIZES = [[10, 5], [5, 10], [10, 10], [10, 5], [5, 10], [10, 5], [5, 10]]
C3D_SIZES = [[5, 5, 10], [5, 10, 5], [5, 10, 10], [10, 5, 5], [10, 5, 10], [10, 10, 5], [10, 10, 10],
             [5, 5, 5], [10, 10, 10], [5, 5, 5]]
C3D_CANDIDATES = 20


@lru_cache(maxsize=1)
def s2d_layouts() -> tuple[np.ndarray, np.ndarray]:
    """(20 candidate centres, permutation rows) from the original MPNet release."""
    root = resources.files("mpnet") / "data_files" / "mpnet-s2d"
    centres = np.frombuffer((root / "obs.dat").read_bytes(), dtype="<f8")[:40].reshape(20, 2).copy()
    perm = np.frombuffer((root / "obs_perm2.dat").read_bytes(), dtype="<i4").reshape(-1, 7)
    return centres, perm


@lru_cache(maxsize=4)
def c3d_layouts(seed: int, count: int = N_TRAIN + N_UNSEEN) -> tuple[np.ndarray, np.ndarray]:
    """20 centres in the inner 30^3 and `count` distinct sorted 10-subsets of them, seeded.
    Rows are drawn in sequence, so the first 110 never depend on `count`."""
    rng = np.random.default_rng([seed, 3])
    centres = rng.uniform(-15.0, 15.0, size=(C3D_CANDIDATES, 3))
    rows, seen = [], set()
    while len(rows) < count:
        row = tuple(sorted(rng.choice(C3D_CANDIDATES, size=len(C3D_SIZES), replace=False).tolist()))
        if row not in seen:
            seen.add(row)
            rows.append(row)
    return centres, np.array(rows)


def split_ids(split: str, count: int) -> list[int]:
    """The first `count` workspace ids of a split."""
    if split == "seen":
        if count > N_TRAIN:
            raise ValueError(f"the seen split has {N_TRAIN} workspaces, {count} asked")
        return list(range(count))
    if split == "unseen":
        if count > N_UNSEEN:
            raise ValueError(f"the unseen split has {N_UNSEEN} workspaces, {count} asked")
        return list(range(N_TRAIN, N_TRAIN + count))
    raise ValueError(f"unknown split {split!r}; choices: seen, unseen")


def make_workspace(spec: EnvSpec, index: int, split: str, seed: int = 0) -> Workspace:
    """Workspace `index` of an env: 0-99 training, 100-109 unseen, beyond: extra layouts
    (point clouds for the autoencoder)."""
    if spec.name == "c3d":
        centres, perm = c3d_layouts(seed, max(N_TRAIN + N_UNSEEN, index + 1))
        return Workspace(str(index), split, centres[perm[index]], np.array(C3D_SIZES, float))
    centres, perm = s2d_layouts()
    c = centres[perm[index]]
    if spec.name == "c2d":
        sizes = np.array(C2D_SIZES, float)
    else:
        sizes = np.full((len(c), 2), 5.0)
    return Workspace(str(index), split, c, sizes)


def make_workspaces(spec: EnvSpec, indices: list[int], split: str, seed: int = 0) -> list[Workspace]:
    """Several workspaces at once (c3d draws its layouts once for the largest index)."""
    if spec.name == "c3d" and indices:
        centres, perm = c3d_layouts(seed, max(N_TRAIN + N_UNSEEN, max(indices) + 1))
        return [Workspace(str(i), split, centres[perm[i]], np.array(C3D_SIZES, float)) for i in indices]
    return [make_workspace(spec, i, split, seed) for i in indices]


def extra_ids(count: int) -> list[int]:
    """Ids of layouts beyond the test splits (never seen or unseen test workspaces)."""
    return list(range(N_TRAIN + N_UNSEEN, N_TRAIN + N_UNSEEN + count))


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
