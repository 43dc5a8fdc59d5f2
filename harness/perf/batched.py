"""Batched planning's throughput beside one query at a time (mpnet.planners.compiled.batched): each
env's queries (the runs' test set and networks, as the bench composes them) planned by the
compiled MPNet-NR one at a time, then a workspace's queries together, in the same process,
one after the other. Queries per second, the median and p90 latency (a batch's query: from its
batch's start to its answer) and the planner's own success (its feasibility check; the bench's
runs are the ones re-checked)."""

from __future__ import annotations

import time
from collections import defaultdict

import numpy as np

from harness.perf.planners import compose_run, run_one


def _child(overrides: list[str], conn) -> None:
    from harness.bench.loop import query_seed
    from harness.bench.run import build_testset, runtime_objects, seed_everything
    from harness.core.settings import settings_of
    from mpnet.planners.base import Problem
    from mpnet.planners.compiled.batched import plan_batch, warm_up

    try:
        run = settings_of(compose_run(overrides))
        seed_everything(run.seed)
        planner = run.planner.make(runtime_objects(run))
        testset, _ = build_testset(run)
        spec, by_id = run.env.spec, {(w.split, w.id): w for w in testset.workspaces}
        groups, checkers = defaultdict(list), {}
        for q in testset.queries:
            ws = by_id[(q.split, q.workspace_id)]
            checker = checkers.setdefault(id(ws), spec.make_checker(ws))
            seed = query_seed(run.seed, q.split, q.id)
            groups[id(ws)].append(Problem(spec, ws, checker, q.start, q.goal, seed=seed))
        batches = list(groups.values())
        warm_up(planner, batches[0][0])  # both paths compiled (or loaded) before either is timed
        one, t = [], time.perf_counter()
        for ps in batches:
            for p in ps:
                t1 = time.perf_counter()
                r = planner.solve(p, run.budget_s)
                one.append((r.solved, time.perf_counter() - t1))
        one_s = time.perf_counter() - t
        together, t = [], time.perf_counter()
        for ps in batches:
            together += [(r.solved, lat) for r, lat in plan_batch(planner, ps, run.budget_s)]
        together_s = time.perf_counter() - t
        conn.send({"one": (one, one_s), "batched": (together, together_s), "batch": len(one) / len(batches)})
    except BaseException as e:  # noqa: BLE001 - reported by the parent as one line
        conn.send({"error": f"{type(e).__name__}: {e}"})
    finally:
        conn.close()


def batched(envs: list[str], planner: str, common: list[str]) -> tuple[list[dict], list[str]]:
    """Rows (section "batched"): per env, one query at a time and batched."""
    rows, errors = [], []
    for env in envs:
        out = run_one([f"+env={env}", f"+planner={planner}", *common], _child)
        if "error" in out:
            errors.append(f"{env} / {planner} batched: {out['error']}")
            continue
        for mode in ("one", "batched"):
            results, wall = out[mode]
            lat = [x for _, x in results]
            rows.append(
                {
                    "section": "batched",
                    "env": env,
                    "planner": planner,
                    "mode": mode,
                    "queries": len(results),
                    "batch_mean": out["batch"] if mode == "batched" else 1.0,
                    "success_rate": float(np.mean([s for s, _ in results])) if results else float("nan"),
                    "queries_per_s": len(results) / wall if wall > 0 else float("nan"),
                    "latency_median_s": float(np.median(lat)) if lat else float("nan"),
                    "latency_p90_s": float(np.percentile(lat, 90)) if lat else float("nan"),
                }
            )
    return rows, errors
