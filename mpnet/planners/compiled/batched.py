"""Batched planning (beyond the paper): the queries of one workspace planned together, so that
Pnet's steps run as one matrix product per step across queries.

Enet encodes the workspace once for the batch. The first NeuralPlanner runs (Algorithm 2) of
all its queries advance in lockstep in one compiled call (compiled_kernels.lockstep): each
step, the proposals of every query still growing come from one batch forward pass
(pnet_kernel.pnet_rows, one dropout mask per row, drawn from the batch's own stream), and each
query's steerTo check runs on its own motion memo.
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

from mpnet.models.pnet_kernel import batch_scratch
from mpnet.planners.base import Problem, Result, check_endpoints, sub_seed
from mpnet.planners.compiled import kernels as K
from mpnet.planners.compiled.planner import CompiledMPNetPlanner

BATCH_MEMO_BITS = 10  # a first run checks at most max_steps (+1) motions


class _Batch:
    """The compiled lockstep's buffers for a batch of B queries of a d-dimensional state."""

    def __init__(self, planner: CompiledMPNetPlanner, B: int):
        d, S = planner.net.state_dim, planner.max_steps
        cap = 1 << BATCH_MEMO_BITS
        self.memos = (np.empty((B, cap, 2 * d)), np.full((B, cap), -1, np.int8), np.zeros(B, np.int64))
        self.counts = np.zeros((B, 3), np.int64)
        self.buf = batch_scratch(planner.kernel.layout, B)
        self.scratch = (np.empty((B, d)), np.empty((B, d)), np.empty((B, d)))
        self.trees = np.empty((B, 2, S + 1, d))
        self.n, self.steps = np.zeros((B, 2), np.int64), np.zeros(B, np.int64)
        self.connected = np.zeros(B, np.bool_)
        self.trace = np.empty((B, S, 2, d))


def _first(batch: _Batch, b: int, shared_s: float):
    """solve's `first` for query b: its run's outcome, with its checks and Pnet calls added to the query's."""
    steps, (na, nb) = int(batch.steps[b]), batch.n[b]
    trace = batch.trace[b, :steps].copy()
    a, g = list(batch.trees[b, 0, :na].copy()), list(batch.trees[b, 1, :nb].copy())

    def adopt(planner: CompiledMPNetPlanner, stats: dict):
        stats["pnet_s"] += shared_s  # the query waited for the whole lockstep
        stats["pnet_calls"] += steps
        connected = bool(batch.connected[b])
        planner.adopt_run(batch.counts[b], trace, None if connected else (a, g))
        return a + g[::-1] if connected else None

    return adopt


def warm_up(planner: CompiledMPNetPlanner, problem: Problem) -> None:
    """The planner's kernels (CompiledMPNetPlanner.warm_up) and the lockstep's compiled, or
    loaded from numba's cache, before a timed batch: a cold cache's compilation would otherwise
    come out of the first batch's budget."""
    planner.warm_up(problem)
    plan_batch(planner, [problem], 1.0)


def plan_batch(planner: CompiledMPNetPlanner, problems: list[Problem], budget_s: float) -> list[tuple[Result, float]]:
    """Plan `problems` (one workspace) together: (Result, latency_s) per problem, in order; a
    query's latency is from the batch's start to its answer (it waits for the queries before
    it). Call warm_up first: the lockstep is compiled on its first call."""
    if not isinstance(planner, CompiledMPNetPlanner) or planner.proposal != "pnet":
        raise ValueError("batched planning takes the compiled planner with Pnet's proposals")
    if not problems:
        return []
    ws = problems[0].workspace
    if any(p.workspace is not ws or p.checker is not problems[0].checker for p in problems):
        raise ValueError("batched planning takes the queries of one workspace, on one checker")
    t0 = time.perf_counter()
    code = planner.encode(planner.cloud(ws))
    seed = problems[0].seed
    rng = np.random.default_rng(sub_seed(seed, 3)) if seed is not None else planner.rng
    batch = _Batch(planner, len(problems))
    starts = np.array([p.start for p in problems], float)
    goals = np.array([p.goal for p in problems], float)
    live = np.array([check_endpoints(p) is None for p in problems])  # a bad endpoint: solve answers it alone
    K.lockstep(
        np.asarray(code, np.float32), starts, goals, planner.max_steps, planner.replanning == "forgiving",
        planner.env_of(problems[0].checker), batch.memos, batch.counts, planner.prop_of(problems[0].spec),
        planner.kernel.args, rng, planner.compiled_dropout, batch.buf, batch.scratch, live, batch.trees, batch.n,
        batch.steps, batch.connected, batch.trace,
    )  # fmt: skip
    shared_s = time.perf_counter() - t0
    out = []
    for b, problem in enumerate(problems):
        first = _first(batch, b, shared_s)
        result = planner.solve(problem, max(0.0, budget_s - shared_s), code=code, first=first)
        out.append((result, time.perf_counter() - t0))
    return out
