"""Expert paths for training Pnet: OMPL's RRT* for a fixed number of iterations (or another
of mpnet.data.expert_planners); its raw vertex list (exact duplicates removed), as the
original trained on, or with `contract` lazy states contraction (a greedy exact shortcut);
then the fine re-check.

An iteration budget, not a time budget, keeps the paths reproducible (RRT-Connect's with
`run_iterations`; without it a run's clock decides, which a build counts and warns of): each chunk of
workspaces runs in a fresh process whose OMPL RNG is seeded from (data seed, chunk), so
the same config gives the same paths on any machine and with any number of processes,
and a build sharded over a cluster (chunk k is shard k % shards's) gives the same paths as
one build.
"""

from __future__ import annotations

import itertools
import math
import os
import time
import uuid
import zipfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from mpnet.data.expert_planners import EXPERTS, PROCESS_SEEDED, dedupe
from mpnet.envs.spec import EnvSpec, random_pairs
from mpnet.envs.workspace import Workspace
from mpnet.motion import lazy_states_contraction, path_cost, verify_path
from mpnet.settings import EXPERT


@dataclass
class ExpertPaths:
    """Paths of one or more workspaces, flattened: states[offsets[i]:offsets[i+1]] is path i."""

    states: np.ndarray
    offsets: np.ndarray
    workspace: np.ndarray
    cost: np.ndarray
    raw_cost: np.ndarray
    seconds: float = 0.0
    raw_states: int = 0  # states of the RRT* paths before contraction (== len(states) without it)
    # expert runs that ended on their clock (max_seconds), not their own count: where it is above
    # 0 the paths depend on the machine's speed and load, and another build under the same key
    # may keep others (FINDINGS, issue 42); None: not known (chunks taken from another dataset)
    clock_stops: int | None = 0

    def __len__(self) -> int:
        return len(self.workspace)

    def path(self, i: int) -> np.ndarray:
        return self.states[self.offsets[i] : self.offsets[i + 1]]

    def paths(self) -> list[np.ndarray]:
        return [self.path(i) for i in range(len(self))]

    @staticmethod
    def of(
        paths: list[np.ndarray],
        workspace,
        cost,
        raw_cost,
        state_dim: int,
        seconds: float = 0.0,
        raw_states: int = 0,
        clock_stops: int | None = 0,
    ) -> ExpertPaths:
        """The paths (each (n_i, state_dim)) flattened, with their workspace rows and costs."""
        lengths = [len(p) for p in paths]
        return ExpertPaths(
            np.concatenate(paths) if paths else np.zeros((0, state_dim)),
            np.concatenate([[0], np.cumsum(lengths)]).astype(np.int64),
            np.asarray(workspace, np.int64).reshape(-1),
            np.asarray(cost, float).reshape(-1),
            np.asarray(raw_cost, float).reshape(-1),
            seconds,
            raw_states,
            clock_stops,
        )

    @staticmethod
    def concat(parts: list[ExpertPaths], state_dim: int) -> ExpertPaths:
        if not parts:
            return ExpertPaths(
                np.zeros((0, state_dim)), np.zeros(1, np.int64), np.zeros(0, np.int64), np.zeros(0), np.zeros(0)
            )
        lengths = np.concatenate([np.diff(p.offsets) for p in parts])
        return ExpertPaths(
            np.concatenate([p.states for p in parts]),
            np.concatenate([[0], np.cumsum(lengths)]).astype(np.int64),
            np.concatenate([p.workspace for p in parts]).astype(np.int64),
            np.concatenate([p.cost for p in parts]),
            np.concatenate([p.raw_cost for p in parts]),
            sum(p.seconds for p in parts),
            sum(p.raw_states for p in parts),
            None if any(p.clock_stops is None for p in parts) else sum(p.clock_stops for p in parts),
        )


# Where expert paths' start/goal pairs come from: the env's own (its test queries' kind:
# MotionBenchMaker's for panda_mbm, uniform states elsewhere), or uniform valid states in any
# env (arm7's recipe on panda_mbm's scenes: no IK, every part of the joint space).
PAIRS = {"env": lambda spec: spec.pairs, "uniform": lambda spec: random_pairs}


def planner_check(spec: EnvSpec, ws: Workspace, checker, path, start, goal) -> bool:
    """The path's ends, bounds, states and motions by the planning checker itself."""
    p = np.asarray(path, float)
    if p.ndim != 2 or len(p) < 2 or not np.all(np.isfinite(p)) or np.abs(p[[0, -1]] - [start, goal]).max() > 1e-6:
        return False
    return all(spec.in_bounds(q) and checker.is_valid(q.tolist()) for q in p) and all(
        checker.motion_valid(a.tolist(), b.tolist()) for a, b in zip(p[:-1], p[1:])
    )


def judge_check(spec: EnvSpec, ws: Workspace, checker, path, start, goal) -> bool:
    return verify_path(spec, ws, path, start, goal) is None


# What an expert path must pass to be kept (env.expert.check).
CHECKS = {"judge": judge_check, "planner": planner_check}


def workspace_paths(
    spec: EnvSpec,
    ws: Workspace,
    ws_index: int,
    count: int,
    seed: int,
    iterations: int,
    max_seconds: float,
    blocked_only: bool = EXPERT.blocked_only,
    max_tries: int = 50,
    contract: bool = EXPERT.contract,
    planner: str = EXPERT.planner,
    pairs: str = EXPERT.pairs,
    check: str = EXPERT.check,
    run_iterations: int | None = None,
) -> ExpertPaths:
    """`count` expert paths between valid start/goal pairs of one workspace (PAIRS: the env's
    own, random states or MotionBenchMaker's queries, or uniform); fewer when they run out.

    blocked_only keeps the pairs whose straight line is blocked, as every test query's
    is: a free pair only teaches Pnet to step onto the goal. contract: lazy states
    contraction of each path (off: RRT*'s vertex list, as the paper trained on). planner:
    rrt_star (`iterations` iterations), or rrt_connect (the best of `iterations` shortened
    runs, see rrt_connect_path). check (CHECKS): what a path must pass to be kept: the
    judge's fine re-check (verify_path), or the planning checker's own states and motions
    (the arm's certified spheres: pybullet's re-check, sampled at the validation step, is a
    large part of the arm expert's work, and stays the judge of logged results).
    run_iterations: rrt_connect's budget a run (see rrt_connect_path)."""
    t0 = time.perf_counter()
    rng = np.random.default_rng([seed, 7, ws_index])
    checker = spec.make_checker(ws)
    states, costs, raws, raw_states, clock = [], [], [], 0, []
    for s, g in itertools.islice(PAIRS[pairs](spec)(spec, ws, checker, rng), count * max_tries):
        if len(states) == count:
            break
        if not (checker.is_valid(s.tolist()) and checker.is_valid(g.tolist())):
            continue
        if blocked_only and checker.motion_valid(s.tolist(), g.tolist()):
            continue
        path = EXPERTS[planner](spec, checker, s, g, iterations, max_seconds, clock, run_iterations)
        if path is None:
            continue
        path = dedupe(path)
        raw, n_raw = path_cost(spec, path), len(path)
        if contract:
            path = lazy_states_contraction(checker, path)
        if len(path) < 2 or not CHECKS[check](spec, ws, checker, path, s, g):
            continue
        raw_states += n_raw
        states.append(np.asarray(path, float))
        costs.append(path_cost(spec, path))
        raws.append(raw)
    workspace = [ws_index] * len(states)
    seconds = time.perf_counter() - t0
    return ExpertPaths.of(states, workspace, costs, raws, spec.state_dim, seconds, raw_states, len(clock))


def chunk_worker(args: tuple) -> ExpertPaths:
    """One chunk of workspaces: seeds OMPL (an expert that draws on its RNG runs each chunk in a
    fresh process: PROCESS_SEEDED), then plans every path (workspace_paths' options by name)."""
    spec, workspaces, count, seed, chunk, options = args
    from mpnet.envs.ompl_space import seed_worker

    seed_worker(seed, 11, chunk, seeded=options.get("planner", EXPERT.planner) in PROCESS_SEEDED)
    return ExpertPaths.concat(
        [workspace_paths(spec, ws, idx, count, seed, **options) for idx, ws in workspaces],
        spec.state_dim,
    )


class MissingChunks(Exception):
    """A build asked to plan nothing (the merge of a sharded build) found chunks missing."""

    def __init__(self, missing: list[int], chunks: int):
        super().__init__(f"{len(missing)} of {chunks} chunks of expert paths missing: {missing}")
        self.missing, self.chunks = missing, chunks


def chunks_of(n: int, chunk_size: int = 1, shard: tuple[int, int] | None = None) -> dict[int, range]:
    """The chunks (index ranges of the n workspaces) a build plans, by chunk number; with
    shard=(i, shards), those of shard i: chunk k is shard k % shards's, so that the shards
    of a build get the same number of chunks give or take one."""
    chunks = {k: range(i, min(i + chunk_size, n)) for k, i in enumerate(range(0, n, chunk_size))}
    if shard is None:
        return chunks
    i, shards = shard
    return {k: c for k, c in chunks.items() if k % shards == i}


def expert_paths(
    spec: EnvSpec,
    workspaces: list[tuple[int, Workspace]],
    count: int,
    seed: int,
    iterations: int,
    max_seconds: float,
    jobs: int = 2,
    chunk_size: int = 1,
    progress=None,
    blocked_only: bool = EXPERT.blocked_only,
    contract: bool = EXPERT.contract,
    resume_dir: Path | None = None,
    shard: tuple[int, int] | None = None,
    plan: bool = True,
    planner: str = EXPERT.planner,
    pairs: str = EXPERT.pairs,
    check: str = EXPERT.check,
    run_iterations: int | None = None,
) -> ExpertPaths:
    """Expert paths for every (index, workspace), in worker processes: a fresh one per chunk
    where the expert draws on OMPL's process-wide RNG (PROCESS_SEEDED), else long-lived ones
    (a process start, ~2 s of imports and kernels loaded, was a third of the compiled expert's
    build); the same paths either way.

    `progress(n)` is called with the number of workspaces each finished chunk held.
    resume_dir: each finished chunk is saved there, and chunks found there are not planned
    again (the folder must belong to these arguments: the artifact store keys it).
    shard=(i, shards): only shard i's chunks (see chunks_of); plan=False: plan nothing,
    read every chunk from resume_dir (MissingChunks if some are not there)."""
    chunks = chunks_of(len(workspaces), chunk_size, shard)
    options = {
        "iterations": iterations,
        "max_seconds": max_seconds,
        "blocked_only": blocked_only,
        "contract": contract,
        "planner": planner,
        "pairs": pairs,
        "check": check,
        "run_iterations": run_iterations,
    }
    tasks = {k: (spec, [workspaces[i] for i in c], count, seed, k, options) for k, c in chunks.items()}
    results: dict[int, ExpertPaths | None] = {}
    for k in tasks:  # chunks a build cut short (or the other shards) already finished
        results[k] = _load_chunk(resume_dir, k)
        if results[k] is not None and progress is not None:
            progress(len(chunks[k]))
    todo = [k for k in tasks if results[k] is None]
    if todo and not plan:
        raise MissingChunks(todo, len(chunks_of(len(workspaces), chunk_size)))

    def done(k: int, paths: ExpertPaths) -> None:
        results[k] = paths
        save_chunk(resume_dir, k, paths)
        if progress is not None:
            progress(len(chunks[k]))

    in_processes(chunk_worker, {k: tasks[k] for k in todo}, jobs, done, fresh=planner in PROCESS_SEEDED)
    return ExpertPaths.concat([results[k] for k in sorted(results)], spec.state_dim)


def in_processes(worker, tasks: dict, jobs: int, done, fresh: bool = True) -> None:
    """worker(tasks[k]) for every k, each in a fresh spawned process (OMPL's RNG is seeded per
    task, and a process start costs less than state left behind; fresh=False: spawned workers
    that run task after task), at most `jobs` at a time; done(k, result) as each finishes."""
    from concurrent.futures import as_completed

    from mpnet.workers import process_pool

    if not tasks:
        return
    with process_pool(min(jobs, len(tasks)), max_tasks_per_child=1 if fresh else None) as pool:
        futures = {pool.submit(worker, args): k for k, args in tasks.items()}
        for fut in as_completed(futures):
            done(futures[fut], fut.result())


_FIELDS = ("states", "offsets", "workspace", "cost", "raw_cost")


def save_chunk(folder: Path | None, k: int, paths: ExpertPaths) -> None:
    if folder is None:
        return
    folder.mkdir(parents=True, exist_ok=True)
    tmp = folder / f".chunk_{k}.{uuid.uuid4().hex[:8]}.tmp.npz"  # two jobs of one shard (a requeue) never share it
    stops = -1 if paths.clock_stops is None else paths.clock_stops  # -1: not known
    np.savez(
        tmp,
        seconds=paths.seconds,
        raw_states=paths.raw_states,
        clock_stops=stops,
        **{f: getattr(paths, f) for f in _FIELDS},
    )
    os.replace(tmp, folder / f"chunk_{k}.npz")


def _load_chunk(folder: Path | None, k: int) -> ExpertPaths | None:
    path = None if folder is None else folder / f"chunk_{k}.npz"
    if path is None or not path.exists():
        return None
    try:
        with np.load(path) as z:
            stops = int(z["clock_stops"]) if "clock_stops" in z.files else -1  # a chunk from before the count
            return ExpertPaths(
                *(z[f] for f in _FIELDS), float(z["seconds"]), int(z["raw_states"]), None if stops < 0 else stops
            )
    except (OSError, ValueError, KeyError, EOFError, zipfile.BadZipFile):  # a damaged piece is planned again
        return None


def summary(paths: ExpertPaths) -> dict:
    """Figures for the manifest: how many, how long, how good."""
    n = len(paths)
    states = np.diff(paths.offsets) if n else np.zeros(0)
    return {
        "paths": n,
        "states_per_path_mean": float(states.mean()) if n else math.nan,
        "raw_states_per_path_mean": paths.raw_states / n if n else math.nan,
        "cost_mean": float(paths.cost.mean()) if n else math.nan,
        "raw_cost_mean": float(paths.raw_cost.mean()) if n else math.nan,
        "planning_seconds": float(paths.seconds),
        "runs_ended_by_clock": paths.clock_stops,  # > 0: the paths depend on the machine (ExpertPaths)
    }
