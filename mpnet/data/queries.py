"""Seeded test sets: the workspaces of each split and their queries.

A test query's start and goal are valid, its straight line is blocked (trivial queries
say nothing, and one of OMPL's planners hung on them), and RRT-Connect solves it. With
blocked_only=False the straight line may be free: the paper's distribution (its test
pairs were the ends of RRT* paths between random free states, unfiltered).
The test set depends on the data config only, never on the run's `seed`.
"""

from __future__ import annotations

import itertools

import numpy as np

from mpnet.envs.ompl_space import is_solvable
from mpnet.envs.scenes.generators import env_split_ids, make_workspace
from mpnet.envs.spec import EnvSpec, TestSet
from mpnet.envs.workspace import Query, Workspace

SPLIT_CODES = {"seen": 1, "unseen": 2}


def make_queries(
    spec: EnvSpec,
    ws: Workspace,
    count: int,
    seed: int,
    split: str,
    solvable_s: float = 2.0,
    max_tries: int = 100000,
    blocked_only: bool = True,
) -> list[Query]:
    """`count` queries in `ws`, drawn by a generator seeded by (seed, split, workspace); fewer
    when the env's pairs for it run out (a MotionBenchMaker scene whose goals RRT-Connect
    cannot reach: the test set is without it, as MBM drops such a scene)."""
    rng = np.random.default_rng([seed, SPLIT_CODES.get(split, 0), int(ws.id) if ws.id.isdigit() else 0])
    checker = spec.make_checker(ws)
    out: list[Query] = []
    tries = 0
    for s, g in itertools.islice(spec.pairs(spec, ws, checker, rng), max_tries):
        tries += 1
        if len(out) == count:
            return out
        if not (checker.is_valid(s.tolist()) and checker.is_valid(g.tolist())):
            continue
        if blocked_only and checker.motion_valid(s.tolist(), g.tolist()):
            continue
        if not is_solvable(spec, checker, s, g, solvable_s):
            continue
        out.append(Query(f"{ws.id}/{len(out)}", ws.id, split, s, g))
    if len(out) == count or tries < max_tries:  # or the workspace's pairs ran out (MBM's scenes)
        return out
    raise RuntimeError(f"workspace {ws.id}: found only {len(out)} of {count} queries in {max_tries} draws")


def make_testset(
    spec: EnvSpec,
    splits: dict[str, tuple[int, int]],
    seed: int = 0,
    solvable_s: float = 2.0,
    progress=None,
    blocked_only: bool = True,
) -> TestSet:
    """splits: {"seen": (workspaces, queries per workspace), "unseen": (...)};
    progress(1) is called after each workspace."""
    workspaces: list[Workspace] = []
    queries: list[Query] = []
    for split, (n_ws, n_q) in splits.items():
        for i in env_split_ids(spec, split, n_ws):
            ws = make_workspace(spec, i, split, seed)
            workspaces.append(ws)
            queries += make_queries(spec, ws, n_q, seed, split, solvable_s, blocked_only=blocked_only)
            if progress is not None:
                progress(1)
    return TestSet(spec, workspaces, queries)
