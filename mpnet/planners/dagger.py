"""DAgger for MPNet's training data (a recipe option, issue 42): the states the first
NeuralPlanner run visits with the current networks, each labelled by the expert's path from
there to the end its tree grows toward.

Why: Pnet is trained on expert waypoints only, but in the closed loop its next input is its
own last output, a state no expert path passes through; its errors compound (on the arm 55%
of second proposals left the joint limits). DAgger (Ross, Gordon and Bagnell, 2011) trains on
the states the learner reaches, labelled by the expert. CMPNet's active continual learning is
not this: it labels the problems the planner fails, from their start.

The rollouts use the numpy planning loop (its trace names every proposal and the tree end it
grew from); the first run alternates the start's tree and the goal's, the start's first, so
proposal i grew toward the goal when i is even and toward the start when odd.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from mpnet.data.expert import CHECKS, EXPERTS, ExpertPaths, dedupe, in_processes
from mpnet.envs.spec import EnvSpec
from mpnet.envs.workspace import Workspace
from mpnet.motion import path_cost
from mpnet.planners.base import Problem, sub_seed
from mpnet.planners.mpnet import from_checkpoint


@dataclass(frozen=True)
class DaggerParams:
    """One round: `queries` expert queries per scene rolled out, `states` visited states
    labelled per query, each rollout given `budget_s`; the expert as the dataset's."""

    queries: int
    states: int
    budget_s: float
    expert: str
    iterations: int
    max_seconds: float
    check: str = "judge"  # mpnet.data.expert.CHECKS, as the dataset's
    run_iterations: int | None = None  # rrt_connect: iterations a run, as the dataset's


def visited(planner, problem: Problem, states: int, budget_s: float, rng: np.random.Generator) -> list:
    """Up to `states` distinct valid states the first NeuralPlanner run reached (the query's
    ends excepted), each with the end its tree grew toward: [(state, end)]."""
    planner.solve(problem, budget_s)
    first = [x for stage, _, x in planner.trace if stage == 0]
    checker = problem.checker
    found = []
    for i, x in enumerate(first):
        end = problem.goal if i % 2 == 0 else problem.start
        if np.all(np.isfinite(x)) and checker.is_valid(np.asarray(x, float).tolist()):
            found.append((np.asarray(x, float), np.asarray(end, float)))
    if len(found) > states:
        found = [found[i] for i in sorted(rng.choice(len(found), states, replace=False))]
    return found


def label(spec: EnvSpec, ws: Workspace, checker, pairs: list, p: DaggerParams) -> list[np.ndarray]:
    """The expert's verified path from each state to its end (None where it finds none)."""
    out = []
    for x, end in pairs:
        path = EXPERTS[p.expert](spec, checker, x, end, p.iterations, p.max_seconds, run_iterations=p.run_iterations)
        if path is None:
            continue
        path = dedupe(path)
        if len(path) >= 2 and CHECKS[p.check](spec, ws, checker, path, x, end):
            out.append(np.asarray(path, float))
    return out


def chunk_worker(args: tuple) -> ExpertPaths:
    """One chunk of scenes in a fresh process: OMPL seeded from (seed, chunk), the networks in
    models_dir, every scene's queries rolled out and their visited states labelled.
    items: [(row, workspace, [(start, goal), ...])], row the scene's row in the dataset;
    cloud: (points_per_block, data_seed), the clouds as the networks were trained on."""
    spec, models_dir, (per_block, data_seed), items, p, seed, chunk = args
    from mpnet.envs.ompl_space import seed_worker

    seed_worker(seed, 13, chunk)

    def cloud(ws):
        return spec.cloud(ws, per_block, data_seed)

    # only the first NeuralPlanner run's proposals are labelled: no replanning after it
    planner = from_checkpoint(Path(models_dir), spec, seed, cloud, name="mpnet_nr", compiled=False, replan_rounds=0)
    states, costs, rows = [], [], []
    for row, ws, queries in items:
        checker = spec.make_checker(ws)
        rng = np.random.default_rng([seed, 17, row])
        for q, (start, goal) in enumerate(queries):
            problem = Problem(
                spec, ws, checker, np.asarray(start, float), np.asarray(goal, float), seed=sub_seed(seed, row, q)
            )
            for path in label(spec, ws, checker, visited(planner, problem, p.states, p.budget_s, rng), p):
                states.append(path)
                costs.append(path_cost(spec, path))
                rows.append(row)
    return ExpertPaths.of(states, rows, costs, costs, spec.state_dim)


def dagger_paths(
    spec: EnvSpec,
    models_dir: Path,
    cloud: tuple[int, int],
    items: list,
    p: DaggerParams,
    seed: int,
    jobs: int = 2,
    chunk_size: int = 10,
    progress=None,
) -> ExpertPaths:
    """Every chunk of `items` (chunk_worker's; cloud: (points_per_block, data_seed)) in fresh
    processes; the labelled paths in chunk order (the same whatever `jobs`)."""
    chunks = [items[i : i + chunk_size] for i in range(0, len(items), chunk_size)]
    results: dict[int, ExpertPaths] = {}

    def done(k: int, paths: ExpertPaths) -> None:
        results[k] = paths
        if progress is not None:
            progress(len(chunks[k]))

    tasks = {k: (spec, str(models_dir), cloud, c, p, seed, k) for k, c in enumerate(chunks)}
    in_processes(chunk_worker, tasks, jobs, done)
    return ExpertPaths.concat([results[k] for k in sorted(results)], spec.state_dim)
