"""Reference path costs: the yardstick of path quality, one per test query.

Point robots in 2D (s2d, c2d) get the exact shortest path: it runs through box corners
(the reflex vertices of the free space), so Dijkstra on the visibility graph of start,
goal and the corners inside the bounds finds it. It is an infimum: it may touch obstacles,
which no collision-free path does, so every planner's cost is >= it. Boxes that touch
along an edge leave a zero-width crack the graph may use; generated layouts (random
centres) have none.

Other envs (c3d, rigid) get the best of two planned paths, each shortened by lazy states
contraction and kept only if it passes the fine re-check: the expert's (RRT* for a fixed
number of iterations, as the training data) and BIT* run for a fixed time.
"""

from __future__ import annotations

import math

import numpy as np

from mpnet.data.expert import EXPERTS
from mpnet.envs.spec import EnvSpec
from mpnet.envs.workspace import Query, Workspace
from mpnet.motion import lazy_states_contraction, path_cost, verify_path
from mpnet.planners.base import Problem
from mpnet.planners.classical import OmplPlanner
from mpnet.settings import EXPERT

EPS = 1e-9


def describe(spec: EnvSpec, expert: str = EXPERT.planner) -> str:
    """How the env's reference cost is computed, in words (for the report)."""
    if spec.exact_reference:
        return "exact shortest path (visibility graph over the box corners)"
    how = "RRT*, fixed iterations" if expert == "rrt_star" else "the shortest of shortened RRT-Connect runs"
    return f"best of the expert path ({how}) and a budgeted BIT* run, both contracted"


def visible(p: np.ndarray, q: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """(m, k) bool: segment p_i -> q_j enters no box's open interior.

    Liang-Barsky clipping against each closed box (mpnet.envs.geometry's slab test, the point
    checker's); a clipped piece longer than EPS whose midpoint lies inside the box by more than
    EPS crosses it (a chord of a convex set lies on its boundary or has its relative interior
    inside). p, q: (m, 2), (k, 2); lo, hi: (n, 2).
    """
    from mpnet.envs.geometry import segments_cross  # numba: loaded by the exact reference only

    p, q = np.ascontiguousarray(p, float), np.ascontiguousarray(q, float)
    lo, hi = (np.ascontiguousarray(v, float).reshape(-1, p.shape[1]) for v in (lo, hi))
    crosses = np.empty((len(p), len(q)), np.bool_)
    segments_cross(p, q, lo, hi, EPS, crosses)
    return ~crosses


def shortest_path_cost_2d(spec: EnvSpec, ws: Workspace, start, goal) -> float:
    """The exact shortest collision-free path length of a point robot among boxes in 2D."""
    from scipy.sparse.csgraph import dijkstra

    if np.allclose(start, goal):
        return 0.0
    lo, hi = ws.lo, ws.hi
    corners = np.concatenate(
        [
            np.stack([lo[:, 0], lo[:, 1]], 1),
            np.stack([lo[:, 0], hi[:, 1]], 1),
            np.stack([hi[:, 0], lo[:, 1]], 1),
            np.stack([hi[:, 0], hi[:, 1]], 1),
        ]
    )
    inb = np.all((corners >= spec.space.lower[:2]) & (corners <= spec.space.upper[:2]), axis=1)
    in_box = (
        ((corners[:, None] > lo[None] + EPS) & (corners[:, None] < hi[None] - EPS)).all(-1).any(-1)
        if len(lo)
        else np.zeros(len(corners), bool)
    )
    nodes = np.concatenate([np.asarray([start, goal], float), corners[inb & ~in_box]])
    seen = visible(nodes, nodes, lo, hi)
    weights = np.linalg.norm(nodes[:, None] - nodes[None], axis=-1)
    graph = np.where(seen & (weights > 0), weights, 0.0)  # dense input: 0 is "no edge"
    return float(dijkstra(graph, directed=False, indices=0)[1])


def planned_cost(
    spec: EnvSpec,
    ws: Workspace,
    checker,
    start,
    goal,
    iterations: int,
    expert_s: float,
    bit_star_s: float,
    expert: str = EXPERT.planner,
) -> float:
    """The best verified, contracted cost of the expert's path (the data's expert planner:
    mpnet.data.expert.EXPERTS) and a BIT* run of bit_star_s seconds; inf when neither finds
    a path."""
    expert_path = EXPERTS[expert](spec, checker, start, goal, iterations, expert_s)  # first: OMPL's RNG order
    bit_star = OmplPlanner("bit_star", "bit_star", stop="time").solve(
        Problem(spec, ws, checker, np.asarray(start, float), np.asarray(goal, float)), float(bit_star_s)
    )
    candidates = [expert_path, bit_star.path]
    best = math.inf
    for path in candidates:
        if path is None:
            continue
        path = lazy_states_contraction(checker, path)
        if verify_path(spec, ws, path, start, goal, spec.validation_step) is None:
            best = min(best, path_cost(spec, path))
    return best


def workspace_references(
    spec: EnvSpec,
    ws: Workspace,
    queries: list[Query],
    iterations: int,
    expert_s: float,
    bit_star_s: float,
    expert: str = EXPERT.planner,
) -> list[float]:
    """The reference cost of each query of one workspace."""
    if spec.exact_reference:
        return [shortest_path_cost_2d(spec, ws, q.start, q.goal) for q in queries]

    checker = spec.make_checker(ws)
    return [planned_cost(spec, ws, checker, q.start, q.goal, iterations, expert_s, bit_star_s, expert) for q in queries]


def _worker(args: tuple) -> list[float]:
    spec, ws, queries, iterations, expert_s, bit_star_s, seed, chunk, expert = args
    from mpnet.envs.ompl_space import seed_worker

    seed_worker(seed, 13, chunk)
    return workspace_references(spec, ws, queries, iterations, expert_s, bit_star_s, expert)


def reference_costs(
    spec: EnvSpec,
    workspaces: list[Workspace],
    queries: list[Query],
    *,
    iterations: int,
    expert_s: float,
    bit_star_s: float,
    expert: str = EXPERT.planner,
    seed: int = 0,
    jobs: int = 2,
    progress=None,
) -> None:
    """Set every query's reference_cost (None where no path was found; planned ones in fresh processes, one workspace
    each, OMPL seeded per workspace so any `jobs` gives the same costs). progress(1) after
    each workspace."""
    by_ws = [(ws, [q for q in queries if q.workspace_id == ws.id and q.split == ws.split]) for ws in workspaces]
    if spec.exact_reference:
        for ws, qs in by_ws:
            for q, c in zip(qs, workspace_references(spec, ws, qs, iterations, expert_s, bit_star_s)):
                q.reference_cost = c if math.isfinite(c) and c > 0 else None
            if progress is not None:
                progress(1)
        return
    from concurrent.futures import as_completed

    from mpnet.workers import process_pool

    tasks = [(spec, ws, qs, iterations, expert_s, bit_star_s, seed, k, expert) for k, (ws, qs) in enumerate(by_ws)]
    with process_pool(min(jobs, len(tasks)), max_tasks_per_child=1) as pool:
        futures = {pool.submit(_worker, t): k for k, t in enumerate(tasks)}
        for fut in as_completed(futures):
            for q, c in zip(by_ws[futures[fut]][1], fut.result()):
                q.reference_cost = c if math.isfinite(c) and c > 0 else None
            if progress is not None:
                progress(1)
