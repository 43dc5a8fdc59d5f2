"""BatchPRM: a probabilistic roadmap grown in batches until it joins start and goal.

Each round draws `batch` uniform states, keeps the valid ones (one batched state check),
links each new node to its `neighbours` nearest nodes whose straight motion is free (one
batched motion check) and asks Dijkstra for a start-goal path. It uses only what the bench
passes in (the Problem's space, checker, start, goal and seed), so it runs in every env.
"""

from __future__ import annotations

import time

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import dijkstra
from scipy.spatial import cKDTree

from mpnet.planners.base import EXACT, TIMEOUT, Problem, Result, check_endpoints


class BatchPRM:
    """The Planner protocol: a `name` and `solve(problem, budget_s) -> Result`."""

    def __init__(self, name: str = "batch_prm", batch: int = 200, neighbours: int = 10):
        if int(batch) < 1 or int(neighbours) < 1:
            raise ValueError(f"config key planner.batch / planner.neighbours: expected >= 1, got {batch}, {neighbours}")
        self.name = name
        self.batch = int(batch)
        self.neighbours = int(neighbours)

    def solve(self, problem: Problem, budget_s: float) -> Result:
        deadline = time.perf_counter() + budget_s
        invalid = check_endpoints(problem)
        if invalid is not None:
            return invalid
        space, checker = problem.spec.space, problem.checker
        start, goal = np.asarray(problem.start, float), np.asarray(problem.goal, float)
        if checker.motion_valid(start, goal):
            return Result([start.tolist(), goal.tolist()], EXACT, {"nodes": 2, "rounds": 0})
        rng = np.random.default_rng(problem.seed)
        nodes = np.stack([start, goal])
        rows, cols, weights = [], [], []
        rounds = 0
        while time.perf_counter() < deadline:
            rounds += 1
            samples = np.stack([space.sample(rng) for _ in range(self.batch)])
            fresh = samples[checker.states_valid(samples)]
            if len(fresh) == 0:
                continue
            first = len(nodes)
            nodes = np.concatenate([nodes, fresh])
            k = min(self.neighbours + 1, len(nodes))
            _, near = cKDTree(nodes).query(nodes[first:], k=k)
            a = np.repeat(np.arange(first, len(nodes)), k)
            b = np.asarray(near).reshape(-1)
            keep = a != b
            a, b = a[keep], b[keep]
            free = checker.motions_valid(nodes[a], nodes[b])
            a, b = a[free], b[free]
            rows += [a, b]
            cols += [b, a]
            weights += [np.array([space.distance(nodes[i], nodes[j]) for i, j in zip(a, b)])] * 2
            graph = coo_matrix(
                (np.concatenate(weights), (np.concatenate(rows), np.concatenate(cols))), shape=(len(nodes),) * 2
            ).tocsr()
            dist, pred = dijkstra(graph, indices=0, return_predecessors=True)
            if np.isfinite(dist[1]):
                path, at = [], 1
                while at >= 0:
                    path.append(nodes[at].tolist())
                    at = pred[at]
                return Result(path[::-1], EXACT, {"nodes": len(nodes), "rounds": rounds})
        return Result(None, TIMEOUT, {"nodes": len(nodes), "rounds": rounds})
