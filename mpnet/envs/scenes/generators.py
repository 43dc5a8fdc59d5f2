"""Seeded workspace generators (docs/environments.md); each env names its generator in the registry.

Workspace ids follow the original MPNet split: ids 0-99 are the training workspaces
(the "seen" test split draws from them), ids 100-109 the "unseen" ones. s2d, c2d and
rigid use the original layout file: workspace i holds blocks at the centres of row i.
"""

from __future__ import annotations

from functools import lru_cache
from importlib import resources

import numpy as np

from mpnet.envs.workspace import Workspace

N_TRAIN = 100
N_UNSEEN = 10
C3D_SIZES = [
    [5, 5, 10],
    [5, 10, 5],
    [5, 10, 10],
    [10, 5, 5],
    [10, 5, 10],
    [10, 10, 5],
    [10, 10, 10],
    [5, 5, 5],
    [10, 10, 10],
    [5, 5, 5],
]
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


def split_ids(
    split: str, count: int, sizes: tuple[int, int] = (N_TRAIN, N_UNSEEN), more_seen: bool = False
) -> list[int]:
    """The first `count` workspace ids of a split, for a generator with `sizes` = (training
    workspaces, unseen ones): ids 0.. are training (seen), the unseen ones follow. more_seen:
    the generator makes a workspace of any id, so training goes on past the unseen block
    (n_train + n_unseen, ...) once its n_train are taken: a larger dataset's first n_train
    workspaces are a smaller one's, and the unseen split stays out of training."""
    n_train, n_unseen = sizes
    if split == "seen":
        if count <= n_train:
            return list(range(count))
        if not more_seen:
            raise ValueError(f"the seen split has {n_train} workspaces, {count} asked")
        return list(range(n_train)) + list(range(n_train + n_unseen, count + n_unseen))
    if split == "unseen":
        if count > n_unseen:
            raise ValueError(f"the unseen split has {n_unseen} workspaces, {count} asked")
        return list(range(n_train, n_train + count))
    raise ValueError(f"unknown split {split!r}; choices: seen, unseen")


def split_sizes(spec) -> tuple[int, int]:
    """(training, unseen) workspaces of an env's generator: the original's 100 and 10 unless
    the generator says otherwise (`split_sizes`)."""
    return getattr(spec.generator, "split_sizes", (N_TRAIN, N_UNSEEN))


def env_split_ids(spec, split: str, count: int) -> list[int]:
    """split_ids for an env's generator: its split sizes, and training ids past the unseen
    block where it makes any id (its `more_seen`)."""
    return split_ids(split, count, split_sizes(spec), bool(getattr(spec.generator, "more_seen", False)))


class OriginalLayouts:
    """The original MPNet layout file: workspace i holds blocks at the centres of row i,
    of the given sizes (s2d, rigid: 5 x 5 squares; c2d: its boxes)."""

    def __init__(self, sizes=None):
        self.sizes = None if sizes is None else np.array(sizes, float)

    def make(self, index: int, split: str, seed: int = 0) -> Workspace:
        centres, perm = s2d_layouts()
        c = centres[perm[index]]
        sizes = np.full((len(c), 2), 5.0) if self.sizes is None else self.sizes
        return Workspace(str(index), split, c, sizes)

    def make_many(self, indices: list[int], split: str, seed: int = 0) -> list[Workspace]:
        return [self.make(i, split, seed) for i in indices]


class C3DLayouts:
    """c3d: 10 boxes of the paper's sizes at 10 of 20 seeded centres."""

    def make(self, index: int, split: str, seed: int = 0) -> Workspace:
        return self.make_many([index], split, seed)[0]

    def make_many(self, indices: list[int], split: str, seed: int = 0) -> list[Workspace]:
        if not indices:
            return []
        centres, perm = c3d_layouts(seed, max(N_TRAIN + N_UNSEEN, max(indices) + 1))
        return [Workspace(str(i), split, centres[perm[i]], np.array(C3D_SIZES, float)) for i in indices]


def generator_of(spec):
    """The env's workspace generator; ValueError for an env of problem files only."""
    if spec.generator is None:
        raise ValueError(f"env {spec.name} has no workspace generator: it plans problem files only (problems=...)")
    return spec.generator


def make_workspace(spec, index: int, split: str, seed: int = 0) -> Workspace:
    """Workspace `index` of an env: 0-99 training, 100-109 unseen, beyond: extra layouts
    (point clouds for the autoencoder)."""
    return generator_of(spec).make(index, split, seed)


def make_workspaces(spec, indices: list[int], split: str, seed: int = 0) -> list[Workspace]:
    """Several workspaces at once (c3d draws its layouts once for the largest index)."""
    return generator_of(spec).make_many(indices, split, seed)


def extra_ids(count: int) -> list[int]:
    """Ids of layouts beyond the test splits (never seen or unseen test workspaces)."""
    return list(range(N_TRAIN + N_UNSEEN, N_TRAIN + N_UNSEEN + count))


class RandomBlocks:
    """s2d-like layouts with any number of blocks: `blocks` squares of side `size` at
    uniformly random centres inside `bounds`, seeded by (seed, blocks, index). For
    measuring how planning cost grows with the number of obstacles (harness.perf); the
    envs' own workspaces never come from it."""

    def __init__(self, blocks: int, size: float = 5.0, bounds: float = 20.0):
        if blocks < 1:
            raise ValueError(f"blocks must be >= 1, got {blocks}")
        self.blocks, self.size, self.bounds = int(blocks), float(size), float(bounds)

    def make(self, index: int, split: str, seed: int = 0) -> Workspace:
        rng = np.random.default_rng([seed, self.blocks, index])
        half = self.bounds - self.size / 2
        centres = rng.uniform(-half, half, size=(self.blocks, 2))
        return Workspace(str(index), split, centres, np.full((self.blocks, 2), self.size))

    def make_many(self, indices: list[int], split: str, seed: int = 0) -> list[Workspace]:
        return [self.make(i, split, seed) for i in indices]
