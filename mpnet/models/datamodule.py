"""Lightning DataModules over in-memory numpy arrays.

- :class:`MPNetDataModule`: Pnet's samples ``(workspace, x_t, x_goal, x_next)``; a batch is a
  dict ``{"clouds": (k, D), "ws": (B,), "x_t", "x_goal", "x_next": (B, state_dim)}`` where
  ``clouds`` holds each distinct workspace of the batch once and ``ws`` indexes into it
  (``features="codes"``: per-workspace Enet codes instead of clouds, under the key ``codes``).
- :class:`CloudDataModule`: flattened point clouds for the autoencoder; a batch is (B, D).
- Their samples come from :func:`mpnet.models.pairs.waypoint_pairs` (expert paths -> Pnet samples).

All values stay raw (workspace coordinates); the LightningModules normalise. The train/val
split is a pure function of ``seed`` (and ``groups``, when given: whole groups, e.g. whole
paths, go to one side). Batches are gathered with one tensor index per batch
(``__getitems__``), not per sample.
"""

from __future__ import annotations

from collections.abc import Sequence

import lightning as L
import numpy as np
import torch
from torch.utils.data import DataLoader, Dataset, Sampler

from mpnet.models.pairs import split_indices


def _identity(batch):
    return batch


class PairDataset(Dataset):
    """Pnet samples over shared tensors; ``rows`` selects this split's samples."""

    def __init__(
        self,
        clouds: torch.Tensor,
        ws: torch.Tensor,
        x_t: torch.Tensor,
        x_goal: torch.Tensor,
        x_next: torch.Tensor,
        rows: np.ndarray,
        key: str = "clouds",
    ):
        self.clouds, self.ws, self.x_t, self.x_goal, self.x_next = clouds, ws, x_t, x_goal, x_next
        self.rows = torch.as_tensor(rows, dtype=torch.long)
        self.key = key

    def __len__(self) -> int:
        return len(self.rows)

    def __getitems__(self, indices: Sequence[int]) -> dict[str, torch.Tensor]:
        r = self.rows[torch.as_tensor(indices, dtype=torch.long)]
        uniq, inverse = torch.unique(self.ws[r], return_inverse=True)
        return {
            self.key: self.clouds[uniq],
            "ws": inverse,
            "wsid": uniq,  # the batch's workspaces as rows of the data (a collision loss finds their scenes)
            "x_t": self.x_t[r],
            "x_goal": self.x_goal[r],
            "x_next": self.x_next[r],
        }

    def __getitem__(self, i: int) -> dict[str, torch.Tensor]:
        return self.__getitems__([i])


class SceneBatches(Sampler):
    """Training batches that each draw on about ``scenes`` workspaces (a recipe-free training
    knob, ``scale.fit.scenes_per_batch``): each epoch the workspaces are shuffled into groups of
    ``scenes``, each group's samples shuffled together, and the concatenation cut into batches
    of ``batch_size``, so a batch spans one group (two at a boundary) where a group holds more
    samples than a batch (e.g. 10 arm scenes of ~230 samples, batches of 100). An end-to-end Enet then
    encodes a few clouds a batch instead of about one a sample; the epoch still sees every
    sample once. Draws one seed per epoch from torch's generator, when iteration starts (as
    torch's RandomSampler does, so a resumed fit draws what one run straight through does)."""

    def __init__(self, workspace: np.ndarray, batch_size: int, scenes: int):
        if scenes < 1:
            raise ValueError(f"scenes_per_batch must be a positive integer, got {scenes}")
        self.batch_size, self.scenes = int(batch_size), int(scenes)
        self.uniq, self.scene_of = np.unique(np.asarray(workspace), return_inverse=True)

    def __len__(self) -> int:
        return -(-len(self.scene_of) // self.batch_size)

    def __iter__(self):
        seed = int(torch.empty((), dtype=torch.int64).random_().item())
        rng = np.random.default_rng(seed)
        group = rng.permutation(len(self.uniq)) // self.scenes  # each workspace's group
        order = np.argsort(group[self.scene_of] + rng.random(len(self.scene_of)), kind="stable")
        for i in range(0, len(order), self.batch_size):
            yield order[i : i + self.batch_size].tolist()


class CloudDataset(Dataset):
    def __init__(self, clouds: torch.Tensor, rows: np.ndarray):
        self.clouds = clouds
        self.rows = torch.as_tensor(rows, dtype=torch.long)

    def __len__(self) -> int:
        return len(self.rows)

    def __getitems__(self, indices: Sequence[int]) -> torch.Tensor:
        return self.clouds[self.rows[torch.as_tensor(indices, dtype=torch.long)]]

    def __getitem__(self, i: int) -> torch.Tensor:
        return self.clouds[self.rows[i]]


def _float_tensor(a, name: str, ndim: int) -> torch.Tensor:
    a = np.asarray(a)
    if a.ndim != ndim:
        raise ValueError(f"{name} must be {ndim}-D, got shape {a.shape}")
    if not np.issubdtype(a.dtype, np.number) or not np.all(np.isfinite(a)):
        raise ValueError(f"{name} must be finite numbers")
    return torch.from_numpy(np.ascontiguousarray(a, dtype=np.float32))


class _Base(L.LightningDataModule):
    def __init__(self, batch_size: int, val_fraction: float, seed: int, num_workers: int):
        super().__init__()
        if batch_size < 1:
            raise ValueError(f"batch_size must be positive, got {batch_size}")
        self.batch_size = int(batch_size)
        self.val_fraction = float(val_fraction)
        self.seed = int(seed)
        self.num_workers = int(num_workers)
        self.train_set: Dataset | None = None
        self.val_set: Dataset | None = None

    def _loader(self, ds: Dataset, shuffle: bool) -> DataLoader:
        sampler = self.batch_sampler(ds) if shuffle else None
        if sampler is not None:
            return DataLoader(
                ds,
                batch_sampler=sampler,
                collate_fn=_identity,
                num_workers=self.num_workers,
                persistent_workers=self.num_workers > 0,
            )
        return DataLoader(
            ds,
            batch_size=self.batch_size,
            shuffle=shuffle,
            collate_fn=_identity,
            num_workers=self.num_workers,
            persistent_workers=self.num_workers > 0,
        )

    def batch_sampler(self, ds: Dataset) -> Sampler | None:
        """The training batches' sampler; None: torch's shuffle."""
        return None

    def train_dataloader(self) -> DataLoader:
        if self.train_set is None:
            self.setup("fit")
        return self._loader(self.train_set, shuffle=True)

    def val_dataloader(self):
        if self.val_set is None:
            self.setup("fit")
        if len(self.val_set) == 0:
            return []
        return self._loader(self.val_set, shuffle=False)


class MPNetDataModule(_Base):
    """Pnet's samples: ``clouds`` (n_ws, n_points * wdim) float32, point-major; sample ``i`` is
    ``(clouds[ws_index[i]], x_t[i], x_goal[i]) -> x_next[i]``. ``groups`` (optional, one id per
    sample, e.g. the path id) keeps whole groups on one side of the split.

    ``features="codes"``: ``clouds`` holds each workspace's Enet code instead (a frozen
    encoder's codes never change, so encoding them once saves most of Pnet's training time
    when batches span many workspaces); ``features="grids"``: each workspace's voxel occupancy
    (a voxel Enet's input, computed once: ``PnetModule.grids``). ``scenes_per_batch``: each
    training batch drawn from about that many workspaces (:class:`SceneBatches`); None: shuffled
    over all samples, the public code's batches."""

    def __init__(
        self,
        clouds: np.ndarray,
        ws_index: np.ndarray,
        x_t: np.ndarray,
        x_goal: np.ndarray,
        x_next: np.ndarray,
        batch_size: int = 100,
        val_fraction: float = 0.1,
        seed: int = 0,
        num_workers: int = 0,
        groups: np.ndarray | None = None,
        features: str = "clouds",
        scenes_per_batch: int | None = None,
    ):
        super().__init__(batch_size, val_fraction, seed, num_workers)
        if scenes_per_batch is not None and (isinstance(scenes_per_batch, bool) or int(scenes_per_batch) < 1):
            raise ValueError(f"scenes_per_batch must be a positive integer, got {scenes_per_batch!r}")
        self.scenes_per_batch = None if scenes_per_batch is None else int(scenes_per_batch)
        if features not in ("clouds", "codes", "grids"):
            raise ValueError(f"features must be 'clouds', 'codes' or 'grids', got {features!r}")
        self.features = features
        self.clouds = _float_tensor(clouds, features, 2)
        ws = np.asarray(ws_index)
        if ws.ndim != 1 or not np.issubdtype(ws.dtype, np.integer):
            raise ValueError(f"ws_index must be a 1-D integer array, got {ws.dtype} {ws.shape}")
        if ws.size and (ws.min() < 0 or ws.max() >= len(self.clouds)):
            raise ValueError(f"ws_index out of range for {len(self.clouds)} clouds")
        self.ws = torch.from_numpy(ws.astype(np.int64))
        self.x_t = _float_tensor(x_t, "x_t", 2)
        self.x_goal = _float_tensor(x_goal, "x_goal", 2)
        self.x_next = _float_tensor(x_next, "x_next", 2)
        n = len(self.ws)
        for name, a in (("x_t", self.x_t), ("x_goal", self.x_goal), ("x_next", self.x_next)):
            if a.shape != (n, self.x_t.shape[1]):
                raise ValueError(f"{name} has shape {tuple(a.shape)}, expected ({n}, state_dim)")
        if n == 0:
            raise ValueError("no samples")
        self.train_indices, self.val_indices = split_indices(n, self.val_fraction, self.seed, groups)

    def batch_sampler(self, ds: Dataset) -> Sampler | None:
        if self.scenes_per_batch is None:
            return None
        return SceneBatches(self.ws[ds.rows].numpy(), self.batch_size, self.scenes_per_batch)

    @property
    def state_dim(self) -> int:
        return int(self.x_t.shape[1])

    @property
    def cloud_dim(self) -> int:
        return int(self.clouds.shape[1])

    def setup(self, stage: str | None = None) -> None:
        args = (self.clouds, self.ws, self.x_t, self.x_goal, self.x_next)
        self.train_set = PairDataset(*args, self.train_indices, key=self.features)
        self.val_set = PairDataset(*args, self.val_indices, key=self.features)


class CloudDataModule(_Base):
    """Flattened point clouds (n_ws, n_points * wdim) for the autoencoder; split by workspace."""

    def __init__(
        self, clouds: np.ndarray, batch_size: int = 100, val_fraction: float = 0.1, seed: int = 0, num_workers: int = 0
    ):
        super().__init__(batch_size, val_fraction, seed, num_workers)
        self.clouds = _float_tensor(clouds, "clouds", 2)
        if len(self.clouds) == 0:
            raise ValueError("no clouds")
        self.train_indices, self.val_indices = split_indices(len(self.clouds), self.val_fraction, self.seed)

    @property
    def cloud_dim(self) -> int:
        return int(self.clouds.shape[1])

    def setup(self, stage: str | None = None) -> None:
        self.train_set = CloudDataset(self.clouds, self.train_indices)
        self.val_set = CloudDataset(self.clouds, self.val_indices)


__all__ = [
    "MPNetDataModule",
    "CloudDataModule",
    "PairDataset",
    "SceneBatches",
    "CloudDataset",
]
