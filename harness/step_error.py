"""`python -m harness.step_error +env=ENV +planner=P`: how far Pnet's step lands from the expert's
next waypoint (dropout off, in the space's distance) on the expert paths its fit held out for
validation: toward each path's end (what the paper trains on) and toward an intermediate waypoint
(what bidirectional planning asks for: the other tree's newest state). Issue 65 found the shipped
arm Pnet about twice as far off toward intermediate goals; `goal_pairs: all` trains on them.
Prints one JSON object; reads the networks the planner would plan with (shipped or cached)."""

from __future__ import annotations

import json

import hydra
import numpy as np
from omegaconf import DictConfig

from harness.core.cli import run_hydra, user_errors


def step_errors(spec, data, params: dict, pnet_path) -> dict:
    """Mean and median step error toward path ends and intermediate waypoints, on the validation
    paths of a fit with `params` (the split is by path, seeded: every recipe holds out the same)."""
    from mpnet.models.checkpoint import load_pnet_numpy
    from mpnet.models.pairs import resampled, split_indices, waypoint_pairs

    paths, ws = data.paths.paths(), np.asarray(data.paths.workspace)
    long = [i for i, p in enumerate(paths) if len(p) >= 2]
    _, val = split_indices(len(long), params["val_fraction"], params["seed"], np.asarray(long))
    held = [long[i] for i in val]
    dense = [resampled(paths[i], spec.space, params.get("waypoint_step"), params.get("min_waypoints")) for i in held]
    end = waypoint_pairs(dense, ws[held], space=spec.space)
    # intermediate goals: every (j, k) with k short of the end, both directions
    inner_paths = [p[:-1] for p in dense] + [p[1:][::-1] for p in dense]
    inner = waypoint_pairs(inner_paths, np.concatenate([ws[held], ws[held]]), False, spec.space, goals="all")
    encode, pnet = load_pnet_numpy(pnet_path)
    codes = encode(data.train_clouds.reshape(len(data.train_clouds), -1))
    out = {"validation_paths": len(held)}
    for name, pairs in (("end", end), ("intermediate", inner)):
        if not len(pairs.x_t):
            out[name] = {"pairs": 0, "mean": None, "median": None}
            continue
        x_t = pairs.x_t.astype(np.float32)
        step = pnet.step(codes[pairs.ws_index], x_t, pairs.x_goal.astype(np.float32))
        err = np.array([spec.space.distance(a, b) for a, b in zip(step, pairs.x_next)])
        out[name] = {"pairs": len(err), "mean": float(err.mean()), "median": float(np.median(err))}
    return out


@hydra.main(version_base="1.3", config_path="../conf", config_name="config")
@user_errors
def main(cfg: DictConfig) -> None:
    from harness.artifacts.ensure import ensure_dataset, ensure_models
    from harness.core.kernels import use_kernel_cache
    from harness.core.settings import settings_of
    from mpnet.data.dataset import load_dataset
    from mpnet.planners.mpnet import PNET_FILE

    run = settings_of(cfg)
    use_kernel_cache(run.cache_dir)  # before the first kernel runs (harness.core.kernels)
    models, _, _ = ensure_models(run, progress=run.progress, planning=True)
    folder, manifest, _ = ensure_dataset(run, run.progress)
    result = step_errors(run.env.spec, load_dataset(folder, manifest), run.models, models / PNET_FILE)
    print(json.dumps({"planner": str(cfg.planner.name), "models": models.name, **result}))


if __name__ == "__main__":
    run_hydra(main, required=("env", "planner"))
