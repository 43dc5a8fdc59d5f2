"""The DAgger recipe option's artifacts (mpnet.planners.dagger): round k's networks train on
the dataset's expert paths plus the paths the expert gave from the states rounds 1..k's
rollouts visited, each round rolling out the networks of the round before.

A round's labelled paths are an artifact of their own (kind "dagger"), keyed by the networks
they rolled out (whose key holds the dataset's) and the round's settings: a resumed or
repeated build reuses them; another network or setting is another artifact."""

from __future__ import annotations

import sys
from dataclasses import replace
from pathlib import Path

import numpy as np

from harness.core.cli import RunRefused
from harness.core.provenance import artifact_provenance
from harness.core.schema import DAGGER_DEFAULTS
from mpnet.data.expert import ExpertPaths, _load_chunk, save_chunk
from mpnet.data.store import ArtifactError, ensure
from mpnet.envs.scenes.generators import make_workspaces

DAGGER_KEYS = ("dagger_rounds", *DAGGER_DEFAULTS)  # the rounds, then each round's settings


def previous_round(run):
    """The run whose networks round k rolls out: round k - 1's (the plain recipe's for k = 1)."""
    models = dict(run.models)
    k = int(models["dagger_rounds"])
    if k > 1:
        models["dagger_rounds"] = k - 1
    else:
        for key in DAGGER_KEYS:
            models.pop(key, None)
    return replace(run, models=models)


def aggregated_paths(run, data, progress: bool, ensure_models) -> ExpertPaths:
    """Every round's labelled paths up to run.models' round (built where the cache lacks
    them, with the networks of each round before: ensure_models(run, progress), the
    artifacts' own, given so that this module needs nothing of theirs)."""
    prev = previous_round(run)
    prev_folder, prev_manifest, _ = ensure_models(prev, progress)
    m, env = run.models, run.env
    k = int(m["dagger_rounds"])
    config = {
        "models": prev_manifest["key"],
        "round": k,
        **{key: m[key] for key in DAGGER_KEYS[1:]},
        "expert": env.expert.planner,
        "iterations": env.expert.iterations,
        "max_seconds": env.expert.max_seconds,
        **({"check": env.expert.check} if env.expert.check != "judge" else {}),
        **({"run_iterations": env.expert.run_iterations} if env.expert.run_iterations is not None else {}),
    }

    def build(folder: Path) -> dict:
        from mpnet.planners.dagger import DaggerParams, dagger_paths

        spec = env.spec
        rows, queries = _queries(data, int(m["dagger_queries"]))
        workspaces = make_workspaces(spec, [int(data.train_ids[r]) for r in rows], "train", env.data_seed)
        items = [(r, ws, q) for r, ws, q in zip(rows, workspaces, queries)]
        p = DaggerParams(
            int(m["dagger_queries"]),
            int(m["dagger_states"]),
            float(m["dagger_budget_s"]),
            env.expert.planner,
            env.expert.iterations,
            env.expert.max_seconds,
            env.expert.check,
            env.expert.run_iterations,
        )
        seed = int(np.random.default_rng([env.data_seed, 23, k]).integers(1, 2**31 - 1))
        print(f"DAgger round {k}: rolling out {prev_folder.name} on {len(items)} scenes", file=sys.stderr)
        paths = dagger_paths(spec, prev_folder, (env.points_per_block, env.data_seed), items, p, seed, jobs=run.jobs)
        save_chunk(folder, 0, paths)
        return {"files": ["chunk_0.npz"], "paths": len(paths), "states": int(len(paths.states))}

    try:
        folder, _, _ = ensure(run.cache_dir, "dagger", config, build, artifact_provenance)
    except ArtifactError as e:
        raise RunRefused(str(e)) from None
    mine = _load_chunk(folder, 0)
    earlier = aggregated_paths(prev, data, progress, ensure_models) if k > 1 else None
    parts = [p for p in (earlier, mine) if p is not None]
    return ExpertPaths.concat(parts, run.env.spec.state_dim)


def _queries(data, per_scene: int) -> tuple[list[int], list[list]]:
    """Each training scene's first `per_scene` expert queries (the ends of its paths, in
    order): the rows that have any, and theirs."""
    by_row: dict[int, list] = {}
    for path, row in zip(data.paths.paths(), data.paths.workspace):
        q = by_row.setdefault(int(row), [])
        if len(q) < per_scene:
            q.append((path[0].copy(), path[-1].copy()))
    rows = sorted(by_row)
    return rows, [by_row[r] for r in rows]


def with_dagger(run, data, progress: bool, ensure_models):
    """The dataset round k trains on: its expert paths and every round's labelled ones."""
    extra = aggregated_paths(run, data, progress, ensure_models)
    return replace(data, paths=ExpertPaths.concat([data.paths, extra], run.env.spec.state_dim))
