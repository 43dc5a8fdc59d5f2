"""Batched planning (beyond the paper): the queries of one workspace planned together, so that
Pnet's steps run as one matrix product per step across queries.

Enet encodes the workspace once for the batch. The first NeuralPlanner runs (Algorithm 2) of
all its queries advance in lockstep: each step, the proposals of every query still growing
come from one batch forward pass (NumpyPnet's batch step, one dropout mask per row, drawn from
the batch's own stream), and each query's steerTo check runs on its own compiled motion memo.
Each query then goes on alone with the compiled planner (lazy states contraction, the
feasibility check, neural or hybrid replanning), its budget less the lockstep's time.

The method per query is MPNet's; its dropout draws differ from the one-query planner's, so its
answers do too: success is measured beside the one-query planner's, not assumed
(`python -m harness.perf`, its `batched` section). Pnet's proposals only (the ablations'
proposals gain nothing from a batch).
"""

from __future__ import annotations

import time

import numpy as np

from mpnet.planners import compiled_kernels as K
from mpnet.planners.base import Problem, Result, check_endpoints, sub_seed
from mpnet.planners.compiled import CompiledMPNetPlanner

BATCH_MEMO_BITS = 10  # a first run checks at most max_steps (+1) motions


class _Run:
    """One query's first NeuralPlanner run in the lockstep: its two trees, which grows next,
    its proposals, checks and the path once its trees connect."""

    def __init__(self, problem: Problem, env: tuple, state_dim: int):
        self.problem, self.env = problem, env
        self.trees = ([problem.start.astype(float)], [problem.goal.astype(float)])
        self.grow = 0  # 0: the start's tree grows this step
        self.trace: list = []
        self.memo, self.counts = K.new_memo(state_dim, BATCH_MEMO_BITS), np.zeros(3, np.int64)
        self.path = None
        self.live = check_endpoints(problem) is None  # a bad endpoint: solve answers it alone

    def connect(self, new: np.ndarray) -> None:
        grown, other = self.trees[self.grow], self.trees[1 - self.grow]
        self.trace.append((0, grown[-1], new))
        grown.append(new)
        if K.motion_valid(self.env, self.memo, self.counts, new, other[-1]):
            a, b = self.trees
            self.path, self.live = a + b[::-1], False
        else:
            self.grow = 1 - self.grow

    def first(self, shared_s: float):
        """solve's `first`: this run's outcome, its checks and Pnet calls added to the query's."""

        def adopt(planner: CompiledMPNetPlanner, stats: dict):
            stats["pnet_s"] += shared_s  # the query waited for the whole lockstep
            stats["pnet_calls"] += len(self.trace)
            planner.trace.extend(self.trace)
            planner._counts += self.counts
            if self.path is None:
                planner._trees = self.trees
            return self.path

        return adopt


def plan_batch(planner: CompiledMPNetPlanner, problems: list[Problem], budget_s: float) -> list[tuple[Result, float]]:
    """Plan `problems` (one workspace) together: (Result, latency_s) per problem, in order; a
    query's latency is from the batch's start to its answer (it waits for the queries before
    it)."""
    if not isinstance(planner, CompiledMPNetPlanner) or planner.proposal != "pnet":
        raise ValueError("batched planning takes the compiled planner with Pnet's proposals")
    if not problems:
        return []
    ws = problems[0].workspace
    if any(p.workspace is not ws for p in problems):
        raise ValueError("batched planning takes the queries of one workspace")
    t0 = time.perf_counter()
    code = planner.encode(planner.cloud(ws))
    spec, net = problems[0].spec, planner.net
    canonical = spec.space.clip if planner.clip else spec.space.wrap
    seed = problems[0].seed
    rng = np.random.default_rng(sub_seed(seed, 3)) if seed is not None else planner.rng
    runs = [_Run(p, planner.env_of(p.checker), net.state_dim) for p in problems]
    if planner.replanning == "forgiving":  # its free straight line first, as MPNetPlanner's precheck
        for r in (r for r in runs if r.live):
            start, goal = r.trees[0][0], r.trees[1][0]
            if K.motion_valid(r.env, r.memo, r.counts, start, goal):
                r.path, r.live = [start, goal], False
    deadline = t0 + budget_s
    for _ in range(planner.max_steps):
        live = [r for r in runs if r.live]
        if not live or time.perf_counter() > deadline:
            break
        tips = np.array([r.trees[r.grow][-1] for r in live])
        targets = np.array([r.trees[1 - r.grow][-1] for r in live])
        proposals = canonical(np.asarray(net.step(code, tips, targets, rng if planner.dropout else None), float))
        for r, new in zip(live, proposals):
            r.connect(new)
    shared_s = time.perf_counter() - t0
    out = []
    for r in runs:
        result = planner.solve(r.problem, max(0.0, budget_s - shared_s), code=code, first=r.first(shared_s))
        out.append((result, time.perf_counter() - t0))
    return out
