"""The training dataset of one env on disk: `data.npz` plus the artifact manifest.

data.npz holds
- train_ids (W,), train_centers / train_sizes (W, n_obstacles, wdim): the training workspaces;
- train_clouds (W, n_points, wdim) float32: their obstacle point clouds (Pnet's input);
- ae_clouds (A, n_points, wdim) float32: clouds of further layouts (never a test
  workspace) for the autoencoder, which wants many workspaces;
- path_states (S, sdim), path_offsets (P+1,), path_workspace (P,) (a row of train_ids),
  path_cost (P,), path_raw_cost (P,): the expert paths, and their costs as stored and as
  RRT* gave them (the same unless the paths were contracted: expert_contract).
"""

from __future__ import annotations

import zipfile
import zlib
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from mpnet.data.expert import ExpertPaths, chunks_of, expert_paths, save_chunk, summary
from mpnet.data.store import ArtifactError
from mpnet.envs.scenes.clouds import clouds
from mpnet.envs.scenes.generators import env_split_ids, extra_ids, make_workspaces
from mpnet.envs.spec import EnvSpec
from mpnet.settings import EXPERT

DATA_FILE = "data.npz"
# @4: clouds drawn from the obstacles in their canonical order, seeded by the geometry (Workspace);
# @3: raw RRT* paths unless expert_contract (@2: always contracted)
FORMAT = "mpnet-bench/data@4"


@dataclass
class DataParams:
    """Everything that decides the dataset's content (and so its cache key)."""

    env: str
    data_seed: int
    points_per_block: int
    train_workspaces: int
    paths_per_workspace: int
    ae_workspaces: int
    expert_iterations: int
    expert_max_seconds: float
    expert_blocked_only: bool = EXPERT.blocked_only
    expert_contract: bool = EXPERT.contract
    geometry: dict | None = None  # the env's motion step and planning margin, where it has them
    expert_chunk: int = EXPERT.chunk  # workspaces per expert process (OMPL's RNG is seeded per chunk)
    expert_planner: str = EXPERT.planner  # mpnet.data.expert.EXPERTS
    expert_pairs: str = EXPERT.pairs  # mpnet.data.expert.PAIRS
    expert_check: str = EXPERT.check  # mpnet.data.expert.CHECKS
    expert_run_iterations: int | None = None  # rrt_connect: iterations a run (None: its clock alone)

    def key_config(self) -> dict:
        key = {"format": FORMAT, **self.__dict__}
        if not self.geometry:  # envs without them keep their keys
            key.pop("geometry")
        if key["expert_run_iterations"] is None:  # keys of the datasets built before it existed
            key.pop("expert_run_iterations")
        for name, default in (
            ("expert_chunk", EXPERT.chunk),
            ("expert_planner", EXPERT.planner),
            ("expert_pairs", EXPERT.pairs),
            ("expert_check", EXPERT.check),
        ):
            if key[name] == default:  # keys of the datasets built before these existed
                key.pop(name)
        return key


@dataclass
class Dataset:
    train_ids: np.ndarray
    train_clouds: np.ndarray
    ae_clouds: np.ndarray
    paths: ExpertPaths
    manifest: dict


def expert_paths_of(spec: EnvSpec, p: DataParams, train: list, **kwargs) -> ExpertPaths:
    """Expert paths for the workspaces `train` (listed by index) as the dataset's params say:
    the expert's knobs read from DataParams in one place (the data stage and its benchmark)."""
    return expert_paths(
        spec,
        list(enumerate(train)),
        p.paths_per_workspace,
        p.data_seed,
        p.expert_iterations,
        p.expert_max_seconds,
        blocked_only=p.expert_blocked_only,
        contract=p.expert_contract,
        chunk_size=p.expert_chunk,
        planner=p.expert_planner,
        pairs=p.expert_pairs,
        check=p.expert_check,
        run_iterations=p.expert_run_iterations,
        **kwargs,
    )


def build_dataset(
    spec: EnvSpec,
    p: DataParams,
    folder: Path,
    jobs: int = 2,
    progress=None,
    resume_dir: Path | None = None,
    plan: bool = True,
) -> dict:
    """Write data.npz into folder; returns the manifest fields. resume_dir: where finished
    chunks of expert paths are kept, so that a build cut short resumes; plan=False: every
    chunk must be there already (the merge of a sharded build; MissingChunks otherwise)."""
    train = make_workspaces(spec, env_split_ids(spec, "seen", p.train_workspaces), "train", p.data_seed)
    paths = expert_paths_of(spec, p, train, jobs=jobs, progress=progress, resume_dir=resume_dir, plan=plan)
    extra = make_workspaces(spec, extra_ids(p.ae_workspaces), "extra", p.data_seed)
    total = spec.cloud_size(p.points_per_block)
    arrays = {
        "train_ids": np.array([int(w.id) for w in train]),
        "train_centers": np.stack([w.centers for w in train]),
        "train_sizes": np.stack([w.sizes for w in train]),
        "train_clouds": clouds(train, total, p.data_seed, spec.sample_cloud),
        "ae_clouds": clouds(extra, total, p.data_seed, spec.sample_cloud)
        if extra
        else np.zeros((0, total, spec.workspace_dim), np.float32),
        "path_states": paths.states,
        "path_offsets": paths.offsets,
        "path_workspace": paths.workspace,
        "path_cost": paths.cost,
        "path_raw_cost": paths.raw_cost,
    }
    np.savez_compressed(folder / DATA_FILE, **arrays)
    return {
        "format": FORMAT,
        "files": [DATA_FILE],
        "expert": summary(paths),
        "sizes": {k: list(v.shape) for k, v in arrays.items()},
        "bytes": (folder / DATA_FILE).stat().st_size,
    }


def build_expert_shard(
    spec: EnvSpec, p: DataParams, resume_dir: Path, shard: tuple[int, int], jobs: int = 2, progress=None
) -> ExpertPaths:
    """Shard (i, shards) of the dataset's expert paths, planned into resume_dir (chunks
    already there are kept); build_dataset with the same resume_dir assembles them."""
    ids = env_split_ids(spec, "seen", p.train_workspaces)
    mine = sorted(i for c in chunks_of(len(ids), p.expert_chunk, shard).values() for i in c)
    made = dict(zip(mine, make_workspaces(spec, [ids[i] for i in mine], "train", p.data_seed)))
    train = [made.get(i) for i in range(len(ids))]  # only this shard's workspaces are made
    return expert_paths_of(spec, p, train, jobs=jobs, progress=progress, resume_dir=resume_dir, shard=shard)


def reusable(p: DataParams, config: dict) -> bool:
    """Does a dataset of key config `config` share chunks of expert paths with this one? It
    does when everything but the number of workspaces is the same: workspace i and chunk k's
    OMPL seed depend on (seed, i) and (seed, k) only, so chunk k is the same in both wherever
    it is whole in both."""
    mine = p.key_config()
    return "train_workspaces" in config and {k: v for k, v in config.items() if k != "train_workspaces"} == {
        k: v for k, v in mine.items() if k != "train_workspaces"
    }


def seed_chunks(p: DataParams, other: Dataset, resume_dir: Path) -> int:
    """Write the chunks this dataset shares with another of another size (see reusable)
    into resume_dir, where the build finds them; the rest are planned. Their planning seconds
    and raw states are the other build's means. Returns how many."""
    paths, n = other.paths, 0
    their_n = int(other.manifest["config"]["train_workspaces"])
    expert = other.manifest.get("expert", {})
    per_path = float(expert.get("planning_seconds", 0.0)) / max(len(paths), 1)
    raw_per_path = float(expert.get("raw_states_per_path_mean", 0.0))
    for k, c in chunks_of(p.train_workspaces, p.expert_chunk).items():
        if len(c) < p.expert_chunk or c.stop > their_n or (resume_dir / f"chunk_{k}.npz").exists():
            continue
        idx = np.flatnonzero((paths.workspace >= c.start) & (paths.workspace < c.stop))
        part = _subset(paths, idx)
        part.seconds, part.raw_states = per_path * len(idx), round(raw_per_path * len(idx))
        save_chunk(resume_dir, k, part)
        n += 1
    return n


def _subset(paths: ExpertPaths, idx: np.ndarray) -> ExpertPaths:
    states = [paths.path(i) for i in idx]
    lengths = [len(x) for x in states]
    return ExpertPaths(
        np.concatenate(states) if states else np.zeros((0, paths.states.shape[1])),
        np.concatenate([[0], np.cumsum(lengths)]).astype(np.int64),
        paths.workspace[idx],
        paths.cost[idx],
        paths.raw_cost[idx],
        clock_stops=None,  # a part of another build: its runs' clock stops are not known per path
    )


def load_dataset(folder: Path, manifest: dict) -> Dataset:
    """The dataset in folder; ArtifactError naming data.npz when it cannot be read whole."""
    path = folder / DATA_FILE
    try:
        with np.load(path) as z:
            paths = ExpertPaths(
                z["path_states"],
                z["path_offsets"],
                z["path_workspace"],
                z["path_cost"],
                z["path_raw_cost"],
                clock_stops=None,  # the manifest's `expert` summary says (runs_ended_by_clock)
            )
            return Dataset(z["train_ids"], z["train_clouds"], z["ae_clouds"], paths, manifest)
    except (OSError, ValueError, EOFError, KeyError, zipfile.BadZipFile, zlib.error) as e:
        raise ArtifactError(f"{path}: unreadable ({type(e).__name__}: {_first_line(e)})") from None


def _first_line(e: BaseException) -> str:
    return (str(e).strip().splitlines() or [""])[0]
